"""A rover's return to launch (RTL): the road home, and the mission it comes back to.

ArduRover's ``ModeRTL`` drives straight to home (or its nearest rally point) at
``RTL_SPEED`` (0: ``WP_SPEED``), says "Reached destination" once within ``WP_RADIUS``
and stands there (a boat loiters); refused while home is not set. Back in AUTO,
``AP_Mission::resume`` restarts the item it was driving to, from where the rover
stands: straight to that waypoint, then on along the mission. PX4's rovers are
modelled the same way (AUTO.RTL home, AUTO.MISSION resumed at its current item).

SMART_RTL (ArduRover's ``ModeSmartRTL``) drives the same way back along the path the
rover drove (``smartrtl.SmartPath``) to its first point.

The turn onto the road home is a corner of the drive's rules (``drive.corner_speed``):
a rover heading away from home brakes along its way to a stand and turns round, as
one with a turn radius must slow for it; one heading home keeps its speed.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from sitl_mock.drive import Ramps, corner_speed
from sitl_mock.ground import Polyline

__all__ = ["Return", "road_home"]

Message = Any  # a pymavlink MAVLink_message (the dialect is untyped)
_BEHIND_M = 1.0  # m: a moving rover's road home starts this far behind it


@dataclass(slots=True)
class Return:
    """A rover on its way home, and what AUTO resumes: ``items`` the mission it drove
    (as a ground station reads it: ArduPilot's home first), ``seq`` the item it was
    driving to. ``reached``: "Reached destination" said; ``goal`` where it goes."""

    items: tuple[Message, ...]
    seq: int
    reached: bool = False
    goal: tuple[float, float] | None = None  # (north, east): home, or a rally point
    smart: bool = False  # SMART_RTL's way: back along its path (``sitl_mock.smartrtl``)


def road_home(
    here: tuple[float, float],
    velocity: tuple[float, float],
    home: tuple[float, float],
    speed: float,
    accel: float,
    wp_radius: float,
    via: Sequence[tuple[float, float]] = (),
) -> tuple[Polyline, float]:
    """The road from ``here`` (world north, east), moving at ``velocity``, to ``home``
    (through ``via`` first: SmartRTL's path back), driven at ``speed`` with the rover's
    ``accel`` and ``wp_radius``: straight there, after the stretch along its way that it
    brakes over to its speed through the turn; and how far along it ``here`` is (a
    moving rover's road starts a metre behind it, on its way, so that it is entered at
    the speed it has, not from a stand)."""
    moving = math.hypot(*velocity)
    first = next((p for p in (*via, home) if math.dist(p, here) > 1e-6), home)
    if moving < 1e-6 or not accel > 0.0:
        still = (here, *via, home)
        return Polyline(still, speed=speed, accel=accel, wp_radius=wp_radius), 0.0
    way = (velocity[0] / moving, velocity[1] / moving)
    behind = (here[0] - way[0] * _BEHIND_M, here[1] - way[1] * _BEHIND_M)
    points = [behind, here]
    away = (first[0] - here[0], first[1] - here[1])
    if math.hypot(*away) > 1e-6:
        turn = math.remainder(math.atan2(away[1], away[0]) - math.atan2(way[1], way[0]), math.tau)
        ramps = Ramps(accel, accel)
        brake = ramps.distance(moving, min(corner_speed(turn, ramps, wp_radius), moving))
        if brake >= wp_radius:  # (a turn to brake for: straight on first)
            points.append((here[0] + way[0] * brake, here[1] + way[1] * brake))
    points += [*via, home]
    return Polyline(tuple(points), speed=speed, accel=accel, wp_radius=wp_radius), _BEHIND_M
