"""Fly a road mission in simulation: the prediction for a road, and the planner's test bench.

Design rules:
- The convoy drives a recorded or generated track; its fixes go through the
  service's own ``ConvoyTracker`` at the track's rate, and the tracker's
  estimate (extrapolated between fixes, stale after a pause) goes into the
  service's own ``RoadMission`` at every step, as the service's control loop
  hands it. The UAVs fly exactly what they are commanded (sampled from their
  trajectories). What is left out is only the autopilots'
  tracking error, so this is what the plan promises on that road.
- Coverage is scored against the convoy's true positions, like the mock's
  ground truth, from the start of protection (or ``score_from``) to the end.
- Pure and deterministic: no clocks, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from convoy_mav.convoy import ConvoyTracker
from convoy_mav.mission.foresight import Foresight
from convoy_mav.mission.recording import MissionRecording
from convoy_mav.mission.road import RoadMission, RoadSettings
from convoy_mav.planning.plan import PlanRequest
from convoy_mav.planning.road import Road, path_lengths
from convoy_mav.tracks.stops import standstills
from convoy_mav.types import ConvoyDrive

__all__ = ["RoadRun", "chord_velocity", "fly_road"]

FloatArray = npt.NDArray[np.float64]
Told = tuple[float, ConvoyDrive, tuple[float, float] | None]
"""(time, drive, where): sent home (RTL) to ``where``, or back to its route there."""


@dataclass(frozen=True, slots=True)
class RoadRun:
    """What a simulated road mission delivered."""

    uavs: int
    protect_start: float | None
    coverage: float  # ground truth from protect_start to the end
    predicted_coverage: float | None  # the mission's own figure
    longest_gap_s: float
    min_turn_radius: float
    speed_range: tuple[float, float]
    uav_replans: int
    legs_late: int
    recording: MissionRecording | None = None  # the mission's inputs, when asked for
    gaps: tuple[tuple[float, float], ...] = ()  # (start, end) of every unseen stretch, s
    # Unseen seconds at which the pattern as laid then had some UAV's place within r of
    # the convoy: the UAVs were off their pattern (late for a meeting), not the pattern
    # leaving a hole (``RoadMission.pattern_positions``).
    unseen_off_pattern_s: float = 0.0


def true_holds(
    route: Road, t: FloatArray, north: FloatArray, east: FloatArray
) -> tuple[tuple[float, float], ...]:
    """The drive's stands (``standstills``) as holds on ``route``: (arc length, seconds)."""
    stands = standstills(t, north, east)
    driven = path_lengths(zip(north, east, strict=True))
    arcs = route.project_along((s.east, s.north, driven[s.index]) for s in stands)
    return tuple(zip(arcs, (s.seconds for s in stands), strict=True))


def true_speeds(
    route: Road,
    north: FloatArray,
    east: FloatArray,
    plan: Sequence[tuple[float, float]],
) -> tuple[tuple[float, float], ...]:
    """A drive's speed plan, (distance driven, m/s from there), on ``route``: (arc length,
    m/s), each placed where the true path has driven that far (``tracks.roads`` plans)."""
    driven = path_lengths(zip(north, east, strict=True))
    at = [min(int(np.searchsorted(driven, d)), len(driven) - 1) for d, _ in plan]
    return route.place(north, east, zip(at, (v for _, v in plan), strict=True))


def fly_road(
    t: npt.ArrayLike,
    north: npt.ArrayLike,
    east: npt.ArrayLike,
    request: PlanRequest,
    uavs: int,
    *,
    true_north: npt.ArrayLike | None = None,
    true_east: npt.ArrayLike | None = None,
    reported: tuple[npt.ArrayLike, npt.ArrayLike] | None = None,
    route_known: bool = False,
    route: Road | None = None,
    settings: RoadSettings | None = None,
    dt: float = 0.5,
    record: bool = False,
    foresight_s: float | None = None,
    replan_lag: tuple[float, float] = (0.0, 0.0),
    holds_known: bool = False,
    holds: Sequence[tuple[float, float]] = (),
    circuit: bool = False,
    speeds: Sequence[tuple[float, float]] = (),
    keeps_speed: bool = False,
    drives: Sequence[tuple[float, ConvoyDrive] | Told] = (),
) -> RoadRun:
    """Fly ``uavs`` UAVs over a convoy whose fixes are (t, north, east).

    Args:
        t, north, east: The convoy's fixes (mission seconds and metres), as recorded.
        request: Aircraft and sensor.
        uavs: Fleet size.
        true_north, true_east: Where the convoy really was at ``t`` (default:
            the fixes): what coverage is scored against.
        reported: The velocity (north, east) each fix reports, as a ground vehicle's
            GLOBAL_POSITION_INT does (``chord_velocity``: the mock's); None, none.
        route_known: Give the mission the track's path (not its timing) as its route.
        route: Give the mission this route instead (one the convoy may not keep to).
        settings: Road mission settings.
        dt: Scoring step, seconds.
        record: Keep the mission's inputs (``RoadRun.recording``), to replay.
        foresight_s: Give the mission's forecast the convoy's true path for this many
            seconds ahead (``Foresight``: 0, the present known exactly; inf, the whole
            future), for the bound on what a better forecast could buy. None: the
            service's own forecast.
        replan_lag: How long a mission step takes to be flown, mission seconds: fixed
            and per UAV re-planned (the mock at 40x on two cores: about 0.15 and 0.4).
            The mission is told (``RoadMission.set_replan_lag``) and, as the service's
            loop, starts no step before the last one is done. Default: at once.
        holds_known: With the route, give the mission where the convoy stands and how
            long (its true stands of 5 s or more, ``standstills``), as a rover's
            mission's hold times give it.
        holds: Or these holds on ``route`` (arc length, seconds), as a mission gives them
            (on a circuit, each lap's at one place).
        circuit: ``route`` is one lap of a circuit the convoy drives round (a mission
            that jumps back to its first waypoint).
        speeds: The speeds the convoy plans on ``route`` (arc length, m/s from there), as
            a mission's DO_CHANGE_SPEEDs give them.
        keeps_speed: The convoy keeps a speed of its own where none is planned, as a
            rover in AUTO drives its default (``ConvoyModel.cruise``).
        drives: What drives the lead vehicle from each time on (time, drive), as its
            mode says (``RoadMission.set_drive``), told the mission at the first step
            at or after it: an operator's HOLD, AUTO again; (time, drive, where) with
            where it goes (``Told``: RTL's home, the waypoint AUTO drives back to).
    """
    ts = np.asarray(t, dtype=np.float64)
    fn, fe = np.asarray(north, dtype=np.float64), np.asarray(east, dtype=np.float64)
    tn = fn if true_north is None else np.asarray(true_north, dtype=np.float64)
    te = fe if true_east is None else np.asarray(true_east, dtype=np.float64)
    if route is None and route_known:
        route = Road.from_points(te, tn)
    ids = list(range(1, uavs + 1))
    mission = RoadMission(
        request, ids, down=lambda _u: -100.0, route=route, settings=settings, record=record
    )
    if foresight_s is not None:
        mission.model = Foresight(mission.model, ts, te, tn, foresight_s)
    mission.set_replan_lag(*replan_lag)
    if holds_known and route is not None and not holds:
        holds = true_holds(route, ts, tn, te)
    if route is not None and (holds or circuit or speeds or keeps_speed):
        mission.set_route(route, holds, circuit, speeds, keeps_speed)
    tracker = ConvoyTracker(window=4.0)
    vn, ve = (None, None) if reported is None else (np.asarray(v, np.float64) for v in reported)
    # The UAVs start circling near the convoy's first fix, spread around it.
    R = request.turn_radius
    joined = False
    end = float(ts[-1])
    samples: list[tuple[float, bool]] = []
    off_pattern: list[float] = []  # (unseen samples the pattern covered)
    k = 0
    busy_until = -math.inf  # (the step in progress, with a lag)
    step_times = np.arange(float(ts[0]), end, dt)
    told = sorted(drives, key=lambda d: d[0])
    for now in step_times.tolist():
        while told and told[0][0] <= now:
            _, drive, *where = told.pop(0)
            mission.set_drive(drive, now, *where)
        while k < len(ts) and ts[k] <= now:
            velocity = None if vn is None or ve is None else (float(vn[k]), float(ve[k]))
            tracker.update(float(ts[k]), float(fn[k]), float(fe[k]), velocity=velocity)
            k += 1
        if now < busy_until:
            _score(samples, off_pattern, mission, ids, now, ts, tn, te, request.sensor_radius)
            continue
        plans = mission.uav_plans
        est = tracker.estimate(now)
        if est is not None:  # every step, as the service's control loop does
            mission.on_convoy(est)
        if not joined and mission.plan is not None:
            poses = {
                u: (
                    float(fn[0]) + 2.0 * R * math.cos(2.0 * math.pi * i / uavs),
                    float(fe[0]) + 2.0 * R * math.sin(2.0 * math.pi * i / uavs),
                    2.0 * math.pi * i / uavs,
                )
                for i, u in enumerate(ids)
            }
            mission.join_many(poses, now)
            joined = True
        mission.tick(now)
        busy_until = now + replan_lag[0] + replan_lag[1] * (mission.uav_plans - plans)
        _score(samples, off_pattern, mission, ids, now, ts, tn, te, request.sensor_radius)
    covered = np.array([s for _, s in samples], dtype=bool)
    gaps: list[tuple[float, float]] = []
    for when, ok in samples:
        if ok:
            continue
        if gaps and math.isclose(gaps[-1][1], when, abs_tol=1e-6):
            gaps[-1] = (gaps[-1][0], when + dt)
        else:
            gaps.append((when, when + dt))
    best = max((b - a for a, b in gaps), default=0.0)
    return RoadRun(
        uavs,
        mission.protect_start,
        float(covered.mean()) if len(covered) else 0.0,
        mission.predicted_coverage,
        best,
        mission.min_turn_radius,
        mission.speed_range,
        mission.uav_replans,
        mission.legs_late,
        mission.recording,
        tuple(gaps),
        dt * len(off_pattern),
    )


def chord_velocity(
    t: npt.ArrayLike, north: npt.ArrayLike, east: npt.ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """The velocity the mock's ground vehicles report at each fix of a track they drive:
    its chord to the next fix (they follow the track's straight segments), zero at the
    end."""
    ts = np.asarray(t, dtype=np.float64)
    dt = np.maximum(np.diff(ts), 1e-9)
    vn = np.append(np.diff(np.asarray(north, dtype=np.float64)) / dt, 0.0)
    ve = np.append(np.diff(np.asarray(east, dtype=np.float64)) / dt, 0.0)
    return vn, ve


def _score(
    samples: list[tuple[float, bool]],
    off_pattern: list[float],
    mission: RoadMission,
    ids: Sequence[int],
    now: float,
    ts: FloatArray,
    tn: FloatArray,
    te: FloatArray,
    r: float,
) -> None:
    """Whether some UAV's setpoint sees the true convoy at ``now`` (in the protect phase);
    if none does, ``now`` goes in ``off_pattern`` when the pattern as laid would have."""
    start = mission.protect_start
    if start is None or now < start:
        return
    cn = float(np.interp(now, ts, tn))
    ce = float(np.interp(now, ts, te))
    seen = False
    for u in ids:
        sp = mission.setpoint(u, now)
        if sp is not None and math.hypot(sp.north - cn, sp.east - ce) <= r:
            seen = True
            break
    samples.append((now, seen))
    if not seen and any(
        math.hypot(pn - cn, pe - ce) <= r for pn, pe in mission.pattern_positions(now).values()
    ):
        off_pattern.append(now)
