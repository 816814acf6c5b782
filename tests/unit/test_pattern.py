"""The paper's moving pattern in the convoy's frame, its counts and the pattern radius."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from convoy_mav.planning import PlanRequest, make_plan
from convoy_mav.planning.moving import beta_from_speed_ratio, min_uavs_moving
from convoy_mav.planning.pattern import (
    MAX_SPEED_RATIO,
    PatternClock,
    beta_for_speed,
    half_cycle_rate,
    min_uavs_road,
    min_uavs_stopped,
    pattern_radius,
    relative_offsets,
)
from convoy_mav.planning.stationary import min_uavs

R, r, V = 150.0, 100.0, 18.0


@given(st.floats(0.001, MAX_SPEED_RATIO))
def test_beta_table_matches_lemma_4_1(ratio: float) -> None:
    assert beta_for_speed(ratio * V, V) == pytest.approx(beta_from_speed_ratio(ratio), abs=2e-6)


def test_beta_is_pi_for_a_stopped_convoy_and_capped_for_a_fast_one() -> None:
    assert beta_for_speed(0.0, V) == math.pi
    assert beta_for_speed(-1.0, V) == math.pi
    assert beta_for_speed(V, V) == pytest.approx(beta_for_speed(MAX_SPEED_RATIO * V, V))


@pytest.mark.parametrize("v", [2.0, 8.0, 12.0])
def test_convoy_plus_pattern_is_the_papers_plan_on_a_straight_road(v: float) -> None:
    """c(t) + q(phase) is Section IV's UAV path exactly (Lemma 4.1, Fig. 10)."""
    plan = make_plan(PlanRequest(R, r, V, convoy_speed=v, uavs=1))
    beta = beta_for_speed(v, V)
    t = np.linspace(0.0, 4.0 / half_cycle_rate(beta, R, V), 400)
    qx, qy = relative_offsets(t * half_cycle_rate(beta, R, V), beta, R)
    s = plan.vehicles[0].trajectory.sample_array(t)
    assert np.allclose(v * t + qx, s.x, atol=1e-3)
    assert np.allclose(qy, s.y, atol=1e-3)


@given(st.floats(0.0, 1.0), st.floats(0.0, 12.0))
def test_every_speed_meets_the_convoy_at_whole_phases(w: float, v: float) -> None:
    beta = beta_for_speed(v, V)
    qx, qy = relative_offsets(np.array([0.0, 1.0, 2.0, 3.0]), beta, R)
    assert np.allclose(qx, 0.0, atol=1e-9) and np.allclose(qy, 0.0, atol=1e-9)
    # ... and the family is continuous in speed: nearby speeds, nearby patterns
    a = relative_offsets(np.array([w]), beta, R)
    b = relative_offsets(np.array([w]), beta_for_speed(v + 0.01, V), R)
    assert math.hypot(float(a[0][0] - b[0][0]), float(a[1][0] - b[1][0])) < 5.0


def test_stopped_count_is_the_limit_of_corollary_4_3_and_at_most_one_over_theorem_3_5() -> None:
    for radius, sensor in [(150, 100), (50, 45), (200, 120), (300, 60), (100, 99)]:
        stopped = min_uavs_stopped(radius, sensor)
        assert min_uavs_moving(radius, sensor, 1e-4) == stopped
        assert min_uavs(radius, sensor) <= stopped <= min_uavs(radius, sensor) + 1


def test_road_count_covers_the_whole_speed_profile() -> None:
    assert min_uavs_road(R, r, V) == max(min_uavs_stopped(R, r), min_uavs(R, r))
    fast_only = min_uavs_road(R, r, V, [10.0, 12.0])
    assert fast_only == max(min_uavs_moving(R, r, 10 / V), min_uavs_moving(R, r, 12 / V))
    assert min_uavs_road(R, r, V, [0.0, 12.0]) == min_uavs_road(R, r, V)


def test_pattern_radius_buys_turn_with_a_spare_uav_and_never_costs_coverage() -> None:
    n = min_uavs(R, r) + 1
    rho = pattern_radius(R, r, n)
    assert R < rho <= 1.3 * R
    # N figure eights of that radius still cover a stopped convoy (Corollary 4.3, v -> 0)
    assert n * 2.0 * math.asin(r / (2.0 * rho)) / math.pi >= 1.0
    assert pattern_radius(R, r, 2) == R  # too few UAVs: the paper's own radius
    with pytest.raises(ValueError):
        pattern_radius(R, r, 0)


def test_clock_lays_the_pattern_along_the_smoothed_course_and_holds_it_at_a_stop() -> None:
    clock = PatternClock(0.0, 8.0, 0.0, tau=20.0)
    clock.advance(100.0, 0.0, 8.0, R, V)  # turned left 90 degrees
    assert clock.course == pytest.approx(math.pi / 2, abs=0.01)
    phase = clock.phase
    clock.advance(300.0, 0.0, 0.0, R, V)  # stopped
    assert clock.course == pytest.approx(math.pi / 2, abs=0.01)
    assert clock.speed < 0.01
    # one half-cycle (a full circle at a stop) every 2 pi R / V
    assert clock.phase - phase == pytest.approx(200.0 * V / (2 * math.pi * R), rel=0.1)


def test_a_stop_shows_in_the_pattern_speed_within_seconds_a_winding_road_keeps_its_progress() -> (
    None
):
    clock = PatternClock(0.0, 8.0, 0.0, tau=20.0, speed_tau=5.0)
    clock.advance(60.0, 8.0, 0.0, R, V)
    assert clock.speed == pytest.approx(8.0, rel=1e-3)
    clock.advance(75.0, 0.0, 0.0, R, V)  # parked for 15 s: three speed_tau
    assert clock.speed < 0.06 * 8.0
    # A road that turns back and forth at full speed: the mean velocity is slower.
    winding = PatternClock(0.0, 8.0, 0.0, tau=20.0, speed_tau=5.0)
    for k in range(20):
        heading = math.pi / 3 * (1 if k % 2 else -1)
        winding.advance(10.0 * (k + 1), 8.0 * math.cos(heading), 8.0 * math.sin(heading), R, V)
    assert winding.speed < 0.6 * 8.0 + 0.5
    copy = winding.copy()
    assert (copy.speed, copy.phase, copy.course) == (winding.speed, winding.phase, winding.course)


def _advanced(
    clock: PatternClock, times: list[float], vx: list[float], vy: list[float]
) -> tuple[list[float], list[float], list[float]]:
    """(phase, course, beta) of a copy of ``clock`` advanced to each time in turn."""
    copy = clock.copy()
    out: tuple[list[float], list[float], list[float]] = ([], [], [])
    for tk, a, b in zip(times, vx, vy, strict=True):
        copy.advance(tk, a, b, R, V)
        for values, value in zip(out, copy.state(V), strict=True):
            values.append(value)
    return out


@given(
    st.lists(
        st.tuples(st.floats(0.0, 3.0), st.floats(-15.0, 15.0), st.floats(-15.0, 15.0)),
        min_size=1,
        max_size=60,
    ),
    st.floats(-10.0, 10.0),
    st.floats(-10.0, 10.0),
)
def test_a_forecast_is_what_advancing_a_copy_step_by_step_gives(
    steps: list[tuple[float, float, float]], vx0: float, vy0: float
) -> None:
    clock = PatternClock(0.0, vx0, vy0, tau=20.0, speed_tau=5.0)
    clock.advance(2.3, 1.0, -2.0, R, V)
    times = list(itertools.accumulate((dt for dt, _, _ in steps), initial=clock.t))[1:]
    vx = [v for _, v, _ in steps]
    vy = [v for _, _, v in steps]
    before = (clock.t, clock.phase, clock.course, clock.speed)
    got = clock.forecast(times, vx, vy, R, V)
    assert (clock.t, clock.phase, clock.course, clock.speed) == before  # left as is
    for values, expected in zip(got, _advanced(clock, times, vx, vy), strict=True):
        np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-9)


def test_a_long_forecast_of_a_fast_low_pass_keeps_its_precision() -> None:
    """Hours of steps through a speed low-pass of a second: its running product
    would underflow whole; solved in runs, it matches the clock advanced step by step."""
    clock = PatternClock(0.0, 8.0, 0.0, tau=20.0, speed_tau=1.0)
    times = [0.5 * (k + 1) for k in range(20_000)]
    vx = [8.0 * (1.0 + math.sin(k / 50.0)) for k in range(20_000)]
    vy = [2.0 * math.cos(k / 70.0) for k in range(20_000)]
    got = clock.forecast(times, vx, vy, R, V)
    for values, expected in zip(got, _advanced(clock, times, vx, vy), strict=True):
        np.testing.assert_allclose(values, expected, rtol=1e-9, atol=1e-9)
