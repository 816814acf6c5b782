"""The road model: arc length, heading, curvature and projection from points as they come."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convoy_mav.errors import PlanningError
from convoy_mav.planning.road import Road


def _circle(radius: float, sweep: float, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    a = np.linspace(0.0, sweep, n)
    return radius * np.sin(a), radius * (1.0 - np.cos(a))  # starts at 0 heading +x, turns left


def test_straight_road_has_its_heading_and_no_curvature() -> None:
    s = np.linspace(0.0, 500.0, 51)
    road = Road.from_points(3.0 + s * math.cos(0.4), -2.0 + s * math.sin(0.4))
    assert road.length == pytest.approx(500.0, rel=1e-3)
    mid = road.point(250.0)
    assert mid.heading == pytest.approx(0.4, abs=1e-6)
    assert abs(mid.curvature) < 1e-6
    assert (mid.x, mid.y) == pytest.approx((3.0 + 250 * math.cos(0.4), -2.0 + 250 * math.sin(0.4)))


def test_circle_curvature_is_one_over_its_radius_away_from_the_ends() -> None:
    road = Road.from_points(*_circle(200.0, math.pi))
    k = road.curvature[(road.s > 60.0) & (road.s < road.length - 60.0)]
    assert np.all(np.abs(k - 1.0 / 200.0) < 0.03 / 200.0)
    assert road.max_curvature() == pytest.approx(1.0 / 200.0, rel=0.05)


def test_gps_noise_does_not_reach_the_curvature() -> None:
    rng = np.random.default_rng(3)
    x = np.arange(0.0, 1000.0, 8.0)  # 1 Hz fixes at 8 m/s with 3 m noise
    road = Road.from_points(x + rng.normal(0, 3, len(x)), rng.normal(0, 3, len(x)), smooth_m=25.0)
    raw = np.arctan2(np.diff(rng.normal(0, 3, len(x))), 8.0)  # what differencing fixes gives
    assert np.max(np.abs(raw)) > 0.5
    assert np.max(np.abs(road.heading)) < 0.1
    assert np.max(np.abs(road.curvature)) < 1.0 / 100.0


def test_beyond_the_ends_the_road_goes_on_straight() -> None:
    road = Road.from_points([0.0, 100.0], [0.0, 0.0])
    after = road.point(road.length + 50.0)
    before = road.point(-30.0)
    assert (after.x, after.y, after.curvature) == pytest.approx((150.0, 0.0, 0.0))
    assert (before.x, before.y) == pytest.approx((-30.0, 0.0))


def test_projection_finds_the_arc_length_near_the_hint_on_a_road_that_doubles_back() -> None:
    # Out along y = 0, a hairpin, back along y = 40: a point between the two legs
    # belongs to whichever leg the convoy is on.
    out = np.arange(0.0, 500.0, 5.0)
    turn = np.linspace(-math.pi / 2, math.pi / 2, 30)
    xs = np.concatenate((out, 500.0 + 20.0 * np.cos(turn), out[::-1]))
    ys = np.concatenate((np.zeros(len(out)), 20.0 + 20.0 * np.sin(turn), np.full(len(out), 40.0)))
    road = Road.from_points(xs, ys, smooth_m=5.0)
    first = road.project(250.0, 15.0, near=250.0, window=100.0)
    second = road.project(250.0, 25.0, near=road.length - 250.0, window=100.0)
    assert first == pytest.approx(250.0, abs=5.0)
    assert second == pytest.approx(road.length - 250.0, abs=5.0)
    assert road.project(700.0, 0.0) > road.length - 5.0 or road.project(-50.0, 0.0) < 0.0


def test_frenet_offsets_are_capped_inside_a_tight_bend() -> None:
    road = Road.from_points(*_circle(50.0, math.pi / 2), smooth_m=2.0)
    s = np.array([road.length / 2])
    x, y = road.frenet(s, np.array([200.0]))  # 200 m to the left: inside a 50-m bend
    p = road.point(float(s[0]))
    assert math.hypot(x[0] - p.x, y[0] - p.y) <= 0.8 * 50.0 * 1.05


def test_repeated_points_are_merged_and_too_few_are_refused() -> None:
    road = Road.from_points([0, 0, 0, 10, 10, 20], [0, 0, 0, 0, 0, 0])
    assert road.length == pytest.approx(20.0, abs=0.5)
    with pytest.raises(PlanningError, match="two distinct points"):
        Road.from_points([1.0, 1.2, float("nan")], [2.0, 2.1, 0.0])
