"""Optimal convoy protection for a stationary convoy (Section III of the paper).

Ding, Rahmani & Egerstedt, "Multi-UAV Convoy Protection: An Optimal Approach to
Path Planning and Coordination", IEEE T-RO 2010.

Design rules:
- The convoy circle is the disk of radius ``r`` (sensor radius) centred on the
  convoy centroid, which is the origin of the frame used here.
- A UAV is a Dubins vehicle of turn radius ``R > r`` and speed ``V``; the paper's
  unit-speed results scale by ``1/V`` in time and not at all in space.
- Fixed entry (Problem 3.1): the optimal path inside is one of L, R, LR, RL
  (Theorem 3.3, eq. 33).  We build each candidate in closed form from the
  geometry of Lemma 3.2 (switch point on the line through the origin and the
  exit point, eq. 27) and keep the longest; no numerical optimisation.
- Free entry (Problem 3.2): the optimal entry states are eq. (37) and the
  optimal convoy-protection orbit is the circle of radius R whose chord inside
  the convoy circle is a diameter (Definition 3.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from convoy_mav.errors import InfeasibleEntryError, PlanningError
from convoy_mav.planning.dubins import Pose, Segment, Turn, wrap_angle

__all__ = [
    "ENTRY_RADIUS_TOLERANCE",
    "EntrySolution",
    "check_entry",
    "coverage_per_uav",
    "min_uavs",
    "optimal_entry_states",
    "optimal_path_from_entry",
    "orbit_cycle",
    "time_inside_optimal",
]

TWO_PI = 2.0 * math.pi

#: Relative distance from the convoy circle within which an entry point is
#: taken to lie on it (and is snapped onto it): typed coordinates carry a few
#: digits only.
ENTRY_RADIUS_TOLERANCE = 1e-3


def _check_radii(turn_radius: float, sensor_radius: float) -> None:
    for name, value in (("turn radius", turn_radius), ("sensor radius", sensor_radius)):
        if not (math.isfinite(value) and value > 0.0):
            raise PlanningError(f"{name} must be a positive finite number, got {value!r}")


def time_inside_optimal(turn_radius: float, sensor_radius: float, speed: float = 1.0) -> float:
    """Longest time one UAV can stay inside the convoy circle: ``2 R asin(r/R) / V``.

    This is the length of the globally optimal path of Theorem 3.5 divided by
    the speed.
    """
    _check_radii(turn_radius, sensor_radius)
    if turn_radius <= sensor_radius:
        return math.inf
    return 2.0 * turn_radius * math.asin(sensor_radius / turn_radius) / speed


def coverage_per_uav(turn_radius: float, sensor_radius: float) -> float:
    """Fraction of time one UAV on an optimal orbit sees the convoy: ``asin(r/R)/pi``.

    The optimal convoy-protection orbit (Definition 3.2) has length ``2 pi R``
    of which ``2 R asin(r/R)`` lies inside the convoy circle (Theorem 3.6).
    """
    _check_radii(turn_radius, sensor_radius)
    if turn_radius <= sensor_radius:
        return 1.0
    return math.asin(sensor_radius / turn_radius) / math.pi


def min_uavs(turn_radius: float, sensor_radius: float) -> int:
    """Minimum number of UAVs for perpetual protection: ``ceil(pi / asin(r/R))`` (eq. 41).

    The trivial case ``R <= r`` needs one UAV orbiting the centroid.
    """
    _check_radii(turn_radius, sensor_radius)
    if turn_radius <= sensor_radius:
        return 1
    ratio = math.pi / math.asin(sensor_radius / turn_radius)
    # A ratio that is an integer up to rounding must not round up to one more UAV.
    nearest = round(ratio)
    return nearest if abs(ratio - nearest) < 1e-9 else math.ceil(ratio)


def optimal_entry_states(
    turn_radius: float, sensor_radius: float, rotation: float = 0.0
) -> tuple[Pose, Pose]:
    """The two optimal entry states of eq. (37) for a given rotation ``theta``.

    Returns ``[-r cos th, -r sin th, asin(r/R) + th]`` (flown turning right) and
    ``[-r cos th, -r sin th, -asin(r/R) + th]`` (flown turning left).  Each
    lies on the line through the origin and its own exit state (eq. 36).
    """
    _check_radii(turn_radius, sensor_radius)
    if turn_radius <= sensor_radius:
        raise PlanningError("R <= r: any orbit of the centroid covers the convoy; no entry needed")
    a = math.asin(sensor_radius / turn_radius)
    base = Pose(-sensor_radius, 0.0, 0.0)
    return (
        Pose(base.x, base.y, a).rotated(rotation),
        Pose(base.x, base.y, -a).rotated(rotation),
    )


def orbit_cycle(
    turn_radius: float, sensor_radius: float, speed: float, rotation: float, turn: Turn
) -> tuple[Segment, Segment]:
    """One lap of an optimal convoy-protection orbit (Definition 3.2).

    The lap starts at an optimal entry state (eq. 37) and is split into the
    arc inside the convoy circle (``2 R asin(r/R)`` long, Theorem 3.5) and the
    arc outside it that brings the UAV back to the same entry state.

    Args:
        turn_radius: R, metres (must exceed r).
        sensor_radius: r, metres.
        speed: UAV speed, m/s.
        rotation: Angle by which the orbit is rotated about the centroid.
        turn: ``Turn.RIGHT`` (clockwise) or ``Turn.LEFT``.
    """
    clockwise, counter_clockwise = optimal_entry_states(turn_radius, sensor_radius, rotation)
    entry = clockwise if turn == Turn.RIGHT else counter_clockwise
    inside = time_inside_optimal(turn_radius, sensor_radius, speed)
    period = TWO_PI * turn_radius / speed
    first = Segment(entry, turn, turn_radius, speed, inside)
    return first, Segment(first.end, turn, turn_radius, speed, period - inside)


@dataclass(frozen=True, slots=True)
class EntrySolution:
    """The time-optimal path inside the convoy circle from a fixed entry (Problem 3.1).

    Attributes:
        sequence: One of ``"L"``, ``"R"``, ``"LR"``, ``"RL"`` (eq. 33).
        entry: The entry state (snapped onto the convoy circle).
        switch: The switching state, or None for a single arc.
        exit: The exit state on the convoy circle.
        time_inside: Time from entry to exit, seconds.
        segments: The one or two arcs flown.
    """

    sequence: str
    entry: Pose
    switch: Pose | None
    exit: Pose
    time_inside: float
    segments: tuple[Segment, ...]


def _first_exit_angle(
    center: tuple[float, float],
    radius: float,
    turn: Turn,
    start: tuple[float, float],
    sensor_radius: float,
    from_boundary: bool,
) -> float | None:
    """Angle swept along an arc from ``start`` until it first meets the convoy circle.

    The arc's circle meets the convoy circle in two points symmetric about the
    line through both centres; we return the smaller positive sweep in the
    direction of travel (skipping the start itself when it lies on the circle).
    """
    cx, cy = center
    dist = math.hypot(cx, cy)
    if dist == 0.0:
        return None
    # Intersection of |p| = r and |p - c| = R: foot of the chord along the centre line.
    along = (dist * dist + sensor_radius * sensor_radius - radius * radius) / (2.0 * dist)
    half_sq = sensor_radius * sensor_radius - along * along
    if half_sq < 0.0:
        return None
    half = math.sqrt(half_sq)
    ux, uy = cx / dist, cy / dist
    points = (
        (along * ux - half * uy, along * uy + half * ux),
        (along * ux + half * uy, along * uy - half * ux),
    )
    start_angle = math.atan2(start[1] - cy, start[0] - cx)
    best: float | None = None
    for px, py in points:
        sweep = (turn * (math.atan2(py - cy, px - cx) - start_angle)) % TWO_PI
        if from_boundary and (sweep < 1e-9 or sweep > TWO_PI - 1e-9):
            continue
        if best is None or sweep < best:
            best = sweep
    return best


def _single_arc(entry: Pose, turn: Turn, R: float, r: float, V: float) -> EntrySolution | None:
    """The pure ``L`` or ``R`` path: turn maximally until the circle is left."""
    seg = Segment(entry, turn, R, V, 0.0)
    sweep = _first_exit_angle(seg.center, R, turn, (entry.x, entry.y), r, from_boundary=True)
    if sweep is None:
        return None
    arc = Segment(entry, turn, R, V, sweep * R / V)
    return EntrySolution(turn.letter, entry, None, arc.end, arc.duration, (arc,))


def _two_arcs(entry: Pose, first: Turn, R: float, r: float, V: float) -> list[EntrySolution]:
    """Every one-switch COT ``first`` then ``-first`` through the entry state.

    In the frame where the exit point is ``[r, 0]`` (Lemma 3.2) and the last
    arc turns through ``2 thetā``, the switch point is ``[r - 2R sin thetā, 0]``
    (eq. 27) and the first arc's centre is ``[r - 3R sin thetā, ±R cos thetā]``.
    Its distance to the origin is fixed by the entry state, which gives a
    quadratic in ``s = sin thetā``::

        8 R² s² - 6 R r s + (r² + R² - |c₁|²) = 0

    Each admissible root gives one candidate; it is kept only if the first arc
    reaches the switch point before leaving the circle and the second arc
    reaches the exit before any other crossing.
    """
    c1x, c1y = Segment(entry, first, R, V, 0.0).center
    c1_sq = c1x * c1x + c1y * c1y
    a, b, c = 8.0 * R * R, -6.0 * R * r, r * r + R * R - c1_sq
    disc = b * b - 4.0 * a * c
    if disc < 0.0:
        return []
    roots = {(-b - math.sqrt(disc)) / (2.0 * a), (-b + math.sqrt(disc)) / (2.0 * a)}
    second = Turn(-first)
    out: list[EntrySolution] = []
    entry_sweep = _first_exit_angle((c1x, c1y), R, first, (entry.x, entry.y), r, True)
    for s in roots:
        if not (0.0 < s < r / R):
            continue
        theta_bar = math.asin(s)
        # Rotated frame: for a last arc turning right the switch heading is +thetā.
        sign = 1.0 if second == Turn.RIGHT else -1.0
        c1_rot = (r - 3.0 * R * s, sign * R * math.cos(theta_bar))
        psi = math.atan2(c1y, c1x) - math.atan2(c1_rot[1], c1_rot[0])
        switch = Pose(r - 2.0 * R * s, 0.0, sign * theta_bar).rotated(psi)
        # Sweep of the first arc from the entry to the switch point.
        start_angle = math.atan2(entry.y - c1y, entry.x - c1x)
        switch_angle = math.atan2(switch.y - c1y, switch.x - c1x)
        sweep1 = (first * (switch_angle - start_angle)) % TWO_PI
        if entry_sweep is None or sweep1 > entry_sweep + 1e-12:
            continue
        arc1 = Segment(entry, first, R, V, sweep1 * R / V)
        if abs(wrap_angle(arc1.end.heading - switch.heading)) > 1e-6:
            continue
        arc2_probe = Segment(arc1.end, second, R, V, 0.0)
        sweep2 = _first_exit_angle(
            arc2_probe.center, R, second, (arc1.end.x, arc1.end.y), r, from_boundary=False
        )
        if sweep2 is None or abs(sweep2 - 2.0 * theta_bar) > 1e-6:
            continue
        arc2 = Segment(arc1.end, second, R, V, 2.0 * theta_bar * R / V)
        out.append(
            EntrySolution(
                first.letter + second.letter,
                entry,
                arc1.end,
                arc2.end,
                arc1.duration + arc2.duration,
                (arc1, arc2),
            )
        )
    return out


def check_entry(entry: Pose, sensor_radius: float) -> Pose:
    """Validate an entry state against the feasible entry set of eq. (8).

    The paper prints eq. (8) as ``-pi/2 < theta - atan2(y, x) < pi/2``, which
    would make the heading point *out* of the circle; the text ("we exclude
    initial conditions that point away from the convoy circle") and the
    optimal entry states of eq. (37) require the heading to be within pi/2 of
    the inward normal ``atan2(-y, -x)``, which is what is checked here.

    Returns:
        The entry snapped exactly onto the convoy circle.

    Raises:
        InfeasibleEntryError: Off the circle, tangent to it, or pointing out.
    """
    values = (entry.x, entry.y, entry.heading)
    if not all(math.isfinite(v) for v in values):
        raise InfeasibleEntryError(f"entry state must be finite, got {list(values)!r}")
    dist = math.hypot(entry.x, entry.y)
    if abs(dist - sensor_radius) > ENTRY_RADIUS_TOLERANCE * sensor_radius:
        raise InfeasibleEntryError(
            f"entry point ({entry.x:g}, {entry.y:g}) is {dist:g} from the centroid, "
            f"not on the convoy circle of radius {sensor_radius:g}"
        )
    inward = math.atan2(-entry.y, -entry.x)
    if abs(wrap_angle(entry.heading - inward)) >= math.pi / 2.0:
        raise InfeasibleEntryError(
            f"entry heading {entry.heading:g} rad does not point into the convoy circle "
            f"(inward normal {inward:g} rad; eq. 8 needs |heading - inward| < pi/2)"
        )
    scale = sensor_radius / dist
    return Pose(entry.x * scale, entry.y * scale, entry.heading)


def optimal_path_from_entry(
    entry: Pose, turn_radius: float, sensor_radius: float, speed: float = 1.0
) -> EntrySolution:
    """Solve Problem 3.1: the longest path inside the convoy circle from a fixed entry.

    By Theorem 3.3 the optimal path switches at most once and by Corollary 3.4
    holds no straight segment, so it is one of L, R, LR, RL (eq. 33); each is
    built in closed form and the longest is returned.  Ties (e.g. entry on the
    line of symmetry, Fig. 5 at x(0) = 0) are resolved in the order LR, RL, L, R.

    Raises:
        PlanningError: Bad radii, or R <= r (the UAV can stay inside forever).
        InfeasibleEntryError: The entry state is not in the feasible set (eq. 8).
    """
    _check_radii(turn_radius, sensor_radius)
    if not (math.isfinite(speed) and speed > 0.0):
        raise PlanningError(f"UAV speed must be a positive finite number, got {speed!r}")
    if turn_radius <= sensor_radius:
        raise PlanningError(
            f"turn radius {turn_radius:g} <= sensor radius {sensor_radius:g}: the UAV can "
            "stay over the convoy indefinitely (trivial case), there is no exit"
        )
    entry = check_entry(entry, sensor_radius)
    R, r, V = turn_radius, sensor_radius, speed
    candidates: list[EntrySolution] = []
    candidates += _two_arcs(entry, Turn.LEFT, R, r, V)
    candidates += _two_arcs(entry, Turn.RIGHT, R, r, V)
    for turn in (Turn.LEFT, Turn.RIGHT):
        single = _single_arc(entry, turn, R, r, V)
        if single is not None:
            candidates.append(single)
    best = candidates[0]
    for cand in candidates[1:]:
        if cand.time_inside > best.time_inside * (1.0 + 1e-12):
            best = cand
    return best
