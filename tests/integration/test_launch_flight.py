"""Take-offs from the mock's row of pads (10 m apart), over real UDP: never abreast.

Scored from the mock's ground truth, sampled every few mission tenths of a second:
no two armed aircraft are ever closer than the separation minima (30 m horizontally
and 3 m vertically), they launch from the top layer down, and the service's own
monitor saw no conflict either. With the sequence turned off, the same check finds
the conflicts it prevents (the PX4 copters flew to their first setpoint on a slant
through each other's climb).
"""

from __future__ import annotations

import asyncio
from dataclasses import replace

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.config import MissionConfig
from convoy_mav.demo import SCENARIOS, run_demo
from convoy_mav.separation import conflicts
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
DURATION = 110.0  # mission s: every aircraft is up at its layer by then


async def fly(
    personality: str, frame: str, sequenced: bool, warmups: dict[int, float] | None = None
) -> tuple[list[str], dict[int, float], int]:
    """Conflicts seen in the truth, the mission time each aircraft armed, and the
    service's count of separation conflicts. ``warmups``: sim s an aircraft refuses
    ARM after boot ("Need Position Estimate"), by sysid."""
    seen: list[str] = []
    armed: dict[int, float] = {}

    def configure(cfg: MissionConfig) -> MissionConfig:
        return replace(cfg, safety=replace(cfg.safety, launch_sequence=sequenced))

    async def watch(fleet: MockFleet, service: ConvoyService) -> None:
        while True:
            await asyncio.sleep(0.01)
            rows = [r for r in fleet.truth_rows() if r.kind == "aircraft" and r.armed]
            for r in rows:
                armed.setdefault(r.sysid, r.t)
            found = conflicts({r.sysid: (r.north, r.east, r.down) for r in rows}, 30.0, 3.0)
            seen.extend(f"{c.a}-{c.b} {c.horizontal_m:.0f} m, {c.vertical_m:.1f} m" for c in found)

    result = await run_demo(
        SCENARIOS["stationary"], duration=DURATION, speedup=SPEEDUP, personality=personality,
        frame=frame, configure=configure, during=watch,
        aircraft=[{"sysid": s, "warmup": w} for s, w in (warmups or {}).items()],
    )  # fmt: skip
    report = result.report.to_dict()
    return seen, armed, report["safety"]["separation_conflicts"]


@pytest.mark.parametrize(
    "personality, frame",
    [("px4", "plane"), ("px4", "copter"), ("ardupilot", "plane"), ("ardupilot", "copter")],
)
async def test_a_row_of_pads_launches_top_layer_first_and_never_abreast(
    personality: str, frame: str
) -> None:
    seen, armed, monitored = await fly(personality, frame, sequenced=True)
    assert not seen, seen[:5]
    assert monitored == 0
    assert len(armed) >= 4
    order = sorted(armed, key=armed.__getitem__)
    assert order == sorted(armed, reverse=True), armed  # (layers rise with the sysid)


async def test_without_the_sequence_the_copters_climb_out_through_each_other() -> None:
    seen, _, monitored = await fly("px4", "copter", sequenced=False)
    assert seen and monitored > 0


async def test_a_uav_whose_autopilot_refuses_to_arm_still_holds_its_neighbours() -> None:
    """ArduCopter SITL refused the top layer's ARM ("Need Position Estimate") for
    25 s after the sequence cleared it; its neighbour, cleared once the first had been
    waited for a while, took off beside it when it armed at last (30 m apart, 1.2 m
    vertically). A UAV cleared to launch holds its neighbours for as long as it arms."""
    # Homes set at 12 s (half the warm-up: ArduPilot takes GUIDED from then), so UAV 4
    # waits for UAV 5 from about 13 s, yielding to it until about 33 s; UAV 5 is
    # cleared at about 21 s and refused ARM until 40 s, past its 10 s of clearance.
    warmups = {1: 24.0, 2: 24.0, 3: 24.0, 4: 24.0, 5: 40.0}
    seen, armed, monitored = await fly("ardupilot", "copter", sequenced=True, warmups=warmups)
    assert not seen, seen[:5]
    assert monitored == 0
    order = sorted(armed, key=armed.__getitem__)
    assert order == sorted(armed, reverse=True), armed
    assert armed[5] >= 40.0, armed  # (it was refused until then)
