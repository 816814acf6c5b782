"""ArduRover's speed rules, from the firmware: the ones ``sitl_mock`` drives its rovers by.

    SITL_DIR=/path/to/ardupilot .venv/bin/python checks/rover_speeds.py
    .venv/bin/python checks/rover_speeds.py --connect tcp:127.0.0.1:5970   # one running

Starts ArduRover SITL (``build/sitl/bin/ardurover``, instance 21, WP_SPEED 8) unless
``--connect`` names a running one, uploads a straight 3.2-km mission east (a waypoint
every 400 m; DO_CHANGE_SPEED 8 m/s first, 6 after the second waypoint, 7 after the
fifth), switches to AUTO and arms, then, as an operator:

1. DO_CHANGE_SPEED 5 m/s by command 150 m in: kept until the mission's next (6 m/s,
   800 m), as ``sitl_mock.roverdrive`` keeps it;
2. HOLD at 1300 m (on the 6 m/s stretch), AUTO 12 s later: WP_SPEED (8 m/s) until the
   mission's next (7 m/s, 2000 m): ``AR_WPNav::init`` on entering AUTO, and no DO
   command run again by ``AP_Mission::resume``.

Prints the drive every 5 s of boot time and each rule's speeds; exit 0 when all four
stretches ran at the expected speed (within 0.1 m/s over their middle). Not part of
``make test``: it needs ArduPilot SITL (see the project's notes on building it).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink
from rover_mission import (  # (checks/, beside this one)
    ROVER_AUTO,
    ROVER_HOLD,
    send_off,
    with_ardurover,
)

HOME = (47.397742, 8.545594, 488.0)
LEG_M = 400.0
# (from, to metres east, the speed ArduRover should keep there, why)
EXPECTED = (
    (300.0, 750.0, 5.0, "told 5 m/s by command, before the mission's next"),
    (900.0, 1250.0, 6.0, "the mission's DO_CHANGE_SPEED 6 after waypoint 2"),
    (1450.0, 1950.0, 8.0, "AUTO again: WP_SPEED, not the mission's 6"),
    (2100.0, 2900.0, 7.0, "the mission's DO_CHANGE_SPEED 7 after waypoint 5"),
)


def _east(metres: float) -> tuple[int, int]:
    lat, lon, _ = HOME
    return round(lat * 1e7), round((lon + metres / (111320.0 * math.cos(math.radians(lat)))) * 1e7)


def _mission(target: tuple[int, int]) -> list[Any]:
    rel, wp = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_WAYPOINT

    def speed(v: float) -> list[Any]:
        return [mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 1,
                1.0, v, -1.0, 0.0, 0, 0, 0.0]  # fmt: skip

    rows = [[mavlink.MAV_FRAME_GLOBAL, wp, 0, 1, 0.0, 0.0, 0.0, 0.0, *_east(0.0), 0.0], speed(8.0)]
    for k in range(1, 9):
        rows.append([rel, wp, 0, 1, 0.0, 0.0, 0.0, 0.0, *_east(LEG_M * k), 0.0])
        if k in (2, 5):
            rows.append(speed(6.0 if k == 2 else 7.0))
    return [
        mavlink.MAVLink_mission_item_int_message(
            *target, seq, *row, mavlink.MAV_MISSION_TYPE_MISSION
        )
        for seq, row in enumerate(rows)
    ]


def run(connection: str) -> int:
    link = mavutil.mavlink_connection(connection, source_system=250, source_component=190)
    if link.wait_heartbeat(timeout=60) is None:
        print(f"no heartbeat on {connection}")
        return 2
    target = (link.target_system, link.target_component)
    answer, armed = send_off(link, target, _mission(target))
    if not armed:
        print(f"the rover was not sent off: upload {answer}, not armed in AUTO")
        return 2
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    link.mav.request_data_stream_send(*target, mavlink.MAV_DATA_STREAM_POSITION, 4, 1)
    lat0, lon0, _ = HOME
    told = False
    held: float | None = None
    back = False
    shown = -math.inf
    drive: list[tuple[float, float]] = []  # (metres east, m/s)
    while not drive or drive[-1][0] < 3000.0:
        m = link.recv_match(type=["GLOBAL_POSITION_INT", "COMMAND_ACK"], blocking=True, timeout=30)
        if m is None:
            print("the rover sends no position")
            return 2
        if m.get_type() == "COMMAND_ACK":
            name = mavlink.enums["MAV_RESULT"][m.result].name
            print(f"  COMMAND_ACK {m.command}: {name}", flush=True)
            continue
        t = m.time_boot_ms * 1e-3
        x = (m.lon * 1e-7 - lon0) * 111320.0 * math.cos(math.radians(lat0))
        v = math.hypot(m.vx, m.vy) * 0.01
        drive.append((x, v))
        if t - shown >= 5.0:
            print(f"boot {t:6.1f} s  {x:7.1f} m east  {v:5.2f} m/s", flush=True)
            shown = t
        if not told and x > 150.0:
            told = True
            link.mav.command_long_send(*target, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0,
                                       mavlink.SPEED_TYPE_GROUNDSPEED, 5.0, -1.0,
                                       0, 0, 0, 0)  # fmt: skip
            print(f"DO_CHANGE_SPEED 5 m/s at {x:.0f} m", flush=True)
        if held is None and x > 1300.0:
            held = t
            link.mav.set_mode_send(target[0], flag, ROVER_HOLD)
            print(f"HOLD at {x:.0f} m", flush=True)
        if held is not None and not back and t > held + 12.0:
            back = True
            link.mav.set_mode_send(target[0], flag, ROVER_AUTO)
            print(f"AUTO at {x:.0f} m", flush=True)
    ok = True
    for lo, hi, expected, why in EXPECTED:
        speeds = [v for x, v in drive if lo <= x <= hi]
        fine = bool(speeds) and all(abs(v - expected) <= 0.1 for v in speeds)
        ok = ok and fine
        got = f"{min(speeds):.2f}-{max(speeds):.2f}" if speeds else "none"
        print(f"{'ok ' if fine else 'BAD'} {lo:.0f}-{hi:.0f} m: {got} m/s, expected {expected:.0f} "
              f"({why})")  # fmt: skip
    return 0 if ok else 1


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--connect", help="a running ArduRover's MAVLink endpoint")
    args = parser.parse_args()
    if args.connect:
        return run(args.connect)
    return with_ardurover(run, instance=21, wp_speed=8, home=HOME)


if __name__ == "__main__":
    sys.exit(main())
