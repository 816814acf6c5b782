"""Fault scripts against the whole service: a fleet that falls silent, a UAV that dies.

Scored from the mock's ground truth, as in ``test_service.py``. A pause freezes the
whole simulation (a paused SITL host: sim time stops, nothing is sent) for a wall
time worth ``PAUSE_S`` mission seconds at the mock's speedup; on resuming, one chosen
vehicle speaks first and the others a little later. Mission time must follow the
autopilots' clocks across it, whichever speaks first, and every UAV declared lost
must fly its slot again.
"""

from __future__ import annotations

import asyncio
import math
import re
import time
from collections.abc import Awaitable, Callable
from typing import Any

import pytest

from convoy_mav import app
from convoy_mav.app import ConvoyService
from convoy_mav.demo import SCENARIOS, run_demo, score_fleet
from convoy_mav.mission.road import RoadMission
from convoy_mav.planning import make_plan
from convoy_mav.types import VehicleStatus
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

SPEEDUP = host_speedup(25.0)
PAUSE_AT = 140.0  # sim s: well into the protect phase (about 80 s in)
DURATION = 420.0


def _orbit() -> float:
    """Seconds of one orbit of the stationary plan (2 pi R / V)."""
    request = make_plan(SCENARIOS["stationary"].plan_request()).request
    return 2 * math.pi * request.turn_radius / request.uav_speed


async def _protecting(fleet: MockFleet, service: ConvoyService) -> None:
    while service.monitor.protect_start is None or fleet.now < PAUSE_AT:
        await asyncio.sleep(0.01)


async def _clock_errors(
    fleet: MockFleet, service: ConvoyService, until: float, errors: list[float]
) -> None:
    """Mission time less the mock's sim time, every 20 ms of wall until sim time ``until``."""
    while fleet.now < until:
        await asyncio.sleep(0.02)
        errors.append(service.clock.now() - fleet.clock.now())


async def _kill_then_reboot(
    fleet: MockFleet, sysid: int, down_s: float, marks: dict[str, float], *, on_pad: bool = False
) -> None:
    """Kill aircraft ``sysid`` now and reboot it ``down_s`` sim s later (``on_pad``: at
    rest on its home pad, relaunched), marking ``killed`` and ``restarted``."""
    fleet.kill(sysid)
    marks["killed"] = fleet.now
    await fleet.wait_until(fleet.now + down_s)
    fleet.reboot(sysid, on_pad=on_pad)
    marks["restarted"] = fleet.now


def _median_abs(errors: list[float]) -> float:
    """The median size of the errors (inf with none: nothing was compared)."""
    settled = sorted(abs(e) for e in errors)
    return settled[len(settled) // 2] if settled else math.inf


@pytest.mark.parametrize(
    ("pause_s", "first"),
    [(14.0, "reference"), (14.0, "other"), (100.0, "other")],
)
async def test_a_fleet_wide_pause_is_followed_and_everyone_rejoins(
    pause_s: float, first: str
) -> None:
    scenario = SCENARIOS["stationary"]
    errors: list[float] = []
    marks: dict[str, float] = {}
    marks_fleet: list[MockFleet] = []
    counting: dict[int, str | None] = {}

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        marks_fleet.append(fleet)
        await _protecting(fleet, service)
        clock = service.clock
        speaker = clock.reference if first == "reference" else max(service.vehicles)
        assert speaker is not None and (first == "reference") == (speaker == clock.reference)
        marks["paused"] = fleet.now
        await fleet.pause(pause_s / SPEEDUP, first=(speaker,))
        marks["resumed"] = fleet.now
        while True:  # the clock's error against the autopilots' from then on
            await asyncio.sleep(0.02)
            errors.append(clock.now() - fleet.clock.now())
            if fleet.now < DURATION - 10.0:  # (before the end, when every UAV holds)
                counting.update(service.why_not_counted)
                if "back" not in marks and all(w is None for w in counting.values()):
                    marks["back"] = fleet.now

    result = await run_demo(scenario, duration=DURATION, speedup=SPEEDUP, during=script)
    report = result.report.to_dict()
    assert "resumed" in marks, "the pause never happened"
    # Mission time followed the autopilots across the silence. The first 0.2 s of wall
    # time are left out (a step is confirmed from a few packets of the new timeline);
    # each sample compares two loops' readings of the time 20 ms apart at most, so
    # one sample may be off by the speedup x a scheduling delay (a loaded CI host: one
    # sample 4.1 s off, the median 0.03 s): the median is held to 0.2 s, 95 % of the
    # samples to 1 s, and every one to half the pause (the bug ran 14 s ahead, always).
    settled = sorted(abs(e) for e in errors[10:])
    assert settled, "no clock samples after the pause"
    median, p95 = settled[len(settled) // 2], settled[int(0.95 * (len(settled) - 1))]
    assert median < 0.2 and p95 < 1.0 and settled[-1] < 0.5 * pause_s, (median, p95, settled[-1])
    # every UAV that was declared lost flies its slot again
    assert counting and all(why is None for why in counting.values()), counting
    # Set up again in seconds (0.5 s in most runs). On a loaded host about one run in
    # five has a UAV whose setpoint-loss hold is reported after it was set up again and
    # is taken for a pilot's: it counts again only when it drifts back onto its slot,
    # up to about an orbit later (noted on the issue; the bound keeps that worst case).
    assert marks["back"] - marks["resumed"] < _orbit() + 30.0
    # every UAV silent at once is a link or a host, not a fleet lost: the plan is kept
    # and nobody is re-phased (each flies its own slot again when heard)
    assert any("every UAV silent at once" in e for e in report["events"])
    assert not {"uav_lost", "uav_returned"} & {r["reason"] for r in report["replans"]}
    # coverage is back within one orbit of the resumption (ground truth)
    orbit = _orbit()
    after = score_fleet(
        marks_fleet[0], result.report.config, marks["resumed"] + orbit, result.report.end_t
    )
    print(
        f"\npause {pause_s:.0f} s, {first} first: clock error median "
        f"{settled[len(settled) // 2]:.3f} s max {settled[-1]:.3f} s, "
        f"every UAV counting again {marks['back'] - marks['resumed']:.1f} s after resuming "
        f"(orbit {orbit:.1f} s), truth coverage from one orbit on {100 * after.fraction:.2f} %"
    )
    assert after.fraction >= 0.99


async def test_a_radio_dropout_is_no_stall_of_the_service() -> None:
    """The ground radio drops every link for 30 mission s while the simulation runs on,
    then the reference autopilot is heard first: mission time, held at the clock's
    ``silence_cap``, runs on from its line (no step). The 20 s it moves on at once were
    the radio's, not a stall of the service's loop (which watched the clock stand
    meanwhile): counted as a silence, neither in ``host_stalled_s`` (20.1 s before)
    nor as a late setpoint round."""
    scenario = SCENARIOS["stationary"]
    marks: dict[str, float] = {}
    errors: list[float] = []

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        await _protecting(fleet, service)
        clock = service.clock
        reference = clock.reference
        assert reference is not None
        links = [fleet.link(e.sysid) for e in fleet.endpoints]
        streamer = service.streamer
        assert streamer is not None
        # (the service takes the recent widest gap itself: the run's widest is ours)
        stalled, widest = service._stalled_s, streamer.widest_gap_s
        for link in links:
            link.muted = True
        marks["muted"] = fleet.now
        await fleet.wait_until(fleet.now + 30.0)
        fleet.link(reference).muted = False
        await asyncio.sleep(0.1)
        for link in links:
            link.muted = False
        marks["unmuted"] = fleet.now
        await fleet.wait_until(fleet.now + 5.0)
        marks["stalled"] = service._stalled_s - stalled
        marks["widest_before"], marks["widest"] = widest, streamer.widest_gap_s
        await _clock_errors(fleet, service, DURATION - 10.0, errors)

    result = await run_demo(scenario, duration=DURATION, speedup=SPEEDUP, during=script)
    assert "unmuted" in marks, "the dropout never ended"
    # (a host this slow may hold the loop up for a second or two of its own meanwhile)
    assert marks["stalled"] < 5.0 and marks["widest"] <= max(marks["widest_before"], 5.0), marks
    assert _median_abs(errors[10:]) < 0.2  # mission time on the autopilots'
    report = result.report.to_dict()
    assert any("every UAV silent at once" in e for e in report["events"])
    print(
        f"\nradio dropout of {marks['unmuted'] - marks['muted']:.0f} mission s: stall counted "
        f"{marks['stalled']:.2f} s, widest round gap {marks['widest']:.2f} s"
    )


async def test_a_uav_whose_join_is_still_planned_is_streamed_a_hold_every_round() -> None:
    """PX4 needs a live stream: a UAV set up while its join is still being planned is
    sent the hold from the streamer every round, not left to its keepalive (which looks
    twice a second while the stream is fed: half a second without a setpoint at every
    join, half PX4's default ``COM_OF_LOSS_T`` and all of a shorter one). Each join here
    takes 3 mission s in the worker: the keepalive fired up to ten times in each before."""
    join_s = 3.0
    windows: dict[int, list[int]] = {}  # UAV -> keepalives [on waiting, last seen waiting]
    stop = asyncio.Event()

    async def slow_joins(fleet: MockFleet, service: ConvoyService) -> None:
        mission = service.mission
        join_many = mission.join_many

        def slow(*args: Any, **kwargs: Any) -> Any:
            time.sleep(join_s / SPEEDUP)
            return join_many(*args, **kwargs)

        mission.join_many = slow  # type: ignore[method-assign]
        vehicles = service.vehicles
        while len(service.view.slots) < len(vehicles) or not vehicles:
            for sysid, vehicle in vehicles.items():
                if vehicle.status is VehicleStatus.FLYING and sysid not in service.view.slots:
                    count = vehicle.counters["keepalive"]
                    windows.setdefault(sysid, [count, count])[1] = count
            await asyncio.sleep(0.002)
        stop.set()

    scenario = SCENARIOS["moving"]
    await run_demo(scenario, duration=DURATION, speedup=SPEEDUP, during=slow_joins, stop=stop)
    assert len(windows) == scenario.fleet(), windows  # each one waited for its join
    for sysid, (first, last) in windows.items():
        assert last - first <= 1, (sysid, first, last)


Script = Callable[[MockFleet, ConvoyService], Awaitable[None]]


async def _until_slowed(
    scenario: str,
    fault: Script,
    marks: dict[str, float],
    then: Script | None = None,
    *,
    late_replans: bool = False,
    late_rounds: bool = False,
    personality: str = "px4",
) -> dict[str, Any]:
    """Fly ``scenario`` with the mock's speedup allowed down to half: once protecting,
    ``fault`` makes the host fall behind; the run stops once the service has halved the
    speedup (``marks["asked"]``, sim time) and ``then`` (or 5 mission s) has run: the
    rest would fly at half speed. Re-plans flown late slow it too only when
    ``late_replans``, and setpoint rounds half a second apart only when ``late_rounds``:
    a slow host's own would before the fault (a loaded CI host's cold start: rounds 0.5
    mission s apart at 10 s, the simulator slowed for them before the fault began)."""
    with pytest.MonkeyPatch.context() as patch:
        if not late_replans:
            patch.setattr(app, "_SLOW_REPLANS_S", math.inf)
        if not late_rounds:
            patch.setattr(app, "_SLOW_GAP_S", math.inf)
        return await _slowed(scenario, fault, marks, then, personality)


async def _slowed(
    scenario: str,
    fault: Script,
    marks: dict[str, float],
    then: Script | None,
    personality: str = "px4",
) -> dict[str, Any]:
    stop = asyncio.Event()

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        await _protecting(fleet, service)
        await fault(fleet, service)
        while fleet.speedup == SPEEDUP and fleet.now < DURATION - 60.0:
            await asyncio.sleep(0.05)
        marks["asked"] = fleet.now
        await (fleet.wait_until(fleet.now + 5.0) if then is None else then(fleet, service))
        stop.set()

    result = await run_demo(
        SCENARIOS[scenario],
        duration=DURATION,
        speedup=SPEEDUP,
        during=script,
        speedup_floor=SPEEDUP / 2,
        stop=stop,
        personality=personality,
    )
    assert "asked" in marks and marks["asked"] < DURATION - 60.0, marks
    report = result.report.to_dict()
    # Halved from the clock's estimate of the speedup, which a loaded host's stalls and
    # the mock's slips can put 10-15 % off (12.5x measured at 11.05x): the simulator
    # runs at what was asked, and that is about half.
    (asked,) = (float(m[1]) for e in report["events"] if (m := _SLOWED.search(e)) is not None)
    assert 0.99 * SPEEDUP / 2 <= asked <= 0.6 * SPEEDUP, (asked, SPEEDUP)  # (3 digits)
    assert report["mission_clock"]["speedup"] == pytest.approx(asked, rel=0.05)
    return report


_SLOWED = re.compile(r"simulator slowed from [\d.]+x to ([\d.]+)x")


@pytest.mark.parametrize("personality", ["px4", "ardupilot"])
async def test_a_planner_behind_the_simulator_slows_it_by_sim_speedup(personality: str) -> None:
    """A host short of CPU for the speedup: every re-plan takes 0.25 wall s more (the
    planner's thread sleeps; the loop and the mock run on). Once each UAV is re-planned
    less than every 6 mission s instead of 4, the service asks the mock for half the
    speedup by ``SIM_SPEEDUP`` over MAVLink; the mock's clock takes it and mission time
    follows at once (a change of rate), not after the fit's whole window.

    The clock's reference is the first vehicle heard, a UAV or the convoy's ground vehicle
    (under ArduPilot, silent until asked for streams, the convoy's in every run seen): the
    convoy's simulator is slowed too, and its word on the new rate is the one the clock
    takes. Told nothing, the clock ran on at the old rate for the
    fit's window, and the convoy's fixes looked stale (``convoy_stale``, and once for
    100 mission s: the UAVs orbited where the convoy had been)."""
    marks: dict[str, float] = {}
    taken: list[int] = []  # who the clock took a new rate from (``rate_set``)
    errors: list[float] = []
    undo: list[Callable[[], None]] = []

    async def slow_planner(fleet: MockFleet, service: ConvoyService) -> None:
        mission = service.mission
        assert isinstance(mission, RoadMission)
        plan_paths = mission._plan_paths
        undo.append(lambda: setattr(mission, "_plan_paths", plan_paths))

        def slow(*args: Any, **kwargs: Any) -> None:
            time.sleep(0.25)
            plan_paths(*args, **kwargs)

        mission._plan_paths = slow  # type: ignore[method-assign]
        marks["slowed_planner"] = fleet.now
        clock = service.clock
        rate_set = clock.rate_set

        def said(rate: float, sysid: int) -> bool:
            took = rate_set(rate, sysid)
            if took:
                taken.append(sysid)
            return took

        clock.rate_set = said  # type: ignore[method-assign]

    async def clock_after(fleet: MockFleet, service: ConvoyService) -> None:
        marks["ground_reference"] = service.clock.reference in service._ground_ids
        undo[0]()  # (the host has room again)
        await fleet.wait_until(fleet.now + 20.0)
        await _clock_errors(fleet, service, fleet.now + 60.0, errors)

    report = await _until_slowed(
        "turning", slow_planner, marks, then=clock_after, personality=personality
    )
    clock = report["mission_clock"]
    assert clock["rate_changes"] == 1, clock
    # The new rate was the simulator's word, from the reference (under ArduPilot the
    # convoy's vehicle in every run seen; under PX4 a UAV or the convoy's, by chance).
    assert len(taken) == 1, taken
    stale = [a for a in report["alarms"] if a["kind"] == "convoy_stale" and a["active"]]
    assert not [a for a in stale if a["t"] >= report["protect_start_s"]], stale
    assert any("simulator slowed" in e and "planner behind" in e for e in report["events"])
    assert _median_abs(errors) < 0.2  # mission time on the mock's
    print(
        f"\nplanner slowed at {marks['slowed_planner']:.0f} s, speedup halved at "
        f"{marks['asked']:.0f} s: {clock}, the reference a ground vehicle: "
        f"{bool(marks['ground_reference'])}"
    )


async def test_re_plans_flown_late_slow_the_simulator() -> None:
    """A host whose re-plans take a while, yet keep their pace: each step that re-plans
    takes 0.3 mission s more (12 wall ms at 25x; a fixed 12 ms was under the bar at the
    10x of a slow host). The road mission lays its legs that far ahead on the paths in
    force, so nothing moves under a UAV, but the legs follow the convoy that much later:
    the service halves the speedup, saying why."""
    marks: dict[str, float] = {}

    async def slow_replans(fleet: MockFleet, service: ConvoyService) -> None:
        mission = service.mission
        assert isinstance(mission, RoadMission)
        plan_paths = mission._plan_paths

        def slow(*args: Any, **kwargs: Any) -> None:
            time.sleep(0.3 / SPEEDUP)
            plan_paths(*args, **kwargs)

        mission._plan_paths = slow  # type: ignore[method-assign]

    report = await _until_slowed("turning", slow_replans, marks, late_replans=True)
    slowed = [e for e in report["events"] if "simulator slowed" in e]
    late = re.search(r"re-plans flown ([\d.]+) mission s past their tick", slowed[0])
    # (past the bar, _SLOW_REPLANS_S: 0.15 s, which the event rounds to two digits)
    assert late is not None and float(late[1]) >= 0.15, slowed


async def test_setpoint_rounds_a_second_apart_slow_the_simulator_before_the_look_ends() -> None:
    """The stream held up for 1.5 mission s (PX4 leaves OFFBOARD after 1 s without a
    setpoint: every UAV at once) just after a look at the host began: the service
    halves the speedup ten mission s into that look, not at its end 30 s in."""
    marks: dict[str, float] = {}

    async def hold_the_stream(fleet: MockFleet, service: ConvoyService) -> None:
        look = service._slow_look
        while service._slow_look == look:  # a fresh look begins
            await asyncio.sleep(0.01)
        streamer = service.streamer
        assert streamer is not None and service._slow_look is not None
        marks["look"] = service._slow_look[0]
        send_round = streamer._round

        async def held(k: int) -> int:
            streamer._round = send_round  # type: ignore[method-assign]
            await service.clock.sleep_until(service.clock.now() + 1.5)
            return await send_round(k)

        await service.clock.sleep_until(marks["look"] + 1.0)
        streamer._round = held  # type: ignore[method-assign]

    report = await _until_slowed("moving", hold_the_stream, marks, late_rounds=True)
    assert marks["asked"] - marks["look"] < 25.0, marks
    assert any("simulator slowed" in e and "setpoint rounds" in e for e in report["events"])


async def test_a_killed_and_restarted_uav_rejoins_and_the_rest_rephase_back() -> None:
    scenario = SCENARIOS["stationary"]
    marks: dict[str, float] = {}
    fleets: list[MockFleet] = []

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        fleets.append(fleet)
        await _protecting(fleet, service)
        await _kill_then_reboot(fleet, 2, 30.0, marks)  # boots where it glided to, disarmed
        while True:
            await asyncio.sleep(0.02)
            if fleet.now < DURATION - 10.0 and all(
                w is None for w in service.why_not_counted.values()
            ):
                marks.setdefault("back", fleet.now)

    result = await run_demo(scenario, duration=DURATION, speedup=SPEEDUP, during=script)
    report = result.report.to_dict()
    reasons = [r["reason"] for r in report["replans"]]
    assert "uav_lost" in reasons and "uav_returned" in reasons, reasons
    returned = next(r for r in report["replans"] if r["reason"] == "uav_returned")
    assert returned["uav_count"] == 5 and returned["predicted_coverage"] == 1.0
    assert report["predicted_coverage"] == 1.0
    assert "back" in marks, "UAV 2 never counted again"
    after = score_fleet(
        fleets[0], result.report.config, marks["back"] + _orbit(), result.report.end_t
    )
    print(
        f"\nkilled at {marks['killed']:.0f} s, restarted at {marks['restarted']:.0f} s, "
        f"every UAV counting again at {marks['back']:.0f} s; truth coverage from one orbit "
        f"on {100 * after.fraction:.2f} %"
    )
    assert after.fraction >= 0.99


@pytest.mark.parametrize("personality", ["ardupilot", "px4"])
async def test_an_autopilot_rebooted_in_the_air_flies_on_without_a_take_off(
    personality: str,
) -> None:
    """A reboot in flight (a watchdog, a brown-out): the autopilot comes back disarmed,
    still flying, its home reset where its first fix puts it, up in the air. Set up
    again, it is armed and flown straight back to its slot. (An ArduPlane was put in
    TAKEOFF to climb to TKOFF_ALT above that home, 6 m, from 6 m below it, and loitered
    there while the set-up waited 120 s and gave up: 75 % covered.)"""
    marks: dict[str, float] = {}
    fleets: list[MockFleet] = []

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        fleets.append(fleet)
        await _protecting(fleet, service)
        fleet.reboot(1)
        marks["rebooted"] = fleet.now
        while True:
            await asyncio.sleep(0.02)
            flying = service.vehicles[1].status is VehicleStatus.FLYING
            if flying and fleet.now > marks["rebooted"] + 1.0:
                marks.setdefault("flying", fleet.now)

    result = await run_demo(SCENARIOS["stationary"], duration=DURATION, speedup=SPEEDUP,
                            personality=personality, during=script)  # fmt: skip
    report = result.report.to_dict()
    assert not [a for a in report["alarms"] if a["kind"] == "uav_failed"], report["alarms"]
    assert "flying" in marks and marks["flying"] - marks["rebooted"] < 30.0, marks
    after = score_fleet(
        fleets[0], result.report.config, marks["flying"] + _orbit(), result.report.end_t
    )
    print(
        f"\nrebooted at {marks['rebooted']:.0f} s, flying again at {marks['flying']:.0f} s; "
        f"truth coverage from one orbit on {100 * after.fraction:.2f} %"
    )
    assert after.fraction >= 0.99


async def test_a_uav_relaunched_far_behind_flies_to_the_fleet_before_the_others_rephase() -> None:
    """A spare (five planes where four cover a convoy at 8 m/s) is lost and relaunched
    from its pad, kilometres behind the convoy. The others keep the plan for four, which
    covers fully, while it flies to them on a slot of it; they re-phase for five only
    once it is there, and it protects again. (Re-planned for five at once, they had
    left its slot empty for the four minutes it took: 83.6 % from the relaunch on.)"""
    scenario = SCENARIOS["moving"]
    count = make_plan(scenario.plan_request()).min_uavs + 1
    marks: dict[str, float] = {}
    fleets: list[MockFleet] = []

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        fleets.append(fleet)
        await _protecting(fleet, service)
        await _kill_then_reboot(fleet, 1, 100.0, marks, on_pad=True)
        while True:
            await asyncio.sleep(0.02)
            rephased = [r["t"] for r in service.replans if r["reason"] == "uav_returned"]
            if rephased and service.why_not_counted.get(1, "?") is None:
                marks.setdefault("back", fleet.now)  # (on its own slot, not beside another's)

    result = await run_demo(
        scenario, duration=700.0, speedup=SPEEDUP, uavs=count, personality="px4", during=script
    )
    report = result.report.to_dict()
    flying_back = [e for e in report["events"] if "uav1: flying back to the fleet" in e]
    assert len(flying_back) == 1, report["events"]
    there = float(re.search(r"there at t=(\d+) s", flying_back[0]).group(1))  # type: ignore[union-attr]
    returned = [r for r in report["replans"] if r["reason"] == "uav_returned"]
    assert len(returned) == 1 and returned[0]["t"] >= there - 1.0, (there, returned)
    assert returned[0]["uav_count"] == count
    assert "back" in marks, "UAV 1 never counted again"
    while_away = score_fleet(fleets[0], result.report.config, marks["restarted"], there)
    print(
        f"\nrelaunched at {marks['restarted']:.0f} s, at the fleet at {there:.0f} s, "
        f"counting again at {marks['back']:.0f} s; truth while it flew there "
        f"{100 * while_away.fraction:.2f} % (longest gap {while_away.longest_gap_s:.1f} s)"
    )
    assert while_away.fraction >= 0.99


async def test_duplicated_and_reordered_datagrams_change_nothing_flown() -> None:
    """Every link repeats a tenth of its datagrams and reorders them (up to 150 ms of
    jitter on 50 ms of latency, both ways): no reboot or clock step is imagined, and the
    parked convoy stays covered as without them."""
    faults = {"latency": 0.05, "jitter": 0.15, "duplicate": 0.1, "seed": 11}
    result = await run_demo(SCENARIOS["stationary"], duration=300.0, speedup=SPEEDUP,
                            faults=faults)  # fmt: skip
    report = result.report.to_dict()
    assert result.truth is not None and result.truth.fraction >= 0.99
    assert not [e for e in report["events"] if "rebooted" in e or "stepped" in e]
    assert report["rejected"]["clock_jumps_reanchored"] == 0
    assert all(v["rejected"]["position_jump"] == 0 for v in report["vehicles"])
    assert abs(report["coverage_fraction"] - result.truth.fraction) <= 0.005
