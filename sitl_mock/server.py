"""The asyncio UDP edge of the mock: one socket per vehicle, one physics loop.

Data flow (each arrow is one function)::

    datagram -> VehicleLink.receive -> faults (loss, latency) -> per-peer parser
             -> SimVehicle.handle -> replies -> VehicleLink.send -> every peer + --gcs

    _physics task: every 1/100 s of sim time -> SimVehicle.step, due_telemetry
                   -> VehicleLink.send; truth rows at their own rate; scheduled faults

Design rules:
    * The vehicles (``sitl_mock.autopilot``) are sans-I/O; this module owns the
      bytes: one ``mavlink.MAVLink`` encoder per vehicle (its own sequence
      numbers) and one robust parser per (vehicle, peer address).
    * Like a real SITL, a vehicle replies to *every* peer that has ever sent to
      it (a GCS and a script at once), plus the fixed ``--gcs`` address.
    * Garbage never kills the loop: bad CRC, malformed and truncated frames,
      unknown message ids and failing handlers are counted and skipped.
    * Physics runs in fixed steps of sim time; if it falls behind by more than
      ``max_lag`` it slips the shared clock instead of spiralling, and the
      achieved real-time factor is reported. ``max_lag`` stays well under the
      setpoint-loss timeout (1 s): a stalled host (a GC pause, a loaded CI
      machine) pauses the simulation, as lockstep SITL does, instead of flying
      every vehicle blind into a failsafe while the physics catches up.
    * :class:`MockFleet` is an async context manager owning one TaskGroup, so a
      test writes ``async with MockFleet(config) as fleet:`` and gets endpoints.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import math
import random
from collections import Counter
from collections.abc import Mapping, Sequence
from contextlib import AsyncExitStack
from dataclasses import dataclass
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav import eventloop
from convoy_mav.errors import ConfigError
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.signing import timestamp_now
from sitl_mock.autopilot import SimVehicle, TruthRow
from sitl_mock.clock import SimClock
from sitl_mock.config import MockConfig
from sitl_mock.faults import DelayQueue, FaultInjector
from sitl_mock.truth import CsvTruthWriter, TruthRecorder, TruthSampler, TruthSink

if TYPE_CHECKING:
    from sitl_mock.autopilot import VehicleSpec

__all__ = ["DROP_REASONS", "VEHICLE_DROP_REASONS", "Endpoint", "MockFleet", "VehicleLink"]

log = logging.getLogger("sitl_mock")

Address = tuple[str, int]

DROP_REASONS = (
    "bad_crc",
    "malformed",
    "truncated",
    "unknown_id",
    "lost_to_vehicle",
    "lost_from_vehicle",
    "killed",
    "handler_error",
    "send_error",
)
"""Counter names of datagrams or messages the server dropped, and why."""

VEHICLE_DROP_REASONS = (
    "foreign_sysid",
    "foreign_compid",
    "unknown_message",
    "unknown_command",
    "unsupported_message",
    "setpoint_bad_frame",
    "param_unknown",
)
"""Counter names of messages the vehicles themselves ignored, and why."""

_MAX_PEERS = 16  # per vehicle; the oldest peer is forgotten beyond this
_BURST_STEPS = 50  # physics steps between yields to the event loop when catching up
_OPERATOR_SYSTEM = 250  # an operator's own ground station ([faults] mode), not the service


@dataclass(frozen=True, slots=True)
class Endpoint:
    """Where a client reaches one mock vehicle.

    Attributes:
        sysid: MAVLink system id of the vehicle.
        kind: ``"aircraft"`` or ``"ground"``.
        personality: ``"px4"`` or ``"ardupilot"``.
        frame: ``"plane"``/``"copter"`` for aircraft, ``"rover"`` for ground vehicles.
        host: Address the vehicle socket is bound to.
        port: UDP port the vehicle listens on.
    """

    sysid: int
    kind: str
    personality: str
    frame: str
    host: str
    port: int

    @property
    def connect(self) -> str:
        """pymavlink connection string for a client (``mavutil.mavlink_connection``)."""
        return f"udpout:{self.host}:{self.port}"

    @property
    def listen(self) -> str:
        """The vehicle's own side: it listens here (mavproxy's ``udpin`` form)."""
        return f"udpin:{self.host}:{self.port}"

    @property
    def mavsdk(self) -> str:
        """MAVSDK 4.x connection URL: the client sends first to the listening vehicle."""
        return f"udpout://{self.host}:{self.port}"

    def describe(self) -> str:
        """One start-up line: everything a user needs to connect."""
        return (
            f"vehicle sysid={self.sysid} kind={self.kind} personality={self.personality} "
            f"frame={self.frame} connect={self.connect} listen={self.listen} "
            f"mavsdk={self.mavsdk}"
        )


class _Outbox:
    """The ``file`` of a pymavlink encoder: collects packed frames."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []

    def write(self, buf: bytes) -> None:
        self.frames.append(bytes(buf))


class VehicleLink(asyncio.DatagramProtocol):
    """One vehicle's socket: peers, codec, faults and counters.

    It is an asyncio datagram protocol, but nothing here needs a socket: unit
    tests call :meth:`connection_made` with a fake transport and feed bytes to
    :meth:`datagram_received`.
    """

    def __init__(self, fleet: MockFleet, vehicle: SimVehicle) -> None:
        self.fleet = fleet
        self.vehicle = vehicle
        self.sysid = vehicle.spec.sysid
        self.transport: asyncio.DatagramTransport | None = None
        self.peers: dict[Address, Any] = {}  # address -> pymavlink parser
        self.outbox = _Outbox()
        self.signing_key = vehicle.spec.signing_key  # MAVLink 2 signing (SETUP_SIGNING sets it)
        self.streams: dict[tuple[int, int, int], int] = {}  # signed streams' last timestamps
        self._sign_ts = 0  # a SETUP_SIGNING's initial timestamp
        self.encoder = self._new_encoder()
        self.counters: Counter[str] = Counter()
        self.alive = True
        self.inbound: DelayQueue[tuple[bytes, Address]] = DelayQueue()
        self.outbound: DelayQueue[bytes] = DelayQueue()
        self._warned: set[str] = set()

    def _new_encoder(self) -> Any:
        spec = self.vehicle.spec
        encoder = mavlink.MAVLink(self.outbox, srcSystem=spec.sysid, srcComponent=spec.compid)
        if self.signing_key is not None:
            signing = encoder.signing
            signing.secret_key, signing.sign_outgoing = self.signing_key, True
            signing.timestamp = max(timestamp_now(), self._sign_ts + 1)
        return encoder

    def _set_signing(self, key: bytes | None, timestamp: int) -> None:
        """SETUP_SIGNING: a new key (all zeros: signing off); every peer parses anew."""
        self.signing_key = key
        self.streams = {}
        self._sign_ts = timestamp
        self.encoder = self._new_encoder()
        self.peers = {addr: self._new_parser() for addr in self.peers}
        self.counters["signing_setup"] += 1

    # -- asyncio callbacks -------------------------------------------------------------

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # CPython's selector datagram transport does not subclass DatagramTransport.
        self.transport = cast(asyncio.DatagramTransport, transport)

    def datagram_received(self, data: bytes, addr: Address) -> None:
        self.receive(data, addr, self.fleet.now)

    def error_received(self, exc: Exception) -> None:
        # ICMP port unreachable from a peer that went away: not our problem.
        self.counters["send_error"] += 1

    # -- inbound -----------------------------------------------------------------------

    def receive(self, data: bytes, addr: Address, now: float) -> None:
        """A datagram arrived from ``addr``: apply faults, then process or delay it."""
        self.counters["datagrams_in"] += 1
        if not self.alive:
            self.counters["killed"] += 1
            return
        if self.deaf:
            self.counters["deaf"] += 1
            return
        faults = self.fleet.faults
        if faults.drop_to_vehicle(self.sysid):
            self.counters["lost_to_vehicle"] += 1
            return
        for _ in range(faults.copies(self.sysid)):
            delay = faults.delay_to_vehicle(self.sysid)
            if delay > 0.0 or self.fleet.frozen:  # (paused: read, and answered, once it runs)
                self.inbound.push(now + delay, (data, addr))
            else:
                self.process(data, addr, now)

    def process(self, data: bytes, addr: Address, now: float) -> None:
        """Decode a datagram with the peer's parser and hand messages to the vehicle."""
        parser = self.peers.get(addr)
        if parser is None:
            if len(self.peers) >= _MAX_PEERS:
                del self.peers[next(iter(self.peers))]
            parser = self._new_parser()
            self.peers[addr] = parser
            log.info("sysid %d: new peer %s:%d", self.sysid, *addr)
        msgs = parser.parse_buffer(data) or []
        for msg in msgs:
            self._dispatch(msg, now)
        if parser.buf_len() > 0:
            # A datagram ends a frame: leftovers are a truncated frame, not a prefix.
            self.counters["truncated"] += 1
            self.peers[addr] = self._new_parser()

    def _new_parser(self) -> Any:
        spec = self.vehicle.spec
        parser = mavlink.MAVLink(None, srcSystem=spec.sysid, srcComponent=spec.compid)
        parser.robust_parsing = True
        if self.signing_key is not None:
            parser.signing.secret_key = self.signing_key
            parser.signing.stream_timestamps = self.streams  # (one table: replays via any peer)
            parser.signing.timestamp = self.encoder.signing.timestamp
        return parser

    def _dispatch(self, msg: Any, now: float) -> None:
        if isinstance(msg, mavlink.MAVLink_bad_data):
            reason = str(msg.reason)
            if "signature" in reason:
                self.counters["bad_signature"] += 1  # (unsigned ones too)
            elif "CRC" in reason:
                self.counters["bad_crc"] += 1
            else:
                self.counters["malformed"] += 1
            return
        if msg.get_type() == "SETUP_SIGNING" and msg.target_system == self.sysid:
            key = bytes(msg.secret_key)
            self._set_signing(None if not any(key) else key, int(msg.initial_timestamp))
            return
        if isinstance(msg, mavlink.MAVLink_unknown):
            self.counters["unknown_id"] += 1
            return
        self.counters["messages_in"] += 1
        reboots = self.vehicle.counters["reboot"]
        try:
            replies = self.vehicle.handle(msg, now)
        except Exception:
            self.counters["handler_error"] += 1
            kind = msg.get_type()
            if kind not in self._warned:
                self._warned.add(kind)
                log.exception(
                    "sysid %d: handling %s failed (further ones not logged)", self.sysid, kind
                )
            return
        self.send(replies, now)
        if self.vehicle.counters["reboot"] != reboots:  # MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN
            self.encoder = self._new_encoder()  # the ACK went out; sequence restarts

    # -- outbound ----------------------------------------------------------------------

    def send(self, msgs: Sequence[Any], now: float) -> None:
        """Encode messages (sequence numbers advance) and transmit or delay them."""
        if not msgs or not self.alive:
            return
        for msg in msgs:
            self.encoder.send(msg)
        frames, self.outbox.frames = self.outbox.frames, []
        self.counters["messages_out"] += len(frames)
        faults = self.fleet.faults
        for frame in frames:
            for _ in range(faults.copies(self.sysid)):
                delay = faults.delay_from_vehicle(self.sysid)
                if delay > 0.0:
                    self.outbound.push(now + delay, frame)
                else:
                    self.transmit(frame)

    def transmit(self, frame: bytes) -> None:
        """Send one frame to every peer and the fixed GCS address."""
        transport = self.transport
        if transport is None or transport.is_closing():
            return
        if self.muted:
            self.counters["muted"] += 1
            return
        faults = self.fleet.faults
        for dest in self._destinations():
            if faults.drop_from_vehicle(self.sysid):
                self.counters["lost_from_vehicle"] += 1
                continue
            transport.sendto(frame, dest)
            self.counters["datagrams_out"] += 1

    def _destinations(self) -> list[Address]:
        gcs = self.fleet.config.gcs
        dests = list(self.peers)
        if gcs is not None and gcs not in self.peers:
            dests.append(gcs)
        return dests

    # -- lifecycle ---------------------------------------------------------------------

    def drain(self, now: float) -> None:
        """Release delayed datagrams that are due (both directions)."""
        for data, addr in self.inbound.pop_due(now):
            if self.alive:
                self.process(data, addr, now)
        for frame in self.outbound.pop_due(now):
            if self.alive:
                self.transmit(frame)

    muted = False
    """Frames are dropped on the way out (a radio still down after a pause)."""

    deaf = False
    """Datagrams are dropped on the way in (an uplink down, the downlink still up)."""

    def kill(self) -> None:
        """Stop answering and sending entirely (power loss)."""
        self.alive = False
        self.inbound.clear()
        self.outbound.clear()

    def reboot(self, now: float, *, on_pad: bool = False) -> None:
        """Reboot the autopilot; sequence numbers restart as on real hardware."""
        self.vehicle.reboot(now, on_pad=on_pad)
        self.outbox.frames.clear()
        self.encoder = self._new_encoder()
        self.alive = True


class MockFleet:
    """K aircraft and G ground vehicles on UDP, sharing one sim clock.

    Use as an async context manager; sockets are bound and the physics task is
    running inside the block::

        async with MockFleet(MockConfig.simple(2, speedup=50, base_port=0)) as fleet:
            port = fleet.endpoint(1).port
            await fleet.wait_until(10.0)
            rows = fleet.truth_rows()

    Args:
        config: What to simulate.
        clock: Sim clock shared by all vehicles (default: wall clock x speedup).
        record_truth: Keep truth samples in memory (:attr:`history`): True for
            all, an int for only the last that many rows.
        run_physics: False to drive :meth:`step` by hand (benchmarks, tests).
        rng: Randomness for the fault injector (default: seeded from config).
    """

    def __init__(
        self,
        config: MockConfig,
        *,
        clock: SimClock | None = None,
        record_truth: bool | int = False,
        run_physics: bool = True,
        rng: random.Random | None = None,
    ) -> None:
        self.config = config
        self._own_clock = clock is None
        self.clock = clock if clock is not None else SimClock(config.speedup)
        self.world = LocalFrame(config.origin)
        self.faults = FaultInjector(config.faults, rng or random.Random(config.faults.seed))
        self.dt = 1.0 / config.physics_rate
        self.max_lag = _max_lag(self.clock.speedup)
        self.history: TruthRecorder | None = None
        self._sinks: list[TruthSink] = []
        if record_truth:
            maxlen = None if record_truth is True else int(record_truth)
            self.history = TruthRecorder(maxlen)
            self._sinks.append(self.history)
        self._run_physics = run_physics
        self._k = 0  # physics steps done; sim time is k * dt (no float drift)
        self.wakes = 0  # times the paced physics loop woke (at most one a timer tick)
        self._links: dict[int, VehicleLink] = {}
        self._sampler = TruthSampler(config.truth_rate)
        self._stack: AsyncExitStack | None = None
        self._physics_task: asyncio.Task[None] | None = None
        self._last_lag_warning = -math.inf
        self._frozen = False  # pause(): no physics, nothing sent, sim time stopped
        for spec in config.vehicles:
            self._links[spec.sysid] = VehicleLink(self, SimVehicle(spec, self.world, 0.0, self))
        for spec in config.vehicles:  # (a convoy's followers drive behind their leader)
            if spec.follows is not None:
                leader = self._links.get(spec.follows)
                trail = None if leader is None else leader.vehicle.trail
                if trail is None or spec.follows >= spec.sysid:
                    raise ValueError(
                        f"sysid {spec.sysid} follows {spec.follows}: no ground vehicle "
                        "with a lower sysid (stepped first) of that id"
                    )
                self._links[spec.sysid].vehicle.follow(trail, spec.lag_s, spec.standstill_m)
        self._endpoints = tuple(
            _endpoint(s, (config.host, config.port_of(s.sysid))) for s in config.vehicles
        )

    # -- public view -------------------------------------------------------------------

    @property
    def now(self) -> float:
        """Sim time the physics has reached (s); what the vehicles report."""
        return self._k * self.dt

    @property
    def speedup(self) -> float:
        """Sim seconds per wall second asked for (``SIM_SPEEDUP``; slips aside)."""
        return self.clock.speedup

    def set_speedup(self, speedup: float) -> None:
        """Run every vehicle at ``speedup`` from now on (any vehicle's ``SIM_SPEEDUP``, as
        a simulator's speed is set in flight); sim time goes on from where it is.

        Raises:
            ValueError: ``speedup`` is not finite and > 0.
        """
        self.clock.set_speedup(speedup)
        self.max_lag = _max_lag(speedup)
        log.info("speedup set to %g", speedup)

    @property
    def endpoints(self) -> tuple[Endpoint, ...]:
        """One per vehicle, in sysid order (ports are real once entered)."""
        return self._endpoints

    def endpoint(self, sysid: int) -> Endpoint:
        """The endpoint of vehicle ``sysid``."""
        for ep in self._endpoints:
            if ep.sysid == sysid:
                return ep
        raise KeyError(sysid)

    @property
    def vehicles(self) -> Mapping[int, SimVehicle]:
        """The sans-I/O vehicles by sysid (read their state; don't drive them)."""
        return {sysid: link.vehicle for sysid, link in self._links.items()}

    def truth_rows(self) -> list[TruthRow]:
        """Every vehicle's true state now (killed vehicles show mode ``KILLED``)."""
        return [self._truth(link) for link in self._links.values()]

    def link(self, sysid: int) -> VehicleLink:
        """The link (socket protocol, peers, counters) of vehicle ``sysid``."""
        return self._links[sysid]

    def truth(self, sysid: int) -> TruthRow:
        """One vehicle's true state now."""
        return self._truth(self._links[sysid])

    def peers(self, sysid: int) -> list[Address]:
        """Addresses vehicle ``sysid`` currently replies to (besides ``--gcs``)."""
        return list(self._links[sysid].peers)

    def counters(self, sysid: int | None = None) -> Counter[str]:
        """Traffic and drop counters of one vehicle, or summed over the fleet.

        Server-side names: ``datagrams_in/out``, ``messages_in/out`` and the
        :data:`DROP_REASONS`; the vehicles' own counters (``foreign_sysid``,
        ``unknown_command``...) are added in.
        """
        links = [self._links[sysid]] if sysid is not None else list(self._links.values())
        total: Counter[str] = Counter()
        for link in links:
            total.update(link.counters)
            total.update({k: v for k, v in link.vehicle.counters.items() if v})
        return total

    def status_line(self) -> str:
        """One line with time, achieved real-time factor and all counters."""
        c = self.counters()
        dropped = set(DROP_REASONS) | set(VEHICLE_DROP_REASONS)
        drops = " ".join(f"{k}={c[k]}" for k in sorted(c) if k in dropped and c[k])
        events = " ".join(
            f"{k}={c[k]}" for k in sorted(c) if k not in dropped and k not in _TRAFFIC and c[k]
        )
        wall = self.clock.wall_elapsed()
        rtf = self.now / wall if wall > 0 else 0.0
        return (
            f"sitl-mock: t={self.now:.2f}s sim, rtf={rtf:.1f} (speedup {self.clock.speedup:g}, "
            f"slips {self.clock.slips}) datagrams in={c['datagrams_in']} out={c['datagrams_out']} "
            f"messages in={c['messages_in']} out={c['messages_out']} "
            f"drops: {drops or 'none'}; events: {events or 'none'}"
        )

    def is_alive(self, sysid: int) -> bool:
        """False once the vehicle has been killed (until a reboot revives it)."""
        return self._links[sysid].alive

    def kill(self, sysid: int) -> None:
        """Kill vehicle ``sysid`` now: it stops responding and sending."""
        self._links[sysid].kill()
        log.warning("sysid %d: killed at t=%.2f s", sysid, self.now)

    def set_mode(self, sysid: int, name: str) -> None:
        """Switch vehicle ``sysid`` to its firmware's mode ``name`` as its own operator's
        ground station does: a SET_MODE from system 250, taken as any other (refused as
        the firmware would, e.g. RTL with no home); its texts go out, its ack to that
        ground station, not to the links' peers."""
        link = self._links[sysid]
        vehicle = link.vehicle
        mode = vehicle.firmware.mode(name)
        msg = mavlink.MAVLink_set_mode_message(
            sysid, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode.custom_mode
        )
        msg.pack(mavlink.MAVLink(None, srcSystem=_OPERATOR_SYSTEM, srcComponent=190))
        replies = vehicle.handle(msg, self.now)
        link.send([m for m in replies if m.get_type() == "STATUSTEXT"], self.now)
        log.warning("sysid %d: its operator switched it to %s at t=%.2f s", sysid, name, self.now)

    def stall(self, sysid: int) -> None:
        """Vehicle ``sysid`` (a ground one) stops now and moves no more, its autopilot
        driving on (``SimVehicle.stall``)."""
        self._links[sysid].vehicle.stall()
        log.warning("sysid %d: stalled at t=%.2f s", sysid, self.now)

    def reboot(self, sysid: int, *, on_pad: bool = False) -> None:
        """Reboot vehicle ``sysid`` now (``time_boot_ms`` restarts from 0); ``on_pad``:
        at rest on its home pad (relaunched), not where it was."""
        self._links[sysid].reboot(self.now, on_pad=on_pad)
        where = " on its pad" if on_pad else ""
        log.warning("sysid %d: rebooted%s at t=%.2f s", sysid, where, self.now)

    @property
    def frozen(self) -> bool:
        """Paused (``pause``): no physics, nothing sent or answered, sim time stopped."""
        return self._frozen

    async def pause(
        self, wall_seconds: float, *, first: Sequence[int] = (), stagger: float = 0.1
    ) -> None:
        """Freeze the whole simulation for ``wall_seconds``, then go on from where it was.

        What a paused host or simulator does to every autopilot at once (SIGSTOP of
        SITL, a lockstep simulator waiting): no physics, nothing sent, sim time
        stopped. On resuming, the vehicles in ``first`` speak first and the others
        ``stagger`` wall seconds later (which vehicle a ground station hears first
        after the silence is up to chance in the field).
        """
        self._frozen = True
        try:
            await asyncio.sleep(wall_seconds)
        finally:
            self.clock.slip(max(self.clock.now() - self.now, 0.0))
            later = [link for sysid, link in self._links.items() if first and sysid not in first]
            for link in later:
                link.muted = True
            self._frozen = False
        log.warning("all vehicles: paused for %.2f wall s at t=%.2f s", wall_seconds, self.now)
        if later:
            await asyncio.sleep(stagger)
            for link in later:
                link.muted = False

    async def wait_until(self, t: float) -> None:
        """Sleep until the physics has reached sim time ``t``."""
        if not self._run_physics:
            raise RuntimeError("wait_until needs run_physics=True")
        while self.now < t:
            await asyncio.sleep(min(max(self.clock.wall_until(t), eventloop.TIMER_TICK), 0.05))

    # -- physics -----------------------------------------------------------------------

    def step(self) -> None:
        """Advance every live vehicle by one fixed step and send what is due."""
        self._k += 1
        now = self._k * self.dt
        for event in self.faults.due_events(now):
            if event.sysid not in self._links:
                log.warning("fault %s for unknown sysid %d ignored", event.kind, event.sysid)
            elif event.kind == "kill":
                self.kill(event.sysid)
            elif event.kind == "mode":
                self.set_mode(event.sysid, event.mode)
            elif event.kind == "stall":
                self.stall(event.sysid)
            else:
                self.reboot(event.sysid)
        for link in self._links.values():
            if not link.alive:
                continue
            link.drain(now)
            vehicle = link.vehicle
            link.send(vehicle.step(now, self.dt), now)
            link.send(vehicle.due_telemetry(now), now)
        if self._sinks and self._sampler.due(now):
            self._write_truth()

    def _write_truth(self) -> None:
        rows = self.truth_rows()
        for sink in self._sinks:
            sink.write(rows)

    def catch_up(self, max_steps: int = _BURST_STEPS) -> int:
        """Step until the physics reaches the clock, at most ``max_steps`` steps.

        If the physics is more than :attr:`max_lag` sim seconds behind, the
        clock is slipped back first (one step behind), so a slow machine runs
        at its own achievable speed instead of spiralling into ever longer
        catch-up bursts.

        Returns:
            The number of steps taken.
        """
        clock = self.clock
        behind = clock.now() - self.now
        if behind > self.max_lag:
            clock.slip(behind - self.dt)
            self._warn_lag()
        steps = 0
        while steps < max_steps and self.now + self.dt <= clock.now() + 1e-9:
            self.step()
            steps += 1
        return steps

    async def _physics(self) -> None:
        while True:
            self.wakes += 1
            if self._frozen:
                await asyncio.sleep(0.005)
            elif self.catch_up() >= _BURST_STEPS:
                await asyncio.sleep(0)  # still behind: let datagrams in, then go on
            else:
                await eventloop.sleep(self.clock.wall_until(self.now + self.dt))

    def _warn_lag(self) -> None:
        wall = self.clock.wall_elapsed()
        if wall - self._last_lag_warning >= 5.0:
            self._last_lag_warning = wall
            log.warning(
                "physics behind: achieved real-time factor %.1f of requested %g (%d slips)",
                self.clock.real_time_factor(),
                self.clock.speedup,
                self.clock.slips,
            )

    def _truth(self, link: VehicleLink) -> TruthRow:
        row = link.vehicle.truth(self.now)
        return row if link.alive else dataclasses.replace(row, mode="KILLED")

    # -- lifecycle ---------------------------------------------------------------------

    async def __aenter__(self) -> MockFleet:
        stack = AsyncExitStack()
        await stack.__aenter__()
        try:
            await self._open(stack)
        except BaseException:
            await stack.aclose()
            raise
        self._stack = stack
        return self

    async def _open(self, stack: AsyncExitStack) -> None:
        loop = asyncio.get_running_loop()
        if self._own_clock:
            self.clock = SimClock(self.config.speedup)  # sim time starts when the sockets do
        endpoints: list[Endpoint] = []
        for spec in self.config.vehicles:
            link = self._links[spec.sysid]
            port = self.config.port_of(spec.sysid)
            try:
                transport, _ = await loop.create_datagram_endpoint(
                    lambda link=link: link,  # type: ignore[misc]
                    local_addr=(self.config.host, port),
                )
            except OSError as e:
                key = "base_port" if self.config.base_port else "host"
                raise ConfigError(
                    key, f"{self.config.host}:{port}", f"cannot bind: {e.strerror or e}"
                ) from e
            stack.callback(transport.close)
            endpoints.append(_endpoint(spec, transport.get_extra_info("sockname")))
        self._endpoints = tuple(endpoints)
        if self.config.truth_path is not None:
            try:
                writer = CsvTruthWriter(self.config.truth_path)
            except OSError as e:
                raise ConfigError("truth", self.config.truth_path, e.strerror or str(e)) from e
            self._sinks.append(writer)
            stack.callback(writer.close)
        if self._sampler.due(self.now):  # the state at t = 0 heads the log
            self._write_truth()
        tg = await stack.enter_async_context(asyncio.TaskGroup())
        if self._run_physics:
            self._physics_task = tg.create_task(self._physics(), name="sitl_mock.physics")

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> bool | None:
        if self._physics_task is not None:
            self._physics_task.cancel()
        stack, self._stack = self._stack, None
        assert stack is not None
        return await stack.__aexit__(exc_type, exc, tb)


_TRAFFIC = {"datagrams_in", "datagrams_out", "messages_in", "messages_out"}


def _max_lag(speedup: float) -> float:
    """Sim s the physics may fall behind its clock before the clock slips."""
    return min(0.5, max(0.25, 0.01 * speedup))


def _endpoint(spec: VehicleSpec, sockname: tuple[str, int]) -> Endpoint:
    frame = spec.airframe.frame if spec.kind == "aircraft" else "rover"
    return Endpoint(
        sysid=spec.sysid,
        kind=spec.kind,
        personality=str(spec.personality),
        frame=frame,
        host=sockname[0],
        port=sockname[1],
    )
