"""Where and how long a drive stood still (pure): the holds of a rover's plan.

A rover's mission says where it holds and for how long (a waypoint's hold time); a drive
recorded or generated says it by standing. ``standstills`` finds those stands in a
drive's true positions, for the mock's rovers to serve as their mission's holds and for
the simulation to give the planner the same plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Standstill", "standstills"]


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
    below_mps: float = 0.3,
    at_least_s: float = 5.0,
) -> list[Standstill]:
    """The stretches slower than ``below_mps`` for ``at_least_s`` or longer, in order
    (a drive's end, standing to the last sample, included).

    Raises:
        ValueError: Arrays of different lengths, or times not increasing.
    """
    ts, ns, es = (np.asarray(a, dtype=np.float64) for a in (t, north, east))
    if not len(ts) == len(ns) == len(es):
        raise ValueError(f"t, north, east: lengths {len(ts)}, {len(ns)}, {len(es)} differ")
    if len(ts) < 2:
        return []
    dt = np.diff(ts)
    if np.any(dt <= 0.0):
        raise ValueError("t must increase strictly")
    slow = np.hypot(np.diff(ns), np.diff(es)) / dt < below_mps  # per interval
    out: list[Standstill] = []
    k, n = 0, len(slow)
    while k < n:
        if not slow[k]:
            k += 1
            continue
        j = k
        while j < n and slow[j]:
            j += 1
        seconds = float(ts[j] - ts[k])
        if seconds >= at_least_s:
            out.append(Standstill(float(ts[k]), seconds, float(ns[k]), float(es[k]), k))
        k = j
    return out
