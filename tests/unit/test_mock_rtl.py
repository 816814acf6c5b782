"""The mock rover told RTL drives home, stands there, and resumes its mission in AUTO."""

from __future__ import annotations

import dataclasses
import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.autopilot import Personality, SimVehicle, VehicleSpec
from sitl_mock.ground import Polyline
from sitl_mock.params import Knob
from sitl_mock.rtl import road_home
from tests.fakes import WORLD, Gcs
from tests.unit.test_mock_driveclock import _mode
from tests.unit.test_mock_mission import rover
from tests.unit.test_mock_upload import AP, items, upload, wp

# A lap of 3.6 km round four corners at 8 m/s, braking at 1 m/s^2 for each.
LAP = Polyline(
    ((0.0, 0.0), (1000.0, 0.0), (1000.0, 800.0), (0.0, 800.0)), speed=8.0, accel=1.0, loop=True
)
_RTL = {Personality.ARDUPILOT: 11, Personality.PX4: (4 << 16) | (5 << 24)}


def _rtl(gcs: Gcs, personality: Personality) -> list[object]:
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    ack, *texts = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, _RTL[personality]))
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED, texts
    return texts


def _drive(gcs: Gcs, seconds: float) -> tuple[list[tuple[float, float, float]], list[str]]:
    """(north, east, speed) every second for ``seconds``, and the texts said."""
    path, texts = [], []
    for _ in range(round(seconds)):
        msgs = gcs.run(1.0)
        texts += [m.text for m in msgs if m.get_type() == "STATUSTEXT"]
        t = gcs.truth()
        path.append((t.north, t.east, t.speed))
    return path, texts


def _home(gcs: Gcs) -> tuple[float, float]:
    """Where the rover's home is (world north, east): where it was once its position
    estimate was good, a few metres along its road."""
    north, east, _ = WORLD.to_ned(gcs.vehicle.flight.home)
    return north, east


def _seqs(gcs: Gcs) -> set[int]:
    return {m.seq for m in gcs.run(1.0) if m.get_type() == "MISSION_CURRENT"}


@pytest.mark.parametrize("personality", [Personality.ARDUPILOT, Personality.PX4])
def test_a_rover_in_rtl_turns_round_drives_home_and_stands_there(
    personality: Personality,
) -> None:
    gcs = Gcs(rover(personality, LAP))
    gcs.run(160.0, telemetry=False)  # (on the second leg, heading away from home)
    was = gcs.truth()
    assert was.north == pytest.approx(1000.0) and was.east > 100.0 and was.speed == 8.0
    driving_to = _seqs(gcs)
    _rtl(gcs, personality)
    path, texts = _drive(gcs, 200.0)
    # It braked along its way at its accel (no jump in speed), turned round and drove
    # straight home at its WP_SPEED; there it stands.
    speeds = [was.speed] + [s for *_, s in path]
    assert all(abs(b - a) <= 1.0 + 1e-6 for a, b in itertools.pairwise(speeds))
    assert min(speeds[:15]) < 2.5  # (a turn of 165 degrees through WP_RADIUS)
    assert max(speeds) == pytest.approx(8.0)
    hn, he = _home(gcs)
    n, e, speed = path[-1]
    assert math.hypot(n - hn, e - he) <= 2.0 and speed == 0.0  # (within WP_RADIUS)
    homing = [(n, e) for n, e, v in path if v == 8.0 and math.hypot(n - hn, e - he) < 600.0]
    bearings = [math.atan2(e - he, n - hn) for n, e in homing]
    assert len(homing) > 30 and max(bearings) - min(bearings) < 1e-3  # (straight home)
    said = [t for t in texts if t == "Reached destination"]
    assert said == (["Reached destination"] if personality is Personality.ARDUPILOT else [])
    # Its MISSION_CURRENT stays the item it was driving to, which AUTO resumes.
    assert _seqs(gcs) == driving_to


@pytest.mark.parametrize("personality", [Personality.ARDUPILOT, Personality.PX4])
def test_back_in_auto_it_drives_to_the_item_it_left_then_on_along_its_mission(
    personality: Personality,
) -> None:
    gcs = Gcs(rover(personality, LAP))
    gcs.run(160.0, telemetry=False)
    driving_to = _seqs(gcs)
    _rtl(gcs, personality)
    gcs.run(200.0, telemetry=False)
    _mode(gcs, personality, "AUTO")
    path, _ = _drive(gcs, 400.0)
    # Straight from home to the corner it was driving to, (1000, 800), then along the
    # mission's next leg to (0, 800).
    hn, he = _home(gcs)
    corner = min(path, key=lambda p: math.hypot(p[0] - 1000.0, p[1] - 800.0))
    assert math.hypot(corner[0] - 1000.0, corner[1] - 800.0) < 10.0
    to_corner = path[: path.index(corner)]
    on_the_way = [p for p in to_corner if math.hypot(p[0] - hn, p[1] - he) > 200.0]
    slope = (800.0 - he) / (1000.0 - hn)
    assert on_the_way and all(abs((e - he) / (n - hn) - slope) < 0.02 for n, e, _ in on_the_way)
    after = path[path.index(corner) :]
    assert min(math.hypot(n, e - 800.0) for n, e, _ in after) < 10.0  # (the next corner)
    assert _seqs(gcs) != driving_to  # (on to the next items)


def test_an_ardurover_in_smart_rtl_drives_home_back_along_the_path_it_drove() -> None:
    """ArduRover's SMART_RTL (``ModeSmartRTL``): refused before its path has begun (its
    position not yet good); then it turns round and retraces the road it drove, round
    its corner, not straight home, says "Reached destination" at the path's first point
    and stands; MISSION_CURRENT keeps the item it was driving to."""
    gcs = Gcs(rover(AP, LAP))
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    ack, *texts = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, 12))
    assert ack.result == mavlink.MAV_RESULT_FAILED
    assert [t.text for t in texts] == ["Flight mode change failed"]
    gcs.run(160.0, telemetry=False)  # (on the second leg, east of the corner at (1000, 0))
    was, driving_to = gcs.truth(), _seqs(gcs)
    ack, *_ = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, 12))
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and gcs.vehicle.mode == "SMART_RTL"
    path, texts = _drive(gcs, 300.0)
    speeds = [was.speed] + [s for *_, s in path]
    assert all(abs(b - a) <= 1.0 + 1e-6 for a, b in itertools.pairwise(speeds))
    for n, e, _ in path:  # (on the legs it drove, and 40 m on along its way to turn round)
        on_second = abs(n - 1000.0) if -5.0 <= e <= was.east + 50.0 else math.inf
        on_first = abs(e) if -5.0 <= n <= 1005.0 else math.inf
        assert min(on_second, on_first) < 3.0, (n, e)
    assert min(math.hypot(n - 1000.0, e) for n, e, _ in path) < 3.0  # (round its corner)
    hn, he = _home(gcs)
    n, e, speed = path[-1]
    assert math.hypot(n - hn, e - he) <= 2.0 and speed == 0.0
    assert texts == ["Reached destination"]
    assert _seqs(gcs) == driving_to


def test_a_stalled_ardurover_its_crash_check_holds_each_time_it_is_sent_on() -> None:
    """FS_CRASH_CHECK (ArduRover's; 0 to 2, nothing else): stalled on its road, with 1
    it holds 2 s after it stands; sent on in AUTO, or home, it stands and holds again;
    with 2 it is disarmed as well. A PX4 rover has no such parameter."""
    gcs = Gcs(rover(AP, LAP))
    (refused, *_) = gcs.send(mavlink.MAVLink_param_set_message(11, 1, b"FS_CRASH_CHECK", 3.0, 9))
    assert refused.param_value == 0.0  # (Rover's default: off)
    gcs.send(mavlink.MAVLink_param_set_message(11, 1, b"FS_CRASH_CHECK", 1.0, 9))
    gcs.run(60.0, telemetry=False)
    gcs.vehicle.stall()
    path, texts = _drive(gcs, 12.0)
    stood = next(k for k, (*_, v) in enumerate(path) if v == 0.0)  # (braked at 1 m/s^2)
    assert 6 <= stood <= 9 and texts == ["Crash: Going to HOLD"], (path, texts)
    assert gcs.truth().mode == "HOLD" and gcs.truth().armed
    for sent in (10, 11):  # (AUTO, RTL: it cannot move, and holds again)
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        gcs.send(mavlink.MAVLink_set_mode_message(11, flag, sent))
        _, texts = _drive(gcs, 4.0)
        assert texts == ["Crash: Going to HOLD"] and gcs.truth().mode == "HOLD", texts
    gcs.send(mavlink.MAVLink_param_set_message(11, 1, b"FS_CRASH_CHECK", 2.0, 9))
    gcs.send(mavlink.MAVLink_set_mode_message(11, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 10))
    _drive(gcs, 4.0)
    assert gcs.truth().mode == "HOLD" and not gcs.truth().armed
    px4 = Gcs(rover(Personality.PX4, LAP))
    asked = mavlink.MAVLink_param_request_read_message(11, 1, b"FS_CRASH_CHECK", -1)
    assert px4.send(asked) == []  # (no such parameter: no answer)


def test_a_rover_is_refused_rtl_before_it_has_a_home_and_takes_the_command() -> None:
    gcs = Gcs(rover(Personality.ARDUPILOT, LAP))
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    ack, *texts = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, _RTL[Personality.ARDUPILOT]))
    assert ack.result == mavlink.MAV_RESULT_FAILED  # (ModeRTL::_enter: no home yet)
    assert [t.text for t in texts] == ["Flight mode change failed"]
    assert gcs.vehicle.mode == "AUTO"
    gcs.run(100.0, telemetry=False)
    ack, _ = gcs.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and gcs.vehicle.mode == "RTL"
    gcs.run(200.0, telemetry=False)
    hn, he = _home(gcs)
    assert math.hypot(gcs.truth().north - hn, gcs.truth().east - he) <= 2.0


def test_rtl_speed_is_its_parameter_and_wp_speed_is_kept() -> None:
    gcs = Gcs(rover(AP, LAP))
    gcs.run(60.0, telemetry=False)  # (on the first leg, 400 m out)
    gcs.send(mavlink.MAVLink_param_set_message(11, 1, b"RTL_SPEED", 4.0, 9))
    _rtl(gcs, Personality.ARDUPILOT)
    path, _ = _drive(gcs, 60.0)
    assert max(s for *_, s in path[20:]) == pytest.approx(4.0)
    (value,) = gcs.send(mavlink.MAVLink_param_request_read_message(11, 1, b"WP_SPEED", -1))
    assert value.param_value == pytest.approx(8.0)
    (refused, *_) = gcs.send(mavlink.MAVLink_param_set_message(11, 1, b"RTL_SPEED", -1.0, 9))
    assert refused.param_value == pytest.approx(4.0)


def test_held_on_its_way_home_it_stands_and_rtl_again_drives_on_home() -> None:
    gcs = Gcs(rover(AP, LAP))
    gcs.run(60.0, telemetry=False)
    _rtl(gcs, Personality.ARDUPILOT)
    gcs.run(20.0, telemetry=False)
    _mode(gcs, Personality.ARDUPILOT, "HOLD")
    gcs.run(15.0, telemetry=False)
    stood = gcs.truth()
    gcs.run(30.0, telemetry=False)
    assert (gcs.truth().north, gcs.truth().speed) == (stood.north, 0.0)
    _rtl(gcs, Personality.ARDUPILOT)
    gcs.run(120.0, telemetry=False)
    hn, he = _home(gcs)
    assert math.hypot(gcs.truth().north - hn, gcs.truth().east - he) <= 2.0


def test_a_mission_uploaded_on_its_way_home_is_started_in_auto() -> None:
    """The return goes on home; AUTO then starts the new mission at its first item."""
    gcs = Gcs(rover(AP, LAP))
    gcs.run(60.0, telemetry=False)
    _rtl(gcs, Personality.ARDUPILOT)
    upload(gcs, items([wp(0.0, 500.0), wp(500.0, 500.0)], home_first=True))
    gcs.run(120.0, telemetry=False)
    hn, he = _home(gcs)
    assert math.hypot(gcs.truth().north - hn, gcs.truth().east - he) <= 2.0
    _mode(gcs, Personality.ARDUPILOT, "AUTO")
    gcs.run(200.0, telemetry=False)
    t = gcs.truth()
    assert (t.north, t.east) == pytest.approx((500.0, 500.0), abs=1.0)


def test_the_convoy_behind_its_leader_follows_it_home() -> None:
    """A follower in AUTO drives the path its leader drives, home too."""
    lead = rover(Personality.ARDUPILOT, LAP)
    spec = VehicleSpec(
        sysid=12, kind="ground", personality=Personality.ARDUPILOT,
        home=WORLD.to_geo(0.0, 0.0, 0.0), route=LAP,
    )  # fmt: skip
    behind = SimVehicle(spec, WORLD, 0.0)
    assert lead.trail is not None
    behind.follow(lead.trail, lag=5.0, standstill=10.0)
    gcs = Gcs(lead)

    def step_behind(now: float) -> None:
        behind.step(now, 0.01)

    gcs.run(160.0, telemetry=False, every=step_behind)
    _rtl(gcs, Personality.ARDUPILOT)
    gcs.run(200.0, telemetry=False, every=step_behind)
    here, there = behind.truth(gcs.now), gcs.truth()
    hn, he = _home(gcs)
    assert math.hypot(there.north - hn, there.east - he) <= 2.0
    gap = math.hypot(here.north - there.north, here.east - there.east)
    assert 9.0 <= gap <= 11.0 and here.speed == 0.0  # (its standstill distance behind)


def test_a_follower_sent_home_leaves_its_leaders_trail_for_its_own_home() -> None:
    """ArduRover's RTL is the vehicle's own: a follower told it (by its operator, not its
    leader's) turns off the trail at the speed it has, drives to its own home and says
    so, while its leader drives on; back in AUTO it drives its own mission (its leader's
    road) from there, no longer behind it. The vehicle behind it drives on behind the
    leader, in its place in the column."""
    lead = rover(Personality.ARDUPILOT, LAP)
    spec = VehicleSpec(
        sysid=12, kind="ground", personality=Personality.ARDUPILOT,
        home=WORLD.to_geo(0.0, -30.0, 0.0), route=LAP,
    )  # fmt: skip
    behind = SimVehicle(spec, WORLD, 0.0)
    last = SimVehicle(dataclasses.replace(spec, sysid=13), WORLD, 0.0)
    assert lead.trail is not None and behind.trail is not None
    behind.follow(lead.trail, lag=5.0, standstill=10.0)
    last.follow(behind.trail, lag=5.0, standstill=10.0)
    gcs, texts = Gcs(lead), list[str]()

    def step_behind(now: float) -> None:
        texts.extend(m.text for m in behind.step(now, 0.01) if m.get_type() == "STATUSTEXT")
        last.step(now, 0.01)

    gcs.run(160.0, telemetry=False, every=step_behind)  # (on the second leg, going east)
    was = behind.truth(gcs.now)
    assert was.north == pytest.approx(1000.0) and was.speed == pytest.approx(8.0, abs=0.1)
    operator = Gcs(behind, now=gcs.now)

    def tell(mode: int) -> None:
        operator.now = gcs.now
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        (ack,) = operator.send(mavlink.MAVLink_set_mode_message(12, flag, mode))
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED

    tell(_RTL[Personality.ARDUPILOT])
    speeds = []
    for _ in range(20):  # (braking on its way at its accel from the speed it had: no jump)
        gcs.run(0.5, telemetry=False, every=step_behind)
        speeds.append(behind.truth(gcs.now).speed)
    steps = [abs(b - a) for a, b in itertools.pairwise([was.speed, *speeds])]
    assert max(steps) <= 0.5 * 1.0 + 1e-6 and min(speeds) < 3.0, speeds
    gcs.run(200.0, telemetry=False, every=step_behind)
    home, there = behind.truth(gcs.now), gcs.truth()
    hn, he, _ = WORLD.to_ned(behind.flight.home)
    assert math.hypot(home.north - hn, home.east - he) <= 2.0 and home.speed == 0.0, home
    assert home.mode == "RTL" and texts == ["Reached destination"], texts
    assert there.mode == "AUTO" and there.speed > 0.0  # (its leader drove on)
    on = last.truth(gcs.now)  # (the one behind it: where the leader was 10 s before)
    assert math.hypot(on.north - hn, on.east - he) > 500.0 and on.speed > 0.0, on
    assert last.follower is not None and last.follower.trail is lead.trail
    assert last.follower.s == pytest.approx(lead.trail.s_at(gcs.now - 10.0), abs=1.0)
    tell(10)  # (AUTO)
    gcs.run(60.0, telemetry=False, every=step_behind)
    off = behind.truth(gcs.now)
    assert off.mode == "AUTO" and off.speed > 2.0, off
    assert math.hypot(off.north - hn, off.east - he) > 100.0  # (on along its mission)


@settings(max_examples=80, deadline=None)
@given(
    st.floats(-2000.0, 2000.0),
    st.floats(-2000.0, 2000.0),
    st.floats(0.0, math.tau),
    st.floats(0.0, 15.0),
)
def test_the_road_home_starts_along_its_way_and_ends_at_home(
    north: float, east: float, heading: float, speed: float
) -> None:
    velocity = (speed * math.cos(heading), speed * math.sin(heading))
    road, arc = road_home((north, east), velocity, (0.0, 0.0), 8.0, 1.0, 2.0)
    assert road.position(road.time_at(arc)) == pytest.approx((north, east), abs=1e-6)
    assert road.position(1e6) == pytest.approx((0.0, 0.0), abs=1e-6)  # (it ends at home)
    points = road.vertices
    if arc > 0.0:  # (moving: the road goes its way a metre behind it and ahead of it)
        for n, e in points[: 3 if len(points) == 4 else 2]:
            along = (n - north) * velocity[0] + (e - east) * velocity[1]
            assert along / speed == pytest.approx(
                math.copysign(math.hypot(n - north, e - east), along), abs=1e-6
            )
    if len(points) == 4:  # (a turn to brake for first: no further than v^2/2a and a jerk)
        assert math.dist(points[2], (north, east)) <= speed * speed / 2.0 + speed + 1e-6


REL, POINT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_RALLY_POINT
RALLY = mavlink.MAV_MISSION_TYPE_RALLY


def _rally(*points: tuple[float, float]) -> list[mavlink.MAVLink_mission_item_int_message]:
    """Rally points at (north, east), as a ground station uploads them."""
    out = []
    for seq, (north, east) in enumerate(points):
        at = WORLD.to_geo(north, east, 0.0)
        x, y = round(at.lat * 1e7), round(at.lon * 1e7)
        out.append(
            mavlink.MAVLink_mission_item_int_message(
                11, 1, seq, REL, POINT, 0, 0, 0.0, 0.0, 0.0, 0.0, x, y, 0.0, RALLY
            )
        )
    return out


def _param(gcs: Gcs, name: str, value: float | None = None) -> float:
    """PARAM_SET (with ``value``) or PARAM_REQUEST_READ: the value it answers."""
    real = mavlink.MAV_PARAM_TYPE_REAL32
    msg = (
        mavlink.MAVLink_param_request_read_message(11, 1, name.encode(), -1)
        if value is None
        else mavlink.MAVLink_param_set_message(11, 1, name.encode(), value, real)
    )
    (answer,) = [m for m in gcs.send(msg) if m.get_type() == "PARAM_VALUE"]
    return float(answer.param_value)


def test_an_ardurover_keeps_rally_points_and_gives_them_back() -> None:
    gcs = Gcs(rover(Personality.ARDUPILOT, LAP))
    rally = mavlink.MAV_MISSION_TYPE_RALLY
    points = _rally((1000.0, 350.0), (-900.0, 0.0))
    upload(gcs, points, rally)
    assert _param(gcs, "RALLY_TOTAL") == 2.0
    assert (_param(gcs, "RALLY_LIMIT_KM"), _param(gcs, "RALLY_INCL_HOME")) == (0.5, 1.0)
    (count,) = gcs.send(mavlink.MAVLink_mission_request_list_message(11, 1, rally))
    assert (count.count, count.mission_type) == (2, rally)
    for sent in points:
        (got,) = gcs.send(mavlink.MAVLink_mission_request_int_message(11, 1, sent.seq, rally))
        assert (got.seq, got.command, got.x, got.y) == (sent.seq, sent.command, sent.x, sent.y)
    # Not a rally point, refused; a count of none clears them; not on PX4's rovers.
    wrong = _rally((0.0, 0.0))[0]
    wrong.command = mavlink.MAV_CMD_NAV_WAYPOINT
    gcs.send(mavlink.MAVLink_mission_count_message(11, 1, 1, rally))
    (ack,) = gcs.send(wrong)
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED
    gcs.send(mavlink.MAVLink_mission_count_message(11, 1, 0, rally))
    assert _param(gcs, "RALLY_TOTAL") == 0.0
    with pytest.raises(ValueError, match="0 or 1"):
        gcs.vehicle._set_knob(Knob.RALLY_INCL_HOME, 0.5)
    px4 = Gcs(rover(Personality.PX4, LAP))
    (ack,) = px4.send(mavlink.MAVLink_mission_count_message(11, 1, 1, rally))
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED


@pytest.mark.parametrize(
    ("limit_km", "goes"),
    [(0.5, (1000.0, 350.0)), (0.05, None)],  # (the point ~120 m off; beyond 50 m: home)
)
def test_an_ardurover_in_rtl_drives_to_its_nearest_rally_point_within_its_limit(
    limit_km: float, goes: tuple[float, float] | None
) -> None:
    gcs = Gcs(rover(Personality.ARDUPILOT, LAP))
    upload(gcs, _rally((1000.0, 350.0), (-900.0, 0.0)), mavlink.MAV_MISSION_TYPE_RALLY)
    assert _param(gcs, "RALLY_LIMIT_KM", limit_km) == pytest.approx(limit_km)
    gcs.run(160.0, telemetry=False)  # (on the second leg, 1000 m north, ~230 m east)
    was = gcs.truth()
    assert 100.0 < math.hypot(was.north - 1000.0, was.east - 350.0) < 150.0
    _rtl(gcs, Personality.ARDUPILOT)
    path, texts = _drive(gcs, 200.0)
    n, e, speed = path[-1]
    goal = goes or _home(gcs)
    assert math.hypot(n - goal[0], e - goal[1]) <= 2.0 and speed == 0.0, (was, path[-1])
    assert texts.count("Reached destination") == 1
