"""SetpointStreamer: mission-time deadlines, latest value, skipped ticks, real mock.

The first tests drive fake vehicles with a MissionClock fed by a fake autopilot
clock running ``speedup`` times faster than the wall (real asyncio time, no
sockets); the last one streams to three PX4 planes of the mock over UDP and
checks what the autopilots received.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import math
import statistics
import time
from collections.abc import AsyncIterator, Coroutine
from typing import TYPE_CHECKING, Any

import pytest

from convoy_mav.clock import MissionClock
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.streaming import MAX_WALL_HZ, MIN_RATE_HZ, IntervalStats, SetpointStreamer
from convoy_mav.types import Setpoint, VehicleStatus
from convoy_mav.vehicle import EventKind, Vehicle, VehicleEvent
from sitl_mock.config import MockConfig
from tests.hostspeed import host_speedup

if TYPE_CHECKING:
    from tests.conftest import StartMock

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]


class FakeVehicle:
    """Records what it is sent, with the wall time."""

    def __init__(self, sysid: int, status: VehicleStatus = VehicleStatus.FLYING) -> None:
        self.sysid = self.uid = sysid
        self.status = status
        self.setpoint_lead = 0.0
        self.sent: list[tuple[float, Setpoint]] = []

    def send_setpoint(self, sp: Setpoint) -> None:
        self.sent.append((time.monotonic(), sp))


@contextlib.asynccontextmanager
async def autopilot_clock(speedup: float) -> AsyncIterator[MissionClock]:
    """A MissionClock fed every 2 ms of wall by an autopilot clock at ``speedup``."""
    clock = MissionClock()
    t0 = time.monotonic()

    async def talk() -> None:
        while True:
            clock.observe(1000.0 * (5.0 + speedup * (time.monotonic() - t0)), 1)
            await asyncio.sleep(0.002)

    async with talking(clock, talk(), settle=0.1):
        yield clock


@contextlib.asynccontextmanager
async def talking(
    clock: MissionClock, talk: Coroutine[Any, Any, None], *, settle: float = 0.3
) -> AsyncIterator[None]:
    """An autopilot's ``talk`` feeding ``clock`` in the background; synced and its rate
    settled (``settle`` wall s) on entry."""
    task = asyncio.create_task(talk, name="test.autopilot")
    try:
        await clock.wait_synced()
        await asyncio.sleep(settle)
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


def setpoint(sysid: int, t: float) -> Setpoint:
    return Setpoint(t, float(sysid), 0.0, -40.0, 1.0, 0.0, 0.0, 0.0, 0.0)


@contextlib.asynccontextmanager
async def streaming(streamer: SetpointStreamer) -> AsyncIterator[None]:
    task = asyncio.create_task(streamer.run(), name="test.streamer")
    try:
        yield
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


@contextlib.asynccontextmanager
async def all_flying(
    links: list[MavLink], vehicles: dict[int, Vehicle], streamer: SetpointStreamer
) -> AsyncIterator[None]:
    """Links open, vehicles and streamer running, every vehicle FLYING (10 s at most)."""
    async with contextlib.AsyncExitStack() as stack:
        for link in links:
            await stack.enter_async_context(link)
        async with asyncio.TaskGroup() as tg:
            tasks = [tg.create_task(v.run()) for v in vehicles.values()]
            tasks.append(tg.create_task(streamer.run()))
            async with asyncio.timeout(10):
                while any(v.status is not VehicleStatus.FLYING for v in vehicles.values()):
                    await asyncio.sleep(0.01)
            yield
            for task in tasks:
                task.cancel()


async def mission_sleep(clock: MissionClock, seconds: float) -> None:
    await clock.sleep_until(clock.now() + seconds)


async def test_streams_on_mission_deadlines_to_flying_and_setting_up_only() -> None:
    vehicles = [
        FakeVehicle(1),
        FakeVehicle(2, VehicleStatus.SETTING_UP),
        FakeVehicle(3, VehicleStatus.HOLDING),
        FakeVehicle(4, VehicleStatus.LOST),
    ]
    calls: list[tuple[int, float]] = []

    def source(sysid: int, t: float) -> Setpoint:
        calls.append((sysid, t))
        return setpoint(sysid, t)

    async with autopilot_clock(20.0) as clock:
        streamer = SetpointStreamer(vehicles, source, clock, rate_hz=20.0)
        async with streaming(streamer):
            start = clock.now()
            await mission_sleep(clock, 10.0)
            duration = clock.now() - start
    expected = 20.0 * duration
    for v in vehicles[:2]:
        assert expected - streamer.missed - 3 <= len(v.sent) <= expected + 2
        assert [sp.north for _, sp in v.sent] == [float(v.sysid)] * len(v.sent)
    assert vehicles[2].sent == vehicles[3].sent == []
    assert {sysid for sysid, _ in calls} == {1, 2}
    times = [t for sysid, t in calls if sysid == 1]
    assert times == sorted(times)  # latest value: never an older instant
    stats = streamer.stats[1]
    assert stats.count == len(vehicles[0].sent)
    assert stats.mission.percentile(50) == pytest.approx(0.05, rel=0.15)
    assert stats.wall.percentile(50) == pytest.approx(0.05 / 20.0, rel=0.2)
    assert streamer.ticks >= len(vehicles[0].sent)


async def test_each_vehicle_is_sent_the_setpoint_for_when_it_will_fly_it() -> None:
    """A vehicle whose commands come back 0.4 s after they go (its ``setpoint_lead``)
    is sent the plan 0.4 mission s ahead; one on a quick link, the plan for now."""
    near, far = FakeVehicle(1), FakeVehicle(2)
    far.setpoint_lead = 0.4
    sent_at: dict[int, list[float]] = {1: [], 2: []}
    async with autopilot_clock(20.0) as clock:

        def source(sysid: int, t: float) -> Setpoint:
            sent_at[sysid].append(clock.now())
            return setpoint(sysid, t)

        streamer = SetpointStreamer([near, far], source, clock, rate_hz=20.0)
        async with streaming(streamer):
            await mission_sleep(clock, 3.0)
    for vehicle, lead in ((near, 0.0), (far, 0.4)):
        ahead = [
            sp.t - now for (_, sp), now in zip(vehicle.sent, sent_at[vehicle.uid], strict=True)
        ]
        assert ahead and max(abs(a - lead) for a in ahead) < 0.01


async def test_a_fast_simulator_gets_fewer_setpoints_per_mission_second() -> None:
    """At 80x, 20 Hz of mission time would be 1,600 sends a wall second: halved to
    10 Hz (800 a wall second), on steady deadlines, none missed."""
    vehicle = FakeVehicle(1)
    async with autopilot_clock(80.0) as clock:
        streamer = SetpointStreamer([vehicle], setpoint, clock, rate_hz=20.0)
        async with streaming(streamer):
            await mission_sleep(clock, 30.0)
    assert streamer.rate == 10.0 and streamer.period == pytest.approx(0.1)
    # Deadlines every 0.1 mission s, each sent or (on a loaded host) skipped. (One
    # wall millisecond of timer jitter is 0.08 mission s at 80x: single intervals
    # say little.)
    assert streamer.ticks + streamer.missed == pytest.approx(30.0 / 0.1, abs=5)
    assert len(vehicle.sent) == streamer.ticks
    assert 1.0 / streamer.stats[1].wall.mean <= MAX_WALL_HZ


@pytest.mark.parametrize(
    ("rate_hz", "speedup", "expected"),
    [
        (20.0, 1.0, 20.0),  # a real autopilot: as configured
        (20.0, 40.0, 20.0),  # 800 a wall second
        (20.0, 80.0, 10.0),
        (20.0, 1000.0, MIN_RATE_HZ),  # never below 5 Hz of mission time
        (2.0, 1000.0, 2.0),  # nor below a slower configured rate
        (100.0, 1.0, 100.0),
    ],
)
def test_the_rate_is_halved_only_while_a_vehicle_would_get_too_many(
    rate_hz: float, speedup: float, expected: float
) -> None:
    streamer = SetpointStreamer([], setpoint, MissionClock(), rate_hz=rate_hz)
    assert streamer.rate_for(speedup) == expected
    assert (
        SetpointStreamer([], setpoint, MissionClock(), rate_hz, max_wall_hz=None).rate_for(speedup)
        == rate_hz
    )


def test_the_rate_comes_back_only_with_room_to_spare() -> None:
    """Halved at 80x; 52x still keeps it halved (20 Hz would be 1,040 a wall
    second, over the cap), 36x doubles it back (720: under 75 % of the cap)."""
    streamer = SetpointStreamer([], setpoint, MissionClock(), rate_hz=20.0)
    streamer.rate = streamer.rate_for(80.0)
    assert streamer.rate == 10.0
    assert streamer.rate_for(52.0) == 10.0
    assert streamer.rate_for(48.0) == 10.0  # 960: under the cap, not with room
    assert streamer.rate_for(36.0) == 20.0
    with pytest.raises(ValueError, match="max_wall_hz"):
        SetpointStreamer([], setpoint, MissionClock(), max_wall_hz=0.0)


async def test_a_big_fleet_is_sent_in_slices_spread_over_the_period() -> None:
    """120 vehicles, 50 a slice: three slices a third of a period apart, each
    vehicle still once per period (but for deadlines skipped on a loaded host),
    at its own steady offset."""
    vehicles = [FakeVehicle(i) for i in range(1, 121)]
    async with autopilot_clock(1.0) as clock:
        streamer = SetpointStreamer(vehicles, setpoint, clock, rate_hz=10.0, slice_size=50)
        assert [len(group) for group in streamer.slices()] == [40, 40, 40]
        async with streaming(streamer):
            await mission_sleep(clock, 1.5)
    period = 0.1
    for v in vehicles:
        times = [sp.t for _, sp in v.sent]
        assert len(times) >= 12
        intervals = [b - a for a, b in itertools.pairwise(times)]
        assert all(dt > 0.5 * period for dt in intervals), v.uid  # never twice a period
        # A longer interval is a deadline the loop was too late for (a loaded host),
        # skipped and counted, never a vehicle left out of its slice.
        assert streamer.missed > 0 or all(dt < 1.5 * period for dt in intervals), v.uid
        slot = (v.uid - 1) % 3  # first seen in list order
        offsets = [math.remainder(t - slot * period / 3, period) for t in times]
        assert statistics.median(abs(x) for x in offsets) < 0.012, (v.uid, offsets)
        assert min(offsets) > -0.005, (v.uid, offsets)  # late on a loaded host, never early


def test_slices_keep_each_vehicle_in_place_as_the_fleet_grows() -> None:
    fleet = [FakeVehicle(i) for i in range(1, 61)]
    streamer = SetpointStreamer(fleet, setpoint, MissionClock(), slice_size=20, max_slices=4)
    before = {v.uid: i for i, group in enumerate(streamer.slices()) for v in group}
    assert sorted(before.values()).count(0) == 20  # 60 vehicles: 3 slices of 20
    fleet.extend(FakeVehicle(i) for i in range(61, 201))  # 200 vehicles: capped at 4 slices
    slices = streamer.slices()
    assert [len(group) for group in slices] == [50, 50, 50, 50]
    assert [v.uid for v in slices[1][:3]] == [2, 6, 10]  # rank % 4, in first-seen order


async def test_a_stalled_loop_skips_ticks_instead_of_bursting() -> None:
    vehicle = FakeVehicle(1)
    async with autopilot_clock(10.0) as clock:
        streamer = SetpointStreamer([vehicle], setpoint, clock, rate_hz=10.0)  # 10 ms of wall
        async with streaming(streamer):
            await mission_sleep(clock, 2.0)
            before = len(vehicle.sent)
            time.sleep(0.2)  # the loop is blocked for 20 ticks (2 mission s)
            stall_end = time.monotonic()
            await mission_sleep(clock, 0.05)  # half a period after the stall
            burst = [w for w, _ in vehicle.sent[before:] if w >= stall_end]
            await mission_sleep(clock, 2.0)
    assert streamer.missed >= 18
    assert len(burst) <= 2, "missed deadlines are skipped, not sent in a burst"
    # sends resume at the normal rate right after
    assert len(vehicle.sent) - before >= 15


async def test_a_stall_shows_as_the_widest_gap_between_rounds_until_taken() -> None:
    vehicle = FakeVehicle(1)
    async with autopilot_clock(10.0) as clock:
        streamer = SetpointStreamer([vehicle], setpoint, clock, rate_hz=10.0)
        async with streaming(streamer):
            await mission_sleep(clock, 1.0)
            on_time = streamer.take_widest_gap()
            time.sleep(0.15)  # the loop is blocked for 1.5 mission s
            await mission_sleep(clock, 0.5)
            stalled = streamer.take_widest_gap()
            await mission_sleep(clock, 0.5)
            after = streamer.take_widest_gap()
    assert 0.05 <= on_time < 0.5  # rounds a period (0.1 s) apart, give or take the loop
    assert stalled >= 1.4
    assert 0.05 <= after < 0.5  # taken: the stall is not reported twice
    assert streamer.widest_gap_s == pytest.approx(stalled)


@pytest.mark.parametrize("first", [2, 1])
async def test_a_fleet_heard_again_after_a_silence_is_no_late_round(first: int) -> None:
    """A radio dropout: neither autopilot is heard for 16-17 mission s; the mission clock
    runs on for its ``silence_cap`` (10 s) and waits. Heard again, it is taken anew (a
    step) from the other autopilot, or runs on from its line with the one it timed
    (1, no step: a silence, since the loop watched it stand). The rounds it could not
    time are not the host's lateness."""
    vehicle = FakeVehicle(1)
    clock = MissionClock(silence_cap=10.0)
    speedup = 20.0
    silent = {1: [math.inf, math.inf], 2: [math.inf, math.inf]}  # wall from, to
    t0 = time.monotonic()

    async def talk() -> None:
        while True:
            now = time.monotonic()
            for sysid, (begin, end) in silent.items():
                if not begin <= now < end:
                    clock.observe(1000.0 * (5.0 + sysid + speedup * (now - t0)), sysid)
            await asyncio.sleep(0.002)

    async with talking(clock, talk()):
        streamer = SetpointStreamer([vehicle], setpoint, clock, rate_hz=20.0)
        async with streaming(streamer):
            await asyncio.sleep(0.2)
            begin = time.monotonic()
            last = 3 - first
            silent[first][:] = [begin, begin + 0.8]  # 16 mission s unheard: heard first
            silent[last][:] = [begin, begin + 0.85]  # 17
            await asyncio.sleep(1.2)
    assert clock.resyncs == (first != 1)  # (1 is the reference)
    assert clock.silences == 1
    times = [sp.t for _, sp in vehicle.sent]
    assert max(b - a for a, b in itertools.pairwise(times)) > 4.0  # mission time stepped on
    # The step over the silence, taken for a late round, would be over 4 s; the loop's
    # own lateness on a busy host is what is left (a CI run beside the suite's other
    # worker: 1.04 mission s, 52 ms of wall time at 20x).
    assert streamer.widest_gap_s < 2.0


async def test_a_paused_simulator_steps_the_clock_and_streaming_goes_on() -> None:
    """The simulator stands still (its host stalled) while we keep running."""
    vehicle = FakeVehicle(1)
    clock = MissionClock()
    speedup = 20.0
    paused = [0.0, math.inf]  # total wall s paused, wall end of the current pause
    t0 = time.monotonic()

    def sim() -> float:
        wall = time.monotonic()
        return 5.0 + speedup * (min(wall, paused[1]) - t0 - paused[0])

    async def talk() -> None:
        while True:
            if time.monotonic() >= paused[1]:  # the pause is over
                paused[0] += 0.2
                paused[1] = math.inf
            if paused[1] == math.inf:
                clock.observe(1000.0 * sim(), 1)
            await asyncio.sleep(0.002)

    async with talking(clock, talk()):
        streamer = SetpointStreamer([vehicle], setpoint, clock, rate_hz=20.0)
        async with streaming(streamer):
            await asyncio.sleep(0.2)
            paused[1] = time.monotonic() + 0.2  # 4 s of sim time never happen
            await asyncio.sleep(0.6)
            assert abs(clock.now() - sim()) < 0.2
    assert clock.steps == 1
    assert streamer.widest_gap_s < 0.5  # (the step back is no gap between rounds)
    walls = [w for w, _ in vehicle.sent]
    gaps = [b - a for a, b in itertools.pairwise(walls)]
    # no pause in the stream: its rounds came well inside the simulator's 0.2-s pause
    # (2.5 ms apart; up to 22 ms on a loaded 2-core host beside another flight)
    assert max(gaps) < 0.1
    times = [sp.t for _, sp in vehicle.sent]
    assert min(times[i + 1] - times[i] for i in range(len(times) - 1)) < -2.0  # it stepped


async def test_a_failing_source_costs_only_its_own_vehicle() -> None:
    ok, bad, idle = FakeVehicle(1), FakeVehicle(2), FakeVehicle(3)

    def source(sysid: int, t: float) -> Setpoint | None:
        if sysid == 2:
            raise RuntimeError("no plan for 2")
        if sysid == 3:
            return None  # nothing to fly this tick
        return setpoint(sysid, t)

    async with autopilot_clock(20.0) as clock:
        streamer = SetpointStreamer([ok, bad, idle], source, clock)
        async with streaming(streamer):
            await mission_sleep(clock, 2.0)
    assert len(ok.sent) >= 30
    assert bad.sent == idle.sent == []
    assert streamer.errors >= 30
    assert 2 not in streamer.stats and 3 not in streamer.stats


async def test_streamer_waits_for_mission_time() -> None:
    vehicle = FakeVehicle(1)
    clock = MissionClock()
    streamer = SetpointStreamer([vehicle], setpoint, clock)
    async with streaming(streamer):
        await asyncio.sleep(0.05)
        assert vehicle.sent == [] and streamer.ticks == 0  # no vehicle heard: no time


def test_interval_stats() -> None:
    stats = IntervalStats(keep=4)
    for x in (0.05, 0.06, 0.04, 0.05, 0.07, 0.05):
        stats.add(x)
    assert stats.count == 6
    assert stats.mean == pytest.approx(0.32 / 6)
    assert stats.max == 0.07
    assert sorted(stats.samples()) == [0.04, 0.05, 0.05, 0.07]  # the last four
    assert stats.percentile(0) == 0.04
    assert stats.percentile(100) == 0.07
    assert stats.percentile(50) == pytest.approx(0.05)
    with pytest.raises(ValueError, match="rate_hz"):
        SetpointStreamer([], setpoint, MissionClock(), rate_hz=0.0)


async def test_three_px4_planes_get_every_setpoint(start_mock: StartMock) -> None:
    """Over UDP: the mock's counters agree with the streamer, at the rate asked."""
    n, speedup, rate = 3, host_speedup(20.0), 20.0
    config = MockConfig.simple(n, speedup=speedup, base_port=0, warmup=1.0, home_spacing=200.0)
    fleet = await start_mock(config, record_truth=True)
    clock = MissionClock(rate_hint=speedup)
    frame = LocalFrame(config.origin)
    events: list[VehicleEvent] = []
    vehicles: dict[int, Vehicle] = {}
    links: list[MavLink] = []
    for i in range(1, n + 1):
        link = MavLink(fleet.endpoint(i).connect, lambda m, i=i: vehicles[i].handle(m))  # type: ignore[misc]
        links.append(link)
        vehicles[i] = Vehicle(
            i, link, clock, frame, on_event=events.append, altitude=40.0 + 10.0 * i
        )

    def source(sysid: int, t: float) -> Setpoint:  # straight and level, northbound
        tel = vehicles[sysid].telemetry
        east = tel.east if tel is not None else 0.0
        return Setpoint(t, 18.0 * t, east, -40.0 - 10.0 * sysid, 18.0, 0.0, 0.0, 0.0, 0.0)

    streamer = SetpointStreamer(vehicles.values(), source, clock, rate_hz=rate)
    async with all_flying(links, vehicles, streamer):
        before = {i: fleet.counters(i)["setpoint"] for i in vehicles}
        sent_before = {i: streamer.stats[i].count for i in vehicles}
        t0 = clock.now()
        await fleet.wait_until(fleet.now + 20.0)
        duration = clock.now() - t0
        received = {i: fleet.counters(i)["setpoint"] - before[i] for i in vehicles}
        sent = {i: streamer.stats[i].count - sent_before[i] for i in vehicles}
    # with the fix awaited first, PX4 accepts OFFBOARD and arming at the first try
    assert not [e for e in events if e.kind is EventKind.REFUSED]
    for i in vehicles:
        assert received[i] >= sent[i] - 2  # all but those still in flight arrived
        assert sent[i] >= rate * duration - streamer.missed - 2
        s = streamer.stats[i]
        print(
            f"\nuav{i}: {sent[i]} setpoints in {duration:.1f} mission s, mock got {received[i]}; "
            f"mission interval p50 {1000 * s.mission.percentile(50):.1f} ms "
            f"p99 {1000 * s.mission.percentile(99):.1f} ms; wall p50 "
            f"{1000 * s.wall.percentile(50):.2f} ms p99 {1000 * s.wall.percentile(99):.2f} ms; "
            f"missed ticks {streamer.missed}/{streamer.ticks}"
        )
        assert s.mission.percentile(50) == pytest.approx(1.0 / rate, rel=0.1)
    assert fleet.history is not None
    late = [r for r in fleet.history.rows if r.t > fleet.now - 10.0]
    assert late and all(r.mode == "OFFBOARD" and r.armed for r in late)


async def test_two_autopilots_with_the_same_sysid_are_two_uavs(start_mock: StartMock) -> None:
    """Two PX4s both left at sysid 1 (two mock processes): one link and one uid each."""
    speedup = 20.0
    fleets = [
        await start_mock(MockConfig.simple(1, speedup=speedup, base_port=0, warmup=1.0))
        for _ in range(2)
    ]
    clock = MissionClock(rate_hint=speedup)
    frame = LocalFrame(fleets[0].config.origin)
    vehicles: dict[int, Vehicle] = {}
    links = [
        MavLink(fleet.endpoint(1).connect, lambda m, uid=uid: vehicles[uid].handle(m))  # type: ignore[misc]
        for uid, fleet in enumerate(fleets, start=1)
    ]
    telemetry: list[int] = []
    for uid, link in enumerate(links, start=1):
        vehicles[uid] = Vehicle(
            1, link, clock, frame, uid=uid, on_telemetry=lambda tel: telemetry.append(tel.sysid)
        )

    def source(uid: int, t: float) -> Setpoint:
        return Setpoint(t, 18.0 * t, 100.0 * uid, -40.0, 18.0, 0.0, 0.0, 0.0, 0.0)

    streamer = SetpointStreamer(vehicles.values(), source, clock, rate_hz=20.0)
    async with all_flying(links, vehicles, streamer):
        await fleets[0].wait_until(fleets[0].now + 5.0)
    assert set(streamer.stats) == {1, 2}
    for uid, fleet in enumerate(fleets, start=1):
        assert fleet.counters(1)["setpoint"] >= streamer.stats[uid].count - 2 > 50
    assert set(telemetry) == {1, 2}
    assert clock.reboots == 0  # two boot clocks under one sysid were not mistaken for reboots
