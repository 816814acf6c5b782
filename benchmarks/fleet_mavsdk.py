"""The MAVSDK-Python 4.x baseline of the fleet benchmark (``bench_fleet.py``).

The workload the issue names: ONE ``Mavsdk`` with one ``udpout://`` connection
per mock aircraft; per vehicle wait for health, arm, set an initial setpoint,
``offboard.start()``, then stream ``set_position_velocity_ned`` at ``rate_hz`` on
monotonic deadlines (one asyncio task per vehicle, as MAVSDK's multi-drone
examples do) and count ``position_velocity_ned`` telemetry updates.

What is measured, and how:
    * Send times are ``perf_counter()`` right after each awaited send returns.
      In MAVSDK 4.x every call is ``run_in_executor`` on the loop's default
      thread pool, and the C++ call only *queues* the datagram for MAVSDK's one
      asio io thread, so a return is not a datagram on the wire.
    * The wire is watched through a *tap*: a small relay process between MAVSDK
      and a few sampled vehicles, taking the kernel receive timestamp
      (``SO_TIMESTAMPNS``) of every setpoint MAVSDK writes. Setpoint values
      are float32 on the wire, so each call is matched to its own datagram:
      call -> wire delay, wire rate and wire intervals (in ``notes``). MAVSDK's
      offboard plugin also re-sends the last setpoint by itself every 50 ms (a
      timer reset by each call); those show up as duplicates.
    * Telemetry latency: the tap notes when it handed each ``LOCAL_POSITION_NED``
      to MAVSDK's socket; MAVSDK's ``PositionVelocityNed`` carries the same
      float32 position, so the value seen in our coroutine is matched exactly.
      The latency is "datagram in MAVSDK's socket -> value in the user's
      coroutine": the client-side share, the part a client library controls.
    * ``cores`` is ``process_time()`` over the window: all threads of this
      process (loop, executor, MAVSDK's native threads; 4.x runs in-process,
      no ``mavsdk_server``, which is checked). The mock and the tap are other
      processes and not counted.
    * One ``Mavsdk`` keys systems by sysid, so it cannot fly more vehicles than
      one sysid space holds (the mock: 250 per process). Beyond that, one
      ``Mavsdk`` per space is used (``sysid_space``), reported in ``notes``.

What MAVSDK 4.1 does at scale (seen here, worth knowing when reading results):
    * Every system's thread broadcasts a PING (target 0) every 5 s, and one
      ``Mavsdk`` sends broadcasts on every connection: N systems -> N**2
      PINGs per 5 s, each answered (N=100: 10,000 in one second; N=250:
      62,500). The single-process mock then serves setpoints late and PX4's
      offboard-loss failsafe (1 s) fires for every vehicle from N=250 on.
    * Blocking calls (``arm``, ``offboard.start/stop``) and the non-blocking
      setpoint sends share the loop's default executor (6 threads on 2 cores).
      Slow command acks starve the setpoint stream; setup stalls from ~1000.
    * One thread per system plus a handful per instance; Python callbacks
      that fall behind are dropped ("Dropping subscription callbacks").

Run: ``python benchmarks/fleet_mavsdk.py [N ...] [--seconds S] [--json]`` (starts
the mock; ``--attach BASE_PORT`` flies one that is already running).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import itertools
import json
import math
import os
import random
import socket
import statistics
import struct
import sys
import tempfile
import threading
import time
from collections import Counter
from collections.abc import AsyncIterator, Callable, Sequence
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from convoy_mav.streaming import percentile

__all__ = [
    "MOCK_MAX_AIRCRAFT",
    "ClientResult",
    "MockPorts",
    "find_free_ports",
    "run_mavsdk",
    "start_mock_process",
]

AIRSPEED = 18.0  # m/s, the mock's default
CIRCLE_RADIUS = 150.0  # m, above the default minimum turn radius (80 m)
ALTITUDE = 30.0  # m, the mock's PX4 takeoff altitude
_SO_TIMESTAMPNS = getattr(socket, "SO_TIMESTAMPNS", 35)  # Linux value; Python may not export it
_CLK_TCK = os.sysconf("SC_CLK_TCK")


@dataclass(frozen=True)
class ClientResult:
    """One client's row of the fleet benchmark (both clients fill the same fields).

    Attributes:
        client: Name and version, e.g. ``"mavsdk-python 4.1.0"``.
        vehicles: Vehicles asked for.
        flying: Vehicles that reached OFFBOARD + armed and streamed in the window
            (whether they were still in OFFBOARD at its end is in ``notes``).
        setup_s: Wall s from start until all were flying, or until it gave up
            (setup timeout, or no progress for a while; see ``notes``).
        seconds: Measured window, wall s.
        cores: CPU s of this process (all threads) per wall s of the window.
        rate_hz_median: Achieved per-vehicle setpoint rate, median over vehicles.
        interval_p50_ms: Per-vehicle inter-send interval p50, median over vehicles.
        interval_p99_ms: Per-vehicle inter-send interval p99, worst vehicle.
        interval_p99_ms_median: Per-vehicle inter-send interval p99, median over vehicles.
        telemetry_hz_median: Position updates received per vehicle per s, median.
        telemetry_latency_p50_ms: Socket -> user-coroutine latency p50 (tapped vehicles).
        telemetry_latency_p99_ms: The same, p99; ``None`` when not measured (see notes).
        notes: Caveats, failures and a CPU breakdown, as ``key=value; ...``.
    """

    client: str
    vehicles: int
    flying: int
    setup_s: float
    seconds: float
    cores: float
    rate_hz_median: float
    interval_p50_ms: float
    interval_p99_ms: float
    interval_p99_ms_median: float
    telemetry_hz_median: float
    telemetry_latency_p50_ms: float | None
    telemetry_latency_p99_ms: float | None
    notes: str

    def describe(self) -> str:
        """Multi-line human-readable form."""
        rows = []
        for f in fields(self):
            v = getattr(self, f.name)
            rows.append(f"  {f.name:26} {v:.4g}" if isinstance(v, float) else f"  {f.name:26} {v}")
        return "\n".join(rows)


# -- statistics ----------------------------------------------------------------------


def _median(xs: Sequence[float]) -> float:
    return statistics.median(xs) if xs else math.nan


# -- CPU accounting from /proc -------------------------------------------------------


def _stat_cpu_s(path: str) -> float:
    """utime + stime (s) from a /proc ``stat`` file; 0 if it vanished."""
    try:
        with open(path) as f:
            rest = f.read().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return 0.0
    return (int(rest[11]) + int(rest[12])) / _CLK_TCK  # fields 14, 15 of proc(5)


def _helper_processes() -> list[int]:
    """Child processes that belong to MAVSDK (a ``mavsdk_server``), if any."""
    me = str(os.getpid())
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                head, rest = f.read().rsplit(")", 1)
        except OSError:
            continue
        if rest.split()[1] == me and "mavsdk" in head.lower():
            found.append(int(pid))
    return found


def _thread_cpu() -> dict[int, float]:
    """CPU s of every thread of this process, by native thread id."""
    out = {}
    for tid in os.listdir("/proc/self/task"):
        out[int(tid)] = _stat_cpu_s(f"/proc/self/task/{tid}/stat")
    return out


def _cpu_breakdown(before: dict[int, float], after: dict[int, float], wall: float) -> str:
    """Cores of the loop thread, the executor threads and the rest (MAVSDK's native threads)."""
    executor = {t.native_id for t in threading.enumerate() if t.name.startswith("asyncio_")}
    loop_tid = threading.get_native_id()
    parts = dict.fromkeys(("loop", "executor", "native"), 0.0)
    busiest = 0.0
    for tid, cpu in after.items():
        kind = "loop" if tid == loop_tid else "executor" if tid in executor else "native"
        parts[kind] += cpu - before.get(tid, 0.0)
        if kind == "native":
            busiest = max(busiest, cpu - before.get(tid, 0.0))
    shares = " ".join(f"{k}={parts[k] / wall:.3f}" for k in ("loop", "executor", "native"))
    return f"{shares} (busiest native thread {busiest / wall:.3f})"


# -- the mock as a subprocess --------------------------------------------------------

MOCK_MAX_AIRCRAFT = 250
"""One mock process (one MAVLink sysid space) holds at most this many aircraft."""


class MockPorts(list[int]):
    """The ports of a running mock fleet, plus its processes.

    Port ``i`` serves sysid ``i % per_process + 1`` of mock process ``i // per_process``:
    beyond :data:`MOCK_MAX_AIRCRAFT` vehicles sysids repeat, one sysid space per process.
    """

    def __init__(self, ports: list[int], per_process: int) -> None:
        super().__init__(ports)
        self.per_process = per_process
        self.pids: list[int] = []
        self.status: list[str] = []  # each process's final status line, filled on exit

    def cpu_s(self) -> float:
        """CPU s used so far by the mock processes."""
        return sum(_stat_cpu_s(f"/proc/{pid}/stat") for pid in self.pids)


def find_free_ports(n: int, host: str = "127.0.0.1", tries: int = 50) -> int:
    """A base port with ``n`` consecutive UDP ports free right now (probed by binding).

    Raises:
        RuntimeError: No such range found in ``tries`` random attempts.
    """
    for _ in range(tries):
        base = random.randrange(20000, 60000 - n)
        socks: list[socket.socket] = []
        try:
            for p in range(base, base + n):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                socks.append(s)
                s.bind((host, p))
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
        return base
    raise RuntimeError(f"no {n} consecutive free UDP ports found")


def _port_bound(port: int, host: str = "127.0.0.1") -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return True
    return False


def _mock_command() -> list[str]:
    exe = Path(sys.executable).with_name("sitl-mock")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "sitl_mock"]


@contextlib.asynccontextmanager
async def start_mock_process(
    n: int,
    base_port: int | None = None,
    *,
    per_process: int = MOCK_MAX_AIRCRAFT,
    physics_rate: float = 20.0,
    ready_timeout: float = 60.0,
) -> AsyncIterator[MockPorts]:
    """Run ``sitl-mock`` with ``n`` PX4 planes at speedup 1, in subprocesses.

    ``n`` above ``per_process`` takes several processes, each its own sysid
    space 1..per_process on consecutive ports (see :class:`MockPorts`). Yields
    once every process printed ``ready`` (printed after binding all its
    sockets) and its first and last ports are confirmed bound; terminates them
    on exit (SIGTERM, then SIGKILL after 10 s).

    Args:
        n: Aircraft in all.
        base_port: First port; ``None`` probes for ``n`` free consecutive ports.
        per_process: Aircraft per mock process, at most :data:`MOCK_MAX_AIRCRAFT`.
        physics_rate: Mock physics rate, Hz of sim time.
        ready_timeout: s to wait for ``ready``.

    Yields:
        The ports (a ``list[int]``), with the processes' pids and final status lines.

    Raises:
        RuntimeError: A mock exited or was not ready in time.
    """
    per_process = min(per_process, MOCK_MAX_AIRCRAFT)
    base = find_free_ports(n) if base_port is None else base_port
    ports = MockPorts(list(range(base, base + n)), per_process)
    async with contextlib.AsyncExitStack() as stack:
        async with asyncio.timeout(ready_timeout):
            for i in range(0, n, per_process):
                shard = ports[i : i + per_process]
                await stack.enter_async_context(_one_mock(shard, physics_rate, ports))
        yield ports


@contextlib.asynccontextmanager
async def _one_mock(ports: list[int], physics_rate: float, fleet: MockPorts) -> AsyncIterator[None]:
    with tempfile.TemporaryDirectory(prefix="fleet_mock_") as tmp:
        config = Path(tmp, "mock.toml")
        config.write_text(
            f"speedup = 1.0\nphysics_rate = {physics_rate}\nbase_port = {ports[0]}\n"
            f'[aircraft]\ncount = {len(ports)}\npersonality = "px4"\nframe = "plane"\n'
            "warmup = 1.0\n"
        )
        with open(Path(tmp, "stderr.txt"), "w+b") as err:
            proc = await asyncio.create_subprocess_exec(
                *_mock_command(),
                "--config",
                str(config),
                stdout=asyncio.subprocess.PIPE,
                stderr=err,
                stdin=asyncio.subprocess.DEVNULL,
            )
            fleet.pids.append(proc.pid)
            try:
                assert proc.stdout is not None
                while not (line := await proc.stdout.readline()).startswith(b"sitl-mock: ready"):
                    if not line:
                        err.seek(0)
                        tail = err.read()[-2000:].decode(errors="replace")
                        raise RuntimeError(f"sitl-mock exited: {tail}")
                if not (_port_bound(ports[0]) and _port_bound(ports[-1])):
                    raise RuntimeError(f"sitl-mock ready but ports {ports[0]}.. not bound")
                yield
            finally:
                fleet.status.extend(await _stop_process(proc))


async def _stop_process(proc: asyncio.subprocess.Process) -> list[str]:
    """Terminate the process; its remaining stdout lines (the mock's status line)."""
    if proc.returncode is None:
        proc.terminate()
    try:
        async with asyncio.timeout(10.0):
            out = await proc.stdout.read() if proc.stdout is not None else b""
            await proc.wait()
    except TimeoutError:
        proc.kill()
        await proc.wait()
        return []
    return [s for s in out.decode(errors="replace").splitlines() if s.strip()]


# -- the tap: a relay process that timestamps the wire ---------------------------------

_LOCAL_POSITION_NED = 32
_SET_POSITION_TARGET_LOCAL_NED = 84


def _msgid(frame: bytes) -> int:
    """Message id of a MAVLink 1 or 2 frame (-1 if neither)."""
    if frame[:1] == b"\xfd" and len(frame) >= 10:
        return int.from_bytes(frame[7:10], "little")
    if frame[:1] == b"\xfe" and len(frame) >= 6:
        return frame[5]
    return -1


def _tap_main(mock_ports: list[int]) -> None:
    """Relay client <-> mock for these ports; on a ``dump`` line on stdin, print what passed.

    Prints its own listen ports first (one per mock port, same order). Records
    ``u PORT X Y Z T``: a setpoint from the client, T its kernel receive time;
    ``d PORT X Y Z T``: a position handed to the client, T right after ``sendto``.
    T is ``CLOCK_MONOTONIC`` (``perf_counter``), shared by all processes.
    """
    import selectors

    from pymavlink.dialects.v20 import common as mavlink

    sel = selectors.DefaultSelector()
    socks = []
    for port in mock_ports:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setsockopt(socket.SOL_SOCKET, _SO_TIMESTAMPNS, 1)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
        sel.register(s, selectors.EVENT_READ, port)
        socks.append(s)
    sel.register(sys.stdin.buffer, selectors.EVENT_READ, None)
    print(" ".join(str(s.getsockname()[1]) for s in socks), flush=True)
    clients: dict[int, Any] = {}
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    records: list[str] = []
    while True:
        for key, _ in sel.select():
            if key.data is None:
                if not os.read(sys.stdin.fileno(), 64):
                    return
                sys.stdout.write("".join(records) + "end\n")
                sys.stdout.flush()
                records.clear()
                continue
            sock, port = key.fileobj, key.data
            assert isinstance(sock, socket.socket)
            while True:
                try:
                    data, anc, _, addr = sock.recvmsg(2048, socket.CMSG_SPACE(16))
                except BlockingIOError:
                    break
                offset_ns = time.time_ns() - time.monotonic_ns()
                upward = addr[1] != port
                if upward:
                    clients[port] = addr
                    sock.sendto(data, ("127.0.0.1", port))
                elif port in clients:
                    sock.sendto(data, clients[port])
                else:
                    continue
                t = time.monotonic()
                want = _SET_POSITION_TARGET_LOCAL_NED if upward else _LOCAL_POSITION_NED
                if _msgid(data) != want:
                    continue
                if upward:
                    for level, kind, cdata in anc:
                        if level == socket.SOL_SOCKET and kind == _SO_TIMESTAMPNS:
                            sec, nsec = struct.unpack("qq", cdata[:16])
                            t = (sec * 1_000_000_000 + nsec - offset_ns) / 1e9
                for m in parser.parse_buffer(data) or []:
                    if m.get_msgId() == want:
                        side = "u" if upward else "d"
                        records.append(f"{side} {port} {m.x!r} {m.y!r} {m.z!r} {t!r}\n")


Key = tuple[int, float, float, float]  # mock port, x, y, z (float32 values)


@dataclass
class _TapRecords:
    down: dict[Key, float]  # position frame -> when it entered MAVSDK's socket
    up: dict[int, list[tuple[tuple[float, float, float], float]]]  # port -> setpoints on the wire


class _Tap:
    """The tap process (see :func:`_tap_main`) between MAVSDK and a few vehicles."""

    def __init__(self, proc: asyncio.subprocess.Process, ports: dict[int, int]) -> None:
        self.proc = proc
        self.ports = ports  # mock port -> tap port (MAVSDK connects there instead)

    @classmethod
    async def start(cls, mock_ports: list[int]) -> _Tap:
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            str(Path(__file__).resolve()),
            "_tap",
            *map(str, mock_ports),
            stdin=asyncio.subprocess.PIPE,
            stdout=asyncio.subprocess.PIPE,
        )
        assert proc.stdout is not None
        try:
            async with asyncio.timeout(15.0):
                line = await proc.stdout.readline()
        except TimeoutError:
            proc.kill()
            await proc.wait()
            raise
        tap_ports = [int(p) for p in line.split()]
        return cls(proc, dict(zip(mock_ports, tap_ports, strict=True)))

    async def dump(self) -> _TapRecords:
        """Everything recorded so far."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(b"dump\n")
        await self.proc.stdin.drain()
        down: dict[Key, float] = {}
        seen: Counter[Key] = Counter()
        up: dict[int, list[tuple[tuple[float, float, float], float]]] = {}
        async with asyncio.timeout(30.0):
            while (line := await self.proc.stdout.readline()) not in (b"end\n", b""):
                side, port, x, y, z, t = line.split()
                key = (int(port), float(x), float(y), float(z))
                if side == b"u":
                    up.setdefault(key[0], []).append((key[1:], float(t)))
                else:
                    seen[key] += 1
                    down.setdefault(key, float(t))
        # A parked plane repeats its position: keep only frames that are unambiguous.
        return _TapRecords({k: t for k, t in down.items() if seen[k] == 1}, up)

    async def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            async with asyncio.timeout(5.0):
                await self.proc.wait()
        except TimeoutError:
            self.proc.kill()
            await self.proc.wait()


# -- the MAVSDK client ---------------------------------------------------------------


def _f32(x: float) -> float:
    """``x`` as it travels in a MAVLink float field."""
    f: float = struct.unpack("f", struct.pack("f", x))[0]
    return f


@dataclass(eq=False)
class _Vehicle:
    """Per-vehicle state of the MAVSDK client."""

    sysid: int
    port: int  # the mock's port (the identity), even when MAVSDK goes through the tap
    system: Any  # keep: plugins die with the System wrapper that made them
    sampled: bool  # behind the tap
    telemetry: Any = None
    action: Any = None
    offboard: Any = None
    flying_at: float | None = None
    failure: str | None = None
    stage: str = "health"  # where setup is: health, arm, fix, offboard
    send_errors: int = 0
    sends: list[float] = field(default_factory=list)
    sent: list[tuple[float, float, float]] = field(default_factory=list)  # sampled only
    updates: list[float] = field(default_factory=list)
    positions: list[tuple[float, float, float]] = field(default_factory=list)  # sampled only
    first_fix: asyncio.Event = field(default_factory=asyncio.Event)
    last_ne: tuple[float, float] = (0.0, 0.0)


async def _watch_position(v: _Vehicle) -> None:
    async for pv in v.telemetry.subscribe_position_velocity_ned():
        v.updates.append(time.perf_counter())
        p = pv.position
        v.last_ne = (p.north_m, p.east_m)
        if v.sampled:
            v.positions.append((p.north_m, p.east_m, p.down_m))
        v.first_fix.set()


async def _setup(v: _Vehicle, deadline: float) -> None:
    """Health, arm, initial setpoint, offboard start: MAVSDK's offboard example."""
    from mavsdk.asyncio import MavsdkError

    async with asyncio.timeout(max(deadline - time.perf_counter(), 0.0)):
        health = v.telemetry.subscribe_health()
        try:
            async for h in health:
                if h.is_global_position_ok and h.is_home_position_ok and h.is_armable:
                    break
        finally:
            await health.aclose()
        v.stage = "arm"
        while True:
            try:
                await v.action.arm()
                break
            except MavsdkError:
                await asyncio.sleep(0.5)
        v.stage = "fix"
        await v.first_fix.wait()
        v.stage = "offboard"
        await _send(v, time.perf_counter(), v.last_ne)  # a setpoint before offboard.start()
        await v.offboard.start()


async def _send(v: _Vehicle, t: float, centre: tuple[float, float]) -> tuple[float, float, float]:
    """One point of a circle around ``centre``; returns the position sent."""
    from mavsdk.asyncio.plugins.offboard import PositionNedYaw, VelocityNedYaw

    th = (AIRSPEED / CIRCLE_RADIUS) * t + v.sysid
    vn, ve = -AIRSPEED * math.sin(th), AIRSPEED * math.cos(th)
    yaw = math.degrees(math.atan2(ve, vn))
    n, e = centre[0] + CIRCLE_RADIUS * math.cos(th), centre[1] + CIRCLE_RADIUS * math.sin(th)
    await v.offboard.set_position_velocity_ned(
        PositionNedYaw(n, e, -ALTITUDE, yaw), VelocityNedYaw(vn, ve, 0.0, yaw)
    )
    return n, e, -ALTITUDE


async def _fly(v: _Vehicle, period: float, deadline: float) -> None:
    """Set up, then stream setpoints on deadlines until cancelled."""
    from mavsdk.asyncio import MavsdkError

    try:
        await _setup(v, deadline)
    except TimeoutError:
        v.failure = f"setup timeout at {v.stage}"
        return
    except Exception as exc:  # any setup failure is a result, not a crash of the run
        v.failure = f"setup: {type(exc).__name__}: {exc}"
        return
    v.flying_at = time.perf_counter()
    centre = v.last_ne
    due = time.perf_counter()
    while True:
        try:
            pos = await _send(v, due, centre)
        except MavsdkError:
            v.send_errors += 1
            pos = (math.nan, math.nan, math.nan)
        now = time.perf_counter()
        v.sends.append(now)
        if v.sampled:
            v.sent.append((_f32(pos[0]), _f32(pos[1]), _f32(pos[2])))
        due += period
        if due < now - period:  # more than a period behind: skip, never burst
            due = now
        await asyncio.sleep(max(due - now, 0.0))


class _LogSink:
    """Takes MAVSDK's log lines off stderr: counts them, keeps the warnings."""

    def __init__(self) -> None:
        self.warnings: Counter[str] = Counter()

    def __call__(self, level: Any, message: str, file: str | None, line: int) -> bool:
        if level.name in {"WARN", "ERROR"}:
            self.warnings[message.split("\n", maxsplit=1)[0][:70]] += 1
        return True


async def _discover(
    sdk: Any,
    wanted: dict[int, int],
    deadline: float,
    start: Callable[[int, int, Any], None],
    idle: float,
    phantoms: set[tuple[int, int]],
) -> None:
    """Start a vehicle for each wanted system (sysid -> port) MAVSDK discovers.

    Gives up at ``deadline``, or once no new system appeared for ``idle`` s.
    Systems with other sysids are only noted in ``phantoms`` (instance id, sysid).
    """
    known: set[int] = set()
    count, last_fetch, last_new = 0, -math.inf, time.perf_counter()
    while len(known) < len(wanted) and (now := time.perf_counter()) < min(
        deadline, last_new + idle
    ):
        new_count = await sdk.system_count()
        if new_count > count and (new_count >= len(wanted) or now - last_fetch > 0.5):
            count, last_fetch, last_new = new_count, now, now
            for system in await sdk.get_systems():  # fresh wrappers each call: fetch sparingly
                sysid = await system.get_system_id()
                if sysid not in wanted:
                    phantoms.add((id(sdk), sysid))
                elif sysid not in known:
                    known.add(sysid)
                    start(wanted[sysid], sysid, system)
        await asyncio.sleep(0.05)


async def _wait_for_setup(vehicles: list[_Vehicle], deadline: float, idle: float) -> None:
    """Until every vehicle flies or failed, the deadline, or ``idle`` s without a new flyer."""
    flying, progress = 0, time.perf_counter()
    while (now := time.perf_counter()) < min(deadline, progress + idle):
        pending = sum(v.flying_at is None and v.failure is None for v in vehicles)
        if not pending:
            return
        if (n := sum(v.flying_at is not None for v in vehicles)) > flying:
            flying, progress = n, now
        await asyncio.sleep(0.05)


@dataclass
class _Window:
    """What the measurement window saw, process-wide."""

    w0: float
    w1: float
    cpu_s: float
    threads0: dict[int, float]
    threads1: dict[int, float]
    mock_cores: float | None

    @property
    def wall(self) -> float:
        return self.w1 - self.w0


async def _measure(seconds: float, ports: list[int]) -> _Window:
    """Sleep through the window, taking CPU readings at both ends."""
    helpers = _helper_processes()  # MAVSDK 4.x has none; a mavsdk_server would be one
    mock = ports.cpu_s if isinstance(ports, MockPorts) else None
    mock0 = mock() if mock else 0.0
    threads0, w0 = _thread_cpu(), time.perf_counter()
    cpu0 = time.process_time() + sum(_stat_cpu_s(f"/proc/{p}/stat") for p in helpers)
    await asyncio.sleep(seconds)
    cpu1 = time.process_time() + sum(_stat_cpu_s(f"/proc/{p}/stat") for p in helpers)
    w1 = time.perf_counter()
    mock_cores = (mock() - mock0) / (w1 - w0) if mock else None
    return _Window(w0, w1, cpu1 - cpu0, threads0, _thread_cpu(), mock_cores)


async def run_mavsdk(
    ports: list[int],
    *,
    seconds: float,
    rate_hz: float = 20.0,
    setup_timeout: float = 120.0,
    latency_sample: int = 10,
    sysid_space: int | None = None,
    discovery_idle: float = 10.0,
) -> ClientResult:
    """Fly the mock fleet on ``ports`` through MAVSDK-Python and measure it.

    Args:
        ports: One mock vehicle per port. Port ``i`` has sysid ``i % per_process + 1``
            for :class:`MockPorts` (see :func:`start_mock_process`), else ``i + 1``.
        seconds: Measurement window, wall s, after setup.
        rate_hz: Setpoint rate per vehicle.
        setup_timeout: Wall s for discovery + arm + offboard; whoever flies by then
            is measured.
        latency_sample: Vehicles behind the tap, for the wire and latency figures (0: none).
        sysid_space: ``None``: one ``Mavsdk`` per sysid space of the mock, i.e.
            ONE for up to 250 vehicles (the issue's setup) and one per mock
            process beyond. ``0``: one ``Mavsdk`` for all ports regardless;
            MAVSDK keys systems by sysid, so vehicles sharing a sysid merge into
            one system and the others are never flown (reported, not raised).
            ``k`` (at most ``per_process``): one ``Mavsdk`` per ``k`` consecutive
            ports. Beyond ~30 instances MAVSDK runs out of MAVLink channels.
        discovery_idle: Stop waiting for systems, or for vehicles to fly, after this
            long without a new one.

    Returns:
        The measured row; failures are described in ``notes``, never raised.
    """
    import mavsdk
    from mavsdk import log_subscribe, log_unsubscribe
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.offboard import OffboardAsync
    from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync

    n = len(ports)
    per_space = ports.per_process if isinstance(ports, MockPorts) else n
    space = per_space if sysid_space is None else (sysid_space or n)
    # sysid -> port, per Mavsdk instance; the mock gives port i sysid i % per_space + 1
    shards = [
        {j % per_space + 1: ports[j] for j in range(i, min(i + space, n))}
        for i in range(0, n, space)
    ]
    sampled = ports[:: max(n // latency_sample, 1)][:latency_sample] if latency_sample else []
    notes: list[str] = []
    logs = _LogSink()
    t0 = time.perf_counter()
    deadline = t0 + setup_timeout
    vehicles: list[_Vehicle] = []
    tasks: list[asyncio.Task[None]] = []
    fly_tasks: dict[_Vehicle, asyncio.Task[None]] = {}
    sdks: list[Any] = []
    phantoms: set[tuple[int, int]] = set()
    tap = await _Tap.start(sampled) if sampled else None
    log_subscribe(logs)
    try:
        async with asyncio.TaskGroup() as tg:

            def start(port: int, sysid: int, system: Any) -> None:
                v = _Vehicle(sysid, port, system, port in sampled)
                v.telemetry, v.action = TelemetryAsync(system), ActionAsync(system)
                v.offboard = OffboardAsync(system)
                name = f"mavsdk[uav{sysid}@{port}]"
                tasks.append(tg.create_task(_watch_position(v), name=f"{name}.telemetry"))
                fly = tg.create_task(_fly(v, 1.0 / rate_hz, deadline), name=f"{name}.fly")
                tasks.append(fly)
                fly_tasks[v] = fly
                vehicles.append(v)

            for shard in shards:
                sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
                sdks.append(sdk)
                for port in shard.values():
                    via = tap.ports.get(port, port) if tap else port
                    await sdk.add_any_connection(f"udpout://127.0.0.1:{via}")
            await asyncio.gather(
                *(
                    _discover(sdk, shard, deadline, start, discovery_idle, phantoms)
                    for sdk, shard in zip(sdks, shards, strict=True)
                )
            )
            await _wait_for_setup(vehicles, deadline, discovery_idle)
            setup_s = time.perf_counter() - t0
            flying = [v for v in vehicles if v.flying_at is not None]
            last = max((v.flying_at for v in flying if v.flying_at), default=t0)
            notes.append(f"setup: {len(flying)} flying, the last after {last - t0:.1f}s")
            for v, fly in fly_tasks.items():  # stragglers' blocking calls would hog the executor
                if v.flying_at is None and v.failure is None:
                    v.failure = f"not flying when the window opened, at {v.stage}"
                    fly.cancel()
            window = await _measure(seconds, ports)
            records = await tap.dump() if tap else _TapRecords({}, {})
            for task in tasks:  # MAVSDK's own 20 Hz re-send keeps OFFBOARD alive meanwhile
                task.cancel()
            modes = await _final_modes(flying, FlightMode.OFFBOARD)
            await _stop_all(flying, notes)
    finally:
        await _destroy(sdks, notes)
        log_unsubscribe()  # after destroy, which logs too
        if tap:
            await tap.close()

    notes[:0] = [
        f"mavsdk_instances={len(sdks)}",
        f"discovered={len(vehicles)}/{n}",
        f"still_offboard_armed_at_end={modes}/{len(flying)}",
    ]
    if len(vehicles) < n and len(shards[0]) < min(space, n):
        notes.append("one Mavsdk merges vehicles that share a sysid: see sysid_space")
    if phantoms:
        notes.append(f"phantom systems (sysids nobody has) discovered={len(phantoms)}")
    failures = Counter(v.failure for v in vehicles if v.failure)
    if failures:
        notes.append("failures: " + ", ".join(f"{k} x{c}" for k, c in failures.most_common(4)))
    if logs.warnings:
        top = logs.warnings.most_common(4)
        notes.append("mavsdk warnings: " + ", ".join(f"{k!r} x{c}" for k, c in top))
    client = f"mavsdk-python {mavsdk.__version__}"
    if len(sdks) > 1:
        client += f" ({len(sdks)} Mavsdk)"
    return _summarize(client, n, setup_s, flying, window, records, notes)


def _wire_notes(flying: list[_Vehicle], window: _Window, rec: _TapRecords) -> str:
    """Setpoints on the wire for the vehicles behind the tap."""
    rates, dups, delays, gaps_p50, gaps_p99 = [], [], [], [], []
    for v in flying:
        wire = [(key, t) for key, t in rec.up.get(v.port, []) if window.w0 <= t <= window.w1]
        if not v.sampled or not wire:
            continue
        first: dict[tuple[float, float, float], float] = {}
        for key, t in wire:
            first.setdefault(key, t)
        rates.append(len(wire) / window.wall)
        dups.append(1.0 - len(first) / len(wire))
        ours = [
            (first[key], t)
            for key, t in zip(v.sent, v.sends, strict=False)
            if window.w0 <= t <= window.w1 and key in first
        ]
        delays += [(t_wire - t_call) * 1e3 for t_wire, t_call in ours]
        gaps = [(b - a) * 1e3 for (a, _), (b, _) in itertools.pairwise(ours)]
        gaps_p50.append(percentile(gaps, 50))
        gaps_p99.append(percentile(gaps, 99))
    if not rates:
        return "wire: not observed"
    return (
        f"wire ({len(rates)} tapped vehicles): setpoint datagrams {_median(rates):.1f}/s/vehicle"
        f" ({100 * _median(dups):.0f}% MAVSDK's own re-sends), call->wire"
        f" p50={percentile(delays, 50):.2f}ms p99={percentile(delays, 99):.1f}ms"
        f" max={max(delays, default=math.nan):.1f}ms, wire interval of our setpoints"
        f" p50={_median(gaps_p50):.1f}ms p99 max={max(gaps_p99, default=math.nan):.1f}ms"
    )


def _summarize(
    client: str,
    n: int,
    setup_s: float,
    flying: list[_Vehicle],
    window: _Window,
    records: _TapRecords,
    notes: list[str],
) -> ClientResult:
    """The result row from what the vehicles recorded during the window."""
    w0, w1, wall = window.w0, window.w1, window.wall
    per_rate, p50s, p99s, tel_hz, latencies = [], [], [], [], []
    for v in flying:
        sends = [t for t in v.sends if w0 <= t <= w1]
        gaps = [(b - a) * 1e3 for a, b in itertools.pairwise(sends)]
        per_rate.append(len(sends) / wall)
        p50s.append(percentile(gaps, 50))
        p99s.append(percentile(gaps, 99))
        tel_hz.append(sum(w0 <= t <= w1 for t in v.updates) / wall)
        for t, pos in zip(v.updates, v.positions, strict=False):
            handed = records.down.get((v.port, *pos))
            if w0 <= t <= w1 and handed is not None:
                latencies.append((t - handed) * 1e3)
    notes += [
        f"send_errors={sum(v.send_errors for v in flying)}",
        f"threads_in_window={len(window.threads1)}",
        f"executor_workers={min(32, (os.cpu_count() or 1) + 4)}",
        f"cores_by_thread: {_cpu_breakdown(window.threads0, window.threads1, wall)}",
        _wire_notes(flying, window, records),
    ]
    if window.mock_cores is not None:
        notes.append(f"mock_cores={window.mock_cores:.2f}")
    lat50 = lat99 = None
    if latencies:
        lat50, lat99 = percentile(latencies, 50), percentile(latencies, 99)
        notes.append(
            f"latency: {len(latencies)} frames of the tapped vehicles, from the frame"
            " entering MAVSDK's socket to the value in the coroutine"
        )
    else:
        notes.append("latency: not measured (no vehicle behind the tap flew)")
    return ClientResult(
        client=client,
        vehicles=n,
        flying=len(flying),
        setup_s=setup_s,
        seconds=wall,
        cores=window.cpu_s / wall,
        rate_hz_median=_median(per_rate),
        interval_p50_ms=_median(p50s),
        interval_p99_ms=max(p99s, default=math.nan),
        interval_p99_ms_median=_median(p99s),
        telemetry_hz_median=_median(tel_hz),
        telemetry_latency_p50_ms=lat50,
        telemetry_latency_p99_ms=lat99,
        notes="; ".join(notes),
    )


async def _final_modes(flying: list[_Vehicle], offboard_mode: Any) -> int:
    """How many vehicles are still armed in OFFBOARD (no setpoint-loss failsafe); -1: no answer."""

    async def one(v: _Vehicle) -> bool:
        mode = await v.telemetry.flight_mode()
        armed = await v.telemetry.armed()
        return bool(mode == offboard_mode and armed)

    try:
        async with asyncio.timeout(10.0):
            return sum(await asyncio.gather(*(one(v) for v in flying)))
    except TimeoutError:
        return -1


async def _stop_all(flying: list[_Vehicle], notes: list[str]) -> None:
    """``offboard.stop()`` (to Hold) for all, bounded: teardown must not hang."""
    from mavsdk.asyncio import MavsdkError

    async def one(v: _Vehicle) -> bool:
        try:
            await v.offboard.stop()
        except MavsdkError:
            return False
        return True

    t = time.perf_counter()
    try:
        async with asyncio.timeout(15.0):
            ok = sum(await asyncio.gather(*(one(v) for v in flying)))
    except TimeoutError:
        notes.append("offboard.stop: timed out after 15 s")
        return
    notes.append(f"offboard.stop ok={ok}/{len(flying)} in {time.perf_counter() - t:.1f}s")


async def _destroy(sdks: list[Any], notes: list[str]) -> None:
    """``Mavsdk.destroy()`` off the loop, in a daemon thread so a hang cannot pin the exit."""
    loop = asyncio.get_running_loop()
    done: asyncio.Future[None] = loop.create_future()

    def finish() -> None:
        if not done.done():
            done.set_result(None)

    def run() -> None:
        try:
            for sdk in sdks:
                sdk.destroy()
        finally:
            loop.call_soon_threadsafe(finish)

    t = time.perf_counter()
    threading.Thread(target=run, name="mavsdk.destroy", daemon=True).start()
    try:
        async with asyncio.timeout(30.0):
            await done
    except TimeoutError:
        notes.append("Mavsdk.destroy: still running after 30 s (left behind)")
        return
    notes.append(f"destroy {time.perf_counter() - t:.1f}s")


# -- command line --------------------------------------------------------------------


@contextlib.asynccontextmanager
async def _attached(base: int, n: int) -> AsyncIterator[MockPorts]:
    """An already running mock fleet on ``base ..``: nothing to start or stop."""
    yield MockPorts(list(range(base, base + n)), MOCK_MAX_AIRCRAFT)


async def _main(args: argparse.Namespace) -> None:
    for n in args.vehicles:
        fleet = _attached(args.attach, n) if args.attach else start_mock_process(n)
        async with fleet as ports:
            result = await run_mavsdk(
                ports,
                seconds=args.seconds,
                rate_hz=args.rate,
                setup_timeout=args.setup_timeout,
                latency_sample=args.latency_sample,
                sysid_space=args.sysid_space,
            )
        if args.json:
            print(json.dumps(asdict(result)), flush=True)
            continue
        print(f"N={n}\n{result.describe()}")
        for line in ports.status:
            print("  mock:", line)
        sys.stdout.flush()


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point: ``fleet_mavsdk.py [N ...]``; ``_tap`` is the internal tap mode."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["_tap"]:
        _tap_main([int(p) for p in argv[1:]])
        return
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    p.add_argument("vehicles", type=int, nargs="*", default=[10, 100])
    p.add_argument("--seconds", type=float, default=10.0, help="measured window, wall s")
    p.add_argument("--rate", type=float, default=20.0, help="setpoints per vehicle per s")
    p.add_argument("--setup-timeout", type=float, default=120.0, help="wall s")
    p.add_argument("--latency-sample", type=int, default=10, help="vehicles behind the tap")
    p.add_argument(
        "--sysid-space",
        type=int,
        metavar="K",
        help=f"one Mavsdk per K vehicles; 0: one for all (default: one per "
        f"{MOCK_MAX_AIRCRAFT}-vehicle sysid space)",
    )
    p.add_argument(
        "--attach",
        type=int,
        metavar="BASE_PORT",
        help=f"fly a mock fleet already running on BASE_PORT.. ({MOCK_MAX_AIRCRAFT} per process)",
    )
    p.add_argument("--json", action="store_true", help="one JSON object per result")
    asyncio.run(_main(p.parse_args(argv)))


if __name__ == "__main__":
    main()
