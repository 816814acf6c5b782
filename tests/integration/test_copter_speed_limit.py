"""A copter's speed limit read over real UDP, and the alarm when the plan outruns it.

The road planner's legs reach 1.15 of the airspeed. A multicopter flies no setpoint
faster than its limit (PX4 ``MPC_XY_VEL_MAX``, ArduCopter ``WPNAV_SPEED``), so a copter
whose limit is the cruise speed falls behind its slot on every fast leg. The mock's
copters answer PARAM_REQUEST_READ as the firmware does; ``demo`` builds them with the
limit at the band's top, and one is built here with it at the cruise speed.
"""

from __future__ import annotations

import pytest

from convoy_mav.demo import SCENARIOS, run_demo
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
    result = await run_demo(
        scenario, duration=90.0, speedup=SPEEDUP, personality=personality, frame="copter",
        aircraft=[{"sysid": 2, "airspeed": scenario.airspeed_mps}],
    )  # fmt: skip
    report = result.report.to_dict()
    limits = {v["sysid"]: v["learnt"].get("speed_limit_mps") for v in report["vehicles"]}
    top = 1.15 * scenario.airspeed_mps
    assert limits == {s: (18.0 if s == 2 else pytest.approx(top)) for s in limits}, limits
    raised = [a for a in report["alarms"] if a["kind"] == "airframe" and a["active"]]
    assert [a["message"] for a in raised] == [
        f"UAV 2 flies no faster than 18.0 m/s ({param}), the plan asks for up to 20.7 m/s: "
        f"set {param} to at least {21 if param == 'MPC_XY_VEL_MAX' else 2070} or scale "
        "airspeed_mps by 0.87"
    ]
