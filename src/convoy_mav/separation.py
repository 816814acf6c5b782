"""Separation between UAVs: every pair closer than the minimum, found by spatial hashing.

Design rules:
- Two UAVs have lost separation when they are closer than ``horizontal_m``
  horizontally *and* than ``vertical_m`` vertically (either one is enough to
  keep them apart: altitude layers separate crossing orbits).
- Positions are hashed into square cells of side ``horizontal_m``; only the
  3 x 3 cells around each UAV are searched, so a check costs O(N) for a fleet
  spread over its area, not O(N^2) (``benchmarks/bench_separation.py``).
- Pure: positions in, pairs out.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["Conflict", "conflicts"]

Position = tuple[float, float, float]  # north, east, down (metres)


@dataclass(frozen=True, slots=True)
class Conflict:
    """Two UAVs too close: their ids (a < b) and their separations, metres."""

    a: int
    b: int
    horizontal_m: float
    vertical_m: float


def conflicts(
    positions: Mapping[int, Position], horizontal_m: float, vertical_m: float
) -> list[Conflict]:
    """Every pair closer than ``horizontal_m`` horizontally and ``vertical_m`` vertically.

    Raises:
        ValueError: A minimum that is not positive and finite.
    """
    if not (math.isfinite(horizontal_m) and horizontal_m > 0.0):
        raise ValueError(f"horizontal_m must be positive and finite, got {horizontal_m!r}")
    if not (math.isfinite(vertical_m) and vertical_m > 0.0):
        raise ValueError(f"vertical_m must be positive and finite, got {vertical_m!r}")
    cells: defaultdict[tuple[int, int], list[int]] = defaultdict(list)
    size = horizontal_m
    for uid, (n, e, _) in positions.items():
        if math.isfinite(n) and math.isfinite(e):
            cells[(math.floor(n / size), math.floor(e / size))].append(uid)
    out: list[Conflict] = []
    for (ci, cj), members in cells.items():
        near = [
            other
            for di in (-1, 0, 1)
            for dj in (-1, 0, 1)
            for other in cells.get((ci + di, cj + dj), ())
        ]
        for a in members:
            na, ea, da = positions[a]
            for b in near:
                if b <= a:
                    continue
                nb, eb, db = positions[b]
                h = math.hypot(na - nb, ea - eb)
                v = abs(da - db)
                if h < horizontal_m and v < vertical_m:
                    out.append(Conflict(a, b, h, v))
    out.sort(key=lambda c: (c.a, c.b))
    return out
