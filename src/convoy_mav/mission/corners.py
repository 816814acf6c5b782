"""How the convoy takes the route's sharp corners, learnt from its own (pure).

A rover in AUTO slows for a sharp corner as its firmware does, whatever speed its
mission sets: ArduRover SITL on the urban grid's 12-m corners braked at about 1 m/s²
from 8 m/s to 2-3 m/s, turned, and was back at 8 m/s some 20 s after it began to
brake, about 10 s later than at speed (tlog, 2026-11-30). A forecast at the planned
speed through the corner had it 60-80 m on from where it came out, and the meetings
laid on that forecast were missed.

Design rules:
- A corner is a stretch of the route sharper than ``curvature`` (1/m; the junction
  hedge's, ``RoadSettings.corner_curvature``), stretches under 5 m apart one corner.
- Each corner the convoy drives through is a sample of how it takes corners: the
  route's length of the corner over the time it took (crossings interpolated between
  estimates, so fixes at 1 Hz do not quantise it). Not if it stood in the corner or in
  the ``after_stand_s`` before it: pulling away from a junction is not cornering.
- The corner speed is the median of the last ``keep`` samples, once there are
  ``min_samples``. It is used only where the convoy keeps a planned speed (a rover's
  mission, a route that says its speeds) and only under ``ratio`` of it: a convoy
  that does not slow, measured along the smoothed route that cuts its corners, reads
  0.7-0.85 of its speed (simulated urban grids at 8 m/s: 5.6-8.0 m/s). Without a plan
  the convoy's speed says too little (a human driver's corners vary, and forecasting
  the recorded drive's slowing cost it up to 6.6 points: ``docs/road-planner.md``).
- The forecast keeps its timetable (holds, speeds) and slows its clock in corners: a
  speed cap along the route, the corner speed in each corner and ``accel`` either side
  of it, and where the timetable would drive faster than the cap its time runs at
  cap / speed (:func:`warp`), so a hold after a corner comes that much later too.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from convoy_mav.planning.road import Road

__all__ = ["CornerHabit", "sharp_stretches", "speed_cap", "warp"]

FloatArray = npt.NDArray[np.float64]

_JOIN_M = 5.0  # sharp stretches this near are one corner
_BACK_M = 20.0  # this far back before a corner entered, the convoy did not drive through it
_FREE_MPS = 1000.0  # the cap where no corner is near


def sharp_stretches(road: Road, curvature: float) -> list[tuple[float, float]]:
    """(start, end) arc lengths of the stretches of ``road`` sharper than ``curvature``
    (none if it is not positive)."""
    if not curvature > 0.0:
        return []
    sharp = np.abs(road.curvature) >= curvature
    edges = np.flatnonzero(np.diff(sharp.astype(np.int8)))
    starts = list(edges[~sharp[edges]] + 1)  # (rising edges)
    ends = list(edges[sharp[edges]])
    if sharp[0]:
        starts.insert(0, 0)
    if sharp[-1]:
        ends.append(len(sharp) - 1)
    out: list[tuple[float, float]] = []
    for a, b in zip(starts, ends, strict=True):
        lo, hi = float(road.s[a]), float(road.s[b])
        if out and lo - out[-1][1] < _JOIN_M:
            out[-1] = (out[-1][0], hi)
        else:
            out.append((lo, hi))
    return out


def speed_cap(
    road: Road, corners: list[tuple[float, float]], speed: float, accel: float
) -> tuple[FloatArray, FloatArray]:
    """The highest speed at each of ``road.s`` for a convoy that takes each corner at
    ``speed`` and brakes into it and speeds up out of it at ``accel``: (arcs, caps);
    ``_FREE_MPS`` where no corner is near."""
    s = road.s
    inside = np.zeros(len(s), dtype=bool)
    for lo, hi in corners:
        inside |= (s >= lo) & (s <= hi)
    v2 = np.where(inside, speed * speed, _FREE_MPS**2).tolist()
    ds2 = (2.0 * accel * np.diff(s)).tolist()
    for i in range(len(v2) - 2, -1, -1):  # (braking into the next corner)
        v2[i] = min(v2[i], v2[i + 1] + ds2[i])
    for i in range(1, len(v2)):  # (speeding up out of the last)
        v2[i] = min(v2[i], v2[i - 1] + ds2[i - 1])
    return s, np.sqrt(v2)


def warp(
    arcs: FloatArray,
    step: float,
    cap: tuple[Sequence[float] | FloatArray, Sequence[float] | FloatArray],
    lap: float,
) -> FloatArray:
    """A timetable's arc lengths (``arcs``, every ``step`` s from now) driven under a
    speed cap along the route (``cap``: arcs, m/s): where the timetable is faster than
    the cap, its clock runs at cap / speed. ``lap``: the route's length on a circuit
    (arcs past it go round), else 0.

    The cap is looked up where the timetable is, so the time each of its steps takes
    is known at once: a cumulative sum, no loop."""
    at, caps = cap
    speed = np.diff(arcs) / step
    middle = 0.5 * (arcs[:-1] + arcs[1:])
    limit = np.interp(np.mod(middle, lap) if lap > 0.0 else middle, at, caps)
    taken = step * np.maximum(1.0, speed / limit)
    clock = np.concatenate(([0.0], np.cumsum(taken)))  # real time at each timetable step
    out: FloatArray = np.interp(np.arange(len(arcs)) * step, clock, arcs)
    return out


class CornerHabit:
    """The convoy's speed through the route's sharp corners, from those it drove.

    Args:
        curvature: A corner is sharper than this, 1/m.
        keep: Samples kept (the latest).
        min_samples: No corner speed before this many.
        after_stand_s: A corner entered this soon after standing is no sample.
        standing_mps: Slower along the route, the convoy stands.
    """

    def __init__(
        self,
        curvature: float = 0.04,
        *,
        keep: int = 5,
        min_samples: int = 2,
        after_stand_s: float = 15.0,
        standing_mps: float = 1.5,
    ) -> None:
        self.curvature = curvature
        self.min_samples = min_samples
        self.after_stand_s = after_stand_s
        self.standing_mps = standing_mps
        self.samples: deque[float] = deque(maxlen=keep)
        self._stretches: dict[int, tuple[Road, list[tuple[float, float]], list[float]]] = {}
        self._caps: dict[tuple[int, float, float], tuple[FloatArray, FloatArray]] = {}
        self._last: tuple[float, float, int] | None = None  # (t, arc, road) of the last estimate
        self._inside: tuple[int, float] | None = None  # (corner, t entered) of the last road
        self._stood_t = -math.inf  # when it last stood
        self._stood_inside = False

    @property
    def speed(self) -> float | None:
        """How fast the convoy takes a corner (m/s along the route), once known."""
        if len(self.samples) < self.min_samples:
            return None
        return float(np.median(self.samples))

    def corners(self, road: Road) -> list[tuple[float, float]]:
        """The sharp stretches of ``road`` (kept per road: the route either way round)."""
        return self._of(road)[1]

    def _of(self, road: Road) -> tuple[Road, list[tuple[float, float]], list[float]]:
        known = self._stretches.get(id(road))
        if known is None or known[0] is not road:
            corners = sharp_stretches(road, self.curvature)
            known = (road, corners, [c[0] for c in corners])
            if len(self._stretches) >= 4:
                self._stretches.clear()
            self._stretches[id(road)] = known
        return known

    def cap(self, road: Road, speed: float, accel: float) -> tuple[FloatArray, FloatArray]:
        """:func:`speed_cap` on ``road`` (kept for the last few corner speeds)."""
        key = (id(road), round(speed, 1), accel)
        cap = self._caps.get(key)
        if cap is None or cap[0] is not road.s:  # (another road where a freed one was)
            if len(self._caps) >= 8:
                self._caps.clear()
            cap = self._caps[key] = speed_cap(road, self.corners(road), key[1], accel)
        return cap

    def observe(self, t: float, road: Road, s: float, along: float) -> None:
        """Fold in the convoy at arc ``s`` of ``road`` (as it drives it) at ``t``."""
        if along < self.standing_mps:
            self._stood_t = t
            self._stood_inside = True
        last, self._last = self._last, (t, s, id(road))
        if last is None or last[2] != id(road) or s == last[1]:
            if last is not None and last[2] != id(road):
                self._inside = None
            return
        t0, s0, _ = last
        _, corners, starts = self._of(road)

        def crossed(arc: float) -> float:
            return t0 + (arc - s0) / (s - s0) * (t - t0)

        if self._inside is None:
            k = bisect.bisect_right(starts, s) - 1
            if k < 0 or not s0 < corners[k][0] <= s:
                return
            entered = crossed(corners[k][0])
            if entered - self._stood_t <= self.after_stand_s:
                return
            self._inside, self._stood_inside = (k, entered), False
        k, entered = self._inside
        lo, hi = corners[k]
        if s > hi:  # (through it, maybe within one estimate)
            took = crossed(hi) - entered
            if took > 0.0 and not self._stood_inside:
                self.samples.append((hi - lo) / took)
            self._inside = None
        elif s < lo - _BACK_M:
            self._inside = None
