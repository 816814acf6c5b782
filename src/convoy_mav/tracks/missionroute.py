"""A ground vehicle's mission as the convoy's route (pure).

An ArduRover or PX4 rover in AUTO drives its mission's waypoints in order: that
polyline is the road the convoy will take, known ahead as a route file is. Which items
count, per the MAVLink mission commands a rover flies:

- Positions in a global frame (``MAV_FRAME_GLOBAL*``, relative and terrain altitudes
  alike: a ground vehicle's altitude is the ground's) of NAV_WAYPOINT, NAV_SPLINE_WAYPOINT
  and the loiters (NAV_LOITER_UNLIM/TURNS/TIME, a rover holds at their point); a point at
  (0, 0) is "no position" (ArduPilot's "here" for some commands) and is skipped.
- NAV_RETURN_TO_LAUNCH drives back to home.
- ArduPilot's item 0 is home (``home_first``): where the rover was armed, not where AUTO
  sets off from (a rover driven to its start by hand), so it is no point of the road
  but the end of a return to launch. AUTO drives from wherever the rover is to the
  first waypoint, which the road model takes as a convoy joining its route.
- DO_JUMP repeats items: the route is driven as laps (``laps``), which the road model
  finds on the whole route whichever lap the convoy is on; the route itself is one lap.
  A jump back to a waypoint (param1, its seq) repeated (param2: a count, or -1 for
  ever; 0 never jumps) with nothing driven after it makes a patrol circuit
  (``circuit``): the route is that lap, closed by the drive back to where it starts
  (the waypoints before it are the way there, which AUTO drives as it drives to any
  first waypoint), and the convoy's forecast goes round it lap after lap.
- Items in a local frame, and commands with a position a rover does not drive to, are
  counted in ``skipped`` and left out.
- Where it will stand, and how long (``holds``): a waypoint's hold time (NAV_WAYPOINT
  param1, seconds: ArduRover's ``loiter_duration``, PX4's hold) and NAV_LOITER_TIME's
  (param1), at that point, or at the last one for a hold "here".
- How fast it drives (``speeds``): a DO_CHANGE_SPEED's speed (param2, m/s; -1 and
  the other values below 0 change nothing) from the waypoint before it on, as the
  firmware runs a DO command once the NAV command before it is done; before any
  waypoint, from the start. On a circuit a speed lasts round the jump: the lap's last
  is in force at its start (from the second lap on); one set on the way there, if the
  lap sets none. Before any, the rover drives its own default (``default_speed``:
  ArduRover's WP_SPEED, read by ``MissionWatch``), which, unknown, the road model learns
  from the drive (``autopilot``: ``ConvoyModel.cruise``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.missionread import MissionItem
from convoy_mav.tracks.plannedroute import SAME_POINT_DEG, PlannedRoute, closed_lap

__all__ = ["driven_to", "mission_route"]

_GLOBAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
_DRIVEN_TO = frozenset(
    {
        mavlink.MAV_CMD_NAV_WAYPOINT,
        mavlink.MAV_CMD_NAV_SPLINE_WAYPOINT,
        mavlink.MAV_CMD_NAV_LOITER_UNLIM,
        mavlink.MAV_CMD_NAV_LOITER_TURNS,
        mavlink.MAV_CMD_NAV_LOITER_TIME,
    }
)
_HOLDS_P1 = frozenset({mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_CMD_NAV_LOITER_TIME})


def driven_to(item: MissionItem) -> tuple[float, float] | None:
    """Where a rover drives to for ``item`` (lat, lon degrees): a waypoint's or a
    loiter's position in a global frame; None for any other item."""
    placed = item.command in _DRIVEN_TO and item.frame in _GLOBAL_FRAMES
    return (item.lat, item.lon) if placed and (item.lat, item.lon) != (0.0, 0.0) else None


def mission_route(
    items: Sequence[MissionItem],
    *,
    home_first: bool,
    home: tuple[float, float] | None = None,
    default_speed: float | None = None,
) -> PlannedRoute:
    """The polyline a rover's mission drives (see the module's rules); ``home`` is where a
    return to launch goes when the items do not hold it (a QGroundControl plan's);
    ``default_speed`` the rover's speed where no DO_CHANGE_SPEED has set one.

    Raises:
        ValueError: Fewer than two distinct points to drive: no road to speak of.
    """
    points: list[tuple[float, float]] = []
    holds: dict[int, float] = {}
    speeds: dict[int, float] = {}
    ok = default_speed is not None and math.isfinite(default_speed) and default_speed > 0.0
    default = default_speed if ok else None
    skipped = 0
    laps = False
    first_point: dict[int, int] = {}  # item seq -> index of the point it drives to
    lap_from: int | None = None  # a jump repeated back to this point, nothing driven since

    def add(lat: float, lon: float) -> None:
        if points and max(abs(lat - points[-1][0]), abs(lon - points[-1][1])) < SAME_POINT_DEG:
            return
        points.append((lat, lon))

    for item in items:
        here = (item.lat, item.lon)
        has_point = math.isfinite(item.lat) and math.isfinite(item.lon) and here != (0.0, 0.0)
        valid = has_point and abs(item.lat) <= 90.0 and abs(item.lon) <= 180.0
        if home_first and item.seq == 0:
            home = here if valid else None
            continue
        if item.command == mavlink.MAV_CMD_DO_JUMP:
            laps = True
            target = item.param1
            later = [i for q, i in first_point.items() if math.isfinite(target) and q >= target]
            if item.param2 != 0.0 and later:  # (back to a waypoint driven already)
                lap_from = min(later)
        elif item.command == mavlink.MAV_CMD_DO_CHANGE_SPEED:
            if math.isfinite(item.param2) and item.param2 > 0.0:
                speeds[max(len(points) - 1, 0)] = item.param2
        elif item.command == mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            if home is not None:
                add(*home)
        elif item.command in _DRIVEN_TO:
            if has_point and (not valid or item.frame not in _GLOBAL_FRAMES):
                skipped += 1
                continue
            if has_point:
                add(*here)  # (without one, "here": it holds where it is)
                lap_from = None
            if points:
                first_point[item.seq] = len(points) - 1
            wait = item.param1 if item.command in _HOLDS_P1 else 0.0
            if points and math.isfinite(wait) and wait > 0.0:
                holds[len(points) - 1] = holds.get(len(points) - 1, 0.0) + wait
        elif valid:
            skipped += 1
    if len(points) < 2:
        raise ValueError(
            f"the mission drives to {len(points)} distinct point(s) of {len(items)} items: no route"
        )
    if lap_from is not None and len(points) - lap_from >= 2:
        lap = closed_lap(points[lap_from:])  # (the drive back to where the lap starts)
        on_lap = {i - lap_from: seconds for i, seconds in holds.items() if i >= lap_from}
        paces = {i - lap_from: v for i, v in speeds.items() if i >= lap_from}
        before = [default, *(v for i, v in sorted(speeds.items()) if i < lap_from)]
        if before[-1] is not None and not paces:
            paces[0] = before[-1]  # (set on the way there, in force round the lap)
        return PlannedRoute(
            tuple(lap), skipped, laps, _sorted(on_lap), True, _sorted(paces), autopilot=True
        )
    if default is not None and 0 not in speeds:
        speeds[0] = default
    return PlannedRoute(
        tuple(points), skipped, laps, _sorted(holds), speeds=_sorted(speeds), autopilot=True
    )


def _sorted(marks: dict[int, float]) -> tuple[tuple[int, float], ...]:
    return tuple(sorted(marks.items()))
