"""What the safety checks cost: separation over 1000 UAVs, the fence per setpoint.

Run with ``make bench`` (or ``pytest benchmarks/bench_safety.py --benchmark-only``).
The separation check runs every control tick (10 Hz of mission time); the fence
check on every setpoint sent (20 Hz per UAV).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.fence import Fence, polygon_from
from convoy_mav.separation import conflicts
from convoy_mav.types import Setpoint

RNG = np.random.default_rng(7)
# 1000 UAVs over 20 km x 20 km, altitude layers 5 m apart: a big fleet's airspace.
FLEET = {
    i: (float(n), float(e), -100.0 - 5.0 * (i % 40))
    for i, (n, e) in enumerate(RNG.uniform(-10_000, 10_000, (1000, 2)), start=1)
}


def _brute(positions: dict[int, tuple[float, float, float]]) -> int:
    return sum(
        1
        for a, b in itertools.combinations(positions, 2)
        if math.hypot(positions[a][0] - positions[b][0], positions[a][1] - positions[b][1]) < 30.0
        and abs(positions[a][2] - positions[b][2]) < 3.0
    )


def test_separation_1000_uavs_hashed(benchmark: BenchmarkFixture) -> None:
    found = benchmark(conflicts, FLEET, 30.0, 3.0)
    assert len(found) == _brute(FLEET)


def test_separation_1000_uavs_every_pair(benchmark: BenchmarkFixture) -> None:
    """The O(N^2) check hashing replaces, for the ratio."""
    benchmark.pedantic(_brute, (FLEET,), rounds=3, iterations=1)  # type: ignore[no-untyped-call]


def test_fence_check_of_one_setpoint_inside(benchmark: BenchmarkFixture) -> None:
    ring = [(3000 * math.cos(a), 3000 * math.sin(a)) for a in np.linspace(0, 2 * math.pi, 21)[:-1]]
    hole = polygon_from([(100, 100), (100, 300), (300, 300), (300, 100)])
    fence = Fence(polygon_from(ring), (hole,), 30.0, 500.0)
    sp = Setpoint(0.0, 500.0, -800.0, -100.0, 10.0, 5.0, 0.0, 0.5, 0.0, (500.0, -650.0), 150.0)
    assert benchmark(fence.clamp, sp) is sp
