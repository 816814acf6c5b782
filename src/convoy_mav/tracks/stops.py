"""Where and how long a drive stood still (pure): the holds of a rover's plan.

A rover's mission says where it holds and for how long (a waypoint's hold time); a drive
recorded or generated says it by standing. ``standstills`` finds those stands in a
drive's true positions, for the mock's rovers to serve as their mission's holds and for
the simulation to give the planner the same plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Standstill", "standstills"]

_REJOIN_S = 10.0  # two stands this close in time and within the radius are one


@dataclass(frozen=True, slots=True)
class Standstill:
    """A stand: from ``t`` for ``seconds`` at (``north``, ``east``), and the index of the
    sample it began at."""

    t: float
    seconds: float
    north: float
    east: float
    index: int


def standstills(
    t: npt.ArrayLike,
    north: npt.ArrayLike,
    east: npt.ArrayLike,
    *,
    radius_m: float = 8.0,
    at_least_s: float = 5.0,
) -> list[Standstill]:
    """The stands of ``at_least_s`` or longer, in order (a drive's end included).

    Stay points (Li et al., 2008): from each sample, the run of samples within
    ``radius_m`` of it, a stand when it lasts ``at_least_s``; its place is the run's
    mean, and its time the span of the samples nearer that mean than twice their
    median distance (at least 1 m), which drops the braking and the pulling away
    inside the radius. In 3 m of GPS noise a fix may land more than the radius from the
    stand's first, splitting it: stands within the radius and ``_REJOIN_S`` of each
    other are one. A convoy moving at 2 m/s leaves the radius in 4 s: not a stand.

    Raises:
        ValueError: Arrays of different lengths, or times not increasing.
    """
    ts, ns, es = (np.asarray(a, dtype=np.float64) for a in (t, north, east))
    if not len(ts) == len(ns) == len(es):
        raise ValueError(f"t, north, east: lengths {len(ts)}, {len(ns)}, {len(es)} differ")
    if np.any(np.diff(ts) <= 0.0):
        raise ValueError("t must increase strictly")
    out: list[Standstill] = []
    i, n = 0, len(ts)
    while i < n - 1:
        j = i + 1
        while j < n and math.hypot(ns[j] - ns[i], es[j] - es[i]) <= radius_m:
            j += 1
        if ts[j - 1] - ts[i] < at_least_s:
            i += 1
            continue
        cn, ce = float(np.mean(ns[i:j])), float(np.mean(es[i:j]))
        d = np.hypot(ns[i:j] - cn, es[i:j] - ce)
        core = np.flatnonzero(d <= max(1.0, 2.0 * float(np.median(d))))
        a, b = i + int(core[0]), i + int(core[-1])
        if ts[b] - ts[a] >= at_least_s:
            stand = Standstill(float(ts[a]), float(ts[b] - ts[a]), cn, ce, a)
            last = out[-1] if out else None
            if (
                last is not None
                and stand.t - (last.t + last.seconds) <= _REJOIN_S
                and math.hypot(stand.north - last.north, stand.east - last.east) <= radius_m
            ):  # one stand that a noisy fix split
                w = last.seconds / (last.seconds + stand.seconds)
                stand = Standstill(
                    last.t,
                    stand.t + stand.seconds - last.t,
                    w * last.north + (1.0 - w) * stand.north,
                    w * last.east + (1.0 - w) * stand.east,
                    last.index,
                )
                out[-1] = stand
            else:
                out.append(stand)
        i = j
    return out
