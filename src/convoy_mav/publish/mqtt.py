"""The MQTT edge: publish the service's state, hear convoy fixes and operator commands.

Design rules (issue 4, item 7: "a broker that is down or slow costs messages,
not setpoints"):
- :meth:`MqttPublisher.publish` is synchronous, O(1), and never blocks or
  raises. It serialises the payload and overwrites one slot per subtopic
  (latest-value, like the setpoint streamer): a backlog of stale states is
  worth nothing to an operator, and an unbounded queue is a memory leak
  while the broker is away.
- One background task per publisher (``mqtt[<prefix>].connection``) owns the
  aiomqtt 2.5 client as an async context manager inside an explicit
  reconnect loop that catches :class:`aiomqtt.MqttError` and backs off
  exponentially (``reconnect_initial`` doubling up to ``reconnect_max``,
  reset after each successful connection). While connected it runs two
  named children in a TaskGroup: ``.send`` drains the pending slots,
  ``.receive`` dispatches incoming messages.
- Subscriptions (``<prefix>/convoy/position``, ``<prefix>/command``,
  ``<prefix>/convoy/route``) are made
  again after every (re)connect: with a clean session the broker forgets them.
- Incoming payloads are validated by :mod:`convoy_mav.publish.topics`;
  bad ones are counted (``bad_input``) and logged with the reason; a callback
  that raises is logged and counted (``callback_errors``). Neither ends the task.
- ``MqttError`` never leaves this module: it is counted, logged and retried.

Counters (``collections.Counter``): ``published``, ``dropped_while_disconnected``
(a pending value overwritten while the broker was unreachable),
``coalesced`` (overwritten while connected, before the sender got to it),
``dropped_full`` (a new subtopic refused: ``max_pending`` slots in use),
``bad_payload`` (our own payload not JSON-serialisable), ``connects``,
``reconnects`` (successful connections after the first), ``connect_failures``,
``subscribe_refused`` (SUBACK failure, e.g. a broker ACL),
``disconnects``, ``convoy_received``, ``commands_received``, ``bad_input``,
``ignored_retained``, ``callback_errors``, ``rate_limited`` (an inbound
message past its topic's rate: dropped before it is parsed).
- Inbound messages are rate-limited per topic (a token bucket on the wall
  clock: ``_INBOUND_RATES``), so a flooding client costs counted drops, not
  the flight loop's time.
- The connection carries a last will: if the service vanishes (a crash, a
  kill, a lost network) the broker publishes ``topics.offline_payload`` on
  ``<prefix>/status``, retained, so no stale "protecting" outlives it.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import json
import logging
import ssl
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Self, TypeVar

import aiomqtt
from paho.mqtt.reasoncodes import ReasonCode

from convoy_mav.errors import ConfigError
from convoy_mav.publish import topics
from convoy_mav.tracks.plannedroute import PlannedRoute

__all__ = ["MqttPublisher"]

log = logging.getLogger(__name__)
_T = TypeVar("_T")
_CLOSE_GRACE_S = 1.0  # longest flush, and longest DISCONNECT wait, at exit

_COUNTERS = (
    "published",
    "dropped_while_disconnected",
    "coalesced",
    "dropped_full",
    "bad_payload",
    "connects",
    "reconnects",
    "connect_failures",
    "subscribe_refused",
    "disconnects",
    "convoy_received",
    "routes_received",
    "commands_received",
    "bad_input",
    "ignored_retained",
    "callback_errors",
    "rate_limited",
)

_INBOUND_RATES = {"convoy": (50.0, 100.0), "command": (5.0, 10.0), "route": (1.0, 5.0)}
"""Inbound messages per wall second, and burst, accepted per topic kind."""


class _Bucket:
    """A token bucket: ``rate`` a second, up to ``burst`` at once (wall clock)."""

    def __init__(self, rate: float, burst: float, clock: Callable[[], float]) -> None:
        self.rate, self.burst, self._clock = rate, burst, clock
        self.tokens = burst
        self.t = clock()

    def take(self) -> bool:
        now = self._clock()
        self.tokens = min(self.burst, self.tokens + (now - self.t) * self.rate)
        self.t = now
        if self.tokens < 1.0:
            return False
        self.tokens -= 1.0
        return True


@dataclass(frozen=True, slots=True)
class _Pending:
    """One serialised payload waiting for the sender."""

    data: bytes
    retain: bool


class MqttPublisher:
    """Publishes JSON state to an MQTT broker and listens for convoy fixes and commands.

    Use as an async context manager; entering never waits for the broker (the
    service must fly with or without one)::

        async with MqttPublisher("127.0.0.1", 1883, "convoy", on_command=cmd) as mqtt:
            mqtt.publish("status", topics.status_payload(...), retain=True)

    Not thread-safe: call :meth:`publish` from the event loop's thread.

    Args:
        host: Broker host name or address.
        port: Broker TCP port.
        prefix: Topic prefix; every topic is ``<prefix>/<subtopic>``.
        client_id: MQTT client identifier (random if None). Two services with the
            same id knock each other off the broker in turn.
        on_convoy: Called with each valid convoy fix (see
            :func:`topics.parse_convoy_position` for the dict's keys).
        on_command: Called with ``"pause"`` or ``"resume"``.
        on_route: Called with each valid route: its (lat, lon) points in order and
            the convoy's plan on it (:func:`topics.parse_convoy_route`; retained
            routes are used).
        reconnect_initial: First back-off delay after a failed or lost connection, s.
        reconnect_max: Upper bound of the doubling back-off, s.
        keepalive: MQTT keep-alive, s: how soon a silent (not closed) broker
            connection is declared dead.
        timeout: Longest wait for one broker operation (connect, subscribe,
            publish hand-off), s; past it the connection is dropped and retried.
        max_pending: Most distinct subtopics held while waiting for the broker.
        username: Broker user name, if the broker asks for one.
        password: Its password (from ``publish.security``: never in a config file).
        tls_context: Encrypt the connection with this context (None: plain TCP).

    Raises:
        ConfigError: For a bad prefix, port or back-off setting.
    """

    def __init__(
        self,
        host: str,
        port: int,
        prefix: str = "convoy",
        *,
        client_id: str | None = None,
        on_convoy: Callable[[dict[str, Any]], None] | None = None,
        on_route: Callable[[PlannedRoute], None] | None = None,
        on_command: Callable[[str], None] | None = None,
        reconnect_initial: float = 0.5,
        reconnect_max: float = 10.0,
        keepalive: int = 10,
        timeout: float = 5.0,
        max_pending: int = 10_000,
        username: str | None = None,
        password: str | None = None,
        tls_context: ssl.SSLContext | None = None,
    ) -> None:
        topics.validate_prefix(prefix)
        if not isinstance(port, int) or not 0 < port < 65536:
            raise ConfigError("mqtt.port", port, "must be an integer in 1..65535")
        if not reconnect_initial > 0.0:
            raise ConfigError("mqtt.reconnect_initial", reconnect_initial, "must be > 0")
        if not reconnect_max >= reconnect_initial:
            raise ConfigError("mqtt.reconnect_max", reconnect_max, "must be >= reconnect_initial")
        if keepalive < 1:
            raise ConfigError("mqtt.keepalive", keepalive, "must be >= 1 s")
        if not timeout > 0.0:
            raise ConfigError("mqtt.timeout", timeout, "must be > 0")
        self.host = host
        self.port = port
        self.prefix = prefix
        self.client_id = client_id
        self.on_convoy = on_convoy
        self.on_command = on_command
        self.on_route = on_route
        self.reconnect_initial = float(reconnect_initial)
        self.reconnect_max = float(reconnect_max)
        self.keepalive = int(keepalive)
        self.timeout = float(timeout)
        self.max_pending = int(max_pending)
        self._username, self._password, self._tls = username, password, tls_context
        self.counters: collections.Counter[str] = collections.Counter(dict.fromkeys(_COUNTERS, 0))
        self._buckets = {k: _Bucket(r, b, time.monotonic) for k, (r, b) in _INBOUND_RATES.items()}
        self.last_error: str | None = None
        self.last_bad_input: str | None = None
        self._pending: dict[str, _Pending] = {}
        self._wakeup = asyncio.Event()
        self._connected = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._failures_in_row = 0
        self._closing = False
        self._convoy_topic = topics.topic(prefix, topics.CONVOY_POSITION)
        self._command_topic = topics.topic(prefix, topics.COMMAND)
        self._route_topic = topics.topic(prefix, topics.CONVOY_ROUTE)

    # ------------------------------------------------------------------ public API

    @property
    def connected(self) -> bool:
        """True while a broker connection is up and subscribed."""
        return self._connected.is_set()

    @property
    def pending(self) -> int:
        """Number of subtopics with a value not yet handed to the broker."""
        return len(self._pending)

    def publish(self, subtopic: str, payload: Mapping[str, Any], *, retain: bool = False) -> None:
        """Queue ``payload`` as the latest value of ``<prefix>/<subtopic>``.

        Never blocks and never raises: a bad subtopic or a payload JSON cannot
        represent is logged and counted (``bad_payload``); NaN/inf become null.
        A value still pending for the same subtopic is overwritten (counted as
        ``dropped_while_disconnected`` or ``coalesced``).

        Args:
            subtopic: Topic below the prefix, e.g. ``"status"`` or ``"vehicle/3"``.
            payload: JSON-serialisable mapping (see :mod:`topics` builders).
            retain: Ask the broker to keep it for late subscribers.
        """
        try:
            topics.validate_subtopic(subtopic)
            data = topics.encode(payload)
        except Exception as exc:  # never raise into the flight loop
            self.counters["bad_payload"] += 1
            log.warning("mqtt: not publishing %r: %s", subtopic, exc)
            return
        if subtopic in self._pending:
            key = "coalesced" if self.connected else "dropped_while_disconnected"
            self.counters[key] += 1
        elif len(self._pending) >= self.max_pending:
            self.counters["dropped_full"] += 1
            return
        self._pending[subtopic] = _Pending(data, bool(retain))
        self._wakeup.set()

    async def wait_connected(self) -> None:
        """Wait until connected and subscribed (wrap in ``asyncio.timeout``)."""
        await self._connected.wait()

    async def __aenter__(self) -> Self:
        if self._task is not None:
            raise RuntimeError("MqttPublisher is not reentrant")
        self._closing = False
        self._task = asyncio.create_task(self._run(), name=f"mqtt[{self.prefix}].connection")
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        # Give the last values (e.g. a final status) a moment to leave when the
        # broker is there; never wait on an absent one.
        grace = min(_CLOSE_GRACE_S, self.timeout)
        if self.connected and self._pending:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(grace):
                    while self._pending and self.connected:
                        await asyncio.sleep(0.01)
        self._closing = True
        self._wakeup.set()
        task, self._task = self._task, None
        if task is not None:
            await self._stop(task, grace)
        self._connected.clear()

    async def _stop(self, task: asyncio.Task[None], grace: float) -> None:
        """Cancel the connection task and wait for it, boundedly.

        Cancelling lets aiomqtt send DISCONNECT and wait for the broker; a hung
        broker must not hold up shutdown. On Python 3.11 ``asyncio.wait_for``
        (used inside aiomqtt) can swallow a cancellation that races with a
        completed operation (CPython gh-86296), so the loops also stop on the
        ``_closing`` flag, and the cancel is repeated. (``Task.cancelling()`` is
        no help there: a 3.11 TaskGroup leaves it raised after a child fails.)
        """
        for _ in range(3):
            task.cancel()
            done, _ = await asyncio.wait({task}, timeout=grace)
            if done:
                if not task.cancelled() and task.exception() is not None:
                    log.error("mqtt: connection task failed", exc_info=task.exception())
                return
        log.error("mqtt: connection task did not stop; abandoning it")

    # ------------------------------------------------------------------ connection

    async def _run(self) -> None:
        """Connect, serve, and on any failure back off and connect again, forever."""
        delay = self.reconnect_initial
        while True:
            try:
                async with aiomqtt.Client(
                    self.host,
                    self.port,
                    identifier=self.client_id,
                    username=self._username,
                    password=self._password,
                    tls_context=self._tls,
                    keepalive=self.keepalive,
                    timeout=self.timeout,
                    will=aiomqtt.Will(
                        topics.topic(self.prefix, topics.STATUS),
                        json.dumps(topics.offline_payload()),
                        qos=1,
                        retain=True,
                    ),
                ) as client:
                    delay = self.reconnect_initial
                    await self._serve(client)
            except* aiomqtt.MqttError as group:
                self._note_failure(group.exceptions[0])
            except* Exception as group:  # a bug must not silence MQTT for the whole run
                self._failures_in_row += 1
                self.counters["connect_failures"] += 1
                self.last_error = repr(group.exceptions[0])
                log.error("mqtt: unexpected error; reconnecting", exc_info=group)
            finally:
                if self._connected.is_set():
                    self._connected.clear()
                    self.counters["disconnects"] += 1
            if self._closing:  # even if the cancel itself got lost (see _stop)
                return
            await asyncio.sleep(delay)
            delay = min(delay * 2.0, self.reconnect_max)

    def _note_failure(self, exc: BaseException) -> None:
        cause = exc.__cause__ or (None if exc.__suppress_context__ else exc.__context__)
        self.last_error = str(exc) or type(exc).__name__
        if cause is not None and str(cause) and str(cause) not in self.last_error:
            self.last_error += f" ({cause})"
        if self._connected.is_set():
            log.warning("mqtt: lost %s:%d: %s", self.host, self.port, self.last_error)
            return
        self.counters["connect_failures"] += 1
        self._failures_in_row += 1
        n = self._failures_in_row
        # A broker away for a long time: log the first attempts, then now and then.
        if n <= 3 or n % 50 == 0:
            where = f"{self.host}:{self.port}"
            log.warning("mqtt: cannot reach %s (try %d): %s", where, n, self.last_error)

    async def _serve(self, client: aiomqtt.Client) -> None:
        """One live connection: subscribe, then send and receive until it fails."""
        wanted = [self._convoy_topic, self._command_topic, self._route_topic]
        granted: list[int | ReasonCode] = list(await client.subscribe([(t, 0) for t in wanted]))
        if self._closing:  # closed while connecting (and the cancel got lost: see _stop)
            return
        for name, code in zip(wanted, granted, strict=False):
            refused = code.is_failure if isinstance(code, ReasonCode) else code >= 0x80
            if refused:
                self.counters["subscribe_refused"] += 1
                log.warning("mqtt: broker refused subscription to %s (%s)", name, code)
        self.counters["connects"] += 1
        if self.counters["connects"] > 1:
            self.counters["reconnects"] += 1
        log.info(
            "mqtt: %s to %s:%d (prefix %r)",
            "reconnected" if self.counters["reconnects"] else "connected",
            self.host,
            self.port,
            self.prefix,
        )
        self._failures_in_row = 0
        self._connected.set()
        self._wakeup.set()  # values that piled up while away
        name = f"mqtt[{self.prefix}]"
        done = asyncio.Event()
        async with asyncio.TaskGroup() as tg:
            tg.create_task(self._send_loop(client, done), name=f"{name}.send")
            tg.create_task(self._receive_loop(client, done), name=f"{name}.receive")

    async def _send_loop(self, client: aiomqtt.Client, done: asyncio.Event) -> None:
        """Hand every pending value to the broker, oldest slot first.

        Also returns when ``done`` (the receiver ended) or the publisher closes,
        not only on cancellation: see :meth:`_stop` for why.
        """
        while True:
            await self._wakeup.wait()
            if done.is_set() or self._closing:
                return
            self._wakeup.clear()
            while self._pending:
                subtopic = next(iter(self._pending))
                item = self._pending.pop(subtopic)
                try:
                    await client.publish(
                        topics.topic(self.prefix, subtopic), item.data, qos=0, retain=item.retain
                    )
                except BaseException:
                    # Not sent: keep it for the next connection unless a newer one came.
                    self._pending.setdefault(subtopic, item)
                    raise
                self.counters["published"] += 1
                if done.is_set() or self._closing:
                    return

    async def _receive_loop(self, client: aiomqtt.Client, done: asyncio.Event) -> None:
        try:
            async for message in client.messages:
                self.dispatch(message.topic.value, message.payload, retain=bool(message.retain))
        finally:
            done.set()
            self._wakeup.set()  # let the sender see it

    # ------------------------------------------------------------------ incoming

    def dispatch(self, topic: str, payload: bytes | str, *, retain: bool = False) -> None:
        """Validate one incoming message and hand it to its callback.

        Public so a replay or a test can feed messages without a broker. Never raises.
        """
        kinds = {self._convoy_topic: "convoy", self._command_topic: "command"}
        kind = kinds.get(topic, "route" if topic == self._route_topic else None)
        if kind is None:
            return
        if not self._buckets[kind].take():
            self.counters["rate_limited"] += 1
            n = self.counters["rate_limited"]
            if n == 1 or n % 1000 == 0:
                log.warning("mqtt: inbound on %s over the rate limit (%d dropped)", topic, n)
            return
        if topic == self._route_topic:  # (retained too: the route is standing information)
            self._dispatch_route(payload)
            return
        if retain:
            self.counters["ignored_retained"] += 1
            log.info("mqtt: ignoring retained message on %s", topic)
            return
        try:
            if topic == self._convoy_topic:
                fix = topics.parse_convoy_position(payload)
                self.counters["convoy_received"] += 1
                if self.on_convoy is not None:
                    self._call(topic, self.on_convoy, fix)
            else:
                command = topics.parse_command(payload)
                self.counters["commands_received"] += 1
                log.info("mqtt: operator command %r", command)
                if self.on_command is not None:
                    self._call(topic, self.on_command, command)
        except topics.BadPayload as exc:
            self.counters["bad_input"] += 1
            self.last_bad_input = f"{topic}: {exc}"
            n = self.counters["bad_input"]
            if n <= 10 or n % 100 == 0:  # a spamming client must not flood the log
                log.warning("mqtt: rejected message on %s (%d so far): %s", topic, n, exc)

    def _dispatch_route(self, payload: bytes | str) -> None:
        try:
            route = topics.parse_convoy_route(payload)
        except topics.BadPayload as exc:
            self.counters["bad_input"] += 1
            self.last_bad_input = f"{self._route_topic}: {exc}"
            log.warning("mqtt: rejected route on %s: %s", self._route_topic, exc)
            return
        self.counters["routes_received"] += 1
        log.info("mqtt: convoy route of %d points %s", len(route.points), route.remarks())
        if self.on_route is not None:
            self._call(self._route_topic, self.on_route, route)

    def _call(self, topic: str, callback: Callable[[_T], None], value: _T) -> None:
        """Run a user callback; its failure is the callback's problem, not the task's."""
        try:
            callback(value)
        except Exception:
            self.counters["callback_errors"] += 1
            log.exception("mqtt: callback for %s failed", topic)
