"""One simulated autopilot: a sans-I/O MAVLink endpoint around the flight physics.

``SimVehicle`` takes decoded MAVLink messages and sim time in and gives MAVLink
message objects out; it never touches a socket or a clock, so the UDP server,
the unit tests and a replay all drive it the same way (h11 style)::

    replies = vehicle.handle(msg, now)        # COMMAND_ACK, PARAM_VALUE, TIMESYNC, ...
    events = vehicle.step(now, dt)            # physics + failsafes; STATUSTEXT events
    telemetry = vehicle.due_telemetry(now)    # the periodic streams due at ``now``
    row = vehicle.truth(now)                  # what really happened, for the truth log

The server packs the returned objects with one ``MAVLink(None, sysid, compid)``
per vehicle. ``time_boot_ms`` counts sim time since the last (re)boot.

Design rules:
    * Incoming messages go through a dict of ``_on_<type>`` handlers, commands
      (COMMAND_LONG and COMMAND_INT alike, see ``messages.Command``) through a
      dict of command handlers; every command gets a COMMAND_ACK (UNSUPPORTED for
      unknown ones). A failing handler is counted (``handler_error``) and the
      vehicle lives on; foreign targets and unknown types are counted too.
    * The flight itself (arming, modes, guidance, failsafes) is
      ``flight.FlightController``; what differs between PX4 and ArduPilot is
      ``personality.Firmware``; stream timing is ``streams.StreamScheduler``;
      parameter names are ``params.ParamTable``. This module wires them to MAVLink.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.rally import ROVER_RALLY_DEFAULTS, rtl_destination
from sitl_mock.clock import Speedup
from sitl_mock.driveclock import DEFAULT_ACCEL
from sitl_mock.flight import FlightController, Outcome
from sitl_mock.ground import Lagged, Polyline, Route, Stationary, StraightLine
from sitl_mock.kinematics import Aircraft, AircraftState, AirframeParams
from sitl_mock.messages import (
    TELEMETRY_BUILDERS,
    Command,
    Frames,
    Snapshot,
    autopilot_version,
    statustext,
)
from sitl_mock.mission import RoverMission, as_float_item
from sitl_mock.params import Knob, ParamTable
from sitl_mock.personality import Behaviour, Firmware, FlightMode, Personality, firmware_for
from sitl_mock.roverdrive import RoverDrive
from sitl_mock.rtl import Return, road_home
from sitl_mock.smartrtl import SmartPath
from sitl_mock.streams import AIRCRAFT_DEFAULT_INTERVALS, GROUND_DEFAULT_INTERVALS, StreamScheduler
from sitl_mock.trail import Follower, Trail
from sitl_mock.uploaded import DEFAULT_WP_SPEED, UploadedMission, upload_result

__all__ = ["SENSORS", "Personality", "SimVehicle", "TruthRow", "VehicleSpec"]

Message = Any  # a pymavlink MAVLink_message (the dialect is untyped)

_R = mavlink
_G = 9.80665
_UNIX_AT_SIM_ZERO_US = 1_704_067_200_000_000  # SYSTEM_TIME: sim t=0 is 2024-01-01T00:00Z
_BATTERY_ENDURANCE_S = 1800.0  # s of armed time from full to empty
_DEFAULT_AIRFRAME = AirframeParams()
_AIRFRAME_KNOBS = (
    Knob.AIRSPEED,
    Knob.AIRSPEED_MIN,
    Knob.AIRSPEED_MAX,
    Knob.TURN_RADIUS,
    Knob.CLIMB_RATE,
)
"""Knobs of the airframe's physics: setting one rebuilds the aircraft around its state."""

SENSORS = (  # SYS_STATUS sensors a healthy mock reports present and healthy
    _R.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | _R.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | _R.MAV_SYS_STATUS_SENSOR_3D_MAG
    | _R.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | _R.MAV_SYS_STATUS_SENSOR_GPS
    | _R.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | _R.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | _R.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | _R.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    | _R.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | _R.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | _R.MAV_SYS_STATUS_SENSOR_BATTERY
    | _R.MAV_SYS_STATUS_PREARM_CHECK
)
"""SYS_STATUS sensors: with GPS and PREARM_CHECK healthy MAVSDK reports the global
position OK and the vehicle armable; both turn healthy at the end of warm-up."""
_ROVER_SPEED_MIN = 0.05  # m/s: the least a rover is told (ArduRover's AR_WPNAV_SPEED_MIN)
_RTL_SPEED_MAX = 100.0  # m/s: ArduRover's RTL_SPEED range
_SRTL_ACCURACY_MAX = 10.0  # m: SRTL_ACCURACY's range
_SMART_RTL = "SMART_RTL"  # ArduRover's mode home back along its path (``smartrtl``)
_CRASH_CHECK_S = 2.0  # s standing with its throttle up: crashed (CRASH_CHECK_TRIGGER_SEC)
_FS_CRASH_HOLD_AND_DISARM = 2  # FS_CRASH_CHECK: 0 off, 1 HOLD, 2 HOLD and disarm
_TRAIL_DT = 0.1  # s between samples of a ground vehicle's path, and its followers' steps
_ONLY_GCS = 1  # MAV_OPTIONS bit 0: hear only MAV_GCS_SYSID (and its own system)
_RADIO = ("RADIO", "RADIO_STATUS")  # (heard from any system: a telemetry radio's)
_GPS_FIX_SHARE = 0.5
"""Share of the warm-up after which GPS_RAW_INT reports a 3D fix (the estimator needs
the rest: real ArduPilot SITL refuses arming for about 40 s after its first fix)."""
_NEEDS_WARMUP = (
    _R.MAV_SYS_STATUS_SENSOR_GPS
    | _R.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | _R.MAV_SYS_STATUS_PREARM_CHECK
)


@dataclass(frozen=True, slots=True, kw_only=True)
class VehicleSpec:
    """What one simulated vehicle is (keyword-only: ``home`` has no default).

    Attributes:
        sysid: MAVLink system id, 1..255.
        kind: ``"aircraft"`` (flies) or ``"ground"`` (follows ``route``).
        personality: Firmware imitated.
        airframe: Physics of an aircraft (its ``frame`` picks plane or copter).
        home: Where it boots: its EKF origin (LOCAL_POSITION_NED) and first home.
        route: Ground vehicles: world-NED motion over sim time (None: parked at home).
        warmup_s: Sim seconds after boot before the position estimate is healthy and
            arming allowed (GPS_RAW_INT reports its 3D fix from half of it).
        setpoint_timeout_s: Setpoint-loss timeout (COM_OF_LOSS_T / GUID_TIMEOUT).
        compid: MAVLink component id of the autopilot.
        streams_on_boot: Stream telemetry before a GCS asks; None: the personality's
            habit (PX4 yes, ArduPilot no: HEARTBEAT only until requested).
        signing_key: MAVLink 2 signing key (32 bytes): it signs what it sends and
            accepts only signed frames (None: unsigned until a SETUP_SIGNING).
        mission: Ground vehicles: serve the route's road as the mission it drives
            (``sitl_mock.mission``), readable over the mission protocol.
        follows: Ground vehicles: the system id of the vehicle it drives behind, on the
            path that one drove (``sitl_mock.trail``), ``lag_s`` behind it and never
            nearer than ``standstill_m``; None: its own ``route``.

    Raises:
        ValueError: A field is out of range; the message names it.
    """

    sysid: int
    kind: Literal["aircraft", "ground"]
    personality: Personality = Personality.PX4
    airframe: AirframeParams = _DEFAULT_AIRFRAME
    home: GeoPoint
    route: Route | None = None
    warmup_s: float = 3.0
    setpoint_timeout_s: float = 1.0
    compid: int = 1
    streams_on_boot: bool | None = None
    signing_key: bytes | None = None
    mission: bool = False
    follows: int | None = None
    lag_s: float = 0.0
    standstill_m: float = 0.0

    def __post_init__(self) -> None:
        if not 1 <= self.sysid <= 255:
            raise ValueError(f"sysid must be in 1..255, got {self.sysid!r}")
        if self.signing_key is not None and len(self.signing_key) != 32:
            raise ValueError(f"signing_key must be 32 bytes, got {len(self.signing_key)}")
        if not 1 <= self.compid <= 255:
            raise ValueError(f"compid must be in 1..255, got {self.compid!r}")
        if self.kind not in ("aircraft", "ground"):
            raise ValueError(f"kind must be 'aircraft' or 'ground', got {self.kind!r}")
        if self.kind == "aircraft" and (self.route is not None or self.mission):
            raise ValueError(
                f"route, mission: sysid {self.sysid} is an aircraft; only ground vehicles"
            )
        if self.follows is not None and (
            self.kind != "ground"
            or not (math.isfinite(self.lag_s) and self.lag_s > 0.0)
            or not (math.isfinite(self.standstill_m) and self.standstill_m >= 0.0)
        ):
            raise ValueError(
                f"follows: sysid {self.sysid} must be a ground vehicle with lag_s > 0 "
                "and standstill_m >= 0"
            )
        if not (math.isfinite(self.warmup_s) and self.warmup_s >= 0.0):
            raise ValueError(f"warmup_s must be finite and >= 0, got {self.warmup_s!r}")
        if not (math.isfinite(self.setpoint_timeout_s) and self.setpoint_timeout_s > 0.0):
            raise ValueError(f"setpoint_timeout_s must be > 0, got {self.setpoint_timeout_s!r}")


@dataclass(frozen=True, slots=True)
class TruthRow:
    """What a vehicle really did at sim time ``t`` (world NED, SI units, yaw in rad).

    ``speed`` is the airspeed of an aircraft and the ground speed of a ground vehicle;
    ``airborne`` is whether an aircraft is off the ground (a ground vehicle: False).
    """

    t: float
    sysid: int
    kind: str
    lat: float
    lon: float
    alt: float
    north: float
    east: float
    down: float
    vn: float
    ve: float
    vd: float
    yaw: float
    speed: float
    yaw_rate: float
    armed: bool
    mode: str
    airborne: bool = False


class SimVehicle:
    """The autopilot of one simulated vehicle (see the module docstring).

    Args:
        spec: What the vehicle is.
        world: The mock's world frame (all physics is in its NED).
        now: Sim time of boot.
        speedup: The clock ``SIM_SPEEDUP`` reads and sets (the mock's, shared by its
            vehicles); None: it reads 1 and cannot be set.

    Attributes:
        spec: As given.
        sysid: ``spec.sysid``.
        compid: ``spec.compid``.
        firmware: The personality strategy in use.
        flight: The flight state machine (armed, mode, guidance).
        counters: Events worth counting: ``foreign_sysid``, ``foreign_compid``,
            ``unknown_message``, ``unknown_command``, ``handler_error``,
            ``setpoint``, ``setpoint_ignored``, ``setpoint_failsafe``, ``reboot``...
        last_error: The exception of the last failing handler, for debugging.
    """

    def __init__(
        self, spec: VehicleSpec, world: LocalFrame, now: float, speedup: Speedup | None = None
    ) -> None:
        self.spec = spec
        self._speedup = speedup
        self.sysid = spec.sysid
        self.compid = spec.compid
        self.world = world
        ground = spec.kind == "ground"
        self.firmware: Firmware = firmware_for(
            spec.personality, "rover" if ground else spec.airframe.frame
        )
        self.counters: Counter[str] = Counter()
        self.last_error: Exception | None = None
        self._frames = Frames(world, LocalFrame(spec.home))
        self._params = ParamTable(self.firmware.params)
        self._ground_down = world.to_ned(spec.home)[2]
        self._warmup = spec.warmup_s
        self._nav_speed: float | None = None  # (as set; None: the airframe's airspeed)
        self._battery_s = 0.0
        self._ground_yaw = 0.0
        # A rover drives its route in AUTO only, armed; told to stand, it brakes and waits.
        # Told a speed (DO_CHANGE_SPEED), it drives the route retimed (``RoverDrive``).
        self._ground = RoverDrive(spec.route) if spec.route is not None else None
        # In RTL it drives home; back in AUTO it resumes the mission it left (``rtl``).
        self._returning: Return | None = None
        self._rtl_speed = 0.0  # (ArduRover's RTL_SPEED: 0, its WP_SPEED)
        # ArduRover's SmartRTL path (SMART_RTL: home back along it), from its position
        # first good (``_smart_saved``), and anew at each arming (``_smart_armed``: armed
        # at the last step).
        self._smart = SmartPath() if ground and self.firmware.is_ardupilot else None
        self._smart_saved = self._smart_armed = False
        # Stalled (a breakdown, a blocked road: ``stall``), it moves no more while its
        # autopilot drives on; ArduRover's crash check (FS_CRASH_CHECK: 0 off, its
        # default; 1 HOLD; 2 HOLD and disarm) counts the seconds it stands so.
        self._stalled = False
        self._fs_crash_check = 0
        self._crash_s = 0.0
        # Its rally points (MISSION_ITEM_INT, NAV_RALLY_POINT; ArduPilot rovers'), and the
        # rule RTL picks one or home by (``rally.rtl_destination``; Rover's defaults).
        self.rally: list[Message] = []
        self._rally_limit_km = ROVER_RALLY_DEFAULTS["RALLY_LIMIT_KM"]
        self._rally_incl_home = ROVER_RALLY_DEFAULTS["RALLY_INCL_HOME"]
        # The path it drove, for the vehicles behind it; a follower drives its leader's.
        self.trail = Trail() if ground else None
        self.follower: Follower | None = None  # (set by ``follow``)
        self._trail_t = 0.0  # sim time the trail was last recorded, and followed
        aircraft = None
        if not ground:
            n, e, d = world.to_ned(spec.home)
            aircraft = Aircraft(spec.airframe, AircraftState(n, e, d, 0.0, 0.0), ground_down=d)
        self.flight = FlightController(
            self.firmware,
            aircraft,
            self._frames,
            spec.home,
            self.counters,
            setpoint_timeout=spec.setpoint_timeout_s,
        )
        self._streams = StreamScheduler(
            GROUND_DEFAULT_INTERVALS if ground else AIRCRAFT_DEFAULT_INTERVALS, now
        )
        fl = self.flight
        self._handlers: dict[str, Callable[[Message, float], list[Message]]] = {
            "HEARTBEAT": self._on_heartbeat,
            "COMMAND_LONG": self._on_command_long,
            "COMMAND_INT": self._on_command_int,
            "SET_MODE": self._on_set_mode,
            "SET_POSITION_TARGET_LOCAL_NED": fl.setpoint_local,
            "SET_POSITION_TARGET_GLOBAL_INT": fl.setpoint_global,
            "PARAM_REQUEST_LIST": self._on_param_request_list,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_SET": self._on_param_set,
            "REQUEST_DATA_STREAM": self._on_request_data_stream,
            "TIMESYNC": self._on_timesync,
            "PING": self._on_ping,
            "MISSION_REQUEST_LIST": self._on_mission_request_list,
            "MISSION_COUNT": self._on_mission_count,
            "MISSION_ITEM_INT": self._on_mission_item_int,
            "MISSION_REQUEST_INT": self._on_mission_request,
            "MISSION_REQUEST": self._on_mission_request,
            "MISSION_ACK": self._on_mission_ack,
            "MISSION_CLEAR_ALL": self._on_mission_clear_all,
        }
        # A rover's mission: its route's road, served to a ground station that reads it,
        # or the one a ground station uploads (``sitl_mock.uploaded``).
        self.mission: RoverMission | UploadedMission | None = (
            RoverMission.of(spec.route, world) if spec.mission and spec.route is not None else None
        )
        # Whether AUTO has a mission to run: its road's (served or not), or one uploaded.
        self._has_mission = spec.route is not None and not isinstance(spec.route, Stationary)
        self.fence: list[Message] = []  # the geofence items last uploaded (MISSION_ITEM_INT)
        self._upload: tuple[int, list[Message | None]] | None = None  # (mission type, items)
        self._commands: dict[int, Callable[[Command, float], Outcome]] = {
            _R.MAV_CMD_COMPONENT_ARM_DISARM: fl.arm_disarm,
            _R.MAV_CMD_DO_SET_MODE: self._cmd_do_set_mode,
            _R.MAV_CMD_NAV_TAKEOFF: fl.takeoff,
            _R.MAV_CMD_DO_REPOSITION: fl.reposition,
            _R.MAV_CMD_DO_CHANGE_SPEED: self._cmd_change_speed,
            _R.MAV_CMD_MISSION_START: self._cmd_mission_start,
            _R.MAV_CMD_NAV_RETURN_TO_LAUNCH: self._cmd_return_to_launch,
            _R.MAV_CMD_NAV_LAND: fl.land,
            _R.MAV_CMD_DO_SET_HOME: self._cmd_set_home,
            _R.MAV_CMD_SET_MESSAGE_INTERVAL: self._cmd_set_message_interval,
            _R.MAV_CMD_GET_MESSAGE_INTERVAL: self._cmd_get_message_interval,
            _R.MAV_CMD_REQUEST_MESSAGE: self._cmd_request_message,
            _R.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._cmd_capabilities,
            _R.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: self._cmd_reboot,
        }
        self.last_gcs_heartbeat: float | None = None
        self.gcs_sysid = 255  # ArduPilot's MAV_GCS_SYSID
        self.mav_options = 0  # ArduPilot's MAV_OPTIONS
        self._home_news = False  # home just set: ArduPilot sends HOME_POSITION unasked
        self._boot(now)

    # ================================================================== lifecycle
    def _boot(self, now: float) -> None:
        self._boot_t = now
        self.flight.reset()
        if self.flight.aircraft is None and not self._has_mission:
            # (a rover boots in AUTO to drive its road; with none, AUTO has no mission)
            self.flight.mode = self.firmware.mode(self.firmware.hold)
        on, fw = self.spec.streams_on_boot, self.firmware
        self._streams.restart(now, enabled=fw.streams_on_boot if on is None else on)
        if on is None and fw.boot_stream_hz:  # (ArduPilot's SRn_* defaults)
            self._streams.request_data_stream(_R.MAV_DATA_STREAM_ALL, fw.boot_stream_hz, 1, now)
        self._update_warm(now)

    def reboot(self, now: float, *, on_pad: bool = False) -> None:
        """Reboot: time_boot_ms from 0, disarmed, boot mode, warm-up and streams anew.

        The airframe stays where it is (a reboot in the air leaves a disarmed
        aircraft gliding down); parameters keep their values, as on real hardware.
        ``on_pad``: it boots at rest on its home pad instead (a SITL process
        started again, an aircraft relaunched with a fresh battery).
        """
        old = self.flight.aircraft
        if on_pad and old is not None:
            n, e, d = self.world.to_ned(self.spec.home)
            self.flight.aircraft = Aircraft(
                old.params, AircraftState(n, e, d, 0.0, 0.0), ground_down=d
            )
        self._boot(now)
        self.counters["reboot"] += 1

    @property
    def armed(self) -> bool:
        """Whether the vehicle is armed."""
        return self.flight.armed

    @property
    def mode(self) -> str:
        """Name of the current flight mode (``"OFFBOARD"``, ``"GUIDED"``...)."""
        return self.flight.mode.name

    @property
    def aircraft(self) -> Aircraft | None:
        """The physics of an aircraft (None for a ground vehicle)."""
        return self.flight.aircraft

    def message_interval_us(self, msg_id: int) -> int:
        """What GET_MESSAGE_INTERVAL answers: microseconds, -1 off, 0 not available."""
        return self._streams.interval_us(msg_id)

    def _update_warm(self, now: float) -> None:
        fl = self.flight
        if fl.warm:
            return
        since = now - self._boot_t
        if since >= self._warmup:
            fl.warm = True
        elif not (self.firmware.home_at_fix and since >= _GPS_FIX_SHARE * self._warmup):
            return
        if not fl.home_set:  # home is set where the vehicle is then
            fl.set_home(self._geo(now))
            # ArduPilot tells every link (AP_AHRS::set_home: GCS_SEND_MESSAGE(MSG_HOME))
            self._home_news = self.firmware.is_ardupilot

    # =================================================================== physics
    def step(self, now: float, dt: float) -> list[Message]:
        """Advance the physics by ``dt`` ending at sim time ``now``; run the failsafes.

        Returns:
            Event messages (STATUSTEXT of failsafes and landings); the periodic
            telemetry comes from ``due_telemetry``.
        """
        self._update_warm(now)
        events: list[Message] = []
        if self.flight.aircraft is None:
            events = self._drive_or_stand(now)
            if now - self._trail_t >= _TRAIL_DT - 1e-9:
                dt_trail = now - self._trail_t
                n, e, speed = self._record_trail(now, dt_trail)
                self._trail_t = now
                events += self._keep_smart_path(now, (n, e))
                events += self._crash_check(now, dt_trail, speed)
        events += self.flight.step(now, dt)
        if self._home_news:
            self._home_news = False
            events.append(TELEMETRY_BUILDERS[_R.MAVLINK_MSG_ID_HOME_POSITION](self._snapshot(now)))
        if self.flight.armed and self.flight.aircraft is not None:
            self._battery_s += dt
        return events

    def _drive_or_stand(self, now: float) -> list[Message]:
        """A rover drives its route while armed in its mission mode (AUTO), home in RTL
        (straight) or SMART_RTL (back along its path), else stands; held during a
        waypoint's hold, it stands the whole hold again once back in AUTO
        (``AP_Mission::resume`` restarts the waypoint, whose hold starts on arrival). Its
        texts ("Reached destination")."""
        fl, ground = self.flight, self._ground
        if ground is None:
            return []
        follower = self.follower
        sent_home = fl.armed and fl.mode.behaviour is Behaviour.RTL
        on_its_own = follower is None or (sent_home and follower.trail.started)
        texts = self._return_or_resume(now, ground) if on_its_own else []
        auto = fl.mode.behaviour is Behaviour.MISSION
        home = fl.mode.behaviour is Behaviour.RTL and self._returning is not None
        driving = fl.armed and (auto or home) and not self._stalled
        ground.follow(now, driving, reset_speed=self.firmware.is_ardupilot and auto)
        mission = self.mission
        if isinstance(mission, UploadedMission) and mission.more and self._returning is None:
            self._go_on(mission, ground, now)
        return texts

    def _return_or_resume(self, now: float, ground: RoverDrive) -> list[Message]:
        """Armed in RTL, the rover sets off home (``rtl.road_home``) and says when it is
        there; armed in AUTO again, it resumes the mission it left at the item it was
        driving to, from where it stands. In any other mode it stands, still on its way.
        A follower sent home leaves its leader's trail for good: from where it is on it,
        at the speed it has, it drives home, and in AUTO its own mission (its leader's
        road) from there; the vehicles behind it follow its leader on (``Trail.hand_over``)."""
        fl, back = self.flight, self._returning
        behaviour = fl.mode.behaviour
        if not fl.armed or behaviour not in (Behaviour.RTL, Behaviour.MISSION):
            return []
        if behaviour is Behaviour.MISSION:
            if back is not None:
                self._returning = None
                self._resume(now, back)
            return []
        (n, e, _, vn, ve, _), *_ = self._kinematics(now)
        wp_radius = self._wp_radius()
        path = self._smart if fl.mode.name == _SMART_RTL else None  # (back along it)
        smart = path is not None
        if back is None or back.smart != smart:
            if back is None:
                # (a follower leaves its leader's trail from where it is, and hands the
                # vehicles behind it on to that leader)
                follower, self.follower = self.follower, None
                if follower is not None:
                    follower.leave(self.trail)
                self._returning = back = self._leave(now)
            way = path.way_home() if path is not None else []
            back.smart, back.reached = smart, False
            back.goal = way.pop() if way else self._rtl_goal((n, e))
            speed = self._rtl_speed or self._wp_speed() or DEFAULT_WP_SPEED
            accel = ground.clock.accel
            road, arc = road_home((n, e), (vn, ve), back.goal, speed, accel, wp_radius, way)
            moving = math.hypot(vn, ve)
            ground.drive_anew(now, road, arc=arc, wp_speed=self._wp_speed(), moving=moving)
            return []
        hn, he = back.goal or self.world.to_ned(fl.home)[:2]
        if back.reached or math.hypot(n - hn, e - he) > wp_radius:
            return []
        back.reached = True  # (ArduRover's ModeRTL; PX4 says nothing)
        if not self.firmware.is_ardupilot:
            return []
        return [statustext(_R.MAV_SEVERITY_INFO, "Reached destination")]

    def _rtl_goal(self, here: tuple[float, float]) -> tuple[float, float]:
        """Where RTL takes the rover from ``here`` (north, east): home, or the rally point
        ArduPilot picks (``rally.rtl_destination``; PX4's: home)."""
        hn, he, _ = self.world.to_ned(self.flight.home)
        if not self.firmware.is_ardupilot or not self.rally:
            return hn, he
        points = []
        for p in self.rally:
            n, e, _ = self.world.to_ned(GeoPoint(p.x * 1e-7, p.y * 1e-7))
            points.append((n, e))
        incl = self._rally_incl_home != 0.0
        return rtl_destination(here, (hn, he), points, self._rally_limit_km, incl)

    def _leave(self, now: float) -> Return:
        """The mission the rover leaves for home, and the item it was driving to: the one
        it serves (uploaded, or its road's), else its road's waypoints as a ground station
        would read them (``RoverMission``: a replayed track's corners and stands)."""
        mission = self.mission
        home_first = self.firmware.is_ardupilot
        route = self.spec.route
        if isinstance(route, Lagged):  # (a follower's own: its leader's road, later)
            route = route.inner
        if mission is None and route is not None:
            mission = RoverMission.of(route, self.world)
        if mission is None:
            return Return((), 0)
        ground = self._ground
        assert ground is not None
        seq = mission.current(ground.at(now), home_first=home_first, times=_arrivals(ground.route))
        if isinstance(mission, UploadedMission):
            return Return(tuple(mission.items), seq)
        target = (self.sysid, self.compid)
        count = mission.count(home_first=home_first)
        items = (
            mission.item(k, self.flight.home, target, home_first=home_first) for k in range(count)
        )
        return Return(tuple(item for item in items if item is not None), seq)

    def _resume(self, now: float, back: Return) -> None:
        """AUTO again after a return home: the mission left, from where the rover stands,
        restarting the item it was driving to (nothing to drive: it stands)."""
        if not back.items:
            self._drive_anew(self._lay((), now, None, None), now)
            return
        first = back.seq if 0 < back.seq < len(back.items) else None
        mission = self._lay(back.items, now, first, None)
        self.mission = mission
        self._drive_anew(mission, now)

    def follow(self, leader: Trail, lag: float, standstill: float) -> None:
        """Drive ``leader``'s path from now on, ``lag`` s behind it and never nearer than
        ``standstill`` metres, speeding up and braking as its own drive does (its road's
        accel)."""
        accel = self._ground.clock.accel if self._ground is not None else DEFAULT_ACCEL
        if self.follower is not None:
            self.follower.leave(None)
        self.follower = Follower(leader, lag, standstill, accel)

    def _record_trail(self, now: float, dt: float) -> tuple[float, float, float]:
        """A follower moves on behind its leader (armed in its mission mode and not
        stalled, or it brakes to a stand); every ground vehicle's path is recorded for
        those behind. Where (north, east) it is now, and its speed."""
        fl, follower = self.flight, self.follower
        if follower is not None:
            driving = fl.armed and fl.mode.behaviour is Behaviour.MISSION and not self._stalled
            follower.step(now, dt, driving)
        (n, e, _, vn, ve, _), *_ = self._kinematics(now)
        if self.trail is not None:
            self.trail.record(now, n, e)
        return n, e, math.hypot(vn, ve)

    def stall(self) -> None:
        """A ground vehicle stops (braking at its accel) and moves no more, whatever it
        is told, while its autopilot drives on: a breakdown, or a road blocked. The
        firmware does not know it; ArduRover's crash check may (``_crash_check``)."""
        self._stalled = True

    def _crash_check(self, now: float, dt: float, speed: float) -> list[Message]:
        """ArduRover's ``Rover::crash_check`` (10 Hz): armed in a mode that drives it
        (AUTO, RTL, SMART_RTL), under 0.08 m/s with its throttle up for 2 s, with
        FS_CRASH_CHECK set: "Crash: Going to HOLD", HOLD (and disarmed, with 2). Its
        throttle is up while it is stalled (not modelled otherwise: a stall at a planned
        hold counts as well, where the firmware waits for the hold's end)."""
        fl = self.flight
        drives = fl.mode.behaviour in (Behaviour.MISSION, Behaviour.RTL)
        if not (self._fs_crash_check and fl.armed and drives and self._stalled and speed < 0.08):
            self._crash_s = 0.0
            return []
        self._crash_s += dt
        if self._crash_s < _CRASH_CHECK_S - 1e-9:
            return []
        self._crash_s = 0.0
        fl.request_mode(self.firmware.mode("HOLD"), now)
        if self._fs_crash_check == _FS_CRASH_HOLD_AND_DISARM:
            fl.armed = False
        return [statustext(_R.MAV_SEVERITY_EMERGENCY, "Crash: Going to HOLD")]

    def _keep_smart_path(self, now: float, here: tuple[float, float]) -> list[Message]:
        """ArduRover's SmartRTL path (``AP_SmartRTL::update``, called at 3 Hz or more):
        started where it is once its position is good, and again as it arms
        (``AP_SmartRTL::set_home``); saved to out of SMART_RTL, and on its way back, the
        points it reaches taken off; what it says."""
        smart, fl = self._smart, self.flight
        if smart is None:
            return []
        n, e = here
        arming = fl.armed and not self._smart_armed
        if fl.home_set and (arming or not self._smart_saved):
            smart.set_home(now, n, e)
            self._smart_saved = True
        self._smart_armed = fl.armed
        if fl.mode.name == _SMART_RTL:
            smart.reached(n, e, self._wp_radius())
            return []
        return [
            statustext(_R.MAV_SEVERITY_WARNING if "deactivated" in t else _R.MAV_SEVERITY_INFO, t)
            for t in smart.update(now, n, e)
        ]

    def _wp_radius(self) -> float:
        """A rover's WP_RADIUS: its road's (2 m, ArduRover's default, without one)."""
        plan = self._ground.plan if self._ground is not None else None
        return plan.wp_radius if isinstance(plan, Polyline) else 2.0

    def _go_on(self, mission: UploadedMission, ground: RoverDrive, now: float) -> None:
        """An uploaded mission's next waypoints laid before the rover gets to the last of
        those laid (``UploadedMission.going_on``): from where it is, at the speed it was
        set to, its jumps counted on."""
        i = mission.going_on(ground.at(now), _arrivals(ground.route))
        drive = mission.drive
        if i is None or drive is None:
            return
        at, jumps = mission.resume[i]
        behind = drive.vertices[i - 1]  # (laid from the waypoint it left: on that leg)
        laid = self._lay(mission.items, now, at, ground.speed_set(now), dict(jumps), behind)
        self.mission = laid
        n, e, *_ = ground.state(now)
        self._drive_anew(laid, now, arc=math.dist(behind, (n, e)))
        self.counters["mission_laid"] += 1

    # ================================================================= telemetry
    def due_telemetry(self, now: float) -> list[Message]:
        """The periodic telemetry messages due at sim time ``now``."""
        ids = self._streams.due(now)
        if not ids:
            return []
        snap = self._snapshot(now)
        out = [TELEMETRY_BUILDERS[i](snap) for i in ids]
        return [m for m in out if m is not None]

    def _kinematics(self, now: float) -> tuple[tuple[float, ...], float, float, float]:
        """World (n, e, d, vn, ve, vd), yaw, yaw rate and speed at ``now``."""
        ac = self.flight.aircraft
        if ac is None:
            ground = self._ground
            if self.follower is not None and self.follower.trail.started:
                n, e, vn, ve = self.follower.state(now - self._trail_t)
            elif ground is None:
                (n, e, _), vn, ve = self.world.to_ned(self.spec.home), 0.0, 0.0
            else:
                n, e, vn, ve = ground.state(now)
            speed = math.hypot(vn, ve)
            if speed > 0.05:
                self._ground_yaw = math.atan2(ve, vn)
            return (n, e, self._ground_down, vn, ve, 0.0), self._ground_yaw, 0.0, speed
        s = ac.state
        return (s.north, s.east, s.down, *s.velocity_ned(ac.params)), s.yaw, s.yaw_rate, s.speed

    def _geo(self, now: float) -> GeoPoint:
        (n, e, d, *_), *_ = self._kinematics(now)
        return self.world.to_geo(n, e, d)

    def _snapshot(self, now: float) -> Snapshot:
        (n, e, d, vn, ve, vd), yaw, yaw_rate, speed = self._kinematics(now)
        geo = self.world.to_geo(n, e, d)
        x, y, z = self._frames.world_to_local(n, e, d)
        fl, fw = self.flight, self.firmware
        airborne = fl.airborne
        plane_bits = _R.MAV_SYS_STATUS_SENSOR_DIFFERENTIAL_PRESSURE if fl.plane else 0
        health = SENSORS if fl.warm else SENSORS & ~_NEEDS_WARMUP
        # The receiver has its 3D fix well before the estimator uses it: in between,
        # GPS_RAW_INT says 3D while arming is refused ("Arm: Need Position Estimate").
        gps = fl.warm or now - self._boot_t >= _GPS_FIX_SHARE * self._warmup
        remaining = max(0.0, 1.0 - self._battery_s / _BATTERY_ENDURANCE_S)
        target = fl.reported_target()
        return Snapshot(
            time_boot_ms=max(0, round((now - self._boot_t) * 1000.0)) & 0xFFFFFFFF,
            unix_usec=_UNIX_AT_SIM_ZERO_US + round(now * 1e6),
            lat=geo.lat,
            lon=geo.lon,
            alt=geo.alt,
            relative_alt=geo.alt - fl.home.alt,
            x=x,
            y=y,
            z=z,
            vn=vn,
            ve=ve,
            vd=vd,
            roll=math.atan(speed * yaw_rate / _G) if airborne else 0.0,  # coordinated turn
            pitch=math.atan2(-vd, max(speed, 1.0)) if airborne else 0.0,
            yaw=yaw,
            yaw_rate=yaw_rate,
            airspeed=speed / fw.airspeed_scale(geo.alt),  # (ArduPlane: its EAS)
            throttle=(55 if airborne else 5) if fl.armed else 0,
            home=fl.home,
            home_local=self._frames.local.to_ned(fl.home),
            home_set=fl.home_set,
            mav_type=fw.mav_type,
            autopilot=fw.autopilot,
            base_mode=fw.base_mode(fl.mode, fl.armed),
            custom_mode=fl.mode.custom_mode,
            system_status=fw.system_status(fl.armed, airborne, fl.failsafe),
            sensors_present=SENSORS | plane_bits,
            sensors_health=health | plane_bits,
            gps_fix=_R.GPS_FIX_TYPE_3D_FIX if gps else _R.GPS_FIX_TYPE_NO_FIX,
            satellites=14 if gps else 0,
            battery_remaining=round(remaining * 100.0),
            battery_voltage=4.0 * (3.5 + 0.7 * remaining),
            battery_current=15.0 if airborne else (2.0 if fl.armed else 0.5),
            battery_consumed_mah=self._battery_s * 15.0 / 3.6,
            landed_state=fl.landed_state(),
            target=None if target is None else self.world.to_geo(*target),
            **self._mission_progress(now),
        )

    def _mission_progress(self, now: float) -> dict[str, int]:
        mission, ground = self.mission, self._ground
        if mission is None or ground is None:
            return {}
        home_first = self.firmware.is_ardupilot
        back = self._returning  # (on its way home: the item AUTO resumes at)
        seq = (
            back.seq
            if back is not None
            else mission.current(
                ground.at(now), home_first=home_first, times=_arrivals(ground.route)
            )
        )
        return {
            "mission_seq": seq,
            # (ArduPilot leaves its home item out of the total: GCS_MAVLINK)
            "mission_total": mission.count(home_first=False),
        }

    def truth(self, now: float) -> TruthRow:
        """The vehicle's true state at sim time ``now`` (world NED, SI units)."""
        (n, e, d, vn, ve, vd), yaw, yaw_rate, speed = self._kinematics(now)
        geo = self.world.to_geo(n, e, d)
        return TruthRow(
            now, self.sysid, self.spec.kind, geo.lat, geo.lon, geo.alt, n, e, d,
            vn, ve, vd, yaw, speed, yaw_rate, self.flight.armed, self.flight.mode.name,
            self.flight.airborne,
        )  # fmt: skip

    # =================================================================== inbound
    def handle(self, msg: Message, now: float) -> list[Message]:
        """Process one decoded incoming message; return the immediate replies.

        Messages for another system (``target_system`` neither 0 nor ours) or
        another component are ignored and counted, as are unknown message types;
        so is all from another system than its ground station's (or its own) on an
        ArduPilot with MAV_OPTIONS bit 0 (``GCS_MAVLINK::accept_packet``).
        """
        if self.mav_options & _ONLY_GCS and not self._accepts(msg):
            self.counters["not_from_gcs"] += 1
            return []
        if getattr(msg, "target_system", 0) not in (0, self.sysid):
            self.counters["foreign_sysid"] += 1
            return []
        if getattr(msg, "target_component", 0) not in (0, self.compid):
            self.counters["foreign_compid"] += 1
            return []
        handler = self._handlers.get(msg.get_type())
        if handler is None:
            self.counters["unknown_message"] += 1
            return []
        self._update_warm(now)
        try:
            return handler(msg, now)
        except Exception as e:  # a bad message must never take the vehicle down
            self.counters["handler_error"] += 1
            self.last_error = e
            return []

    def _accepts(self, msg: Message) -> bool:
        src = msg.get_srcSystem()
        return src in (self.sysid, self.gcs_sysid) or msg.get_type() in _RADIO

    def _on_heartbeat(self, msg: Message, now: float) -> list[Message]:
        self.last_gcs_heartbeat = now
        return []

    def _on_timesync(self, msg: Message, now: float) -> list[Message]:
        if msg.tc1 != 0:  # an answer to a request we never make
            return []
        tc1 = max(0, round((now - self._boot_t) * 1e9))
        return [_R.MAVLink_timesync_message(tc1, msg.ts1)]

    def _on_ping(self, msg: Message, now: float) -> list[Message]:
        if msg.target_system != 0:  # a response, not a request
            return []
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        return [_R.MAVLink_ping_message(msg.time_usec, msg.seq, src, comp)]

    def _on_mission_request_list(self, msg: Message, now: float) -> list[Message]:
        """How many items a read will get: a rover's mission, an ArduPilot rover's rally
        points, else none of any type."""
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        count = 0
        if self.mission is not None and msg.mission_type == _R.MAV_MISSION_TYPE_MISSION:
            count = self.mission.count(home_first=self.firmware.is_ardupilot)
            self.counters["mission_reads"] += 1
        elif msg.mission_type == _R.MAV_MISSION_TYPE_RALLY:
            count = len(self.rally)
            self.counters["rally_reads"] += 1
        return [_R.MAVLink_mission_count_message(src, comp, count, msg.mission_type)]

    def _on_mission_request(self, msg: Message, now: float) -> list[Message]:
        """One item of a read: MISSION_ITEM_INT, or MISSION_ITEM to the float form's
        MISSION_REQUEST (as ArduPilot answers it); an item it does not hold is a MISSION_ACK
        error."""
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        kind = msg.mission_type
        item = None
        if self.mission is not None and kind == _R.MAV_MISSION_TYPE_MISSION:
            item = self.mission.item(
                msg.seq, self.flight.home, (src, comp), home_first=self.firmware.is_ardupilot
            )
        elif kind == _R.MAV_MISSION_TYPE_RALLY and 0 <= msg.seq < len(self.rally):
            p = self.rally[msg.seq]
            item = _R.MAVLink_mission_item_int_message(
                src, comp, msg.seq, p.frame, p.command, 0, 0, p.param1, p.param2, p.param3,
                p.param4, p.x, p.y, p.z, kind,
            )  # fmt: skip
        if item is None:
            bad = _R.MAV_MISSION_INVALID_SEQUENCE
            return [_R.MAVLink_mission_ack_message(src, comp, bad, kind)]
        if msg.get_type() == "MISSION_REQUEST":
            return [as_float_item(item)]
        return [item]

    def _on_mission_ack(self, msg: Message, now: float) -> list[Message]:
        """A reader closing its read (or cancelling it): nothing to answer."""
        self.counters["mission_read_acks"] += 1
        return []

    def _on_mission_count(
        self, msg: Message, now: float, sender: tuple[int, int] | None = None
    ) -> list[Message]:
        """An upload begins: a geofence (MAV_MISSION_TYPE_FENCE), a rover's mission
        (``sitl_mock.uploaded``) or an ArduPilot rover's rally points: ask for item 0; a
        count of 0 clears it.

        An aircraft's mission or rally points, and a PX4 rover's rally points, are
        refused: the mock flies no missions, and models ArduRover's RTL only.
        """
        src, comp = sender or (msg.get_srcSystem(), msg.get_srcComponent())
        kind = msg.mission_type
        rover = self.flight.aircraft is None
        rover_mission = rover and kind == _R.MAV_MISSION_TYPE_MISSION
        rally = rover and self.firmware.is_ardupilot and kind == _R.MAV_MISSION_TYPE_RALLY
        if kind != _R.MAV_MISSION_TYPE_FENCE and not (rover_mission or rally):
            return [_R.MAVLink_mission_ack_message(src, comp, _R.MAV_MISSION_UNSUPPORTED, kind)]
        if msg.count == 0:
            self._upload = None
            texts = self._store(kind, [], now)
            accepted = _R.MAV_MISSION_ACCEPTED
            return [_R.MAVLink_mission_ack_message(src, comp, accepted, kind), *texts]
        self._upload = (kind, [None] * msg.count)
        return [_R.MAVLink_mission_request_int_message(src, comp, 0, kind)]

    def _on_mission_clear_all(self, msg: Message, now: float) -> list[Message]:
        """MISSION_CLEAR_ALL (QGroundControl's and MAVSDK's clear): as an upload of none."""
        return self._on_mission_count(
            _R.MAVLink_mission_count_message(
                msg.target_system, msg.target_component, 0, msg.mission_type
            ),
            now,
            sender=(msg.get_srcSystem(), msg.get_srcComponent()),
        )

    def _on_mission_item_int(self, msg: Message, now: float) -> list[Message]:
        """One item of an upload, in order: store it, ask for the next, accept when all
        are in (a fence's vertices only; a rover's mission, ``uploaded.upload_result``).

        An item out of turn is answered as the firmware does. ArduPilot: MAV_MISSION_ERROR
        with no upload open, MAV_MISSION_INVALID_SEQUENCE during one
        (``GCS_MAVLINK::handle_mission_item``, ``MissionItemProtocol``). PX4: the last item
        sent again after the upload closed is ACCEPTED again (its ACK was lost), any other
        is refused with MAV_MISSION_ERROR and "IGN MISSION_ITEM: No transfer"; during an
        upload an item out of turn is ignored (``MavlinkMissionManager``).
        """
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        kind = msg.mission_type

        def ack(result: int) -> Message:
            return _R.MAVLink_mission_ack_message(src, comp, result, kind)

        ardupilot = self.firmware.is_ardupilot
        kinds = (_R.MAV_MISSION_TYPE_FENCE, _R.MAV_MISSION_TYPE_MISSION, _R.MAV_MISSION_TYPE_RALLY)
        if kind not in kinds:
            return [ack(_R.MAV_MISSION_UNSUPPORTED)]
        if self._upload is None or self._upload[0] != kind:
            if ardupilot:
                return [ack(_R.MAV_MISSION_ERROR)]
            last = self._stored(kind)
            if last and msg.seq == last - 1:
                return [ack(_R.MAV_MISSION_ACCEPTED)]
            text = statustext(_R.MAV_SEVERITY_CRITICAL, "IGN MISSION_ITEM: No transfer")
            return [text, ack(_R.MAV_MISSION_ERROR)]
        upload = self._upload[1]
        expected = upload.index(None)
        if msg.seq != expected:
            return [ack(_R.MAV_MISSION_INVALID_SEQUENCE)] if ardupilot else []
        if kind == _R.MAV_MISSION_TYPE_FENCE:
            vertex = (
                _R.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
                _R.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
            )
            ok = msg.command in vertex
            result = _R.MAV_MISSION_ACCEPTED if ok else _R.MAV_MISSION_UNSUPPORTED
        elif kind == _R.MAV_MISSION_TYPE_RALLY:  # (``MissionItemProtocol_Rally``)
            ok = msg.command == _R.MAV_CMD_NAV_RALLY_POINT
            result = _R.MAV_MISSION_ACCEPTED if ok else _R.MAV_MISSION_UNSUPPORTED
        else:  # (ArduPilot's item 0 is home: whatever is sent there, home stays its own)
            home = ardupilot and msg.seq == 0
            result = _R.MAV_MISSION_ACCEPTED if home else upload_result(msg)
        if result != _R.MAV_MISSION_ACCEPTED:
            self._upload = None
            return [ack(result)]
        upload[msg.seq] = msg
        if msg.seq + 1 < len(upload):
            return [_R.MAVLink_mission_request_int_message(src, comp, msg.seq + 1, kind)]
        self._upload = None
        texts = self._store(kind, [item for item in upload if item is not None], now)
        if ardupilot and kind == _R.MAV_MISSION_TYPE_FENCE:
            # (SITL's debug text once the fence is stored, after the ACK on the wire)
            texts = [statustext(_R.MAV_SEVERITY_DEBUG, "Fence Indexed OK")]
        return [ack(_R.MAV_MISSION_ACCEPTED), *texts]

    def _stored(self, kind: int) -> int:
        """How many items of ``kind`` the last upload stored."""
        if kind == _R.MAV_MISSION_TYPE_FENCE:
            return len(self.fence)
        if kind == _R.MAV_MISSION_TYPE_RALLY:
            return len(self.rally)
        return len(self.mission.items) if isinstance(self.mission, UploadedMission) else 0

    def _store(self, kind: int, items: list[Message], now: float) -> list[Message]:
        """An upload complete: the fence, or the rover's mission; the texts it sends.

        A mission is driven from where the rover is (``RoverDrive.drive_anew``). Changed
        while it runs in AUTO, ArduRover goes on at the item it was at in the new one
        ("Auto mission changed, restarted command"), or stops if there is none such;
        its mission over, it waits for AUTO to be entered again. PX4's starts again at
        its first item. An empty mission clears it: the rover stands."""
        if kind == _R.MAV_MISSION_TYPE_FENCE:
            self.fence = items
            self.counters["fence_uploads"] += bool(items)
            return []
        if kind == _R.MAV_MISSION_TYPE_RALLY:  # (RTL picks among them when entered)
            self.rally = items
            self.counters["rally_uploads"] += 1
            return []
        self.counters["mission_uploads"] += 1
        fw, fl, ground = self.firmware, self.flight, self._ground
        ardupilot = fw.is_ardupilot
        texts = [statustext(_R.MAV_SEVERITY_INFO, "Flight plan received")] if ardupilot else []
        in_auto = fl.armed and fl.mode.behaviour is Behaviour.MISSION
        running = in_auto and ground is not None and not ground.finished(now)
        first = None
        if running and ardupilot:
            # (a road not served as a mission, a follower's: its item unknown, the first)
            at = self._mission_progress(now).get("mission_seq", int(ardupilot))
            restarted = 0 < at < len(items)
            first = at if restarted else len(items)  # (none such: nothing more to drive)
            text = ", restarted command" if restarted else " but failed to restart command"
            texts.append(statustext(_R.MAV_SEVERITY_CRITICAL, f"Auto mission changed{text}"))
        speed_now = ground.speed_set(now) if first is not None and ground else None
        mission = self._lay(items, now, first, speed_now)
        self.mission = mission if items else None
        self._has_mission = mission.count(home_first=False) > 0
        if self._returning is not None:  # (on its way home: AUTO starts the new one)
            self._returning = Return(tuple(items), int(ardupilot), goal=self._returning.goal)
            return texts
        self._drive_anew(mission, now, wait=in_auto and not running and ardupilot)
        return texts

    def _lay(
        self,
        items: Sequence[Message],
        now: float,
        first: int | None,
        speed_now: float | None,
        jumps: Mapping[int, int] | None = None,
        start: tuple[float, float] | None = None,
    ) -> UploadedMission:
        """The mission ``items`` as driven from ``start`` (None: where the rover is now;
        ``UploadedMission``)."""
        (n, e, *_), *_ = self._kinematics(now)
        n, e = start or (n, e)
        ground = self._ground
        plan = ground.plan if ground is not None else None
        return UploadedMission.of(
            items,
            home_first=self.firmware.is_ardupilot,
            world=self.world,
            start=(n, e),
            home=self.flight.home,
            speed=self._wp_speed() or DEFAULT_WP_SPEED,
            accel=ground.clock.accel if ground is not None else DEFAULT_ACCEL,
            wp_radius=plan.wp_radius if isinstance(plan, Polyline) else 2.0,
            first=first,
            speed_now=speed_now,
            jumps=jumps,
        )

    def _drive_anew(
        self, mission: UploadedMission, now: float, *, wait: bool = False, arc: float = 0.0
    ) -> None:
        """The rover drives ``mission``'s road from now, ``arc`` metres along its first leg
        (a parked one sets off from a stand)."""
        (n, e, *_), *_ = self._kinematics(now)
        here = Polyline(((n, e),), speed=0.0)
        ground = self._ground
        if ground is None:
            ground = self._ground = RoverDrive(here)
        ground.drive_anew(now, mission.drive or here, wait=wait, arc=arc)

    def _on_request_data_stream(self, msg: Message, now: float) -> list[Message]:
        if not self.firmware.is_ardupilot:  # PX4 has no stream groups
            self.counters["unsupported_message"] += 1
            return []
        self._streams.request_data_stream(
            msg.req_stream_id, msg.req_message_rate, msg.start_stop, now
        )
        return []

    # -------------------------------------------------------------------- params
    def _on_param_request_list(self, msg: Message, now: float) -> list[Message]:
        return list(self._params.request_list(self._knob))

    def _on_param_request_read(self, msg: Message, now: float) -> list[Message]:
        reply = self._params.request_read(msg.param_id, msg.param_index, self._knob)
        if reply is None:
            self.counters["param_unknown"] += 1
            return []
        return [reply]

    def _on_param_set(self, msg: Message, now: float) -> list[Message]:
        result = self._params.set(msg.param_id, msg.param_value, self._knob, self._set_knob)
        if result is None:
            self.counters["param_unknown"] += 1
            return []
        reply, error = result
        if error is None:
            return [reply]
        return [reply, statustext(_R.MAV_SEVERITY_WARNING, error)]

    def _knob(self, knob: Knob) -> float:
        fl = self.flight
        params = fl.aircraft.params if fl.aircraft is not None else self.spec.airframe
        route = self.spec.route
        values = {
            Knob.AIRSPEED: params.airspeed,
            Knob.NAV_SPEED: params.airspeed if self._nav_speed is None else self._nav_speed,
            Knob.AIRSPEED_MIN: params.min_airspeed_ratio * params.airspeed,
            Knob.AIRSPEED_MAX: params.max_airspeed_ratio * params.airspeed,
            Knob.TURN_RADIUS: params.min_turn_radius,
            Knob.CLIMB_RATE: params.max_climb_rate,
            Knob.SETPOINT_TIMEOUT: fl.setpoint_timeout,
            Knob.LOITER_RADIUS: fl.loiter_radius,
            Knob.TAKEOFF_ALT: fl.takeoff_alt,
            Knob.RTL_ALT: fl.rtl_alt,
            Knob.WARMUP: self._warmup,
            Knob.SYSID: float(self.sysid),
            Knob.SPEEDUP: 1.0 if self._speedup is None else self._speedup.speedup,
            Knob.WP_SPEED: self._wp_speed(),
            Knob.ROVER_ACCEL: route.accel if isinstance(route, Polyline) else 0.0,
            Knob.WP_RADIUS: route.wp_radius if isinstance(route, Polyline) else 2.0,
            Knob.GCS_SYSID: float(self.gcs_sysid),
            Knob.MAV_OPTIONS: float(self.mav_options),
            Knob.RTL_SPEED: self._rtl_speed,
            Knob.RALLY_LIMIT_KM: self._rally_limit_km,
            Knob.RALLY_INCL_HOME: self._rally_incl_home,
            Knob.RALLY_TOTAL: float(len(self.rally)),
            Knob.SRTL_ACCURACY: self._smart.accuracy if self._smart is not None else 0.0,
            Knob.SRTL_POINTS: float(self._smart.points_max) if self._smart is not None else 0.0,
            Knob.FS_CRASH_CHECK: float(self._fs_crash_check),
        }
        return values[knob]

    def _wp_speed(self) -> float:
        """A rover's WP_SPEED: its plan's (0: a recorded track's own speeds; parked and
        never told one, ArduRover's default)."""
        ground, route = self._ground, self.spec.route
        if ground is not None and ground.wp_speed > 0.0:
            return ground.wp_speed
        return _road_speed(route) if route is not None else DEFAULT_WP_SPEED

    def _set_knob(self, knob: Knob, value: float) -> None:
        """Apply a parameter; airframe changes rebuild the physics around its state.

        Raises:
            ValueError: The airframe refuses the value.
        """
        fl = self.flight
        ac = fl.aircraft
        if knob in _AIRFRAME_KNOBS:
            assert ac is not None
            p = ac.params
            if knob is Knob.AIRSPEED:  # (a plane's minimum and maximum stay as they were)
                params = dataclasses.replace(
                    p,
                    airspeed=value,
                    min_airspeed_ratio=min(p.min_airspeed_ratio * p.airspeed / value, 1.0),
                    max_airspeed_ratio=max(p.max_airspeed_ratio * p.airspeed / value, 1.0),
                )
                if fl.plane:
                    fl.cruise = None  # the new trim airspeed is the cruise speed
            elif knob is Knob.AIRSPEED_MIN:
                params = dataclasses.replace(p, min_airspeed_ratio=value / p.airspeed)
            elif knob is Knob.AIRSPEED_MAX:
                params = dataclasses.replace(p, max_airspeed_ratio=value / p.airspeed)
            elif knob is Knob.TURN_RADIUS:
                params = dataclasses.replace(p, min_turn_radius=value)
            else:
                params = dataclasses.replace(p, max_climb_rate=value)
            fl.aircraft = Aircraft(params, ac.state, ground_down=ac.ground_down)
            if fl.cruise is not None:
                fl.aircraft.set_speed(fl.cruise)
        elif knob is Knob.NAV_SPEED:  # (ArduCopter: the speed of position moves alone)
            self._nav_speed = value
            fl.cruise = value
            if ac is not None:
                ac.set_speed(value)
        elif knob is Knob.SETPOINT_TIMEOUT:
            fl.setpoint_timeout = value
        elif knob is Knob.LOITER_RADIUS:
            fl.loiter_radius = value
        elif knob is Knob.TAKEOFF_ALT:
            fl.takeoff_alt = value
        elif knob is Knob.RTL_ALT:
            fl.rtl_alt = value
        elif knob is Knob.WARMUP:
            self._warmup = value
        elif knob is Knob.RTL_SPEED:
            if not 0.0 <= value <= _RTL_SPEED_MAX:
                raise ValueError(f"must be 0..{_RTL_SPEED_MAX:g} m/s, got {value:g}")
            self._rtl_speed = value
        elif knob is Knob.RALLY_LIMIT_KM:
            if not value >= 0.0:
                raise ValueError(f"must be 0 km or more, got {value:g}")
            self._rally_limit_km = value
        elif knob is Knob.FS_CRASH_CHECK:
            if value not in (0.0, 1.0, 2.0):
                raise ValueError(f"must be 0 (off), 1 (HOLD) or 2 (HOLD and disarm), got {value:g}")
            self._fs_crash_check = int(value)
        elif knob is Knob.SRTL_ACCURACY:
            if not 0.0 <= value <= _SRTL_ACCURACY_MAX or self._smart is None:
                raise ValueError(f"must be 0..{_SRTL_ACCURACY_MAX:g} m, got {value:g}")
            self._smart.accuracy = value
        elif knob is Knob.RALLY_INCL_HOME:
            if value not in (0.0, 1.0):
                raise ValueError(f"must be 0 or 1, got {value:g}")
            self._rally_incl_home = value
        elif knob in (Knob.GCS_SYSID, Knob.MAV_OPTIONS):
            top = 255 if knob is Knob.GCS_SYSID else 0xFFFF
            if value != int(value) or not 0 <= value <= top:
                raise ValueError(f"must be a whole number in 0..{top}, got {value:g}")
            if knob is Knob.GCS_SYSID:
                self.gcs_sysid = int(value)
            else:
                self.mav_options = int(value)
        elif knob is Knob.SPEEDUP:
            if self._speedup is None:
                raise ValueError("no simulator clock to set the speedup of")
            self._speedup.set_speedup(value)

    # ------------------------------------------------------------------ commands
    def _on_command_long(self, msg: Message, now: float) -> list[Message]:
        return self._command(Command.from_long(msg, self.firmware.long_alt_relative), now)

    def _on_command_int(self, msg: Message, now: float) -> list[Message]:
        return self._command(Command.from_int(msg), now)

    def _command(self, cmd: Command, now: float) -> list[Message]:
        handler = self._commands.get(cmd.command)
        extra: list[Message] = []
        if handler is None:
            self.counters["unknown_command"] += 1
            result = _R.MAV_RESULT_UNSUPPORTED
        else:
            result, extra = handler(cmd, now)
        ack = _R.MAVLink_command_ack_message(
            cmd.command, result, 0, 0, cmd.src_system, cmd.src_component
        )
        return [ack, *extra]

    def _on_set_mode(self, msg: Message, now: float) -> list[Message]:
        fw = self.firmware
        mode = None
        if msg.base_mode & _R.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            mode = fw.decode_mode(msg.custom_mode)
        result, extra = self._request_mode(mode, now)
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        return [_R.MAVLink_command_ack_message(fw.set_mode_ack, result, 0, 0, src, comp), *extra]

    def _cmd_do_set_mode(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_DO_SET_MODE: param1 base mode (CUSTOM_MODE flag), param2 main, param3 sub."""
        mode = None
        if math.isfinite(c.p1) and int(c.p1) & _R.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            mode = self.firmware.decode_do_set_mode(c.p2, c.p3)
        return self._request_mode(mode, now)

    def _cmd_mission_start(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_MISSION_START: AUTO, as a mode change (ArduPilot: param1 and param2, the
        first and last item, must be 0, else DENIED). PX4 arms as well, and denies it
        without a mission ("Mission start denied! No valid mission")."""
        fw, fl = self.firmware, self.flight
        auto = next(m for m in fw.modes if m.behaviour is Behaviour.MISSION)
        if fw.is_ardupilot:
            if c.p1 != 0.0 or c.p2 != 0.0:
                return _R.MAV_RESULT_DENIED, []
            result, texts = self._request_mode(auto, now)
            ok = result == _R.MAV_RESULT_ACCEPTED
            return (_R.MAV_RESULT_ACCEPTED if ok else _R.MAV_RESULT_FAILED), texts
        if fl.aircraft is None and not self._has_mission:
            text = statustext(_R.MAV_SEVERITY_CRITICAL, "Mission start denied! No valid mission")
            return _R.MAV_RESULT_DENIED, [text]
        result, texts = self._request_mode(auto, now)
        if result == _R.MAV_RESULT_ACCEPTED and not fl.armed:
            arm = dataclasses.replace(c, command=_R.MAV_CMD_COMPONENT_ARM_DISARM, p1=1.0, p2=0.0)
            result, more = fl.arm_disarm(arm, now)
            texts = [*texts, *more]
        return result, texts

    def _request_mode(self, mode: FlightMode | None, now: float) -> Outcome:
        """A mode change, as the flight takes it; a rover's AUTO needs a mission (ArduRover
        ``ModeAuto::_enter``: "No Mission. Can't set AUTO.", then "Flight mode change
        failed"; PX4: the mode is not available without a valid mission), and its RTL a
        home (``ModeRTL::_enter``)."""
        fw = self.firmware
        rtl = mode is not None and mode.behaviour is Behaviour.RTL and mode != self.flight.mode
        smart = self._smart
        no_path = smart is not None and not smart.active  # (``ModeSmartRTL::_enter``)
        if rtl and mode is not None and mode.name == _SMART_RTL and no_path:
            failed = statustext(_R.MAV_SEVERITY_WARNING, "Flight mode change failed")
            return _R.MAV_RESULT_FAILED, [failed]
        if rtl and self.flight.aircraft is None and not self.flight.home_set:
            assert mode is not None
            if fw.is_ardupilot:
                failed = statustext(_R.MAV_SEVERITY_WARNING, "Flight mode change failed")
                return _R.MAV_RESULT_FAILED, [failed]
            text = fw.mode_denied_text(mode, "no home position")
            return fw.reject_result, [statustext(_R.MAV_SEVERITY_CRITICAL, text)]
        auto = mode is not None and mode.behaviour is Behaviour.MISSION and mode != self.flight.mode
        if auto and self.flight.aircraft is None and not self._has_mission:
            assert mode is not None
            if fw.is_ardupilot:
                return _R.MAV_RESULT_FAILED, [
                    statustext(_R.MAV_SEVERITY_NOTICE, "No Mission. Can't set AUTO."),
                    statustext(_R.MAV_SEVERITY_WARNING, "Flight mode change failed"),
                ]
            text = fw.mode_denied_text(mode, "no mission")
            return fw.reject_result, [statustext(_R.MAV_SEVERITY_CRITICAL, text)]
        return self.flight.request_mode(mode, now)

    def _cmd_return_to_launch(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_NAV_RETURN_TO_LAUNCH: RTL mode; an aircraft's (``FlightController``),
        or a rover's, which drives home (ArduRover: ACCEPTED, or FAILED as its mode
        change is)."""
        fw = self.firmware
        if self.flight.aircraft is not None or fw.rtl is None:
            return self.flight.return_to_launch(c, now)
        result, texts = self._request_mode(fw.mode(fw.rtl), now)
        if fw.is_ardupilot and result != _R.MAV_RESULT_ACCEPTED:
            result = _R.MAV_RESULT_FAILED
        return result, texts

    def _cmd_change_speed(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_DO_CHANGE_SPEED: an aircraft's (``FlightController.change_speed``), or
        a rover's, in AUTO: param1 the speed type (ground or air: both the ground speed;
        climb and descent refused), param2 m/s (-1: no change), until the mission's next
        DO_CHANGE_SPEED (ArduRover ``handle_command_int_packet``, ``AR_WPNav``)."""
        if self.flight.aircraft is not None:
            return self.flight.change_speed(c, now)
        fl = self.flight
        if c.p1 not in (_R.SPEED_TYPE_AIRSPEED, _R.SPEED_TYPE_GROUNDSPEED):
            return _R.MAV_RESULT_DENIED, []
        ground = self._ground
        if ground is None or fl.mode.behaviour is not Behaviour.MISSION:
            return _R.MAV_RESULT_FAILED, []  # (Mode::set_desired_speed: AUTO's alone)
        if c.p2 == -1.0:
            return _R.MAV_RESULT_ACCEPTED, []
        if not (math.isfinite(c.p2) and c.p2 >= _ROVER_SPEED_MIN):
            return _R.MAV_RESULT_FAILED, []
        told = ground.tell(now, float(c.p2))
        return (_R.MAV_RESULT_ACCEPTED if told else _R.MAV_RESULT_FAILED), []

    def _cmd_set_home(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_DO_SET_HOME: param1 1 uses the current position, else lat/lon/alt."""
        fl = self.flight
        if c.p1 >= 0.5 or not (math.isfinite(c.lat) and math.isfinite(c.lon)):
            home = self._geo(now)
        else:
            alt = c.alt if math.isfinite(c.alt) else fl.home.alt
            if c.alt_relative and c.is_int:
                alt += fl.home.alt
            home = GeoPoint(c.lat, c.lon, alt)
        fl.set_home(home)
        msg = TELEMETRY_BUILDERS[_R.MAVLINK_MSG_ID_HOME_POSITION](self._snapshot(now))
        return _R.MAV_RESULT_ACCEPTED, [msg]

    def _cmd_set_message_interval(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_SET_MESSAGE_INTERVAL: param1 message id, param2 us (-1 off, 0 default)."""
        ok = self._streams.set_message_interval(_msg_id(c.p1), c.p2, now)
        return (_R.MAV_RESULT_ACCEPTED if ok else _R.MAV_RESULT_DENIED), []

    def _cmd_get_message_interval(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_GET_MESSAGE_INTERVAL: answered with MESSAGE_INTERVAL."""
        msg_id = _msg_id(c.p1)
        reply = _R.MAVLink_message_interval_message(msg_id, self.message_interval_us(msg_id))
        return _R.MAV_RESULT_ACCEPTED, [reply]

    def _cmd_request_message(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_REQUEST_MESSAGE: AUTOPILOT_VERSION or any message the mock streams."""
        msg_id = _msg_id(c.p1)
        if msg_id == _R.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            return self._cmd_capabilities(c, now)
        builder = TELEMETRY_BUILDERS.get(msg_id)
        if builder is None:
            return _R.MAV_RESULT_DENIED, []
        msg = builder(self._snapshot(now))
        if msg is None:  # HOME_POSITION before home is set
            return _R.MAV_RESULT_FAILED, []
        return _R.MAV_RESULT_ACCEPTED, [msg]

    def _cmd_capabilities(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES (legacy): AUTOPILOT_VERSION."""
        fw = self.firmware
        return _R.MAV_RESULT_ACCEPTED, [autopilot_version(fw.capabilities, fw.version, self.sysid)]

    def _cmd_reboot(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN param1 1: reboot (refused while armed)."""
        if not math.isfinite(c.p1) or round(c.p1) != 1:
            return _R.MAV_RESULT_UNSUPPORTED, []
        if self.flight.armed and self.flight.aircraft is not None:
            return _R.MAV_RESULT_DENIED, [
                statustext(_R.MAV_SEVERITY_CRITICAL, "Reboot denied: armed")
            ]
        self.reboot(now)
        return _R.MAV_RESULT_ACCEPTED, []


def _msg_id(value: float) -> int:
    return int(value) if math.isfinite(value) and value >= 0.0 else -1


def _arrivals(route: Route | None) -> tuple[float, ...] | None:
    """When a polyline's drive reaches each vertex (None: another route's own times)."""
    return route.arrivals if isinstance(route, Polyline) else None


def _road_speed(route: Route | None) -> float:
    """The one speed a ground route drives at (a line's, a polyline's), as a rover's
    WP_SPEED; 0 for a recorded track, which drives its own speeds (or none)."""
    return float(route.speed) if isinstance(route, StraightLine | Polyline) else 0.0
