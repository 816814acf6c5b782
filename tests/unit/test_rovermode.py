"""A ground vehicle's HEARTBEAT read as what drives it: its mission, a stand, or else."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.rovermode import RoverMode, rover_mode
from convoy_mav.types import ConvoyDrive

_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
_AP, _PX4 = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, mavlink.MAV_AUTOPILOT_PX4


def _px4(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


def _heartbeat(
    autopilot: int, custom: int, *, armed: bool = True, kind: int = mavlink.MAV_TYPE_GROUND_ROVER
) -> mavlink.MAVLink_heartbeat_message:
    base = _ARMED if armed else mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    return mavlink.MAVLink_heartbeat_message(kind, autopilot, base, custom, 4, 3)


@pytest.mark.parametrize(
    ("autopilot", "custom", "drive", "name"),
    [
        (_AP, 10, ConvoyDrive.MISSION, "AUTO"),
        (_AP, 4, ConvoyDrive.HELD, "HOLD"),
        (_AP, 5, ConvoyDrive.HELD, "LOITER"),
        (_AP, 0, ConvoyDrive.OTHER, "MANUAL"),
        (_AP, 15, ConvoyDrive.OTHER, "GUIDED"),
        (_AP, 11, ConvoyDrive.HOME, "RTL"),
        (_AP, 12, ConvoyDrive.RETRACE, "SMART_RTL"),
        (_AP, 99, ConvoyDrive.OTHER, "MODE(99)"),
        (_PX4, _px4(4, 4), ConvoyDrive.MISSION, "AUTO.MISSION"),
        (_PX4, _px4(4, 3), ConvoyDrive.HELD, "AUTO.LOITER"),
        (_PX4, _px4(1), ConvoyDrive.OTHER, "MANUAL"),
        (_PX4, _px4(4, 5), ConvoyDrive.HOME, "AUTO.RTL"),
    ],
)
def test_each_firmwares_modes_say_what_drives_the_rover(
    autopilot: int, custom: int, drive: ConvoyDrive, name: str
) -> None:
    assert rover_mode(_heartbeat(autopilot, custom)) == RoverMode(drive, name)


def test_a_disarmed_rover_stands_and_a_boat_is_read_as_a_rover() -> None:
    assert rover_mode(_heartbeat(_AP, 10, armed=False)) == RoverMode(
        ConvoyDrive.HELD, "AUTO, disarmed"
    )
    boat = _heartbeat(_PX4, _px4(4, 4), kind=mavlink.MAV_TYPE_SURFACE_BOAT)
    assert rover_mode(boat) == RoverMode(ConvoyDrive.MISSION, "AUTO.MISSION")


def test_nothing_is_said_of_other_vehicles_or_firmwares() -> None:
    assert rover_mode(_heartbeat(_AP, 10, kind=mavlink.MAV_TYPE_FIXED_WING)) is None
    assert rover_mode(_heartbeat(mavlink.MAV_AUTOPILOT_GENERIC, 10)) is None
    assert rover_mode(_heartbeat(mavlink.MAV_AUTOPILOT_INVALID, 0)) is None
