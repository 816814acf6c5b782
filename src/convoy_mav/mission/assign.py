"""Who flies and which slot: the roster and the assignment both planners share (pure)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence

__all__ = ["Roster", "best_assignment"]

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


class Roster:
    """The live and lost UAVs of a mission, the lost ones flying back to it (returning:
    still lost, not yet in the plan), and when protection began.

    Raises:
        ValueError: If ``uav_ids`` is empty or has duplicates.
    """

    def __init__(self, uav_ids: Sequence[int]) -> None:
        if not uav_ids or len(set(uav_ids)) != len(uav_ids):
            raise ValueError(f"uav_ids must be non-empty and unique, got {list(uav_ids)!r}")
        self._live: list[int] = list(uav_ids)
        self._lost: list[int] = []
        self._returning: set[int] = set()  # lost, flying again, not yet taken back
        self._protect_start: float | None = None

    @property
    def live_uavs(self) -> tuple[int, ...]:
        """UAVs still in the mission, in configuration order (returned ones last)."""
        return tuple(self._live)

    @property
    def lost_uavs(self) -> tuple[int, ...]:
        """UAVs taken out by ``on_lost`` and not flying back."""
        return tuple(u for u in self._lost if u not in self._returning)

    @property
    def returning_uavs(self) -> tuple[int, ...]:
        """Lost UAVs flying back to the fleet, not yet in the plan."""
        return tuple(u for u in self._lost if u in self._returning)

    @property
    def protect_start(self) -> float | None:
        """First mission time at which every live UAV was protecting."""
        return self._protect_start

    def _take_out(self, uav: int) -> bool:
        """Move a live UAV to the lost; False if it was not live."""
        return _move(uav, self._live, self._lost)

    def _take_back(self, uav: int) -> bool:
        """Move a lost UAV (returning or not) back to the live; False if it was not lost."""
        self._returning.discard(uav)
        return _move(uav, self._lost, self._live)


def _move(uav: int, source: list[int], target: list[int]) -> bool:
    """Move ``uav`` from ``source`` to the end of ``target``; False if it was not in ``source``."""
    if uav not in source:
        return False
    source.remove(uav)
    target.append(uav)
    return True
