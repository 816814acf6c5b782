"""Where an ArduPilot ground vehicle sent home (RTL) drives: home, or a rally point.

ArduRover's ``ModeRTL`` drives to ``AP_Rally::calc_best_rally_or_home_location`` from
where it is when RTL is entered: the nearest of its rally points (uploaded as
MAV_MISSION_TYPE_RALLY), unless ``RALLY_LIMIT_KM`` (0: none) is set and that point is
farther, or ``RALLY_INCL_HOME`` is set and home is nearer; home when it has none. Rover's
defaults are 0.5 km and 1. :func:`rtl_destination` is that rule (the service forecasts
the convoy's lead there, the mock drives its rovers there); :class:`RallyRead` reads the
points and both parameters over MAVLink (sans-I/O, as :class:`MissionRead`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.codec import GCS_SYSTEM, Message
from convoy_mav.mavlink.missionread import MissionRead, ParamAsks

__all__ = ["RALLY_PARAMS", "ROVER_RALLY_DEFAULTS", "RallyRead", "rtl_destination"]

RALLY_PARAMS = ("RALLY_LIMIT_KM", "RALLY_INCL_HOME")
ROVER_RALLY_DEFAULTS = {"RALLY_LIMIT_KM": 0.5, "RALLY_INCL_HOME": 1.0}  # (AP_Rally.cpp)

Point = tuple[float, float]


def rtl_destination(
    here: Point, home: Point, rallies: Sequence[Point], limit_km: float, incl_home: bool
) -> Point:
    """Where RTL takes a vehicle at ``here``, with its ``home`` and ``rallies`` (local
    metres, any one frame): ``AP_Rally::calc_best_rally_or_home_location``."""
    if not rallies:
        return home
    nearest = min(rallies, key=lambda p: math.dist(here, p))
    far = math.dist(here, nearest)
    if limit_km > 0.0 and far > limit_km * 1000.0:
        return home
    if not incl_home or far < math.dist(here, home):
        return nearest
    return home


class RallyRead:
    """One read of an ArduPilot vehicle's rally points and ``RALLY_PARAMS``.

    Driven as :class:`MissionRead` is (:meth:`start`, :meth:`handle` for every message
    from the vehicle, :meth:`poll` now and then; each returns what to send). ``done``
    once the points are read (or the read failed: ``error``) and both parameters are
    answered or asked ``PARAM_TRIES`` times (then Rover's defaults stand).
    """

    def __init__(
        self, target_system: int, target_component: int = 1, *, own: int = GCS_SYSTEM
    ) -> None:
        self.target = (target_system, target_component)
        self._read = MissionRead(
            target_system, target_component, own=own, mission_type=mavlink.MAV_MISSION_TYPE_RALLY
        )
        self._asks = ParamAsks(self.target, RALLY_PARAMS)

    @property
    def done(self) -> bool:
        return self._read.done and self._asks.settled

    @property
    def params(self) -> dict[str, float]:
        """``RALLY_PARAMS`` as answered."""
        return self._asks.values

    @property
    def error(self) -> str | None:
        """Why the points were not read (None: read, or still reading)."""
        return self._read.error

    @property
    def points(self) -> list[tuple[float, float]]:
        """The rally points read, (lat, lon) degrees (none before or without a read)."""
        items = self._read.items or []
        rally = mavlink.MAV_CMD_NAV_RALLY_POINT
        return [(i.lat, i.lon) for i in items if i.command == rally]

    @property
    def limit_km(self) -> float:
        return self.params.get("RALLY_LIMIT_KM", ROVER_RALLY_DEFAULTS["RALLY_LIMIT_KM"])

    @property
    def incl_home(self) -> bool:
        return self.params.get("RALLY_INCL_HOME", ROVER_RALLY_DEFAULTS["RALLY_INCL_HOME"]) != 0.0

    def start(self, now: float) -> list[Message]:
        return self._read.start(now) + self._asks.ask(now)

    def handle(self, msg: Message, now: float) -> list[Message]:
        """A message from the vehicle; what to send in answer."""
        self._asks.take(msg)
        return self._read.handle(msg, now)

    def poll(self, now: float) -> list[Message]:
        """Ask again what is overdue."""
        return self._read.poll(now) + self._asks.ask(now)
