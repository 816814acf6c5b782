"""The re-plan lag the service learns and hands to the road mission."""

from __future__ import annotations

import math

import pytest

from convoy_mav.mission.lag import ReplanLag


def test_the_lag_is_fitted_as_a_tick_plus_a_cost_per_uav() -> None:
    lag = ReplanLag()
    for _ in range(60):  # the mock at 40x: a tick of 0.1 s, 0.4 s a UAV re-planned
        lag.observe(0.1, 0)
        lag.observe(0.1 + 0.4 * 3, 3)
        lag.observe(0.1 + 0.4, 1)
    assert lag.base == pytest.approx(0.1, rel=1e-3)
    assert lag.per_uav == pytest.approx(0.4, rel=1e-3)
    base, per_uav = lag.lead()
    assert base == pytest.approx(1.25 * 0.1, rel=1e-3)
    assert per_uav == pytest.approx(1.25 * 0.4, rel=1e-3)


def test_the_fit_is_settled_after_a_few_times_its_memory_of_re_planning_steps() -> None:
    lag = ReplanLag(alpha=0.2)
    for k in range(20):
        assert lag.settled == (k >= 15)
        lag.observe(0.1, 0)  # (steps that re-plan nobody do not count)
        lag.observe(0.5, 1)
    assert lag.planned == 20 and lag.settled
    lag.observe(math.nan, 1)  # (nor nonsense)
    assert lag.planned == 20


def test_a_host_at_real_time_has_next_to_no_lag() -> None:
    lag = ReplanLag()
    for _ in range(60):
        lag.observe(0.01, 0)
        lag.observe(0.012, 2)
    base, per_uav = lag.lead()
    assert base < 0.02 and per_uav < 0.005


def test_nonsense_is_ignored_and_the_lead_is_capped() -> None:
    lag = ReplanLag(cap=8.0)
    for bad in (math.nan, math.inf, -1.0):
        lag.observe(bad, 2)
    lag.observe(1.0, -1)
    assert (lag.base, lag.per_uav) == (0.0, 0.0)
    for _ in range(100):  # a host stalled for a minute at a time
        lag.observe(60.0, 0)
        lag.observe(120.0, 1)
    base, per_uav = lag.lead()
    assert base <= 8.0 and base + per_uav <= 8.0 + 1e-9
