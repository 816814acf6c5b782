"""Road planner speed: a one-hour route, one UAV's re-plan, one convoy fix.

Run with ``make bench`` (or ``pytest benchmarks/bench_road.py --benchmark-only``).

Where each runs in the service:
- a convoy fix (``ConvoyTracker.update``) runs on the flight loop, per ground
  vehicle message;
- the road estimate (``RoadMission.on_convoy``: the route projection, the
  pattern clock) and every re-plan run in the mission worker thread, once per
  control step (10 Hz), off the flight loop: setpoints are streamed from the
  last frozen view meanwhile, so planning never holds them (the report's
  ``setpoint_gap_max_s`` per UAV shows it).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.convoy import ConvoyTracker
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mission.convoy_model import ConvoyModel
from convoy_mav.mission.road import RoadMission
from convoy_mav.mission.simulate import fly_road
from convoy_mav.planning import PlanRequest
from convoy_mav.planning.dubins import Pose, Segment, Turn
from convoy_mav.planning.plan import Trajectory
from convoy_mav.planning.road import Road
from convoy_mav.tracks import load_track
from convoy_mav.types import ConvoyDrive, ConvoyEstimate

TRACKS = Path(__file__).resolve().parents[2] / "shared" / "tracks"
FAST = PlanRequest(200.0, 120.0, 28.0)  # configs/rehearse_fast_planes.toml


def _drive() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    track = load_track(TRACKS / "istanbul_drive.gpx")
    norths, easts = track.in_frame(LocalFrame(GeoPoint(track.lats[0], track.lons[0])))
    return np.array(track.times), np.array(norths), np.array(easts)


def test_fly_a_one_hour_route(benchmark: BenchmarkFixture) -> None:
    """The whole recorded drive (62 min, 2,685 fixes), 6 UAVs, route known: every
    re-plan of every UAV and every setpoint, as the service would make them."""
    t, north, east = _drive()
    run = benchmark.pedantic(  # type: ignore[no-untyped-call]
        fly_road, args=(t, north, east, FAST, 6), kwargs={"route_known": True}, rounds=3
    )
    assert run.protect_start is not None


def test_replan_one_uav(benchmark: BenchmarkFixture) -> None:
    """One UAV's legs re-planned (what a control step does for a few UAVs at a time)."""
    t, north, east = _drive()
    mission = RoadMission(FAST, [1, 2, 3, 4, 5, 6], down=lambda _u: -100.0)
    tracker = ConvoyTracker(window=4.0)
    for k in range(40):
        tracker.update(float(t[k]), float(north[k]), float(east[k]))
        est = tracker.estimate(float(t[k]))
        assert est is not None
        mission.on_convoy(est)
    now = float(t[39])
    mission.join_many({u: (north[0] + 50.0 * u, east[0], 0.0) for u in range(1, 7)}, now)
    benchmark(mission._plan_paths, now, [1])


def test_replan_one_uav_filling_a_hole(benchmark: BenchmarkFixture) -> None:
    """One protecting UAV's re-plan when the fleet leaves the convoy unseen: its legs,
    the path in force to keep or not, the leg to the convoy and the detour that keeps
    it in sight (``_fill``), all tried. The other five UAVs' paths are moved far off
    so that every re-plan does."""
    request = PlanRequest(150.0, 100.0, 18.0)
    mission = RoadMission(request, [1, 2, 3, 4, 5, 6], down=lambda _u: -100.0)
    tracker = ConvoyTracker(window=4.0)
    for k in range(2001):
        now = 0.1 * k
        if k % 10 == 0:
            tracker.update(now, 8.0 * now, 0.0)
        est = tracker.estimate(now)
        if est is not None:
            mission.on_convoy(est)
        if mission.plan is not None and not mission._slots:
            mission.join_many(
                {u: (300.0 * math.cos(u), 300.0 * math.sin(u), 0.0) for u in range(1, 7)}, now
            )
    assert mission.protect_start is not None
    far = Trajectory(
        now, (Segment(Pose(1e5, 1e5, 0.0), Turn.LEFT, 150.0, 18.0, 2 * math.pi * 150.0 / 18.0),)
    )
    planned = dict(mission._trajectories)

    def replan(uav: int) -> bool:
        fills = mission.fills
        mission._trajectories.update({u: far for u in planned if u != uav})
        mission._trajectories[uav] = planned[uav]
        mission._plan_paths(now, [uav])
        return mission.fills > fills

    # A UAV the detour helps (one whose own legs see the convoy soon needs none).
    uav = next(u for u in planned if replan(u))
    assert benchmark(replan, uav)


def test_convoy_fix_on_the_flight_loop(benchmark: BenchmarkFixture) -> None:
    """One ground vehicle fix folded into the convoy estimate (flight loop, per message)."""
    tracker = ConvoyTracker(window=4.0)
    state = {"t": 0.0}

    def fix() -> None:
        state["t"] += 0.1
        tracker.update(state["t"], 8.0 * state["t"], 0.0, 5)

    benchmark(fix)


@pytest.mark.parametrize("part_m", [0.0, 200.0])
def test_convoy_fix_of_a_convoy_of_four(benchmark: BenchmarkFixture, part_m: float) -> None:
    """One fix of four vehicles 20 m apart, each at 1 Hz with the velocity it reports:
    with ``part_m``, the lead's group found again (``parting.convoy_group``) and the
    vehicles standing while the lead drives on judged (``parting.StandWatch``) at each;
    0, none ever parts."""
    tracker = ConvoyTracker(window=4.0, part_m=part_m, lead=5)
    clock = {"t": 0.0}
    turn = itertools.cycle(range(4))

    def fix() -> None:
        clock["t"] += 0.25
        k = next(turn)
        tracker.update(clock["t"], 8.0 * clock["t"] - 20.0 * k, 0.0, 5 + k, (8.0, 0.0))

    benchmark(fix)
    assert tracker.sources == {5, 6, 7, 8}


def test_convoy_fix_with_its_velocity_on_the_flight_loop(benchmark: BenchmarkFixture) -> None:
    """The same, the vehicle reporting its velocity (GLOBAL_POSITION_INT vx/vy, 10 Hz):
    the reports' steadiness over 10 s and their agreement with the fixes, judged."""
    tracker = ConvoyTracker(window=4.0)
    state = {"t": 0.0}

    def fix() -> None:
        state["t"] += 0.1
        tracker.update(state["t"], 8.0 * state["t"], 0.0, 5, (8.0, 0.0))

    benchmark(fix)
    assert tracker.counters["velocity_reported"] > 0


def test_road_estimate_update(benchmark: BenchmarkFixture) -> None:
    """The road mission folding in one convoy estimate on a known 25-km route
    (projection near the last arc length, the pattern clock): worker thread, 10 Hz."""
    t, north, east = _drive()
    route = Road.from_points(east, north)
    mission = RoadMission(FAST, [1, 2, 3, 4, 5, 6], down=lambda _u: -100.0, route=route)
    state = {"k": 0}

    def update() -> None:
        k = state["k"] = (state["k"] + 1) % (len(t) - 1)
        est = ConvoyEstimate(
            float(t[k]) + 1e4 * (k == 0), float(north[k]), float(east[k]), 5.0, 5.0
        )
        mission.model.observe(est)

    benchmark(update)


def test_road_estimate_update_of_a_rover_on_its_mission(benchmark: BenchmarkFixture) -> None:
    """The same for a rover driving the route as its mission (``keeps_speed``), steady
    at its own 5 m/s where the plan says 8: whether it keeps a speed of its own
    (``ConvoyModel.kept``: the last 6 s of its speed and the route's curvature ahead)."""
    _, north, east = _drive()
    route = Road.from_points(east, north)
    mission = RoadMission(FAST, [1, 2, 3, 4, 5, 6], down=lambda _u: -100.0, route=route)
    mission.model.set_route(route, speeds=[(0.0, 8.0)], keeps_speed=True)
    state = {"k": 0}

    def update() -> None:
        k = state["k"] = state["k"] + 1
        q = route.point((0.5 * k) % route.length)  # (5 m/s, an estimate every 0.1 s)
        vx, vy = 5.0 * math.cos(q.heading), 5.0 * math.sin(q.heading)
        mission.model.observe(ConvoyEstimate(0.1 * k, q.y, q.x, vy, vx))

    benchmark(update)


def _forecaster(
    holds: bool, speeds: bool = False, keeps_speed: bool = False
) -> tuple[ConvoyModel, np.ndarray]:
    """A convoy driving a known 25-km route at 8 m/s, with a hold every 500 m ahead or
    none (and a planned speed of 6 or 10 m/s from each 250 m between, or its own kept),
    and a re-plan's forecast grid (0.5 s over 200 s)."""
    _, north, east = _drive()
    route = Road.from_points(east, north)
    model = ConvoyModel()
    stops = [(float(s), 30.0) for s in np.arange(1000.0, route.length, 500.0)]
    paces = [
        (float(s), 6.0 + 4.0 * (k % 2)) for k, s in enumerate(np.arange(750.0, route.length, 500.0))
    ]
    model.set_route(
        route, stops if holds else (), speeds=paces if speeds else (), keeps_speed=keeps_speed
    )
    seconds = 40 if keeps_speed else 10  # (its own speed: learnt from 30 s of driving)
    for k in range(seconds):  # (driving up the route, an estimate a second)
        q = route.point(720.0 + 8.0 * (k - seconds + 10))
        vx, vy = 8.0 * math.cos(q.heading), 8.0 * math.sin(q.heading)
        model.observe(ConvoyEstimate(float(k - seconds + 10), q.y, q.x, vy, vx))
    return model, 9.0 + np.arange(0.0, 200.0, 0.5)


def test_forecast_along_the_route(benchmark: BenchmarkFixture) -> None:
    """The convoy's forecast for one re-plan (``ConvoyModel.positions``): worker thread,
    once per mission step; without holds, for the ratio to the next."""
    model, grid = _forecaster(holds=False)
    benchmark(model.positions, grid)


def test_forecast_along_the_route_with_holds(benchmark: BenchmarkFixture) -> None:
    """The same with the rover mission's holds: the timetable of braking, standing and
    pulling away (``ConvoyModel._arcs``)."""
    model, grid = _forecaster(holds=True)
    x, y = model.positions(grid)
    assert np.count_nonzero(np.hypot(np.diff(x), np.diff(y)) < 1e-9) >= 100  # (holds: 30 s)
    benchmark(model.positions, grid)


def test_forecast_along_the_route_with_holds_and_speeds(benchmark: BenchmarkFixture) -> None:
    """The same with the mission's speeds too (DO_CHANGE_SPEED): a speed change between
    each two holds."""
    model, grid = _forecaster(holds=True, speeds=True)
    benchmark(model.positions, grid)


def test_forecast_along_the_route_slowing_for_its_corners(benchmark: BenchmarkFixture) -> None:
    """The same with the convoy seen to take its corners at 2.5 m/s (``CornerHabit``):
    the timetable's clock slowed where it is over the corner cap (``corners.warp``)."""
    model, grid = _forecaster(holds=True, speeds=True)
    model.corner_habit.samples.extend([2.5, 2.5])
    assert model.corner_speed == 2.5
    benchmark(model.positions, grid)


def test_forecast_along_the_route_at_its_own_speed(benchmark: BenchmarkFixture) -> None:
    """The same with no speed planned, a rover keeping its own (``ConvoyModel.cruise``,
    learnt from the drive: a percentile of the last 120 s, once an estimate)."""
    model, grid = _forecaster(holds=True, keeps_speed=True)
    model.corner_habit.samples.extend([2.5, 2.5])
    assert model.cruise == 8.0 and model.corner_speed == 2.5
    benchmark(model.positions, grid)


def _driven_home() -> tuple[ConvoyModel, np.ndarray]:
    """A convoy seen driving the recorded drive's 25 km with no route (an estimate a
    second, the path kept as its SmartRTL keeps its own) and its corners at 2.5 m/s;
    a re-plan's forecast grid."""
    t, north, east = _drive()
    model = ConvoyModel()
    model.corner_habit.samples.extend([2.5, 2.5])
    step = max(1, len(t) // 3000)
    for k in range(step, len(t), step):
        dt = float(t[k] - t[k - step]) or 1.0
        vn, ve = (north[k] - north[k - step]) / dt, (east[k] - east[k - step]) / dt
        model.observe(ConvoyEstimate(float(t[k]), float(north[k]), float(east[k]), vn, ve))
    return model, float(t[-1]) + np.arange(0.0, 200.0, 0.5)


def test_way_back_along_the_path_it_drove(benchmark: BenchmarkFixture) -> None:
    """SMART_RTL heard: the path it was seen to drive simplified, its loops cut and made
    the road back (``ConvoyModel._way_back``): worker thread, once per mode change."""
    model, _ = _driven_home()
    way = benchmark(model._way_back)
    assert way is not None and way.length > 1000.0


def test_forecast_back_along_the_path_it_drove(benchmark: BenchmarkFixture) -> None:
    """The forecast for one re-plan of a convoy on its way back along that path
    (SMART_RTL), slowing for its corners: worker thread, once per mission step."""
    model, grid = _driven_home()
    model.set_drive(ConvoyDrive.RETRACE)
    assert model._retrace is not None
    benchmark(model.positions, grid)
