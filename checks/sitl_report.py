"""Score a `convoy-mav run` against SITL from its tlog: take-off, tracking, coverage.

    python checks/sitl_report.py MISSION.toml REPORT.json MISSION.tlog

The autopilots' own GLOBAL_POSITION_INT are the aircraft's truth (SITL's estimate is
its simulated state within centimetres), airborne above 3 m over home; the convoy is
the config's scripted route, set off at the report's ``route_start_s``, or (``[convoy]
source = "mavlink"``: ``sitl-mock`` rovers driving a road) the centroid of its vehicles'
own GLOBAL_POSITION_INT, which the mock reports without noise (of the lead's group, a
vehicle parted from it left out, as the service does: ``parting``; each rover's mode
from its HEARTBEAT, dated at its last position before it). Times are mission time,
rebuilt from ``time_boot_ms`` the way the service does (``MissionClock`` fed with the
tlog's arrival stamps, the rovers' clocks mapped onto the aircraft's).
"""

from __future__ import annotations

import bisect
import json
import math
import sys
from collections import defaultdict

from pymavlink import mavutil

from convoy_mav.clock import MissionClock
from convoy_mav.config import load_config
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.rovermode import rover_mode
from convoy_mav.planning.export import compass_to_planner
from convoy_mav.scoring import TruthFix, score_truth
from convoy_mav.types import ConvoyDrive

_TICK = 0.1  # s of mission time between scored samples
_AIRBORNE_M = 3.0


def main(config_path: str, report_path: str, tlog_path: str) -> int:
    cfg = load_config(config_path)
    with open(report_path) as fh:
        report = json.load(fh)
    uavs = {u.sysid for u in cfg.uav_list}
    rovers = {g.sysid for g in cfg.convoy.vehicles} if cfg.convoy.source == "mavlink" else set()
    wall = [0.0]
    clock = MissionClock(lambda: wall[0])
    fixes: dict[int, list[tuple[float, float, float, float]]] = defaultdict(list)
    drives: dict[int, list[tuple[float, ConvoyDrive]]] = defaultdict(list)
    log = mavutil.mavlink_connection(tlog_path)
    while (msg := log.recv_match(type=["GLOBAL_POSITION_INT", "HEARTBEAT"])) is not None:
        sysid = msg.get_srcSystem()
        if sysid not in uavs | rovers:
            continue
        if msg.get_type() == "HEARTBEAT":
            mode = rover_mode(msg) if sysid in rovers and fixes[sysid] else None
            if mode is not None:
                drives[sysid].append((fixes[sysid][-1][0], mode.drive))
            continue
        wall[0] = msg._timestamp
        clock.observe(msg.time_boot_ms, sysid)
        t = clock.to_mission(msg.time_boot_ms, sysid)
        fixes[sysid].append((t, msg.lat * 1e-7, msg.lon * 1e-7, msg.relative_alt * 1e-3))
    start, end = report.get("protect_start_s"), report.get("end_s")
    route_t0 = report.get("route_start_s")
    print(
        f"{'uav':>4} {'take-off s':>10} {'max alt m':>9} {'median err m':>12} "
        f"{'mean err m':>10} {'in circle':>9} {'msgs/s':>7}"
    )
    vehicles = {v["sysid"]: v for v in report["vehicles"]}
    for sysid in sorted(uavs):
        rows = fixes.get(sysid, [])
        up = next((t for t, _, _, alt in rows if alt > _AIRBORNE_M), None)
        top = max((alt for *_, alt in rows), default=math.nan)
        v = vehicles.get(sysid, {})
        med, mean = v.get("median_tracking_error_m"), v.get("mean_tracking_error_m")
        print(
            f"{sysid:>4} {'never' if up is None else f'{up:.1f}':>10} {top:>9.1f} "
            f"{'-' if med is None else f'{med:.1f}':>12} "
            f"{'-' if mean is None else f'{mean:.1f}':>10} "
            f"{100 * v.get('time_in_circle_fraction', 0.0):>8.1f}% "
            f"{v.get('messages_per_s') or 0:>7.1f}"
        )
    if start is None or (route_t0 is None and not rovers):
        print("no protect phase: nothing to score")
        return 1
    frame = LocalFrame(cfg.origin)
    c = cfg.convoy
    heading = compass_to_planner(c.heading_deg)
    truth: list[TruthFix] = []
    cursor = dict.fromkeys(uavs | rovers, 0)
    t = start
    while t <= end:
        if not rovers:
            run = c.speed_mps * (t - route_t0)
            g = frame.to_geo(
                c.start_north_m + run * math.sin(heading), c.start_east_m + run * math.cos(heading)
            )
            truth.append(TruthFix(t, 0, "ground", g.lat, g.lon))
        for sysid in sorted(rovers | uavs):  # the latest fix at t (held at most a second)
            rows, i = fixes.get(sysid, []), cursor[sysid]
            while i + 1 < len(rows) and rows[i + 1][0] <= t:
                i += 1
            cursor[sysid] = i
            if not (rows and rows[i][0] <= t and t - rows[i][0] <= 1.0):
                continue
            _, lat, lon, alt = rows[i]
            if sysid in rovers:
                said = drives.get(sysid, [])
                k = bisect.bisect_right(said, t, key=lambda d: d[0])
                drive = said[k - 1][1] if k else None
                truth.append(TruthFix(t, sysid, "ground", lat, lon, drive=drive))
            else:
                truth.append(TruthFix(t, sysid, "aircraft", lat, lon, True, alt > _AIRBORNE_M))
        t += _TICK
    lead = c.vehicles[0].sysid if c.vehicles else None  # (its group is the convoy)
    stats = score_truth(
        truth, cfg.origin, cfg.sensor_radius_m, start=start, end=end,
        lead=lead, part_m=cfg.convoy_part_m,
    )  # fmt: skip
    print(
        f"protect phase {start:.1f}..{end:.1f} s: coverage {100 * stats.fraction:.2f} % "
        f"(service's monitor {100 * (report['coverage_fraction'] or 0):.2f} %, predicted "
        f"{100 * (report['predicted_coverage'] or 0):.2f} %), longest gap "
        f"{stats.longest_gap_s:.1f} s, {stats.gaps} gaps"
    )
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    sys.exit(main(*sys.argv[1:]))
