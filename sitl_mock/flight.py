"""The flight state machine of a simulated autopilot: arming, modes, goals, failsafes.

``FlightController`` decides *what* an aircraft flies -- a ``kinematics.Guidance``
in world NED -- from the commands it accepted; the ``Aircraft`` decides how.
It is firmware-neutral: behaviours (hold, fly external setpoints, take off,
return, land) are implemented here once, and everything a ground station can
tell PX4 and ArduPilot apart by comes from the ``personality.Firmware`` it holds.
``autopilot.SimVehicle`` owns one and translates MAVLink to its methods.

Design rules:
    * Guidance is re-derived every step from (armed, mode, airborne, goal, pending
      takeoff); re-commanding an equal value is free in ``Aircraft.command``.
    * A *goal* is what the current mode flies once airborne: a setpoint, a
      reposition loiter, a hold captured where the mode began, or Idle to land.
      Every mode change clears it; it is captured lazily when first needed.
    * Take-off is as strict as the firmware: a plane leaves the ground only in its
      take-off mode (ArduPlane TAKEOFF, PX4 AUTO.TAKEOFF after NAV_TAKEOFF), climbing
      straight out to the takeoff altitude (TKOFF_ALT / MIS_TAKEOFF_ALT or the
      command's); armed in GUIDED or OFFBOARD on the ground, or given a
      DO_REPOSITION there, it stays on the runway with its throttle suppressed, as
      ArduPlane does. A PX4 copter in OFFBOARD lifts off when its setpoint is above
      it; an ArduCopter takes off only on NAV_TAKEOFF in GUIDED (as the real one).
      Pilot modes (MANUAL, STABILIZE...) hold position in the air: no RC exists.
    * Refusals carry the firmware's COMMAND_ACK result and a STATUSTEXT reason.
"""

from __future__ import annotations

import dataclasses
import math
from collections import Counter
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint
from sitl_mock.kinematics import Aircraft, Guidance, Idle, Loiter, Takeoff, TrackTarget
from sitl_mock.messages import (
    Command,
    Frames,
    decode_global_setpoint,
    decode_local_setpoint,
    statustext,
)
from sitl_mock.personality import Behaviour, Firmware, FlightMode, SetpointPolicy

__all__ = ["FlightController", "Outcome"]

Message = Any  # a pymavlink MAVLink_message (the dialect is untyped)
Outcome = tuple[int, list[Message]]
"""A command's COMMAND_ACK result and the messages to send after the ACK."""

_R = mavlink
_FORCE_MAGIC = 21196  # COMPONENT_ARM_DISARM param2: arm/disarm regardless of checks
_LIFTOFF_AGL = 2.0  # m: PX4 copter offboard lift-off before the setpoint takes over
_RTL_LAND_RADIUS = 1.0  # m: a returning copter lands once this close to home
_MIN_AGL = 1.0  # m: no commanded altitude is lower than this above the ground
_Z_IGNORE = 4  # POSITION_TARGET_TYPEMASK_Z_IGNORE


class FlightController:
    """Arming, flight modes and guidance of one vehicle (see the module docstring).

    Args:
        firmware: The personality strategy.
        aircraft: The physics; None for a ground vehicle, which only keeps an
            armed flag and a mode label (its route is its truth).
        frames: World and vehicle-local frames.
        home: Initial home (the boot position).
        counters: Where to count events (shared with the vehicle).

    Attributes:
        armed, mode, failsafe: What HEARTBEAT reports.
        home, home_set: Home position and whether it is valid yet.
        warm: Sensors warmed up (GPS fix); set by the vehicle.
        setpoint_timeout, loiter_radius, takeoff_alt, rtl_alt: Settings (s, m)
            that parameters expose.
    """

    def __init__(
        self,
        firmware: Firmware,
        aircraft: Aircraft | None,
        frames: Frames,
        home: GeoPoint,
        counters: Counter[str],
        *,
        setpoint_timeout: float,
    ) -> None:
        self.firmware = firmware
        self.aircraft = aircraft
        self.frames = frames
        self.counters = counters
        self.plane = aircraft is not None and aircraft.params.frame == "plane"
        self.setpoint_timeout = setpoint_timeout
        self.loiter_radius = aircraft.params.min_turn_radius if self.plane and aircraft else 0.0
        self.takeoff_alt = 30.0 if self.plane else 10.0
        self.rtl_alt = 60.0 if self.plane else 30.0
        self.cruise: float | None = None
        self._equivalent = self.plane and firmware.equivalent_airspeeds
        self._tas_key: int | None = None
        self._tas_scale = 1.0
        self.home = home
        self.reset()

    def reset(self) -> None:
        """Boot state: disarmed (a ground vehicle armed), boot mode, no goal, not warm."""
        self.armed = self.aircraft is None
        self.mode: FlightMode = self.firmware.mode(self.firmware.boot)
        self.failsafe = False
        self.warm = False
        self.home_set = False
        self.setpoint: TrackTarget | None = None
        self.setpoint_t = -math.inf
        self.goal: Guidance | None = None
        self.guided_radius = 0.0
        """ArduPlane: the last DO_REPOSITION radius given in this GUIDED (0: none)."""
        self.takeoff_down: float | None = None
        self._was_airborne = self.airborne

    # ----------------------------------------------------------------- queries
    @property
    def airborne(self) -> bool:
        """True while the aircraft is off the ground."""
        return self.aircraft is not None and self.aircraft.state.airborne

    def position_geo(self) -> GeoPoint:
        """Where the aircraft is (the home for a ground vehicle)."""
        if self.aircraft is None:
            return self.home
        s = self.aircraft.state
        return self.frames.world.to_geo(s.north, s.east, s.down)

    def landed_state(self) -> int:
        """EXTENDED_SYS_STATE.landed_state."""
        ac = self.aircraft
        state = _R.MAV_LANDED_STATE_IN_AIR
        if ac is None or not ac.state.airborne:
            state = _R.MAV_LANDED_STATE_ON_GROUND
        elif isinstance(ac.guidance, Takeoff):
            state = _R.MAV_LANDED_STATE_TAKEOFF
        elif isinstance(ac.guidance, Idle):
            state = _R.MAV_LANDED_STATE_LANDING
        return int(state)

    def reported_target(self) -> tuple[float, float, float] | None:
        """The (north, east, down) ArduPilot reports in POSITION_TARGET_GLOBAL_INT.

        ArduPlane: its ``next_WP_loc`` (here the loiter it flies: a DO_REPOSITION's
        centre, a hold's). ArduCopter: ``get_wp`` of GUIDED, a target only in its
        position-only and waypoint sub-modes (a position + velocity target reports
        none). PX4 is not modelled: None.
        """
        fw, goal = self.firmware, self.goal
        if not fw.is_ardupilot or self.aircraft is None:
            return None
        if self.plane:
            return (goal.north, goal.east, goal.down) if isinstance(goal, Loiter) else None
        if self.mode.behaviour is not Behaviour.EXTERNAL:
            return None
        if isinstance(goal, Loiter):
            return goal.north, goal.east, goal.down
        if (
            isinstance(goal, TrackTarget)
            and goal.vn is None
            and goal.north is not None
            and goal.east is not None
        ):
            return goal.north, goal.east, self._ac().state.down if goal.down is None else goal.down
        return None

    def _fresh(self, now: float) -> bool:
        return now - self.setpoint_t <= self.setpoint_timeout

    def _ac(self) -> Aircraft:
        assert self.aircraft is not None
        return self.aircraft

    def set_home(self, home: GeoPoint) -> None:
        """Move home (DO_SET_HOME, first fix, arming)."""
        self.home = home
        self.home_set = True

    # ------------------------------------------------------------------ physics
    def step(self, now: float, dt: float) -> list[Message]:
        """Failsafes, takeoff/landing transitions and ``dt`` of physics ending at ``now``."""
        events: list[Message] = []
        ac = self.aircraft
        if ac is None:
            return events
        self._check_setpoint_loss(now, events)
        self._check_launch(now)
        if self._equivalent:
            self._true_airspeed(ac)
        ac.command(self._desired())
        ac.step(dt)
        self._after_step(events)
        return events

    def _true_airspeed(self, ac: Aircraft) -> None:
        """Fly the airspeed in force (told, else the airframe's cruise) as the equivalent
        airspeed it is to ArduPlane: faster through thinner air (``Firmware.airspeed_scale``),
        followed as the plane climbs or descends (set again once it moved a metre). The
        airframe's stall and maximum airspeeds are equivalent airspeeds too."""
        eas = self.cruise if self.cruise is not None else ac.params.airspeed
        key = round(ac.state.down)
        if key != self._tas_key:
            amsl = self.frames.world.origin.alt - ac.state.down
            self._tas_key, self._tas_scale = key, self.firmware.airspeed_scale(amsl)
        # (each step: a command or a rebuilt airframe may have set others)
        ac.scale_airspeed_range(self._tas_scale)
        ac.set_speed(eas * self._tas_scale)

    def _desired(self) -> Guidance:
        behaviour = self.mode.behaviour
        if not self.armed or behaviour is Behaviour.LAND:
            return Idle()
        if self.takeoff_down is not None:
            return Takeoff(self.takeoff_down)
        if not self.airborne:
            return Idle()
        px4_offboard = behaviour is Behaviour.EXTERNAL and self.firmware.loss_changes_mode
        if px4_offboard and self.setpoint is not None:
            return self.setpoint  # PX4 OFFBOARD flies the latest setpoint
        if self.goal is None:
            if behaviour is Behaviour.RTL:
                self.goal = self._rtl_goal()
            elif behaviour is Behaviour.TAKEOFF:
                self.goal = self._takeoff_in_flight()
            else:
                self.goal = self._hold_here()
        return self.goal

    def _takeoff_in_flight(self) -> Loiter:
        """A take-off mode entered (or armed in) while flying: ArduPlane's ModeTakeoff,
        "Climbing to TKOFF alt then loitering" below TKOFF_ALT above home, "Above TKOFF
        alt - loitering" where it is otherwise. (PX4's AUTO.TAKEOFF: holds here.)"""
        here = self._hold_here()
        if not self.firmware.is_ardupilot:
            return here
        _, _, home_down = self.frames.world.to_ned(self.home)
        return dataclasses.replace(here, down=min(here.down, home_down - self.takeoff_alt))

    def _hold_here(self) -> Loiter:
        s = self._ac().state
        return self._loiter(s.north, s.east, s.down, self.loiter_radius, clockwise=True)

    def _rtl_goal(self) -> Loiter:
        n, e, d = self.frames.world.to_ned(self.home)
        down = min(self._ac().state.down, d - self.rtl_alt)
        return self._loiter(n, e, down, self.loiter_radius, clockwise=True)

    def _loiter(
        self, north: float, east: float, down: float, radius: float, clockwise: bool
    ) -> Loiter:
        """The circle the firmware's navigation flies for a loiter commanded at ``radius``
        (ArduPlane: wider by the air's density, ``Firmware.loiter_scale``)."""
        if radius > 0.0:
            radius *= self.firmware.loiter_scale(self.frames.world.origin.alt - down)
        return Loiter(north, east, down, radius, clockwise)

    def _check_launch(self, now: float) -> None:
        """Start a takeoff when an armed aircraft on the ground is told to fly."""
        ac = self._ac()
        if not self.armed or ac.state.airborne or self.takeoff_down is not None:
            return
        behaviour = self.mode.behaviour
        climb_out = ac.ground_down - self.takeoff_alt
        if behaviour is Behaviour.TAKEOFF:
            self.takeoff_down = climb_out
        elif self.plane:
            return  # GUIDED/OFFBOARD or a reposition on the ground: throttle suppressed
        elif isinstance(self.goal, Loiter):  # a copter told to go somewhere: it lifts off
            self.takeoff_down = min(self.goal.down, climb_out)
        elif behaviour is Behaviour.EXTERNAL and self.firmware.loss_changes_mode:
            sp = self.setpoint
            if sp is None or not self._fresh(now):
                return
            lift = ac.ground_down - _LIFTOFF_AGL
            if sp.down is not None and sp.down < ac.ground_down - 0.5:
                self.takeoff_down = max(sp.down, lift)
            elif sp.down is None and sp.vd is not None and sp.vd < -0.1:
                self.takeoff_down = lift

    def _after_step(self, events: list[Message]) -> None:
        ac = self._ac()
        s = ac.state
        if self.takeoff_down is not None and ac.takeoff_complete:
            done = self.takeoff_down
            self.takeoff_down = None
            if self.mode.behaviour is Behaviour.TAKEOFF and not self.firmware.is_ardupilot:
                self._set_mode(self.firmware.mode(self.firmware.hold))  # PX4: takeoff -> hold
            if self.goal is None:  # hold at the takeoff altitude, not a little short of it
                self.goal = dataclasses.replace(self._hold_here(), down=done)
        goal = self.goal
        if (
            self.mode.behaviour is Behaviour.RTL
            and not self.plane
            and isinstance(goal, Loiter)
            and math.hypot(s.north - goal.north, s.east - goal.east) < _RTL_LAND_RADIUS
            and abs(s.down - goal.down) < 1.0
        ):
            self.goal = Idle()  # over home: land
        if self.armed and self._was_airborne and not s.airborne:
            self._disarm()
            events.append(statustext(_R.MAV_SEVERITY_INFO, "Landing detected, disarmed"))
        self._was_airborne = s.airborne

    def _check_setpoint_loss(self, now: float, events: list[Message]) -> None:
        if not self.armed or self.mode.behaviour is not Behaviour.EXTERNAL or self._fresh(now):
            return
        fw = self.firmware
        if fw.loss_changes_mode:  # PX4 offboard failsafe: hold, reported as a mode change
            self._set_mode(fw.mode(fw.hold))
            self.failsafe = True
            self.counters["setpoint_failsafe"] += 1
            text = "Failsafe: no offboard signal, Hold"
            events.append(statustext(_R.MAV_SEVERITY_CRITICAL, text))
        elif fw.setpoints is SetpointPolicy.FULL and isinstance(self.goal, TrackTarget):
            goal = self.goal
            if goal.vn is None and goal.vd is None:
                return
            # ArduCopter GUIDED: stale velocity targets are zeroed; a position stays.
            self.counters["setpoint_timeout"] += 1
            if goal.north is not None and goal.east is not None:
                self.goal = TrackTarget(goal.north, goal.east, goal.down)
            else:
                self.goal = None  # -> hold where it is

    # --------------------------------------------------------------- setpoints
    def setpoint_local(self, msg: Message, now: float) -> list[Message]:
        """SET_POSITION_TARGET_LOCAL_NED (see ``messages.decode_local_setpoint``)."""
        if self._ignore_setpoint():
            return []
        s = self._ac().state
        if self.firmware.setpoints is SetpointPolicy.ALTITUDE_ONLY:
            # ArduPlane: only LOCAL_OFFSET_NED z, as a change of the loiter altitude.
            if msg.coordinate_frame == _R.MAV_FRAME_LOCAL_OFFSET_NED and not (
                msg.type_mask & _Z_IGNORE
            ):
                return self._plane_altitude(self._plane_goal().down + msg.z)
            self.counters["setpoint_ignored"] += 1
            return []
        target = decode_local_setpoint(msg, self.frames, (s.north, s.east, s.down), s.yaw)
        return self._accept_setpoint(target, now)

    def setpoint_global(self, msg: Message, now: float) -> list[Message]:
        """SET_POSITION_TARGET_GLOBAL_INT (see ``messages.decode_global_setpoint``)."""
        if self._ignore_setpoint():
            return []
        target = decode_global_setpoint(msg, self.frames, self.home.alt)
        if self.firmware.setpoints is SetpointPolicy.ALTITUDE_ONLY:
            if target is None or target.down is None:
                self.counters["setpoint_ignored"] += 1
                return []
            return self._plane_altitude(target.down)
        return self._accept_setpoint(target, now)

    def _ignore_setpoint(self) -> bool:
        """Setpoints dropped outright: ground vehicles, and ArduPilot outside GUIDED."""
        fw = self.firmware
        ignored = fw.setpoints is SetpointPolicy.NONE or (
            fw.is_ardupilot and self.mode.behaviour is not Behaviour.EXTERNAL
        )
        if ignored:
            self.counters["setpoint_ignored"] += 1
        return ignored

    def _accept_setpoint(self, target: TrackTarget | None, now: float) -> list[Message]:
        if target is None:
            self.counters["setpoint_bad_frame"] += 1
            return []
        self.counters["setpoint"] += 1
        self.setpoint, self.setpoint_t = target, now  # PX4 keeps it in any mode
        if self.firmware.is_ardupilot and self.airborne:  # ArduCopter GUIDED
            self.goal = target
            self.takeoff_down = None  # a new target ends a guided takeoff
        return []

    def _plane_goal(self) -> Loiter:
        if not isinstance(self.goal, Loiter):
            self.goal = self._hold_here()
        return self.goal

    def _plane_altitude(self, down: float) -> list[Message]:
        """ArduPlane GUIDED: a setpoint only moves the loiter's altitude."""
        self.counters["setpoint"] += 1
        down = min(down, self._ac().ground_down - _MIN_AGL)
        self.goal = dataclasses.replace(self._plane_goal(), down=down)
        rel = self.frames.down_of(self.home.alt) - down
        return [statustext(_R.MAV_SEVERITY_INFO, f"Change alt to {rel:.1f}")]

    # ----------------------------------------------------------------- commands
    def _refuse(self, text: str, result: int | None = None) -> Outcome:
        result = self.firmware.reject_result if result is None else result
        return result, [statustext(_R.MAV_SEVERITY_CRITICAL, text)]

    def arm_disarm(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_COMPONENT_ARM_DISARM (param1 1 arm / 0 disarm, param2 21196 force)."""
        force = math.isfinite(c.p2) and round(c.p2) == _FORCE_MAGIC
        fw = self.firmware
        if self.aircraft is None:
            self.armed = c.p1 >= 0.5
            return _R.MAV_RESULT_ACCEPTED, []
        if c.p1 < 0.5:
            if self.armed and self.airborne and not force:
                return self._refuse(fw.arm_denied_text("vehicle is flying, not disarming"))
            self._disarm()
            return _R.MAV_RESULT_ACCEPTED, []
        if self.armed:
            return _R.MAV_RESULT_ACCEPTED, []
        reason = None
        px4_offboard = self.mode.behaviour is Behaviour.EXTERNAL and fw.loss_changes_mode
        if not self.warm:
            reason = fw.warmup_reason()
        elif not self.mode.armable:
            reason = f"mode {self.mode.name} not armable"
        elif px4_offboard and not self._fresh(now):
            reason = "no offboard signal"
        if reason is not None and not force:
            return self._refuse(fw.arm_denied_text(reason))
        self.armed = True
        self.goal = None
        if not self.airborne:
            self.set_home(self.position_geo())  # both firmwares move home to where they arm
        return _R.MAV_RESULT_ACCEPTED, [statustext(_R.MAV_SEVERITY_INFO, "Armed")]

    def _disarm(self) -> None:
        self.armed = False
        self.goal = None
        self.takeoff_down = None
        self.failsafe = False

    def request_mode(self, mode: FlightMode | None, now: float) -> Outcome:
        """Switch to ``mode`` if the firmware would (DO_SET_MODE, SET_MODE)."""
        fw = self.firmware
        if mode is None:
            return self._refuse("Unknown flight mode", _R.MAV_RESULT_DENIED)
        if self.aircraft is None or mode == self.mode:
            self.mode = mode
            self.failsafe = False
            return _R.MAV_RESULT_ACCEPTED, []
        reason = None
        if mode.needs_position and not (self.warm or (fw.home_at_fix and self.home_set)):
            reason = "requires position"
        elif mode.behaviour is Behaviour.MISSION:
            reason = "no mission"
        elif mode.behaviour is Behaviour.LAND and self.plane:
            reason = "landing is not simulated for planes"
        elif mode.behaviour is Behaviour.EXTERNAL and fw.loss_changes_mode and not self._fresh(now):
            reason = "no offboard signal"
        if reason is not None:
            return self._refuse(fw.mode_denied_text(mode, reason))
        self._set_mode(mode)
        return _R.MAV_RESULT_ACCEPTED, []

    def _set_mode(self, mode: FlightMode) -> None:
        self.mode = mode
        self.guided_radius = 0.0  # (ArduPlane: ModeGuided::_enter forgets the radius)
        self.goal = None
        self.takeoff_down = None
        self.failsafe = False

    def _flight_checks(self, what: str) -> Outcome | None:
        """Refusal of a command that needs an armed aircraft with a position, if any."""
        if self.aircraft is None:
            return _R.MAV_RESULT_UNSUPPORTED, []
        if not self.armed:
            return self._refuse(f"{what} denied: not armed", _R.MAV_RESULT_DENIED)
        if not self.warm:
            return self._refuse(f"{what} denied: no position", _R.MAV_RESULT_DENIED)
        return None

    def _amsl(self, c: Command, default: float) -> float:
        if not math.isfinite(c.alt):
            return default
        return self.home.alt + c.alt if c.alt_relative else c.alt

    def takeoff(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_NAV_TAKEOFF: param7 altitude (PX4 AMSL, ArduPilot above home).

        PX4 switches to AUTO.TAKEOFF and holds when there; ArduCopter must be in
        GUIDED on the ground and hovers there (setpoints take over); an ArduPlane
        refuses (only a QuadPlane takes off by command: use TAKEOFF mode).
        """
        fw = self.firmware
        if self.plane and fw.is_ardupilot:
            return self._refuse("Takeoff: use TAKEOFF mode", _R.MAV_RESULT_FAILED)
        refusal = self._flight_checks("Takeoff")
        if refusal is not None:
            return refusal
        ac = self._ac()
        default = self.home.alt + self.takeoff_alt
        alt = self._amsl(c, default)
        if fw.is_ardupilot:
            if self.mode.behaviour is not Behaviour.EXTERNAL:
                return self._refuse("Takeoff: mode not GUIDED", _R.MAV_RESULT_FAILED)
            if ac.state.airborne:
                return self._refuse("Takeoff: already flying", _R.MAV_RESULT_FAILED)
            if not alt > self.home.alt:  # param7 0: PILOT_TKOFF_ALT
                alt = default
        elif fw.takeoff is not None and self.mode.name != fw.takeoff:
            self._set_mode(fw.mode(fw.takeoff))
        self.takeoff_down = min(self.frames.down_of(alt), ac.ground_down - _MIN_AGL)
        return _R.MAV_RESULT_ACCEPTED, []

    def reposition(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_DO_REPOSITION: loiter (plane) or hover (copter) at lat/lon/alt.

        param1 ground speed (> 0 applies), param2 bit 0 switches mode (to GUIDED on
        ArduPilot, AUTO.LOITER on PX4), param3/param4 plane loiter radius and
        direction as ``Firmware.loiter_circle`` reads them. NaN position or
        altitude keep the current one. Without the mode bit ArduPilot fails unless
        in GUIDED; PX4 accepts but flies it only in Hold.
        """
        refusal = self._flight_checks("Reposition")
        if refusal is not None:
            return refusal
        fw = self.firmware
        ac = self._ac()
        s = ac.state
        n, e = s.north, s.east
        if math.isfinite(c.lat) and math.isfinite(c.lon):
            n, e, _ = self.frames.world.to_ned(GeoPoint(c.lat, c.lon))
        down = s.down
        if math.isfinite(c.alt):
            down = min(self.frames.down_of(self._amsl(c, 0.0)), ac.ground_down - _MIN_AGL)
        change_mode = math.isfinite(c.p2) and int(c.p2) & _R.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        wanted = fw.external if fw.is_ardupilot and fw.external else fw.hold
        if self.mode.name != wanted:
            if not change_mode:
                return (_R.MAV_RESULT_FAILED if fw.is_ardupilot else _R.MAV_RESULT_ACCEPTED), []
            self._set_mode(fw.mode(wanted))
        radius, clockwise = 0.0, True
        if self.plane:
            # ArduPlane keeps the radius of the last reposition that gave one until
            # GUIDED is entered again (``set_radius_and_direction`` only for param3 > 0):
            # a radius-0 reposition after a 2 km one loiters 2 km around its point.
            kept = self.guided_radius if fw.is_ardupilot else 0.0
            radius, clockwise = fw.loiter_circle(c.p3, c.p4, kept or self.loiter_radius)
            if fw.is_ardupilot and math.isfinite(c.p3) and c.p3 > 0.0:
                self.guided_radius = radius
        if math.isfinite(c.p1) and c.p1 > 0.0:
            self._set_speed(c.p1)
        if s.airborne and not (self.plane and self.takeoff_down is not None):
            self.takeoff_down = None  # a copter goes now; a plane finishes its climb-out
        self.goal = self._loiter(n, e, down, radius, clockwise)
        return _R.MAV_RESULT_ACCEPTED, []

    def _set_speed(self, speed: float) -> None:
        self.cruise = speed
        self._ac().set_speed(speed)

    def change_speed(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_DO_CHANGE_SPEED: param2 speed (m/s, -1 no change)."""
        if self.aircraft is None:
            return _R.MAV_RESULT_UNSUPPORTED, []
        fw = self.firmware
        if fw.is_ardupilot and self.plane:
            if self.mode.behaviour is not Behaviour.EXTERNAL:
                return _R.MAV_RESULT_FAILED, []  # ArduPlane: only in GUIDED (or AUTO)
            p = self._ac().params
            if c.p2 == -2.0:  # back to the default airspeed
                self.cruise = None
                self._ac().set_speed(p.airspeed)
                return _R.MAV_RESULT_ACCEPTED, []
            # Plane::do_change_speed takes an airspeed only inside AIRSPEED_MIN..MAX;
            # another is refused and the one in force kept (not clamped)
            lo, hi = p.min_airspeed_ratio * p.airspeed, p.max_airspeed_ratio * p.airspeed
            if not lo - 1e-6 <= c.p2 <= hi + 1e-6:
                return _R.MAV_RESULT_FAILED, []
        if math.isfinite(c.p2) and c.p2 > 0.0:
            self._set_speed(c.p2)
        return _R.MAV_RESULT_ACCEPTED, []

    def return_to_launch(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_NAV_RETURN_TO_LAUNCH: RTL mode (copter lands at home, plane loiters)."""
        fw = self.firmware
        if self.aircraft is None or fw.rtl is None:
            return _R.MAV_RESULT_UNSUPPORTED, []
        return self.request_mode(fw.mode(fw.rtl), now)

    def land(self, c: Command, now: float) -> Outcome:
        """MAV_CMD_NAV_LAND: LAND mode, descend where it is and disarm on touchdown."""
        fw = self.firmware
        if self.aircraft is None:
            return _R.MAV_RESULT_UNSUPPORTED, []
        if fw.land is None:
            return self._refuse("Landing is not simulated for planes", _R.MAV_RESULT_DENIED)
        return self.request_mode(fw.mode(fw.land), now)
