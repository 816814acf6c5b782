"""Cost of one physics step: the mock must run 200 aircraft at 100 Hz faster than real time.

200 x 100 = 20,000 steps per simulated second, so a step must stay well under 50 us
(on one core, with the server's MAVLink work on top); the target is a few us.

Run: ``.venv/bin/python -m pytest benchmarks/bench_mock_kinematics.py --benchmark-only``.
"""

from __future__ import annotations

import math

from pytest_benchmark.fixture import BenchmarkFixture

from sitl_mock.kinematics import Aircraft, AircraftState, AirframeParams, TrackTarget

_STEPS = 1000


def _tracking_plane() -> Aircraft:
    """A plane in wind tracking a circle streamed as pos+vel targets, like the product's."""
    params = AirframeParams(wind_north=3.0, wind_east=-2.0)
    ac = Aircraft(params, AircraftState(150.0, 0.0, -60.0, 1.6, 18.0, airborne=True))
    radius, speed = 120.0, 18.0
    for k in range(3):  # two targets give the reference's turn rate
        th = speed / radius * 0.05 * k
        ac.command(
            TrackTarget(
                north=radius * math.cos(th),
                east=radius * math.sin(th),
                down=-50.0,
                vn=-speed * math.sin(th),
                ve=speed * math.cos(th),
            )
        )
        for _ in range(5):
            ac.step(0.01)
    return ac


def test_step_tracking_aircraft(benchmark: BenchmarkFixture) -> None:
    ac = _tracking_plane()
    step = ac.step

    def run() -> None:
        for _ in range(_STEPS):
            step(0.01)

    benchmark(run)
    assert ac.state.airborne
    if benchmark.stats is not None:  # None under --benchmark-disable
        per_step_us = benchmark.stats.stats.median / _STEPS * 1e6
        benchmark.extra_info["median_step_us"] = round(per_step_us, 3)
        assert per_step_us < 50.0
