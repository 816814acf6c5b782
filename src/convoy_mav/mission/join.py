"""Timed Dubins joins: from wherever a UAV is to its moving plan slot, exactly on time.

Method (all in the planner frame and planner time; V the UAV speed, R its
minimum turn radius):

- The slot is the pose ``g(T)`` the plan gives the UAV's vehicle at time T.
  Let ``L(T)`` be the Dubins distance from the UAV's pose at ``t`` to ``g(T)``
  and ``f(T) = L(T) - V (T - t)``: how much longer the shortest path is than
  the time left allows.  A constant-speed path arriving exactly at T (length
  ``V (T - t)``) can only exist where ``f(T) <= 0``.
- ``f`` never increases.  The slot itself moves along a curvature-bounded
  path at speed V, so the shortest path to ``g(T)`` followed by the slot's
  own path for ``dT`` reaches ``g(T + dT)`` in ``L(T) + V dT``: hence
  ``L(T + dT) <= L(T) + V dT``.  So ``{T : f(T) <= 0}`` is a half-line and
  its start ``T1`` is found by doubling and bisection, robustly, even though
  Dubins distance jumps (it is discontinuous in the goal pose).
- At ``T1`` ``f`` usually crosses zero continuously: the Dubins path to
  ``g(T1)`` is exactly as long as the time allows and the UAV flies it at
  constant speed V and lands on its slot on time (to bisection precision,
  well under a millimetre).
- If ``f`` jumps over zero at ``T1`` (the shortest path suddenly becomes much
  shorter, e.g. when the slot laps the UAV on its own circle), no shortest
  path fits exactly.  Every single Dubins word's length is continuous in T
  except where one of its arcs wraps, so we scan the six words (not only the
  shortest) forward from ``T1`` and take the first exact zero of
  ``L_w(T) - V (T - t)``: a slightly longer, non-shortest path that is
  exactly as long as the time allows.
- Fallback (no word fits before it): ``T2``, the first time at which
  ``f(T2) <= -2 pi R``; fly a *wait circle* of radius
  ``rho = -f(T2) / (2 pi) >= R`` from the current pose (it returns to the same
  pose), then the shortest path to ``g(T2)``: total length exactly
  ``V (T2 - t)``.
- Constant speed V throughout: no speed change is needed, so this works for
  fixed-wing autopilots that do not track speed commands well.  Small phase
  errors while flying are left to the autopilot layer's along-track speed
  correction.
- The join path is the ``lead_in`` of a ``Trajectory`` whose ``cycle`` is the
  slot's cycle re-started at the arrival point: the result is continuous in
  position and heading and coincides with the plan after arrival.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

from convoy_mav.errors import PlanningError
from convoy_mav.planning.dubins import (
    DubinsPath,
    Pose,
    Segment,
    Turn,
    dubins_shortest_path,
    dubins_word_lengths,
    dubins_word_path,
)
from convoy_mav.planning.plan import Trajectory

__all__ = [
    "EXACT_TIME_TOLERANCE",
    "Join",
    "earliest_arrival",
    "plan_join",
    "rotated_cycle",
    "slot_pose",
]

#: Bisection stops when the arrival time is bracketed this tightly, seconds.
EXACT_TIME_TOLERANCE = 1e-7
#: Largest drop of ``f`` across the final bracket still taken as continuous, metres.
_JUMP_TOLERANCE = 1e-3
#: Give up when no arrival is found this many "natural times" after the start.
_HORIZON_FACTOR = 1000.0


@dataclass(frozen=True, slots=True)
class Join:
    """A timed join to a plan slot.

    Attributes:
        trajectory: Lead-in (optional wait circle, then the Dubins path) and
            then the slot's cycle; planner frame and planner time.
        start: Planner time at which the join begins.
        arrival: Planner time at which the UAV is on its slot.
        path_length: Metres flown from ``start`` to ``arrival``.
        word: Dubins word of the path (``"LSR"``...), ``""`` if already on slot.
        loiter_radius: Radius of the wait circle flown first, or None.
    """

    trajectory: Trajectory
    start: float
    arrival: float
    path_length: float
    word: str
    loiter_radius: float | None

    @property
    def duration(self) -> float:
        """Seconds from the start of the join to arrival."""
        return self.arrival - self.start


def slot_pose(slot: Trajectory, tau: float) -> Pose:
    """The pose of a plan slot at planner time ``tau``."""
    s = slot.sample(tau)
    return Pose(s.x, s.y, s.heading)


def rotated_cycle(slot: Trajectory, tau: float) -> tuple[Segment, ...]:
    """The slot's cycle re-started at planner time ``tau``: one lap from ``slot_pose(tau)``.

    With the slot's drift, a ``Trajectory`` whose cycle starts at ``tau`` with
    these segments samples exactly as ``slot`` does from ``tau`` on.

    Raises:
        ValueError: If ``tau`` falls in the slot's own lead-in.
    """
    if tau < slot.cycle_start and slot.lead_in:
        raise ValueError("cannot re-start a cycle inside its trajectory's lead-in")
    cycle = slot.cycle
    times = list(itertools.accumulate((s.duration for s in cycle), initial=0.0))
    lap, rem = divmod(tau - slot.cycle_start, slot.period)
    i = min(bisect.bisect_right(times, rem) - 1, len(cycle) - 1)
    seg = cycle[i]
    u = min(max(rem - times[i], 0.0), seg.duration)
    dx, dy = lap * slot.drift[0], lap * slot.drift[1]
    nx, ny = dx + slot.drift[0], dy + slot.drift[1]

    def moved(s: Segment, ox: float, oy: float, duration: float | None = None) -> Segment:
        d = s.duration if duration is None else duration
        return Segment(s.start.translated(ox, oy), s.turn, s.radius, s.speed, d)

    head = Segment(seg.at(u).translated(dx, dy), seg.turn, seg.radius, seg.speed, seg.duration - u)
    out = [head]
    out += [moved(s, dx, dy) for s in cycle[i + 1 :]]
    out += [moved(s, nx, ny) for s in cycle[:i]]
    out.append(moved(seg, nx, ny, u))
    kept = tuple(s for s in out if s.duration > 0.0)
    return kept or (head,)


@dataclass(frozen=True, slots=True)
class _Crossing:
    lo: float  # f(lo) > level
    hi: float  # f(hi) <= level
    f_lo: float
    f_hi: float


def _first_crossing(
    f: Callable[[float], float], lo: float, level: float, step: float, horizon: float, tol: float
) -> _Crossing:
    """Bracket ``inf {T >= lo : f(T) <= level}`` of a non-increasing ``f`` to ``tol``."""
    f_lo = f(lo)
    if f_lo <= level:
        return _Crossing(lo, lo, f_lo, f_lo)
    origin = lo
    hi = lo + step
    f_hi = f(hi)
    while f_hi > level:
        if hi - origin > horizon:
            raise PlanningError(f"no join arrival found within {horizon:.0f} s")
        lo, f_lo = hi, f_hi
        step *= 2.0
        hi = lo + step
        f_hi = f(hi)
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        f_mid = f(mid)
        if f_mid <= level:
            hi, f_hi = mid, f_mid
        else:
            lo, f_lo = mid, f_mid
    return _Crossing(lo, hi, f_lo, f_hi)


@dataclass(frozen=True, slots=True)
class _Solution:
    arrival: float
    path: DubinsPath
    loiter_radius: float | None


def _scan_words(
    start: Pose,
    slot: Trajectory,
    tau0: float,
    window: tuple[float, float],
    radius: float,
    speed: float,
    tol: float,
    jump: float,
) -> _Solution | None:
    """Earliest exact-length single-word path in ``window``, or None.

    Each word's length is continuous in T except where an arc wraps, so a
    sign change of ``L_w(T) - V (T - t)`` between two grid times brackets an
    exact-length path unless the bisection ends on a wrap (a jump).
    """
    lo_t, hi_t = window

    def g(tau: float) -> dict[str, float]:
        lengths = dubins_word_lengths(start, slot_pose(slot, tau), radius)
        return {w: length - speed * (tau - tau0) for w, length in lengths.items()}

    step = max(0.1 * radius / speed, 4.0 * tol)
    prev_t, prev = lo_t, g(lo_t)
    while prev_t < hi_t:
        cur_t = min(prev_t + step, hi_t)
        cur = g(cur_t)
        found: list[_Solution] = []
        for word, value in cur.items():
            before = prev.get(word)
            if before is None or (before > 0.0) == (value > 0.0):
                continue

            def fw(tau: float, word: str = word) -> float:
                return g(tau).get(word, math.nan)

            a, b, fa, fb = prev_t, cur_t, before, value
            while b - a > tol:
                mid = 0.5 * (a + b)
                fm = fw(mid)
                if math.isnan(fm):
                    break
                if (fm > 0.0) == (fa > 0.0):
                    a, fa = mid, fm
                else:
                    b, fb = mid, fm
            if b - a > tol or abs(fa - fb) > jump:
                continue  # the word vanished or wrapped: no exact length here
            root = a if abs(fa) < abs(fb) else b
            path = dubins_word_path(start, slot_pose(slot, root), word, radius, speed)
            if path is not None and abs(path.length - speed * (root - tau0)) <= jump:
                found.append(_Solution(root, path, None))
        if found:
            return min(found, key=lambda sol: sol.arrival)
        prev_t, prev = cur_t, cur
    return None


def _solve(
    start: Pose, slot: Trajectory, tau0: float, radius: float, speed: float, tol: float
) -> _Solution:
    def shortest_to(tau: float) -> DubinsPath:
        return dubins_shortest_path(start, slot_pose(slot, tau), radius, speed)

    def f(tau: float) -> float:
        lengths = dubins_word_lengths(start, slot_pose(slot, tau), radius)
        return min(lengths.values()) - speed * (tau - tau0)

    circle = 2.0 * math.pi * radius
    step = max(f(tau0), circle) / speed
    horizon = _HORIZON_FACTOR * step
    jump = _JUMP_TOLERANCE + 3.0 * speed * tol
    first = _first_crossing(f, tau0, 0.0, step, horizon, tol)
    if first.f_lo - first.f_hi <= jump or first.lo == first.hi:
        return _Solution(first.hi, shortest_to(first.hi), None)
    # The shortest length jumped over zero.  Fallback: at the first time the
    # shortest path is one R-circle shorter than allowed, a wait circle of
    # radius >= R absorbs the slack exactly.  Before that, any single word of
    # exactly the right length is better (earlier).
    second = _first_crossing(f, first.lo, -circle, step, horizon, tol)
    window = (first.hi, second.hi)
    word = _scan_words(start, slot, tau0, window, radius, speed, tol, jump)
    if word is not None:
        return word
    path = shortest_to(second.hi)
    slack = speed * (second.hi - tau0) - path.length
    return _Solution(second.hi, path, max(radius, slack / (2.0 * math.pi)))


def _check(radius: float, speed: float) -> None:
    for name, value in (("radius", radius), ("speed", speed)):
        if not (math.isfinite(value) and value > 0.0):
            raise ValueError(f"{name} must be positive and finite, got {value!r}")


def earliest_arrival(
    start: Pose,
    slot: Trajectory,
    tau0: float,
    *,
    radius: float,
    speed: float,
) -> float:
    """Planner time at which ``plan_join`` from ``start`` at ``tau0`` reaches ``slot``.

    The same search without building the trajectory: for ranking candidate
    slots (about 0.3 ms per call).
    """
    _check(radius, speed)
    return _solve(start, slot, tau0, radius, speed, EXACT_TIME_TOLERANCE).arrival


def plan_join(start: Pose, slot: Trajectory, tau0: float, *, radius: float, speed: float) -> Join:
    """A constant-speed path from ``start`` at planner time ``tau0`` onto ``slot``, on time.

    Args:
        start: The UAV's pose at ``tau0`` (planner frame).
        slot: The plan trajectory to join (no lead-in of its own).
        tau0: Planner time the join starts.
        radius: Minimum turn radius R used for the path and any wait circle.
        speed: UAV speed V (the slot's speed).

    Raises:
        PlanningError: If no arrival is found (cannot happen for the paper's
            plans: the slot returns or the convoy is slower than V).
    """
    _check(radius, speed)
    sol = _solve(start, slot, tau0, radius, speed, EXACT_TIME_TOLERANCE)
    lead: list[Segment] = []
    if sol.loiter_radius is not None:
        turn = next((s.turn for s in sol.path.segments if s.duration > 0.0), Turn.RIGHT)
        if turn == Turn.STRAIGHT:
            turn = Turn.RIGHT
        rho = sol.loiter_radius
        lead.append(Segment(start, turn, rho, speed, 2.0 * math.pi * rho / speed))
    lead += [s for s in sol.path.segments if s.duration > 0.0]
    flown = sum(s.length for s in lead)
    arrival = tau0 + flown / speed
    cycle = rotated_cycle(slot, sol.arrival)
    trajectory = Trajectory(tau0, cycle, tuple(lead), slot.drift)
    word = sol.path.word if sol.path.length > 0.0 else ""
    return Join(trajectory, tau0, arrival, flown, word, sol.loiter_radius)
