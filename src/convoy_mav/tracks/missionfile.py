"""A rover's mission saved by a ground station, as the convoy's route (pure).

Operators plan a rover's drive in QGroundControl or Mission Planner and save it; that file
is the road as well as the live mission is (:mod:`convoy_mav.tracks.missionroute` makes
the road of the items either way). Two formats:

    QGC WPL 110   ``.waypoints`` (Mission Planner, MAVProxy ``wp save``, QGroundControl's
                  export): a ``QGC WPL 110`` line, then one item a line, tab (or space)
                  separated: index, current, frame, command, param1..4, lat, lon, alt,
                  autocontinue. Item 0 is home, as both ground stations write it.
    QGC .plan     QGroundControl's JSON plan: ``mission.items``, each ``SimpleItem`` a
                  ``command``, ``frame`` and seven ``params`` (lat, lon the 5th and 6th);
                  home is ``mission.plannedHomePosition``. Complex items (surveys,
                  corridor scans) are no road: counted among those left out.

Bad input is a ``ValueError`` naming the file, and the line (WPL) or the item (plan).
"""

from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.missionread import MissionItem
from convoy_mav.tracks.missionroute import mission_route
from convoy_mav.tracks.plannedroute import PlannedRoute

__all__ = ["WPL_HEADER", "parse_plan", "parse_waypoints"]

WPL_HEADER = "QGC WPL 110"


def _finite(value: float, where: str) -> float:
    if not math.isfinite(value):
        raise ValueError(f"{where}: {value!r} is not a finite number")
    return value


def parse_waypoints(text: str, name: str) -> PlannedRoute:
    """The road of a QGC WPL 110 file.

    Raises:
        ValueError: Not such a file, a malformed line, or no road (``mission_route``).
    """
    lines = text.splitlines()
    if not lines or not lines[0].strip().startswith(WPL_HEADER):
        raise ValueError(f"{name}:1: not a waypoints file: the first line is not {WPL_HEADER!r}")
    items: list[MissionItem] = []
    for number, line in enumerate(lines[1:], start=2):
        fields = line.split()
        if not fields:
            continue
        where = f"{name}:{number}"
        if len(fields) != 12:
            raise ValueError(f"{where}: {len(fields)} fields, a waypoint line has 12")
        try:
            seq, _current, frame, command = (int(f) for f in fields[:4])
            p1, p2, _p3, _p4, lat, lon = (float(f) for f in fields[4:10])
        except ValueError:
            raise ValueError(f"{where}: a field is not a number: {line.strip()!r}") from None
        lat, lon, p1, p2 = (_finite(v, where) for v in (lat, lon, p1, p2))
        items.append(MissionItem(seq, command, frame, lat, lon, p1, p2))
    try:
        return mission_route(items, home_first=True)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def parse_plan(data: bytes, name: str) -> PlannedRoute:
    """The road of a QGroundControl ``.plan``.

    Raises:
        ValueError: Not JSON, not a plan, a malformed item, or no road.
    """
    try:
        doc = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: not a QGroundControl plan (not JSON: {exc})") from None
    mission = doc.get("mission") if isinstance(doc, dict) else None
    raw = mission.get("items") if isinstance(mission, dict) else None
    if not isinstance(raw, list):
        raise ValueError(f"{name}: not a QGroundControl plan: no mission.items list")
    home = None
    planned = mission.get("plannedHomePosition") if isinstance(mission, dict) else None
    if isinstance(planned, list) and len(planned) >= 2 and _numbers(planned[:2]):
        home = (float(planned[0]), float(planned[1]))
    items: list[MissionItem] = []
    jump_ids: dict[int, int] = {}  # doJumpId -> the item's place among the items read
    complex_items = 0
    for k, entry in enumerate(raw):
        where = f"{name}: mission.items[{k}]"
        if not isinstance(entry, dict):
            raise ValueError(f"{where}: not an object")
        if entry.get("type") != "SimpleItem":
            complex_items += 1
            continue
        params, command, frame = entry.get("params"), entry.get("command"), entry.get("frame")
        if not isinstance(command, int) or not isinstance(frame, int):
            raise ValueError(f"{where}: command and frame must be integers")
        if not isinstance(params, list) or len(params) != 7:
            raise ValueError(f"{where}: params must be a list of seven")
        # QGC writes null for a parameter that is NaN (unused): none is a position.
        p = [float("nan") if v is None else v for v in params]
        if not _numbers(p):
            raise ValueError(f"{where}: a parameter is not a number")
        lat, lon = (0.0, 0.0) if math.isnan(p[4]) or math.isnan(p[5]) else (p[4], p[5])
        if isinstance(entry.get("doJumpId"), int):
            jump_ids[entry["doJumpId"]] = len(items)
        items.append(MissionItem(len(items), command, frame, lat, lon, p[0], p[1]))
    # A plan's DO_JUMP names its target by doJumpId, not by its place in the mission.
    items = [
        dataclasses.replace(i, param1=jump_ids.get(int(i.param1), math.nan))
        if i.command == mavlink.MAV_CMD_DO_JUMP and math.isfinite(i.param1)
        else i
        for i in items
    ]
    try:
        route = mission_route(items, home_first=False, home=home)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None
    if complex_items:  # (a survey's transects are no road the convoy drives)
        return dataclasses.replace(route, skipped=route.skipped + complex_items)
    return route


def _numbers(values: list[Any]) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)
