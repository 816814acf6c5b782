"""Which UAV takes which slot: the assignment both planners share (pure)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence

__all__ = ["best_assignment"]

#: Exhaustive assignment up to this many candidate permutations; greedy beyond.
EXHAUSTIVE_LIMIT = 5040


def best_assignment(
    uavs: Sequence[int], slots: Sequence[int], cost: Mapping[tuple[int, int], float]
) -> tuple[int, ...]:
    """The slot of ``slots`` for each of ``uavs`` minimising the largest cost, then the total.

    Exhaustive for small fleets (``EXHAUSTIVE_LIMIT`` permutations); beyond, the
    cheapest (UAV, slot) pairs are taken greedily.
    """
    if math.perm(len(slots), len(uavs)) <= EXHAUSTIVE_LIMIT:
        best: tuple[int, ...] = ()
        best_key = (math.inf, math.inf)
        for perm in itertools.permutations(slots, len(uavs)):
            values = [cost[u, i] for u, i in zip(uavs, perm, strict=True)]
            key = (max(values, default=0.0), sum(values))
            if key < best_key:
                best, best_key = perm, key
        return best
    chosen: dict[int, int] = {}
    used: set[int] = set()
    for (u, i), _ in sorted(cost.items(), key=lambda kv: kv[1]):
        if u not in chosen and i not in used:
            chosen[u] = i
            used.add(i)
    return tuple(chosen[u] for u in uavs)
