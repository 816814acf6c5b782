"""Detours: the two-arc manoeuvre that keeps a moving target in sight longest."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.planning.detours import best_detour
from convoy_mav.planning.dubins import Pose, Segment, Turn, arc_points
from convoy_mav.planning.meets import LegLimits

R, V, r = 150.0, 18.0, 100.0
LIMITS = LegLimits(R, V, (0.85, 1.15))
TIMES = np.arange(0.0, 41.0, 1.0)


def _convoy(
    vx: float, vy: float, x0: float = 0.0, y0: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    return x0 + vx * TIMES, y0 + vy * TIMES


def _seen_by(segments: tuple[Segment, ...], target: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Samples of ``target`` the flown segments see, sampled segment by segment."""
    seen = np.zeros(len(TIMES), dtype=bool)
    start = 0.0
    for seg in segments:
        for i, t in enumerate(TIMES):
            if start - 1e-9 <= t <= start + seg.duration + 1e-9:
                at = seg.at(min(max(t - start, 0.0), seg.duration))
                seen[i] |= math.hypot(at.x - target[0][i], at.y - target[1][i]) <= r
        start += seg.duration
    return seen


def test_a_uav_flying_away_from_the_convoy_turns_back_and_keeps_it_in_sight() -> None:
    # The UAV has just met a convoy driving north at 8 m/s and flies away east.
    target = _convoy(0.0, 8.0)
    pose = Pose(20.0, 0.0, 0.0)
    wanted = np.ones(len(TIMES), dtype=bool)
    straight_on = Segment(pose, Turn.STRAIGHT, 0.0, V, 40.0)
    mine = _seen_by((straight_on,), target)
    assert mine.sum() <= 8  # flying on, it loses the convoy within seconds
    detour = best_detour(pose, 0.0, TIMES, target, wanted, mine, r, LIMITS)
    assert detour is not None
    seen = _seen_by(detour.segments, target)
    # What the search scored is what the segments fly.
    assert detour.seen == int(seen.sum())
    flown = np.asarray(TIMES - detour.t_end <= 0.0)
    assert detour.score == detour.seen - int((mine & flown).sum())
    assert detour.seen >= 2 * int(mine.sum()) >= 8  # seen twice as long at least
    assert detour.segments[0].turn == Turn.LEFT  # back toward the convoy's side


def test_no_detour_when_nothing_is_wanted_or_the_uav_sees_it_all_already() -> None:
    target = _convoy(0.0, 8.0)
    pose = Pose(20.0, 0.0, 0.0)
    none = np.zeros(len(TIMES), dtype=bool)
    assert best_detour(pose, 0.0, TIMES, target, none, none, r, LIMITS) is None
    everything = np.ones(len(TIMES), dtype=bool)
    assert best_detour(pose, 0.0, TIMES, target, everything, everything, r, LIMITS) is None
    # Far beyond reach: nothing to gain.
    far = _convoy(0.0, 8.0, x0=5000.0)
    assert best_detour(pose, 0.0, TIMES, far, everything, none, r, LIMITS) is None


@settings(max_examples=60, deadline=None)
@given(
    st.floats(-400.0, 400.0),
    st.floats(-400.0, 400.0),
    st.floats(-math.pi, math.pi),
    st.floats(-12.0, 12.0),
    st.floats(-12.0, 12.0),
    st.integers(0, 2**41 - 1),
)
def test_every_detour_is_flyable_and_sees_what_it_was_scored_for(
    x: float, y: float, heading: float, vx: float, vy: float, holes: int
) -> None:
    target = _convoy(vx, vy)
    wanted = np.array([(holes >> i) & 1 == 1 for i in range(len(TIMES))])
    pose = Pose(x, y, heading)
    detour = best_detour(pose, 0.0, TIMES, target, wanted, np.zeros_like(wanted), r, LIMITS)
    if detour is None:
        return
    lo, hi = LIMITS.speeds
    start = pose
    for seg in detour.segments:
        assert lo - 1e-9 <= seg.speed <= hi + 1e-9
        assert seg.turn == Turn.STRAIGHT or seg.radius >= R - 1e-6
        # Continuous: each segment starts where the last one ended, on its heading.
        assert math.hypot(seg.start.x - start.x, seg.start.y - start.y) < 1e-6
        assert abs(math.remainder(seg.start.heading - start.heading, 2 * math.pi)) < 1e-9
        start = seg.at(seg.duration)
    assert detour.t_end == sum(s.duration for s in detour.segments)
    assert detour.score > 0
    assert detour.seen == int((_seen_by(detour.segments, target) & wanted).sum())


def test_arc_points_is_the_segment_in_closed_form_on_arcs_and_straights() -> None:
    pose = Pose(10.0, -20.0, 0.7)
    for turn, radius in ((Turn.LEFT, R), (Turn.RIGHT, R), (Turn.STRAIGHT, 0.0), (Turn.LEFT, 2 * R)):
        seg = Segment(pose, turn, radius, V, 30.0)
        k = 0.0 if turn == Turn.STRAIGHT else float(turn) / radius
        for t in (0.0, 7.5, 30.0):
            end = seg.at(t)
            x, y, h = arc_points(pose.x, pose.y, pose.heading, k, V * t)
            assert math.hypot(float(x) - end.x, float(y) - end.y) < 1e-9
            assert abs(float(h) - end.heading) < 1e-12
