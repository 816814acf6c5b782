"""The coverage monitor core: protect-phase accounting, tracking error, alarms."""

from __future__ import annotations

import math

import pytest

from convoy_mav.monitor import Alarm, Monitor
from convoy_mav.types import ConvoyEstimate, Setpoint, Telemetry


def tel(sysid: int, t: float, north: float, east: float) -> Telemetry:
    return Telemetry(sysid, t, north, east, -100.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def sp(t: float, north: float, east: float) -> Setpoint:
    return Setpoint(t, north, east, -100.0, 0.0, 0.0, 0.0, 0.0, 0.0)


CONVOY = ConvoyEstimate(0.0, 0.0, 0.0, 0.0, 0.0)


def test_nothing_counted_before_protect() -> None:
    m = Monitor(sensor_radius=10.0)
    assert m.update(0.0, CONVOY, {1: tel(1, 0.0, 50.0, 0.0)}) == []
    snap = m.snapshot(0.0)
    assert snap.protect_start is None and not snap.covered
    assert snap.stats.elapsed_s == 0.0


def test_gap_alarms_and_scores() -> None:
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)
    planned = sp(0.0, 3.0, 4.0)

    def tick(t: float, north: float) -> list[Alarm]:
        update = tel(1, t, north, 0.0)
        m.track(update, planned.north, planned.east)
        return m.update(t, CONVOY, {1: update})

    assert tick(0.0, 0.0) == []
    alarms = tick(1.0, 20.0)
    assert [(a.kind, a.active) for a in alarms] == [("gap", True)]
    alarms = tick(2.0, 1.0)
    assert [(a.kind, a.active) for a in alarms] == [("gap", False)]
    snap = m.snapshot(2.0)
    assert snap.covered and snap.covering == (1,)
    assert snap.stats.fraction == pytest.approx(0.5)
    (score,) = snap.vehicles
    assert score.time_in_circle_fraction == pytest.approx(0.5)
    errors = [math.hypot(0 - 3, 0 - 4), math.hypot(20 - 3, 0 - 4), math.hypot(1 - 3, 0 - 4)]
    assert score.mean_tracking_error_m == pytest.approx(sum(errors) / 3)
    assert score.tracking_error_m == pytest.approx(errors[-1])


def test_prediction_missed_and_stale_convoy_alarms() -> None:
    m = Monitor(sensor_radius=10.0, predicted_coverage=1.0, prediction_grace=5.0)
    m.start_protect(0.0)
    kinds = []
    for k in range(20):
        t = float(k)
        convoy = ConvoyEstimate(t, 0.0, 0.0, 0.0, 0.0, stale=5 <= k < 8)
        far = k % 2 == 0
        kinds += [
            (a.kind, a.active)
            for a in m.update(t, convoy, {1: tel(1, t, 30.0 if far else 0.0, 0.0)})
        ]
    assert ("convoy_stale", True) in kinds and ("convoy_stale", False) in kinds
    assert kinds.count(("prediction_missed", True)) == 1  # edge-triggered, not every tick


def test_no_convoy_fix_yet() -> None:
    m = Monitor(sensor_radius=10.0)
    m.start_protect(0.0)
    assert m.update(0.0, None, {1: tel(1, 0.0, 0.0, 0.0)}) == []
    assert not m.snapshot(0.0).covered


def test_tracking_error_is_scored_per_update_from_protect_on() -> None:
    m = Monitor(sensor_radius=10.0)
    planned = (3.0, 4.0)
    assert m.track(tel(1, 0.0, 0.0, 0.0), *planned) is None  # joining: not scored
    m.start_protect(1.0)
    assert m.track(tel(1, 1.0, 0.0, 0.0), *planned) == pytest.approx(5.0)
    assert m.track(tel(1, 1.1, 3.0, 4.0), *planned) == pytest.approx(0.0)
    assert m.track(tel(1, 1.2, math.nan, 0.0), *planned) is None  # bad input: skipped
    # ticks in between do not count a position again
    m.update(1.5, CONVOY, {1: tel(1, 1.1, 3.0, 4.0)})
    m.update(1.6, CONVOY, {1: tel(1, 1.1, 3.0, 4.0)})
    (score,) = m.snapshot(1.6).vehicles
    assert score.mean_tracking_error_m == pytest.approx(2.5)
    assert score.tracking_error_m == pytest.approx(0.0)
