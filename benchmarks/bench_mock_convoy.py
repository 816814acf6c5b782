"""Cost of a convoy that drives behind its leader, in the mock's loop (``sitl_mock.trail``).

Each of a road convoy's following vehicles drives the path the one ahead drove: every
ground vehicle's path is recorded, and each follower stepped, at 10 Hz. Side by side, a
convoy of four on the city circuit stepped as the mock steps it (physics at 100 Hz,
telemetry built but not sent), with its followers behind their leaders and with each
on its own copy of the road (the mock before them).

Run: ``.venv/bin/python -m pytest benchmarks/bench_mock_convoy.py --benchmark-only``.
"""

from __future__ import annotations

import dataclasses

import pytest
from pytest_benchmark.fixture import BenchmarkFixture

from sitl_mock.config import config_from_mapping
from sitl_mock.server import MockFleet

_CIRCUIT = {
    "route": "polyline",
    "points": [[0, 0], [500, 0], [500, 350], [250, 350], [250, 600], [0, 600]],
    "loop": True,
    "speed": 8.0,
    "accel": 1.0,
    "holds": [[2, 30.0]],
    "speeds": [[0, 8.0], [3, 6.0]],
    "spacing": 20.0,
    "personality": "ardupilot",
}
_STEPS = 1000  # 10 sim s


def _fleet(behind: bool) -> MockFleet:
    config = config_from_mapping({"aircraft": {"count": 0}, "ground": {"count": 4, **_CIRCUIT}})
    if not behind:  # (each on its own copy of the road, a time behind)
        specs = tuple(dataclasses.replace(v, follows=None) for v in config.vehicles)
        config = dataclasses.replace(config, vehicles=specs)
    fleet = MockFleet(config, run_physics=False)
    for _ in range(6000):  # (a minute: under way, the trail as long as it gets)
        fleet.step()
    return fleet


@pytest.mark.parametrize("behind", [True, False], ids=["behind-leader", "own-road"])
def test_stepping_a_convoy_of_four(benchmark: BenchmarkFixture, behind: bool) -> None:
    fleet = _fleet(behind)

    def steps() -> None:
        for _ in range(_STEPS):
            fleet.step()

    benchmark(steps)
    rows = [r for r in fleet.truth_rows() if r.kind == "ground"]
    assert len(rows) == 4 and all(r.speed > 0.0 for r in rows)  # (all four driving)
