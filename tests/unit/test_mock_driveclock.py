"""The mock rover stands when told to (HOLD, MANUAL, disarmed) and drives on in AUTO."""

from __future__ import annotations

import itertools

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.autopilot import Personality
from sitl_mock.driveclock import DriveClock
from sitl_mock.ground import Polyline
from tests.fakes import Gcs
from tests.unit.test_mock_mission import rover


def test_the_drive_time_is_sim_time_while_driving() -> None:
    clock = DriveClock()
    assert clock.driving
    assert [clock.at(t) for t in (0.0, 5.0, 123.4)] == [0.0, 5.0, 123.4]
    assert clock.rate(50.0) == 1.0


def test_it_brakes_at_its_accel_stands_and_pulls_away_again() -> None:
    clock = DriveClock(accel=1.0)
    clock.drive(100.0, False, 8.0)  # 8 m/s: 8 s of braking, 4 s of drive time
    assert not clock.driving
    assert clock.rate(104.0) == pytest.approx(0.5)
    assert clock.at(108.0) == pytest.approx(104.0)  # 32 m at 8 m/s: v^2 / 2a
    assert clock.at(200.0) == pytest.approx(104.0) and clock.rate(200.0) == 0.0
    clock.drive(200.0, True, 8.0)
    assert clock.rate(204.0) == pytest.approx(0.5)
    assert clock.at(208.0) == pytest.approx(108.0)
    assert clock.at(218.0) == pytest.approx(118.0) and clock.rate(218.0) == 1.0
    clock.drive(210.0, True, 8.0)  # (already driving: nothing changes)
    assert clock.at(218.0) == pytest.approx(118.0)


def test_a_stand_from_standing_is_at_once_and_bad_accels_are_refused() -> None:
    clock = DriveClock()
    clock.drive(10.0, False, 0.0)  # (stood at a hold: no braking)
    assert clock.at(30.0) == 10.0
    with pytest.raises(ValueError, match="accel"):
        DriveClock(accel=0.0)


@settings(max_examples=60, deadline=None)
@example([(22.75, False, 15.0), (11.0, False, 0.0)])
@given(
    st.lists(
        st.tuples(st.floats(0.5, 30.0), st.booleans(), st.floats(0.0, 15.0)),
        min_size=1,
        max_size=8,
    )
)
def test_drive_time_never_runs_back_nor_faster_than_sim_time(
    changes: list[tuple[float, bool, float]],
) -> None:
    clock, t = DriveClock(accel=1.5), 0.0
    for gap, driving, speed in changes:
        times = [t + 0.1 * k for k in range(round(gap * 10) + 1)]
        taus = [clock.at(x) for x in times]
        # (within rounding: the ramp's end is a sum of its terms, once 4e-15 s under)
        assert all(-1e-9 <= b - a <= 0.1 + 1e-9 for a, b in itertools.pairwise(taus))
        assert all(0.0 <= clock.rate(x) <= 1.0 for x in times)
        t = times[-1]
        before = clock.at(t)
        clock.drive(t, driving, speed)
        assert clock.at(t) == pytest.approx(before)  # (no jump)
    ramped = clock.at(t + 200.0) - clock.at(t + 100.0)  # (every ramp is over by then)
    assert ramped == pytest.approx(100.0 if clock.driving else 0.0)


def _mode(gcs: Gcs, personality: Personality, name: str) -> None:
    custom = {
        Personality.ARDUPILOT: {"HOLD": 4, "AUTO": 10, "MANUAL": 0},
        Personality.PX4: {"HOLD": (4 << 16) | (3 << 24), "AUTO": (4 << 16) | (4 << 24)},
    }[personality][name]
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    (ack,) = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, custom))
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED


@pytest.mark.parametrize("personality", [Personality.ARDUPILOT, Personality.PX4])
def test_a_rover_told_to_hold_brakes_stands_and_drives_on_in_auto(
    personality: Personality,
) -> None:
    gcs = Gcs(rover(personality, Polyline(((0.0, 0.0), (2000.0, 0.0)), speed=8.0, accel=1.0)))
    gcs.run(50.0, telemetry=False)
    _mode(gcs, personality, "HOLD")
    assert gcs.vehicle.mode in ("HOLD", "AUTO.LOITER")
    braking_from = gcs.truth().north
    gcs.run(8.5, telemetry=False)
    stood = gcs.truth()
    assert stood.speed == 0.0
    assert stood.north - braking_from == pytest.approx(32.0, abs=0.5)  # 8^2 / (2 * 1)
    gcs.run(60.0, telemetry=False)
    assert gcs.truth().north == stood.north  # stands for as long as it is told
    _mode(gcs, personality, "AUTO")
    gcs.run(4.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(4.0, abs=0.1)  # pulling away at 1 m/s^2
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(8.0)


def test_a_rover_stands_in_manual_or_disarmed_and_its_mission_item_waits() -> None:
    road = Polyline(((0.0, 0.0), (400.0, 0.0), (400.0, 400.0)), speed=8.0, accel=1.0)
    gcs = Gcs(rover(Personality.ARDUPILOT, road))
    gcs.run(30.0, telemetry=False)
    _mode(gcs, Personality.ARDUPILOT, "MANUAL")  # (no sticks: it stands)
    gcs.run(200.0, telemetry=False)  # (long enough to have reached the corner)
    assert gcs.truth().speed == 0.0 and gcs.truth().north < 400.0
    current = gcs.run(1.0)
    seqs = {m.seq for m in current if m.get_type() == "MISSION_CURRENT"}
    # still driving to the corner, item 2 (item 1 is where it set off, home item 0)
    assert seqs == {2}, seqs
    _mode(gcs, Personality.ARDUPILOT, "AUTO")
    ack, _ = gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(30.0, telemetry=False)
    assert gcs.truth().speed == 0.0 and not gcs.vehicle.armed
    assert not gcs.heartbeat().base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    stood = gcs.truth()
    gcs.arm()
    gcs.run(30.0, telemetry=False)
    assert gcs.truth().north == 400.0 and gcs.truth().east > stood.east  # round the corner


@pytest.mark.parametrize("loop", [False, True])
def test_a_rover_held_during_its_waypoints_hold_stands_the_whole_hold_again(loop: bool) -> None:
    """ArduRover back in AUTO restarts the waypoint it stands at, and its hold with it."""
    road = Polyline(
        ((0.0, 0.0), (300.0, 0.0), (300.0, 300.0)), speed=8.0, accel=1.0, holds=((1, 30.0),),
        loop=loop,
    )  # fmt: skip
    lap = road.arrivals[-1] if loop else 0.0  # (on a loop: the second lap's hold)
    gcs = Gcs(rover(Personality.ARDUPILOT, road))
    gcs.run(lap + road.arrivals[1] + 10.0, telemetry=False)  # 10 s into the hold
    at = gcs.truth()
    _mode(gcs, Personality.ARDUPILOT, "HOLD")
    gcs.run(20.0, telemetry=False)
    _mode(gcs, Personality.ARDUPILOT, "AUTO")
    gcs.run(29.5, telemetry=False)
    assert (gcs.truth().north, gcs.truth().east, gcs.truth().speed) == (at.north, at.east, 0.0)
    gcs.run(2.0, telemetry=False)
    assert gcs.truth().speed > 0.0  # (30 s after AUTO: pulling away)
    assert road.hold_began(lap + road.arrivals[1] + 5.0) == pytest.approx(lap + road.arrivals[1])
    assert road.hold_began(20.0) == 20.0  # (driving: no hold)
