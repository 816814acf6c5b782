"""SimVehicle as a MAVLink endpoint: identity, arming, modes, streams, params, robustness.

Every exchange goes through bytes: a pymavlink ``MAVLink`` object plays the GCS
and packs each message, the vehicle gets what a separate parser decodes from
those bytes, and every reply is packed with the vehicle's own encoder and
parsed again -- the path the UDP server takes, minus the sockets (h11 style).
Flight behaviour (setpoints, failsafes, the product's three flows) is in
``test_mock_autopilot_flight.py``.
"""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.autopilot import Personality, SimVehicle, VehicleSpec
from sitl_mock.ground import StraightLine
from tests.fakes import (
    AP,
    GCS_COMPID,
    GCS_SYSID,
    PX4,
    WORLD,
    Gcs,
    Msg,
    make_vehicle,
    of_type,
    offboard_setpoint,
    px4_mode,
    texts,
    warm_gcs,
)


# ==================================================================== identity
@pytest.mark.parametrize(
    ("personality", "frame", "mav_type", "autopilot", "custom_mode", "base_mode"),
    [
        # PX4 boots in Hold: AUTO (4) / LOITER (3), flags CUSTOM|AUTO|GUIDED|STABILIZE.
        (PX4, "plane", 1, 12, px4_mode(4, 3), 1 | 4 | 8 | 16),
        (PX4, "copter", 2, 12, px4_mode(4, 3), 1 | 4 | 8 | 16),
        # ArduCopter boots in STABILIZE (0); ArduPlane in MANUAL (0).
        (AP, "copter", 2, 3, 0, 1 | 16 | 64),
        (AP, "plane", 1, 3, 0, 1 | 64),
    ],
)
def test_boot_heartbeat_identifies_firmware_and_frame(
    personality: Personality,
    frame: str,
    mav_type: int,
    autopilot: int,
    custom_mode: int,
    base_mode: int,
) -> None:
    gcs = Gcs(make_vehicle(personality, frame))
    hb = of_type(gcs.run(0.05), "HEARTBEAT")
    assert len(hb) == 1  # due at boot, then every second
    assert (hb[0].type, hb[0].autopilot) == (mav_type, autopilot)
    assert (hb[0].custom_mode, hb[0].base_mode) == (custom_mode, base_mode)
    assert hb[0].system_status == mavlink.MAV_STATE_STANDBY
    assert hb[0].get_srcSystem() == 1 and hb[0].get_srcComponent() == 1


@pytest.mark.parametrize(
    ("personality", "frame", "main", "sub", "custom_mode", "base_mode"),
    [
        (PX4, "plane", 6, 0, 6 << 16, 1 | 4 | 8 | 16 | 128),  # OFFBOARD
        (AP, "copter", 4, 0, 4, 1 | 8 | 16 | 64 | 128),  # ArduCopter GUIDED
        (AP, "plane", 15, 0, 15, 1 | 8 | 16 | 64 | 128),  # ArduPlane GUIDED
    ],
)
def test_heartbeat_reports_external_mode_and_armed_flag(
    personality: Personality, frame: str, main: int, sub: int, custom_mode: int, base_mode: int
) -> None:
    gcs = warm_gcs(make_vehicle(personality, frame))
    if personality is PX4:
        offboard_setpoint(gcs)
    assert gcs.set_mode(main, sub).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    hb = gcs.heartbeat()
    assert (hb.custom_mode, hb.base_mode) == (custom_mode, base_mode)
    assert hb.system_status == mavlink.MAV_STATE_ACTIVE or frame == "plane"


def test_px4_mode_numbers_round_trip_through_set_mode_message() -> None:
    gcs = warm_gcs(make_vehicle(PX4, "copter"))
    for name, main, sub in [("POSCTL", 3, 0), ("AUTO.RTL", 4, 5), ("AUTO.LOITER", 4, 3)]:
        replies = gcs.send(
            mavlink.MAVLink_set_mode_message(1, 1, px4_mode(main, sub))  # base_mode CUSTOM
        )
        ack = of_type(replies, "COMMAND_ACK")[0]
        assert ack.command == mavlink.MAV_CMD_DO_SET_MODE  # PX4 acks SET_MODE as DO_SET_MODE
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        assert gcs.vehicle.mode == name
        assert gcs.heartbeat().custom_mode == px4_mode(main, sub)


def test_ardupilot_acks_set_mode_message_with_its_message_id() -> None:
    gcs = warm_gcs(make_vehicle(AP, "copter"))
    ack = of_type(gcs.send(mavlink.MAVLink_set_mode_message(1, 1, 5)), "COMMAND_ACK")[0]
    assert (ack.command, ack.result) == (mavlink.MAVLINK_MSG_ID_SET_MODE, 0)
    assert gcs.vehicle.mode == "LOITER"


def test_unknown_mode_is_denied_with_a_reason() -> None:
    gcs = warm_gcs(make_vehicle(AP, "copter"))
    ack, extra = gcs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 99)
    assert ack.result == mavlink.MAV_RESULT_DENIED
    assert texts(extra)


# ===================================================================== arming
@pytest.mark.parametrize(
    ("personality", "result", "prefix"),
    [
        (PX4, mavlink.MAV_RESULT_TEMPORARILY_REJECTED, "Arming denied!"),
        (AP, mavlink.MAV_RESULT_FAILED, "Arm: Need Position Estimate"),
    ],
)
def test_arming_is_refused_during_warmup_then_accepted(
    personality: Personality, result: int, prefix: str
) -> None:
    vehicle = make_vehicle(personality, "copter", warmup_s=3.0)
    gcs = Gcs(vehicle)
    early = gcs.run(1.0)
    gps = of_type(early, "GPS_RAW_INT")
    status = of_type(early, "SYS_STATUS")
    if personality is PX4:  # ArduPilot sends nothing unasked (tested below)
        assert gps[-1].fix_type < mavlink.GPS_FIX_TYPE_3D_FIX
        assert not status[-1].onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_SENSOR_GPS
    ack, extra = gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == result
    assert texts(extra)[0].startswith(prefix)
    assert not vehicle.armed
    # The receiver's 3D fix comes first (half the warm-up); arming still waits for the
    # position estimate, as the real firmware refuses it well after its first fix.
    fixed = gcs.run(1.0)
    if personality is PX4:
        assert of_type(fixed, "GPS_RAW_INT")[-1].fix_type == mavlink.GPS_FIX_TYPE_3D_FIX
    ack, extra = gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == result and texts(extra)[0].startswith(prefix)
    late = gcs.run(1.1)
    if personality is PX4:
        assert of_type(late, "GPS_RAW_INT")[-1].fix_type == mavlink.GPS_FIX_TYPE_3D_FIX
        health = of_type(late, "SYS_STATUS")[-1].onboard_control_sensors_health
        assert health & mavlink.MAV_SYS_STATUS_SENSOR_GPS
        assert health & mavlink.MAV_SYS_STATUS_PREARM_CHECK
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    assert vehicle.armed and gcs.heartbeat().base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def test_force_arm_skips_checks_and_disarm_in_flight_needs_force() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    assert gcs.arm().result != mavlink.MAV_RESULT_ACCEPTED
    assert gcs.arm(force=True).result == mavlink.MAV_RESULT_ACCEPTED
    disarm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    assert gcs.command(disarm, 0)[0].result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(3.1, telemetry=False)
    gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, 498.0)
    gcs.run(5.0, telemetry=False)
    assert gcs.truth().down < -5.0
    ack, extra = gcs.command(disarm, 0)
    assert ack.result != mavlink.MAV_RESULT_ACCEPTED and texts(extra)
    assert gcs.command(disarm, 0, 21196)[0].result == mavlink.MAV_RESULT_ACCEPTED


def test_px4_offboard_needs_a_live_setpoint_stream() -> None:
    gcs = warm_gcs(make_vehicle(PX4, "plane"))
    ack, extra = gcs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 6)
    assert ack.result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    assert "Offboard" in texts(extra)[0]
    offboard_setpoint(gcs)
    gcs.run(1.5, telemetry=False)  # the stream went quiet: older than COM_OF_LOSS_T
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    offboard_setpoint(gcs)
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.vehicle.mode == "OFFBOARD"
    assert gcs.heartbeat().custom_mode == 6 << 16


def test_commands_needing_arming_are_denied_when_disarmed() -> None:
    gcs = warm_gcs(make_vehicle(AP, "copter"))
    gcs.set_mode(4)
    for command in (mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_DO_REPOSITION):
        ack, extra = gcs.command(command, 0, 1, 0, 0, 47.4, 8.5, 20.0)
        assert ack.result == mavlink.MAV_RESULT_DENIED
        assert texts(extra)
    assert not gcs.vehicle.flight.airborne


# ==================================================================== streams
def _count(msgs: list[Msg], name: str) -> int:
    return len(of_type(msgs, name))


def test_px4_streams_by_default_and_set_message_interval_changes_rates() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    gpi = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    first = gcs.run(10.0)
    assert _count(first, "GLOBAL_POSITION_INT") in (100, 101)  # 10 Hz
    assert _count(first, "HEARTBEAT") in (10, 11)  # 1 Hz
    for name in ("ATTITUDE", "LOCAL_POSITION_NED", "SYS_STATUS", "HOME_POSITION", "VFR_HUD"):
        assert _count(first, name) > 0, name
    assert gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 200_000)[0].result == 0
    assert _count(gcs.run(10.0), "GLOBAL_POSITION_INT") in (50, 51)  # 5 Hz
    _, extra = gcs.command(mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, gpi)
    assert of_type(extra, "MESSAGE_INTERVAL")[0].interval_us == 200_000
    gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, -1)
    assert _count(gcs.run(5.0), "GLOBAL_POSITION_INT") == 0
    _, extra = gcs.command(mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, gpi)
    assert of_type(extra, "MESSAGE_INTERVAL")[0].interval_us == -1
    gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 0)  # back to the default
    assert _count(gcs.run(5.0), "GLOBAL_POSITION_INT") in (50, 51)
    unknown = gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 100_000)[0]
    assert unknown.result == mavlink.MAV_RESULT_DENIED


def test_ardupilot_is_silent_but_heartbeat_until_streams_are_requested() -> None:
    gcs = Gcs(make_vehicle(AP, "copter"))  # (ArduCopter's SRn_* are 0)
    quiet = gcs.run(5.0)
    # (and its home, once set at the fix, told every link unasked: AP_AHRS::set_home)
    assert [m.get_type() for m in quiet].count("HOME_POSITION") == 1
    assert {m.get_type() for m in quiet} == {"HEARTBEAT", "HOME_POSITION"}
    assert len(quiet) in (6, 7)
    gcs.send(
        mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_POSITION, 4, 1)
    )
    got = gcs.run(5.0)
    assert _count(got, "GLOBAL_POSITION_INT") in (20, 21)  # 4 Hz
    assert _count(got, "LOCAL_POSITION_NED") in (20, 21)
    assert _count(got, "ATTITUDE") == 0
    att = mavlink.MAVLINK_MSG_ID_ATTITUDE
    assert gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, att, 100_000)[0].result == 0
    assert _count(gcs.run(2.0), "ATTITUDE") in (20, 21)
    gcs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_ALL, 0, 0))
    assert {m.get_type() for m in gcs.run(3.0)} == {"HEARTBEAT"}


@pytest.mark.parametrize("frame", ["plane", "rover"])
def test_arduplane_and_ardurover_stream_every_group_at_1_hz_until_asked(frame: str) -> None:
    """Their SRn_* defaults are 1 Hz (``GCS_MAVLink_Parameters.cpp``): heard, and timed,
    before anyone asks; the first request sets the rates as ever."""
    from tests.unit.test_mock_mission import rover

    gcs = Gcs(make_vehicle(AP, "plane") if frame == "plane" else rover(AP))
    got = gcs.run(5.0)
    assert _count(got, "GLOBAL_POSITION_INT") in (5, 6)
    assert _count(got, "SYS_STATUS") in (5, 6)
    assert _count(got, "EXTENDED_SYS_STATE") == 0  # (in no group)
    sysid = gcs.vehicle.sysid
    gcs.send(
        mavlink.MAVLink_request_data_stream_message(
            sysid, 1, mavlink.MAV_DATA_STREAM_POSITION, 4, 1
        )
    )
    assert _count(gcs.run(5.0), "GLOBAL_POSITION_INT") in (20, 21)


def test_px4_ignores_request_data_stream() -> None:
    gcs = Gcs(make_vehicle(PX4, "plane"))
    gcs.send(mavlink.MAVLink_request_data_stream_message(1, 1, 0, 0, 0))
    assert _count(gcs.run(1.0), "GLOBAL_POSITION_INT") == 11  # at boot, then every 0.1 s
    assert gcs.vehicle.counters["unsupported_message"] == 1


def test_streams_on_boot_can_be_forced() -> None:
    gcs = Gcs(make_vehicle(AP, "copter", streams_on_boot=True))
    assert _count(gcs.run(1.0), "GLOBAL_POSITION_INT") == 11


# ========================================================== one-off requests
@pytest.mark.parametrize("personality", [PX4, AP])
def test_request_message_autopilot_version_and_legacy_capabilities(
    personality: Personality,
) -> None:
    gcs = Gcs(make_vehicle(personality, "plane"))
    for ack, extra in (
        gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION),
        gcs.command(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1),
    ):
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        assert (ack.target_system, ack.target_component) == (GCS_SYSID, GCS_COMPID)
        (version,) = of_type(extra, "AUTOPILOT_VERSION")
        for cap in (
            mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2,
            mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
            mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT,
            mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT,
            mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
            mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT,
        ):
            assert version.capabilities & cap
        major = version.flight_sw_version >> 24
        assert major == (1 if personality is PX4 else 4)


def test_request_message_home_position_only_once_home_is_set() -> None:
    vehicle = make_vehicle(PX4, "copter", home_ned=(120.0, -40.0, -5.0))
    gcs = Gcs(vehicle)
    home_id = mavlink.MAVLINK_MSG_ID_HOME_POSITION
    assert gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, home_id)[0].result == (
        mavlink.MAV_RESULT_FAILED
    )
    gcs.run(3.1, telemetry=False)
    ack, extra = gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, home_id)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    (home,) = of_type(extra, "HOME_POSITION")
    expected = vehicle.spec.home
    assert home.latitude == round(expected.lat * 1e7)
    assert home.longitude == round(expected.lon * 1e7)
    assert home.altitude == round(expected.alt * 1000)
    assert abs(home.x) < 1e-6 and abs(home.y) < 1e-6 and abs(home.z) < 1e-6
    denied = gcs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 9999)[0]
    assert denied.result == mavlink.MAV_RESULT_DENIED


def test_unknown_command_is_unsupported_and_counted() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    ack, _ = gcs.command(mavlink.MAV_CMD_DO_SET_SERVO, 1, 1500)
    assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED
    assert gcs.vehicle.counters["unknown_command"] == 1


# ===================================================================== params
def _params(replies: list[Msg]) -> dict[str, Msg]:
    return {m.param_id: m for m in of_type(replies, "PARAM_VALUE")}


@pytest.mark.parametrize(
    ("personality", "frame", "name", "value"),
    [
        (PX4, "plane", "FW_AIRSPD_TRIM", 18.0),
        (PX4, "copter", "MPC_XY_VEL_MAX", 18.0),
        (AP, "copter", "WPNAV_SPEED", 1800.0),  # cm/s
        (AP, "plane", "AIRSPEED_CRUISE", 18.0),
        (PX4, "plane", "FW_AIRSPD_MAX", 27.0),  # the airframe's 1.5 of cruise
        (AP, "plane", "AIRSPEED_MIN", 10.8),  # ... and 0.6
    ],
)
def test_param_list_uses_the_firmware_names_and_units(
    personality: Personality, frame: str, name: str, value: float
) -> None:
    gcs = Gcs(make_vehicle(personality, frame))
    replies = gcs.send(mavlink.MAVLink_param_request_list_message(1, 1))
    values = of_type(replies, "PARAM_VALUE")
    assert sorted(m.param_index for m in values) == list(range(len(values)))
    assert {m.param_count for m in values} == {len(values)}
    assert _params(replies)[name].param_value == pytest.approx(value)
    assert {m.param_type for m in values} == {mavlink.MAV_PARAM_TYPE_REAL32}


def test_a_copters_speed_parameters_bound_what_each_firmware_bounds() -> None:
    """PX4's MPC_XY_VEL_MAX clamps every horizontal velocity (the copter's airspeed);
    ArduCopter's WPNAV_SPEED is only the speed of moves to a position: a velocity
    target is flown at its own speed, up to the airframe's."""
    setp = mavlink.MAVLink_param_set_message
    px4 = make_vehicle(PX4, "copter", airspeed=20.0)
    Gcs(px4).send(setp(1, 1, b"MPC_XY_VEL_MAX", 12.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert px4.aircraft is not None and px4.aircraft.params.airspeed == 12.0
    ap = make_vehicle(AP, "copter", airspeed=20.0)
    (reply,) = Gcs(ap).send(setp(1, 1, b"WPNAV_SPEED", 700.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert reply.param_value == pytest.approx(700.0)
    assert ap.aircraft is not None and ap.aircraft.params.airspeed == 20.0
    assert ap.flight.cruise == pytest.approx(7.0)
    read = Gcs(ap).send(mavlink.MAVLink_param_request_read_message(1, 1, b"WPNAV_SPEED", -1))
    assert _params(read)["WPNAV_SPEED"].param_value == pytest.approx(700.0)


def test_param_read_and_set_round_trip_and_apply_to_the_vehicle() -> None:
    vehicle = make_vehicle(PX4, "plane")
    gcs = Gcs(vehicle)
    read = gcs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"COM_OF_LOSS_T", -1))
    (loss,) = of_type(read, "PARAM_VALUE")
    assert loss.param_value == pytest.approx(1.0)
    by_index = gcs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"", loss.param_index))
    assert of_type(by_index, "PARAM_VALUE")[0].param_id == "COM_OF_LOSS_T"
    setp = mavlink.MAVLink_param_set_message
    (reply,) = gcs.send(setp(1, 1, b"COM_OF_LOSS_T", 2.5, mavlink.MAV_PARAM_TYPE_REAL32))
    assert (reply.param_id, reply.param_value) == ("COM_OF_LOSS_T", pytest.approx(2.5))
    assert vehicle.flight.setpoint_timeout == pytest.approx(2.5)
    (reply,) = gcs.send(setp(1, 1, b"FW_AIRSPD_TRIM", 22.0, 9))
    assert reply.param_value == pytest.approx(22.0)
    assert vehicle.aircraft is not None and vehicle.aircraft.params.airspeed == 22.0
    bad = gcs.send(setp(1, 1, b"FW_AIRSPD_TRIM", -3.0, 9))
    assert _params(bad)["FW_AIRSPD_TRIM"].param_value == pytest.approx(22.0)
    assert texts(bad)
    # the airspeed range (the airframe's bounds on what it is commanded) stays where it
    # was, 10.8-27 m/s, when the trim moves
    read = gcs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"FW_AIRSPD_MAX", -1))
    assert _params(read)["FW_AIRSPD_MAX"].param_value == pytest.approx(27.0)
    gcs.send(setp(1, 1, b"FW_AIRSPD_MAX", 24.0, 9))
    gcs.send(setp(1, 1, b"FW_AIRSPD_MIN", 20.0, 9))
    airframe = vehicle.aircraft.params
    assert airframe.min_airspeed_ratio * 22.0 == pytest.approx(20.0)
    assert airframe.max_airspeed_ratio * 22.0 == pytest.approx(24.0)
    bad = gcs.send(setp(1, 1, b"FW_AIRSPD_MIN", 23.0, 9))  # above the trim: refused
    assert _params(bad)["FW_AIRSPD_MIN"].param_value == pytest.approx(20.0) and texts(bad)
    (sysid,) = gcs.send(setp(1, 1, b"MAV_SYS_ID", 7.0, 9))  # read-only
    assert sysid.param_value == 1.0
    assert gcs.send(setp(1, 1, b"NO_SUCH_PARAM", 1.0, 9)) == []
    assert vehicle.counters["param_unknown"] == 1


class FakeSpeedup:
    """The mock's clock as a vehicle's ``SIM_SPEEDUP`` sees it."""

    def __init__(self) -> None:
        self.speedup = 40.0

    def set_speedup(self, speedup: float) -> None:
        if not speedup > 0.0:
            raise ValueError("speedup must be > 0")
        self.speedup = speedup


@pytest.mark.parametrize("personality", [PX4, AP])
def test_sim_speedup_reads_and_sets_the_mocks_clock(personality: Personality) -> None:
    """ArduPilot SITL's ``SIM_SPEEDUP``, on either personality: the whole mock's clock
    (its vehicles share it); a vehicle with none reads 1 and refuses a new one."""
    clock = FakeSpeedup()
    gcs = Gcs(make_vehicle(personality, "plane", speedup=clock))
    setp = mavlink.MAVLink_param_set_message
    assert _params(gcs.send(mavlink.MAVLink_param_request_list_message(1, 1)))[
        "SIM_SPEEDUP"
    ].param_value == pytest.approx(40.0)
    (reply,) = gcs.send(setp(1, 1, b"SIM_SPEEDUP", 10.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert (reply.param_id, reply.param_value, clock.speedup) == ("SIM_SPEEDUP", 10.0, 10.0)
    bad = gcs.send(setp(1, 1, b"SIM_SPEEDUP", 0.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert _params(bad)["SIM_SPEEDUP"].param_value == 10.0 and texts(bad)
    alone = Gcs(make_vehicle(personality, "plane"))
    refused = alone.send(setp(1, 1, b"SIM_SPEEDUP", 10.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert _params(refused)["SIM_SPEEDUP"].param_value == 1.0 and texts(refused)


# ================================================================ timesync/ping
def test_timesync_answers_requests_with_time_since_boot() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    gcs.run(2.5, telemetry=False)
    (reply,) = gcs.send(mavlink.MAVLink_timesync_message(0, 123_456_789))
    assert reply.ts1 == 123_456_789
    assert reply.tc1 == pytest.approx(2.5e9, abs=1e3)
    assert gcs.send(mavlink.MAVLink_timesync_message(5, 6)) == []  # a response: ignored


def test_ping_is_answered_to_the_requester_only() -> None:
    gcs = Gcs(make_vehicle(AP, "copter"))
    (reply,) = gcs.send(mavlink.MAVLink_ping_message(42_000, 7, 0, 0))
    assert (reply.time_usec, reply.seq) == (42_000, 7)
    assert (reply.target_system, reply.target_component) == (GCS_SYSID, GCS_COMPID)
    assert gcs.send(mavlink.MAVLink_ping_message(42_000, 8, 1, 1)) == []


# ================================================================= robustness
def test_messages_for_another_system_are_ignored_and_counted() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    replies = gcs.send(
        mavlink.MAVLink_command_long_message(99, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0,
                                             1, 21196, 0, 0, 0, 0, 0)
    )  # fmt: skip
    assert replies == []
    assert gcs.vehicle.counters["foreign_sysid"] == 1
    assert not gcs.vehicle.armed
    broadcast = gcs.command(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1, target=0)[0]
    assert broadcast.result == mavlink.MAV_RESULT_ACCEPTED


def test_an_ardupilot_that_hears_only_its_ground_station_ignores_other_systems() -> None:
    """MAV_OPTIONS bit 0 (``GCS_MAVLINK::accept_packet``): only MAV_GCS_SYSID is heard,
    and the vehicle's own system (a companion computer); PX4 has no such option."""
    setp = mavlink.MAVLink_param_set_message
    vehicle = make_vehicle(AP, "copter")
    default, ours, companion = (
        Gcs(vehicle),
        Gcs(vehicle, system=42),
        Gcs(vehicle, system=1, component=mavlink.MAV_COMP_ID_ONBOARD_COMPUTER),
    )
    (gcs_id,) = default.send(setp(1, 1, b"MAV_GCS_SYSID", 42.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert gcs_id.param_value == 42.0
    bad = default.send(setp(1, 1, b"MAV_OPTIONS", 0.5, mavlink.MAV_PARAM_TYPE_REAL32))
    assert _params(bad)["MAV_OPTIONS"].param_value == 0.0 and texts(bad)  # (a bitmask)
    (options,) = default.send(setp(1, 1, b"MAV_OPTIONS", 1.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert options.param_value == 1.0
    capabilities = mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
    asked = mavlink.MAVLink_command_long_message(1, 1, capabilities, 0, 1, 0, 0, 0, 0, 0, 0)
    assert default.send(asked) == [] and vehicle.counters["not_from_gcs"] == 1
    assert ours.command(capabilities, 1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    assert companion.command(capabilities, 1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    ours.send(setp(1, 1, b"MAV_OPTIONS", 0.0, mavlink.MAV_PARAM_TYPE_REAL32))
    assert default.command(capabilities, 1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    assert "MAV_GCS_SYSID" not in _params(
        Gcs(make_vehicle(PX4, "copter")).send(mavlink.MAVLink_param_request_list_message(1, 1))
    )


def test_unknown_message_types_are_counted() -> None:
    gcs = Gcs(make_vehicle(PX4, "copter"))
    assert gcs.send(mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0)) == []
    assert gcs.vehicle.counters["unknown_message"] == 1


def test_a_failing_handler_is_counted_and_the_vehicle_lives_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    vehicle = make_vehicle(PX4, "copter")
    gcs = Gcs(vehicle)

    def boom(msg: Msg, now: float) -> list[Msg]:
        raise RuntimeError("handler bug")

    monkeypatch.setitem(vehicle._handlers, "PING", boom)
    assert gcs.send(mavlink.MAVLink_ping_message(1, 1, 0, 0)) == []
    assert vehicle.counters["handler_error"] == 1
    assert isinstance(vehicle.last_error, RuntimeError)
    assert _count(gcs.run(0.5), "HEARTBEAT") == 1


# ===================================================================== reboot
def test_reboot_restarts_boot_time_disarms_and_warms_up_again() -> None:
    vehicle = make_vehicle(AP, "copter", streams_on_boot=None)
    gcs = warm_gcs(vehicle)
    att = mavlink.MAVLINK_MSG_ID_ATTITUDE
    gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, att, 100_000)
    gcs.set_mode(4)
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    before = of_type(gcs.run(7.0), "ATTITUDE")[-1].time_boot_ms
    assert before == pytest.approx(10_100, abs=10)
    vehicle.reboot(gcs.now)
    assert not vehicle.armed and vehicle.mode == "STABILIZE"
    after = gcs.run(2.0)
    # streams forgotten (its home set anew at the fix is told unasked, as at boot)
    assert {m.get_type() for m in after} == {"HEARTBEAT", "HOME_POSITION"}
    gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, att, 100_000)
    assert of_type(gcs.run(0.05), "ATTITUDE")[0].time_boot_ms == pytest.approx(2_010, abs=10)
    ack, extra = gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result != mavlink.MAV_RESULT_ACCEPTED and texts(extra)  # warming up again
    assert vehicle.counters["reboot"] == 1


def test_reboot_command_is_refused_when_armed() -> None:
    gcs = warm_gcs(make_vehicle(PX4, "copter"))
    reboot = mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
    gcs.arm()
    assert gcs.command(reboot, 1)[0].result == mavlink.MAV_RESULT_DENIED
    gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    assert gcs.command(reboot, 1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.vehicle.counters["reboot"] == 1


# ============================================================== ground vehicles
def test_ground_vehicle_follows_its_route_and_reports_it() -> None:
    route = StraightLine(north=100.0, east=-50.0, speed=5.0, heading=math.pi / 2)
    spec = VehicleSpec(sysid=11, kind="ground", home=WORLD.to_geo(100.0, -50.0), route=route)
    vehicle = SimVehicle(spec, WORLD, 0.0)
    gcs = Gcs(vehicle)
    msgs = gcs.run(10.0)
    (hb, *_) = of_type(msgs, "HEARTBEAT")
    assert hb.type == mavlink.MAV_TYPE_GROUND_ROVER
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    last = of_type(msgs, "GLOBAL_POSITION_INT")[-1]
    expected = WORLD.to_geo(*route.position(last.time_boot_ms / 1000.0))
    assert last.lat == pytest.approx(expected.lat * 1e7, abs=2)
    assert last.lon == pytest.approx(expected.lon * 1e7, abs=2)
    assert (last.vx, last.vy) == (0, 500)
    assert of_type(msgs, "LOCAL_POSITION_NED")[-1].y == pytest.approx(50.0, abs=0.2)
    row = gcs.truth()
    assert (row.north, row.east, row.speed) == pytest.approx((100.0, 0.0, 5.0))
    assert row.kind == "ground" and row.armed
    assert gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0)[0].result == mavlink.MAV_RESULT_UNSUPPORTED
    assert gcs.set_mode(4, 3).result == mavlink.MAV_RESULT_ACCEPTED  # a label only
    assert offboard_setpoint(gcs) == [] and vehicle.counters["setpoint_ignored"] == 1
    assert gcs.truth().east == pytest.approx(0.0)


def test_vehicle_spec_validates_fields() -> None:
    home = WORLD.origin
    with pytest.raises(ValueError, match="sysid"):
        VehicleSpec(sysid=0, kind="aircraft", home=home)
    with pytest.raises(ValueError, match="route"):
        VehicleSpec(sysid=1, kind="aircraft", home=home, route=StraightLine(0, 0, 1, 0))
    with pytest.raises(ValueError, match="setpoint_timeout_s"):
        VehicleSpec(sysid=1, kind="aircraft", home=home, setpoint_timeout_s=0.0)
