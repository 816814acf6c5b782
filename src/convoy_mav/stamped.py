"""Coverage judged at the telemetry's own times, not when the service happened to look.

A host stall (a loaded machine, a long garbage collection) holds the control loop up
for a while; the autopilots fly on, and their fixes, stamped by their own clocks,
arrive late and together. A monitor that looks only at the latest fix on each tick
must call the stall unknown (and under-claim what was covered) or hold the last
state (and over-claim). This decides each instant of a fixed grid of mission time
from the fixes around it instead:

* a UAV's position at grid time ``tau`` is interpolated between its fixes just
  before and after (at most ``max_gap`` apart: 5 s of a plane on a 150-m turn is a
  chord 7 m inside its arc), or carried forward along its velocity at most
  ``fresh_s`` past its last fix; otherwise it is unknown;
* ``tau`` is decided as soon as a UAV covers it, or once every counted UAV has a
  fix after it, or once the fleet's telemetry has come ``horizon`` seconds past it
  (by its stamps, not the service's clock, which runs on through a stall) and a few
  ticks have gone by, or at the latest 10 s on: on what is known then (an unknown
  position sees nothing);
* which UAVs count at ``tau`` (heard, airborne, in band, on their slot) and the
  convoy's position are those of the first control tick at or after ``tau``,
  the convoy interpolated between ticks.

At the mission's end no later instant is decided, and the report's ``flush``
decides the last few seconds on the fixes that have come in by then.

Decided instants are handed to the :class:`~convoy_mav.coverage.CoverageTracker`
as evenly spaced samples, so the totals, gaps and per-UAV times follow, a few
seconds behind at most. Pure and synchronous; mission seconds throughout.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from dataclasses import dataclass, field

__all__ = ["StampedCoverage", "StampedSample"]

Point = tuple[float, float]

_LONGEST_WAIT_S = 10.0
"""Mission s an undecided instant waits at most, whatever the telemetry (none at all)."""
_TICKS_AFTER = 3
"""Ticks an undecided instant waits for at least, however late: the first tick after a
stall runs before the fixes that came meanwhile are read (one datagram per socket per
turn of the event loop)."""


@dataclass(frozen=True, slots=True)
class StampedSample:
    """One decided grid instant: the convoy and the counted UAVs' positions then."""

    t: float
    convoy: Point
    uavs: dict[int, Point]


@dataclass(slots=True)
class _Fixes:
    """One UAV's recent fixes, in stamp order (parallel columns, trimmed from the left)."""

    times: list[float] = field(default_factory=list)
    rows: list[tuple[float, float, float, float]] = field(default_factory=list)  # n, e, vn, ve

    def add(self, t: float, row: tuple[float, float, float, float], keep_from: float) -> None:
        if self.times and t <= self.times[-1]:
            return  # (a repeat or a reordered fix: the later one stands)
        self.times.append(t)
        self.rows.append(row)
        if self.times[0] < keep_from and len(self.times) > 64:
            cut = bisect.bisect_left(self.times, keep_from)
            del self.times[:cut], self.rows[:cut]

    def at(self, tau: float, max_gap: float, fresh_s: float) -> Point | None:
        times = self.times
        k = bisect.bisect_right(times, tau)  # times[k - 1] <= tau < times[k]
        if k and k < len(times) and times[k] - times[k - 1] <= max_gap:
            a, b = self.rows[k - 1], self.rows[k]
            f = (tau - times[k - 1]) / (times[k] - times[k - 1])
            return a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])
        if k and tau - times[k - 1] <= fresh_s:
            n, e, vn, ve = self.rows[k - 1]
            dt = tau - times[k - 1]
            return n + vn * dt, e + ve * dt
        if k == 0 and times and times[0] - tau <= fresh_s:  # (just before its first fix)
            n, e, vn, ve = self.rows[k]
            dt = times[k] - tau
            return n - vn * dt, e - ve * dt
        return None

    def after(self, tau: float) -> bool:
        return bool(self.times) and self.times[-1] > tau


@dataclass
class StampedCoverage:
    """Decides grid instants of coverage from stamped fixes (see the module docstring).

    Args:
        sensor_radius: r, metres.
        step: Grid spacing, mission s (the control tick's).
        max_gap: Longest interval between two fixes a position is interpolated over.
        fresh_s: How long past its last fix a UAV is carried along its velocity.
        horizon: Longest wait for fixes before an instant is decided on what is known.
    """

    sensor_radius: float
    step: float = 0.1
    max_gap: float = 5.0
    fresh_s: float = 1.0
    horizon: float = 3.0
    _fixes: dict[int, _Fixes] = field(default_factory=dict)
    _ticks: deque[tuple[float, Point, frozenset[int]]] = field(default_factory=deque)
    _next: float | None = None
    _origin: float = 0.0  # the grid is origin + k * step (no drift of summed steps)
    _frontier: float = -math.inf  # the latest stamp of any fix: how far telemetry has come
    _k: int = 0
    _end: float = math.inf  # no instant past it is decided (the mission's end)

    def start(self, t: float) -> None:
        """Decide instants from ``t`` on (the protect phase's start)."""
        self._next, self._origin, self._k = t, t, 0
        while self._ticks and self._ticks[0][0] < t - self.step:
            self._ticks.popleft()

    def fix(self, sysid: int, t: float, north: float, east: float, vn: float, ve: float) -> None:
        """A UAV's position, stamped ``t`` by its own clock, as it arrives."""
        if not all(map(math.isfinite, (t, north, east, vn, ve))):
            return
        fixes = self._fixes.get(sysid)
        if fixes is None:
            fixes = self._fixes[sysid] = _Fixes()
        keep = (self._next if self._next is not None else t) - self.max_gap - self.horizon
        fixes.add(t, (north, east, vn, ve), keep)
        self._frontier = max(self._frontier, t)

    def end(self, t: float) -> None:
        """The mission ends at ``t``: no later instant is decided (ticks go on meanwhile,
        for the convoy's position up to ``t``)."""
        self._end = t

    def flush(self) -> list[StampedSample]:
        """Decide every instant left up to the end on what is known now (the report's:
        the fixes of the last seconds have come in by then)."""
        if not self._ticks or not math.isfinite(self._end):
            return []
        return self._decide(self._end, force=True)

    def tick(self, t: float, convoy: Point, counted: frozenset[int]) -> list[StampedSample]:
        """A control tick at ``t``: the convoy and the UAVs counted then; returns the
        instants decided now, in order."""
        ticks = self._ticks
        if ticks and t <= ticks[-1][0]:
            return []
        ticks.append((t, convoy, counted))
        return self._decide(min(t, self._end), force=False)

    def _decide(self, t: float, *, force: bool) -> list[StampedSample]:
        """Instants up to ``t`` that can be decided (all of them if ``force``)."""
        ticks = self._ticks
        out: list[StampedSample] = []
        tau = self._next
        if tau is None:
            return out
        r = self.sensor_radius
        while tau <= t:
            while len(ticks) > 1 and ticks[1][0] <= tau:
                ticks.popleft()  # (ticks[0] is the last at or before tau)
            first = ticks[0]
            nxt = ticks[1] if len(ticks) > 1 and first[0] < tau else first
            centre = _between(first, nxt, tau)
            positions = {}
            for sysid in nxt[2]:
                fixes = self._fixes.get(sysid)
                p = None if fixes is None else fixes.at(tau, self.max_gap, self.fresh_s)
                if p is not None:
                    positions[sysid] = p
            covered = any(math.dist(p, centre) <= r for p in positions.values())
            settled = all((f := self._fixes.get(s)) is not None and f.after(tau) for s in nxt[2])
            later = len(ticks) - (1 if first[0] <= tau else 0)
            forced = (
                force
                or (self._frontier - tau >= self.horizon and later >= _TICKS_AFTER)
                or ticks[-1][0] - tau >= _LONGEST_WAIT_S
            )
            if not (covered or settled or forced):
                break  # (fixes of this instant may still be on their way)
            out.append(StampedSample(tau, centre, positions))
            self._k += 1
            tau = self._origin + self._k * self.step
        self._next = tau
        return out


def _between(
    a: tuple[float, Point, frozenset[int]], b: tuple[float, Point, frozenset[int]], tau: float
) -> Point:
    """The convoy at ``tau`` between two ticks (the later one's, past both)."""
    (ta, pa, _), (tb, pb, _) = a, b
    if tb <= ta or tau >= tb:
        return pb
    f = max(0.0, (tau - ta) / (tb - ta))
    return pa[0] + f * (pb[0] - pa[0]), pa[1] + f * (pb[1] - pa[1])
