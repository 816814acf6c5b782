"""End-to-end pure simulation: ConvoyTracker + Mission + ideal UAVs + CoverageTracker.

The UAVs fly their setpoints exactly (ideal kinematics), so these tests score
the mission logic alone: joins land on time, replans follow the convoy, and
the coverage over every protect interval is what the plan predicts.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import pytest

from convoy_mav.convoy import ConvoyTracker
from convoy_mav.coverage import CoverageStats, CoverageTracker
from convoy_mav.mission import Mission, MissionEvent, PhaseChanged, Replanned
from convoy_mav.planning import PlanRequest

R, r, V = 150.0, 100.0, 18.0
IDS = (1, 2, 3, 4, 5)
Route = Callable[[float], tuple[float, float]]


def start_turn_route(t_start: float = 150.0, t_turn: float = 450.0, speed: float = 6.0) -> Route:
    """Stationary, then north-east at ``speed``, then a 60 deg turn to the right."""

    def position(t: float) -> tuple[float, float]:
        if t <= t_start:
            return 0.0, 0.0
        c1, c2 = math.radians(45.0), math.radians(105.0)
        d1 = speed * (min(t, t_turn) - t_start)
        d2 = speed * max(t - t_turn, 0.0)
        return d1 * math.cos(c1) + d2 * math.cos(c2), d1 * math.sin(c1) + d2 * math.sin(c2)

    return position


@dataclass
class SimResult:
    mission: Mission
    events: list[MissionEvent]
    intervals: list[tuple[float, float, CoverageStats]]  # protect intervals and their coverage
    max_step: float  # largest distance any UAV moved in one step
    min_step: float  # smallest, once flying


def simulate(
    route: Route, end: float, dt: float, lose: tuple[int, float] | None = None
) -> SimResult:
    """Run the mission loop the service runs, with perfect UAVs and two trucks."""
    mission = Mission(PlanRequest(R, r, V), IDS, down=lambda u: -100.0 - 10.0 * u)
    tracker = ConvoyTracker(window=4.0)
    pose = {u: (-500.0 + 60.0 * u, -300.0 + 20.0 * u, 0.3 * u) for u in IDS}
    events: list[MissionEvent] = []
    intervals: list[tuple[float, float, CoverageStats]] = []
    current: tuple[float, CoverageTracker] | None = None
    max_step, min_step = 0.0, math.inf
    flying: set[int] = set()  # UAVs that had a setpoint at the previous step
    for k in range(round(end / dt) + 1):
        t = k * dt
        n, e = route(t)
        # two trucks 20 m apart reporting alternately
        tracker.update(t, n + (10.0 if k % 2 else -10.0), e, source=100 + k % 2)
        est = tracker.estimate(t)
        assert est is not None
        events += mission.on_convoy(est)
        if lose is not None and abs(t - lose[1]) < dt / 2:
            events += mission.on_lost(lose[0], t)
        if mission.plan is not None and mission.awaiting_join:
            events += mission.join_many({u: pose[u] for u in mission.awaiting_join}, t)
        events += mission.tick(t)
        for uav in mission.live_uavs:
            sp = mission.setpoint(uav, t)
            if sp is not None:
                step = math.hypot(sp.north - pose[uav][0], sp.east - pose[uav][1])
                if uav in flying:
                    max_step, min_step = max(max_step, step), min(min_step, step)
                pose[uav] = (sp.north, sp.east, sp.yaw)
                flying.add(uav)
        joined = mission.joined_at
        if joined is not None and t >= joined:
            if current is None:
                current = (t, CoverageTracker(r))
            current[1].update(t, (n, e), {u: pose[u][:2] for u in mission.live_uavs})
        elif current is not None:
            intervals.append((current[0], t, current[1].stats()))
            current = None
    if current is not None:
        intervals.append((current[0], end, current[1].stats()))
    return SimResult(mission, events, intervals, max_step, min_step)


def test_stationary_start_turn_is_covered_in_every_protect_interval() -> None:
    res = simulate(start_turn_route(), end=800.0, dt=0.1)
    replans = [ev for ev in res.events if isinstance(ev, Replanned)]
    assert [(ev.reason, ev.case, ev.uav_count) for ev in replans] == [
        ("initial", "stationary", 5),
        ("convoy_started", "moving", 5),
        ("heading_change", "moving", 5),
    ]
    # replans follow the changes within a few seconds (window 4 s, confirm 2 s)
    assert 150.0 < replans[1].t < 157.0 and 450.0 < replans[2].t < 457.0
    # the moving plan is on the convoy's real course and speed
    plan = res.mission.plan
    assert plan is not None
    assert plan.request.convoy_speed == pytest.approx(6.0, rel=1e-3)
    assert math.degrees(plan.request.convoy_heading) == pytest.approx(90.0 - 105.0, abs=0.1)
    # one protect interval after each join phase, each covered >= 99.9 %
    assert len(res.intervals) == 3
    for (start, stop, stats), replan in zip(res.intervals, replans, strict=True):
        assert start - replan.t < 120.0  # joins take about one orbit
        assert stop - start > 80.0
        assert stats.fraction >= 0.999, (start, stop, stats)
    # every UAV reached protect after every replan
    protects = [ev for ev in res.events if isinstance(ev, PhaseChanged) and ev.phase == "protect"]
    assert len(protects) == 3 * len(IDS)
    assert res.mission.protect_start == pytest.approx(res.intervals[0][0], abs=0.1)
    # ideal kinematics: constant speed V, continuous through every join and replan
    assert res.max_step <= V * 0.1 * (1 + 1e-6)
    assert res.min_step >= V * 0.1 * 0.999


@pytest.mark.parametrize(
    ("route", "predicted"),
    [
        (start_turn_route(t_start=1e9), 4 * math.asin(r / R) / math.pi),  # stationary: 0.929
        (start_turn_route(t_start=50.0, t_turn=1e9), 1.0),  # moving: 4 = min_uavs
    ],
    ids=["stationary", "moving"],
)
def test_losing_a_uav_gives_the_predicted_coverage(route: Route, predicted: float) -> None:
    res = simulate(route, end=1000.0, dt=0.2, lose=(3, 400.0))
    lost = [ev for ev in res.events if isinstance(ev, Replanned) and ev.reason == "uav_lost"]
    assert len(lost) == 1 and lost[0].uav_count == 4
    assert lost[0].predicted_coverage == pytest.approx(predicted)
    assert res.mission.live_uavs == (1, 2, 4, 5)
    before, after = res.intervals[-2], res.intervals[-1]
    assert before[1] == pytest.approx(400.0) and before[2].fraction >= 0.999
    start, stop, stats = after
    assert start - 400.0 < 120.0 and stop - start > 450.0  # about 9 orbits re-phased
    assert abs(stats.fraction - predicted) <= 0.01, stats.fraction
    assert res.max_step <= V * 0.2 * (1 + 1e-6)
