"""What a ground vehicle's HEARTBEAT says of its drive: its mission, a stand, or else.

A rover driving its mission in AUTO keeps the mission's plan (its holds, its speeds),
which the service reads as the convoy's (``[convoy] route = "mission"``). Switched to
HOLD, or disarmed, it stands until its operator switches it back, and does not pull
away at the end of a planned hold; back in AUTO it pulls away at once, seconds before
its fixes can show it. In RTL it drives straight home and stands there (ArduRover's
``ModeRTL``), off its route; in SMART_RTL home back along the path it drove
(``ModeSmartRTL``, an action of ArduRover's failsafes, ``FS_ACTION`` 3 and 4): for
the lead, as in MANUAL or GUIDED, something other than the mission drives it, at
speeds the plan does not say; for a follower, as in RTL, it leaves the convoy. So the
lead vehicle's mode tells the road model which forecast holds
(``ConvoyModel.set_drive``). Modes by firmware:

- ArduRover (``Rover/mode.h``): AUTO 10 drives the mission, HOLD 4 stands (it cuts
  the throttle: ``ModeHold::update``); LOITER 5 holds a point, a stand for a car; RTL
  11 goes home, SMART_RTL 12 retraces its path home.
- PX4's rovers: AUTO.MISSION drives the mission, AUTO.LOITER is their hold, AUTO.RTL
  their return.
- Other autopilots (a phone, a tracker sending positions): nothing is said (None).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.autopilots.ardupilot import ROVER_MODES, ardupilot_mode_name
from convoy_mav.mavlink.autopilots.px4 import px4_mode_name
from convoy_mav.types import ConvoyDrive

__all__ = ["RoverMode", "drive_of", "rover_mode"]

_MISSION = frozenset({"AUTO", "AUTO.MISSION"})
_STANDS = frozenset({"HOLD", "LOITER", "AUTO.LOITER"})
_HOME = frozenset({"RTL", "AUTO.RTL"})
_RETRACE = frozenset({"SMART_RTL"})
_GROUND = frozenset({mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_TYPE_SURFACE_BOAT})


@dataclass(frozen=True, slots=True)
class RoverMode:
    """A rover's mode: what drives it, and the mode's name as its firmware calls it."""

    drive: ConvoyDrive
    name: str  # "AUTO", "HOLD", "AUTO.MISSION", "AUTO, disarmed"


def rover_mode(heartbeat: Any) -> RoverMode | None:
    """What a HEARTBEAT says drives the rover; None if it is no ArduPilot or PX4 rover
    (or boat), whose modes are not known here."""
    if heartbeat.type not in _GROUND:
        return None
    custom = int(heartbeat.custom_mode)
    if heartbeat.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA:
        name = ardupilot_mode_name(ROVER_MODES, custom)
    elif heartbeat.autopilot == mavlink.MAV_AUTOPILOT_PX4:
        name = px4_mode_name(custom)
    else:
        return None
    armed = bool(heartbeat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    return RoverMode(drive_of(name, armed), name if armed else f"{name}, disarmed")


def drive_of(name: str, armed: bool) -> ConvoyDrive:
    """What drives a rover in the mode its firmware names ``name`` (ArduRover's "AUTO",
    PX4's "AUTO.MISSION"), armed or not: disarmed, it stands."""
    if not armed or name in _STANDS:
        return ConvoyDrive.HELD
    if name in _MISSION:
        return ConvoyDrive.MISSION
    if name in _HOME:
        return ConvoyDrive.HOME
    return ConvoyDrive.RETRACE if name in _RETRACE else ConvoyDrive.OTHER
