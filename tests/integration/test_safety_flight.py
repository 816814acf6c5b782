"""A fence that cuts the plan, over real UDP against ``sitl_mock``: no setpoint leaves it.

The stationary convoy sits at the origin; the fence's north edge is 120 m north of
it, through the UAVs' orbits. Every setpoint the service sends is inside the
fence (checked at the mock's end: what the aircraft received), the plan and the
clamps are alarmed, and separation is watched (the layers keep crossing orbits apart).
"""

from __future__ import annotations

import asyncio
import math
from dataclasses import replace
from typing import Any

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.config import MissionConfig, SafetyConfig
from convoy_mav.demo import SCENARIOS, run_demo
from convoy_mav.fence import fence_from
from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
DURATION = 260.0


async def test_setpoints_stay_inside_a_fence_that_cuts_the_orbits() -> None:
    fences: list[Any] = []

    sent: list[tuple[int, float, float, float]] = []

    def fenced(cfg: MissionConfig) -> MissionConfig:
        frame = LocalFrame(cfg.origin)
        corners = [(120.0, -1500.0), (120.0, 1500.0), (-1500.0, 1500.0), (-1500.0, -1500.0)]
        ring = tuple((p.lat, p.lon) for p in (frame.to_geo(n, e) for n, e in corners))
        safety = SafetyConfig(fence=ring, max_alt_m=400.0, fence_margin_m=20.0)
        fences.append(fence_from(safety, frame))
        return replace(cfg, safety=safety)

    uploaded: dict[int, list[Any]] = {}

    async def watch(fleet: MockFleet, service: ConvoyService) -> None:
        while True:  # what the service sends, as it sends it
            uploaded.update({s: v.fence for s, v in fleet.vehicles.items() if v.fence})
            await asyncio.sleep(0.005)
            for sysid, v in service.vehicles.items():
                sp = v.last_setpoint
                if sp is not None:
                    sent.append((sysid, sp.north, sp.east, -sp.down))

    result = await run_demo(
        SCENARIOS["stationary"], duration=DURATION, speedup=SPEEDUP, configure=fenced,
        during=watch,
    )  # fmt: skip
    report = result.report.to_dict()
    fence = fences[0]
    assert sent and all(fence.contains(n, e) and up <= 400.0 for _, n, e, up in sent)
    assert sum(report["safety"]["fence_clamps"].values()) > 0
    kinds = {a["kind"] for a in report["alarms"]}
    assert {"fence", "fence_plan"} <= kinds, kinds
    # Each autopilot was given the fence too (mission protocol, fence items): it holds
    # the four inclusion vertices.
    uavs = [v["sysid"] for v in report["vehicles"]]
    assert report["safety"]["fence_uploads"] == dict.fromkeys(
        uavs, "geofence of 4 vertices uploaded"
    )
    for s in uavs:
        assert [item.command for item in uploaded[s]] == [5001] * 4
        assert all(item.param1 == 4.0 for item in uploaded[s])
    # From the mock's row of pads the planes launch in turn (test_launch_flight.py), and
    # their altitude layers keep their crossing orbits apart: no conflict, ever.
    raised = [a for a in report["alarms"] if a["kind"] == "separation" and a["active"]]
    assert report["safety"]["separation_conflicts"] == len(raised) == 0, raised


async def test_a_convoy_leaving_the_fence_is_not_followed_out() -> None:
    """The moving convoy (north-east, 8 m/s) crosses the fence's edge 1800 m along its
    road: the UAVs hold inside, on one loiter circle nearest it (each joining it from
    where it is, so a plane needs about a minute and a half to settle on it)."""
    fences: list[Any] = []
    frames: list[LocalFrame] = []

    def fenced(cfg: MissionConfig) -> MissionConfig:
        frame = LocalFrame(cfg.origin)
        edge = 1800.0 * math.sqrt(2.0)  # n + e = edge: the convoy's crossing, 225 s out
        corners = [(-5000.0, -5000.0), (-5000.0, 5000.0), (edge - 5000.0, 5000.0),
                   (5000.0, edge - 5000.0), (5000.0, -5000.0)]  # fmt: skip
        ring = tuple((p.lat, p.lon) for p in (frame.to_geo(n, e) for n, e in corners))
        safety = SafetyConfig(fence=ring, fence_margin_m=20.0)
        fences.append(fence_from(safety, frame))
        frames.append(frame)
        return replace(cfg, safety=safety)

    rows: list[tuple[float, int, float, float]] = []

    async def watch(fleet: MockFleet, service: ConvoyService) -> None:
        while True:
            await asyncio.sleep(0.05)
            for truth in fleet.truth_rows():
                if truth.kind == "aircraft" and truth.airborne:
                    n, e, _ = frames[0].to_ned(GeoPoint(truth.lat, truth.lon))
                    rows.append((service.clock.now(), truth.sysid, n, e))

    result = await run_demo(
        SCENARIOS["moving"], duration=420.0, speedup=SPEEDUP, configure=fenced, during=watch
    )
    report = result.report.to_dict()
    out = [a for a in report["alarms"] if a["kind"] == "convoy_outside_fence"]
    assert out and out[0]["active"] and "hold inside" in out[0]["message"], out
    left = out[0]["t"]
    assert 200.0 < left < 260.0, left
    fence = fences[0]
    settled = [(t, s, n, e) for t, s, n, e in rows if t > left + 90.0]
    assert settled, "no truth rows after the hold settled"
    outside = [r for r in settled if not fence.contains(r[2], r[3])]
    assert not outside, outside[:5]
    # One circle, the turn radius's, nearest the convoy's road beyond the edge.
    centre = fence.hold_center(1300.0, 1300.0, 150.0)
    late = [math.dist((n, e), centre) for t, _, n, e in settled if t > left + 150.0]
    assert late and all(110.0 < d < 200.0 for d in late), (min(late), max(late))
