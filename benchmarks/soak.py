"""The fault soak (a benchmark, not a test): an hour of mission through every fault at once.

    .venv/bin/python benchmarks/soak.py [--duration 3600] [--speedup 40] [--json out/soak.json]
        [--report out/soak-report.json] [--personality ardupilot] [--road KIND [--route-known]]
        [--link-only] [--seed 3] [--frame copter]

Against ``sitl_mock`` (PX4 planes, the moving convoy; or ArduPilot's, or copters, or the
road planner's fleet on a generated road) and a real mosquitto: 30 % packet
loss both ways, 200 ms latency with up to 100 ms of jitter (reordering) and 5 % of
datagrams repeated on every link, one autopilot rebooted, the broker
killed and restarted twice, and floods of 100 000 random and 100 000 valid-but-foreign
MAVLink datagrams at the service's ports and 10 000 absurd MQTT inputs. Prints, and
writes with ``--json``: coverage (the mock's truth, the service's monitor and its
prediction), UAVs lost and back, alarms by kind, what was dropped and counted, and the
process's resident memory after set-up and at the end (it must stay flat).
``--link-only`` keeps the link's faults alone (no reboot, flood, broker or MQTT fault):
how the fleet flies such a link; ``--seed`` draws its losses anew.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import socket
import sys
import tempfile
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import aiomqtt
from pymavlink.dialects.v20 import common as mavlink

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # (tests.broker)

from convoy_mav.app import ConvoyService
from convoy_mav.config import DEFAULT_ORIGIN, MissionConfig, MqttConfig
from convoy_mav.demo import SCENARIOS, replay_scenario, run_demo
from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.tracks.roads import KINDS as ROAD_KINDS
from convoy_mav.tracks.roads import road_kind
from sitl_mock import MockFleet
from tests.broker import Broker, find_mosquitto

PREFIX = "soak"
_ABSURD = (
    '{"north": 1e308, "east": 0}',
    '{"north": 0, "east": 0, "t": 1e12}',
    "garbage",
    '{"command": "self-destruct"}',
)


def _rss_mib() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / (1 << 20)


def _flood(ports: list[int], random_n: int, foreign_n: int) -> None:
    """Random bytes, then well-formed frames from a stranger, at every port."""
    rng = random.Random(7)
    stranger = MavCodec(77, 1)
    frame = stranger.pack(
        mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
        )
    )
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for k in range(random_n):
            s.sendto(rng.randbytes(rng.randint(1, 280)), ("127.0.0.1", ports[k % len(ports)]))
        for k in range(foreign_n):
            s.sendto(frame, ("127.0.0.1", ports[k % len(ports)]))


async def soak(
    duration: float | None,
    speedup: float,
    report_file: str | None = None,
    *,
    personality: str = "px4",
    road: str | None = None,
    route_known: bool = False,
    link_only: bool = False,
    seed: int = 3,
    frame: str = "plane",
) -> dict[str, Any]:
    scenario, whole = SCENARIOS["moving"], 3600.0
    if road is not None:  # (a generated road, driven to its end)
        track = road_kind(road).geotrack(DEFAULT_ORIGIN)
        scenario, whole = replay_scenario(track, SCENARIOS["stationary"]), track.duration
    length = whole if duration is None else duration
    executable = find_mosquitto()
    if executable is None:
        raise SystemExit("needs mosquitto: make broker")
    workdir = Path(tempfile.mkdtemp(prefix="convoy-soak-"))
    broker = Broker(executable, workdir)
    broker.start()
    faults_done: list[str] = []
    fleets: list[MockFleet] = []
    memory: dict[str, float] = {}

    def configure(cfg: MissionConfig) -> MissionConfig:
        return replace(cfg, mqtt=MqttConfig(broker.host, broker.port, PREFIX))

    async def script(fleet: MockFleet, service: ConvoyService) -> None:
        while service.monitor.protect_start is None:
            await asyncio.sleep(0.05)
        memory["after_setup_mib"] = _rss_mib()
        fleets.append(fleet)
        plan = [(0.25, "flood"), (0.4, "broker"), (0.5, "rss"), (0.7, "broker"), (0.8, "mqtt")]
        if link_only:
            plan = [(0.5, "rss")]
        start = fleet.now
        for at, fault in plan:
            while fleet.now < start + at * (length - start):
                await asyncio.sleep(0.05)
            if fault == "rss":
                memory["half_mib"] = _rss_mib()
                truth = fleet.history
                if truth is not None:
                    memory["half_truth_store_mib"] = truth.nbytes / 2**20
                continue
            if fault == "flood":
                ports = [
                    a[1]
                    for v in service.vehicles.values()
                    if (a := v.link.local_address)  # type: ignore[attr-defined]
                ]
                # (from a process of its own, as an attacker's host: flooded from a
                # thread here, its 200 000 sends took the interpreter from the service
                # and the in-process mock, and late setpoint rounds failed PX4s safe)
                flooder = await asyncio.create_subprocess_exec(
                    sys.executable, __file__, "--flood", *map(str, ports)
                )
                await flooder.wait()
                faults_done.append(f"t={fleet.now:.0f}: 100k random + 100k foreign datagrams")
            elif fault == "broker":
                await asyncio.to_thread(broker.kill)
                await asyncio.sleep(1.0)
                await asyncio.to_thread(broker.restart)
                faults_done.append(f"t={fleet.now:.0f}: broker killed, restarted 1 s later")
            else:
                async with aiomqtt.Client(broker.host, broker.port) as c:
                    for k in range(10_000):
                        payload = _ABSURD[k % 4]
                        topic = "command" if k % 4 == 3 else "convoy/position"
                        await c.publish(f"{PREFIX}/{topic}", payload)
                faults_done.append(f"t={fleet.now:.0f}: 10k absurd MQTT inputs")

    faults: dict[str, Any] = {
        "loss_to_vehicle": 0.3, "loss_from_vehicle": 0.3, "latency": 0.2, "jitter": 0.1,
        "duplicate": 0.05, "seed": seed,
    }  # fmt: skip
    reboot = [] if link_only else [f"UAV 1 rebooted at t={0.55 * length:.0f}"]
    if not link_only:
        faults["reboot"] = [f"1@{0.55 * length:.0f}"]
    try:
        result = await run_demo(
            scenario, duration=length, speedup=speedup, configure=configure,
            during=script, faults=faults, personality=personality, frame=frame,
            route_known=route_known,
            uavs=None if road is None else scenario.fleet(route_known=route_known),
        )  # fmt: skip
    finally:
        broker.stop()
    memory["end_mib"] = _rss_mib()
    if fleets and fleets[0].history is not None:
        memory["end_truth_store_mib"] = fleets[0].history.nbytes / 2**20
    report = result.report.to_dict()
    if report_file:
        Path(report_file).write_text(json.dumps(report, indent=1))
    truth = result.truth
    events = report["events"]
    return {
        "duration_s": length,
        "speedup": speedup,
        "personality": personality,
        "frame": frame,
        "road": road or "the moving convoy (straight)",
        "route_known": route_known,
        "uavs": len(report["vehicles"]),
        "faults": [
            "30 % loss each way, 200 ms latency plus up to 100 ms of jitter (reordering), "
            f"5 % of datagrams repeated, every link (seed {seed})",
            *reboot,
            *faults_done,
        ],
        "coverage_truth": None if truth is None else round(truth.fraction, 4),
        "coverage_monitor": report["coverage_fraction"],
        "predicted": report["predicted_coverage"],
        "longest_gap_truth_s": None if truth is None else round(truth.longest_gap_s, 1),
        "uavs_lost": sum("declared lost" in e or " lost" in e for e in events),
        "alarms": dict(Counter(a["kind"] for a in report["alarms"] if a["active"])),
        "rejected": report["rejected"],
        "vehicles_rejected": {v["sysid"]: v["rejected"] for v in report["vehicles"]},
        "tracking_mean_m": {v["sysid"]: v["mean_tracking_error_m"] for v in report["vehicles"]},
        "link_round_trip_s": {v["sysid"]: v["link_round_trip_s"] for v in report["vehicles"]},
        "streams_asked_again_stopped": {
            v["sysid"]: (v["streams_asked_again"], v["streams_stopped"]) for v in report["vehicles"]
        },
        "messages_per_s": {v["sysid"]: v["messages_per_s"] for v in report["vehicles"]},
        "memory_mib": {k: round(v, 1) for k, v in memory.items()},
        # (the mock's ground-truth rows, kept in this process to score the run, grow with
        # the mission, as columns: ``*_truth_store_mib``; the service's own are bounded)
        "truth_rows": len(fleets[0].history.rows) if fleets and fleets[0].history else None,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, help="mission s (an hour; a road: its length)")
    parser.add_argument("--speedup", type=float, default=40.0)
    parser.add_argument("--json", metavar="FILE")
    parser.add_argument("--report", metavar="FILE", help="the service's whole report (JSON)")
    parser.add_argument("--personality", choices=("px4", "ardupilot"), default="px4")
    parser.add_argument("--road", choices=sorted(ROAD_KINDS), help="a generated road instead")
    parser.add_argument("--route-known", action="store_true", help="with --road: its route")
    parser.add_argument("--link-only", action="store_true", help="the link's faults alone")
    parser.add_argument("--seed", type=int, default=3, help="the link's random draws")
    parser.add_argument("--frame", choices=("plane", "copter"), default="plane")
    parser.add_argument("--flood", metavar="PORT", type=int, nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.flood:  # (the soak's flooder, in a process of its own)
        _flood(args.flood, 100_000, 100_000)
        return
    out = asyncio.run(
        soak(args.duration, args.speedup, args.report, personality=args.personality,
             road=args.road, route_known=args.route_known, link_only=args.link_only,
             seed=args.seed, frame=args.frame)
    )  # fmt: skip
    text = json.dumps(out, indent=2)
    print(text)
    if args.json:
        Path(args.json).write_text(text)


if __name__ == "__main__":
    main()
