"""Dubins primitives and shortest paths."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.planning import Pose, Segment, Turn, dubins_shortest_path, wrap_angle
from convoy_mav.planning.dubins import DUBINS_WORDS, _word_params

coord = st.floats(-500.0, 500.0)
angle = st.floats(-math.pi, math.pi)
pose = st.builds(Pose, coord, coord, angle)


def test_wrap_angle_range() -> None:
    assert wrap_angle(math.pi) == pytest.approx(math.pi)
    assert wrap_angle(-math.pi) == pytest.approx(math.pi)
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(0.0) == 0.0


@pytest.mark.parametrize("turn", [Turn.LEFT, Turn.RIGHT])
def test_full_arc_returns_to_start(turn: Turn) -> None:
    seg = Segment(Pose(3.0, -2.0, 0.7), turn, 40.0, 12.0, 2 * math.pi * 40.0 / 12.0)
    end = seg.end
    assert (end.x, end.y) == pytest.approx((3.0, -2.0), abs=1e-9)
    assert wrap_angle(end.heading - 0.7) == pytest.approx(0.0, abs=1e-12)


def test_left_quarter_turn_geometry() -> None:
    # Heading east, turning left about a centre R to the north: a quarter turn ends at (R, R).
    seg = Segment(Pose(0.0, 0.0, 0.0), Turn.LEFT, 10.0, 1.0, 10.0 * math.pi / 2)
    assert seg.center == pytest.approx((0.0, 10.0))
    assert (seg.end.x, seg.end.y, seg.end.heading) == pytest.approx((10.0, 10.0, math.pi / 2))
    assert seg.turn_rate == pytest.approx(0.1)


def test_straight_segment() -> None:
    seg = Segment(Pose(1.0, 1.0, math.pi / 2), Turn.STRAIGHT, 0.0, 2.0, 3.0)
    assert (seg.end.x, seg.end.y) == pytest.approx((1.0, 7.0))
    assert seg.turn_rate == 0.0
    assert seg.length == 6.0
    with pytest.raises(ValueError, match="no centre"):
        _ = seg.center


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"duration": -1.0}, "duration"),
        ({"speed": 0.0}, "speed"),
        ({"radius": math.nan}, "radius"),
    ],
)
def test_segment_rejects_bad_values(kwargs: dict[str, float], match: str) -> None:
    base: dict[str, float] = {"radius": 1.0, "speed": 1.0, "duration": 1.0}
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        Segment(Pose(0, 0, 0), Turn.LEFT, base["radius"], base["speed"], base["duration"])


@settings(max_examples=400, deadline=None)
@given(pose, pose, st.floats(1.0, 200.0))
def test_dubins_path_lands_on_goal_and_is_shortest(start: Pose, goal: Pose, radius: float) -> None:
    path = dubins_shortest_path(start, goal, radius, 15.0)
    end = path.segments[-1].end
    scale = max(radius, math.hypot(goal.x - start.x, goal.y - start.y))
    assert math.hypot(end.x - goal.x, end.y - goal.y) <= 1e-6 * scale
    assert abs(wrap_angle(end.heading - goal.heading)) <= 1e-6
    # No shorter than the straight line, no longer than any other word that lands.
    assert path.length >= math.hypot(goal.x - start.x, goal.y - start.y) - 1e-6 * scale
    for a, b in zip(path.segments, path.segments[1:], strict=False):
        assert math.hypot(a.end.x - b.start.x, a.end.y - b.start.y) < 1e-9
    dx, dy = goal.x - start.x, goal.y - start.y
    theta = math.atan2(dy, dx)
    d = math.hypot(dx, dy) / radius
    for word in DUBINS_WORDS:
        params = _word_params(
            word, (start.heading - theta) % math.tau, (goal.heading - theta) % math.tau, d
        )
        if params is not None:
            p = start
            for letter, n in zip(word, params, strict=True):
                turn = {"L": Turn.LEFT, "R": Turn.RIGHT, "S": Turn.STRAIGHT}[letter]
                p = Segment(p, turn, radius, 15.0, n * radius / 15.0).end
            if math.hypot(p.x - goal.x, p.y - goal.y) < 1e-6 * scale:
                assert path.length <= sum(params) * radius + 1e-6


def test_dubins_straight_ahead_is_pure_straight() -> None:
    path = dubins_shortest_path(Pose(0, 0, 0), Pose(100, 0, 0), 10.0, 5.0)
    assert path.length == pytest.approx(100.0)
    assert path.duration == pytest.approx(20.0)


def test_dubins_reversal_needs_turns() -> None:
    # Turning back to fly the opposite way from the same point: a CCC word of length > 2 pi R.
    path = dubins_shortest_path(Pose(0, 0, 0), Pose(0, 0, math.pi), 10.0, 1.0)
    assert path.word in {"LRL", "RLR"}
    assert path.length > 2 * math.pi * 10.0 * 0.5


def test_dubins_rejects_bad_radius() -> None:
    with pytest.raises(ValueError, match="turn radius"):
        dubins_shortest_path(Pose(0, 0, 0), Pose(1, 1, 0), 0.0, 1.0)
