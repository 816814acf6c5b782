"""Real tracks as they come: repeated time stamps merged, spikes and backward times dropped.

A phone or a car's receiver records what a convoy did, with what receivers do: two
fixes under one time stamp (a 1-Hz log of a receiver that updates faster), a fix now
and then hundreds of metres off (multipath, a cold start), and the odd stamp earlier
than the one before. None of that makes a track unusable, so none of it refuses one:

* fixes sharing a time stamp are merged into their mean position;
* a fix stamped no later than the fix kept before it is dropped (``out_of_order``);
* a *single-fix spike*, a fix that only a vehicle faster than ``max_speed`` could
  reach from the fix before and leave for the fix after while those two are
  consistent with each other, is dropped (``spikes``). A run of such fixes is a
  real move (a tunnel's exit, a gap in the log), not a spike, and is kept.

Counts of each come back in :class:`TrackCleaning`, for the report. Pure: no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from convoy_mav.geo import GeoPoint, LocalFrame

__all__ = ["MAX_CONVOY_SPEED_MPS", "TrackCleaning", "clean_fixes"]

MAX_CONVOY_SPEED_MPS = 60.0
"""216 km/h: no convoy drives faster; a fix that implies more there and back is a spike."""


@dataclass(frozen=True, slots=True)
class TrackCleaning:
    """What cleaning a track did (all zero for a clean one).

    Attributes:
        merged: Fixes folded into another one stamped with the same time.
        out_of_order: Fixes dropped for a time stamp no later than the one before.
        spikes: Single fixes dropped as spikes.
        untimed: Points dropped for having no time, among others that have one (a GPX
            point added in an editor, or logged before the receiver knew the time).
        unfixed: Rows dropped for having a time but no position (empty or NaN
            latitude and longitude: a logger's row before its receiver had a fix).
    """

    merged: int = 0
    out_of_order: int = 0
    spikes: int = 0
    untimed: int = 0
    unfixed: int = 0

    @property
    def changed(self) -> int:
        """Fixes that did not make it into the track as recorded."""
        return self.merged + self.out_of_order + self.spikes + self.untimed + self.unfixed

    def summary(self) -> str:
        """One line of what was done, for the operator ("" when nothing was)."""
        parts = [
            f"{n} {what}"
            for n, what in (
                (self.merged, "fixes sharing a time stamp merged"),
                (self.out_of_order, "stamped no later than the one before dropped"),
                (self.spikes, "single-fix spikes dropped"),
                (self.untimed, "points without a time dropped"),
                (self.unfixed, "rows without a position dropped"),
            )
            if n
        ]
        return ", ".join(parts)


Fixes = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]


def clean_fixes(
    times: Sequence[float],
    lats: Sequence[float],
    lons: Sequence[float],
    *,
    max_speed: float = MAX_CONVOY_SPEED_MPS,
) -> tuple[Fixes, TrackCleaning]:
    """``(times, lats, lons)`` with strictly increasing times, and what was done.

    Args:
        times, lats, lons: The fixes in file order (finite, lat/lon in range).
        max_speed: The fastest the convoy can go, m/s (spikes need more).

    Raises:
        ValueError: ``max_speed`` not > 0, or the sequences differ in length.
    """
    if not max_speed > 0.0:
        raise ValueError(f"max_speed must be > 0, got {max_speed!r}")
    if not len(times) == len(lats) == len(lons):
        raise ValueError("times, lats and lons must have the same length")
    merged = out_of_order = 0
    ts: list[float] = []
    groups: list[list[tuple[float, float]]] = []
    for t, lat, lon in zip(times, lats, lons, strict=True):
        if ts and t == ts[-1]:
            groups[-1].append((lat, lon))
            merged += 1
        elif ts and t < ts[-1]:
            out_of_order += 1
        else:
            ts.append(t)
            groups.append([(lat, lon)])
    la = [sum(p[0] for p in g) / len(g) for g in groups]
    lo = [sum(p[1] for p in g) / len(g) for g in groups]
    keep, spikes = _without_spikes(ts, la, lo, max_speed)
    fixes = (
        tuple(ts[i] for i in keep),
        tuple(la[i] for i in keep),
        tuple(lo[i] for i in keep),
    )
    return fixes, TrackCleaning(merged, out_of_order, spikes)


def _without_spikes(
    ts: list[float], lats: list[float], lons: list[float], max_speed: float
) -> tuple[list[int], int]:
    """Indices of the fixes kept, and how many single-fix spikes were dropped."""
    if len(ts) < 3:
        return list(range(len(ts))), 0
    frame = LocalFrame(GeoPoint(lats[0], lons[0]))
    ne = [frame.to_ned(GeoPoint(a, b))[:2] for a, b in zip(lats, lons, strict=True)]

    def too_fast(i: int, j: int) -> bool:
        return math.dist(ne[i], ne[j]) > max_speed * (ts[j] - ts[i])

    keep = [0]
    spikes = 0
    for i in range(1, len(ts) - 1):
        prev = keep[-1]
        if too_fast(prev, i) and too_fast(i, i + 1) and not too_fast(prev, i + 1):
            spikes += 1
            continue
        keep.append(i)
    keep.append(len(ts) - 1)
    return keep, spikes
