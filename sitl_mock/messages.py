"""MAVLink messages <-> mock values: setpoint decoding and telemetry building.

Two directions, both pure:

* Inbound, ``decode_local_setpoint`` / ``decode_global_setpoint`` turn a
  SET_POSITION_TARGET_* message into a ``kinematics.TrackTarget`` in the mock's
  *world* NED frame, honouring ``type_mask`` ignore bits and the coordinate frame
  the way PX4's ``mavlink_receiver`` reads them. A vehicle's own local frame is
  NED at its EKF origin (where it booted), not at the world origin, so
  positions cross between the two through latitude/longitude (``Frames``).
* Outbound, ``build_telemetry`` turns one ``Snapshot`` of the vehicle into any
  streamed message; the snapshot is taken once per tick, so every message of a
  tick reports the same instant.

Units on the wire follow common.xml exactly (degE7, mm, cm/s, cdeg); values
are clamped to their field's range so a wild state can never make ``pack`` fail.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock.kinematics import TrackTarget

__all__ = [
    "TELEMETRY_BUILDERS",
    "Command",
    "Frames",
    "Snapshot",
    "autopilot_version",
    "build_telemetry",
    "decode_global_setpoint",
    "decode_local_setpoint",
    "statustext",
    "wrap_pi",
]

_UINT16_MAX = 0xFFFF
_INT16_MAX = 0x7FFF

# type_mask ignore bits
_X, _Y, _Z = 1, 2, 4
_VX, _VY, _VZ = 8, 16, 32
_YAW, _YAW_RATE = 1024, 2048

_GLOBAL_AMSL = (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT)
_GLOBAL_RELATIVE = (
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    # Terrain following is not modelled: the ground is flat at home altitude.
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
)


def wrap_pi(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    a = math.remainder(angle, math.tau)
    return math.pi if a == -math.pi else a


@dataclass(frozen=True, slots=True)
class Frames:
    """The world frame and a vehicle's own local frame (NED at its EKF origin)."""

    world: LocalFrame
    local: LocalFrame

    def local_to_world(self, n: float, e: float, d: float) -> tuple[float, float, float]:
        """Vehicle-local NED to world NED."""
        return self.world.to_ned(self.local.to_geo(n, e, d))

    def world_to_local(self, n: float, e: float, d: float) -> tuple[float, float, float]:
        """World NED to vehicle-local NED."""
        return self.local.to_ned(self.world.to_geo(n, e, d))

    def down_of(self, amsl: float) -> float:
        """World ``down`` of an altitude above mean sea level."""
        return self.world.origin.alt - amsl


def _given(mask: int, bit: int, value: float) -> bool:
    return not mask & bit and math.isfinite(value)


def _yaw_fields(mask: int, yaw: float, yaw_rate: float) -> tuple[float | None, float | None]:
    y = wrap_pi(yaw) if _given(mask, _YAW, yaw) else None
    r = yaw_rate if _given(mask, _YAW_RATE, yaw_rate) else None
    return y, r


def decode_local_setpoint(
    msg: mavlink.MAVLink_set_position_target_local_ned_message,
    frames: Frames,
    position: tuple[float, float, float],
    yaw: float,
) -> TrackTarget | None:
    """SET_POSITION_TARGET_LOCAL_NED -> world-frame target; None for unsupported frames.

    Frames, as in common.xml and PX4: LOCAL_NED (positions from the EKF origin),
    LOCAL_OFFSET_NED (positions added to the current one, NED velocities),
    BODY_NED (positions as LOCAL_NED, velocities in the heading frame) and
    BODY_OFFSET_NED (both relative to the vehicle and rotated by its heading).
    A horizontal position or velocity counts only when both components do.

    Args:
        msg: The decoded message.
        frames: World and vehicle-local frames.
        position: The vehicle's current world (north, east, down).
        yaw: The vehicle's current heading (rad), for the body frames.
    """
    frame = msg.coordinate_frame
    mask = msg.type_mask
    has_xy = _given(mask, _X, msg.x) and _given(mask, _Y, msg.y)
    has_z = _given(mask, _Z, msg.z)
    has_vxy = _given(mask, _VX, msg.vx) and _given(mask, _VY, msg.vy)
    c, s = math.cos(yaw), math.sin(yaw)
    north = east = down = None
    if frame in (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_NED):
        # Local positions convert as a point; a missing axis comes from the vehicle.
        cur_local = frames.world_to_local(*position)
        lx = msg.x if has_xy else cur_local[0]
        ly = msg.y if has_xy else cur_local[1]
        lz = msg.z if has_z else cur_local[2]
        wn, we, wd = frames.local_to_world(lx, ly, lz)
        north, east = (wn, we) if has_xy else (None, None)
        down = wd if has_z else None
    elif frame in (mavlink.MAV_FRAME_LOCAL_OFFSET_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED):
        dx, dy = msg.x, msg.y
        if frame == mavlink.MAV_FRAME_BODY_OFFSET_NED:
            dx, dy = c * msg.x - s * msg.y, s * msg.x + c * msg.y
        if has_xy:
            north, east = position[0] + dx, position[1] + dy
        down = position[2] + msg.z if has_z else None
    else:
        return None
    vn = ve = None
    if has_vxy:
        vn, ve = msg.vx, msg.vy
        if frame in (mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED):
            vn, ve = c * msg.vx - s * msg.vy, s * msg.vx + c * msg.vy
    vd = msg.vz if _given(mask, _VZ, msg.vz) else None
    y, r = _yaw_fields(mask, msg.yaw, msg.yaw_rate)
    return TrackTarget(north, east, down, vn, ve, vd, y, r)


def decode_global_setpoint(
    msg: mavlink.MAVLink_set_position_target_global_int_message,
    frames: Frames,
    home_alt: float,
) -> TrackTarget | None:
    """SET_POSITION_TARGET_GLOBAL_INT -> world-frame target; None for unsupported frames.

    GLOBAL(_INT) altitudes are AMSL; RELATIVE_ALT and TERRAIN_ALT ones are taken
    relative to the vehicle's home altitude (the mock's ground is flat).
    """
    frame = msg.coordinate_frame
    mask = msg.type_mask
    if frame in _GLOBAL_AMSL:
        base = 0.0
    elif frame in _GLOBAL_RELATIVE:
        base = home_alt
    else:
        return None
    north = east = down = None
    if not mask & _X and not mask & _Y:
        north, east, _ = frames.world.to_ned(GeoPoint(msg.lat_int * 1e-7, msg.lon_int * 1e-7))
    if _given(mask, _Z, msg.alt):
        down = frames.down_of(base + msg.alt)
    vn = ve = None
    if _given(mask, _VX, msg.vx) and _given(mask, _VY, msg.vy):
        vn, ve = msg.vx, msg.vy
    vd = msg.vz if _given(mask, _VZ, msg.vz) else None
    y, r = _yaw_fields(mask, msg.yaw, msg.yaw_rate)
    return TrackTarget(north, east, down, vn, ve, vd, y, r)


# ========================================================================= commands
_INT32_MAX = 0x7FFFFFFF


@dataclass(frozen=True, slots=True)
class Command:
    """A COMMAND_LONG or COMMAND_INT, normalised so one handler serves both.

    Attributes:
        command: MAV_CMD id.
        p1: param1 .. p4: param4 as sent.
        lat: Latitude (deg) of a positional command, NaN when not given.
        lon: Longitude (deg), NaN when not given.
        alt: Altitude (m; param7 / z), NaN when not given.
        alt_relative: ``alt`` is above home rather than AMSL.
        is_int: Came as COMMAND_INT.
        src_system: Sender's system id (the ACK goes back to it).
        src_component: Sender's component id.
    """

    command: int
    p1: float
    p2: float
    p3: float
    p4: float
    lat: float
    lon: float
    alt: float
    alt_relative: bool
    is_int: bool
    src_system: int
    src_component: int

    @classmethod
    def from_long(cls, msg: mavlink.MAVLink_command_long_message, alt_relative: bool) -> Command:
        """COMMAND_LONG: param5/6 are degrees (PX4 also accepts degE7), param7 metres."""
        lat, lon = msg.param5, msg.param6
        if math.isfinite(lat) and abs(lat) > 1000.0:
            lat *= 1e-7
        if math.isfinite(lon) and abs(lon) > 1000.0:
            lon *= 1e-7
        return cls(
            msg.command, msg.param1, msg.param2, msg.param3, msg.param4,
            lat, lon, msg.param7, alt_relative, False,
            msg.get_srcSystem(), msg.get_srcComponent(),
        )  # fmt: skip

    @classmethod
    def from_int(cls, msg: mavlink.MAVLink_command_int_message) -> Command:
        """COMMAND_INT: x/y are degE7 in global frames, z metres in the frame's datum."""
        frame = msg.frame
        lat = lon = math.nan
        is_global = frame in _GLOBAL_AMSL or frame in _GLOBAL_RELATIVE
        if is_global and _INT32_MAX not in (msg.x, msg.y):
            lat, lon = msg.x * 1e-7, msg.y * 1e-7
        return cls(
            msg.command, msg.param1, msg.param2, msg.param3, msg.param4,
            lat, lon, msg.z, frame in _GLOBAL_RELATIVE, True,
            msg.get_srcSystem(), msg.get_srcComponent(),
        )  # fmt: skip


# ======================================================================== telemetry
@dataclass(frozen=True, slots=True)
class Snapshot:
    """Everything telemetry reports about a vehicle at one instant (SI units).

    Positions are geodetic (``lat``/``lon`` degrees, ``alt`` m AMSL) and in the
    vehicle's local frame (``x``/``y``/``z`` from its EKF origin); velocities are
    ground velocities NED; angles in radians.
    """

    time_boot_ms: int
    unix_usec: int
    lat: float
    lon: float
    alt: float
    relative_alt: float
    x: float
    y: float
    z: float
    vn: float
    ve: float
    vd: float
    roll: float
    pitch: float
    yaw: float
    yaw_rate: float
    airspeed: float
    throttle: int
    home: GeoPoint
    home_local: tuple[float, float, float]
    home_set: bool
    mav_type: int
    autopilot: int
    base_mode: int
    custom_mode: int
    system_status: int
    sensors_present: int
    sensors_health: int
    gps_fix: int
    satellites: int
    battery_remaining: int
    battery_voltage: float
    battery_current: float
    battery_consumed_mah: float
    landed_state: int
    target: GeoPoint | None = None  # the position target the firmware reports, if any
    mission_seq: int = 0  # a rover's mission: the item it drives to ...
    mission_total: int = 0  # ... of this many (0: no mission, no MISSION_CURRENT)

    @property
    def groundspeed(self) -> float:
        """Horizontal ground speed (m/s)."""
        return math.hypot(self.vn, self.ve)


def _clamp_int(value: float, lo: int, hi: int) -> int:
    if not math.isfinite(value):
        return hi
    return max(lo, min(hi, round(value)))


def _cdeg(angle: float) -> int:
    """Heading (rad) to centidegrees in [0, 36000)."""
    return round(math.degrees(angle) * 100.0) % 36000


def _deg_e7(deg: float) -> int:
    return round(deg * 1e7)


def _heartbeat(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_heartbeat_message(
        s.mav_type, s.autopilot, s.base_mode, s.custom_mode, s.system_status, 3
    )


def _sys_status(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_sys_status_message(
        onboard_control_sensors_present=s.sensors_present,
        onboard_control_sensors_enabled=s.sensors_present,
        onboard_control_sensors_health=s.sensors_health,
        load=150,
        voltage_battery=_clamp_int(s.battery_voltage * 1000.0, 0, _UINT16_MAX - 1),
        current_battery=_clamp_int(s.battery_current * 100.0, -1, _INT16_MAX),
        battery_remaining=s.battery_remaining,
        drop_rate_comm=0,
        errors_comm=0,
        errors_count1=0,
        errors_count2=0,
        errors_count3=0,
        errors_count4=0,
    )


def _gps_raw_int(s: Snapshot) -> mavlink.MAVLink_message:
    fixed = s.gps_fix >= mavlink.GPS_FIX_TYPE_3D_FIX
    return mavlink.MAVLink_gps_raw_int_message(
        time_usec=s.time_boot_ms * 1000,
        fix_type=s.gps_fix,
        lat=_deg_e7(s.lat) if fixed else 0,
        lon=_deg_e7(s.lon) if fixed else 0,
        alt=round(s.alt * 1000.0) if fixed else 0,
        eph=80 if fixed else _UINT16_MAX,
        epv=120 if fixed else _UINT16_MAX,
        vel=_clamp_int(s.groundspeed * 100.0, 0, _UINT16_MAX - 1) if fixed else _UINT16_MAX,
        cog=_cdeg(math.atan2(s.ve, s.vn)) if fixed and s.groundspeed > 0.1 else _UINT16_MAX,
        satellites_visible=s.satellites,
        alt_ellipsoid=round(s.alt * 1000.0) if fixed else 0,
        h_acc=500 if fixed else 0,
        v_acc=800 if fixed else 0,
        vel_acc=100 if fixed else 0,
        hdg_acc=0,
        yaw=0,
    )


def _global_position_int(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_global_position_int_message(
        time_boot_ms=s.time_boot_ms,
        lat=_deg_e7(s.lat),
        lon=_deg_e7(s.lon),
        alt=round(s.alt * 1000.0),
        relative_alt=round(s.relative_alt * 1000.0),
        vx=_clamp_int(s.vn * 100.0, -_INT16_MAX, _INT16_MAX),
        vy=_clamp_int(s.ve * 100.0, -_INT16_MAX, _INT16_MAX),
        vz=_clamp_int(s.vd * 100.0, -_INT16_MAX, _INT16_MAX),
        hdg=_cdeg(s.yaw),
    )


def _local_position_ned(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_local_position_ned_message(
        s.time_boot_ms, s.x, s.y, s.z, s.vn, s.ve, s.vd
    )


def _attitude(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_attitude_message(
        s.time_boot_ms, s.roll, s.pitch, s.yaw, 0.0, 0.0, s.yaw_rate
    )


def _vfr_hud(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_vfr_hud_message(
        airspeed=s.airspeed,
        groundspeed=s.groundspeed,
        heading=round(math.degrees(s.yaw)) % 360,
        throttle=s.throttle,
        alt=s.alt,
        climb=-s.vd,
    )


def _extended_sys_state(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_extended_sys_state_message(
        mavlink.MAV_VTOL_STATE_UNDEFINED, s.landed_state
    )


def _system_time(s: Snapshot) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_system_time_message(s.unix_usec, s.time_boot_ms)


def _timesync(s: Snapshot) -> mavlink.MAVLink_message:
    """A request of the autopilot's own (``tc1`` 0, ``ts1`` its time in ns): PX4's
    onboard profile streams them at 10 Hz (``mavlink_main.cpp``)."""
    return mavlink.MAVLink_timesync_message(0, s.time_boot_ms * 1_000_000)


def _battery_status(s: Snapshot) -> mavlink.MAVLink_message:
    cell = _clamp_int(s.battery_voltage * 1000.0 / 4.0, 0, _UINT16_MAX - 1)
    return mavlink.MAVLink_battery_status_message(
        id=0,
        battery_function=mavlink.MAV_BATTERY_FUNCTION_ALL,
        type=mavlink.MAV_BATTERY_TYPE_LIPO,
        temperature=_INT16_MAX,
        voltages=[cell] * 4 + [_UINT16_MAX] * 6,
        current_battery=_clamp_int(s.battery_current * 100.0, -1, _INT16_MAX),
        current_consumed=_clamp_int(s.battery_consumed_mah, 0, 2**31 - 1),
        energy_consumed=-1,
        battery_remaining=s.battery_remaining,
        time_remaining=0,
        charge_state=mavlink.MAV_BATTERY_CHARGE_STATE_OK,
        voltages_ext=[0, 0, 0, 0],
        mode=0,
        fault_bitmask=0,
    )


def _home_position(s: Snapshot) -> mavlink.MAVLink_message | None:
    if not s.home_set:
        return None
    x, y, z = s.home_local
    return mavlink.MAVLink_home_position_message(
        latitude=_deg_e7(s.home.lat),
        longitude=_deg_e7(s.home.lon),
        altitude=round(s.home.alt * 1000.0),
        x=x,
        y=y,
        z=z,
        q=[1.0, 0.0, 0.0, 0.0],
        approach_x=0.0,
        approach_y=0.0,
        approach_z=0.0,
        time_usec=s.time_boot_ms * 1000,
    )


_TARGET_XYZ_ONLY = 0xFFF8
"""POSITION_TARGET_GLOBAL_INT.type_mask ArduPilot reports: only x, y, z (its
``POSITION_TARGET_TYPEMASK_LAST_BYTE`` set too)."""


def _position_target_global_int(s: Snapshot) -> mavlink.MAVLink_message | None:
    """ArduPilot's report of where it is going (ArduPlane ``next_WP_loc``, ArduCopter
    guided ``get_wp``), AMSL in MAV_FRAME_GLOBAL; nothing when it has no such target."""
    t = s.target
    if t is None:
        return None
    return mavlink.MAVLink_position_target_global_int_message(
        s.time_boot_ms, mavlink.MAV_FRAME_GLOBAL, _TARGET_XYZ_ONLY,
        round(t.lat * 1e7), round(t.lon * 1e7), t.alt, 0, 0, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip


def _mission_current(s: Snapshot) -> mavlink.MAVLink_message | None:
    """A rover's progress along its mission (nothing when it holds none)."""
    if s.mission_total == 0:
        return None
    return mavlink.MAVLink_mission_current_message(
        s.mission_seq, s.mission_total, mavlink.MISSION_STATE_ACTIVE, 0
    )


TELEMETRY_BUILDERS: dict[int, Callable[[Snapshot], mavlink.MAVLink_message | None]] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: _heartbeat,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: _sys_status,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: _gps_raw_int,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: _global_position_int,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: _local_position_ned,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: _attitude,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: _vfr_hud,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: _extended_sys_state,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: _system_time,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: _battery_status,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: _home_position,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: _position_target_global_int,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: _mission_current,
    mavlink.MAVLINK_MSG_ID_TIMESYNC: _timesync,
}
"""Message id -> builder; a builder returns None when it has nothing to say yet
(HOME_POSITION before home is set)."""


def build_telemetry(msg_id: int, snapshot: Snapshot) -> mavlink.MAVLink_message | None:
    """The telemetry message ``msg_id`` describing ``snapshot`` (None if not available).

    Raises:
        KeyError: The mock does not produce ``msg_id``.
    """
    return TELEMETRY_BUILDERS[msg_id](snapshot)


def statustext(severity: int, text: str) -> mavlink.MAVLink_statustext_message:
    """A single-chunk STATUSTEXT (at most 50 characters, as the field holds)."""
    return mavlink.MAVLink_statustext_message(severity, text[:50].encode("ascii", "replace"), 0, 0)


def autopilot_version(
    capabilities: int, version: int, sysid: int
) -> mavlink.MAVLink_autopilot_version_message:
    """AUTOPILOT_VERSION of a mock vehicle; the uid is derived from the sysid."""
    return mavlink.MAVLink_autopilot_version_message(
        capabilities=capabilities,
        flight_sw_version=version,
        middleware_sw_version=0,
        os_sw_version=0,
        board_version=0,
        flight_custom_version=[0] * 8,
        middleware_custom_version=[0] * 8,
        os_custom_version=[0] * 8,
        vendor_id=0,
        product_id=0,
        uid=0x4D4F434B00000000 | sysid,  # "MOCK" + sysid: stable and unique per vehicle
        uid2=[0] * 18,
    )
