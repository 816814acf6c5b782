"""A stranger takes a UAV out of the mission (DO_SET_MODE from another ground station).

The service respects it (it does not fight for the aircraft), raises ``uav_taken``,
re-phases the others around the gap, and flies the UAV in its slot again when the
operator resumes it. Against ``sitl_mock`` over real UDP, scored from its ground truth.

Seconds before, the same UAV failed safe when our setpoints stopped reaching it (its
uplink down): that hold is ours, and it is taken back. The stranger's, right after,
is not, though our stream has just resumed and the failsafe's text is the last the
autopilot sent (each once made the service fight the stranger: a loaded host's
stream hiccups did what the uplink does here).
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.demo import SCENARIOS, run_demo
from convoy_mav.types import VehicleStatus
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
DEAF_AT = 125.0  # sim s: into the protect phase, UAV 2's uplink goes down ...
DEAF_S = 3.0  # ... for this long: it fails safe to its hold
TAKE_AFTER_S = 2.0  # sim s after it flies again, the stranger takes it
RESUME_AT = 260.0
DURATION = 420.0
PX4_AUTO, PX4_LOITER = 4, 3  # main and sub mode of AUTO.LOITER


async def test_a_uav_taken_by_another_station_is_alarmed_rephased_and_resumed() -> None:
    scenario = SCENARIOS["stationary"]
    uavs = scenario.fleet() + 1
    marks: dict[str, Any] = {}

    async def stranger(fleet: MockFleet, service: ConvoyService) -> None:
        while service.monitor.protect_start is None or fleet.now < DEAF_AT:
            await asyncio.sleep(0.01)
        link, uav = fleet.link(2), service.vehicles[2]

        def note_held() -> None:
            if "held_at" not in marks and uav.status is not VehicleStatus.FLYING:
                marks["held_at"] = fleet.now

        link.deaf = True
        marks["deaf_at"] = fleet.now
        while fleet.now < marks["deaf_at"] + DEAF_S:
            note_held()
            await asyncio.sleep(0.01)
        link.deaf = False
        while "held_at" not in marks or uav.status is not VehicleStatus.FLYING:
            note_held()
            await asyncio.sleep(0.01)
        marks["flying_again_at"] = fleet.now
        await fleet.wait_until(marks["flying_again_at"] + TAKE_AFTER_S)
        port = int(fleet.endpoint(2).connect.rsplit(":", 1)[1])
        gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=200)
        try:
            marks["taken_at"] = fleet.now
            gcs.mav.command_long_send(
                2, 1, mavlink.MAV_CMD_DO_SET_MODE, 0,
                mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, PX4_AUTO, PX4_LOITER, 0, 0, 0, 0,
            )  # fmt: skip
            while 2 not in service.view.lost:
                await asyncio.sleep(0.01)
            marks["rephased_at"] = fleet.now
            marks["alarms"] = sorted(service.monitor.active | service._vehicle_alarms)
            while fleet.now < RESUME_AT:
                await asyncio.sleep(0.01)
            service.command("resume")  # (what {"command": "resume"} on MQTT does)
            while 2 in service.view.lost:
                await asyncio.sleep(0.01)
            marks["rejoined_at"] = fleet.now
        finally:
            gcs.close()

    result = await run_demo(
        scenario, duration=DURATION, speedup=SPEEDUP, uavs=uavs, during=stranger
    )
    report = result.report.to_dict()
    taken = [a for a in report["alarms"] if a["kind"] == "uav_taken"]
    # (what the stranger got to do, and when protection began, for a run that fails here)
    assert [a["active"] for a in taken] == [True, False], (taken, marks, report["protect_start_s"])
    # its own failsafe before was taken back, in seconds
    assert any("uav2: re-engaging" in e for e in report["events"]), marks
    assert marks["flying_again_at"] - marks["deaf_at"] < DEAF_S + 10.0, marks
    assert "uav_taken:2" in marks["alarms"]
    assert marks["rephased_at"] - marks["taken_at"] < 10.0  # (3 s to tell it from a reboot)
    assert "rejoined_at" in marks
    assert any(r["reason"] == "uav_lost" for r in report["replans"])
    # The others went on covering the convoy (a spare UAV; each re-phase costs a
    # join: 90-97 % over the protect phase in five runs), by the mock's truth.
    assert result.truth is not None and result.truth.fraction >= 0.85, result.truth
