"""The mock rover's mission (``sitl_mock.mission``): its road thinned to waypoints, served
over the mission protocol as each firmware numbers it, its progress in MISSION_CURRENT;
and the service's own reader taking it, through MAVLink bytes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import ConfigError
from convoy_mav.mavlink.missionread import MissionWatch
from convoy_mav.tracks.missionroute import mission_route
from sitl_mock.autopilot import Personality, SimVehicle, VehicleSpec
from sitl_mock.config import MockConfig
from sitl_mock.ground import Polyline, StraightLine, Track
from sitl_mock.mission import RoverMission, thin
from tests.fakes import WORLD, Gcs, of_type

CORNERS = ((0.0, 0.0), (400.0, 0.0), (400.0, 300.0), (0.0, 300.0))
MISSION = mavlink.MAV_MISSION_TYPE_MISSION


def rover(personality: Personality, route: Any = None, *, mission: bool = True) -> SimVehicle:
    route = route or Polyline(CORNERS, speed=10.0)
    spec = VehicleSpec(
        sysid=11,
        kind="ground",
        personality=personality,
        home=WORLD.to_geo(*route.position(0.0)),
        route=route,
        mission=mission,
    )
    return SimVehicle(spec, WORLD, 0.0)


def test_thinning_keeps_the_corners_and_drops_jitter_along_a_straight() -> None:
    rng = np.random.default_rng(1)
    straight = [(float(x), float(rng.normal(0.0, 0.8))) for x in range(0, 200, 5)]
    corner = [(200.0, float(y)) for y in range(5, 200, 5)]
    points = straight + corner
    kept = thin(points, 3.0)
    assert kept[0] == 0 and kept[-1] == len(points) - 1
    assert len(straight) in kept or len(straight) - 1 in kept  # the corner
    assert len(kept) <= 5
    assert thin(points[:2], 3.0) == [0, 1]


def read_mission(gcs: Gcs) -> tuple[MissionWatch, list[Any]]:
    """The service's MissionWatch reading the rover's mission through ``gcs``, as the
    service asks for it (MISSION_CURRENT at 1 Hz, then the read): the watch and the items."""
    watch = MissionWatch(11)
    interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
    gcs.command(interval, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, 1e6)
    for msg in gcs.run(2.0):
        watch.handle(msg, gcs.now, gcs.now)
    sent = watch.poll(gcs.now, gcs.now)
    while sent:
        sent = [
            out for msg in sent for reply in gcs.send(msg) for out in watch.handle(reply, 0.0, 0.0)
        ]
    read = watch.take()
    assert read is not None and read.items is not None
    return watch, list(read.items)


def test_a_polyline_is_its_corners_and_a_loop_comes_back_to_the_first() -> None:
    mission = RoverMission.of(Polyline(CORNERS, speed=10.0), WORLD)
    assert mission is not None and len(mission.waypoints) == 4
    assert mission.times == pytest.approx((0.0, 40.0, 70.0, 110.0))
    lap = RoverMission.of(Polyline(CORNERS, speed=10.0, loop=True), WORLD)
    assert lap is not None and lap.laps and len(lap.waypoints) == 5
    assert lap.current(150.0 + 5.0, home_first=False) == 1  # (a lap is 140 s)
    assert RoverMission.of(StraightLine(0.0, 0.0, 5.0, 0.0), WORLD) is None


def test_a_track_is_thinned_to_where_it_turns() -> None:
    t = np.arange(0.0, 101.0)
    north = np.where(t <= 50, 8.0 * t, 400.0)
    east = np.where(t <= 50, 0.0, 8.0 * (t - 50))
    mission = RoverMission.of(Track(tuple(t), tuple(north), tuple(east)), WORLD)
    assert mission is not None
    assert mission.times == (0.0, 50.0, 100.0)


@pytest.mark.parametrize(
    ("personality", "home_first"), [(Personality.ARDUPILOT, True), (Personality.PX4, False)]
)
def test_the_mission_is_served_as_the_firmware_numbers_it(
    personality: Personality, home_first: bool
) -> None:
    gcs = Gcs(rover(personality))
    (n,) = gcs.send(mavlink.MAVLink_mission_request_list_message(11, 1, MISSION))
    assert (n.get_type(), n.count) == ("MISSION_COUNT", 4 + home_first)
    (first,) = gcs.send(mavlink.MAVLink_mission_request_int_message(11, 1, 0, MISSION))
    assert first.get_type() == "MISSION_ITEM_INT" and first.command == mavlink.MAV_CMD_NAV_WAYPOINT
    home_frame = (
        mavlink.MAV_FRAME_GLOBAL if home_first else mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    )
    assert first.frame == home_frame
    (last,) = gcs.send(mavlink.MAVLink_mission_request_int_message(11, 1, 3 + home_first, MISSION))
    corner = WORLD.to_geo(*CORNERS[3])
    assert (last.x, last.y) == (round(corner.lat * 1e7), round(corner.lon * 1e7))
    (legacy,) = gcs.send(mavlink.MAVLink_mission_request_message(11, 1, 1, MISSION))
    assert legacy.get_type() == "MISSION_ITEM"  # the float form's answer
    (past,) = gcs.send(mavlink.MAVLink_mission_request_int_message(11, 1, 9, MISSION))
    assert (past.get_type(), past.type) == ("MISSION_ACK", mavlink.MAV_MISSION_INVALID_SEQUENCE)
    # MISSION_CURRENT: the waypoint being driven to, of a total without home (asked for:
    # ArduPilot streams nothing unasked, as the service asks it).
    interval = mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
    assert gcs.command(interval, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, 1e6)[0].result == 0
    msgs = gcs.run(45.0)
    now = of_type(msgs, "MISSION_CURRENT")[-1]
    assert (now.seq, now.total) == (2 + home_first, 4)


def test_a_rover_without_a_mission_has_none_to_give() -> None:
    gcs = Gcs(rover(Personality.ARDUPILOT, mission=False))
    (n,) = gcs.send(mavlink.MAVLink_mission_request_list_message(11, 1, MISSION))
    assert n.count == 0
    assert of_type(gcs.run(3.0), "MISSION_CURRENT") == []


@pytest.mark.parametrize("loop", [False, True])
@pytest.mark.parametrize("personality", [Personality.ARDUPILOT, Personality.PX4])
def test_the_services_reader_takes_the_rovers_road(personality: Personality, loop: bool) -> None:
    """The service's MissionWatch against the mock rover, through MAVLink bytes: the
    route it makes is the road's corners (from home, on ArduPilot: the first corner); a
    looping road's is a circuit, its lap closed and a DO_JUMP back to the first corner."""
    gcs = Gcs(rover(personality, Polyline(CORNERS, speed=10.0, loop=loop)))
    watch, items = read_mission(gcs)
    route = mission_route(items, home_first=watch.ardupilot, default_speed=watch.default_speed)
    assert watch.ardupilot is (personality is Personality.ARDUPILOT)
    corners = [WORLD.to_geo(*c) for c in CORNERS + CORNERS[:1] * loop]
    assert route.circuit is loop and route.laps is loop
    # ArduPilot's WP_SPEED (the polyline's 10 m/s) asked alongside: its planned speed.
    assert route.speeds == (((0, 10.0),) if personality is Personality.ARDUPILOT else ())
    assert [(round(a, 6), round(b, 6)) for a, b in route.points] == [
        (round(c.lat, 6), round(c.lon, 6)) for c in corners
    ]
    for msg in gcs.run(3.0):  # its MISSION_CURRENT agrees: no second read
        watch.handle(msg, gcs.now, gcs.now)
    assert watch.poll(gcs.now + 100.0, gcs.now + 100.0) == []


def test_only_a_ground_vehicle_with_a_road_has_a_mission() -> None:
    with pytest.raises(ValueError, match="only ground vehicles"):
        VehicleSpec(sysid=1, kind="aircraft", home=WORLD.to_geo(0.0, 0.0), mission=True)
    with pytest.raises(ConfigError, match="needs a road"):
        MockConfig.simple(1, ground=1, ground_route="line", ground_speed=5.0, ground_mission=True)
    config = MockConfig.simple(
        1, ground=2, ground_route="polyline", ground_points=[[0, 0], [500, 0]],
        ground_speed=5.0, ground_mission=True,
    )  # fmt: skip
    missions = [v.mission for v in config.vehicles if v.kind == "ground"]
    assert missions == [True, False]  # the lead's
    assert math.isfinite(config.vehicles[-1].warmup_s)


def test_a_tracks_stands_are_its_missions_holds() -> None:
    """A track standing 40 s at its corner: the mission holds there 40 s (param1), and
    MISSION_CURRENT stays on that waypoint while it stands."""
    t = np.arange(0.0, 141.0)
    north = np.clip(8.0 * t, 0.0, 400.0)
    east = np.where(t <= 90, 0.0, 8.0 * (t - 90))
    mission = RoverMission.of(Track(tuple(t), tuple(north), tuple(east)), WORLD)
    assert mission is not None
    assert mission.times == (0.0, 50.0, 140.0) and mission.holds == (0.0, 40.0, 0.0)
    item = mission.item(1, WORLD.to_geo(0.0, 0.0), (255, 190), home_first=False)
    assert item is not None and item.param1 == 40.0
    assert [mission.current(s, home_first=False) for s in (49.0, 70.0, 91.0)] == [1, 1, 2]
