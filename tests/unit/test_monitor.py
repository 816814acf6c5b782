"""The coverage monitor core: protect-phase accounting, tracking error, alarms."""

from __future__ import annotations

import math

import pytest

from convoy_mav.monitor import Alarm, Monitor, sees, why_not_counted
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


def _fly(
    m: Monitor, times: list[float], north: object, *, ticks: list[float] | None = None
) -> list[Alarm]:
    """UAV 1's fixes at ``times`` (north given by ``north(t)``), each tick seeing it."""
    alarms: list[Alarm] = []
    fixes = iter(times)
    pending = next(fixes, None)
    latest = None  # (the service passes each counted UAV's latest, however old)
    for t in ticks if ticks is not None else times:
        while pending is not None and pending <= t + 1e-9:
            latest = tel(1, pending, north(pending), 0.0)  # type: ignore[operator]
            m.fix(latest)
            pending = next(fixes, None)
        alarms += m.update(t, CONVOY, {1: latest} if latest is not None else {})
    return alarms


def _grid(a: float, b: float) -> list[float]:
    return [round(a + 0.1 * k, 6) for k in range(round((b - a) / 0.1) + 1)]


def test_gap_alarms_and_scores() -> None:
    """Inside for a second, out for a second, inside again: a gap of a second, decided
    at the fixes' own times; two thirds covered, as long in the circle."""
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)
    planned = sp(0.0, 3.0, 4.0)
    m.track(tel(1, 0.0, 0.0, 0.0), planned.north, planned.east)
    alarms = _fly(m, _grid(0.0, 3.05), lambda t: 20.0 if 1.0 <= t < 2.0 else 0.0)
    assert [(a.kind, a.active) for a in alarms] == [("gap", True), ("gap", False)]
    assert alarms[0].t == pytest.approx(1.0, abs=1e-6)
    assert alarms[1].t == pytest.approx(2.0, abs=1e-6)
    assert "after 1.0 s" in alarms[1].message
    snap = m.snapshot(3.0)
    assert snap.covered and snap.covering == (1,)
    assert snap.stats.fraction == pytest.approx(2.0 / 3.0, abs=0.04)
    (score,) = snap.vehicles
    assert score.time_in_circle_fraction == pytest.approx(2.0 / 3.0, abs=0.04)
    assert score.mean_tracking_error_m == pytest.approx(5.0)


def test_a_host_stall_is_scored_from_the_fixes_that_come_after_it() -> None:
    """No tick from 5 s to 7 s (the host held the loop up); the fixes of that while
    arrive together at 7 s: every instant is decided from them, all covered."""
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)
    ticks = [t for t in _grid(0.0, 10.0) if not 5.0 < t < 7.0]
    alarms = _fly(m, _grid(0.0, 10.0), lambda t: 3.0, ticks=ticks)
    assert alarms == []
    stats = m.snapshot(10.0).stats
    assert stats.fraction == pytest.approx(1.0) and stats.elapsed_s >= 9.5


def test_the_report_spans_the_protect_phase_to_its_end_and_no_further() -> None:
    """The mission ends at 7 s while the fixes of its last 2 s are still on their way
    (decided a few seconds behind, the monitor had counted 6 s); they come in as the
    UAVs are told to loiter, one of them leaving the convoy at 8.5 s. The report
    counts 0-7 s, all of it covered, and nothing after."""
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)

    def north(t: float) -> float:
        return 3.0 if t < 8.5 else 30.0

    _fly(m, _grid(0.0, 5.0), north, ticks=_grid(0.0, 7.0))
    m.end(7.0)
    counted = m.snapshot(7.0).stats.elapsed_s
    for t in _grid(5.1, 10.0):
        m.fix(tel(1, t, north(t), 0.0))
    m.finish()
    stats = m.snapshot(7.0).stats
    assert counted < 6.5
    assert stats.elapsed_s == pytest.approx(7.0) and stats.fraction == pytest.approx(1.0)
    m.finish()  # (twice: nothing more)
    assert m.snapshot(7.0).stats.elapsed_s == pytest.approx(7.0)


def test_a_uav_silent_longer_than_the_interpolation_gap_sees_nothing_meanwhile() -> None:
    """Fixes stop from 5 s to 11 s (longer than the 5 s interpolated over): carried
    along for a second, then unknown (nothing is claimed without telemetry); a short
    silence between two fixes inside is interpolated (it flew on between them)."""
    m = Monitor(sensor_radius=10.0, prediction_grace=1e9)
    m.start_protect(0.0)
    fixes = [t for t in _grid(0.0, 15.0) if not (5.0 < t < 11.0 or 12.0 < t < 15.0)]
    alarms = _fly(m, fixes, lambda t: 3.0, ticks=_grid(0.0, 15.0))
    assert [(a.kind, a.active) for a in alarms] == [("gap", True), ("gap", False)]
    assert alarms[0].t == pytest.approx(6.1, abs=1e-6)
    assert alarms[1].t == pytest.approx(11.0, abs=1e-6)
    assert m.snapshot(15.0).stats.fraction == pytest.approx(10.1 / 15.0, abs=0.02)


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


def test_a_uav_off_its_slot_sees_by_the_same_band_rule() -> None:
    """``sees`` is ``why_not_counted``'s airborne-and-in-band part, whatever the phase."""
    for airborne in (True, False):
        for error in (None, math.nan, -20.0, -14.0, 0.0, 15.0, 16.0):
            protecting = why_not_counted(
                status="flying", airborne=airborne, altitude_error=error, band=15.0,
                phase="protect",
            )  # fmt: skip
            assert sees(airborne=airborne, altitude_error=error, band=15.0) == (protecting is None)
