"""A mock rover told a speed (DO_CHANGE_SPEED) drives it until its mission's next one."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.autopilot import Personality
from sitl_mock.ground import Polyline
from tests.fakes import Gcs
from tests.unit.test_mock_driveclock import _mode
from tests.unit.test_mock_mission import rover

# 8 m/s, then 6 m/s from the third corner (point 2) on: a lap of 2.2 km.
LAP = ((0.0, 0.0), (500.0, 0.0), (500.0, 350.0), (250.0, 350.0), (250.0, 600.0), (0.0, 600.0))
_GROUND = mavlink.SPEED_TYPE_GROUNDSPEED


def _road(*, loop: bool = False, marks: bool = True, holds: bool = False) -> Polyline:
    speeds = ((0, 8.0), (2, 6.0)) if marks else ()
    stands = ((1, 20.0), (3, 10.0)) if holds else ()
    return Polyline(LAP, speed=8.0, accel=1.0, loop=loop, speeds=speeds, holds=stands)


def test_told_a_speed_the_road_is_the_same_place_and_gives_way_at_the_next_mark() -> None:
    road = _road()
    told, tau = road.with_speed_from(20.0, 5.0)  # (on the first leg, at 8 m/s)
    assert told.position(tau) == pytest.approx(road.position(20.0))
    assert math.hypot(*told.velocity(tau + 10.0)) == pytest.approx(5.0)
    # Until the third corner, the mission's DO_CHANGE_SPEED to 6 m/s.
    end = told.told_until(tau)
    assert told.position(end) == pytest.approx(LAP[2])
    assert told.arrivals[2] == end and len(told.arrivals) == len(road.arrivals)
    planned = told.as_planned()
    assert planned == road and planned.planned_speed(end + 60.0) == 6.0
    assert told.moment_on(planned, end) == pytest.approx(road.arrivals[2])
    # Told again, the last told speed is the one in force; told at the mark, the mark's.
    again, tau2 = told.with_speed_from(tau + 30.0, 7.0)
    assert again.told is not None and again.told[1] == 7.0
    assert again.position(tau2) == pytest.approx(told.position(tau + 30.0))
    at_mark, _ = road.with_speed_from(road.arrivals[2], 3.0)
    assert at_mark.told is not None and at_mark.told[1] == 6.0  # (its own as it leaves)


def test_a_loop_keeps_a_told_speed_every_lap_unless_its_mission_sets_one() -> None:
    plain = _road(loop=True, marks=False)
    told, tau = plain.with_speed_from(20.0, 5.0)
    corner = told.told_until(tau)  # (at its next corner: from there on, every lap)
    assert told.position(corner) == pytest.approx(LAP[1])
    after = told.after_told()
    assert after.speed == 5.0 and after.told is None
    assert told.moment_on(after, corner) == pytest.approx(after.arrivals[1])
    marked = _road(loop=True)
    late = marked.arrivals[4] + 5.0  # (past the last mark: on into the next lap's first)
    told, tau = marked.with_speed_from(late, 5.0)
    end = told.told_until(tau)
    assert end == pytest.approx(told.arrivals[-1])  # (the next lap's start: its first mark)
    assert told.position(end) == pytest.approx(LAP[0])


def _speed_command(gcs: Gcs, speed: float, kind: int = _GROUND) -> int:
    ack, _ = gcs.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, kind, speed, -1.0)
    return int(ack.result)


@pytest.mark.parametrize("personality", [Personality.ARDUPILOT, Personality.PX4])
def test_a_rover_told_a_speed_in_auto_drives_it_until_its_missions_next(
    personality: Personality,
) -> None:
    gcs = Gcs(rover(personality, _road()))
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(8.0)
    assert _speed_command(gcs, 5.0) == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(1.5, telemetry=False)
    # Braking as ArduRover's S-curve does: 3 m/s in dv / a + a / j = 4 s at 1 m/s^2, 1 m/s^3.
    assert gcs.truth().speed == pytest.approx(8.0 - 1.5 * 3.0 / 4.0, abs=0.05)
    gcs.run(10.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(5.0)
    _, (current,) = gcs.command(
        mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT
    )
    first = 2 + (personality is Personality.ARDUPILOT)  # (after home and the first speed)
    assert current.seq == first, current  # (still driving to the first corner)
    gcs.run(200.0, telemetry=False)  # (past the third corner: the mission's 6 m/s)
    assert gcs.truth().north == pytest.approx(500.0) or gcs.truth().east < 500.0
    assert gcs.truth().speed == pytest.approx(6.0)


def test_a_speed_is_refused_out_of_auto_or_of_the_wrong_kind_and_minus_one_changes_nothing() -> (
    None
):
    gcs = Gcs(rover(Personality.ARDUPILOT, _road()))
    gcs.run(20.0, telemetry=False)
    assert _speed_command(gcs, 5.0, mavlink.SPEED_TYPE_CLIMB_SPEED) == mavlink.MAV_RESULT_DENIED
    assert _speed_command(gcs, 0.0) == mavlink.MAV_RESULT_FAILED
    assert _speed_command(gcs, -1.0) == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(5.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(8.0)
    _mode(gcs, Personality.ARDUPILOT, "HOLD")
    assert _speed_command(gcs, 5.0) == mavlink.MAV_RESULT_FAILED


def test_ardurover_back_in_auto_drives_wp_speed_until_the_next_mark_px4_its_missions() -> None:
    """``AR_WPNav::init`` on entering AUTO: WP_SPEED, not the mission's last speed."""
    for personality, expected in ((Personality.ARDUPILOT, 8.0), (Personality.PX4, 6.0)):
        road = Polyline(LAP, speed=8.0, accel=1.0, loop=True, speeds=((2, 6.0), (4, 7.0)))
        gcs = Gcs(rover(personality, road))
        gcs.run(road.arrivals[2] + 20.0, telemetry=False)  # (on the 6 m/s stretch)
        assert gcs.truth().speed == pytest.approx(6.0)
        _mode(gcs, personality, "HOLD")
        gcs.run(10.0, telemetry=False)
        _mode(gcs, personality, "AUTO")
        gcs.run(12.0, telemetry=False)
        assert gcs.truth().speed == pytest.approx(expected), personality
        gcs.run(200.0, telemetry=False)  # (past point 4: the mission's 7 m/s for both)
        assert gcs.truth().speed == pytest.approx(7.0), personality


def test_ardurover_told_a_speed_on_a_loop_drives_wp_speed_again_back_in_auto() -> None:
    """A loop with no speeds keeps a told speed every lap, until AUTO again: WP_SPEED."""
    gcs = Gcs(rover(Personality.ARDUPILOT, _road(loop=True, marks=False)))
    gcs.run(20.0, telemetry=False)
    assert _speed_command(gcs, 5.0) == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(150.0, telemetry=False)  # (past its next corner: every lap's speed now)
    assert gcs.truth().speed == pytest.approx(5.0)
    _mode(gcs, Personality.ARDUPILOT, "HOLD")
    gcs.run(10.0, telemetry=False)
    _mode(gcs, Personality.ARDUPILOT, "AUTO")
    gcs.run(15.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(8.0)


@pytest.mark.parametrize("marks", [True, False])
def test_a_px4_rover_back_in_its_mission_forgets_a_told_speed_for_its_missions(
    marks: bool,
) -> None:
    """``MissionBase::on_activation``: ``reset_cruising_speed``, then the mission's last
    speed item replayed; ArduRover instead keeps driving WP_SPEED (above)."""
    road = _road(loop=True, marks=marks)
    gcs = Gcs(rover(Personality.PX4, road))
    gcs.run(20.0, telemetry=False)
    assert _speed_command(gcs, 5.0) == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(30.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(5.0)
    _mode(gcs, Personality.PX4, "HOLD")
    gcs.run(10.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(0.0)
    _mode(gcs, Personality.PX4, "AUTO")
    gcs.run(12.0, telemetry=False)  # (from a stand to 8 m/s at 1 m/s^2, and the S-curve)
    assert gcs.truth().speed == pytest.approx(8.0)


def test_told_slower_just_before_a_laps_end_it_brakes_on_into_the_next_lap() -> None:
    """The lap's last vertex is its first: told 1 m/s less than a metre before it, braking
    at 1 m/s² on from the speed it has, it starts the next lap at the speed it got to
    there, not at the 1 m/s it was told (once a jump of 1.4 m/s at the lap's start)."""
    road = _road(loop=True)
    end = road.arrivals[-1]  # (the lap's end: its first vertex again, the 8 m/s mark)
    tau = end - 0.3
    now = math.hypot(*road.velocity(tau))
    told, at = road.with_speed_from(tau, 1.0)
    ends = told.told_until(at)
    before, after = told.velocity(ends - 1e-6), told.velocity(ends + 1e-6)
    assert told.position(ends) == pytest.approx(LAP[0], abs=1e-6)
    assert math.hypot(*after) == pytest.approx(math.hypot(*before), abs=1e-3)
    gone = math.dist(road.position(tau), LAP[0])  # (braked over at 1 m/s²)
    assert math.hypot(*after) == pytest.approx(math.sqrt(now * now - 2.0 * gone), abs=1e-3)


@settings(max_examples=60, deadline=None)
@example([(9.0, 12.0), (83.0, 12.0), (50.0, 12.0), (90.0, 12.0), (5.0, 1.0)], True, True, False)
@given(
    st.lists(st.tuples(st.floats(3.0, 90.0), st.floats(1.0, 12.0)), min_size=1, max_size=6),
    st.booleans(),
    st.booleans(),
    st.booleans(),
)
def test_a_told_speed_never_jumps_nor_changes_faster_than_the_accel(
    commands: list[tuple[float, float]], loop: bool, marks: bool, holds: bool
) -> None:
    gcs = Gcs(rover(Personality.ARDUPILOT, _road(loop=loop, marks=marks, holds=holds)))
    gcs.run(5.0, telemetry=False)
    rows = [gcs.truth()]
    for wait, speed in commands:
        _speed_command(gcs, speed)
        for _ in range(round(wait / 0.5)):
            gcs.run(0.5, telemetry=False)
            rows.append(gcs.truth())
    for a, b in itertools.pairwise(rows):
        moved = math.hypot(b.north - a.north, b.east - a.east)
        # (no jump: within 0.5 s no faster than either end's speed and the accel's 0.25 m/s)
        assert moved <= 0.5 * (max(a.speed, b.speed) + 0.25) + 1e-6
        assert abs(b.speed - a.speed) <= 0.5 * 1.0 + 1e-6  # (at the accel or gentler)
