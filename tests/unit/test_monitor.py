"""The coverage monitor core: protect-phase accounting, tracking error, alarms."""

from __future__ import annotations

import math

import pytest

from convoy_mav.monitor import Alarm, Monitor, why_not_counted
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


# =================================================================== who counts
@pytest.mark.parametrize(
    ("status", "airborne", "altitude_error", "phase", "why"),
    [
        ("flying", True, 2.0, "protect", None),
        ("flying", True, -14.0, "protect", None),  # inside the band
        ("flying", False, 0.0, "protect", "on ground"),  # an ArduPlane armed on the runway
        ("flying", True, -60.0, "protect", "climbing"),
        ("flying", True, 40.0, "protect", "above its altitude band"),
        ("flying", True, 0.0, "join", "joining"),
        ("flying", True, 0.0, "pending", "not assigned"),
        ("flying", True, None, "protect", "no position"),
        ("lost", True, 0.0, "protect", "lost"),
        ("flying", True, 0.0, "lost", "lost"),
        # set up again after a failsafe, or holding: airborne on its slot, it still sees
        ("setting_up", True, 0.0, "protect", None),
        ("holding", True, 0.0, "protect", None),
        ("setting_up", False, 0.0, "protect", "on ground"),
        ("connecting", True, 0.0, "protect", "connecting"),
        ("failed", False, 0.0, "protect", "failed"),
    ],
)
def test_only_a_uav_that_can_see_counts(
    status: str, airborne: bool, altitude_error: float | None, phase: str, why: str | None
) -> None:
    got = why_not_counted(
        status=status, airborne=airborne, altitude_error=altitude_error, band=15.0, phase=phase
    )
    assert got == why


def test_median_tracking_error_is_kept_per_uav() -> None:
    mon = Monitor(100.0)
    mon.start_protect(0.0)
    for i, err in enumerate([1.0, 2.0, 3.0, 50.0, 4.0]):
        mon.track(tel(7, 0.1 * i, err, 0.0), 0.0, 0.0)
    (score,) = mon.snapshot(1.0).vehicles
    assert score.median_tracking_error_m == pytest.approx(3.0, abs=0.25)
    assert score.mean_tracking_error_m == pytest.approx(12.0)


def test_old_telemetry_says_nothing_of_now_and_fresh_is_carried_forward() -> None:
    """A host stall or a slow link leaves old positions: they do not count (the monitor
    never claims coverage it has no telemetry for); fresh ones move on to the tick."""
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)
    m.update(0.0, CONVOY, {1: tel(1, 0.0, 0.0, 0.0)})
    stale = tel(1, 0.5, 0.0, 0.0)  # over the convoy, but 2.5 s before the tick
    m.update(3.0, CONVOY, {1: stale})
    assert not m.snapshot(3.0).covered
    moving = Telemetry(1, 3.6, -16.0, 0.0, -100.0, 20.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    m.update(4.0, CONVOY, {1: moving})  # 16 m short at 3.6 s, at 20 m/s: 8 m short at 4.0 s
    snap = m.snapshot(4.0)
    assert snap.covered and snap.sample is not None
    assert snap.sample.nearest_m == pytest.approx(8.0)
