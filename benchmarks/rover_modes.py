"""A rover's operator at work, in simulation: its mode or speed told the road model, or not.

    .venv/bin/python benchmarks/rover_modes.py            # five testbeds, 14 drives each (~9 min)
    .venv/bin/python benchmarks/rover_modes.py --drives 6

The convoy is a rover driving the urban grid (``tracks.roads``) as its mission, the
grid's corners as waypoints (thinned as the mock's rovers and ``checks/rover_mission.py``
thin them; the road ArduRover SITL drives for ``ROAD=urban ROVER=1``), at 8 m/s with
ArduRover's 1 m/s² (``sitl_mock.drive``), four 30-s holds at random waypoints, and a
DO_CHANGE_SPEED to 8 m/s: its plan, as the service reads it. Its operator then, per
drive (seeded):

- ``holds``: holds it 45-120 s longer at one to three of its planned holds (HOLD 10 s
  into the hold, then AUTO: the hold starts again, as ArduRover restarts the waypoint);
- ``manual``: drives it in MANUAL for two or three stretches of 60-180 s at 0.5-0.7 of
  its mission's speed, along the same road;
- ``stands``: holds it 20-120 s at three random points (HOLD, then AUTO);
- ``speeds``: its mission also changes speed (DO_CHANGE_SPEED to 6 or 8 m/s at three
  random waypoints), and its operator tells it another two or three times
  (DO_CHANGE_SPEED by command, 0.5-1.3 of its plan's speed there, at least 3 m/s), each
  in force until the mission's next (``sitl_mock.roverdrive``);
- ``rtl``: calls it home (RTL) once, 200-450 s in: it drives straight home as the mock's
  rovers do (``sitl_mock.rtl``), stands there 30-90 s, and in AUTO drives straight back
  to the waypoint it was driving to and on along its mission. Told: RTL with its home,
  AUTO with that waypoint (``ConvoyModel.set_drive``); not told: RTL as a mode that
  sets the plan aside, AUTO as any (what the service did before it knew RTL).

Each drive is flown twice by the demo's six planes (``fly_road``, with the fixes' own
velocity as the mock's rovers report it): the mode told (``drives``, 0.5 s after the
change, as a 1-Hz HEARTBEAT tells it on average) and not; for ``speeds``, the speed it
keeps seen (``ConvoyModel.kept``) and not (``kept_window_s`` 0). Printed per testbed:
the mean coverage both ways and the paired difference with its standard error.
"""

from __future__ import annotations

import argparse
import bisect
import math
import os
import statistics
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

import numpy as np

from convoy_mav.mission.road import RoadSettings
from convoy_mav.mission.simulate import RoadRun, fly_road
from convoy_mav.planning.plan import PlanRequest
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import road_kind
from convoy_mav.types import ConvoyDrive
from sitl_mock.driveclock import DriveClock
from sitl_mock.ground import Polyline
from sitl_mock.mission import DEFAULT_TOLERANCE_M, thin
from sitl_mock.roverdrive import RoverDrive
from sitl_mock.rtl import road_home

REQUEST = PlanRequest(150.0, 100.0, 18.0)  # the demo's planes
UAVS = 6  # the road's count with a route
SPEED = 8.0
HORIZON_S = 900.0
STEP_S = 0.1  # the drive's truth, sampled at 1 Hz for the fixes
HEARD_S = 0.5

Drive = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
Told = list[tuple[float, ConvoyDrive, tuple[float, float] | None]]
Testbed = tuple[list[int], Drive, Told, list[tuple[int, float]]]  # (holds, drive, told, speeds)


def _waypoints() -> tuple[tuple[float, float], ...]:
    grid = road_kind("urban")
    xy = list(zip(grid.true_north.tolist(), grid.true_east.tolist(), strict=True))
    return tuple(xy[i] for i in thin(xy, DEFAULT_TOLERANCE_M))


WAYPOINTS = _waypoints()
ROAD = Road.from_points(np.array([e for _, e in WAYPOINTS]), np.array([n for n, _ in WAYPOINTS]))


def _planned(rng: np.random.Generator) -> tuple[Polyline, list[int]]:
    """The mission: four 30-s holds at random waypoints."""
    at = sorted(rng.choice(np.arange(3, len(WAYPOINTS) - 3), 4, replace=False).tolist())
    line = Polyline(WAYPOINTS, speed=SPEED, accel=1.0, holds=tuple((int(i), 30.0) for i in at))
    return line, at


def _sample(line: Polyline, rate_at: Callable[[float, float], float]) -> Drive:
    """The rover's fixes at 1 Hz: its road at drive time, whose rate ``rate_at(t, tau)``
    sets (each call advances it ``STEP_S``)."""
    times = np.arange(0.0, HORIZON_S, STEP_S)
    rows = []
    tau = 0.0
    for t in times.tolist():
        rate = rate_at(t, tau)
        n, e = line.position(tau)
        vn, ve = line.velocity(tau)
        rows.append((n, e, vn * rate, ve * rate))
        tau += rate * STEP_S
    out = np.array(rows)[:: round(1.0 / STEP_S)]
    return times[:: round(1.0 / STEP_S)], out[:, 0], out[:, 1], out[:, 2], out[:, 3]


def _clocked(
    line: Polyline, stands: list[tuple[float, float]], *, drive_time: bool
) -> tuple[Drive, Told]:
    """Driven as the mock's rover is (``DriveClock``), told to stand at each (when, for how
    long): ``when`` in sim time, or in drive time (``drive_time``: where it is along its
    timetable, as at a waypoint's hold); and what it was told, when."""
    clock, pending = DriveClock(1.0), sorted(stands)
    told: Told = []
    resume: list[float] = []

    def rate_at(t: float, tau: float) -> float:
        if pending and clock.driving and (tau if drive_time else t) >= pending[0][0]:
            clock.follow(t, False, line)
            resume.append(t + pending.pop(0)[1])
            told.append((t, ConvoyDrive.HELD, None))
        if resume and t >= resume[0]:
            resume.pop(0)
            clock.follow(t, True, line)  # (a held waypoint's hold starts again)
            told.append((t, ConvoyDrive.MISSION, None))
        return (clock.at(t + STEP_S) - clock.at(t)) / STEP_S

    return _sample(line, rate_at), told


def _holds(seed: int) -> Testbed:
    rng = np.random.default_rng(seed)
    line, at = _planned(rng)
    longer = [i for i in at if rng.random() < 0.6] or at[:1]
    stands = [(line.arrivals[i] + 10.0, float(rng.uniform(45.0, 120.0))) for i in longer]
    drive, told = _clocked(line, stands, drive_time=True)
    return at, drive, told, []


def _stands(seed: int) -> Testbed:
    rng = np.random.default_rng(seed)
    line, at = _planned(rng)
    stands: list[tuple[float, float]] = []
    t = 60.0 + float(rng.uniform(0.0, 120.0))
    while t < HORIZON_S - 150.0:
        seconds = float(rng.uniform(20.0, 120.0))
        stands.append((t, seconds))
        t += seconds + float(rng.uniform(100.0, 250.0))
    drive, told = _clocked(line, stands, drive_time=False)
    return at, drive, told, []


def _manual(seed: int) -> Testbed:
    rng = np.random.default_rng(seed)
    line, at = _planned(rng)
    spells, t = [], 80.0 + float(rng.uniform(0.0, 100.0))
    while t < HORIZON_S - 150.0:
        seconds = float(rng.uniform(60.0, 180.0))
        spells.append((t, t + seconds, float(rng.uniform(0.5, 0.7))))
        t += seconds + float(rng.uniform(100.0, 200.0))
    rate = [1.0]

    def rate_at(t: float, _tau: float) -> float:
        target = next((f for a, b, f in spells if a <= t < b), 1.0)
        rate[0] += float(np.clip(target - rate[0], -0.02, 0.02))  # (about 1 m/s² at 8 m/s)
        return rate[0]

    told: Told = sorted(
        [(a, ConvoyDrive.OTHER, None) for a, _, _ in spells]
        + [(b, ConvoyDrive.MISSION, None) for _, b, _ in spells]
    )
    return at, _sample(line, rate_at), told, []


def _speeds(seed: int) -> Testbed:
    rng = np.random.default_rng(seed)
    line, at = _planned(rng)
    where = sorted(rng.choice(np.arange(4, len(WAYPOINTS) - 4), 3, replace=False).tolist())
    marks = [(int(i), float(rng.choice([6.0, 8.0]))) for i in where]
    line = replace(line, speeds=((0, SPEED), *marks))
    rover = RoverDrive(line)
    commands: list[tuple[float, float]] = []
    t = 60.0 + float(rng.uniform(0.0, 120.0))
    while t < HORIZON_S - 120.0 and len(commands) < 3:
        commands.append((t, float(rng.uniform(0.5, 1.3))))
        t += float(rng.uniform(150.0, 300.0))
    rows = []
    times = np.arange(0.0, HORIZON_S, STEP_S)
    for now in times.tolist():
        if commands and now >= commands[0][0]:
            _, share = commands.pop(0)
            route = rover.route
            assert isinstance(route, Polyline)
            rover.tell(now, max(3.0, share * route.planned_speed(rover.at(now))))
        rover.follow(now, True, reset_speed=True)
        rows.append(rover.state(now))
    out = np.array(rows)[:: round(1.0 / STEP_S)]
    drive = times[:: round(1.0 / STEP_S)], out[:, 0], out[:, 1], out[:, 2], out[:, 3]
    return at, drive, [], marks


def _rtl(seed: int) -> Testbed:
    rng = np.random.default_rng(seed)
    line, at = _planned(rng)
    rover = RoverDrive(line)
    home = WAYPOINTS[0]
    called = float(rng.uniform(200.0, 450.0))
    back: float | None = None
    told: Told = []
    rows = []
    times = np.arange(0.0, HORIZON_S, STEP_S)
    for now in times.tolist():
        if not told and now >= called:  # (RTL: straight home, from the way it drives)
            n, e, vn, ve = rover.state(now)
            driving_to = bisect.bisect_right(line.arrivals, rover.at(now))
            road, arc = road_home((n, e), (vn, ve), home, SPEED, 1.0, line.wp_radius)
            rover.drive_anew(now, road, arc=arc)
            told.append((now, ConvoyDrive.HOME, (home[1], home[0])))
        elif len(told) == 1 and rover.finished(now) and back is None:
            back = now + float(rng.uniform(30.0, 90.0))
        elif back is not None and now >= back and len(told) == 1:  # (AUTO: the item it left)
            n, e, _, _ = rover.state(now)
            rest = WAYPOINTS[driving_to:]
            holds = tuple((i - driving_to + 1, 30.0) for i in at if i >= driving_to)
            rover.drive_anew(now, Polyline(((n, e), *rest), SPEED, accel=1.0, holds=holds))
            goal = WAYPOINTS[driving_to]
            told.append((now, ConvoyDrive.MISSION, (goal[1], goal[0])))
        rover.follow(now, True, reset_speed=False)
        rows.append(rover.state(now))
    out = np.array(rows)[:: round(1.0 / STEP_S)]
    drive = times[:: round(1.0 / STEP_S)], out[:, 0], out[:, 1], out[:, 2], out[:, 3]
    return at, drive, told, []


# Each testbed's drive, and whether what is told is the speed kept (the others: the mode).
TESTBEDS: dict[str, Callable[[int], Testbed]] = {
    "holds": _holds,
    "manual": _manual,
    "stands": _stands,
    "speeds": _speeds,
    "rtl": _rtl,
}
KEPT_TOLD = {"speeds"}
_UNTOLD = {ConvoyDrive.HOME: ConvoyDrive.OTHER}


def _flown(job: tuple[str, int, bool]) -> RoadRun:
    testbed, seed, tell = job
    at, (t, n, e, vn, ve), told, marks = TESTBEDS[testbed](seed)
    holds = [(ROAD.project(WAYPOINTS[i][1], WAYPOINTS[i][0], None), 30.0) for i in at]
    paces = [(0.0, SPEED)] + [
        (ROAD.project(WAYPOINTS[i][1], WAYPOINTS[i][0], None), v) for i, v in marks
    ]
    if tell:
        drives = [(when + HEARD_S, d, where) for when, d, where in told]
    elif testbed == "rtl":  # (before: RTL a mode like MANUAL, AUTO with no waypoint)
        drives = [(when + HEARD_S, _UNTOLD.get(d, d), None) for when, d, _ in told]
    else:
        drives = []
    kept_off = testbed in KEPT_TOLD and not tell
    return fly_road(
        t, n, e, REQUEST, UAVS, reported=(vn, ve), route=ROAD, holds=holds,
        speeds=paces, keeps_speed=True, drives=drives,
        settings=RoadSettings(kept_window_s=0.0) if kept_off else None,
    )  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--drives", type=int, default=14, help="drives per testbed")
    parser.add_argument("--testbed", choices=sorted(TESTBEDS), action="append")
    args = parser.parse_args()
    testbeds = args.testbed or list(TESTBEDS)
    jobs = [(b, s, tell) for b in testbeds for s in range(args.drives) for tell in (True, False)]
    with ProcessPoolExecutor(os.cpu_count()) as pool:
        runs = dict(zip(jobs, pool.map(_flown, jobs), strict=True))
    print(f"urban grid mission, {len(WAYPOINTS)} waypoints, {ROAD.length:.0f} m; {UAVS} planes")
    print(
        "| testbed | drives | told | not told | paired difference | higher / lower "
        "| longest gap, either |"
    )
    print("|---|---|---|---|---|---|---|")
    for b in testbeds:
        told = [100.0 * runs[(b, s, True)].coverage for s in range(args.drives)]
        plain = [100.0 * runs[(b, s, False)].coverage for s in range(args.drives)]
        diff = [a - c for a, c in zip(told, plain, strict=True)]
        se = statistics.stdev(diff) / math.sqrt(len(diff)) if len(diff) > 1 else math.nan
        gaps = [
            runs[(b, s, tell)].longest_gap_s for s in range(args.drives) for tell in (True, False)
        ]
        print(
            f"| {b} | {args.drives} | {statistics.mean(told):.2f} % | "
            f"{statistics.mean(plain):.2f} % | {statistics.mean(diff):+.2f} ± {se:.2f} | "
            f"{sum(d > 0 for d in diff)} / {sum(d < 0 for d in diff)} | "
            f"{max(gaps):.1f} s |"
        )


if __name__ == "__main__":
    main()
