"""ArduPilot: GUIDED mode, streams by request, planes steered by loiters.

What differs from PX4 (ArduPilot's ``mode.h`` and ``GCS_Mavlink.cpp``):
    * HEARTBEAT.custom_mode is the vehicle's own mode number (Copter GUIDED 4,
      LOITER 5; Plane GUIDED 15, LOITER 12); DO_SET_MODE takes it in param2.
    * Nothing but HEARTBEAT is sent until a ground station asks. Each message is
      asked for with SET_MESSAGE_INTERVAL (ArduPilot >= 4.0); the legacy
      REQUEST_DATA_STREAM groups switch on a whole group each (POSITION brings
      LOCAL_POSITION_NED, EXTRA1 AHRS2 and SIMSTATE, EXTRA3 AHRS, WIND, EKF_STATUS...:
      25 messages a second where 11 are used), and its SRn_* parameters stream
      every group at 1 Hz unasked (SITL: 31 messages a second measured). So every
      group is stopped first (REQUEST_DATA_STREAM ALL, stop), then each message
      is asked for; the groups are asked for only of a firmware that refuses
      SET_MESSAGE_INTERVAL.
    * Refusals are FAILED with a ``PreArm: ...`` / ``Mode change ... failed``
      STATUSTEXT; COMMAND_LONG altitudes are relative to home.
    * ArduCopter: GUIDED, arm, NAV_TAKEOFF (param7 above home), then position
      + velocity + yaw targets exactly as for PX4 (GLOBAL_INT, AMSL).
    * ArduPlane ignores the horizontal part of SET_POSITION_TARGET_*: the arc
      being flown is sent as a DO_REPOSITION loiter (COMMAND_INT, GLOBAL_INT,
      param3 radius, param4 = 1 counter-clockwise), re-sent only when the arc
      changes (or until accepted: a second time 0.1 s on, then each second; and
      again when the target it reports after the ACK is not it), and the
      along-track phase is corrected with rate-limited DO_CHANGE_SPEED. A straight
      segment is flown as a loiter around a point far ahead on the line (a
      "carrot"), moved as the plane
      advances; so is an arc wider than ArduPlane's loiters (65535 m). Its radius
      is given (the plan's tightest arc, at most a quarter of the look-ahead),
      never left 0 once an arc was sent:
      ArduPlane keeps the last radius a reposition gave until GUIDED is entered
      again, so a carrot sent with 0 after a 2 km arc was flown as a 2 km loiter
      around the carrot, away from it (SITL: the plane 1 km off its slot, re-joined;
      holds alike). ArduPlane flies its loiters wide: L1 scales every radius by
      ``EAS2TAS^2`` (6-7 % at 600 m AMSL, from the standard atmosphere at the
      loiter's altitude) and overshoots a tight one (learnt from telemetry); the
      commanded radius is shrunk to match the plan (``loiter.LoiterModel``).
    * ArduPlane armed in GUIDED on the ground keeps its throttle suppressed and
      never leaves the runway: it takes off in TAKEOFF mode (13), which climbs to
      TKOFF_ALT (set first, by PARAM_SET, to the flight altitude above home) and
      loiters there; only then is it switched to GUIDED.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from typing import ClassVar

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import l1_loiter_scale
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.autopilots.base import (
    Autopilot,
    CommandSpec,
    Message,
    PhaseLoop,
    SetupStep,
    SpeedParams,
    VehicleClass,
    global_setpoint,
)
from convoy_mav.mavlink.autopilots.loiter import LoiterModel
from convoy_mav.types import Setpoint

__all__ = ["ROVER_MODES", "ArduCopter", "ArduPilot", "ArduPlane", "ardupilot_mode_name"]

_LEARNT_SAMPLES = 200
"""Loiter samples (10 s at 20 Hz) before the learnt overshoot is trusted to judge a plan."""
_LOITER_RADIUS_MAX = 65535.0  # m: ArduPlane's widest GUIDED loiter (UINT16_MAX)
_TARGET_TOL_E7 = 10  # 1e-7 degrees (about a metre) between a loiter sent and the target reported

_M = mavlink

_COPTER_MODES = {
    0: "STABILIZE",
    1: "ACRO",
    2: "ALT_HOLD",
    3: "AUTO",
    4: "GUIDED",
    5: "LOITER",
    6: "RTL",
    7: "CIRCLE",
    9: "LAND",
    11: "DRIFT",
    13: "SPORT",
    15: "AUTOTUNE",
    16: "POSHOLD",
    17: "BRAKE",
    18: "THROW",
    20: "GUIDED_NOGPS",
    21: "SMART_RTL",
}
_PLANE_MODES = {
    0: "MANUAL",
    1: "CIRCLE",
    2: "STABILIZE",
    3: "TRAINING",
    4: "ACRO",
    5: "FBWA",
    6: "FBWB",
    7: "CRUISE",
    8: "AUTOTUNE",
    10: "AUTO",
    11: "RTL",
    12: "LOITER",
    13: "TAKEOFF",
    14: "AVOID_ADSB",
    15: "GUIDED",
    17: "QSTABILIZE",
    18: "QHOVER",
    19: "QLOITER",
    20: "QLAND",
    21: "QRTL",
}
ROVER_MODES = {
    0: "MANUAL",
    1: "ACRO",
    3: "STEERING",
    4: "HOLD",
    5: "LOITER",
    6: "FOLLOW",
    7: "SIMPLE",
    8: "DOCK",
    9: "CIRCLE",
    10: "AUTO",
    11: "RTL",
    12: "SMART_RTL",
    15: "GUIDED",
    16: "INITIALISING",
}
"""ArduRover's mode numbers (``Rover/mode.h``): the convoy's rovers, not flown here."""


def ardupilot_mode_name(modes: Mapping[int, str], custom_mode: int) -> str:
    """A HEARTBEAT.custom_mode's name in one vehicle's ``modes`` (``"MODE(n)"`` if unknown)."""
    return modes.get(custom_mode, f"MODE({custom_mode})")


_STREAM_GROUPS: Mapping[int, tuple[int, ...]] = {
    _M.MAV_DATA_STREAM_POSITION: (_M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,),
    _M.MAV_DATA_STREAM_EXTRA1: (_M.MAVLINK_MSG_ID_ATTITUDE,),
    _M.MAV_DATA_STREAM_EXTENDED_STATUS: (
        _M.MAVLINK_MSG_ID_SYS_STATUS,
        _M.MAVLINK_MSG_ID_GPS_RAW_INT,
        _M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
        _M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT,
    ),
    _M.MAV_DATA_STREAM_EXTRA3: (_M.MAVLINK_MSG_ID_SYSTEM_TIME,),
}
"""REQUEST_DATA_STREAM groups (ArduPilot's SRn_* parameters) of the messages we use."""


class ArduPilot(Autopilot):
    """What ArduCopter and ArduPlane share: mode numbers and stream requests."""

    name: ClassVar[str] = "ArduPilot"
    modes: ClassVar[Mapping[int, str]] = {}
    reports_target: ClassVar[bool] = True  # (``send_position_target_global_int``)

    def mode_name(self, custom_mode: int) -> str:
        """``"GUIDED"``, ``"LOITER"``... (``"MODE(n)"`` if unknown)."""
        return ardupilot_mode_name(self.modes, custom_mode)

    @property
    def external_mode(self) -> str:
        return "GUIDED"

    @property
    def hold_mode(self) -> str:
        return "LOITER"

    def mode_command(self, name: str) -> CommandSpec:
        number = next((n for n, m in self.modes.items() if m == name), None)
        if number is None:
            raise KeyError(name)
        return CommandSpec.long(
            _M.MAV_CMD_DO_SET_MODE, float(_M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(number)
        )

    def __init__(self, sysid: int, compid: int, frame: LocalFrame, kind: VehicleClass) -> None:
        super().__init__(sysid, compid, frame, kind)
        self.legacy_streams = False
        """SET_MESSAGE_INTERVAL was refused: fall back to the stream groups."""

    def wanted_streams(self, rates: Mapping[int, float]) -> dict[int, float]:
        """``rates`` and its position target at 1 Hz (another controller shows in it)."""
        return {_M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0, **rates}

    def stream_requests(
        self, rates: Mapping[int, float], again: Collection[int] | None = None
    ) -> list[Message]:
        """Every group stopped, then SET_MESSAGE_INTERVAL per message; REQUEST_DATA_STREAM
        per group (integer Hz, the fastest member) once the firmware refused the former.
        Asked ``again`` for some, no group is stopped: a stop that overtook the intervals
        on the link, or arrived without them, would silence the streams flowing."""
        rates = self.wanted_streams(rates)
        out: list[Message] = []
        if not self.legacy_streams:  # (before the intervals: stopping a group stops its members)
            if again is None:
                out.append(
                    _M.MAVLink_request_data_stream_message(
                        self.sysid, self.compid, _M.MAV_DATA_STREAM_ALL, 0, 0
                    )
                )
        else:
            for group, members in _STREAM_GROUPS.items():
                wanted = [rates[m] for m in members if m in rates]
                if wanted and (again is None or any(m in again for m in members)):
                    hz = max(1, math.ceil(max(wanted)))
                    out.append(
                        _M.MAVLink_request_data_stream_message(
                            self.sysid, self.compid, group, hz, 1
                        )
                    )
        return out + super().stream_requests(rates, again)

    def on_ack(self, command: int, result: int, t: float) -> None:
        """A firmware without SET_MESSAGE_INTERVAL gets the stream groups instead."""
        if command == _M.MAV_CMD_SET_MESSAGE_INTERVAL and result in (
            _M.MAV_RESULT_UNSUPPORTED,
            _M.MAV_RESULT_DENIED,
        ):
            self.legacy_streams = True


class ArduCopter(ArduPilot):
    """ArduCopter in GUIDED: position + velocity + yaw targets after NAV_TAKEOFF.

    No speed parameter bounds these targets: GUIDED shapes a position + velocity
    target with ``limit_output`` false (``mode_guided.cpp``, ``posvelaccel_control_run``),
    so ``WPNAV_SPEED`` caps only the correction towards the position, not the
    velocity fed forward. In SITL (4.7.0-dev) three copters with WPNAV_SPEED 700 flew
    the plan's 8 m/s at 8.2 m/s. So its speed range is not asked for; its top speed,
    where its lean at ANGLE_MAX holds it (11.5 m/s in SITL), is seen in flight.
    """

    name: ClassVar[str] = "ArduCopter"
    modes: ClassVar[Mapping[int, str]] = _COPTER_MODES
    lean_param = "ANGLE_MAX"  # (its top speed, where drag balances that lean: seen in flight)
    setup_steps: tuple[SetupStep, ...] = (
        SetupStep.MODE,
        SetupStep.ARM,
        SetupStep.TAKEOFF,
    )

    def __str__(self) -> str:
        return self.name

    def takeoff_command(self, relative_alt: float, amsl: float) -> CommandSpec | None:
        """NAV_TAKEOFF, param7 metres above home (ArduPilot's COMMAND_LONG convention)."""
        return CommandSpec.long(_M.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, relative_alt)

    def setpoint_messages(
        self, sp: Setpoint, t: float, position: tuple[float, float] | None
    ) -> list[Message]:
        return [global_setpoint(sp, self.frame, self.sysid, self.compid, t)]


class ArduPlane(ArduPilot):
    """ArduPlane in GUIDED: DO_REPOSITION loiters plus DO_CHANGE_SPEED for the phase.

    Args (besides the base's):
        retry: Mission seconds before an unacknowledged or refused loiter is re-sent.
        copy_after: Mission seconds before a new loiter is sent the second time, unless
            acknowledged by then (a link quicker than that sends it once).
        speed_interval: Least mission seconds between two DO_CHANGE_SPEED.
        speed_step: Least change (m/s) worth a DO_CHANGE_SPEED.
        carrot: Look-ahead (m) of the loiter point that flies a straight segment.
    """

    name: ClassVar[str] = "ArduPlane"
    commanded_as: ClassVar[str] = "equivalent airspeed"
    modes: ClassVar[Mapping[int, str]] = _PLANE_MODES
    setup_steps: tuple[SetupStep, ...] = (
        SetupStep.TAKEOFF_MODE,
        SetupStep.ARM,
        SetupStep.TAKEOFF,
        SetupStep.MODE,
    )
    takeoff_mode: ClassVar[str | None] = "TAKEOFF"
    speed_params = SpeedParams(  # (DO_CHANGE_SPEED's clamp; named ARSPD_FBW_* before 4.5)
        "AIRSPEED_MAX",
        "AIRSPEED_MIN",
        older=(("ARSPD_FBW_MAX", "AIRSPEED_MAX"), ("ARSPD_FBW_MIN", "AIRSPEED_MIN")),
    )

    retry = 1.0
    copy_after = 0.1
    speed_interval = 1.0
    speed_step = 0.2
    carrot = 600.0
    _MOVE_TOL = 1.0  # m (centre, altitude) and 0.5 m (radius) before a loiter is re-sent
    _RADIUS_TOL = 0.5

    def __str__(self) -> str:
        return self.name

    def takeoff_params(self, relative_alt: float) -> dict[str, float]:
        """TKOFF_ALT: TAKEOFF mode climbs to it (m above home) and loiters there."""
        return {"TKOFF_ALT": round(relative_alt, 1)}

    @staticmethod
    def end_command(action: str) -> CommandSpec | None:
        """ArduPlane cannot land without a landing sequence: ``"land"`` returns home."""
        return Autopilot.end_command("rtl" if action == "land" else action)

    def __init__(self, sysid: int, compid: int, frame: LocalFrame, kind: VehicleClass) -> None:
        super().__init__(sysid, compid, frame, kind)
        self.loiter: tuple[float, float, float, float, bool] | None = None
        """(north, east, down, radius, clockwise) of the last DO_REPOSITION sent."""
        self.loiter_sent_t = -math.inf
        self.loiter_acked = False
        self.loiter_sends = 0
        """Sends of the loiter in force (1: the first)."""
        self.loiter_xy: tuple[int, int] | None = None
        """Its centre as sent (1e-7 degrees), to tell it in the target reported."""
        self.loiter_acked_t = -math.inf
        self.speed: float | None = None
        """The last speed commanded (m/s), None to re-send."""
        self.speed_t = -math.inf
        self.speed_acked = False
        self.counters = {"reposition": 0, "change_speed": 0, "refused": 0, "target_not_ours": 0}
        self.phase = PhaseLoop()
        """The along-track phase loop (its learnt speed offset is the airframe's)."""
        self.model = LoiterModel()
        """How wide this aircraft flies its loiters (learnt while flying them)."""
        self.scale = 1.0
        """L1's density scaling of the last loiter laid (``EAS2TAS^2`` at its altitude)."""
        self.tightest_arc: float | None = None
        """The plan's tightest arc so far (m): the radius of carrots and holds."""
        self.too_tight: float | None = None
        """The largest planned radius no loiter command flies (None: all flyable)."""
        self.arc: tuple[float, float, float, bool] | None = None
        """(north, east, planned radius, clockwise) of the arc being flown, and since when:"""
        self.arc_since = -math.inf

    def reposition(
        self, north: float, east: float, down: float, radius: float, clockwise: bool
    ) -> Message:
        """DO_REPOSITION loiter as COMMAND_INT in MAV_FRAME_GLOBAL_INT (alt AMSL).

        param1 -1 (speed unchanged), param2 0 (no mode change: only flown in
        GUIDED, so a pilot's mode switch is never overridden), param3 radius
        (0: WP_LOITER_RAD) in whole metres, which ArduPlane cuts it to (rounded here,
        not cut: at most half a metre off), param4 1 for counter-clockwise.
        """
        geo = self.frame.to_geo(north, east, down)
        return _M.MAVLink_command_int_message(
            self.sysid, self.compid, _M.MAV_FRAME_GLOBAL_INT, _M.MAV_CMD_DO_REPOSITION, 0, 0,
            -1.0, 0.0, float(round(radius)), 0.0 if clockwise else 1.0,
            round(geo.lat * 1e7), round(geo.lon * 1e7), geo.alt,
        )  # fmt: skip

    def change_speed(self, speed: float) -> Message:
        """DO_CHANGE_SPEED: param1 0 (airspeed), param2 speed, param3 -1 (throttle kept)."""
        return CommandSpec.long(_M.MAV_CMD_DO_CHANGE_SPEED, 0.0, speed, -1.0).message(
            self.sysid, self.compid
        )

    def as_commanded(self, speed: float) -> float:
        """The equivalent airspeed that flies the true ``speed`` at the last loiter's
        altitude: ArduPlane's airspeeds are EAS (TECS flies ``EAS * EAS2TAS``), 3.3 %
        slower than the true airspeed 684 m above the sea and 9 % at 2 km. (SITL's
        planes fly another 3.4 % faster, its pitot dividing by EAS2TAS twice: the phase
        loop learns that part.)"""
        return speed / math.sqrt(self.scale)

    def _loiter_radius(self, sp: Setpoint, scale: float) -> float | None:
        """The radius to command for the arc ``sp`` flies; None to fly it as a straight:
        a hold, no arc, or one wider than ArduPlane takes. ``set_radius_and_direction``
        cuts the radius to 65535 m, and the centre of a wider arc is far off: SITL told
        an arc of 180 km flew at its centre, 190 km away, until the next (re-joined).
        Over the carrot's look-ahead such an arc is within 3 m of its tangent."""
        if sp.hold or sp.center is None or sp.radius <= 0.0:
            return None
        radius = self.model.command_radius(sp.radius, scale)
        return radius if radius <= _LOITER_RADIUS_MAX else None

    def _loiter_for(self, sp: Setpoint) -> tuple[tuple[float, float, float, float, bool], bool]:
        """The loiter that flies ``sp`` (north, east, down, radius, clockwise), and
        whether it is a straight's carrot."""
        scale = self.scale = self._scale(sp.down)
        if sp.hold:
            return (sp.north, sp.east, sp.down, self._point_radius(scale), True), False
        radius = self._loiter_radius(sp, scale)
        if radius is not None and sp.center is not None:
            learnt = self.model.samples >= _LEARNT_SAMPLES
            if learnt and not self.model.feasible(sp.radius, scale):
                self.too_tight = max(self.too_tight or 0.0, sp.radius)
            self.tightest_arc = min(self.tightest_arc or math.inf, sp.radius)
            return (sp.center[0], sp.center[1], sp.down, radius, sp.clockwise), False
        point = self._point_radius(scale)
        v = math.hypot(sp.vn, sp.ve)
        if v < 1e-6:
            return (sp.north, sp.east, sp.down, point, True), True
        k = self.carrot / v
        return (sp.north + k * sp.vn, sp.east + k * sp.ve, sp.down, point, True), True

    def _point_radius(self, scale: float) -> float:
        """The radius of a loiter around a point (a carrot, a hold): the plan's tightest
        arc, at most a quarter of the carrot's look-ahead (flown towards, not around);
        0 (WP_LOITER_RAD) only while no arc was ever sent, for 0 repeats the last
        radius given in this GUIDED, however wide."""
        if self.tightest_arc is None:
            return 0.0
        return self.model.command_radius(min(self.tightest_arc, 0.25 * self.carrot), scale)

    def _scale(self, down: float) -> float:
        """L1's ``EAS2TAS^2`` at a loiter ``down`` metres below the frame's origin."""
        return l1_loiter_scale(self.frame.origin.alt - down)

    def _loiter_changed(self, new: tuple[float, float, float, float, bool], straight: bool) -> bool:
        old = self.loiter
        if old is None or old[4] != new[4] or abs(old[3] - new[3]) > self._RADIUS_TOL:
            return True
        if abs(old[2] - new[2]) > self._MOVE_TOL:
            return True
        moved = math.hypot(old[0] - new[0], old[1] - new[1])
        return moved > (0.1 * self.carrot if straight else self._MOVE_TOL)

    def setpoint_messages(
        self, sp: Setpoint, t: float, position: tuple[float, float] | None
    ) -> list[Message]:
        """DO_REPOSITION when the arc changes (or is unconfirmed), DO_CHANGE_SPEED
        when the phase-corrected speed moved by ``speed_step`` (rate-limited)."""
        out: list[Message] = []
        if position is not None:
            self._learn(sp, t, position)
        loiter, straight = self._loiter_for(sp)
        # Unconfirmed, a new loiter is sent again ``copy_after`` on, then every ``retry``:
        # one lost on the link left the plane on the arc before for a whole retry, and a
        # switch a second late swung it 20-60 m off the next arc (30 % loss each way).
        wait = self.copy_after if self.loiter_sends == 1 else self.retry
        stale = not self.loiter_acked and t - self.loiter_sent_t >= wait
        changed = self._loiter_changed(loiter, straight)
        if changed or stale:
            msg = self.reposition(*loiter)
            out.append(msg)
            self.loiter_xy = (msg.x, msg.y)
            self.loiter, self.loiter_sent_t, self.loiter_acked = loiter, t, False
            self.loiter_sends = 1 if changed else self.loiter_sends + 1
            self.counters["reposition"] += 1
        if sp.hold or position is None or t - self.speed_t < self.speed_interval:
            return out
        speed = self.within_range(self.as_commanded(self.phase.speed(sp, *position, t)))
        # Re-sent, like a loiter, until acknowledged: on a lossy link a lost one left the
        # plane at the speed before for as long as the phase loop asked the same.
        unconfirmed = not self.speed_acked and t - self.speed_t >= self.retry
        changed = self.speed is None or abs(speed - self.speed) >= self.speed_step
        if speed > 0.0 and (changed or unconfirmed):
            out.append(self.change_speed(speed))
            self.speed, self.speed_t, self.speed_acked = speed, t, False
            self.counters["change_speed"] += 1
        return out

    def _learn(self, sp: Setpoint, t: float, position: tuple[float, float]) -> None:
        """Measure how wide the arc in force is flown; a new arc restarts the settling."""
        if sp.center is None or self._loiter_radius(sp, self.scale) is None:
            self.arc = None
            return
        arc = (sp.center[0], sp.center[1], sp.radius, sp.clockwise)
        old = self.arc
        if (
            old is None
            or old[3] != arc[3]
            or math.hypot(old[0] - arc[0], old[1] - arc[1]) > self._MOVE_TOL
            or abs(old[2] - arc[2]) > self._RADIUS_TOL
        ):
            self.arc, self.arc_since = arc, t
            return
        loiter = self.loiter
        if loiter is None or not self.loiter_acked:
            return
        distance = math.hypot(position[0] - loiter[0], position[1] - loiter[1])
        self.model.observe(
            distance, loiter[3], t - self.arc_since, math.hypot(sp.vn, sp.ve), self.scale
        )

    def learnt(self) -> dict[str, float]:
        """The loiter overshoot k (m^2) and density scaling, the tightest loiter flown,
        the speed offset; the airspeed range."""
        return {
            **super().learnt(),
            "loiter_overshoot_m2": round(self.model.k, 1),
            "loiter_scale": round(self.scale, 4),
            "tightest_loiter_m": round(self.model.tightest(self.scale), 1),
            "phase_speed_offset": round(self.phase.bias, 4),
        }

    def cannot_fly(
        self, airspeed: float = 0.0, band: tuple[float, float] = (1.0, 1.0)
    ) -> str | None:
        """The plan's arcs are tighter than any loiter command makes this plane fly, or
        its speeds outside AIRSPEED_MIN..AIRSPEED_MAX."""
        if self.too_tight is None:
            return super().cannot_fly(airspeed, band)
        tightest = self.model.tightest(self.scale)
        return (
            f"flies no loiter tighter than {tightest:.0f} m (its L1 overshoot), the plan "
            f"asks for {self.too_tight:.0f} m: plan with turn_radius_m >= {tightest:.0f}"
        )

    def on_ack(self, command: int, result: int, t: float) -> None:
        """Confirm a loiter; a refused loiter or speed change is re-sent."""
        super().on_ack(command, result, t)
        accepted = result == _M.MAV_RESULT_ACCEPTED
        if command == _M.MAV_CMD_DO_REPOSITION:
            self.loiter_acked = accepted
            self.loiter_acked_t = t
            if not accepted:  # (answered: no copy, a retry)
                self.loiter_sends = max(self.loiter_sends, 2)
                self.counters["refused"] += 1
        elif command == _M.MAV_CMD_DO_CHANGE_SPEED:
            self.speed_acked = accepted
            if not accepted:
                self.speed = None
                self.counters["refused"] += 1

    def on_target(self, lat_e7: int, lon_e7: int, t: float) -> None:
        """A target reported after our loiter's ACK that is not its centre: an older
        loiter of ours overtook it on the link (a retry, jittered), or the ACK was an
        older one's. Sent again at the next setpoint. (Another controller's target
        is ``contest``'s to judge; this only keeps ours in force.)"""
        xy = self.loiter_xy
        if xy is None or not self.loiter_acked or t <= self.loiter_acked_t:
            return  # (a report from before the ACK shows the loiter before)
        if abs(lat_e7 - xy[0]) + abs(lon_e7 - xy[1]) > _TARGET_TOL_E7:
            self.loiter_acked = False
            self.loiter_sent_t = -math.inf
            self.counters["target_not_ours"] += 1

    def reset(self) -> None:
        """Re-send everything at the next setpoint (after a mode change or reboot)."""
        self.loiter = None
        self.loiter_acked = False
        self.speed = None
        self.speed_t = -math.inf
        self.speed_acked = False
        self.arc = None  # (the learnt overshoot stays: it is the airframe's)
