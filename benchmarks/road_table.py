"""The README's road table: every generated road kind and the recorded drive, both modes.

    .venv/bin/python benchmarks/road_table.py            # the planner's own simulation (~3 min)
    .venv/bin/python benchmarks/road_table.py --mock     # + flown against sitl_mock (~20 min)
    .venv/bin/python benchmarks/road_table.py --unseen   # random roads, other grids (~2 min)
    .venv/bin/python benchmarks/road_table.py --unseen --mock  # + against sitl_mock
    .venv/bin/python benchmarks/road_table.py --variants  # the kinds with other numbers (~2 min)
    .venv/bin/python benchmarks/road_table.py --others  # roads of other kinds (~2 min)
    .venv/bin/python benchmarks/road_table.py --corners  # sudden corners, no route (~1 min)
    .venv/bin/python benchmarks/road_table.py --junctions  # a stop, then a turn (~2 min)
    .venv/bin/python benchmarks/road_table.py --gaps  # where the loss is, why (~3 min)
    .venv/bin/python benchmarks/road_table.py --foresight  # given the true future (~5 min)
    .venv/bin/python benchmarks/road_table.py --fast-stops  # stops from speed (~2 min)
    .venv/bin/python benchmarks/road_table.py --stop-reach  # could the fleet close them (~1 min)
    .venv/bin/python benchmarks/road_table.py --no-route-count  # 6 or 7 UAVs, no route (~8 min)
    .venv/bin/python benchmarks/road_table.py --deviations  # routes the convoy leaves (~3 min)
    .venv/bin/python benchmarks/road_table.py --aircraft  # the kinds, other aircraft (~15 min)
    .venv/bin/python benchmarks/road_table.py --holds  # with its stops, speeds as its plan
    .venv/bin/python benchmarks/road_table.py --patrol  # a circuit's laps and holds (~10 min)
    .venv/bin/python benchmarks/road_table.py --spread DIR  # cells kept by --mock --keep DIR

Simulation: the service's ``RoadMission`` fed the convoy's fixes through its own
``ConvoyTracker``, UAVs flying exactly what they are sent (``fly_road``), coverage
scored against the convoy's true positions from the start of protection to the
end of the track. ``--mock`` flies the same roads through ``convoy-mav replay``,
each in a process of its own (real UDP, the mock's PX4 planes at 40x), and adds
the mock's ground truth and the service's own prediction.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import numpy.typing as npt

from convoy_mav.config import DEFAULT_ORIGIN
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mission.choose import road_fleet
from convoy_mav.mission.recording import load_recording
from convoy_mav.mission.road import RoadMission, RoadSettings
from convoy_mav.mission.simulate import RoadRun, chord_velocity, fly_road, true_speeds
from convoy_mav.planning import PlanRequest
from convoy_mav.planning.dubins import Pose, dubins_word_lengths
from convoy_mav.planning.road import Road
from convoy_mav.tracks import GeoTrack, load_track
from convoy_mav.tracks.roads import (
    DEVIATIONS,
    KINDS,
    OTHERS,
    VARIANTS,
    Deviation,
    RoadTrack,
    corner,
    junction,
    patrol,
    random_road,
    road_kind,
    stops_from,
)
from convoy_mav.tracks.stops import standstills

ROOT = Path(__file__).resolve().parents[1]
TRACKS = ROOT.parent / "shared" / "tracks"
DEFAULT = PlanRequest(150.0, 100.0, 18.0)
FAST = PlanRequest(200.0, 120.0, 28.0)  # configs/rehearse_fast_planes.toml
FloatArray = npt.NDArray[np.float64]


Truth = tuple[FloatArray, FloatArray] | None


@cache
def _roads() -> list[tuple[str, GeoTrack, PlanRequest, Truth]]:
    out: list[tuple[str, GeoTrack, PlanRequest, Truth]] = []
    for kind in KINDS:
        rt = road_kind(kind)
        out.append((kind, rt.geotrack(DEFAULT_ORIGIN), DEFAULT, (rt.true_north, rt.true_east)))
    for name, req in (("istanbul_drive.gpx", FAST), ("istanbul_drive_slow.gpx", DEFAULT)):
        out.append((name, load_track(TRACKS / name), req, None))
    return out


Paths = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


def _paths(track: GeoTrack, truth: Truth) -> Paths:
    """The convoy's fix times, its fixes (north, east in the track's own frame) and where
    it truly was then: a generated road's true positions, a recorded one's fixes."""
    times = np.asarray(track.times, dtype=np.float64)
    n, e = track.in_frame(LocalFrame(GeoPoint(track.lats[0], track.lons[0])))
    north, east = np.asarray(n, dtype=np.float64), np.asarray(e, dtype=np.float64)
    if truth is not None and len(truth[0]) == len(n):
        first = LocalFrame(DEFAULT_ORIGIN).to_ned(GeoPoint(track.lats[0], track.lons[0]))
        return times, north, east, truth[0] - first[0], truth[1] - first[1]
    return times, north, east, north, east


def _fly(
    paths: Paths, req: PlanRequest, known: bool, foresight_s: float | None = None, more: int = 0
) -> RoadRun:
    """Fly a road in simulation (with ``more`` UAVs than the road's count), its fixes
    reporting the velocity the mock's ground vehicles report when they drive it
    (``chord_velocity``)."""
    times, north, east, tn, te = paths
    uavs = road_fleet(req.turn_radius, req.sensor_radius, route=known) + more
    return fly_road(
        times, north, east, req, uavs, true_north=tn, true_east=te, route_known=known,
        foresight_s=foresight_s, reported=chord_velocity(times, north, east),
    )  # fmt: skip


def _simulate(track: GeoTrack, req: PlanRequest, truth: Truth, known: bool) -> tuple[str, float]:
    run = _fly(_paths(track, truth), req, known)
    start = "-" if run.protect_start is None else f"{run.protect_start:.0f}"
    return f"{100 * run.coverage:.1f} % / {run.longest_gap_s:.0f} s / {start} s", run.coverage


GAP_CLASSES = ("stopped", "starting", "turning", "driving")
_STOPPED_MPS = 0.5  # slower, the convoy stands
_STARTING_S = 30.0  # this long after standing, it is starting
_TURNING_DEG = 30.0  # its course changing more than this ...
_TURN_WINDOW_S = (20.0, 5.0)  # ... from this long before to this long after: turning


def gap_classes(
    run: RoadRun, times: FloatArray, north: FloatArray, east: FloatArray, dt: float = 0.5
) -> dict[str, float]:
    """Seconds of ``run``'s unseen stretches by what the convoy (truly at ``north``, ``east``
    at ``times``) was doing then: standing, starting (within 30 s of standing), turning
    (its course changing more than 30 deg within 20 s before to 5 s after) or driving.

    Speeds are a 5-s running mean of the fixes' differences, so a recorded drive's
    jitter does not count as moving."""
    steps = np.diff(times)
    raw = np.hypot(np.diff(north), np.diff(east)) / np.maximum(steps, 1e-9)
    mid = times[:-1] + 0.5 * steps
    grid = np.arange(times[0], times[-1], dt)
    k = max(1, round(5.0 / dt))
    speed = np.convolve(np.interp(grid, mid, raw), np.ones(k) / k, mode="same")
    stood = grid[speed < _STOPPED_MPS]
    vx, vy = np.gradient(np.interp(grid, times, east)), np.gradient(np.interp(grid, times, north))
    course = np.unwrap(np.arctan2(vx, vy))
    out = dict.fromkeys(GAP_CLASSES, 0.0)
    for start, end in run.gaps:
        for when in np.arange(start, end - 1e-9, dt):
            i = min(int(np.searchsorted(grid, when)), len(grid) - 1)
            last_stood = int(np.searchsorted(stood, when, side="right"))  # (one past it)
            if speed[i] < _STOPPED_MPS:
                what = "stopped"
            elif last_stood and when - stood[last_stood - 1] <= _STARTING_S:
                what = "starting"
            else:
                lo, hi = when - _TURN_WINDOW_S[0], when + _TURN_WINDOW_S[1]
                near = course[(grid >= lo) & (grid <= hi) & (speed >= _STOPPED_MPS)]
                turned = len(near) > 1 and math.degrees(float(np.ptp(near))) > _TURNING_DEG
                what = "turning" if turned else "driving"
            out[what] += dt
    return out


def _gaps() -> None:
    """The table's roads in simulation, both modes: the unseen seconds by what the
    convoy was doing (``gap_classes``), and how many of them the pattern as laid then
    covered (the UAVs off it: ``RoadRun.unseen_off_pattern_s``)."""
    head = (
        "| road | route | coverage | unseen s | UAVs off the pattern | "
        + " | ".join(GAP_CLASSES)
        + " |"
    )
    print(head + "\n|" + "---|" * (head.count("|") - 1))
    totals: dict[bool, dict[str, float]] = {}
    off: dict[bool, float] = {}
    for name, track, req, truth in _roads():
        paths = _paths(track, truth)
        times, _, _, north, east = paths
        for known in (True, False):
            run = _fly(paths, req, known)
            by = gap_classes(run, times, north, east)
            total = totals.setdefault(known, dict.fromkeys(GAP_CLASSES, 0.0))
            for what, seconds in by.items():
                total[what] += seconds
            off[known] = off.get(known, 0.0) + run.unseen_off_pattern_s
            cells = [f"{by[w]:.1f}" for w in GAP_CLASSES]
            print(
                f"| {name} | {'known' if known else 'none'} | {100 * run.coverage:.1f} % | "
                f"{sum(by.values()):.1f} | {run.unseen_off_pattern_s:.1f} | "
                + " | ".join(cells)
                + " |",
                flush=True,
            )
    for known, total in totals.items():
        whole = sum(total.values()) or 1.0
        shares = " | ".join(f"{100 * total[w] / whole:.0f} %" for w in GAP_CLASSES)
        away = f"{100 * off[known] / whole:.0f} %"
        print(f"| all | {'known' if known else 'none'} | | {whole:.1f} | {away} | {shares} |")


def _mock(
    name: str,
    req: PlanRequest,
    known: bool,
    track: GeoTrack | None = None,
    keep: Path | None = None,
) -> tuple[str, float]:
    """``convoy-mav replay`` of the road in a process of its own, as a user runs it.

    One process per mission: run after run in one process, every mission's
    leftovers (the mock's ground truth among them) sit in the heap the
    collector walks, and a late mission in the table stalled for seconds at 40x.
    A ``track`` (an unseen road) is replayed from a CSV of its fixes. ``keep``: a
    folder that keeps each cell's report, tlog and mission recording (a cell whose
    truth falls short of its prediction is then looked into, not flown again).
    """
    cmd = [sys.executable, "-m", "convoy_mav", "replay", "--speedup", "40", "-q"]
    if req == FAST:
        cmd += ["--config", str(ROOT / "configs" / "rehearse_fast_planes.toml")]
    if known:
        cmd.append("--route-known")
    with tempfile.TemporaryDirectory() as tmp:
        if track is not None:
            csv = Path(tmp) / "track.csv"
            rows = zip(track.times, track.lats, track.lons, strict=True)
            csv.write_text(
                "time,lat,lon\n" + "".join(f"{t:.3f},{a:.8f},{o:.8f}\n" for t, a, o in rows)
            )
            cmd.append(str(csv))
        elif name.endswith(".gpx"):
            cmd.append(str(TRACKS / name))
        else:
            cmd += ["--road", name]
        out = Path(tmp) / "report.json"
        if keep is not None:
            keep.mkdir(parents=True, exist_ok=True)
            stem = keep / f"{Path(name).stem}-{'known' if known else 'none'}"
            out = stem.with_suffix(".json")
            cmd += ["--tlog", str(stem.with_suffix(".tlog"))]
            cmd += ["--record-mission", str(stem.with_suffix(".inputs"))]
        subprocess.run([*cmd, "--report", str(out)], check=False, capture_output=True)
        if not out.exists():
            return "never protected", 0.0
        report = json.loads(out.read_text())
    truth = report.get("truth_coverage_fraction")
    if truth is None:
        return "never protected", 0.0
    predicted = report.get("predicted_coverage")
    pred = "-" if predicted is None else f"{100 * predicted:.1f}"
    return f"{100 * truth:.1f} % (pred. {pred}) / {report['truth_longest_gap_s']:.0f} s", truth


def _unseen() -> list[tuple[str, GeoTrack, PlanRequest, Truth]]:
    """Roads the planner was not tuned on: random roads and other urban grids."""
    out: list[tuple[str, GeoTrack, PlanRequest, Truth]] = []
    drives = [(f"random seed {s}", random_road(np.random.default_rng(s))) for s in range(1, 9)]
    drives += [(f"urban seed {s}", road_kind("urban", seed=s)) for s in (1, 2)]
    for name, rt in drives:
        out.append((name, rt.geotrack(DEFAULT_ORIGIN), DEFAULT, (rt.true_north, rt.true_east)))
    return out


def _made(
    kinds: dict[str, Callable[[np.random.Generator], RoadTrack]] = VARIANTS,
) -> list[tuple[str, GeoTrack, PlanRequest, Truth]]:
    """Roads of ``kinds`` made as the table flies them: by default the kinds with other
    numbers (``tracks.roads.VARIANTS``: faster convoys, sharper bends, coarser fixes, as
    other roads of these kinds may have), or roads of other kinds (``OTHERS``)."""
    out: list[tuple[str, GeoTrack, PlanRequest, Truth]] = []
    for name, make in kinds.items():
        rt = make(np.random.default_rng(7))
        out.append((name, rt.geotrack(DEFAULT_ORIGIN), DEFAULT, (rt.true_north, rt.true_east)))
    return out


CORNERS_DEG = (-120.0, -90.0, -60.0, -30.0, 30.0, 60.0, 90.0, 120.0)  # + turns right
CORNER_AT_S = (300.0, 311.0, 323.0)  # a third of the meet period apart at 8 m/s


def _corners() -> None:
    """A convoy at 8 m/s that turns once, at a corner nobody foresaw (no route), for
    each angle and three times of the turn (the formation's phase then): coverage
    of the protect phase to 200 s past the turn, and the longest gap."""
    print("| corner | " + " | ".join(f"turn at {t:.0f} s" for t in CORNER_AT_S) + " |")
    print("|" + "---|" * (len(CORNER_AT_S) + 1))
    coverages, gaps = [], []
    for angle in CORNERS_DEG:
        cells = []
        for at in CORNER_AT_S:
            t, north, east = corner(angle, at)
            uavs = road_fleet(DEFAULT.turn_radius, DEFAULT.sensor_radius, route=False)
            run = fly_road(t, north, east, DEFAULT, uavs)
            coverages.append(run.coverage)
            gaps.append(run.longest_gap_s)
            cells.append(f"{100 * run.coverage:.1f} % / {run.longest_gap_s:.0f} s")
        side = "right" if angle > 0 else "left"
        print(f"| {abs(angle):.0f}° {side} | " + " | ".join(cells) + " |", flush=True)
    print(
        f"mean {100 * np.mean(coverages):.1f} %, worst {100 * min(coverages):.1f} %, "
        f"longest gap {max(gaps):.0f} s"
    )


JUNCTION_AT_M = (2400.0, 2488.0, 2576.0)  # a third of the meet period apart at 8 m/s
JUNCTION_STOPS_S = (10.0, 25.0, 45.0)


def _junctions() -> None:
    """A convoy at 8 m/s that stops at a junction for 10-45 s, then turns 90 deg either
    way, at three phases of the formation, with the route known and without: coverage
    of the protect phase and the longest gap."""
    print("| stop, then turn | " + " | ".join(f"at {m:.0f} m" for m in JUNCTION_AT_M) + " |")
    print("|" + "---|" * (len(JUNCTION_AT_M) + 1))
    coverages: dict[bool, list[float]] = {True: [], False: []}
    for angle in (90.0, -90.0):
        for stop in JUNCTION_STOPS_S:
            cells = []
            for at in JUNCTION_AT_M:
                rt = junction(stop, angle, at)
                pair = []
                for known in (True, False):
                    uavs = road_fleet(DEFAULT.turn_radius, DEFAULT.sensor_radius, route=known)
                    run = fly_road(
                        rt.t, rt.north, rt.east, DEFAULT, uavs, true_north=rt.true_north,
                        true_east=rt.true_east, route_known=known,
                    )  # fmt: skip
                    coverages[known].append(run.coverage)
                    pair.append(f"{100 * run.coverage:.1f} % / {run.longest_gap_s:.0f} s")
                cells.append(" · ".join(pair))
            side = "left" if angle > 0 else "right"
            print(f"| {stop:.0f} s, 90° {side} | " + " | ".join(cells) + " |", flush=True)
    print("(each cell: route known · no route)")
    for known, label in ((True, "route known"), (False, "no route")):
        values = coverages[known]
        print(f"{label}: mean {100 * np.mean(values):.1f} %, worst {100 * min(values):.1f} %")


#: (route known, seconds of the true future) of the ``--foresight`` columns; None: none.
FORESIGHT = (
    (False, None), (False, 0.0), (False, 10.0), (False, 20.0),
    (True, None), (True, 10.0), (True, math.inf),
)  # fmt: skip


def _foreseen(job: tuple[int, bool, float | None]) -> float:
    """Coverage of road ``job[0]`` of ``_roads()``, route known or not, with foresight."""
    index, known, foresight_s = job
    _, track, req, truth = _roads()[index]
    return _fly(_paths(track, truth), req, known, foresight_s).coverage


def _foresight() -> None:
    """The table's roads flown with the forecast given the convoy's true path ahead
    (``Foresight``): the present known exactly (0 s), 10 and 20 s of it, or all of it.
    What foresight gains is the loss to the forecast; what it leaves, the fleet's."""
    names = [name for name, _, _, _ in _roads()]
    jobs = [(i, known, h) for i in range(len(names)) for known, h in FORESIGHT]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        coverage = list(pool.map(_foreseen, jobs))

    def label(h: float | None) -> str:
        return "forecast" if h is None else "all" if math.isinf(h) else f"{h:.0f} s"

    head = [f"no route, {label(h)}" for k, h in FORESIGHT if not k]
    head += [f"route, {label(h)}" for k, h in FORESIGHT if k]
    print("| road | " + " | ".join(head) + " |")
    print("|" + "---|" * (len(head) + 1))
    width = len(FORESIGHT)
    for i, name in enumerate(names):
        row = coverage[i * width : (i + 1) * width]
        print(f"| {name} | " + " | ".join(f"{100 * c:.1f} %" for c in row) + " |")
    means = np.mean(np.reshape(coverage, (len(names), width)), axis=0)
    print("| mean | " + " | ".join(f"{100 * m:.1f} %" for m in means) + " |")


#: Convoy speeds of ``--fast-stops``, as fractions of the airspeed, and the aircraft.
FAST_STOP_RATIOS = (0.33, 0.44, 0.5, 0.56, 0.61, 0.67, 0.78)
FAST_STOP_AIRCRAFT = (DEFAULT, PlanRequest(150.0, 100.0, 24.0), FAST)


def _stopped(job: tuple[float, PlanRequest]) -> RoadRun:
    ratio, req = job
    rt = stops_from(ratio * req.uav_speed)
    uavs = road_fleet(req.turn_radius, req.sensor_radius)
    return fly_road(
        rt.t, rt.north, rt.east, req, uavs, true_north=rt.true_north, true_east=rt.true_east,
        route_known=True,
    )  # fmt: skip


def _fast_stops() -> None:
    """Stops from a steady speed (1 m/s^2 braking, four stops of 60 s, the route known),
    for convoy speeds from a third of the airspeed to 0.78 of it, on three airframes:
    coverage of the protect phase and the longest gap (``FAST_CONVOY_RATIO``)."""
    jobs = [(ratio, req) for ratio in FAST_STOP_RATIOS for req in FAST_STOP_AIRCRAFT]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = list(pool.map(_stopped, jobs))
    head = [
        f"R {q.turn_radius:g} m, r {q.sensor_radius:g} m, {q.uav_speed:g} m/s"
        for q in FAST_STOP_AIRCRAFT
    ]
    print("| convoy speed / airspeed | " + " | ".join(head) + " |")
    print("|" + "---|" * (len(head) + 1))
    width = len(FAST_STOP_AIRCRAFT)
    for i, ratio in enumerate(FAST_STOP_RATIOS):
        row = runs[i * width : (i + 1) * width]
        cells = [f"{100 * run.coverage:.1f} % / {run.longest_gap_s:.0f} s" for run in row]
        print(f"| {ratio:.2f} | " + " | ".join(cells) + " |", flush=True)


REACH_SPEED_RATIO = 0.67  # --stop-reach: stops from 12 m/s for the demo's 18 m/s planes
REACH_FORESIGHT_S = (None, 0.0, 2.0, 5.0, 7.0, 10.0, math.inf)


def _soonest(mission: RoadMission, t: float, x: float, y: float, req: PlanRequest) -> list[float]:
    """Mission times at which each UAV, from where its path in force has it at ``t``, could
    first be within r of (x, y): the shortest Dubins path at the top of the speed band to
    a point 0.9 r from it, any heading, sampled (24 points, 12 headings)."""
    r, R = req.sensor_radius, req.turn_radius
    fastest = RoadSettings().speed_band[1] * req.uav_speed
    goals = [
        Pose(x + 0.9 * r * math.cos(a), y + 0.9 * r * math.sin(a), h)
        for a in np.linspace(0.0, 2.0 * math.pi, 24, endpoint=False)
        for h in np.linspace(0.0, 2.0 * math.pi, 12, endpoint=False)
    ]
    out = []
    for uav in range(1, 64):
        path = mission.trajectory(uav)
        if path is None:
            continue
        s = path.sample(t)
        here = Pose(s.x, s.y, s.heading)
        length = min(min(dubins_word_lengths(here, g, R).values()) for g in goals)
        out.append(t + length / fastest)
    return sorted(out)


def _reached(foresight: float | None) -> RoadRun:
    req = DEFAULT
    rt = stops_from(REACH_SPEED_RATIO * req.uav_speed)
    uavs = road_fleet(req.turn_radius, req.sensor_radius)
    return fly_road(
        rt.t, rt.north, rt.east, req, uavs, true_north=rt.true_north, true_east=rt.true_east,
        route_known=True, record=foresight is None, foresight_s=foresight,
    )  # fmt: skip


def _stop_reach() -> None:
    """Whether a fast convoy's stop leaves a gap the fleet could have closed: stops from
    0.67 of the airspeed (``stops_from``, the route known). For each gap of 10 s or
    more, when each UAV could at the soonest be over the stopped convoy, from where it
    flew at the gap's start and at the onset of the braking; then the same stops given
    the convoy's true next seconds (``fly_road(foresight_s=...)``)."""
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = list(pool.map(_reached, REACH_FORESIGHT_S))
    run, rt, req = runs[0], stops_from(REACH_SPEED_RATIO * DEFAULT.uav_speed), DEFAULT
    assert run.recording is not None
    speed = np.hypot(np.gradient(rt.true_north, rt.t), np.gradient(rt.true_east, rt.t))
    top = float(np.max(speed))
    print("| gap | braking from | stopped at | soonest over it, from the gap's start | "
          "from the onset of braking |\n|---|---|---|---|---|")  # fmt: skip
    for start, end in run.gaps:
        if end - start < 10.0:
            continue
        before = rt.t < start
        onset = float(rt.t[before & (speed >= 0.98 * top)][-1])
        k = int(np.flatnonzero((rt.t > onset) & (speed < 0.05))[0])
        x, y = float(rt.true_east[k]), float(rt.true_north[k])
        cells = []
        for t in (start, onset):
            mission = RoadMission.replayed(run.recording, until=t)
            cells.append(", ".join(f"{a:.0f}" for a in _soonest(mission, t, x, y, req)))
        print(f"| {start:.0f}-{end:.0f} s | {onset:.0f} s | {rt.t[k]:.0f} s | "
              f"{cells[0]} | {cells[1]} |")  # fmt: skip
    print("\n| foresight | coverage | longest gap |\n|---|---|---|")
    for h, flown in zip(REACH_FORESIGHT_S, runs, strict=True):
        label = "forecast" if h is None else "all" if math.isinf(h) else f"{h:.0f} s"
        print(f"| {label} | {100 * flown.coverage:.2f} % | {flown.longest_gap_s:.1f} s |")


COUNT_OFFSETS_S = (0.0, 11.0, 23.0)  # the track's first seconds dropped: another phase


def _count_roads() -> list[tuple[str, GeoTrack, PlanRequest, Truth]]:
    """The table's roads, two more urban grids and three random roads."""
    others = {"urban seed 1", "urban seed 2", "random seed 1", "random seed 3", "random seed 5"}
    return _roads() + [road for road in _unseen() if road[0] in others]


def _counted(job: tuple[int, float, int]) -> float:
    i, offset, extra = job
    _, track, req, truth = _count_roads()[i]
    times, north, east, tn, te = _paths(track, truth)
    keep = times >= times[0] + offset
    uavs = road_fleet(req.turn_radius, req.sensor_radius) + extra
    run = fly_road(
        times[keep] - times[keep][0], north[keep], east[keep], req, uavs,
        true_north=tn[keep], true_east=te[keep],
    )  # fmt: skip
    return run.coverage


def _no_route_count() -> None:
    """Without a route, the stationary minimum + 1 against + 2 UAVs, side by side: each
    road flown from ``COUNT_OFFSETS_S`` (every corner then meets the formation at another
    phase, the run-to-run noise of a chaotic road), and the paired difference."""
    names = [name for name, _, _, _ in _count_roads()]
    jobs = [(i, o, extra) for i in range(len(names)) for o in COUNT_OFFSETS_S for extra in (0, 1)]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        coverage = np.reshape(list(pool.map(_counted, jobs)), (len(names), len(COUNT_OFFSETS_S), 2))
    print("| road | + 1 | + 2 |\n|---|---|---|")
    for name, row in zip(names, coverage, strict=True):
        cells = [" · ".join(f"{100 * c:.2f}" for c in row[:, k]) + " %" for k in (0, 1)]
        print(f"| {name} | " + " | ".join(cells) + " |")
    diff = (coverage[:, :, 1] - coverage[:, :, 0]).ravel()
    print(
        f"mean {100 * coverage[:, :, 0].mean():.2f} -> {100 * coverage[:, :, 1].mean():.2f} %, "
        f"paired {100 * diff.mean():+.2f} +- {100 * diff.std(ddof=1) / math.sqrt(len(diff)):.2f} "
        f"points (standard error, {len(diff)} pairs)"
    )


HOLD_ROADS = (
    *KINDS,
    *(f"urban grid, seed {k}" for k in range(1, 6)),
    *(f"random road, seed {k}" for k in range(1, 9)),
    "stops of 30 s from 10 m/s",
    "stops of 60 s from 12 m/s",
    "urban, 5 m noise at 2 Hz",
    "urban at 0.5 Hz",
    "2 and 14 m/s",
    "5 and 15 m/s",
    "roundabout at 12 m/s",
    *(f"stops from {r} of the airspeed" for r in (0.5, 0.61, 0.67, 0.78)),
)
"""``--holds``: the kinds, other grids, random roads, the variants with stops or speeds,
and fast stops (``stops_from``)."""


def _hold_road(name: str) -> RoadTrack:
    if name.startswith("urban grid, seed "):
        return road_kind("urban", seed=int(name.rsplit(" ", 1)[1]))
    if name.startswith("random road, seed "):
        return random_road(np.random.default_rng(int(name.rsplit(" ", 1)[1])))
    if name.startswith("stops from "):
        return stops_from(float(name.split()[2]) * DEFAULT.uav_speed)
    if name in VARIANTS:
        return VARIANTS[name](np.random.default_rng(7))
    return road_kind(name)


PLANS = ("route known", "with its holds", "with its holds and speeds")


def _held(job: tuple[str, str]) -> tuple[float, float]:
    name, plan = job
    rt = _hold_road(name)
    route = Road.from_points(rt.true_east, rt.true_north)
    speeds = true_speeds(route, rt.true_north, rt.true_east, rt.speeds) if "speeds" in plan else ()
    run = fly_road(
        rt.t, rt.north, rt.east, DEFAULT, road_fleet(DEFAULT.turn_radius, DEFAULT.sensor_radius),
        true_north=rt.true_north, true_east=rt.true_east, route=route,
        reported=chord_velocity(rt.t, rt.north, rt.east), holds_known=plan != PLANS[0],
        speeds=speeds,
    )  # fmt: skip
    return run.coverage, run.longest_gap_s


def _holds() -> None:
    """Route known, without and with the convoy's stands as its plan's holds (a rover's
    mission's hold times, ``fly_road(holds_known=True)``), and with the drive's speeds
    too (its DO_CHANGE_SPEEDs, ``true_speeds``), side by side."""
    jobs = [(name, plan) for name in HOLD_ROADS for plan in PLANS]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = dict(zip(jobs, pool.map(_held, jobs), strict=True))
    print("| road | " + " | ".join(PLANS) + " |\n|---|---|---|---|")
    for name in HOLD_ROADS:
        cells = [f"{100 * c:.2f} % / {g:.1f} s" for c, g in (runs[name, p] for p in PLANS)]
        print(f"| {name} | " + " | ".join(cells) + " |")
    for plan, than in ((PLANS[1], PLANS[0]), (PLANS[2], PLANS[1])):
        diff = np.array([runs[n, plan][0] - runs[n, than][0] for n in HOLD_ROADS])
        before = np.mean([runs[n, than][0] for n in HOLD_ROADS])
        print(
            f"{plan}: mean {100 * before:.2f} -> {100 * (before + diff.mean()):.2f} %, paired "
            f"{100 * diff.mean():+.2f} +- {100 * diff.std(ddof=1) / math.sqrt(len(diff)):.2f} "
            f"points (standard error, {len(diff)} roads), worst {100 * diff.min():+.2f}"
        )


#: Other aircraft on the generated kinds (name: R, r, V), as other fleets may fly them.
AIRCRAFT = {
    "demo planes": DEFAULT,
    "wide camera, r/R 0.8": PlanRequest(100.0, 80.0, 18.0),
    "narrow camera, r/R 0.5": PlanRequest(150.0, 75.0, 18.0),
    "tight turns, R 75 m": PlanRequest(75.0, 50.0, 18.0),
    "large planes, R 300 m": PlanRequest(300.0, 200.0, 30.0),
    "rehearse_fast_planes.toml": FAST,
    "multirotor-like, R 40 m, 15 m/s": PlanRequest(40.0, 30.0, 15.0),
}
SENSOR_SWEEP_M = (60.0, 75.0, 90.0, 110.0, 135.0)  # r, with the demo's R and V

AircraftJob = tuple[str, PlanRequest, bool, int]  # kind, aircraft, route known, UAVs more


def _flown_by(job: AircraftJob) -> float:
    kind, req, known, more = job
    rt = road_kind(kind)
    paths = _paths(rt.geotrack(DEFAULT_ORIGIN), (rt.true_north, rt.true_east))
    return _fly(paths, req, known, more=more).coverage


def _aircraft() -> None:
    """The generated kinds flown by other aircraft (``AIRCRAFT``), both modes, then the
    demo's planes with cameras of other radii, route known, with the road's count and
    one UAV more: whether the road planner holds beyond the aircraft it was tuned on."""
    named = [
        (k, req, known, 0) for req in AIRCRAFT.values() for k in KINDS for known in (True, False)
    ]
    swept = [
        (k, replace(DEFAULT, sensor_radius=r), True, more)
        for r in SENSOR_SWEEP_M for k in KINDS for more in (0, 1)
    ]  # fmt: skip
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        coverage = iter(list(pool.map(_flown_by, named + swept)))
    rows = [
        (f"{name}: {req.turn_radius:.0f}, {req.sensor_radius:.0f} m, {req.uav_speed:.0f} m/s",
         [road_fleet(req.turn_radius, req.sensor_radius, route=k) for k in (True, False)])
        for name, req in AIRCRAFT.items()
    ]  # fmt: skip
    _pairs("aircraft (R, r, V) | UAVs (route / none)", rows, coverage)
    print()
    counts = [road_fleet(DEFAULT.turn_radius, r) for r in SENSOR_SWEEP_M]
    rows = [
        (f"{r:.0f} m (r/R {r / DEFAULT.turn_radius:.2f})", [n, n + 1])
        for r, n in zip(SENSOR_SWEEP_M, counts, strict=True)
    ]
    _pairs("camera radius, route known | UAVs (road's count / + 1)", rows, coverage)


def _pairs(head: str, rows: list[tuple[str, list[int]]], coverage: Iterator[float]) -> None:
    """A table of ``rows`` (label, UAV counts), each kind's cell a pair of coverages taken
    in turn from ``coverage``, and the pairs' means."""
    print(f"| {head} | " + " | ".join(KINDS) + " | mean |")
    print("|" + "---|" * (len(KINDS) + 3))
    for label, uavs in rows:
        pairs = [(next(coverage), next(coverage)) for _ in KINDS]
        cells = [" · ".join(f"{100 * c:.1f}" for c in pair) + " %" for pair in pairs]
        mean = " · ".join(f"{100 * np.mean(c):.1f}" for c in zip(*pairs, strict=True)) + " %"
        print(f"| {label} | {' / '.join(map(str, uavs))} | " + " | ".join([*cells, mean]) + " |")


DEVIATION_MODES = ("route given", "no route", "its own path as route")


def _deviated(job: tuple[str, float, str]) -> RoadRun:
    name, offset, mode = job
    dev = DEVIATIONS[name](np.random.default_rng(0))
    rt = dev.track
    keep = rt.t >= rt.t[0] + offset
    given = Road.from_points(dev.route_east, dev.route_north) if mode == "route given" else None
    return fly_road(
        rt.t[keep] - rt.t[keep][0], rt.north[keep], rt.east[keep], DEFAULT,
        road_fleet(DEFAULT.turn_radius, DEFAULT.sensor_radius, route=mode != "no route"),
        true_north=rt.true_north[keep], true_east=rt.true_east[keep],
        route=given, route_known=mode != "no route",
    )  # fmt: skip


def _deviations() -> None:
    """Drives that leave the route planned for them (``tracks.roads.DEVIATIONS``), each
    from ``COUNT_OFFSETS_S``: with that route, with none (and the count without one), and
    with the drive's own path as its route (what keeping to it would have given)."""
    jobs = [(n, o, m) for n in DEVIATIONS for m in DEVIATION_MODES for o in COUNT_OFFSETS_S]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = list(pool.map(_deviated, jobs))
    print("| drive | " + " | ".join(DEVIATION_MODES) + " |\n|---|---|---|---|")
    means: dict[str, list[float]] = {m: [] for m in DEVIATION_MODES}
    it = iter(runs)
    for name in DEVIATIONS:
        cells = []
        for mode in DEVIATION_MODES:
            row = [next(it) for _ in COUNT_OFFSETS_S]
            means[mode] += [run.coverage for run in row]
            cov = " · ".join(f"{100 * run.coverage:.1f}" for run in row)
            cells.append(f"{cov} % / {max(run.longest_gap_s for run in row):.0f} s")
        print(f"| {name} | " + " | ".join(cells) + " |")
    print("mean " + ", ".join(f"{m} {100 * np.mean(v):.2f} %" for m, v in means.items()))


PATROL_MODES = ("lap as route", "+ holds", "lap as circuit", "circuit + holds")
PATROLS = ((8.0, 0.0), (8.0, 60.0), (11.0, 60.0))  # (speed m/s, stop s each lap)


def _patrolled(job: tuple[float, float, float, str]) -> RoadRun:
    speed, stop_s, offset, mode = job
    dev = patrol(speed, stop_s)
    rt = dev.track
    keep = rt.t >= rt.t[0] + offset
    lap = Road.from_points(dev.route_east, dev.route_north)
    holds = ((lap.project(*_stop_point(dev)), stop_s),) if stop_s and "holds" in mode else ()
    return fly_road(
        rt.t[keep] - rt.t[keep][0], rt.north[keep], rt.east[keep], DEFAULT,
        road_fleet(DEFAULT.turn_radius, DEFAULT.sensor_radius, route=True),
        true_north=rt.true_north[keep], true_east=rt.true_east[keep],
        route=lap, holds=holds, circuit="circuit" in mode,
    )  # fmt: skip


def _stop_point(dev: Deviation) -> tuple[float, float]:
    """(east, north) of the lap's stop: where the first of its stands is."""
    stand = standstills(dev.track.t, dev.track.true_north, dev.track.true_east)[0]
    return stand.east, stand.north


def _patrols() -> None:
    """A patrol circuit driven three laps, given as one lap, as a rover's mission that
    jumps back to its first waypoint gives it: as a plain route, with its hold, known as
    a circuit, and both; each from ``COUNT_OFFSETS_S``, 6 UAVs."""
    jobs = [(v, h, o, m) for v, h in PATROLS for m in PATROL_MODES for o in COUNT_OFFSETS_S]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = list(pool.map(_patrolled, jobs))
    print("| drive | " + " | ".join(PATROL_MODES) + " |\n|---|---|---|---|---|")
    it = iter(runs)
    for speed, stop_s in PATROLS:
        cells = []
        for mode in PATROL_MODES:
            if stop_s == 0.0 and "holds" in mode:
                cells.append("-")
                for _ in COUNT_OFFSETS_S:
                    next(it)
                continue
            row = [next(it) for _ in COUNT_OFFSETS_S]
            cov = " · ".join(f"{100 * run.coverage:.1f}" for run in row)
            cells.append(f"{cov} % / {max(run.longest_gap_s for run in row):.0f} s")
        what = f"{speed:g} m/s" + (f", {stop_s:g}-s stop each lap" if stop_s else "")
        print(f"| {what} | " + " | ".join(cells) + " |")


SPREAD_FACTORS = (0.97, 0.98, 0.99, 1.01, 1.02, 1.03)


def _respread(job: tuple[Path, float]) -> float:
    """Predicted coverage of one kept mock cell replayed with its lags scaled."""
    path, factor = job
    replay = RoadMission.replayed(load_recording(path).with_lag_scaled(factor))
    return float("nan") if replay.predicted_coverage is None else replay.predicted_coverage


def _spread(keep: Path) -> None:
    """How far one flight's coverage could have gone: each mock cell kept in ``keep``
    (``--mock --keep``) replayed with its re-plan lags 1-3 % shorter and longer
    (``MissionRecording.with_lag_scaled``), the predicted coverage of each replay.
    The prediction is within a point of the truth, so this is the spread of the truth
    a second flight of the cell could give, without flying it again."""
    cells = sorted(p for p in keep.glob("*.inputs") if p.with_suffix(".json").exists())
    jobs = [(p, f) for p in cells for f in SPREAD_FACTORS]
    with ProcessPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        predicted = list(pool.map(_respread, jobs))
    print("| cell | truth | predicted as flown | replays 0.97-1.03: min · median · max |")
    print("|---|---|---|---|")
    for k, path in enumerate(cells):
        report = json.loads(path.with_suffix(".json").read_text())
        got = np.array(predicted[k * len(SPREAD_FACTORS) : (k + 1) * len(SPREAD_FACTORS)])
        truth, flown = report.get("truth_coverage_fraction"), report.get("predicted_coverage")
        spread = " · ".join(f"{100 * v:.1f}" for v in (got.min(), np.median(got), got.max()))
        row = [path.stem, _pct(truth), _pct(flown), f"{spread} %"]
        print("| " + " | ".join(row) + " |", flush=True)


def _pct(value: float | None) -> str:
    return "-" if value is None else f"{100 * value:.1f} %"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mock", action="store_true", help="also fly them against sitl_mock")
    parser.add_argument(
        "--unseen", action="store_true", help="the simulation on random roads and other grids"
    )
    parser.add_argument(
        "--variants", action="store_true", help="the simulation on the kinds with other numbers"
    )
    parser.add_argument(
        "--others", action="store_true", help="the simulation on roads of other kinds"
    )
    parser.add_argument(
        "--corners", action="store_true", help="the simulation of single unforeseen corners"
    )
    parser.add_argument(
        "--junctions", action="store_true", help="the simulation of a stop, then a turn"
    )
    parser.add_argument(
        "--gaps", action="store_true", help="where the loss is: unseen seconds by convoy state"
    )
    parser.add_argument(
        "--foresight", action="store_true", help="the simulation given the true future"
    )
    parser.add_argument(
        "--fast-stops", action="store_true", help="the simulation of stops from speed"
    )
    parser.add_argument(
        "--stop-reach",
        action="store_true",
        help="whether a fast convoy's stop leaves a gap the fleet could have closed",
    )
    parser.add_argument(
        "--no-route-count",
        action="store_true",
        help="the simulation without a route, stationary minimum + 1 against + 2 UAVs",
    )
    parser.add_argument(
        "--deviations", action="store_true", help="the simulation of routes the convoy leaves"
    )
    parser.add_argument(
        "--aircraft", action="store_true", help="the simulation of the kinds with other aircraft"
    )
    parser.add_argument(
        "--holds", action="store_true", help="route known, with the convoy's stops as holds"
    )
    parser.add_argument(
        "--patrol", action="store_true", help="a circuit given as one lap: holds and laps"
    )
    parser.add_argument(
        "--keep",
        type=Path,
        metavar="DIR",
        help="with --mock: keep each mock cell's report, tlog and mission recording in DIR",
    )
    parser.add_argument(
        "--spread",
        type=Path,
        metavar="DIR",
        help="replay each mock cell kept in DIR with its lags 1-3 %% off: one flight's spread",
    )
    args = parser.parse_args()
    if args.spread:
        _spread(args.spread)
        return
    if args.deviations:
        _deviations()
        return
    if args.aircraft:
        _aircraft()
        return
    if args.holds:
        _holds()
        return
    if args.patrol:
        _patrols()
        return
    if args.no_route_count:
        _no_route_count()
        return
    if args.fast_stops:
        _fast_stops()
        return
    if args.stop_reach:
        _stop_reach()
        return
    if args.foresight:
        _foresight()
        return
    if args.gaps:
        _gaps()
        return
    if args.corners:
        _corners()
        return
    if args.junctions:
        _junctions()
        return
    if args.unseen or args.variants or args.others:
        head = "| road | route known | no route |"
        if args.mock:
            head += " mock, route known | mock, no route |"
        print(head + "\n|" + "---|" * (head.count("|") - 1))
        means: dict[tuple[bool, bool], list[float]] = {}  # (mock, route known) -> coverages
        roads = _unseen() if args.unseen else _made(OTHERS if args.others else VARIANTS)
        for name, track, req, truth in roads:
            cells = []
            runs = [(False, k) for k in (True, False)] + [(True, k) for k in (True, False)]
            for mock, known in runs[: 4 if args.mock else 2]:
                if mock:
                    cell, coverage = _mock(name, req, known, track, args.keep)
                else:
                    cell, coverage = _simulate(track, req, truth, known)
                means.setdefault((mock, known), []).append(coverage)
                cells.append(cell)
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
        print("| mean | " + " | ".join(f"{100 * np.mean(v):.1f} %" for v in means.values()) + " |")
        return
    head = "| road | UAVs (route / none) | route known: coverage / longest gap / protected from |"
    head += " no route |"
    if args.mock:
        head += " mock, route known: truth (predicted) / gap | mock, no route |"
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for name, track, req, truth in _roads():
        uavs = [road_fleet(req.turn_radius, req.sensor_radius, route=k) for k in (True, False)]
        row = [name, " / ".join(map(str, uavs))]
        row += [_simulate(track, req, truth, k)[0] for k in (True, False)]
        if args.mock:
            row += [_mock(name, req, k, keep=args.keep)[0] for k in (True, False)]
        print("| " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
