"""What every autopilot strategy offers, and the arithmetic they share.

One :class:`Autopilot` object per vehicle (as skybrush-server's ``autopilots/``):
it knows how *its* firmware names modes, which set-up steps make it flyable,
how a :class:`~convoy_mav.types.Setpoint` becomes MAVLink, and how to make it
hold. It builds message objects and remembers what it sent; it never touches a
socket, a clock or asyncio (time comes in as ``t``, mission seconds), so the
unit tests drive it directly and the :class:`~convoy_mav.vehicle.Vehicle` only
executes what it decides.

Conventions (shared by PX4 and ArduCopter):
    * Setpoints go out as SET_POSITION_TARGET_GLOBAL_INT in MAV_FRAME_GLOBAL_INT,
      altitude AMSL = mission origin altitude - ``down``. Every vehicle's home (and
      local NED origin) differs and moves when it arms; latitude/longitude with
      AMSL altitude is the one frame all autopilots share with the mission.
    * Position + velocity + yaw (``SETPOINT_POS_VEL_YAW``: accelerations and yaw
      rate ignored). Yaw is absolute, so a dropped packet costs nothing; the
      velocity is the feed-forward along the arc.
    * Fixed-wing aircraft fly ``|v|`` as their airspeed and cannot otherwise make
      up a phase error along the path: :class:`PhaseLoop` scales the commanded
      speed by up to +-15 % to converge in phase, with integral action for the
      speed offset the airframe needs (see :func:`phase_corrected_speed`).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, ClassVar

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.autopilots.topspeed import TopSpeed
from convoy_mav.types import Setpoint

__all__ = [
    "DEFAULT_STREAM_RATES",
    "FLIGHT_STREAM_RATES",
    "PHASE_LIMIT",
    "SETPOINT_POSITION_ONLY",
    "SETPOINT_POS_VEL_YAW",
    "Autopilot",
    "CommandSpec",
    "Message",
    "PhaseLoop",
    "SetupStep",
    "SpeedParams",
    "VehicleClass",
    "along_track_error",
    "global_setpoint",
    "param_request_message",
    "param_set_message",
    "phase_corrected_speed",
    "set_message_interval",
    "vehicle_class",
]

Message = Any
"""A pymavlink ``MAVLink_message`` (the generated dialect is untyped)."""

_SPEED_LIMIT_TOL = 0.05
"""m/s: a plan this little outside an airframe's speed range is its rounding, not a
plan it cannot fly."""

PHASE_LIMIT = 0.15
"""The largest relative speed change a plane's phase loop commands (+-15 %)."""

_M = mavlink

SETPOINT_POS_VEL_YAW = (
    _M.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_AY_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_AZ_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
)
"""type_mask: position, velocity and yaw used; accelerations and yaw rate ignored."""

SETPOINT_POSITION_ONLY = (
    SETPOINT_POS_VEL_YAW
    | _M.POSITION_TARGET_TYPEMASK_VX_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_VY_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_VZ_IGNORE
    | _M.POSITION_TARGET_TYPEMASK_YAW_IGNORE
)
"""type_mask of a hold setpoint: go to (and stay at) a point."""

DEFAULT_STREAM_RATES: Mapping[int, float] = {
    _M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0,
    _M.MAVLINK_MSG_ID_ATTITUDE: 1.0,
    _M.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    _M.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    _M.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
}
"""Telemetry rates requested (Hz of mission time): position for the coverage
monitor and the phase correction (its ``hdg`` is the heading; ATTITUDE is only
the fallback), the rest for set-up and liveness."""

FLIGHT_STREAM_RATES: Mapping[int, float] = {
    **DEFAULT_STREAM_RATES,
    _M.MAVLINK_MSG_ID_ATTITUDE: 0.2,
    _M.MAVLINK_MSG_ID_SYS_STATUS: 0.2,
    _M.MAVLINK_MSG_ID_GPS_RAW_INT: 0.2,
    _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 0.2,
    _M.MAVLINK_MSG_ID_HOME_POSITION: 0.1,
}
"""Rates once a vehicle flies: position as before, what only set-up needed
(fix, landed state, home) slowed to a watch. Each UAV then sends about 11
messages a second instead of 16, which is the telemetry radio's budget and the
service's receive cost (a third less) for a big fleet."""

_COPTERS = frozenset(
    getattr(_M, name)
    for name in (
        "MAV_TYPE_QUADROTOR",
        "MAV_TYPE_COAXIAL",
        "MAV_TYPE_HELICOPTER",
        "MAV_TYPE_HEXAROTOR",
        "MAV_TYPE_OCTOROTOR",
        "MAV_TYPE_TRICOPTER",
        "MAV_TYPE_DODECAROTOR",
        "MAV_TYPE_DECAROTOR",
        "MAV_TYPE_GENERIC_MULTIROTOR",
    )
    if hasattr(_M, name)
)
_PLANES = frozenset(
    getattr(_M, name)
    for name in (
        "MAV_TYPE_FIXED_WING",
        "MAV_TYPE_VTOL_DUOROTOR",
        "MAV_TYPE_VTOL_QUADROTOR",
        "MAV_TYPE_VTOL_TILTROTOR",
        "MAV_TYPE_VTOL_RESERVED2",
        "MAV_TYPE_VTOL_RESERVED3",
        "MAV_TYPE_VTOL_RESERVED4",
        "MAV_TYPE_VTOL_RESERVED5",
    )
    if hasattr(_M, name)
)


class VehicleClass(StrEnum):
    """How a vehicle flies, from HEARTBEAT.type."""

    PLANE = "plane"  # flies |v| as airspeed, cannot stop: phase by speed, loiters
    COPTER = "copter"  # can hover and fly any speed up to its maximum
    OTHER = "other"  # rovers, boats, gimbals...: not flown by this service


def vehicle_class(mav_type: int) -> VehicleClass:
    """Plane, copter or other from a HEARTBEAT.type (VTOLs count as planes)."""
    if mav_type in _PLANES:
        return VehicleClass.PLANE
    if mav_type in _COPTERS:
        return VehicleClass.COPTER
    return VehicleClass.OTHER


class SetupStep(StrEnum):
    """One step of making a vehicle flyable; the Vehicle skips steps already true."""

    SETPOINTS = "stream setpoints"  # PX4: OFFBOARD needs a live stream before the switch
    TAKEOFF_MODE = "take-off mode"  # ArduPlane: its take-off parameters, then TAKEOFF mode
    MODE = "set mode"  # to the strategy's external (offboard/guided) mode
    ARM = "arm"
    TAKEOFF = "take off"  # climb to the flight altitude (NAV_TAKEOFF, or the mode's climb)
    CLIMB = "climb out"  # PX4 multicopter: armed in OFFBOARD, straight up on setpoints


@dataclass(frozen=True, slots=True)
class CommandSpec:
    """A MAV_CMD with its parameters, before it is addressed and numbered.

    Attributes:
        command: MAV_CMD id.
        params: param1..param7. For COMMAND_INT, params 5/6 are the integer x/y
            (degE7 in global frames) and param 7 is z.
        use_int: Send as COMMAND_INT (positional commands) rather than COMMAND_LONG.
        frame: MAV_FRAME of a COMMAND_INT.
    """

    command: int
    params: tuple[float, float, float, float, float, float, float]
    use_int: bool = False
    frame: int = _M.MAV_FRAME_GLOBAL_INT

    @classmethod
    def long(cls, command: int, *params: float) -> CommandSpec:
        """COMMAND_LONG with the given leading parameters (the rest 0)."""
        p = tuple(float(x) for x in params) + (0.0,) * (7 - len(params))
        return cls(command, p)  # type: ignore[arg-type]

    def message(self, target_system: int, target_component: int, confirmation: int = 0) -> Message:
        """The COMMAND_LONG / COMMAND_INT message (``confirmation`` counts retries)."""
        p = self.params
        if self.use_int:
            return _M.MAVLink_command_int_message(
                target_system, target_component, self.frame, self.command, 0, 0,
                p[0], p[1], p[2], p[3], int(p[4]), int(p[5]), p[6],
            )  # fmt: skip
        return _M.MAVLink_command_long_message(
            target_system, target_component, self.command, min(confirmation, 255), *p
        )


# ============================================================== shared arithmetic
def _wrap_pi(angle: float) -> float:
    a = math.remainder(angle, math.tau)
    return math.pi if a == -math.pi else a


def along_track_error(sp: Setpoint, north: float, east: float) -> float:
    """How far (m) the UAV at (north, east) trails its setpoint along the path.

    Positive: the setpoint is ahead, the UAV is behind and must speed up;
    negative: the UAV is ahead. On an arc (``sp.center`` and ``sp.radius``) the
    error is arc length at the setpoint's radius between the UAV's and the
    setpoint's bearings from the centre, in the arc's direction, so it stays
    meaningful half a lap away; on a straight it is the projection of the offset
    on the setpoint's velocity.
    """
    if sp.center is not None and sp.radius > 0.0:
        cn, ce = sp.center
        ahead = _wrap_pi(
            math.atan2(sp.east - ce, sp.north - cn) - math.atan2(east - ce, north - cn)
        )  # bearings grow clockwise (north -> east)
        return sp.radius * (ahead if sp.clockwise else -ahead)
    speed = math.hypot(sp.vn, sp.ve)
    if speed < 1e-6:
        return 0.0
    return ((sp.north - north) * sp.vn + (sp.east - east) * sp.ve) / speed


def phase_corrected_speed(
    sp: Setpoint,
    north: float,
    east: float,
    *,
    time_constant: float = 20.0,
    limit: float = PHASE_LIMIT,
    bias: float = 0.0,
) -> float:
    """Speed (m/s) to command a fixed-wing aircraft so it converges in phase.

    A plane flies its commanded speed as airspeed and steers only its course, so
    a UAV that is behind its slot (along the path) stays behind for ever. The
    commanded speed is ``V (1 + clamp(e / (V T), -limit, limit))`` with ``V`` the
    setpoint's speed and ``e`` :func:`along_track_error`: a proportional phase
    loop closing the gap with time constant ``T``, saturated at +-``limit`` so
    the aircraft stays near its planned airspeed (turn radius ~ V^2, and the
    plan's radii assume V).

    Args:
        sp: The setpoint (its velocity gives V and the path direction).
        north, east: Where the UAV is now (mission frame, m).
        time_constant: T, seconds.
        limit: Largest relative speed change (0.15 = +-15 %).
        bias: A relative speed change added before the clamp (``PhaseLoop``'s
            integral term).
    """
    v = math.hypot(sp.vn, sp.ve)
    if v < 1e-6:
        return 0.0
    ratio = along_track_error(sp, north, east) / (v * time_constant) + bias
    ratio = min(max(ratio, -limit), limit)
    return v * (1.0 + ratio)


class PhaseLoop:
    """:func:`phase_corrected_speed` with integral action, for one aircraft.

    A proportional loop alone holds a steady error wherever the aircraft needs a
    steady speed offset to stay on its slot: an ArduPlane that cuts inside at every
    switch between arcs flies less path than planned, needs about 4.5 % less speed,
    and with T = 20 s sat about 20 m ahead of its slot in SITL. The integral term
    learns that offset (``bias``, relative speed), so the error goes to zero:
    ``e'' + e'/T + e/(T_i) = 0`` for a constant offset, damped (zeta 0.5) at
    T = 20 s, T_i = 400 s. It integrates only while the command is not saturated
    the same way (no wind-up through a long join) and is kept between arcs and
    replans: the offset belongs to the airframe, not to one arc.

    Args:
        time_constant: T of the proportional part, seconds.
        integral_time: T_i, seconds.
        limit: Largest relative speed change, integral included.
    """

    __slots__ = ("_last_t", "bias", "integral_time", "limit", "time_constant")

    def __init__(
        self,
        time_constant: float = 20.0,
        integral_time: float = 400.0,
        limit: float = PHASE_LIMIT,
    ) -> None:
        self.time_constant = time_constant
        self.integral_time = integral_time
        self.limit = limit
        self.bias = 0.0
        self._last_t: float | None = None

    def speed(self, sp: Setpoint, north: float, east: float, t: float) -> float:
        """The speed to command now (m/s), the integral advanced to mission time ``t``."""
        v = math.hypot(sp.vn, sp.ve)
        if v < 1e-6:
            return 0.0
        error = along_track_error(sp, north, east)
        wanted = error / (v * self.time_constant) + self.bias
        dt = 0.0 if self._last_t is None else min(max(t - self._last_t, 0.0), 1.0)
        self._last_t = t
        if abs(wanted) < self.limit or (wanted > 0.0) != (error > 0.0):
            step = error / (v * self.integral_time) * dt
            self.bias = min(max(self.bias + step, -self.limit), self.limit)
        return phase_corrected_speed(
            sp, north, east, time_constant=self.time_constant, limit=self.limit, bias=self.bias
        )


def global_setpoint(
    sp: Setpoint,
    frame: LocalFrame,
    target_system: int,
    target_component: int,
    t: float,
    *,
    speed_scale: float = 1.0,
) -> Message:
    """SET_POSITION_TARGET_GLOBAL_INT for ``sp`` (MAV_FRAME_GLOBAL_INT, AMSL).

    A ``hold`` setpoint is position-only (the aircraft goes there and stays:
    a copter hovers, a plane circles); otherwise position, velocity (scaled by
    ``speed_scale`` horizontally, the phase correction) and yaw.
    """
    geo = frame.to_geo(sp.north, sp.east, sp.down)
    if sp.hold:
        mask, vn, ve, vd = SETPOINT_POSITION_ONLY, 0.0, 0.0, 0.0
    else:
        mask, vn, ve, vd = SETPOINT_POS_VEL_YAW, sp.vn * speed_scale, sp.ve * speed_scale, sp.vd
    return _M.MAVLink_set_position_target_global_int_message(
        int(t * 1000.0) & 0xFFFFFFFF, target_system, target_component,
        _M.MAV_FRAME_GLOBAL_INT, mask,
        round(geo.lat * 1e7), round(geo.lon * 1e7), geo.alt,
        vn, ve, vd, 0.0, 0.0, 0.0, _wrap_pi(sp.yaw), 0.0,
    )  # fmt: skip


def param_set_message(system: int, component: int, name: str, value: float) -> Message:
    """PARAM_SET of ``name`` to ``value`` for ``system``/``component`` (a float
    parameter; its PARAM_VALUE answers)."""
    return _M.MAVLink_param_set_message(
        system, component, name.encode(), value, _M.MAV_PARAM_TYPE_REAL32
    )


def param_request_message(system: int, component: int, name: str) -> Message:
    """PARAM_REQUEST_READ of ``name`` (by name: index -1); its PARAM_VALUE answers."""
    return _M.MAVLink_param_request_read_message(system, component, name.encode(), -1)


def set_message_interval(rate_hz: float, msg_id: int) -> CommandSpec:
    """MAV_CMD_SET_MESSAGE_INTERVAL for ``msg_id`` at ``rate_hz`` (<= 0: stop)."""
    interval = 1e6 / rate_hz if rate_hz > 0.0 else -1.0
    return CommandSpec.long(_M.MAV_CMD_SET_MESSAGE_INTERVAL, float(msg_id), interval)


@dataclass(frozen=True, slots=True)
class SpeedParams:
    """The parameters holding the speeds an airframe flies setpoints at.

    Attributes:
        high: The fastest (a copter's horizontal speed limit, a plane's maximum
            airspeed): faster setpoints are flown at it, behind their slot.
        low: The slowest (a plane's minimum airspeed); None for a copter, which
            slows down to a hover.
        unit: Metres a second per unit of the parameters (0.01: cm/s).
        older: What older firmware names them, ``(old name, name)`` pairs (ArduPlane
            before 4.5: ``ARSPD_FBW_MAX``); asked for too until one answers.
    """

    high: str
    low: str | None = None
    unit: float = 1.0
    older: tuple[tuple[str, str], ...] = ()

    def names_of(self, name: str) -> list[str]:
        """``name`` and what older firmware calls it."""
        return [name, *(old for old, new in self.older if new == name)]


# ======================================================================= strategy
class Autopilot(ABC):
    """The firmware strategy of one vehicle.

    Args:
        sysid: The vehicle's system id.
        compid: Its autopilot's component id (commands go there).
        frame: The mission frame (setpoints are converted through it).
        kind: Plane or copter, from HEARTBEAT.type.

    Class attributes:
        name: Firmware name for messages ("PX4", "ArduCopter"...).
        setup_steps: What makes it flyable, in order.
        streams_during_setup: Setpoints must flow while setting up (PX4 offboard).
        reports_target: It reports where it is going (POSITION_TARGET_GLOBAL_INT):
            how another controller driving it shows (:mod:`convoy_mav.contest`).

    Attributes:
        speed_params: Where the firmware keeps the speeds it flies setpoints at in
            the plan's modes (None: unknown); asked for at set-up.
        speed_limit: The fastest (m/s), once the autopilot has reported it.
        speed_floor: The slowest (m/s, planes), once reported.
        speed_names: The names under which the autopilot reported them.
        fastest_asked: The fastest horizontal speed the setpoints asked for (m/s).
        top_speed: A copter's top speed as seen in flight (:mod:`.topspeed`).
        lean_param: What bounds how far a copter leans, so how fast it flies (for
            the alarm's advice; None: unknown).
    """

    name: ClassVar[str] = "autopilot"
    setup_steps: tuple[SetupStep, ...] = ()
    streams_during_setup: ClassVar[bool] = False
    reports_target: ClassVar[bool] = False
    takeoff_mode: ClassVar[str | None] = None
    """The mode that climbs out by itself (ArduPlane TAKEOFF); None: a command does."""
    speed_params: SpeedParams | None = None
    lean_param: str | None = None
    commanded_as: ClassVar[str] = "as commanded"
    """What its speed commands mean, where :meth:`as_commanded` converts a true speed."""
    stream_loss_modes: ClassVar[frozenset[str]] = frozenset()
    """The modes it falls to, in a failsafe, when our setpoints stop (PX4's offboard loss);
    none where a lost stream changes no mode (ArduPilot's GUIDED flies on to the last)."""

    def __init__(self, sysid: int, compid: int, frame: LocalFrame, kind: VehicleClass) -> None:
        self.sysid = sysid
        self.compid = compid
        self.frame = frame
        self.kind = kind
        self.speed_limit: float | None = None
        self.speed_floor: float | None = None
        self.speed_names: dict[str, str] = {}
        self.fastest_asked = 0.0
        self.top_speed = TopSpeed() if kind is VehicleClass.COPTER else None

    def __str__(self) -> str:
        return f"{self.name} {self.kind}"

    # ------------------------------------------------------------------- modes
    @abstractmethod
    def mode_name(self, custom_mode: int) -> str:
        """Name of the mode a HEARTBEAT.custom_mode reports ("OFFBOARD", "GUIDED")."""

    @property
    @abstractmethod
    def external_mode(self) -> str:
        """The mode in which it flies our setpoints."""

    @property
    @abstractmethod
    def hold_mode(self) -> str:
        """The mode that loiters/hovers where it is."""

    @abstractmethod
    def mode_command(self, name: str) -> CommandSpec:
        """MAV_CMD_DO_SET_MODE switching to mode ``name``.

        Raises:
            KeyError: The firmware has no such mode.
        """

    def hold_command(self) -> CommandSpec:
        """The command that makes it hold where it is."""
        return self.mode_command(self.hold_mode)

    @staticmethod
    def arm_command(arm: bool = True) -> CommandSpec:
        """MAV_CMD_COMPONENT_ARM_DISARM."""
        return CommandSpec.long(_M.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0)

    def takeoff_command(self, relative_alt: float, amsl: float) -> CommandSpec | None:
        """MAV_CMD_NAV_TAKEOFF to ``relative_alt`` above home / ``amsl``; None if unused."""
        return None

    def takeoff_params(self, relative_alt: float) -> dict[str, float]:
        """Parameters to set before ``takeoff_mode`` (its climb altitude); none by default."""
        return {}

    @staticmethod
    def end_command(action: str) -> CommandSpec | None:
        """What ends a mission: ``"rtl"`` NAV_RETURN_TO_LAUNCH, ``"land"`` NAV_LAND
        where it is; ``"loiter"`` is the hold mode (None here)."""
        if action == "rtl":
            return CommandSpec.long(_M.MAV_CMD_NAV_RETURN_TO_LAUNCH)
        if action == "land":
            nan = math.nan  # (land here: the autopilot keeps its position and yaw)
            return CommandSpec.long(_M.MAV_CMD_NAV_LAND, 0, 0, 0, nan, nan, nan, 0)
        return None

    # --------------------------------------------------------------- telemetry
    def wanted_streams(self, rates: Mapping[int, float]) -> dict[int, float]:
        """Every message ``stream_requests(rates)`` asks for, at its rate (Hz)."""
        return dict(rates)

    def stream_requests(
        self, rates: Mapping[int, float], again: Collection[int] | None = None
    ) -> list[Message]:
        """Messages asking for ``rates`` (message id -> Hz of mission time); with
        ``again``, only those of its messages, once more, nothing else changed (a
        request lost on the link)."""
        return [
            set_message_interval(hz, msg_id).message(self.sysid, self.compid)
            for msg_id, hz in self.wanted_streams(rates).items()
            if again is None or msg_id in again
        ]

    # ---------------------------------------------------------------- setpoints
    @abstractmethod
    def setpoint_messages(
        self, sp: Setpoint, t: float, position: tuple[float, float] | None
    ) -> list[Message]:
        """What to send for setpoint ``sp`` at mission time ``t``.

        Args:
            sp: The setpoint (mission frame).
            t: Mission time now.
            position: The UAV's latest (north, east), None if unknown.
        """

    def on_ack(self, command: int, result: int, t: float) -> None:  # noqa: B027 - optional hook
        """A COMMAND_ACK arrived (strategies re-send refused stream-path commands)."""

    def on_target(self, lat_e7: int, lon_e7: int, t: float) -> None:  # noqa: B027 - optional hook
        """It reported its position target, as it stood at mission time ``t`` (a
        strategy whose commands stand until replaced checks its last one is in force)."""

    def reset(self) -> None:  # noqa: B027 - optional hook
        """Forget what was sent: everything is re-sent (after a re-set-up or reboot)."""

    def on_param(self, name: str, value: float) -> None:
        """A PARAM_VALUE arrived: keep the speed range's ends it reports."""
        p = self.speed_params
        if p is None:
            return
        current = dict(p.older).get(name, name)
        if current == p.high:
            if self.top_speed is not None and self.speed_limit != value * p.unit:
                self.top_speed.forget()  # (seen held back by the old limit, maybe)
            self.speed_limit = value * p.unit
        elif current == p.low:
            self.speed_floor = value * p.unit
        else:
            return
        self.speed_names[current] = name

    def unread_speed_params(self) -> list[str]:
        """The speed parameters to ask the autopilot for: those it has not reported
        (under any of their names)."""
        p = self.speed_params
        if p is None:
            return []
        names = p.names_of(p.high) if self.speed_limit is None else []
        if p.low is not None and self.speed_floor is None:
            names += p.names_of(p.low)
        return names

    def asked(self, sp: Setpoint) -> None:
        """A plan setpoint was sent: keep the fastest horizontal speed asked for."""
        speed = math.hypot(sp.vn, sp.ve)
        self.fastest_asked = max(self.fastest_asked, speed)

    def as_commanded(self, speed: float) -> float:
        """A true ``speed`` (m/s) as the autopilot's speed commands and parameters reckon
        it (``commanded_as``): the same, but for a plane's equivalent airspeed."""
        return speed

    def within_range(self, speed: float) -> float:
        """``speed`` (m/s) inside the range the autopilot reported, where it has: ArduPlane
        refuses a DO_CHANGE_SPEED outside AIRSPEED_MIN..MAX and keeps the speed in
        force, so the nearest it takes is sent instead (the airframe alarm says why)."""
        if self.speed_floor is not None and speed < self.speed_floor:
            speed = self.speed_floor
        if self.speed_limit is not None and speed > self.speed_limit:
            speed = self.speed_limit
        return speed

    def speed_range(self) -> str:
        """The speed range the autopilot reported, under the names it answered to (for
        the operator): e.g. ``10.0-30.0 m/s (AIRSPEED_MIN, AIRSPEED_MAX)``."""
        p = self.speed_params
        lo, hi = self.speed_floor, self.speed_limit
        if p is None or (lo is None and hi is None):
            return "no speed range reported"
        high = self.speed_names.get(p.high, p.high)
        low = self.speed_names.get(p.low, p.low) if p.low is not None else ""
        if lo is not None and hi is not None:
            return f"{lo:.1f}-{hi:.1f} m/s ({low}, {high})"
        if hi is not None:
            return f"up to {hi:.1f} m/s ({high})"
        return f"from {lo:.1f} m/s ({low})"

    def observe_flight(self, t: float, flown: float, asked: float, behind: float) -> bool:
        """A position update on its slot: ``flown`` and ``asked`` horizontal speeds
        (m/s), how far (m) it trails its setpoint. True when a copter's top speed was
        learnt or moved (:class:`.TopSpeed`)."""
        learner = self.top_speed
        return learner is not None and learner.observe(t, flown, asked, behind) is not None

    def learnt(self) -> dict[str, float]:
        """What the strategy has learnt of the airframe while flying (for the report)."""
        out = {}
        if self.speed_limit is not None:
            out["speed_limit_mps"] = round(self.speed_limit, 2)
        if self.speed_floor is not None:
            out["speed_floor_mps"] = round(self.speed_floor, 2)
        if (top := self.seen_top) is not None:
            out["top_speed_mps"] = round(top, 2)
        return out

    def speed_seen(self) -> tuple[float | None, float | None, float | None]:
        """The speeds known of the airframe (limit, floor, top seen): when they change,
        an alarm on them is looked at again."""
        return self.speed_limit, self.speed_floor, self.seen_top

    @property
    def seen_top(self) -> float | None:
        """A copter's top speed as seen in flight (m/s); None until seen, or a plane."""
        return None if self.top_speed is None else self.top_speed.top

    def cannot_fly(
        self, airspeed: float = 0.0, band: tuple[float, float] = (1.0, 1.0)
    ) -> str | None:
        """Why the plan asks for more than this airframe gives, if it does: speeds
        outside the range its autopilot reported, or above a copter's top speed seen.

        Args:
            airspeed: The plan's cruise airspeed (m/s).
            band: The fractions of it the plan's legs fly at (the road planner's
                0.85-1.15); a plane's phase loop adds +-``PHASE_LIMIT`` round it, and
                a copter needs that much over the plan's speed too, to catch up once
                behind its slot (SITL ArduCopters whose top speed was the plan's trailed
                it 70-110 m for good).
        """
        lo, hi = band[0], max(band[1], 1.0 + PHASE_LIMIT)
        if self.kind is VehicleClass.PLANE:
            lo = min(lo, 1.0 - PHASE_LIMIT)
        top, bottom = max(self.fastest_asked, hi * airspeed), lo * airspeed
        asks = f"the plan asks for up to {top:.1f} m/s"
        if band[1] < hi and top == hi * airspeed:  # (the margin, not the plan, sets it)
            asks += f" ({airspeed:.1f} and {100 * PHASE_LIMIT:.0f} % to catch up)"
        limit, floor = self.speed_limit, self.speed_floor
        seen = self.seen_top
        top_c, bottom_c = self.as_commanded(top), self.as_commanded(bottom)
        if abs(top_c - top) >= 0.05:
            asks += f" ({top_c:.1f} m/s {self.commanded_as})"
        if seen is not None and (limit is None or seen < limit) and top > seen + _SPEED_LIMIT_TOL:
            lean = f"let it lean further ({self.lean_param}) or " if self.lean_param else ""
            return (
                f"flies no faster than {seen:.1f} m/s (seen in flight, behind its slot), "
                f"{asks}: {lean}scale airspeed_mps by {seen / top:.2f}"
            )
        p = self.speed_params
        if p is None:
            return None
        if limit is not None and top_c > limit + _SPEED_LIMIT_TOL:
            high = self.speed_names.get(p.high, p.high)
            return (
                f"flies no faster than {limit:.1f} m/s ({high}), {asks}: set {high} to at "
                f"least {math.ceil(top_c / p.unit - 1e-9)} or scale airspeed_mps by "
                f"{limit / top_c:.2f}"
            )
        if p.low is not None and floor is not None and 0.0 < bottom_c < floor - _SPEED_LIMIT_TOL:
            low = self.speed_names.get(p.low, p.low)
            down = f"{bottom:.1f} m/s"
            if abs(bottom_c - bottom) >= 0.05:
                down += f" ({bottom_c:.1f} m/s {self.commanded_as})"
            return (
                f"flies no slower than {floor:.1f} m/s ({low}), the plan asks for down to "
                f"{down}: set {low} to at most {math.floor(bottom_c / p.unit + 1e-9)} "
                f"or scale airspeed_mps by {floor / bottom_c:.2f}"
            )
        return None
