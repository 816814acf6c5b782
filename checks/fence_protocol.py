"""What an autopilot answers in a geofence upload's corner cases (mission protocol,
MAV_MISSION_TYPE_FENCE): the check that ``sitl_mock`` answers them as the firmware does.

    .venv/bin/python checks/fence_protocol.py udpin:127.0.0.1:14550   # ArduPilot SITL
    .venv/bin/python checks/fence_protocol.py --mock ardupilot        # the mock, same probes

Probes, each on a four-vertex inclusion polygon:
  in-turn       the upload as the service makes it: every answer, to the final MISSION_ACK;
  copy-of-last  the last item sent again after the upload closed (its ACK lost);
  copy-mid      item 0 sent twice during an upload, then the rest;
  out-of-turn   item 2 sent when item 1 is asked for, then the rest.
Prints one line per probe: what came back to each message sent (REQ n: a request for item
n; ACK NAME: a MISSION_ACK; -: nothing within a second), and any STATUSTEXT about
them.
Not part of ``make test``: it needs a running autopilot (ArduPilot SITL, see the
project's notes on building it).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

FENCE = mavlink.MAV_MISSION_TYPE_FENCE
RING = ((-35.3620, 149.1640), (-35.3620, 149.1665), (-35.3645, 149.1665), (-35.3645, 149.1640))
ANSWERS = ("MISSION_ACK", "MISSION_REQUEST", "MISSION_REQUEST_INT", "STATUSTEXT")


def item(target: tuple[int, int], seq: int) -> Any:
    lat, lon = RING[seq]
    return mavlink.MAVLink_mission_item_int_message(
        *target, seq, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
        0, 1, float(len(RING)), 0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0, FENCE,
    )  # fmt: skip


def count(target: tuple[int, int]) -> Any:
    return mavlink.MAVLink_mission_count_message(*target, len(RING), FENCE)


def exchange(link: Any, msg: Any, wait: float = 1.0) -> str:
    """Send ``msg``; what came back within ``wait`` s (until a mission answer, then 0.2 s)."""
    link.mav.send(msg)
    out: list[str] = []
    deadline = time.monotonic() + wait
    while time.monotonic() < deadline:
        reply = link.recv_match(type=list(ANSWERS), blocking=True, timeout=0.05)
        if reply is None:
            continue
        kind = reply.get_type()
        if kind == "STATUSTEXT":
            if any(word in reply.text.lower() for word in ("fence", "mission", "item")):
                out.append(f"TEXT {reply.text!r}")  # (not the EKF's or the GPS's news)
            continue
        if getattr(reply, "mission_type", FENCE) != FENCE:
            continue
        if kind == "MISSION_ACK":
            out.append(f"ACK {mavlink.enums['MAV_MISSION_RESULT'][reply.type].name[12:]}")
        else:
            out.append(f"REQ {reply.seq}")
        deadline = min(deadline, time.monotonic() + 0.2)
    return ", ".join(out) or "-"


def probe(link: Any, name: str, sends: list[Any]) -> None:
    answers = []
    for msg in sends:
        what = "COUNT" if msg.get_type() == "MISSION_COUNT" else f"ITEM {msg.seq}"
        answers.append(f"{what} -> {exchange(link, msg)}")
    print(f"{name:13s} " + " | ".join(answers), flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("connection", nargs="?", help="the autopilot's MAVLink endpoint")
    parser.add_argument("--mock", choices=("px4", "ardupilot"), help="start sitl_mock instead")
    parser.add_argument("--sysid", type=int, default=1)
    args = parser.parse_args()
    mock = None
    connection = args.connection
    if args.mock:
        mock = subprocess.Popen(
            [sys.executable, "-m", "sitl_mock", "--aircraft", "1", "--ground", "0",
             "--frame", "plane", "--personality", args.mock, "--base-port", "14790"],
        )  # fmt: skip
        connection = "udpout:127.0.0.1:14790"
    if connection is None:
        parser.error("give a connection or --mock")
    try:
        link = mavutil.mavlink_connection(connection, source_system=255, source_component=190)
        if mock is not None:
            time.sleep(1.0)
        for _ in range(50):
            link.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            hb = link.recv_match(type="HEARTBEAT", blocking=True, timeout=0.5)
            if hb is not None and hb.get_srcSystem() == args.sysid:
                break
        else:
            print(f"no HEARTBEAT from system {args.sysid} on {connection}", file=sys.stderr)
            return 2
        target = (args.sysid, hb.get_srcComponent())
        last = len(RING) - 1
        steps = [count(target)] + [item(target, k) for k in range(len(RING))]
        probe(link, "in-turn", steps)
        probe(link, "copy-of-last", [item(target, last)])
        probe(link, "copy-mid", [*steps[:2], item(target, 0), *steps[2:]])
        probe(link, "out-of-turn", [*steps[:2], item(target, 2), *steps[2:]])
        return 0
    finally:
        if mock is not None:
            mock.terminate()
            mock.wait()


if __name__ == "__main__":
    sys.exit(main())
