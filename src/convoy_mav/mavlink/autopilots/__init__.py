"""One strategy class per autopilot firmware, chosen from the first HEARTBEAT.

``autopilot_for`` recognises the firmware from HEARTBEAT.autopilot (PX4 = 12,
ArduPilot = 3) and the airframe from HEARTBEAT.type, and returns the strategy
that drives that vehicle (see ``base.Autopilot``); None means "not something
this service can fly" (a rover, a gimbal, an unknown firmware).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.autopilots.ardupilot import ArduCopter, ArduPilot, ArduPlane
from convoy_mav.mavlink.autopilots.base import (
    DEFAULT_STREAM_RATES,
    FLIGHT_STREAM_RATES,
    Autopilot,
    CommandSpec,
    PhaseLoop,
    SetupStep,
    VehicleClass,
    along_track_error,
    phase_corrected_speed,
    vehicle_class,
)
from convoy_mav.mavlink.autopilots.px4 import PX4

__all__ = [
    "DEFAULT_STREAM_RATES",
    "FLIGHT_STREAM_RATES",
    "PX4",
    "ArduCopter",
    "ArduPilot",
    "ArduPlane",
    "Autopilot",
    "CommandSpec",
    "PhaseLoop",
    "SetupStep",
    "VehicleClass",
    "along_track_error",
    "autopilot_for",
    "firmware_name",
    "phase_corrected_speed",
    "vehicle_class",
]


def firmware_name(autopilot: int) -> str:
    """A readable name of a MAV_AUTOPILOT value (for messages about unsupported ones)."""
    entry = mavlink.enums["MAV_AUTOPILOT"].get(autopilot)
    return entry.name if entry is not None else f"MAV_AUTOPILOT {autopilot}"


def autopilot_for(
    autopilot: int, mav_type: int, sysid: int, compid: int, frame: LocalFrame
) -> Autopilot | None:
    """The strategy for a vehicle whose HEARTBEAT says ``autopilot`` and ``mav_type``.

    Args:
        autopilot: HEARTBEAT.autopilot (MAV_AUTOPILOT).
        mav_type: HEARTBEAT.type (MAV_TYPE).
        sysid: The vehicle's system id.
        compid: The component id that sent the heartbeat (the autopilot).
        frame: The mission frame.

    Returns:
        PX4, ArduCopter or ArduPlane; None for other firmwares or airframes.
    """
    kind = vehicle_class(mav_type)
    if kind is VehicleClass.OTHER:
        return None
    if autopilot == mavlink.MAV_AUTOPILOT_PX4:
        return PX4(sysid, compid, frame, kind)
    if autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA:
        cls = ArduPlane if kind is VehicleClass.PLANE else ArduCopter
        return cls(sysid, compid, frame, kind)
    return None
