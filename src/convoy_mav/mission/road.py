"""The road mission: the paper's pattern laid along whatever road the convoy drives.

Design rules:
- What each UAV should fly is the moving-convoy pattern of Section IV
  (``planning.pattern``) around the convoy: ``c(t) + Rot(course) q(phase + i/N
  + (i mod 2); beta)`` (every other UAV a half-cycle on: the mirror image, meeting
  at the same times, so consecutive meetings alternate sides of the convoy and a
  sudden turn either way finds every other UAV coming back from the side it
  turned to; ``_offset``), with the course and ``beta`` from the convoy's velocity
  low-passed over ``course_tau_s`` (``PatternClock``), so curves, stops and
  speed changes reshape it gradually and a stop is the ``beta -> pi`` limit
  of the same family: nothing ever forces a re-join.
- What each UAV is commanded is flyable: meet-to-meet legs
  (``planning.meets``) that follow the pattern from the UAV's pose to the
  pattern at its next meetings, re-planned every ``replan_every_s`` from
  the pose the last plan put it at now, so setpoints are continuous in
  position and heading, curvature never exceeds 1/R and speed stays in the
  band. The pattern's arcs are laid wider than R when the fleet has a UAV
  to spare (``planning.pattern.pattern_radius``): turn left over to follow
  the road with.
- The fleet's coverage, not each UAV's, decides between plans: a
  protecting UAV keeps its path in force over a re-plan, or first flies to
  the convoy or a detour that keeps it in sight (``planning.detours``), when
  that sees the forecast convoy longer while no other UAV does (``_keeps``,
  ``_fill``). The pattern is laid for the convoy's course low-passed; after a
  sudden turn or stop its meetings can all fall where the convoy is not, and
  the UAV that can close the hole does. With a route, these choices are
  weighed against the convoy stopped short of the next sharp corner too (a
  junction it may stand at), and, while it stands, against it driving off
  along the route (``Hedge``, ``Watch``): the route says where the road
  turns, not when the convoy stops or goes. While it stands, the pattern
  (and a fill's leg to the convoy) is laid round the midpoint of it standing
  and it driving off (``Forecast.centre``), so the next meetings see it
  either way.
- A protecting UAV left flying the mirror image of its pattern (met on the
  mirror of its heading, it meets so again arc after arc) goes back to its
  side on a straight road, when that costs the fleet little (``_side_switch``):
  every other UAV then comes back from each side at the next sudden corner.
- A joining UAV takes a free slot and flies legs from where it is; it is
  ``protect`` from its first meeting on time, within r of the pattern on its
  way there on average (its sensor disk over its slot's), or from the end of
  a leg that meets the pattern on its heading (``_join_on_heading``), which it
  keeps aiming at until there. Half of r held a
  UAV joining a convoy that drives off or speeds up back for minutes: each
  re-plan's meeting moved, and its legs, on time, stayed 60-200 m off the
  pattern (the recorded drive: protection from 353 s, now 161 s). A UAV
  lost or back changes N:
  the others' offsets are re-spread, and their legs re-planned.
- A convoy feed silent for ``hold_after_s`` (a logger that records only on the
  move, a dropped link) is planned for as a convoy stopped where last seen,
  re-planned as usual, until a fresh estimate comes (``tick``).
- ``predicted_coverage`` is the coverage the commanded paths give against
  the convoy as estimated, over the protect phase so far: what the UAVs
  will have delivered if they fly what they are sent.
- A re-plan reaches the UAVs a while after it starts (``set_replan_lag``, which
  the service measures: seconds of mission time at a high speedup). Each new
  path keeps the one in force until then (``_start``), so the setpoint never
  moves under a UAV and what is predicted is what is flown.
- The same driving surface as ``Mission`` (``on_convoy``, ``join_many``,
  ``on_lost``, ``on_returned``, ``tick``, ``setpoint``), so the service
  flies either. Pure and synchronous: every method takes the mission time.
- Frames: the planner frame is the mission frame with x east, y north
  (``plan_origin`` (0, 0), ``plan_t0`` 0).
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
import numpy.typing as npt

from convoy_mav.errors import PlanningError
from convoy_mav.mission.assign import Roster, best_assignment
from convoy_mav.mission.convoy_model import KEPT_WINDOW_S, ConvoyModel, RoadMotion
from convoy_mav.mission.events import (
    MissionEvent,
    Phase,
    PhaseChanged,
    Replanned,
    Returning,
    phase_at,
)
from convoy_mav.mission.forecast import FORECAST_STEP, Forecast, Hedge, Watch
from convoy_mav.mission.join import slot_pose
from convoy_mav.mission.recording import MissionRecording
from convoy_mav.planning.detours import best_detour
from convoy_mav.planning.dubins import Pose, Segment, Turn, wrap_angle
from convoy_mav.planning.meets import (
    Leg,
    LegLimits,
    Where,
    pattern_pose,
    plan_leg,
    plan_leg_to_pose,
)
from convoy_mav.planning.pattern import (
    PatternClock,
    beta_for_speed,
    half_cycle_rate,
    min_uavs_road,
    pattern_radius,
)
from convoy_mav.planning.plan import PlanRequest, Trajectory
from convoy_mav.planning.road import Road
from convoy_mav.schedule import setpoint_on, yaw_to_heading
from convoy_mav.types import ConvoyDrive, ConvoyEstimate, Setpoint

__all__ = ["FAST_CONVOY_RATIO", "RoadMission", "RoadSettings"]

FloatArray = npt.NDArray[np.float64]

_SCORE_STEP = 0.5  # s: resolution of the planned-coverage score
FAST_CONVOY_RATIO = 0.5
"""A convoy faster than this fraction of the airspeed is one a stop can leave unseen.

The pattern's arcs turn back less the faster the convoy (Lemma 4.1: v/V = sin b / b,
b 109 deg at 0.5 V, 90 at 2/pi = 0.64 V): at speed hardly a UAV flies back towards it,
so when it brakes to a stop every UAV overshoots and the first back has to turn round.
Stops from a steady speed (1 m/s^2 braking, the route known; ``road_table.py
--fast-stops``): 98.8-99.8 % up to half the airspeed on three airframes, gaps of 2 s at
most; from 0.56-0.61 V on, 87-97 % with gaps of 6-27 s. Neither a UAV more (91.6 % at
0.67 V) nor knowing the stop from the onset of braking (93 %) buys it back; knowing it
8 s before it, or aircraft twice the convoy's speed, do.
"""
_ABSENT = object()  # a setting an older build's pickle does not have
_MOVING_MPS = 1.0  # m/s: a convoy slower than this has no course to speak of
_SWITCH_STRAIGHT_DEG = 10.0  # a side switch starts while the pattern lies this close to the road
_SWITCH_STRAIGHT_S = 60.0  # ... and the convoy drove on straight this long
_SWITCH_PERSIST_S = 90.0  # ... and the UAV has flown the mirror image this long
_SWITCH_SLACK_S = 5.0  # a meeting this close after a side switch's is that one
_SWITCH_LAGS_S = (-4.0, -2.0, 0.0, 2.0, 4.0, 6.0, 8.0)  # a side switch meets the pattern so late
_JOIN_LAGS_S = (0.0, 2.0, 4.0, 6.0, 8.0)  # a join on the pattern's heading meets it so late
_REPLAN_BATCHES = 8  # a fleet's re-plans are spread over this many mission steps at least
_RECENT_GAPS = 24  # re-plans the recent re-plan interval is the median of


@dataclass(frozen=True, slots=True)
class RoadSettings:
    """How the road mission plans.

    Attributes:
        speed_band: (low, high) fractions of cruise the legs may fly (planes +-15 %).
        replan_every_s: Mission seconds between two re-plans of every UAV's legs.
        course_tau_s: Time constant of the convoy velocity the pattern is laid along.
        speed_tau_s: Time constant of the convoy speed that can lower the pattern's
            (``PatternClock``): a stop shows within seconds.
        legs_ahead: Meetings planned ahead at each re-plan (>= 2 keeps a
            plan in force past the next re-plan).
        min_lead_s: A meeting closer than this is not aimed at (the next one is).
        pattern_cap: Widest pattern radius, as a multiple of R.
        settle_s: Seconds of convoy fixes before the pattern is laid (the
            tracker's velocity settles first).
        join_heading_weight: A joining UAV's legs also aim to meet the pattern
            on its heading (metres of mean offset a radian is worth, ``plan_leg``).
        on_pattern_m: A UAV protects from its first leg that arrives on time
            within this mean distance of the pattern (0: r).
        keep_horizon_s: A re-plan is not taken when the path in force sees the
            forecast convoy ``keep_margin_s`` longer, while no other UAV does, over
            this horizon (``_keeps``).
        keep_margin_s: ... seconds longer.
        fill_margin_s: A protecting UAV flies to the forecast convoy first when that sees
            it this much longer than its legs do while no other UAV does (``_fill``;
            0: never).
        hold_after_s: Seconds without a fresh convoy estimate after which the convoy
            is planned for as stopped where last seen (``tick``).
        shadow_after_s: A UAV back from a loss, farther from the fleet than this many
            seconds of closing, flies to it beside a slot before the fleet re-spreads
            for it (``on_returned``).
        corner_curvature: With a route, keeps and fills are also weighed against the
            convoy stopped short of the next corner sharper than this, 1/m (a
            junction; ``Watch``; 0: never).
        corner_short_m: ... this many metres short of it.
        drive_off_below_mps: With a route, a convoy slower than this along it is also
            weighed driving off along it (0: never) ...
        drive_off_accel: ... at this acceleration, m/s^2, up to its last driving speed;
        drive_off_weight: ... a second of it worth this many of the forecast's (0: never);
        drive_off_blend: ... and the pattern laid this fraction of the way from it
            standing to it driving off (``Forecast.centre``; 0: round it standing).
        side_switch_cost_s: A UAV flying the mirror image of its pattern goes back to
            its side when that leaves the convoy unseen this long at most
            (``_side_switch``; < 0: never). Going back skips a meeting: 4-5 s unseen
            where no other UAV's meeting overlaps it, against 17-28 s at a sudden
            corner with a UAV left mirrored.
        speed_relax_s: With a route, a convoy faster than its recent mean speed is
            forecast to relax to it with this time constant, s (``ConvoyModel``; 0:
            held at its speed) ...
        speed_mean_s: ... its mean over this many seconds, stops included.
        kept_window_s: A rover on its mission seen this long at one speed off its
            plan's keeps it (``ConvoyModel.kept``: told it); 0: never seen so.
        join_heading_deg: A joining UAV whose legs would meet the pattern farther than
            this off its heading meets it on its heading instead, when a leg to the
            same meeting fits (``_join_on_heading``; 180: never).
        replan_on_change_mps: A UAV is re-planned at once, out of its turn, when the
            convoy's estimated velocity is this far (m/s) from the one its legs were
            planned on (``_fold``; 0: only in turn). Just above the tracker's velocity
            noise in 3 m of GPS noise (about 1 m/s).
        replan_budget_s: When re-plans take a while to reach the UAVs
            (``set_replan_lag``), those a change calls for are spread over mission
            steps of about this many seconds' lag each, the UAVs nearest the convoy
            first (``_fold``).
    """

    speed_band: tuple[float, float] = (0.85, 1.15)
    replan_every_s: float = 4.0
    course_tau_s: float = 20.0
    speed_tau_s: float = 5.0
    legs_ahead: int = 2
    min_lead_s: float = 3.0
    pattern_cap: float = 1.3
    settle_s: float = 4.0
    join_heading_weight: float = 50.0
    on_pattern_m: float = 0.0
    keep_horizon_s: float = 40.0
    keep_margin_s: float = 0.5
    fill_margin_s: float = 1.5
    hold_after_s: float = 5.0
    corner_curvature: float = 0.04
    corner_short_m: float = 5.0
    drive_off_below_mps: float = 1.5
    drive_off_accel: float = 1.0
    drive_off_weight: float = 0.5
    drive_off_blend: float = 0.5
    side_switch_cost_s: float = 5.0
    speed_relax_s: float = 30.0
    speed_mean_s: float = 90.0
    kept_window_s: float = KEPT_WINDOW_S
    join_heading_deg: float = 15.0
    replan_on_change_mps: float = 1.5
    replan_budget_s: float = 1.0
    shadow_after_s: float = 60.0

    def __setstate__(self, state: Sequence[Any]) -> None:
        """Unpickled (a recording, ``mission.recording``) from an older build, which had
        fewer settings: those added since (appended) at their defaults."""
        values = itertools.chain(state, itertools.repeat(_ABSENT))
        for f, value in zip(fields(self), values, strict=False):
            object.__setattr__(self, f.name, f.default if value is _ABSENT else value)

    @property
    def hedge(self) -> Hedge:
        """The other course a re-plan's choices are weighed on, with a route."""
        return Hedge(
            self.corner_curvature,
            self.corner_short_m,
            self.drive_off_below_mps,
            self.drive_off_accel,
            self.drive_off_weight,
            self.drive_off_blend,
        )


@dataclass(frozen=True, slots=True)
class _Start:
    """Where a UAV's re-planned legs begin: ``t_legs``, at ``pose``, along its path in
    force (``kept``, its part from ``t``), so the new path begins at ``t`` where the old
    one is (``_start``)."""

    t: float
    t_legs: float
    pose: Pose
    kept: tuple[Segment, ...] = ()


@dataclass(frozen=True, slots=True)
class RoadPlanInfo:
    """What is in force: the pattern radius, the live UAVs and the road's count."""

    pattern_radius: float
    uavs: int
    min_uavs: int


class RoadMission(Roster):
    """Plans and phases of the UAVs protecting a convoy on a road.

    Args:
        request: Geometry and speeds (turn radius R, sensor radius r, UAV speed V).
        uav_ids: The UAVs of the mission (MAVLink sysids).
        down: Altitude setpoint (metres down) of each UAV, by id.
        route: The route the convoy will drive, if known (planner frame).
        settings: Planning settings.
        record: Keep every input in ``recording`` (a ``MissionRecording``), to replay.

    Raises:
        ValueError: If ``uav_ids`` is empty or has duplicates.
    """

    def __init__(
        self,
        request: PlanRequest,
        uav_ids: Sequence[int],
        *,
        down: Callable[[int], float],
        route: Road | None = None,
        settings: RoadSettings | None = None,
        record: bool = False,
    ) -> None:
        super().__init__(uav_ids)
        self.request = request
        self.settings = settings or RoadSettings()
        # Every input taken, to replay offline (``recording``), when asked for.
        self.recording = (
            MissionRecording(
                request, sorted(uav_ids), {u: down(u) for u in uav_ids}, route, self.settings
            )
            if record
            else None
        )
        self._hedge = self.settings.hedge
        self.model = ConvoyModel(
            route,
            relax_s=self.settings.speed_relax_s,
            mean_window_s=self.settings.speed_mean_s,
            corner_curvature=self.settings.corner_curvature,
            kept_window_s=self.settings.kept_window_s,
        )
        self._down = down
        self._slots: dict[int, int] = {}  # uav -> slot index in 0..N-1
        self._side = 0  # which parity of slots flies the mirrored arcs (``_offset``)
        self._switching: dict[int, float] = {}  # uav -> end of its leg back to its side
        self._mirrored_since: dict[int, float] = {}  # uav -> since when it flies mirrored
        self._join_aims: dict[int, float] = {}  # uav -> when its join meets its own side
        self._trajectories: dict[int, Trajectory] = {}
        self._starts: dict[int, Pose] = {}  # joined, not yet planned: where it was
        self._arrival: dict[int, float] = {}
        self._announced: set[int] = set()
        self._clock: PatternClock | None = None
        self._planned_at: dict[int, float] = {}
        self._planned_v: dict[int, tuple[float, float]] = {}  # convoy velocity planned on
        self._first_fix: float | None = None
        self._history: deque[tuple[float, float, float]] = deque(maxlen=4096)
        self._scored_until: float | None = None
        self._covered_s = 0.0
        self._scored_s = 0.0
        self.replans = 0
        self.legs_late = 0
        self.plans_kept = 0
        self.fills = 0
        self.side_switches = 0
        self.uav_replans = 0
        self.uav_plans = 0  # UAVs re-planned (their plans kept too): the cost of re-planning
        self._lag = (0.0, 0.0)  # mission s a re-plan takes to reach the UAVs: fixed, per UAV
        self._lag_max = 0.0  # the longest lag of a one-UAV re-plan told (the report)
        # Mission s between two re-plans of one protecting UAV, recent ones and the
        # run's: more than replan_every_s when the host is short of CPU.
        self._replan_gaps: deque[float] = deque(maxlen=_RECENT_GAPS)
        self._gaps_total = 0.0
        self._gaps_count = 0
        self.replan_interval_s: float | None = None  # median of the recent ones
        self._margins: dict[int, tuple[float, float, float]] = {}  # radius, slowest, fastest
        self._convoy_speeds: tuple[float, float] | None = None
        self._fast_s = 0.0  # protect-phase seconds the convoy was fast (FAST_CONVOY_RATIO)
        self._top_ratio = 0.0  # the highest speed_ratio in the protect phase
        self._ratio_t: float | None = None  # (up to when _fast_s is counted)
        # The convoy feed: the latest fresh estimate's time, and whether the convoy is
        # held where it was last seen (``tick``; the model's estimate says where).
        self._fresh_t: float | None = None
        self._holding = False
        self.holds = 0

    @classmethod
    def replayed(cls, recording: MissionRecording, until: float | None = None) -> RoadMission:
        """A new mission fed every input of ``recording`` (those stamped after ``until``,
        if given, left out): the recorded mission as it was then, plan for plan."""
        downs = dict(recording.downs)
        mission = cls(
            recording.request,
            recording.uav_ids,
            down=lambda u: downs.get(u, 0.0),
            route=recording.route,
            settings=recording.settings,
        )
        for method, args in recording.inputs(until):
            getattr(mission, method)(*args)
        return mission

    # ------------------------------------------------------------------ state

    @property
    def plan(self) -> RoadPlanInfo | None:
        """What is in force, None before the convoy is located."""
        if self._clock is None:
            return None
        return RoadPlanInfo(self.pattern_radius, len(self._live), self.min_uavs)

    @property
    def pattern_radius(self) -> float:
        """Radius the pattern's arcs are laid with for the live fleet, metres."""
        r = self.request
        n = max(len(self._live), 1)
        return pattern_radius(r.turn_radius, r.sensor_radius, n, self.settings.pattern_cap)

    @property
    def min_uavs(self) -> int:
        """UAVs that cover this convoy wherever it may stop (``min_uavs_road``)."""
        r = self.request
        return min_uavs_road(r.turn_radius, r.sensor_radius, r.uav_speed)

    @property
    def motion(self) -> RoadMotion | None:
        """The convoy's speed (and route status) as the model sees it."""
        return self.model.motion

    @property
    def plan_origin(self) -> tuple[float, float]:
        """Planner origin in the mission frame: the mission origin."""
        return (0.0, 0.0)

    @property
    def plan_t0(self) -> float:
        """Planner time is mission time."""
        return 0.0

    @property
    def speed_ratio(self) -> float | None:
        """The convoy's speed as the pattern is laid for it (``PatternClock.speed``, low-
        passed), over the airspeed; None before the convoy is located. From
        ``FAST_CONVOY_RATIO`` on, a stop can leave the convoy unseen."""
        if self._clock is None:
            return None
        return self._clock.speed / self.request.uav_speed

    @property
    def predicted_coverage(self) -> float | None:
        """Coverage the commanded paths give against the convoy as estimated, so far."""
        if self._scored_s <= 0.0:
            return None
        return self._covered_s / self._scored_s

    @property
    def min_turn_radius(self) -> float:
        """The tightest turn any UAV was commanded, metres (inf before any plan)."""
        return min((m[0] for m in self._margins.values()), default=math.inf)

    @property
    def speed_range(self) -> tuple[float, float]:
        """Slowest and fastest speed any UAV was commanded, m/s."""
        margins = self._margins.values()
        return min((m[1] for m in margins), default=math.inf), max(
            (m[2] for m in margins), default=0.0
        )

    @property
    def awaiting_join(self) -> tuple[int, ...]:
        """Live UAVs with no slot yet."""
        return tuple(u for u in self._live if u not in self._slots)

    def arrival(self, uav: int) -> float | None:
        """Mission time of the UAV's first meeting on time (its protect phase), if planned."""
        if uav not in self._slots:
            return None
        return self._arrival.get(uav, math.inf)

    def trajectory(self, uav: int) -> Trajectory | None:
        """The UAV's commanded path (planner frame = mission frame, mission time)."""
        return self._trajectories.get(uav)

    def phase(self, uav: int, t: float) -> Phase:
        """Where ``uav`` is at mission time ``t`` (flying back to the fleet: ``join``)."""
        if uav in self._returning:
            return "join" if uav in self._slots else "pending"
        return phase_at(uav in self._lost, self.arrival(uav), t)

    def pattern_positions(self, t: float) -> dict[int, tuple[float, float]]:
        """Where the pattern, laid as it is at ``t``, puts each slotted UAV then (north,
        east, mission frame): what its legs aim for; empty before the convoy is located.
        ``t`` is now (no earlier than the latest estimate): it is forecast from the
        mission's present state.

        Set beside the setpoints, it tells an unseen convoy the pattern left
        uncovered from one the UAVs flew away from: off their pattern, late for a
        meeting (``fly_road``'s ``unseen_off_pattern_s``).
        """
        if self._clock is None:
            return {}
        forecast = self._forecast(t, FORECAST_STEP, hedged=True)
        n = len(self._live)
        at = np.array([t])
        out: dict[int, tuple[float, float]] = {}
        for uav, slot in self._slots.items():
            x, y = forecast.pattern(self._offset(slot, n))(at)
            out[uav] = (float(y[0]), float(x[0]))
        return out

    def setpoint(self, uav: int, t: float) -> Setpoint | None:
        """What ``uav`` should fly at mission time ``t``; None if it has no path."""
        traj = self._trajectories.get(uav)
        if traj is None:
            return None
        return setpoint_on(traj, t, plan_origin=(0.0, 0.0), plan_t0=0.0, down=self._down(uav))

    # --------------------------------------------------------------- inputs

    def tick(self, t: float) -> list[MissionEvent]:
        """Report UAVs that reached their first meeting; note when protection began; with
        the convoy feed silent ``hold_after_s``, plan for the convoy held where last seen.

        A feed goes silent when a convoy's logger records only while it moves,
        or its link drops. Planning on for a convoy stopped where it was last
        seen keeps the fleet's figure eights over it; flying on the plans in
        force takes every UAV to the end of its legs and round a hold circle
        there, hundreds of metres off (the recorded drive, whose logger paused
        1400 s of its 4900, flown on its raw fixes: 90.1 -> 96.6 % with the route
        known, 85.9 -> 91.4 % without).
        """
        if self.recording is not None:
            self.recording.add("tick", (t,))
        events = self._announce(t)
        fresh = self._fresh_t
        if (
            self._clock is not None
            and fresh is not None
            and t - fresh >= self.settings.hold_after_s
            and t > self._clock.t
        ):
            self.holds += not self._holding
            self._holding = True
            last = self.model.estimate
            assert last is not None  # (a fresh estimate was folded in)
            events += self._fold(ConvoyEstimate(t, last.north, last.east, 0.0, 0.0))
        return events

    def _announce(self, t: float) -> list[MissionEvent]:
        """``PhaseChanged(.., "protect", ..)`` for UAVs at their first meeting by ``t``;
        a UAV flying back beside a slot is taken back then, and the fleet re-spread."""
        events: list[MissionEvent] = []
        back = [u for u in self._returning if self._arrival.get(u, math.inf) <= t]
        if back and self._clock is not None:
            for uav in sorted(back):
                self._take_back(uav)
            self._advance_clock(t)
            self._respread()
            self._plan_paths(t)
            events.append(self._replanned(t, "uav_returned"))
        due = sorted(
            (a, u)
            for u, a in self._arrival.items()
            if u in self._slots and u not in self._announced and a <= t
        )
        for arrival, uav in due:
            self._announced.add(uav)
            events.append(PhaseChanged(uav, "protect", arrival))
        if self._protect_start is None and self._live and not self.awaiting_join:
            arrivals = [self._arrival.get(u, math.inf) for u in self._live]
            if max(arrivals) <= t:
                self._protect_start = max(arrivals)
        return events

    def on_convoy(self, est: ConvoyEstimate) -> list[MissionEvent]:
        """Fold in a convoy estimate; re-plan every UAV's legs when due."""
        if self.recording is not None:
            self.recording.add("on_convoy", (est,))
        events = self._announce(est.t)
        if est.stale or not all(map(math.isfinite, (est.t, est.north, est.east, est.vn, est.ve))):
            return events
        self._fresh_t = est.t if self._fresh_t is None else max(est.t, self._fresh_t)
        self._holding = False
        if self._protect_start is not None:
            lo, hi = self._convoy_speeds or (math.inf, 0.0)
            self._convoy_speeds = (min(lo, est.speed), max(hi, est.speed))
        return events + self._fold(est)

    def _fold(self, est: ConvoyEstimate) -> list[MissionEvent]:
        """Fold in a finite estimate, fresh or held; re-plan every UAV's legs when due."""
        events: list[MissionEvent] = []
        self.model.observe(est)
        self._history.append((est.t, est.east, est.north))
        V = self.request.uav_speed
        if self._clock is None:
            if self._first_fix is None:
                self._first_fix = est.t
            if est.t - self._first_fix < self.settings.settle_s:
                return events  # (the tracker's velocity is still settling)
            self._clock = PatternClock(
                est.t,
                est.ve,
                est.vn,
                tau=self.settings.course_tau_s,
                speed_tau=self.settings.speed_tau_s,
            )
            events.append(self._replanned(est.t, "initial"))
            return events
        self._clock.advance(est.t, est.ve, est.vn, self.pattern_radius, V)
        ratio = self.speed_ratio
        if self._protect_start is not None and ratio is not None:
            self._top_ratio = max(self._top_ratio, ratio)
            since = self._ratio_t
            if since is not None and est.t > since:
                self._fast_s += (est.t - since) * (ratio >= FAST_CONVOY_RATIO)
            self._ratio_t = est.t if since is None else max(since, est.t)
        # Each UAV is re-planned every replan_every_s, a few at a time (a plan is
        # 3-5 ms a UAV): the loop driving the mission never waits long. One whose
        # legs were planned on a convoy velocity replan_on_change_mps off the one now
        # (a corner, a stop, a start) is re-planned at once (``_urgent``: a few a
        # step when re-plans lag): in its turn, the last of the fleet would be up to
        # replan_every_s late with it.
        every = self.settings.replan_every_s
        due = sorted(
            (self._planned_at.get(u, -math.inf), u)
            for u in self._slots
            if est.t - self._planned_at.get(u, -math.inf) >= every
        )
        batch = max(1, math.ceil(len(self._slots) / _REPLAN_BATCHES))
        chosen = [u for _, u in due[:batch]]
        chosen += self._urgent([u for u in self._changed() if u not in chosen], len(chosen), est.t)
        if chosen:
            self._plan_paths(est.t, chosen)
        return events + self._announce(est.t)

    def _urgent(self, changed: list[int], besides: int, t: float) -> list[int]:
        """The ``changed`` UAVs re-planned now, ``besides`` others in their turn: all of
        them when re-plans reach the UAVs at once; else as many as ``replan_budget_s``
        of lag allows with the others (one at least), the nearest the convoy first.

        A step's re-plans are flown only once they all are done (``_start``). At 40x
        on two cores a change that re-planned a fleet of six at once had each UAV
        fly its new legs 2.5 s late. The UAV at or about to meet the convoy needs
        them most; one half a cycle away can wait a step or two. Twenty-six roads
        without a route, simulated at that lag: 90.7 % all at once, 91.9 % one
        changed UAV a step beside the one in turn, 90.7 % four; the changed ones
        alone, those in turn left waiting while changes last, 88.5 %.
        """
        per_uav = self._lag[1]
        if per_uav <= 0.0 or not changed:
            return changed
        room = max(int(self.settings.replan_budget_s / per_uav) - besides, 1)
        if len(changed) <= room:
            return changed
        x, y = self.model.position(t)

        def away(u: int) -> float:
            pose = self._pose_at(u, t)
            return math.inf if pose is None else math.hypot(pose.x - x, pose.y - y)

        return sorted(changed, key=away)[:room]

    def _changed(self) -> list[int]:
        """UAVs whose legs were planned on a convoy velocity ``replan_on_change_mps`` or
        more off the one now."""
        dv = self.settings.replan_on_change_mps
        if dv <= 0.0:
            return []
        vx, vy = self.model.velocity()
        return [
            u
            for u, (px, py) in self._planned_v.items()
            if u in self._slots and math.hypot(vx - px, vy - py) > dv
        ]

    def _course(self) -> float | None:
        """The convoy's course now (planner frame), None while it barely moves."""
        vx, vy = self.model.velocity()
        return math.atan2(vy, vx) if math.hypot(vx, vy) >= _MOVING_MPS else None

    def set_replan_lag(self, base_s: float, per_uav_s: float) -> None:
        """How long a re-plan takes to reach the UAVs, mission seconds: ``base_s`` plus
        ``per_uav_s`` for each UAV re-planned (the service measures it). The new legs
        begin that far ahead along each UAV's path in force (``_start``)."""
        lag = (max(base_s, 0.0), max(per_uav_s, 0.0))
        if not all(map(math.isfinite, lag)) or lag == self._lag:
            return
        if self.recording is not None:
            self.recording.add("set_replan_lag", lag)
        self._lag = lag
        self._lag_max = max(self._lag_max, lag[0] + lag[1])

    def set_route(
        self,
        route: Road,
        holds: Sequence[tuple[float, float]] = (),
        circuit: bool = False,
        speeds: Sequence[tuple[float, float]] = (),
        keeps_speed: bool = False,
    ) -> None:
        """The route the convoy will drive from now on (a new one over MQTT, a rover's
        mission) and the plan it keeps on it, if any: where it stands (arc length,
        seconds), whether the route is one lap of a circuit, the speeds it drives (arc
        length, m/s from there), and whether it keeps a speed of its own where none is
        planned (``ConvoyModel.set_route``)."""
        if self.recording is not None:
            plan = (tuple(holds), circuit, tuple(speeds), *((True,) if keeps_speed else ()))
            self.recording.add("set_route", (route, *plan) if any(plan) else (route,))
        self.model.set_route(route, holds, circuit=circuit, speeds=speeds, keeps_speed=keeps_speed)

    def set_drive(
        self, drive: ConvoyDrive | None, t: float, destination: tuple[float, float] | None = None
    ) -> None:
        """What drives the convoy's lead vehicle from mission time ``t`` on, as its mode
        says (``ConvoyModel.set_drive``): its mission, a stand it is told to, its way
        home to ``destination`` (x, y), or else."""
        if self.recording is not None:
            home = () if destination is None else (destination,)
            self.recording.add("set_drive", (drive, t, *home))
        self.model.set_drive(drive, destination)

    def join(self, uav: int, north: float, east: float, yaw: float, t: float) -> list[MissionEvent]:
        """``join_many`` for one UAV."""
        return self.join_many({uav: (north, east, yaw)}, t)

    def join_many(
        self, poses: Mapping[int, tuple[float, float, float]], t: float
    ) -> list[MissionEvent]:
        """Give UAVs free slots (the nearest jointly) and plan their legs from these poses.

        Raises:
            PlanningError: If the convoy has not been located yet.
            ValueError: If a UAV is not live, or a pose is not finite.
        """
        for uav, pose in poses.items():
            if uav not in self._live and uav not in self._returning:
                raise ValueError(f"UAV {uav} is not live in this mission")
            if len(pose) != 3 or not all(map(math.isfinite, (*pose, t))):
                raise ValueError(f"UAV {uav}: join pose must be 3 finite numbers, got {pose}")
        if self._clock is None:
            raise PlanningError("no plan yet: the convoy has not been located")
        if self.recording is not None:  # (a refused join changed nothing: not taken)
            self.recording.add("join_many", (dict(poses), t))
        self._advance_clock(t)
        events: list[MissionEvent] = []
        returning = {u: p for u, p in poses.items() if u in self._returning}
        if returning:
            events += self._welcome(returning, t)
            poses = {u: p for u, p in poses.items() if u in self._live}
            if not poses:
                return [*events, *self.tick(t)]
        for uav in poses:
            self._slots.pop(uav, None)
            self._trajectories.pop(uav, None)
            self._arrival.pop(uav, None)
            self._announced.discard(uav)
        self._respread()
        n = len(self._live)
        taken = set(self._slots.values())
        free = [i for i in range(n) if i not in taken]
        starts = {u: Pose(e, nn, yaw_to_heading(y)) for u, (nn, e, y) in poses.items()}
        order = list(starts)
        forecast = self._forecast(t, 60.0)
        ahead = t + 30.0
        cost = {}
        for i in free:
            px, py = forecast.pattern(self._offset(i, n))(np.array([ahead]))
            for u in order:
                cost[u, i] = math.hypot(starts[u].x - float(px[0]), starts[u].y - float(py[0]))
        for uav, slot in zip(order, best_assignment(order, free, cost), strict=True):
            self._slots[uav] = slot
            self._starts[uav] = starts[uav]
        self._plan_paths(t)
        return [*events, *(PhaseChanged(u, "join", t) for u in order), *self.tick(t)]

    def on_lost(self, uav: int, t: float) -> list[MissionEvent]:
        """Take ``uav`` out; the others re-spread over the slots left and re-plan."""
        if self.recording is not None:
            self.recording.add("on_lost", (uav, t))
        if uav in self._returning:  # lost again on its way back
            self._returning.discard(uav)
            self._forget(uav)
            return []
        if not self._take_out(uav):
            return []
        self._forget(uav)
        if self._clock is None:
            return []
        self._advance_clock(t)
        self._respread()
        self._plan_paths(t)
        return [*self.tick(t), self._replanned(t, "uav_lost")]

    def on_returned(self, uav: int, t: float) -> list[MissionEvent]:
        """A lost ``uav`` flies again: pending until joined from its pose, which decides
        how it is taken back (``Mission.on_returned``'s rule). Near enough, or needed
        at once (the others fewer than a stop needs, bar one), it is taken back, the
        others re-spread and it joins a free slot. Farther, it first flies to the
        fleet on a slot of the pattern in force beside the UAV that flies it, on its
        own layer, not counted by the others' choices (``Returning``); at its first
        meeting there it is taken back and the fleet re-spread."""
        if self.recording is not None:
            self.recording.add("on_returned", (uav, t))
        if uav not in self._lost or uav in self._returning:
            return []
        if not self._live or self._clock is None:
            self._take_back(uav)
            if self._clock is None:
                return []
            return [*self.tick(t), self._replanned(t, "uav_returned")]
        self._returning.add(uav)
        return self.tick(t)

    def _welcome(
        self, poses: Mapping[int, tuple[float, float, float]], t: float
    ) -> list[MissionEvent]:
        """Join returning UAVs: taken back at once if near or needed, else sent to the
        fleet beside the slot nearest them (``Returning``)."""
        assert self._clock is not None
        n = len(self._live)
        spare = n >= self.min_uavs - 1
        closing = max(self.request.uav_speed - self._clock.speed, 0.25 * self.request.uav_speed)
        forecast = self._forecast(t, 60.0)
        ahead = np.array([t + 30.0])
        events: list[MissionEvent] = []
        near: list[int] = []
        for uav, (north, east, _) in poses.items():
            gaps = {}
            for slot in range(n):
                px, py = forecast.pattern(self._offset(slot, n))(ahead)
                gaps[slot] = math.hypot(east - float(px[0]), north - float(py[0]))
            slot = min(gaps, key=gaps.__getitem__)
            if not spare or gaps[slot] / closing <= self.settings.shadow_after_s:
                near.append(uav)
                continue
            self._forget(uav)
            self._slots[uav] = slot
            self._starts[uav] = Pose(east, north, yaw_to_heading(poses[uav][2]))
            self._plan_paths(t, [uav])
            arrival = self._arrival.get(uav, math.inf)
            events.append(Returning(uav, t, slot, arrival))
        if near:
            for uav in near:
                self._take_back(uav)
            events.append(self._replanned(t, "uav_returned"))
        return events

    def _forget(self, uav: int) -> None:
        """Drop ``uav``'s slot, paths and join state."""
        for table in (
            self._slots,
            self._trajectories,
            self._arrival,
            self._starts,
            self._join_aims,
        ):
            table.pop(uav, None)
        self._planned_at.pop(uav, None)
        self._planned_v.pop(uav, None)
        self._announced.discard(uav)

    # ------------------------------------------------------------- internals

    def _replanned(self, t: float, reason: str) -> Replanned:
        self.replans += 1
        n = len(self._live)
        predicted = self.predicted_coverage
        return Replanned(
            t, reason, 1.0 if predicted is None else predicted, n, self.min_uavs, "road"
        )

    def _advance_clock(self, t: float) -> None:
        assert self._clock is not None
        if t > self._clock.t:
            vx, vy = self.model.velocity()
            self._clock.advance(t, vx, vy, self.pattern_radius, self.request.uav_speed)

    def _respread(self) -> None:
        """Slots 0..N-1 for the slotted UAVs, in their present order (N = live UAVs),
        each UAV kept on the side of the convoy it flies when one choice of sides can."""
        ranked = sorted(
            (u for u in self._slots if u not in self._returning), key=self._slots.__getitem__
        )
        n = len(self._live)
        step = n / max(len(ranked), 1)  # (pending UAVs keep gaps to join into)
        before = {u: (slot + self._side) % 2 for u, slot in self._slots.items()}
        beside = {u: self._slots[u] for u in self._returning if u in self._slots}
        self._slots = {u: min(round(k * step), n - 1) for k, u in enumerate(ranked)}
        kept = sum(before[u] == slot % 2 for u, slot in self._slots.items())
        self._side = 0 if 2 * kept >= len(self._slots) else 1
        self._slots.update({u: min(slot, n - 1) for u, slot in beside.items()})

    def _offset(self, slot: int, n: int) -> float:
        """Pattern phase of ``slot`` of ``n``: ``slot / n`` half-cycles behind slot 0
        (Corollary 4.3), and one more half-cycle on every other slot.

        With the paper's phasing every meeting of a half-cycle ends the same arc:
        for a whole half-cycle the UAVs come back to the convoy from one side, and
        a sudden turn away from it makes each of them late in turn (one 60-deg
        corner: 23 s unseen turning one way, none the other). A half-cycle later
        a UAV flies the mirror image of its arc and meets at the same times, so
        on a straight road the plan is the paper's; consecutive meetings then
        come from alternate sides (at most two in a row from one side with an
        even N), and whichever way the convoy turns, every other UAV comes back
        from the side it turned to.
        """
        return slot / n + (slot + self._side) % 2

    def _forecast(self, t: float, horizon: float, *, hedged: bool = False) -> Forecast:
        """The forecast from ``t``; ``hedged``: with the other course the route leaves open
        too, for a ``Watch`` (``Hedge``)."""
        assert self._clock is not None
        return Forecast(
            self._clock,
            self.model,
            t,
            horizon,
            self.pattern_radius,
            self.request.uav_speed,
            hedge=self._hedge if hedged else None,
        )

    def _limits(self) -> LegLimits:
        r = self.request
        return LegLimits(
            r.turn_radius, r.uav_speed, self.settings.speed_band, pattern_radius=self.pattern_radius
        )

    def _plan_paths(self, t: float, uavs: Sequence[int] | None = None) -> None:
        """Re-plan the legs of ``uavs`` (default: every slotted UAV) from where their
        current paths have them when the new paths reach them (``_start``)."""
        if self._clock is None:
            return
        self._score(t)
        self._advance_clock(t)
        n = len(self._live)
        V = self.request.uav_speed
        beta = beta_for_speed(self._clock.speed, V)
        period = 1.0 / half_cycle_rate(beta, self.pattern_radius, V)
        horizon = (self.settings.legs_ahead + 1.5) * period + 60.0
        forecast = self._forecast(t, horizon, hedged=True)
        limits = self._limits()
        # A joining UAV's late legs are planned for where the pattern is when they
        # arrive, as before the scan: it protects once a leg meets the pattern close,
        # and the earliest-meeting legs the scan gives a protecting UAV skirt it.
        join_limits = replace(limits, late_max_s=0.0)
        velocity = self.model.velocity()  # (what the legs are planned on, ``_changed``)
        watch: Watch | None = None
        chosen = list(self._slots if uavs is None else uavs)
        lead = self._lag[0] + self._lag[1] * len(chosen)
        for uav in chosen:
            slot = self._slots[uav]
            start = self._start(uav, t, lead)
            before = self._planned_at.get(uav)
            if before is not None and self._arrival.get(uav, math.inf) <= before:
                self._replan_gaps.append(t - before)
                self._gaps_total += t - before
                self._gaps_count += 1
            self._planned_at[uav] = t
            self._planned_v[uav] = velocity
            self.uav_plans += 1
            if start is None:
                continue
            pose, t_legs = start.pose, start.t_legs
            offset = self._offset(slot, n)
            pattern = forecast.pattern(offset)
            close = self.settings.on_pattern_m or self.request.sensor_radius
            meetings = forecast.meetings(offset, t_legs)
            joining = uav not in self._arrival
            aiming = joining or uav in self._join_aims
            weight = self.settings.join_heading_weight if joining else 0.0
            how = join_limits if joining else limits
            if joining:  # (a UAV lost and back starts afresh)
                self._switching.pop(uav, None)
                self._mirrored_since.pop(uav, None)
            switch = None if aiming else self._side_switch(uav, start, forecast, pattern, meetings)
            if (
                switch is None
                and t_legs < self._switching.get(uav, -math.inf) - self.settings.min_lead_s
            ):
                # On its way back to its side, and no new leg there fits: the one in force
                # still gets there.
                self.plans_kept += 1
                continue
            on_heading = False
            if switch is None:
                legs = self._legs(pose, t_legs, pattern, meetings, how, weight)
                if aiming and legs:
                    legs, on_heading = self._join_on_heading(
                        uav, pose, t_legs, pattern, meetings, legs, how
                    )
            else:
                legs = self._legs_after(switch, pattern, meetings, how)
            if not legs:
                continue
            first_leg = legs[0]
            path = self._path(start, legs)
            filled = None
            kept = False
            if self._arrival.get(uav, math.inf) <= t and uav in self._trajectories:
                # A protecting UAV: its path in force, or a detour to the convoy, may
                # see more of it than the new legs do.
                watch = watch or Watch(
                    forecast, self.settings.keep_horizon_s, self.request.sensor_radius
                )
                others = self._others_see(uav, t, watch)
                mine = watch.sees(path)
                in_force = watch.sees(self._trajectories[uav])
                # A detour is weighed against what the UAV will fly otherwise: the path
                # it keeps, or its new legs. (A switch of sides was weighed over its
                # whole leg, the hole it leaves included: ``_side_switch``.)
                kept = switch is None and self._keeps(in_force, mine, watch, others)
                flown = in_force if kept else mine
                filled = (
                    None
                    if switch is not None
                    else self._fill(uav, start, flown, forecast, watch, others, limits)
                )
                if filled is None and kept:
                    self.plans_kept += 1
                    continue
                if filled is not None:
                    self.fills += 1
                    legs, path = filled
                    first_leg = legs[0]
            segments = tuple(seg for leg in legs for seg in leg.segments)
            if switch is not None and filled is None:
                self.side_switches += uav not in self._switching
                self._switching[uav] = switch.t_end
            else:
                self._switching.pop(uav, None)
            self.legs_late += not first_leg.on_time or first_leg.late_s > 0.0
            if uav not in self._arrival and (
                on_heading or (first_leg.on_time and first_leg.mean_offset <= close)
            ):
                self._arrival[uav] = first_leg.t_end
            self._record(uav, segments)
            self._trajectories[uav] = path
            self._starts.pop(uav, None)
        if self._replan_gaps:  # (one assignment: the service reads it from another thread)
            self.replan_interval_s = float(np.median(self._replan_gaps))

    def _drove_straight(self, t: float, span: float, limit: float) -> bool:
        """Whether the convoy drove on over the last ``span`` seconds, its course in its
        two halves within ``limit`` radians of each other."""
        hist = self._history
        if len(hist) < 2 or hist[0][0] > t - span:
            return False
        times = [h[0] for h in hist]
        k0 = bisect.bisect_left(times, t - span)
        k1 = bisect.bisect_left(times, t - 0.5 * span)
        (_, x0, y0), (_, x1, y1), (_, x2, y2) = hist[k0], hist[k1], hist[-1]
        reach = _MOVING_MPS * 0.5 * span
        if math.hypot(x1 - x0, y1 - y0) < reach or math.hypot(x2 - x1, y2 - y1) < reach:
            return False
        turned = math.atan2(y2 - y1, x2 - x1) - math.atan2(y1 - y0, x1 - x0)
        return abs(math.remainder(turned, math.tau)) <= limit

    def _join_on_heading(
        self,
        uav: int,
        pose: Pose,
        t: float,
        pattern: Where,
        meetings: Sequence[float],
        legs: list[Leg],
        limits: LegLimits,
    ) -> tuple[list[Leg], bool]:
        """A joining UAV's legs, or, when the first of them would meet the pattern more
        than ``join_heading_deg`` off its heading, legs that meet it on its heading at
        that meeting or the next (up to 8 s late: ``plan_leg_to_pose``), aimed at the
        same point at every re-plan until there; the legs as they are when none fits.
        True when the first leg is the one on its heading: the UAV protects from its
        end.

        ``plan_leg``'s arcs meet the pattern with whatever heading they come in on,
        and keep it: a UAV that joins 20-90 deg off may meet the convoy going the
        mirror image of its pattern's way from its second meeting on, for good. Going
        back to its side once protecting skips a meeting (``_side_switch``): 1-3 s
        unseen on a straight road. Before it protects, the way to its side costs
        nothing.

        It protects from the end of that leg, wherever it comes from, and the leg is
        re-planned to the same pose at every re-plan (its arrival set or not) until
        there. Waiting instead for a later leg within r of the pattern on average
        put protection on an urban grid with a route (stops at the start) at 232 s;
        now 124 s. The pose moves with the pattern, which each UAV that joins or
        leaves re-spreads: when it moves out of reach, the UAV is aimed afresh, as a
        join, and keeps the arrival it was given (moving the arrival with the aim
        kept UAVs joining longer and lost 1.4 points of coverage without a route).
        Dropping the aim instead, its legs met the pattern as they came, and 90 s
        into protection it switched sides: seven UAVs joining a straight road at
        8 m/s one a second apart on the mock lost 0.7-1.7 s in 5 of 8 runs (none
        in 14 now), and 3 of the 12 courses of
        ``test_uavs_joining_one_at_a_time_never_protect_mirrored`` in simulation.
        Aiming afresh so, and at the next meeting too when no leg fits the first,
        left the road table unchanged (14 roads x 3 start offsets, paired: +0.03 +- 0.10 points
        with a route, +0.22 +- 0.25 without).
        """
        min_lead = self.settings.min_lead_s
        limit = math.radians(self.settings.join_heading_deg)
        aim = self._join_aims.get(uav)
        if aim is not None:
            if t >= aim - min_lead:
                # There: ``plan_leg``'s legs keep it on its heading.
                self._join_aims.pop(uav)
                return legs, False
            leg = plan_leg_to_pose(pose, t, pattern, aim, limits)
            if leg is not None:
                leg = replace(leg, t_end=aim)  # (its durations sum to it, to the last bits)
                return self._legs_after(leg, pattern, meetings, limits), True
            # Out of reach (the pattern moved: a UAV joined or left, the convoy turned):
            # aimed afresh, as a join.
            self._join_aims.pop(uav)
        ahead = [m for m in meetings if m >= t + min_lead]
        first = legs[0]
        off = _heading_error(first.end, pattern, first.t_end)
        if not ahead or off <= limit:
            return legs, False
        for meet, lag in itertools.product(ahead[:2], _JOIN_LAGS_S):
            leg = plan_leg_to_pose(pose, t, pattern, meet + lag, limits)
            if leg is not None:
                aim = self._join_aims[uav] = meet + lag
                leg = replace(leg, t_end=aim)
                return self._legs_after(leg, pattern, meetings, limits), True
        return legs, False

    def _side_switch(
        self, uav: int, start: _Start, forecast: Forecast, pattern: Where, meetings: Sequence[float]
    ) -> Leg | None:
        """The leg that takes a protecting UAV flying the mirror image of its pattern back
        to its own side, or on there (None: it flies its own side, or stays put).

        Mirrored, its path meets the convoy going the mirror of the pattern's way
        (more than a right angle off), and from there every ``plan_leg`` arc meets
        it so again: the same meetings, from the other side. A join that met the
        pattern so leaves it there for good (the turning demo on the mock: one
        UAV in each of five runs). On a straight road that covers as well; at a
        sudden corner every other UAV no longer comes back from each side (the
        demo's 60-deg corner: three meetings in a row from its inside, 13-16 s
        unseen). The way back is a leg to the pattern on its heading at one of
        the next two meetings, up to 8 s late (``plan_leg_to_pose``), taken when
        it costs at most ``side_switch_cost_s`` of the convoy seen by no other
        UAV until it arrives, and aimed at the same point at every re-plan. Only
        on a straight road, after ``_SWITCH_PERSIST_S`` mirrored: on a winding
        one the next bend may turn the formation round anyway, and a switch
        under way gives way (fills, keeps) as soon as the road turns.
        """
        settings = self.settings
        traj = self._trajectories.get(uav)
        if settings.side_switch_cost_s < 0.0 or traj is None or self._protect_start is None:
            return None
        pose, t = start.pose, start.t_legs
        ahead = [m for m in meetings if m >= t + settings.min_lead_s]
        if not ahead:
            return None
        now = self._course()
        limit = math.radians(_SWITCH_STRAIGHT_DEG)
        if now is None or abs(math.remainder(now - float(forecast.course[0]), math.tau)) > limit:
            # Turning or stopping: the pattern swings round, and the sides with it; a
            # switch under way gives way to what the fleet needs now (fills).
            self._switching.pop(uav, None)
            return None
        until = self._switching.get(uav)
        limits = self._limits()
        if until is not None and t < until - settings.min_lead_s:
            return plan_leg_to_pose(pose, t, pattern, until, limits)
        meets = self._pose_at(uav, ahead[0])
        assert meets is not None  # (it has a path)
        laid = pattern_pose(pattern, ahead[0])
        on_it = math.hypot(meets.x - laid.x, meets.y - laid.y)
        mirrored = _heading_error(meets, pattern, ahead[0]) > 0.5 * math.pi
        if on_it > self.request.sensor_radius or not mirrored:
            self._mirrored_since.pop(uav, None)
            return None
        since = self._mirrored_since.setdefault(uav, t)
        if t - since < _SWITCH_PERSIST_S or not self._drove_straight(t, _SWITCH_STRAIGHT_S, limit):
            return None  # (a bend, or the next one, may bring it round as well)
        best: tuple[float, Leg] | None = None
        for aim in ahead[:2]:
            for lag in _SWITCH_LAGS_S:
                if aim + lag < t + settings.min_lead_s:
                    continue
                leg = plan_leg_to_pose(pose, t, pattern, aim + lag, limits)
                if leg is not None:
                    cost = self._switch_cost(uav, start, traj, leg, forecast)
                    if best is None or cost < best[0]:
                        best = (cost, leg)
            if best is not None and best[0] <= settings.side_switch_cost_s:
                return best[1]
        return None

    def _switch_cost(
        self, uav: int, start: _Start, traj: Trajectory, leg: Leg, forecast: Forecast
    ) -> float:
        """Seconds of the forecast convoy, until ``leg`` ends, that ``traj`` sees and
        neither ``leg`` nor any other UAV does: the hole the switch leaves (a UAV
        joining again counts: it will be protecting by then).

        Not netted against what the leg sees alone: ``traj`` past its legs is a
        circle held where they end (``_path``), a re-plan that never comes, so the
        leg's own meeting at its end, which the UAV's next re-plan makes either way,
        looked like a gain. Netted, a switch that left a 4-s hole in the middle of
        an 8 m/s straight road was taken for one costing under 2 s (the convoy
        unseen 1-4 s on the mock a minute later, after fills)."""
        watch = Watch(forecast, leg.t_end - start.t, self.request.sensor_radius)
        others = self._others_see(uav, start.t, watch, joining=True)
        switch = self._path(start, [leg])
        return watch.seconds(watch.sees(traj) & ~others & ~watch.sees(switch))

    def _others_see(
        self, uav: int, t: float, watch: Watch, *, joining: bool = False
    ) -> npt.NDArray[np.bool_]:
        """Samples of ``watch`` some other protecting UAV's path in force sees (``joining``:
        or a joining one's, on its way to protect)."""
        seen = np.zeros(len(watch.times), dtype=bool)
        for other, traj in self._trajectories.items():
            if other == uav or other in self._returning:
                continue
            if joining or self._arrival.get(other, math.inf) <= t:
                seen |= watch.sees(traj)
        return seen

    def _keeps(
        self,
        in_force: npt.NDArray[np.bool_],
        mine: npt.NDArray[np.bool_],
        watch: Watch,
        others: npt.NDArray[np.bool_],
    ) -> bool:
        """Whether a protecting UAV keeps its path in force (which sees ``in_force`` of
        ``watch``) over its new legs (which see ``mine``): it does when the path in force
        sees the convoy, as forecast, ``keep_margin_s`` longer over the next
        ``keep_horizon_s`` while no other UAV (``others``) does.

        A re-plan follows the forecast of the moment. When the convoy turns or
        stops unforeseen, the new plan can throw away a pass that is about to
        see it for a meeting well after; the pass is flown first. Only what no
        other UAV sees counts: a pass another UAV makes too is not worth keeping
        the pattern's next meeting waiting for.
        """
        old = in_force & ~others
        new = mine & ~others
        return watch.seconds(old) > watch.seconds(new) + self.settings.keep_margin_s

    def _path(self, start: _Start, legs: Sequence[Leg]) -> Trajectory:
        """The path in force kept from ``start.t``, the legs from ``start.t_legs``, then
        (a re-plan that never came) a circle where the last one ends."""
        segments = start.kept + tuple(seg for leg in legs for seg in leg.segments)
        last = segments[-1]
        lap = 2.0 * math.pi * self.pattern_radius / last.speed
        hold = Segment(last.at(last.duration), Turn.LEFT, self.pattern_radius, last.speed, lap)
        return Trajectory(start.t, (hold,), lead_in=segments)

    def _start(self, uav: int, t: float, lead: float) -> _Start | None:
        """Where a re-plan at ``t`` begins the UAV's new legs: ``lead`` seconds on along
        its path in force (a joining UAV without one: where it was, at ``t``).

        A re-plan takes a while to reach the autopilot: milliseconds a UAV, seconds
        of mission time at a high speedup. New legs laid from where the path had
        the UAV at ``t`` have parted from that path by the time they are flown: at
        a turn reversed, 25 m and 45 deg in 3 s, more than a plane at its turn
        limit can make up on arcs at that limit. On the mock at 40x a sudden
        change re-planning the whole fleet at once took 2.5-4 s of mission time:
        the planes flew 10 m off their paths in the median, 100 m in the worst
        hundredth (3 m and 16 m with a UAV or two a step), and the urban grid
        without a route fell up to 4 points below its prediction.
        """
        traj = self._trajectories.get(uav)
        if traj is None:
            pose = self._starts.get(uav)
            return None if pose is None else _Start(t, t, pose)
        t_legs = t + lead
        return _Start(t, t_legs, slot_pose(traj, t_legs), traj.segments_between(t, t_legs))

    def _fill(
        self,
        uav: int,
        start: _Start,
        mine: npt.NDArray[np.bool_],
        forecast: Forecast,
        watch: Watch,
        others: npt.NDArray[np.bool_],
        limits: LegLimits,
    ) -> tuple[list[Leg], Trajectory] | None:
        """Legs that first fly to the forecast convoy, or a detour that keeps it in
        sight, then back to the pattern, when they see it ``fill_margin_s`` longer
        than what the UAV flies otherwise (which sees ``mine`` of ``watch``) while no
        other UAV does.

        The pattern's meetings are laid for the convoy's course low-passed; after a
        sudden turn or stop every UAV's next meetings can fall where the convoy is
        not, and the fleet leaves it unseen until the pattern has swung round. A
        UAV that can reach the convoy in that hole closes it; the others stay on
        the pattern. Often the one that can is the UAV that has just met the
        convoy and is flying away from it: meeting it again takes a turn round,
        while turning back (``planning.detours``) keeps it in the sensor disk
        (sudden corners of 30-120 deg: longest gap 16 -> 8 s). Only tried once
        protection has begun (before, the fleet's holes are those of UAVs still
        joining) and when the fleet's paths leave a hole.
        """
        settings = self.settings
        if self._protect_start is None or settings.fill_margin_s <= 0.0:
            return None
        pose, t = start.pose, start.t_legs
        holes = watch.times[~(others | mine)]
        if len(holes) == 0:
            return None
        # It sees the convoy from about r out: too far to get there before the last
        # hole at the fastest speed, it fills none (a cheap test first: a re-plan
        # runs beside the setpoint stream).
        r = self.request.sensor_radius
        hi = limits.speeds[1]
        gap = math.hypot(pose.x - forecast.cx[0], pose.y - forecast.cy[0])  # (from t)
        step = np.hypot(np.diff(forecast.cx), np.diff(forecast.cy))
        closing = hi + float(np.max(step, initial=0.0)) / FORECAST_STEP
        if gap - r > (holes[-1] - t) * closing:
            return None
        mine_alone = watch.seconds(mine & ~others)
        offset = self._offset(self._slots[uav], len(self._live))
        pattern = forecast.pattern(offset)
        best: tuple[float, list[Leg], Trajectory] | None = None
        starts = self._fill_starts(
            start, mine, mine_alone, holes[-1], forecast, watch, others, limits
        )
        for first in starts:
            after = forecast.meetings(offset, first.t_end)
            legs = [first, *self._legs(first.end, first.t_end, pattern, after, limits, 0.0)]
            alt = self._path(start, legs)
            gain = watch.seconds(watch.sees(alt) & ~others) - mine_alone
            if gain > settings.fill_margin_s and (best is None or gain > best[0]):
                best = (gain, legs, alt)
        return None if best is None else (best[1], best[2])

    def _fill_starts(
        self,
        start: _Start,
        mine: npt.NDArray[np.bool_],
        mine_alone: float,
        last_hole: float,
        forecast: Forecast,
        watch: Watch,
        others: npt.NDArray[np.bool_],
        limits: LegLimits,
    ) -> list[Leg]:
        """The first legs a fill may take: to the forecast convoy (the pattern's centre;
        met on time, before the last hole, and seeing more of it than the
        ``mine_alone`` seconds ``mine`` sees that no other UAV does), and the detour
        that sees the holes longest."""
        settings = self.settings
        pose, t = start.pose, start.t_legs
        reach = 2.0 * watch.r / self.request.uav_speed
        starts: list[Leg] = []
        to_convoy = plan_leg(
            pose,
            t,
            forecast.centre,
            t + settings.min_lead_s,
            replace(limits, late_max_s=max(last_hole + reach - t - settings.min_lead_s, 0.0)),
            heading_weight=settings.join_heading_weight,
        )
        if (
            to_convoy.on_time
            and to_convoy.t_end - reach <= last_hole
            and watch.seconds(watch.sees(self._path(start, [to_convoy])) & ~others) > mine_alone
        ):
            starts.append(to_convoy)
        k = int(np.searchsorted(watch.times, t))  # (the path in force is kept until t)
        detour = best_detour(
            pose,
            t,
            watch.times[k:],
            (watch.cx[k:], watch.cy[k:]),
            ~others[k:],
            mine[k:],
            watch.r,
            limits,
        )
        if detour is not None:
            # (Not a leg to the pattern: it has no offset from it to speak of.)
            starts.append(Leg(detour.segments, t, detour.t_end, detour.speed, True, math.nan))
        return starts

    def _legs(
        self,
        pose: Pose,
        t: float,
        pattern: Where,
        meetings: list[float],
        limits: LegLimits,
        heading_weight: float,
    ) -> list[Leg]:
        legs: list[Leg] = []
        start, t0 = pose, t
        for tm in meetings:
            if tm < t0 + self.settings.min_lead_s:
                continue
            leg = plan_leg(start, t0, pattern, tm, limits, heading_weight=heading_weight)
            legs.append(leg)
            start, t0 = leg.end, leg.t_end
            if len(legs) >= self.settings.legs_ahead:
                break
        return legs

    def _legs_after(
        self, leg: Leg, pattern: Where, meetings: Sequence[float], limits: LegLimits
    ) -> list[Leg]:
        """``leg`` (a side switch's, a join's on heading), then legs to the meetings after
        it: one within ``_SWITCH_SLACK_S`` of its end is the one it makes."""
        later = [m for m in meetings if m > leg.t_end + _SWITCH_SLACK_S]
        return [leg, *self._legs(leg.end, leg.t_end, pattern, later, limits, 0.0)]

    def _pose_at(self, uav: int, t: float) -> Pose | None:
        """Where the UAV's path in force has it at ``t`` (a joining UAV: where it is)."""
        traj = self._trajectories.get(uav)
        return self._starts.get(uav) if traj is None else slot_pose(traj, t)

    def _record(self, uav: int, segments: Sequence[Segment]) -> None:
        """Flyability margins of what is commanded, per UAV (for the report)."""
        self.uav_replans += 1
        radius, lo, hi = self._margins.get(uav, (math.inf, math.inf, 0.0))
        for seg in segments:
            lo, hi = min(lo, seg.speed), max(hi, seg.speed)
            if seg.turn != Turn.STRAIGHT:
                radius = min(radius, seg.radius)
        self._margins[uav] = (radius, lo, hi)

    def report(self) -> dict[str, Any]:
        """What the report says of the road mission: the pattern, the road, the margins."""
        route = self.model.route
        speeds = self._convoy_speeds
        corner = self.model.corner_habit.speed
        cruise, kept = self.model.cruise, self.model.kept
        return {
            "pattern_radius_m": round(self.pattern_radius, 1),
            "road_min_uavs": self.min_uavs,
            "route_known": route is not None,
            "route_length_m": None if route is None else round(route.length, 1),
            "route_max_curvature_per_m": None if route is None else route.max_curvature(),
            "convoy_left_route": self.model.counters["left_route"],
            "convoy_found_again_on_route": self.model.counters["found_again"],
            "convoy_laps": self.model.counters["laps"],
            # Sent home or back to its route, seen driving elsewhere (a rally point?).
            "convoy_astray": self.model.counters["astray"],
            # How fast it was seen to take the route's sharp corners (None: not yet).
            "convoy_corner_speed_mps": None if corner is None else round(corner, 2),
            # The speed a rover driving its mission keeps where none is planned (learnt).
            "convoy_cruise_mps": None if cruise is None else round(cruise, 2),
            # The speed it keeps in place of its plan's (told it: DO_CHANGE_SPEED), and
            # each change of it: {t, mps (None: the plan's again), plan_mps}.
            "convoy_kept_mps": None if kept is None else round(kept, 2),
            "convoy_kept": [
                {"t": round(t, 1), "mps": _rounded(v), "plan_mps": _rounded(plan)}
                for t, v, plan in self.model.kept_log
            ],
            "convoy_speed_range_mps": None if speeds is None else [round(v, 2) for v in speeds],
            "convoy_fast": {
                "above_speed_ratio": FAST_CONVOY_RATIO,
                "seconds": round(self._fast_s, 1),
                "max_speed_ratio": round(self._top_ratio, 3),
            },
            "uav_replans": self.uav_replans,
            "replan_interval_s": None
            if not self._gaps_count
            else round(self._gaps_total / self._gaps_count, 2),
            "replan_lag_s": {
                "base": round(self._lag[0], 3),
                "per_uav": round(self._lag[1], 3),
                "max_one_uav": round(self._lag_max, 3),
            },
            "legs_late": self.legs_late,
            "plans_kept": self.plans_kept,
            "fills": self.fills,
            "side_switches": self.side_switches,
            "convoy_holds": self.holds,
            "flyability": {
                str(u): {
                    "min_turn_radius_m": round(radius, 1),
                    "speed_range_mps": [round(lo, 2), round(hi, 2)],
                }
                for u, (radius, lo, hi) in sorted(self._margins.items())
            },
        }

    def _score(self, t: float) -> None:
        """Coverage the paths in force gave, since the last score, against the estimates."""
        start = self._scored_until
        self._scored_until = t
        if start is None or self._protect_start is None or len(self._history) < 2:
            return
        # On a fixed grid of mission time: sampled from each call's own start, every
        # control step was a sample, and the score weighed steps rather than time.
        start = math.ceil(max(start, self._protect_start) / _SCORE_STEP) * _SCORE_STEP
        times = np.arange(start, t, _SCORE_STEP)
        if len(times) == 0:
            return
        hist = self._history
        ht = [h[0] for h in hist]
        r = self.request.sensor_radius
        for tau in times.tolist():
            j = bisect.bisect_right(ht, tau)
            if j == 0:
                continue
            if j >= len(hist):
                cx, cy = self.model.position(tau)
            else:
                (t0, x0, y0), (t1, x1, y1) = hist[j - 1], hist[j]
                f = (tau - t0) / max(t1 - t0, 1e-9)
                cx, cy = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
            seen = False
            for uav, traj in self._trajectories.items():
                if self._arrival.get(uav, math.inf) > tau:
                    continue
                s = traj.sample(tau)
                if math.hypot(s.x - cx, s.y - cy) <= r:
                    seen = True
                    break
            self._scored_s += _SCORE_STEP
            self._covered_s += _SCORE_STEP * seen


def _heading_error(pose: Pose, pattern: Where, t: float) -> float:
    """Radians ``pose`` at ``t`` goes off the pattern's way there (more than a right
    angle: its mirror image)."""
    return abs(wrap_angle(pose.heading - pattern_pose(pattern, t).heading))


def _rounded(value: float | None) -> float | None:
    """``value`` to the centimetre (None stays None), for the report."""
    return None if value is None else round(value, 2)
