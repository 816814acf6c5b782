"""A rover in AUTO as the firmware drives it, end to end: its mission read, its corners learnt.

The mock's lead rover drives a city circuit as ArduRover does (``sitl_mock.drive``:
braking at 1 m/s² to 2-3 m/s for each corner, a hold, a slower stretch set by
DO_CHANGE_SPEED), and serves it as its mission. The service reads the route, its hold and
its speeds over MAVLink (``[convoy] route = "mission"``), learns how slowly the convoy
takes its corners, and protects it; over real UDP against ``sitl_mock`` at 20x, both
personalities, scored from the mock's ground truth. And its
operator holds it a minute (HOLD, then AUTO, from a ground station of their own): the
rover stands, the service hears it and watches a standing convoy; or tells it a slower
speed (DO_CHANGE_SPEED): the rover keeps it until its mission's next, and the service
forecasts it at that. Or holds the follower alone, or sends it home: it parts from the
convoy, and the service protects the lead.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import AsyncIterator, Awaitable, Callable, Coroutine
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.coverage import CoverageStats
from convoy_mav.demo import SCENARIOS, DemoResult, run_demo
from sitl_mock.drive import Ramps, corner_speed
from sitl_mock.server import MockFleet
from tests.hostspeed import host_speedup

# 20x: at 40x on two cores the UAVs flew their legs late, each of the three flights
# below missed its bound in a clean-clone CI run (the truth 2.6-2.7 points under the
# prediction, or 95.2 % against a bar of 96 %), and four flights of the slowed rovers
# gave up to 2.6 points under it; at 20x, 0.6-1.4 in three.
SPEEDUP = host_speedup(20.0)
pytestmark = pytest.mark.integration
_LATE_OVER = 0.04  # (the prediction's further room over the truth on a host late to fly)

# A lap of 2.2 km round six city corners, the third held 30 s; 8 m/s, then 6 m/s from
# the fourth corner back round to the start.
CIRCUIT = {
    "route": "polyline",
    "points": [[0, 0], [500, 0], [500, 350], [250, 350], [250, 600], [0, 600]],
    "loop": True,
    "speed": 8.0,
    "accel": 1.0,  # ArduRover's ATC_ACCEL_MAX (WP_RADIUS 2 m and WP_JERK 0: the defaults)
    "holds": [[2, 30.0]],
    "speeds": [[0, 8.0], [3, 6.0]],
}


# Held at its speedup and flown after the parallel run, two at a time (``paired``): beside
# two other flights at 40x on two cores its UAVs flew their legs seconds late (a CI run:
# 94.3 % against 98.5 % predicted) and slowed the others' (a keep-alive test missed its
# deadline). One beside another, each a core to itself (2026-12-02, the ten flights twice,
# 203 and 195 s against 408 s one at a time): each flight as long as alone (31-46 s
# against 34-48), the prediction -0.6 to +0.3 points of the truth (alone -0.5 to +0.1).
@pytest.mark.paired
@pytest.mark.parametrize(("personality", "planned"), [("ardupilot", True), ("px4", False)])
async def test_a_rovers_corners_are_learnt_and_its_convoy_protected(
    personality: str, planned: bool
) -> None:
    """With its speeds in the mission; or none (a PX4 rover's default speed is not asked):
    the speed it keeps between corners learnt from the drive."""
    scenario = SCENARIOS["turning"]
    road = CIRCUIT if planned else {k: v for k, v in CIRCUIT.items() if k != "speeds"}
    result = await run_demo(
        scenario, duration=600.0, speedup=SPEEDUP, personality=personality,
        uavs=scenario.fleet(route_known=True), route_mission=True, road=road,
    )  # fmt: skip
    report = result.report.to_dict()
    planner = report["planner"]
    assert planner["name"] == "road" and planner["route_known"] is True
    # The mission read: a circuit of six corners, its hold and both speeds.
    source = planner["route_source"]
    assert source.startswith("ground vehicle") and "mission (a circuit" in source, source
    said = "1 holds, 30 s, 2 speeds, 6-8 m/s" if planned else "1 holds, 30 s)"
    assert said in source, source
    # The corners learnt: under 0.6 of the planned 8 m/s, as the rover drives them (2.38
    # m/s at each corner, braked for over 34 m), so the forecast slows for them.
    at_corner = corner_speed(math.pi / 2, Ramps(1.0, 1.0), 2.0)
    learnt = planner["convoy_corner_speed_mps"]
    assert learnt is not None and 0.6 * at_corner < learnt < 0.6 * 8.0, learnt
    if not planned:  # (its 8 m/s, the 75th percentile of its speeds while driving)
        assert planner["convoy_cruise_mps"] == pytest.approx(8.0, abs=0.3)
    truth = result.truth
    assert truth is not None and report["protect_start_s"] < 240.0
    # (measured at 15x, 900 s: 99.24 % with the corners forecast, 98.92 % without)
    assert truth.fraction >= 0.96, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 12.0, truth
    # (1.5 points, as the road replays allow a flight beside another)
    _assert_predicted(report, truth, 0.015)


_ARDUROVER_HOLD, _ARDUROVER_AUTO, _ARDUROVER_RTL, _ARDUROVER_SMART_RTL = 4, 10, 11, 12


@pytest.mark.paired
async def test_a_rover_its_operator_holds_stands_and_is_watched_standing() -> None:
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        """Holds every ground vehicle of the convoy, as its operator does, then AUTO."""
        lead = service.config.convoy.vehicles[0].sysid
        await _until_protected(fleet, service, 250.0)
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        async with _ground_station(fleet, service) as tell:
            for mode, name, hold_s in (
                (_ARDUROVER_HOLD, "held", 60.0),
                (_ARDUROVER_AUTO, "auto", 20.0),
            ):
                marks[name] = fleet.now
                await tell("set_mode_send", flag, mode)
                await _until(fleet, marks[name] + 15.0)
                marks[f"{name}+15"] = fleet.truth(lead)
                await _until(fleet, marks[name] + hold_s)
                marks[f"{name}+end"] = fleet.truth(lead)

    result = await _operated(operator, 480.0)
    report = result.report.to_dict()
    assert "auto+end" in marks, marks
    # The rover braked to a stand within 15 s and stood the minute; in AUTO it drove on.
    stood, still = marks["held+15"], marks["held+end"]
    assert stood.mode == "HOLD" and stood.speed == 0.0, stood
    assert (still.north, still.east) == (stood.north, stood.east)
    assert marks["auto+15"].mode == "AUTO" and marks["auto+15"].speed > 2.0, marks["auto+15"]
    # The service heard each mode, in order, and said what it makes of it.
    modes = [m["mode"] for m in report["planner"]["convoy_modes"]]
    assert modes == ["AUTO", "HOLD", "AUTO"], modes
    heard = report["planner"]["convoy_modes"][1]["t"]  # (mission time: the mock's clock)
    assert marks["held"] - 1.0 <= heard <= marks["held"] + 5.0  # (HEARTBEAT at 1 Hz)
    assert any("in HOLD (was AUTO): it stands" in e for e in report["events"]), report["events"]
    truth = result.truth
    assert truth is not None
    # (seven flights at 40x: 95.2-98.8 %, predicted 0.0-2.6 points higher, as the UAVs flew
    # their legs late at that speedup; 98.1-98.3 % without the hold. Over 360 s of
    # protection one 10-s gap is 2.8 points.)
    assert truth.fraction >= 0.94, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 12.0, truth
    _assert_predicted(report, truth, 0.02)


@pytest.mark.paired
@pytest.mark.parametrize(
    ("mode", "name"),
    [(_ARDUROVER_HOLD, "HOLD"), (_ARDUROVER_RTL, "RTL"), (_ARDUROVER_SMART_RTL, "SMART_RTL")],
)
async def test_a_follower_its_operator_holds_or_sends_home_parts_and_the_lead_is_protected(
    mode: int, name: str
) -> None:
    """One truck stopped, or sent home (straight, or back along its path), by its own
    operator or its failsafe while the lead drives on: its HEARTBEAT says so, and 3 s
    later it has parted from the convoy, the service says why and protects the lead,
    scored from the truth of the lead's group. (Before, the
    convoy stayed the centroid of the two, drifting back between them: in a flight of
    600 s at 20x its UAVs saw the lead 52 % of the protect phase, while the truth of that
    centroid said 93 %; parted by distance alone, 200 m off, the held one's ten flights
    gave 94.9-99.3 %, most of the loss in the 40 s after it parted, the estimate 100 m on
    at once, and one sent home rejoined as the lead passed its home, 88.9-97.0 %; back
    along its path, read as a driver's mode, 96.0-97.2 % in three.)"""
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        follower = service.config.convoy.vehicles[1].sysid
        await _until_protected(fleet, service, 220.0)
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        async with _ground_station(fleet, service, only=follower) as tell:
            marks["told"] = fleet.now
            await tell("set_mode_send", flag, mode)
            # (back along its path, 1.5 km of it, it is home some 205 s later)
            await _until(fleet, marks["told"] + (230.0 if name == "SMART_RTL" else 200.0))
            marks["end"] = (
                fleet.truth(follower),
                fleet.truth(service.config.convoy.vehicles[0].sysid),
            )

    result = await _operated(operator, 480.0)
    report = result.report.to_dict()
    assert "end" in marks, marks
    stood, lead = marks["end"]
    assert stood.mode == name and stood.speed == 0.0, stood  # (held, or home)
    assert lead.mode == "AUTO" and lead.speed > 0.0, lead
    # Parted 3 s after its HEARTBEAT said so (at 1 Hz), a few tens of metres behind.
    (parted,) = report["planner"]["convoy_parted"]
    assert parted["source"] == stood.sysid and parted["event"] == "parted", parted
    assert marks["told"] + 2.0 <= parted["t"] <= marks["told"] + 8.0, (parted, marks["told"])
    assert parted["apart_m"] is not None and parted["apart_m"] < 80.0, parted
    does = {"HOLD": "stands", "RTL": "drives home", "SMART_RTL": "drives home back along its path"}
    said = f"in {name}: it {does[name]} while the lead drives"
    assert said in parted["why"], parted
    alarms = [a for a in report["alarms"] if a["kind"] == "convoy_parted"]
    assert [a["active"] for a in alarms] == [True], alarms
    assert f"ground vehicle {stood.sysid} parted from the convoy ({said}" in alarms[0]["message"]
    assert report["planner"]["convoy_modes"] == [report["planner"]["convoy_modes"][0]]  # (lead's)
    truth = result.truth
    assert truth is not None
    # (2026-12-01 at 20x, seven flights held and five sent home: 97.0-99.6 and
    # 97.3-99.2 %, longest gaps 1.0-7.6 s; predicted 0.0-2.2 points over the truth;
    # three sent back along its path: 98.3-98.8 %, gaps 1.8-2.4 s, 0.2-0.6 over)
    assert truth.fraction >= 0.95, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 12.0, truth
    _assert_predicted(report, truth, 0.03)


@pytest.mark.paired
async def test_a_lead_sent_home_back_along_its_path_is_forecast_round_its_corners() -> None:
    """SMART_RTL on the lead 220 s into the circuit (its operator, or its failsafe:
    ArduRover's FS_ACTION 3 and 4): it turns round and drives home back along its path,
    round the corners it took, and stands where it set off. The service hears the mode
    and forecasts the convoy back along the path it saw it drive, to that start."""
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        lead = service.config.convoy.vehicles[0].sysid
        await _until_protected(fleet, service, 220.0)
        marks["home"] = fleet.world.to_ned(fleet.vehicles[lead].flight.home)  # (where armed)
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        async with _ground_station(fleet, service, only=lead) as tell:
            marks["told"] = fleet.now
            await tell("set_mode_send", flag, _ARDUROVER_SMART_RTL)
            await _until(fleet, marks["told"] + 240.0)  # (1.6 km back: home 220 s on)
            marks["end"] = fleet.truth(lead)

    result = await _operated(operator, 480.0)
    report = result.report.to_dict()
    assert "end" in marks, marks
    (hn, he, _), end = marks["home"], marks["end"]
    assert end.mode == "SMART_RTL" and end.speed == 0.0, end
    assert math.hypot(end.north - hn, end.east - he) <= 3.0, (end, hn, he)
    said = "in SMART_RTL (was AUTO): it drives home back along its path: forecast back along"
    assert any(said in e for e in report["events"]), report["events"]
    truth = result.truth
    assert truth is not None
    # (2026-12-01, seven flights at 15.6x, this host's share of 20x: 95.3-99.3 %, median
    # 97.6, longest gaps 0.7-11.2 s; forecast from its own velocity, as a driver's mode,
    # before: 93.7-98.6 %, median 96.6, gaps 2.2-16.5 s. The circuit's own corners cost
    # as much before the switch: the forecast itself is ``test_retrace.py``'s and
    # ``test_forecast.py``'s, its error 20 s on at most 44 m from the convoy here, 160 m
    # before.)
    assert truth.fraction >= 0.95, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 12.0, truth
    _assert_predicted(report, truth, 0.03)


@pytest.mark.paired
async def test_a_rover_its_operator_calls_home_is_watched_off_its_route_and_back() -> None:
    """RTL from the circuit (the lead alone, the convoy behind it): the lead drives
    straight home across the block and stands there; in AUTO it drives back to the
    waypoint it left and on round the circuit. The service hears each mode, asks the
    lead's HOME_POSITION and forecasts the convoy straight home, off its route, then
    straight back to the waypoint its MISSION_CURRENT names and on along the route.
    RTL again with a rally point nearer than home: the service reads it and forecasts
    the convoy there."""
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        lead = service.config.convoy.vehicles[0].sysid
        await _until_protected(fleet, service, 200.0)
        flag = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        home = fleet.world.to_ned(fleet.vehicles[lead].flight.home)
        async with _ground_station(fleet, service, only=lead) as tell:
            marks["rtl"], marks["left"] = fleet.now, fleet.truth(lead)
            await tell("set_mode_send", flag, _ARDUROVER_RTL)
            await _until(fleet, marks["rtl"] + 120.0)
            marks["home"] = fleet.truth(lead), home
            marks["auto"] = fleet.now
            await tell("set_mode_send", flag, _ARDUROVER_AUTO)
            await _until(fleet, marks["auto"] + 30.0)
            marks["auto+30"] = fleet.truth(lead)
            # Once 300 m from home, a rally point 150 m to its left (its operator's upload,
            # as stored), and RTL: ArduRover drives there, nearer than home; AUTO again.
            hn, he, _ = home
            while math.hypot((at := fleet.truth(lead)).north - hn, at.east - he) < 300.0:
                await asyncio.sleep(0.01)
            left = at.yaw - math.pi / 2.0
            rally = (at.north + 150.0 * math.cos(left), at.east + 150.0 * math.sin(left))
            where = fleet.world.to_geo(*rally, 0.0)
            rel, point = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_RALLY_POINT
            fleet.vehicles[lead].rally = [
                mavlink.MAVLink_mission_item_int_message(
                    lead,
                    1,
                    0,
                    rel,
                    point,
                    0,
                    0,
                    0,
                    0,
                    0,
                    0,
                    round(where.lat * 1e7),
                    round(where.lon * 1e7),
                    0.0,
                    mavlink.MAV_MISSION_TYPE_RALLY,
                )
            ]
            await tell("set_mode_send", flag, _ARDUROVER_RTL)
            await _until(fleet, at.t + 60.0)
            marks["rally"] = fleet.truth(lead), rally
            await tell("set_mode_send", flag, _ARDUROVER_AUTO)

    result = await _operated(operator, 540.0)
    report = result.report.to_dict()
    assert "rally" in marks, marks
    # Home within 120 s (at most 600 m off at 8 m/s), standing in RTL; then driving.
    (at_home, (hn, he, _)) = marks["home"]
    assert at_home.mode == "RTL" and at_home.speed == 0.0, at_home
    assert math.hypot(at_home.north - hn, at_home.east - he) <= 2.0, (at_home, hn, he)
    assert marks["auto+30"].mode == "AUTO" and marks["auto+30"].speed > 2.0, marks["auto+30"]
    (at_rally, (rn, re_)) = marks["rally"]
    assert at_rally.mode == "RTL" and at_rally.speed == 0.0, at_rally
    assert math.hypot(at_rally.north - rn, at_rally.east - re_) <= 2.0, (at_rally, rn, re_)
    modes = [m["mode"] for m in report["planner"]["convoy_modes"]]
    assert modes == ["AUTO", "RTL", "AUTO", "RTL", "AUTO"], modes
    for said in (
        "in RTL (was AUTO): it drives home: forecast straight there",
        "in AUTO (was RTL): it drives its mission, straight back to item",
        "in RTL drives to its rally point 1 of 1, ",
    ):
        assert any(said in e for e in report["events"]), (said, report["events"])
    truth = result.truth
    assert truth is not None
    # (sixteen flights at 20x on 2026-12-01 with the one RTL, ten with the turn round
    # forecast, six without: 92.3-98.8 %, median 96.1 %, longest gaps 1.4-17.8 s, most
    # 10-25 s after the RTL as the fleet turns round with the convoy; predicted within
    # 0.0-2.6 points of the truth, the operator's RTL being unforeseen. Forecast along
    # its route as before, not home: 88.5 and 91.8 %, 21 s unseen as it turned off it.
    # With the rally RTL as well, six flights: 94.1-97.8 %, gaps 2.8-16.9 s; its rally
    # points not read, 91.9-94.5 % in four, 91.6-94.1 % in three with no astray either.
    # On 2026-12-01 at 14.5x, twelve flights: 91.7-98.1 %, median 95.2, gaps up to 21.6 s,
    # predicted 0.0-2.8 points over the truth, the planes 60-80 m off their straight legs
    # at times: the mock's planes flew 13 deg off a far loiter's centre, SITL's 0.5. Flying
    # at it as L1 does, eight: 93.7-99.0 %, median 97.3, gaps 1.3-17.3 s, predicted -0.8
    # to +0.4 points of the truth, mean tracking errors 2.0-6.2 m from 3.6-21.0.)
    assert truth.fraction >= 0.91, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 20.0, truth
    _assert_predicted(report, truth, 0.03)  # (ten flights on a quiet host: -0.1 to +0.5)


def _assert_predicted(report: dict[str, Any], truth: CoverageStats, tol: float) -> None:
    """The service's prediction within ``tol`` of the truth; over it by up to
    ``_LATE_OVER`` more only where the service said its re-plans or setpoints reached
    the UAVs late: a host short of CPU for the test's speedup flies the plans behind
    them (clean-clone CI runs of 2026-12-01: 98.5 % predicted against 94.5 % true with
    "setpoints late: 0.53 mission s between two rounds at 20x", 98.5 against 96.7 %
    with "re-plans late ... 0.20 mission s"; on a quiet host within 0.5 points)."""
    over = report["predicted_coverage"] - truth.fraction
    late = any("re-plans late" in e or "setpoints late" in e for e in report["events"])
    top = tol + (_LATE_OVER if late else 0.0)
    assert -tol <= over <= top, (report["predicted_coverage"], truth, late)


async def _operated(
    operator: Callable[[MockFleet, ConvoyService], Coroutine[Any, Any, None]], duration: float
) -> DemoResult:
    """The circuit flown on ArduPilot, its mission read as the route, ``operator``
    beside the service (``run_demo(during=...)``)."""
    scenario = SCENARIOS["turning"]
    return await run_demo(
        scenario, duration=duration, speedup=SPEEDUP, personality="ardupilot",
        uavs=scenario.fleet(route_known=True), route_mission=True, road=CIRCUIT, during=operator,
    )  # fmt: skip


async def _until(fleet: MockFleet, t: float) -> None:
    """Sleep until the mock's clock reads ``t``."""
    while fleet.now < t:
        await asyncio.sleep(0.01)


async def _until_protected(fleet: MockFleet, service: ConvoyService, t: float) -> None:
    """Sleep until the service protects the convoy and the mock's clock reads ``t``."""
    while service.monitor.protect_start is None:
        await asyncio.sleep(0.01)
    await _until(fleet, t)


@contextlib.asynccontextmanager
async def _ground_station(
    fleet: MockFleet, service: ConvoyService, only: int | None = None
) -> AsyncIterator[Callable[..., Awaitable[None]]]:
    """An operator's own link to each ground vehicle of the convoy (system 250), or
    ``only`` one: tells every one the same, ``tell(sender, *args)`` (a ``link.mav``
    method and its arguments after the target system), thrice, as a ground station
    repeats itself over UDP."""
    links = {
        v.sysid: mavutil.mavlink_connection(
            f"udpout:127.0.0.1:{fleet.endpoint(v.sysid).connect.rsplit(':', 1)[1]}",
            source_system=250,
        )
        for v in service.config.convoy.vehicles
        if only in (None, v.sysid)
    }

    async def tell(sender: str, *args: Any) -> None:
        for _ in range(3):
            for sysid, link in links.items():
                getattr(link.mav, sender)(sysid, *args)
            await asyncio.sleep(0.02)

    try:
        yield tell
    finally:
        for link in links.values():
            link.close()


@pytest.mark.paired
async def test_a_rover_its_operator_slows_keeps_the_speed_and_is_forecast_at_it() -> None:
    """DO_CHANGE_SPEED 5 m/s on the circuit's 8 m/s stretch: kept to the 6 m/s mark."""
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        lead = service.config.convoy.vehicles[0].sysid
        await _until_protected(fleet, service, 150.0)
        async with _ground_station(fleet, service) as tell:
            while fleet.truth(lead).speed < 7.9:  # (on a straight, at its 8 m/s)
                await asyncio.sleep(0.01)
            marks["told"] = fleet.now
            await tell(
                "command_long_send", 1, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0,
                mavlink.SPEED_TYPE_GROUNDSPEED, 5.0, -1.0, 0, 0, 0, 0,
            )  # fmt: skip
            await _until(fleet, marks["told"] + 15.0)
            marks["told+15"] = fleet.truth(lead)

    result = await _operated(operator, 480.0)
    report = result.report.to_dict()
    assert "told+15" in marks, marks
    assert marks["told+15"].speed == pytest.approx(5.0, abs=0.05)  # (the rover keeps it)
    kept = report["planner"]["convoy_kept"]
    assert kept and kept[0]["mps"] == pytest.approx(5.0, abs=0.2), kept
    assert kept[0]["plan_mps"] == 8.0 and kept[0]["t"] <= marks["told"] + 15.0, kept
    truth = result.truth
    assert truth is not None
    # (seven flights: 95.6-99.0 %, the prediction 0.6-2.6 points higher at 40x, 0.6-1.4 at 20x)
    assert truth.fraction >= 0.94, (truth, report["predicted_coverage"])
    assert truth.longest_gap_s <= 12.0, truth
    _assert_predicted(report, truth, 0.02)


async def _upload(fleet: MockFleet, sysid: int, items: list[Any]) -> str:
    """An operator's upload of ``items`` to ground vehicle ``sysid`` from a ground station
    of their own (system 250), as QGroundControl sends one: the vehicle's last answer."""
    port = fleet.endpoint(sysid).connect.rsplit(":", 1)[1]
    link = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=250)
    mission = mavlink.MAV_MISSION_TYPE_MISSION
    try:
        link.mav.mission_count_send(sysid, 1, len(items), mission)
        deadline = fleet.now + 30.0
        while fleet.now < deadline:
            msg = link.recv_match(type=["MISSION_REQUEST_INT", "MISSION_ACK"], blocking=False)
            if msg is None or msg.target_system != 250:
                await asyncio.sleep(0.005)
                continue
            if msg.get_type() == "MISSION_ACK":
                return str(mavlink.enums["MAV_MISSION_RESULT"][msg.type].name)
            link.mav.send(items[msg.seq])
        return "no answer"
    finally:
        link.close()


@pytest.mark.paired
async def test_a_rovers_mission_its_operator_changes_is_read_again_and_flown() -> None:
    """A corner of the circuit moved and the mission uploaded again as the rover
    drives it (as many items: MISSION_CURRENT's total does not change). ArduRover goes on
    at its item in the new mission and says so to every link ("Auto mission changed,
    restarted command"); the service reads it again and takes the new route."""
    marks: dict[str, Any] = {}

    async def operator(fleet: MockFleet, service: ConvoyService) -> None:
        lead = service.config.convoy.vehicles[0].sysid
        await _until_protected(fleet, service, 200.0)
        rover = fleet.vehicles[lead]
        mission = rover.mission
        assert mission is not None
        target = (lead, 1)
        count = mission.count(home_first=True)
        home = rover.flight.home
        items = [mission.item(seq, home, target, home_first=True) for seq in range(count)]
        # (10 m: the convoy's following vehicle drives where the lead drove; when it drove
        # the road it was given, the old one, the convoy parted and the prediction was
        # 2.3 points over the truth, scored on both; a 2-m move was all the test took)
        moved = fleet.world.to_geo(250.0, 360.0)  # (the corner at (250, 350), 10 m east)
        corner = fleet.world.to_geo(250.0, 350.0)
        at = (round(corner.lat * 1e7), round(corner.lon * 1e7))
        for k, it in enumerate(items):
            if it is not None and (it.x, it.y) == at:
                items[k] = mavlink.MAVLink_mission_item_int_message(
                    *target, it.seq, it.frame, it.command, 0, 1, it.param1, it.param2,
                    it.param3, it.param4, round(moved.lat * 1e7), round(moved.lon * 1e7),
                    it.z, mavlink.MAV_MISSION_TYPE_MISSION,
                )  # fmt: skip
                marks["moved"] = k
        marks["reads"] = fleet.counters(lead)["mission_reads"]  # (the service's, so far)
        marks["uploaded"] = await _upload(fleet, lead, items)
        marks["t"] = fleet.now
        await _until(fleet, marks["t"] + 20.0)
        marks["reads+20"] = fleet.counters(lead)["mission_reads"]

    result = await _operated(operator, 420.0)
    report = result.report.to_dict()
    assert "moved" in marks and marks["uploaded"] == "MAV_MISSION_ACCEPTED", marks
    assert marks["reads+20"] > marks["reads"], marks  # (read again within 20 s)
    received = [e for e in report["events"] if "convoy route received" in e]
    assert len(received) == 2, received  # (the first read, and the moved corner's)
    truth = result.truth
    assert truth is not None
    assert truth.fraction >= 0.94, (truth, report["predicted_coverage"])
    _assert_predicted(report, truth, 0.02)


async def test_a_rovers_mission_is_read_through_a_lossy_radio() -> None:
    """The lead's link losing 30 % of what goes each way (its telemetry too), 0.2 s
    late: the mission is read at the first go and flown. The protocol's five tries of
    each request fail one item in 30 on that link, a read of the circuit's items about
    one in four; the read takes as many tries as the link's answer rate needs
    (``MissionRead.tries_allowed``: ArduRover SITL behind such a radio was never read
    with five)."""
    scenario = SCENARIOS["turning"]
    uavs = scenario.fleet(route_known=True)
    lead = uavs + 1  # (the ground vehicles' system ids follow the aircraft's)
    lossy = {"loss_to_vehicle": 0.3, "loss_from_vehicle": 0.3, "latency": 0.2, "sysids": [lead]}
    seen: dict[str, Any] = {}

    async def watch(fleet: MockFleet, service: ConvoyService) -> None:
        while True:
            seen.update(fleet.counters(lead))
            await asyncio.sleep(0.05)

    result = await run_demo(
        scenario, duration=150.0, speedup=SPEEDUP, personality="ardupilot", uavs=uavs,
        route_mission=True, road=CIRCUIT, faults=lossy, during=watch,
    )  # fmt: skip
    planner = result.report.to_dict()["planner"]
    assert "mission (a circuit" in planner["route_source"], planner["route_source"]
    assert planner["mission_reads"] == 1, planner  # (read whole at the first go)
    # The link lost what it should have: the requests and the items.
    assert seen["lost_to_vehicle"] > 0 and seen["lost_from_vehicle"] > 0, seen
    assert seen["mission_reads"] >= 1, seen
