"""A copter's speed limit read over real UDP, and the alarm when the plan outruns it.

The road planner's legs reach 1.15 of the airspeed. PX4 flies no OFFBOARD setpoint
faster than ``MPC_XY_VEL_MAX``, so a copter whose limit is the cruise speed falls
behind its slot on every fast leg. The mock's copters answer PARAM_REQUEST_READ as the
firmware does; ``demo`` builds them with the limit at the band's top, and one is built
here with it at the cruise speed. Raised from another ground station in flight, the
autopilot's PARAM_VALUE clears the alarm. ArduCopter's ``WPNAV_SPEED`` bounds no
GUIDED velocity target, so it is neither alarmed nor does it slow the copter.
"""

from __future__ import annotations

import asyncio

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.demo import SCENARIOS, run_demo
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)


def _station(fleet: MockFleet, sysid: int) -> mavutil.mavfile:
    """Another ground station on UAV ``sysid``'s port, as a user's MAVProxy would be."""
    port = int(fleet.endpoint(sysid).connect.rsplit(":", 1)[1])
    return mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=200)


async def test_a_px4_copter_slower_than_the_plan_is_alarmed_until_its_limit_is_raised() -> None:
    scenario = SCENARIOS["turning"]  # the road planner: legs up to 1.15 of 18 m/s
    param = "MPC_XY_VEL_MAX"
    marks: dict[str, object] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        """Another station raises the limit as the alarm says, once it is raised."""
        while "airframe:2" not in service._vehicle_alarms:
            await asyncio.sleep(0.01)
        marks["active"] = sorted(service._vehicle_alarms)
        gcs = _station(fleet, 2)
        try:
            gcs.mav.param_set_send(2, 1, param.encode(), 21.0, mavlink.MAV_PARAM_TYPE_REAL32)
            while "airframe:2" in service._vehicle_alarms:
                await asyncio.sleep(0.01)
            marks["cleared"] = True
        finally:
            gcs.close()

    result = await run_demo(
        scenario, duration=90.0, speedup=SPEEDUP, personality="px4", frame="copter",
        aircraft=[{"sysid": 2, "airspeed": scenario.airspeed_mps}], during=operator,
    )  # fmt: skip
    report = result.report.to_dict()
    assert marks["active"] == ["airframe:2"] and marks.get("cleared"), marks
    limits = {v["sysid"]: v["learnt"].get("speed_limit_mps") for v in report["vehicles"]}
    top = 1.15 * scenario.airspeed_mps
    assert limits == {s: (21.0 if s == 2 else pytest.approx(top)) for s in limits}, limits
    airframe = [(a["active"], a["message"]) for a in report["alarms"] if a["kind"] == "airframe"]
    assert airframe == [
        (True, f"UAV 2 flies no faster than 18.0 m/s ({param}), the plan asks for up to "
               f"20.7 m/s: set {param} to at least 21 or scale airspeed_mps by 0.87"),
        (False, f"UAV 2 flies the plan's speeds now (up to 21.0 m/s ({param}))"),
    ]  # fmt: skip


async def test_an_arducopter_flies_the_plans_speeds_whatever_its_wpnav_speed() -> None:
    scenario = SCENARIOS["turning"]
    marks: dict[str, float] = {}
    speeds: list[float] = []  # UAV 2's true speed, once its WPNAV_SPEED is 7 m/s

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        """Another station sets WPNAV_SPEED to 7 m/s on UAV 2 once the fleet protects."""
        while service.monitor.protect_start is None:
            await asyncio.sleep(0.01)
        gcs = _station(fleet, 2)
        try:
            gcs.mav.param_set_send(2, 1, b"WPNAV_SPEED", 700.0, mavlink.MAV_PARAM_TYPE_REAL32)
            marks["set_at"] = fleet.now
        finally:
            gcs.close()
        await fleet.wait_until(marks["set_at"] + 5.0)
        while True:  # (cancelled when the flight ends)
            speeds.append(fleet.truth(2).speed)
            await asyncio.sleep(0.01)

    result = await run_demo(
        scenario, duration=120.0, speedup=SPEEDUP, personality="ardupilot", frame="copter",
        during=operator,
    )  # fmt: skip
    report = result.report.to_dict()
    assert "set_at" in marks
    assert not [a for a in report["alarms"] if a["kind"] == "airframe"]
    assert all("speed_limit_mps" not in v["learnt"] for v in report["vehicles"])
    assert speeds and max(speeds) > 15.0, max(speeds, default=None)  # (not held to 7 m/s)
    assert result.truth is not None and result.truth.fraction >= 0.99, result.truth


async def test_an_arducopter_slower_than_the_plan_is_seen_so_in_flight() -> None:
    """No parameter says how fast an ArduCopter flies (its lean at ANGLE_MAX does):
    one built with a top speed of 12 m/s, asked for the road planner's 20.7, is seen
    saturated behind its slot, and alarmed with that speed; the others are not."""
    scenario = SCENARIOS["turning"]
    result = await run_demo(
        scenario, duration=150.0, speedup=SPEEDUP, personality="ardupilot", frame="copter",
        aircraft=[{"sysid": 2, "airspeed": 12.0}],
    )  # fmt: skip
    report = result.report.to_dict()
    tops = {v["sysid"]: v["learnt"].get("top_speed_mps") for v in report["vehicles"]}
    assert tops == {s: (pytest.approx(12.0, abs=0.2) if s == 2 else None) for s in tops}, tops
    raised = [a["message"] for a in report["alarms"] if a["kind"] == "airframe"]
    assert len(raised) == 1 and raised[0].startswith("UAV 2 flies no faster than 1"), raised
    assert raised[0].endswith(
        "m/s (seen in flight, behind its slot), the plan asks for up to 20.7 m/s: let it "
        "lean further (ANGLE_MAX) or scale airspeed_mps by 0.58"
    ), raised
