"""Real roads end to end: generated roads driven by the mock's rovers, the service, the truth.

Over real UDP against ``sitl_mock`` at 40x, both personalities; scored from the
mock's ground truth. The road planner flies the road's count of UAVs (the
stationary minimum + 1); what it predicts must be what the truth measures.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.cli import main
from convoy_mav.config import DEFAULT_ORIGIN
from convoy_mav.demo import replay_scenario, run_demo, score_fleet
from convoy_mav.geo import LocalFrame
from convoy_mav.mission.recording import load_recording
from convoy_mav.mission.road import RoadMission
from convoy_mav.tracks.roads import DEVIATIONS, road_kind
from sitl_mock import MockFleet
from tests.hostspeed import host_speedup

SPEEDUP = host_speedup(40.0)  # (>= 20 on a host as fast as the reference)
pytestmark = pytest.mark.integration

# The flights held at a fixed speedup are marked ``alone`` (run after the parallel run):
# at 40x a road keeps the service and the mock busy on both cores, and beside another
# flight their re-plans and setpoints came seconds late (a CI run at 19x: setpoint gaps
# of 2.6 s, re-plans 0.9 s late, the truth 2-4 points off the prediction, 22 m off the
# paths; the three passed alone on the same host).


def _replayed(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> dict[str, Any]:
    """``convoy-mav replay`` with ``argv``, scored from the mock's ground truth: its report."""
    report_path = tmp_path / "r.json"
    assert main([*argv, "--report", str(report_path)]) == 0
    assert "ground truth" in capsys.readouterr().out
    report: dict[str, Any] = json.loads(report_path.read_text())
    return report


@pytest.mark.alone
@pytest.mark.parametrize(
    ("road", "personality", "known"),
    [("bends", "px4", True), ("stop-and-go", "ardupilot", False)],
)
def test_a_road_is_protected_as_predicted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], road: str, personality: str, known: bool
) -> None:
    # (the speedup held: these roads are flown at 20x or more; slowing a simulator whose
    # re-plans come late is test_service_faults')
    argv = ["replay", "--road", road, "--duration", "500", "--speedup", str(SPEEDUP)]
    argv.append("--fixed-speedup")
    argv += ["--personality", personality, "--quiet"]
    argv += ["--record-mission", str(tmp_path / "mission.inputs")]
    report = _replayed(argv + (["--route-known"] if known else []), tmp_path, capsys)
    assert report["uav_count"] == (6 if known else 7)  # (``road_fleet``)
    planner = report["planner"]
    assert planner["name"] == "road" and planner["route_known"] is known
    if known:
        assert planner["route_length_m"] > 5000.0
        assert planner["route_max_curvature_per_m"] == pytest.approx(1 / 150, rel=0.2)
    assert 0.3 < planner["convoy_fast"]["max_speed_ratio"] < 0.6  # (8 m/s of 18)
    for margins in planner["flyability"].values():  # what was commanded was flyable
        assert margins["min_turn_radius_m"] >= 150.0 - 0.1
        assert margins["speed_range_mps"][0] >= 0.85 * 18.0 - 0.01
        assert margins["speed_range_mps"][1] <= 1.15 * 18.0 + 0.01
    start = report["protect_start_s"]
    assert start is not None and start < 240.0
    truth = report["truth_coverage_fraction"]
    # (the first 260-380 s of protection; the README's table has the whole roads)
    why = _diagnosis(report)
    assert truth >= 0.90, why
    assert report["predicted_coverage"] == pytest.approx(truth, abs=0.015), why
    assert report["coverage_fraction"] == pytest.approx(truth, abs=0.015), why
    # The planes fly what they are sent: re-plans reach them late at 40x and are laid
    # ahead on their paths for it (1-7 m off them on average here; the urban grid,
    # whose corners re-plan the fleet at once, 23 m when they were not).
    errors = {v["sysid"]: v["mean_tracking_error_m"] for v in report["vehicles"]}
    assert all(e is not None and e < 12.0 for e in errors.values()), why
    # The flight's planning, replayed offline from its recorded inputs, is the flight's
    # (the last mission step, still running when the flight ended, is in the recording
    # but not in the report: a fraction of a second of prediction).
    replay = RoadMission.replayed(load_recording(tmp_path / "mission.inputs"))
    assert replay.predicted_coverage == pytest.approx(report["predicted_coverage"], abs=2e-3)
    assert replay.protect_start == pytest.approx(start, abs=1e-6)


@pytest.mark.alone
def test_a_planned_route_the_convoy_drives_out_and_back_is_flown_as_its_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``replay TRACK --route FILE``: the service is given the route planned (the way out
    only, a CSV of lat,lon) while the mock's rovers drive out and back: it finds the
    convoy again on the route driven the other way and covers it as it predicts."""
    dev = DEVIATIONS["out and back"](np.random.default_rng(0))
    frame = LocalFrame(DEFAULT_ORIGIN)
    rt = dev.track
    drive_csv, route_csv = tmp_path / "drive.csv", tmp_path / "route.csv"
    rows = ["time,lat,lon"]
    for t, n, e in zip(rt.t, rt.north, rt.east, strict=True):
        p = frame.to_geo(float(n), float(e))
        rows.append(f"{t:.1f},{p.lat:.7f},{p.lon:.7f}")
    drive_csv.write_text("\n".join(rows) + "\n")
    way = zip(dev.route_north[::10], dev.route_east[::10], strict=True)  # (every 5 m)
    route_csv.write_text("".join(f"{q.lat:.7f},{q.lon:.7f}\n" for q in (
        frame.to_geo(float(n), float(e)) for n, e in way)))  # fmt: skip
    argv = ["replay", str(drive_csv), "--route", str(route_csv)]
    argv += ["--speedup", str(SPEEDUP), "--fixed-speedup", "--quiet"]
    report = _replayed(argv, tmp_path, capsys)
    planner = report["planner"]
    assert report["uav_count"] == 6  # (the count with a route)
    assert planner["name"] == "road" and planner["route_known"]
    assert planner["route_length_m"] == pytest.approx(400.0 + 75.0 * math.pi + 800.0, abs=5.0)
    assert planner["convoy_found_again_on_route"] >= 1  # (driving it back)
    why = _diagnosis(report)
    truth = report["truth_coverage_fraction"]
    # The regression this guards: before the convoy was found again on the route driven
    # back, 82-84 %. One flight is one draw of a few points (the README's 97.3 % on the
    # mock; a healthy CI flight at 9x, 1-2 m on its paths, 94.6 % as predicted, 94.3 %).
    assert truth >= 0.92, why
    assert report["predicted_coverage"] == pytest.approx(truth, abs=0.015), why


def test_a_route_file_that_cannot_be_read_is_refused_before_the_flight(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "route.csv"
    bad.write_text("lat,lon\n52.1,not a number\n")
    argv = ["replay", "--road", "bends", "--route", str(bad), "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--route" in err and str(bad) in err
    assert main(["replay", "--road", "bends", "--route", str(bad), "--route-known"]) == 2
    assert "not both" in capsys.readouterr().err


def _diagnosis(report: dict[str, Any]) -> str:
    """What a failed flight's report says of where the coverage went (for the failure)."""
    planner = report["planner"]
    counters = ("uav_replans", "legs_late", "fills", "convoy_holds", "replan_lag_s")
    told = ("gap", "lost", "late", "join", "back", "slot", "silent", "heard", "clock")
    lines = [
        f"truth {report['truth_coverage_fraction']:.4f}, predicted "
        f"{report['predicted_coverage']:.4f}, monitor {report['coverage_fraction']:.4f}",
        f"planner { ({k: planner.get(k) for k in counters}) }",
        f"clock {report['mission_clock']}, replans {len(report['replans'])}",
        *(f"  {e}" for e in report["events"] if any(word in e for word in told)),
        *(
            f"  UAV {v['sysid']}: {v['status']}, tracking {_metres(v['mean_tracking_error_m'])}, "
            f"in circle {v['time_in_circle_fraction']:.3f}, {v['messages_per_s']} msg/s, "
            f"setpoint gap max {v['setpoint_gap_max_s']} s, not counted {v['not_counted_s']}, "
            f"rejected {v['rejected']}"
            for v in report["vehicles"]
        ),
    ]
    return "\n".join(lines)


def _metres(value: float | None) -> str:
    """A UAV's mean tracking error, or why it has none (it never protected)."""
    return "none (never protected)" if value is None else f"{value:.1f} m"


async def test_a_convoy_whose_feed_falls_silent_while_parked_is_held_in_sight() -> None:
    """The ground vehicles stop reporting for 80 s of a 120-s stop (a logger that records
    only on the move): the fleet plans on for the convoy held where last seen, and the
    truth, parked there, stays covered (flying on the plans in force instead: 80 % over
    the silence, gaps of 11 s)."""
    road = road_kind("stop-and-go")
    speed = np.hypot(np.gradient(road.true_north, road.t), np.gradient(road.true_east, road.t))
    parked = road.t[speed < 0.01]
    stop_start = float(parked[parked > 60.0][0])  # the first stop, after the start
    # (from 30 s in: the pattern has closed into the stop's figure eights by then)
    silent_from, silent_to = stop_start + 30.0, stop_start + 110.0
    marks: dict[str, float] = {}

    async def mute_the_convoy(fleet: MockFleet, service: ConvoyService) -> None:
        ground = [e.sysid for e in fleet.endpoints if e.kind == "ground"]
        await fleet.wait_until(silent_from)
        assert service.monitor.protect_start is not None  # (protecting by then)
        for sysid in ground:
            fleet.link(sysid).muted = True
        marks["muted"] = fleet.now
        await fleet.wait_until(silent_to)
        for sysid in ground:
            fleet.link(sysid).muted = False
        marks["unmuted"] = fleet.now

    fleets: list[MockFleet] = []

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        fleets.append(fleet)
        await mute_the_convoy(fleet, service)

    scenario = replay_scenario(road.geotrack(DEFAULT_ORIGIN))
    # (20x on a host as fast as the reference: with the mock in this process, a slow host
    # at 40x starved the flight loop late in a test session; 82 % over the silence)
    speedup = host_speedup(20.0)
    result = await run_demo(scenario, duration=silent_to + 60.0, speedup=speedup, during=script)
    assert "unmuted" in marks, "the silence never ended"
    report = result.report.to_dict()
    assert report["planner"]["convoy_holds"] >= 1
    assert "uav_lost" not in {r["reason"] for r in report["replans"]}  # (the convoy fell silent)
    assert any(a["kind"] == "convoy_stale" for a in report["alarms"]), report["alarms"]
    # The mock's truth over the silence itself (the convoy parked, unheard).
    silence = score_fleet(fleets[0], result.report.config, marks["muted"], marks["unmuted"])
    assert result.truth is not None
    print(
        f"\nconvoy silent {marks['unmuted'] - marks['muted']:.0f} s while parked: truth over "
        f"the silence {100 * silence.fraction:.2f} % (longest gap {silence.longest_gap_s:.1f} s), "
        f"over the protect phase {100 * result.truth.fraction:.2f} %"
    )
    assert silence.fraction >= 0.95 and silence.longest_gap_s <= 6.0
    assert result.truth.fraction >= 0.92


def test_the_lead_rovers_mission_is_read_as_the_convoys_route(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``replay --route-mission``: the mock's lead rover (ArduPilot: its mission's item 0
    is home) drives the road as its mission, holding where the road stops; the service
    reads that mission over MAVLink and flies it as the route, with its holds, and the
    route's count of UAVs."""
    argv = ["replay", "--road", "stop-and-go", "--route-mission", "--duration", "240"]
    argv += ["--personality", "ardupilot", "--speedup", str(SPEEDUP), "--quiet"]
    report = _replayed(argv, tmp_path, capsys)
    planner = report["planner"]
    assert report["uav_count"] == 6  # (the count with a route)
    # The road's three stops (120, 120 and 30 s), as its rover's hold times.
    assert planner["route_source"].startswith("ground vehicle 7's mission (3 holds, ")
    assert planner["mission_reads"] == 1  # (its MISSION_CURRENT says it did not change)
    assert planner["route_known"]
    # The whole road, its arcs as the chords of the waypoints it was thinned to.
    road = road_kind("stop-and-go")
    assert planner["route_length_m"] == pytest.approx(road.length_m, rel=0.02)
    assert any("route received from ground vehicle 7's mission" in e for e in report["events"])
    assert report["protect_start_s"] is not None


def test_a_json_route_with_its_stops_is_flown_with_them(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``replay --road stop-and-go --route route.json``: a command post's route, with the
    three stops it plans (``holds``: where, and how long); the service reads them with
    the road and covers the convoy through its first stop (from 1.5 km: 190-310 s) as it
    predicts."""
    frame = LocalFrame(DEFAULT_ORIGIN)
    way = [frame.to_geo(float(n), 0.0) for n in range(0, 6501, 500)]  # (the road: north)
    plan = {
        "type": "Feature",
        "properties": {"name": "stop and go", "holds": [[3, 120], [7, 120], [10, 30]]},
        "geometry": {"type": "LineString", "coordinates": [[p.lon, p.lat] for p in way]},
    }
    route = tmp_path / "route.geojson"
    route.write_text(json.dumps(plan))
    argv = ["replay", "--road", "stop-and-go", "--route", str(route), "--duration", "420"]
    argv += ["--personality", "px4", "--speedup", str(SPEEDUP), "--quiet"]
    report = _replayed(argv, tmp_path, capsys)
    planner = report["planner"]
    assert report["uav_count"] == 6  # (the count with a route)
    assert planner["route_source"] == "file (3 holds, 270 s)"
    assert planner["route_length_m"] == pytest.approx(6500.0, rel=0.01)
    why = _diagnosis(report)
    truth = report["truth_coverage_fraction"]
    assert truth >= 0.97, why
    assert report["predicted_coverage"] == pytest.approx(truth, abs=0.015), why
