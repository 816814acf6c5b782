"""The README's road table: every generated road kind and the recorded drive, both modes.

    .venv/bin/python benchmarks/road_table.py            # the planner's own simulation (~3 min)
    .venv/bin/python benchmarks/road_table.py --mock     # + flown against sitl_mock (~15 min)

Simulation: the service's ``RoadMission`` fed the convoy's fixes through its own
``ConvoyTracker``, UAVs flying exactly what they are sent (``fly_road``), coverage
scored against the convoy's true positions from the start of protection to the
end of the track. ``--mock`` flies the same roads through ``convoy-mav replay``
(real UDP, the mock's PX4 planes at 40x) and adds the mock's ground truth and
the service's own prediction.
"""

from __future__ import annotations

import argparse
import asyncio
from pathlib import Path

import numpy as np
import numpy.typing as npt

from convoy_mav.config import DEFAULT_ORIGIN
from convoy_mav.demo import Scenario, replay_scenario, run_demo
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mission.choose import road_fleet
from convoy_mav.mission.simulate import fly_road
from convoy_mav.planning import PlanRequest
from convoy_mav.tracks import GeoTrack, load_track
from convoy_mav.tracks.roads import KINDS, road_kind

TRACKS = Path(__file__).resolve().parents[2] / "shared" / "tracks"
DEFAULT = PlanRequest(150.0, 100.0, 18.0)
FAST = PlanRequest(200.0, 120.0, 28.0)  # configs/rehearse_fast_planes.toml
FloatArray = npt.NDArray[np.float64]


Truth = tuple[FloatArray, FloatArray] | None


def _roads() -> list[tuple[str, GeoTrack, PlanRequest, Truth]]:
    out: list[tuple[str, GeoTrack, PlanRequest, Truth]] = []
    for kind in KINDS:
        rt = road_kind(kind)
        out.append((kind, rt.geotrack(DEFAULT_ORIGIN), DEFAULT, (rt.true_north, rt.true_east)))
    for name, req in (("istanbul_drive.gpx", FAST), ("istanbul_drive_slow.gpx", DEFAULT)):
        out.append((name, load_track(TRACKS / name), req, None))
    return out


def _simulate(track: GeoTrack, req: PlanRequest, truth: Truth, known: bool) -> str:
    n, e = track.in_frame(LocalFrame(GeoPoint(track.lats[0], track.lons[0])))
    tn = te = None
    if truth is not None and len(truth[0]) == len(n):  # generated: the true positions,
        first = LocalFrame(DEFAULT_ORIGIN).to_ned(GeoPoint(track.lats[0], track.lons[0]))
        tn, te = truth[0] - first[0], truth[1] - first[1]  # in the track's own frame
    uavs = road_fleet(req.turn_radius, req.sensor_radius)
    run = fly_road(track.times, n, e, req, uavs, true_north=tn, true_east=te, route_known=known)
    start = "-" if run.protect_start is None else f"{run.protect_start:.0f}"
    return f"{100 * run.coverage:.1f} % / {run.longest_gap_s:.0f} s / {start} s"


def _mock(track: GeoTrack, req: PlanRequest, known: bool) -> str:
    base = Scenario(
        "replay", sensor_radius_m=req.sensor_radius, turn_radius_m=req.turn_radius,
        airspeed_mps=req.uav_speed, altitude_m=100.0,
    )  # fmt: skip
    scenario = replay_scenario(track, base)
    result = asyncio.run(
        run_demo(scenario, duration=track.duration, speedup=40.0, route_known=known)
    )
    truth, report = result.truth, result.report
    if truth is None:
        return "never protected"
    predicted = report.predicted_coverage
    pred = "-" if predicted is None else f"{100 * predicted:.1f}"
    return f"{100 * truth.fraction:.1f} % (pred. {pred}) / {truth.longest_gap_s:.0f} s"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mock", action="store_true", help="also fly them against sitl_mock")
    args = parser.parse_args()
    head = "| road | UAVs | route known: coverage / longest gap / protected from | no route |"
    if args.mock:
        head += " mock, route known: truth (predicted) / gap | mock, no route |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for name, track, req, truth in _roads():
        uavs = road_fleet(req.turn_radius, req.sensor_radius)
        row = [name, str(uavs)] + [_simulate(track, req, truth, k) for k in (True, False)]
        if args.mock:
            row += [_mock(track, req, k) for k in (True, False)]
        print("| " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
