"""The service's own MAVLink ids (``[mission] source_system``) against autopilots that
hear only their ground station: ArduPilot's MAV_OPTIONS bit 0 (SYSID_ENFORCE before),
which drops every frame from a system other than MAV_GCS_SYSID or its own. The mock's
ArduPilot does the same (``GCS_MAVLINK::accept_packet``), over real UDP."""

from __future__ import annotations

from dataclasses import replace

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.demo import SCENARIOS, run_demo
from sitl_mock.server import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
GCS = 42  # the system id these autopilots were given as their ground station's


async def _hear_only_gcs(fleet: MockFleet, service: ConvoyService) -> None:
    """As an operator set them before the flight (MAV_GCS_SYSID 42, MAV_OPTIONS 1)."""
    for vehicle in fleet.vehicles.values():
        vehicle.gcs_sysid, vehicle.mav_options = GCS, 1


@pytest.mark.parametrize("source_system", [GCS, 255], ids=["its-gcs", "default-ids"])
async def test_an_ardupilot_that_hears_only_its_gcs_is_flown_under_that_id(
    source_system: int,
) -> None:
    """Under MAV_GCS_SYSID the service flies it as ever. Under the default 255 the
    autopilot hears nothing the service sends: the set-up gives up, and says why."""
    flies = source_system == GCS
    result = await run_demo(
        SCENARIOS["stationary"],
        duration=160.0 if flies else 40.0,
        speedup=SPEEDUP,
        personality="ardupilot",
        frame="copter",
        configure=lambda c: replace(
            c, source_system=source_system, setup_timeout_s=c.setup_timeout_s if flies else 25.0
        ),
        during=_hear_only_gcs,
    )
    report = result.report.to_dict()
    statuses = {v["sysid"]: v["status"] for v in report["vehicles"]}
    if flies:
        assert "failed" not in statuses.values(), statuses
        assert result.truth is not None and result.truth.fraction >= 0.99
        return
    assert set(statuses.values()) == {"failed"}, statuses
    assert result.truth is None  # (never protected)
    for vehicle in report["vehicles"]:
        said = vehicle["failure"]
        assert said.startswith(f"UAV {vehicle['sysid']} (ArduCopter): HEARTBEATs only"), said
        assert "it answered nothing from our system id 255" in said
        assert "which [mission] source_system must be" in said
    assert any("every UAV failed its set-up" in e for e in report["events"])
