"""Planner speed: plan time for 32 UAVs and sampling throughput.

Run with ``make bench`` (or ``pytest benchmarks/bench_planning.py --benchmark-only``).
Throughput in samples/s is ``samples / median`` of the reported times.
"""

from __future__ import annotations

import numpy as np
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.planning import Plan, PlanRequest, make_plan

# R/r = 10 needs exactly 32 UAVs in the stationary case (Corollary 3.7).
STATIONARY_32 = PlanRequest(1000.0, 100.0, 20.0)
MOVING_32 = PlanRequest(1000.0, 100.0, 20.0, convoy_speed=5.0, uavs=32)
N_VECTOR = 100_000


def test_plan_32_uavs_stationary(benchmark: BenchmarkFixture) -> None:
    plan = benchmark(make_plan, STATIONARY_32)
    assert len(plan.vehicles) == 32


def test_plan_32_uavs_moving(benchmark: BenchmarkFixture) -> None:
    plan = benchmark(make_plan, MOVING_32)
    assert len(plan.vehicles) == 32


def _tick(plan: Plan, t: float) -> float:
    """One setpoint tick: sample every vehicle once (what the streamer does)."""
    acc = 0.0
    for v in plan.vehicles:
        acc += v.sample(t).x
    return acc


def test_sample_scalar_tick_32_uavs(benchmark: BenchmarkFixture) -> None:
    """32 scalar samples per call: samples/s = 32 / median."""
    plan = make_plan(MOVING_32)
    benchmark(_tick, plan, 1234.5)


def test_sample_array_100k(benchmark: BenchmarkFixture) -> None:
    """100 000 vectorised samples per call: samples/s = 1e5 / median."""
    traj = make_plan(MOVING_32).vehicles[5].trajectory
    ts = np.linspace(0.0, 3600.0, N_VECTOR)
    out = benchmark(traj.sample_array, ts)
    assert out.x.shape == (N_VECTOR,)
