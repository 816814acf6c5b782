"""A rover's mission, from a real autopilot: read as the service reads it, and driven.

    .venv/bin/python checks/rover_mission.py read udpin:127.0.0.1:14550   # ArduRover SITL
    .venv/bin/python checks/rover_mission.py read --mock ardupilot        # the mock's rover
    .venv/bin/python checks/rover_mission.py drive tcp:127.0.0.1:5962 road.csv 8
    .venv/bin/python checks/rover_mission.py drive tcp:127.0.0.1:5962 road.csv 8 --hold 300:60
    .venv/bin/python checks/rover_mission.py drive tcp:127.0.0.1:5962 road.csv 8 --speed-at 300:5
    .venv/bin/python checks/rover_mission.py compare mission.tlog road.csv 8 --accel 1

``read`` checks that the service's reader (``mavlink.missionread``) and the road it
makes of the items (``tracks.missionroute``) work with the firmware, and that
``sitl_mock`` serves the same. Against an autopilot it acts as two ground stations on one
link: the operator's uploads a mission (waypoints, a DO_CHANGE_SPEED, a hold "here", a
return to launch), the service's ``MissionWatch`` reads it and prints the route it makes;
the operator then uploads a longer one, and the watch must see MISSION_CURRENT's total
change and read it again, then a patrol (the first road jumping back to its first
waypoint for ever), which must read as a circuit with the same hold and speed. Against
the mock, ``--mock ardupilot`` the same, to a parked rover; ``--mock px4`` reads the road
its rover serves as its mission, the first read alone. Exit 0 when every read gave the
mission uploaded.

``drive`` sends a rover down a road as its operator would: the road's corners (a CSV
time,lat,lon, as ``checks/ardupilot_sitl.sh`` writes for ROAD=KIND, thinned as the
mock's rovers thin theirs, ``sitl_mock.mission.thin``) as waypoints after a
DO_CHANGE_SPEED to the speed given (m/s; 0: none, the rover drives its WP_SPEED), then
AUTO and arming, retried until the firmware accepts. Run beside ``convoy-mav run``
with ``[convoy] route = "mission"``. ``--hold AT:FOR`` (repeatable) is its operator
holding it: HOLD at the rover's own boot time AT s, AUTO again FOR s later; each prints
where the rover was, how far it ran on after HOLD and how long it took to stand, and
whether it drove on in AUTO. ``--speed-at AT:MPS`` (repeatable) is its operator telling
it a speed: DO_CHANGE_SPEED by command at boot time AT s; each prints the rover's answer
and its speed 10-20 s later. ``--move-at AT:METRES`` (repeatable) is its operator moving
a waypoint three ahead of the one it drives to METRES east and uploading the mission
again at boot time AT s, as it drives; each prints the answer and the texts it sent.
``--rtl-at AT:FOR`` (repeatable) is its operator calling it home: RTL at boot time AT s,
AUTO again FOR s later; each prints how far from home it stood and its speed in AUTO;
with ``--rally-left METRES`` a rally point that far to its left is uploaded first
(ArduRover drives there if it is nearer than home and within RALLY_LIMIT_KM).
``--smart-rtl-at AT:FOR`` (repeatable) is the same with SMART_RTL: home back along the
path it drove.

``compare`` sets the drive of a real rover (its GLOBAL_POSITION_INT in a tlog, from when
it first moves to when it last does) beside the mock's rover driving the same road as
AUTO does (``sitl_mock.drive``, at ``--accel``, ATC_ACCEL_MAX): how long each took, and
each corner's seconds under 7.5 m/s and its slowest speed.

Not part of ``make test``: it needs a running autopilot (ArduPilot SITL, see the
project's notes on building it).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.missionread import MissionWatch
from convoy_mav.tracks.missionroute import mission_route
from convoy_mav.tracks.plannedroute import PlannedRoute
from sitl_mock.ground import Polyline
from sitl_mock.mission import DEFAULT_TOLERANCE_M, thin

MISSION = mavlink.MAV_MISSION_TYPE_MISSION
RALLY = mavlink.MAV_MISSION_TYPE_RALLY
ROVER_AUTO = 10  # ArduRover's custom modes
ROVER_HOLD = 4
ROVER_RTL = 11
ROVER_SMART_RTL = 12
REL = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
FIRST = ((-35.3620, 149.1650), (-35.3600, 149.1650), (-35.3600, 149.1680))
SECOND = (*FIRST, (-35.3620, 149.1680), (-35.3630, 149.1660))


def items(
    target: tuple[int, int], road: tuple[tuple[float, float], ...], *, patrol: bool = False
) -> list[Any]:
    """Home (seq 0, replaced by the autopilot's), the road's waypoints with a speed change
    after the first and a hold "here" after the second, then a return to launch; or, on
    ``patrol``, a DO_JUMP back to the first waypoint for ever."""

    def wp(lat: float, lon: float, command: int = mavlink.MAV_CMD_NAV_WAYPOINT) -> list[Any]:
        return [REL, command, 0, 1, 0.0, 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0]

    rows = [[mavlink.MAV_FRAME_GLOBAL, *wp(*road[0])[1:]]]
    for k, point in enumerate(road):
        rows.append(wp(*point))
        if k == 0:
            speed = [mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 1]
            rows.append([*speed, 1.0, 6.0, -1.0, 0.0, 0, 0, 0.0])
        if k == 1:
            rows.append([REL, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1, 5.0, 0, 0, 0, 0, 0, 0.0])
    if patrol:
        rows.append([mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_JUMP, 0, 1,
                     1.0, -1.0, 0.0, 0.0, 0, 0, 0.0])  # fmt: skip
    else:
        rows.append([mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, 0, 1,
                     0.0, 0.0, 0.0, 0.0, 0, 0, 0.0])  # fmt: skip
    return [
        mavlink.MAVLink_mission_item_int_message(*target, seq, *row, MISSION)
        for seq, row in enumerate(rows)
    ]


def upload(link: Any, target: tuple[int, int], mission: list[Any], kind: int = MISSION) -> str:
    """The operator's upload (of ``kind``: the mission, its rally points); the
    autopilot's final answer."""
    link.mav.send(mavlink.MAVLink_mission_count_message(*target, len(mission), kind))
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        msg = link.recv_match(
            type=["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], blocking=True,
            timeout=0.5,
        )  # fmt: skip
        if msg is None or getattr(msg, "mission_type", MISSION) != kind:
            continue
        if msg.get_type() == "MISSION_ACK":
            return str(mavlink.enums["MAV_MISSION_RESULT"][msg.type].name)
        link.mav.send(mission[msg.seq])
    return "no answer"


def watch_read(link: Any, watch: MissionWatch, wait: float) -> PlannedRoute | str:
    """Run the watch on the link until a read finishes; its route, or why not."""
    deadline = time.monotonic() + wait  # (wall time for the link and the waits alike)
    while (now := time.monotonic()) < deadline:
        for out in watch.poll(now, now):
            link.mav.send(out)
        msg = link.recv_match(blocking=True, timeout=0.05)
        if msg is not None and msg.get_srcSystem() == watch.target[0]:
            now = time.monotonic()
            for out in watch.handle(msg, now, now):
                link.mav.send(out)
        read = watch.take()
        if read is None:
            continue
        if read.error is not None:
            return f"read failed: it {read.error}"
        try:
            items = read.items or []
            return mission_route(
                items, home_first=watch.ardupilot, default_speed=watch.default_speed
            )
        except ValueError as exc:
            return f"no route: {exc}"
    return f"no read finished in {wait:.0f} s"


def report(
    name: str, got: PlannedRoute | str, road: tuple[tuple[float, float], ...], *, patrol: bool
) -> bool:
    """Print what was read; whether it is the mission ``items`` uploaded: its road, the
    hold and the speed change at the waypoints they follow, a circuit on ``patrol``."""
    if isinstance(got, str):
        print(f"{name}: {got}", flush=True)
        return False
    points = [(round(a, 6), round(b, 6)) for a, b in got.points]
    print(f"{name}: {len(points)} points {points}", flush=True)
    if got.remarks():
        print(f"{name}: {got.remarks()}", flush=True)
    plan = (got.holds, got.speeds, got.circuit) == (((1, 5.0),), ((0, 6.0),), patrol)
    return plan and points[: len(road)] == [(round(a, 6), round(b, 6)) for a, b in road]


def road_corners(path: str) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """The road's waypoints (lat, lon), thinned as the mock's rovers thin theirs, and the
    same in metres north and east of its first fix."""
    with open(path, newline="") as fh:
        rows = [(float(r["lat"]), float(r["lon"])) for r in csv.DictReader(fh)]
    frame = LocalFrame(GeoPoint(rows[0][0], rows[0][1], 0.0))
    xy = [frame.to_ned(GeoPoint(lat, lon, 0.0))[:2] for lat, lon in rows]
    keep = thin(xy, DEFAULT_TOLERANCE_M)
    return [rows[i] for i in keep], [xy[i] for i in keep]


def road_items(target: tuple[int, int], path: str, speed: float) -> list[Any]:
    corners, _ = road_corners(path)
    rel = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    wp = mavlink.MAV_CMD_NAV_WAYPOINT
    first = [mavlink.MAV_FRAME_GLOBAL, wp, 0, 1, 0.0, 0.0, 0.0, 0.0]
    rows_out = [[*first, round(corners[0][0] * 1e7), round(corners[0][1] * 1e7), 0.0]]
    if speed > 0.0:  # (0: none, the rover drives its WP_SPEED and the plan says no speed)
        rows_out.append([mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 1,
                         1.0, speed, -1.0, 0.0, 0, 0, 0.0])  # fmt: skip
    for lat, lon in corners:
        rows_out.append(
            [rel, wp, 0, 1, 0.0, 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0]
        )
    return [
        mavlink.MAVLink_mission_item_int_message(*target, seq, *row, MISSION)
        for seq, row in enumerate(rows_out)
    ]


def drive(
    connection: str,
    path: str,
    speed: float,
    holds: Sequence[tuple[float, float]] = (),
    speeds: Sequence[tuple[float, float]] = (),
    moves: Sequence[tuple[float, float]] = (),
    rtls: Sequence[tuple[float, float]] = (),
    rally_left: float | None = None,
    smart_rtls: Sequence[tuple[float, float]] = (),
) -> int:
    """Upload the road, AUTO, arm (see the module's ``drive``)."""
    link = mavutil.mavlink_connection(connection, source_system=250, source_component=190)
    hb = link.wait_heartbeat(timeout=60)
    if hb is None:
        print(f"no heartbeat on {connection}")
        return 2
    target = (link.target_system, link.target_component)
    items = road_items(target, path, speed)
    answer, armed = send_off(link, target, items)
    print(f"{time.strftime('%H:%M:%S')} upload {len(items) - 2} waypoints: {answer}", flush=True)
    if not armed:
        print("the rover refused to arm")
        return 1
    print(f"{time.strftime('%H:%M:%S')} armed in AUTO", flush=True)
    return _operator(link, target, holds, speeds, moves, items, rtls, rally_left, smart_rtls)


def hail(link: Any) -> tuple[int, int] | None:
    """Heartbeats to the rover until it answers with its own (a UDP peer is heard only
    once it has spoken): its (system, component), or None after a minute."""
    for _ in range(120):
        link.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        hb = link.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
        if hb is not None and hb.type == mavlink.MAV_TYPE_GROUND_ROVER:
            return hb.get_srcSystem(), hb.get_srcComponent()
    return None


def reach(connection: str) -> tuple[Any, tuple[int, int]] | None:
    """A link to the rover at ``connection`` as its operator's station (system 250), and
    its (system, component) once it has answered (``hail``); None, said, if it never
    did."""
    link = mavutil.mavlink_connection(connection, source_system=250, source_component=190)
    target = hail(link)
    if target is None:
        print(f"no rover's HEARTBEAT on {connection}")
        return None
    return link, target


def send_off(link: Any, target: tuple[int, int], items: list[Any]) -> tuple[str, bool]:
    """Wait until the rover has a home (its position estimate is good: then it can be
    sent off), upload ``items``, switch to AUTO and arm, retried until the firmware
    accepts: the upload's answer, and whether it armed."""
    deadline = time.monotonic() + 120.0
    home = mavlink.MAVLINK_MSG_ID_HOME_POSITION
    while time.monotonic() < deadline:
        link.mav.command_long_send(
            *target, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, home, 0, 0, 0, 0, 0, 0
        )
        if link.recv_match(type="HOME_POSITION", blocking=True, timeout=2.0) is not None:
            break
    answer = upload(link, target, items)
    if answer != "MAV_MISSION_ACCEPTED":
        return answer, False
    link.mav.set_mode_send(target[0], mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_AUTO)
    arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    for _ in range(60):
        link.mav.command_long_send(*target, arm, 0, 1, 0, 0, 0, 0, 0, 0)
        ack = link.recv_match(type="COMMAND_ACK", blocking=True, timeout=2.0)
        if ack is not None and ack.command == arm and ack.result == mavlink.MAV_RESULT_ACCEPTED:
            return answer, True
        time.sleep(1.0)
    return answer, False


def _moved(items: list[Any], seq: int, metres: float) -> list[Any]:
    """``items`` with the waypoint three after item ``seq`` (or the last) ``metres`` east."""
    waypoints = [it.seq for it in items if it.command == mavlink.MAV_CMD_NAV_WAYPOINT]
    k = min([w for w in waypoints if w >= seq + 3] or waypoints[-1:])
    it = items[k]
    lat = it.x * 1e-7
    east = round(metres / (111_320.0 * math.cos(math.radians(lat))) * 1e7)
    moved = mavlink.MAVLink_mission_item_int_message(
        it.target_system, it.target_component, it.seq, it.frame, it.command, 0,
        it.autocontinue, it.param1, it.param2, it.param3, it.param4, it.x, it.y + east, it.z,
        MISSION,
    )  # fmt: skip
    return [moved if j == k else other for j, other in enumerate(items)]


def with_ardurover(
    run: Callable[[str], int], *, instance: int, wp_speed: float, home: tuple[float, ...]
) -> int:
    """Start ArduRover SITL (``$SITL_DIR/build/sitl/bin/ardurover``, instance ``instance``,
    WP_SPEED and CRUISE_SPEED ``wp_speed``, at ``home`` (lat, lon, alt), 5x), ``run`` it
    through its serial0 (TCP 5760 + 10 per instance), stop it: ``run``'s answer (2: no
    SITL to start)."""
    sitl = os.environ.get("SITL_DIR")
    binary = os.path.join(sitl or "", "build/sitl/bin/ardurover")
    if not sitl or not os.path.exists(binary):
        print("set SITL_DIR to an ArduPilot tree with build/sitl/bin/ardurover, or --connect")
        return 2
    with tempfile.TemporaryDirectory() as work:
        params = os.path.join(work, "speed.parm")
        with open(params, "w") as fh:
            fh.write(f"WP_SPEED {wp_speed:g}\nCRUISE_SPEED {wp_speed:g}\n")
        defaults = f"{sitl}/Tools/autotest/default_params/rover.parm,{params}"
        at = ",".join(str(c) for c in (*home, 0))
        argv = [binary, "--model", "rover", "--speedup", "5", "-I", str(instance), "--home", at,
                "--defaults", defaults]  # fmt: skip
        with open(os.path.join(work, "sitl.log"), "w") as log:
            return _beside(
                argv, 2.0, run, f"tcp:127.0.0.1:{5760 + 10 * instance}",
                cwd=work, stdout=log, stderr=subprocess.STDOUT,
            )  # fmt: skip


def _beside(
    argv: list[str], settle_s: float, run: Callable[[str], int], connection: str, **popen: Any
) -> int:
    """``run`` on ``connection`` while the process ``argv`` runs (``settle_s`` to start)."""
    proc = subprocess.Popen(argv, **popen)
    try:
        time.sleep(settle_s)
        return run(connection)
    finally:
        proc.terminate()
        proc.wait()


def check_main(
    description: str,
    run: Callable[[str], int],
    *,
    home: tuple[float, float, float],
    instance: int,
    wp_speed: float,
    mock_port: int,
    mock_speedup: float | None = None,
) -> int:
    """A rover check's command line: ``run`` against a running rover (``--connect``),
    the mock's parked rover (``--mock``: ``sitl_mock`` on ``mock_port`` at ``home``), or
    ArduRover SITL started for it (``with_ardurover``)."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--connect", help="a running rover's MAVLink endpoint")
    parser.add_argument("--mock", choices=("ardupilot",), help="start sitl_mock instead")
    args = parser.parse_args()
    if args.connect:
        return run(args.connect)
    if not args.mock:
        return with_ardurover(run, instance=instance, wp_speed=wp_speed, home=home)
    lat, lon, alt = home
    speedup = [] if mock_speedup is None else ["--speedup", f"{mock_speedup:g}"]
    argv = [sys.executable, "-m", "sitl_mock", "--aircraft", "0", "--ground", "1",
            "--personality", args.mock, "--base-port", str(mock_port), "--ground-route",
            "stationary", "--origin", f"{lat},{lon},{alt}", *speedup]  # fmt: skip
    return _beside(argv, 1.0, run, f"udpout:127.0.0.1:{mock_port}")


def _operator(
    link: Any,
    target: tuple[int, int],
    holds: Sequence[tuple[float, float]],
    speeds: Sequence[tuple[float, float]] = (),
    moves: Sequence[tuple[float, float]] = (),
    items: list[Any] | None = None,
    rtls: Sequence[tuple[float, float]] = (),
    rally_left: float | None = None,
    smart_rtls: Sequence[tuple[float, float]] = (),
) -> int:
    """HOLD at each (boot time, seconds), then AUTO; DO_CHANGE_SPEED at each (boot time,
    m/s); the mission uploaded again with a waypoint ahead moved at each (boot time,
    metres east); RTL at each (boot time, seconds), then AUTO (with ``rally_left``, a
    rally point that far to its left uploaded first); SMART_RTL at each, then AUTO; what
    the rover did, printed."""
    if not holds and not speeds and not moves and not rtls and not smart_rtls:
        return 0
    link.mav.request_data_stream_send(*target, mavlink.MAV_DATA_STREAM_POSITION, 4, 1)
    frame: LocalFrame | None = None

    def fix() -> tuple[float, float, float, float]:
        """(boot s, north, east, speed) of the rover's next position."""
        nonlocal frame
        while True:
            m = link.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=30.0)
            if m is None:
                raise TimeoutError("the rover sends no position")
            geo = GeoPoint(m.lat * 1e-7, m.lon * 1e-7, 0.0)
            frame = frame or LocalFrame(geo)
            n, e, _ = frame.to_ned(geo)
            return m.time_boot_ms * 1e-3, n, e, math.hypot(m.vx, m.vy) * 0.01

    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    plan = sorted([(at, "hold", seconds) for at, seconds in holds] +
                  [(at, "speed", mps) for at, mps in speeds] +
                  [(at, "move", metres) for at, metres in moves] +
                  [(at, "rtl", seconds) for at, seconds in rtls] +
                  [(at, "smart", seconds) for at, seconds in smart_rtls])  # fmt: skip
    home = (0.0, 0.0)  # (north, east: the frame's origin is its first fix, where it armed)
    for at, kind, value in plan:
        t, n0, e0, v0 = fix()
        while t < at:
            t, n0, e0, v0 = fix()
        if kind == "move" and items is not None:
            request = mavlink.MAV_CMD_REQUEST_MESSAGE
            current = mavlink.MAVLINK_MSG_ID_MISSION_CURRENT
            link.mav.command_long_send(*target, request, 0, current, 0, 0, 0, 0, 0, 0)
            now = link.recv_match(type="MISSION_CURRENT", blocking=True, timeout=5.0)
            seq = 1 if now is None else int(now.seq)
            items = _moved(items, seq, value)
            answer = upload(link, target, items)
            texts = []
            while (m := link.recv_match(type="STATUSTEXT", blocking=True, timeout=1.0)) is not None:
                texts.append(m.text)
            print(f"mission uploaded again at {at:.0f} s (boot), driving to item {seq}, a "
                  f"waypoint ahead {value:.0f} m east: {answer}; {sorted(set(texts))}",
                  flush=True)  # fmt: skip
            continue
        if kind == "speed":
            link.mav.command_long_send(*target, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0,
                                       mavlink.SPEED_TYPE_GROUNDSPEED, value, -1.0,
                                       0, 0, 0, 0)  # fmt: skip
            ack = link.recv_match(type="COMMAND_ACK", blocking=True, timeout=5.0)
            said = "no answer" if ack is None else mavlink.enums["MAV_RESULT"][ack.result].name
            speeds_seen = []
            while t < at + 20.0:
                t, _, _, v = fix()
                speeds_seen.append(v)
            print(f"DO_CHANGE_SPEED {value:.1f} m/s at {at:.0f} s (boot), {v0:.1f} m/s: "
                  f"{said}; 10-20 s later {min(speeds_seen[-10:]):.1f}-"
                  f"{max(speeds_seen[-10:]):.1f} m/s", flush=True)  # fmt: skip
            continue
        if kind in ("rtl", "smart"):
            goal, to = home, "home" if kind == "rtl" else "home back along its path"
            if kind == "rtl" and rally_left is not None and frame is not None:
                _, n1, e1, _ = fix()
                left = math.atan2(e1 - e0, n1 - n0) - math.pi / 2.0
                goal = (n1 + rally_left * math.cos(left), e1 + rally_left * math.sin(left))
                answer = upload(link, target, [_rally_item(target, frame, goal)], RALLY)
                to = f"a rally point {rally_left:.0f} m to its left ({answer})"
            link.mav.set_mode_send(target[0], flag, ROVER_RTL if kind == "rtl" else ROVER_SMART_RTL)
            while t < at + value:
                t, n, e, v = fix()
            off = math.dist((n, e), goal)
            link.mav.set_mode_send(target[0], flag, ROVER_AUTO)
            while t < at + value + 15.0:
                t, _, _, v_auto = fix()
            name = "RTL" if kind == "rtl" else "SMART_RTL"
            print(f"{name} at {at:.0f} s (boot), {v0:.1f} m/s, {math.dist((n0, e0), home):.0f} m "
                  f"from home, to {to}: {off:.1f} m from it at {at + value:.0f} s, {v:.1f} m/s; "
                  f"AUTO: {v_auto:.1f} m/s 15 s later", flush=True)  # fmt: skip
            continue
        link.mav.set_mode_send(target[0], flag, ROVER_HOLD)
        stood: tuple[float, float] | None = None  # (boot s, metres run on) once standing
        while t < at + value:
            t, n, e, v = fix()
            if stood is None and v < 0.1:
                stood = (t - at, math.hypot(n - n0, e - e0))
        link.mav.set_mode_send(target[0], flag, ROVER_AUTO)
        while t < at + value + 15.0:
            t, n, e, v = fix()
        said = (
            "never stood" if stood is None else f"stood {stood[0]:.1f} s later, {stood[1]:.1f} m on"
        )
        print(f"HOLD at {at:.0f} s (boot), {v0:.1f} m/s: {said}; AUTO at {at + value:.0f} s: "
              f"{v:.1f} m/s 15 s later", flush=True)  # fmt: skip
    return 0


def _rally_item(target: tuple[int, int], frame: LocalFrame, at: tuple[float, float]) -> Any:
    """A rally point at ``at`` (north, east in ``frame``), as a ground station uploads it."""
    where = frame.to_geo(at[0], at[1], 0.0)
    x, y = round(where.lat * 1e7), round(where.lon * 1e7)
    rel, point = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_RALLY_POINT
    return mavlink.MAVLink_mission_item_int_message(
        *target, 0, rel, point, 0, 0, 0, 0, 0, 0, x, y, 0.0, RALLY
    )


def _slow_spells(
    times: Sequence[float], speeds: Sequence[float], below: float = 7.5
) -> list[tuple[float, float]]:
    """Each stretch under ``below`` m/s after the first: its seconds and slowest speed."""
    spells: list[tuple[float, float]] = []
    since, low = None, math.inf
    for t, v in zip(times, speeds, strict=True):
        if v < below:
            since, low = (t if since is None else since), min(low, v)
        elif since is not None:
            spells.append((t - since, low))
            since, low = None, math.inf
    return spells[1:]  # (the first: setting off)


def compare(tlog: str, path: str, speed: float, accel: float, sysid: int | None) -> int:
    """A real rover's drive against the mock's (see the module's ``compare``)."""
    link = mavutil.mavlink_connection(tlog)
    fixes: dict[float, float] = {}
    while (msg := link.recv_match(type=["HEARTBEAT", "GLOBAL_POSITION_INT"])) is not None:
        if msg.get_type() == "HEARTBEAT":
            if sysid is None and msg.type == mavlink.MAV_TYPE_GROUND_ROVER:
                sysid = msg.get_srcSystem()
        elif msg.get_srcSystem() == sysid:
            fixes[msg.time_boot_ms / 1000.0] = math.hypot(msg.vx, msg.vy) / 100.0
    moving = [t for t, v in sorted(fixes.items()) if v > 0.5]
    if not moving:
        print(f"{tlog}: no rover drives in it (sysid {sysid})", file=sys.stderr)
        return 2
    times = [t for t in sorted(fixes) if moving[0] <= t <= moving[-1]]
    real = _slow_spells(times, [fixes[t] for t in times])
    _, points = road_corners(path)
    rover = Polyline(tuple(points), speed, accel=accel)
    steps = [0.1 * k for k in range(int(rover.arrivals[-1] / 0.1))]
    mock = _slow_spells(steps, [math.hypot(*rover.velocity(t)) for t in steps])
    ideal = Polyline(tuple(points), speed).arrivals[-1]
    print(f"{len(points)} waypoints, {rover.length:.0f} m: {ideal:.0f} s at {speed:g} m/s; "
          f"the rover (sysid {sysid}) {moving[-1] - moving[0]:.0f} s, the mock "
          f"{rover.arrivals[-1]:.0f} s")  # fmt: skip
    for name, spells in (("rover", real), ("mock", mock)):
        if spells:
            print(f"{name}: {len(spells)} corners, {statistics.mean(s for s, _ in spells):.1f} s "
                  f"each under 7.5 m/s, at {min(v for _, v in spells):.1f}-"
                  f"{max(v for _, v in spells):.1f} m/s at the slowest")  # fmt: skip
    return 0


def read(args: argparse.Namespace) -> int:
    """Upload, read, upload again, read again (see the module's ``read``)."""
    mock = None
    connection = args.connection
    own_road = args.mock == "px4"  # (ArduPilot's: parked, it takes the uploads, as SITL)
    if args.mock:
        lat, lon = FIRST[0]
        road = ["--ground-route", "stationary"]
        if own_road:
            road = ["--ground-route", "polyline", "--ground-points", "0,0;220,0;220,270",
                    "--ground-speed", "5", "--ground-mission"]  # fmt: skip
        mock = subprocess.Popen(
            [sys.executable, "-m", "sitl_mock", "--aircraft", "0", "--ground", "1",
             "--personality", args.mock, "--base-port", "14790", f"--origin={lat},{lon},584",
             *road],
        )  # fmt: skip
        connection = "udpout:127.0.0.1:14790"
        args.sysid = 1
    if connection is None:
        print("give a connection or --mock", file=sys.stderr)
        return 2
    try:
        link = mavutil.mavlink_connection(connection, source_system=255, source_component=190)
        if mock is not None:
            time.sleep(1.0)
        for _ in range(60):
            link.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            hb = link.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
            if hb is not None and hb.get_srcSystem() == args.sysid:
                break
        else:
            print(f"no HEARTBEAT from system {args.sysid} on {connection}", file=sys.stderr)
            return 2
        target = (args.sysid, hb.get_srcComponent())
        # MISSION_CURRENT, as the service asks for it.
        link.mav.command_long_send(
            *target, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
            mavlink.MAVLINK_MSG_ID_MISSION_CURRENT, 1e6, 0, 0, 0, 0, 0,
        )  # fmt: skip
        watch = MissionWatch(*target)
        watch.handle(hb, time.monotonic(), time.monotonic())
        if own_road:
            got = watch_read(link, watch, 20.0)
            return 0 if not isinstance(got, str) and len(got.points) == 3 else 1
        print(f"upload 1 ({len(FIRST)} waypoints): {upload(link, target, items(target, FIRST))}")
        ok = report("read 1", watch_read(link, watch, 20.0), FIRST, patrol=False)
        print(f"upload 2 ({len(SECOND)} waypoints): {upload(link, target, items(target, SECOND))}")
        again = watch_read(link, watch, 20.0)
        ok = report("read 2 (MISSION_CURRENT's total changed)", again, SECOND, patrol=False) and ok
        # A patrol: the first road again, jumping back to its first waypoint for ever.
        lap = items(target, FIRST, patrol=True)
        print(f"upload 3 ({len(FIRST)} waypoints, a patrol): {upload(link, target, lap)}")
        ok = report("read 3 (a circuit)", watch_read(link, watch, 20.0), FIRST, patrol=True) and ok
        print(f"reads: {watch.reads}; default speed (WP_SPEED): {watch.default_speed}", flush=True)
        return 0 if ok else 1
    finally:
        if mock is not None:
            mock.terminate()
            mock.wait()


def _pair(text: str) -> tuple[float, float]:
    at, _, value = text.partition(":")
    try:
        return float(at), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: give two numbers, AT:VALUE") from None


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("read", help="read a mission as the service does")
    r.add_argument("connection", nargs="?", help="the rover's MAVLink endpoint")
    r.add_argument("--mock", choices=("px4", "ardupilot"), help="start sitl_mock instead")
    r.add_argument("--sysid", type=int, default=1)
    d = sub.add_parser("drive", help="send a rover down a road as its mission")
    d.add_argument("connection", help="the rover's MAVLink endpoint (another than the service's)")
    d.add_argument("road", help="CSV time,lat,lon")
    d.add_argument("speed", type=float, help="m/s")
    d.add_argument(
        "--hold", action="append", default=[], type=_pair, metavar="AT:FOR",
        help="HOLD at the rover's boot time AT s, AUTO again FOR s later (repeatable)",
    )  # fmt: skip
    d.add_argument(
        "--speed-at", action="append", default=[], type=_pair, metavar="AT:MPS",
        help="DO_CHANGE_SPEED to MPS at the rover's boot time AT s (repeatable)",
    )  # fmt: skip
    d.add_argument(
        "--move-at", action="append", default=[], type=_pair, metavar="AT:METRES",
        help="at the rover's boot time AT s, upload the mission again with a waypoint "
        "three ahead moved METRES east (repeatable)",
    )  # fmt: skip
    d.add_argument(
        "--rtl-at", action="append", default=[], type=_pair, metavar="AT:FOR",
        help="RTL at the rover's boot time AT s, AUTO again FOR s later (repeatable)",
    )  # fmt: skip
    d.add_argument(
        "--rally-left", type=float, metavar="METRES",
        help="before each RTL, upload a rally point METRES to the rover's left",
    )  # fmt: skip
    d.add_argument(
        "--smart-rtl-at", action="append", default=[], type=_pair, metavar="AT:FOR",
        help="SMART_RTL at the rover's boot time AT s, AUTO again FOR s later (repeatable)",
    )  # fmt: skip
    c = sub.add_parser("compare", help="a rover's drive in a tlog against the mock's rover")
    c.add_argument("tlog", help="the tlog of the rover's drive")
    c.add_argument("road", help="the CSV time,lat,lon it was sent down (``drive``)")
    c.add_argument("speed", type=float, help="m/s, as given to ``drive``")
    c.add_argument("--accel", type=float, default=1.0, help="the mock's m/s² (ATC_ACCEL_MAX)")
    c.add_argument("--sysid", type=int, help="the rover's (default: the tlog's ground rover)")
    args = parser.parse_args()
    if args.command == "compare":
        return compare(args.tlog, args.road, args.speed, args.accel, args.sysid)
    if args.command == "drive":
        return drive(
            args.connection, args.road, args.speed, args.hold, args.speed_at, args.move_at,
            args.rtl_at, args.rally_left, args.smart_rtl_at,
        )  # fmt: skip
    return read(args)


if __name__ == "__main__":
    sys.exit(main())
