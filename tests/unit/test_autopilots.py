"""The autopilot strategies: recognition, modes, setpoints, loiters, phase correction.

Besides checking field values, the messages are fed through MAVLink bytes into
the mock's sans-I/O autopilot (``tests.fakes.Gcs``), which mirrors what PX4 and
ArduPilot do with them: the mock is the independent reader here.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace
from typing import Any, Literal

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import eas2tas, eas2tas_squared
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.autopilots import (
    PX4,
    ArduCopter,
    ArduPlane,
    Autopilot,
    PhaseLoop,
    SetupStep,
    VehicleClass,
    along_track_error,
    autopilot_for,
    phase_corrected_speed,
)
from convoy_mav.mavlink.autopilots.base import (
    FLIGHT_STREAM_RATES,
    SETPOINT_POS_VEL_YAW,
    SETPOINT_POSITION_ONLY,
    SpeedParams,
    global_setpoint,
    param_request_message,
)
from convoy_mav.types import Setpoint
from sitl_mock.kinematics import Loiter
from sitl_mock.messages import Frames, decode_global_setpoint
from sitl_mock.personality import Personality, firmware_for
from tests.fakes import AP, WORLD, Gcs, make_vehicle, of_type, warm_gcs
from tests.fakes import PX4 as MOCK_PX4

M = mavlink
FW, QUAD = M.MAV_TYPE_FIXED_WING, M.MAV_TYPE_QUADROTOR
FRAME: LocalFrame = WORLD


def strategy(autopilot: int, mav_type: int, sysid: int = 1) -> Autopilot:
    ap = autopilot_for(autopilot, mav_type, sysid, 1, FRAME)
    assert ap is not None
    return ap


def circle_setpoint(
    bearing: float, *, radius: float = 100.0, speed: float = 18.0, clockwise: bool = True
) -> Setpoint:
    """The setpoint on a circle around (0, 0) at ``bearing`` (rad from north, cw)."""
    n, e = radius * math.cos(bearing), radius * math.sin(bearing)
    sign = 1.0 if clockwise else -1.0
    vn, ve = -sign * speed * math.sin(bearing), sign * speed * math.cos(bearing)
    return Setpoint(
        0.0, n, e, -40.0, vn, ve, 0.0, math.atan2(ve, vn), sign * speed / radius,
        center=(0.0, 0.0), radius=radius, clockwise=clockwise,
    )  # fmt: skip


def send_and_ack(gcs: Gcs, msg: object) -> tuple[Any, list[Any]]:
    """Send through bytes to the mock vehicle; its COMMAND_ACK and other replies."""
    replies = gcs.send(msg)
    acks = [m for m in replies if m.get_type() == "COMMAND_ACK"]
    assert len(acks) == 1, replies
    return acks[0], [m for m in replies if m is not acks[0]]


def roundtrip(msg: Any) -> Any:
    """Pack with one MAVLink object, parse with another: what the autopilot receives."""
    tx = M.MAVLink(None, srcSystem=255, srcComponent=190)
    rx = M.MAVLink(None)
    parsed = rx.parse_buffer(bytes(msg.pack(tx)))
    assert parsed is not None and len(parsed) == 1
    return parsed[0]


# ======================================================================= recognition
@pytest.mark.parametrize(
    ("autopilot", "mav_type", "cls", "kind"),
    [
        (M.MAV_AUTOPILOT_PX4, FW, PX4, VehicleClass.PLANE),
        (M.MAV_AUTOPILOT_PX4, QUAD, PX4, VehicleClass.COPTER),
        (M.MAV_AUTOPILOT_PX4, M.MAV_TYPE_VTOL_TILTROTOR, PX4, VehicleClass.PLANE),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW, ArduPlane, VehicleClass.PLANE),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, M.MAV_TYPE_HEXAROTOR, ArduCopter, VehicleClass.COPTER),
    ],
)
def test_firmware_and_airframe_are_recognised(
    autopilot: int, mav_type: int, cls: type, kind: VehicleClass
) -> None:
    ap = strategy(autopilot, mav_type)
    assert type(ap) is cls
    assert ap.kind is kind


@pytest.mark.parametrize(
    ("autopilot", "mav_type"),
    [
        (M.MAV_AUTOPILOT_GENERIC, FW),
        (M.MAV_AUTOPILOT_INVALID, M.MAV_TYPE_GCS),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, M.MAV_TYPE_GROUND_ROVER),
        (M.MAV_AUTOPILOT_PX4, M.MAV_TYPE_GIMBAL),
    ],
)
def test_unsupported_vehicles_get_no_strategy(autopilot: int, mav_type: int) -> None:
    assert autopilot_for(autopilot, mav_type, 1, 1, FRAME) is None


def test_setup_steps_per_firmware() -> None:
    px4 = strategy(M.MAV_AUTOPILOT_PX4, QUAD)
    assert px4.setup_steps == (SetupStep.SETPOINTS, SetupStep.MODE, SetupStep.ARM, SetupStep.CLIMB)
    assert px4.streams_during_setup
    # a fixed-wing PX4 takes off in AUTO.TAKEOFF before OFFBOARD, never from the ground
    px4_plane = strategy(M.MAV_AUTOPILOT_PX4, FW)
    assert px4_plane.setup_steps == (
        SetupStep.ARM,
        SetupStep.TAKEOFF,
        SetupStep.SETPOINTS,
        SetupStep.MODE,
    )
    copter = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    assert copter.setup_steps == (SetupStep.MODE, SetupStep.ARM, SetupStep.TAKEOFF)
    # ArduPlane: TKOFF_ALT and TAKEOFF mode, arm, the climb, and only then GUIDED
    plane = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW)
    assert plane.setup_steps == (
        SetupStep.TAKEOFF_MODE,
        SetupStep.ARM,
        SetupStep.TAKEOFF,
        SetupStep.MODE,
    )
    assert plane.takeoff_mode == "TAKEOFF"
    assert plane.takeoff_params(87.26) == {"TKOFF_ALT": 87.3}
    assert plane.takeoff_command(80.0, 600.0) is None
    assert not copter.streams_during_setup and not plane.streams_during_setup


@pytest.mark.parametrize(
    ("autopilot", "mav_type", "action", "command"),
    [
        (M.MAV_AUTOPILOT_PX4, FW, "rtl", M.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        (M.MAV_AUTOPILOT_PX4, QUAD, "land", M.MAV_CMD_NAV_LAND),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD, "land", M.MAV_CMD_NAV_LAND),
        # ArduPlane lands only through a landing sequence: "land" returns home
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW, "land", M.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW, "loiter", None),
    ],
)
def test_end_of_mission_commands(autopilot: int, mav_type: int, action: str, command: int) -> None:
    spec = strategy(autopilot, mav_type).end_command(action)
    assert (None if spec is None else spec.command) == command


# ============================================================================ modes
@pytest.mark.parametrize(
    ("personality", "frame", "autopilot", "mav_type"),
    [
        (MOCK_PX4, "plane", M.MAV_AUTOPILOT_PX4, FW),
        (MOCK_PX4, "copter", M.MAV_AUTOPILOT_PX4, QUAD),
        (AP, "plane", M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW),
        (AP, "copter", M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD),
    ],
)
def test_mode_names_and_commands_match_the_firmware(
    personality: Personality, frame: Literal["plane", "copter"], autopilot: int, mav_type: int
) -> None:
    ap = strategy(autopilot, mav_type)
    firmware = firmware_for(personality, frame)
    for mode in firmware.modes:
        assert ap.mode_name(mode.custom_mode) == mode.name
    # the external and hold modes, commanded our way, are what the mock switches to
    gcs = warm_gcs(make_vehicle(personality, frame))
    for name in (ap.hold_mode, ap.external_mode):
        if name == "OFFBOARD":
            continue  # needs a live setpoint stream (see the Vehicle tests)
        ack, _ = send_and_ack(gcs, ap.mode_command(name).message(1, 1))
        assert ack.result == M.MAV_RESULT_ACCEPTED
        assert gcs.vehicle.mode == name


def test_mode_command_parameters() -> None:
    px4 = strategy(M.MAV_AUTOPILOT_PX4, FW)
    assert px4.mode_command("OFFBOARD").params[:3] == (1.0, 6.0, 0.0)
    assert px4.hold_command().params[:3] == (1.0, 4.0, 3.0)
    assert px4.mode_name(6 << 16) == "OFFBOARD"
    assert px4.mode_name(4 << 16) == "AUTO.MISSION"
    assert px4.mode_name(42 << 16) == "MODE(42,0)"
    copter = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    assert copter.mode_command("GUIDED").params[:2] == (1.0, 4.0)
    assert copter.hold_command().params[:2] == (1.0, 5.0)
    plane = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW)
    assert plane.mode_command("GUIDED").params[:2] == (1.0, 15.0)
    assert plane.hold_command().params[:2] == (1.0, 12.0)
    assert plane.mode_name(99) == "MODE(99)"
    with pytest.raises(KeyError):
        plane.mode_command("OFFBOARD")
    with pytest.raises(KeyError):
        px4.mode_command("GUIDED")


def test_takeoff_altitude_conventions() -> None:
    copter = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    cmd = copter.takeoff_command(30.0, 518.0)
    assert cmd is not None and cmd.command == M.MAV_CMD_NAV_TAKEOFF
    assert cmd.params[6] == 30.0  # ArduPilot: above home
    px4 = strategy(M.MAV_AUTOPILOT_PX4, QUAD)
    cmd = px4.takeoff_command(30.0, 518.0)
    assert cmd is not None and cmd.params[6] == 518.0  # PX4: AMSL
    assert strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW).takeoff_command(30.0, 518.0) is None


def test_commands_carry_retry_count_and_target() -> None:
    px4 = strategy(M.MAV_AUTOPILOT_PX4, FW, sysid=7)
    msg = roundtrip(px4.arm_command().message(7, 1, confirmation=3))
    assert msg.get_type() == "COMMAND_LONG"
    assert (msg.target_system, msg.confirmation, msg.param1) == (7, 3, 1.0)


# ======================================================================= telemetry
def test_stream_requests() -> None:
    rates = {M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0, M.MAVLINK_MSG_ID_SYS_STATUS: 0.5}
    px4 = strategy(M.MAV_AUTOPILOT_PX4, FW).stream_requests(rates)
    assert {m.get_type() for m in px4} == {"COMMAND_LONG"}
    asked = {(m.param1, m.param2) for m in px4}
    assert {(33.0, 100_000.0), (1.0, 2_000_000.0)} <= asked
    # ... and the high-rate streams of its profiles the service never reads, stopped
    stopped = {int(m.param1) for m in px4 if m.param2 == -1.0}
    assert {M.MAVLINK_MSG_ID_LOCAL_POSITION_NED, M.MAVLINK_MSG_ID_HIGHRES_IMU} <= stopped
    assert stopped.isdisjoint(rates)
    # ArduPilot: every group stopped (SRn_* stream them unasked), then message intervals
    ap = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    stop, *intervals = ap.stream_requests(rates)
    assert stop.get_type() == "REQUEST_DATA_STREAM"
    assert (stop.req_stream_id, stop.start_stop) == (M.MAV_DATA_STREAM_ALL, 0)
    assert [m.get_type() for m in intervals] == ["COMMAND_LONG"] * 3
    # ... its position target too, at 1 Hz (another controller's targets show in it)
    assert (float(M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT), 1_000_000.0) in {
        (m.param1, m.param2) for m in intervals
    }
    # ... unless the firmware refuses SET_MESSAGE_INTERVAL (before 4.0): then the groups
    ap.on_ack(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAV_RESULT_UNSUPPORTED, 1.0)
    ardu = ap.stream_requests(rates)
    groups = {(m.req_stream_id, m.req_message_rate) for m in ardu if m.get_type() != "COMMAND_LONG"}
    assert groups == {(M.MAV_DATA_STREAM_POSITION, 10), (M.MAV_DATA_STREAM_EXTENDED_STATUS, 1)}
    assert sum(m.get_type() == "COMMAND_LONG" for m in ardu) == 3


def test_streams_asked_again_are_those_alone_with_no_group_stopped() -> None:
    """A request lost on the link is made again for its message alone: a stop sent with
    it would silence every stream flowing, should it arrive without the rest."""
    rates = {M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0, M.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0}
    gps = [M.MAVLINK_MSG_ID_GPS_RAW_INT]
    for ap in (strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD), strategy(M.MAV_AUTOPILOT_PX4, FW)):
        again = ap.stream_requests(rates, gps)
        assert [(m.get_type(), m.param1, m.param2) for m in again] == [
            ("COMMAND_LONG", float(M.MAVLINK_MSG_ID_GPS_RAW_INT), 1_000_000.0)
        ]
        assert set(gps) | set(rates) <= set(ap.wanted_streams(rates))
    # a firmware without SET_MESSAGE_INTERVAL: the message's group, at its fastest member
    ap = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    ap.on_ack(M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAV_RESULT_UNSUPPORTED, 1.0)
    groups = [m for m in ap.stream_requests(rates, gps) if m.get_type() == "REQUEST_DATA_STREAM"]
    assert [(m.req_stream_id, m.req_message_rate, m.start_stop) for m in groups] == [
        (M.MAV_DATA_STREAM_EXTENDED_STATUS, 1, 1)
    ]


def test_px4_stops_the_streams_the_service_never_reads() -> None:
    gcs = Gcs(make_vehicle(MOCK_PX4, "plane"))
    before = Counter(m.get_type() for m in gcs.run(1.0))
    assert before["LOCAL_POSITION_NED"] >= 9 and before["VFR_HUD"] >= 3
    px4 = strategy(M.MAV_AUTOPILOT_PX4, FW)
    for msg in px4.stream_requests(FLIGHT_STREAM_RATES):
        gcs.send(msg)
    after = Counter(m.get_type() for m in gcs.run(1.0))
    assert after["LOCAL_POSITION_NED"] == after["VFR_HUD"] == 0
    assert 9 <= after["GLOBAL_POSITION_INT"] <= 11  # (what it reads, as asked)
    assert sum(after.values()) < 0.6 * sum(before.values())


def test_ardupilot_streams_start_on_request() -> None:
    gcs = Gcs(make_vehicle(AP, "copter"))
    assert not [m for m in gcs.run(1.0) if m.get_type() == "GLOBAL_POSITION_INT"]
    ap = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    for msg in ap.stream_requests({M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0}):
        gcs.send(msg)
    got = [m for m in gcs.run(1.0) if m.get_type() == "GLOBAL_POSITION_INT"]
    assert 9 <= len(got) <= 11


# ======================================================================== setpoints
def test_global_setpoint_is_read_back_where_it_was_meant() -> None:
    sp = circle_setpoint(0.3)
    msg = roundtrip(global_setpoint(sp, FRAME, 3, 1, 12.345))
    assert msg.coordinate_frame == M.MAV_FRAME_GLOBAL_INT
    assert msg.type_mask == SETPOINT_POS_VEL_YAW
    assert msg.time_boot_ms == 12345
    assert msg.alt == pytest.approx(FRAME.origin.alt + 40.0)
    target = decode_global_setpoint(msg, Frames(WORLD, WORLD), home_alt=400.0)
    assert target is not None
    assert (target.north, target.east, target.down) == pytest.approx(
        (sp.north, sp.east, sp.down), abs=0.02
    )
    assert (target.vn, target.ve) == pytest.approx((sp.vn, sp.ve), abs=1e-4)
    assert target.yaw == pytest.approx(sp.yaw, abs=1e-6)
    assert target.yaw_rate is None  # ignored: yaw is absolute, robust to lost packets


def test_hold_setpoint_is_position_only() -> None:
    sp = Setpoint(0.0, 50.0, -20.0, -60.0, 5.0, 5.0, 0.0, 1.0, 0.0, hold=True)
    msg = roundtrip(global_setpoint(sp, FRAME, 1, 1, 0.0))
    assert msg.type_mask == SETPOINT_POSITION_ONLY
    target = decode_global_setpoint(msg, Frames(WORLD, WORLD), home_alt=0.0)
    assert target is not None and target.vn is None and target.yaw is None


def test_along_track_error_on_arcs_and_straights() -> None:
    r = 100.0
    sp = circle_setpoint(math.radians(40.0), radius=r)
    behind = (r * math.cos(math.radians(30.0)), r * math.sin(math.radians(30.0)))
    assert along_track_error(sp, *behind) == pytest.approx(r * math.radians(10.0))
    ahead = (r * math.cos(math.radians(55.0)), r * math.sin(math.radians(55.0)))
    assert along_track_error(sp, *ahead) == pytest.approx(-r * math.radians(15.0))
    # half a lap away the sign is still meaningful (wrapped to +-pi R)
    opposite = circle_setpoint(math.radians(40.0 + 170.0), radius=r)
    assert along_track_error(opposite, *behind) == pytest.approx(r * math.radians(180.0), rel=1e-6)
    ccw = circle_setpoint(math.radians(40.0), radius=r, clockwise=False)
    assert along_track_error(ccw, *behind) == pytest.approx(-r * math.radians(10.0))
    # farther out than the circle: the phase is the bearing difference at radius R
    assert along_track_error(sp, 2 * behind[0], 2 * behind[1]) == pytest.approx(
        r * math.radians(10.0)
    )
    straight = Setpoint(0.0, 100.0, 0.0, -40.0, 10.0, 0.0, 0.0, 0.0, 0.0)
    assert along_track_error(straight, 70.0, 25.0) == pytest.approx(30.0)
    assert along_track_error(straight, 120.0, 0.0) == pytest.approx(-20.0)


def test_phase_corrected_speed_is_bounded_and_signed() -> None:
    v, r = 18.0, 100.0
    sp = circle_setpoint(1.0, radius=r, speed=v)
    on = (sp.north, sp.east)
    assert phase_corrected_speed(sp, *on) == pytest.approx(v)
    slightly = (r * math.cos(0.9), r * math.sin(0.9))  # 10 m behind
    assert phase_corrected_speed(sp, *slightly) == pytest.approx(v * (1 + 10.0 / (v * 20.0)))
    far_behind = (r * math.cos(-1.0), r * math.sin(-1.0))
    assert phase_corrected_speed(sp, *far_behind) == pytest.approx(1.15 * v)
    far_ahead = (r * math.cos(2.5), r * math.sin(2.5))
    assert phase_corrected_speed(sp, *far_ahead) == pytest.approx(0.85 * v)
    assert phase_corrected_speed(sp, *far_ahead, limit=0.05) == pytest.approx(0.95 * v)
    still = Setpoint(0.0, 0.0, 0.0, -40.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert phase_corrected_speed(still, 10.0, 10.0) == 0.0


def test_px4_plane_speeds_up_when_behind_copter_does_not() -> None:
    sp = circle_setpoint(1.0)
    behind = (100 * math.cos(0.2), 100 * math.sin(0.2))
    (plane_msg,) = strategy(M.MAV_AUTOPILOT_PX4, FW).setpoint_messages(sp, 1.0, behind)
    assert math.hypot(plane_msg.vx, plane_msg.vy) == pytest.approx(1.15 * 18.0)
    (copter_msg,) = strategy(M.MAV_AUTOPILOT_PX4, QUAD).setpoint_messages(sp, 1.0, behind)
    assert math.hypot(copter_msg.vx, copter_msg.vy) == pytest.approx(18.0)
    (unknown,) = strategy(M.MAV_AUTOPILOT_PX4, FW).setpoint_messages(sp, 1.0, None)
    assert math.hypot(unknown.vx, unknown.vy) == pytest.approx(18.0)


def test_a_px4_copter_learns_its_speed_limit_and_says_when_the_plan_asks_more() -> None:
    """The limit is asked for by name and read from the autopilot's answer (the mock's
    autopilot, through MAVLink bytes); legs faster than it are said, slower are not."""
    name, unit = "MPC_XY_VEL_MAX", 1.0
    ap = strategy(M.MAV_AUTOPILOT_PX4, QUAD)
    assert ap.speed_params == SpeedParams(name, None, unit)
    gcs = warm_gcs(make_vehicle(MOCK_PX4, "copter", airspeed=18.0))
    (answer,) = of_type(gcs.send(param_request_message(1, ap.compid, name)), "PARAM_VALUE")
    ap.asked(circle_setpoint(0.3, speed=18.4))
    road = (0.85, 1.15)  # the road planner's band, at 18 m/s
    assert ap.cannot_fly(18.0, road) is None  # (no limit known yet: nothing to say)
    ap.on_param("RTL_ALT", 50.0)
    ap.on_param(answer.param_id, answer.param_value)
    assert ap.speed_limit == pytest.approx(18.0)
    assert ap.learnt() == {"speed_limit_mps": 18.0}
    assert ap.cannot_fly(18.0) == (  # the paper's plan at 18 m/s, and 15 % to catch up
        f"flies no faster than 18.0 m/s ({name}), the plan asks for up to 20.7 m/s (18.0 "
        f"and 15 % to catch up): set {name} to at least {math.ceil(20.7 / unit - 1e-9)} or "
        "scale airspeed_mps by 0.87"
    )
    assert ap.cannot_fly(18.0, road) == (  # the road's top speed before any is sent
        f"flies no faster than 18.0 m/s ({name}), the plan asks for up to 20.7 m/s: set "
        f"{name} to at least {math.ceil(20.7 / unit - 1e-9)} or scale airspeed_mps by 0.87"
    )
    ap.asked(circle_setpoint(0.3, speed=22.0))  # (a setpoint faster still says so)
    assert "asks for up to 22.0 m/s" in (ap.cannot_fly(18.0, road) or "")
    ap.on_param(name, 2200 if unit < 1.0 else 22.0)  # raised to the plan's top speed
    assert ap.cannot_fly(18.0, road) is None
    assert ap.speed_range() == f"up to 22.0 m/s ({name})"


def test_an_arducopter_has_no_speed_limit_on_guided_targets_to_read() -> None:
    """GUIDED flies a position + velocity target's velocity whatever WPNAV_SPEED is
    (it caps only the correction): nothing is asked for, no plan speed is refused."""
    ap = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, QUAD)
    assert ap.speed_params is None and ap.unread_speed_params() == []
    ap.on_param("WPNAV_SPEED", 700.0)
    ap.asked(circle_setpoint(0.3, speed=25.0))
    assert ap.cannot_fly(18.0, (0.85, 1.15)) is None
    assert ap.speed_limit is None and "speed_limit_mps" not in ap.learnt()


@pytest.mark.parametrize(
    ("autopilot", "personality", "low", "high"),
    [
        (M.MAV_AUTOPILOT_PX4, MOCK_PX4, "FW_AIRSPD_MIN", "FW_AIRSPD_MAX"),
        (M.MAV_AUTOPILOT_ARDUPILOTMEGA, AP, "AIRSPEED_MIN", "AIRSPEED_MAX"),
    ],
)
def test_a_plane_learns_its_airspeed_range_and_says_when_the_plan_leaves_it(
    autopilot: int, personality: Personality, low: str, high: str
) -> None:
    """A plane's range is read from the mock's autopilot (its airframe's 0.6-1.5 of
    cruise); its phase loop flies +-15 % round any plan, so that is checked too."""
    ap = strategy(autopilot, FW)
    assert ap.speed_params is not None
    assert (ap.speed_params.high, ap.speed_params.low) == (high, low)
    gcs = warm_gcs(make_vehicle(personality, "plane", airspeed=18.0))
    for name in (low, high):
        (answer,) = of_type(gcs.send(param_request_message(1, ap.compid, name)), "PARAM_VALUE")
        ap.on_param(answer.param_id, answer.param_value)
    assert (ap.speed_floor, ap.speed_limit) == pytest.approx((10.8, 27.0))
    assert ap.learnt().items() >= {"speed_limit_mps": 27.0, "speed_floor_mps": 10.8}.items()
    assert ap.cannot_fly(18.0, (0.85, 1.15)) is None
    ap.on_param(high, 20.0)  # the top of the phase loop, 20.7 m/s, is out of reach
    assert ap.cannot_fly(18.0) == (
        f"flies no faster than 20.0 m/s ({high}), the plan asks for up to 20.7 m/s (18.0 "
        f"and 15 % to catch up): set {high} to at least 21 or scale airspeed_mps by 0.97"
    )
    ap.on_param(high, 21.0)
    ap.on_param(low, 16.0)
    assert ap.cannot_fly(18.0) == (
        f"flies no slower than 16.0 m/s ({low}), the plan asks for down to 15.3 m/s: "
        f"set {low} to at most 15 or scale airspeed_mps by 1.05"
    )
    ap.on_param(low, 15.0)
    assert ap.cannot_fly(18.0) is None
    assert ap.speed_range() == f"15.0-21.0 m/s ({low}, {high})"
    assert ap.unread_speed_params() == []  # (read: no more asking)


def test_an_arduplane_before_4_5_is_asked_for_its_older_names_and_told_in_them() -> None:
    """ArduPlane named its airspeed range ARSPD_FBW_MIN/MAX until 4.5: both names are
    asked for until either answers, and the alarm names the one the autopilot knows."""
    ap = plane()
    assert ap.unread_speed_params() == [
        "AIRSPEED_MAX", "ARSPD_FBW_MAX", "AIRSPEED_MIN", "ARSPD_FBW_MIN"
    ]  # fmt: skip
    assert ap.speed_range() == "no speed range reported"
    ap.on_param("ARSPD_FBW_MAX", 20.0)
    assert ap.unread_speed_params() == ["AIRSPEED_MIN", "ARSPD_FBW_MIN"]
    assert ap.speed_range() == "up to 20.0 m/s (ARSPD_FBW_MAX)"
    assert ap.speed_limit == 20.0
    assert ap.cannot_fly(18.0) == (
        "flies no faster than 20.0 m/s (ARSPD_FBW_MAX), the plan asks for up to 20.7 m/s "
        "(18.0 and 15 % to catch up): set ARSPD_FBW_MAX to at least 21 or scale "
        "airspeed_mps by 0.97"
    )
    ap.on_param("AIRSPEED_MIN", 9.0)
    assert ap.unread_speed_params() == [] and ap.speed_floor == 9.0


# ========================================================================= ArduPlane
def plane() -> ArduPlane:
    ap = strategy(M.MAV_AUTOPILOT_ARDUPILOTMEGA, FW)
    assert isinstance(ap, ArduPlane)
    return ap


def test_arduplane_reposition_only_when_the_arc_changes() -> None:
    ap = plane()
    sp = circle_setpoint(0.5, radius=120.0, clockwise=False)
    (msg,) = ap.setpoint_messages(sp, 10.0, None)
    msg = roundtrip(msg)
    assert msg.get_type() == "COMMAND_INT"
    assert msg.command == M.MAV_CMD_DO_REPOSITION
    assert msg.frame == M.MAV_FRAME_GLOBAL_INT
    centre = FRAME.to_geo(0.0, 0.0, -40.0)
    # (L1 flies it EAS2TAS^2 wider: commanded that much tighter, in whole metres)
    assert msg.param3 == round(120.0 / eas2tas_squared(centre.alt))
    assert msg.param4 == 1.0
    assert (msg.x, msg.y) == (round(centre.lat * 1e7), round(centre.lon * 1e7))
    assert msg.z == pytest.approx(centre.alt)
    # the same arc, further along: sent once more `copy_after` on (a copy, should the
    # first be lost), then nothing new while waiting for the ACK
    on = circle_setpoint(0.6, radius=120.0, clockwise=False)
    assert ap.setpoint_messages(on, 10.05, None) == []
    assert len(ap.setpoint_messages(on, 10.15, None)) == 1
    assert ap.setpoint_messages(on, 10.5, None) == []
    # unacknowledged for `retry`: sent again; acknowledged: quiet
    assert len(ap.setpoint_messages(sp, 11.15, None)) == 1
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 11.2)
    assert ap.setpoint_messages(sp, 20.0, None) == []
    # a new arc (another centre, radius or direction): sent at once
    moved = replace(sp, center=(30.0, 0.0))
    assert len(ap.setpoint_messages(moved, 20.1, None)) == 1
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_FAILED, 20.15)  # (answered: no copy)
    assert ap.setpoint_messages(moved, 20.5, None) == []
    assert len(ap.setpoint_messages(moved, 21.2, None)) == 1  # refused: retried
    flipped = replace(moved, clockwise=True)
    assert len(ap.setpoint_messages(flipped, 21.3, None)) == 1


def test_a_new_loiter_is_sent_twice_unless_acknowledged_at_once() -> None:
    """On a link whose answers take longer than ``copy_after``, each new loiter goes
    twice (a lost switch between arcs swung planes 20-60 m off the next arc); on a
    quick link its ACK comes first and it goes once."""
    sp = circle_setpoint(0.5, radius=120.0)
    for rtt, sends in ((0.03, 1), (0.4, 2)):
        ap = plane()
        out = [len(ap.setpoint_messages(sp, 10.0, None))]
        for k in range(1, 10):  # a setpoint every 0.05 s
            t = 10.0 + 0.05 * k
            if t >= 10.0 + rtt and not ap.loiter_acked:
                ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, t)
            out.append(len(ap.setpoint_messages(sp, t, None)))
        assert sum(out) == sends == ap.counters["reposition"]


def test_an_arduplane_reporting_another_target_after_the_ack_is_sent_its_loiter_again() -> None:
    """An older loiter of ours, retried and jittered, overtook the newest on the link:
    the ACK came, but the plane flies the old one, which its reported target shows."""
    ap = plane()
    sp = circle_setpoint(0.5, radius=120.0)
    (sent,) = ap.setpoint_messages(sp, 10.0, None)
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 10.3)
    older = (sent.x + 20_000, sent.y)  # (about 2 km north)
    ap.on_target(*older, 10.2)  # (reported before the ACK: the loiter before, rightly)
    ap.on_target(sent.x, sent.y + 3, 11.0)  # (ours: within a metre)
    assert ap.setpoint_messages(sp, 11.05, None) == []
    ap.on_target(*older, 11.2)
    (again,) = ap.setpoint_messages(sp, 11.25, None)
    assert (again.command, again.x, again.y) == (M.MAV_CMD_DO_REPOSITION, sent.x, sent.y)
    assert ap.counters["target_not_ours"] == 1


def _eas(speed: float, down: float = -40.0) -> float:
    """The equivalent airspeed ArduPlane is told to fly a true ``speed`` at ``down``."""
    return speed / eas2tas(FRAME.origin.alt - down)


def test_arduplane_speed_changes_are_rate_limited() -> None:
    ap = plane()
    sp = circle_setpoint(1.0)
    ap.setpoint_messages(sp, 0.0, (sp.north, sp.east))  # reposition + first speed
    assert ap.speed == pytest.approx(_eas(18.0))
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 0.05)
    behind = (100 * math.cos(0.5), 100 * math.sin(0.5))
    assert ap.setpoint_messages(sp, 0.5, behind) == []  # too soon
    (msg,) = ap.setpoint_messages(sp, 1.0, behind)
    assert msg.command == M.MAV_CMD_DO_CHANGE_SPEED
    assert (msg.param1, msg.param3) == (0.0, -1.0)
    # the proportional speed, plus the integral the phase loop learnt over that second
    assert ap.phase.bias > 0.0
    flown = phase_corrected_speed(sp, *behind, bias=ap.phase.bias)
    assert msg.param2 == pytest.approx(_eas(flown))
    ap.on_ack(M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_RESULT_ACCEPTED, 1.1)
    assert ap.setpoint_messages(sp, 2.5, behind) == []  # no change worth sending
    ap.on_ack(M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_RESULT_FAILED, 2.6)
    assert len(ap.setpoint_messages(sp, 3.6, behind)) == 1  # refused: sent again


def test_an_arduplane_speed_change_lost_on_the_link_is_sent_again() -> None:
    """Unacknowledged for ``retry``, a DO_CHANGE_SPEED goes again though the phase loop
    asks the same: in the ArduPlane soak (30 % loss each way) a lost one left planes at
    the speed before, 28-36 m off their plans on average against PX4's 9-10 m."""
    ap = plane()
    sp = circle_setpoint(1.0)
    on_slot = (sp.north, sp.east)
    first = ap.setpoint_messages(sp, 0.0, on_slot)
    (sent,) = [m.param2 for m in first if m.command == M.MAV_CMD_DO_CHANGE_SPEED]
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 0.05)
    assert ap.setpoint_messages(sp, 0.6, on_slot) == []  # (too soon to tell)
    (again,) = ap.setpoint_messages(sp, 1.0, on_slot)  # no answer within retry: again
    assert again.command == M.MAV_CMD_DO_CHANGE_SPEED and again.param2 == pytest.approx(sent)
    ap.on_ack(M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_RESULT_ACCEPTED, 1.2)
    assert ap.setpoint_messages(sp, 5.0, on_slot) == []  # acknowledged: quiet


def test_arduplane_speed_changes_stay_inside_its_airspeed_range() -> None:
    """ArduPlane refuses a DO_CHANGE_SPEED outside AIRSPEED_MIN..MAX (and keeps the
    speed in force): once the range is read, the phase loop's speed is sent inside it."""
    ap = plane()
    sp = circle_setpoint(1.0)
    ap.on_param("AIRSPEED_MAX", 19.0)
    ap.on_param("AIRSPEED_MIN", 17.5)
    behind = (100 * math.cos(0.5), 100 * math.sin(0.5))  # the loop asks 1.15 x 18
    msgs = ap.setpoint_messages(sp, 0.0, behind)
    assert [m.param2 for m in msgs if m.command == M.MAV_CMD_DO_CHANGE_SPEED] == [19.0]
    ahead = (100 * math.cos(1.5), 100 * math.sin(1.5))
    msgs = ap.setpoint_messages(sp, 2.0, ahead)  # ... and 0.85 x 18
    assert [m.param2 for m in msgs if m.command == M.MAV_CMD_DO_CHANGE_SPEED] == [17.5]


def test_arduplane_is_told_the_equivalent_airspeed_of_the_plans_speed() -> None:
    """ArduPlane's airspeeds are equivalent airspeeds (TECS flies ``EAS * EAS2TAS``):
    18 m/s planned at 568 m AMSL is told 17.5, and at 2 km 16.3. Its range is in
    the same terms, so the plan's top speed is checked against AIRSPEED_MAX as told."""
    ap = plane()
    for down, told in ((-80.0, 17.51), (-1512.0, 16.32)):
        sp = replace(circle_setpoint(0.3), down=down)
        msgs = ap.setpoint_messages(sp, 0.0, (sp.north, sp.east))
        (speed,) = [m.param2 for m in msgs if m.command == M.MAV_CMD_DO_CHANGE_SPEED]
        assert speed == pytest.approx(told, abs=0.01)
        assert speed == pytest.approx(_eas(18.0, down))
        ap.reset()
    # At 2 km the phase loop's top, 1.15 x 18 = 20.7 m/s, is 18.8 m/s EAS: inside 19.
    ap.on_param("AIRSPEED_MAX", 19.0)
    assert ap.cannot_fly(18.0) is None
    ap.on_param("AIRSPEED_MAX", 18.0)
    assert ap.cannot_fly(18.0) == (
        "flies no faster than 18.0 m/s (AIRSPEED_MAX), the plan asks for up to 20.7 m/s "
        "(18.0 and 15 % to catch up) (18.8 m/s equivalent airspeed): set AIRSPEED_MAX to "
        "at least 19 or scale airspeed_mps by 0.96"
    )


def test_arduplane_straight_is_a_moving_carrot() -> None:
    ap = plane()
    sp = Setpoint(0.0, 0.0, 0.0, -40.0, 0.0, 18.0, 0.0, math.pi / 2, 0.0)  # due east
    ap.setpoint_messages(sp, 0.0, None)
    assert ap.loiter is not None
    assert ap.loiter[:2] == pytest.approx((0.0, ap.carrot))
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 0.1)
    near = replace(sp, east=0.05 * ap.carrot)
    assert ap.setpoint_messages(near, 1.0, None) == []
    far = replace(sp, east=0.2 * ap.carrot)
    assert len(ap.setpoint_messages(far, 2.0, None)) == 1


def test_arduplane_carrots_and_holds_carry_a_radius_once_an_arc_had_one() -> None:
    """ArduPlane keeps the last radius a reposition gave (param3 > 0) until GUIDED is
    entered again: a carrot sent with 0 after a 2 km arc was a 2 km loiter around it
    (SITL flew away from the carrot, 1 km off its slot). 0 only before any arc."""
    ap = plane()
    east = Setpoint(0.0, 0.0, 0.0, -40.0, 0.0, 18.0, 0.0, math.pi / 2, 0.0)
    (msg,) = ap.setpoint_messages(east, 0.0, None)
    assert msg.param3 == 0.0  # nothing given yet: WP_LOITER_RAD
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 0.1)
    (msg,) = ap.setpoint_messages(circle_setpoint(0.5, radius=2000.0), 1.0, None)
    scale = eas2tas_squared(FRAME.origin.alt + 40.0)
    assert msg.param3 == pytest.approx(2000.0 / scale, abs=0.5)
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 1.1)
    (msg,) = ap.setpoint_messages(replace(east, t=2.0), 2.0, None)  # a straight again
    assert msg.param3 == round(ap.model.command_radius(0.25 * ap.carrot, scale))
    ap.setpoint_messages(circle_setpoint(0.5, radius=120.0), 3.0, None)
    hold = replace(east, t=4.0, vn=0.0, ve=0.0, hold=True)
    (msg,) = ap.setpoint_messages(hold, 4.0, None)
    assert msg.param3 == round(ap.model.command_radius(120.0, scale))  # the tightest


def test_an_arc_wider_than_arduplane_takes_is_flown_as_the_straight_it_nearly_is() -> None:
    """ArduPlane cuts a loiter's radius to 65535 m (``set_radius_and_direction``): SITL
    told an arc of 180 km flew at its centre, 190 km off, until the next one. Wider
    arcs go as carrots along their tangent, moved on as straights are."""
    ap = plane()
    wide = circle_setpoint(0.0, radius=180_000.0)  # (at the arc's top, heading east)
    (msg,) = ap.setpoint_messages(wide, 0.0, None)
    assert msg.command == M.MAV_CMD_DO_REPOSITION
    assert ap.loiter is not None
    assert ap.loiter[:2] == pytest.approx((wide.north, wide.east + ap.carrot))
    assert msg.param3 < 1000.0  # (a carrot's radius: nothing given yet, 0)
    assert ap.arc is None  # (not learnt from as a loiter)
    ap.on_ack(M.MAV_CMD_DO_REPOSITION, M.MAV_RESULT_ACCEPTED, 0.1)
    on = circle_setpoint(0.05 * ap.carrot / 180_000.0, radius=180_000.0)
    assert ap.setpoint_messages(on, 1.0, None) == []
    (msg,) = ap.setpoint_messages(circle_setpoint(0.0, radius=60_000.0), 2.0, None)
    assert msg.param3 == round(60_000.0 / eas2tas_squared(FRAME.origin.alt + 40.0))


def test_the_mock_arduplane_cuts_a_loiters_radius_to_65535_m() -> None:
    gcs = warm_gcs(make_vehicle(AP, "plane"))
    ap = plane()
    assert send_and_ack(gcs, ap.mode_command("GUIDED").message(1, 1))[0].result == 0
    assert send_and_ack(gcs, ap.arm_command().message(1, 1))[0].result == 0
    msg = ap.reposition(0.0, 180_000.0, -40.0, 180_000.0, True)
    assert send_and_ack(gcs, msg)[0].result == M.MAV_RESULT_ACCEPTED
    goal = gcs.vehicle.flight.goal
    assert isinstance(goal, Loiter)
    assert goal.radius == pytest.approx(65535.0 * eas2tas_squared(FRAME.origin.alt + 40.0))


def test_arduplane_loiter_is_flown_by_the_mock() -> None:
    """Our DO_REPOSITION, through bytes, makes the mock's ArduPlane loiter as meant."""
    gcs = warm_gcs(make_vehicle(AP, "plane"))
    ap = plane()
    assert send_and_ack(gcs, ap.mode_command("GUIDED").message(1, 1))[0].result == 0
    assert send_and_ack(gcs, ap.arm_command().message(1, 1))[0].result == 0
    sp = circle_setpoint(0.0, radius=150.0, clockwise=False)
    (msg,) = ap.setpoint_messages(sp, gcs.now, None)
    ack, _ = send_and_ack(gcs, msg)
    assert ack.result == M.MAV_RESULT_ACCEPTED
    goal = gcs.vehicle.flight.goal
    assert isinstance(goal, Loiter)
    # (the radius sent in whole metres, as ArduPlane takes it: 150 m within half of one)
    assert (goal.north, goal.east, goal.clockwise) == pytest.approx((0.0, 0.0, False), abs=0.02)
    assert goal.radius == pytest.approx(150.0, abs=0.5 * eas2tas_squared(FRAME.origin.alt + 40.0))
    assert goal.down == pytest.approx(-40.0, abs=0.01)


@pytest.mark.parametrize(("gain", "integral_time"), [(1.045, 400.0), (0.96, 400.0), (1.0, 400.0)])
def test_phase_loop_removes_the_steady_error_a_speed_offset_leaves(
    gain: float, integral_time: float
) -> None:
    """A plane that makes ``gain`` times the commanded speed along its path (an ArduPlane
    cutting inside at arc switches: 1.045) on a slot moving at V: the proportional loop
    alone sits V T (1 - 1/gain) off its slot; with the integral the error goes to 0."""
    v, dt = 22.0, 0.5

    def fly(loop: PhaseLoop, seconds: float) -> tuple[float, float]:
        s_plane, fastest = -150.0, 0.0  # starts 150 m behind its slot
        for k in range(round(seconds / dt)):
            t = k * dt
            sp = Setpoint(t, v * t, 0.0, -100.0, v, 0.0, 0.0, 0.0, 0.0)  # north at V
            cmd = loop.speed(sp, s_plane, 0.0, t)
            fastest = max(fastest, cmd)
            s_plane += gain * cmd * dt
        return v * round(seconds / dt) * dt - s_plane, fastest

    p_only, _ = fly(PhaseLoop(integral_time=math.inf), 900.0)
    assert p_only == pytest.approx(-v * 20.0 * (1.0 - 1.0 / gain), abs=1.0)  # ahead: < 0
    loop = PhaseLoop(integral_time=integral_time)
    error, fastest = fly(loop, 900.0)
    assert abs(error) < 1.0
    assert loop.bias == pytest.approx(1.0 / gain - 1.0, abs=0.005)  # the offset, learnt
    assert fastest <= 1.15 * v + 1e-9  # within the airspeed band throughout
