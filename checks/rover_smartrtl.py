"""A rover sent home back along its path (SMART_RTL), from the firmware: as ``sitl_mock`` does.

    SITL_DIR=/path/to/ardupilot .venv/bin/python checks/rover_smartrtl.py
    .venv/bin/python checks/rover_smartrtl.py --mock ardupilot      # the mock's parked rover
    .venv/bin/python checks/rover_smartrtl.py --connect tcp:127.0.0.1:6000   # one running

Starts ArduRover SITL (instance 24, WP_SPEED 8) unless ``--connect`` names a running one
or ``--mock`` starts ``sitl_mock`` with one parked rover, sets RTL_SPEED 8 m/s, uploads
``rover_rtl.py``'s L (600 m east, 600 m north, 600 m west, at 8 m/s) and sends it off in
AUTO, then, as its operator, 200 m up the second leg heading north: SMART_RTL (12). As
ArduRover's ``ModeSmartRTL`` drives its ``AP_SmartRTL`` path (``sitl_mock.smartrtl``),
it must turn round on its way (never more than 45 m on), drive back south along the
leg it came up and west along the first, never more than 5 m off the road it drove
(never across the block, as RTL does), round the corner 600 m east within 5 m, say
"Reached destination" within WP_RADIUS + 1 m of where it set off, and stand there.

Prints the drive every 10 s of boot time and each rule's outcome; exit 0 when all hold.
Not part of ``make test``: it needs ArduPilot SITL. Run against both to set them side by
side.
"""

from __future__ import annotations

import itertools
import math
import sys

from pymavlink.dialects.v20 import common as mavlink
from rover_mission import check_main  # (checks/, beside this one)
from rover_rtl import CORNERS, HOME, LEG_M, RTL_AT_NORTH, WP_RADIUS, Drive, check, set_off

ROVER_SMART_RTL = 12  # ArduRover's custom mode
OFF_ROAD_M = 5.0  # m: the most it may stray from the road it drove, corners cut included
TURN_ON_M = 45.0  # m: the most it may go on along its way before it is back


def _off_road(at: tuple[float, float]) -> float:
    """How far ``at`` (north, east) is from the L's first two legs: the road it drove."""
    best = math.inf
    for (n0, e0), (n1, e1) in itertools.pairwise(CORNERS[:3]):
        dn, de = n1 - n0, e1 - e0
        t = max(0.0, min(1.0, ((at[0] - n0) * dn + (at[1] - e0) * de) / (dn * dn + de * de)))
        best = min(best, math.hypot(at[0] - n0 - t * dn, at[1] - e0 - t * de))
    return best


def run(connection: str) -> int:
    started = set_off(connection)
    if started is None:
        return 2
    link, target, drive = started
    if not drive.wait(lambda d: math.hypot(*d.at) > 1.0):
        return 2
    start = drive.at  # (its path began where it armed: about here)
    if not drive.wait(lambda d: d.at[0] > RTL_AT_NORTH and d.at[1] > LEG_M - 20.0):
        return 2
    link.mav.set_mode_send(target[0], mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_SMART_RTL)
    told = drive.at
    print(f"SMART_RTL at north {told[0]:.0f} east {told[1]:.0f}", flush=True)
    seen = {"off": 0.0, "on": 0.0, "corner": math.inf}

    def home(d: Drive) -> bool:
        seen["off"] = max(seen["off"], _off_road(d.at))
        seen["on"] = max(seen["on"], d.at[0] - told[0])
        seen["corner"] = min(seen["corner"], math.dist(d.at, CORNERS[1]))
        return "Reached destination" in d.texts

    if not drive.wait(home):
        return check(False, "never said 'Reached destination'") and 1
    ok = check(seen["on"] <= TURN_ON_M, f"turns round {seen['on']:.1f} m on its way")
    ok &= check(seen["off"] <= OFF_ROAD_M, f"back along its road: {seen['off']:.1f} m off it")
    ok &= check(seen["corner"] <= OFF_ROAD_M, f"round its corner: {seen['corner']:.1f} m off")
    off = math.dist(drive.at, start)
    ok &= check(off <= WP_RADIUS + 1.0, f"'Reached destination' {off:.1f} m from its start")
    t0 = drive.t
    drive.wait(lambda d: d.t > t0 + 10.0)
    stood, t0 = drive.at, drive.t
    drive.wait(lambda d: d.t > t0 + 10.0)
    moved = math.dist(drive.at, stood)
    ok &= check(moved < 1.0 and drive.speed < 0.2, f"stands: {moved:.1f} m in 10 s")
    return 0 if ok else 1


def main() -> int:
    return check_main(
        __doc__.split("\n\n")[0], run, home=HOME, instance=24, wp_speed=8,
        mock_port=14798, mock_speedup=5.0,
    )  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
