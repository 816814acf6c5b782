"""The convoy's corners: where the route's are, how fast it takes them, and the forecast
of a convoy that keeps a planned speed but slows for them."""

from __future__ import annotations

import numpy as np
import pytest

from convoy_mav.mission.convoy_model import CORNER_RATIO, ConvoyModel
from convoy_mav.mission.corners import CornerHabit, sharp_stretches, speed_cap, warp
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import Piece, route_of
from convoy_mav.types import ConvoyEstimate

# North 400 m, a 12-m corner right (east) for 500 m, a 12-m corner left (north) for 400 m:
# two blocks of an urban grid.
NORTH, EAST = route_of(
    [
        Piece(400.0),
        Piece(radius=12.0, angle_deg=-90.0),
        Piece(500.0),
        Piece(radius=12.0, angle_deg=90.0),
        Piece(400.0),
    ]
)
GRID = Road.from_points(EAST, NORTH)


def test_the_routes_sharp_stretches_are_its_corners() -> None:
    corners = sharp_stretches(GRID, 0.04)
    assert len(corners) == 2
    (a0, a1), (b0, b1) = corners
    # The drawn corners' middles (0.5-m points), on the road (which cuts its corners).
    first, second = (
        GRID.project(float(EAST[i]), float(NORTH[i])) for i in (819, 819 + 1038)
    )  # fmt: skip
    assert a0 < first < a1 and b0 < second < b1
    assert 5.0 < a1 - a0 < 40.0  # (the smoothed road's corner: wider than the drawn 18.8 m)
    assert sharp_stretches(GRID, 0.0) == []  # (no corner curvature: no corners)
    assert sharp_stretches(Road.straight(0.0, 0.0, 0.0, 1000.0), 0.04) == []


def test_the_speed_cap_brakes_into_each_corner_and_speeds_up_out_of_it() -> None:
    corners = sharp_stretches(GRID, 0.04)
    at, cap = speed_cap(GRID, corners, 2.5, 1.0)
    s, v = np.array(at), np.array(cap)
    (a0, a1), _ = corners
    inside = (s >= a0) & (s <= a1)
    assert np.allclose(v[inside], 2.5)
    before = np.interp(a0 - 28.0, s, v)  # v^2 = 2.5^2 + 2 a d
    assert before == pytest.approx(np.sqrt(2.5**2 + 2.0 * 28.0), abs=0.05)
    after = np.interp(a1 + 28.0, s, v)
    assert after == pytest.approx(np.sqrt(2.5**2 + 2.0 * 28.0), abs=0.05)
    assert np.interp(200.0, s, v) > 20.0  # (far from any corner: no cap to speak of)


def test_warp_slows_a_timetable_where_it_is_over_the_cap_only() -> None:
    step = 0.25
    arcs = np.arange(0.0, 60.0, step) * 8.0  # (8 m/s for a minute)
    free = ([0.0, 1000.0], [20.0, 20.0])
    assert np.allclose(warp(arcs, step, free, 0.0), arcs)
    slow = ([0.0, 199.99, 200.0, 240.0, 240.01], [20.0, 20.0, 2.0, 2.0, 20.0])  # (2 m/s, 40 m)
    warped = warp(arcs, step, slow, 0.0)
    assert np.all(np.diff(warped) >= 0.0)
    assert np.allclose(warped[arcs <= 200.0], arcs[arcs <= 200.0])
    # 40 m at 2 m/s instead of 8: 15 s later past it, then at 8 m/s again.
    t_past = np.interp(300.0, warped, np.arange(len(arcs)) * step)
    assert t_past == pytest.approx(300.0 / 8.0 + 15.0, abs=0.5)
    assert (warped[-1] - warped[-5]) / (4 * step) == pytest.approx(8.0, abs=1e-6)
    # Round a circuit of 500 m the cap is looked up on the lap.
    lapped = warp(arcs + 500.0, step, slow, 500.0)
    assert np.allclose(lapped - 500.0, warped)


def _drive(
    habit: CornerHabit,
    road: Road,
    profile: list[tuple[float, float]],
    t: float = 0.0,
    s: float = 0.0,
) -> tuple[float, float]:
    """Drive ``road`` from (``t``, ``s``) at (up to arc length, m/s) in turn, an
    estimate a second; (t, s) at the end."""
    for until, speed in profile:
        while s < until:
            habit.observe(t, road, s, speed)
            t, s = t + 1.0, s + speed
    return t, s


def test_a_convoy_is_seen_to_take_its_corners_slowly() -> None:
    habit = CornerHabit(0.04)
    (a0, a1), (b0, b1) = habit.corners(GRID)
    t, s = _drive(habit, GRID, [(a0 - 30.0, 8.0), (a1 + 1.0, 2.5), (b0 - 30.0, 8.0)])
    assert habit.speed is None  # (one corner: not yet)
    _drive(habit, GRID, [(b1 + 1.0, 2.5), (GRID.length, 8.0)], t, s)
    assert list(habit.samples) == pytest.approx([2.5, 2.5], abs=1e-9)
    assert habit.speed == pytest.approx(2.5)


def test_a_corner_after_a_stand_or_stood_in_is_no_sample_and_one_estimate_will_do() -> None:
    (a0, a1), (b0, _) = sharp_stretches(GRID, 0.04)
    pulled_away = CornerHabit(0.04)
    t, s = _drive(pulled_away, GRID, [(a0 - 5.0, 8.0)])
    for k in range(20):  # (standing just short of it, 20 s, then through it at 3 m/s)
        pulled_away.observe(t + k, GRID, s, 0.0)
    _drive(pulled_away, GRID, [(b0 - 10.0, 3.0)], t + 20.0, s)
    assert len(pulled_away.samples) == 0
    stood_in = CornerHabit(0.04, after_stand_s=0.0)
    t, s = _drive(stood_in, GRID, [(a0 + 2.0, 8.0)])
    stood_in.observe(t, GRID, s, 0.0)  # (standing in it)
    _drive(stood_in, GRID, [(b0 - 10.0, 8.0)], t + 1.0, s + 0.5)
    assert len(stood_in.samples) == 0
    fast = CornerHabit(0.04)
    fast.observe(0.0, GRID, a0 - 10.0, 30.0)
    fast.observe(1.0, GRID, a1 + 10.0, 30.0)  # (through it between two estimates)
    assert list(fast.samples) == pytest.approx([(a1 - a0) / ((a1 - a0) / (a1 - a0 + 20.0))])


def _keeping(corner_mps: float, pace: float = 8.0) -> ConvoyModel:
    """A convoy with a planned speed of ``pace`` on ``GRID``, seen to take its first two
    corners at ``corner_mps`` (along the route), now back on the third block's start."""
    model = ConvoyModel(GRID)
    model.set_route(GRID, speeds=[(0.0, pace)])
    corners = model.corner_habit.corners(GRID)
    for lo, hi in corners:  # (two corners' samples, as the habit takes them)
        model.corner_habit.observe(0.0, GRID, lo - 1.0, pace)
        model.corner_habit.observe((hi - lo + 1.0) / corner_mps, GRID, hi, corner_mps)
        model.corner_habit.observe(100.0, GRID, hi + 30.0, pace)
    p = GRID.point(100.0)  # (then driving the first block again: the route's start)
    model.observe(ConvoyEstimate(200.0, p.y, p.x, pace, 0.0))
    return model


def test_a_convoy_seen_to_slow_for_corners_is_forecast_to_slow_for_the_next() -> None:
    slow, brisk = _keeping(2.5), _keeping(CORNER_RATIO * 8.0 + 0.1)
    assert slow.corner_speed == pytest.approx(2.5) and brisk.corner_speed is None
    dt = np.arange(0.0, 120.0, 1.0)
    s_slow = slow._arcs(dt)
    s_brisk = brisk._arcs(dt)
    # Both at 8 m/s to where the first corner's braking begins (from 300 m on: 2.5 m/s
    # at 400 m is 29 m of braking), then the slow one drops behind; past the corner it
    # is back at 8 m/s, some 10 s behind the forecast at speed, until the next corner.
    assert np.allclose(s_slow[dt <= 24.0], s_brisk[dt <= 24.0])
    lag = np.interp(700.0, s_slow, dt) - np.interp(700.0, s_brisk, dt)
    assert 5.0 < lag < 20.0
    speed = np.diff(s_slow)
    between = (s_slow[1:] > 480.0) & (s_slow[1:] < 850.0)  # (the block between the corners)
    assert speed[between].max() == pytest.approx(8.0, abs=0.05)
    assert speed.min() == pytest.approx(2.5, abs=0.05)
    # Without a planned speed in force, no corner speed is forecast (a human driver's
    # corners vary): the forecast is the convoy's own speed.
    planless = ConvoyModel(GRID)
    planless.corner_habit = slow.corner_habit
    p = GRID.point(100.0)
    planless.observe(ConvoyEstimate(200.0, p.y, p.x, 8.0, 0.0))
    assert planless.corner_speed is None
    assert np.allclose(planless._arcs(dt), 100.0 + 8.0 * dt, atol=0.5)


def _rover(corner_mps: float, *, keeps_speed: bool = True) -> tuple[ConvoyModel, float]:
    """A convoy on ``GRID`` at 8 m/s that takes its corners at ``corner_mps``, its route
    given as a rover's mission with no speed in it; estimates a second through both
    corners, to 60 m past the second. The model, and the arc it is at."""
    model = ConvoyModel(GRID)
    model.set_route(GRID, keeps_speed=keeps_speed)
    corners = model.corner_habit.corners(GRID)
    t, s = 0.0, 5.0
    end = corners[-1][1] + 60.0
    while s < end:
        v = corner_mps if any(lo - 1.0 <= s <= hi + 1.0 for lo, hi in corners) else 8.0
        x, y, h, _ = GRID.arrays(np.array([s]))
        heading = float(h[0])
        model.observe(
            ConvoyEstimate(t, float(y[0]), float(x[0]), v * np.sin(heading), v * np.cos(heading))
        )
        t, s = t + 1.0, s + v
    return model, s - 8.0


def test_a_rover_keeping_its_own_speed_is_forecast_at_it_and_slow_in_its_corners() -> None:
    """A PX4 rover's mission says no speed (its default is not asked): the speed it keeps
    between corners is learnt from the drive, and with its slow corners it is forecast
    as a planned one is."""
    rover, at = _rover(2.5)
    corner = rover.corner_speed  # (crossings timed between estimates a second apart)
    assert rover.cruise == pytest.approx(8.0) and corner is not None and 2.5 <= corner < 4.0
    assert rover._pace_at(at) == pytest.approx(8.0)
    planned = ConvoyModel(GRID)
    planned.set_route(GRID, speeds=[(0.0, 8.0)])
    planned.corner_habit = rover.corner_habit
    planned.observe(rover.estimate)  # type: ignore[arg-type]
    dt = np.arange(0.0, 60.0, 1.0)
    assert np.allclose(rover._arcs(dt), planned._arcs(dt))
    # Not told it keeps a speed (a route file), or seen to take its corners at its
    # speed (a drive that keeps none: forecast at one, roundabouts, speed changes and
    # the recorded drives lost 3-8 points): no speed of its own.
    assert _rover(2.5, keeps_speed=False)[0].cruise is None
    brisk, _ = _rover(7.5)
    assert brisk.corner_habit.speed is not None and brisk.cruise is None
