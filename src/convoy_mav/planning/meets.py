"""Meet-to-meet legs: flyable arcs that follow the pattern from one meeting to the next.

Design rules:
- Section IV's UAV meets the convoy at the end of every maximal arc
  (Lemma 4.1), and N UAVs meet it in turn, ``T / N`` apart (Corollary 4.3).
  Along a road the pattern (``convoy_mav.planning.pattern``, laid around
  the convoy) is what the UAV should fly, but it is not always flyable: the
  convoy's own turns and speed changes add to the pattern's maximal turns.
  A *leg* is the flyable path that stays closest to the pattern from the
  UAV's pose now to the pattern's position at the UAV's next meeting time.
- A leg is an optional steering part (a maximal turn either way, or a
  straight) of length ``l1``, then one circular arc tangent to the heading
  that ends on the target. Its speed is its length over the time left,
  clipped to the airframe's band. Of the candidates (three steering kinds x
  a grid of ``l1``; arcs tighter than ``R`` are never candidates) the leg
  kept is the one that arrives on time and stays nearest the pattern on
  the way (mean distance). On a straight road at constant speed that is the
  paper's arc itself, with no steering.
- A leg that cannot arrive on time meets the pattern at the earliest later
  time it can (scanned in ``late_step_s`` steps): just past its meeting the
  pattern is still over the convoy, so a leg a few seconds late still
  covers it. Iterating "plan again for where the pattern is when the leg
  arrives" overshoots: each retry arrives later, and a sudden turn of the
  convoy made every UAV 20-45 s late at once. Never at a point the pattern
  has left.
- Every leg starts at the pose the previous one ended with: position and
  heading are continuous, curvature is at most 1/R and speed inside the
  band, by construction, whatever the road or the convoy does.
- Pure; vectorised over the candidates.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from convoy_mav.errors import PlanningError
from convoy_mav.planning.dubins import (
    Pose,
    Segment,
    Turn,
    arc_points,
    dubins_word_lengths,
    dubins_word_path,
)
from convoy_mav.planning.plan import chain_positions

__all__ = ["Leg", "LegLimits", "Where", "pattern_pose", "plan_leg", "plan_leg_to_pose"]

FloatArray = npt.NDArray[np.float64]
Where = Callable[["FloatArray"], tuple["FloatArray", "FloatArray"]]
"""Where the pattern puts a UAV (planner x, y arrays) at each of an array of times."""

_TRACK_SAMPLES = 24  # points per candidate at which its distance to the pattern is taken
_RETARGETS = 3  # past the scan: times a late leg is planned again for where it arrives
_LATE_CHUNK = 8  # late times the scan for a late leg's meeting tries first (then 16, 32...)
_SCORE_CHUNK = 16  # late candidates scored first, least late first (then 32, 64...)
_HEADING_DT = 0.5  # s: the pattern's heading at a meeting, from its positions this far apart
_POSE_SCORED = 8  # legs to a pose built and scored: those nearest cruise speed
_POSE_RADII = tuple(1.0 + 0.125 * i for i in range(25))  # turn radii (x R) of a leg to a pose


@dataclass(frozen=True, slots=True)
class LegLimits:
    """What a leg may ask of the airframe.

    Attributes:
        turn_radius: R, metres: no arc is tighter.
        cruise: V, m/s.
        speed_band: (low, high) fractions of cruise a leg may be flown at.
        steer_max_s: Longest steering part considered, seconds at cruise.
        steer_step_s: Grid step of the steering part, seconds at cruise.
        pattern_radius: Radius of the pattern's arcs (0: R), a steering curvature.
        late_step_s: Step of the scan for a late leg's earliest feasible meeting.
        late_max_s: How far past its meeting the scan looks, seconds (0: no scan;
            a late leg is planned again for where the pattern is when it arrives).
    """

    turn_radius: float
    cruise: float
    speed_band: tuple[float, float] = (0.85, 1.15)
    steer_max_s: float = 40.0
    steer_step_s: float = 1.0
    pattern_radius: float = 0.0
    late_step_s: float = 1.0
    late_max_s: float = 60.0

    def __post_init__(self) -> None:
        lo, hi = self.speed_band
        for name in ("turn_radius", "cruise", "steer_max_s", "steer_step_s", "late_step_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise PlanningError(f"leg {name} must be positive and finite, got {value!r}")
        if not (math.isfinite(self.late_max_s) and self.late_max_s >= 0.0):
            raise PlanningError(f"leg late_max_s must be >= 0 and finite, got {self.late_max_s!r}")
        if not (0.0 < lo <= 1.0 <= hi and math.isfinite(hi)):
            raise PlanningError(f"speed band must satisfy 0 < low <= 1 <= high, got {lo}, {hi}")

    @property
    def steer_curvatures(self) -> tuple[float, ...]:
        """Steering curvatures: either way at R, at the pattern radius and at 2R; straight."""
        out = [0.0]
        for radius in (
            self.turn_radius,
            self.pattern_radius or self.turn_radius,
            2.0 * self.turn_radius,
        ):
            out += [1.0 / radius, -1.0 / radius]
        return tuple(sorted(set(out)))

    @property
    def speeds(self) -> tuple[float, float]:
        """Slowest and fastest speed a leg is flown at, m/s."""
        return self.speed_band[0] * self.cruise, self.speed_band[1] * self.cruise


@dataclass(frozen=True, slots=True)
class Leg:
    """One planned leg.

    Attributes:
        segments: The steering part (if any) then the arc, all flown at ``speed``.
        t_start: When the leg begins.
        t_end: When it ends: on the pattern, ``late_s`` past the meeting asked for,
            when ``on_time``; else where the speed band left it, early or late.
        speed: Speed it is flown at, m/s.
        on_time: The band allowed arriving at the pattern at ``t_end``.
        mean_offset: Mean distance from the pattern along the leg, metres.
        late_s: Seconds past the meeting asked for that ``t_end`` is (0: met on time).
    """

    segments: tuple[Segment, ...]
    t_start: float
    t_end: float
    speed: float
    on_time: bool
    mean_offset: float
    late_s: float = 0.0

    @property
    def end(self) -> Pose:
        """Pose at the end of the leg."""
        last = self.segments[-1]
        return last.at(last.duration)


def pattern_pose(pattern: Where, t: float) -> Pose:
    """Where the pattern puts the UAV at ``t``, going its way there (the heading from its
    positions ``_HEADING_DT`` apart)."""
    tx, ty = pattern(np.array([t, t + _HEADING_DT]))
    return Pose(float(tx[0]), float(ty[0]), math.atan2(float(ty[1] - ty[0]), float(tx[1] - tx[0])))


def plan_leg(
    pose: Pose,
    t: float,
    pattern: Where,
    t_meet: float,
    limits: LegLimits,
    *,
    heading_weight: float = 0.0,
) -> Leg:
    """The flyable leg from ``pose`` at ``t`` to the pattern at ``t_meet``.

    Args:
        pose: The UAV's pose at ``t`` (planner frame).
        t: Start time.
        pattern: Where the pattern puts this UAV at a time (at ``t_meet``: on
            the convoy, its meeting).
        t_meet: The meeting this leg is for (> t).
        limits: What the airframe can fly.
        heading_weight: Metres of mean distance from the pattern a radian of heading
            off the pattern's at the meeting is worth: a joining UAV that meets the
            pattern going its way flies it from there (0: position only).
    """
    steer = _steer(pose, limits)
    leg = _leg_to(steer, t, t_meet, pattern, limits, heading_weight)
    if leg.on_time:
        return leg
    late = _earliest_late_leg(steer, t, t_meet, pattern, limits, heading_weight)
    if late is not None:
        return late
    for _ in range(_RETARGETS):
        if leg.on_time:
            break
        leg = _leg_to(steer, t, leg.t_end, pattern, limits, heading_weight)
    return replace(leg, late_s=max(leg.t_end - t_meet, 0.0))


def plan_leg_to_pose(
    pose: Pose, t: float, pattern: Where, t_meet: float, limits: LegLimits
) -> Leg | None:
    """A leg from ``pose`` at ``t`` that meets the pattern at ``t_meet`` on its heading
    there, on time; None when none fits the speed band.

    ``plan_leg``'s legs end on the pattern with whatever heading their arc
    gives: a UAV that meets the convoy going the mirror image of its pattern's
    way meets it so again, arc after arc. This one is a Dubins path to the
    pattern's pose (every word, at turn radii of 1-4 R, after a whole turn
    either way or not, to take up the time), flown at one speed inside the
    band; of the few nearest cruise speed, the one nearest the pattern on the
    way (mean distance, as ``plan_leg``'s).
    """
    lo, hi = limits.speeds
    left = t_meet - t
    if left <= 0.0:
        return None
    goal = pattern_pose(pattern, t_meet)
    taus = np.linspace(0.0, left, _TRACK_SAMPLES)
    rx, ry = pattern(t + taus)
    # Every word's length first (closed form, cheap); the few nearest cruise are built.
    fits: list[tuple[float, Turn, float, str]] = []
    for loop in (Turn.STRAIGHT, Turn.LEFT, Turn.RIGHT):
        # (a whole turn at R first, either way, when the time left is that much longer)
        lap = 0.0 if loop == Turn.STRAIGHT else 2.0 * math.pi * limits.turn_radius
        for scale in _POSE_RADII:
            radius = scale * limits.turn_radius
            for word, length in dubins_word_lengths(pose, goal, radius).items():
                if lo * left <= length + lap <= hi * left:
                    fits.append((abs(length + lap - limits.cruise * left), loop, radius, word))
    best: tuple[float, tuple[Segment, ...], float] | None = None
    for _, loop, radius, word in sorted(fits)[:_POSE_SCORED]:
        path = dubins_word_path(pose, goal, word, radius, limits.cruise)
        if path is None:
            continue
        lap = 0.0 if loop == Turn.STRAIGHT else 2.0 * math.pi * limits.turn_radius
        speed = (path.length + lap) / left
        first = (Segment(pose, loop, limits.turn_radius, speed, lap / speed),) if lap else ()
        segments = first + tuple(
            Segment(seg.start, seg.turn, seg.radius, speed, seg.length / speed)
            for seg in path.segments
            if seg.length > 1e-9
        )
        offset = _mean_offset(segments, t, taus, rx, ry)
        if best is None or offset < best[0]:
            best = (offset, segments, speed)
    if best is None:
        return None
    offset, segments, speed = best
    return Leg(segments, t, t + sum(s.duration for s in segments), speed, True, offset)


def _mean_offset(
    segments: tuple[Segment, ...], t: float, taus: FloatArray, rx: FloatArray, ry: FloatArray
) -> float:
    """Mean distance of a path (segments from ``t``) from the pattern's points ``rx, ry``
    at ``t + taus``."""
    x, y = chain_positions(segments, taus)
    return float(np.mean(np.hypot(x - rx, y - ry)))


def _earliest_late_leg(
    steer: _Steer, t: float, t_meet: float, pattern: Where, limits: LegLimits, heading_weight: float
) -> Leg | None:
    """The leg to the pattern at the first time past ``t_meet`` some candidate reaches it
    in the speed band; None if none does within ``late_max_s``.

    One vectorised pass over every (time, candidate) pair, then one leg: a late
    leg costs about what an on-time one does (the planner runs beside the
    setpoint stream, which must never wait long).
    """
    lo, hi = limits.speeds
    step = limits.late_step_s
    taus = t_meet + np.arange(step, limits.late_max_s + 0.5 * step, step)
    # In growing chunks, soonest first: most late legs are found a few steps in.
    begin, size = 0, _LATE_CHUNK
    while begin < len(taus):
        chunk = taus[begin : begin + size]
        tx, ty = pattern(chunk)
        _, _, k2, _, total = _candidates(steer, (tx, ty))
        left = (chunk - t)[:, None]
        fits = _flyable(k2, limits) & (total >= lo * left) & (total <= hi * left)
        first = np.nonzero(fits.any(axis=1))[0]
        if len(first):
            tau = float(chunk[first[0]])
            leg = _leg_to(steer, t, tau, pattern, limits, heading_weight, on_time_only=True)
            return replace(leg, late_s=tau - t_meet)
        begin += size
        size *= 2
    return None


def _leg_to(
    steer: _Steer,
    t: float,
    t_meet: float,
    pattern: Where,
    limits: LegLimits,
    heading_weight: float,
    *,
    on_time_only: bool = False,
) -> Leg:
    lo, hi = limits.speeds
    left = max(t_meet - t, 1e-3)
    goal = pattern_pose(pattern, t_meet)
    target = (goal.x, goal.y)
    pose = steer.pose
    k1, l1, k2, arc, total = _candidates(steer, target)
    speed = np.clip(total / left, lo, hi)
    late = np.abs(total / speed - left)  # seconds early or late
    on_time = late < 0.05
    # cost = lateness + heading (the bound, cheap) + mean offset (the dear part)
    bound = np.where(_flyable(k2, limits) & (on_time | (not on_time_only)), late, np.inf)
    bound *= limits.cruise
    if heading_weight > 0.0:
        want = goal.heading
        h_end = pose.heading + k1 * l1 + np.where(np.isfinite(k2), k2, 0.0) * arc
        bound += heading_weight * np.abs(np.mod(h_end - want + math.pi, 2 * math.pi) - math.pi)
    taus = np.linspace(0.0, left, _TRACK_SAMPLES)
    rx, ry = pattern(t + taus)
    cost = np.full(len(bound), np.inf)
    offset = np.zeros(len(bound))

    def score(rows: npt.NDArray[np.intp]) -> None:
        if len(rows) == 0:
            return
        px, py = _positions(steer, rows, k2[rows], speed[rows], taus)
        offset[rows] = np.mean(np.hypot(px - rx[None, :], py - ry[None, :]), axis=1)
        cost[rows] = bound[rows] + offset[rows]

    # The on-time candidates first; then the late ones, least late first, in growing
    # chunks: one whose bound alone is above the best so far cannot win (the same
    # leg as scoring all, for a fraction of the work at a corner).
    finite = np.isfinite(bound)
    score(np.nonzero(finite & on_time)[0])
    best = float(np.min(cost))
    rows = np.nonzero(finite & ~on_time & (bound < best))[0]
    rows = rows[np.argsort(bound[rows], kind="stable")]
    begin, size = 0, _SCORE_CHUNK
    while begin < len(rows):
        chunk = rows[begin : begin + size]
        chunk = chunk[bound[chunk] < best]
        if len(chunk) == 0:
            break  # (the rest are later still)
        score(chunk)
        best = min(best, float(np.min(cost[chunk])))
        begin += size
        size *= 2
    i = int(np.argmin(cost))
    if not math.isfinite(float(cost[i])):  # pragma: no cover - a long enough turn always fits
        raise PlanningError("no flyable leg reaches the pattern")
    v = float(speed[i])
    segments = _candidate_segments(steer, i, float(k2[i]), float(arc[i]), v)
    end = t + sum(s.duration for s in segments)
    return Leg(segments, t, end, v, bool(late[i] < 0.05), float(offset[i]))


def _candidate_segments(
    steer: _Steer, i: int, k2: float, arc: float, speed: float
) -> tuple[Segment, ...]:
    """Candidate ``i``'s path flown at ``speed``: its steering part (if any), then its arc
    of curvature ``k2`` and length ``arc`` (what ``_positions`` scores it on)."""
    k1, l1 = float(steer.k1[i]), float(steer.l1[i])
    segments = []
    start = steer.pose
    if l1 > 0.0:
        kind = Turn.STRAIGHT if k1 == 0.0 else (Turn.LEFT if k1 > 0.0 else Turn.RIGHT)
        radius = 0.0 if k1 == 0.0 else 1.0 / abs(k1)
        first = Segment(start, kind, radius, speed, l1 / speed)
        segments.append(first)
        start = first.at(first.duration)
    if abs(k2) > 1e-12:
        kind = Turn.LEFT if k2 > 0.0 else Turn.RIGHT
        segments.append(Segment(start, kind, 1.0 / abs(k2), speed, arc / speed))
    elif arc > 1e-9:
        segments.append(Segment(start, Turn.STRAIGHT, 0.0, speed, arc / speed))
    if not segments:  # already there, at the meeting time
        segments.append(Segment(start, Turn.STRAIGHT, 0.0, speed, 1e-3))
    return tuple(segments)


def _flyable(k2: FloatArray, limits: LegLimits) -> npt.NDArray[np.bool_]:
    """Candidates whose arc is no tighter than R (a full turn's ``inf`` never is)."""
    return np.abs(k2) <= 1.0 / limits.turn_radius + 1e-12


@dataclass(frozen=True, slots=True)
class _Steer:
    """The steering parts a leg from ``pose`` may start with, and where each ends.

    The same for every target a leg from this pose is tried against (the meeting,
    then the late scan's times), so it is laid out once per leg.
    """

    pose: Pose
    k1: FloatArray  # steer curvature
    l1: FloatArray  # steer length
    x1: FloatArray  # where the steering part ends (planner frame)
    y1: FloatArray
    h1: FloatArray  # heading there
    hx: FloatArray  # cos h1
    hy: FloatArray  # sin h1


def _steer(pose: Pose, limits: LegLimits) -> _Steer:
    """Every steering part from ``pose``: three kinds x the grid of lengths."""
    step = limits.steer_step_s * limits.cruise
    lengths = np.arange(0.0, limits.steer_max_s * limits.cruise + 0.5 * step, step)
    kinds = np.array(limits.steer_curvatures)
    k1 = np.repeat(kinds, len(lengths))
    l1 = np.tile(lengths, len(kinds))
    x1, y1, h1 = arc_points(pose.x, pose.y, pose.heading, k1, l1)
    return _Steer(pose, k1, l1, x1, y1, h1, np.cos(h1), np.sin(h1))


def _candidates(
    steer: _Steer, target: tuple[float, float] | tuple[FloatArray, FloatArray]
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Every candidate: (steer curvature, steer length, arc curvature, arc length, total).

    ``target`` may be arrays of points: the arc parts (and ``total``) then have one row
    per point.
    """
    gx, gy = (np.asarray(g, dtype=np.float64) for g in target)
    if gx.ndim:
        gx, gy = gx[:, None], gy[:, None]
    dx, dy = gx - steer.x1, gy - steer.y1
    d2 = dx * dx + dy * dy
    hx, hy = steer.hx, steer.hy
    cross = hx * dy - hy * dx
    dot = hx * dx + hy * dy
    # The circle tangent to the heading through the target: signed curvature
    # 2 cross / d^2, turning twice the angle between the heading and the chord.
    k2 = np.where(d2 > 1e-12, 2.0 * cross / np.maximum(d2, 1e-12), 0.0)
    turn = 2.0 * np.arctan2(np.abs(cross), dot)
    straight = np.abs(k2) <= 1e-12
    arc = np.where(straight, np.sqrt(d2), turn / np.where(straight, 1.0, np.abs(k2)))
    # A target straight behind is only reached by a full turn: not a candidate.
    k2 = np.where(straight & (dot < 0.0), np.inf, k2)
    return steer.k1, steer.l1, k2, arc, steer.l1 + arc


def _positions(
    steer: _Steer, rows: npt.NDArray[np.intp], k2: FloatArray, speed: FloatArray, taus: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Where each candidate (``rows`` of the steering parts, with their arcs ``k2`` and
    speeds) is ``taus`` seconds after it starts (columns).

    One pass of ``arc_points`` over the grid: on the steering part from the pose,
    past it on the arc from where the steering part ends (that end, per row).
    """
    dist = speed[:, None] * taus[None, :]
    l1c = steer.l1[rows][:, None]
    on_arc = dist > l1c
    pose = steer.pose
    x0 = np.where(on_arc, steer.x1[rows][:, None], pose.x)
    y0 = np.where(on_arc, steer.y1[rows][:, None], pose.y)
    h0 = np.where(on_arc, steer.h1[rows][:, None], pose.heading)
    k2c = np.where(np.isfinite(k2), k2, 0.0)[:, None]
    k = np.where(on_arc, k2c, steer.k1[rows][:, None])
    s = np.where(on_arc, dist - l1c, dist)
    x, y, _ = arc_points(x0, y0, h0, k, s)
    return x, y
