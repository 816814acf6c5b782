"""A mission a ground station uploads to a mock rover: kept as sent, driven as AUTO runs it
(pure).

A rover's operator plans its mission in a ground station (QGroundControl, MAVProxy,
MAVSDK's ``mission_raw``) and uploads it over the mission protocol; the rover drives it
in AUTO. The mock keeps the items as they came (a read gives them back, ArduPilot's item
0 being home, as the firmware's is) and drives the road they make, as ArduRover's
``ModeAuto`` runs them item by item (``AP_Mission``):

- NAV_WAYPOINT and NAV_SPLINE_WAYPOINT drive to their point and hold there param1 s;
  NAV_LOITER_TIME holds param1 s; NAV_LOITER_TURNS is driven to; NAV_LOITER_UNLIM is
  driven to and stood at for good (the mission goes no further). A point at (0, 0) is
  "here": the rover holds where it is.
- NAV_RETURN_TO_LAUNCH drives to home.
- DO_CHANGE_SPEED (param2 m/s; -1 and below 0: no change) sets the speed from the
  waypoint before it on; before any waypoint, from the start.
- DO_JUMP (param1 the seq jumped to, param2 the repeats, -1 for ever) is unrolled: the
  road is driven as the items come, ``CHUNK`` waypoints at a time (``more``): the
  autopilot lays the next ones from where the rover is before it gets to the last
  (``going_on``), so a patrol for ever is driven for ever.

The drive sets off from where the rover is when the upload ends (AUTO drives from there
to the first waypoint), at the speed it has; ``speed`` is the rover's WP_SPEED before any
DO_CHANGE_SPEED. At upload (``upload_result``) an item is refused as both firmwares refuse
it: a command MAVLink does not define (MAV_MISSION_UNSUPPORTED), a position in a frame
that is not global (MAV_MISSION_UNSUPPORTED_FRAME), a latitude or longitude out of range,
a parameter that is not a number (MAV_MISSION_INVALID_PARAMn; a NAV command's yaw,
param4, may be NaN: "none").
Any other command is kept, and skipped when driven (``skipped``), as ArduRover's
``ModeAuto::start_command`` skips what a rover has no use for (a landing, a camera's).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock.ground import Polyline
from sitl_mock.mission import driving_to, waypoint_item

__all__ = ["CHUNK", "DEFAULT_WP_SPEED", "UploadedMission", "upload_result"]

DEFAULT_WP_SPEED = 2.0
"""m/s: a rover's speed with no road of its own set (ArduRover's ``AR_WPNAV_SPEED_DEFAULT``)."""

CHUNK = 200
"""Waypoints laid at a time: laid out and entered in 23 ms in the mock's loop, against
623 ms for 5000, laid again at each speed mark (``benchmarks/bench_mock_missions.py``)."""
_AHEAD = 10  # (waypoints left when the next ones are laid)

_M = mavlink
_AT_POINT = frozenset(
    {
        _M.MAV_CMD_NAV_WAYPOINT,
        _M.MAV_CMD_NAV_SPLINE_WAYPOINT,
        _M.MAV_CMD_NAV_LOITER_TIME,
        _M.MAV_CMD_NAV_LOITER_TURNS,
        _M.MAV_CMD_NAV_LOITER_UNLIM,
    }
)
_GLOBAL = frozenset(
    {
        _M.MAV_FRAME_GLOBAL,
        _M.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        _M.MAV_FRAME_GLOBAL_INT,
        _M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        _M.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        _M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
_HOLDS_P1 = frozenset(
    {_M.MAV_CMD_NAV_WAYPOINT, _M.MAV_CMD_NAV_SPLINE_WAYPOINT, _M.MAV_CMD_NAV_LOITER_TIME}
)
_HERE_M = 0.01  # (a point this near the last is the same one: its hold adds up)


def upload_result(item: mavlink.MAVLink_mission_item_int_message) -> int:
    """MAV_MISSION_ACCEPTED, or the MAV_MISSION_RESULT refusing this item of an upload."""
    if item.command not in mavlink.enums["MAV_CMD"]:
        return int(_M.MAV_MISSION_UNSUPPORTED)
    navigates = item.command < _M.MAV_CMD_NAV_LAST
    params = (item.param1, item.param2, item.param3, item.param4)
    for k, value in enumerate(params):  # (a NAV command's param4, its yaw, may be NaN: none)
        if not math.isfinite(value) and not (navigates and k == 3 and math.isnan(value)):
            return int(_M.MAV_MISSION_INVALID_PARAM1 + k)  # (AP_Mission::sanity_check_params)
    if navigates and (item.x, item.y) != (0, 0) and item.frame not in _GLOBAL:
        return int(_M.MAV_MISSION_UNSUPPORTED_FRAME)
    if abs(item.x) > 900_000_000 and item.frame in _GLOBAL:
        return int(_M.MAV_MISSION_INVALID_PARAM5_X)
    if abs(item.y) > 1_800_000_000 and item.frame in _GLOBAL:
        return int(_M.MAV_MISSION_INVALID_PARAM6_Y)
    return int(_M.MAV_MISSION_ACCEPTED)


@dataclass(frozen=True, slots=True)
class UploadedMission:
    """The items as uploaded, the road they drive from where the rover was (None: no
    point to drive to), and the item each of its vertices is driven to by."""

    items: tuple[mavlink.MAVLink_mission_item_int_message, ...]
    home_first: bool  # (ArduPilot: items[0] is home)
    drive: Polyline | None
    seqs: tuple[int, ...]  # (per vertex of ``drive``)
    skipped: int = 0  # (items driven past, each once: commands a rover has no use for)
    more: bool = False  # (the items go on past the last waypoint laid)
    resume: tuple[tuple[int, tuple[tuple[int, int], ...]], ...] = ()  # (per vertex: the
    # index of the item that lays it, and the jumps made before it)

    @classmethod
    def of(
        cls,
        items: Sequence[mavlink.MAVLink_mission_item_int_message],
        *,
        home_first: bool,
        world: LocalFrame,
        start: tuple[float, float],
        home: GeoPoint,
        speed: float,
        accel: float,
        wp_radius: float = 2.0,
        first: int | None = None,
        speed_now: float | None = None,
        jumps: Mapping[int, int] | None = None,
    ) -> UploadedMission:
        """The mission ``items`` (seq order) driven from world (north, east) ``start``,
        from item ``first`` on (None: its first; a mission changed while it runs goes on
        at the item it was at: ArduRover's ``restart_current_nav_cmd``), at ``speed_now``
        until a DO_CHANGE_SPEED (None: ``speed``, WP_SPEED; going on, the speed its
        navigation was set to, which no DO command run again changes), ``jumps`` the
        DO_JUMPs made so far (by their seq: going on, the count so far)."""
        points: list[tuple[float, float]] = [start]
        seqs: list[int] = [-1]
        resume: list[tuple[int, tuple[tuple[int, int], ...]]] = [(-1, ())]
        holds: dict[int, float] = {}
        speeds: dict[int, float] = {}
        made = dict(jumps or {})  # (a DO_JUMP's seq: jumps made)
        k = int(home_first) if first is None else first
        steps = 0
        skipped: set[int] = set()
        while k < len(items) and len(points) <= CHUNK and steps < 10 * CHUNK:
            steps += 1
            at = k
            item, k = items[k], k + 1
            command = item.command
            if command == _M.MAV_CMD_DO_JUMP:
                done, repeats = made.get(item.seq, 0), round(item.param2)
                to = round(item.param1)
                if (repeats < 0 or done < repeats) and 0 <= to < len(items):
                    made[item.seq] = done + 1
                    k = to
                continue
            if command == _M.MAV_CMD_DO_CHANGE_SPEED:
                if math.isfinite(item.param2) and item.param2 > 0.0:
                    speeds[len(points) - 1] = float(item.param2)
                continue
            if command not in _AT_POINT and command != _M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
                skipped.add(item.seq)
                continue
            if command == _M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
                n, e, _ = world.to_ned(home)
            elif (item.x, item.y) == (0, 0):
                n, e = points[-1]
            else:
                n, e, _ = world.to_ned(GeoPoint(item.x * 1e-7, item.y * 1e-7, 0.0))
            if math.dist((n, e), points[-1]) > _HERE_M:
                points.append((n, e))
                seqs.append(item.seq)
                resume.append((at, tuple(sorted(made.items()))))
            elif seqs[-1] < 0:  # (the first waypoint is where it stands)
                seqs[-1] = item.seq
            wait = item.param1 if command in _HOLDS_P1 else 0.0
            if math.isfinite(wait) and wait > 0.0:
                holds[len(points) - 1] = holds.get(len(points) - 1, 0.0) + float(wait)
            if command == _M.MAV_CMD_NAV_LOITER_UNLIM:
                break
        more = k < len(items) and len(points) > CHUNK
        if len(seqs) > 1 and seqs[0] < 0:
            seqs[0], resume[0] = seqs[1], resume[1]
        if speed_now is not None and speed_now > 0.0 and 0 not in speeds:
            speeds[0] = speed_now
        drive = None
        if len(points) > 1:
            drive = Polyline(
                tuple(points),
                speed=speed,
                accel=accel,
                wp_radius=wp_radius,
                holds=tuple(sorted(holds.items())),
                speeds=tuple(sorted(speeds.items())),
            )
        return cls(tuple(items), home_first, drive, tuple(seqs), len(skipped), more, tuple(resume))

    def count(self, *, home_first: bool) -> int:
        """Items a read gets (``home_first``: ArduPilot's home among them)."""
        return len(self.items) - (self.home_first and not home_first)

    def item(
        self, seq: int, home: GeoPoint, target: tuple[int, int], *, home_first: bool
    ) -> mavlink.MAVLink_mission_item_int_message | None:
        """Item ``seq`` as uploaded, to ``target`` (ArduPilot's item 0: home as it is now;
        None: out of range)."""
        if not 0 <= seq < self.count(home_first=home_first):
            return None
        if home_first and seq == 0:
            return waypoint_item(0, home, target, home=True)
        it = self.items[seq]
        return mavlink.MAVLink_mission_item_int_message(
            target[0], target[1], seq, it.frame, it.command, 0, it.autocontinue,
            it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z,
            mavlink.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip

    def going_on(self, t: float, times: Sequence[float] | None = None) -> int | None:
        """The vertex to lay the rest from at drive time ``t``, the one it drives to once
        within ``_AHEAD`` of the last laid (None: not yet, held at one, or no more)."""
        drive = self.drive
        if not self.more or drive is None:
            return None
        i, held = self._driving_to(drive, t, times)
        if i < len(self.seqs) - _AHEAD or held:
            return None
        return min(i, len(self.seqs) - 1)

    def current(self, t: float, *, home_first: bool, times: Sequence[float] | None = None) -> int:
        """The item driven to, or held at, at drive time ``t`` (the last once arrived);
        ``times``: when each vertex is reached (the drive retimed by a speed told)."""
        drive = self.drive
        if drive is None:
            return int(home_first and len(self.items) > 1)
        i, held = self._driving_to(drive, t, times)
        return self.seqs[min(i - held, len(self.seqs) - 1)]

    def _driving_to(
        self, drive: Polyline, t: float, times: Sequence[float] | None
    ) -> tuple[int, bool]:
        """``mission.driving_to`` on ``drive`` (``times``: its vertices' arrivals if
        retimed by a speed told)."""
        times = drive.arrivals if times is None or len(times) != len(self.seqs) else times
        return driving_to(t, times, lambda k: drive.vertex_holds.get(k, 0.0))
