"""ArduPilot personality over real UDP with pymavlink: the GUIDED flows.

Copter: request streams, GUIDED (retried until the warm-up is over), arm,
NAV_TAKEOFF, then position+velocity setpoints along a circle. Plane: GUIDED via
SET_MODE, arm, DO_REPOSITION with a loiter radius and direction; the flown
circle must have that radius (within a few per cent) and that direction.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import eas2tas
from convoy_mav.geo import LocalFrame
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import MavClient

pytestmark = [pytest.mark.integration, pytest.mark.timeout(90)]

COPTER_GUIDED, PLANE_TAKEOFF, PLANE_GUIDED = 4, 13, 15
POS_VEL_MASK = 0b1101_1100_0000


async def sim_sleep(client: MavClient, fleet: MockFleet, seconds: float) -> None:
    """Let ``seconds`` of sim time pass while polling ``client``."""
    end = fleet.now + seconds
    await client.until(lambda: fleet.now >= end)


async def until_accepted(client: MavClient, fleet: MockFleet, send: Callable[[], Any]) -> list[Any]:
    """Repeat a request every half sim second until its ACK says ACCEPTED."""
    acks = []
    for _ in range(100):
        ack = await send()
        acks.append(ack)
        if ack.result == mavlink.MAV_RESULT_ACCEPTED:
            return acks
        await sim_sleep(client, fleet, 0.5)
    raise AssertionError(f"never accepted: {[a.result for a in acks]}")


async def start_guided(client: MavClient, fleet: MockFleet, use_set_mode: bool, mode: int) -> None:
    """Streams on, GUIDED (refused until the origin is set at the fix, half-way through
    the warm-up), armed (refused until the estimator uses the GPS, at its end) -- the
    usual ArduPilot preamble."""
    client.hello()
    hb = await client.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 1)
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    if mode != PLANE_TAKEOFF:  # (ArduPlane's SRn_* stream every group at 1 Hz unasked)
        assert not client.of("ATTITUDE"), "ArduCopter streams nothing until asked"
    client.mav.request_data_stream_send(1, 1, mavlink.MAV_DATA_STREAM_ALL, 10, 1)
    await client.wait_for("ATTITUDE")

    async def set_mode() -> Any:
        if use_set_mode:
            client.mav.set_mode_send(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
            return await client.wait_for("COMMAND_ACK", lambda m: m.command == 11)
        return await client.command(mavlink.MAV_CMD_DO_SET_MODE, 1, mode)

    acks = await until_accepted(client, fleet, set_mode)
    assert acks[0].result == mavlink.MAV_RESULT_FAILED, "refused before the fix"
    await client.wait_for("HEARTBEAT", lambda m: m.custom_mode == mode)

    async def arm() -> Any:
        return await client.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)

    acks = await until_accepted(client, fleet, arm)
    assert acks[0].result == mavlink.MAV_RESULT_FAILED, "refused before the warm-up ends"
    texts = [m.text for m in client.of("STATUSTEXT")]
    assert "Arm: Need Position Estimate" in texts, texts


async def test_copter_guided_takeoff_then_setpoint_circle(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    v, r_min = 12.0, 30.0
    config = MockConfig.simple(
        1,
        speedup=30,
        base_port=0,
        personality="ardupilot",
        frame="copter",
        airspeed=v,
        turn_radius=r_min,
        warmup=8.0,
    )
    fleet = await start_mock(config, record_truth=True)
    client = mav_client(fleet.endpoint(1).port)
    await start_guided(client, fleet, use_set_mode=False, mode=COPTER_GUIDED)
    hb = client.of("HEARTBEAT")[-1]
    assert hb.type == mavlink.MAV_TYPE_QUADROTOR

    ack = await client.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, 0, 0, 20.0)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    await client.until(
        lambda: (
            bool(client.of("LOCAL_POSITION_NED")) and client.of("LOCAL_POSITION_NED")[-1].z < -19.0
        ),
        timeout=20,
    )

    from tests.mavclient import Circle

    speed, radius = 0.8 * v, 1.3 * r_min  # slower than the copter can fly, so it catches up
    circle = Circle(0.0, radius, radius, speed, True, math.pi, fleet.now)  # passes overhead
    t_start = fleet.now
    lap = 2 * math.pi * radius / speed
    next_t = 0.0

    def fly() -> bool:
        nonlocal next_t
        if fleet.now >= next_t:
            n, e, vn, ve = circle.at(fleet.now)
            client.mav.set_position_target_local_ned_send(
                0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_VEL_MASK,
                n, e, -20.0, vn, ve, 0.0, 0, 0, 0, 0, 0,
            )  # fmt: skip
            next_t = fleet.now + 0.05
        return fleet.now >= t_start + 2.5 * lap

    await client.until(fly, timeout=30)

    assert fleet.history is not None
    rows = fleet.history.of(1)
    assert all(abs(r.yaw_rate) <= r.speed / r_min * 1.001 + 1e-9 for r in rows if r.speed > 0.5)
    assert max(abs(m.yawspeed) for m in client.of("ATTITUDE")) <= v / r_min * 1.001
    late = [r for r in rows if r.t > t_start + 1.5 * lap]
    errors = [circle.radial_error(r.north, r.east) / radius for r in late]
    assert abs(sum(errors) / len(errors)) < 0.03
    assert max(abs(x) for x in errors) < 0.05
    assert all(r.mode == "GUIDED" and abs(r.down + 20.0) < 1.0 for r in late)


@pytest.mark.parametrize("clockwise", [True, False])
async def test_plane_do_reposition_loiter_radius_and_direction(
    start_mock: StartMock, mav_client: Callable[..., MavClient], clockwise: bool
) -> None:
    v, r_min, radius = 22.0, 80.0, 150.0
    config = MockConfig.simple(
        1,
        speedup=40,
        base_port=0,
        personality="ardupilot",
        frame="plane",
        airspeed=v,
        turn_radius=r_min,
        warmup=8.0,
    )
    fleet = await start_mock(config, record_truth=True)
    client = mav_client(fleet.endpoint(1).port)
    # ArduPlane leaves the runway in TAKEOFF mode only (never armed in GUIDED)
    await start_guided(client, fleet, use_set_mode=True, mode=PLANE_TAKEOFF)
    assert client.of("HEARTBEAT")[-1].type == mavlink.MAV_TYPE_FIXED_WING
    await client.until(lambda: fleet.truth(1).down < -20.0, timeout=30)

    centre_n, centre_e = 400.0, 100.0
    centre = LocalFrame(fleet.config.origin).to_geo(centre_n, centre_e)
    client.mav.command_int_send(
        1, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0,
        -1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, radius, 0 if clockwise else 1,
        round(centre.lat * 1e7), round(centre.lon * 1e7), 60.0,
    )  # fmt: skip
    ack = await client.wait_for("COMMAND_ACK", lambda m: m.command == mavlink.MAV_CMD_DO_REPOSITION)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    t_start = fleet.now
    lap = 2 * math.pi * radius / v
    await client.until(lambda: fleet.now >= t_start + 20.0 + 2.5 * lap, timeout=30)

    assert fleet.history is not None
    rows = fleet.history.of(1)
    # (its airspeed is an equivalent airspeed, flown 2.7 % faster 548 m above the sea)
    true_v = v * eas2tas(fleet.config.origin.alt + 60.0)
    assert max(abs(r.yaw_rate) for r in rows) <= true_v / r_min * 1.001
    late = [r for r in rows if r.t > t_start + 20.0 + 1.5 * lap]
    dist = [math.hypot(r.north - centre_n, r.east - centre_e) for r in late]
    flown = radius + (v * 1.9) ** 2 / radius  # wide, as ArduPlane's L1 flies it (lag 1.9 s)
    assert abs(sum(dist) / len(dist) / flown - 1.0) < 0.03
    assert max(abs(d / flown - 1.0) for d in dist) < 0.05
    # Direction: the angular momentum about the centre (north x east) is positive
    # for a clockwise circle seen from above.
    spins = [(r.north - centre_n) * r.ve - (r.east - centre_e) * r.vn for r in late]
    assert all((s > 0) == clockwise for s in spins)
    assert all(abs(r.down + 60.0) < 1.5 for r in late)
    assert all(m.custom_mode == PLANE_GUIDED for m in client.of("HEARTBEAT")[-5:])
