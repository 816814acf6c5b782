"""convoy-mav's side of the fleet benchmark: its own flight loop for N autopilots.

What runs is the service's bridge exactly as ``ConvoyService`` wires it: one
:class:`~convoy_mav.mavlink.MavLink` (asyncio UDP, pymavlink codec) and one
:class:`~convoy_mav.vehicle.Vehicle` driver per autopilot (heartbeat, stream
requests, PX4 set-up: setpoints first, OFFBOARD, arm; liveness), one
:class:`~convoy_mav.streaming.SetpointStreamer` for the whole fleet sampling the
paper's stationary plan for N UAVs at 20 Hz of mission time, and the coverage
:class:`~convoy_mav.monitor.Monitor` as the service feeds it: each position
update scored against the plan as it arrives, coverage on the 10 Hz control
tick. What is
left out is the mission layer's joins (an N x N slot assignment, minutes at
N = 1000; ``benchmarks/bench_planning.py`` measures planning): every UAV flies
its plan slot from wherever it is.

Measured over a window once every vehicle flies: CPU seconds of this process
per wall second, each vehicle's achieved setpoint rate and inter-send interval
(wall time right after the ``sendto``), and the telemetry-to-monitor latency:
wall time from a GLOBAL_POSITION_INT being decoded to the monitor tick that
uses it (the tick period bounds it: the monitor samples, it is not woken per
packet).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import statistics
import time
from typing import Any

from fleet_mavsdk import ClientResult, MockPorts

import convoy_mav
from convoy_mav.clock import MissionClock
from convoy_mav.eventloop import loop_name
from convoy_mav.gcpolicy import collect_on_schedule, flight_gc
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.monitor import Monitor
from convoy_mav.planning import PlanRequest, make_plan
from convoy_mav.schedule import POSITION_AT_HORIZON_S, position_at, setpoint_at
from convoy_mav.streaming import SetpointStreamer, percentile
from convoy_mav.types import ConvoyEstimate, Setpoint, Telemetry, VehicleStatus
from convoy_mav.vehicle import Vehicle

__all__ = ["run_convoy_mav"]

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)  # sitl_mock's default world origin
CONTROL_HZ = 10.0  # ConvoyService's control (monitor) tick


async def run_convoy_mav(
    ports: MockPorts,
    *,
    seconds: float,
    rate_hz: float = 20.0,
    setup_timeout: float = 120.0,
) -> ClientResult:
    """Fly the ``len(ports)`` mock PX4 planes and measure.

    UAV ``uid = i + 1`` is the plane on ``ports[i]``; beyond one mock process its
    MAVLink sysid repeats (``i % ports.per_process + 1``): one link, one UAV.
    """
    n = len(ports)
    clock = MissionClock(rate_hint=1.0)
    frame = LocalFrame(ORIGIN)
    vehicles: dict[int, Vehicle] = {}
    decoded: dict[int, float] = {}  # sysid -> wall time its latest position was decoded
    received = dict.fromkeys(range(1, n + 1), 0)  # positions decoded per vehicle
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0, uavs=n))
    monitor = Monitor(100.0, step=1.0 / CONTROL_HZ)

    def source(sysid: int, t: float) -> Setpoint:
        return setpoint_at(plan, sysid - 1, t, plan_origin=(0.0, 0.0), plan_t0=0.0, down=-100.0)

    def on_telemetry(tel: Telemetry) -> None:  # as ConvoyService._track
        monitor.fix(tel)
        planned = vehicles[tel.sysid].last_setpoint
        if planned is None or planned.hold or abs(tel.t - planned.t) > POSITION_AT_HORIZON_S:
            planned = source(tel.sysid, tel.t)
        monitor.track(tel, *position_at(planned, tel.t))
        decoded[tel.sysid] = time.perf_counter()
        received[tel.sysid] = received.get(tel.sysid, 0) + 1

    start = time.perf_counter()
    async with contextlib.AsyncExitStack() as stack:
        for i, port in enumerate(ports):
            uid = i + 1
            link = await stack.enter_async_context(
                MavLink(f"udpout:127.0.0.1:{port}", _Deliver(vehicles, uid), name=f"uav{uid}")
            )
            vehicles[uid] = Vehicle(
                i % ports.per_process + 1,
                link,
                clock,
                frame,
                uid=uid,
                on_telemetry=on_telemetry,
                setup_timeout=setup_timeout,
                altitude=100.0,
            )
        streamer = SetpointStreamer(list(vehicles.values()), source, clock, rate_hz)
        stack.enter_context(flight_gc())  # as ConvoyService does once its links are up
        tasks = [asyncio.create_task(v.run(), name=f"{v.name}.run") for v in vehicles.values()]
        tasks.append(asyncio.create_task(streamer.run(), name="bench.stream"))
        tasks.append(asyncio.create_task(collect_on_schedule(), name="bench.gc"))
        try:
            deadline = start + setup_timeout
            while time.perf_counter() < deadline and not all(
                v.status is VehicleStatus.FLYING for v in vehicles.values()
            ):
                await asyncio.sleep(0.1)
            setup_s = time.perf_counter() - start
            flying = sum(v.status is VehicleStatus.FLYING for v in vehicles.values())
            window = await _measure(clock, vehicles, streamer, monitor, decoded, received, seconds)
        finally:
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)
    sent, wall_s, cpu_s, latencies, telemetry_counts = window
    rates = [sent.get(s, 0) / wall_s for s in vehicles]
    p50 = [st.wall.percentile(50) for st in streamer.stats.values() if st.wall.count]
    p99 = [st.wall.percentile(99) for st in streamer.stats.values() if st.wall.count]
    return ClientResult(
        client=f"convoy-mav {convoy_mav.__version__} ({loop_name(asyncio.get_running_loop())})",
        vehicles=n,
        flying=flying,
        setup_s=setup_s,
        seconds=wall_s,
        cores=cpu_s / wall_s,
        rate_hz_median=statistics.median(rates) if rates else math.nan,
        interval_p50_ms=1e3 * statistics.median(p50) if p50 else math.nan,
        interval_p99_ms=1e3 * max(p99) if p99 else math.nan,
        interval_p99_ms_median=1e3 * statistics.median(p99) if p99 else math.nan,
        telemetry_hz_median=statistics.median(telemetry_counts) / wall_s,
        telemetry_latency_p50_ms=1e3 * percentile(latencies, 50) if latencies else None,
        telemetry_latency_p99_ms=1e3 * percentile(latencies, 99) if latencies else None,
        notes=(
            f"monitor tick {CONTROL_HZ:g} Hz; joins not run (see fleet_convoy.py); "
            f"clock steps {clock.steps}, missed ticks {streamer.missed}"
        ),
    )


class _Deliver:
    """A link's messages go to its own vehicle (system ids may repeat across links)."""

    def __init__(self, vehicles: dict[int, Vehicle], uid: int) -> None:
        self.vehicles = vehicles
        self.uid = uid

    def __call__(self, msg: Any) -> None:
        self.vehicles[self.uid].handle(msg)


async def _measure(
    clock: MissionClock,
    vehicles: dict[int, Vehicle],
    streamer: SetpointStreamer,
    monitor: Monitor,
    decoded: dict[int, float],
    received: dict[int, int],
    seconds: float,
) -> tuple[dict[int, int], float, float, list[float], list[int]]:
    """Run the monitor tick for ``seconds`` of wall time; return what was measured."""
    convoy = ConvoyEstimate(clock.now(), 0.0, 0.0, 0.0, 0.0)
    monitor.start_protect(clock.now())
    streamer.stats.clear()
    used: dict[int, float] = {}  # sysid -> decode time of the position the monitor last used
    latencies: list[float] = []
    received.update(dict.fromkeys(received, 0))
    cpu0, wall0 = time.process_time(), time.perf_counter()
    t = clock.now()
    while time.perf_counter() - wall0 < seconds:
        await clock.sleep_until(t + 1.0 / CONTROL_HZ)
        t = clock.now()
        telemetry = {s: v.telemetry for s, v in vehicles.items() if v.telemetry is not None}
        monitor.update(t, convoy, telemetry)
        now = time.perf_counter()
        for sysid in telemetry:
            seen = decoded.get(sysid)
            if seen is not None and seen != used.get(sysid) and seen >= wall0:
                latencies.append(now - seen)
                used[sysid] = seen
    wall_s = time.perf_counter() - wall0
    cpu_s = time.process_time() - cpu0
    sent = {s: st.count for s, st in streamer.stats.items()}
    return sent, wall_s, cpu_s, latencies, list(received.values())
