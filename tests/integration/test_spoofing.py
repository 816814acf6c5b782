"""Strangers and forgeries on a UAV's ``udpin`` link, over real UDP (the issue's probes).

A genuine autopilot (pymavlink, sysid 1) talks to a :class:`Vehicle` on a real
``udpin`` :class:`MavLink`. Then:
- another sender on the same port claims to be the UAV: refused unread, never
  adopted, its position never flown on;
- one frame with a ``time_boot_ms`` an hour ahead (496 s -> 4066 s) comes in:
  dropped and counted; mission time and the setpoints' clock run on;
- one frame with a plausible time but 3 km off: dropped and counted, warned of;
- a frame on the UAV's link claiming another vehicle's system id is not
  delivered to that vehicle (``ConvoyService._route``).
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.clock import MissionClock
from convoy_mav.config import parse_config
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.vehicle import EventKind, Vehicle, VehicleEvent
from tests.mavclient import MavClient

pytestmark = pytest.mark.integration

ORIGIN = GeoPoint(47.3977, 8.5456, 488.0)
BOOT_S = 496.0  # the autopilot has been up this long


class Autopilot:
    """A PX4 plane circling slowly north-east of the origin, stamped by its boot clock."""

    def __init__(self, client: MavClient) -> None:
        self.client = client
        self.t0 = time.monotonic()
        self.frame = LocalFrame(ORIGIN)

    def boot_ms(self) -> int:
        return int(1000.0 * (BOOT_S + time.monotonic() - self.t0))

    def position(
        self, north: float = 100.0, east: float = 50.0, boot_ms: int | None = None
    ) -> None:
        p = self.frame.to_geo(north, east, -100.0)
        self.client.mav.global_position_int_send(
            self.boot_ms() if boot_ms is None else boot_ms,
            int(p.lat * 1e7), int(p.lon * 1e7), int(p.alt * 1000), 100_000, 0, 0, 0, 0,
        )  # fmt: skip

    def heartbeat(self) -> None:
        self.client.mav.heartbeat_send(
            mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 0, 0, mavlink.MAV_STATE_ACTIVE
        )

    def home(self) -> None:
        """HOME_POSITION: its estimate has settled (positions are judged from now on)."""
        p = self.frame.to_geo(0.0, 0.0, 0.0)
        self.client.mav.home_position_send(
            int(p.lat * 1e7), int(p.lon * 1e7), int(p.alt * 1000), 0, 0, 0,
            [1.0, 0.0, 0.0, 0.0], 0, 0, 0,
        )  # fmt: skip


async def _talk(ap: Autopilot, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        ap.heartbeat()
        ap.position()
        ap.client.poll()
        await asyncio.sleep(0.02)


async def test_strangers_and_forged_frames_change_nothing_flown(
    mav_client: Callable[..., MavClient],
) -> None:
    events: list[VehicleEvent] = []
    clock = MissionClock()
    holder: list[Vehicle] = []

    def deliver(msg: Any) -> None:
        holder[0].handle(msg)

    async with MavLink("udpin:127.0.0.1:0", deliver, name="uav1") as link:
        vehicle = Vehicle(1, link, clock, LocalFrame(ORIGIN), on_event=events.append,
                          max_speed=45.0, heartbeat=False)  # fmt: skip
        holder.append(vehicle)
        assert link.local_address is not None
        port = link.local_address[1]
        genuine = Autopilot(MavClient(port, source_system=1))
        genuine.client.conn.mav.srcComponent = 1
        try:
            # Before its estimator has an origin, ArduPilot reports metres off (0, 0):
            # no position yet, neither flown nor a jump when the real one comes.
            for dn, de in ((614, 2111), (720, 2450)):
                genuine.client.mav.global_position_int_send(
                    genuine.boot_ms(), dn, de, 50, 58, 0, 0, 0, 0
                )
                await asyncio.sleep(0.02)
            # ... nor is its altitude finding AMSL while it settles (before home is set).
            here = genuine.frame.to_geo(100.0, 50.0)
            genuine.client.mav.global_position_int_send(
                genuine.boot_ms(), int(here.lat * 1e7), int(here.lon * 1e7), 0, 100_000,
                0, 0, 0, 0,
            )  # fmt: skip
            genuine.position(north=100.0)  # (100 m up: its altitude found)
            await asyncio.sleep(0.05)
            genuine.home()
            await _talk(genuine, 3.5)  # (positions are judged 3 s after home is set)
            settling = vehicle.counters.get("position_jump", 0)  # (nothing judged yet)
            assert vehicle.counters["no_position_yet"] == 2 and settling == 0
            assert link.peer is not None and vehicle.telemetry is not None
            assert vehicle.telemetry.north == pytest.approx(100.0, abs=1.0)

            # A stranger on the same port, claiming sysid 1: refused, never adopted.
            stranger = Autopilot(MavClient(port, source_system=1))
            stranger.client.conn.mav.srcComponent = 1
            pinned = link.peer
            for _ in range(20):
                stranger.position(north=3000.0)
                await _talk(genuine, 0.02)
            assert link.peer == pinned and link.counters["foreign_peer"] >= 20
            assert vehicle.telemetry.north == pytest.approx(100.0, abs=1.0)
            stranger.client.close()

            # On the pinned path: one stamp an hour ahead, one fix 3 km off.
            before = clock.now()
            genuine.position(boot_ms=4_066_000)
            genuine.position(north=3100.0)
            await _talk(genuine, 0.5)
            assert vehicle.counters["clock_jump"] == 1 and vehicle.counters["position_jump"] == 1
            assert clock.now() - before < 2.0  # (it ran on with the wall, not 3570 s ahead)
            assert clock.now() == pytest.approx(genuine.boot_ms() / 1000.0, abs=0.2)
            assert clock.reboots == clock.jumps == 0
            assert vehicle.telemetry.north == pytest.approx(100.0, abs=1.0)
            warned = [e for e in events if e.kind is EventKind.REJECTED]
            assert len(warned) == 2
            assert "time_boot_ms 4066000 is ahead of its clock" in warned[0].message
            assert "farther than it can have flown" in warned[1].message
        finally:
            genuine.client.close()


def test_a_frame_claiming_another_vehicle_on_a_link_is_not_delivered() -> None:
    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0},
            "uav": [
                {"connection": "udpin:127.0.0.1:14561", "sysid": 1},
                {"connection": "udpin:127.0.0.1:14562", "sysid": 2},
            ],
        }
    )
    service = ConvoyService(cfg)
    heard: list[int] = []

    class Recorder:
        def __init__(self, sysid: int) -> None:
            self.sysid = sysid

        def handle(self, msg: Any) -> None:
            heard.append(self.sysid)

    service.vehicles = {1: Recorder(1), 2: Recorder(2)}  # type: ignore[dict-item]
    codec = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    forged = codec.heartbeat_encode(
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 0, 0, mavlink.MAV_STATE_ACTIVE
    )
    forged.pack(codec)
    service._route(1, forged)  # sysid 2's heartbeat, on UAV 1's link
    service._route(2, forged)  # the same, on its own link
    assert heard == [2]
    assert service._foreign_claims == {1: 1}
