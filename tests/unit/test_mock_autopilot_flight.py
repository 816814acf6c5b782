"""SimVehicle flight behaviour: setpoints into world-frame targets, failsafes, the flows.

Same in-memory byte path as ``test_mock_autopilot.py`` (its ``Gcs`` harness); the
physics runs in 10 ms sim steps, a few sim minutes at most per test.
"""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import eas2tas, eas2tas_squared
from sitl_mock.autopilot import Personality, SimVehicle
from sitl_mock.kinematics import Loiter, TrackTarget
from tests.fakes import (
    AP,
    PX4,
    WORLD,
    Gcs,
    make_vehicle,
    of_type,
    texts,
    warm_gcs,
)

# type_mask: which fields a setpoint carries (everything else ignored)
IGNORE_ALL = 0b0000_1101_1111_1111  # x..az ignored, yaw ignored, yaw_rate ignored, FORCE clear
POS = IGNORE_ALL & ~0b111
VEL = IGNORE_ALL & ~0b111000
POS_VEL = POS & VEL
POS_YAW = POS & ~mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE

HOME_A = (0.0, 0.0, 0.0)
HOME_B = (400.0, -250.0, -12.0)  # 400 m north, 250 m west, 12 m higher


def local_sp(
    vehicle: SimVehicle, frame: int, mask: int, pos: tuple[float, float, float],
    vel: tuple[float, float, float] = (0.0, 0.0, 0.0), yaw: float = 0.0,
) -> mavlink.MAVLink_set_position_target_local_ned_message:  # fmt: skip
    return mavlink.MAVLink_set_position_target_local_ned_message(
        0, vehicle.sysid, 1, frame, mask, *pos, *vel, 0.0, 0.0, 0.0, yaw, 0.0
    )


def global_sp(
    vehicle: SimVehicle, frame: int, mask: int, ned: tuple[float, float], alt: float,
    vel: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> mavlink.MAVLink_set_position_target_global_int_message:  # fmt: skip
    geo = WORLD.to_geo(*ned)
    return mavlink.MAVLink_set_position_target_global_int_message(
        0, vehicle.sysid, 1, frame, mask, round(geo.lat * 1e7), round(geo.lon * 1e7), alt,
        *vel, 0.0, 0.0, 0.0, 0.0, 0.0,
    )  # fmt: skip


def setpoint(vehicle: SimVehicle) -> TrackTarget:
    sp = vehicle.flight.setpoint
    assert sp is not None
    return sp


def approx(value: float | None, expected: float, abs_: float = 0.05) -> bool:
    return value is not None and abs(value - expected) <= abs_


# ================================================================ setpoints
@pytest.mark.parametrize("home", [HOME_A, HOME_B])
def test_local_ned_setpoint_type_masks_give_world_frame_targets(
    home: tuple[float, float, float],
) -> None:
    vehicle = make_vehicle(PX4, "copter", home_ned=home)
    gcs = Gcs(vehicle)
    hn, he, hd = home
    lned = mavlink.MAV_FRAME_LOCAL_NED

    gcs.send(local_sp(vehicle, lned, POS, (100.0, 50.0, -20.0), (9.0, 9.0, 9.0)))
    sp = setpoint(vehicle)
    assert approx(sp.north, hn + 100.0) and approx(sp.east, he + 50.0)
    assert approx(sp.down, hd - 20.0)
    assert (sp.vn, sp.ve, sp.vd, sp.yaw) == (None, None, None, None)

    gcs.send(local_sp(vehicle, lned, VEL, (100.0, 50.0, -20.0), (5.0, -3.0, -1.0)))
    sp = setpoint(vehicle)
    assert (sp.north, sp.east, sp.down) == (None, None, None)
    assert (sp.vn, sp.ve, sp.vd) == (5.0, -3.0, -1.0)

    gcs.send(local_sp(vehicle, lned, POS_VEL, (10.0, 20.0, -30.0), (1.0, 2.0, 0.5)))
    sp = setpoint(vehicle)
    assert approx(sp.north, hn + 10.0) and approx(sp.east, he + 20.0)
    assert approx(sp.down, hd - 30.0) and (sp.vn, sp.ve, sp.vd) == (1.0, 2.0, 0.5)

    gcs.send(local_sp(vehicle, lned, POS_YAW, (0.0, 0.0, -5.0), yaw=4.0))
    sp = setpoint(vehicle)
    assert sp.yaw == pytest.approx(4.0 - 2 * math.pi)  # wrapped to (-pi, pi]
    assert sp.yaw_rate is None


def test_offset_and_body_frames_are_relative_to_the_vehicle() -> None:
    vehicle = make_vehicle(PX4, "copter", home_ned=HOME_B)
    gcs = Gcs(vehicle)
    assert vehicle.aircraft is not None
    vehicle.aircraft.state.yaw = math.pi / 2  # facing east
    hn, he, hd = HOME_B
    gcs.send(local_sp(vehicle, mavlink.MAV_FRAME_LOCAL_OFFSET_NED, POS_VEL, (10.0, 0.0, -5.0),
                      (2.0, 0.0, 0.0)))  # fmt: skip
    sp = setpoint(vehicle)
    assert approx(sp.north, hn + 10.0) and approx(sp.east, he) and approx(sp.down, hd - 5.0)
    assert (sp.vn, sp.ve) == (2.0, 0.0)
    gcs.send(local_sp(vehicle, mavlink.MAV_FRAME_BODY_OFFSET_NED, POS_VEL, (10.0, 0.0, -5.0),
                      (2.0, 0.0, 0.0)))  # fmt: skip
    sp = setpoint(vehicle)  # 10 m ahead is 10 m east; forward speed is an east velocity
    assert approx(sp.north, hn) and approx(sp.east, he + 10.0)
    assert approx(sp.vn, 0.0, 1e-9) and approx(sp.ve, 2.0, 1e-9)
    bad = local_sp(vehicle, mavlink.MAV_FRAME_LOCAL_FRD, POS, (1.0, 1.0, 1.0))
    gcs.send(bad)
    assert vehicle.counters["setpoint_bad_frame"] == 1


def test_same_global_target_is_the_same_world_point_whatever_the_home() -> None:
    a = make_vehicle(PX4, "copter", sysid=1, home_ned=HOME_A)
    b = make_vehicle(PX4, "copter", sysid=2, home_ned=HOME_B)
    targets = []
    for vehicle in (a, b):
        gcs = warm_gcs(vehicle)
        rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        gcs.send(global_sp(vehicle, rel, POS_VEL, (250.0, 80.0), 30.0, (4.0, -1.0, 0.0)))
        targets.append(setpoint(vehicle))
        gcs.send(global_sp(vehicle, mavlink.MAV_FRAME_GLOBAL_INT, POS, (250.0, 80.0), 600.0))
        amsl = setpoint(vehicle)
        assert approx(amsl.down, 488.0 - 600.0, 1e-6)  # world origin is 488 m AMSL
    ta, tb = targets
    for t in targets:
        assert approx(t.north, 250.0, 0.01) and approx(t.east, 80.0, 0.01)
        assert (t.vn, t.ve) == (4.0, -1.0)
    # Relative altitude is above each vehicle's own home: B's home is 12 m higher.
    assert approx(ta.down, -30.0, 1e-6) and approx(tb.down, -42.0, 1e-6)
    # And the same LOCAL_NED point is a different world point for each.
    for vehicle, (hn, he, _) in ((a, HOME_A), (b, HOME_B)):
        Gcs(vehicle).send(local_sp(vehicle, mavlink.MAV_FRAME_LOCAL_NED, POS, (5.0, 5.0, -10.0)))
        assert approx(setpoint(vehicle).north, hn + 5.0) and approx(
            setpoint(vehicle).east, he + 5.0
        )


# ================================================================= the flows
def test_px4_plane_flow_setpoints_offboard_arm_flies_the_setpoints() -> None:
    vehicle = make_vehicle(PX4, "plane")
    gcs = warm_gcs(vehicle)
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    speed, t0 = 15.0, gcs.now

    def reference(now: float) -> None:  # a reference flying east at 15 m/s, 60 m up
        if round(now * 100) % 10 == 0:
            east = 300.0 + speed * (now - t0)
            gcs.send(global_sp(vehicle, rel, POS_VEL, (200.0, east), 60.0, (0.0, speed, 0.0)))

    reference(gcs.now)
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(5.0, reference, telemetry=False)
    assert not vehicle.flight.airborne  # a plane never launches in OFFBOARD
    assert gcs.truth().speed == 0.0
    # NAV_TAKEOFF (param7 AMSL): AUTO.TAKEOFF climbs out, then Hold; then OFFBOARD again
    amsl = WORLD.origin.alt + 40.0
    ack, _ = gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, math.nan, 0, 0, amsl)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and vehicle.mode == "AUTO.TAKEOFF"
    gcs.run(2.0, reference, telemetry=False)
    assert vehicle.truth(gcs.now).down < -1.0  # climbing out
    gcs.run(20.0, reference, telemetry=False)
    assert vehicle.mode == "AUTO.LOITER" and gcs.truth().down == pytest.approx(-40.0, abs=1.5)
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(98.0, reference, telemetry=False)
    row = gcs.truth()
    # On the reference's track, at its velocity (a plane cannot catch up along the
    # track by itself: closing that gap is the setpoint generator's job).
    assert row.north == pytest.approx(200.0, abs=10.0)
    assert (row.vn, row.ve) == pytest.approx((0.0, speed), abs=0.5)
    assert row.down == pytest.approx(-60.0, abs=1.0)
    assert row.mode == "OFFBOARD" and row.armed


def test_px4_copter_lifts_off_in_offboard_and_failsafes_to_hold() -> None:
    vehicle = make_vehicle(PX4, "copter", home_ned=HOME_B)
    gcs = warm_gcs(vehicle)
    hn, he, hd = HOME_B
    lned = mavlink.MAV_FRAME_LOCAL_NED

    def stream(now: float) -> None:
        if round(now * 100) % 10 == 0:
            gcs.send(local_sp(vehicle, lned, POS, (60.0, -30.0, -15.0)))

    stream(gcs.now)
    gcs.set_mode(6)
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(40.0, stream, telemetry=False)
    row = gcs.truth()
    assert (row.north, row.east, row.down) == pytest.approx((hn + 60, he - 30, hd - 15), abs=0.5)
    out = gcs.run(3.0)  # the stream stops
    assert "Failsafe" in texts(out)[0]
    fail_t = next(t for t, m in gcs.received if "Failsafe" in getattr(m, "text", ""))
    assert fail_t - (gcs.now - 3.0) == pytest.approx(1.0, abs=0.05)  # COM_OF_LOSS_T
    hb = of_type(out, "HEARTBEAT")[-1]
    assert hb.custom_mode == (4 << 16) | (3 << 24)  # AUTO.LOITER
    assert hb.system_status == mavlink.MAV_STATE_CRITICAL
    assert vehicle.mode == "AUTO.LOITER" and vehicle.counters["setpoint_failsafe"] == 1
    gcs.run(10.0, telemetry=False)
    assert gcs.truth().speed < 0.1  # hovering where it was
    # Offboard cannot be re-entered without a stream; with one it can.
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    stream(round(gcs.now, 1))
    assert gcs.set_mode(6).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.heartbeat().system_status == mavlink.MAV_STATE_ACTIVE


def test_ardupilot_copter_flow_guided_arm_takeoff_then_setpoints() -> None:
    vehicle = make_vehicle(AP, "copter", home_ned=HOME_B)
    gcs = warm_gcs(vehicle)
    hn, he, hd = HOME_B
    assert gcs.set_mode(4).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(3.0, telemetry=False)
    assert not vehicle.flight.airborne  # ArduCopter waits for NAV_TAKEOFF
    ack, _ = gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 20.0)  # relative
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().down == pytest.approx(hd - 20.0, abs=0.6)
    again = gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 20.0)[0]
    assert again.result == mavlink.MAV_RESULT_FAILED  # already flying
    lned = mavlink.MAV_FRAME_LOCAL_NED
    gcs.send(local_sp(vehicle, lned, POS, (-40.0, 25.0, -25.0)))
    gcs.run(30.0, telemetry=False)
    row = gcs.truth()
    assert (row.north, row.east, row.down) == pytest.approx((hn - 40, he + 25, hd - 25), abs=0.5)
    assert row.mode == "GUIDED"


def test_ardupilot_copter_velocity_setpoint_times_out_to_a_stop_in_guided() -> None:
    vehicle = make_vehicle(AP, "copter")
    gcs = warm_gcs(vehicle)
    gcs.set_mode(4)
    gcs.arm()
    gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10.0)
    gcs.run(15.0, telemetry=False)
    gcs.send(local_sp(vehicle, mavlink.MAV_FRAME_LOCAL_NED, VEL, (0, 0, 0), (5.0, 0.0, 0.0)))
    gcs.run(0.9, telemetry=False)
    assert gcs.truth().speed > 0.5
    gcs.run(6.0, telemetry=False)
    assert gcs.truth().speed < 0.1  # GUID_TIMEOUT (1 s here): stopped and hovering
    assert vehicle.mode == "GUIDED" and vehicle.counters["setpoint_timeout"] == 1


def test_ardupilot_plane_flow_guided_arm_reposition_loiters_as_told() -> None:
    vehicle = make_vehicle(AP, "plane", home_ned=HOME_B)
    gcs = warm_gcs(vehicle)
    hn, he, hd = HOME_B
    assert gcs.set_mode(15).result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.arm().result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(10.0, telemetry=False)
    # Armed in GUIDED on the runway, ArduPlane keeps its throttle suppressed
    assert not vehicle.flight.airborne and gcs.truth().speed == 0.0
    gcs.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 18.0, -1)
    gcs.run(5.0, telemetry=False)
    assert not vehicle.flight.airborne
    # TAKEOFF mode climbs to TKOFF_ALT and loiters there; then GUIDED
    assert gcs.set_mode(13).result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(1.0, telemetry=False)
    assert vehicle.flight.airborne
    gcs.run(30.0, telemetry=False)
    assert gcs.truth().down == pytest.approx(hd - 30.0, abs=1.0)  # TKOFF_ALT 30 m
    assert vehicle.mode == "TAKEOFF"  # ArduPlane stays in TAKEOFF, loitering
    assert gcs.set_mode(15).result == mavlink.MAV_RESULT_ACCEPTED
    # DO_CHANGE_SPEED only inside AIRSPEED_MIN..MAX (10.8-27 m/s): another is refused
    # and the airspeed in force kept, as Plane::do_change_speed does; -2 is the default
    speed = mavlink.MAV_CMD_DO_CHANGE_SPEED
    assert gcs.command(speed, 0, 30.0, -1)[0].result == mavlink.MAV_RESULT_FAILED
    assert gcs.command(speed, 0, 20.0, -1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    assert gcs.command(speed, 0, 9.0, -1)[0].result == mavlink.MAV_RESULT_FAILED
    assert vehicle.flight.cruise == 20.0
    assert gcs.command(speed, 0, -2.0, -1)[0].result == mavlink.MAV_RESULT_ACCEPTED
    assert vehicle.flight.cruise is None
    # Horizontal setpoints are ignored by ArduPlane; only the altitude is taken.
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    out = gcs.send(global_sp(vehicle, rel, POS, (hn + 3000.0, he), 45.0))
    assert texts(out) == ["Change alt to 45.0"]
    gcs.run(60.0, telemetry=False)
    row = gcs.truth()
    assert math.hypot(row.north - hn, row.east - he) < 600.0
    assert row.down == pytest.approx(hd - 45.0, abs=1.0)
    # DO_REPOSITION (COMMAND_INT): 150 m radius, param4 != 0 -> counter-clockwise.
    centre = WORLD.to_geo(hn + 900.0, he + 400.0)
    ack, _ = gcs.command_int(
        mavlink.MAV_CMD_DO_REPOSITION, rel, (-1.0, 1.0, 150.0, 1.0),
        round(centre.lat * 1e7), round(centre.lon * 1e7), 80.0,
    )  # fmt: skip
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(120.0, telemetry=False)
    distances, rates = [], []
    for _ in range(40):
        gcs.run(1.0, telemetry=False)
        row = gcs.truth()
        distances.append(math.hypot(row.north - hn - 900.0, row.east - he - 400.0))
        rates.append(row.yaw_rate)
    flown = 150.0 * eas2tas_squared(WORLD.origin.alt - hd + 80.0)  # L1's density scaling
    assert min(distances) > flown - 5.0 and max(distances) < flown + 5.0
    assert all(r < 0.0 for r in rates)  # counter-clockwise
    assert row.down == pytest.approx(hd - 80.0, abs=1.0)
    assert row.mode == "GUIDED"


def test_px4_plane_reposition_switches_to_hold_and_loiters_clockwise() -> None:
    vehicle = make_vehicle(PX4, "plane")
    gcs = warm_gcs(vehicle)
    gcs.arm()
    assert not vehicle.flight.airborne  # armed in Hold on the ground: stays put
    target = WORLD.to_geo(-500.0, 700.0, -70.0)
    ack, _ = gcs.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan,
                         target.lat, target.lon, target.alt)  # fmt: skip
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(5.0, telemetry=False)
    assert not vehicle.flight.airborne  # a reposition does not launch a plane
    gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, math.nan, 0, 0, WORLD.origin.alt + 30)
    gcs.run(15.0, telemetry=False)
    assert vehicle.flight.airborne and vehicle.mode == "AUTO.LOITER"
    ack, _ = gcs.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan,
                         target.lat, target.lon, target.alt)  # fmt: skip
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(150.0, telemetry=False)
    samples = []
    for _ in range(20):
        gcs.run(1.0, telemetry=False)
        samples.append(gcs.truth())
    assert all(abs(math.hypot(r.north + 500.0, r.east - 700.0) - 80.0) < 5.0 for r in samples)
    assert all(r.yaw_rate > 0.0 for r in samples)  # NAV_LOITER_RAD, clockwise
    assert samples[-1].mode == "AUTO.LOITER"
    assert samples[-1].down == pytest.approx(-70.0, abs=1.0)


def test_attitude_roll_is_a_coordinated_turn_and_yaw_is_heading() -> None:
    vehicle = make_vehicle(AP, "plane")
    gcs = warm_gcs(vehicle)
    gcs.set_mode(13)
    gcs.arm()
    gcs.run(60.0, telemetry=False)
    gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 100_000)
    (att,) = of_type(gcs.run(0.01), "ATTITUDE")
    row = gcs.truth()
    assert abs(row.yaw_rate) > 0.1  # circling
    assert att.roll == pytest.approx(math.atan(row.speed * row.yaw_rate / 9.80665), abs=1e-3)
    assert att.yaw == pytest.approx(row.yaw, abs=1e-3)


def _guided_plane(personality: Personality, speed: float = 22.0, lag: float = 1.55) -> Gcs:
    """A plane climbed out in its take-off mode, then in GUIDED (ArduPilot) or Hold (PX4)."""
    vehicle = make_vehicle(
        personality, "plane", airspeed=speed, min_turn_radius=60.0, loiter_lag=lag
    )
    gcs = warm_gcs(vehicle)
    if personality is AP:
        gcs.set_mode(13)
        gcs.arm()
        gcs.run(30.0, telemetry=False)
        gcs.set_mode(15)
    else:
        gcs.arm()
        gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, 548.0)
        gcs.run(30.0, telemetry=False)
    return gcs


def _loiter(gcs: Gcs, personality: Personality, north: float, east: float, radius: float,
            clockwise: bool) -> None:  # fmt: skip
    """DO_REPOSITION a loiter at 60 m above home: ArduPlane's param3/param4, PX4's signed
    param3 (``Firmware.loiter_circle``)."""
    centre = WORLD.to_geo(north, east)
    if personality is AP:
        p3, p4 = radius, 0.0 if clockwise else 1.0
    else:
        p3, p4 = (radius if clockwise else -radius), 0.0
    gcs.command_int(mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                    (-1.0, 0.0, p3, p4), round(centre.lat * 1e7), round(centre.lon * 1e7),
                    60.0)  # fmt: skip


@pytest.mark.parametrize(
    ("personality", "radius", "speed"),
    [(AP, 100.0, 22.0), (AP, 150.0, 18.0), (AP, 300.0, 22.0), (AP, 2000.0, 22.0),
     (PX4, 300.0, 22.0), (PX4, 2000.0, 22.0)],
)  # fmt: skip
def test_plane_loiters_wide_as_its_navigation_controller_does(
    personality: Personality, radius: float, speed: float
) -> None:
    """ArduPlane: L1 scales the radius by EAS2TAS^2 at the loiter's altitude (548 m
    AMSL here: 5.4 %), then overshoots by (V T)^2 / R; PX4: the overshoot only."""
    lag = 1.55
    gcs = _guided_plane(personality, speed, lag)
    _loiter(gcs, personality, 600.0, 0.0, radius, clockwise=True)
    gcs.run(240.0 if radius < 1000.0 else 900.0, telemetry=False)
    flown = []
    for _ in range(60):
        gcs.run(1.0, telemetry=False)
        row = gcs.truth()
        flown.append(math.hypot(row.north - 600.0, row.east))
    scaled = radius * (eas2tas_squared(548.0) if personality is AP else 1.0)
    expected = scaled + (speed * lag) ** 2 / scaled  # wider the faster and the tighter
    assert sum(flown) / len(flown) == pytest.approx(expected, abs=1.5)
    assert max(flown) - min(flown) < 3.0  # a steady circle, only a wider one
    if personality is AP:
        assert eas2tas_squared(548.0) == pytest.approx(1.0544, abs=1e-4)


@pytest.mark.parametrize("personality", [AP, PX4])
def test_an_arduplanes_airspeed_is_equivalent_and_flown_faster_in_thin_air(
    personality: Personality,
) -> None:
    """ArduPlane's TECS demands an equivalent airspeed (``_TAS_dem = _EAS_dem *
    EAS2TAS``): told 20 m/s at 548 m AMSL it flies 20.5 through the air, and at 3 km
    above home 23.8, reporting 20 in VFR_HUD; SITL at 684 m flew 19.23 m/s over the
    ground told 18 (1.068: its pitot divides by EAS2TAS twice). PX4's plane here flies
    the speed told."""
    gcs = _guided_plane(personality)
    _loiter(gcs, personality, 600.0, 0.0, 400.0, clockwise=True)
    gcs.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 20.0, -1)
    for above, amsl in ((60.0, 548.0), (3000.0, 3488.0)):
        centre = WORLD.to_geo(600.0, 0.0)
        gcs.command_int(mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                        (-1.0, 0.0, 400.0, 0.0), round(centre.lat * 1e7),
                        round(centre.lon * 1e7), above)  # fmt: skip
        gcs.run(1000.0 if above > 100.0 else 60.0, telemetry=False)
        scale = eas2tas(amsl) if personality is AP else 1.0
        assert gcs.truth().down == pytest.approx(WORLD.origin.alt - amsl, abs=1.0)
        assert gcs.truth().speed == pytest.approx(20.0 * scale, abs=0.02)
        hud = of_type(gcs.run(1.0), "VFR_HUD")[-1]
        assert hud.airspeed == pytest.approx(20.0, abs=0.02)
        assert hud.groundspeed == pytest.approx(20.0 * scale, abs=0.02)
    if personality is AP:  # (the standard atmosphere: 2.7 % at 548 m, 19 % at 3.5 km)
        assert eas2tas(3488.0) == pytest.approx(1.1905, abs=1e-4)


@pytest.mark.parametrize("personality", [AP, PX4])
def test_an_arduplanes_airspeed_range_is_equivalent_too(personality: Personality) -> None:
    """AIRSPEED_MIN and AIRSPEED_MAX are equivalent airspeeds as well (a wing stalls at
    a dynamic pressure): told its maximum 3 km above home, ArduPlane flies it 19 %
    faster through the air, not clamped to the maximum at sea level. PX4's plane flies
    its maximum as told."""
    gcs = _guided_plane(personality)
    aircraft = gcs.vehicle.flight.aircraft
    assert aircraft is not None
    top = aircraft.params.max_airspeed_ratio * aircraft.params.airspeed
    centre = WORLD.to_geo(600.0, 0.0)
    gcs.command_int(mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                    (-1.0, 0.0, 400.0, 0.0), round(centre.lat * 1e7), round(centre.lon * 1e7),
                    3000.0)  # fmt: skip
    ack, _ = gcs.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, top, -1)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(1000.0, telemetry=False)
    scale = eas2tas(3488.0) if personality is AP else 1.0
    assert gcs.truth().speed == pytest.approx(top * scale, abs=0.02)


def test_arduplane_keeps_the_last_reposition_radius_until_guided_is_entered_again() -> None:
    """``ModeGuided::set_radius_and_direction`` runs only for param3 > 0, and
    ``active_radius_m`` is cleared only when GUIDED is entered: a reposition with radius
    0 after a 1500 m one loiters 1500 m around its point (scaled, as every loiter)."""
    gcs = _guided_plane(AP)
    scale = eas2tas_squared(548.0)
    _loiter(gcs, AP, 600.0, 0.0, 1500.0, clockwise=True)
    goal = gcs.vehicle.flight.goal
    assert isinstance(goal, Loiter) and goal.radius == pytest.approx(1500.0 * scale)
    _loiter(gcs, AP, 900.0, 0.0, 0.0, clockwise=True)
    goal = gcs.vehicle.flight.goal
    assert isinstance(goal, Loiter) and goal.radius == pytest.approx(1500.0 * scale)
    assert (goal.north, goal.east) == pytest.approx((900.0, 0.0), abs=0.01)
    assert gcs.set_mode(12).result == mavlink.MAV_RESULT_ACCEPTED  # LOITER, then GUIDED
    assert gcs.set_mode(15).result == mavlink.MAV_RESULT_ACCEPTED
    _loiter(gcs, AP, 900.0, 0.0, 0.0, clockwise=True)
    goal = gcs.vehicle.flight.goal
    default = gcs.vehicle.flight.loiter_radius  # WP_LOITER_RAD
    assert isinstance(goal, Loiter) and goal.radius == pytest.approx(default * scale)


def test_a_km_loiter_laid_through_an_arduplane_sends_it_out_in_seconds() -> None:
    """ArduPlane SITL on a 2275 m circle, told to loiter on it, turned 80 degrees outward
    and was 160 m out 10 s later: L1 wants the circle 7 % wider and closes on it with
    its PD's period, whatever the radius. The mock's plane does the same (not within
    a km, as a field scaled by the radius would)."""
    gcs = _guided_plane(AP)
    _loiter(gcs, AP, 600.0, 0.0, 300.0, clockwise=True)
    gcs.run(120.0, telemetry=False)
    row = gcs.truth()
    radius = 2000.0  # a circle through the plane, tangent to its course, clockwise
    centre = (row.north - radius * math.cos(row.yaw + math.pi / 2),
              row.east - radius * math.sin(row.yaw + math.pi / 2))  # fmt: skip
    assert math.hypot(row.north - centre[0], row.east - centre[1]) == pytest.approx(radius)
    _loiter(gcs, AP, *centre, radius, clockwise=True)
    out = []
    for _ in range(12):
        gcs.run(1.0, telemetry=False)
        row = gcs.truth()
        out.append(math.hypot(row.north - centre[0], row.east - centre[1]) - radius)
    assert out[-1] > 80.0, out  # SITL: 164 m (its T and density a little larger)
    assert out[-1] < 1.1 * (eas2tas_squared(548.0) - 1.0) * radius, out  # not beyond


def test_copter_rtl_returns_home_lands_and_disarms() -> None:
    vehicle = make_vehicle(PX4, "copter")
    gcs = warm_gcs(vehicle)
    gcs.arm()
    gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, 508.0)
    gcs.run(15.0, telemetry=False)
    assert vehicle.mode == "AUTO.LOITER"  # takeoff done: Hold
    target = WORLD.to_geo(60.0, 0.0, -20.0)
    gcs.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, target.lat, target.lon, 508.0)
    gcs.run(30.0, telemetry=False)
    assert gcs.truth().north == pytest.approx(60.0, abs=0.5)
    assert gcs.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH)[0].result == 0
    out = gcs.run(60.0)
    assert "Landing detected, disarmed" in texts(out)
    row = gcs.truth()
    assert not row.armed and abs(row.north) < 1.0 and row.down == pytest.approx(0.0)


def test_an_arduplane_put_in_takeoff_while_flying_climbs_to_tkoff_alt_or_loiters_here() -> None:
    """ArduPlane's ModeTakeoff::update, already flying: "Climbing to TKOFF alt then
    loitering" when below TKOFF_ALT above home, "Above TKOFF alt - loitering" where it is
    otherwise (it does not fly level at its own altitude for ever)."""
    gcs = _guided_plane(AP)  # (climbed out to TKOFF_ALT, 30 m above home, then GUIDED)
    flight = gcs.vehicle.flight
    _, _, home_down = WORLD.to_ned(flight.home)
    setp = mavlink.MAVLink_param_set_message
    for tkoff_alt, expected_rel in ((80.0, 80.0), (10.0, 80.0)):  # (then above it: stays)
        gcs.send(setp(1, 1, b"TKOFF_ALT", tkoff_alt, mavlink.MAV_PARAM_TYPE_REAL32))
        assert gcs.set_mode(13).result == mavlink.MAV_RESULT_ACCEPTED  # TAKEOFF, in flight
        gcs.run(60.0, telemetry=False)
        goal = flight.goal
        assert isinstance(goal, Loiter), goal
        assert home_down - goal.down == pytest.approx(expected_rel, abs=1.0)
        assert home_down - gcs.truth().down == pytest.approx(expected_rel, abs=3.0)
        assert gcs.set_mode(15).result == mavlink.MAV_RESULT_ACCEPTED  # (GUIDED again)
