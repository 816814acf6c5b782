"""MAVSDK 4.x (native ``mavsdk.asyncio``) flies an OFFBOARD circle on the mock.

The flow is MAVSDK's own fixed-wing example: connect, wait for health (global
position, home position, armable), arm, ``action.takeoff()`` (a PX4 plane leaves the
ground in AUTO.TAKEOFF only), then its offboard example: set an initial setpoint,
``offboard.start()``, then keep streaming ``set_position_velocity_ned``. The mock
listens, so MAVSDK must send first: its client form ``udpout://HOST:PORT``.
A pymavlink peer on the same port watches the same flight.
"""

from __future__ import annotations

import asyncio
import itertools
import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.config import MockConfig

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import MavClient

mavsdk_asyncio = pytest.importorskip("mavsdk.asyncio")

pytestmark = [pytest.mark.integration, pytest.mark.timeout(120)]

SPEEDUP = 20.0
V, R_MIN = 18.0, 80.0
ALT = 30.0  # the mock's MIS_TAKEOFF_ALT: AUTO.TAKEOFF climbs to it, then OFFBOARD
PX4_OFFBOARD = 6 << 16


async def next_value(gen: Any, timeout: float = 10.0) -> Any:
    """The next value of a MAVSDK subscription."""
    async with asyncio.timeout(timeout):
        return await anext(gen)


async def test_mavsdk_offboard_circle_with_a_pymavlink_watcher(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.offboard import OffboardAsync, PositionNedYaw, VelocityNedYaw
    from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync

    from tests.mavclient import Circle

    config = MockConfig.simple(
        1,
        speedup=SPEEDUP,
        base_port=0,
        airspeed=V,
        turn_radius=R_MIN,
        warmup=5.0,
        setpoint_timeout=3.0,  # COM_OF_LOSS_T: 150 ms of wall time at this speedup
    )
    fleet = await start_mock(config, record_truth=True)
    endpoint = fleet.endpoint(1)
    assert endpoint.mavsdk.startswith("udpout://")
    watcher = mav_client(endpoint.port, source_system=254)
    watcher.hello()

    async def poll_watcher() -> None:
        while True:
            watcher.poll()
            await asyncio.sleep(0.002)

    sdk_config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with asyncio.timeout(90), Mavsdk(sdk_config) as sdk, asyncio.TaskGroup() as tg:
        poller = tg.create_task(poll_watcher(), name="test.watcher")
        await sdk.add_any_connection(endpoint.mavsdk)
        system = await sdk.first_autopilot(timeout_s=10.0)
        assert system is not None
        telemetry, action, offboard = (
            TelemetryAsync(system),
            ActionAsync(system),
            OffboardAsync(system),
        )

        health_stream = telemetry.subscribe_health()
        while True:
            h = await next_value(health_stream)
            if h.is_global_position_ok and h.is_home_position_ok and h.is_armable:
                break
        await health_stream.aclose()
        assert fleet.now >= 5.0, "healthy only after the warm-up"

        await action.arm()
        assert await next_value(telemetry.subscribe_armed())
        await action.takeoff()
        while (await telemetry.position_velocity_ned()).position.down_m > -(ALT - 1.0):
            await asyncio.sleep(0.01)

        radius = 1.3 * R_MIN
        circle = Circle(300.0, 0.0, radius, V, t0=fleet.now)

        async def send_setpoint() -> None:
            n, e, vn, ve = circle.at(fleet.now)
            await offboard.set_position_velocity_ned(
                PositionNedYaw(n, e, -ALT, 0.0), VelocityNedYaw(vn, ve, 0.0, 0.0)
            )

        await send_setpoint()  # "set an initial setpoint" before starting offboard
        await offboard.start()
        assert await offboard.is_active()
        modes = telemetry.subscribe_flight_mode()
        while await next_value(modes) != FlightMode.OFFBOARD:
            await send_setpoint()
        await modes.aclose()

        # Climb-out, then re-anchor the circle on the plane so it joins in phase.
        while True:
            await send_setpoint()
            pv = await telemetry.position_velocity_ned()
            if pv.position.down_m < -(ALT - 1.0):
                break
            await asyncio.sleep(0.005)
        heading = math.atan2(pv.velocity.east_m_s, pv.velocity.north_m_s)
        circle = Circle.through(
            pv.position.north_m, pv.position.east_m, heading, radius, V, fleet.now
        )
        t_join = fleet.now
        lap = 2 * math.pi * radius / V
        while fleet.now < t_join + 1.6 * lap:
            await send_setpoint()
            await asyncio.sleep(0.005)
        mode_at_end = await telemetry.flight_mode()
        poller.cancel()

    assert mode_at_end == FlightMode.OFFBOARD
    bound = V / R_MIN
    assert fleet.history is not None
    rows = fleet.history.of(1)
    assert max(abs(r.yaw_rate) for r in rows) <= bound * 1.001
    late = [r for r in rows if r.t > t_join + 1.1 * lap]
    errors = [circle.radial_error(r.north, r.east) / radius for r in late]
    assert len(late) > 50
    assert abs(sum(errors) / len(errors)) < 0.03
    assert max(abs(x) for x in errors) < 0.05
    assert all(r.mode == "OFFBOARD" for r in late)

    # The pymavlink watcher saw the same flight: OFFBOARD heartbeats, turn rates
    # within the bound, and positions that agree with the truth log.
    assert any(m.custom_mode == PX4_OFFBOARD for m in watcher.of("HEARTBEAT"))
    attitudes = [m for m in watcher.of("ATTITUDE") if m.time_boot_ms / 1000 > t_join]
    assert len(attitudes) > 100
    assert max(abs(m.yawspeed) for m in attitudes) <= bound * 1.001
    worst = max(
        abs(math.remainder(m1.yaw - m0.yaw, math.tau)) / ((m1.time_boot_ms - m0.time_boot_ms) / 1e3)
        for m0, m1 in itertools.pairwise(attitudes)
        if m1.time_boot_ms > m0.time_boot_ms
    )
    assert worst <= bound * 1.02
    last = [m for m in watcher.of("LOCAL_POSITION_NED") if m.time_boot_ms / 1000 > t_join + lap]
    assert last
    assert all(abs(circle.radial_error(m.x, m.y)) < 0.05 * radius for m in last)
    assert any(m.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM for m in watcher.of("COMMAND_ACK"))


@pytest.mark.parametrize("personality", ["px4", "ardupilot"])
async def test_mavsdk_downloads_the_mock_rovers_mission(
    start_mock: StartMock, personality: str
) -> None:
    """An independent client reads the mission the service reads as the convoy's route:
    MAVSDK's MissionRaw against a rover of the mock, over real UDP."""
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync

    corners = [[0.0, 0.0], [400.0, 0.0], [400.0, 300.0], [0.0, 300.0]]
    config = MockConfig.simple(
        0, ground=1, speedup=SPEEDUP, base_port=0, ground_route="polyline",
        ground_points=corners, ground_speed=8.0, ground_mission=True, personality=personality,
    )  # fmt: skip
    fleet = await start_mock(config)
    (rover,) = fleet.endpoints
    sdk_config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with asyncio.timeout(60), Mavsdk(sdk_config) as sdk:
        await sdk.add_any_connection(rover.mavsdk)
        system = await sdk.first_autopilot(timeout_s=10.0)
        assert system is not None
        items = await MissionRawAsync(system).download_mission()
    world = fleet.world
    expected = [world.to_geo(n, e) for n, e in corners]
    if personality == "ardupilot":  # item 0 is home, where the rover booted
        home, *items = items
        assert (home.seq, home.frame) == (0, mavlink.MAV_FRAME_GLOBAL)
    assert [i.seq for i in items] == [1, 2, 3, 4] if personality == "ardupilot" else [0, 1, 2, 3]
    assert all(i.command == mavlink.MAV_CMD_NAV_WAYPOINT for i in items)
    assert [(i.x, i.y) for i in items] == [
        (round(g.lat * 1e7), round(g.lon * 1e7)) for g in expected
    ]
    assert fleet.counters(rover.sysid)["mission_reads"] >= 1


@pytest.mark.parametrize("personality", ["px4", "ardupilot"])
async def test_mavsdk_uploads_a_mission_to_a_parked_rover_and_starts_it(
    start_mock: StartMock, personality: str
) -> None:
    """An operator's ground station plans the rover's mission: MAVSDK's MissionRaw uploads
    it to a parked rover of the mock (which refuses AUTO without one), starts it, and the
    rover drives it (the mock's ground truth); a download gives the items back."""
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.mission_raw import MissionItem, MissionRawAsync

    config = MockConfig.simple(
        0, ground=1, speedup=SPEEDUP, base_port=0, ground_route="stationary",
        personality=personality,
    )  # fmt: skip
    fleet = await start_mock(config)
    (rover,) = fleet.endpoints
    world = fleet.world
    ardupilot = personality == "ardupilot"
    corners = [(0.0, 0.0)] * ardupilot + [(150.0, 0.0), (150.0, 100.0)]  # (ArduPilot: home)
    wp, rel = mavlink.MAV_CMD_NAV_WAYPOINT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    items = [
        MissionItem(seq, rel if seq or not ardupilot else mavlink.MAV_FRAME_GLOBAL, wp,
                    int(seq == 0), 1,
                    0.0, 0.0, 0.0, float("nan"),
                    round(g.lat * 1e7), round(g.lon * 1e7), 0.0, mavlink.MAV_MISSION_TYPE_MISSION)
        for seq, g in enumerate(world.to_geo(n, e) for n, e in corners)
    ]  # fmt: skip
    sdk_config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with asyncio.timeout(90), Mavsdk(sdk_config) as sdk:
        await sdk.add_any_connection(rover.mavsdk)
        system = await sdk.first_autopilot(timeout_s=10.0)
        assert system is not None
        missions = MissionRawAsync(system)
        await missions.upload_mission(items)
        await missions.start_mission()
        start = fleet.now
        while fleet.now < start + 60.0:  # (150 m at WP_SPEED's 2 m/s: some 78 s)
            await asyncio.sleep(0.05)
        row = fleet.truth(rover.sysid)
        assert row.mode == ("AUTO" if ardupilot else "AUTO.MISSION")
        assert 80.0 < row.north < 125.0 and row.speed == pytest.approx(2.0)
        back = await missions.download_mission()
    assert [(i.command, i.x, i.y) for i in back[ardupilot:]] == [
        (i.command, i.x, i.y) for i in items[ardupilot:]
    ]
    assert fleet.counters(rover.sysid)["mission_uploads"] == 1
