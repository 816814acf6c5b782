"""One UAV as the service sees it: its state, its set-up, its liveness.

A :class:`Vehicle` is skybrush's per-UAV driver: it is fed every decoded message
from its system id (``handle``, synchronous and cheap, dispatched through a dict
of ``handle_<TYPE>`` methods), keeps the last message of each type with the
mission time it arrived, and runs three small tasks (``run``): the life cycle,
the liveness check and our own 1 Hz HEARTBEAT. Everything firmware-specific is
asked of its :class:`~convoy_mav.mavlink.autopilots.Autopilot` strategy, chosen
from the first HEARTBEAT.

Life cycle (``VehicleStatus``)::

    CONNECTING --heartbeat--> WAITING_FIX --fix--> SETTING_UP --steps done--> FLYING
         any --silent lost_after--> LOST --heard again--> WAITING_FIX ... (re-set-up)
         SETTING_UP --setup_timeout--> FAILED        hold() --> HOLDING --resume()--> ...

* Streams are requested right after the first HEARTBEAT (and again when
  position telemetry stops, e.g. after an ArduPilot reboot).
* The fix is GPS_RAW_INT.fix_type >= 3, or SYS_STATUS reporting a healthy GPS,
  plus a GLOBAL_POSITION_INT; the estimator uses it some time later (ArduPilot
  refuses to arm with "Need Position Estimate" for about 40 s after its first
  fix), which HOME_POSITION announces: both firmwares send it once home is set
  from the estimate. Set-up waits for it, or for ``_HOME_WAIT`` after the fix
  (a firmware that never sends it). ``fix_timeout`` lets set-up start without
  a fix (the autopilot then says why it refuses, shown to the operator).
* Set-up steps come from the strategy and are skipped when already true (armed,
  in the right mode, airborne), so a re-set-up after a link outage is quick.
  Commands are retried until COMMAND_ACK: ACCEPTED is done, IN_PROGRESS waits,
  refusals are retried with exponential back-off and reported with the
  autopilot's latest STATUSTEXT; no answer is re-sent after ``command_retry``.
  After ``setup_timeout`` mission seconds the vehicle is FAILED, with a message
  naming it and the autopilot's last reason.
* While the autopilot needs a live stream (PX4 OFFBOARD) and the streamer is
  silent for ``keepalive`` mission seconds (looked at twice a second while
  fed), the vehicle sends its own hold setpoint (the last setpoint's position,
  or where it is at flight altitude); at once after mission time broke (a step
  followed, a silence heard out), since the last setpoint's age is then unknown.
* If the autopilot leaves the external mode on its own while FLYING (a
  failsafe, a pilot), the vehicle goes to HOLDING and says so: the service never
  fights a pilot; ``resume()`` re-engages.

All durations are mission seconds (see :mod:`convoy_mav.clock`).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import math
from collections import Counter, deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock, Observed
from convoy_mav.contest import ControlWatch
from convoy_mav.errors import AutopilotError
from convoy_mav.eventloop import wait_set
from convoy_mav.geo import GeoPoint, LocalFrame, no_position_yet
from convoy_mav.launch import LaunchSequence
from convoy_mav.mavlink.autopilots import (
    DEFAULT_STREAM_RATES,
    FLIGHT_STREAM_RATES,
    ArduPilot,
    Autopilot,
    CommandSpec,
    SetupStep,
    VehicleClass,
    autopilot_for,
    firmware_name,
)
from convoy_mav.mavlink.autopilots.base import param_request_message, param_set_message
from convoy_mav.mavlink.streams import faster_than_asked
from convoy_mav.plausible import JumpGate
from convoy_mav.roundtrip import RoundTrip
from convoy_mav.types import Setpoint, Telemetry, VehicleStatus

__all__ = ["EventKind", "LinkLike", "Vehicle", "VehicleEvent", "refusal_reason"]

log = logging.getLogger(__name__)

Message = Any
_M = mavlink
_S = VehicleStatus
_STREAM_NEEDED = (_S.SETTING_UP, _S.FLYING)

_ARMED = _M.MAV_MODE_FLAG_SAFETY_ARMED
_GPS_BIT = _M.MAV_SYS_STATUS_SENSOR_GPS
_REFUSALS = {
    _M.MAV_RESULT_TEMPORARILY_REJECTED: "TEMPORARILY_REJECTED",
    _M.MAV_RESULT_DENIED: "DENIED",
    _M.MAV_RESULT_FAILED: "FAILED",
}
_REASON_WAIT = 0.3  # mission s to wait for the STATUSTEXT that explains a refusal
_TEXTS_KEPT = 16  # STATUSTEXTs kept to find a refusal's reasons among
_SETTLE_S = 3.0  # mission s after home is set before position jumps are judged
_LISTEN_S = 8.0  # mission s a UAV found flying in the external mode is watched first
_ADOPTED_YIELD_S = 600.0  # mission s a UAV we found flying is yielded to another controller
# (ArduPlane's loiter target changes every half minute or so: the other's shows late)
_XY_IGNORED = _M.POSITION_TARGET_TYPEMASK_X_IGNORE | _M.POSITION_TARGET_TYPEMASK_Y_IGNORE
_CONFIRM_WAIT = 2.5  # mission s for a HEARTBEAT to confirm an accepted mode/arm
_DEAF_TRIES = 5  # unanswered set-up tries before saying the autopilot may not hear us
_FLYING_STATES = (
    _M.MAV_LANDED_STATE_IN_AIR,
    _M.MAV_LANDED_STATE_TAKEOFF,
    _M.MAV_LANDED_STATE_LANDING,
)
_AIRBORNE_AGL = 3.0  # m above home: flying, when no landed state is sent
_PLANE_FLYING_SPEED = 5.0  # m/s over the ground: a plane this slow is not flying
_LANDED_FRESH = 12.0  # mission s a landed state stands for (sent at 0.2 Hz in flight)
_PARAM_TOL = 0.05  # a PARAM_VALUE this close to what was set confirms it
_HOME_WAIT = 60.0  # mission s after the fix that set-up waits for HOME_POSITION at most
_STREAM_RETRY = 5.0  # mission s between stream requests while no position arrives
_CLIMBS = (SetupStep.TAKEOFF, SetupStep.CLIMB)  # set-up steps that end at the flight altitude
_TIMESYNC_EVERY = 1.0  # mission s between two TIMESYNC requests (the link's round trip)
_CARRY_S = 2.0  # mission s a fix is carried on at its velocity to a setpoint's time
_COMMANDS = (_M.MAVLINK_MSG_ID_COMMAND_LONG, _M.MAVLINK_MSG_ID_COMMAND_INT)
_STREAM_WATCH_S = 2.0  # mission s a message asked for may be unheard before it is asked again
_STREAM_WATCH_PERIODS = 5.0  # ...or this many of its periods, if longer
_RATE_WINDOW_S = 10.0  # mission s over which streams are counted against what was asked
_RATE_SETTLE_S = 2.0  # mission s after a request before its streams are counted (a round trip)
_RATE_ASK_MAX_S = 600.0  # mission s at most between asks to slow a stream that goes on
_MSG_NAMES = {i: c.msgname for i, c in _M.mavlink_map.items()}
_MSG_IDS = {name: i for i, name in _MSG_NAMES.items()}
_FED_LOOK = 0.5  # mission s between looks at a fed stream (PX4's COM_OF_LOSS_T: 1 s)
_STREAM_GAP_S = 1.0  # mission s without a setpoint an autopilot may take for a loss (PX4's default)
_OWN_FAILSAFE_S = 10.0  # mission s after a link is back in which a hold is our stream's doing
_REFLY_FAILSAFE_S = 30.0  # mission s after flying again in which a hold is our outage's
_FAILSAFE_TEXT_S = 5.0  # mission s between a stream-loss STATUSTEXT and the hold it explains
_FOREIGN_MODE_S = 5.0  # mission s after another station's mode command is accepted: its hold
_MODE_COMMANDS = (_M.MAV_CMD_DO_SET_MODE, _M.MAVLINK_MSG_ID_SET_MODE)  # what a mode ACK answers
_JUMP_SLACK_M = 50.0  # m a fix may land past max_speed x the time since the last (GPS glitches)
_JUMP_CONFIRM = 5  # agreeing fixes in a row that make a jump the vehicle's own (an estimator reset)
_REJECT_WARN_EVERY = 10.0  # mission s between two warnings of rejected frames of one kind
_FENCE_TRIES = 3  # sends of one fence message that got no answer before the upload gives up
_FENCE_ANSWERS_PER_ITEM = 6  # answers read per fence item at most (duplicates included)
_LAUNCH_NOTE_S = 30.0  # mission s between two notes of a UAV still waiting to launch
_LOST_MARGIN = 1e-3  # mission s past lost_after the watchdog looks (silence must exceed it)


def _is_stream_loss_failsafe(text: str | None) -> bool:
    """Whether an autopilot's STATUSTEXT blames a lost offboard setpoint stream (PX4:
    "Failsafe: no offboard signal", "Offboard signal lost")."""
    if not text:
        return False
    low = text.lower()
    return "offboard" in low and ("signal" in low or "lost" in low or "loss" in low)


def refusal_reason(texts: Iterable[tuple[int, str]]) -> str | None:
    """The reason for a refusal among the STATUSTEXTs (severity, text) since the command.

    The texts of NOTICE or worse, each once, in the order said; with none, the latest.
    ArduCopter answers an arming refused with its checks ("Arm: Gyros inconsistent",
    "Arm: Need Position Estimate", CRITICAL) and may go on with news of its own ("Field
    Elevation Set", INFO) before the reason is read; a mode it refuses with why (NOTICE)
    and that it failed (WARNING). None when nothing was said.
    """
    said = list(texts)
    if not said:
        return None
    serious = [text for severity, text in said if severity <= _M.MAV_SEVERITY_NOTICE]
    return "; ".join(dict.fromkeys(serious)) if serious else said[-1][1]


class LinkLike(Protocol):
    """What a Vehicle needs of its link (``convoy_mav.mavlink.MavLink`` is one)."""

    def send(self, msg: Any) -> bool:
        """Send one message; never blocks; False if it could not go out."""
        ...


class EventKind(StrEnum):
    """What a :class:`VehicleEvent` reports."""

    STATUS = "status"  # a status transition
    SETUP = "setup"  # a set-up step done (parameter set, mode, armed, airborne)
    STATUSTEXT = "statustext"  # a text from the autopilot, as sent
    REFUSED = "refused"  # a set-up command was refused (the autopilot's reason attached)
    FAILED = "failed"  # set-up gave up, or the vehicle cannot be flown
    LOST = "lost"  # silent for lost_after
    RECOVERED = "recovered"  # heard again after LOST
    REBOOTED = "rebooted"  # time_boot_ms jumped back
    REJECTED = "rejected"  # frames dropped: a clock or a position no airframe can reach
    MODE = "mode"  # the autopilot left the external mode on its own
    CONTESTED = "contested"  # another controller drives it (or stopped: ``contested`` says)
    WARNING = "warning"  # anything else the operator should know


@dataclass(frozen=True, slots=True)
class VehicleEvent:
    """Something the operator should see about one vehicle.

    Attributes:
        sysid: The vehicle (its ``uid``: the MAVLink sysid unless configured otherwise).
        t: Mission time, seconds.
        kind: What happened.
        message: One readable line, naming the vehicle.
        status: The vehicle's status after the event.
        severity: MAV_SEVERITY (0 emergency .. 7 debug).
    """

    sysid: int
    t: float
    kind: EventKind
    message: str
    status: VehicleStatus
    severity: int = _M.MAV_SEVERITY_INFO


class _SetupFailed(AutopilotError):
    """Set-up cannot go on; the message is the operator's explanation (never escapes:
    it ends in status FAILED, ``failure`` and a FAILED event)."""


class Vehicle:
    """The driver of one UAV (see the module docstring).

    Args:
        sysid: Its MAVLink system id.
        link: Where to send (``send(msg) -> bool``); incoming messages are
            passed to :meth:`handle` by whoever owns the link.
        clock: The shared mission clock (fed here from ``time_boot_ms``).
        frame: The mission frame.
        on_event: Receives every :class:`VehicleEvent`.
        on_telemetry: Receives each new :class:`Telemetry` (GLOBAL_POSITION_INT).
        setup_timeout: Mission s from first heartbeat to FLYING before FAILED.
        lost_after: Mission s of silence before LOST.
        command_retry: Mission s to wait for a COMMAND_ACK before re-sending, and
            the first back-off after a refusal (doubling up to ``max_backoff``).
        max_backoff: Longest back-off between refused attempts, mission s.
        arm_backoff: Longest back-off between refused ARMs, mission s: an autopilot
            refuses ARM while its checks settle (ArduPilot's ``Need Position
            Estimate`` for 20-45 s after its GPS fix) and arms the moment they pass,
            and its neighbours on the launch sequence wait on it.
        altitude: Flight altitude above the mission origin, m (take-off and own
            hold setpoints).
        fix_timeout: Start set-up after this many mission s without a GPS fix
            (None: wait for one until ``setup_timeout``).
        keepalive: Mission s without a setpoint before the vehicle sends its own
            (only for autopilots that need a live stream).
        stream_rates: Message id -> Hz of mission time to request while setting up.
        flight_stream_rates: The same once FLYING (set-up-only streams slowed down).
        gcs_sysid: Our system id (``[mission] source_system``): COMMAND_ACKs and fence
            upload answers for other ground stations are ignored.
        heartbeat: Send our own HEARTBEAT at 1 Hz (False when the link owner does).
        uid: This UAV's id in the service (clock, telemetry, events, setpoints);
            default ``sysid``. A link is one vehicle, so system ids may repeat
            across links (PX4s leave the factory as sysid 1; a MAVLink network
            has at most 255), as long as uids do not.
        max_speed: Fastest the UAV can move, m/s: a fix farther from the last than
            this allows is dropped (``plausible.JumpGate``), counted and warned of.
        launch: The fleet's launch sequence, asked before arming a UAV on the
            ground (None: it arms when its set-up gets there).

    Attributes:
        status, firmware, telemetry, mode, armed, last_statustext: As named.
        last: Last message of each type; ``last_t``: mission time it arrived.
        failure: Why set-up failed (None otherwise).
        counters: ``ignored``, ``handler_error``, ``commands``, ``refused``,
            ``ack_timeout``, ``setpoints``, ``setpoints_dropped``, ``keepalive``,
            ``send_failed``, ``reboots``...
    """

    def __init__(
        self,
        sysid: int,
        link: LinkLike,
        clock: MissionClock,
        frame: LocalFrame,
        *,
        on_event: Callable[[VehicleEvent], None] | None = None,
        on_telemetry: Callable[[Telemetry], None] | None = None,
        setup_timeout: float = 120.0,
        lost_after: float = 3.0,
        command_retry: float = 1.0,
        max_backoff: float = 10.0,
        arm_backoff: float = 2.0,
        altitude: float = 50.0,
        fix_timeout: float | None = None,
        keepalive: float = 0.3,
        stream_rates: Mapping[int, float] = DEFAULT_STREAM_RATES,
        flight_stream_rates: Mapping[int, float] = FLIGHT_STREAM_RATES,
        gcs_sysid: int = 255,
        heartbeat: bool = True,
        uid: int | None = None,
        max_speed: float = 150.0,
        launch: LaunchSequence | None = None,
    ) -> None:
        self.sysid = sysid
        self.uid = sysid if uid is None else uid
        self.link = link
        self.clock = clock
        self.frame = frame
        self.name = f"convoy[uav{sysid}]"
        self._on_event = on_event
        self._on_telemetry = on_telemetry
        self.setup_timeout = setup_timeout
        self.lost_after = lost_after
        self.command_retry = command_retry
        self.max_backoff = max_backoff
        self.arm_backoff = arm_backoff
        self.altitude = altitude
        self.fix_timeout = fix_timeout
        self.keepalive = keepalive
        self.stream_rates = dict(stream_rates)
        self.flight_stream_rates = dict(flight_stream_rates)
        self.gcs_sysid = gcs_sysid
        self._heartbeat = heartbeat
        self.max_speed = max_speed
        self.launch = launch

        self.status: VehicleStatus = _S.CONNECTING
        self.firmware: Autopilot | None = None
        self.telemetry: Telemetry | None = None
        self.mode = ""
        self.armed = False
        self.home: GeoPoint | None = None
        self.last: dict[str, Message] = {}
        self.last_t: dict[str, float] = {}
        self.failure: str | None = None
        self.params: dict[str, float] = {}
        self.counters: Counter[str] = Counter()
        self.received = 0  # messages from the autopilot (the telemetry budget)
        self._heard_n: dict[str, int] = {}  # messages of the autopilot's, by name
        self._rate_window: tuple[float, dict[str, int]] | None = None  # start, counts then
        self._rate_from = -math.inf  # mission time its streams may be counted from
        self._too_fast: dict[int, tuple[int, float]] = {}  # message -> asks in a row, last
        self.recovered_t = -math.inf  # mission time it was last heard again after LOST
        self.stream_resumed_t = -math.inf  # mission time our setpoints resumed after a gap
        self.reflying_t = -math.inf  # mission time it flew again after a new set-up
        self.foreign_mode_t = -math.inf  # mission time another station's mode change was taken
        self._stream_loss_text_t = -math.inf  # mission time of the last stream-loss STATUSTEXT
        self._failsafe_beat_t = -math.inf  # mission time of its last HEARTBEAT in a failsafe
        # The autopilot's own time (s since boot) of its latest stamp, of that text and of
        # its last fall from our mode: no step of mission time falls between them (a
        # simulator paused, a fleet-wide silence heard out), so they are compared so too.
        self._boot_s = -math.inf
        self._stream_loss_text_boot = -math.inf
        self._left_mode_boot = -math.inf
        self._flown = False
        self.first_heard_t: float | None = None
        # (the latest texts, mission time and severity: the last word, a refusal's reasons)
        self._texts: deque[tuple[float, int, str]] = deque(maxlen=_TEXTS_KEPT)
        self._fix_t: float | None = None  # mission time a fix was first seen
        self._home_t = -math.inf  # mission time home was set (since boot)
        self._gate = JumpGate(max_speed, slack_m=_JUMP_SLACK_M, confirm=_JUMP_CONFIRM)
        self.control = ControlWatch()  # signs of another controller driving it
        self.contested: str | None = None  # why another controller drives it, while it does
        self.ours = False  # set-up went past listening: we command it
        self.refused = False  # another controller drove it first: we backed off
        self._ours_t = -math.inf  # mission time we took it
        self._adopted = False  # found flying under external control when we took it
        self._warned_t: dict[str, float] = {}  # rejected-frame warnings, by kind
        self._heard_t = -math.inf
        self._acks: dict[int, tuple[int, int]] = {}  # command -> (result, seq)
        self._ack_seq = 0
        self._streams_t = -math.inf
        self._asked: dict[int, float] = {}  # message id -> when last asked for
        self.round_trip = RoundTrip()
        """The link's round trips (TIMESYNC, commands): how late setpoints are flown."""
        self._last_sp: Setpoint | None = None
        self._last_sp_t = -math.inf
        self._last_sp_breaks = 0  # the clock's breaks when it was sent
        self._own_sp_t = -math.inf  # when the keepalive last sent one of its own
        self._setup_sent = 0  # setpoints sent since set-up began
        self._airborne_already = False  # set-up found it flying: no take-off
        self._takeoff_accepted = False  # set-up: the take-off mode was ACCEPTED
        self._asked_params: set[str] = set()  # parameters we set or asked for
        self._pad: tuple[float, float] | None = None  # climbing out straight up from it
        self._hold_requested = False
        self._unsupported = False
        self._compid = _M.MAV_COMP_ID_AUTOPILOT1  # the autopilot's, once its HEARTBEAT says
        self._changed = asyncio.Event()
        self._start = asyncio.Event()
        self._session: asyncio.Task[None] | None = None
        self._handlers: dict[str, Callable[[Message, float], None]] = {
            "HEARTBEAT": self.handle_HEARTBEAT,
            "COMMAND_ACK": self.handle_COMMAND_ACK,
            "STATUSTEXT": self.handle_STATUSTEXT,
            "GLOBAL_POSITION_INT": self.handle_GLOBAL_POSITION_INT,
            "HOME_POSITION": self.handle_HOME_POSITION,
            "PARAM_VALUE": self.handle_PARAM_VALUE,
            "POSITION_TARGET_GLOBAL_INT": self.handle_POSITION_TARGET_GLOBAL_INT,
            "TIMESYNC": self.handle_TIMESYNC,
            "MISSION_ACK": self._on_mission_reply,
            "MISSION_REQUEST_INT": self._on_mission_reply,
            "MISSION_REQUEST": self._on_mission_reply,
        }
        self._fence_replies: deque[Message] | None = None  # while a fence upload runs

    def __repr__(self) -> str:
        return f"<Vehicle {self.sysid} {self.firmware or '?'} {self.status}>"

    # ================================================================= queries
    @property
    def position(self) -> tuple[float, float] | None:
        """Latest (north, east) in the mission frame, if any."""
        tel = self.telemetry
        return None if tel is None else (tel.north, tel.east)

    def _fix_carried_to(self, t: float) -> tuple[float, float] | None:
        """Where the latest fix puts the vehicle at mission time ``t`` (a setpoint's,
        ``setpoint_lead`` ahead, to be compared with it): carried on at its velocity,
        for ``_CARRY_S`` at most; None from an older fix (a telemetry gap: no phase
        correction from it)."""
        tel = self.telemetry
        if tel is None:
            return None
        dt = max(t - tel.t, 0.0)
        if dt > _CARRY_S:
            return None
        return tel.north + tel.vn * dt, tel.east + tel.ve * dt

    @property
    def setpoint_lead(self) -> float:
        """Mission seconds ahead to sample its setpoints: the link's round trip, by
        which they are flown late (``roundtrip``)."""
        return self.round_trip.lead

    @property
    def last_setpoint(self) -> Setpoint | None:
        """The setpoint sent last (the plan's, or one of its own while holding)."""
        return self._last_sp

    @property
    def has_fix(self) -> bool:
        """A 3D GPS fix (or a healthy GPS in SYS_STATUS) and a position."""
        if self.telemetry is None:
            return False
        gps = self.last.get("GPS_RAW_INT")
        if gps is not None and gps.fix_type >= _M.GPS_FIX_TYPE_3D_FIX:
            return True
        sys = self.last.get("SYS_STATUS")
        return bool(
            sys is not None
            and sys.onboard_control_sensors_present & _GPS_BIT
            and sys.onboard_control_sensors_health & _GPS_BIT
        )

    def _estimate_ready(self) -> bool:
        """A fix the estimator uses: home announced, or long enough after the fix."""
        if not self.has_fix:
            return False
        now = self.clock.now()
        if self._fix_t is None:
            self._fix_t = now
        return self.home is not None or now - self._fix_t >= _HOME_WAIT

    def _settled(self, now: float) -> bool:
        """Is its estimate settled (home set a while ago, or long after the fix), so a
        jump in its position is a forger's or a glitch, not the estimator finding its
        origin? (ArduPlane sends HOME_POSITION just before its altitude jumps to AMSL.)"""
        return (self.home is not None and now - self._home_t >= _SETTLE_S) or (
            self._fix_t is not None and now - self._fix_t >= _HOME_WAIT
        )

    @property
    def airborne(self) -> bool:
        """Whether the autopilot says it is flying; never assumed from being armed.

        EXTENDED_SYS_STATE's landed state decides where it is sent and fresh (an
        ArduPlane armed in GUIDED on the runway is ON_GROUND); otherwise height above
        home, and for a plane, which cannot hover, a flying ground speed as well.
        """
        now = self.clock.now()
        ext = self.last.get("EXTENDED_SYS_STATE")
        if (
            ext is not None
            and ext.landed_state != _M.MAV_LANDED_STATE_UNDEFINED
            and now - self.last_t["EXTENDED_SYS_STATE"] <= _LANDED_FRESH
        ):
            return bool(ext.landed_state in _FLYING_STATES)
        rel = self.relative_alt
        if rel is None or rel <= _AIRBORNE_AGL:
            return False
        ap = self.firmware
        if ap is None or ap.kind is not VehicleClass.PLANE:
            return True
        gpi = self.last["GLOBAL_POSITION_INT"]
        return math.hypot(gpi.vx, gpi.vy) * 0.01 >= _PLANE_FLYING_SPEED

    @property
    def relative_alt(self) -> float | None:
        """Height above home (m) from GLOBAL_POSITION_INT, if any."""
        gpi = self.last.get("GLOBAL_POSITION_INT")
        return None if gpi is None else gpi.relative_alt * 1e-3

    # ================================================================ inbound
    def handle(self, msg: Message) -> None:
        """Take one decoded message (any sysid; others are counted and ignored)."""
        if msg.get_srcSystem() != self.sysid:
            self.counters["ignored"] += 1
            return
        boot_ms = getattr(msg, "time_boot_ms", None)
        # (a camera or companion has a boot clock of its own)
        if boot_ms is not None and msg.get_srcComponent() == self._compid:
            if self._observe_boot(boot_ms) is Observed.REJECTED:
                self._reject(
                    "clock_jump", f"time_boot_ms {boot_ms} is ahead of its clock; frame dropped"
                )
                return
            self._boot_s = boot_ms / 1000.0
        now = self.clock.now()
        self._heard_t = now
        self.received += 1
        if self.first_heard_t is None and self.clock.synced:
            self.first_heard_t = now
        kind = msg.get_type()
        self.last[kind] = msg
        self.last_t[kind] = now
        if msg.get_srcComponent() == self._compid:
            heard = self._heard_n
            heard[kind] = heard.get(kind, 0) + 1
        handler = self._handlers.get(kind)
        if handler is not None:
            try:
                handler(msg, now)
            except Exception:
                self.counters["handler_error"] += 1
                if self.counters["handler_error"] == 1:
                    log.exception("%s: handler for %s failed", self.name, kind)
        if self.status is _S.LOST and self.firmware is not None:
            self.recovered_t = now
            self._set_status(_S.WAITING_FIX)
            self._emit(EventKind.RECOVERED, "heard again; setting up anew", _M.MAV_SEVERITY_NOTICE)
            self._start.set()
        self._changed.set()

    def _reject(self, kind: str, text: str) -> None:
        """Count a dropped frame; warn the operator (not more than every few seconds)."""
        self.counters[kind] += 1
        now = self.clock.now()
        if now - self._warned_t.get(kind, -math.inf) >= _REJECT_WARN_EVERY:
            self._warned_t[kind] = now
            total = self.counters[kind]
            self._emit(EventKind.REJECTED, f"{text} ({total} so far)", _M.MAV_SEVERITY_WARNING)

    def _observe_boot(self, boot_ms: int) -> Observed:
        seen = self.clock.observe(boot_ms, self.uid)  # (it tells a reboot from reordering)
        if seen is Observed.REBOOTED:
            self.counters["reboots"] += 1
            self._stream_loss_text_boot = self._left_mode_boot = -math.inf  # (another boot)
            self.home = None  # (set anew by the estimator)
            self._emit(EventKind.REBOOTED, "autopilot rebooted", _M.MAV_SEVERITY_WARNING)
            if self.firmware is not None:
                self.firmware.reset()
                self._request_streams()
            if not self._hold_requested and self.status in (_S.SETTING_UP, _S.FLYING, _S.HOLDING):
                self._interrupt()
                self._start.set()
        return seen

    def handle_HEARTBEAT(self, msg: Message, now: float) -> None:
        """Recognise the firmware; track mode and armed state."""
        if msg.autopilot == _M.MAV_AUTOPILOT_INVALID:
            return  # a GCS, gimbal or camera sharing the sysid: not the autopilot
        ap = self.firmware
        if ap is None:
            ap = autopilot_for(
                msg.autopilot, msg.type, self.sysid, msg.get_srcComponent(), self.frame
            )
            if ap is None:
                self._refuse_unsupported(msg)
                return
            self.firmware = ap
            self._compid = ap.compid
            self._emit(EventKind.STATUS, f"recognised {ap}")
            if self.status is _S.CONNECTING:
                self._start.set()
        elif msg.get_srcComponent() != ap.compid:
            return
        self.armed = bool(msg.base_mode & _ARMED)
        if msg.system_status == _M.MAV_STATE_CRITICAL:
            self._failsafe_beat_t = now  # (on the very HEARTBEAT that shows its failsafe mode)
        mode, self.mode = self.mode, ap.mode_name(msg.custom_mode)
        if self.status is _S.FLYING and mode == ap.external_mode != self.mode:
            self._left_mode_boot = self._boot_s
            self._emit(
                EventKind.MODE,
                f"autopilot left {mode} for {self.mode} (failsafe or pilot); "
                "not taking control back until resumed",
                _M.MAV_SEVERITY_WARNING,
            )
            self._set_status(_S.HOLDING)

    def _refuse_unsupported(self, msg: Message) -> None:
        if self._unsupported:
            return
        self._unsupported = True
        self.failure = (
            f"UAV {self.sysid}: {firmware_name(msg.autopilot)} with vehicle type {msg.type} "
            "is not supported (PX4 or ArduPilot planes and copters only)"
        )
        self.status = _S.FAILED
        self._emit(EventKind.FAILED, self.failure, _M.MAV_SEVERITY_ERROR)

    def handle_COMMAND_ACK(self, msg: Message, now: float) -> None:
        """Record the result for a waiting command; tell the strategy."""
        target = getattr(msg, "target_system", 0)
        if target not in (0, self.gcs_sysid):
            # The answer to another ground station (seen where the link is shared: a
            # router, a radio, one UDP port). Its mode command taken is the sign a mode
            # change that follows is its, not our stream's failsafe (``hold_is_ours``).
            if msg.command in _MODE_COMMANDS and msg.result == _M.MAV_RESULT_ACCEPTED:
                self.foreign_mode_t = now
                self.counters["foreign_mode"] += 1
            return
        self._ack_seq += 1
        self._acks[msg.command] = (msg.result, self._ack_seq)
        self.round_trip.answered(msg.command, now)
        if self.firmware is not None:
            self.firmware.on_ack(msg.command, msg.result, now)

    def handle_STATUSTEXT(self, msg: Message, now: float) -> None:
        """Keep the latest text (a refusal's reason) and pass it on to the operator."""
        text = msg.text if isinstance(msg.text, str) else bytes(msg.text).decode(errors="replace")
        text = text.rstrip("\x00").strip()
        self._texts.append((now, int(msg.severity), text))
        if _is_stream_loss_failsafe(text):
            self._stream_loss_text_t = now
            self._stream_loss_text_boot = self._boot_s
        self._emit(EventKind.STATUSTEXT, text, int(msg.severity))

    def handle_GLOBAL_POSITION_INT(self, msg: Message, now: float) -> None:
        """Position, velocity and heading into the mission frame."""
        if no_position_yet(msg.lat, msg.lon):
            self.counters["no_position_yet"] += 1
            return
        lat, lon, alt = msg.lat * 1e-7, msg.lon * 1e-7, msg.alt * 1e-3
        north, east, down = self.frame.to_ned(GeoPoint(lat, lon, alt))
        vn, ve, vd = msg.vx * 0.01, msg.vy * 0.01, msg.vz * 0.01
        if msg.hdg != 0xFFFF:
            yaw = math.remainder(math.radians(msg.hdg * 0.01), math.tau)
        elif now - self.last_t.get("ATTITUDE", -math.inf) < 1.0:  # (a watch in flight: stale)
            yaw = self.last["ATTITUDE"].yaw
        else:
            yaw = math.atan2(ve, vn)
        t = self.clock.to_mission(msg.time_boot_ms, self.uid)
        tel = Telemetry(self.uid, t, north, east, down, vn, ve, vd, yaw, lat, lon, alt)
        if not self._settled(now):  # (ArduPilot's altitude jumps to AMSL as it settles)
            self._gate.seed(t, north, east, down)
        elif not self._gate.admit(t, north, east, down):  # (``plausible.JumpGate``)
            self._reject(
                "position_jump",
                f"position {lat:.6f}, {lon:.6f} is farther than it can have flown; fix dropped",
            )
            return
        self.telemetry = tel
        if self._on_telemetry is not None:
            self._on_telemetry(tel)

    def handle_PARAM_VALUE(self, msg: Message, now: float) -> None:
        """Keep every parameter value the autopilot reports (confirms a PARAM_SET)."""
        name = msg.param_id if isinstance(msg.param_id, str) else bytes(msg.param_id).decode()
        name = name.rstrip("\x00")
        self.params[name] = float(msg.param_value)
        if name in self._asked_params:  # (an answer to us: not a change it announces)
            self.counters["param_answers"] += 1
        if self.firmware is not None:
            self.firmware.on_param(name, float(msg.param_value))
        if name == "SIM_SPEEDUP":  # a simulator says at what rate its clock runs now
            self.clock.rate_set(float(msg.param_value), self.uid)

    def handle_POSITION_TARGET_GLOBAL_INT(self, msg: Message, now: float) -> None:
        """Where the autopilot is going: ours, or another controller's (``contest``)."""
        ap = self.firmware
        if (
            ap is None
            or not ap.reports_target
            or self.mode != ap.external_mode  # (a take-off, a hold: the autopilot's own)
            or self.status is _S.HOLDING  # (told to hold or return: its HEARTBEAT may lag)
            or msg.type_mask & _XY_IGNORED
        ):
            return
        if msg.lat_int or msg.lon_int:  # (0, 0: no target yet)
            self.control.reported(now, msg.lat_int, msg.lon_int)
            self._check_control(now)
            if self.contested is None:  # (no fight made fiercer: the operator decides)
                t = self.clock.to_mission(msg.time_boot_ms, self.uid)
                ap.on_target(msg.lat_int, msg.lon_int, t)

    def stranger(self, what: str) -> None:
        """Another controller's frame for this vehicle was seen on its link."""
        now = self.clock.now()
        self.control.stranger(now, what)
        self._check_control(now)

    def _check_control(self, now: float) -> None:
        """Refuse a UAV another controller drives before we fly it, or one we found flying
        under external control and took (we are the second service: we back off, in our
        first ``_ADOPTED_YIELD_S`` of it); alarm one we launched (the operator decides:
        two controllers fight, and neither covers)."""
        reason = self.control.check(now)
        if reason == self.contested:
            return
        self.contested = reason
        if reason is None:
            if not self.refused:  # (a refused UAV's contest was never alarmed)
                self._emit(EventKind.CONTESTED, "no other controller seen for a while")
            return
        if not self.ours or (self._adopted and now - self._ours_t < _ADOPTED_YIELD_S):
            self._interrupt()
            self.ours = False
            self.refused = True
            self.failure = self._refusal(reason)
            self._set_status(_S.FAILED)
            self._emit(EventKind.FAILED, self.failure, _M.MAV_SEVERITY_ERROR)
            return
        self._emit(
            EventKind.CONTESTED,
            f"another controller drives it too ({reason}): stop it, or take the UAV out",
            _M.MAV_SEVERITY_WARNING,
        )

    def _refusal(self, reason: str) -> str:
        return (
            f"UAV {self.sysid}: refused: another ground station is driving it ({reason}); "
            "stop it, or give this service other UAVs"
        )

    def handle_HOME_POSITION(self, msg: Message, now: float) -> None:
        """Home moves when the vehicle arms: the take-off altitude is relative to it."""
        if self.home is None:
            self._home_t = now
        self.home = GeoPoint(msg.latitude * 1e-7, msg.longitude * 1e-7, msg.altitude * 1e-3)

    # =============================================================== outbound
    def _send(self, msg: Message) -> None:
        if not self.link.send(msg):
            self.counters["send_failed"] += 1
            return
        kind = msg.get_msgId()  # (our position targets, to tell them from another's)
        if kind in _COMMANDS:
            self.round_trip.sent(msg.command, self.clock.now())
        if kind == _M.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT:
            if not msg.type_mask & _XY_IGNORED:
                self.control.sent(self.clock.now(), msg.lat_int, msg.lon_int)
        elif kind == _M.MAVLINK_MSG_ID_COMMAND_INT and msg.command == _M.MAV_CMD_DO_REPOSITION:
            self.control.sent(self.clock.now(), msg.x, msg.y)

    def send_param_set(self, name: str, value: float) -> bool:
        """Send one PARAM_SET of ``name`` (its PARAM_VALUE lands in ``params``); False if
        the autopilot is not recognised yet."""
        ap = self.firmware
        if ap is None:
            return False
        self._send(param_set_message(self.sysid, ap.compid, name, value))
        self._asked_params.add(name)
        self.counters["param_set"] += 1
        return True

    def send_setpoint(self, sp: Setpoint) -> None:
        """Fly ``sp`` now (FLYING; also SETTING_UP for autopilots needing a stream).

        Otherwise (connecting, holding, lost...) the setpoint is dropped and counted.
        """
        ap = self.firmware
        st = self.status
        if ap is None or not (st is _S.FLYING or (st is _S.SETTING_UP and ap.streams_during_setup)):
            self.counters["setpoints_dropped"] += 1
            return
        if self._pad is not None:
            sp = self._climb_out(sp)
        elif not sp.hold:
            ap.asked(sp)
        now = self.clock.now()
        if math.isfinite(self._last_sp_t) and now - self._last_sp_t > _STREAM_GAP_S:
            self.stream_resumed_t = now  # (a gap: the autopilot may have failed safe meanwhile)
        for msg in ap.setpoint_messages(sp, now, self._fix_carried_to(sp.t)):
            self._send(msg)
        self._last_sp, self._last_sp_t = sp, now
        self._last_sp_breaks = self.clock.breaks
        self._setup_sent += 1
        self.counters["setpoints"] += 1

    def _climb_out(self, sp: Setpoint) -> Setpoint:
        """The flight altitude straight above the pad, instead of ``sp``, until set-up is
        done (an autopilot that takes off on setpoints alone would climb towards ``sp``
        on a slant, through its neighbours' climb-outs)."""
        assert self._pad is not None
        north, east = self._pad
        return Setpoint(sp.t, north, east, -self.altitude, 0.0, 0.0, 0.0, sp.yaw, 0.0)

    def hold_setpoint(self) -> Setpoint | None:
        """The hold the keepalive would send, now, for an autopilot that needs a live
        stream (PX4 OFFBOARD) while it has nothing else to fly (None otherwise).

        The streamer sends it while the mission has no slot for the UAV (set up, its
        join still being planned): left to the keepalive, which looks twice a second
        while the stream is fed, the stream could stop for half a second at every
        join, half PX4's default ``COM_OF_LOSS_T`` and all of a shorter one.
        """
        ap = self.firmware
        if ap is None or not ap.streams_during_setup or self.status not in _STREAM_NEEDED:
            return None
        return self._own_setpoint()

    def _own_setpoint(self) -> Setpoint | None:
        """Hold where the last setpoint was, or where the UAV is at flight altitude."""
        now = self.clock.now()
        if self._last_sp is not None:
            sp = self._last_sp
            return Setpoint(now, sp.north, sp.east, sp.down, 0.0, 0.0, 0.0, sp.yaw, 0.0, hold=True)
        tel = self.telemetry
        if tel is None:
            return None
        return Setpoint(now, tel.north, tel.east, -self.altitude, 0, 0, 0, tel.yaw, 0, hold=True)

    def _stream_rates(self) -> Mapping[int, float]:
        return self.flight_stream_rates if self.status is _S.FLYING else self.stream_rates

    def _request_streams(self, *, fresh: bool = True) -> None:
        """Ask for the streams; ``fresh`` stops every other first (ArduPilot's boot
        groups), which only the first request of a set-up, or after a reboot, needs: a
        stop lost or overtaken on the link silences what the requests with it start."""
        ap = self.firmware
        if ap is None:
            return
        rates = self._stream_rates()
        wanted = ap.wanted_streams(rates)
        for msg in ap.stream_requests(rates, None if fresh else wanted.keys()):
            self._send(msg)
        now = self.clock.now()
        self._asked = {m: now for m, hz in wanted.items() if hz > 0.0}
        self._rate_window, self._rate_from = None, now + _RATE_SETTLE_S
        # the speed range, with the streams: as often as they are asked for, until read
        for name in ap.unread_speed_params():
            self._send(param_request_message(self.sysid, ap.compid, name))
            self._asked_params.add(name)
        self._streams_t = self.clock.now()
        self.counters["stream_requests"] += 1

    def _emit(self, kind: EventKind, text: str, severity: int = _M.MAV_SEVERITY_INFO) -> None:
        who = f"UAV {self.sysid}" + (f" ({self.firmware})" if self.firmware else "")
        message = text if text.startswith("UAV ") else f"{who}: {text}"
        event = VehicleEvent(self.uid, self.clock.now(), kind, message, self.status, severity)
        if severity <= _M.MAV_SEVERITY_WARNING:
            level = logging.WARNING
        else:  # the autopilot's chatter (INFO texts) is detail; our own events are news
            level = logging.DEBUG if kind is EventKind.STATUSTEXT else logging.INFO
        log.log(level, "%s", message)
        if self._on_event is not None:
            try:
                self._on_event(event)
            except Exception:
                log.exception("%s: on_event failed", self.name)

    def _set_status(self, status: VehicleStatus) -> None:
        if status is not self.status:
            if status is _S.FLYING:
                if self._flown:  # (set up again: a hold of its own may still be reported)
                    self.reflying_t = self.clock.now()
                self._flown = True
            self.status = status
            self._emit(EventKind.STATUS, str(status))

    # ================================================================== tasks
    async def run(self) -> None:
        """Life cycle and watchdog tasks; runs until cancelled."""
        async with asyncio.TaskGroup() as tg:
            tg.create_task(self._lifecycle(), name=f"{self.name}.lifecycle")
            tg.create_task(self._watchdog(), name=f"{self.name}.watchdog")

    async def _watchdog(self) -> None:
        """Our heartbeat, liveness, and the keepalive of autopilots needing a stream.

        One task, one timer, since a fleet pays per wake-up: it wakes for the
        next heartbeat (1 Hz of mission time), and for the instant the vehicle
        would have been silent for ``lost_after`` -- which every message heard
        pushes back, so a live vehicle costs one wake-up a second, and a silent
        one is declared lost on time, not at the next poll. While the stream is
        needed it looks for a quiet stream every ``_FED_LOOK`` while the streamer
        feeds it (not every ``keepalive``: a fed fleet would pay several wake-ups a
        second per vehicle for nothing), and keeps it alive every ``keepalive`` once
        it has gone quiet: the longest silence PX4 sees is about half a second,
        half its default COM_OF_LOSS_T.
        """
        hb = _M.MAVLink_heartbeat_message(
            _M.MAV_TYPE_GCS, _M.MAV_AUTOPILOT_INVALID, 0, 0, _M.MAV_STATE_ACTIVE, 3
        )
        clock = self.clock
        next_hb = next_sync = -math.inf
        while not clock.synced:  # nobody heard yet: no mission time to pace by
            if not self._heartbeat:
                await clock.wait_synced()
                break
            self._send(hb)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(0.5):  # (wall s; see eventloop.wait_set)
                    await clock.wait_synced()
        if self._heard_t > -math.inf:  # heard before mission time began: heard at its start
            self._heard_t = max(self._heard_t, clock.now())
        while True:
            now = clock.now()
            due = now + 1.0
            if self._heartbeat:
                if now >= next_hb:
                    self._send(hb)
                    next_hb = now + 1.0
                due = next_hb
            self._check_liveness(now)
            if self.contested is not None:
                self._check_control(now)  # (free again after a quiet while)
            ap = self.firmware
            if ap is not None and self.status not in (_S.CONNECTING, _S.LOST):
                due = min(due, max(self._heard_t + self.lost_after, now) + _LOST_MARGIN)
                if now >= next_sync:
                    self._time_link(now)
                    next_sync = now + _TIMESYNC_EVERY
            if ap is not None and ap.streams_during_setup and self.status in _STREAM_NEEDED:
                if self._setpoint_age(now) >= self.keepalive:
                    sp = self._own_setpoint()
                    if sp is not None:
                        self.counters["keepalive"] += 1
                        self.send_setpoint(sp)
                        self._own_sp_t = self._last_sp_t
                fed = self._last_sp_t > self._own_sp_t
                look = max(
                    self._last_sp_t + self.keepalive,
                    now + (_FED_LOOK if fed else self.keepalive / 3.0),
                )
                due = min(due, look)
            await clock.sleep_until(due)

    def _setpoint_age(self, now: float) -> float:
        """Mission s since the last setpoint; unknown (inf) across a break of mission
        time. A step back after the host stalled (a simulator slipping its clock) would
        otherwise date the last setpoint up to the whole step ahead of the autopilot's
        clock, and the keepalive would wait that long while PX4 times out."""
        if self.clock.breaks != self._last_sp_breaks:
            return math.inf
        return now - self._last_sp_t

    def _time_link(self, now: float) -> None:
        """A TIMESYNC request (``tc1`` 0, ``ts1`` now in ns): its answer times the link."""
        ts1 = max(round(now * 1e9), 0)
        self._send(_M.MAVLink_timesync_message(0, ts1))
        self.round_trip.sent(("timesync", ts1), now)

    def handle_TIMESYNC(self, msg: Message, now: float) -> None:
        """An answer to our TIMESYNC (``ts1`` echoed): the link's round trip. (A request
        of the autopilot's own, ``tc1`` 0, is not answered: nothing here needs it.)"""
        if msg.tc1 != 0:
            self.round_trip.answered(("timesync", msg.ts1), now)

    @property
    def heard_t(self) -> float:
        """Mission time this vehicle was last heard (-inf: never)."""
        return self._heard_t

    def _check_liveness(self, now: float) -> None:
        if self.status in (_S.CONNECTING, _S.LOST) or self.firmware is None:
            return
        silent = now - self._heard_t
        if silent > self.lost_after:
            self._interrupt()
            self._set_status(_S.LOST)
            self._emit(EventKind.LOST, f"silent for {silent:.1f} s", _M.MAV_SEVERITY_CRITICAL)
            return
        no_position = now - self.last_t.get("GLOBAL_POSITION_INT", -math.inf)
        if no_position > 2 * self.lost_after and now - self._streams_t > _STREAM_RETRY:
            self._request_streams()  # heartbeats only: streams were forgotten (reboot)
        else:
            self._watch_streams(now)

    def _watch_streams(self, now: float) -> None:
        """Ask once more for each message asked for but not heard while the vehicle is.

        One request lost on the link (a set-up's GPS_RAW_INT: set-up waited 120 s for a
        fix it was never sent; a flight's GLOBAL_POSITION_INT: the plane flown blind)
        would otherwise stand until the whole set was asked for again. A message the
        firmware does not send (no home yet) is asked for every few of its periods.
        """
        ap = self.firmware
        if ap is None or now - self._heard_t > self.lost_after:
            return  # (a silent link is the liveness check's)
        rates = ap.wanted_streams(self._stream_rates())
        self._watch_rates(now, ap, rates)
        again = [
            m
            for m, t in self._asked.items()
            if m in rates
            and now - max(t, self.last_t.get(_MSG_NAMES[m], -math.inf))
            >= max(_STREAM_WATCH_S, _STREAM_WATCH_PERIODS / rates[m])
        ]
        if not again:
            return
        for msg in ap.stream_requests(rates, again):
            self._send(msg)
        for m in again:
            self._asked[m] = now
        # (counted if it flowed before: one not sent yet, ArduCopter's position target
        # outside GUIDED, a home not yet set, is no loss)
        self.counters["streams_asked_again"] += sum(_MSG_NAMES[m] in self.last_t for m in again)

    def _watch_rates(self, now: float, ap: Autopilot, rates: Mapping[int, float]) -> None:
        """Ask again, every ``_RATE_WINDOW_S``, for each stream that flowed faster than
        asked for (``faster_than_asked``): its rate's change lost on the link, or the stop
        of a stream never asked for (ArduPilot's boot groups, PX4's profile); by message,
        SET_MESSAGE_INTERVAL (-1 stops it), so nothing races a stop on the link."""
        if now < self._rate_from:
            return
        window = self._rate_window
        self._rate_window = (now, dict(self._heard_n)) if window is None else window
        if window is None or now - window[0] < _RATE_WINDOW_S:
            return
        start, before = window
        self._rate_window = (now, dict(self._heard_n))
        counts = {k: n - before.get(k, 0) for k, n in self._heard_n.items()}
        asked = {_MSG_NAMES[m]: hz for m, hz in rates.items()}
        asked.setdefault("TIMESYNC", 1.0 / _TIMESYNC_EVERY)  # (the answers to ours)
        found = faster_than_asked(counts, now - start, asked)
        flowing = [_MSG_IDS[k] for k in found if k in _MSG_IDS]  # (not a dialect's unknown)
        self._too_fast = {m: v for m, v in self._too_fast.items() if m in flowing}
        fast = []
        for m in flowing:  # (one the firmware will not stop is asked ever more seldom)
            asks, last = self._too_fast.get(m, (0, -math.inf))
            if now - last >= min(_RATE_WINDOW_S * 2.0 ** max(asks - 2, 0), _RATE_ASK_MAX_S):
                fast.append(m)
                self._too_fast[m] = (asks + 1, now)
        if not fast:
            return
        log.debug(
            "%s: flowing faster than asked, asked again: %s",
            self.name,
            ", ".join(
                f"{_MSG_NAMES[m]} ({counts[_MSG_NAMES[m]]} in {now - start:.0f} s)" for m in fast
            ),
        )
        stops = {**{m: 0.0 for m in fast}, **rates}
        for msg in ap.stream_requests(stops, fast):
            self._send(msg)
        # (asked for, at a rate or to stop: a request lost; never asked for: a profile's
        # stream the service does not read, or one of a group whose stop was lost)
        again = sum(m in rates for m in fast)
        self.counters["streams_asked_again"] += again
        self.counters["streams_stopped"] += len(fast) - again

    async def _lifecycle(self) -> None:
        while True:
            await self._start.wait()
            self._start.clear()
            self._session = asyncio.create_task(self._run_session(), name=f"{self.name}.setup")
            try:
                await self._session
            except asyncio.CancelledError:
                task = asyncio.current_task()
                if task is not None and task.cancelling():
                    raise
            finally:
                self._session = None

    def _interrupt(self) -> None:
        if self._session is not None and not self._session.done():
            self._session.cancel()

    async def _run_session(self) -> None:
        try:
            if self._hold_requested:
                self._set_status(_S.HOLDING)
                await self._hold_command(5.0)
            else:
                await self._set_up()
        except _SetupFailed as e:
            self.failure = str(e)
            self._set_status(_S.FAILED)
            self._emit(EventKind.FAILED, self.failure, _M.MAV_SEVERITY_ERROR)

    # ================================================================= set-up
    async def _set_up(self) -> None:
        ap = self.firmware
        assert ap is not None
        self.failure = None
        self._set_status(_S.WAITING_FIX)
        self._request_streams()
        if not self.clock.synced:  # (mission time comes with the first stamped message:
            await self._await_mission_time()  # an autopilot up an hour is at t = 3600 then)
        start = self.clock.now()
        deadline = start + self.setup_timeout
        self._fix_t = None
        while not self._estimate_ready():
            now = self.clock.now()
            if (
                self.fix_timeout is not None
                and now - start >= self.fix_timeout
                and self.telemetry is not None
            ):
                self._emit(EventKind.WARNING, "no GPS fix reported; setting up anyway")
                break
            if now >= deadline:
                raise _SetupFailed(self._no_fix_message())
            if self.telemetry is None and now - self._streams_t >= _STREAM_RETRY:
                self._request_streams()
            await self._wait_until(self._estimate_ready, min(1.0, deadline - now))
        self._set_status(_S.SETTING_UP)
        if not self.ours and self.armed and self.mode == ap.external_mode and ap.reports_target:
            # Flying under external control already, before we ever flew it: someone
            # else's, or ours before a restart of the service. Listen before taking it
            # (a target that keeps moving is being driven).
            self._adopted = True
            self.control.forget_ours()
            self.control.needed = 2  # (yield on less: the other was there first)
            await self._wait_until(lambda: self.status is _S.FAILED, _LISTEN_S)
        if not self.ours:  # (a set-up again after an outage keeps the UAV ours)
            self.ours, self._ours_t = True, self.clock.now()
        ap.reset()
        self._setup_sent = 0
        # Flying already (rebooted in the air, a link outage, a failsafe taken back): no
        # take-off; the setpoints bring it back to its altitude. (An ArduPlane rebooted
        # in the air had its home reset up there and waited for ever for a climb to
        # TKOFF_ALT above it that its TAKEOFF mode, loitering, never flew.)
        self._airborne_already = self.airborne
        self._takeoff_accepted = False
        unconfirmed: list[SetupStep] = []  # achieved, its HEARTBEAT not yet in
        while True:
            for step in ap.setup_steps:
                if not self._step_done(step):
                    if step is SetupStep.ARM:  # (arming launches it: its turn first)
                        deadline = await self._arm_in_turn(deadline)
                    else:
                        await self._achieve(step, deadline)
                    if step in _CLIMBS and not self._step_done(step):
                        break  # (disarmed, or left the mode that climbs it: round again,
                        # never on to the next step below the flight altitude: ArduPlane
                        # put in GUIDED 12 m up loitered there, set up never ending)
                    if step not in unconfirmed:
                        unconfirmed.append(step)
                for late in [s for s in unconfirmed if self._step_done(s)]:
                    unconfirmed.remove(late)  # (reported once seen done, in order)
                    self._emit(EventKind.SETUP, self._step_report(late))
            if all(self._step_done(step) for step in ap.setup_steps):
                break
            if self.clock.now() >= deadline:
                raise _SetupFailed(self._gave_up("final check", 0, None))
            await self.clock.sleep_until(self.clock.now() + self.command_retry)
        self._pad = None  # (up: the plan's setpoints from now on)
        self._set_status(_S.FLYING)
        self._request_streams(fresh=False)  # the flight rates

    async def _arm_in_turn(self, deadline: float) -> float:
        """Arm once the fleet's launch sequence clears this UAV; the set-up's deadline,
        put back by the wait. The sequence learns when the arming ended (armed,
        refused to the end, or cancelled): until then its neighbours hold."""
        deadline += await self._clear_to_launch()
        try:
            await self._achieve(SetupStep.ARM, deadline)
        finally:
            if self.launch is not None:
                self.launch.armed(self.uid, self.clock.now())
        return deadline

    async def _clear_to_launch(self) -> float:
        """Wait until the fleet's launch sequence clears this UAV to arm; the mission
        seconds waited (they do not count against the set-up's timeout)."""
        seq = self.launch
        if seq is None or self.airborne:
            return 0.0
        why: str | None = None

        def cleared() -> bool:
            nonlocal why
            why = seq.ask(self.uid, self.clock.now())
            return why is None

        start = self.clock.now()
        try:
            if cleared():
                return 0.0
            self._emit(EventKind.SETUP, f"waiting to launch: {why}")
            while not await self._wait_until(cleared, _LAUNCH_NOTE_S):
                self._emit(EventKind.SETUP, f"still waiting to launch: {why}")
        finally:
            seq.withdraw(self.uid)
        waited = self.clock.now() - start
        self._emit(EventKind.SETUP, f"cleared to launch after {waited:.1f} s")
        return waited

    def _step_report(self, step: SetupStep) -> str:
        """What a set-up step achieved, for the operator."""
        if step in (SetupStep.TAKEOFF, SetupStep.CLIMB):
            rel = self.relative_alt
            return f"airborne at {rel:.0f} m above home" if rel is not None else "airborne"
        ap = self.firmware
        if step is SetupStep.TAKEOFF_MODE and ap is not None and self.mode != ap.takeoff_mode:
            # airborne before a HEARTBEAT shows the mode (a late one, on a loaded link)
            said = f"{ap.takeoff_mode} accepted" if self._takeoff_accepted else "armed"
            return f"{said} and airborne (its HEARTBEAT still says {self.mode})"
        if step in (SetupStep.MODE, SetupStep.TAKEOFF_MODE):
            return f"in {self.mode}"
        return "armed" if step is SetupStep.ARM else f"{step} done"

    async def _await_mission_time(self) -> None:
        """Wait for the first time-stamped message of the fleet, asking for streams
        again every ``_STREAM_RETRY`` mission s as the clock's rate hint counts them
        (a request lost on the link; an ArduPilot sends nothing but HEARTBEATs until
        asked).

        Raises:
            _SetupFailed: Nothing stamped within ``setup_timeout``, so counted.
        """
        clock = self.clock
        waited = 0.0
        while not clock.synced:
            if waited >= self.setup_timeout:
                raise _SetupFailed(
                    f"UAV {self.sysid} ({self.firmware}): heard, but none of the telemetry "
                    f"asked for in {self.setup_timeout:.0f} s "
                    f"({self.counters['stream_requests']} requests); "
                    f"{self._last_word()}{self._deaf_hint()}"
                )
            span = _STREAM_RETRY / clock.rate  # (wall s: no mission time yet)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(span):  # (see eventloop.wait_set)
                    await clock.wait_synced()
            waited += _STREAM_RETRY
            if not clock.synced:
                self._request_streams()

    def _unanswered(self, what: str, attempts: int) -> None:
        """Say early, once a set-up step has gone unanswered ``_DEAF_TRIES`` times,
        what an autopilot that never answered may be doing (the set-up goes on)."""
        hint = self._deaf_hint()
        if attempts == _DEAF_TRIES and hint:
            self._emit(
                EventKind.WARNING,
                f"{what}: {attempts} tries, no answer{hint}",
                _M.MAV_SEVERITY_WARNING,
            )

    def _deaf_hint(self) -> str:
        """Why an ArduPilot may answer nothing of ours, if it has answered nothing
        (no COMMAND_ACK to us, no PARAM_VALUE of a parameter we set or asked for)."""
        answered = self._ack_seq or self.counters["param_answers"]
        if answered or not isinstance(self.firmware, ArduPilot):
            return ""
        return (
            f"; it answered nothing from our system id {self.gcs_sysid}: an ArduPilot "
            "with MAV_OPTIONS bit 0 (SYSID_ENFORCE) hears only its MAV_GCS_SYSID "
            "(SYSID_MYGCS), which [mission] source_system must be"
        )

    def _no_fix_message(self) -> str:
        gps = self.last.get("GPS_RAW_INT")
        state = "no GPS_RAW_INT" if gps is None else f"GPS fix type {gps.fix_type}"
        if self.has_fix:
            state = "a GPS fix, but no position estimate (no HOME_POSITION)"
        if self.telemetry is None:
            state += ", no GLOBAL_POSITION_INT"
        asked_for = ("GPS_RAW_INT", "GLOBAL_POSITION_INT", "SYS_STATUS")  # (none came)
        deaf = "" if any(k in self.last for k in asked_for) else self._deaf_hint()
        return (
            f"UAV {self.sysid} ({self.firmware}): no position fix within "
            f"{self.setup_timeout:.0f} s ({state}); {self._last_word()}{deaf}"
        )

    def _last_word(self) -> str:
        if self.last_statustext is None:
            return "the autopilot sent no STATUSTEXT"
        return f"last word from the autopilot: {self.last_statustext!r}"

    def _gave_up(self, what: str, attempts: int, result: str | None) -> str:
        how = f"; last answer {result}" if result else ""
        deaf = self._deaf_hint() if attempts else ""
        return (
            f"UAV {self.sysid} ({self.firmware}): set-up gave up after "
            f"{self.setup_timeout:.0f} s at step '{what}' ({attempts} attempts{how}); "
            f"{self._last_word()}{deaf}"
        )

    def _target_relative_alt(self) -> tuple[float, float]:
        """(metres above home, AMSL) of the flight altitude. Home is HOME_POSITION once
        the autopilot has sent it (before its estimator sets home, ArduPilot's
        GLOBAL_POSITION_INT.relative_alt is the altitude AMSL); else alt - relative_alt
        of GLOBAL_POSITION_INT, else the mission origin."""
        amsl = self.frame.origin.alt + self.altitude
        gpi = self.last.get("GLOBAL_POSITION_INT")
        if self.home is not None:
            home = self.home.alt
        elif gpi is not None:
            home = (gpi.alt - gpi.relative_alt) * 1e-3
        else:
            home = self.frame.origin.alt
        return max(amsl - home, 2.0), amsl

    def _step_done(self, step: SetupStep) -> bool:
        ap = self.firmware
        assert ap is not None
        if step is SetupStep.SETPOINTS:
            return self._setup_sent >= 3 and self.clock.now() - self._last_sp_t < 1.0
        if step is SetupStep.MODE:
            return self.mode == ap.external_mode
        if step is SetupStep.TAKEOFF_MODE:
            return self.mode == ap.takeoff_mode or (self.armed and self.airborne)
        if step is SetupStep.ARM:
            return self.armed
        rel = self.relative_alt
        target = self._climb_target()
        up = rel is not None and rel >= target - max(1.0, 0.05 * target) and self.airborne
        return self.armed and (up or self._airborne_already)

    def _climb_target(self) -> float:
        """Metres above home the take-off climbs to: the flight altitude, or what the
        autopilot holds for its take-off mode's altitude if it kept a lower one."""
        target, _ = self._target_relative_alt()
        ap = self.firmware
        if ap is not None and ap.takeoff_mode is not None:
            for name in ap.takeoff_params(target):
                if name in self.params:
                    target = min(target, self.params[name])
        return target

    async def _achieve(self, step: SetupStep, deadline: float) -> None:
        ap = self.firmware
        assert ap is not None
        if step is SetupStep.SETPOINTS:  # the streamer or the keepalive sends them
            if not await self._wait_until(
                lambda: self._step_done(step), deadline - self.clock.now()
            ):
                raise _SetupFailed(self._gave_up(str(step), 0, None))
        elif step is SetupStep.MODE:
            target = ap.external_mode
            in_mode = functools.partial(self._in_mode, target)
            await self._command(ap.mode_command(target), f"mode {target}", deadline, in_mode)
            await self._wait_until(in_mode, _CONFIRM_WAIT)
        elif step is SetupStep.TAKEOFF_MODE:
            rel, _ = self._target_relative_alt()
            for name, value in ap.takeoff_params(rel).items():
                await self._set_param(name, value, deadline)
            climb = ap.takeoff_mode
            assert climb is not None
            climbing = functools.partial(self._step_done, step)
            if await self._command(ap.mode_command(climb), f"mode {climb}", deadline, climbing):
                self._takeoff_accepted = True
            await self._wait_until(climbing, _CONFIRM_WAIT)
        elif step is SetupStep.ARM:
            tel = self.telemetry
            if SetupStep.CLIMB in ap.setup_steps and tel is not None and not self.airborne:
                self._pad = (tel.north, tel.east)  # (climb straight up from here)
            await self._command(ap.arm_command(), "arm", deadline, self._is_armed, self.arm_backoff)
            await self._wait_until(self._is_armed, _CONFIRM_WAIT)
        elif step is SetupStep.CLIMB:  # (the setpoints climb it: ``_climb_out``)
            in_mode = functools.partial(self._in_mode, ap.external_mode)
            await self._reach_altitude(step, deadline, in_mode)
        else:
            rel, amsl = self._target_relative_alt()
            takeoff = ap.takeoff_command(rel, amsl)
            what = f"take off to {rel:.0f} m"
            if takeoff is not None and not await self._command(
                takeoff, what, deadline, self._is_airborne
            ):  # already flying (a re-set-up after a link outage): setpoints will climb
                self._airborne_already = True
                return
            await self._reach_altitude(step, deadline)

    async def _reach_altitude(
        self, step: SetupStep, deadline: float, holds: Callable[[], bool] = lambda: True
    ) -> None:
        """Wait for the climb to the flight altitude; on a disarm, or once ``holds()`` is
        false (the autopilot left the mode that climbs it), set-up goes round again.

        A disarm is one seen after the arming: the HEARTBEAT that shows it armed may
        come after the arming's COMMAND_ACK (lost, on a lossy link), and taking the
        HEARTBEATs before it for a disarm sent an ArduPlane climbing in TAKEOFF into
        GUIDED a few metres up."""
        seen_armed = self.armed

        def over() -> bool:
            nonlocal seen_armed
            seen_armed = seen_armed or self.armed
            return self._step_done(step) or (seen_armed and not self.armed) or not holds()

        reached = await self._wait_until(over, deadline - self.clock.now())
        if not reached:
            raise _SetupFailed(self._gave_up(str(step), 1, None))

    def _in_mode(self, mode: str) -> bool:
        return self.mode == mode

    def _is_airborne(self) -> bool:
        return self.airborne

    async def _set_param(self, name: str, value: float, deadline: float) -> None:
        """PARAM_SET until the autopilot's PARAM_VALUE echoes ``value``.

        Raises:
            _SetupFailed: ``deadline`` passed without a confirmation.
        """
        assert self.firmware is not None

        def confirmed() -> bool:
            held = self.params.get(name)
            return held is not None and abs(held - value) <= _PARAM_TOL

        self.params.pop(name, None)
        attempts = 0
        while not confirmed():
            if self.clock.now() >= deadline:
                raise _SetupFailed(self._gave_up(f"set {name} = {value:g}", attempts, None))
            self.send_param_set(name, value)
            attempts += 1
            await self._wait_until(lambda: name in self.params, self.command_retry)
            if name not in self.params:
                self._unanswered(f"set {name}", attempts)
            elif not confirmed():
                self._emit(
                    EventKind.WARNING,
                    f"{name} is {self.params[name]:g}, not {value:g}: the autopilot kept "
                    "its own value",
                    _M.MAV_SEVERITY_WARNING,
                )
                return
        self._emit(EventKind.SETUP, f"{name} set to {value:g}")

    def _is_armed(self) -> bool:
        return self.armed

    async def _command(
        self,
        spec: CommandSpec,
        what: str,
        deadline: float,
        moot: Callable[[], bool] | None = None,
        max_backoff: float | None = None,
    ) -> bool:
        """Send until ACCEPTED; refusals back off exponentially (to ``max_backoff``,
        by default the vehicle's) and are reported.

        Returns:
            True once ACCEPTED; False if ``moot()`` became true before an attempt
            (someone else did it, or it no longer applies).

        Raises:
            _SetupFailed: ``deadline`` passed, or the autopilot does not support it.
        """
        ap = self.firmware
        assert ap is not None
        backoff = self.command_retry
        cap = self.max_backoff if max_backoff is None else max_backoff
        attempts = 0
        result_name: str | None = None
        said: tuple[str | None, float] | None = None  # the refusal last reported, and when
        while True:
            now = self.clock.now()
            if moot is not None and moot():
                return False
            if now >= deadline:
                raise _SetupFailed(self._gave_up(what, attempts, result_name))
            seq = self._ack_seq
            self._send(spec.message(self.sysid, ap.compid, attempts))
            attempts += 1
            self.counters["commands"] += 1
            result = await self._wait_ack(spec.command, seq, self.command_retry)
            while result == _M.MAV_RESULT_IN_PROGRESS:
                result = await self._wait_ack(spec.command, self._ack_seq, 5 * self.command_retry)
            if result is None:
                self.counters["ack_timeout"] += 1
                result_name = "no COMMAND_ACK"
                self._unanswered(what, attempts)
                continue
            if result == _M.MAV_RESULT_ACCEPTED:
                return True
            if result not in _REFUSALS:
                raise _SetupFailed(
                    f"UAV {self.sysid} ({ap}): {what} is not supported by the autopilot "
                    f"(COMMAND_ACK result {result}); {self._last_word()}"
                )
            result_name = _REFUSALS[result]
            self.counters["refused"] += 1
            await self._wait_until(functools.partial(self._text_since, now), _REASON_WAIT)
            since = ((severity, text) for t, severity, text in self._texts if t >= now)
            reason = refusal_reason(since) or "no reason heard"
            wait = min(backoff, max(deadline - self.clock.now(), 0.0))
            if said is None or said[0] != reason or now - said[1] >= self.max_backoff:
                # (the same refusal again within max_backoff is not said again)
                tally = "" if attempts == 1 else f" {attempts} times"
                self._emit(
                    EventKind.REFUSED,
                    f"{what} refused{tally} ({result_name}): {reason!r}; retrying in {wait:.1f} s",
                    _M.MAV_SEVERITY_WARNING,
                )
                said = (reason, now)
            await self.clock.sleep_until(self.clock.now() + wait)
            backoff = min(2.0 * backoff, cap)

    def hold_is_ours(self, t: float) -> bool:
        """Whether the autopilot's fall from our mode to its hold, reported at ``t``, is
        our setpoint stream's doing (a failsafe: take the UAV back) rather than a pilot's
        or another ground station's (respect it).

        Ours when the autopilot said so: a stream-loss STATUSTEXT within
        ``_FAILSAFE_TEXT_S`` of ``t``, either side (the text and the HEARTBEAT that shows
        the hold come in either order); or a HEARTBEAT that says it is in a failsafe as it
        holds in a mode its stream-loss failsafe falls to (PX4 reports MAV_STATE_CRITICAL
        then, ACTIVE after a pilot's or a station's mode change: the text is sent once,
        the HEARTBEAT every second, so a lossy link that loses the one still shows the
        other). With nothing said, ours soon after the link came back, our stream resumed
        after a gap, or the UAV flew again after an outage. Not ours, whatever those say,
        when another station's mode command was accepted within ``_FOREIGN_MODE_S``
        (either side, too): a stranger who takes the UAV while our stream hiccups keeps
        it. (A text from minutes ago explains no hold now: a UAV that once failed safe
        would be fought for ever after.)
        """
        if abs(t - self.foreign_mode_t) < _FOREIGN_MODE_S:
            return False
        ap = self.firmware
        return (
            abs(t - self._stream_loss_text_t) < _FAILSAFE_TEXT_S
            # (the same by the autopilot's clock: mission time may have stepped between
            # the text and the hold, on a loaded host after a simulator's pause)
            or abs(self._left_mode_boot - self._stream_loss_text_boot) < _FAILSAFE_TEXT_S
            or (
                ap is not None
                and self.mode in ap.stream_loss_modes
                and abs(t - self._failsafe_beat_t) < _FAILSAFE_TEXT_S
            )
            or 0.0 <= t - self.recovered_t < _OWN_FAILSAFE_S
            or 0.0 <= t - self.stream_resumed_t < _OWN_FAILSAFE_S
            # (a UAV set up again may report the hold of its outage late: the known
            # loaded-host case of the fleet-pause test)
            or 0.0 <= t - self.reflying_t < _REFLY_FAILSAFE_S
        )

    def _text_since(self, t: float) -> bool:
        return bool(self._texts) and self._texts[-1][0] >= t

    @property
    def last_statustext(self) -> str | None:
        """The autopilot's latest STATUSTEXT (None: it has said none)."""
        return self._texts[-1][2] if self._texts else None

    async def _wait_ack(self, command: int, seq: int, timeout: float) -> int | None:
        def answered() -> bool:
            entry = self._acks.get(command)
            return entry is not None and entry[1] > seq

        if not await self._wait_until(answered, timeout):
            return None
        return self._acks[command][0]

    async def _wait_until(self, done: Callable[[], bool], timeout: float) -> bool:
        """Wait (mission s) until ``done()``, re-checked whenever a message arrives."""
        deadline = self.clock.now() + timeout
        while True:
            self._changed.clear()
            if done():
                return True
            wall = self.clock.wall_until(deadline)
            if wall <= 0.0:
                return False
            await wait_set(self._changed, wall)

    # ============================================================ geofence
    async def upload_fence(
        self, items: Sequence[tuple[int, int, float, float]], timeout: float = 5.0
    ) -> str:
        """Upload a geofence (mission protocol, MAV_MISSION_TYPE_FENCE); the outcome in words.

        The autopilot's answers are read in the order they came, not only the latest:
        a copy sent again after a timeout is answered twice, and on a lagging link the
        second answer (ArduPilot's MAV_MISSION_ERROR to an item after the upload closed,
        MAV_MISSION_INVALID_SEQUENCE to an item already stored) can arrive in the same
        burst as the first, which is the one that says how the upload went.

        Args:
            items: (command, vertex count, lat, lon) per vertex, in order
                (``fence.fence_items``).
            timeout: Mission s to wait for each answer before sending again (3 tries).
        """
        fw = self.firmware
        target = (self.sysid, fw.compid if fw is not None else _M.MAV_COMP_ID_AUTOPILOT1)
        fence = _M.MAV_MISSION_TYPE_FENCE
        replies: deque[Message] = deque()
        self._fence_replies = replies
        message: Message = _M.MAVLink_mission_count_message(*target, len(items), fence)
        try:
            tries, send = 0, True
            for _ in range(_FENCE_ANSWERS_PER_ITEM * (len(items) + 1)):
                if send:
                    if tries == _FENCE_TRIES:
                        break
                    self._send(message)
                    tries += 1
                send = True
                if not await self._wait_until(lambda: bool(replies), timeout):
                    continue
                reply = replies.popleft()
                if reply.get_type() == "MISSION_ACK":
                    if reply.type == _M.MAV_MISSION_ACCEPTED:
                        return f"geofence of {len(items)} vertices uploaded"
                    if reply.type == _M.MAV_MISSION_INVALID_SEQUENCE:
                        send = False  # (a copy of an item it had: wait for its next request)
                        continue
                    name = _M.enums["MAV_MISSION_RESULT"][reply.type].name
                    return f"geofence refused ({name})"
                if not 0 <= reply.seq < len(items):
                    return f"geofence upload asked for item {reply.seq} of {len(items)}"
                command, count, lat, lon = items[reply.seq]
                message = _M.MAVLink_mission_item_int_message(
                    *target, reply.seq, _M.MAV_FRAME_GLOBAL, command, 0, 1, float(count),
                    0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0, fence,
                )  # fmt: skip
                tries = 0
            return "geofence upload got no answer"
        finally:
            self._fence_replies = None

    def _on_mission_reply(self, msg: Message, now: float) -> None:
        """Queue a fence upload's answer (MISSION_ACK or MISSION_REQUEST[_INT]) for it,
        not the vehicle's answers to another ground station's upload on a shared link."""
        replies = self._fence_replies
        if (
            replies is not None
            and msg.mission_type == _M.MAV_MISSION_TYPE_FENCE
            and msg.target_system in (0, self.gcs_sysid)
        ):
            replies.append(msg)

    # ============================================================ hold, resume
    async def hold(self, timeout: float = 5.0) -> bool:
        """Loiter/hover where it is (pause, shutdown); waits up to ``timeout`` for the ACK.

        Set-up in progress is abandoned; setpoints are dropped until :meth:`resume`.
        A vehicle on the ground, disarmed, is left alone.

        Returns:
            True if the autopilot accepted the hold mode (or none was needed).
        """
        if self.refused:
            return True  # (another controller's UAV: not ours to hold)
        self._hold_requested = True
        self._interrupt()
        if self.status is _S.LOST:
            return False  # sent when it is heard again
        if self.firmware is None:
            self._set_status(_S.HOLDING)
            return True
        if not self.armed and self.status is _S.FAILED:
            return True  # (failed on the ground: it stays so, and says so)
        self._set_status(_S.HOLDING)
        if not self.armed:
            return True
        return await self._hold_command(timeout)

    async def finish(self, action: str = "loiter", timeout: float = 5.0) -> bool:
        """End of mission: ``"loiter"`` where it is, ``"rtl"`` home, ``"land"`` there.

        Like :meth:`hold` it ends set-up and setpoints; a refused return or landing
        falls back to the hold mode, so no UAV is left flying a stale setpoint.

        Returns:
            True if the autopilot accepted the action (or none was needed).
        """
        if self.refused:
            return True  # (another controller's UAV: not ours to end)
        ap = self.firmware
        spec = None if ap is None else ap.end_command(action)
        if spec is None or self.status is _S.LOST or not self.armed:
            return await self.hold(timeout)
        self._hold_requested = True
        self._interrupt()
        self._set_status(_S.HOLDING)
        try:
            await self._command(spec, action, self.clock.now() + timeout)
        except _SetupFailed as e:
            self._emit(EventKind.WARNING, f"{action} not accepted ({e}); holding instead")
            return await self._hold_command(timeout)
        self._emit(EventKind.STATUS, f"mission over: {action}")
        return True

    async def _hold_command(self, timeout: float) -> bool:
        ap = self.firmware
        assert ap is not None
        try:
            deadline = self.clock.now() + timeout
            holding = functools.partial(self._in_mode, ap.hold_mode)  # (e.g. after a failsafe)
            await self._command(ap.hold_command(), f"hold ({ap.hold_mode})", deadline, holding)
        except _SetupFailed as e:
            self._emit(EventKind.WARNING, f"hold not confirmed: {e}", _M.MAV_SEVERITY_ERROR)
            return False
        return True

    def resume(self) -> None:
        """Leave HOLDING (or retry after FAILED): set up again and fly setpoints."""
        self._hold_requested = False
        if self.status not in (_S.HOLDING, _S.FAILED) or self._unsupported:
            return
        if self.firmware is None:  # held before its first HEARTBEAT
            self._set_status(_S.CONNECTING)
            return
        self._interrupt()
        self._start.set()
