"""PX4 personality over real UDP with pymavlink: OFFBOARD circle, watched by two peers.

Client A (a script) arms -- refused with a STATUSTEXT until warm-up is over --
takes off (NAV_TAKEOFF: a PX4 plane leaves the ground in AUTO.TAKEOFF only), streams
position+velocity setpoints along a circle of radius 1.3 R_min at the airspeed, and
switches to OFFBOARD; the plane joins the circle.
Client B (a second ground station on the same port) only listens and must see
the same flight. Checks: the turn rate never exceeds V / R_min, in telemetry and
in the truth log; the flown radius converges to the commanded one.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import math
from collections.abc import AsyncIterator, Callable
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import LocalFrame
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import Circle, MavClient

pytestmark = [pytest.mark.integration, pytest.mark.timeout(90)]

SPEEDUP = 25.0
V, R_MIN = 18.0, 80.0
PX4_OFFBOARD = 6 << 16  # HEARTBEAT.custom_mode of OFFBOARD (main mode 6)
POS_VEL_MASK = 0b1101_1100_0000  # ignore accelerations, yaw and yaw rate
WARMUP = 10.0  # s of sim time: long enough that the first arm attempt comes before
CLIMB_OUT_DOWN = -30.0  # MIS_TAKEOFF_ALT of the mock: the circle is flown there


def circle_class() -> type[Circle]:
    from tests.mavclient import Circle

    return Circle


class SetpointStream:
    """Streams the circle reference every ``period`` sim seconds in one frame."""

    def __init__(self, client: MavClient, fleet: MockFleet, frame: str, circle: Circle) -> None:
        self.client = client
        self.fleet = fleet
        self.frame = frame
        self.circle = circle
        self.world = LocalFrame(fleet.config.origin)
        self.sent = 0

    def send(self) -> None:
        t = self.fleet.now
        n, e, vn, ve = self.circle.at(t)
        ms = int(t * 1000)
        if self.frame == "local":
            self.client.mav.set_position_target_local_ned_send(
                ms, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_VEL_MASK,
                n, e, CLIMB_OUT_DOWN, vn, ve, 0.0, 0, 0, 0, 0, 0,
            )  # fmt: skip
        else:
            geo = self.world.to_geo(n, e)
            self.client.mav.set_position_target_global_int_send(
                ms, 1, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, POS_VEL_MASK,
                round(geo.lat * 1e7), round(geo.lon * 1e7), -CLIMB_OUT_DOWN,
                vn, ve, 0.0, 0, 0, 0, 0, 0,
            )  # fmt: skip
        self.sent += 1

    async def run(self, period: float = 0.05) -> None:
        next_t = 0.0
        while True:
            if self.fleet.now >= next_t:
                self.send()
                next_t = self.fleet.now + period
            await asyncio.sleep(0.001)


@contextlib.asynccontextmanager
async def background(coro: Any) -> AsyncIterator[asyncio.Task[Any]]:
    """Run a coroutine as a task for the duration of the block."""
    task = asyncio.create_task(coro, name="test.setpoints")
    try:
        yield task
    finally:
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task


async def sim_sleep(a: MavClient, b: MavClient, fleet: MockFleet, seconds: float) -> None:
    """Let ``seconds`` of sim time pass while polling both clients."""
    end = fleet.now + seconds
    await a.until(lambda: fleet.now >= end, others=[b])


async def arm_after_warmup(a: MavClient, b: MavClient, fleet: MockFleet) -> list[Any]:
    """Arm, retrying every half sim second; returns the ACKs (refusals first)."""
    acks = []
    async with asyncio.timeout(20):
        while True:
            ack = await a.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            acks.append(ack)
            if ack.result == mavlink.MAV_RESULT_ACCEPTED:
                return acks
            b.poll()
            await sim_sleep(a, b, fleet, 0.5)


def max_telemetry_turn_rate(attitudes: list[Any]) -> float:
    """Largest |yaw change| / dt between consecutive ATTITUDE messages."""
    worst = 0.0
    for m0, m1 in itertools.pairwise(attitudes):
        dt = (m1.time_boot_ms - m0.time_boot_ms) / 1000.0
        if dt <= 0:
            continue
        dyaw = math.remainder(m1.yaw - m0.yaw, math.tau)
        worst = max(worst, abs(dyaw) / dt)
    return worst


@pytest.mark.parametrize("frame", ["local", "global"])
async def test_offboard_circle_is_flown_and_seen_by_a_second_peer(
    start_mock: StartMock, mav_client: Callable[..., MavClient], frame: str
) -> None:
    config = MockConfig.simple(
        1,
        speedup=SPEEDUP,
        base_port=0,
        airspeed=V,
        turn_radius=R_MIN,
        warmup=WARMUP,
        setpoint_timeout=3.0,  # COM_OF_LOSS_T: 120 ms of wall time, slack for a loaded CI box
    )
    fleet = await start_mock(config, record_truth=True)
    port = fleet.endpoint(1).port
    a, b = mav_client(port), mav_client(port, source_system=254)
    a.hello()
    b.hello()
    hb = await a.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 1, others=[b])
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
    assert hb.type == mavlink.MAV_TYPE_FIXED_WING

    acks = await arm_after_warmup(a, b, fleet)
    assert acks[0].result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    assert acks[-1].result == mavlink.MAV_RESULT_ACCEPTED
    refusals = [m.text for m in a.of("STATUSTEXT") if "Arming denied" in m.text]
    assert refusals, "the refusal reason is sent as STATUSTEXT"
    amsl = fleet.config.origin.alt - CLIMB_OUT_DOWN  # PX4: NAV_TAKEOFF param7 is AMSL
    nan = math.nan
    ack = await a.command(mavlink.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan, amsl)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED

    radius = 1.3 * R_MIN
    Circle = circle_class()
    # Until the plane is up, stream a circle ahead of it; then re-anchor the
    # circle on the plane so it joins in phase (what a real client would do).
    stream = SetpointStream(a, fleet, frame, Circle(300.0, 0.0, radius, V, t0=fleet.now))
    async with background(stream.run()):
        await a.until(lambda: stream.sent >= 3, others=[b])
        ack = await a.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 6, 0)
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        await a.wait_for("HEARTBEAT", lambda m: m.custom_mode == PX4_OFFBOARD, others=[b])

        def climbed() -> bool:
            pos = a.of("LOCAL_POSITION_NED")
            return bool(pos) and pos[-1].z < CLIMB_OUT_DOWN + 1.0

        await a.until(climbed, timeout=20, others=[b])
        pos, att = a.of("LOCAL_POSITION_NED")[-1], a.of("ATTITUDE")[-1]
        stream.circle = Circle.through(pos.x, pos.y, att.yaw, radius, V, fleet.now)
        t_join = fleet.now
        lap = 2 * math.pi * radius / V
        await a.until(lambda: fleet.now >= t_join + 1.6 * lap, timeout=30, others=[b])

    # -- the turn-rate bound, from telemetry and from the truth log
    bound = V / R_MIN
    attitudes = a.of("ATTITUDE")
    assert len(attitudes) > 100
    assert max_telemetry_turn_rate(attitudes) <= bound * 1.02
    assert max(abs(m.yawspeed) for m in attitudes) <= bound * 1.001
    assert fleet.history is not None
    rows = fleet.history.of(1)
    assert max(abs(r.yaw_rate) for r in rows) <= bound * 1.001
    # The circle is tight enough to need most of that bound, so the check has teeth.
    assert max(abs(r.yaw_rate) for r in rows if r.t > t_join) > 0.7 * bound

    # -- the flown radius converges to the commanded one (last half lap)
    late = [r for r in rows if r.t > t_join + 1.1 * lap]
    errors = [stream.circle.radial_error(r.north, r.east) / radius for r in late]
    assert len(late) > 50
    assert abs(sum(errors) / len(errors)) < 0.03
    assert max(abs(x) for x in errors) < 0.05
    assert all(r.mode == "OFFBOARD" and r.armed for r in late)

    # -- the second peer saw the same flight (same samples, same ACKs)
    stamps_a = {m.time_boot_ms for m in a.of("ATTITUDE")}
    stamps_b = {m.time_boot_ms for m in b.of("ATTITUDE")}
    assert len(stamps_a & stamps_b) >= 0.95 * len(stamps_a)
    assert any(m.command == mavlink.MAV_CMD_DO_SET_MODE for m in b.of("COMMAND_ACK"))
    assert any("Arming denied" in m.text for m in b.of("STATUSTEXT"))
    assert {p[1] for p in fleet.peers(1)} >= {a.conn.port.getsockname()[1]}
    assert len(fleet.peers(1)) == 2
