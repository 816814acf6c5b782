"""MqttPublisher against a real mosquitto: payloads, inputs, and a broker that dies or hangs.

The flight-loop stand-in ticks every few milliseconds and calls ``publish()``
on each tick; the point of the outage tests is that its tick rate does not
notice the broker going away (issue 4: "setpoints never stop, publishing resumes").
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import sys
import time
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import aiomqtt
import pytest

from convoy_mav.coverage import CoverageSample, CoverageStats
from convoy_mav.publish import MqttPublisher, topics
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.types import Telemetry, VehicleStatus
from tests.broker import Broker, mqtt_broker_fixture  # noqa: F401 - provides `mqtt_broker`

pytestmark = [pytest.mark.integration, pytest.mark.timeout(30)]

PREFIX = "test/convoy"
WALL = 1_714_564_800.0

Received = list[tuple[str, Any, bool]]  # topic, decoded JSON (or text), retain flag


def publisher(broker: Broker, **kwargs: Any) -> MqttPublisher:
    """A publisher on the test prefix with back-off small enough for a test (50-200 ms)."""
    kwargs.setdefault("reconnect_initial", 0.05)
    kwargs.setdefault("reconnect_max", 0.2)
    return MqttPublisher(broker.host, broker.port, PREFIX, **kwargs)


async def wait_for(predicate: Callable[[], bool], timeout: float = 3.0, what: str = "") -> None:
    """Poll ``predicate`` on the event loop until true, or fail the test."""
    try:
        async with asyncio.timeout(timeout):
            while not predicate():
                await asyncio.sleep(0.005)
    except TimeoutError:
        pytest.fail(f"timed out after {timeout}s waiting for {what or predicate}")


def _decode(payload: Any) -> Any:
    try:
        return json.loads(payload)
    except ValueError:
        return payload


@contextlib.asynccontextmanager
async def subscriber(broker: Broker, pattern: str = f"{PREFIX}/#") -> AsyncIterator[Received]:
    """An independent aiomqtt client that records everything under ``pattern``."""
    got: Received = []
    async with aiomqtt.Client(broker.host, broker.port) as client:
        await client.subscribe(pattern)

        async def collect() -> None:
            async for m in client.messages:
                got.append((m.topic.value, _decode(m.payload), bool(m.retain)))

        task = asyncio.create_task(collect(), name="test.subscriber")
        try:
            yield got
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError, aiomqtt.MqttError):
                await task


async def send(
    broker: Broker, items: Sequence[tuple[str, str | bytes]], retain: bool = False
) -> None:
    """Publish raw payloads from a separate client (an operator or a convoy tracker)."""
    async with aiomqtt.Client(broker.host, broker.port) as client:
        for subtopic, payload in items:
            await client.publish(f"{PREFIX}/{subtopic}", payload, retain=retain)


@dataclass
class FlightLoop:
    """Stand-in for the setpoint loop: ticks on a short period, publishes every tick."""

    pub: MqttPublisher
    period: float = 0.002
    ticks: int = 0
    max_gap: float = 0.0
    stamps: list[float] = field(default_factory=list)

    async def run(self) -> None:
        last = time.monotonic()
        while True:
            await asyncio.sleep(self.period)
            now = time.monotonic()
            self.max_gap = max(self.max_gap, now - last)
            last = now
            self.ticks += 1
            self.pub.publish(topics.STATUS, {"tick": self.ticks, "x": math.nan}, retain=True)
            self.pub.publish(topics.vehicle_topic(1), {"tick": self.ticks})


def status_ticks(got: Received) -> list[int]:
    return [p["tick"] for t, p, _ in got if t == f"{PREFIX}/status" and isinstance(p, dict)]


# ------------------------------------------------------------------------------- tests


async def test_documented_payloads_reach_a_subscriber(mqtt_broker: Broker) -> None:
    tel = Telemetry(3, 10.0, 100.0, -20.0, -80.0, 12.0, 5.0, 0.0, 0.5, 47.39, 8.54, 568.0)
    stats = CoverageStats(100.0, 99.5, 0.5, 0.0, 1, {3: 60.0}, 0.0)
    sent = {
        topics.STATUS: topics.status_payload(
            t=10.0, wall=WALL, phase="protecting", uptime_s=5.0, vehicles={3: VehicleStatus.FLYING}
        ),
        topics.vehicle_topic(3): topics.vehicle_payload(
            sysid=3, t=10.0, wall=WALL, state=VehicleStatus.FLYING, telemetry=tel, mode="OFFBOARD"
        ),
        topics.COVERAGE: topics.coverage_payload(
            t=10.0, wall=WALL, stats=stats, sample=CoverageSample(10.0, True, (3,), 5.0)
        ),
        topics.ALARM: topics.alarm_payload(
            t=10.0, wall=WALL, seq=1, kind="gap_opened", message="convoy not covered"
        ),
    }
    retained = {topics.STATUS, topics.vehicle_topic(3), topics.COVERAGE}
    async with (
        subscriber(mqtt_broker) as got,
        publisher(mqtt_broker) as pub,
    ):
        async with asyncio.timeout(3):
            await pub.wait_connected()
        for subtopic, payload in sent.items():
            pub.publish(subtopic, payload, retain=subtopic in retained)
        await wait_for(lambda: len(got) >= len(sent), what="four messages")
        assert pub.counters["published"] == 4 and pub.pending == 0
    by_topic = {t: p for t, p, _ in got}
    for subtopic, payload in sent.items():
        assert by_topic[f"{PREFIX}/{subtopic}"] == json.loads(topics.encode(payload))
    assert by_topic[f"{PREFIX}/vehicle/3"]["position"]["lat"] == 47.39
    assert by_topic[f"{PREFIX}/coverage"]["fraction"] == 0.995

    # A late subscriber gets the retained state topics, but not the alarm event.
    async with subscriber(mqtt_broker) as late:
        await wait_for(lambda: len(late) >= 3, what="retained messages")
        await asyncio.sleep(0.1)
    assert {t for t, _, r in late if r} == {f"{PREFIX}/{s}" for s in retained}


async def test_convoy_and_command_inputs_reach_callbacks(mqtt_broker: Broker) -> None:
    fixes: list[dict[str, Any]] = []
    commands: list[str] = []

    def on_command(command: str) -> None:
        commands.append(command)
        if len(commands) == 1:
            raise RuntimeError("operator handler bug")  # must not kill the receiver

    # A retained "pause" left on the broker must not pause the fleet at (re)connect.
    await send(mqtt_broker, [("command", "pause")], retain=True)
    async with publisher(mqtt_broker, on_convoy=fixes.append, on_command=on_command) as pub:
        async with asyncio.timeout(3):
            await pub.wait_connected()
        await wait_for(lambda: pub.counters["ignored_retained"] == 1, what="retained ignored")
        await send(
            mqtt_broker,
            [
                ("convoy/position", '{"lat": 47.39, "lon": 8.54, "t": 12.5}'),
                ("convoy/position", '{"lat": NaN, "lon": 8.54}'),  # bad: NaN
                ("convoy/position", '{"north": 1.0}'),  # bad: missing east
                ("convoy/position", b"\xff\x00garbage"),  # bad: not UTF-8
                ("command", '{"command": "pause"}'),  # callback raises
                ("command", "self-destruct"),  # bad: unknown
                ("command", "resume"),
                ("convoy/position", '{"north": 100, "east": -50, "source": "ugv2"}'),
                ("vehicle/9", "ignored: not an input topic"),
            ],
        )
        await wait_for(lambda: len(fixes) == 2 and len(commands) == 2, what="callbacks")
        assert pub.connected  # still alive and subscribed
        assert fixes == [
            {"lat": 47.39, "lon": 8.54, "t": 12.5},
            {"north": 100.0, "east": -50.0, "source": "ugv2"},
        ]
        assert commands == ["pause", "resume"]
        assert pub.counters["bad_input"] == 4
        assert pub.counters["callback_errors"] == 1
        assert pub.counters["convoy_received"] == 2 and pub.counters["commands_received"] == 2
        assert pub.last_bad_input is not None and "unknown command" in pub.last_bad_input


async def test_a_route_and_its_plan_come_in_retained_and_replaced(mqtt_broker: Broker) -> None:
    """A command post's route, retained before the service connects, with where the
    convoy will stop; published again with the stop moved and a speed, it replaces the
    first; a bad plan is counted and changes nothing."""
    routes: list[PlannedRoute] = []
    points = [[47.40, 8.54], [47.41, 8.54], [47.41, 8.55]]
    first = {"points": points, "holds": [{"point": 1, "seconds": 60}]}
    await send(mqtt_broker, [("convoy/route", json.dumps(first))], retain=True)
    async with publisher(mqtt_broker, on_route=routes.append) as pub:
        await wait_for(lambda: len(routes) == 1, what="the retained route")
        assert routes[0].holds == ((1, 60.0),) and routes[0].points[1] == (47.41, 8.54)
        again = {"points": points, "holds": [[2, 90]], "speeds": [[0, 9.5]], "circuit": True}
        bad = {"points": points, "holds": [[7, 90]]}
        await send(mqtt_broker, [("convoy/route", json.dumps(bad))])
        await send(mqtt_broker, [("convoy/route", json.dumps(again))])
        await wait_for(lambda: len(routes) == 2, what="the route published again")
        assert routes[1].holds == ((2, 90.0),) and routes[1].speeds == ((0, 9.5),)
        assert routes[1].circuit and routes[1].points[-1] == routes[1].points[0]
        assert pub.counters["routes_received"] == 2 and pub.counters["bad_input"] == 1
        assert pub.last_bad_input is not None and "an index of the route's 3 points" in (
            pub.last_bad_input
        )


async def test_broker_killed_and_restarted(mqtt_broker: Broker) -> None:
    commands: list[str] = []
    async with publisher(mqtt_broker, on_command=commands.append) as pub:
        loop = FlightLoop(pub)
        flight = asyncio.create_task(loop.run(), name="test.flight")
        try:
            async with subscriber(mqtt_broker) as got:
                await wait_for(lambda: len(status_ticks(got)) >= 5, what="status before kill")

            # Signals and restarts run in a thread: the test itself must not stall
            # the loop whose tick gaps it measures.
            await asyncio.to_thread(mqtt_broker.kill)
            await wait_for(lambda: not pub.connected, what="disconnect noticed")
            ticks_at_kill = loop.ticks
            await wait_for(lambda: pub.counters["connect_failures"] >= 3, what="retries")
            ticks_during_outage = loop.ticks - ticks_at_kill
            assert pub.counters["dropped_while_disconnected"] > 0
            assert pub.pending == 2  # latest value per subtopic, not a backlog

            await asyncio.to_thread(mqtt_broker.restart)
            async with asyncio.timeout(3):
                await pub.wait_connected()
            ticks_at_restart = loop.ticks
            assert pub.counters["reconnects"] == 1

            async with subscriber(mqtt_broker) as got_after:
                await wait_for(
                    lambda: any(t > ticks_at_restart for t in status_ticks(got_after)),
                    what="fresh status after restart",
                )
            # Subscriptions were renewed on the new connection.
            await send(mqtt_broker, [("command", "pause")])
            await wait_for(lambda: commands == ["pause"], what="command after restart")
        finally:
            flight.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await flight
    # The outage lasted >= 3 back-off periods (~0.15 s+); at a 2 ms period the loop
    # kept ticking all along, and no tick ever waited on MQTT.
    assert ticks_during_outage >= 30, ticks_during_outage
    assert loop.max_gap < 0.05, f"flight loop stalled {loop.max_gap:.3f}s"
    print(f"ticks during outage: {ticks_during_outage}, max tick gap {loop.max_gap * 1e3:.1f} ms")


async def test_hung_broker_costs_messages_not_ticks(mqtt_broker: Broker) -> None:
    async with publisher(mqtt_broker, keepalive=1, timeout=1.0) as pub:
        loop = FlightLoop(pub)
        flight = asyncio.create_task(loop.run(), name="test.flight")
        try:
            async with asyncio.timeout(3):
                await pub.wait_connected()
            mqtt_broker.pause()  # SIGSTOP: socket open, nobody home
            try:
                ticks_at_pause = loop.ticks
                await wait_for(lambda: not pub.connected, timeout=6.0, what="hung broker dropped")
                assert loop.ticks - ticks_at_pause > 100
            finally:
                mqtt_broker.resume()
            async with asyncio.timeout(3):
                await pub.wait_connected()
            assert pub.counters["reconnects"] == 1
            published = pub.counters["published"]
            await wait_for(lambda: pub.counters["published"] > published + 10, what="resumed")
        finally:
            flight.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await flight
    assert loop.max_gap < 0.05, f"flight loop stalled {loop.max_gap:.3f}s"


async def test_no_broker_publish_never_blocks_or_raises(mqtt_broker: Broker) -> None:
    mqtt_broker.stop()  # a port where nothing listens
    async with publisher(mqtt_broker) as pub:
        start = time.perf_counter()
        for i in range(10_000):
            pub.publish(topics.STATUS, {"i": i})
        pub.publish("status/#", {"i": 0})  # bad subtopic
        pub.publish(topics.COVERAGE, {"obj": object()})  # not JSON
        elapsed = time.perf_counter() - start
        await wait_for(lambda: pub.counters["connect_failures"] >= 3, what="retries")
        assert not pub.connected
    assert elapsed < 1.0  # ~10 us per call; nothing waits for the broker
    assert pub.counters["dropped_while_disconnected"] == 9_999
    assert pub.counters["bad_payload"] == 2 and pub.counters["published"] == 0
    assert pub.last_error


async def test_exit_flushes_a_final_status(mqtt_broker: Broker) -> None:
    async with subscriber(mqtt_broker) as got:
        async with publisher(mqtt_broker) as pub:
            async with asyncio.timeout(3):
                await pub.wait_connected()
            pub.publish(topics.STATUS, {"phase": "stopped"}, retain=True)
        await wait_for(lambda: len(got) == 1, what="final status")
    assert got == [(f"{PREFIX}/status", {"phase": "stopped"}, False)]


async def test_exit_is_prompt_with_a_hung_broker(mqtt_broker: Broker) -> None:
    pub = publisher(mqtt_broker)
    async with pub:
        async with asyncio.timeout(3):
            await pub.wait_connected()
        mqtt_broker.pause()
        pub.publish(topics.STATUS, {"phase": "stopping"})
        start = time.monotonic()
    try:
        elapsed = time.monotonic() - start  # flush grace + DISCONNECT wait, both bounded
    finally:
        mqtt_broker.resume()
    assert elapsed < 3.0, f"shutdown held up {elapsed:.2f}s by a hung broker"
    assert not pub.connected


def test_bad_settings_are_config_errors() -> None:
    from convoy_mav.errors import ConfigError

    with pytest.raises(ConfigError, match=r"mqtt\.prefix"):
        MqttPublisher("127.0.0.1", 1883, "bad/#")
    with pytest.raises(ConfigError, match=r"mqtt\.port"):
        MqttPublisher("127.0.0.1", 0)
    with pytest.raises(ConfigError, match=r"mqtt\.reconnect_max"):
        MqttPublisher("127.0.0.1", 1883, reconnect_initial=2.0, reconnect_max=1.0)


_VANISH = """
import asyncio, os, sys
from convoy_mav.publish import MqttPublisher

async def main() -> None:
    pub = MqttPublisher(sys.argv[1], int(sys.argv[2]), sys.argv[3])
    async with pub:
        await pub.wait_connected()
        pub.publish("status", {"phase": "protecting"}, retain=True)
        await asyncio.sleep(0.3)
        print("connected", flush=True)
        os._exit(9)  # a crash: no DISCONNECT, no final status

asyncio.run(main())
"""


async def test_a_vanished_service_leaves_its_last_will(mqtt_broker: Broker) -> None:
    """The broker marks a service that crashed offline (retained), not "protecting"."""
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-c", _VANISH, mqtt_broker.host, str(mqtt_broker.port), PREFIX,
        stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    async with asyncio.timeout(15):
        out, _ = await proc.communicate()
    assert b"connected" in out and proc.returncode == 9
    async with subscriber(mqtt_broker, f"{PREFIX}/status") as got:  # (retained only)
        await wait_for(lambda: len(got) == 1, what="retained status")
    assert got == [(f"{PREFIX}/status", topics.offline_payload(), True)]


async def test_flooding_and_absurd_inputs_cost_counted_drops(mqtt_broker: Broker) -> None:
    fixes: list[dict[str, Any]] = []
    async with publisher(mqtt_broker, on_convoy=fixes.append) as pub:
        async with asyncio.timeout(3):
            await pub.wait_connected()
        absurd = [
            '{"north": 1e308, "east": 0}',
            '{"north": 0, "east": 0, "t": 1e12}',
            '{"north": 0, "east": 0, "t": -5}',
        ]
        await send(mqtt_broker, [("convoy/position", p) for p in absurd])
        await wait_for(lambda: pub.counters["bad_input"] == 3, what="absurd fixes refused")
        flood = [("convoy/position", f'{{"north": {i}, "east": 0}}') for i in range(1000)]
        await send(mqtt_broker, flood)
        await wait_for(
            lambda: len(fixes) + pub.counters["rate_limited"] == 1000, what="flood handled"
        )
    assert fixes == [] or all(abs(f["north"]) < 1000 for f in fixes)
    assert pub.counters["rate_limited"] > 500  # a burst of 100, then 50 a second
    assert len(fixes) >= 100
