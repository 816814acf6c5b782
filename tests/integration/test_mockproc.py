"""``MockProcess``: the mock in a child process, reached over UDP, truth sent back.

The service flies against it as against a real autopilot (nothing shared but
sockets); the ground truth must come back whole when the flight ends, and a
mock that cannot start must say why in the parent.
"""

from __future__ import annotations

import asyncio
import socket

import pytest

from convoy_mav.demo import SCENARIOS, mock_mapping, run_demo
from convoy_mav.errors import ConfigError
from convoy_mav.mockproc import MockProcess, MockProcessError
from tests.hostspeed import host_speedup

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]


async def test_a_demo_against_a_mock_in_its_own_process_is_scored_from_its_truth() -> None:
    scenario = SCENARIOS["stationary"]
    # (the service's own interpreter flies six UAVs: at the host's speedup, as in-process
    # flights do; a fixed 40x on a host 2.7 times slower never reached the slots)
    result = await run_demo(scenario, duration=150.0, speedup=host_speedup(40.0), mock_process=True)
    assert result.truth is not None and result.truth.elapsed_s > 20.0
    report = result.to_dict()
    # the same verdict by the service's monitor and by the child's truth
    assert result.truth.fraction >= 0.99, result.truth
    assert abs(report["coverage_fraction"] - result.truth.fraction) < 0.02
    assert report["uav_count"] == scenario.fleet()


async def test_the_truth_comes_back_for_every_vehicle_and_the_child_is_gone() -> None:
    mapping = mock_mapping(SCENARIOS["moving"], 2, speedup=40.0, duration=60.0)
    mock = MockProcess(mapping)
    async with mock:
        assert [e.kind for e in mock.endpoints] == ["aircraft", "aircraft", "ground", "ground"]
        assert all(e.port > 0 for e in mock.endpoints)  # bound by the child
        proc = mock._proc
        assert proc is not None and proc.is_alive()
        # Let its simulation run a while (40 sim s a wall second): stopped at once, a child
        # on a loaded host had recorded only its first truth rows, at t = 0.
        await asyncio.sleep(1.0)
    assert not proc.is_alive()
    assert mock.history is not None
    rows = mock.history.rows
    assert {r.sysid for r in rows} == {e.sysid for e in mock.endpoints}
    assert max(r.t for r in rows) > 0.0


async def test_a_mock_that_cannot_start_says_why_in_the_parent() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        mapping = mock_mapping(SCENARIOS["moving"], 1, speedup=40.0, duration=60.0)
        mapping["base_port"] = port
        mapping["host"] = "127.0.0.1"
        with pytest.raises(MockProcessError, match="sitl_mock failed"):
            async with MockProcess(mapping):
                pass


async def test_a_mock_that_died_in_flight_says_so_instead_of_a_missing_truth() -> None:
    mapping = mock_mapping(SCENARIOS["moving"], 1, speedup=40.0, duration=60.0)
    with pytest.raises(MockProcessError, match="exited"):
        async with MockProcess(mapping) as mock:
            assert mock._proc is not None
            mock._proc.kill()
            mock._proc.join()


def test_a_bad_mock_config_is_refused_before_any_process_starts() -> None:
    mapping = mock_mapping(SCENARIOS["moving"], 1, speedup=40.0, duration=60.0)
    mapping["speedup"] = -1.0
    with pytest.raises(ConfigError):
        MockProcess(mapping)


async def test_a_fault_script_needs_the_mock_in_process() -> None:
    async def script(fleet: object, service: object) -> None:
        pass

    with pytest.raises(ValueError, match="in-process"):
        await run_demo(SCENARIOS["stationary"], duration=10.0, mock_process=True, during=script)
