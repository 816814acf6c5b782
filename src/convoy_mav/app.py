"""The convoy-protection service: every part wired into one structured task group.

Data flow (one ``asyncio.TaskGroup``, every task named ``convoy[...]``)::

    MavLink (one per autopilot) --msg--> router --> Vehicle.handle (UAVs)
                                               \\-> ConvoyTracker (ground vehicles)
    control loop (10 Hz mission time): convoy estimate -> Mission (replans, joins,
        losses) -> Monitor (coverage, alarms) -> History, MQTT, progress
    SetpointStreamer (20 Hz mission time): Mission.setpoint -> Vehicle.send_setpoint

Design rules:
- Time is the autopilots' (``MissionClock``); the service flies the same at any
  simulator speedup.
- The flight loop never waits on MQTT or logging: publishing is fire-and-forget
  into latest-value slots, the tlog is buffered and flushed off the loop.
- Shutdown (SIGINT/SIGTERM or the end of ``duration``) tells every vehicle to
  loiter where it is before the links close.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import logging
import math
import sys
import time
from collections import Counter, deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock, Observed
from convoy_mav.config import MissionConfig, UavConfig
from convoy_mav.convoy import ConvoyTracker, Source
from convoy_mav.errors import ConfigError, PlanningError
from convoy_mav.fence import Fence, fence_from, fence_items, join_orbit, orbit_setpoint
from convoy_mav.gcpolicy import collect_on_schedule, flight_gc
from convoy_mav.geo import GeoPoint, LocalFrame, no_position_yet
from convoy_mav.history import History
from convoy_mav.launch import Craft, LaunchSequence
from convoy_mav.mavlink import MavLink
from convoy_mav.mavlink.autopilots.base import (
    along_track_error,
    param_set_message,
    set_message_interval,
)
from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.mavlink.missionread import MissionItem, MissionWatch
from convoy_mav.mavlink.rally import RallyRead, rtl_destination
from convoy_mav.mavlink.rovermode import RoverMode, rover_mode
from convoy_mav.mavlink.signing import Signing, load_key
from convoy_mav.mission import (
    Mission,
    MissionAlarm,
    MissionView,
    PhaseChanged,
    Replanned,
    ReplanThresholds,
    Returning,
)
from convoy_mav.mission.choose import choose_planner
from convoy_mav.mission.lag import ReplanLag
from convoy_mav.mission.road import FAST_CONVOY_RATIO, RoadMission
from convoy_mav.monitor import Alarm, Monitor, MonitorSnapshot, sees, why_not_counted
from convoy_mav.parting import STAND_S, leaves
from convoy_mav.planning.export import compass_to_planner
from convoy_mav.planning.road import Road
from convoy_mav.publish import topics
from convoy_mav.publish.mqtt import MqttPublisher
from convoy_mav.publish.security import mqtt_security
from convoy_mav.recording import TlogRecorder
from convoy_mav.schedule import POSITION_AT_HORIZON_S, position_at
from convoy_mav.separation import conflicts
from convoy_mav.streaming import SetpointStreamer
from convoy_mav.tracks import load_planned_route
from convoy_mav.tracks.missionroute import driven_to, mission_route
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.types import ConvoyDrive, ConvoyEstimate, Setpoint, Telemetry, VehicleStatus
from convoy_mav.vehicle import EventKind, Vehicle, VehicleEvent

__all__ = ["ConvoyService", "Progress", "ServiceReport"]

log = logging.getLogger(__name__)

Marks = tuple[tuple[float, float], ...]  # (arc length on the route, value) in order
_GIL_SWITCH_S = 0.001  # s: how long the mission worker may hold the GIL at a time
_GROUND_STREAM_RETRY = 5.0  # mission s between stream requests to a silent ground vehicle
_VELOCITY_SOURCES = ("velocity_reported", "velocity_fitted")  # (tracker counters)
_GROUND_POSITION_HZ = 10  # GLOBAL_POSITION_INT rate asked of ground vehicles
_MAX_SPEED_FACTOR = 2.5  # a UAV fix implying more than this x its airspeed is not its own
_MAX_SPEED_FLOOR = 30.0  # m/s: ... nor more than this, whatever the airspeed (wind, a dive)
_FIX_WINDOW_S = (30.0, 2.0)  # mission s an external fix may be stamped before / after now
_TAKEN_CONFIRM_S = 3.0  # mission s a mode change must stand (no reboot) to be a pilot's
_STALL_TICKS = 3  # a control tick this many periods late is a stall of the host
_PLANNER_BEHIND = 1.5  # re-plans this many times rarer than planned: the planner is behind
_REPLANS_LATE_S = 0.1  # mission s past its tick a one-UAV re-plan is flown: late (half: not)
_SLOW_REPLANS_S = 0.15  # mission s past its tick re-plans slow a simulator (``_check_speedup``)
_SLOW_REFIT = 15  # steps with re-plans the lag fit takes in at a new speedup before it counts
_SETPOINTS_LATE_S = 0.5  # mission s between setpoint rounds: half PX4's COM_OF_LOSS_T (1 s)
_FAST_CLEARS = 0.9  # a convoy speed alarm clears below this fraction of its bound ...
_FAST_CLEARS_AFTER_S = 30.0  # ... held this long (mission s)
_REAL_TIME_ABOVE = 1.5  # a speedup up to this is real time (no speedup to lower)
_ON_TIME_FOR_S = 60.0  # mission s on time (setpoint rounds, re-plans) before late is news again
_SLOW_LOOK_S = 30.0  # mission s the host is judged over before (and after) a speedup change
_SLOW_STALLED = 0.2  # ... a loop held up this fraction of them is behind the simulator
_SLOW_GAP_S = _SETPOINTS_LATE_S  # ... or two setpoint rounds this far apart (see below)
_SLOW_GAP_SETTLE_S = 10.0  # ... which acts once this long has passed, not the whole look
_SLOW_TAKEN = 1.25  # a speedup still above the one asked times this was not taken
_LAUNCH_CLEARANCE = 1.5  # a pad is clear of UAVs this many horizontal minima away ...
_LAUNCH_HEADROOM = 2.0  # ... or this many vertical minima above it, bound higher
_SETTING_UP = frozenset({VehicleStatus.WAITING_FIX, VehicleStatus.SETTING_UP})
_FINISH_WALL_S = 15.0  # wall s the end-of-mission commands are waited for at most
_MODES_KEPT = 1000  # the lead ground vehicle's mode changes kept for the report
_APART_AFTER_S = 3.0  # mission s a follower's mode says it left before it is parted (a
# convoy held or sent on as a whole is heard one vehicle at a time, at 1 Hz each)
_JOINABLE = frozenset({"pending", "protect"})
"""Phases a join starts from: a UAV without a slot, or one far off its slot (``_off_slot``)."""
_OFF_SLOT_S = 5.0  # mission s a protecting UAV is farther than R off its slot before...
_REJOIN_EVERY_S = 30.0  # ... it is joined to it again from where it is (at most this often)
_OFF_SLOT = frozenset({"joining", "not assigned", "lost"})
"""Not protecting, yet seeing what it sees if airborne in its band (the ground truth
counts it too)."""
_COMMANDING = frozenset(
    {
        "SET_POSITION_TARGET_GLOBAL_INT",
        "SET_POSITION_TARGET_LOCAL_NED",
        "SET_ATTITUDE_TARGET",
        "COMMAND_LONG",
        "COMMAND_INT",
        "SET_MODE",
    }
)
"""Messages that drive a vehicle: another system's, for our UAV, is another controller."""
_FENCE_LOOK_STEPS = 60  # a new plan's paths are checked against the fence this many steps
_FENCE_LOOK_DT = 2.0  # mission s apart (two minutes ahead)
_PROGRESS_ALARM_S = 10.0  # mission s between two alarms of clamped setpoints


@dataclass(frozen=True, slots=True)
class Progress:
    """What the operator sees on a long run."""

    t: float
    phase: str  # "connecting", "joining", "protecting", "holding"
    flying: int
    uavs: int
    covered: bool
    coverage_fraction: float | None
    gaps: int
    longest_gap_s: float
    predicted_coverage: float | None
    message: str = ""
    counted: int = 0  # UAVs that count for coverage now (airborne, in band, on slot)
    states: Mapping[str, int] = field(default_factory=dict)  # the others by status
    alarms: tuple[str, ...] = ()  # alarms in force


@dataclass
class ServiceReport:
    """The outcome of a run (``to_dict`` is the ``--report`` JSON)."""

    config: MissionConfig
    snapshot: MonitorSnapshot
    end_t: float
    predicted_coverage: float | None
    convoy_speed_mps: float
    statuses: dict[int, str]
    replans: list[dict[str, Any]] = field(default_factory=list)
    alarms: list[dict[str, Any]] = field(default_factory=list)
    events: list[str] = field(default_factory=list)
    vehicle_extra: dict[int, dict[str, Any]] = field(default_factory=dict)
    route_start_s: float | None = None
    planner: dict[str, Any] = field(default_factory=dict)
    rejected: dict[str, int] = field(default_factory=dict)
    tlog: str | None = None
    safety: dict[str, Any] = field(default_factory=dict)
    refused: str | None = None
    clock: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The report JSON (keys documented in the README)."""
        snap = self.snapshot
        craft = self.config.plan_aircraft
        stats = snap.stats
        scores = {v.sysid: v for v in snap.vehicles}
        return {
            "coverage_fraction": stats.fraction if snap.protect_start is not None else None,
            "longest_gap_s": stats.longest_gap_s,
            "gaps": stats.gaps,
            "uav_count": len(self.config.uav_list),
            "predicted_coverage": self.predicted_coverage,
            "sensor_radius_m": self.config.sensor_radius_m,
            "turn_radius_m": craft.turn_radius_m,
            "airspeed_mps": craft.airspeed_mps,
            "convoy_speed_mps": self.convoy_speed_mps,
            "protect_start_s": snap.protect_start,
            "route_start_s": self.route_start_s,
            "end_s": self.end_t,
            "protected_s": stats.elapsed_s,
            "planner": self.planner,
            "replans": self.replans,
            "alarms": self.alarms,
            "events": self.events,
            # Inputs dropped as implausible or malformed, by kind (per UAV under vehicles).
            "rejected": self.rejected,
            "tlog": self.tlog,
            # Why the service flew nothing: every UAV driven by another controller.
            "refused": self.refused,
            # Fence clamps per UAV, separation conflicts (see the README's Safety section).
            "safety": self.safety,
            # How mission time ran: the autopilots' speedup, their clocks' steps and the like.
            "mission_clock": self.clock,
            "vehicles": [
                {
                    "sysid": uav.sysid,
                    "status": self.statuses.get(uav.sysid, "unknown"),
                    "time_in_circle_fraction": (
                        scores[uav.sysid].time_in_circle_fraction if uav.sysid in scores else 0.0
                    ),
                    "mean_tracking_error_m": (
                        scores[uav.sysid].mean_tracking_error_m if uav.sysid in scores else None
                    ),
                    "median_tracking_error_m": (
                        scores[uav.sysid].median_tracking_error_m if uav.sysid in scores else None
                    ),
                    **self.vehicle_extra.get(uav.sysid, {}),
                }
                for uav in self.config.uav_list
            ],
        }


def _link_rejections(link: object) -> dict[str, int]:
    """What a UAV's link refused: a foreign peer's datagrams, unsigned or forged frames."""
    if not isinstance(link, MavLink):
        return {"foreign_peer": 0, "unsigned": 0, "bad_signature": 0}
    codec = link.codec.counters
    return {
        "foreign_peer": link.counters["foreign_peer"],
        "unsigned": codec["unsigned"],
        "bad_signature": codec["bad_signature"],
    }


def _signing(uav: UavConfig) -> Signing | None:
    """The link's MAVLink 2 signing, if the UAV has a key; its timestamps kept by the key."""
    if not uav.signed:
        return None
    name = f"uav[{uav.sysid}].signing_key_" + ("file" if uav.signing_key_file else "env")
    key = load_key(name, file=uav.signing_key_file, env=uav.signing_key_env)
    state = uav.signing_state or (
        f"{uav.signing_key_file}.state.json" if uav.signing_key_file else None
    )
    return Signing.from_files(key, uav.sysid & 0xFF, state)


def _without_setpoints(firmware: set[str]) -> str:
    """What the fleet's autopilots do when setpoints stop (``Firmware.name`` of each
    recognised one), for the late-setpoints warning."""
    if not firmware or "PX4" in firmware:
        return "PX4 leaves OFFBOARD after 1 s without one"
    return (
        "ArduPilot holds its last target without one: ArduCopter stops there after "
        "GUID_TIMEOUT, 3 s, ArduPlane circles it"
    )


def _firmware_family(vehicle: Vehicle) -> str | None:
    """``px4`` or ``ardupilot`` (the MQTT schema's names), once recognised."""
    if vehicle.firmware is None:
        return None
    return "px4" if vehicle.firmware.name == "PX4" else "ardupilot"


_T = TypeVar("_T")


def _home_request(sysid: int) -> Any:
    """MAV_CMD_REQUEST_MESSAGE of a ground vehicle's HOME_POSITION."""
    return mavlink.MAVLink_command_long_message(
        sysid, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
        mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip


def _source_name(source: Source) -> str:
    """A convoy source as the operator knows it: a ground vehicle by its system id."""
    return f"ground vehicle {source}" if isinstance(source, int) else f"convoy source {source!r}"


def _left_by_mode(mode: RoverMode, lead: RoverMode | None) -> str | None:
    """Why a follower in ``mode`` has left a convoy whose lead is in ``lead``
    (``parting.leaves``), or None: it has not, or it cannot be told."""
    if lead is None or not leaves(mode.drive, lead.drive):
        return None
    does = {
        ConvoyDrive.HELD: "stands",
        ConvoyDrive.HOME: "drives home",
        ConvoyDrive.RETRACE: "drives home back along its path",
        ConvoyDrive.MISSION: "drives its mission",
        ConvoyDrive.OTHER: "is driven otherwise",
    }
    return f"in {mode.name}: it {does[mode.drive]} while the lead {does[lead.drive]}"


def _drained(queue: deque[_T]) -> list[_T]:
    """Every item in ``queue``, taken out in order (safe beside another thread's
    ``append``: each ``popleft`` is atomic, where a swap of the whole could drop one)."""
    out: list[_T] = []
    with contextlib.suppress(IndexError):
        while True:
            out.append(queue.popleft())
    return out


class _Stop(Exception):
    """Raised inside the task group to end the run after a clean hold."""


class ConvoyService:
    """The flight service for one mission (see the module docstring).

    Args:
        config: The mission.
        rate_hint: Expected simulator speedup (mission seconds per wall second)
            until the clock has measured it; None for real autopilots.
        on_progress: Called about every ``progress_every`` mission seconds.
        on_alarm: Called with every alarm (gaps, missed prediction, stale convoy).
        thresholds: Replan thresholds (defaults: ``ReplanThresholds()``).
        publisher: Something with ``publish(subtopic, payload)`` (the MQTT adapter),
            or None.
        route: The convoy's route (mission frame as planner x east, y north), for
            the road planner; default: the config's ``convoy.route`` file, if any.
    """

    def __init__(
        self,
        config: MissionConfig,
        *,
        rate_hint: float | None = None,
        on_progress: Callable[[Progress], None] | None = None,
        on_alarm: Callable[[Alarm], None] | None = None,
        thresholds: ReplanThresholds | None = None,
        publisher: Any = None,
        control_rate_hz: float = 10.0,
        progress_every: float = 10.0,
        history_interval: float = 0.5,
        route: Road | None = None,
    ) -> None:
        self.config = config
        self.frame = LocalFrame(config.origin)
        # (mission time waits out a fleet-wide silence once every UAV is declared lost)
        self.clock = MissionClock(
            rate_hint=rate_hint, silence_cap=max(10.0, 3.0 * config.lost_after_s)
        )
        # (the convoy is the lead's group: a vehicle parted from it is not in its centroid)
        self.tracker = ConvoyTracker(
            stale_after=config.convoy.stale_after_s,
            window=4.0,
            part_m=config.convoy_part_m,
            lead=config.convoy.vehicles[0].sysid if config.convoy.vehicles else None,
        )
        self._parted: frozenset[Source] = frozenset()  # (as last said)
        # The followers' modes: one held or sent home while the lead does otherwise has
        # left the convoy (``_left_by_mode``), from when, and why.
        self._follower_modes: dict[int, RoverMode] = {}
        self._apart_since: dict[int, float] = {}
        self._apart_why: dict[int, str] = {}
        self.convoy_parted: list[dict[str, Any]] = []  # each part and rejoin, for the report
        self.fence = fence_from(config.safety, self.frame)
        self._fence_clamps: Counter[int] = Counter()  # setpoints moved inside the fence, per UAV
        craft = config.plan_aircraft  # (once: the setpoint path runs 20 times a second a UAV)
        self._turn_radius, self._airspeed = craft.turn_radius_m, craft.airspeed_mps
        self._fence_seen = 0  # clamps already alarmed
        self._convoy_out = False  # the convoy is outside the fence
        self._hold: tuple[float, float] | None = None  # centre of the hold meanwhile
        self._hold_orbits: dict[int, tuple[float, bool]] = {}  # (phase, clockwise) per UAV
        self._off_slot_since: dict[int, float] = {}  # protecting UAVs far off their slot
        self._rejoined_t: dict[int, float] = {}  # when each was last sent back to it
        self._conflicts: set[tuple[int, int]] = set()  # pairs below the separation minima
        self._conflict_count = 0
        self._closest_m: float | None = None  # least horizontal separation in a conflict
        self._fence_alarm_t = -math.inf
        self.fence_uploads: dict[int, str] = {}  # the autopilots' own geofence, per UAV
        self.refused: str | None = None  # why the service flew nothing (others drive them)
        self._stop_event: asyncio.Event | None = None
        self._stalled_s = 0.0  # mission s the control loop was held up (a loaded host)
        self._planner_behind = False
        self._replans_late_t: float | None = None  # last look that found re-plans late
        # convoy_fast, convoy_outruns in force: since when the convoy is slow (None: fast)
        self._speed_alarms: dict[str, float | None] = {}
        self._astray = False  # the convoy on its way home drives elsewhere (as last said)
        self._warned: set[str] = set()  # what ``_warn_once`` has warned of
        self._setpoints_late_t: float | None = None  # last look that found rounds late
        self.streamer: SetpointStreamer | None = None  # (while the mission flies)
        self._end_t: float | None = None  # mission time the flight ended
        # Slowing the simulator (``_check_speedup``): the look begun (mission t, stalled s
        # then), the speedup asked for, and whether the simulator took no SIM_SPEEDUP.
        self._slow_look: tuple[float, float] | None = None
        self._speedup_asked: float | None = None
        self._speedup_refused = False
        self._slow_gap = 0.0  # the widest gap between setpoint rounds since the last look
        self._slowed_at_plans = 0  # the lag fit's steps when the speedup was last changed
        self._fence_clear_until: dict[int, tuple[float, float]] = {}  # (from, to) mission s
        self.history = History(interval=history_interval)
        self.monitor = Monitor(config.sensor_radius_m, step=1.0 / control_rate_hz)
        self.publisher = publisher
        self._on_progress = on_progress
        self._on_alarm = on_alarm
        self._control_dt = 1.0 / control_rate_hz
        self._progress_every = progress_every
        self._publish_every = 1.0
        self._started_wall = time.time()
        self.vehicles: dict[int, Vehicle] = {}
        self._ground_ids = {v.sysid for v in config.convoy.vehicles}
        self._ground_links: list[MavLink] = []  # (one per convoy vehicle, in order)
        self._ground_heard: dict[int, float] = {}
        self._ground_rejected = 0  # ground fixes dropped: a clock ahead of its own
        self._fixes_rejected = 0  # external fixes dropped: stamped far from mission time
        self._tlog_path: str | None = None
        self._foreign_sysid: Counter[int] = Counter()  # frames of another sysid, per link owner
        self._taken: set[int] = set()  # UAVs a pilot or another GCS took (mode changed)
        self._taken_pending: dict[int, tuple[float, int, str]] = {}  # (t, reboots, message)
        self._foreign_claims: Counter[int] = Counter()  # ... claiming another vehicle's sysid
        self._foreign_seen: dict[int, int] = {}  # strangers at a link: last alarmed totals
        self._altitudes = {
            uav.sysid: uav.aircraft.altitude_m + i * config.altitude_step_m
            for i, uav in enumerate(config.uav_list)
        }
        request = config.plan_request()
        uav_ids = [u.sysid for u in config.uav_list]
        self.planner, why = choose_planner(
            config.planner,
            len(uav_ids),
            request.turn_radius,
            request.sensor_radius,
            route=route is not None
            or config.convoy.route_file is not None
            or config.convoy.route_from_mission,
        )
        self.mission: Mission | RoadMission
        saved: PlannedRoute | None = None  # a route file that can carry a plan
        if self.planner == "road":
            if route is None and config.convoy.route_file is not None:
                route, saved = self._load_route(config)
            self.mission = RoadMission(
                request,
                uav_ids,
                down=self._down,
                route=route,
                record=config.mission_recording is not None,
            )
            if route is not None and saved is not None and saved.planned:
                self.mission.set_route(route, *self._plan_on(route, saved))
        else:
            self.mission = Mission(request, uav_ids, down=self._down, thresholds=thresholds)
        self._planner_why = why
        # A new route (MQTT, a rover's mission) and its plan (holds, whether a circuit,
        # speeds), for the next mission step: the newest is taken. (A deque: appended on
        # the event loop, drained in the mission's worker thread, and neither loses one.)
        self._new_routes: deque[tuple[Road, Marks, bool, Marks, bool]] = deque()
        self._route_taken = saved  # (the last route taken, with its plan)
        remarks = "" if saved is None else saved.remarks()
        self._route_source = (
            "file" + (f" ({remarks})" if remarks else "")
            if config.convoy.route_file is not None
            else ("given" if self.route is not None else None)  # (replay --route-known)
        )
        # The lead ground vehicle's mode (a rover's: its mission, a stand, or else), as
        # heard, each change for the road mission's next step (every one, in order: a
        # HOLD then AUTO between two steps restarts a held hold) and the report.
        self._lead_id = config.convoy.vehicles[0].sysid if config.convoy.vehicles else None
        self._lead_mode: RoverMode | None = None
        # Its home (x, y: east, north), where RTL drives it: asked for until heard, and
        # again each time it is sent home (ArduPilot resets home when it arms).
        self._lead_home: tuple[float, float] | None = None
        # Asked at its heartbeats 1, 3, 6, 11, 20, 37, then every 33rd: one that never
        # answers is not asked at each heartbeat of a long mission.
        self._home_wait, self._home_gap = 0, 1
        # ArduPilot's RTL drives to the nearest rally point instead, by its RALLY_ params
        # (``rally.rtl_destination``), from where it was sent home: read at each RTL.
        self._rally: RallyRead | None = None  # (a read under way)
        self._rallies: tuple[list[tuple[float, float]], float, bool] | None = None  # (x, y)
        self._rtl_from: tuple[float, float] | None = None  # (x, y) the lead sent home at
        self._ground_xy: dict[int, tuple[float, float]] = {}  # (x, y) each last heard at
        self._mission_items: list[MissionItem] = []  # (its mission as last read)
        self._new_drives: deque[tuple[ConvoyDrive, tuple[float, float] | None]] = deque()
        self.convoy_modes: list[tuple[float, str]] = []
        # The lead ground vehicle's own mission, read as the convoy's route.
        self._mission_watch = (
            MissionWatch(self._lead_id, own=config.source_system)
            if config.convoy.route_from_mission and self._lead_id is not None
            else None
        )
        # The mission step running in its worker thread, if one is.
        self._mission_job: (
            asyncio.Future[tuple[list[Any], MissionView, list[tuple[int, Setpoint]], int]] | None
        ) = None
        self._mission_job_t = 0.0  # (the running step's mission time)
        self._replan_lag = ReplanLag()  # how long a step's re-plans take to be flown
        self._next_fence_look = -math.inf  # (the worker's: when it next looks along the plan)
        self._planner_note = f"planner: {self.planner} ({why})"
        # What the streamer and the monitor read: swapped after each mission step.
        self.view = MissionView()
        self.replans: list[dict[str, Any]] = []
        self.alarms: list[dict[str, Any]] = []
        self.events: list[str] = []
        self.paused = False
        self._stopping = False
        self._stopped = False  # every UAV told how to end: the retained status says so
        self._vehicle_alarms: set[str] = set()  # "uav_lost:3": active per-vehicle alarms
        self._airframe_range: dict[int, tuple[float | None, ...]] = {}  # as alarmed
        self._last_est: ConvoyEstimate | None = None
        self._route_t0: float | None = None  # mission time the scripted convoy set off
        self.why_not_counted: dict[int, str | None] = {}  # latest, per UAV
        self._not_counted_s: dict[int, dict[str, float]] = {}  # protect-phase seconds per reason
        self._counted_t: float | None = None
        self._silence: tuple[float, float | None] | None = None  # fleet-wide: (began, ended)

    @staticmethod
    def _load_route(config: MissionConfig) -> tuple[Road, PlannedRoute]:
        """The convoy's route file as a road in the mission frame, and the route as read,
        with the convoy's plan on it if the file carries one (a rover's saved mission, a
        JSON route with holds, speeds or laps)."""
        path = config.convoy.route_file
        assert path is not None
        try:
            saved = load_planned_route(path)
            return Road.from_geo(saved.points, LocalFrame(config.origin)), saved
        except (OSError, ValueError) as exc:
            raise ConfigError("convoy.route", path, f"cannot be used as a route ({exc})") from exc

    # ------------------------------------------------------------------ inputs

    def _route(self, owner: int, msg: Any) -> None:
        """Every decoded message from every link lands here (must stay cheap).

        A link is one vehicle's (``owner``): a frame on it with another system id
        (another UAV's, spoofed; a GCS's) is dropped and counted, never delivered.
        """
        sysid = msg.get_srcSystem()
        if sysid != owner:
            self._foreign_sysid[owner] += 1
            if sysid in self.vehicles or sysid in self._ground_ids:  # a spoof, not a GCS
                self._foreign_claims[owner] += 1
            else:
                self._other_controller(owner, sysid, msg)
            return
        vehicle = self.vehicles.get(sysid)
        if vehicle is not None:
            vehicle.handle(msg)
            return
        watch = self._mission_watch
        if watch is not None and sysid == watch.target[0]:
            mission = self.clock.now() if self.clock.synced else 0.0
            self._mission_sends(watch.handle(msg, time.monotonic(), mission))
        if self._rally is not None and sysid == self._lead_id:
            self._rally_sends(self._rally.handle(msg, time.monotonic()))
        if sysid in self._ground_ids and msg.get_type() == "HEARTBEAT":
            if sysid == self._lead_id:
                self._lead_heartbeat(sysid, msg)
            elif (mode := rover_mode(msg)) is not None:
                self._follower_modes[sysid] = mode
            self._judge_apart()
        elif sysid == self._lead_id and msg.get_type() == "HOME_POSITION":
            self._lead_home_heard(msg)
        elif sysid in self._ground_ids and msg.get_type() == "PARAM_VALUE":
            if msg.param_id == "SIM_SPEEDUP":  # (a simulated convoy slowed with the UAVs)
                self.clock.rate_set(float(msg.param_value), sysid)
        elif sysid in self._ground_ids and msg.get_type() == "GLOBAL_POSITION_INT":
            if no_position_yet(msg.lat, msg.lon):
                return
            if self.clock.observe(msg.time_boot_ms, sysid) is Observed.REJECTED:
                self._ground_rejected += 1
                return
            if not self.clock.synced:
                return
            t = self.clock.to_mission(msg.time_boot_ms, sysid)
            north, east, _ = self.frame.to_ned(GeoPoint(msg.lat * 1e-7, msg.lon * 1e-7))
            # vx, vy: the vehicle's own NED ground velocity, cm/s (the tracker judges it)
            velocity = (msg.vx * 0.01, msg.vy * 0.01)
            self._convoy_fix(t, north, east, sysid, velocity)
            self._ground_heard[sysid] = t
            self._ground_xy[sysid] = (east, north)

    def _lead_heartbeat(self, sysid: int, msg: Any) -> None:
        """The lead ground vehicle's mode: a change is noted and told the road mission
        (``ConvoyModel.set_drive``)."""
        mode = rover_mode(msg)
        if mode is None:
            return
        homeward = mode.drive is ConvoyDrive.HOME and mode != self._lead_mode
        if homeward:  # (its home may be new: ask at once; and where it goes instead)
            self._home_wait, self._home_gap = 0, 1
            self._rtl_from, self._rallies = self._ground_xy.get(sysid), None
            if msg.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA and self._ground_links:
                self._rally = RallyRead(sysid, own=self.config.source_system)
                self._rally_sends(self._rally.start(time.monotonic()))
        if (self._lead_home is None or homeward) and self._ground_links:
            if self._home_wait > 0:
                self._home_wait -= 1
            else:
                self._ground_links[0].send(_home_request(sysid))
                self._home_wait, self._home_gap = self._home_gap, min(2 * self._home_gap, 32)
        if mode == self._lead_mode:
            return
        was, self._lead_mode = self._lead_mode, mode
        back = (  # (AUTO after SMART_RTL resumes its mission as after RTL)
            mode.drive is ConvoyDrive.MISSION
            and was is not None
            and was.drive in (ConvoyDrive.HOME, ConvoyDrive.RETRACE)
        )
        where = self._lead_destination() if homeward else (self._resumed_at() if back else None)
        self._new_drives.append((mode.drive, where))
        if len(self.convoy_modes) < _MODES_KEPT:
            self.convoy_modes.append((round(self.clock.now(), 1), mode.name))
        watch = self._mission_watch
        driving = "drives its mission"
        if back and where is not None and watch is not None:
            driving += f", straight back to item {watch.current} of it first"
        going = "drives home: forecast straight there, where it stands"
        if self._lead_home is None:
            going = "drives home, not known yet: forecast from its own velocity"
        what = {
            ConvoyDrive.MISSION: driving,
            ConvoyDrive.HELD: "stands until its mode changes",
            ConvoyDrive.OTHER: "is driven otherwise: its mission's plan is set aside",
            ConvoyDrive.HOME: going,
            ConvoyDrive.RETRACE: (
                "drives home back along its path: forecast back along the path it was seen "
                "to drive, where it stands at its start; its mission's plan is set aside"
            ),
        }[mode.drive]
        since = "" if was is None else f" (was {was.name})"
        self._note(f"ground vehicle {sysid} in {mode.name}{since}: it {what}")

    def _resumed_at(self) -> tuple[float, float] | None:
        """Where (x, y) the lead drives back to in AUTO after RTL: the waypoint its
        MISSION_CURRENT still names (``AP_Mission::resume``), if its mission was read."""
        watch = self._mission_watch
        if watch is None or watch.current is None:
            return None
        item = next((i for i in self._mission_items if i.seq == watch.current), None)
        at = None if item is None else driven_to(item)
        if at is None:
            return None
        return self._xy(*at)

    def _lead_home_heard(self, msg: Any) -> None:
        """The lead ground vehicle's HOME_POSITION: where RTL takes it (on its way
        there already, the road mission is told at once)."""
        if no_position_yet(msg.latitude, msg.longitude):
            return
        home = self._xy(msg.latitude * 1e-7, msg.longitude * 1e-7)
        if home == self._lead_home:
            return
        self._lead_home = home
        mode = self._lead_mode
        if mode is not None and mode.drive is ConvoyDrive.HOME:
            self._new_drives.append((ConvoyDrive.HOME, self._lead_destination()))

    def _lead_destination(self) -> tuple[float, float] | None:
        """Where the lead's RTL takes it (x, y): its home, or the rally point its firmware
        picks from where it was sent home (``rtl_destination``); None: home not known."""
        home, rallies, here = self._lead_home, self._rallies, self._rtl_from
        if home is None or rallies is None or here is None:
            return home
        points, limit_km, incl_home = rallies
        return rtl_destination(here, home, points, limit_km, incl_home)

    def _rally_sends(self, out: Sequence[Any]) -> None:
        """Send a rally read's requests to the lead; take it once done, and tell the road
        mission the lead's way if a rally point is where it goes."""
        for msg in out:
            self._ground_links[0].send(msg)
        read = self._rally
        if read is None or not read.done:
            return
        self._rally = None
        who = f"ground vehicle {read.target[0]}"
        if read.error is not None:
            self._note(f"{who}'s rally points not read: it {read.error}; forecast home")
            return
        points = [self._xy(lat, lon) for lat, lon in read.points]
        self._rallies = (points, read.limit_km, read.incl_home)
        mode, where = self._lead_mode, self._lead_destination()
        if mode is None or mode.drive is not ConvoyDrive.HOME or where == self._lead_home:
            return
        self._new_drives.append((ConvoyDrive.HOME, where))
        assert where is not None and self._rtl_from is not None
        far = math.dist(where, self._rtl_from)
        nearer = ", nearer than home" if read.incl_home else ""
        self._note(
            f"{who} in RTL drives to its rally point {points.index(where) + 1} of "
            f"{len(points)}, {far:.0f} m off (its nearest, within RALLY_LIMIT_KM "
            f"{read.limit_km:g}{nearer}): forecast straight there, where it stands"
        )

    def _xy(self, lat: float, lon: float) -> tuple[float, float]:
        """(x, y): east, north in the mission frame."""
        north, east, _ = self.frame.to_ned(GeoPoint(lat, lon))
        return east, north

    def _mission_sends(self, out: Sequence[Any]) -> None:
        """Send a mission read's requests to the lead ground vehicle; take a finished read."""
        for msg in out:
            self._ground_links[0].send(msg)
        watch = self._mission_watch
        read = None if watch is None else watch.take()
        if watch is None or read is None:
            return
        sysid = watch.target[0]
        if read.error is not None:
            self._note(f"ground vehicle {sysid}'s mission not read: it {read.error}")
            return
        self._mission_items = read.items or []
        try:
            route = mission_route(
                read.items or [], home_first=watch.ardupilot, default_speed=watch.default_speed
            )
        except ValueError as exc:
            self._note(f"ground vehicle {sysid}'s mission is no route yet: {exc}")
            return
        self.set_route(route, source=f"ground vehicle {sysid}'s mission")

    def _on_mqtt_convoy(self, fix: Mapping[str, Any]) -> None:
        """A convoy position from ``<prefix>/convoy/position`` (already validated)."""
        if "lat" in fix:
            north, east, _ = self.frame.to_ned(GeoPoint(fix["lat"], fix["lon"]))
        else:
            north, east = fix["north"], fix["east"]
        if self.config.convoy.source == "mqtt" and self.clock.synced:
            source = fix.get("source")
            self.convoy_fix(
                north,
                east,
                fix.get("t"),
                source="external" if source is None else f"mqtt:{source}",
                velocity=fix.get("velocity"),
            )

    def convoy_fix(
        self,
        north: float,
        east: float,
        t: float | None = None,
        *,
        source: str = "external",
        velocity: tuple[float, float] | None = None,
    ) -> bool:
        """An external convoy fix (MQTT, replay) in the mission frame, from ``source``
        (each vehicle its own: the estimate is the centroid of their latest fixes), with
        the ``(vn, ve)`` it reports, if any.

        A fix stamped outside ``_FIX_WINDOW_S`` of mission time now is dropped and
        counted: it would move the estimate, and every plan, to another time.
        """
        now = self.clock.now()
        if t is not None and not now - _FIX_WINDOW_S[0] <= t <= now + _FIX_WINDOW_S[1]:
            self._fixes_rejected += 1
            if self._fixes_rejected == 1 or self._fixes_rejected % 100 == 0:
                log.warning(
                    "convoy fix at t=%.6g dropped: mission time is %.1f (%d dropped)",
                    t, now, self._fixes_rejected,
                )  # fmt: skip
            return False
        return self._convoy_fix(now if t is None else t, north, east, source, velocity)

    def _convoy_fix(
        self,
        t: float,
        north: float,
        east: float,
        source: Source,
        velocity: tuple[float, float] | None,
    ) -> bool:
        """A fix of one of the convoy's vehicles into its estimate; a vehicle that parts
        from the lead's group, or rejoins it, said."""
        used = self.tracker.update(t, north, east, source=source, velocity=velocity)
        if self.tracker.parted != self._parted:
            self._say_parted(t)
        return used

    def _judge_apart(self) -> None:
        """Keep apart from the convoy each follower whose mode has said for
        ``_APART_AFTER_S`` that it left (``_left_by_mode``): parted however near, rather
        than only once 2 sensor radii off with the convoy dragged back towards it
        meanwhile; and let it rejoin once its mode no longer says so."""
        t, lead = self.clock.now(), self._lead_mode
        for sysid, mode in self._follower_modes.items():
            why = _left_by_mode(mode, lead)
            if why is None:
                self._apart_since.pop(sysid, None)
                if self._apart_why.pop(sysid, None) is not None:
                    self.tracker.keep_apart(sysid, False)
                continue
            since = self._apart_since.setdefault(sysid, t)
            if t - since >= _APART_AFTER_S and self._apart_why.get(sysid) != why:
                self._apart_why[sysid] = why
                self.tracker.keep_apart(sysid, True)

    def _say_parted(self, t: float) -> None:
        """Alarm a vehicle parted from the convoy (no longer in the centroid the UAVs
        protect: stopped while the rest drive on, sent home, gone elsewhere), and clear
        it when it rejoins or is no longer heard."""
        tracker, was = self.tracker, self._parted
        self._parted = now = tracker.parted
        for source in sorted(now - was, key=str):
            apart = tracker.apart(source)
            why = self._apart_why.get(source) if isinstance(source, int) else None
            if why is None and source in tracker.standing:
                why = f"it has stood {STAND_S:.0f} s while the lead drove on"
            if why is None:
                far = "" if apart is None else f"{apart:.0f} m from the nearest of the rest, "
                why = f"{far}beyond {tracker.part_m:.0f} m"
            self._alarm(
                Alarm(t, "convoy_parted", True, f"{_source_name(source)} parted from the "
                      f"convoy ({why}): the UAVs protect the rest, not it")
            )  # fmt: skip
            self.convoy_parted.append(
                {"t": t, "source": source, "event": "parted", "apart_m": apart, "why": why}
            )
        for source in sorted(was - now, key=str):
            back = source in tracker.sources
            what = "rejoined the convoy" if back else "is no longer heard"
            self._alarm(Alarm(t, "convoy_parted", False, f"{_source_name(source)} {what}"))
            self.convoy_parted.append(
                {"t": t, "source": source, "event": "rejoined" if back else "silent"}
            )

    def command(self, command: str) -> None:
        """Operator command: ``pause`` (every UAV loiters) or ``resume``."""
        if command == "pause" and not self.paused:
            self.paused = True
            for v in self.vehicles.values():
                asyncio.get_running_loop().create_task(v.hold(), name=f"{v.name}.hold")
            self._note("operator: pause, every UAV told to loiter")
        elif command == "resume" and self.paused:
            self.paused = False
            for v in self.vehicles.values():
                v.resume()
            self._note("operator: resume")
        elif command == "resume" and self._taken:
            for sysid in sorted(self._taken):
                self.vehicles[sysid].resume()
            self._note(f"operator: resume UAVs {sorted(self._taken)} taken by another")

    def _on_vehicle_event(self, event: VehicleEvent) -> None:
        self._note(event.message, logged=True)  # (the vehicle has logged it at its level)
        vehicle = self.vehicles.get(event.sysid)
        if (
            event.kind == EventKind.MODE
            and vehicle is not None
            and not self.paused
            and not self._stopping  # (the end of the mission's own holds are no failsafe)
            and vehicle.hold_is_ours(event.t)
        ):
            # Our own setpoint stream hiccupped (a stalled host, a lossy link, a link
            # just back after an outage, whose failsafe text may have been lost with
            # it) and the autopilot fell back to its hold: take control back.  Any
            # other mode change is a pilot's, and is respected.
            self._take_back(vehicle)
        elif (
            event.kind == EventKind.MODE
            and not self.paused
            and not self._stopping
            and vehicle is not None
        ):
            # A pilot or another ground station took the UAV -- unless it turns out, in a
            # moment, to have rebooted (its mode changes before the reboot is confirmed).
            self._taken_pending[event.sysid] = (event.t, vehicle.counters["reboots"], event.message)
        if event.kind is EventKind.REJECTED:
            self._alarm(Alarm(event.t, "telemetry_rejected", True, event.message), event.sysid)
        if event.kind is EventKind.CONTESTED and vehicle is not None:
            active = vehicle.contested is not None
            self._alarm(Alarm(event.t, "uav_contested", active, event.message), event.sysid)
        if (
            event.kind is EventKind.FAILED
            and self.vehicles
            and all(v.refused for v in self.vehicles.values())
        ):
            self.refused = (
                "every UAV is driven by another ground station; stop it, or give this "
                "service other UAVs"
            )
            self._note(f"refused: {self.refused}")
            if self._stop_event is not None:
                self._stop_event.set()
        elif (
            event.kind is EventKind.FAILED
            and not self.clock.synced
            and all(v.status is VehicleStatus.FAILED for v in self.vehicles.values())
        ):
            # (no mission time ever began: the run's end would never come)
            self._note("stopping: every UAV failed its set-up before sending any telemetry")
            if self._stop_event is not None:
                self._stop_event.set()
        if event.kind in (EventKind.LOST, EventKind.FAILED, EventKind.RECOVERED):
            active = event.kind != EventKind.RECOVERED
            kind = "uav_lost" if event.kind == EventKind.RECOVERED else f"uav_{event.kind}"
            self._alarm(Alarm(event.t, kind, active, event.message), event.sysid)

    def _check_taken(self, t: float) -> None:
        """A mode change not ours, still in force ``_TAKEN_CONFIRM_S`` later and no reboot
        meanwhile: the UAV was taken. Respected, alarmed; the others re-phase around it
        until the operator resumes it."""
        for sysid, (since, reboots, message) in list(self._taken_pending.items()):
            if t - since < _TAKEN_CONFIRM_S:
                continue
            del self._taken_pending[sysid]
            v = self.vehicles[sysid]
            if v.status is not VehicleStatus.HOLDING:
                continue
            if v.hold_is_ours(since):  # (its stream-loss text came after the HEARTBEAT)
                self._take_back(v)
            elif v.counters["reboots"] == reboots:
                self._taken.add(sysid)
                self._alarm(Alarm(t, "uav_taken", True, f"{message}; the others re-phase"), sysid)

    def _take_back(self, vehicle: Vehicle) -> None:
        """Fly a UAV our own stream's failsafe held again. (The vehicle reports the mode
        change before it marks itself HOLDING: resumed on the next turn of the loop.)"""
        self._note(f"uav{vehicle.uid}: re-engaging after a setpoint-loss failsafe")
        asyncio.get_running_loop().call_soon(vehicle.resume)

    def _plan_leaves_fence(
        self, t: float, view: MissionView, skip: set[int]
    ) -> list[tuple[int, Setpoint]]:
        """Where the plan's paths leave the fence in the next two minutes: a setpoint per
        UAV (those in ``skip`` already alarmed). Runs in the mission's worker thread."""
        fence = self.fence
        if fence is None or t < self._next_fence_look:
            return []
        self._next_fence_look = t + self._progress_every
        found = []
        for sysid in self.vehicles.keys() - skip:
            for k in range(_FENCE_LOOK_STEPS):
                sp = view.setpoint(sysid, t + k * _FENCE_LOOK_DT)
                if sp is not None and not fence.allows(sp):
                    found.append((sysid, sp))
                    break
        return found

    def _alarm_plan_fence(self, t: float, found: list[tuple[int, Setpoint]]) -> None:
        """A plan that leaves the fence is alarmed, naming the UAV and the point, once per
        UAV until its alarms clear (the streamer keeps every setpoint inside anyway)."""
        for sysid, sp in found:
            p = self.frame.to_geo(sp.north, sp.east, sp.down)
            self._alarm(
                Alarm(t, "fence_plan", True, f"UAV {sysid}'s plan leaves the fence at "
                      f"{p.lat:.6f}, {p.lon:.6f}, {-sp.down:.0f} m (t={sp.t:.0f} s): "
                      "flown clamped inside it"),
                sysid,
            )  # fmt: skip

    def _check_safety(self, t: float, est: ConvoyEstimate | None) -> None:
        """Fence (the convoy outside it, setpoints clamped) and separation alarms."""
        fence = self.fence
        if fence is not None:
            clamps = sum(self._fence_clamps.values())
            if clamps > self._fence_seen and t >= self._fence_alarm_t + _PROGRESS_ALARM_S:
                self._fence_seen, self._fence_alarm_t = clamps, t
                self._alarm(Alarm(t, "fence", True, f"{clamps} setpoints clamped inside the fence"))
            if est is not None and not est.stale:
                self._check_convoy_in_fence(t, fence, est)
        safety = self.config.safety
        positions = {
            s: (tel.north, tel.east, tel.down)
            for s, v in self.vehicles.items()
            if (tel := v.telemetry) is not None and v.airborne
        }
        pairs = conflicts(positions, safety.min_separation_m, safety.min_vertical_separation_m)
        now = {(c.a, c.b) for c in pairs}
        for c in pairs:
            self._closest_m = min(self._closest_m or math.inf, c.horizontal_m)
            if (c.a, c.b) not in self._conflicts:
                self._conflict_count += 1
                self._alarm(
                    Alarm(t, "separation", True, f"UAVs {c.a} and {c.b} {c.horizontal_m:.0f} m "
                          f"apart, {c.vertical_m:.1f} m vertically"),
                )  # fmt: skip
        if self._conflicts and not now:
            self._alarm(Alarm(t, "separation", False, "separation restored"))
        self._conflicts = now

    def _check_convoy_in_fence(self, t: float, fence: Fence, est: ConvoyEstimate) -> None:
        """A convoy outside the fence is not followed out: the UAVs hold inside, on one
        circle of the turn radius nearest it (moved when the convoy has gone 2 R along),
        until the convoy is back ``fence_margin_m`` inside."""
        n, e = est.north, est.east
        out = not fence.contains(n, e, fence.margin_m if self._convoy_out else 0.0)
        if out:
            radius = self._turn_radius
            try:
                center = fence.hold_center(n, e, radius)
            except ValueError:  # (no room for a loiter circle: setpoints are clamped)
                center = None
            hold = self._hold
            if center is None or hold is None or math.dist(center, hold) > 2.0 * radius:
                self._place_hold(t, center)
        else:
            self._place_hold(t, None)
        if out == self._convoy_out:
            return
        self._convoy_out = out
        if not out:
            text = "convoy back inside the fence: the UAVs fly the plan again"
        elif self._hold is None:
            text = "convoy left the fence, which has no room for a hold: flown clamped"
        else:
            p = self.frame.to_geo(*self._hold, 0.0)
            text = f"convoy left the fence: the UAVs hold inside it at {p.lat:.6f}, {p.lon:.6f}"
        self._alarm(Alarm(t, "convoy_outside_fence", out, text))

    def _place_hold(self, t: float, center: tuple[float, float] | None) -> None:
        """Each UAV joins the hold circle turning its own way, from abeam of where it is
        (no race round the circle for a slot; the altitude layers keep them apart)."""
        self._hold = center
        self._hold_orbits.clear()
        if center is None:
            return
        for sysid, v in self.vehicles.items():
            tel = v.telemetry
            self._hold_orbits[sysid] = (
                (0.0, True)
                if tel is None
                else join_orbit(
                    t, center, self._turn_radius, self._airspeed,
                    (tel.north, tel.east), (tel.vn, tel.ve),
                )
            )  # fmt: skip

    def _other_controller(self, owner: int, sysid: int, msg: Any) -> None:
        """Another controller's frame on a UAV's link (a shared link: a router, a radio):
        commands for that UAV, or a ground station using our own ids (this service
        started twice). A GCS that only watches (its heartbeat, other ids) is fine."""
        vehicle = self.vehicles.get(owner)
        if vehicle is None:
            return
        cfg = self.config
        kind = msg.get_type()
        if kind in _COMMANDING and getattr(msg, "target_system", None) == owner:
            vehicle.stranger(f"system {sysid} sends it {kind}")
        elif (
            kind == "HEARTBEAT"
            and msg.type == mavlink.MAV_TYPE_GCS
            and (sysid, msg.get_srcComponent()) == (cfg.source_system, cfg.source_component)
        ):
            vehicle.stranger(f"another ground station uses our ids {sysid}/{cfg.source_component}")

    def _check_planner(self, t: float) -> None:
        """Say when the road planner falls behind its re-plans, and when it catches up.

        Its re-plans run in the mission's worker thread; on a host short of CPU for
        the speedup (a simulator at 40x and the service on one core) each UAV is
        re-planned less often than ``replan_every_s``, and coverage pays for it.
        """
        mission = self.mission
        if not isinstance(mission, RoadMission):
            return
        every = mission.settings.replan_every_s
        lag = mission.replan_interval_s
        behind = lag is not None and lag > _PLANNER_BEHIND * every
        if behind and not self._planner_behind:
            text = (
                f"planner behind: each UAV re-planned every {lag:.1f} mission s instead of "
                f"{every:g} (the host is short of CPU at this speedup)"
            )
            log.warning("%s", text)
            self._note(text, logged=True)
        elif self._planner_behind and not behind:
            self._note(f"planner caught up: re-plans every {lag:.1f} mission s")
        self._planner_behind = behind
        self._check_replan_lag(t)

    def _check_convoy_speed(self, t: float) -> None:
        """Alarm while the convoy drives faster than the road pattern can follow it to a
        stop (``convoy_fast``: ``FAST_CONVOY_RATIO`` of the airspeed), and while it
        outruns the UAVs' fastest speed (``convoy_outruns``: the top of the road
        planner's speed band); each cleared once the convoy has been back under 0.9 of
        its bound for 30 s (``_speed_alarm``: no flicker in traffic). No plan
        covers either: the operator learns it from the alarm before a gap shows it,
        and what aircraft would (twice the convoy's speed)."""
        mission = self.mission
        if not isinstance(mission, RoadMission) or (ratio := mission.speed_ratio) is None:
            return
        top = mission.settings.speed_band[1]
        self._speed_alarm(t, "convoy_fast", ratio, FAST_CONVOY_RATIO)
        self._speed_alarm(t, "convoy_outruns", ratio, top)

    def _check_convoy_way(self) -> None:
        """Say when the convoy sent home (or back to its route) is seen to drive elsewhere
        past its turn round (``ConvoyModel.astray``: a rally point nearer than home, a
        home moved, SMART_RTL's way back read as RTL), and when it heads there again."""
        mission = self.mission
        if not isinstance(mission, RoadMission) or mission.model.astray == self._astray:
            return
        self._astray = mission.model.astray
        who = f"ground vehicle {self._lead_id}"
        if self._astray:
            self._note(
                f"{who} drives elsewhere than it was forecast to (a rally point nearer than "
                "home, or a home moved?): forecast from its own velocity"
            )
        else:
            self._note(f"{who} heads where it was forecast to again")

    def _speed_alarm(self, t: float, kind: str, ratio: float, bound: float) -> None:
        """Raise ``kind`` at ``bound`` (a speed ratio); clear it once the convoy has been
        below 0.9 of that for ``_FAST_CLEARS_AFTER_S``: in city traffic the recorded drive
        crossed half the airspeed 24 times an hour, often 10-20 s apart."""
        speed = ratio * self._airspeed
        if kind not in self._speed_alarms:
            if ratio >= bound:
                self._speed_alarms[kind] = None
                self._alarm(Alarm(t, kind, True, self._speed_text(kind, speed, bound)))
            return
        slowed = self._speed_alarms[kind]
        if ratio >= _FAST_CLEARS * bound:
            self._speed_alarms[kind] = None  # (fast again: the hold starts over)
        elif slowed is None:
            self._speed_alarms[kind] = t
        elif t - slowed >= _FAST_CLEARS_AFTER_S:
            del self._speed_alarms[kind]
            self._alarm(Alarm(t, kind, False, f"convoy slowed to {speed:.1f} m/s"))

    def _speed_text(self, kind: str, speed: float, bound: float) -> str:
        """What a convoy speed alarm says when raised (built then, not every tick)."""
        if kind == "convoy_outruns":
            return (
                f"convoy at {speed:.1f} m/s, faster than the UAVs fly "
                f"({bound * self._airspeed:.1f} m/s at most): they fall behind it until it slows"
            )
        return (
            f"convoy at {speed:.1f} m/s, {bound:g} of the airspeed or more: the UAVs' arcs "
            "barely turn back towards it, and a stop from this fast can leave it unseen "
            "10-20 s while they turn round; aircraft of twice its speed would cover it"
        )

    def _check_replan_lag(self, t: float) -> None:
        """Say when re-plans reach the UAVs late in mission time, and when they have stayed
        on time a while again.

        The road mission lays a re-plan's legs that far ahead on the paths in force
        (``ReplanLag``), so the UAVs fly them correctly, but later: in simulation a
        lag of 0.1 mission s a UAV cost 0.7 points of coverage on 26 roads without a
        route, 0.2-0.4 s two points, and the urban grids four (the mock at 40x on two
        cores: 0.3-0.6 s). At real time it is a control tick: late is ``_REPLANS_LATE_S``
        past it, and on time again under half that for ``_ON_TIME_FOR_S`` (the fit of a
        host near the bar swings across it every 10-30 s: one event, not a dozen).
        Warned the first time, with the remedy (the speedup that would bring it there);
        noted each time it comes back.
        """
        past = self._replans_past()
        if past is None:
            return
        lag = past + self._control_dt
        late_since = self._replans_late_t
        if past > (_REPLANS_LATE_S if late_since is None else _REPLANS_LATE_S / 2.0):
            if late_since is None:
                self._warn_once("replans_late", self._replans_late_text(past, lag))
            self._replans_late_t = t
        elif late_since is not None and t - late_since >= _ON_TIME_FOR_S:
            self._note(f"re-plans on time again: {lag:.2f} mission s for {t - late_since:.0f} s")
            self._replans_late_t = None

    def _replans_late_text(self, past: float, lag: float) -> str:
        """The late re-plans' warning, with the remedy: the speedup that would bring them
        on time (the step's compute, in mission s, scales with the speedup; the tick does
        not)."""
        rate = self.clock.rate
        fits = max(1.0, rate * _REPLANS_LATE_S / past)
        remedy = (
            "a faster host"
            if rate <= _REAL_TIME_ABOVE
            else f"slowing the simulator (towards about {fits:.2g}x, not below "
            f"{self.config.sim_speedup_floor:g}x)"
            if self._slowable(rate)
            else f"lower the speedup (to about {fits:.2g}x on this host)"
        )
        return (
            f"re-plans late: a re-planned UAV flies its new legs {lag:.2f} mission s after "
            f"the step that laid them, at {rate:.3g}x; coverage pays for it on winding "
            f"roads: {remedy}"
        )

    def _replans_past(self) -> float | None:
        """Mission s past its control tick a one-UAV re-plan is flown (the lag fit's means,
        without the margin; a step is taken in at the tick after it ends), None until the
        fit has settled."""
        fit = self._replan_lag
        if not fit.settled:
            return None
        return fit.base + fit.per_uav - self._control_dt

    def _slowable(self, rate: float) -> bool:
        """Whether ``_check_speedup`` may slow a simulator running at ``rate`` (x): a floor
        is set, the simulator takes SIM_SPEEDUP, and ``rate`` is at least ``_SLOW_TAKEN``
        times the floor (nearer it, the simulator is at the floor already)."""
        floor = self.config.sim_speedup_floor
        return floor is not None and not self._speedup_refused and floor * _SLOW_TAKEN <= rate

    def _check_setpoints(self, t: float) -> None:
        """Say when setpoint rounds go out too far apart in mission time, and when they
        have stayed on time a while again.

        On a host short of CPU for the speedup (a simulator at 40x on a slow machine,
        the mock in the service's own process) the event loop falls behind mission
        time, and each round it skips is a mission second and more without a setpoint:
        PX4 leaves OFFBOARD after ``COM_OF_LOSS_T`` (1 s by default), and coverage
        pays while the service takes it back. Said at half that, with the remedy,
        before the autopilots' failsafes say it their way: warned the first time, noted
        (the report's events) each time it comes back after ``_ON_TIME_FOR_S`` on time.
        """
        streamer = self.streamer
        if streamer is None:
            return
        gap = streamer.take_widest_gap()
        if gap == 0.0:  # no round since the last look (the mission clock stood)
            return
        self._slow_gap = max(self._slow_gap, gap)
        if gap > _SETPOINTS_LATE_S:
            if self._setpoints_late_t is None:
                rate = self.clock.rate
                remedy = "at this speedup: lower it" if rate > _REAL_TIME_ABOVE else "(real time)"
                firmware = {
                    v.firmware.name for v in self.vehicles.values() if v.firmware is not None
                }
                text = (
                    f"setpoints late: {gap:.2f} mission s between two rounds at {rate:.3g}x "
                    f"({_without_setpoints(firmware)}); the host is short of CPU {remedy}"
                )
                self._warn_once("setpoints_late", text)
            self._setpoints_late_t = t
        elif self._setpoints_late_t is not None and t - self._setpoints_late_t >= _ON_TIME_FOR_S:
            self._note(
                f"setpoints on time again: rounds at most {_SETPOINTS_LATE_S:g} mission s apart "
                f"for {t - self._setpoints_late_t:.0f} s"
            )
            self._setpoints_late_t = None

    def _check_speedup(self, t: float) -> None:
        """Halve a simulator's speedup (``SIM_SPEEDUP`` to every UAV) when the host has
        fallen behind it, down to ``sim_speedup_floor`` (unset: never).

        A host short of CPU for the speedup flies worse plans, not just later ones:
        re-plans come rarer, setpoint rounds late, PX4 leaves OFFBOARD (the turning
        demo at 40x on a slow 2-core host: 63-91 % covered, against 98.6 % at 20x and
        99.3 % at 10x). Behind is the planner behind, the control loop held up
        ``_SLOW_STALLED`` of the last ``_SLOW_LOOK_S`` mission s or more, two setpoint
        rounds ``_SLOW_GAP_S`` apart in them, or re-plans flown ``_SLOW_REPLANS_S`` past
        their tick once the lag fit has taken ``_SLOW_REFIT`` steps in at this speedup
        (the re-plans' compute is mission seconds at a high speedup; the urban grid with
        its route on the mock: 94.4 % at 40x, 0.37 mission s a UAV, against 97.3 % at
        10x, 0.07 s); a change is judged after as long again.

        The gap is half PX4's ``COM_OF_LOSS_T``: a host that has used half the margin
        once uses all of it sooner or later, and then every UAV leaves OFFBOARD at once
        (``make demo`` at 40x on a slow 2-core host: rounds up to 0.94 s apart in seven
        runs of ten, and in three 1.7-3.4 s, fleet-wide failsafes, in two of them 98.3
        and 98.5 % covered, when it took a whole second to act). It is acted on
        ``_SLOW_GAP_SETTLE_S`` into a look, not at its end (at 1 s, ``make demo`` at 40x
        on a slow host lost 2-3 % of its coverage to the failsafes that came before the
        first look). A simulator that
        keeps its speed (PX4 SITL, whose speed is an environment variable) is told
        about once, and left alone.
        """
        floor = self.config.sim_speedup_floor
        if floor is None or self._speedup_refused:
            return
        look = self._slow_look
        if look is None:
            self._slow_look = (t, self._stalled_s)
            return
        looked = t - look[0]
        if looked < _SLOW_LOOK_S and not (
            looked >= _SLOW_GAP_SETTLE_S and self._slow_gap >= _SLOW_GAP_S
        ):
            return
        self._slow_look = (t, self._stalled_s)
        rate = self.clock.rate
        asked = self._speedup_asked
        if asked is not None and rate > _SLOW_TAKEN * asked:
            self._speedup_refused = True
            self._note(
                f"the simulator kept {rate:.3g}x, not the {asked:.3g}x asked: it takes no "
                "SIM_SPEEDUP; lower its speedup yourself"
            )
            return
        stalled = (self._stalled_s - look[1]) / looked
        gap, self._slow_gap = self._slow_gap, 0.0
        past = self._replans_past()
        late = (
            past is not None
            and past > _SLOW_REPLANS_S
            and self._replan_lag.planned - self._slowed_at_plans >= _SLOW_REFIT
        )
        if not (self._planner_behind or stalled >= _SLOW_STALLED or gap >= _SLOW_GAP_S or late):
            return
        if not self._slowable(rate):
            return  # (at the floor)
        target = max(floor, rate / 2.0)
        asked_any = [v.send_param_set("SIM_SPEEDUP", target) for v in self.vehicles.values()]
        if not any(asked_any):
            return
        # The convoy's simulator too, if it is one: the world slows as a whole, and the
        # mission clock's reference may be a ground vehicle (the first heard), whose
        # word on its new rate is then the one the clock takes (``rate_set``).
        for link, g in zip(self._ground_links, self.config.convoy.vehicles, strict=True):
            link.send(param_set_message(g.sysid, 1, "SIM_SPEEDUP", target))
        self._speedup_asked = target
        self._slowed_at_plans = self._replan_lag.planned
        why = (
            "the planner behind"
            if self._planner_behind
            else f"loop held up {stalled:.0%}"
            if stalled >= _SLOW_STALLED
            else f"setpoint rounds {gap:.1f} s apart"
            if gap >= _SLOW_GAP_S
            else f"re-plans flown {past:.2f} mission s past their tick"
        )
        text = f"simulator slowed from {rate:.3g}x to {target:.3g}x: the host fell behind ({why})"
        log.warning("%s", text)
        self._note(text, logged=True)

    def _check_links(self, t: float) -> None:
        """Alarm on strangers at a UAV's link: a second peer refused, or frames that
        claim another vehicle's system id (a GCS's own heartbeats are only counted)."""
        for sysid, vehicle in self.vehicles.items():
            refused = _link_rejections(vehicle.link)
            claims = self._foreign_claims[sysid]
            total = sum(refused.values()) + claims
            if total > self._foreign_seen.get(sysid, 0):
                self._foreign_seen[sysid] = total
                text = (
                    f"UAV {sysid}: refused {refused['foreign_peer']} datagrams of a foreign "
                    f"peer, {refused['unsigned']} unsigned and {refused['bad_signature']} badly "
                    f"signed frames, {claims} frames claiming another vehicle's id"
                )
                self._alarm(Alarm(t, "link_stranger", True, text), sysid)

    def _warn_once(self, what: str, text: str) -> None:
        """An event for the report, logged as a warning the first time ``what`` happens
        (news the operator acts on once; its comings back are in the events)."""
        if what in self._warned:
            self._note(text)
        else:
            self._warned.add(what)
            log.warning("%s", text)
            self._note(text, logged=True)

    def _note(self, text: str, *, logged: bool = False) -> None:
        """An event for the report (and the log, unless already logged)."""
        if not logged:
            log.info("%s", text)
        self.events.append(f"t={self.clock.now():.1f} {text}")

    def _down(self, sysid: int) -> float:
        return -self._altitudes[sysid]

    # -------------------------------------------------------------- setpoints

    def _setpoint(self, sysid: int, t: float) -> Setpoint | None:
        if self.paused:
            return None
        sp = self.view.setpoint(sysid, t)
        if sp is None:  # no slot yet (its join in the worker): hold, as the keepalive would
            vehicle = self.vehicles.get(sysid)
            return None if vehicle is None else vehicle.hold_setpoint()
        fence = self.fence
        if fence is None:
            return sp
        hold = self._hold
        if hold is not None:  # (the convoy is outside the fence)
            phase, clockwise = self._hold_orbits.get(sysid, (0.0, True))
            sp = orbit_setpoint(
                t, hold, self._turn_radius, self._airspeed, phase, sp.down, clockwise=clockwise
            )
        until = self._fence_clear_until.get(sysid)
        if (
            until is not None
            and until[0] <= t <= until[1]
            and sp.radius <= 2.0 * self._turn_radius
            and fence.altitude_allows(sp)
        ):
            return sp  # (well inside: it cannot have reached an edge since it was measured)
        safe = fence.clamp(sp)  # (the last line of defence: never a setpoint outside)
        if safe is sp:
            # Setpoints move at most the plan's speed (+15 %, twice for margin), and a loiter
            # centre lies within an arc's radius (at most 2R) of its point: until the edge
            # is that far, the next setpoints need no look at the fence's edges.
            room = fence.clearance(sp.north, sp.east) - 4.0 * self._turn_radius - fence.margin_m
            if room > 0.0:
                self._fence_clear_until[sysid] = (t, t + room / (2.0 * self._airspeed))
        else:
            self._fence_clamps[sysid] += 1
        return safe

    # ------------------------------------------------------------------- loop

    async def run(
        self, *, duration: float | None = None, stop: asyncio.Event | None = None
    ) -> ServiceReport:
        """Fly the mission until ``stop`` is set or ``duration`` mission seconds pass."""
        stop = stop or asyncio.Event()
        self._stop_event = stop
        cfg = self.config
        self._note(self._planner_note)
        # Mission work runs in a worker thread; a short GIL switch interval lets the
        # flight loop (setpoints, telemetry) in every millisecond meanwhile.
        switch = sys.getswitchinterval()
        sys.setswitchinterval(_GIL_SWITCH_S)
        async with contextlib.AsyncExitStack() as stack:
            stack.callback(sys.setswitchinterval, switch)
            recorder = None
            if cfg.tlog:
                recorder = await stack.enter_async_context(TlogRecorder(cfg.tlog))
                self._tlog_path = recorder.path  # (a new name if the file existed)
            if cfg.mqtt is not None and self.publisher is None:
                secure = mqtt_security(cfg.mqtt)
                self.publisher = await stack.enter_async_context(
                    MqttPublisher(
                        cfg.mqtt.host,
                        cfg.mqtt.port,
                        cfg.mqtt.prefix,
                        on_convoy=self._on_mqtt_convoy,
                        on_command=self.command,
                        on_route=self.set_route,
                        username=secure.username,
                        password=secure.password,
                        tls_context=secure.tls_context,
                    )
                )
            launch = self._launch_sequence()
            for uav in cfg.uav_list:
                signing = _signing(uav)
                if signing is not None:
                    stack.callback(signing.save)  # (after the link closed: its last stamps)
                link = await stack.enter_async_context(
                    MavLink(
                        uav.connection,
                        functools.partial(self._route, uav.sysid),
                        codec=MavCodec(cfg.source_system, cfg.source_component, signing=signing),
                        recorder=recorder,
                        name=f"uav{uav.sysid}",
                        peer=uav.peer,
                    )
                )
                self.vehicles[uav.sysid] = Vehicle(
                    uav.sysid,
                    link,
                    self.clock,
                    self.frame,
                    on_event=self._on_vehicle_event,
                    on_telemetry=self._track,
                    setup_timeout=cfg.setup_timeout_s,
                    lost_after=cfg.lost_after_s,
                    altitude=self._altitudes[uav.sysid],
                    max_speed=max(_MAX_SPEED_FACTOR * uav.aircraft.airspeed_mps, _MAX_SPEED_FLOOR),
                    launch=launch,
                    gcs_sysid=cfg.source_system,
                )
            ground_links = [
                await stack.enter_async_context(
                    MavLink(
                        g.connection,
                        functools.partial(self._route, g.sysid),
                        codec=MavCodec(cfg.source_system, cfg.source_component),
                        recorder=recorder,
                        name=f"ground{g.sysid}",
                        peer=g.peer,
                    )
                )
                for g in cfg.convoy.vehicles
            ]
            self._ground_links = ground_links
            streamer = SetpointStreamer(
                list(self.vehicles.values()), self._setpoint, self.clock, cfg.setpoint_rate_hz
            )
            self.streamer = streamer
            # What exists now lives for the whole mission: out of the collector's
            # sight, and the collector runs on a schedule (see gcpolicy).
            stack.enter_context(flight_gc())
            try:
                async with asyncio.TaskGroup() as tg:
                    for v in self.vehicles.values():
                        tg.create_task(v.run(), name=f"{v.name}.run")
                    tg.create_task(streamer.run(), name="convoy.stream")
                    tg.create_task(collect_on_schedule(), name="convoy.gc")
                    tg.create_task(self._control(), name="convoy.control")
                    if self.fence is not None and self.config.safety.fence:
                        tg.create_task(self._upload_fences(), name="convoy.fences")
                    if ground_links:
                        tg.create_task(self._ground_streams(ground_links), name="convoy.ground")
                    tg.create_task(self._supervise(stop, duration), name="convoy.supervise")
            except* _Stop:
                pass
        self._save_recording()
        return self._report()

    def _launch_sequence(self) -> LaunchSequence | None:
        """Take-offs near another UAV's pad in turn, clear of the separation minima by a
        half again horizontally and twice vertically (``launch.py``); None if off."""
        safety = self.config.safety
        if not safety.launch_sequence:
            return None
        return LaunchSequence(
            self._launch_fleet,
            _LAUNCH_CLEARANCE * safety.min_separation_m,
            _LAUNCH_HEADROOM * safety.min_vertical_separation_m,
        )

    def _launch_fleet(self) -> dict[int, Craft]:
        """The UAVs with a position, for the launch sequence."""
        out: dict[int, Craft] = {}
        for s, v in self.vehicles.items():
            tel = v.telemetry
            if tel is not None:
                moving = v.armed or v.airborne
                setting_up = not moving and v.status in _SETTING_UP
                layer = self._altitudes[s]
                out[s] = Craft(s, tel.north, tel.east, tel.down, layer, moving, setting_up)
        return out

    def _save_recording(self) -> None:
        """Write the road planner's inputs where the config asks (``[record] mission``)."""
        path = self.config.mission_recording
        recording = getattr(self.mission, "recording", None)
        if path is None:
            return
        if recording is None:
            self._note(f"no mission inputs recorded to {path}: only the road planner records")
            return
        try:
            recording.save(path)
        except OSError as e:
            log.error("mission inputs not recorded to %s: %s", path, e)
            self._note(f"mission inputs not recorded to {path}: {e}", logged=True)
            return
        self._note(f"mission inputs recorded to {path} ({len(recording.calls)} inputs)")

    async def _upload_fences(self) -> None:
        """Give every autopilot the fence too, once we take it (it enforces it itself)."""
        items = fence_items(self.config.safety)
        started: set[int] = set()
        async with asyncio.TaskGroup() as tg:
            while len(started) < len(self.vehicles):
                for sysid, v in self.vehicles.items():
                    if sysid not in started and v.ours:  # (not another controller's)
                        started.add(sysid)
                        tg.create_task(self._upload_fence(sysid, v, items))
                await asyncio.sleep(0.05)

    async def _upload_fence(self, sysid: int, v: Vehicle, items: Any) -> None:
        result = await v.upload_fence(items)
        self.fence_uploads[sysid] = result
        if result.endswith("uploaded"):
            self._note(f"uav{sysid}: {result}")
        else:
            self._alarm(
                Alarm(self.clock.now(), "fence_upload", True, f"UAV {sysid}: {result}"), sysid
            )

    async def _until(self, t: float) -> None:
        """Sleep until mission time ``t``, through steps of the autopilots' clock."""
        while self.clock.now() < t:
            await self.clock.sleep_until(t)

    async def _supervise(self, stop: asyncio.Event, duration: float | None) -> None:
        """Wait for the end, make every UAV loiter, then end the task group."""
        if duration is not None:
            # (a stop while no autopilot has answered yet ends the run too)
            synced = asyncio.create_task(self.clock.wait_synced(), name="convoy.sync-wait")
            stopped = asyncio.create_task(stop.wait(), name="convoy.stop-wait")
            try:
                await asyncio.wait({synced, stopped}, return_when=asyncio.FIRST_COMPLETED)
            finally:
                synced.cancel()
                stopped.cancel()
            if stop.is_set():
                duration = 0.0
            end = self.clock.now() + duration
            stopper = asyncio.create_task(stop.wait(), name="convoy.stop-wait")
            timer = asyncio.create_task(self._until(end), name="convoy.timer")
            try:
                await asyncio.wait({stopper, timer}, return_when=asyncio.FIRST_COMPLETED)
            finally:
                stopper.cancel()
                timer.cancel()
        else:
            await stop.wait()
        self._end_t = self.clock.now()
        self.monitor.end(self._end_t)
        self._stopping = True
        action = self.config.end
        told = {"loiter": "loiter where it is", "rtl": "return home", "land": "land"}[action]
        self._note(f"shutting down: every UAV told to {told}")
        ending = asyncio.gather(
            *(v.finish(action) for v in self.vehicles.values()), return_exceptions=True
        )
        try:  # (wall seconds: mission time stands still if every autopilot went quiet)
            async with asyncio.timeout(_FINISH_WALL_S):
                await ending
        except TimeoutError:
            self._note(f"shutdown: not every UAV confirmed within {_FINISH_WALL_S:g} s")
        self._stopped = True
        self._publish_state(self.clock.now())  # the retained status says "stopped"
        raise _Stop

    async def _ground_streams(self, links: list[MavLink]) -> None:
        """Ask ground vehicles for positions until they send some (ArduPilot is silent),
        and to stop the local positions nobody reads (PX4 streams them unasked, and
        ArduPilot's position group brings them along)."""
        interval = set_message_interval(
            _GROUND_POSITION_HZ, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
        )
        unread = set_message_interval(0.0, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED)
        # A mission read as the route: its progress says when it changes (ArduPilot
        # streams MISSION_CURRENT only when asked).
        progress = set_message_interval(1.0, mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)
        watch = self._mission_watch
        while True:
            now = self.clock.now() if self.clock.synced else 0.0
            if watch is not None:
                self._mission_sends(watch.poll(time.monotonic(), now))
            if self._rally is not None:
                self._rally_sends(self._rally.poll(time.monotonic()))
            for i, (link, g) in enumerate(zip(links, self.config.convoy.vehicles, strict=True)):
                if now - self._ground_heard.get(g.sysid, -math.inf) > _GROUND_STREAM_RETRY:
                    if watch is not None and i == 0:
                        link.send(progress.message(g.sysid, 1))
                    # Firmware unknown here: the modern request, and ArduPilot's stream group.
                    link.send(interval.message(g.sysid, 1))
                    link.send(
                        mavlink.MAVLink_request_data_stream_message(
                            g.sysid,
                            1,
                            mavlink.MAV_DATA_STREAM_POSITION,
                            _GROUND_POSITION_HZ,
                            1,
                        )
                    )
                    link.send(unread.message(g.sysid, 1))
            await asyncio.sleep(1.0 / max(1.0, self.clock.rate))

    def _scripted_convoy(self, t: float) -> None:
        """The scripted route sets off when the mission starts (its first control
        step), not when an autopilot booted: autopilots may have been up for hours."""
        c = self.config.convoy
        if self._route_t0 is None:
            self._route_t0 = t
        run = c.speed_mps * (t - self._route_t0)
        heading = compass_to_planner(c.heading_deg)
        north = c.start_north_m + run * math.sin(heading)
        east = c.start_east_m + run * math.cos(heading)
        self.tracker.update(t, north, east, "route")

    async def _control(self) -> None:
        await self.clock.wait_synced()
        last = self.clock.reading()
        next_progress = next_publish = last.t
        while True:
            now = self.clock.reading()
            t, held = now.t, now.since(last)
            if held > _STALL_TICKS * self._control_dt:
                self._stalled_s += held - self._control_dt  # the loop was held up
            last = now
            await self._control_step(t)
            self._check_convoy_speed(t)
            self._check_convoy_way()
            if t >= next_publish:
                next_publish = t + self._publish_every
                self._publish_state(t)
            if t >= next_progress:
                next_progress = t + self._progress_every
                self._progress(t)
                self._check_links(t)
                self._check_planner(t)
                self._check_setpoints(t)
                self._check_speedup(t)
            await self.clock.sleep_until(t + self._control_dt)

    async def _control_step(self, t: float) -> None:
        """One tick: inputs gathered here, mission work in a thread, the rest here.

        The mission's work (re-plans, joins: milliseconds to tens of them, a long
        time at a high speedup) runs in a worker thread and is not waited for: the
        tick hands it the inputs and goes on scoring coverage with the plan in
        force; its result (events and a new frozen view) is taken in at the first
        tick after it is done, and the next inputs are handed over then.
        """
        if self.config.convoy.source == "route":
            self._scripted_convoy(t)
        est = self.tracker.estimate(t)
        self._last_est = est
        job = self._mission_job
        if job is not None and job.done():
            self._mission_job = None
            events, self.view, off_fence, plans = job.result()
            self._replan_lag.observe(t - self._mission_job_t, plans)
            for ev in events:
                self._mission_event(ev)
            self._alarm_plan_fence(t, off_fence)
        if self._mission_job is None:
            view = self.view
            lost = self._newly_lost(t, view)
            flying = [s for s, v in self.vehicles.items() if v.status == VehicleStatus.FLYING]
            returned = [s for s in flying if s in view.lost]  # lost, set up again: rejoin
            for sysid in self._taken & set(flying):  # resumed by the operator
                self._taken.discard(sysid)
                self._alarm(Alarm(t, "uav_taken", False, f"UAV {sysid} resumed"), sysid)
            ready = {
                sysid: (tel.north, tel.east, tel.yaw)
                for sysid in flying
                if (tel := self.vehicles[sysid].telemetry) is not None
                and view.phase(sysid, t) in ("pending", "lost")
            }
            ready.update(self._off_slot(t, flying))
            alarmed = {s for s in self.vehicles if f"fence_plan:{s}" in self._vehicle_alarms}
            lead = self._replan_lag.lead()
            job = asyncio.ensure_future(
                asyncio.to_thread(self._mission_step, t, est, lost, returned, ready, alarmed, lead)
            )
            self._mission_job_t = t
            # (a step still running when the mission ends is never taken in: its
            # failure, if any, must not be reported as "never retrieved")
            job.add_done_callback(lambda f: f.cancelled() or f.exception())
            self._mission_job = job
        view = self.view
        if self.monitor.protect_start is None and view.protect_start is not None:
            self.monitor.start_protect(view.protect_start)
            self.monitor.predicted_coverage = view.predicted_coverage or 1.0
            self._note(f"protect phase begins at t={view.protect_start:.1f}")
        self._check_airframes(t)
        self._check_taken(t)
        self._check_safety(t, est)
        telemetry = self._counted_telemetry(t)
        for alarm in self.monitor.update(t, est, telemetry):
            self._alarm(alarm)
        self.history.record(
            t,
            (est.north, est.east) if est is not None else None,
            {s: (tel.north, tel.east) for s, tel in telemetry.items()},
            self.monitor.snapshot(t).covered,
            self.monitor.protect_start is not None,
        )

    def _off_slot(self, t: float, flying: list[int]) -> dict[int, tuple[float, float, float]]:
        """Protecting UAVs more than a turn radius off their slot for ``_OFF_SLOT_S`` (a
        fight with another controller, a pilot's loiter, the fence's hold, a gust):
        joined to it again from where they are, not left to claw the phase back at a
        plane's few per cent of speed."""
        if self.paused or self._hold is not None:
            return {}
        out = {}
        for sysid in flying:
            since = self._off_slot_since.get(sysid)
            tel = self.vehicles[sysid].telemetry
            if (
                since is None
                or tel is None
                or t - since < _OFF_SLOT_S
                or t - self._rejoined_t.get(sysid, -math.inf) < _REJOIN_EVERY_S
            ):
                continue
            self._rejoined_t[sysid] = t
            self._off_slot_since.pop(sysid, None)
            self._note(f"uav{sysid}: far off its slot; joining it again from where it is")
            out[sysid] = (tel.north, tel.east, tel.yaw)
        return out

    def _newly_lost(self, t: float, view: MissionView) -> list[int]:
        """UAVs to take out of the plan now.

        Every live UAV silent at once is the ground radio or a paused host, not a
        fleet of aircraft lost: the plan is kept (its slots are timed, and the
        autopilots fly on or stand still with their clocks), so each UAV flies its
        own slot again when it is heard, without re-phasing the others. Once one
        speaks, the others have ``lost_after_s`` more to do so before they are lost.
        The UAVs' watchdogs fire a tick or so apart: while every live UAV not yet
        declared lost has been quiet for half of ``lost_after_s``, the ones declared
        are held back (the fleet is going silent together, not one UAV lost).
        """
        lost = [
            sysid
            for sysid, v in self.vehicles.items()
            if sysid not in view.lost
            and (
                v.status in (VehicleStatus.LOST, VehicleStatus.FAILED)
                or (sysid in self._taken and v.status is VehicleStatus.HOLDING)
            )
        ]
        live = [s for s in self.vehicles if s not in view.lost]
        silent = [s for s in live if self.vehicles[s].status is VehicleStatus.LOST]
        quiet_since = t - 0.5 * self.config.lost_after_s
        if silent and all(
            s in silent or -math.inf < self.vehicles[s].heard_t <= quiet_since for s in live
        ):  # (every one silent, or the rest a tick behind)
            if len(silent) == len(live) and self._silence is None:
                self._silence = (t, None)
                self._note("every UAV silent at once: keeping the plan until they speak")
            return [s for s in lost if s not in silent]
        if self._silence is not None:
            began, ended = self._silence
            if ended is None:
                self._silence = (began, t)
                # (mission time: about 0 when the clocks stood still, a paused host)
                self._note(f"heard again after {max(t - began, 0.0):.1f} s of fleet silence")
            elif t - ended >= self.config.lost_after_s:
                self._silence = None
            if self._silence is not None:
                return [s for s in lost if self.vehicles[s].status is not VehicleStatus.LOST]
        return lost

    def _mission_step(
        self,
        t: float,
        est: ConvoyEstimate | None,
        lost: list[int],
        returned: list[int],
        ready: dict[int, tuple[float, float, float]],
        fence_alarmed: set[int],
        lead: tuple[float, float],
    ) -> tuple[list[Any], MissionView, list[tuple[int, Setpoint]], int]:
        """The only code that touches the Mission (runs in a worker thread), and the
        look ahead along its plan for the fence (60 samples a UAV); the UAVs it
        re-planned (a road mission's, for ``ReplanLag``), last."""
        mission = self.mission
        events: list[Any] = []
        roads, drives = _drained(self._new_routes), _drained(self._new_drives)
        road_mission = mission if isinstance(mission, RoadMission) else None
        if road_mission is not None:
            if roads:
                road_mission.set_route(*roads[-1])
            for drive, home in drives:
                road_mission.set_drive(drive, t, home)
            road_mission.set_replan_lag(*lead)
        plans_before = 0 if road_mission is None else road_mission.uav_plans
        if est is not None:
            events += mission.on_convoy(est)
        for sysid in lost:
            if sysid in mission.live_uavs or sysid in mission.returning_uavs:
                events += mission.on_lost(sysid, t)
        for sysid in returned:
            events += mission.on_returned(sysid, t)
        if mission.plan is not None:
            ready = {u: p for u, p in ready.items() if mission.phase(u, t) in _JOINABLE}
            if ready:
                events += mission.join_many(ready, t)
        events += mission.tick(t)
        view = MissionView.of(mission, self._down)
        plans = 0 if road_mission is None else road_mission.uav_plans - plans_before
        return events, view, self._plan_leaves_fence(t, view, fence_alarmed), plans

    def _track(self, tel: Telemetry) -> None:
        """Score each position update of a protecting UAV against its plan, as it comes.

        The plan at the update's time is the last setpoint sent, moved along its
        own arc (``position_at``: exact on its segment), rather than the plan
        sampled again: a quarter of the receive path's cost at 1000 UAVs. With
        no recent plan setpoint (paused, or the stream stalled) the plan is sampled.
        """
        self.monitor.fix(tel)  # (coverage is judged at each fix's own stamp)
        view = self.view
        if view.phase(tel.sysid, tel.t) != "protect":
            return
        planned = self.vehicles[tel.sysid].last_setpoint
        if planned is None or planned.hold or abs(tel.t - planned.t) > POSITION_AT_HORIZON_S:
            planned = view.setpoint(tel.sysid, tel.t)
            if planned is None:
                return
        err = self.monitor.track(tel, *position_at(planned, tel.t))
        if err is not None and err > self._turn_radius:
            self._off_slot_since.setdefault(tel.sysid, tel.t)
        else:
            self._off_slot_since.pop(tel.sysid, None)
        ap = self.vehicles[tel.sysid].firmware
        if ap is not None and ap.top_speed is not None and not planned.hold:
            asked = math.hypot(planned.vn, planned.ve)  # (the setpoint has moved on since)
            behind = along_track_error(planned, tel.north, tel.east) + asked * (tel.t - planned.t)
            ap.observe_flight(tel.t, math.hypot(tel.vn, tel.ve), asked, behind)

    def _check_airframes(self, t: float) -> None:
        """Alarm (once per UAV) when an airframe cannot fly what the plan asks of it: a
        plane's loiters, or the plan's speeds outside the range its autopilot flies; the
        alarm clears when the operator widens that range (its PARAM_VALUE is heard)."""
        mission = self.mission
        band = mission.settings.speed_band if isinstance(mission, RoadMission) else (1.0, 1.0)
        for sysid, v in self.vehicles.items():
            ap = v.firmware
            if ap is None:
                continue
            ranged = ap.speed_seen()
            if f"airframe:{sysid}" in self._vehicle_alarms:
                # (its text is not built again every step: only once the operator has
                # changed the range, from another station, or it flew faster than its
                # top speed seen, does it get another look)
                if ranged != self._airframe_range.get(sysid):
                    self._airframe_range[sysid] = ranged
                    if ap.cannot_fly(self._airspeed, band) is None:
                        fits = f"UAV {sysid} flies the plan's speeds now ({ap.speed_range()})"
                        self._alarm(Alarm(t, "airframe", False, fits), sysid)
                continue
            why = ap.cannot_fly(self._airspeed, band)
            if why is not None:
                self._airframe_range[sysid] = ranged
                self._alarm(Alarm(t, "airframe", True, f"UAV {sysid} {why}"), sysid)

    def _counted_telemetry(self, t: float) -> dict[int, Telemetry]:
        """The telemetry of the UAVs that can see now: protecting on their slot
        (``monitor.why_not_counted``), or airborne in their band off it (joining, taken
        out of the plan) or silent (its fixes stamped around each instant decide:
        ``stamped``); the reasons for not protecting are timed for the report."""
        view = self.view
        dt = 0.0 if self._counted_t is None else max(t - self._counted_t, 0.0)
        self._counted_t = t
        protecting = self.monitor.protect_start is not None
        counted: dict[int, Telemetry] = {}
        for sysid, v in self.vehicles.items():
            tel = v.telemetry
            flying = v.status is VehicleStatus.FLYING
            heard = v.status not in (VehicleStatus.LOST, VehicleStatus.CONNECTING)
            why = why_not_counted(
                status=str(v.status),
                airborne=heard and v.airborne,  # (asked only of those it can matter for)
                altitude_error=None if tel is None else -tel.down - self._altitudes[sysid],
                band=self.config.altitude_band_m,
                phase=view.phase(sysid, t),
            )
            news = flying and why != self.why_not_counted.get(sysid, "")
            if news and why not in ("joining", "not assigned"):  # (phases are noted apart)
                self._note(f"uav{sysid}: " + ("counts for coverage" if why is None else why))
            self.why_not_counted[sysid] = why
            if why is None and tel is not None:
                counted[sysid] = tel
                continue
            if protecting:
                spent = self._not_counted_s.setdefault(sysid, {})
                reason = why or "no position"
                spent[reason] = spent.get(reason, 0.0) + dt
            if (
                why in _OFF_SLOT
                and tel is not None
                and sees(
                    airborne=v.airborne,
                    altitude_error=-tel.down - self._altitudes[sysid],
                    band=self.config.altitude_band_m,
                )
            ):
                counted[sysid] = tel  # (off its slot, or silent: what it saw still counts)
        return counted

    def _mission_event(self, ev: Any) -> None:
        if isinstance(ev, Replanned):
            self.replans.append(
                {
                    "t": ev.t,
                    "reason": ev.reason,
                    "case": ev.case,
                    "uav_count": ev.uav_count,
                    "min_uavs": ev.min_uavs,
                    "predicted_coverage": ev.predicted_coverage,
                }
            )
            if self.monitor.protect_start is not None:
                self.monitor.restart_protect(ev.t, ev.predicted_coverage)
            self._note(
                f"replanned ({ev.reason}): {ev.case}, {ev.uav_count} UAVs "
                f"(minimum {ev.min_uavs}), predicted coverage {100 * ev.predicted_coverage:.1f} %"
            )
        elif isinstance(ev, PhaseChanged):
            self._note(f"uav{ev.uav}: {ev.phase}")
        elif isinstance(ev, Returning):
            there = f"t={ev.arrival:.0f} s" if math.isfinite(ev.arrival) else "its first meeting"
            self._note(
                f"uav{ev.uav}: flying back to the fleet beside slot {ev.slot + 1}, there at "
                f"{there}; the others keep their plan until then"
            )
        elif isinstance(ev, MissionAlarm):
            self._alarm(Alarm(ev.t, "mission", True, ev.message))

    def _alarm(self, alarm: Alarm, sysid: int | None = None) -> None:
        if sysid is not None:
            key = f"{alarm.kind}:{sysid}"
            if alarm.active:
                self._vehicle_alarms.add(key)
            elif alarm.kind == "airframe":  # its parameters changed: that alone is over
                self._vehicle_alarms.discard(key)
            else:  # heard again: whatever was wrong with it is over
                self._vehicle_alarms -= {a for a in self._vehicle_alarms if a.endswith(f":{sysid}")}
        entry = {"t": alarm.t, "kind": alarm.kind, "active": alarm.active, "message": alarm.message}
        self.alarms.append(entry)
        self.events.append(f"t={alarm.t:.1f} alarm {alarm.kind}: {alarm.message}")
        log.log(
            logging.WARNING if alarm.active else logging.INFO,
            "alarm %s %s: %s",
            alarm.kind,
            "raised" if alarm.active else "cleared",
            alarm.message,
        )
        self._publish(
            topics.ALARM,
            topics.alarm_payload(
                t=alarm.t,
                wall=time.time(),
                seq=len(self.alarms),
                kind=alarm.kind,
                message=alarm.message,
                severity="warning" if alarm.active else "info",
                sysid=sysid,
                data={"active": alarm.active},
            ),
        )
        if self._on_alarm is not None:
            self._on_alarm(alarm)

    def _publish(self, subtopic: str, payload: Mapping[str, Any], retain: bool = False) -> None:
        if self.publisher is not None:
            self.publisher.publish(subtopic, payload, retain=retain)

    def _publish_state(self, t: float) -> None:
        """Status, coverage and every vehicle, as documented in the README (MQTT)."""
        if self.publisher is None:
            return
        wall = time.time()
        snap = self.monitor.snapshot(t)
        parted = {f"convoy_parted:{s}" for s in self._parted}  # (each parted vehicle)
        active = sorted(self.monitor.active | self._vehicle_alarms | parted)
        self._publish(
            topics.STATUS,
            topics.status_payload(
                t=t,
                wall=wall,
                phase=self._phase(snap),
                uptime_s=wall - self._started_wall,
                vehicles={s: v.status for s, v in self.vehicles.items()},
                alarms=active,
                paused=self.paused,
            ),
            retain=True,
        )
        self._publish(
            topics.COVERAGE,
            topics.coverage_payload(
                t=t,
                wall=wall,
                stats=snap.stats if snap.protect_start is not None else None,
                sample=snap.sample,
                predicted=self.view.predicted_coverage,
                protect_start_s=snap.protect_start,
            ),
            retain=True,
        )
        errors = {v.sysid: v.tracking_error_m for v in snap.vehicles}
        for sysid, v in self.vehicles.items():
            # A UAV its driver has declared lost is lost at once, not only after the
            # next control step has re-phased the others: state and phase agree.
            lost = v.status is VehicleStatus.LOST
            self._publish(
                topics.vehicle_topic(sysid),
                topics.vehicle_payload(
                    sysid=sysid,
                    t=t,
                    wall=wall,
                    state=v.status,
                    telemetry=v.telemetry,
                    mode=v.mode or None,
                    firmware=_firmware_family(v),
                    phase="lost" if lost else self.view.phase(sysid, t),
                    tracking_error_m=errors.get(sysid),
                    statustext=v.last_statustext,
                    why_not_counted="lost"
                    if lost
                    else self.why_not_counted.get(sysid, str(v.status)),
                ),
                retain=True,
            )

    def _phase(self, snap: MonitorSnapshot) -> str:
        flying = any(v.status == VehicleStatus.FLYING for v in self.vehicles.values())
        if self._stopped:
            return "stopped"
        if self._stopping:
            return "stopping"
        if self.paused:
            return "paused"
        if snap.protect_start is not None:
            return "protecting"
        if self.view.slots and flying:
            return "joining"
        return "starting"

    def _progress(self, t: float) -> None:
        snap = self.monitor.snapshot(t)
        protecting = snap.protect_start is not None
        progress = Progress(
            t=t,
            phase=self._phase(snap),
            flying=sum(v.status == VehicleStatus.FLYING for v in self.vehicles.values()),
            uavs=len(self.vehicles),
            counted=sum(why is None for why in self.why_not_counted.values()),
            states=Counter(
                str(v.status) for v in self.vehicles.values() if v.status != VehicleStatus.FLYING
            ),
            alarms=tuple(sorted(self.monitor.active | self._vehicle_alarms)),
            covered=snap.covered,
            coverage_fraction=snap.stats.fraction if protecting else None,
            gaps=snap.stats.gaps,
            longest_gap_s=snap.stats.longest_gap_s,
            predicted_coverage=self.view.predicted_coverage,
        )
        if self._on_progress is not None:
            self._on_progress(progress)

    def _report(self) -> ServiceReport:
        end_t = self.clock.now() if self._end_t is None else self._end_t
        self.monitor.finish()
        est = self._last_est
        streamer = self.streamer
        return ServiceReport(
            config=self.config,
            snapshot=self.monitor.snapshot(end_t),
            end_t=end_t,
            predicted_coverage=self.view.predicted_coverage,
            convoy_speed_mps=(
                self.view.convoy_speed
                if self.view.convoy_speed is not None
                else (est.speed if est is not None else 0.0)
            ),
            statuses={s: str(v.status) for s, v in self.vehicles.items()},
            replans=self.replans,
            alarms=self.alarms,
            events=self.events,
            vehicle_extra={s: self._vehicle_report(s, v, end_t) for s, v in self.vehicles.items()},
            route_start_s=self._route_t0,
            planner=self._planner_report(),
            rejected={
                "clock_stamps": self.clock.rejected,
                "clock_jumps_reanchored": self.clock.jumps,
                "ground_fixes": self._ground_rejected,
                "external_fixes_out_of_time": self._fixes_rejected,
                **{
                    f"convoy_{k}": n
                    for k, n in self.tracker.counters.items()
                    if k not in ("accepted", *_VELOCITY_SOURCES)
                },
            },
            tlog=self._tlog_path,
            refused=self.refused,
            clock=self._clock_report(),
            safety={
                "fence": self.fence is not None,
                "fence_clamps": dict(sorted(self._fence_clamps.items())),
                "fence_uploads": dict(sorted(self.fence_uploads.items())),
                "separation_conflicts": self._conflict_count,
                "closest_in_conflict_m": None
                if self._closest_m is None
                else round(self._closest_m, 1),
                # Mission s the control loop ran late (a loaded or stalled host); coverage
                # meanwhile is scored from telemetry stamped then, never assumed.
                "host_stalled_s": round(self._stalled_s, 2),
                # Widest mission-time gap between two setpoint rounds (``_check_setpoints``).
                "setpoint_round_gap_max_s": None
                if streamer is None
                else round(streamer.widest_gap_s, 3),
            },
        )

    def _clock_report(self) -> dict[str, float]:
        c = self.clock
        return {
            "speedup": round(c.rate, 2),
            "steps": c.steps,
            "rate_changes": c.rate_changes,
            "silences": c.silences,
            "resyncs": c.resyncs,
            "handovers": c.handovers,
            "reboots": c.reboots,
        }

    def set_route(self, route: PlannedRoute, *, source: str = "MQTT convoy/route") -> None:
        """A new route for the convoy (MQTT ``convoy/route``, or the lead ground vehicle's
        mission), its points (lat, lon) in order and the convoy's plan on it if it says
        one: holds, laps and speeds.

        Taken in at the next mission step (the mission lives in its worker thread);
        the paper's planner has no use for one, which the log says. The route in force
        sent again (a command post republishing it, a mission read again) is left as it
        is: taking it afresh would find the convoy on it anew.
        """
        points = route.points
        if route == self._route_taken:
            return
        if not isinstance(self.mission, RoadMission):
            self._note(f"route of {len(points)} points ignored: the paper's planner flies")
            return
        try:
            road = Road.from_geo(points, self.frame)
        except PlanningError as exc:
            self._note(f"route of {len(points)} points from {source} refused: {exc}")
            return
        self._new_routes.append((road, *self._plan_on(road, route)))
        self._route_taken = route
        remarks = route.remarks()
        self._route_source = source + (f" ({remarks})" if remarks else "")
        self._note(
            f"convoy route received from {self._route_source}: {len(points)} points, "
            f"{road.length:.0f} m"
        )

    def _plan_on(self, road: Road, plan: PlannedRoute) -> tuple[Marks, bool, Marks, bool]:
        """A route's plan on ``road``: its holds (arc length, seconds), whether it is a
        circuit, its speeds (arc length, m/s), whether an autopilot drives it (keeping a
        speed of its own where none is planned); each mark found near the distance driven
        to its point (``Road.place``: a route that comes back along itself has the point
        on two passes)."""
        if not (plan.holds or plan.speeds):
            return (), plan.circuit, (), plan.autopilot
        ned = [self.frame.to_ned(GeoPoint(lat, lon)) for lat, lon in plan.points]
        north, east = [p[0] for p in ned], [p[1] for p in ned]
        return (
            road.place(north, east, plan.holds),
            plan.circuit,
            road.place(north, east, plan.speeds),
            plan.autopilot,
        )

    @property
    def route(self) -> Road | None:
        """The convoy's route the road planner was given, if any (planner frame)."""
        return self.mission.model.route if isinstance(self.mission, RoadMission) else None

    def _planner_report(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.planner, "why": self._planner_why}
        out["route_source"] = self._route_source
        if self._mission_watch is not None:
            out["mission_reads"] = self._mission_watch.reads
        # The lead ground vehicle's modes as heard: (mission time, name), in order.
        out["convoy_modes"] = [{"t": t, "mode": name} for t, name in self.convoy_modes]
        # Convoy estimates whose velocity was the vehicles' own, and the fixes' slope.
        out["convoy_velocity"] = {k: self.tracker.counters[k] for k in _VELOCITY_SOURCES}
        # Vehicles parted from the lead's group and back (``parting``): each, when.
        out["convoy_parted"] = list(self.convoy_parted)
        if isinstance(self.mission, RoadMission):
            out.update(self.mission.report())
        return out

    def _stream_health(self, sysid: int) -> dict[str, float | None]:
        streamer = self.streamer
        stats = None if streamer is None else streamer.stats.get(sysid)
        if streamer is None or stats is None or stats.count < 2:
            return dict.fromkeys(("setpoint_rate_hz", "setpoint_gap_max_s", "setpoint_gap_p99_s"))
        return {
            # (halved at a speedup that would feed a simulator faster than it can use)
            "setpoint_rate_hz": streamer.rate,
            "setpoint_gap_max_s": round(stats.mission.max, 3),
            "setpoint_gap_p99_s": round(stats.mission.percentile(99.0), 3),
        }

    def _vehicle_report(self, sysid: int, v: Vehicle, end_t: float) -> dict[str, Any]:
        """What the report adds per UAV: why it did not count, and its telemetry rate."""
        heard = None if v.first_heard_t is None else end_t - v.first_heard_t
        return {
            "firmware": None if v.firmware is None else str(v.firmware),
            "failure": v.failure,  # (why its set-up gave up, while it is failed)
            "airborne": v.airborne,
            "why_not_counted": self.why_not_counted.get(sysid),
            "not_counted_s": {
                why: round(s, 1) for why, s in sorted(self._not_counted_s.get(sysid, {}).items())
            },
            "messages_per_s": round(v.received / heard, 2) if heard else None,
            # The link's round trip (mission s; its setpoints are sampled that far ahead,
            # None: never timed), and telemetry streams asked for again, lost on the link.
            "link_round_trip_s": round(v.setpoint_lead, 3) if v.round_trip.samples else None,
            "streams_asked_again": v.counters["streams_asked_again"],
            "streams_stopped": v.counters["streams_stopped"],
            # Frames dropped as implausible: a time_boot_ms ahead of anything its clock
            # can have run, a position farther than the airframe can have flown.
            "rejected": {
                **{k: v.counters[k] for k in ("clock_jump", "position_jump")},
                **_link_rejections(v.link),
                "other_sysid": self._foreign_sysid[sysid],
            },
            # Signs of another controller driving it (its targets, its frames); refused:
            # it was driven before we took it, and never commanded.
            "other_controller": {"signs": v.control.signs, "refused": v.refused},
            # Setpoint stream health: the longest wait between two setpoints sent (mission
            # s), and its 99th percentile over the last 2048: the mission's planning runs
            # off the flight loop and must never hold the stream.
            **self._stream_health(sysid),
            "learnt": {} if v.firmware is None else v.firmware.learnt(),
        }
