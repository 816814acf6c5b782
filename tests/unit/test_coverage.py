"""Pure coverage arithmetic."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convoy_mav.coverage import CoverageTracker, GapClosed, GapOpened
from convoy_mav.planning import PlanRequest, make_plan


def test_single_gap_bookkeeping() -> None:
    tr = CoverageTracker(sensor_radius=10.0, max_hold=5.0)
    convoy = (0.0, 0.0)
    s, ev = tr.update(0.0, convoy, {1: (5.0, 0.0)})
    assert s.covered and s.covering == (1,) and ev == []
    _, ev = tr.update(1.0, convoy, {1: (15.0, 0.0)})
    assert ev == [GapOpened(1.0)]
    _, ev = tr.update(2.0, convoy, {1: (20.0, 0.0)})
    assert ev == []
    assert tr.stats().current_gap_s == pytest.approx(1.0)
    _, ev = tr.update(3.5, convoy, {1: (0.0, 9.0), 2: (3.0, 3.0)})
    assert ev == [GapClosed(3.5, 2.5)]
    tr.update(4.0, convoy, {1: (0.0, 9.0), 2: (30.0, 0.0)})
    st = tr.stats()
    assert st.elapsed_s == 4.0
    assert st.covered_s == pytest.approx(1.0 + 0.5)
    assert st.fraction == pytest.approx(1.5 / 4.0)
    assert st.longest_gap_s == pytest.approx(2.5)
    assert st.gaps == 1
    assert st.time_inside_s == {1: pytest.approx(1.5), 2: pytest.approx(0.5)}
    assert st.time_inside_fraction(2) == pytest.approx(0.125)


def test_stale_updates_count_as_uncovered() -> None:
    tr = CoverageTracker(sensor_radius=10.0, max_hold=1.0)
    tr.update(0.0, (0.0, 0.0), {1: (0.0, 0.0)})
    _, ev = tr.update(5.0, (0.0, 0.0), {1: (0.0, 0.0)})
    # Held for 1 s, then 4 s without news: a gap from 1.0 to 5.0.
    assert ev == [GapOpened(1.0), GapClosed(5.0, 4.0)]
    st = tr.stats()
    assert st.covered_s == pytest.approx(1.0)
    assert st.stale_s == pytest.approx(4.0)


def test_nan_positions_and_bad_times_are_harmless() -> None:
    tr = CoverageTracker(sensor_radius=10.0)
    tr.update(0.0, (0.0, 0.0), {1: (math.nan, 0.0), 2: (1.0, 1.0)})
    s, ev = tr.update(math.nan, (0.0, 0.0), {})
    assert s.t == 0.0 and ev == []
    s, _ = tr.update(-1.0, (0.0, 0.0), {})
    assert s.t == 0.0  # out of order: ignored
    s, _ = tr.update(0.5, (0.0, 0.0), {1: (math.nan, math.nan)})
    assert not s.covered and s.nearest_m == math.inf


def test_open_gap_measured_to_now() -> None:
    tr = CoverageTracker(sensor_radius=1.0)
    tr.update(0.0, (0.0, 0.0), {})
    tr.update(0.5, (0.0, 0.0), {})
    assert tr.stats(now=3.0).current_gap_s == pytest.approx(3.0)
    assert tr.stats(now=3.0).longest_gap_s == pytest.approx(3.0)


def test_rejects_bad_radius() -> None:
    with pytest.raises(ValueError, match="sensor_radius"):
        CoverageTracker(sensor_radius=0.0)


@pytest.mark.parametrize("uavs", [None, 3])
def test_tracker_agrees_with_plan_prediction(uavs: int | None) -> None:
    """Fed the planned positions at 20 Hz, the tracker reproduces predicted_coverage."""
    plan = make_plan(
        PlanRequest(150.0, 100.0, 18.0, convoy_speed=6.0, convoy_heading=0.3, uavs=uavs)
    )
    tr = CoverageTracker(sensor_radius=100.0)
    ts = np.arange(0.0, 600.0, 0.05)
    samples = [v.trajectory.sample_array(ts) for v in plan.vehicles]
    for k, t in enumerate(ts):
        convoy = plan.convoy_position(float(t))
        tr.update(
            float(t), convoy, {i: (float(s.x[k]), float(s.y[k])) for i, s in enumerate(samples)}
        )
    st = tr.stats()
    assert st.fraction == pytest.approx(plan.predicted_coverage, abs=5e-3)
    if uavs is None:
        assert st.gaps == 0
        assert st.longest_gap_s == 0.0
    else:
        assert st.gaps > 0
