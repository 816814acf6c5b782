"""The wired service over MQTT against a real mosquitto, including a broker killed mid-mission.

Issue 4's acceptance criterion: "topics and payloads as documented; broker killed
and restarted mid-run: setpoints never stop, publishing resumes". The adapter on
its own is tested that way in ``test_mqtt.py``; here ``ConvoyService`` flies the
mock fleet through ``run_demo`` with an ``[mqtt]`` table, and three independent
observers judge it:

- an aiomqtt subscriber on ``<prefix>/#`` (reconnecting by itself) checks the
  README's topics and payload fields, the operator commands, and that
  publishing resumes after the broker comes back, with mission time moving on;
- a second ground station on every aircraft (the mock, like PX4 SITL, answers
  every peer) watches HEARTBEAT and STATUSTEXT, and sets the autopilot's own
  setpoint-loss failsafe ``COM_OF_LOSS_T`` through PARAM_SET: a hole in the
  setpoint stream longer than that, as the autopilot receives it, makes it drop
  out of OFFBOARD and say "no offboard signal";
- the mock's ground truth scores coverage over the protect phase (``run_demo``).

The service's own send statistics (``SetpointStreamer.stats``) add what the
in-process mock can hardly see: the whole process (mock included) stalling.

Hole and speed: 1 s of sim time (PX4's default ``COM_OF_LOSS_T``) at speedup 10
(``test_service.py`` flies at 25), i.e. 100 ms of wall time. Mock, service and
test share one process; on the 2-core machine a full garbage collection of it
takes 13-40 ms and a loaded scheduler adds hiccups of 25-85 ms (measured), so
0.5 s at 25x (20 ms) or at 10x (50 ms) fails now and then with no MQTT
involved, while a flight loop waiting on a dead broker would stall for seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import re
import socket
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field, replace
from typing import Any

import aiomqtt
import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.config import MissionConfig, MqttConfig
from convoy_mav.demo import SCENARIOS, DemoResult, run_demo
from tests.broker import Broker, mqtt_broker_fixture  # noqa: F401 - provides `mqtt_broker`

# pytest-timeout's SIGALRM can land inside an event-loop callback, where asyncio
# logs it and carries on: each test also bounds itself with asyncio.timeout.
pytestmark = [pytest.mark.integration, pytest.mark.timeout(90)]
TEST_LIMIT_S = 60.0

PREFIX = "e2e/convoy"
SPEEDUP = 10.0  # see the module docstring
SETPOINT_GAP_S = 1.0  # sim s: the longest setpoint hole tolerated (COM_OF_LOSS_T)
OUTAGE_S = 2.0  # wall s between SIGKILL and restart
STATES = ("connecting", "waiting_fix", "setting_up", "flying", "holding", "lost", "failed")
ISO_TS = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z$")

# The README's MQTT table, field by field.
STATUS_KEYS = {"t", "ts", "phase", "paused", "uptime_s", "uavs", "alarms"}
VEHICLE_KEYS = {
    *("t", "ts", "sysid", "state", "mode", "firmware", "phase", "position", "velocity"),
    *("yaw", "telemetry_t", "tracking_error_m", "statustext", "counted", "why_not_counted"),
}
COVERAGE_KEYS = {
    *("t", "ts", "covered", "covering", "nearest_m", "fraction", "elapsed_s", "covered_s"),
    *("current_gap_s", "longest_gap_s", "gaps", "predicted", "protect_start_s"),
}
ALARM_KEYS = {"t", "ts", "seq", "kind", "severity", "message", "sysid", "data"}
INPUT_TOPICS = {"command", "convoy/position"}

_PX4_OFFBOARD = 6  # PX4 main mode (custom_mode bits 16..23), px4_custom_mode.h
_OUR_SYSID = 250  # the watching ground station


# ------------------------------------------------------------------------ MQTT side


@dataclass(frozen=True, slots=True)
class Received:
    """One message as the subscriber got it."""

    wall: float  # time.monotonic() on arrival
    subtopic: str  # below the prefix
    payload: Any  # decoded JSON (or the raw bytes if not JSON)
    retain: bool


@dataclass
class Subscriber:
    """An aiomqtt client on ``<prefix>/#`` that reconnects by itself when the broker dies."""

    broker: Broker
    got: list[Received] = field(default_factory=list)
    sessions: int = 0  # connections made so far

    async def run(self) -> None:
        while True:
            try:
                async with aiomqtt.Client(self.broker.host, self.broker.port) as client:
                    await client.subscribe(f"{PREFIX}/#")
                    self.sessions += 1
                    async for m in client.messages:
                        self.got.append(
                            Received(
                                time.monotonic(),
                                m.topic.value.removeprefix(f"{PREFIX}/"),
                                _decode(m.payload),
                                bool(m.retain),
                            )
                        )
            except aiomqtt.MqttError:
                await asyncio.sleep(0.05)

    def of(self, subtopic: str, since: float = -1.0) -> list[Any]:
        """Payloads of one subtopic that arrived after wall time ``since``, in order."""
        return [r.payload for r in self.got if r.subtopic == subtopic and r.wall > since]

    def last(self, subtopic: str) -> Any:
        """The latest payload of one subtopic (None if none yet)."""
        payloads = self.of(subtopic)
        return payloads[-1] if payloads else None


def _decode(payload: Any) -> Any:
    try:
        return json.loads(payload)
    except (TypeError, ValueError):
        return payload


@contextlib.asynccontextmanager
async def subscribed(broker: Broker) -> AsyncIterator[Subscriber]:
    """A running :class:`Subscriber`, stopped on exit."""
    sub = Subscriber(broker)
    task = asyncio.create_task(sub.run(), name="test.subscriber")
    try:
        yield sub
    finally:
        await _end(task, 3.0)


async def _end(task: asyncio.Task[Any], grace: float) -> None:
    """Cancel ``task`` and wait for it, but never for longer than ``grace`` seconds.

    Bounded because a swallowed cancellation (CPython gh-86296, see
    ``MqttPublisher._stop``) must fail the test, not hang the session.
    """
    task.cancel()
    done, _ = await asyncio.wait({task}, timeout=grace)
    if done and not task.cancelled():
        task.exception()  # retrieved: the test has already reported what went wrong


async def send_command(broker: Broker, command: str) -> None:
    """An operator's client publishing to ``<prefix>/command``."""
    async with asyncio.timeout(5.0), aiomqtt.Client(broker.host, broker.port) as client:
        await client.publish(f"{PREFIX}/command", json.dumps({"command": command}))


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def check_payload(subtopic: str, p: Any, uavs: int) -> None:
    """One payload against the README's table (keys, types, ranges); inputs pass."""
    if subtopic in INPUT_TOPICS:
        return  # the operator's own messages, seen by a subscriber on `<prefix>/#`
    where = f"{subtopic}: {p!r}"
    assert isinstance(p, dict), where
    assert p["t"] is None or _number(p["t"]), where
    assert isinstance(p["ts"], str) and ISO_TS.match(p["ts"]), where
    if subtopic == "status":
        assert p.keys() == STATUS_KEYS, where
        assert isinstance(p["phase"], str) and isinstance(p["paused"], bool), where
        assert _number(p["uptime_s"]) and p["uptime_s"] >= 0.0, where
        assert p["uavs"].keys() == {"total", *STATES}, where
        assert p["uavs"]["total"] == uavs == sum(p["uavs"][s] for s in STATES), where
        assert all(isinstance(a, str) for a in p["alarms"]), where
    elif subtopic == "coverage":
        assert p.keys() == COVERAGE_KEYS, where
        assert p["covered"] is None or isinstance(p["covered"], bool), where
        assert all(isinstance(s, int) for s in p["covering"]), where
        for key in ("elapsed_s", "covered_s", "current_gap_s", "longest_gap_s"):
            assert _number(p[key]) and p[key] >= 0.0, where
        assert isinstance(p["gaps"], int), where
        for key in ("nearest_m", "fraction", "predicted", "protect_start_s"):
            assert p[key] is None or _number(p[key]), where
        assert p["fraction"] is None or 0.0 <= p["fraction"] <= 1.0, where
    elif subtopic.startswith("vehicle/"):
        assert p.keys() == VEHICLE_KEYS, where
        assert p["sysid"] == int(subtopic.split("/")[1]), where
        assert p["state"] in STATES, where
        for key in ("mode", "firmware", "phase", "statustext"):
            assert p[key] is None or isinstance(p[key], str), where
        assert p["firmware"] in (None, "px4", "ardupilot"), where
        if p["position"] is not None:
            assert p["position"].keys() == {"lat", "lon", "alt", "north", "east", "down"}, where
            assert all(_number(x) for x in p["position"].values()), where
        if p["velocity"] is not None:
            assert p["velocity"].keys() == {"vn", "ve", "vd"}, where
        for key in ("yaw", "telemetry_t", "tracking_error_m"):
            assert p[key] is None or _number(p[key]), where
    elif subtopic == "alarm":
        assert p.keys() == ALARM_KEYS, where
        assert isinstance(p["seq"], int) and p["seq"] >= 1, where
        assert isinstance(p["kind"], str) and isinstance(p["message"], str), where
        assert p["severity"] in ("info", "warning", "critical"), where
        assert p["sysid"] is None or isinstance(p["sysid"], int), where
        assert isinstance(p["data"], dict), where
    else:
        pytest.fail(f"undocumented topic {PREFIX}/{subtopic}: {p!r}")


# ------------------------------------------------------------------ autopilot side


class _Frames:
    """The ``file`` of a pymavlink encoder: keeps the packed frames."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []

    def write(self, buf: bytes) -> None:
        self.frames.append(bytes(buf))


class AutopilotWatch(asyncio.DatagramProtocol):
    """A second ground station on one PX4 autopilot: watches modes and texts, sets a param.

    Only HEARTBEAT, PARAM_VALUE and STATUSTEXT are decoded (the frame header says
    which message a datagram holds); the rest of the telemetry is dropped
    unparsed, so watching costs the shared event loop next to nothing.
    """

    _WANTED = frozenset(
        {
            mavlink.MAVLINK_MSG_ID_HEARTBEAT,
            mavlink.MAVLINK_MSG_ID_PARAM_VALUE,
            mavlink.MAVLINK_MSG_ID_STATUSTEXT,
        }
    )

    def __init__(self, sysid: int) -> None:
        self.sysid = sysid
        self.transport: asyncio.DatagramTransport | None = None
        self._out = _Frames()
        self._mav: Any = mavlink.MAVLink(self._out, srcSystem=_OUR_SYSID, srcComponent=190)
        self._parser: Any = mavlink.MAVLink(None, srcSystem=_OUR_SYSID, srcComponent=190)
        self._parser.robust_parsing = True
        self.loss_timeout: float | None = None  # COM_OF_LOSS_T as the autopilot reports it
        self.offboard: list[tuple[float, bool]] = []  # (wall, in OFFBOARD) per HEARTBEAT
        self.texts: list[tuple[float, str]] = []  # (wall, STATUSTEXT)

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = transport  # type: ignore[assignment]
        # A GCS heartbeat: the autopilot learns our address and streams to us too.
        self.send(
            mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
            )
        )

    def datagram_received(self, data: bytes, addr: tuple[str, int]) -> None:
        # The mock sends one MAVLink 2 frame per datagram; message id in bytes 7..9.
        if len(data) < 12 or data[0] != 0xFD:
            return
        if int.from_bytes(data[7:10], "little") not in self._WANTED:
            return
        now = time.monotonic()
        for msg in self._parser.parse_buffer(data) or []:
            if msg.get_srcSystem() != self.sysid:
                continue
            kind = msg.get_type()
            if kind == "HEARTBEAT":
                self.offboard.append((now, (msg.custom_mode >> 16) & 0xFF == _PX4_OFFBOARD))
            elif kind == "STATUSTEXT":
                self.texts.append((now, str(msg.text)))
            elif kind == "PARAM_VALUE" and msg.param_id == "COM_OF_LOSS_T":
                self.loss_timeout = float(msg.param_value)

    def send(self, msg: Any) -> None:
        assert self.transport is not None
        self._mav.send(msg)
        frames, self._out.frames = self._out.frames, []
        for frame in frames:
            self.transport.sendto(frame)

    async def set_loss_timeout(self, seconds: float) -> None:
        """PARAM_SET COM_OF_LOSS_T until the autopilot echoes the new value."""
        set_param = mavlink.MAVLink_param_set_message(
            self.sysid, 1, b"COM_OF_LOSS_T", seconds, mavlink.MAV_PARAM_TYPE_REAL32
        )
        for _ in range(20):
            self.send(set_param)
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(0.25):
                    while self.loss_timeout is None or abs(self.loss_timeout - seconds) > 1e-6:
                        await asyncio.sleep(0.005)
                    return
        pytest.fail(f"uav{self.sysid} never confirmed COM_OF_LOSS_T={seconds}")

    def failsafes(self, start: float, end: float) -> list[str]:
        """The autopilot's setpoint-loss reports ("no offboard signal") in a wall window."""
        return [t for w, t in self.texts if start <= w < end and "offboard" in t.lower()]

    def modes(self, start: float, end: float) -> list[bool]:
        """In OFFBOARD or not, per HEARTBEAT received in a wall window."""
        return [offboard for w, offboard in self.offboard if start <= w < end]


@contextlib.asynccontextmanager
async def watching(config: MissionConfig) -> AsyncIterator[dict[int, AutopilotWatch]]:
    """One :class:`AutopilotWatch` per aircraft of the mission, closed on exit."""
    loop = asyncio.get_running_loop()
    watches: dict[int, AutopilotWatch] = {}
    async with contextlib.AsyncExitStack() as stack:
        for uav in config.uav_list:
            watch = AutopilotWatch(uav.sysid)
            port = int(uav.connection.rsplit(":", 1)[1])  # "udpout:127.0.0.1:PORT"
            transport, _ = await loop.create_datagram_endpoint(
                lambda watch=watch: watch,  # type: ignore[misc]
                remote_addr=("127.0.0.1", port),
            )
            stack.callback(transport.close)
            sock = transport.get_extra_info("socket")
            if sock is not None:  # room for a burst a loaded machine reads late
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            watches[uav.sysid] = watch
        async with asyncio.timeout(5.0):
            while not all(w.offboard for w in watches.values()):
                await asyncio.sleep(0.01)  # heard every autopilot's HEARTBEAT
        yield watches


# -------------------------------------------------------------------- the mission


@dataclass
class Flight:
    """``run_demo`` running as a task, and what the test can see of it."""

    task: asyncio.Task[DemoResult]
    stop: asyncio.Event
    services: list[ConvoyService]
    configs: list[MissionConfig]

    @property
    def service(self) -> ConvoyService:
        return self.services[0]

    @property
    def config(self) -> MissionConfig:
        return self.configs[0]

    def now(self) -> float:
        """Mission time (the autopilots' clock, as the service estimates it)."""
        return self.service.clock.now()

    async def until(self, predicate: Callable[[], bool], timeout: float, what: str) -> None:
        """Poll ``predicate`` until true; fail on timeout or if the mission ended."""
        try:
            async with asyncio.timeout(timeout):
                while not predicate():
                    if self.task.done():
                        self.task.result()  # the mission's own error, if it had one
                        pytest.fail(f"mission ended while waiting for {what}")
                    await asyncio.sleep(0.01)
        except TimeoutError:
            pytest.fail(f"timed out after {timeout} s waiting for {what}")

    async def finish(self, timeout: float = 15.0) -> DemoResult:
        """Stop the mission (every UAV told to loiter) and return the scored result."""
        self.stop.set()
        async with asyncio.timeout(timeout):
            return await self.task


@contextlib.asynccontextmanager
async def flying(
    broker: Broker,
    *,
    speedup: float,
    configure: Callable[[MissionConfig], MissionConfig] = lambda cfg: cfg,
    **kwargs: Any,
) -> AsyncIterator[Flight]:
    """``run_demo`` as a task: stationary convoy, PX4 planes, ``[mqtt]`` on ``broker``.

    The mission runs until the test calls :meth:`Flight.finish` (or leaves).
    """
    configs: list[MissionConfig] = []

    def with_mqtt(cfg: MissionConfig) -> MissionConfig:
        cfg = configure(replace(cfg, mqtt=MqttConfig(broker.host, broker.port, PREFIX)))
        configs.append(cfg)
        return cfg

    stop = asyncio.Event()
    services: list[ConvoyService] = []
    task = asyncio.create_task(
        run_demo(
            SCENARIOS["stationary"],
            duration=3600.0,  # an upper bound: the test stops the mission
            speedup=speedup,
            configure=with_mqtt,
            stop=stop,
            history=services,
            **kwargs,
        ),
        name="test.mission",
    )
    flight = Flight(task, stop, services, configs)
    try:
        await flight.until(lambda: bool(services), 10.0, "the service to start")
        yield flight
    finally:
        if not task.done():
            stop.set()  # every UAV told to loiter, links closed, fleet stopped
            await asyncio.wait({task}, timeout=10.0)
        await _end(task, 5.0)


# ------------------------------------------------------------------------- tests


async def test_broker_killed_and_restarted_mid_mission(mqtt_broker: Broker) -> None:
    async with (
        asyncio.timeout(TEST_LIMIT_S),
        subscribed(mqtt_broker) as sub,
        flying(mqtt_broker, speedup=SPEEDUP) as flight,
        watching(flight.config) as watches,
    ):
        service, cfg = flight.service, flight.config
        sysids = [u.sysid for u in cfg.uav_list]
        uavs = len(sysids)
        state_topics = {"status", "coverage", *(f"vehicle/{s}" for s in sysids)}

        def protecting_for(seconds: float) -> bool:
            cov = sub.last("coverage")
            start = None if cov is None else cov["protect_start_s"]
            return start is not None and cov["t"] >= start + seconds

        await flight.until(lambda: protecting_for(10.0), 25.0, "10 s of the protect phase")

        # Documented topics and payloads: every message so far.
        assert {r.subtopic for r in sub.got} >= state_topics
        for r in sub.got:
            check_payload(r.subtopic, r.payload, uavs)
        status = sub.last("status")
        assert (status["phase"], status["paused"], status["uavs"]["flying"]) == (
            "protecting",
            False,
            uavs,
        )
        assert sub.last("coverage")["predicted"] == 1.0
        for sysid in sysids:
            v = sub.last(f"vehicle/{sysid}")
            assert (v["state"], v["mode"], v["firmware"], v["phase"]) == (
                "flying",
                "OFFBOARD",
                "px4",
                "protect",
            ), v
            assert v["position"] is not None and v["tracking_error_m"] is not None
        t_before = sub.last("status")["t"]

        # From here on, a setpoint hole of SETPOINT_GAP_S drops an autopilot out of
        # OFFBOARD. The window opens once every autopilot has said OFFBOARD since: a
        # hole that began before that timeout was in force is not the outage's.
        await asyncio.gather(*(w.set_loss_timeout(SETPOINT_GAP_S) for w in watches.values()))
        timeout_set = time.monotonic()
        await flight.until(
            lambda: all(any(w.modes(timeout_set, math.inf)) for w in watches.values()),
            5.0,
            "OFFBOARD heartbeats with the timeout set",
        )
        watched, t_watched = time.monotonic(), flight.now()
        # The service's send statistics start afresh too (the streamer re-creates them).
        assert service.streamer is not None
        stats = service.streamer.stats
        stats.clear()

        def sent() -> dict[int, int]:
            return {s: stats[s].count if s in stats else 0 for s in sysids}

        # ----- SIGKILL the broker, keep it dead for a few wall seconds, restart it.
        pub = service.publisher
        assert pub is not None and pub.connected
        failures = pub.counters["connect_failures"]
        sent_at_kill = sent()
        t_kill = flight.now()
        await asyncio.to_thread(mqtt_broker.kill)  # signals in a thread: never stall the loop
        await flight.until(lambda: not pub.connected, 5.0, "the service to notice the outage")
        await asyncio.sleep(OUTAGE_S)
        await flight.until(
            lambda: pub.counters["connect_failures"] > failures, 5.0, "a failed reconnect"
        )
        assert pub.counters["dropped_while_disconnected"] > 0
        assert pub.pending <= len(state_topics) + 1  # latest value per topic, not a backlog
        await asyncio.to_thread(mqtt_broker.restart)
        restarted = time.monotonic()
        t_restart = flight.now()
        sent_in_outage = {s: n - sent_at_kill[s] for s, n in sent().items()}
        await flight.until(lambda: pub.connected, 15.0, "the service to reconnect")
        assert pub.counters["reconnects"] == 1

        def fresh(subtopic: str) -> int:
            return sum(p["t"] > t_restart for p in sub.of(subtopic, restarted))

        await flight.until(
            lambda: fresh("status") >= 3 and fresh("coverage") >= 3,
            10.0,
            "fresh status and coverage after the restart",
        )
        t_fresh = flight.now()
        await flight.until(lambda: flight.now() > t_fresh + 15.0, 10.0, "15 s more of flight")

        # The state topics are retained again on the new (empty) broker.
        async with subscribed(mqtt_broker) as late:
            await flight.until(
                lambda: {r.subtopic for r in late.got if r.retain} >= state_topics,
                5.0,
                "retained state after the restart",
            )

        stopping = time.monotonic()
        longest_sent = max(stats[s].mission.max for s in sysids)
        result = await flight.finish()
        # The last retained status tells a late subscriber the service stopped.
        async with asyncio.timeout(5.0):
            while sub.last("status")["phase"] != "stopped":
                await asyncio.sleep(0.01)
        assert sub.last("status")["uavs"].get("holding") == len(sysids)
        async with subscribed(mqtt_broker) as late, asyncio.timeout(5.0):
            while not [r for r in late.got if r.subtopic == "status" and r.retain]:
                await asyncio.sleep(0.01)
        assert [r for r in late.got if r.subtopic == "status"][-1].payload["phase"] == "stopped"

    # Setpoints never stopped, as the autopilots received them: none reported a
    # setpoint loss or showed another mode than OFFBOARD while it was watched.
    for sysid, watch in watches.items():
        assert watch.loss_timeout == pytest.approx(SETPOINT_GAP_S)
        assert not watch.failsafes(watched, stopping), (sysid, watch.texts)
        modes = watch.modes(watched, stopping)
        assert modes and all(modes), (sysid, modes)
    late_events = [e for e in service.events if float(e[2:].split()[0]) >= t_watched]
    assert not [e for e in late_events if "failsafe" in e], late_events
    # The service sent them without a stall (this also sees the whole process
    # stalling, which the in-process mock hardly can: its clock stalls too) and at
    # their rate (20 Hz of mission time; late ticks are skipped, not queued).
    assert longest_sent < SETPOINT_GAP_S, {s: stats[s].mission.max for s in sysids}
    outage_s = t_restart - t_kill
    assert outage_s > 10.0
    for sysid, count in sent_in_outage.items():
        assert count >= 0.5 * cfg.setpoint_rate_hz * outage_s, (sysid, count, outage_s)
    assert service.streamer is not None and service.streamer.errors == 0

    # Coverage by the mock's ground truth over the protect phase, outage included.
    report = result.report.to_dict()
    assert result.truth is not None and result.truth.elapsed_s > 50.0
    assert result.truth.fraction >= 0.995, result.truth
    assert report["coverage_fraction"] == pytest.approx(result.truth.fraction, abs=0.005)
    assert [r["reason"] for r in report["replans"]] == ["initial"]

    # Publishing resumed, with mission time moving on.
    times = [p["t"] for p in sub.of("status")]
    assert times == sorted(times) and len(set(times)) == len(times)
    after = sub.of("status", restarted)
    assert after and after[0]["t"] > t_before
    assert sub.sessions >= 2
    for r in sub.got:
        check_payload(r.subtopic, r.payload, uavs)
    for sysid in sysids:
        for v in sub.of(f"vehicle/{sysid}", restarted):
            if v["t"] < result.report.end_t:
                assert (v["state"], v["mode"], v["phase"]) == ("flying", "OFFBOARD", "protect"), v

    print(
        f"broker down {outage_s:.1f} s sim, fresh messages {t_fresh - t_restart:.1f} s sim "
        f"after the restart; setpoints sent in the outage {min(sent_in_outage.values())}"
        f"-{max(sent_in_outage.values())} per UAV; longest send interval from kill to stop "
        f"{longest_sent:.3f} s sim; truth coverage {100 * result.truth.fraction:.2f} % "
        f"over {result.truth.elapsed_s:.0f} s; {len(times)} status messages, "
        f"{sub.sessions} subscriber sessions"
    )


async def test_operator_pause_resume_and_alarm(mqtt_broker: Broker) -> None:
    lost = 5  # the mock kills this aircraft early: a `uav_lost` alarm to check
    async with (
        asyncio.timeout(TEST_LIMIT_S),
        subscribed(mqtt_broker) as sub,
        flying(mqtt_broker, speedup=SPEEDUP, kill=(lost, 20.0)) as flight,
        watching(flight.config) as watches,
    ):
        service, cfg = flight.service, flight.config
        sysids = [u.sysid for u in cfg.uav_list]
        live = [s for s in sysids if s != lost]
        uavs = len(sysids)

        def vehicles(state: str, offboard: bool) -> bool:
            payloads = [sub.last(f"vehicle/{s}") for s in live]
            return all(
                v is not None and v["state"] == state and (v["mode"] == "OFFBOARD") == offboard
                for v in payloads
            )

        def lost_alarms() -> list[Any]:
            return [a for a in sub.of("alarm") if (a["kind"], a["sysid"]) == ("uav_lost", lost)]

        await flight.until(lambda: bool(lost_alarms()), 20.0, f"uav_lost alarm for uav{lost}")
        alarm = lost_alarms()[0]
        check_payload("alarm", alarm, uavs)
        assert (alarm["severity"], alarm["data"]) == ("warning", {"active": True})
        assert alarm["t"] > 20.0 and "silent" in alarm["message"]
        await flight.until(
            lambda: (
                sub.last("status")["uavs"]["lost"] == 1
                and vehicles("flying", True)
                and sub.last(f"vehicle/{lost}")["state"] == "lost"
            ),
            10.0,
            "the others flying, one lost",
        )
        assert f"uav_lost:{lost}" in sub.last("status")["alarms"]
        assert sub.last(f"vehicle/{lost}")["phase"] == "lost"

        # pause: every UAV loiters, no setpoints.
        paused = time.monotonic()
        await send_command(mqtt_broker, "pause")
        await flight.until(
            lambda: sub.last("status")["paused"] and vehicles("holding", False),
            10.0,
            "every UAV holding",
        )
        status = sub.last("status")
        assert (status["phase"], status["uavs"]["holding"]) == ("paused", len(live))

        def sends(uav: int) -> int:
            # (a UAV can be in OFFBOARD on its set-up's own stream before the
            # plan gives it a setpoint: no count yet)
            streamer = service.streamer
            stats = None if streamer is None else streamer.stats.get(uav)
            return 0 if stats is None else stats.count

        held = {s: sends(s) for s in live}
        t_held = flight.now()
        await flight.until(lambda: flight.now() > t_held + 5.0, 5.0, "5 s of holding")
        assert {s: sends(s) for s in live} == held

        # resume: back to OFFBOARD and the plan.
        resumed = time.monotonic()
        await send_command(mqtt_broker, "resume")
        await flight.until(
            lambda: not sub.last("status")["paused"] and vehicles("flying", True),
            15.0,
            "every UAV flying again",
        )
        await flight.until(
            lambda: all(sends(s) > held[s] + 20 for s in live),
            5.0,
            "setpoints again",
        )
        assert sub.last("status")["phase"] != "paused"
        ended = time.monotonic()
        await flight.finish()

    assert service.publisher is not None
    assert service.publisher.counters["commands_received"] == 2
    assert service.publisher.counters["bad_input"] == 0
    for r in sub.got:
        check_payload(r.subtopic, r.payload, uavs)
        if r.subtopic == "alarm":
            assert not r.retain
    # The autopilots' side: out of OFFBOARD while paused, back in after the resume.
    for sysid in live:
        assert False in watches[sysid].modes(paused, resumed), sysid
        assert True in watches[sysid].modes(resumed, ended), sysid
