"""The ``convoy-mav`` command line.

Every failure the user can cause ends in one line on stderr and exit status 2
(never a traceback); ``--json`` output is a stable contract (see
``convoy_mav.planning.export``).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import logging
import math
import os
import signal
import sys
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, NoReturn, TypeVar

from convoy_mav import __version__, eventloop
from convoy_mav.app import ConvoyService, Progress
from convoy_mav.config import (
    DEFAULT_ORIGIN,
    AircraftConfig,
    ConvoyConfig,
    MissionConfig,
    load_config,
    validate_connection,
)
from convoy_mav.demo import (
    SCENARIOS,
    Scenario,
    rehearsal,
    rehearsed_config,
    replay_scenario,
    run_demo,
)
from convoy_mav.errors import ConfigError, ConvoyError, PlanningError
from convoy_mav.fence import fence_from
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.codec import GCS_SYSTEM
from convoy_mav.mavlink.signing import load_key
from convoy_mav.mission.road import FAST_CONVOY_RATIO, RoadMission, RoadSettings
from convoy_mav.oplog import operator_log
from convoy_mav.planning import Plan, Pose, make_plan, optimal_path_from_entry
from convoy_mav.planning.export import entry_to_dict, plan_to_dict
from convoy_mav.provision import provision_signing
from convoy_mav.schedule import setpoint_at
from convoy_mav.tracks import FORMATS, load_route, load_track, track_speeds
from convoy_mav.tracks.geotrack import SPEED_WINDOW_S
from convoy_mav.tracks.roads import KINDS as ROAD_KINDS
from convoy_mav.tracks.roads import road_kind

__all__ = ["main"]

EXIT_USAGE = 2
EXIT_OUTPUT = 1  # the flight ran; an output could not be written (the others were)

T = TypeVar("T")


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line instead of usage + error."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n")


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="convoy-mav",
        description="Keep a ground convoy under continuous UAV watch.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    plan = sub.add_parser(
        "plan",
        help="optimal convoy-protection plan (Ding, Rahmani & Egerstedt, T-RO 2010)",
        description=(
            "Print the optimal orbits/arcs, the minimum UAV count and the phasing for a "
            "stationary or straight-moving convoy; or, with --entry, the time-optimal path "
            "inside the convoy circle from one entry state (paper frame, Problem 3.1)."
        ),
    )
    plan.add_argument("--config", metavar="FILE", help="mission TOML (flags override it)")
    plan.add_argument("--turn-radius", type=float, metavar="R", help="UAV min turn radius, m")
    plan.add_argument("--sensor-radius", type=float, metavar="r", help="sensor disk radius, m")
    plan.add_argument("--uav-speed", type=float, metavar="V", help="UAV airspeed, m/s")
    plan.add_argument("--convoy-speed", type=float, metavar="VG", help="convoy speed, m/s")
    plan.add_argument(
        "--convoy-heading", type=float, metavar="DEG", help="convoy course, compass degrees"
    )
    plan.add_argument("--uavs", type=int, metavar="N", help="plan for N UAVs (default: minimum)")
    plan.add_argument(
        "--entry",
        type=float,
        nargs=3,
        metavar=("X", "Y", "HEADING"),
        help="entry state on the convoy circle: metres from the centroid, heading in rad CCW "
        "from +x",
    )
    plan.add_argument("--json", action="store_true", help="print one JSON object")

    run = sub.add_parser(
        "run",
        help="fly a mission against real autopilots (PX4/ArduPilot SITL or hardware)",
        description="Connect to every [[uav]] of the config, set them up, fly the plan and "
        "monitor coverage until SIGINT/SIGTERM (every UAV is then told to loiter).",
    )
    run.add_argument("--config", metavar="FILE", required=True, help="mission TOML")
    run.add_argument("--duration", type=float, metavar="S", help="stop after S mission seconds")
    run.add_argument("--report", metavar="FILE.json", help="write the mission report here")
    run.add_argument("--plot", metavar="FILE.png", help="draw tracks and coverage here")
    run.add_argument("--tlog", metavar="FILE.tlog", help="record every MAVLink message")
    run.add_argument(
        "--record-mission", metavar="FILE", help="record the road planner's inputs, to replay"
    )
    _add_verbosity(run)

    setup = sub.add_parser(
        "sign-setup",
        help="provision an autopilot with a MAVLink 2 signing key (SETUP_SIGNING)",
        description="Send the key to one autopilot (SETUP_SIGNING, in the clear: use a link "
        "nobody else hears; ArduPilot takes it over USB only), then check that it signs. "
        "Give the same key file to its [[uav]] signing_key_file.",
    )
    setup.add_argument("--connection", required=True, metavar="CONN",
                       help="e.g. udpout:127.0.0.1:14550 or tcp:127.0.0.1:5760")  # fmt: skip
    setup.add_argument("--sysid", type=int, default=1, metavar="N", help="its system id")
    setup.add_argument("--source-system", type=int, default=GCS_SYSTEM, metavar="N",
                       help=f"ours (default {GCS_SYSTEM}; [mission] source_system, where the "
                       "autopilot accepts only its MAV_GCS_SYSID)")  # fmt: skip
    setup.add_argument("--signing-key-file", required=True, metavar="FILE",
                       help="64 hex digits, or a passphrase (its SHA-256)")  # fmt: skip

    demo = sub.add_parser(
        "demo",
        help="fly a scenario against the built-in mock autopilots",
        description="Start sitl_mock with the aircraft a scenario needs and the convoy's "
        "ground vehicles, fly the mission, score it from the mock's ground truth.",
    )
    demo.add_argument(
        "--scenario", choices=sorted(SCENARIOS), default="stationary",
        help="stationary: a parked convoy; moving: 8 m/s on a straight road; turning: "
        "the same with one 60 degree turn (default stationary)",
    )  # fmt: skip
    _add_mock_flight_options(demo, 1200.0, "mission (sim) seconds to fly (default 1200)")

    replay = sub.add_parser(
        "replay",
        help="fly the mock with the convoy replaying a recorded track",
        description="Start sitl_mock with the convoy's ground vehicles driving a recorded "
        "track (CSV time,lat,lon; GPX; or the ground vehicles of a .tlog) and the aircraft "
        "it needs (the road's count: the stationary minimum + 1 with --route-known, + 2 "
        "without), fly the mission, "
        "score it from the mock's ground truth.",
    )
    replay.add_argument("track", metavar="TRACK", nargs="?", help="the track: .csv, .gpx or .tlog")
    replay.add_argument(
        "--road", choices=sorted(ROAD_KINDS), metavar="KIND",
        help="instead of TRACK, drive a generated road: " + ", ".join(sorted(ROAD_KINDS)),
    )  # fmt: skip
    replay.add_argument(
        "--route-known",
        action="store_true",
        help="give the service the track's path (not its timing) as the convoy's route; "
        "without it the service sees only the ground vehicles' telemetry",
    )
    replay.add_argument(
        "--route-mission",
        action="store_true",
        help="the lead ground vehicle drives the track's path as its mission (a rover in "
        "AUTO); the service reads that mission over MAVLink as the convoy's route "
        '([convoy] route = "mission")',
    )
    replay.add_argument(
        "--route", metavar="FILE",
        help="give the service this planned route (GPX trk/rte, CSV lat,lon, GeoJSON, KML/KMZ, "
        "a rover mission saved as .plan or .waypoints), "
        "as [convoy] route does for run, while the convoy drives TRACK, which need not keep "
        "to it: a detour, the route driven back, a circuit lapped",
    )  # fmt: skip
    replay.add_argument(
        "--format", choices=FORMATS, help="the track's format (default: from the extension)"
    )
    replay.add_argument(
        "--sysid",
        type=int,
        nargs="+",
        action="extend",
        metavar="N",
        help="tlog: the convoy's system ids, after TRACK (default: every ground rover)",
    )
    _add_mock_flight_options(
        replay, None, "mission (sim) seconds to fly (default: the track's length)"
    )
    return parser


def _add_mock_flight_options(
    parser: argparse.ArgumentParser, duration: float | None, duration_help: str
) -> None:
    """The options ``demo`` and ``replay`` share (flying against the mock in its own process)."""
    parser.add_argument("--duration", type=float, default=duration, metavar="S",
                        help=duration_help)  # fmt: skip
    parser.add_argument(
        "--config", metavar="FILE",
        help="rehearse your own mission: its [mission] (sensor radius, altitude band, "
        "end...) and [aircraft] (airspeed, turn radius, altitude) fly the plan, and the "
        "mock's aircraft are built to match (its [[uav]] and [convoy] are not used)",
    )  # fmt: skip
    parser.add_argument("--speedup", type=float, default=DEMO_SPEEDUP, metavar="X",
                        help="sim seconds per wall second to start at "
                        f"(default {DEMO_SPEEDUP:g}); "
                        "halved while the host falls behind it, down to "
                        f"{DEMO_SPEEDUP_FLOOR:g}")  # fmt: skip
    parser.add_argument("--fixed-speedup", action="store_true",
                        help="keep --speedup however far behind the host falls")  # fmt: skip
    parser.add_argument(
        "--uavs", type=int, metavar="N",
        help=f"aircraft, 1..{MAX_MOCK_UAVS} (default: the paper's minimum for a parked or "
        "straight-line convoy; on a road or track the road's count, the stationary "
        "minimum + 1 with its route known, + 2 without)",
    )  # fmt: skip
    parser.add_argument(
        "--personality", choices=["px4", "ardupilot"], default="px4",
        help="the mock's firmware: PX4 (OFFBOARD) or ArduPilot (GUIDED) (default px4)",
    )  # fmt: skip
    parser.add_argument(
        "--frame", choices=["plane", "copter"], default="plane",
        help="the mock's airframes (default plane)",
    )  # fmt: skip
    parser.add_argument(
        "--signing-key-file", metavar="FILE",
        help="MAVLink 2 signing: the mock's aircraft and the service sign with this key "
        "(64 hex digits, or a passphrase: its SHA-256, as MAVProxy's signing setup)",
    )  # fmt: skip
    parser.add_argument("--report", metavar="FILE.json", help="write the mission report here")
    parser.add_argument("--plot", metavar="FILE.png", help="draw tracks and coverage here")
    parser.add_argument("--tlog", metavar="FILE.tlog", help="record every MAVLink message")
    parser.add_argument(
        "--record-mission", metavar="FILE", help="record the road planner's inputs, to replay"
    )
    _add_verbosity(parser)


MAX_MOCK_UAVS = 200
"""The most aircraft demo/replay fly: the mock runs 200 in real time on a core of its own,
and the ground vehicles take the system ids after the aircraft (255 in all)."""


def _add_verbosity(parser: argparse.ArgumentParser) -> None:
    """-v / -q of the flying commands (default: INFO, what an operator should see)."""
    parser.add_argument(
        "-v", "--verbose", action="count", default=0,
        help="also log debug detail: every STATUSTEXT, every set-up message (default: INFO)",
    )  # fmt: skip
    parser.add_argument(
        "-q", "--quiet", action="store_true",
        help="no progress lines; log warnings and errors only",
    )  # fmt: skip


def _require(value: float | None, flag: str) -> float:
    if value is None:
        raise ConfigError(flag, None, "is required (or give --config)")
    return value


def _check_flag(flag: str, value: float | None, *, positive: bool) -> None:
    if value is None:
        return
    if not math.isfinite(value):
        raise ConfigError(flag, value, "must be a finite number")
    if positive and value <= 0.0:
        raise ConfigError(flag, value, "must be > 0")
    if not positive and value < 0.0:
        raise ConfigError(flag, value, "must be >= 0")


def _mission_from_args(args: argparse.Namespace) -> MissionConfig:
    _check_flag("--turn-radius", args.turn_radius, positive=True)
    _check_flag("--sensor-radius", args.sensor_radius, positive=True)
    _check_flag("--uav-speed", args.uav_speed, positive=True)
    _check_flag("--convoy-speed", args.convoy_speed, positive=False)
    if args.convoy_heading is not None and not math.isfinite(args.convoy_heading):
        raise ConfigError("--convoy-heading", args.convoy_heading, "must be a finite number")
    if args.uavs is not None and not 1 <= args.uavs <= MAX_MOCK_UAVS:
        raise ConfigError("--uavs", args.uavs, f"must be 1..{MAX_MOCK_UAVS}")
    base = load_config(args.config) if args.config else None
    aircraft = base.plan_aircraft if base else None
    convoy = base.convoy if base else ConvoyConfig()
    sensor = _first(args.sensor_radius, base.sensor_radius_m if base else None)
    turn = _first(args.turn_radius, aircraft.turn_radius_m if aircraft else None)
    speed = _first(args.uav_speed, aircraft.airspeed_mps if aircraft else 1.0)
    convoy_speed = _first(args.convoy_speed, convoy.speed_mps)
    if speed is not None and convoy_speed is not None and convoy_speed >= speed:
        raise ConfigError(
            "--convoy-speed",
            convoy_speed,
            f"must be below the UAV speed ({speed:g} m/s): the UAVs cannot keep up",
        )
    return MissionConfig(
        sensor_radius_m=_require(sensor, "--sensor-radius"),
        aircraft=AircraftConfig(
            airspeed_mps=_require(speed, "--uav-speed"),
            turn_radius_m=_require(turn, "--turn-radius"),
        ),
        convoy=replace(
            convoy,
            speed_mps=_require(convoy_speed, "--convoy-speed"),
            heading_deg=_first(args.convoy_heading, convoy.heading_deg) or 0.0,
        ),
        uav_count=_first(args.uavs, base.planned_uavs if base else None),
    )


def _first(*values: T | None) -> T | None:
    """The first value that is not None (a flag given beats the config)."""
    return next((v for v in values if v is not None), None)


def _fmt(x: float | None, unit: str = "", digits: int = 4) -> str:
    if x is None:
        return "-"
    return f"{x:.{digits}g}{unit}"


def _print_plan_table(out: dict[str, Any]) -> None:
    rows: list[tuple[str, str]] = [
        ("case", out["case"]),
        ("turn radius R", _fmt(out["turn_radius_m"], " m")),
        ("sensor radius r", _fmt(out["sensor_radius_m"], " m")),
        ("UAV speed", _fmt(out["uav_speed_mps"], " m/s")),
        (
            "convoy",
            f"{_fmt(out['convoy_speed_mps'], ' m/s')} @ {out['convoy_heading_deg']:.1f} deg",
        ),
        ("minimum UAVs", str(out["min_uavs"])),
        ("planned UAVs", str(out["uavs"])),
        ("coverage per UAV", f"{100 * out['coverage_per_uav']:.2f} %"),
        ("predicted coverage", f"{100 * out['predicted_coverage']:.2f} %"),
    ]
    if out["case"] == "stationary":
        rows += [
            ("entry heading offset", _fmt(out["entry_heading_offset_rad"], " rad")),
            ("orbit period", _fmt(out["orbit_period_s"], " s")),
            ("time inside per lap", _fmt(out["time_inside_s"], " s")),
        ]
    elif out["case"] == "moving":
        gamma = out["gamma_star_rad"]
        rows += [
            ("speed ratio VG/V", _fmt(out["speed_ratio"])),
            ("beta", _fmt(out["beta_rad"], " rad")),
            ("V*_G (one UAV enough)", _fmt(out["v_star"], " x V")),
            ("gamma*", "- (one UAV suffices)" if gamma is None else _fmt(gamma, " rad")),
            ("meet period", _fmt(out["meet_period_s"], " s")),
        ]
    sep = out["min_horizontal_separation_m"]
    rows.append(("min UAV separation", "-" if sep is None else _fmt(sep, " m")))
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")
    print()
    print(f"{'uav':>3}  {'phase s':>9}  {'period s':>9}  segments")
    for v in out["vehicles"]:
        word = "".join(seg["turn"] for seg in v["segments"])
        print(f"{v['index']:>3}  {v['phase_s']:>9.2f}  {v['period_s']:>9.2f}  {word}")


def _print_entry_table(out: dict[str, Any]) -> None:
    def pose(p: list[float] | None) -> str:
        return "-" if p is None else f"({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g} rad)"

    rows = [
        ("sequence", out["sequence"]),
        ("entry", pose(out["entry"])),
        ("switch", pose(out["switch"])),
        ("exit", pose(out["exit"])),
        ("time inside", _fmt(out["time_inside_s"], " s", 6)),
    ]
    width = max(len(k) for k, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


def _cmd_plan(args: argparse.Namespace) -> int:
    mission = _mission_from_args(args)
    if args.entry is not None:
        x, y, heading = args.entry
        if mission.convoy.speed_mps > 0.0:
            raise ConfigError(
                "--convoy-speed", mission.convoy.speed_mps, "--entry is for a stationary convoy"
            )
        for name, value in zip(("X", "Y", "HEADING"), args.entry, strict=True):
            if not math.isfinite(value):
                raise ConfigError(f"--entry {name}", value, "must be a finite number")
        solution = optimal_path_from_entry(
            Pose(x, y, heading),
            mission.aircraft.turn_radius_m,
            mission.sensor_radius_m,
            mission.aircraft.airspeed_mps,
        )
        out = entry_to_dict(solution, mission.aircraft.turn_radius_m, mission.sensor_radius_m)
        if args.json:
            print(json.dumps(out))
        else:
            _print_entry_table(out)
        return 0
    plan = make_plan(mission.plan_request())
    if args.config:
        _check_fence(plan, load_config(args.config), mission)
    out = plan_to_dict(plan)
    if args.json:
        print(json.dumps(out))
    else:
        _print_plan_table(out)
    return 0


def _check_fence(plan: Plan, base: MissionConfig, mission: MissionConfig) -> None:
    """Refuse a plan whose paths leave the config's fence, naming the UAV and the point."""
    frame = LocalFrame(base.origin)
    fence = fence_from(base.safety, frame)
    if fence is None:
        return
    origin = (mission.convoy.start_north_m, mission.convoy.start_east_m)
    down = -base.plan_aircraft.altitude_m
    for k, vehicle in enumerate(plan.vehicles):
        for t in (vehicle.trajectory.period * i / 720.0 for i in range(720)):
            sp = setpoint_at(plan, k, t, plan_origin=origin, plan_t0=0.0, down=down)
            if not fence.allows(sp):
                p = frame.to_geo(sp.north, sp.east, sp.down)
                raise PlanningError(
                    f"UAV {k + 1}'s path leaves the fence at {p.lat:.6f}, {p.lon:.6f}, "
                    f"{-sp.down:.0f} m (t={t:.0f} s): move the fence or the convoy"
                )


def _print_progress(p: Progress) -> None:
    coverage = "-" if p.coverage_fraction is None else f"{100 * p.coverage_fraction:6.2f} %"
    predicted = "-" if p.predicted_coverage is None else f"{100 * p.predicted_coverage:.2f} %"
    others = "".join(f", {n} {state}" for state, n in sorted(p.states.items()) if n)
    alarms = f"  ALARMS {', '.join(p.alarms)}" if p.alarms else ""
    print(
        f"[t={p.t:7.1f} s] {p.phase:<10} {p.counted}/{p.uavs} counting ({p.flying} flying"
        f"{others})  {'seen' if p.covered else 'NOT SEEN'}  coverage {coverage} "
        f"(predicted {predicted})  gaps {p.gaps}  longest {p.longest_gap_s:.1f} s{alarms}",
        flush=True,
    )


def _stop_on_signals(stop: asyncio.Event) -> None:
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        with contextlib.suppress(NotImplementedError, RuntimeError):
            loop.add_signal_handler(sig, stop.set)


def _write_outputs(
    args: argparse.Namespace, report: dict[str, Any], service: ConvoyService | None
) -> int:
    """Report, then plot: each written whatever became of the other. Exit status."""
    status = 0
    if args.report:
        try:
            with open(args.report, "w") as fh:
                json.dump(report, fh, indent=2)
            print(f"report written to {args.report}")
        except OSError as exc:
            print(f"convoy-mav: error: report {args.report}: {exc}", file=sys.stderr)
            status = EXIT_OUTPUT
    if args.plot and service is not None:
        try:
            _plot(args, report, service)
        except Exception as exc:  # (matplotlib raises many kinds: the report is safe)
            print(f"convoy-mav: error: plot {args.plot}: {exc}", file=sys.stderr)
            status = EXIT_OUTPUT
    return status


def _plot(args: argparse.Namespace, report: dict[str, Any], service: ConvoyService) -> None:
    # Imported here: matplotlib takes a third of a second, which every run would
    # otherwise spend before its signal handlers are in place.
    from convoy_mav.plot import plot_mission  # noqa: PLC0415 - lazy on purpose

    route = service.route
    coverage = report["coverage_fraction"]
    track = report.get("track")
    plot_mission(
        service.history,
        args.plot,
        sensor_radius=service.config.sensor_radius_m,
        road=None if route is None else (route.y.tolist(), route.x.tolist()),
        fast_mps=FAST_CONVOY_RATIO * service.config.plan_aircraft.airspeed_mps
        if isinstance(service.mission, RoadMission)
        else None,
        title=f"convoy-mav: {report.get('scenario', 'mission')}"
        + (f" of {os.path.basename(track)}" if track else "")
        + f", {report['uav_count']} UAVs, coverage "
        + ("-" if coverage is None else f"{100 * coverage:.2f} %"),
    )
    print(f"plot written to {args.plot}")


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.2f} %"


def _summary(report: dict[str, Any]) -> None:
    pct = _pct
    if report["protect_start_s"] is None:
        print(
            f"never protected: the protect phase did not begin by t={report['end_s']:.1f} s "
            "(see the events in the report, and each UAV's why_not_counted)"
        )
        return
    print(
        f"protected from t={report['protect_start_s']:.1f} s to {report['end_s']:.1f} s: "
        f"coverage {pct(report['coverage_fraction'])} "
        f"(predicted {pct(report['predicted_coverage'])}"
        + (
            f", ground truth {pct(report['truth_coverage_fraction'])}"
            if "truth_coverage_fraction" in report
            else ""
        )
        + f"), longest gap {report['longest_gap_s']:.1f} s"
    )


async def _cmd_run(args: argparse.Namespace) -> int:
    _check_duration(args.duration)
    _check_outputs(args)
    cfg = load_config(args.config)
    if args.tlog:
        cfg = replace(cfg, tlog=args.tlog)
    if args.record_mission:
        cfg = replace(cfg, mission_recording=args.record_mission)
    if not cfg.uav_list:
        raise ConfigError("uav", [], "the config names no [[uav]] to fly")
    stop = asyncio.Event()
    _stop_on_signals(stop)
    service = ConvoyService(cfg, on_progress=None if args.quiet else _print_progress)
    report = (await service.run(duration=args.duration, stop=stop)).to_dict()
    _summary(report)
    status = _write_outputs(args, report, service)
    if service.refused is not None:
        print(f"convoy-mav: error: {service.refused}", file=sys.stderr)
        return EXIT_USAGE
    return status


MAX_SPEEDUP = 1000.0
"""Fastest the mock runs: past it a step of its kinematics is longer than a setpoint period."""
DEMO_SPEEDUP = 20.0
"""demo, replay: the mock's speedup to start at. Twice it, 40x, leaves a 2-core host
25 wall ms between two setpoints before PX4's 1-s ``COM_OF_LOSS_T``, about what the
host's own scheduling jitter is: some UAV failed safe in seven runs of ten there (``app``,
``_check_speedup``)."""
DEMO_SPEEDUP_FLOOR = 5.0
"""demo, replay: the mock's speedup is not halved below this (``sim_speedup_floor``)."""
MAX_DURATION_S = 7 * 86_400.0
"""Longest flight a command takes: a week of mission time."""


def _check_duration(duration: float | None) -> None:
    if duration is not None and not (math.isfinite(duration) and 0 < duration <= MAX_DURATION_S):
        raise ConfigError("--duration", duration, f"must be > 0 and <= {MAX_DURATION_S:g} s")


_PLOT_FORMATS = frozenset({".png", ".pdf", ".svg", ".jpg", ".jpeg"})


def _check_outputs(args: argparse.Namespace) -> None:
    """Every output path can be written, checked before the flight, not after it."""
    for flag in ("report", "plot", "tlog"):
        path = getattr(args, flag, None)
        if not path:
            continue
        parent = os.path.dirname(os.path.abspath(path))
        if os.path.isdir(path):
            raise ConfigError(f"--{flag}", path, "is a directory")
        if not os.path.isdir(parent):
            raise ConfigError(f"--{flag}", path, f"its folder {parent} does not exist")
        if not os.access(parent, os.W_OK) or (
            os.path.exists(path) and flag != "tlog" and not os.access(path, os.W_OK)
        ):
            raise ConfigError(f"--{flag}", path, "cannot be written (permissions)")
        if flag == "plot" and os.path.splitext(path)[1].lower() not in _PLOT_FORMATS:
            formats = ", ".join(sorted(_PLOT_FORMATS))
            raise ConfigError(f"--{flag}", path, f"must end in one of {formats}")


async def _cmd_sign_setup(args: argparse.Namespace) -> int:
    if not 1 <= args.sysid <= 255:
        raise ConfigError("--sysid", args.sysid, "must be a MAVLink system id in 1..255")
    if not 1 <= args.source_system <= 255 or args.source_system == args.sysid:
        raise ConfigError(
            "--source-system", args.source_system, "must be in 1..255 and not the vehicle's"
        )
    validate_connection(args.connection, "--connection")
    key = load_key("--signing-key-file", file=args.signing_key_file)
    print(await provision_signing(args.connection, args.sysid, key, source=args.source_system))
    return 0


def _check_mock_flight_options(args: argparse.Namespace) -> None:
    _check_duration(args.duration)
    if not (math.isfinite(args.speedup) and 0 < args.speedup <= MAX_SPEEDUP):
        raise ConfigError("--speedup", args.speedup, f"must be > 0 and <= {MAX_SPEEDUP:g}")
    _check_outputs(args)
    if args.uavs is not None and not 1 <= args.uavs <= MAX_MOCK_UAVS:
        raise ConfigError("--uavs", args.uavs, f"must be 1..{MAX_MOCK_UAVS}")


async def _cmd_demo(args: argparse.Namespace) -> int:
    _check_mock_flight_options(args)
    return await _fly_mock(args, _rehearsed(args, SCENARIOS[args.scenario]), args.duration)


def _rehearsed(args: argparse.Namespace, scenario: Scenario) -> Scenario:
    """The scenario with the aircraft of ``--config``, if given."""
    if args.config is None:
        return scenario
    return rehearsal(scenario, load_config(args.config))


async def _cmd_replay(args: argparse.Namespace) -> int:
    _check_mock_flight_options(args)
    for sysid in args.sysid or ():
        if not 1 <= sysid <= 255:
            raise ConfigError("--sysid", sysid, "must be a MAVLink system id in 1..255")
    if (args.track is None) == (args.road is None):
        raise ConfigError("TRACK", args.track, "give a track file or --road KIND (one of them)")
    if args.road is not None:
        track = road_kind(args.road).geotrack(DEFAULT_ORIGIN)
        args.track = f"road:{args.road}"
    else:
        try:
            track = load_track(args.track, args.format, sysids=args.sysid or ())
        except OSError as e:
            raise ConvoyError(f"{args.track}: cannot read the track: {e.strerror or e}") from e
        except ValueError as e:  # the message names the file and the line
            raise ConvoyError(str(e)) from e
    if args.route_known and args.route_mission:
        raise ConfigError("--route-mission", True, "give it or --route-known, not both")
    if args.route is not None:
        if args.route_known or args.route_mission:
            other = "--route-known" if args.route_known else "--route-mission"
            raise ConfigError("--route", args.route, f"give --route FILE or {other}, not both")
        try:
            load_route(args.route)
        except OSError as e:
            raise ConfigError("--route", args.route, f"cannot be read ({e.strerror or e})") from e
        except ValueError as e:
            raise ConfigError("--route", args.route, f"cannot be used as a route ({e})") from e
    scenario = replay_scenario(track, _rehearsed(args, SCENARIOS["stationary"]))
    duration = track.duration if args.duration is None else args.duration
    if duration <= 0.0:
        raise ConfigError(
            "--duration", args.duration, f"{args.track} spans 0 s: give the seconds to fly"
        )
    if not args.quiet:
        uavs = args.uavs or scenario.fleet(route_known=_has_route(args))
        known = ", route known" if args.route_known else ""
        known += ", route from the lead vehicle's mission" if args.route_mission else ""
        known += f", route {args.route}" if args.route is not None else ""
        print(
            f"replaying {args.track}: {len(track.times)} fixes over {track.duration:.1f} s, "
            f"{uavs} UAVs{known}",
            flush=True,
        )
        if track.cleaning.changed:
            print(f"read as recorded: {track.cleaning.summary()}", flush=True)
        top, airspeed = track_speeds(track).max_mps, scenario.airspeed_mps
        if top >= FAST_CONVOY_RATIO * airspeed:
            fastest = RoadSettings().speed_band[1] * airspeed  # (the road planner's band)
            outruns = top >= fastest
            print(
                f"note: the convoy drives at up to {top:.1f} m/s (over {SPEED_WINDOW_S:g}-s "
                f"windows), {top / airspeed:.2f} of the airspeed"
                + (f", faster than the UAVs fly ({fastest:.1f} m/s at most): they fall behind "
                   "it there, and" if outruns else ":")
                + f" a stop from faster than {FAST_CONVOY_RATIO:g} of it can leave it unseen "
                + ("10-20 s (alarms convoy_outruns, convoy_fast)" if outruns else
                   "10-20 s (alarm convoy_fast)"),
                flush=True,
            )  # fmt: skip
    return await _fly_mock(args, scenario, duration)


def _has_route(args: argparse.Namespace) -> bool:
    """``replay`` gives the service a route: the track's path, or a route file."""
    return bool(
        getattr(args, "route_known", False)
        or getattr(args, "route_mission", False)
        or getattr(args, "route", None)
    )


async def _fly_mock(args: argparse.Namespace, scenario: Scenario, duration: float) -> int:
    """Fly ``scenario`` against the mock in a process of its own; summary, report, plot."""
    stop = asyncio.Event()
    _stop_on_signals(stop)
    services: list[ConvoyService] = []
    mission = None if args.config is None else load_config(args.config)

    def configure(cfg: MissionConfig) -> MissionConfig:
        if mission is not None:
            cfg = rehearsed_config(cfg, mission)
        if (route := getattr(args, "route", None)) is not None:
            cfg = replace(cfg, convoy=replace(cfg.convoy, route_file=route))
        return replace(cfg, mission_recording=args.record_mission)

    result = await run_demo(
        scenario,
        duration=duration,
        speedup=args.speedup,
        uavs=args.uavs or (scenario.fleet(route_known=True) if _has_route(args) else None),
        personality=args.personality,
        frame=args.frame,
        tlog=args.tlog,
        on_progress=None if args.quiet else _print_progress,
        stop=stop,
        history=services,
        configure=configure,
        route_known=getattr(args, "route_known", False),
        route_mission=getattr(args, "route_mission", False),
        signing_key_file=args.signing_key_file,
        mock_process=True,
        speedup_floor=None if args.fixed_speedup else DEMO_SPEEDUP_FLOOR,
    )
    report = result.to_dict()
    _summary(report)
    return _write_outputs(args, report, services[0] if services else None)


def _log_level(args: argparse.Namespace) -> int:
    if args.command == "plan":
        return logging.ERROR
    if getattr(args, "quiet", False):
        return logging.WARNING
    return logging.DEBUG if getattr(args, "verbose", 0) else logging.INFO


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``convoy-mav`` console script."""
    args = _build_parser().parse_args(argv)
    with operator_log(_log_level(args)):
        return _dispatch(args)


def _dispatch(args: argparse.Namespace) -> int:
    try:
        if args.command == "plan":
            return _cmd_plan(args)
        if args.command == "run":
            return int(eventloop.run(_cmd_run(args)))
        if args.command == "demo":
            return int(eventloop.run(_cmd_demo(args)))
        if args.command == "replay":
            return int(eventloop.run(_cmd_replay(args)))
        if args.command == "sign-setup":
            return int(eventloop.run(_cmd_sign_setup(args)))
    except ConvoyError as exc:
        print(f"convoy-mav: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    return EXIT_USAGE  # pragma: no cover - argparse enforces a known command


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
