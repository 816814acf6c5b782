"""A copter's speed limit read over real UDP, and the alarm when the plan outruns it.

The road planner's legs reach 1.15 of the airspeed. A multicopter flies no setpoint
faster than its limit (PX4 ``MPC_XY_VEL_MAX``, ArduCopter ``WPNAV_SPEED``), so a copter
whose limit is the cruise speed falls behind its slot on every fast leg. The mock's
copters answer PARAM_REQUEST_READ as the firmware does; ``demo`` builds them with the
limit at the band's top, and one is built here with it at the cruise speed. Raised
from another ground station in flight, the autopilot's PARAM_VALUE clears the alarm.
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


@pytest.mark.parametrize(
    ("personality", "param"), [("px4", "MPC_XY_VEL_MAX"), ("ardupilot", "WPNAV_SPEED")]
)
async def test_a_copter_slower_than_the_plan_raises_the_airframe_alarm(
    personality: str, param: str
) -> None:
    scenario = SCENARIOS["turning"]  # the road planner: legs up to 1.15 of 18 m/s
    fix = 21 if param == "MPC_XY_VEL_MAX" else 2070
    marks: dict[str, object] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        """Another station raises the limit as the alarm says, once it is raised."""
        while "airframe:2" not in service._vehicle_alarms:
            await asyncio.sleep(0.01)
        marks["active"] = sorted(service._vehicle_alarms)
        port = int(fleet.endpoint(2).connect.rsplit(":", 1)[1])
        gcs = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=200)
        try:
            gcs.mav.param_set_send(2, 1, param.encode(), fix, mavlink.MAV_PARAM_TYPE_REAL32)
            while "airframe:2" in service._vehicle_alarms:
                await asyncio.sleep(0.01)
            marks["cleared"] = True
        finally:
            gcs.close()

    result = await run_demo(
        scenario, duration=90.0, speedup=SPEEDUP, personality=personality, frame="copter",
        aircraft=[{"sysid": 2, "airspeed": scenario.airspeed_mps}], during=operator,
    )  # fmt: skip
    report = result.report.to_dict()
    assert marks["active"] == ["airframe:2"] and marks.get("cleared"), marks
    limits = {v["sysid"]: v["learnt"].get("speed_limit_mps") for v in report["vehicles"]}
    top = 1.15 * scenario.airspeed_mps
    raised = 21.0 if fix == 21 else 20.7  # (in m/s)
    assert limits == {s: (raised if s == 2 else pytest.approx(top)) for s in limits}, limits
    airframe = [(a["active"], a["message"]) for a in report["alarms"] if a["kind"] == "airframe"]
    assert airframe == [
        (True, f"UAV 2 flies no faster than 18.0 m/s ({param}), the plan asks for up to "
               f"20.7 m/s: set {param} to at least {fix} or scale airspeed_mps by 0.87"),
        (False, f"UAV 2 flies the plan's speeds now (up to {raised:.1f} m/s ({param}))"),
    ]  # fmt: skip
