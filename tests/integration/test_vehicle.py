"""Vehicle + SetpointStreamer over real UDP against sitl_mock, per firmware.

For a PX4 plane, an ArduCopter and an ArduPlane: the Vehicle recognises the
firmware, starts setting up during the mock's warm-up (``fix_timeout=0``) so
the refusals and their STATUSTEXT reasons are exercised and reported, reaches
FLYING; the streamer flies a circle whose phase starts 40 degrees off; the
mock's ground truth must show the aircraft on the circle (radius within a few
per cent) and -- the planes through the speed correction -- converged in phase.
Then ``hold()`` makes it loiter (truth mode AUTO.LOITER / LOITER), ``resume()``
re-engages it, and a killed vehicle is declared LOST within ``lost_after``
mission seconds.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import re
import time
from collections.abc import AsyncIterator, Callable, Coroutine
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock
from convoy_mav.config import SafetyConfig
from convoy_mav.fence import fence_items
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.mavlink.autopilots import FLIGHT_STREAM_RATES
from convoy_mav.streaming import SetpointStreamer
from convoy_mav.types import Setpoint, Telemetry, VehicleStatus
from convoy_mav.vehicle import EventKind, Vehicle, VehicleEvent
from sitl_mock.autopilot import Personality
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet
from tests.fakes import make_vehicle
from tests.hostspeed import host_speedup

if TYPE_CHECKING:
    from tests.conftest import StartMock

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

SPEEDUP = host_speedup(40.0)  # (a fixed 40x failed on this 2-core host in a slow hour)
WARMUP = 6.0
ALTITUDE = 40.0
LOST_AFTER = 3.0


@dataclass(frozen=True)
class Circle:
    """A constant circle as a setpoint source (mission frame, started at ``t0``)."""

    north: float
    east: float
    radius: float
    speed: float
    clockwise: bool
    phase: float  # bearing from the centre at t0, rad clockwise from north
    t0: float

    def bearing(self, t: float) -> float:
        sign = 1.0 if self.clockwise else -1.0
        return self.phase + sign * self.speed / self.radius * (t - self.t0)

    def at(self, t: float) -> Setpoint:
        b = self.bearing(t)
        sign = 1.0 if self.clockwise else -1.0
        vn, ve = -sign * self.speed * math.sin(b), sign * self.speed * math.cos(b)
        return Setpoint(
            t, self.north + self.radius * math.cos(b), self.east + self.radius * math.sin(b),
            -ALTITUDE, vn, ve, 0.0, math.atan2(ve, vn), sign * self.speed / self.radius,
            center=(self.north, self.east), radius=self.radius, clockwise=self.clockwise,
        )  # fmt: skip

    def radial_error(self, north: float, east: float) -> float:
        return math.hypot(north - self.north, east - self.east) - self.radius

    def phase_lag(self, t: float, north: float, east: float) -> float:
        """Metres (along the circle) the aircraft trails the reference; < 0 ahead."""
        sign = 1.0 if self.clockwise else -1.0
        own = math.atan2(east - self.east, north - self.north)
        return sign * self.radius * math.remainder(self.bearing(t) - own, math.tau)


class CircleSource:
    """Streams a circle; once the aircraft is up, a circle through it with the
    reference 40 degrees ahead (the phase the speed correction has to make up)."""

    def __init__(self, vehicle: Vehicle, radius: float, speed: float, clockwise: bool) -> None:
        self.vehicle = vehicle
        self.radius, self.speed, self.clockwise = radius, speed, clockwise
        self.circle: Circle | None = None
        self.pre = Circle(0.0, 0.0, radius, speed, clockwise, 0.0, 0.0)

    def __call__(self, sysid: int, t: float) -> Setpoint | None:
        tel = self.vehicle.telemetry
        if self.circle is None:
            up = tel is not None and -tel.down > 0.6 * ALTITUDE
            if self.vehicle.status is not VehicleStatus.FLYING or tel is None or not up:
                return self.pre.at(t)  # set-up and climb-out: any live setpoint
            sign = 1.0 if self.clockwise else -1.0
            course = math.atan2(tel.ve, tel.vn)
            to_centre = course + sign * math.pi / 2
            cn = tel.north + self.radius * math.cos(to_centre)
            ce = tel.east + self.radius * math.sin(to_centre)
            own = math.atan2(tel.east - ce, tel.north - cn)
            ahead = own + sign * math.radians(40.0)
            self.circle = Circle(cn, ce, self.radius, self.speed, self.clockwise, ahead, t)
        return self.circle.at(t)


@contextlib.asynccontextmanager
async def running(*coros: Coroutine[Any, Any, None]) -> AsyncIterator[None]:
    async with asyncio.TaskGroup() as tg:
        tasks = [tg.create_task(c) for c in coros]
        try:
            yield
        finally:
            for task in tasks:
                task.cancel()


async def until(done: Callable[[], bool], timeout: float) -> None:
    async with asyncio.timeout(timeout):
        while not done():
            await asyncio.sleep(0.005)


def has_status(vehicle: Vehicle, status: VehicleStatus) -> bool:
    return vehicle.status is status  # (a function: mypy would keep an earlier narrowing)


async def sim_sleep(fleet: MockFleet, seconds: float) -> None:
    await fleet.wait_until(fleet.now + seconds)


async def clock_agrees(clock: MissionClock, fleet: MockFleet, within: float) -> None:
    """The mission clock reads the mock's time within ``within`` mission s, within a
    wall second: a slip of the mock's (its clock pausing while its host stalls) is a
    step that the clock follows only once a run of packets confirms it."""
    await until(lambda: abs(clock.now() - fleet.now) < within, timeout=1.0)


@pytest.mark.parametrize(
    ("personality", "frame", "hold_mode", "refusal"),
    [
        # a PX4 plane arms first (then NAV_TAKEOFF, then OFFBOARD): refused until warm
        ("px4", "plane", "AUTO.LOITER", "Arming denied! No valid global position estimate"),
        ("ardupilot", "copter", "LOITER", "Mode change to GUIDED failed"),
        # ArduPlane: TKOFF_ALT, then TAKEOFF mode (refused until warm), arm, climb, GUIDED
        ("ardupilot", "plane", "LOITER", "Mode change to TAKEOFF failed"),
    ],
)
async def test_set_up_fly_a_circle_hold_and_lose(
    start_mock: StartMock, personality: str, frame: str, hold_mode: str, refusal: str
) -> None:
    plane = frame == "plane"
    v, r_min = (18.0, 80.0) if plane else (12.0, 30.0)
    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality=personality, frame=frame,
        airspeed=v, turn_radius=r_min, warmup=WARMUP, setpoint_timeout=2.0,
    )  # fmt: skip
    fleet = await start_mock(config, record_truth=True)
    mission = LocalFrame(config.origin)
    clock = MissionClock()  # no rate hint: the speedup is measured
    events: list[VehicleEvent] = []
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(
        1, link, clock, mission, on_event=events.append, altitude=ALTITUDE,
        fix_timeout=0.0, lost_after=LOST_AFTER, setup_timeout=60.0,
    )  # fmt: skip
    radius, speed = (1.3 * r_min, v) if plane else (2.5 * r_min, 0.8 * v)
    source = CircleSource(vehicle, radius, speed, clockwise=personality != "ardupilot")
    streamer = SetpointStreamer([vehicle], source, clock, rate_hz=20.0)

    async with link, running(vehicle.run(), streamer.run()):
        await until(lambda: vehicle.status is VehicleStatus.FLYING, timeout=15)
        t_flying = fleet.now
        # -- set-up: started during warm-up, refused with the autopilot's reason, retried
        assert vehicle.firmware is not None
        refused = [e for e in events if e.kind is EventKind.REFUSED]
        assert refused, [e.message for e in events]
        assert refusal in refused[0].message and "UAV 1" in refused[0].message
        # back-off: 1, 2, 4 s... (ARM 1, 2, 2 s...); a refusal said again only 10 s on
        assert len(refused) <= vehicle.counters["refused"] <= 10
        statuses = [e.message.split(": ")[-1] for e in events if e.kind is EventKind.STATUS]
        assert statuses[-3:] == ["waiting_fix", "setting_up", "flying"]
        assert WARMUP <= t_flying < WARMUP + 25.0  # every aircraft takes off first
        # -- the mission clock follows the autopilot's (its rate too, once a slip of the
        # mock's has been followed: the line restarts from the packets after it)
        await clock_agrees(clock, fleet, within=0.25)
        await until(lambda: abs(clock.rate / SPEEDUP - 1.0) < 0.03, timeout=1.0)

        # -- flying: position as before, the set-up-only streams slowed to a watch
        await sim_sleep(fleet, 1.0)
        sim = fleet.vehicles[1]
        for msg_id, hz in FLIGHT_STREAM_RATES.items():
            assert sim.message_interval_us(msg_id) == round(1e6 / hz), msg_id

        # -- fly: climb-out (planes), then four laps from 40 degrees behind
        await until(lambda: source.circle is not None, timeout=5)
        circle = source.circle
        assert circle is not None
        lap = 2 * math.pi * radius / speed
        await sim_sleep(fleet, 4.0 * lap)
        t_end = fleet.now

        # -- truth: on the circle, in phase (the planes via their speed)
        assert fleet.history is not None
        rows = [r for r in fleet.history.of(1) if r.t > t_end - lap]
        assert len(rows) > 20
        radial = [circle.radial_error(r.north, r.east) / radius for r in rows]
        lag = [circle.phase_lag(r.t, r.north, r.east) for r in rows]
        print(  # measured numbers for the report
            f"\n{personality} {frame}: flying at {t_flying:.1f} s, refusals {len(refused)}, "
            f"radial mean {100 * sum(radial) / len(radial):+.2f} % max "
            f"{100 * max(map(abs, radial)):.2f} %, phase lag last lap mean "
            f"{sum(lag) / len(lag):+.1f} m max {max(map(abs, lag)):.1f} m, "
            f"clock rate {clock.rate:.2f} err {clock.now() - fleet.now:+.3f} s, "
            f"streamer missed {streamer.missed}"
        )
        assert abs(sum(radial) / len(radial)) < 0.03
        assert max(abs(x) for x in radial) < 0.06
        assert max(abs(x) for x in lag) < 0.01 * 2 * math.pi * radius
        if plane:  # the 40 degrees were made up by flying faster, within +15 %
            joining = [r.speed for r in fleet.history.of(1) if circle.t0 < r.t < circle.t0 + lap]
            assert 1.1 * v < max(joining) <= 1.15 * v + 0.01
        assert all(abs(r.down + ALTITUDE) < 2.0 for r in rows)
        assert all(r.armed and r.mode == vehicle.firmware.external_mode for r in rows)
        # a plane's speed range was asked for and read, its minimum and maximum
        # airspeed: the circle is inside it (ArduCopter has none on GUIDED targets)
        ap = vehicle.firmware
        assert ap.speed_limit == (pytest.approx(1.5 * v) if plane else None)
        assert ap.speed_floor == (pytest.approx(0.6 * v) if plane else None)
        assert ap.cannot_fly(speed) is None

        # -- hold: loiter where it is
        assert await vehicle.hold()
        assert vehicle.status is VehicleStatus.HOLDING
        await sim_sleep(fleet, 2.0)
        assert fleet.truth(1).mode == hold_mode
        assert vehicle.mode == hold_mode
        sent = vehicle.counters["setpoints"]
        await sim_sleep(fleet, 1.0)
        assert vehicle.counters["setpoints"] == sent  # nothing streamed while holding

        # -- resume: set up again (armed and airborne already: mode only), fly setpoints
        takeoffs = vehicle.counters["commands"]
        vehicle.resume()
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=5)
        assert vehicle.counters["commands"] - takeoffs == 1  # just the mode
        await sim_sleep(fleet, 1.0)
        assert fleet.truth(1).mode == vehicle.firmware.external_mode
        assert vehicle.counters["setpoints"] > sent

        # -- liveness: killed -> LOST after lost_after mission seconds
        t_kill = clock.now()
        fleet.kill(1)
        await until(lambda: has_status(vehicle, VehicleStatus.LOST), timeout=5)
        lost = [e for e in events if e.kind is EventKind.LOST and e.t >= t_kill]
        assert len(lost) == 1
        # A stall of the whole test process (this machine is shared) pauses the
        # in-process mock's clock while the mission clock runs on for a moment:
        # a loss declared then must have been recovered from, as flying on shows.
        early = [e for e in events if e.kind is EventKind.LOST and e.t < t_kill]
        assert len(early) <= sum(e.kind is EventKind.RECOVERED for e in events)
        # silence counts from the last message heard (a telemetry period before
        # the kill at most); the watchdog looks at that instant, not at a poll
        assert LOST_AFTER - 0.3 <= lost[0].t - t_kill < LOST_AFTER + 1.0


async def test_keepalive_holds_offboard_when_the_setpoints_stop(start_mock: StartMock) -> None:
    """PX4 leaves OFFBOARD after 1 s without setpoints: the vehicle keeps the stream
    alive on its own (a hold where the last setpoint was) until the source is back."""
    config = MockConfig.simple(1, speedup=SPEEDUP, base_port=0, warmup=1.0, setpoint_timeout=1.0)
    fleet = await start_mock(config)
    clock = MissionClock()
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(1, link, clock, LocalFrame(config.origin), altitude=ALTITUDE, fix_timeout=0.0)

    def source(uid: int, t: float) -> Setpoint:  # straight and level, northbound
        return Setpoint(t, 18.0 * t, 0.0, -ALTITUDE, 18.0, 0.0, 0.0, 0.0, 0.0)

    streamer = SetpointStreamer([vehicle], source, clock, rate_hz=20.0)
    async with link, running(vehicle.run()):
        stream = asyncio.create_task(streamer.run())
        await until(lambda: vehicle.status is VehicleStatus.FLYING, timeout=15)
        fed, breaks = vehicle.counters["keepalive"], clock.breaks  # (set-up streams first)
        await sim_sleep(fleet, 1.0)
        # nothing of its own while fed, but at a break of mission time (a host stall)
        assert vehicle.counters["keepalive"] - fed <= clock.breaks - breaks
        stream.cancel()
        before = fleet.counters(1)["setpoint"]
        await sim_sleep(fleet, 6.0)
        own = vehicle.counters["keepalive"] - fed
        assert 6.0 * 2.0 < own <= 6.0 / 0.3 + 2  # one per keepalive (0.3 s): above PX4's 2 Hz
        assert fleet.counters(1)["setpoint"] - before >= own - 1
        assert fleet.truth(1).mode == "OFFBOARD" and vehicle.status is VehicleStatus.FLYING


async def test_keepalive_holds_offboard_across_a_host_stall(start_mock: StartMock) -> None:
    """The host stalls just as the setpoints stop (the whole process: the mock and the
    service). The mock slips its clock, mission time steps back to it, and the last
    setpoint's stamp lies ahead of the autopilot's clock: the keepalive must not wait
    for it, or PX4's 1-s COM_OF_LOSS_T fails safe (the stall, 2.5 mission s, exceeds
    the mock's catch-up, so a step is taken every time)."""
    config = MockConfig.simple(1, speedup=SPEEDUP, base_port=0, warmup=1.0, setpoint_timeout=1.0)
    fleet = await start_mock(config)
    clock = MissionClock()
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(1, link, clock, LocalFrame(config.origin), altitude=ALTITUDE, fix_timeout=0.0)

    def source(uid: int, t: float) -> Setpoint:
        return Setpoint(t, 18.0 * t, 0.0, -ALTITUDE, 18.0, 0.0, 0.0, 0.0, 0.0)

    streamer = SetpointStreamer([vehicle], source, clock, rate_hz=20.0)
    async with link, running(vehicle.run()):
        stream = asyncio.create_task(streamer.run())
        await until(lambda: vehicle.status is VehicleStatus.FLYING, timeout=15)
        await sim_sleep(fleet, 1.0)
        steps, slips = clock.steps, fleet.clock.slips
        stream.cancel()
        time.sleep(2.5 / SPEEDUP)  # the stall: nothing runs meanwhile
        await sim_sleep(fleet, 3.0)
        assert fleet.clock.slips > slips and clock.steps > steps  # (the stall was one)
        assert fleet.truth(1).mode == "OFFBOARD" and vehicle.status is VehicleStatus.FLYING


async def test_gives_up_with_the_autopilots_reason(start_mock: StartMock) -> None:
    """Set-up that cannot succeed ends FAILED, naming the vehicle and the last refusal."""
    config = MockConfig.simple(1, ground=1, speedup=SPEEDUP, base_port=0, warmup=1000.0)
    fleet = await start_mock(config)
    clock = MissionClock(rate_hint=SPEEDUP)
    events: list[VehicleEvent] = []
    vehicles: dict[int, Vehicle] = {}
    links = [
        MavLink(fleet.endpoint(i).connect, lambda m, i=i: vehicles[i].handle(m))  # type: ignore[misc]
        for i in (1, 2)
    ]
    for i, link in zip((1, 2), links, strict=True):
        vehicles[i] = Vehicle(
            i, link, clock, LocalFrame(config.origin), on_event=events.append,
            setup_timeout=8.0, fix_timeout=0.0, max_backoff=2.0,
        )  # fmt: skip
    async with links[0], links[1], running(*(v.run() for v in vehicles.values())):
        await until(lambda: all(v.status is VehicleStatus.FAILED for v in vehicles.values()), 5)
    plane, rover = vehicles[1].failure, vehicles[2].failure
    assert plane is not None and rover is not None
    assert plane.startswith("UAV 1 (PX4 plane): set-up gave up after 8 s at step 'arm'")
    assert "'Arming denied! No valid global position estimate'" in plane
    assert "TEMPORARILY_REJECTED" in plane
    assert rover.startswith("UAV 2: MAV_AUTOPILOT_PX4 with vehicle type 10 is not supported")
    failed = [e for e in events if e.kind is EventKind.FAILED]
    assert {e.sysid for e in failed} == {1, 2}
    assert all(e.severity == 3 for e in failed)  # MAV_SEVERITY_ERROR


async def test_lost_then_rebooted_vehicle_is_set_up_again(start_mock: StartMock) -> None:
    """Killed -> LOST; rebooted (it comes back disarmed, streams off) -> set up anew."""
    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality="ardupilot", frame="copter",
        airspeed=12.0, turn_radius=30.0, warmup=2.0,
    )  # fmt: skip
    fleet = await start_mock(config)
    clock = MissionClock(rate_hint=SPEEDUP)
    events: list[VehicleEvent] = []
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(
        1, link, clock, LocalFrame(config.origin), on_event=events.append, altitude=20.0
    )
    async with link, running(vehicle.run()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=10)
        assert not [e for e in events if e.kind is EventKind.REFUSED]  # the fix was awaited
        fleet.kill(1)
        await until(lambda: has_status(vehicle, VehicleStatus.LOST), timeout=5)
        t_lost = clock.now()
        await sim_sleep(fleet, 2.0)
        fleet.reboot(1)  # revives it: boots on the ground, HEARTBEAT only
        await until(lambda: vehicle.counters["reboots"] == 1, timeout=5)
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=10)
    kinds = [e.kind for e in events]
    assert kinds.count(EventKind.LOST) == 1 and kinds.count(EventKind.RECOVERED) == 1
    assert kinds.count(EventKind.REBOOTED) == 1
    # mission time went on through the loss and the reboot (the only clock died)
    assert clock.reboots == 1
    assert clock.now() > t_lost + 2.0
    assert abs(clock.now() - fleet.now) < 0.5
    assert fleet.truth(1).armed and fleet.truth(1).mode == "GUIDED"


class ScriptedCopter:
    """An in-memory ArduCopter-like peer (no sockets) answering in ways the mock doesn't:
    IN_PROGRESS before ACCEPTED, ACKs addressed to another ground station, DENIED."""

    def __init__(self, speedup: float) -> None:
        self.m = mavlink
        self.tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.rx = mavlink.MAVLink(None)
        self.speedup = speedup
        self.t0 = asyncio.get_running_loop().time()
        self.vehicle: Vehicle | None = None
        self.commands: list[int] = []
        self.mode, self.armed, self.alt = 0, False, 0.0
        self.arm_refusals = 1
        self.arm_result = mavlink.MAV_RESULT_DENIED
        # what it says after a refused arming (severity, text)
        self.arm_texts = [(mavlink.MAV_SEVERITY_CRITICAL, "PreArm: Throttle")]

    def now(self) -> float:
        return 3.0 + self.speedup * (asyncio.get_running_loop().time() - self.t0)

    def deliver(self, msg: object) -> None:
        assert self.vehicle is not None
        for parsed in self.rx.parse_buffer(bytes(msg.pack(self.tx))) or []:  # type: ignore[attr-defined]
            self.vehicle.handle(parsed)

    def send(self, msg: object) -> bool:  # the Vehicle's link: we are the autopilot
        m = self.m
        if getattr(msg, "get_type", lambda: "")() != "COMMAND_LONG":
            return True
        cmd = msg.command  # type: ignore[attr-defined]
        self.commands.append(cmd)
        ack = m.MAVLink_command_ack_message
        asyncio.get_running_loop().call_soon(
            self.deliver, ack(cmd, m.MAV_RESULT_DENIED, 0, 0, 254, 1)
        )
        if cmd == m.MAV_CMD_DO_SET_MODE:
            self.deliver(ack(cmd, m.MAV_RESULT_IN_PROGRESS, 50, 0, 255, 190))
            loop = asyncio.get_running_loop()
            loop.call_later(0.3 / self.speedup, self._mode_done, int(msg.param2))  # type: ignore[attr-defined]
        elif cmd == m.MAV_CMD_COMPONENT_ARM_DISARM and self.arm_refusals:
            self.arm_refusals -= 1
            self.deliver(ack(cmd, self.arm_result, 0, 0, 255, 190))
            for severity, text in self.arm_texts:
                self.deliver(m.MAVLink_statustext_message(severity, text.encode()))
        else:
            self.armed = self.armed or cmd == m.MAV_CMD_COMPONENT_ARM_DISARM
            if cmd == m.MAV_CMD_NAV_TAKEOFF:
                self.alt = msg.param7  # type: ignore[attr-defined]
            self.deliver(ack(cmd, m.MAV_RESULT_ACCEPTED, 0, 0, 255, 190))
        return True

    def _mode_done(self, mode: int) -> None:
        self.mode = mode
        self.deliver(
            self.m.MAVLink_command_ack_message(
                self.m.MAV_CMD_DO_SET_MODE, self.m.MAV_RESULT_ACCEPTED, 0, 0, 255, 190
            )
        )

    async def run(self) -> None:
        m = self.m
        next_hb = 0.0
        while True:
            t = self.now()
            if t >= next_hb:
                base = m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (128 if self.armed else 0)
                self.deliver(m.MAVLink_heartbeat_message(2, 3, base, self.mode, 3, 3))
                self.deliver(m.MAVLink_gps_raw_int_message(0, 3, 0, 0, 0, 0, 0, 0, 0, 10))
                next_hb = t + 1.0
            rel = round(self.alt * 1000)
            gpi = m.MAVLink_global_position_int_message
            self.deliver(gpi(round(t * 1000), 473977420, 85455940, 488000 + rel, rel, 0, 0, 0, 0))
            await asyncio.sleep(0.002)


async def _fly_scripted(
    arm_refusals: int, timeout: float, peer: ScriptedCopter | None = None
) -> tuple[ScriptedCopter, list[VehicleEvent]]:
    """Set up a vehicle on a ``ScriptedCopter`` that refuses ARM so many times, to FLYING."""
    peer = peer or ScriptedCopter(speedup=20.0)
    peer.arm_refusals = arm_refusals
    clock = MissionClock(rate_hint=20.0)
    events: list[VehicleEvent] = []
    frame = LocalFrame(MockConfig.simple(1).origin)
    vehicle = Vehicle(1, peer, clock, frame, on_event=events.append, altitude=15.0)
    peer.vehicle = vehicle
    async with running(peer.run(), vehicle.run()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=timeout)
    return peer, events


async def test_in_progress_foreign_acks_and_refusals() -> None:
    peer, events = await _fly_scripted(arm_refusals=1, timeout=5)
    m = peer.m
    # IN_PROGRESS waited for (no re-send), the foreign DENIED ignored, our DENIED retried
    assert peer.commands.count(m.MAV_CMD_DO_SET_MODE) == 1
    assert peer.commands.count(m.MAV_CMD_COMPONENT_ARM_DISARM) == 2
    assert peer.commands.count(m.MAV_CMD_NAV_TAKEOFF) == 1
    refused = [e.message for e in events if e.kind is EventKind.REFUSED]
    assert refused == [
        "UAV 1 (ArduCopter): arm refused (DENIED): 'PreArm: Throttle'; retrying in 1.0 s"
    ]
    assert peer.alt == pytest.approx(15.0)  # relative to home, which is at the origin here


async def test_a_refusal_is_explained_by_its_checks_not_by_news_after_them() -> None:
    """Real ArduCopter SITL, warming up: the arming FAILED, then its two checks
    (CRITICAL) and its news of the field elevation (INFO) in the same instant. The
    reason given is the checks', not the latest text."""
    peer = ScriptedCopter(speedup=20.0)
    m = peer.m
    peer.arm_result = m.MAV_RESULT_FAILED
    peer.arm_texts = [
        (m.MAV_SEVERITY_CRITICAL, "Arm: Gyros inconsistent"),
        (m.MAV_SEVERITY_CRITICAL, "Arm: Need Position Estimate"),
        (m.MAV_SEVERITY_INFO, "Field Elevation Set: 584m"),
    ]
    _, events = await _fly_scripted(arm_refusals=1, timeout=5, peer=peer)
    refused = [e.message for e in events if e.kind is EventKind.REFUSED]
    assert refused == [
        "UAV 1 (ArduCopter): arm refused (FAILED): "
        "'Arm: Gyros inconsistent; Arm: Need Position Estimate'; retrying in 1.0 s"
    ]


async def test_refused_arm_is_retried_at_most_arm_backoff_apart() -> None:
    """An autopilot refuses ARM until its position estimate settles and arms the
    moment it does: the retries back off to ``arm_backoff`` (2 s), not ``max_backoff``
    (10 s), and the same refusal is said again only ``max_backoff`` later."""
    peer, events = await _fly_scripted(arm_refusals=8, timeout=10)
    assert peer.commands.count(peer.m.MAV_CMD_COMPONENT_ARM_DISARM) == 9
    refused = [e for e in events if e.kind is EventKind.REFUSED]
    assert refused[0].message == (
        "UAV 1 (ArduCopter): arm refused (DENIED): 'PreArm: Throttle'; retrying in 1.0 s"
    )
    again = re.compile(r"UAV 1 \(ArduCopter\): arm refused (\d) times \(DENIED\): "
                       r"'PreArm: Throttle'; retrying in 2\.0 s")  # fmt: skip
    assert len(refused) == 2 and (said := again.fullmatch(refused[1].message))
    assert int(said[1]) in (6, 7)  # (the first refusal 10 s before)
    assert refused[1].t - refused[0].t >= 10.0
    # eight refusals backed off 1 + 7 x 2 s, where the old cap took 1 + 2 + 4 + 8 + 4 x 10
    flying = next(e.t for e in events if e.status is VehicleStatus.FLYING)
    assert flying - refused[0].t < 25.0


@pytest.mark.parametrize("heartbeat_lag", [0.0, 4.0], ids=["on-time", "heartbeats-late"])
async def test_an_arduplane_armed_on_the_runway_is_taken_off_not_counted(
    start_mock: StartMock, heartbeat_lag: float
) -> None:
    """The field failure: ArduPlane armed in GUIDED on the runway keeps its throttle
    suppressed. A set-up that only checks mode and arm calls it flying while it sits
    there; the service must take it off (TAKEOFF mode) and never count it grounded.
    Its HEARTBEATs ``heartbeat_lag`` mission s late (a loaded host) confirm TAKEOFF only
    after the set-up has moved on: the step is still reported once confirmed."""
    from convoy_mav.monitor import why_not_counted

    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality="ardupilot", frame="plane",
        airspeed=18.0, turn_radius=80.0, warmup=1.0,
    )  # fmt: skip
    fleet = await start_mock(config, record_truth=True)
    sim = fleet.vehicles[1]
    await sim_sleep(fleet, 1.5)  # warm: a pilot arms it in GUIDED on the runway
    sim.flight.request_mode(sim.firmware.mode("GUIDED"), fleet.now)
    sim.flight.armed = True
    await sim_sleep(fleet, 5.0)
    assert sim.armed and sim.mode == "GUIDED" and not fleet.truth(1).airborne
    grounded: list[str | None] = []

    def on_telemetry(tel: Telemetry) -> None:  # each update while the truth is grounded
        if not fleet.truth(1).airborne:
            why = why_not_counted(
                status=str(vehicle.status), airborne=vehicle.airborne,
                altitude_error=0.0, band=15.0, phase="protect",
            )  # fmt: skip
            grounded.append(why)
            claims.append(vehicle.airborne)  # what the autopilot's telemetry says

    claims: list[bool] = []
    clock = MissionClock(rate_hint=SPEEDUP)
    events: list[VehicleEvent] = []
    loop = asyncio.get_running_loop()

    def heard(msg: Any) -> None:
        if heartbeat_lag and msg.get_type() == "HEARTBEAT":  # (in order: one lag for all)
            loop.call_later(heartbeat_lag / SPEEDUP, vehicle.handle, msg)
        else:
            vehicle.handle(msg)

    link = MavLink(fleet.endpoint(1).connect, heard)
    vehicle = Vehicle(
        1,
        link,
        clock,
        LocalFrame(config.origin),
        on_event=events.append,
        altitude=ALTITUDE,
        on_telemetry=on_telemetry,
    )
    async with link, running(vehicle.run()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=20)
        row = fleet.truth(1)
    assert grounded and None not in grounded, grounded  # never counted on the runway
    assert not any(claims)  # and never taken for airborne there
    steps = [e.message for e in events if e.kind is EventKind.SETUP]
    took_off = ("in TAKEOFF", "TAKEOFF accepted and airborne (its HEARTBEAT still says GUIDED)")
    assert any(s.endswith(took_off) for s in steps), steps
    assert steps[-1].endswith("in GUIDED"), steps
    assert row.airborne and row.mode == "GUIDED"
    assert -row.down == pytest.approx(ALTITUDE, abs=0.05 * ALTITUDE + 1.0)


class LaggingFenceLink:
    """The Vehicle's link to the mock's autopilot (no sockets; bytes both ways) on a loaded
    link: its mission ACKs (``hold_all``: all its answers) are held back ``lag`` wall s,
    then come in one burst, as queued UDP datagrams do when the host is busy."""

    def __init__(self, personality: Personality, lag: float, hold_all: bool) -> None:
        self.autopilot = make_vehicle(personality, "plane")
        self.tx = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        self.rx = mavlink.MAVLink(None)
        self.reply_tx = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.reply_rx = mavlink.MAVLink(None)
        self.lag = lag
        self.hold_all = hold_all
        self.held: list[Any] = []
        self.sent: list[str] = []
        self.vehicle: Vehicle | None = None

    def send(self, msg: Any) -> bool:
        self.sent.append(msg.get_type())
        loop = asyncio.get_running_loop()
        for parsed in self.rx.parse_buffer(bytes(msg.pack(self.tx))) or []:
            for reply in self.autopilot.handle(parsed, 10.0):
                if reply.get_type() != "MISSION_ACK" and not self.hold_all:
                    loop.call_soon(self._deliver, [reply])
                    continue
                if not self.held:
                    loop.call_later(self.lag, self._flush)
                self.held.append(reply)
        return True

    def _flush(self) -> None:
        burst, self.held = self.held, []
        self._deliver(burst)

    def _deliver(self, replies: list[Any]) -> None:
        assert self.vehicle is not None
        for reply in replies:
            for parsed in self.reply_rx.parse_buffer(bytes(reply.pack(self.reply_tx))) or []:
                self.vehicle.handle(parsed)


@pytest.mark.parametrize("hold_all", [False, True], ids=["acks-late", "all-late"])
@pytest.mark.parametrize("personality", ["px4", "ardupilot"])
async def test_a_fence_answered_late_is_read_in_order(personality: str, hold_all: bool) -> None:
    """A message whose answer is late is sent again, and the copy is answered too: the last
    item's copy with ArduPilot's ERROR or PX4's ACCEPTED again, in the same burst as the
    first ACCEPTED; an item's copy mid-upload with ArduPilot's INVALID_SEQUENCE (PX4 ignores
    it), the count's copy with the upload started over. Read in order, the upload succeeds."""
    link = LaggingFenceLink(Personality(personality), lag=0.12, hold_all=hold_all)
    clock = MissionClock(rate_hint=20.0, silence_cap=math.inf)  # (runs on at 20x once heard)
    clock.observe(10_000, 1)
    frame = LocalFrame(MockConfig.simple(1).origin)
    vehicle = Vehicle(1, link, clock, frame, altitude=40.0)
    link.vehicle = vehicle
    ring = ((47.39, 8.54), (47.39, 8.55), (47.40, 8.55), (47.40, 8.54))
    items = fence_items(SafetyConfig(fence=ring))
    result = await vehicle.upload_fence(items, timeout=1.0)  # (0.05 wall s at 20x)
    assert result == "geofence of 4 vertices uploaded"
    assert link.sent.count("MISSION_ITEM_INT") > len(items)  # (the last one was sent again)
    assert [(m.x, m.y) for m in link.autopilot.fence] == [
        (round(lat * 1e7), round(lon * 1e7)) for lat, lon in ring
    ]
