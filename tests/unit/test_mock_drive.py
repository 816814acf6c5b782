"""A mock rover driving its polyline as AUTO does (``sitl_mock.drive``): corners braked
for, holds stood, speeds changed; and its mission saying so over MAVLink."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import ConfigError
from convoy_mav.tracks.missionroute import mission_route
from sitl_mock.autopilot import Personality
from sitl_mock.config import MockConfig
from sitl_mock.drive import Ramps, corner_speed
from sitl_mock.ground import Polyline
from sitl_mock.mission import RoverMission
from tests.fakes import WORLD, Gcs
from tests.unit.test_mock_mission import read_mission, rover

GRID = ((0.0, 0.0), (200.0, 0.0), (200.0, 200.0), (0.0, 200.0))
ROVER = Ramps(1.0, 1.0)  # ArduRover's ATC_ACCEL_MAX, and WP_JERK 0
STEP = 0.05


def speeds_along(route: Polyline, until: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, positions and speeds every STEP seconds."""
    t = np.arange(STEP, until, STEP)
    pos = np.array([route.position(x) for x in t])
    v = np.array([math.hypot(*route.velocity(x)) for x in t])
    return t, pos, v


def test_the_corner_speed_is_the_scurve_blends_within_wp_radius() -> None:
    """ArduRover's defaults (1 m/s², 2 m): 2.38 m/s at a 90° corner between long legs,
    slower the sharper, none on a straight; a corner drawn with short legs is taken no
    faster than such a leg is driven from rest to rest (SITL: 2.0-2.8 m/s)."""
    assert corner_speed(math.pi / 2, ROVER, 2.0) == pytest.approx(2.378, abs=1e-3)
    assert corner_speed(math.pi, ROVER, 2.0) == pytest.approx(0.0, abs=1e-9)  # (turns back)
    assert corner_speed(0.0, ROVER, 2.0) == math.inf
    assert corner_speed(math.pi / 2, Ramps(math.inf, math.inf), 2.0) == math.inf
    sharper = [corner_speed(math.radians(a), ROVER, 2.0) for a in (20, 45, 90, 135)]
    assert sharper == sorted(sharper, reverse=True)
    assert corner_speed(-math.pi / 2, ROVER, 2.0) == corner_speed(math.pi / 2, ROVER, 2.0)
    short = corner_speed(math.radians(45), ROVER, 2.0, leg=8.4)
    assert short == pytest.approx(ROVER.peak(0.0, 0.0, 8.4, math.inf)) and 2.3 < short < 2.6
    # the curve a 60-m leg turning 90° draws (a radius of 42 m): the blend still binds
    assert corner_speed(math.pi / 2, ROVER, 2.0, leg=60.0) == pytest.approx(2.378, abs=1e-3)


def test_a_speed_changes_as_an_s_curve() -> None:
    """``dv / a + a / j`` for a change that reaches the accel, ``2 sqrt(dv / j)`` for one
    that does not; the distance is the mean speed's; ``fastest`` and ``peak`` invert it."""
    assert ROVER.time(8.0, 2.0) == pytest.approx(7.0)
    assert ROVER.time(2.0, 2.5) == pytest.approx(2.0 * math.sqrt(0.5))
    assert ROVER.distance(0.0, 8.0) == pytest.approx(36.0)
    assert ROVER.fastest(0.0, 36.0) == pytest.approx(8.0, abs=1e-6)
    assert ROVER.peak(2.0, 2.0, 2.0 * ROVER.distance(2.0, 6.0), 8.0) == pytest.approx(6.0)
    assert ROVER.peak(2.0, 2.0, 1000.0, 8.0) == 8.0


def test_without_accel_the_polyline_drives_as_before() -> None:
    """No ATC_ACCEL_MAX: constant speed from t = 0, each corner at full speed."""
    route = Polyline(GRID, speed=8.0)
    assert route.arrivals == pytest.approx((0.0, 25.0, 50.0, 75.0))
    assert route.position(12.5) == pytest.approx((100.0, 0.0))
    assert math.hypot(*route.velocity(24.9)) == pytest.approx(8.0)
    assert route.position(80.0) == GRID[-1] and route.velocity(80.0) == (0.0, 0.0)


def test_a_rover_brakes_for_its_corners_and_speeds_up_after() -> None:
    """8 m/s on 200-m legs at 1 m/s²: from rest, 2.38 m/s at each corner, braked for
    34 m before it, cruising between; no faster than 8 m/s nor harder than 1 m/s²."""
    route = Polyline(GRID, speed=8.0, accel=1.0)
    _, pos, v = speeds_along(route, 120.0)
    assert v.max() == pytest.approx(8.0)
    assert np.abs(np.diff(v)).max() <= 1.0 * STEP + 1e-9
    steps = np.hypot(*np.diff(pos, axis=0).T)
    assert steps.max() <= 8.0 * STEP + 1e-9  # (no jump)
    low = corner_speed(math.pi / 2, ROVER, 2.0)
    braking = ROVER.distance(8.0, low)
    assert 34.0 < braking < 35.0
    for j in (1, 2):
        at = route.arrivals[j]
        assert math.hypot(*route.velocity(at)) == pytest.approx(low, abs=0.01)
        assert route.position(at) == pytest.approx(GRID[j], abs=1e-6)
        assert route.position(at - ROVER.time(8.0, low)) == pytest.approx(
            (GRID[j][0] - braking * (j == 1), GRID[j][1] - braking * (j == 2)), abs=0.05
        )
    # Each corner costs the time braking and speeding up take over the constant speed.
    ideal = Polyline(GRID, speed=8.0).arrivals
    lost = np.diff(np.subtract(route.arrivals, ideal))
    per_ramp = ROVER.time(8.0, low) - braking / 8.0
    assert lost[1] == pytest.approx(2.0 * per_ramp, abs=1e-6) and 4.0 < lost[1] < 5.0
    assert route.position(200.0) == GRID[-1] and route.velocity(200.0) == (0.0, 0.0)


def test_a_hold_is_stood_and_a_speed_driven_from_its_point_on() -> None:
    route = Polyline(GRID, speed=8.0, accel=1.0, holds=((2, 30.0),), speeds=((1, 4.0),))
    at = route.arrivals[2]
    for dt in (0.0, 10.0, 29.9):
        assert route.position(at + dt) == pytest.approx(GRID[2]) and route.velocity(at + dt) == (
            0.0,
            0.0,
        )
    t, _, v = speeds_along(route, route.arrivals[3])
    second_leg = (t > route.arrivals[1]) & (t < at)
    assert v[second_leg].max() == pytest.approx(4.0)  # (braked to before the corner)
    assert v[t < route.arrivals[1]].max() == pytest.approx(8.0)
    assert route.arrivals[3] - at > 30.0 + 200.0 / 4.0  # (the last leg at 4 m/s too)


@pytest.mark.parametrize("accel", [0.0, 1.0])
def test_a_lap_is_driven_again_and_again(accel: float) -> None:
    route = Polyline(GRID, speed=8.0, loop=True, accel=accel, holds=((0, 10.0),))
    lap = route.arrivals[-1]
    assert len(route.arrivals) == 5 and lap >= 800.0 / 8.0 + 10.0
    for t in (3.0, 47.0, 101.0, lap - 0.5):
        assert route.position(t + lap) == pytest.approx(route.position(t))
        assert route.position(t + 3 * lap) == pytest.approx(route.position(t))
    assert route.velocity(lap + 5.0) == (0.0, 0.0)  # (standing at the first point again)


def test_the_drive_and_its_points_are_checked() -> None:
    with pytest.raises(ValueError, match=r"holds\[0\]: no point 7"):
        Polyline(GRID, speed=8.0, holds=((7, 10.0),))
    with pytest.raises(ValueError, match=r"speeds\[1\]: 0.0 is out of range"):
        Polyline(GRID, speed=8.0, speeds=((1, 5.0), (2, 0.0)))
    with pytest.raises(ValueError, match="given twice"):
        Polyline(((0.0, 0.0), (9.0, 0.0), (9.0, 0.0)), speed=8.0, holds=((1, 3.0), (2, 3.0)))
    with pytest.raises(ValueError, match="accel must be >= 0"):
        Polyline(GRID, speed=8.0, accel=-1.0)
    with pytest.raises(ValueError, match="must be finite"):
        Polyline(GRID, speed=8.0, wp_radius=math.nan)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-400.0, 400.0), st.floats(-400.0, 400.0)), min_size=2, max_size=7),
    st.floats(1.0, 20.0),
    st.floats(0.3, 3.0),
    st.booleans(),
)
def test_any_drive_keeps_to_its_speeds_and_its_accel(
    points: list[tuple[float, float]], speed: float, accel: float, loop: bool
) -> None:
    """Random roads: never faster than the speed, never harder than the accel, every
    corner no faster than its corner speed, and no jump."""
    route = Polyline(tuple(points), speed=speed, accel=accel, loop=loop)
    if not route.arrivals:
        return
    until = route.arrivals[-1] * (1.5 if loop else 1.0) + 1.0
    _, pos, v = speeds_along(route, until)
    assert v.max() <= speed + 1e-6
    assert np.abs(np.diff(v)).max() <= accel * STEP + 1e-6
    assert np.hypot(*np.diff(pos, axis=0).T).max() <= speed * STEP + 1e-6
    nodes = route.vertices
    for j in range(1, len(nodes) - 1):
        heading = [
            math.atan2(b[1] - a[1], b[0] - a[0])
            for a, b in (nodes[j - 1 : j + 1], nodes[j : j + 2])
        ]
        turn = (heading[1] - heading[0] + math.pi) % (2 * math.pi) - math.pi
        at = route.arrivals[j]
        ramps = Ramps(accel, accel)
        leg = min(math.dist(*nodes[j - 1 : j + 1]), math.dist(*nodes[j : j + 2]))
        assert math.hypot(*route.velocity(at)) <= corner_speed(turn, ramps, 2.0, leg) + 1e-6
        assert route.position(at) == pytest.approx(nodes[j], abs=1e-6)


def test_the_mission_holds_and_changes_speed_as_the_drive_does() -> None:
    """A hold is its waypoint's param1; a speed a DO_CHANGE_SPEED after the waypoint it is
    driven from; MISSION_CURRENT names the waypoint, never the DO item."""
    route = Polyline(GRID, speed=8.0, accel=1.0, holds=((2, 30.0),), speeds=((1, 4.0),))
    mission = RoverMission.of(route, WORLD)
    assert mission is not None
    home = WORLD.to_geo(0.0, 0.0)
    items = [mission.item(k, home, (255, 190), home_first=True) for k in range(6)]
    assert [i.command for i in items if i is not None] == [
        mavlink.MAV_CMD_NAV_WAYPOINT,  # home
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_DO_CHANGE_SPEED,
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_WAYPOINT,
    ]
    assert items[3] is not None and (items[3].param1, items[3].param2) == (1.0, 4.0)
    assert items[4] is not None and items[4].param1 == 30.0
    assert mission.item(6, home, (255, 190), home_first=True) is None
    arrive = route.arrivals
    seqs = [mission.current(t, home_first=True) for t in (1.0, arrive[1] + 1.0, arrive[2] + 20.0)]
    assert seqs == [2, 4, 4]  # (to the second waypoint; then to, and held at, the third)
    assert mission.current(arrive[2] + 31.0, home_first=True) == 5


def test_a_lap_that_changes_speed_sets_its_first_legs_too() -> None:
    route = Polyline(GRID, speed=8.0, loop=True, speeds=((2, 4.0),))
    mission = RoverMission.of(route, WORLD)
    assert mission is not None and mission.speeds[:3] == (4.0, 0.0, 4.0)
    assert route.arrivals[1] == pytest.approx(200.0 / 4.0)  # (every lap as the last left it)


@pytest.mark.parametrize("loop", [False, True])
@pytest.mark.parametrize("ardupilot", [True, False])
def test_the_services_reader_takes_the_holds_and_speeds(loop: bool, ardupilot: bool) -> None:
    """Through MAVLink bytes, as each firmware numbers the mission: the service's route
    has the hold at its point and the speed from its point on; before it, an ArduPilot
    rover's WP_SPEED (a PX4 rover's default is not asked), or on a lap the speed the last
    lap left (set again at the first waypoint). An autopilot drives it."""
    route = Polyline(GRID, speed=8.0, loop=loop, accel=1.0, holds=((2, 30.0),), speeds=((1, 4.0),))
    gcs = Gcs(rover(Personality.ARDUPILOT if ardupilot else Personality.PX4, route))
    watch, items = read_mission(gcs)
    planned = mission_route(items, home_first=ardupilot, default_speed=watch.default_speed)
    assert planned.holds == ((2, 30.0),) and planned.circuit is loop and planned.autopilot
    if loop:
        assert planned.speeds == ((0, 4.0), (1, 4.0))
    else:
        assert planned.speeds == (((0, 8.0), (1, 4.0)) if ardupilot else ((1, 4.0),))


def test_the_config_gives_the_drive_by_key() -> None:
    config = MockConfig.simple(
        1, ground=1, ground_route="polyline", ground_points=[list(p) for p in GRID],
        ground_speed=8.0, ground_accel=1.0, ground_wp_radius=3.0,
        ground_holds=[[2, 30.0]], ground_speeds=[[1, 4.0]], ground_mission=True,
    )  # fmt: skip
    route = config.vehicles[-1].route
    assert isinstance(route, Polyline)
    assert (route.accel, route.wp_radius, route.holds, route.speeds) == (
        1.0, 3.0, ((2, 30.0),), ((1, 4.0),),
    )  # fmt: skip
    bad = {
        "ground_holds": ([[9, 30.0]], r"ground\.holds\[0\].*no point 9"),
        "ground_speeds": ([[1, 0.0]], r"ground\.speeds\[0\].*must be > 0"),
        "ground_accel": (-1.0, r"ground\.accel"),
    }
    for key, (value, match) in bad.items():
        with pytest.raises(ConfigError, match=match):
            MockConfig.simple(
                1, ground=1, ground_route="polyline", ground_points=[list(p) for p in GRID],
                ground_speed=8.0, **{key: value},
            )  # fmt: skip
    with pytest.raises(ConfigError, match=r"ground\.accel.*polyline's, not route line's"):
        MockConfig.simple(1, ground=1, ground_route="line", ground_speed=5.0, ground_accel=1.0)


def test_the_rover_says_its_accel_and_radius() -> None:
    """ArduRover's ATC_ACCEL_MAX and WP_RADIUS, read-only (the road's drive is scripted)."""
    gcs = Gcs(rover(Personality.ARDUPILOT, Polyline(GRID, speed=8.0, accel=1.0)))
    for name, value in (("ATC_ACCEL_MAX", 1.0), ("WP_RADIUS", 2.0)):
        (reply,) = gcs.send(mavlink.MAVLink_param_request_read_message(11, 1, name.encode(), -1))
        assert (reply.param_id, reply.param_value) == (name, value)


def test_the_command_line_gives_the_accel() -> None:
    from sitl_mock.__main__ import build_config

    argv = ["--ground", "1", "--ground-route", "polyline", "--ground-points", "0,0;200,0;200,90"]
    config = build_config([*argv, "--ground-speed", "8", "--ground-accel", "1"])
    route = config.vehicles[-1].route
    assert isinstance(route, Polyline) and route.accel == 1.0
    assert route.arrivals[-1] > Polyline(route.points, speed=8.0).arrivals[-1] + 8.0
