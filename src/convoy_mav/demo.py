"""``convoy-mav demo`` and ``replay``: the mock fleet, the service and a ground-truth score.

A scenario names the convoy's motion; the mock is started with the right number
of aircraft (``Scenario.fleet``: the paper's minimum for a parked or straight-line
convoy, the road's count for a road, unless ``uavs`` says otherwise) and the
convoy's ground vehicles, the service connects to them exactly as it would to
PX4/ArduPilot SITL (UDP, MAVLink), flies the mission, and the mission is scored
twice: by the service's own monitor, and from the mock's ground truth.

A replay scenario (:func:`replay_scenario`) drives the ground vehicles along a
recorded track instead, the mock's world origin at the track's first fix. The
service locates the convoy from the ground vehicles' GLOBAL_POSITION_INT, as in
every other scenario; with ``route_known`` it is also given the track's path (not
its timing) as the convoy's route.

The mock's airframes turn tighter than the plan asks (``turn_margin``): a plan
at the hard turn limit leaves the autopilot no authority to correct errors.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
from collections.abc import Callable, Coroutine, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, Literal

from convoy_mav.app import ConvoyService, Progress, ServiceReport
from convoy_mav.config import (
    AircraftConfig,
    ConvoyConfig,
    ConvoyVehicleConfig,
    MissionConfig,
    UavConfig,
)
from convoy_mav.coverage import CoverageStats
from convoy_mav.errors import PlanningError
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.rovermode import drive_of
from convoy_mav.mavlink.signing import load_key
from convoy_mav.mission.choose import road_fleet
from convoy_mav.mission.road import RoadSettings
from convoy_mav.mockproc import MockProcess
from convoy_mav.planning import PlanRequest, make_plan
from convoy_mav.planning.export import compass_to_planner
from convoy_mav.planning.road import Road
from convoy_mav.scoring import TruthFix, score_truth
from convoy_mav.tracks import GeoTrack, track_speeds
from convoy_mav.tracks.geotrack import SPEED_WINDOW_S
from sitl_mock import MockFleet
from sitl_mock.config import config_from_mapping

__all__ = [
    "SCENARIOS",
    "DemoResult",
    "Scenario",
    "rehearsal",
    "rehearsed_config",
    "replay_scenario",
    "run_demo",
    "score_fleet",
]

ScenarioName = Literal["stationary", "moving", "turning", "replay"]


@dataclass(frozen=True, slots=True)
class Scenario:
    """A convoy motion and the aircraft that protect it."""

    name: ScenarioName
    convoy_speed_mps: float = 0.0
    heading_deg: float = 45.0
    turn_after_m: float | None = None  # turning: distance before the turn
    turn_deg: float = 60.0  # turning: course change (positive = to the left)
    sensor_radius_m: float = 100.0
    turn_radius_m: float = 150.0
    airspeed_mps: float = 18.0
    altitude_m: float = 100.0
    turn_margin: float = 0.85  # mock airframe min turn radius / planned radius
    track: GeoTrack | None = None  # replay: the convoy's recorded route, t = 0 at its start
    origin: GeoPoint | None = None  # rehearsal: the mission's (its altitude: the air's density)

    def fleet(self, *, route_known: bool = False) -> int:
        """Aircraft a scenario flies by default: the paper's minimum for a parked or
        straight-line convoy, the road's count (``road_fleet``) for a road, with its
        route known to the service or not."""
        if self.name in ("stationary", "moving"):
            return make_plan(self.plan_request()).min_uavs
        return road_fleet(self.turn_radius_m, self.sensor_radius_m, route=route_known)

    def route(self) -> Road | None:
        """The replayed track's path (not its timing) in the mission frame, if replaying."""
        if self.track is None:
            return None
        origin = GeoPoint(self.track.lats[0], self.track.lons[0])
        return Road.from_geo(zip(self.track.lats, self.track.lons, strict=True), LocalFrame(origin))

    def plan_request(self, uavs: int | None = None) -> PlanRequest:
        """The planner's view (the convoy at its cruise speed)."""
        return PlanRequest(
            self.turn_radius_m,
            self.sensor_radius_m,
            self.airspeed_mps,
            convoy_speed=self.convoy_speed_mps,
            convoy_heading=compass_to_planner(self.heading_deg),
            uavs=uavs,
        )

    def ground_route(self, duration: float) -> dict[str, Any]:
        """The mock's ``[ground]`` table for this scenario."""
        if self.track is not None:
            track = self.track
            rows = zip(track.times, track.lats, track.lons, strict=True)
            return {"route": "track", "track": [list(row) for row in rows]}
        if self.convoy_speed_mps <= 0.0:
            return {"route": "stationary", "start": [0.0, 0.0]}
        if self.turn_after_m is None:
            return {
                "route": "line",
                "start": [0.0, 0.0],
                "speed": self.convoy_speed_mps,
                "heading": self.heading_deg,
            }
        first = math.radians(self.heading_deg)
        second = math.radians(self.heading_deg - self.turn_deg)
        corner = (self.turn_after_m * math.cos(first), self.turn_after_m * math.sin(first))
        far = self.convoy_speed_mps * duration + 1000.0
        end = (corner[0] + far * math.cos(second), corner[1] + far * math.sin(second))
        return {
            "route": "polyline",
            "points": [[0.0, 0.0], list(corner), list(end)],
            "speed": self.convoy_speed_mps,
        }


def rehearsal(scenario: Scenario, mission: MissionConfig) -> Scenario:
    """``scenario`` flown by the aircraft and sensor of a user's own mission config.

    The plan's aircraft (``[aircraft]``, the slowest airspeed and largest turn radius
    of its ``[[uav]]``), its sensor radius and altitude replace the demo's; the mock's
    airframes follow from them (``mock_mapping``). The mission's other keys are
    applied by :func:`rehearsed_config`.
    """
    craft = mission.plan_aircraft
    return replace(
        scenario,
        sensor_radius_m=mission.sensor_radius_m,
        turn_radius_m=craft.turn_radius_m,
        airspeed_mps=craft.airspeed_mps,
        altitude_m=craft.altitude_m,
        origin=mission.origin,
    )


def rehearsed_config(cfg: MissionConfig, mission: MissionConfig) -> MissionConfig:
    """The mock mission ``cfg`` with the ``[mission]`` settings of the user's config."""
    return replace(
        cfg,
        setpoint_rate_hz=mission.setpoint_rate_hz,
        altitude_step_m=mission.altitude_step_m,
        altitude_band_m=mission.altitude_band_m,
        setup_timeout_s=mission.setup_timeout_s,
        lost_after_s=mission.lost_after_s,
        end=mission.end,
    )


SCENARIOS: dict[str, Scenario] = {
    "stationary": Scenario("stationary"),
    "moving": Scenario("moving", convoy_speed_mps=8.0),
    "turning": Scenario("turning", convoy_speed_mps=8.0, turn_after_m=2400.0),
}


def replay_scenario(track: GeoTrack, base: Scenario | None = None) -> Scenario:
    """The demo's aircraft and sensor, with the convoy replaying ``track``.

    A replay is a road: :meth:`Scenario.fleet` flies the road's count. The
    scenario's convoy speed (reported as the track's *planning speed*) is the
    speed the convoy is at least as fast as 90 % of the time over 10-s windows
    (:func:`~convoy_mav.tracks.track_speeds`), what the paper's planner would plan
    for; it must be slower than the aircraft. Faster windows are flown: the
    planners keep their plans through them and the service alarms them
    (``convoy_outruns``, ``convoy_fast``), so a real drive that speeds past the
    aircraft now and then is rehearsed, not refused (the recorded drive, 20.3 m/s
    at most, with 18 m/s planes: 94.4 % on the mock, predicted 94.2 %).

    Args:
        track: The recorded track (rebased here to start at ``t = 0``).
        base: Aircraft, sensor and altitude (default: the demo's).

    Raises:
        PlanningError: The convoy is not slower than the aircraft most of the time.
    """
    track = track.rebased()
    speeds = track_speeds(track)
    scenario = replace(
        base or Scenario("replay"),
        name="replay",
        convoy_speed_mps=speeds.planning_mps,
        heading_deg=speeds.heading_deg,
        turn_after_m=None,
        track=track,
    )
    try:
        scenario.plan_request()
    except PlanningError as e:
        raise PlanningError(
            f"{track.source or 'the track'}: the convoy drives at {speeds.planning_mps:.1f} "
            f"m/s or faster 90 % of the time (over {SPEED_WINDOW_S:g}-s windows), not below "
            f"the UAVs' airspeed of {scenario.airspeed_mps:g} m/s: they cannot keep up"
        ) from e
    return scenario


@dataclass
class DemoResult:
    """The service's report and the ground truth's verdict over the same window."""

    report: ServiceReport
    truth: CoverageStats | None
    scenario: Scenario

    def to_dict(self) -> dict[str, Any]:
        """The ``--report`` JSON: the service's report plus ``truth_*`` keys."""
        out = self.report.to_dict()
        out["scenario"] = self.scenario.name
        track = self.scenario.track
        if track is not None:
            out["track"] = track.source
            out["track_format"] = track.format
            out["track_duration_s"] = track.duration
            out["track_planning_speed_mps"] = self.scenario.convoy_speed_mps
            out["track_fixes_merged"] = track.cleaning.merged
            out["track_fixes_out_of_order"] = track.cleaning.out_of_order
            out["track_spikes_rejected"] = track.cleaning.spikes
            out["track_points_untimed"] = track.cleaning.untimed
            out["track_points_unfixed"] = track.cleaning.unfixed
        out["truth_coverage_fraction"] = self.truth.fraction if self.truth else None
        out["truth_longest_gap_s"] = self.truth.longest_gap_s if self.truth else None
        return out


def mock_mapping(
    scenario: Scenario,
    uavs: int,
    *,
    speedup: float,
    duration: float,
    personality: str = "px4",
    frame: str = "plane",
    ground: int = 2,
    faults: dict[str, Any] | None = None,
    signing_key: str | None = None,
    aircraft: Sequence[Mapping[str, Any]] = (),
    ground_mission: bool = False,
    road: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The sitl_mock configuration (as a mapping) for a scenario.

    ``ground_mission``: the lead ground vehicle serves its road as its mission (a rover
    in AUTO), for the service to read as the convoy's route. ``road``: the mock's
    ``[ground]`` route keys in place of the scenario's (a rover's own polyline, its
    corners braked for, its holds and speeds).

    ``signing_key`` (hex or a passphrase): every aircraft signs with it and accepts
    only frames signed with it. ``aircraft``: per-aircraft overrides, the mock's
    ``[[aircraft.vehicle]]`` tables (e.g. ``{"sysid": 5, "warmup": 40.0}``).

    Copters are set up as for this mission: their top speed (the mock's copter
    ``airspeed``, PX4's MPC_XY_VEL_MAX) at the top of the road planner's speed band,
    which its legs fly at; at the cruise airspeed they fall behind those legs.
    """
    airspeed = scenario.airspeed_mps
    if frame == "copter":
        airspeed *= RoadSettings().speed_band[1]
    mapping: dict[str, Any] = {
        "speedup": speedup,
        "base_port": 0,
        "aircraft": {
            "count": uavs,
            "personality": personality,
            "frame": frame,
            "airspeed": airspeed,
            "turn_radius": scenario.turn_radius_m * scenario.turn_margin,
            "warmup": 3.0,
        },
        "ground": {
            "count": ground,
            "spacing": 20.0,
            **(scenario.ground_route(duration) if road is None else road),
        },
    }
    if ground_mission:
        mapping["ground"]["mission"] = True
    if signing_key is not None:
        mapping["aircraft"]["signing_key"] = signing_key
    if aircraft:
        mapping["aircraft"]["vehicle"] = [dict(v) for v in aircraft]
    origin = scenario.origin
    if scenario.track is not None:  # the world (and mission) origin at the first fix,
        # at the rehearsed mission's elevation (ArduPlane flies wider loiters up high)
        alt = 0.0 if origin is None else origin.alt
        mapping["origin"] = [scenario.track.lats[0], scenario.track.lons[0], alt]
    elif origin is not None:
        mapping["origin"] = [origin.lat, origin.lon, origin.alt]
    if faults:
        mapping["faults"] = faults
    return mapping


def mission_for(
    scenario: Scenario, fleet: Any, *, tlog: str | None = None, signing_key_file: str | None = None
) -> MissionConfig:
    """The service's mission config pointing at a running ``MockFleet``'s endpoints
    (each UAV's link signed with the key in ``signing_key_file``, if given)."""
    craft = AircraftConfig(scenario.airspeed_mps, scenario.turn_radius_m, scenario.altitude_m)
    aircraft = [e for e in fleet.endpoints if e.kind == "aircraft"]
    ground = [e for e in fleet.endpoints if e.kind == "ground"]
    return MissionConfig(
        sensor_radius_m=scenario.sensor_radius_m,
        aircraft=craft,
        uav_list=tuple(
            UavConfig(e.connect, e.sysid, craft, signing_key_file=signing_key_file)
            for e in aircraft
        ),
        convoy=ConvoyConfig(
            source="mavlink",
            vehicles=tuple(ConvoyVehicleConfig(e.connect, e.sysid) for e in ground),
        ),
        origin=fleet.config.origin,
        tlog=tlog,
    )


async def run_demo(
    scenario: Scenario,
    *,
    duration: float,
    speedup: float = 40.0,
    uavs: int | None = None,
    personality: str = "px4",
    frame: str = "plane",
    tlog: str | None = None,
    on_progress: Callable[[Progress], None] | None = None,
    kill: tuple[int, float] | None = None,
    configure: Callable[[MissionConfig], MissionConfig] | None = None,
    stop: asyncio.Event | None = None,
    history: list[ConvoyService] | None = None,
    during: Callable[[MockFleet, ConvoyService], Coroutine[Any, Any, None]] | None = None,
    route_known: bool = False,
    route_mission: bool = False,
    signing_key_file: str | None = None,
    faults: dict[str, Any] | None = None,
    mock_process: bool = False,
    speedup_floor: float | None = None,
    aircraft: Sequence[Mapping[str, Any]] = (),
    road: Mapping[str, Any] | None = None,
) -> DemoResult:
    """Start the mock, fly ``duration`` mission seconds, score from ground truth.

    Args:
        scenario: The convoy's motion and the aircraft.
        duration: Mission seconds to fly (after the service has synced its clock).
        speedup: The mock's sim-time speedup.
        uavs: Aircraft to fly (default: the paper's minimum for the scenario).
        personality: ``"px4"`` or ``"ardupilot"``.
        frame: ``"plane"`` or ``"copter"``.
        tlog: Record every MAVLink message to this file.
        on_progress: Progress callback (about every 10 mission seconds).
        kill: ``(sysid, sim_time)``: the mock kills that aircraft then.
        configure: Adjust the mission config before the service starts.
        stop: Set it to end the run early (SIGINT): the UAVs are told to loiter.
        history: If given, the service is appended to it (for plots after the run).
        during: A fault script run beside the service (pauses, kills, restarts);
            cancelled when the flight ends.
        route_known: Replay: the service is given the track's path (not its
            timing) as the convoy's route.
        route_mission: The lead ground vehicle drives its road as a mission (a rover in
            AUTO), which the service reads over MAVLink as the route (``[convoy] route =
            "mission"``).
        signing_key_file: MAVLink 2 signing: the mock's aircraft and the service's
            links sign with the key in this file (hex or a passphrase).
        faults: The mock's ``[faults]`` table (loss, latency, reboots...), ``kill`` added.
        mock_process: Run the mock in a process of its own (``MockProcess``): the
            service then has the interpreter to itself, as beside a real
            autopilot. ``during`` needs the mock in-process.
        speedup_floor: The service halves the mock's speedup (``SIM_SPEEDUP``) when the
            host falls behind it, down to this (``sim_speedup_floor``); None: never.
        aircraft: Per-aircraft overrides of the mock (``mock_mapping``).
        road: The ground vehicles' route keys in place of the scenario's
            (``mock_mapping``).
    """
    if mock_process and during is not None:
        raise ValueError("a fault script (during) needs the mock in-process")
    count = uavs or scenario.fleet(route_known=route_known)
    faults = dict(faults or {})
    if kill:
        faults["kill"] = [*faults.get("kill", []), f"{kill[0]}@{kill[1]}"]
    mapping = mock_mapping(
        scenario,
        count,
        speedup=speedup,
        duration=duration,
        personality=personality,
        frame=frame,
        faults=faults or None,
        aircraft=aircraft,
        ground_mission=route_mission,
        road=road,
        # (the mock takes the key as 64 hex digits: the very key the service reads)
        signing_key=None
        if signing_key_file is None
        else load_key("--signing-key-file", file=signing_key_file).hex(),
    )
    fleet: MockFleet | MockProcess = (
        MockProcess(mapping)
        if mock_process
        else MockFleet(config_from_mapping(mapping), record_truth=True)
    )
    async with fleet:
        cfg = mission_for(scenario, fleet, tlog=tlog, signing_key_file=signing_key_file)
        if uavs is not None:
            cfg = replace(cfg, uav_count=uavs)
        if route_mission:
            cfg = replace(cfg, convoy=replace(cfg.convoy, route_from_mission=True))
        if configure is not None:
            cfg = configure(cfg)
        if speedup_floor is not None:
            cfg = replace(cfg, sim_speedup_floor=min(speedup_floor, speedup))
        route = scenario.route() if route_known else None
        service = ConvoyService(cfg, rate_hint=speedup, on_progress=on_progress, route=route)
        if history is not None:
            history.append(service)
        script = None
        if during is not None:
            assert isinstance(fleet, MockFleet)
            script = asyncio.create_task(during(fleet, service))
        try:
            report = await service.run(duration=duration, stop=stop)
        finally:
            if script is not None:
                script.cancel()
                with contextlib.suppress(asyncio.CancelledError):
                    await script
    start = report.snapshot.protect_start  # (a process's truth arrives as it stops)
    truth = None if start is None else score_fleet(fleet, cfg, start, report.end_t)
    return DemoResult(report, truth, scenario)


def score_fleet(
    fleet: MockFleet | MockProcess, cfg: MissionConfig, start: float, end: float
) -> CoverageStats:
    """Coverage from the mock's ground truth (killed or grounded aircraft see nothing):
    of the lead's group, as the service's convoy is (a vehicle parted from it is not)."""
    if fleet.history is None:
        raise ValueError("the fleet keeps no truth history (record_truth=False)")
    fixes = (
        TruthFix(
            r.t, r.sysid, r.kind, r.lat, r.lon, r.mode != "KILLED", r.airborne,
            drive_of(r.mode, r.armed) if r.kind == "ground" else None,
        )
        for r in fleet.history.rows
    )  # fmt: skip
    lead = cfg.convoy.vehicles[0].sysid if cfg.convoy.vehicles else None
    return score_truth(
        fixes, cfg.origin, cfg.sensor_radius_m, start=start, end=end,
        lead=lead, part_m=cfg.convoy_part_m,
    )  # fmt: skip
