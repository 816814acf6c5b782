"""The mission state machine: which plan is in force and what every UAV flies.

Design rules:
- One ``Plan`` at a time, from ``planning.make_plan`` with one slot per live
  UAV.  It lives in the planner frame; ``plan_origin`` (mission north/east
  of the convoy at ``plan_t0``) and ``plan_t0`` place it in the mission.
- Each UAV is ``pending`` (no join yet), then ``join`` (flying a timed Dubins
  join, ``convoy_mav.mission.join``), then ``protect`` (on its slot) -- until
  a replan sends it back to ``join``, or it is ``lost``.
- A replan (convoy started/stopped/turned/changed speed/drifted, see
  ``replan.py``; or a UAV lost) anchors a new plan at the convoy as estimated
  (moving case: origin = convoy position at replan time, ``plan_t0`` = that
  time) and re-joins every joined UAV from the pose it was *planned* to have
  at that instant, so every setpoint stream stays continuous.  Slots are
  assigned to minimise the last arrival (then the sum), by exhaustive search
  for small fleets and greedily beyond.
- A UAV back from a loss (``on_returned``) whose join would take longer than
  ``shadow_after_s`` (it was relaunched from its pad, far behind the convoy),
  while the others cover the convoy fully without it (a spare), is not planned
  for at once: re-planned for it, the others would leave its slot empty all the
  while it flies there. It first joins a slot of the plan in force
  (``Returning``), on its own altitude layer beside the UAV that flies it; once
  there, it is taken back and the fleet re-phases round it from there. (Without
  a spare the fleet's plan has holes either way, and is re-planned at once: on
  the mock, a copter relaunched 1.2 km behind, 80.3 % against 78.1 %; with a
  spare, a plane 3.7 km behind, 93.0 % against 83.6 %, from the relaunch on.)
- Pure and synchronous: every method takes the mission time; events are
  returned, never emitted.  Costs: a join is about 0.3-2 ms; a replan of N
  UAVs computes N x N joins (about 10-50 ms for N = 5).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

from convoy_mav.errors import PlanningError
from convoy_mav.mission.assign import Roster, best_assignment
from convoy_mav.mission.events import (
    MissionAlarm,
    MissionEvent,
    Phase,
    PhaseChanged,
    Replanned,
    Returning,
    phase_at,
)
from convoy_mav.mission.join import Join, earliest_arrival, plan_join
from convoy_mav.mission.replan import ChangeDetector, ConvoyMotion, ReplanThresholds
from convoy_mav.planning.dubins import Pose
from convoy_mav.planning.plan import Plan, PlanRequest, Trajectory, make_plan
from convoy_mav.schedule import mission_to_planner, setpoint_on
from convoy_mav.types import ConvoyEstimate, Setpoint

__all__ = ["Mission"]


@dataclass(frozen=True, slots=True)
class _Assignment:
    index: int  # vehicle index in the plan
    join: Join  # planner frame, planner time

    def arrival(self, plan_t0: float) -> float:
        return self.join.arrival + plan_t0


class Mission(Roster):
    """Plan, assignments and phases of the UAVs protecting one convoy.

    Args:
        request: Geometry and speeds (turn radius R, sensor radius r, UAV
            speed V).  Its convoy speed/heading and UAV count are ignored:
            they come from the convoy estimate and the live UAVs.
        uav_ids: The UAVs of the mission (MAVLink sysids), all live at start.
        down: Altitude setpoint (metres down, negative above the origin) of
            each UAV, by id.
        thresholds: Replan rules; ``position_tol`` None means ``r / 4``.
        shadow_after_s: A returned UAV whose join would take longer than this
            (mission s) flies to the fleet on a slot of the plan in force first.

    Driving it (the service's loop):

    - every convoy estimate -> ``on_convoy(est)`` (the first plan comes from
      the first steady fresh estimates);
    - once ``plan`` is not None, UAVs in ``awaiting_join`` that are flying ->
      ``join``/``join_many`` with their telemetry pose;
    - the setpoint streamer's source is ``setpoint(uav, t)``;
    - a vehicle declared lost -> ``on_lost(uav, t)``; flying again after that ->
      ``on_returned(uav, t)``, then ``join`` like any pending UAV;
    - ``tick(t)`` now and then (``PhaseChanged(.., "protect", ..)`` events are
      reported from there even when the convoy feed is stale).

    Raises:
        ValueError: If ``uav_ids`` is empty or has duplicates.
    """

    def __init__(
        self,
        request: PlanRequest,
        uav_ids: Sequence[int],
        *,
        down: Callable[[int], float],
        thresholds: ReplanThresholds | None = None,
        shadow_after_s: float = 60.0,
    ) -> None:
        super().__init__(uav_ids)
        if not shadow_after_s >= 0.0:
            raise ValueError(f"shadow_after_s must be >= 0, got {shadow_after_s!r}")
        self.shadow_after_s = shadow_after_s
        self.request = replace(request, convoy_speed=0.0, convoy_heading=0.0, uavs=None)
        self.thresholds = thresholds or ReplanThresholds()
        tol = self.thresholds.position_tol
        self.detector = ChangeDetector(
            self.thresholds, tol if tol is not None else 0.25 * request.sensor_radius
        )
        self._down = down
        self._plan: Plan | None = None
        self._motion: ConvoyMotion | None = None
        self._assigned: dict[int, _Assignment] = {}
        self._announced: set[int] = set()
        self._shadows: dict[int, _Assignment] = {}  # returning: the slot flown to the fleet
        self.replans = 0

    # ------------------------------------------------------------------ state

    @property
    def plan(self) -> Plan | None:
        """The plan in force (planner frame), None before the first convoy estimate."""
        return self._plan

    @property
    def motion(self) -> ConvoyMotion | None:
        """What the plan assumes the convoy does (its anchor and velocity)."""
        return self._motion

    @property
    def plan_origin(self) -> tuple[float, float]:
        """Mission (north, east) of the planner origin: the convoy at ``plan_t0``."""
        m = self._motion
        return (0.0, 0.0) if m is None else (m.north, m.east)

    @property
    def plan_t0(self) -> float:
        """Mission time of planner time 0 (the last replan)."""
        return 0.0 if self._motion is None else self._motion.t0

    @property
    def predicted_coverage(self) -> float | None:
        """Coverage the plan in force predicts once every UAV is on its slot."""
        return None if self._plan is None else self._plan.predicted_coverage

    @property
    def awaiting_join(self) -> tuple[int, ...]:
        """Live UAVs with no join yet (call ``join`` for them once a plan exists)."""
        return tuple(u for u in self._live if u not in self._assigned)

    @property
    def joined_at(self) -> float | None:
        """When every live UAV is (or will be) on its slot of the current plan.

        None while some live UAV has no join yet, or there is no plan.
        """
        if self._plan is None or not self._live or self.awaiting_join:
            return None
        return max(self._assigned[u].arrival(self.plan_t0) for u in self._live)

    def _of(self, uav: int) -> _Assignment | None:
        """The UAV's slot and join: its own, or the one it flies back to the fleet on."""
        return self._assigned.get(uav) or self._shadows.get(uav)

    def assignment(self, uav: int) -> int | None:
        """Plan vehicle index the UAV flies, None if it has none."""
        a = self._of(uav)
        return None if a is None else a.index

    def arrival(self, uav: int) -> float | None:
        """Mission time the UAV reaches (reached) its slot, None if it has no join.
        For a UAV flying back to the fleet, when it reaches the slot it flies there on
        (it is then taken back and joins anew)."""
        a = self._of(uav)
        return None if a is None else a.arrival(self.plan_t0)

    def join_info(self, uav: int) -> Join | None:
        """The UAV's current join (planner frame and time), for reports and plots."""
        a = self._of(uav)
        return None if a is None else a.join

    def trajectory(self, uav: int) -> Trajectory | None:
        """The UAV's trajectory (join lead-in + slot cycle), planner frame and time."""
        a = self._of(uav)
        return None if a is None else a.join.trajectory

    def phase(self, uav: int, t: float) -> Phase:
        """Where ``uav`` is at mission time ``t`` (flying back to the fleet: ``join``)."""
        if uav in self._returning:
            return "pending" if uav not in self._shadows else "join"
        return phase_at(uav in self._lost, self.arrival(uav), t)

    def convoy_position(self, t: float) -> tuple[float, float] | None:
        """Where the plan in force expects the convoy at mission time ``t``."""
        return None if self._motion is None else self._motion.position(t)

    def setpoint(self, uav: int, t: float) -> Setpoint | None:
        """What ``uav`` should fly at mission time ``t``; None if pending or lost."""
        a = self._of(uav)
        if a is None:
            return None
        return setpoint_on(
            a.join.trajectory,
            t,
            plan_origin=self.plan_origin,
            plan_t0=self.plan_t0,
            down=self._down(uav),
        )

    # --------------------------------------------------------------- inputs

    def tick(self, t: float) -> list[MissionEvent]:
        """Advance to mission time ``t``: report UAVs that reached their slots.

        ``PhaseChanged(uav, "protect", arrival)`` carries the exact arrival time
        (it may be slightly before ``t``).  Called by every other input too.
        """
        events: list[MissionEvent] = []
        back = [u for u, a in self._shadows.items() if a.arrival(self.plan_t0) <= t]
        if back and self._motion is not None:  # at the fleet: take them back, re-phase
            for uav in back:
                self._take_back(uav)
            events += self._replan(self._motion.advanced(t), "uav_returned", t)
        due = [
            (a.arrival(self.plan_t0), u)
            for u, a in self._assigned.items()
            if u not in self._announced and a.arrival(self.plan_t0) <= t
        ]
        for arrival, uav in sorted(due):
            self._announced.add(uav)
            events.append(PhaseChanged(uav, "protect", arrival))
        joined = self.joined_at
        if self._protect_start is None and joined is not None and joined <= t:
            self._protect_start = joined
        return events

    def on_convoy(self, est: ConvoyEstimate) -> list[MissionEvent]:
        """Fold in a convoy estimate; replans (first plan included) when the rules say so.

        Stale estimates never trigger a replan.
        """
        events = self.tick(est.t)
        decision = self.detector.observe(est)
        if decision is not None:
            events += self._replan(decision.motion, decision.reason, est.t)
        return events

    def join(self, uav: int, north: float, east: float, yaw: float, t: float) -> list[MissionEvent]:
        """Send ``uav`` from its pose at mission time ``t`` onto a free slot, on time.

        The free slot reached earliest is taken.  Calling it again for a UAV
        that already has a slot re-joins it from the given (actual) pose, e.g.
        after it was blown off its track.

        Args:
            uav: A live UAV.
            north, east: Its position, mission frame.
            yaw: Its course, rad clockwise from north.
            t: Mission time of that pose.

        Raises:
            PlanningError: If there is no plan yet (no convoy estimate).
            ValueError: If ``uav`` is not live, or the pose is not finite.
        """
        return self.join_many({uav: (north, east, yaw)}, t)

    def join_many(
        self, poses: Mapping[int, tuple[float, float, float]], t: float
    ) -> list[MissionEvent]:
        """``join`` for several UAVs at once, with the slots assigned jointly.

        Better than one ``join`` after another when several UAVs become ready
        together: the free slots are shared out to minimise the last arrival.

        Args:
            poses: (north, east, yaw) of each UAV at mission time ``t``.
            t: Mission time of the poses.

        Raises:
            PlanningError: If there is no plan yet (no convoy estimate).
            ValueError: If a UAV is not live, or a pose is not finite.
        """
        for uav, pose in poses.items():
            if uav not in self._live and uav not in self._returning:
                raise ValueError(f"UAV {uav} is not live in this mission")
            if len(pose) != 3 or not all(map(math.isfinite, (*pose, t))):
                raise ValueError(f"UAV {uav}: join pose must be 3 finite numbers, got {pose}")
        plan = self._plan
        if plan is None:
            raise PlanningError("no plan yet: the convoy has not been located")
        events: list[MissionEvent] = []
        returning = {u: p for u, p in poses.items() if u in self._returning}
        if returning:
            events += self._welcome(returning, t)
            poses = {u: p for u, p in poses.items() if u in self._live}
            plan = self._plan
            if not poses or plan is None:
                return events + self.tick(t)
        taken = {a.index for u, a in self._assigned.items() if u not in poses}
        free = [i for i in range(len(plan.vehicles)) if i not in taken]
        origin = self.plan_origin
        starts = {u: mission_to_planner(n, e, y, origin) for u, (n, e, y) in poses.items()}
        order = list(starts)
        tau0 = t - self.plan_t0
        for uav, index in zip(order, self._best_slots(order, starts, tau0, free), strict=True):
            self._assign(uav, index, starts[uav], tau0)
        return [*events, *(PhaseChanged(u, "join", t) for u in order), *self.tick(t)]

    def on_lost(self, uav: int, t: float) -> list[MissionEvent]:
        """Remove ``uav``; re-plan for the rest and re-join them to the new even spacing.

        The new plan keeps the convoy motion of the old one (re-anchored at
        ``t``); its ``Replanned.predicted_coverage`` is what the remaining
        UAVs can still give.
        """
        if uav in self._returning:  # lost again on its way back
            self._returning.discard(uav)
            self._shadows.pop(uav, None)
            return []
        if not self._take_out(uav):
            return []
        self._assigned.pop(uav, None)
        self._announced.discard(uav)
        if self._motion is None:
            return []
        return self.tick(t) + self._replan(self._motion.advanced(t), "uav_lost", t)

    def on_returned(self, uav: int, t: float) -> list[MissionEvent]:
        """A lost ``uav`` flies again: it is pending until joined (``join``/``join_many``
        from its actual pose), which decides how it is taken back.

        Near enough (its join within ``shadow_after_s``), or needed at once (the
        others do not cover the convoy fully), the fleet is re-planned for one more
        at once, the others re-phasing to the new even spacing while it joins its
        free slot. Farther, with the others covering fully, it flies to the fleet on
        a slot of the plan in force first (``Returning``), and is taken back once
        there. With no UAV left in the mission, or no plan yet, it is taken back at
        once.
        """
        if uav not in self._lost or uav in self._returning:
            return []
        if not self._live or self._motion is None or self._plan is None:
            self._take_back(uav)
            if self._motion is None:
                return []
            return self.tick(t) + self._replan(self._motion.advanced(t), "uav_returned", t)
        self._returning.add(uav)
        return self.tick(t)

    def _welcome(
        self, poses: Mapping[int, tuple[float, float, float]], t: float
    ) -> list[MissionEvent]:
        """Join returning UAVs: taken back at once if their join onto the plan in
        force is short or the plan does not cover fully, else sent to the fleet on its
        nearest slot (``Returning``)."""
        plan = self._plan
        assert plan is not None
        spare = plan.predicted_coverage >= 1.0 - 1e-9
        origin = self.plan_origin
        tau0 = t - self.plan_t0
        near: list[int] = []
        events: list[MissionEvent] = []
        for uav, (n, e, y) in poses.items():
            start = mission_to_planner(n, e, y, origin)
            costs = {i: self._cost(start, i, tau0) for i in range(len(plan.vehicles))}
            index = min(costs, key=costs.__getitem__)
            if not spare or costs[index] - tau0 <= self.shadow_after_s:
                near.append(uav)
                continue
            slot = plan.vehicles[index].trajectory
            r = self.request
            join = plan_join(start, slot, tau0, radius=r.turn_radius, speed=r.uav_speed)
            self._shadows[uav] = _Assignment(index, join)
            events.append(Returning(uav, t, index, join.arrival + self.plan_t0))
        if near and self._motion is not None:
            for uav in near:
                self._take_back(uav)
            events += self._replan(self._motion.advanced(t), "uav_returned", t)
        return events

    # ------------------------------------------------------------- internals

    def _cost(self, start: Pose, index: int, tau0: float) -> float:
        assert self._plan is not None
        slot = self._plan.vehicles[index].trajectory
        r = self.request
        return earliest_arrival(start, slot, tau0, radius=r.turn_radius, speed=r.uav_speed)

    def _assign(self, uav: int, index: int, start: Pose, tau0: float) -> None:
        assert self._plan is not None
        slot = self._plan.vehicles[index].trajectory
        r = self.request
        join = plan_join(start, slot, tau0, radius=r.turn_radius, speed=r.uav_speed)
        self._assigned[uav] = _Assignment(index, join)
        self._announced.discard(uav)

    def _replan(self, motion: ConvoyMotion, reason: str, t: float) -> list[MissionEvent]:
        if not self._live:  # nobody left to fly to: the returning are the fleet now
            for uav in sorted(self._returning):
                self._take_back(uav)
        count = len(self._live)
        self.detector.set_reference(motion)
        if count == 0:
            self._plan, self._motion = None, motion
            self._assigned.clear()
            return [Replanned(t, reason, 0.0, 0)]
        heading = math.atan2(motion.vn, motion.ve) if motion.moving else 0.0
        try:
            request = replace(
                self.request, convoy_speed=motion.speed, convoy_heading=heading, uavs=count
            )
            plan = make_plan(request)
        except PlanningError as exc:
            return [MissionAlarm(t, f"replan ({reason}) failed, keeping the last plan: {exc}")]
        # Where every joined UAV is planned to be now: the start of its new join.
        poses = {}
        for uav in [*self._live, *self._shadows]:
            sp = self.setpoint(uav, t)
            if sp is not None:
                poses[uav] = (sp.north, sp.east, sp.yaw)
        self._plan, self._motion = plan, motion
        self._assigned.clear()
        self._announced.clear()
        self._shadows.clear()
        self.replans += 1
        tau0 = t - motion.t0
        starts = {
            u: mission_to_planner(n, e, y, self.plan_origin) for u, (n, e, y) in poses.items()
        }
        order = [u for u in starts if u in self._live]
        slots = range(len(plan.vehicles))
        for uav, index in zip(order, self._best_slots(order, starts, tau0, slots), strict=True):
            self._assign(uav, index, starts[uav], tau0)
        r = self.request
        for uav in self._returning & starts.keys():  # on their way: to the new plan's fleet
            index = min(slots, key=lambda i: self._cost(starts[uav], i, tau0))
            join = plan_join(
                starts[uav], plan.vehicles[index].trajectory, tau0,
                radius=r.turn_radius, speed=r.uav_speed,
            )  # fmt: skip
            self._shadows[uav] = _Assignment(index, join)
        events: list[MissionEvent] = [
            Replanned(t, reason, plan.predicted_coverage, count, plan.min_uavs, plan.case)
        ]
        events += [PhaseChanged(u, "join", t) for u in order]
        return events + self.tick(t)

    def _best_slots(
        self, uavs: list[int], starts: dict[int, Pose], tau0: float, slots: Sequence[int]
    ) -> tuple[int, ...]:
        """Slot (of ``slots``) for each of ``uavs`` minimising the last arrival, then the total."""
        cost = {(u, i): self._cost(starts[u], i, tau0) for u in uavs for i in slots}
        return best_assignment(uavs, slots, cost)
