"""The parameter protocol of a simulated vehicle: names, indices and units.

Each firmware names its parameters its own way (PX4 ``FW_AIRSPD_TRIM`` in m/s,
ArduCopter ``WPNAV_SPEED`` in cm/s), and means its own thing by them (PX4's
``MPC_XY_VEL_MAX`` clamps a copter's every velocity, ArduCopter's ``WPNAV_SPEED``
only its moves to a position); the vehicle underneath keeps physical
values in SI units under a small set of *knobs* (``Knob``). A ``ParamTable``
maps one to the other, keeps the list order (PARAM_VALUE's ``param_index``)
and builds the PARAM_VALUE replies. Applying a value is the vehicle's business:
the table only converts and validates.

Every parameter is sent as MAV_PARAM_TYPE_REAL32, which both PX4 and ArduPilot
use for their float parameters, so no byte-wise integer encoding is needed.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum

from pymavlink.dialects.v20 import common as mavlink

__all__ = ["Knob", "KnobGetter", "KnobSetter", "ParamDef", "ParamTable"]

_PARAM_ID_LEN = 16


class Knob(StrEnum):
    """A physical setting of the vehicle that a parameter exposes (SI units)."""

    AIRSPEED = "airspeed"  # m/s: plane cruise / copter max horizontal speed
    NAV_SPEED = "nav_speed"  # m/s: copter: speed of moves to a position; velocities fly their own
    AIRSPEED_MIN = "airspeed_min"  # m/s: plane: the slowest airspeed it is commanded
    AIRSPEED_MAX = "airspeed_max"  # m/s: plane: the fastest
    TURN_RADIUS = "turn_radius"  # m: airframe minimum turn radius
    CLIMB_RATE = "climb_rate"  # m/s: maximum climb rate
    SETPOINT_TIMEOUT = "setpoint_timeout"  # s: offboard / guided setpoint loss
    LOITER_RADIUS = "loiter_radius"  # m: default loiter radius (hold, reposition)
    TAKEOFF_ALT = "takeoff_alt"  # m above home: default takeoff / climb-out height
    RTL_ALT = "rtl_alt"  # m above home: return altitude
    WARMUP = "warmup"  # s: sensor warm-up after boot (applies at the next boot)
    SPEEDUP = "speedup"  # sim s per wall s: the whole mock's clock (ArduPilot SITL's too)
    SYSID = "sysid"  # read-only: the MAVLink system id
    WP_SPEED = "wp_speed"  # m/s, read-only: a rover's speed in AUTO (its road's; 0: none)
    ROVER_ACCEL = "rover_accel"  # m/s², read-only: a rover's braking and speeding up (0: none)
    WP_RADIUS = "wp_radius"  # m, read-only: a rover passes its corners within it
    GCS_SYSID = "gcs_sysid"  # ArduPilot: the system id of its ground station (1..255)
    MAV_OPTIONS = "mav_options"  # ArduPilot: bit 0, hear only that ground station
    RTL_SPEED = "rtl_speed"  # m/s: a rover's speed home in RTL (0: its WP_SPEED)
    RALLY_LIMIT_KM = "rally_limit_km"  # km: RTL to a rally point only this near (0: any)
    RALLY_INCL_HOME = "rally_incl_home"  # 1: RTL to a rally point only if nearer than home
    RALLY_TOTAL = "rally_total"  # read-only: the rally points it holds
    SRTL_ACCURACY = "srtl_accuracy"  # m: SmartRTL's path points this far apart, at least
    SRTL_POINTS = "srtl_points"  # read-only: the most points SmartRTL's path holds
    FS_CRASH_CHECK = "fs_crash_check"  # a rover standing with its throttle up: 1 HOLD


KnobGetter = Callable[[Knob], float]
"""Reads a knob's SI value from the vehicle."""
KnobSetter = Callable[[Knob, float], None]
"""Applies a knob's SI value to the vehicle; raises ValueError when it cannot."""


@dataclass(frozen=True, slots=True)
class ParamDef:
    """One parameter as a firmware names it.

    Attributes:
        name: Parameter id (at most 16 characters).
        knob: The physical setting behind it.
        scale: ``param value = physical value * scale`` (100 for cm/s, cm).
        read_only: PARAM_SET is answered with the unchanged value.
        minimum: Smallest accepted physical value (inclusive).
    """

    name: str
    knob: Knob
    scale: float = 1.0
    read_only: bool = False
    minimum: float = 0.0

    def __post_init__(self) -> None:
        if not 0 < len(self.name) <= _PARAM_ID_LEN:
            raise ValueError(f"parameter name must be 1..16 characters, got {self.name!r}")
        if not (math.isfinite(self.scale) and self.scale > 0.0):
            raise ValueError(f"scale of {self.name} must be > 0, got {self.scale!r}")


class ParamTable:
    """The ordered parameter list of one vehicle.

    Args:
        defs: Parameters in the order PARAM_REQUEST_LIST reports them.

    Raises:
        ValueError: Two parameters share a name.
    """

    def __init__(self, defs: Sequence[ParamDef]) -> None:
        self.defs: tuple[ParamDef, ...] = tuple(defs)
        self._index = {d.name: i for i, d in enumerate(self.defs)}
        if len(self._index) != len(self.defs):
            raise ValueError("parameter names must be unique")

    def __len__(self) -> int:
        return len(self.defs)

    def lookup(self, name: str, index: int = -1) -> int | None:
        """Index of a parameter by ``index`` (if >= 0) else by ``name``; None if unknown.

        Names compare as MAVLink sends them: at most 16 characters, NUL-padded.
        """
        if index >= 0:
            return index if index < len(self.defs) else None
        return self._index.get(name.rstrip("\x00")[:_PARAM_ID_LEN])

    def to_physical(self, index: int, value: float) -> float:
        """Convert a PARAM_SET value to the knob's SI value.

        Raises:
            ValueError: The value is not finite or below the parameter's minimum.
        """
        d = self.defs[index]
        if not math.isfinite(value):
            raise ValueError(f"{d.name} must be finite, got {value!r}")
        physical = value / d.scale
        if physical < d.minimum:
            raise ValueError(f"{d.name} must be >= {d.minimum * d.scale:g}, got {value:g}")
        return physical

    def param_value(self, index: int, physical: float) -> mavlink.MAVLink_param_value_message:
        """The PARAM_VALUE message reporting parameter ``index`` at ``physical``."""
        d = self.defs[index]
        return mavlink.MAVLink_param_value_message(
            param_id=d.name.encode("ascii"),
            param_value=float(physical * d.scale),
            param_type=mavlink.MAV_PARAM_TYPE_REAL32,
            param_count=len(self.defs),
            param_index=index,
        )

    # ------------------------------------------------------------- the protocol
    def request_list(self, get: KnobGetter) -> list[mavlink.MAVLink_param_value_message]:
        """PARAM_REQUEST_LIST: every parameter, in index order."""
        return [self.param_value(i, get(d.knob)) for i, d in enumerate(self.defs)]

    def request_read(
        self, param_id: str, param_index: int, get: KnobGetter
    ) -> mavlink.MAVLink_param_value_message | None:
        """PARAM_REQUEST_READ: the one parameter asked for; None if unknown (no reply)."""
        index = self.lookup(param_id, param_index)
        if index is None:
            return None
        return self.param_value(index, get(self.defs[index].knob))

    def set(
        self, param_id: str, value: float, get: KnobGetter, put: KnobSetter
    ) -> tuple[mavlink.MAVLink_param_value_message, str | None] | None:
        """PARAM_SET: apply and report the value now in force.

        Returns:
            None for an unknown parameter (autopilots do not answer those); else the
            PARAM_VALUE to send and, when the value was refused, why. A refused or
            read-only parameter is answered with its unchanged value, which is how a
            ground station learns that the set did not take.
        """
        index = self.lookup(param_id)
        if index is None:
            return None
        d = self.defs[index]
        error = None
        if not d.read_only:
            try:
                put(d.knob, self.to_physical(index, value))
            except ValueError as e:
                error = f"{d.name}: {e}"
        return self.param_value(index, get(d.knob)), error
