"""A mission a ground station uploads to a mock rover (``sitl_mock.uploaded``): kept as
sent, read back as the firmware numbers it, driven in AUTO as ArduRover runs it; and AUTO
refused without one."""

from __future__ import annotations

import itertools
import math

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint
from convoy_mav.tracks.missionroute import mission_route
from sitl_mock import uploaded
from sitl_mock.autopilot import Personality, SimVehicle, VehicleSpec
from sitl_mock.ground import Polyline
from sitl_mock.uploaded import CHUNK, UploadedMission
from tests.fakes import WORLD, Gcs, Msg, make_vehicle, of_type, texts
from tests.unit.test_mock_driveclock import _mode
from tests.unit.test_mock_mission import read_mission, rover

MISSION = mavlink.MAV_MISSION_TYPE_MISSION
WP = mavlink.MAV_CMD_NAV_WAYPOINT
SPEED = mavlink.MAV_CMD_DO_CHANGE_SPEED
JUMP = mavlink.MAV_CMD_DO_JUMP
RTL = mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
AP, PX4 = Personality.ARDUPILOT, Personality.PX4


def wp(north: float, east: float, hold: float = 0.0) -> tuple[int, int, float, float, GeoPoint]:
    return WP, REL, hold, 0.0, WORLD.to_geo(north, east, 0.0)


def do(command: int, p1: float, p2: float) -> tuple[int, int, float, float, GeoPoint]:
    return command, mavlink.MAV_FRAME_MISSION, p1, p2, GeoPoint(0.0, 0.0, 0.0)


def items(plan: list[tuple[int, int, float, float, GeoPoint]], *, home_first: bool) -> list[Msg]:
    """The plan as MISSION_ITEM_INTs, numbered as the firmware does (ArduPilot: home
    first, here a dummy a ground station sends)."""
    if home_first:
        plan = [wp(0.0, 0.0), *plan]
    return [item(seq, *entry) for seq, entry in enumerate(plan)]


def item(seq: int, command: int, frame: int, p1: float, p2: float, where: GeoPoint) -> Msg:
    return mavlink.MAVLink_mission_item_int_message(
        11, 1, seq, frame, command, 0, 1, p1, p2, 0.0, 0.0,
        round(where.lat * 1e7), round(where.lon * 1e7), 0.0, MISSION,
    )  # fmt: skip


def upload(gcs: Gcs, sent: list[Msg], kind: int = MISSION) -> list[Msg]:
    """The upload in turn (of ``kind``), each answer checked; the last replies."""
    replies = gcs.send(mavlink.MAVLink_mission_count_message(11, 1, len(sent), kind))
    (request,) = of_type(replies, "MISSION_REQUEST_INT")
    assert request.seq == 0
    for item in sent:
        replies = gcs.send(item)
        nxt = of_type(replies, "MISSION_REQUEST_INT")
        if item is not sent[-1]:
            assert [r.seq for r in nxt] == [item.seq + 1], replies
    (ack,) = of_type(replies, "MISSION_ACK")
    assert (ack.type, ack.mission_type) == (mavlink.MAV_MISSION_ACCEPTED, kind)
    return replies


def current_seq(gcs: Gcs) -> int:
    request = mavlink.MAV_CMD_REQUEST_MESSAGE
    _, (current,) = gcs.command(request, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)
    return int(current.seq)


def parked(personality: Personality) -> Gcs:
    spec = VehicleSpec(sysid=11, kind="ground", personality=personality, home=WORLD.to_geo(0, 0))
    gcs = Gcs(SimVehicle(spec, WORLD, 0.0))
    gcs.run(5.0, telemetry=False)
    return gcs


def set_mode(gcs: Gcs, personality: Personality, name: str) -> tuple[Msg, list[Msg]]:
    custom = {AP: {"AUTO": 10, "HOLD": 4}, PX4: {"AUTO": (4 << 16) | (4 << 24)}}[personality]
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    (ack, *rest) = gcs.send(mavlink.MAVLink_set_mode_message(11, flag, custom[name]))
    return ack, rest


PLAN = [wp(300.0, 0.0, hold=10.0), do(SPEED, 1.0, 4.0), wp(300.0, 300.0), wp(0.0, 300.0)]


@pytest.mark.parametrize("personality", [AP, PX4])
def test_a_parked_rover_refuses_auto_until_a_mission_is_uploaded_then_drives_it(
    personality: Personality,
) -> None:
    gcs = parked(personality)
    ack, rest = set_mode(gcs, personality, "AUTO")
    if personality is AP:  # (ArduRover ModeAuto::_enter, then Rover::set_mode)
        assert ack.result == mavlink.MAV_RESULT_FAILED
        assert texts(rest) == ["No Mission. Can't set AUTO.", "Flight mode change failed"]
    else:
        assert ack.result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    ardupilot = personality is AP
    sent = items(PLAN, home_first=ardupilot)
    upload(gcs, sent)
    assert gcs.vehicle.counters["mission_uploads"] == 1
    # Read back as sent (ArduPilot's item 0: its own home), as the service reads it.
    watch, got = read_mission(gcs)
    route = mission_route(got, home_first=watch.ardupilot)
    assert [(round(a, 6), round(b, 6)) for a, b in route.points][-3:] == [
        (round(g.lat, 6), round(g.lon, 6)) for g in (p[4] for p in (PLAN[0], PLAN[2], PLAN[3]))
    ]
    assert route.holds[-1][1] == 10.0 and route.speeds[-1][1] == 4.0
    _mode(gcs, personality, "AUTO")
    gcs.run(60.0, telemetry=False)  # (300 m at 2 m/s, WP_SPEED's default: not there yet)
    row = gcs.truth()
    assert row.speed == pytest.approx(2.0) and 100.0 < row.north < 125.0
    assert row.east == pytest.approx(0.0, abs=0.05)
    gcs.run(95.0, telemetry=False)  # (at the first waypoint from 152 s, held 10 s)
    held = gcs.truth()
    assert held.north == pytest.approx(300.0, abs=0.05) and held.speed == 0.0
    assert current_seq(gcs) == sent[ardupilot].seq  # (held at the first waypoint: its item)
    gcs.run(20.0, telemetry=False)  # (then at the 4 m/s of the DO_CHANGE_SPEED)
    assert gcs.truth().speed == pytest.approx(4.0) and gcs.truth().east > 10.0
    assert current_seq(gcs) == sent[ardupilot + 2].seq
    gcs.run(200.0, telemetry=False)  # (at the last waypoint: stands)
    end = gcs.truth()
    assert end.north == pytest.approx(0.0, abs=0.05) and end.speed == 0.0
    assert end.east == pytest.approx(300.0, abs=0.05)


@pytest.mark.parametrize("personality", [AP, PX4])
def test_unknown_commands_bad_parameters_and_other_frames_are_refused_and_end_the_upload(
    personality: Personality,
) -> None:
    gcs = parked(personality)
    ardupilot = personality is AP
    local = (WP, mavlink.MAV_FRAME_LOCAL_NED, 0.0, 0.0, WORLD.to_geo(100.0, 0.0))
    for bad, result in (
        (do(65000, 0.0, 0.0), mavlink.MAV_MISSION_UNSUPPORTED),
        (do(JUMP, 1.0, math.nan), mavlink.MAV_MISSION_INVALID_PARAM2),
        (do(SPEED, math.inf, 4.0), mavlink.MAV_MISSION_INVALID_PARAM1),
        (local, mavlink.MAV_MISSION_UNSUPPORTED_FRAME),
    ):
        sent = items([wp(100.0, 0.0), bad], home_first=ardupilot)
        gcs.send(mavlink.MAVLink_mission_count_message(11, 1, len(sent), MISSION))
        for one in sent[:-1]:
            gcs.send(one)
        (ack,) = of_type(gcs.send(sent[-1]), "MISSION_ACK")
        assert ack.type == result
        again = of_type(gcs.send(sent[-1]), "MISSION_ACK")  # (the upload has ended)
        assert again[0].type == mavlink.MAV_MISSION_ERROR
    assert gcs.vehicle.mission is None and gcs.vehicle.counters["mission_uploads"] == 0
    assert set_mode(gcs, personality, "AUTO")[0].result != mavlink.MAV_RESULT_ACCEPTED


def test_commands_a_rover_has_no_use_for_are_kept_and_driven_past() -> None:
    gcs = parked(AP)
    land = do(mavlink.MAV_CMD_NAV_LAND, 0.0, 0.0)
    sent = items([wp(100.0, 0.0), land, wp(100.0, 100.0)], home_first=True)
    upload(gcs, sent)
    mission = gcs.vehicle.mission
    assert isinstance(mission, UploadedMission) and mission.skipped == 1
    assert mission.seqs == (1, 1, 3)
    _, got = read_mission(gcs)
    assert [i.command for i in got] == [WP, WP, mavlink.MAV_CMD_NAV_LAND, WP]


def test_an_aircraft_still_takes_no_mission() -> None:
    gcs = Gcs(make_vehicle(PX4, "plane"))
    (ack,) = gcs.send(mavlink.MAVLink_mission_count_message(1, 1, 3, MISSION))
    assert ack.type == mavlink.MAV_MISSION_UNSUPPORTED


@pytest.mark.parametrize("personality", [AP, PX4])
def test_a_mission_uploaded_to_a_rover_driving_its_road_takes_over_where_it_is(
    personality: Personality,
) -> None:
    """The new mission is driven from where the rover is, at the speed it has: ArduRover
    goes on at the item it was driving to (``restart_current_nav_cmd``), PX4 at its first."""
    gcs = Gcs(rover(personality, Polyline(((0.0, 0.0), (2000.0, 0.0)), speed=8.0, accel=1.0)))
    gcs.run(30.0, telemetry=False)
    before = gcs.truth()
    ardupilot = personality is AP
    at = current_seq(gcs)  # (the second waypoint's item: 2 on ArduPilot, home first; PX4 1)
    plan = [wp(before.north, 400.0), wp(1000.0, 400.0), wp(1000.0, 800.0)]
    sent = items(plan, home_first=ardupilot)
    replies = upload(gcs, sent)
    if ardupilot:
        assert texts(replies) == ["Flight plan received", "Auto mission changed, restarted command"]
    goal = plan[at - ardupilot][4]  # (ArduRover: item ``at`` again; PX4: its first)
    goal = plan[0][4] if not ardupilot else goal
    rows = [gcs.truth()]
    for _ in range(40):
        gcs.run(0.5, telemetry=False)
        rows.append(gcs.truth())
    for a, b in itertools.pairwise(rows):
        moved = math.hypot(b.north - a.north, b.east - a.east)
        assert moved <= 0.5 * (max(a.speed, b.speed) + 0.25) + 1e-6
        assert abs(b.speed - a.speed) <= 0.5 * 1.0 + 1e-6
    assert rows[0].north == pytest.approx(before.north, abs=0.1)
    n, e, _ = WORLD.to_ned(goal)
    heading = math.atan2(e - rows[-1].east, n - rows[-1].north)
    assert math.atan2(rows[-1].ve, rows[-1].vn) == pytest.approx(heading, abs=0.01)
    assert current_seq(gcs) == (at if ardupilot else 0)


@pytest.mark.parametrize("personality", [AP, PX4])
def test_a_mission_cleared_leaves_the_rover_standing_and_auto_refused(
    personality: Personality,
) -> None:
    gcs = Gcs(rover(personality, Polyline(((0.0, 0.0), (2000.0, 0.0)), speed=8.0, accel=1.0)))
    gcs.run(20.0, telemetry=False)
    replies = gcs.send(mavlink.MAVLink_mission_count_message(11, 1, 0, MISSION))
    assert of_type(replies, "MISSION_ACK")[0].type == mavlink.MAV_MISSION_ACCEPTED
    if personality is AP:  # (as ArduRover SITL: the mission it ran is gone)
        assert "Auto mission changed but failed to restart command" in texts(replies)
    gcs.run(15.0, telemetry=False)  # (from 8 m/s at 1 m/s^2)
    assert gcs.truth().speed == 0.0
    _mode(gcs, personality, "HOLD")
    assert set_mode(gcs, personality, "AUTO")[0].result != mavlink.MAV_RESULT_ACCEPTED
    (count,) = gcs.send(mavlink.MAVLink_mission_request_list_message(11, 1, MISSION))
    assert count.count == 0


def test_jumps_are_driven_as_the_items_come_and_a_return_goes_home() -> None:
    home = WORLD.to_geo(0.0, 0.0)
    laps = [wp(100.0, 0.0), wp(100.0, 100.0, hold=5.0), do(JUMP, 1.0, 2.0), do(RTL, 0.0, 0.0)]
    mission = UploadedMission.of(
        items(laps, home_first=True), home_first=True, world=WORLD, start=(0.0, 0.0),
        home=home, speed=5.0, accel=1.0,
    )  # fmt: skip
    drive = mission.drive
    assert drive is not None
    # Here, then three passes of the two waypoints (the jump made twice), then home.
    passes = [(100, 0), (100, 100)] * 3
    assert [tuple(round(c) for c in v) for v in drive.vertices] == [(0, 0), *passes, (0, 0)]
    assert mission.seqs == (1, 1, 2, 1, 2, 1, 2, 4)
    assert sorted(drive.vertex_holds) == [2, 4, 6]
    assert mission.current(0.0, home_first=True) == 1
    assert mission.current(drive.arrivals[2] + 1.0, home_first=True) == 2  # (holding there)
    assert mission.current(drive.arrivals[-1] + 1.0, home_first=True) == 4
    forever = [wp(100.0, 0.0), wp(100.0, 100.0), do(JUMP, 0.0, -1.0)]
    patrol = UploadedMission.of(
        items(forever, home_first=False), home_first=False, world=WORLD, start=(0.0, 0.0),
        home=home, speed=5.0, accel=1.0,
    )  # fmt: skip
    assert patrol.drive is not None and len(patrol.drive.vertices) == CHUNK + 1
    assert patrol.more and patrol.resume[-1] == (1, ((2, CHUNK // 2 - 1),))
    here = [wp(100.0, 0.0), do(mavlink.MAV_CMD_NAV_LOITER_TIME, 7.0, 0.0), wp(300.0, 0.0)]
    held = UploadedMission.of(
        items(here, home_first=False), home_first=False, world=WORLD, start=(0.0, 0.0),
        home=home, speed=5.0, accel=1.0,
    )  # fmt: skip
    assert held.drive is not None and held.drive.vertex_holds == {1: 7.0}
    assert held.seqs == (0, 0, 2)  # (a hold "here" is at the waypoint driven to before it)


def test_ardurover_with_its_mission_over_takes_a_new_one_when_auto_is_entered_again() -> None:
    """AUTO with the mission complete: ``AP_Mission`` runs no new one until AUTO is entered
    again (``start_or_resume``, a mission over starts from its first item)."""
    gcs = Gcs(rover(AP, Polyline(((0.0, 0.0), (200.0, 0.0)), speed=8.0, accel=1.0)))
    gcs.run(60.0, telemetry=False)
    assert gcs.truth().north == pytest.approx(200.0) and gcs.truth().speed == 0.0
    replies = upload(gcs, items([wp(200.0, 200.0)], home_first=True))
    assert texts(replies) == ["Flight plan received"]  # (no command running to restart)
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().speed == 0.0 and gcs.truth().east == pytest.approx(0.0, abs=1e-6)
    _mode(gcs, AP, "HOLD")
    gcs.run(1.0, telemetry=False)
    _mode(gcs, AP, "AUTO")
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().east > 20.0 and current_seq(gcs) == 1


@pytest.mark.parametrize("personality", [AP, PX4])
def test_mission_start_is_auto_and_needs_a_mission(personality: Personality) -> None:
    """MAV_CMD_MISSION_START (what MAVSDK's ``start_mission`` sends ArduPilot): ArduRover
    sets AUTO (``GCS_MAVLINK_Rover``: first and last item must be 0); PX4 switches to its
    mission and arms, and denies it without one."""
    gcs = parked(personality)
    start = mavlink.MAV_CMD_MISSION_START
    ack, rest = gcs.command(start)
    if personality is AP:
        assert ack.result == mavlink.MAV_RESULT_FAILED
        assert texts(rest) == ["No Mission. Can't set AUTO.", "Flight mode change failed"]
        assert gcs.command(start, 1.0)[0].result == mavlink.MAV_RESULT_DENIED
    else:
        assert ack.result == mavlink.MAV_RESULT_DENIED
        assert texts(rest) == ["Mission start denied! No valid mission"]
    upload(gcs, items([wp(100.0, 0.0)], home_first=personality is AP))
    assert gcs.command(start)[0].result == mavlink.MAV_RESULT_ACCEPTED
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().mode in ("AUTO", "AUTO.MISSION") and gcs.truth().north > 20.0


def test_ardurover_going_on_in_a_changed_mission_keeps_the_speed_it_was_set_to() -> None:
    """``restart_current_nav_cmd`` runs no DO command again: the rover on its mission's 6
    m/s stretch keeps 6 m/s in the new mission until a DO_CHANGE_SPEED of its own."""
    points = ((0.0, 0.0), (300.0, 0.0), (2000.0, 0.0))
    road = Polyline(points, speed=8.0, accel=1.0, speeds=((0, 8.0), (1, 6.0)))
    gcs = Gcs(rover(AP, road))
    gcs.run(80.0, telemetry=False)  # (past the first corner: 6 m/s)
    assert gcs.truth().speed == pytest.approx(6.0)
    vehicle = gcs.vehicle
    mission = vehicle.mission
    assert mission is not None
    home, count = vehicle.flight.home, mission.count(home_first=True)
    sent = [mission.item(seq, home, (11, 1), home_first=True) for seq in range(count)]
    replies = upload(gcs, [m for m in sent if m is not None])
    assert "Auto mission changed, restarted command" in texts(replies)
    gcs.run(20.0, telemetry=False)
    assert gcs.truth().speed == pytest.approx(6.0)


def test_mission_clear_all_clears_it_as_an_upload_of_none() -> None:
    """QGroundControl's and MAVSDK's clear: MISSION_CLEAR_ALL, answered by MISSION_ACK."""
    gcs = parked(AP)
    upload(gcs, items(PLAN, home_first=True))
    replies = gcs.send(mavlink.MAVLink_mission_clear_all_message(11, 1, MISSION))
    (ack,) = of_type(replies, "MISSION_ACK")
    assert (ack.type, ack.target_system) == (mavlink.MAV_MISSION_ACCEPTED, 255)
    assert gcs.vehicle.mission is None
    assert set_mode(gcs, AP, "AUTO")[0].result == mavlink.MAV_RESULT_FAILED


def test_a_patrol_for_ever_is_laid_a_chunk_at_a_time_and_driven_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The next waypoints laid from where the rover is before it gets to the last laid:
    no stop, no jump, at the accel or gentler, MISSION_CURRENT round the lap."""
    monkeypatch.setattr(uploaded, "CHUNK", 12)
    gcs = parked(AP)
    lap = [wp(100.0, 0.0), wp(100.0, 100.0), wp(0.0, 100.0), wp(0.0, 0.0)]
    upload(gcs, items([do(SPEED, 1.0, 5.0), *lap, do(JUMP, 2.0, -1.0)], home_first=True))
    _mode(gcs, AP, "AUTO")
    rows, seqs = [gcs.truth()], []
    for _ in range(500):  # (250 s: 1250 m, three laps and more)
        gcs.run(0.5, telemetry=False)
        rows.append(gcs.truth())
        seqs.append(current_seq(gcs))
    for a, b in itertools.pairwise(rows):
        moved = math.hypot(b.north - a.north, b.east - a.east)
        assert moved <= 0.5 * (max(a.speed, b.speed) + 0.25) + 1e-6
        assert abs(b.speed - a.speed) <= 0.5 * 1.0 + 1e-6
    assert gcs.vehicle.counters["mission_laid"] >= 2
    assert all(r.speed > 1.0 for r in rows[40:])  # (its corners slowed for, never a stop)
    assert set(seqs[100:]) == {2, 3, 4, 5}  # (round the lap: the jump back to item 2)
