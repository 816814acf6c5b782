"""Firmware personalities: how PX4 and ArduPilot say the same things differently.

The state machine in ``autopilot.py`` is firmware-neutral: it knows *behaviours*
(hold here, fly external setpoints, take off, return, land). One ``Firmware``
strategy object per (personality, vehicle class) supplies everything a ground
station can tell the firmwares apart by:

* mode numbers and their encoding in HEARTBEAT.custom_mode (PX4 packs
  ``main << 16 | sub << 24``; ArduPilot sends the mode number of its vehicle),
  and the HEARTBEAT.base_mode flags each firmware derives from the mode;
* which COMMAND_ACK result and STATUSTEXT a refusal carries (PX4 rejects arming
  and mode changes with TEMPORARILY_REJECTED, ArduPilot with FAILED, both with a
  text in their own words);
* parameter names and units; altitude conventions of commands (PX4 reads a
  COMMAND_LONG altitude as AMSL, ArduPilot as relative to home);
* which position setpoints are flown (PX4: all, in OFFBOARD; ArduCopter: all, in
  GUIDED; ArduPlane: only the altitude, which is why planes are steered with
  DO_REPOSITION) and whether losing them changes the mode (PX4 only);
* whether telemetry streams before a ground station asks (PX4 yes, ArduPilot no).

The tables follow PX4 ``px4_custom_mode.h`` (main/sub mode numbers) and its
HEARTBEAT base-mode flags, and ArduPilot's ``mode.h`` / ``GCS_Mavlink.cpp`` of each
vehicle (mode numbers, ``base_mode()``, ``handle_command_int_do_reposition``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Literal

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import l1_loiter_scale
from sitl_mock.params import Knob, ParamDef

__all__ = [
    "Behaviour",
    "Firmware",
    "FlightMode",
    "Personality",
    "SetpointPolicy",
    "VehicleClass",
    "firmware_for",
]

VehicleClass = Literal["plane", "copter", "rover"]

_MANUAL = mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
_STAB = mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
_GUIDED = mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
_AUTO = mavlink.MAV_MODE_FLAG_AUTO_ENABLED


class Personality(StrEnum):
    """Which firmware a simulated vehicle imitates."""

    PX4 = "px4"
    ARDUPILOT = "ardupilot"


class Behaviour(Enum):
    """What a flight mode makes the vehicle do, independent of the firmware."""

    MANUAL = "manual"  # pilot modes; with no RC input the mock holds position in the air
    HOLD = "hold"  # loiter / hover at the entry point (or a reposition target)
    EXTERNAL = "external"  # fly a companion's setpoints (PX4 OFFBOARD, ArduPilot GUIDED)
    TAKEOFF = "takeoff"  # climb to the takeoff altitude, then hold
    MISSION = "mission"  # the mock has no mission: refused for aircraft
    RTL = "rtl"  # go home (copter lands there, plane loiters over it)
    LAND = "land"  # descend where it is and disarm on touchdown


class SetpointPolicy(Enum):
    """Which SET_POSITION_TARGET_* fields a firmware flies in its external mode."""

    FULL = "full"
    ALTITUDE_ONLY = "altitude_only"
    NONE = "none"


@dataclass(frozen=True, slots=True)
class FlightMode:
    """One flight mode of one firmware.

    Attributes:
        name: Mode name as ground stations show it (``"OFFBOARD"``, ``"GUIDED"``).
        custom_mode: HEARTBEAT.custom_mode value of the mode.
        behaviour: What it does.
        flags: HEARTBEAT.base_mode flags of the mode, besides CUSTOM_MODE_ENABLED
            and SAFETY_ARMED which the firmware adds.
        needs_position: Refused until the position estimate is valid (warm-up).
        armable: Arming is allowed in this mode.
    """

    name: str
    custom_mode: int
    behaviour: Behaviour
    flags: int
    needs_position: bool = True
    armable: bool = True


@dataclass(frozen=True, slots=True)
class Firmware:
    """Everything firmware-specific about one kind of simulated vehicle.

    Attributes:
        personality: PX4 or ArduPilot.
        vehicle_class: ``"plane"``, ``"copter"`` or ``"rover"``.
        modes: Every mode the vehicle accepts.
        boot: Mode after boot. hold/external/takeoff/rtl/land: the mode that
            implements that behaviour (``None`` when the vehicle has none).
        streams_on_boot: Telemetry streams run before anyone asks (PX4).
        boot_stream_hz: Else, the rate of every REQUEST_DATA_STREAM group from boot:
            ArduPilot's SRn_* defaults, 1 Hz for ArduPlane and ArduRover, 0 for
            ArduCopter (``GCS_MAVLink_Parameters.cpp``).
        reject_result: COMMAND_ACK result of a refused arm or mode change.
        set_mode_ack: ``command`` field of the COMMAND_ACK answering a SET_MODE
            message (ArduPilot acks with the message id 11, PX4 with DO_SET_MODE).
        long_alt_relative: COMMAND_LONG altitudes are relative to home (ArduPilot)
            rather than AMSL (PX4).
        setpoints: Which SET_POSITION_TARGET fields the external mode flies.
        loss_changes_mode: Losing the setpoint stream switches to the hold mode
            (PX4 offboard failsafe) instead of stopping in place (ArduCopter).
        params: The parameter list.
        version: AUTOPILOT_VERSION.flight_sw_version.
        capabilities: AUTOPILOT_VERSION.capabilities.
    """

    personality: Personality
    vehicle_class: VehicleClass
    modes: tuple[FlightMode, ...]
    boot: str
    hold: str
    external: str | None
    takeoff: str | None
    rtl: str | None
    land: str | None
    streams_on_boot: bool
    boot_stream_hz: int
    reject_result: int
    set_mode_ack: int
    long_alt_relative: bool
    setpoints: SetpointPolicy
    loss_changes_mode: bool
    params: tuple[ParamDef, ...]
    version: int
    capabilities: int

    # ------------------------------------------------------------------ identity
    @property
    def autopilot(self) -> int:
        """HEARTBEAT.autopilot."""
        if self.personality is Personality.PX4:
            return int(mavlink.MAV_AUTOPILOT_PX4)
        return int(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA)

    @property
    def mav_type(self) -> int:
        """HEARTBEAT.type."""
        types: dict[str, int] = {
            "plane": mavlink.MAV_TYPE_FIXED_WING,
            "copter": mavlink.MAV_TYPE_QUADROTOR,
            "rover": mavlink.MAV_TYPE_GROUND_ROVER,
        }
        return types[self.vehicle_class]

    # --------------------------------------------------------------------- modes
    def mode(self, name: str) -> FlightMode:
        """The mode called ``name``.

        Raises:
            KeyError: The firmware has no such mode.
        """
        for m in self.modes:
            if m.name == name:
                return m
        raise KeyError(name)

    def decode_mode(self, custom_mode: int) -> FlightMode | None:
        """The mode a HEARTBEAT/SET_MODE ``custom_mode`` value names, if any."""
        if self.personality is Personality.PX4:
            main = (custom_mode >> 16) & 0xFF
            sub = (custom_mode >> 24) & 0xFF
            if main == _PX4_AUTO and sub == 0:
                sub = _PX4_SUB_MISSION  # PX4: AUTO without a sub mode means mission
            elif main != _PX4_AUTO:
                sub = 0
            custom_mode = _px4(main, sub)
        for m in self.modes:
            if m.custom_mode == custom_mode:
                return m
        return None

    def decode_do_set_mode(self, param2: float, param3: float) -> FlightMode | None:
        """The mode MAV_CMD_DO_SET_MODE asks for (param2 main/number, param3 PX4 sub)."""
        if not (math.isfinite(param2) and param2 >= 0.0):
            return None
        if self.personality is Personality.PX4:
            sub = int(param3) if math.isfinite(param3) and param3 >= 0.0 else 0
            return self.decode_mode(_px4(int(param2), sub))
        return self.decode_mode(int(param2))

    def base_mode(self, mode: FlightMode, armed: bool) -> int:
        """HEARTBEAT.base_mode for ``mode``."""
        flags = int(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED) | mode.flags
        if armed:
            flags |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        return flags

    def system_status(self, armed: bool, airborne: bool, failsafe: bool) -> int:
        """HEARTBEAT.system_status: STANDBY, ACTIVE, or CRITICAL in a failsafe."""
        if failsafe and armed:
            return int(mavlink.MAV_STATE_CRITICAL)
        # ArduPlane reports ACTIVE only while flying; the others once armed.
        active = airborne if self.is_ardupilot and self.vehicle_class == "plane" else armed
        return int(mavlink.MAV_STATE_ACTIVE if active else mavlink.MAV_STATE_STANDBY)

    # ------------------------------------------------------------- refusal texts
    @property
    def is_ardupilot(self) -> bool:
        """True for the ArduPilot personality."""
        return self.personality is Personality.ARDUPILOT

    @property
    def home_at_fix(self) -> bool:
        """Home (the estimator's origin) is set at the receiver's 3D fix, and modes
        that need a position are entered from then, while arming is refused until
        the estimator uses the GPS: ArduPilot (ArduCopter SITL set its origin and
        took GUIDED some 20 sim s before "EKF3 IMU0 is using GPS", refusing ARM with
        "Need Position Estimate" in between). PX4 sets home as its estimate turns
        valid, when it may also arm."""
        return self.is_ardupilot

    def arm_denied_text(self, reason: str) -> str:
        """STATUSTEXT of a refused arming, in the firmware's words."""
        if self.is_ardupilot:  # ArduPilot >= 4.5: "Arm:" when refusing, "PreArm:" periodically
            return f"Arm: {reason}"
        return f"Arming denied! {reason}"

    def warmup_reason(self) -> str:
        """Why arming is refused before the sensors are warm."""
        if self.is_ardupilot:
            return "Need Position Estimate"
        return "No valid global position estimate"

    def mode_denied_text(self, mode: FlightMode, reason: str) -> str:
        """STATUSTEXT of a refused mode change."""
        if self.is_ardupilot:
            return f"Mode change to {mode.name} failed: {reason}"
        return f"Switching to {mode.name.title()} is currently not available"

    # ----------------------------------------------------------------- commands
    def loiter_circle(self, param3: float, param4: float, default: float) -> tuple[float, bool]:
        """Radius and clockwise flag of a DO_REPOSITION loiter (planes).

        ArduPlane: radius from param3 when > 0, cut to whole metres up to 65535
        (``ModeGuided::set_radius_and_direction``, ``constrain_int32`` to ``UINT16_MAX``:
        a wider loiter is flown at that radius about its far centre), counter-clockwise
        when param4 is non-zero (``handle_command_int_do_reposition``). PX4 has no documented
        radius parameter; the mock reads |param3| as the radius and a negative
        param3 as counter-clockwise, as recent PX4 builds do, and otherwise uses
        NAV_LOITER_RAD clockwise.
        """
        if self.is_ardupilot:
            given = math.isfinite(param3) and param3 > 0.0
            radius = (float(min(int(param3), _UINT16_MAX)) if given else 0.0) or default
            ccw = math.isfinite(param4) and param4 != 0.0
            return radius, not ccw
        if math.isfinite(param3) and param3 != 0.0:
            return abs(param3), param3 > 0.0
        return default, True

    def loiter_scale(self, amsl: float) -> float:
        """How much wider than commanded a plane flies a loiter at ``amsl`` (m).

        ArduPlane's L1 flies every loiter at its radius times ``EAS2TAS^2``
        (``AP_L1_Control::loiter_radius``, ``NAVL1_LIM_BANK`` 0, its default): SITL
        at 630 m AMSL flies a 2275 m loiter at 2438 m, 1000 m at 1073 m. PX4's
        NPFG flies the radius it is given.
        """
        return l1_loiter_scale(amsl) if self.is_ardupilot else 1.0

    def airspeed_scale(self, amsl: float) -> float:
        """True airspeed a plane flies per unit of airspeed commanded, at ``amsl`` (m).

        ArduPlane's airspeeds (DO_CHANGE_SPEED, AIRSPEED_CRUISE/MIN/MAX) are equivalent
        airspeeds: TECS demands ``_TAS_dem = _EAS_dem * EAS2TAS`` (``AP_TECS``), so a
        plane told 22 m/s 684 m above the sea flies 22.7 m/s through the air. (ArduPlane
        SITL flies 23.5: its simulated pitot divides the EAS it is handed by EAS2TAS
        once more, ``SITL_State::_update_airspeed``; a real pitot does not.) ArduCopter's
        speeds are ground speeds, and PX4's planes here fly their setpoints' speeds.
        """
        return math.sqrt(l1_loiter_scale(amsl)) if self.equivalent_airspeeds else 1.0

    @property
    def equivalent_airspeeds(self) -> bool:
        """A plane whose commanded airspeeds are equivalent airspeeds (ArduPlane)."""
        return self.is_ardupilot and self.vehicle_class == "plane"


# ============================================================================ tables
_UINT16_MAX = 65535
_PX4_AUTO = 4
_PX4_SUB_MISSION = 4


def _px4(main: int, sub: int = 0) -> int:
    return ((main & 0xFF) << 16) | ((sub & 0xFF) << 24)


def _px4_modes(rotary: bool) -> tuple[FlightMode, ...]:
    auto = _AUTO | _STAB | _GUIDED
    b = Behaviour
    return (
        FlightMode("MANUAL", _px4(1), b.MANUAL, _MANUAL | (_STAB if rotary else 0), False),
        FlightMode("ALTCTL", _px4(2), b.MANUAL, _MANUAL | _STAB, False),
        FlightMode("POSCTL", _px4(3), b.HOLD, _MANUAL | _STAB | _GUIDED),
        FlightMode("AUTO.TAKEOFF", _px4(4, 2), b.TAKEOFF, auto),
        FlightMode("AUTO.LOITER", _px4(4, 3), b.HOLD, auto),
        FlightMode("AUTO.MISSION", _px4(4, 4), b.MISSION, auto),
        FlightMode("AUTO.RTL", _px4(4, 5), b.RTL, auto, armable=False),
        FlightMode("AUTO.LAND", _px4(4, 6), b.LAND, auto, armable=False),
        FlightMode("ACRO", _px4(5), b.MANUAL, _MANUAL, False),
        FlightMode("OFFBOARD", _px4(6), b.EXTERNAL, auto),
        FlightMode("STABILIZED", _px4(7), b.MANUAL, _MANUAL | _STAB, False),
    )


def _arducopter_modes() -> tuple[FlightMode, ...]:
    base = _STAB | _MANUAL
    g = base | _GUIDED
    b = Behaviour
    return (
        FlightMode("STABILIZE", 0, b.MANUAL, base, False),
        FlightMode("ACRO", 1, b.MANUAL, base, False),
        FlightMode("ALT_HOLD", 2, b.MANUAL, base, False),
        FlightMode("AUTO", 3, b.MISSION, g),
        FlightMode("GUIDED", 4, b.EXTERNAL, g),
        FlightMode("LOITER", 5, b.HOLD, g),
        FlightMode("RTL", 6, b.RTL, g, armable=False),
        FlightMode("CIRCLE", 7, b.HOLD, g),
        FlightMode("LAND", 9, b.LAND, base, armable=False),
        FlightMode("POSHOLD", 16, b.HOLD, g),
        FlightMode("BRAKE", 17, b.HOLD, g),
        FlightMode("SMART_RTL", 21, b.RTL, g, armable=False),
    )


def _arduplane_modes() -> tuple[FlightMode, ...]:
    stab = _STAB | _MANUAL  # stick mixing (default) adds MANUAL_INPUT to every mode
    g = _GUIDED | stab
    b = Behaviour
    return (
        FlightMode("MANUAL", 0, b.MANUAL, _MANUAL, False),
        FlightMode("CIRCLE", 1, b.HOLD, g, False),
        FlightMode("STABILIZE", 2, b.MANUAL, stab, False),
        FlightMode("TRAINING", 3, b.MANUAL, stab, False),
        FlightMode("ACRO", 4, b.MANUAL, stab, False),
        FlightMode("FBWA", 5, b.MANUAL, stab, False),
        FlightMode("FBWB", 6, b.MANUAL, stab, False),
        FlightMode("CRUISE", 7, b.MANUAL, stab, False),
        FlightMode("AUTO", 10, b.MISSION, g),
        FlightMode("RTL", 11, b.RTL, g),
        FlightMode("LOITER", 12, b.HOLD, g),
        FlightMode("TAKEOFF", 13, b.TAKEOFF, g),
        FlightMode("GUIDED", 15, b.EXTERNAL, g),
    )


def _ardurover_modes() -> tuple[FlightMode, ...]:
    g = _GUIDED | _STAB
    b = Behaviour
    return (
        FlightMode("MANUAL", 0, b.MANUAL, _MANUAL, False),
        FlightMode("ACRO", 1, b.MANUAL, _STAB, False),
        FlightMode("STEERING", 3, b.MANUAL, _STAB, False),
        FlightMode("HOLD", 4, b.HOLD, _STAB, False),
        FlightMode("LOITER", 5, b.HOLD, g, False),
        FlightMode("AUTO", 10, b.MISSION, g, False),
        FlightMode("RTL", 11, b.RTL, g, False),
        FlightMode("SMART_RTL", 12, b.RTL, g, False),
        FlightMode("GUIDED", 15, b.EXTERNAL, g, False),
    )


def _version(major: int, minor: int, patch: int) -> int:
    official = int(mavlink.FIRMWARE_VERSION_TYPE_OFFICIAL)
    return (major << 24) | (minor << 16) | (patch << 8) | official


_CAPS = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
)


def _common_params(personality: Personality) -> tuple[ParamDef, ...]:
    sysid = "SYSID_THISMAV" if personality is Personality.ARDUPILOT else "MAV_SYS_ID"
    common = (
        ParamDef("SIM_TURN_RAD", Knob.TURN_RADIUS, minimum=1.0),
        ParamDef("SIM_WARMUP_S", Knob.WARMUP),
        ParamDef("SIM_SPEEDUP", Knob.SPEEDUP, minimum=0.01),  # (ArduPilot SITL's name)
        ParamDef(sysid, Knob.SYSID, read_only=True),
    )
    if personality is Personality.PX4:
        return common
    return (  # (this SITL build's names; SYSID_MYGCS and SYSID_ENFORCE in older releases)
        *common,
        ParamDef("MAV_GCS_SYSID", Knob.GCS_SYSID, minimum=1.0),
        ParamDef("MAV_OPTIONS", Knob.MAV_OPTIONS),
    )


def _params(personality: Personality, vehicle_class: VehicleClass) -> tuple[ParamDef, ...]:
    common = _common_params(personality)
    if vehicle_class == "rover" and personality is Personality.ARDUPILOT:
        # AUTO's speed where the mission sets none (WP_SPEED; 0: CRUISE_SPEED's): the speed
        # its road is driven at, scripted, so not to be set.
        return (
            ParamDef("WP_SPEED", Knob.WP_SPEED, read_only=True),
            ParamDef("CRUISE_SPEED", Knob.WP_SPEED, read_only=True),
            ParamDef("ATC_ACCEL_MAX", Knob.ROVER_ACCEL, read_only=True),
            ParamDef("WP_RADIUS", Knob.WP_RADIUS, read_only=True),
            ParamDef("RTL_SPEED", Knob.RTL_SPEED),
            ParamDef("RALLY_LIMIT_KM", Knob.RALLY_LIMIT_KM),
            ParamDef("RALLY_INCL_HOME", Knob.RALLY_INCL_HOME),
            ParamDef("RALLY_TOTAL", Knob.RALLY_TOTAL, read_only=True),
            ParamDef("SRTL_ACCURACY", Knob.SRTL_ACCURACY),
            ParamDef("SRTL_POINTS", Knob.SRTL_POINTS, read_only=True),
            ParamDef("FS_CRASH_CHECK", Knob.FS_CRASH_CHECK),
            *common[1:],
        )
    if vehicle_class == "rover":
        return common[1:]
    k = Knob
    own: tuple[ParamDef, ...]
    if personality is Personality.PX4 and vehicle_class == "plane":
        own = (
            ParamDef("FW_AIRSPD_TRIM", k.AIRSPEED, minimum=0.5),
            ParamDef("FW_AIRSPD_MIN", k.AIRSPEED_MIN, minimum=0.5),
            ParamDef("FW_AIRSPD_MAX", k.AIRSPEED_MAX, minimum=0.5),
            ParamDef("FW_T_CLMB_MAX", k.CLIMB_RATE, minimum=0.1),
            ParamDef("NAV_LOITER_RAD", k.LOITER_RADIUS),
            ParamDef("COM_OF_LOSS_T", k.SETPOINT_TIMEOUT, minimum=0.01),
            ParamDef("MIS_TAKEOFF_ALT", k.TAKEOFF_ALT, minimum=1.0),
            ParamDef("RTL_RETURN_ALT", k.RTL_ALT),
        )
    elif personality is Personality.PX4:
        own = (
            ParamDef("MPC_XY_VEL_MAX", k.AIRSPEED, minimum=0.5),
            ParamDef("MPC_Z_VEL_MAX_UP", k.CLIMB_RATE, minimum=0.1),
            ParamDef("COM_OF_LOSS_T", k.SETPOINT_TIMEOUT, minimum=0.01),
            ParamDef("MIS_TAKEOFF_ALT", k.TAKEOFF_ALT, minimum=1.0),
            ParamDef("RTL_RETURN_ALT", k.RTL_ALT),
        )
    elif vehicle_class == "plane":
        own = (
            ParamDef("AIRSPEED_CRUISE", k.AIRSPEED, minimum=0.5),
            ParamDef("AIRSPEED_MIN", k.AIRSPEED_MIN, minimum=0.5),
            ParamDef("AIRSPEED_MAX", k.AIRSPEED_MAX, minimum=0.5),
            ParamDef("TECS_CLMB_MAX", k.CLIMB_RATE, minimum=0.1),
            ParamDef("WP_LOITER_RAD", k.LOITER_RADIUS),
            ParamDef("TKOFF_ALT", k.TAKEOFF_ALT, minimum=1.0),
            ParamDef("RTL_ALTITUDE", k.RTL_ALT),
        )
    else:
        own = (
            # (GUIDED's speed to a position, and its cap on correcting towards a moving
            # one; a velocity target is flown at its own speed: mode_guided.cpp's
            # posvelaccel run shapes with limit_output false)
            ParamDef("WPNAV_SPEED", k.NAV_SPEED, scale=100.0, minimum=0.5),
            ParamDef("WPNAV_SPEED_UP", k.CLIMB_RATE, scale=100.0, minimum=0.1),
            ParamDef("GUID_TIMEOUT", k.SETPOINT_TIMEOUT, minimum=0.01),
            ParamDef("PILOT_TKOFF_ALT", k.TAKEOFF_ALT, scale=100.0, minimum=1.0),
            ParamDef("RTL_ALT", k.RTL_ALT, scale=100.0),
        )
    return own + common


def firmware_for(personality: Personality, vehicle_class: VehicleClass) -> Firmware:
    """The firmware strategy of a ``vehicle_class`` vehicle running ``personality``."""
    px4 = personality is Personality.PX4
    modes: tuple[FlightMode, ...]
    if px4:
        modes = _px4_modes(rotary=vehicle_class == "copter")
        names = ("AUTO.LOITER", "OFFBOARD", "AUTO.TAKEOFF", "AUTO.RTL", "AUTO.LAND")
        boot = "AUTO.MISSION" if vehicle_class == "rover" else "AUTO.LOITER"
    elif vehicle_class == "copter":
        modes = _arducopter_modes()
        names = ("LOITER", "GUIDED", "GUIDED", "RTL", "LAND")
        boot = "STABILIZE"
    elif vehicle_class == "plane":
        modes = _arduplane_modes()
        names = ("LOITER", "GUIDED", "TAKEOFF", "RTL", "")
        boot = "MANUAL"
    else:
        modes = _ardurover_modes()
        names = ("HOLD", "GUIDED", "", "RTL", "")
        boot = "AUTO"
    hold, external, takeoff, rtl, land = names
    if vehicle_class == "plane":
        land = ""  # no landing pattern in the mock: planes are refused LAND
    if vehicle_class == "rover":
        setpoints = SetpointPolicy.NONE
    elif vehicle_class == "plane" and not px4:
        setpoints = SetpointPolicy.ALTITUDE_ONLY
    else:
        setpoints = SetpointPolicy.FULL
    byte_params = (
        mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
        if px4
        else mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    )
    return Firmware(
        personality=personality,
        vehicle_class=vehicle_class,
        modes=modes,
        boot=boot,
        hold=hold,
        external=external or None,
        takeoff=takeoff or None,
        rtl=rtl or None,
        land=land or None,
        streams_on_boot=px4,
        boot_stream_hz=0 if px4 or vehicle_class == "copter" else 1,
        reject_result=(
            mavlink.MAV_RESULT_TEMPORARILY_REJECTED if px4 else mavlink.MAV_RESULT_FAILED
        ),
        set_mode_ack=mavlink.MAV_CMD_DO_SET_MODE if px4 else mavlink.MAVLINK_MSG_ID_SET_MODE,
        long_alt_relative=not px4,
        setpoints=setpoints,
        loss_changes_mode=px4,
        params=_params(personality, vehicle_class),
        version=_version(1, 14, 3) if px4 else _version(4, 5, 7),
        capabilities=_CAPS | byte_params,
    )
