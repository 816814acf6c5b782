"""A rover's mission uploaded by its operator, from the firmware: what ``sitl_mock`` answers.

    SITL_DIR=/path/to/ardupilot .venv/bin/python checks/rover_uploads.py
    .venv/bin/python checks/rover_uploads.py --mock ardupilot        # the mock's parked rover
    .venv/bin/python checks/rover_uploads.py --connect tcp:127.0.0.1:5980   # one running

Starts ArduRover SITL (``build/sitl/bin/ardurover``, instance 22, WP_SPEED 4) unless
``--connect`` names a running one or ``--mock`` starts ``sitl_mock`` with one parked
rover, and acts as its operator's ground station:

1. AUTO (DO_SET_MODE) with no mission: the answer and the STATUSTEXTs (a rover with no
   mission boots in HOLD);
2. uploads refused: a command MAVLink does not define, a waypoint in a local frame;
3. a mission of home, waypoints 30, 180 and 330 m north (the first held 5 s), a NAV_LAND
   and a DO_CHANGE_SPEED to 3 m/s after the first: uploaded, read back, driven in AUTO
   (armed), its MISSION_CURRENT followed: the landing must be driven past;
4. 100 m north, driving to item 4, the mission uploaded again with item 4 moved 60 m
   east: the rover must drive on to the new item 4 ("Auto mission changed, restarted
   command"), then item 5;
5. the mission cleared (a count of 0) while it drives: it stands; HOLD, then AUTO
   refused again.

Prints each answer; exit 0 when each is as ``sitl_mock.uploaded`` and the mock's
autopilot give them (``EXPECTED``). Run against both to set them side by side. Not part
of ``make test``: it needs ArduPilot SITL (see the project's notes on building it).
"""

from __future__ import annotations

import math
import sys
import time
from typing import Any

from pymavlink.dialects.v20 import common as mavlink
from rover_mission import (  # (checks/, beside this one)
    ROVER_AUTO,
    ROVER_HOLD,
    check_main,
    reach,
    upload,
)

HOME = (47.397742, 8.545594, 488.0)
MISSION = mavlink.MAV_MISSION_TYPE_MISSION
NO_MISSION = "MAV_RESULT_FAILED: Flight mode change failed | No Mission. Can't set AUTO."
RECEIVED = "MAV_MISSION_ACCEPTED: Flight plan received"
EXPECTED = {
    "auto, no mission": NO_MISSION,
    "upload, command 65000": "MAV_MISSION_UNSUPPORTED",
    "upload, local frame": "MAV_MISSION_UNSUPPORTED_FRAME",
    "upload, with a landing": RECEIVED,
    "read back": "6 items: 16 16 21 178 16 16",
    "auto": "MAV_RESULT_ACCEPTED",
    "mission current, before the change": "1 4",
    "upload while driving to item 4": (
        "MAV_MISSION_ACCEPTED: Auto mission changed, restarted command | Flight plan received"
    ),
    "driven to the new item 4": "yes",
    "mission current, after": "5",
    "clear while driving": (
        "MAV_MISSION_ACCEPTED: Auto mission changed but failed to restart command"
        " | Flight plan received"
    ),
    "stands": "yes",
    "hold, then auto": f"MAV_RESULT_ACCEPTED, {NO_MISSION}",
}


def _at(north: float, east: float = 0.0) -> tuple[int, int]:
    lat, lon, _ = HOME
    lon_m = 111_320.0 * math.cos(math.radians(lat))
    return round((lat + north / 111_320.0) * 1e7), round((lon + east / lon_m) * 1e7)


Row = tuple[int, int, float, float, tuple[int, int]]
# (ArduRover's texts the mock does not send: its estimator's, its pre-arm checks', and the
# "Mission: 4 WP" of each item it starts)
_CHATTER = ("EKF", "Field Elevation", "AHRS", "GPS", "PreArm", "Mission: ")
_WP, _REL = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
_SET_MODE, _REQUEST = mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_REQUEST_MESSAGE


def _items(target: tuple[int, int], rows: list[Row]) -> list[Any]:
    """(command, frame, param1, param2, (lat, lon) e7) rows as MISSION_ITEM_INTs."""
    return [
        mavlink.MAVLink_mission_item_int_message(
            *target, seq, frame, command, 0, 1, p1, p2, 0.0, 0.0, *where, 0.0, MISSION
        )
        for seq, (command, frame, p1, p2, where) in enumerate(rows)
    ]


def _answers(link: Any, seconds: float, acks: list[str], texts: list[str]) -> None:
    """COMMAND_ACKs of DO_SET_MODE and MISSION_ACKs, and STATUSTEXTs, for ``seconds``."""
    deadline = time.monotonic() + seconds
    kinds = ["COMMAND_ACK", "MISSION_ACK", "STATUSTEXT"]
    while time.monotonic() < deadline:
        m = link.recv_match(type=kinds, blocking=True, timeout=0.2)
        if m is None:
            continue
        if m.get_type() == "STATUSTEXT":
            if not m.text.startswith(_CHATTER):
                texts.append(m.text)
        elif m.get_type() == "MISSION_ACK":
            acks.append(mavlink.enums["MAV_MISSION_RESULT"][m.type].name)
        elif m.command == mavlink.MAV_CMD_DO_SET_MODE:
            acks.append(mavlink.enums["MAV_RESULT"][m.result].name)


def _said(acks: list[str], texts: list[str]) -> str:
    """The answers, and the texts each once, sorted (ArduRover checks for a changed mission
    as the items come: it may restart its command more than once during one upload)."""
    said = sorted(set(texts))
    return ", ".join(acks or ["no answer"]) + (": " + " | ".join(said) if said else "")


def _mode(link: Any, target: tuple[int, int], mode: int, *, seconds: float = 2.0) -> str:
    """DO_SET_MODE to ArduRover's ``mode``: the answer and the texts within ``seconds``."""
    flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    link.mav.command_long_send(*target, _SET_MODE, 0, flag, mode, 0, 0, 0, 0, 0)
    acks: list[str] = []
    texts: list[str] = []
    _answers(link, seconds, acks, texts)
    return _said(acks, texts)


def _upload(link: Any, target: tuple[int, int], mission: list[Any]) -> str:
    """``upload``'s answer and the texts within 2 s after."""
    answer = upload(link, target, mission)
    acks: list[str] = []
    texts: list[str] = []
    _answers(link, 2.0, acks, texts)
    return _said([answer], texts)


def _read_back(link: Any, target: tuple[int, int]) -> str:
    link.mav.mission_request_list_send(*target, MISSION)
    count = link.recv_match(type="MISSION_COUNT", blocking=True, timeout=5.0)
    if count is None:
        return "no count"
    commands = []
    for seq in range(count.count):
        link.mav.mission_request_int_send(*target, seq, MISSION)
        item = link.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=5.0)
        commands.append(str(item.command) if item is not None else "?")
    link.mav.mission_ack_send(*target, mavlink.MAV_MISSION_ACCEPTED, MISSION)
    return f"{count.count} items: {' '.join(commands)}"


class _Drive:
    """The rover's MISSION_CURRENT and place, as they come."""

    def __init__(self, link: Any) -> None:
        self.link = link
        self.seqs: list[int] = []
        self.north = self.east = self.speed = 0.0

    def until(self, done: Any, seconds: float) -> bool:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            kinds = ["MISSION_CURRENT", "GLOBAL_POSITION_INT"]
            m = self.link.recv_match(type=kinds, blocking=True, timeout=1.0)
            if m is None:
                continue
            if m.get_type() == "MISSION_CURRENT":
                if not self.seqs or self.seqs[-1] != m.seq:
                    self.seqs.append(m.seq)
                    print(f"  MISSION_CURRENT {m.seq}", flush=True)
                continue
            lat0, lon0, _ = HOME
            self.north = (m.lat * 1e-7 - lat0) * 111_320.0
            self.east = (m.lon * 1e-7 - lon0) * 111_320.0 * math.cos(math.radians(lat0))
            self.speed = math.hypot(m.vx, m.vy) * 0.01
            if done(self):
                return True
        return False


def run(connection: str) -> int:
    reached = reach(connection)
    if reached is None:
        return 2
    link, target = reached
    home = mavlink.MAVLINK_MSG_ID_HOME_POSITION
    for _ in range(60):  # (a home, as an operator waits for one)
        link.mav.command_long_send(*target, _REQUEST, 0, home, 0, 0, 0, 0, 0, 0)
        if link.recv_match(type="HOME_POSITION", blocking=True, timeout=2.0) is not None:
            break
    link.mav.request_data_stream_send(*target, mavlink.MAV_DATA_STREAM_ALL, 4, 1)
    got: dict[str, str] = {}

    def say(key: str, value: str) -> None:
        got[key] = value
        print(f"{key}: {value}", flush=True)

    say("auto, no mission", _mode(link, target, ROVER_AUTO))
    wp, rel, gm = _WP, _REL, mavlink.MAV_FRAME_MISSION
    home_row = (wp, mavlink.MAV_FRAME_GLOBAL, 0.0, 0.0, _at(0.0))
    first = (wp, rel, 0.0, 0.0, _at(50.0))
    unknown = (65000, gm, 0.0, 0.0, (0, 0))
    say("upload, command 65000", upload(link, target, _items(target, [home_row, first, unknown])))
    local = (wp, mavlink.MAV_FRAME_LOCAL_NED, 0.0, 0.0, (500, 0))
    say("upload, local frame", upload(link, target, _items(target, [home_row, first, local])))
    rows: list[Row] = [
        home_row,
        (wp, rel, 5.0, 0.0, _at(30.0)),
        (mavlink.MAV_CMD_NAV_LAND, rel, 0.0, 0.0, (0, 0)),
        (mavlink.MAV_CMD_DO_CHANGE_SPEED, gm, 1.0, 3.0, (0, 0)),
        (wp, rel, 0.0, 0.0, _at(180.0)),
        (wp, rel, 0.0, 0.0, _at(330.0)),
    ]
    say("upload, with a landing", _upload(link, target, _items(target, rows)))
    say("read back", _read_back(link, target))
    got["auto"] = _mode(link, target, ROVER_AUTO)
    arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    for _ in range(30):
        link.mav.command_long_send(*target, arm, 0, 1, 0, 0, 0, 0, 0, 0)
        ack = link.recv_match(type="COMMAND_ACK", blocking=True, timeout=2.0)
        if ack is not None and ack.command == arm and ack.result == mavlink.MAV_RESULT_ACCEPTED:
            break
        time.sleep(1.0)
    drive = _Drive(link)
    drive.until(lambda d: d.north > 100.0, 120.0)
    say("mission current, before the change", " ".join(str(s) for s in drive.seqs if s > 0))
    # Item 4 moved 60 m east: ArduRover drives on to the new item 4 at once.
    moved = list(rows)
    moved[4] = (wp, rel, 0.0, 0.0, _at(180.0, 60.0))
    drive.seqs.clear()
    say("upload while driving to item 4", _upload(link, target, _items(target, moved)))
    there = drive.until(lambda d: math.hypot(d.north - 180.0, d.east - 60.0) < 3.0, 120.0)
    say("driven to the new item 4", "yes" if there else "no")
    drive.until(lambda d: d.north > 220.0, 60.0)
    say("mission current, after", " ".join(str(s) for s in drive.seqs if s > 4))
    say("clear while driving", _upload(link, target, []))
    stood = drive.until(lambda d: d.speed < 0.1, 60.0)
    say("stands", "yes" if stood else "no")
    hold = _mode(link, target, ROVER_HOLD)
    say("hold, then auto", f"{hold}, {_mode(link, target, ROVER_AUTO)}")
    ok = True
    for key, want in EXPECTED.items():
        fine = got.get(key) == want
        ok = ok and fine
        wanted = "" if fine else f" (expected {want!r})"
        print(f"{'ok ' if fine else 'BAD'} {key}: {got.get(key)!r}{wanted}")
    return 0 if ok else 1


def main() -> int:
    return check_main(
        __doc__.split("\n\n")[0], run, home=HOME, instance=22, wp_speed=4,
        mock_port=14795,
    )  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
