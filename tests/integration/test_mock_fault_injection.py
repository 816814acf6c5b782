"""Injected faults seen from a client over real UDP: kill, reboot, loss, latency."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import TYPE_CHECKING

import pytest
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.config import MockConfig

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import MavClient

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]


async def test_killed_vehicle_stops_sending_and_answering(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    fleet = await start_mock(
        MockConfig.simple(2, speedup=20, base_port=0, faults={"kill": ["1@4"]})
    )
    a, b = mav_client(fleet.endpoint(1).port), mav_client(fleet.endpoint(2).port)
    a.hello()
    b.hello()
    await a.until(lambda: fleet.now >= 3.5, others=[b])
    assert a.of("HEARTBEAT") and fleet.is_alive(1)
    await a.until(lambda: fleet.now >= 4.2, others=[b])
    n_before = len(a.log)
    await a.until(lambda: fleet.now >= 8.0, others=[b])
    assert len(a.log) == n_before, "nothing at all after the kill"
    assert not fleet.is_alive(1)
    assert max(m.time_boot_ms for m in a.of("ATTITUDE")) <= 4000
    a.mav.command_long_send(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    await a.until(lambda: fleet.now >= 9.0, others=[b])
    assert not a.of("COMMAND_ACK")
    assert fleet.counters(1)["killed"] >= 1
    assert fleet.truth(1).mode == "KILLED"
    # The other vehicle is unaffected.
    assert max(m.time_boot_ms for m in b.of("ATTITUDE")) > 8000


async def test_reboot_restarts_time_boot_ms(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    fleet = await start_mock(
        MockConfig.simple(1, speedup=20, base_port=0, faults={"reboot": ["1@5"]})
    )
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    await client.until(lambda: fleet.now >= 8.0)
    stamps = [m.time_boot_ms for m in client.of("ATTITUDE")]
    drop = [i for i in range(1, len(stamps)) if stamps[i] < stamps[i - 1]]
    assert len(drop) == 1
    assert stamps[drop[0] - 1] >= 4900
    assert stamps[drop[0]] <= 100
    assert stamps[-1] == pytest.approx(3000, abs=200)
    assert fleet.counters(1)["reboot"] == 1


async def test_total_loss_from_vehicle_means_silence(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    faults = {"loss_from_vehicle": 1.0}
    fleet = await start_mock(MockConfig.simple(1, speedup=20, base_port=0, faults=faults))
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    client.mav.command_long_send(1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0, 0, 0, 0, 0, 0, 0)
    await client.until(lambda: fleet.now >= 3.0)
    assert client.log == []
    c = fleet.counters(1)
    assert c["messages_in"] == 2  # the vehicle hears us...
    assert c["lost_from_vehicle"] >= 30  # ...and everything it says is lost
    assert c["datagrams_out"] == 0


async def test_latency_delays_both_directions_in_sim_time(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    latency = 0.5
    fleet = await start_mock(
        MockConfig.simple(1, speedup=20, base_port=0, faults={"latency": latency})
    )
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    await client.wait_for("HEARTBEAT")
    t_sent = fleet.now
    ack = await client.command(mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 30)
    round_trip = fleet.now - t_sent
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    assert 2 * latency <= round_trip < 2 * latency + 0.3
    # Telemetry is late by the latency: the newest ATTITUDE is about 0.5 s old.
    await client.until(lambda: fleet.now >= t_sent + 3.0)
    newest = max(m.time_boot_ms for m in client.of("ATTITUDE")) / 1000.0
    assert fleet.now - newest >= latency - 0.02


async def test_a_paused_fleet_answers_nothing_until_it_runs_again(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    """A paused simulator (SIGSTOP, a lockstep wait) reads nothing: a TIMESYNC sent
    during the pause is answered once it runs, never during it, so a ground station
    hears the silence it must (a link timed by TIMESYNC once kept every UAV 'heard')."""
    fleet = await start_mock(MockConfig.simple(1, speedup=20, base_port=0))
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    await client.wait_for("HEARTBEAT")
    pause = asyncio.create_task(fleet.pause(0.3))
    await asyncio.sleep(0.05)
    n_before = len(client.log)
    client.mav.timesync_send(0, 123_456)
    await client.until(pause.done)
    assert not [m for m in client.log[n_before:] if m.get_type() == "TIMESYNC"]
    answer = await client.wait_for("TIMESYNC", lambda m: m.ts1 == 123_456, since=n_before)
    assert answer.tc1 > 0  # (its boot time: an answer, not a request)
