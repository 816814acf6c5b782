"""Timed Dubins joins: continuous, constant speed, bounded turn rate, on time."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from convoy_mav.mission import join as join_module
from convoy_mav.mission.join import (
    earliest_arrival,
    plan_join,
    rotated_cycle,
    slot_pose,
)
from convoy_mav.planning import Plan, PlanRequest, Pose, Trajectory, make_plan
from convoy_mav.planning.dubins import dubins_shortest_path

R, r, V = 150.0, 100.0, 18.0
PLANS = {
    "stationary": make_plan(PlanRequest(R, r, V)),
    "moving": make_plan(PlanRequest(R, r, V, convoy_speed=6.0, convoy_heading=0.7)),
    "trivial": make_plan(PlanRequest(80.0, r, 15.0, uavs=2)),
}


def _starts(n: int, seed: int) -> list[Pose]:
    rng = random.Random(seed)
    return [
        Pose(rng.uniform(-900, 900), rng.uniform(-900, 900), rng.uniform(-math.pi, math.pi))
        for _ in range(n)
    ]


def _check_join(plan: Plan, index: int, start: Pose, tau0: float) -> None:
    """Every property a join must have, checked on densely sampled states."""
    req = plan.request
    slot = plan.vehicles[index].trajectory
    join = plan_join(start, slot, tau0, radius=req.turn_radius, speed=req.uav_speed)
    traj = join.trajectory
    speed, radius = req.uav_speed, req.turn_radius
    # starts where the UAV is
    s0 = traj.sample(tau0)
    assert (s0.x, s0.y) == pytest.approx((start.x, start.y), abs=1e-6)
    assert math.cos(s0.heading - start.heading) == pytest.approx(1.0)
    # constant speed V: the path is exactly as long as the time to arrival allows
    assert join.path_length == pytest.approx(speed * (join.arrival - tau0), abs=1e-6)
    assert join.arrival >= tau0
    dt = 0.02
    ts = np.arange(tau0, join.arrival + slot.period, dt)
    samples = [traj.sample(float(t)) for t in ts]
    x = np.array([s.x for s in samples])
    y = np.array([s.y for s in samples])
    steps = np.hypot(np.diff(x), np.diff(y))
    assert np.max(steps) <= speed * dt * (1 + 1e-9)  # continuous: never a jump
    assert np.min(steps) >= speed * dt * 0.999  # never slower either
    assert all(s.speed == pytest.approx(speed) for s in samples)
    assert max(abs(s.turn_rate) for s in samples) <= speed / radius * (1 + 1e-12)
    # after arrival it is the plan slot
    for t in ts[ts >= join.arrival + 1e-6][::50]:
        a, b = traj.sample(float(t)), slot.sample(float(t))
        assert math.hypot(a.x - b.x, a.y - b.y) < 1e-3
        assert math.cos(a.heading - b.heading) == pytest.approx(1.0)
    assert earliest_arrival(start, slot, tau0, radius=radius, speed=speed) == pytest.approx(
        join.arrival, abs=1e-4
    )


@pytest.mark.parametrize("case", sorted(PLANS))
def test_joins_from_anywhere_are_continuous_constant_speed_and_on_time(case: str) -> None:
    plan = PLANS[case]
    for k, start in enumerate(_starts(4, seed=len(case))):
        _check_join(plan, k % len(plan.vehicles), start, tau0=13.0 + 7.0 * k)


@pytest.mark.parametrize("case", ["stationary", "moving"])
@pytest.mark.parametrize("lag", [0.5, 5.0, -5.0, -40.0])
def test_joins_onto_the_slots_own_path(case: str, lag: float) -> None:
    # Behind or ahead of the slot on its own path: the shortest path never fits
    # exactly (the slot cannot be caught at equal speed, or is overshot), so a
    # longer Dubins word of exactly the right length is found.
    plan = PLANS[case]
    slot = plan.vehicles[1].trajectory
    start = slot_pose(slot, 20.0 - lag)
    _check_join(plan, 1, start, 20.0)
    join = plan_join(start, slot, 20.0, radius=R, speed=V)
    assert join.loiter_radius is None
    assert join.duration > 10.0


def test_already_on_slot_arrives_at_once() -> None:
    slot = PLANS["moving"].vehicles[2].trajectory
    join = plan_join(slot_pose(slot, 50.0), slot, 50.0, radius=R, speed=V)
    assert (join.arrival, join.path_length, join.word, join.trajectory.lead_in) == (
        50.0,
        0.0,
        "",
        (),
    )
    assert join.trajectory.sample(80.0).x == pytest.approx(slot.sample(80.0).x)


def test_f_never_increases() -> None:
    # The arrival search rests on f(T) = L(T) - V (T - t) being non-increasing.
    for case in ("stationary", "moving"):
        slot = PLANS[case].vehicles[0].trajectory
        for start in _starts(3, seed=11):
            taus = np.linspace(5.0, 5.0 + 2 * slot.period, 600)
            f = [
                dubins_shortest_path(start, slot_pose(slot, float(t)), R, V).length - V * (t - 5.0)
                for t in taus
            ]
            assert np.max(np.diff(f)) < 1e-6


def test_wait_circle_fallback_is_exact(monkeypatch: pytest.MonkeyPatch) -> None:
    # Force the last resort (no single word of the right length before T2):
    # a wait circle of radius >= R absorbs the slack exactly.
    monkeypatch.setattr(join_module, "_scan_words", lambda *args: None)
    plan = PLANS["stationary"]
    slot = plan.vehicles[0].trajectory
    start = slot_pose(slot, 20.0 - 5.0)  # trailing the slot on its own circle
    join = plan_join(start, slot, 20.0, radius=R, speed=V)
    assert join.loiter_radius is not None and join.loiter_radius >= R
    first = join.trajectory.lead_in[0]
    assert first.radius == join.loiter_radius
    assert first.duration == pytest.approx(2 * math.pi * join.loiter_radius / V)
    _check_join(plan, 0, start, 20.0)  # same checks, through the fallback


@pytest.mark.parametrize("case", ["stationary", "moving"])
def test_rotated_cycle_samples_as_the_slot(case: str) -> None:
    slot = PLANS[case].vehicles[1].trajectory
    for tau in (3.0, slot.cycle[0].duration + 0.5, 2.5 * slot.period, slot.t_start):
        rotated = Trajectory(tau, rotated_cycle(slot, tau), drift=slot.drift)
        for t in np.linspace(tau, tau + 3 * slot.period, 50):
            a, b = rotated.sample(float(t)), slot.sample(float(t))
            assert (a.x, a.y, a.turn_rate) == pytest.approx((b.x, b.y, b.turn_rate), abs=1e-6)


def test_bad_arguments() -> None:
    slot = PLANS["stationary"].vehicles[0].trajectory
    with pytest.raises(ValueError):
        plan_join(Pose(0, 0, 0), slot, 0.0, radius=0.0, speed=V)
    with pytest.raises(ValueError):
        earliest_arrival(Pose(0, 0, 0), slot, 0.0, radius=R, speed=math.nan)
    joined = plan_join(Pose(500, 0, 0), slot, 0.0, radius=R, speed=V).trajectory
    with pytest.raises(ValueError, match="lead-in"):
        rotated_cycle(joined, 1.0)
