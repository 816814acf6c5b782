"""SimClock: sim time = speedup x wall time - slips, on an injected wall clock."""

from __future__ import annotations

import pytest

from sitl_mock.clock import ManualTime, SimClock


def test_sim_time_runs_speedup_times_faster_than_the_wall() -> None:
    wall = ManualTime(1000.0)
    clock = SimClock(25.0, wall)
    assert clock.now() == 0.0
    wall.advance(2.0)
    assert clock.now() == pytest.approx(50.0)
    assert clock.wall_elapsed() == pytest.approx(2.0)
    assert clock.wall_until(75.0) == pytest.approx(1.0)
    assert clock.wall_until(10.0) < 0.0
    assert clock.real_time_factor() == pytest.approx(25.0)


def test_slip_sets_sim_time_back_and_lowers_the_achieved_factor() -> None:
    wall = ManualTime()
    clock = SimClock(10.0, wall)
    wall.advance(1.0)
    clock.slip(4.0)
    clock.slip(0.0)  # not a slip
    assert clock.now() == pytest.approx(6.0)
    assert clock.slips == 1
    assert clock.slipped == pytest.approx(4.0)
    assert clock.real_time_factor() == pytest.approx(6.0)


def test_a_new_speedup_runs_on_from_where_sim_time_is() -> None:
    """``SIM_SPEEDUP`` set in flight: no jump, the new rate from now; slips still count."""
    wall = ManualTime()
    clock = SimClock(40.0, wall)
    wall.advance(1.0)
    clock.slip(5.0)
    clock.set_speedup(10.0)
    assert clock.now() == pytest.approx(35.0)
    assert clock.speedup == 10.0
    wall.advance(2.0)
    assert clock.now() == pytest.approx(55.0)
    assert clock.wall_until(65.0) == pytest.approx(1.0)
    assert clock.real_time_factor() == pytest.approx(55.0 / 3.0)
    assert clock.slipped == 5.0


@pytest.mark.parametrize("speedup", [0.0, -1.0, float("nan"), float("inf")])
def test_speedup_must_be_positive_and_finite(speedup: float) -> None:
    with pytest.raises(ValueError, match="speedup"):
        SimClock(speedup, ManualTime())
    clock = SimClock(2.0, ManualTime())
    with pytest.raises(ValueError, match="speedup"):
        clock.set_speedup(speedup)
    assert clock.speedup == 2.0


def test_manual_time_refuses_to_go_backwards() -> None:
    wall = ManualTime()
    with pytest.raises(ValueError):
        wall.advance(-0.1)
