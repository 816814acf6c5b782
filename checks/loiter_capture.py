"""How ArduPlanes fly to their DO_REPOSITION loiters, from a tlog: SITL's against the mock's.

    python checks/loiter_capture.py MISSION.tlog [MISSION.tlog ...]

For each tlog (a `convoy-mav run` against ArduPlane SITL, ``checks/ardupilot_sitl.sh
plane``; or a mock flight, ``convoy-mav replay --personality ardupilot --tlog F``), every
plane's GLOBAL_POSITION_INT is set against the last DO_REPOSITION the service sent it
(COMMAND_INT 192, the tlog's outgoing frames):

- far off: the plane's course against the bearing to the loiter's centre, by how many
  L1 distances (``NAVL1_PERIOD`` 15, damping 0.75: 3.58 s of flight) it is outside the
  circle. L1's capture law (``AP_L1_Control::update_loiter``) flies straight at the
  centre there;
- on a straight leg (a carrot: a loiter 600 m ahead on the line, moved as the plane
  advances): the plane's distance from the line through its last two carrots.
"""

from __future__ import annotations

import math
import statistics
import sys
from collections import defaultdict

from pymavlink import mavutil

from convoy_mav.geo import GeoPoint, LocalFrame, no_position_yet

_L1_S = 0.3183 * 0.75 * 15.0  # s: L1's distance over the ground speed
_FAR = 4.0  # L1 distances out: far off, on a carrot's way
_DO_REPOSITION = 192


def _quantiles(values: list[float]) -> str:
    values = sorted(values)
    if not values:
        return "none"
    p90 = values[int(0.9 * (len(values) - 1))]
    return f"{len(values)} samples, median {statistics.median(values):.1f}, p90 {p90:.1f}"


def measure(path: str) -> dict[str, list[float]]:
    """Course offsets far off (deg) and cross-track distances on carrots (m) in a tlog."""
    link = mavutil.mavlink_connection(path)
    centres: dict[int, list[tuple[float, float, float]]] = defaultdict(list)
    out: dict[str, list[float]] = {"far_deg": [], "line_m": []}
    while (msg := link.recv_match(type=["COMMAND_INT", "GLOBAL_POSITION_INT"])) is not None:
        if msg.get_type() == "COMMAND_INT":
            if msg.command == _DO_REPOSITION and msg.x != 0:
                kept = centres[msg.target_system]
                kept.append((msg.x * 1e-7, msg.y * 1e-7, msg.param3))
                del kept[:-2]
            continue
        kept = centres.get(msg.get_srcSystem(), [])
        speed = math.hypot(msg.vx, msg.vy) / 100.0
        if not kept or speed < 5.0 or kept[-1][2] <= 0.0:
            continue
        if no_position_yet(msg.lat, msg.lon):
            continue
        plane = LocalFrame(GeoPoint(msg.lat * 1e-7, msg.lon * 1e-7))  # (at its origin)
        cn, ce, _ = plane.to_ned(GeoPoint(kept[-1][0], kept[-1][1]))
        if (math.hypot(cn, ce) - kept[-1][2]) / (_L1_S * speed) < _FAR:
            continue
        course = math.atan2(msg.vy, msg.vx)
        off = (course - math.atan2(ce, cn) + math.pi) % (2.0 * math.pi) - math.pi
        out["far_deg"].append(abs(math.degrees(off)))
        if len(kept) == 2:
            an, ae, _ = plane.to_ned(GeoPoint(kept[0][0], kept[0][1]))
            step = math.hypot(cn - an, ce - ae)
            if 20.0 < step < 200.0:  # (a carrot moved on along its line)
                out["line_m"].append(abs((an * (ce - ae) - ae * (cn - an)) / step))
    return out


def main(paths: list[str]) -> int:
    for path in paths:
        got = measure(path)
        print(path)
        far = _quantiles(got["far_deg"])
        print(f"  course off the centre, {_FAR:g}+ L1 distances out (deg): {far}")
        print(f"  off a carrot's line (m): {_quantiles(got['line_m'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]) if len(sys.argv) > 1 else 2)
