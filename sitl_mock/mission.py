"""A mock rover's mission: the road its route drives, as AUTO would drive it (pure).

A ground vehicle whose route is a polyline or a recorded track can serve that road as
its mission (``[ground] mission = true``), as an ArduRover or PX4 rover in AUTO holds
the waypoints it drives: a ground station reads it over the mission protocol
(MISSION_REQUEST_LIST, MISSION_REQUEST_INT, MISSION_ITEM_INT, MISSION_ACK) and follows
its progress in MISSION_CURRENT.

Design rules:
    * The waypoints are the route's vertices; a recorded track is thinned
      (Douglas-Peucker, ``tolerance`` metres) to the corners a planner would have
      clicked, so GPS jitter along a straight is not a waypoint.
    * Where a track stands still 5 s or more (``convoy_mav.tracks.stops``), the rover's
      mission holds: a waypoint there with that hold time (NAV_WAYPOINT param1, as
      ArduRover's ``loiter_duration``), the plan it keeps. No speeds: the track's own
      say how it drives between.
    * A polyline's holds are its waypoints' hold times, and its speeds DO_CHANGE_SPEED
      items (param2, ground speed) after the waypoint they are driven from, as the
      firmware runs a DO command once the NAV command before it is done. A lap that
      changes speed sets its first leg's too, so every lap is driven alike.
    * Numbering follows the firmware: ArduPilot's item 0 is home (a NAV_WAYPOINT in
      MAV_FRAME_GLOBAL), PX4's items are the waypoints alone.
    * A looping route is a patrol: its waypoints close the lap, and a last item
      DO_JUMPs back to the first waypoint for ever (param2 -1), as a ground station
      plans one.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.tracks.stops import standstills
from sitl_mock.ground import Polyline, Route, Track

__all__ = ["RoverMission", "as_float_item", "driving_to", "thin", "waypoint_item"]

DEFAULT_TOLERANCE_M = 3.0


def thin(points: Sequence[tuple[float, float]], tolerance: float) -> list[int]:
    """Indices of the points Douglas-Peucker keeps (first and last always)."""
    n = len(points)
    if n <= 2:
        return list(range(n))
    keep = [False] * n
    keep[0] = keep[-1] = True
    stack = [(0, n - 1)]
    while stack:
        a, b = stack.pop()
        (ax, ay), (bx, by) = points[a], points[b]
        dx, dy = bx - ax, by - ay
        length = math.hypot(dx, dy)
        worst, at = -1.0, -1
        for i in range(a + 1, b):
            px, py = points[i][0] - ax, points[i][1] - ay
            d = abs(px * dy - py * dx) / length if length > 0.0 else math.hypot(px, py)
            if d > worst:
                worst, at = d, i
        if at >= 0 and worst > tolerance:
            keep[at] = True
            stack += [(a, at), (at, b)]
    return [i for i in range(n) if keep[i]]


@dataclass(frozen=True, slots=True)
class RoverMission:
    """Waypoints (geodetic) in order, and the sim time the route passes each."""

    waypoints: tuple[GeoPoint, ...]
    times: tuple[float, ...]
    laps: bool = False  # a looping polyline: driven again from the first once at the last
    holds: tuple[float, ...] = ()  # seconds held at each waypoint (none: no holds)
    speeds: tuple[float, ...] = ()  # m/s driven on from each waypoint (0: as before; none)
    _entries: tuple[int, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # Each item after home: a waypoint's index, or -1 for its DO_CHANGE_SPEED (the
        # waypoint before it says which), and -2 for a lap's DO_JUMP.
        entries: list[int] = []
        for k in range(len(self.waypoints)):
            entries.append(k)
            if self.speeds and self.speeds[k] > 0.0:
                entries.append(-1)
        if self.laps:
            entries.append(-2)
        object.__setattr__(self, "_entries", tuple(entries))

    @classmethod
    def of(
        cls, route: Route, world: LocalFrame, tolerance: float = DEFAULT_TOLERANCE_M
    ) -> RoverMission | None:
        """The mission driving ``route``'s road (None: a route with no road to give)."""
        held: dict[int, float] = {}
        speeds: dict[int, float] = {}
        if isinstance(route, Track):
            points = list(zip(route.norths, route.easts, strict=True))
            stands = standstills(route.times, route.norths, route.easts)
            held = {stand.index: stand.seconds for stand in stands}
            keep = sorted(set(thin(points, tolerance)) | set(held))
            times = [route.times[i] for i in keep]
            points = [points[i] for i in keep]
            held = {k: held[i] for k, i in enumerate(keep) if i in held}
        elif isinstance(route, Polyline) and route.arrivals:
            points, times = list(route.vertices), list(route.arrivals)
            held = dict(route.vertex_holds)
            speeds = dict(route.vertex_speeds)
        else:
            return None
        if len(points) < 2:
            return None
        geo = tuple(world.to_geo(n, e, 0.0) for n, e in points)
        holds = tuple(held.get(k, 0.0) for k in range(len(points))) if held else ()
        legs = tuple(speeds.get(k, 0.0) for k in range(len(points))) if speeds else ()
        laps = isinstance(route, Polyline) and route.loop
        return cls(geo, tuple(times), laps=laps, holds=holds, speeds=legs)

    def count(self, *, home_first: bool) -> int:
        return len(self._entries) + home_first

    def item(
        self, seq: int, home: GeoPoint, target: tuple[int, int], *, home_first: bool
    ) -> mavlink.MAVLink_mission_item_int_message | None:
        """Item ``seq`` as MISSION_ITEM_INT (None: out of range)."""
        if not 0 <= seq < self.count(home_first=home_first):
            return None
        entry = -3 if home_first and seq == 0 else self._entries[seq - home_first]
        if entry == -2:
            return mavlink.MAVLink_mission_item_int_message(
                target[0], target[1], seq, mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_JUMP,
                0, 1, float(home_first), -1.0, 0.0, 0.0, 0, 0, 0.0,
                mavlink.MAV_MISSION_TYPE_MISSION,
            )  # fmt: skip
        if entry == -1:
            speed = self.speeds[self._entries[seq - home_first - 1]]
            return mavlink.MAVLink_mission_item_int_message(
                target[0], target[1], seq, mavlink.MAV_FRAME_MISSION,
                mavlink.MAV_CMD_DO_CHANGE_SPEED, 0, 1, 1.0, speed, -1.0, 0.0, 0, 0, 0.0,
                mavlink.MAV_MISSION_TYPE_MISSION,
            )  # fmt: skip
        if entry == -3:
            return waypoint_item(seq, home, target, home=True)
        hold = self.holds[entry] if self.holds else 0.0
        return waypoint_item(seq, self.waypoints[entry], target, hold=hold)

    def current(self, t: float, *, home_first: bool, times: Sequence[float] | None = None) -> int:
        """The item being driven to, or held at, at drive time ``t`` (the last once
        arrived); ``times``: when each waypoint is reached if not ``self.times`` (a
        drive retimed by a speed its operator told)."""
        times = self.times if times is None or len(times) != len(self.times) else times
        if self.laps and t > 0.0:
            t %= times[-1]
        i, held = driving_to(t, times, lambda k: self.holds[k] if self.holds else 0.0)
        return self._entries.index(min(i - held, len(times) - 1)) + home_first


def driving_to(t: float, times: Sequence[float], hold: Callable[[int], float]) -> tuple[int, bool]:
    """The waypoint a drive reaching each at ``times`` drives to at ``t`` (``len(times)``
    once past the last), and whether it still holds at the one before (``hold``: its
    seconds there), whose item is then the one in force."""
    i = bisect.bisect_right(times, t)
    return i, i > 0 and t < times[i - 1] + hold(i - 1)


def waypoint_item(
    seq: int, where: GeoPoint, target: tuple[int, int], *, hold: float = 0.0, home: bool = False
) -> mavlink.MAVLink_mission_item_int_message:
    """A NAV_WAYPOINT at ``where``, held ``hold`` s: relative altitude 0, or ArduPilot's
    home item (``home``: MAV_FRAME_GLOBAL, its altitude)."""
    frame = mavlink.MAV_FRAME_GLOBAL if home else mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    return mavlink.MAVLink_mission_item_int_message(
        target[0], target[1], seq, frame, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1, hold, 0.0, 0.0,
        0.0, round(where.lat * 1e7), round(where.lon * 1e7), where.alt if home else 0.0,
        mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip


def as_float_item(item: mavlink.MAVLink_mission_item_int_message) -> mavlink.MAVLink_message:
    """The same item as MISSION_ITEM (degrees as floats), the float form's answer."""
    return mavlink.MAVLink_mission_item_message(
        item.target_system, item.target_component, item.seq, item.frame, item.command,
        item.current, item.autocontinue, item.param1, item.param2, item.param3, item.param4,
        item.x * 1e-7, item.y * 1e-7, item.z, item.mission_type,
    )  # fmt: skip
