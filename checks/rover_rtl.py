"""A rover called home (RTL) and sent on again (AUTO), from the firmware: as ``sitl_mock`` does.

    SITL_DIR=/path/to/ardupilot .venv/bin/python checks/rover_rtl.py
    .venv/bin/python checks/rover_rtl.py --mock ardupilot        # the mock's parked rover
    .venv/bin/python checks/rover_rtl.py --connect tcp:127.0.0.1:5990   # one running

Starts ArduRover SITL (``build/sitl/bin/ardurover``, instance 23, WP_SPEED 8) unless
``--connect`` names a running one or ``--mock`` starts ``sitl_mock`` with one parked
rover, sets RTL_SPEED 8 m/s, uploads a mission of an L (600 m east, then 600 m north, then
600 m west, at 8 m/s by DO_CHANGE_SPEED) and sends it off in AUTO, then, as its
operator:

1. 200 m up the second leg, heading north away from home: RTL (SET_MODE). It must brake
   on its way and turn round without a stop (20-45 m on, never under 1 m/s), drive
   home (its bearing from home, once at speed, steady), say "Reached destination" within
   WP_RADIUS of home and come to a stand there (within twice that), its
   MISSION_CURRENT still the item it was driving to (``sitl_mock.rtl``);
2. 10 s later, AUTO: it must drive from home straight to that item (the corner 600 m
   east and north), as ``AP_Mission::resume`` restarts the current command, and then on
   to the next;
3. two rally points uploaded (MAV_MISSION_TYPE_RALLY) and read back as the service reads
   them (``convoy_mav.mavlink.rally.RallyRead``, with RALLY_LIMIT_KM and RALLY_INCL_HOME),
   RTL: it must drive to the one ``rally.rtl_destination`` picks from where it is, not
   home, and say "Reached destination" there; AUTO, and 200 m on with RALLY_LIMIT_KM
   set to 0.1, RTL again: home.

Prints the drive every 10 s of boot time and each rule's outcome; exit 0 when all hold.
Not part of ``make test``: it needs ArduPilot SITL (see the project's notes on building
it). Run against both to set them side by side.
"""

from __future__ import annotations

import math
import sys
import time
from types import SimpleNamespace
from typing import Any

from pymavlink.dialects.v20 import common as mavlink
from rover_mission import (  # (checks/, beside this one)
    ROVER_AUTO,
    ROVER_RTL,
    check_main,
    reach,
    send_off,
    upload,
)

from convoy_mav.mavlink.rally import RallyRead, rtl_destination

HOME = (47.397742, 8.545594, 488.0)
LEG_M = 600.0
CORNERS = ((0.0, 0.0), (0.0, LEG_M), (LEG_M, LEG_M), (LEG_M, 0.0))  # (north, east) m
RTL_AT_NORTH = 200.0  # m up the second leg
SPEED = 8.0  # m/s: the mission's DO_CHANGE_SPEED and RTL_SPEED (WP_SPEED may differ)
WP_RADIUS = 2.0  # m: ArduRover's default
STEADY_RAD = 0.02  # rad: a straight drive's bearing varies less
# Sent home heading away at 8 m/s it brakes on its way at about 1 m/s^2 and turns round
# without a stop (SITL: 29 m on, 1.65 m/s; what the service forecasts, ``ConvoyModel._way``).
TURN_ON_M = (20.0, 45.0)
# Then, heading west past item 4: one rally point 330 m off (nearer than home, within
# Rover's RALLY_LIMIT_KM 0.5), one 1 km off.
RALLY_POINTS = ((450.0, 250.0), (1200.0, 1200.0))
TURN_SLOWEST_MPS = 1.0


def _geo(north: float, east: float) -> tuple[int, int]:
    lat, lon, _ = HOME
    d_lat = north / 111_320.0
    d_lon = east / (111_320.0 * math.cos(math.radians(lat)))
    return round((lat + d_lat) * 1e7), round((lon + d_lon) * 1e7)


def _ned(msg: Any) -> tuple[float, float]:
    lat, lon, _ = HOME
    north = (msg.lat * 1e-7 - lat) * 111_320.0
    east = (msg.lon * 1e-7 - lon) * 111_320.0 * math.cos(math.radians(lat))
    return north, east


def mission(target: tuple[int, int]) -> list[Any]:
    rel, wp = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT
    speed = (mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED, 1.0, SPEED, 0, 0)
    rows = [(mavlink.MAV_FRAME_GLOBAL, wp, 0.0, 0.0, *_geo(0.0, 0.0))]  # (item 0: home)
    rows += [(rel, wp, 0.0, 0.0, *_geo(*CORNERS[0])), speed]
    rows += [(rel, wp, 0.0, 0.0, *_geo(n, e)) for n, e in CORNERS[1:]]
    kind = mavlink.MAV_MISSION_TYPE_MISSION
    return [
        mavlink.MAVLink_mission_item_int_message(
            *target, seq, frame, command, 0, 1, p1, p2, 0.0, 0.0, x, y, 0.0, kind
        )
        for seq, (frame, command, p1, p2, x, y) in enumerate(rows)
    ]


class Drive:
    """What the rover said and did, message by message."""

    def __init__(self, link: Any) -> None:
        self.link = link
        self.at = (0.0, 0.0)
        self.speed = 0.0
        self.t = 0.0
        self.seq = -1
        self.texts: list[str] = []
        self._shown = -math.inf

    def wait(self, until: Any, timeout: float = 600.0) -> bool:
        """Read the rover until ``until(self)`` holds (False: it fell silent or never did)."""
        deadline = time.monotonic() + timeout
        kinds = ["GLOBAL_POSITION_INT", "MISSION_CURRENT", "STATUSTEXT"]
        while time.monotonic() < deadline:
            m = self.link.recv_match(type=kinds, blocking=True, timeout=30)
            if m is None:
                print("the rover fell silent")
                return False
            kind = m.get_type()
            if kind == "STATUSTEXT":
                self.texts.append(m.text)
                print(f"  STATUSTEXT {m.text!r}", flush=True)
            elif kind == "MISSION_CURRENT":
                self.seq = m.seq
            else:
                self.t, self.at = m.time_boot_ms * 1e-3, _ned(m)
                self.speed = math.hypot(m.vx, m.vy) * 0.01
                if self.t - self._shown >= 10.0:
                    self._shown = self.t
                    n, e = self.at
                    print(f"boot {self.t:6.1f} s  north {n:7.1f}  east {e:7.1f}  "
                          f"{self.speed:5.2f} m/s  item {self.seq}", flush=True)  # fmt: skip
            if until(self):
                return True
        return False


def _bearing(frm: tuple[float, float], to: tuple[float, float]) -> float:
    return math.atan2(to[1] - frm[1], to[0] - frm[0])


def check(ok: bool, what: str) -> bool:
    print(f"{'ok ' if ok else 'BAD'} {what}", flush=True)
    return ok


def set_off(connection: str) -> tuple[Any, tuple[int, int], Drive] | None:
    """The rover at ``connection`` reached, RTL_SPEED set, sent off along the L in AUTO,
    and read (``Drive``); None, said, if it could not be."""
    reached = reach(connection)
    if reached is None:
        return None
    link, target = reached
    link.mav.param_set_send(*target, b"RTL_SPEED", SPEED, mavlink.MAV_PARAM_TYPE_REAL32)
    answer, armed = send_off(link, target, mission(target))
    if not armed:
        print(f"the rover was not sent off: upload {answer}, not armed in AUTO")
        return None
    for stream in (mavlink.MAV_DATA_STREAM_POSITION, mavlink.MAV_DATA_STREAM_EXTENDED_STATUS):
        link.mav.request_data_stream_send(*target, stream, 4, 1)
    return link, target, Drive(link)


def run(connection: str) -> int:
    started = set_off(connection)
    if started is None:
        return 2
    link, target, drive = started
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    corner = CORNERS[2]
    if not drive.wait(lambda d: d.at[0] > RTL_AT_NORTH and d.at[1] > LEG_M - 20.0):
        return 2
    driving_to = drive.seq
    link.mav.set_mode_send(target[0], flag, ROVER_RTL)
    print(f"RTL at north {drive.at[0]:.0f} east {drive.at[1]:.0f}, driving to item {driving_to}")
    ok = True
    bearings: list[float] = []
    seqs: set[int] = set()
    told_at, told_t = drive.at, drive.t
    turn = {"on": 0.0, "slowest": math.inf}  # (how far on its way it went, how slow)

    def home_reached(d: Drive) -> bool:
        seqs.add(d.seq)
        if d.t - told_t <= 20.0:
            turn["on"] = max(turn["on"], d.at[0] - told_at[0])
            turn["slowest"] = min(turn["slowest"], d.speed)
        if d.speed > 0.9 * SPEED and math.hypot(*d.at) < 500.0:
            bearings.append(_bearing((0.0, 0.0), d.at))
        return "Reached destination" in d.texts

    if not drive.wait(home_reached):
        return check(False, "never said 'Reached destination'") and 1
    off = math.hypot(*drive.at)
    ok &= check(off <= WP_RADIUS + 1.0, f"'Reached destination' {off:.1f} m from home")
    spread = max(bearings) - min(bearings) if bearings else math.inf
    ok &= check(spread < STEADY_RAD, f"straight home: bearing spread {spread:.4f} rad")
    ok &= check(seqs == {driving_to}, f"MISSION_CURRENT while home-bound {sorted(seqs)}")
    on, slowest = turn["on"], turn["slowest"]
    ok &= check(
        TURN_ON_M[0] <= on <= TURN_ON_M[1] and slowest >= TURN_SLOWEST_MPS,
        f"turns round braking on its way: {on:.1f} m on, slowest {slowest:.2f} m/s",
    )
    t0 = drive.t
    drive.wait(lambda d: d.t > t0 + 10.0)
    stood_at, t0 = drive.at, drive.t
    drive.wait(lambda d: d.t > t0 + 10.0)
    moved, off = math.dist(drive.at, stood_at), math.hypot(*drive.at)
    ok &= check(moved < 1.0 and drive.speed < 0.2, f"stands: {moved:.1f} m in 10 s")
    ok &= check(off <= 2.0 * WP_RADIUS, f"stands {off:.1f} m from home")
    link.mav.set_mode_send(target[0], flag, ROVER_AUTO)
    print("AUTO", flush=True)
    start, way = drive.at, _bearing(drive.at, corner)
    off_way: list[float] = []

    def at_corner(d: Drive) -> bool:
        if math.dist(d.at, start) > 50.0 and math.dist(d.at, corner) > 50.0:
            off_way.append(abs(math.remainder(_bearing(start, d.at) - way, math.tau)))
        return math.dist(d.at, corner) < 10.0

    if not drive.wait(at_corner):
        return check(False, "never came to the item it had left") and 1
    worst = max(off_way) if off_way else math.inf
    ok &= check(worst < 0.05, f"straight to item {driving_to}: off its bearing {worst:.3f} rad")
    drive.wait(lambda d: d.seq > driving_to or math.dist(d.at, corner) > 60.0)
    ok &= check(drive.seq == driving_to + 1, f"then on to item {drive.seq}")
    return 0 if _to_rally(link, target, drive) and ok else 1


def _to_rally(link: Any, target: tuple[int, int], drive: Drive) -> bool:
    """Rally points uploaded, read back as the service reads them (``RallyRead``), and
    RTL: the rover must drive to the one ``rtl_destination`` picks from where it is."""
    rally = mavlink.MAV_MISSION_TYPE_RALLY
    rel, point = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_RALLY_POINT
    points = []
    for seq, (n, e) in enumerate(RALLY_POINTS):
        x, y = _geo(n, e)
        points.append(
            mavlink.MAVLink_mission_item_int_message(
                *target, seq, rel, point, 0, 0, 0, 0, 0, 0, x, y, 0.0, rally
            )
        )
    answer = upload(link, target, points, rally)
    ok = check(answer == "MAV_MISSION_ACCEPTED", f"rally points uploaded: {answer}")
    read = RallyRead(*target, own=250)
    for out in read.start(time.monotonic()):
        link.mav.send(out)
    deadline = time.monotonic() + 20.0
    while not read.done and time.monotonic() < deadline:
        msg = link.recv_match(blocking=True, timeout=0.1)
        now = time.monotonic()
        outs = read.poll(now) if msg is None else read.handle(msg, now) + read.poll(now)
        for out in outs:
            link.mav.send(out)
    got = [_ned(SimpleNamespace(lat=lat * 1e7, lon=lon * 1e7)) for lat, lon in read.points]
    ok &= check(
        read.done and read.error is None and len(got) == len(RALLY_POINTS),
        f"read back: {len(got)} points, RALLY_LIMIT_KM {read.limit_km:g}, "
        f"RALLY_INCL_HOME {read.incl_home:d} ({read.error or 'ok'})",
    )
    ok &= _rtl_to(link, target, drive, got, read.limit_km, read.incl_home, "the rally point")
    # On in AUTO until 200 m from it, RALLY_LIMIT_KM 0.1: RTL must now take it home.
    link.mav.set_mode_send(target[0], mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_AUTO)
    rally_at = drive.at
    drive.wait(lambda d: math.dist(d.at, rally_at) > 200.0)
    link.mav.param_set_send(*target, b"RALLY_LIMIT_KM", 0.1, mavlink.MAV_PARAM_TYPE_REAL32)
    time.sleep(0.5)
    return _rtl_to(link, target, drive, got, 0.1, read.incl_home, "home, the point too far") and ok


def _rtl_to(
    link: Any,
    target: tuple[int, int],
    drive: Drive,
    rallies: list[tuple[float, float]],
    limit_km: float,
    incl_home: bool,
    what: str,
) -> bool:
    """RTL now: the rover must say "Reached destination" where ``rtl_destination`` says."""
    drive.wait(lambda d: d.t > 0.0)  # (where it is now)
    goal = rtl_destination(drive.at, (0.0, 0.0), rallies, limit_km, incl_home)
    (n, e), (gn, ge) = drive.at, goal
    print(f"RTL at north {n:.0f} east {e:.0f}: to north {gn:.0f} east {ge:.0f}", flush=True)
    drive.texts.clear()
    link.mav.set_mode_send(target[0], mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_RTL)
    if not drive.wait(lambda d: "Reached destination" in d.texts):
        return check(False, "never said 'Reached destination'")
    off = math.dist(drive.at, goal)
    return check(off <= WP_RADIUS + 1.0, f"at {what}: {off:.1f} m off")


def main() -> int:
    return check_main(
        __doc__.split("\n\n")[0], run, home=HOME, instance=23, wp_speed=8,
        mock_port=14797, mock_speedup=5.0,
    )  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
