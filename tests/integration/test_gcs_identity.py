"""The service's own MAVLink ids (``[mission] source_system``) against autopilots that
hear only their ground station: ArduPilot's MAV_OPTIONS bit 0 (SYSID_ENFORCE before),
which drops every frame from a system other than MAV_GCS_SYSID or its own. The mock's
ArduPilot does the same (``GCS_MAVLINK::accept_packet``), over real UDP."""

from __future__ import annotations

import asyncio
import contextlib
from dataclasses import replace
from typing import TYPE_CHECKING

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.clock import MissionClock
from convoy_mav.demo import SCENARIOS, run_demo
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.types import VehicleStatus
from convoy_mav.vehicle import Vehicle, VehicleEvent
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet
from tests.hostspeed import host_speedup

if TYPE_CHECKING:
    from tests.conftest import StartMock

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
GCS = 42  # the system id these autopilots were given as their ground station's


async def _hear_only_gcs(fleet: MockFleet, service: ConvoyService) -> None:
    """As an operator set them before the flight (MAV_GCS_SYSID 42, MAV_OPTIONS 1)."""
    for vehicle in fleet.vehicles.values():
        vehicle.gcs_sysid, vehicle.mav_options = GCS, 1


async def test_an_ardupilot_that_hears_only_its_gcs_is_flown_under_that_id() -> None:
    result = await run_demo(
        SCENARIOS["stationary"],
        duration=160.0,
        speedup=SPEEDUP,
        personality="ardupilot",
        frame="copter",
        configure=lambda c: replace(c, source_system=GCS),
        during=_hear_only_gcs,
    )
    report = result.report.to_dict()
    statuses = {v["sysid"]: v["status"] for v in report["vehicles"]}
    assert "failed" not in statuses.values(), statuses
    assert result.truth is not None and result.truth.fraction >= 0.99


@pytest.mark.parametrize(
    ("frame", "why"),
    [
        # ArduCopter streams nothing until asked (its SRn_* are 0): HEARTBEATs only.
        ("copter", "no position fix within 25 s (no GPS_RAW_INT, no GLOBAL_POSITION_INT)"),
        # ArduPlane streams at 1 Hz from boot, and sends its home once set: its set-up's
        # first step goes unanswered.
        ("plane", "set-up gave up after 25 s at step 'set TKOFF_ALT = "),
    ],
)
async def test_under_other_ids_it_hears_nothing_and_the_service_says_why(
    frame: str, why: str
) -> None:
    """Under the default 255 the autopilot hears nothing the service sends: the set-up
    says early what may be wrong, gives up at its time-out and says why."""
    result = await run_demo(
        SCENARIOS["stationary"],
        duration=45.0,
        speedup=SPEEDUP,
        personality="ardupilot",
        frame=frame,
        configure=lambda c: replace(c, setup_timeout_s=25.0),
        during=_hear_only_gcs,
    )
    report = result.report.to_dict()
    assert result.truth is None  # (never protected)
    hint = (
        "it answered nothing from our system id 255: an ArduPilot with MAV_OPTIONS bit 0 "
        "(SYSID_ENFORCE) hears only its MAV_GCS_SYSID (SYSID_MYGCS), which [mission] "
        "source_system must be"
    )
    for vehicle in report["vehicles"]:
        assert vehicle["status"] == "failed", vehicle
        said = vehicle["failure"]
        assert said.startswith(f"UAV {vehicle['sysid']} (Ardu"), said
        assert why in said and said.endswith(hint), said
    if frame == "plane":  # (said early, after five tries, while the set-up went on)
        early = [e for e in report["events"] if "5 tries, no answer" in e]
        assert len(early) == len(report["vehicles"]) and all(e.endswith(hint) for e in early)


async def test_a_fleet_that_sends_nothing_asked_for_fails_its_set_up_and_says_why(
    start_mock: StartMock,
) -> None:
    """Nobody streams (an ArduCopter, its SRn_* 0, hearing only its ground station):
    no mission time ever begins. The set-up asks again every 5 s as the rate hint
    counts them, and gives up at its time-out; before, it waited for ever."""
    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality="ardupilot", frame="copter"
    )
    fleet = await start_mock(config)
    fleet.vehicles[1].gcs_sysid, fleet.vehicles[1].mav_options = GCS, 1
    clock = MissionClock(rate_hint=SPEEDUP)
    events: list[VehicleEvent] = []
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(
        1, link, clock, LocalFrame(config.origin), on_event=events.append, setup_timeout=20.0
    )
    async with link:
        task = asyncio.create_task(vehicle.run())
        try:
            async with asyncio.timeout(20.0 / SPEEDUP + 10.0):
                while vehicle.status is not VehicleStatus.FAILED:
                    await asyncio.sleep(0.01)
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
    assert not clock.synced
    assert vehicle.failure is not None and vehicle.failure.startswith(
        "UAV 1 (ArduCopter): heard, but none of the telemetry asked for in 20 s (5 requests)"
    ), vehicle.failure
    assert vehicle.failure.endswith("which [mission] source_system must be")
    assert fleet.vehicles[1].counters["not_from_gcs"] > 5  # (all it was sent, dropped)
