"""Score a mission from ground truth, independently of what the service believed.

The mock (or any simulator) writes every vehicle's true position at a fixed
rate; this module replays those rows through the same coverage arithmetic the
live monitor uses, with the convoy centroid taken from the ground vehicles'
true positions: those of the lead's group, by the service's own rule
(``parting.convoy_group``: a follower 2 sensor radii off, or whose mode says it left
the lead, at once), when a part distance is given.  A service that is
wrong about where its UAVs or the convoy are is caught here.
"""

from __future__ import annotations

import csv
import math
import os
from collections import defaultdict
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from convoy_mav.coverage import CoverageStats, CoverageTracker
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.rovermode import drive_of
from convoy_mav.parting import StandWatch, convoy_group, leaves
from convoy_mav.types import ConvoyDrive

__all__ = ["TruthFix", "read_truth_csv", "score_truth"]


@dataclass(frozen=True, slots=True)
class TruthFix:
    """One true position of one vehicle."""

    t: float
    sysid: int
    kind: str  # "aircraft" or "ground"
    lat: float
    lon: float
    alive: bool = True
    airborne: bool = True
    drive: ConvoyDrive | None = None  # a ground vehicle's, as its mode says (None: unknown)


def read_truth_csv(path: str | os.PathLike[str]) -> Iterator[TruthFix]:
    """Rows of a ``sitl-mock --truth`` CSV (header ``t,sysid,kind,lat,lon,...,mode``)."""
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            yield TruthFix(
                t=float(row["t"]),
                sysid=int(row["sysid"]),
                kind=row["kind"],
                lat=float(row["lat"]),
                lon=float(row["lon"]),
                alive=row.get("mode") != "KILLED",
                airborne=row.get("airborne", "1") not in ("0", "False"),
                drive=_drive(row),
            )


def _drive(row: dict[str, str]) -> ConvoyDrive | None:
    """A ground vehicle's drive from its truth row's mode and arming (None: no mode)."""
    mode = row.get("mode")
    if row.get("kind") != "ground" or not mode:
        return None
    return drive_of(mode, row.get("armed", "1") not in ("0", "False"))


def score_truth(
    fixes: Iterable[TruthFix],
    origin: GeoPoint,
    sensor_radius: float,
    *,
    start: float,
    end: float | None = None,
    max_hold: float = 1.0,
    lead: int | None = None,
    part_m: float = 0.0,
) -> CoverageStats:
    """Coverage of the convoy by the aircraft between ``start`` and ``end`` (mission s).

    Rows are grouped by time stamp; at each stamp the convoy is the centroid of
    the ground vehicles' true positions (with ``part_m``, those of ``lead``'s group:
    one parted from it, whose mode says it left the lead's, or that has stood while the
    lead drove on, is not the convoy) and
    every live aircraft's true position counts.  Killed vehicles and aircraft on the
    ground see nothing.
    """
    frame = LocalFrame(origin)
    by_t: dict[float, list[TruthFix]] = defaultdict(list)
    for fix in fixes:
        if fix.t >= start and (end is None or fix.t <= end):
            by_t[fix.t].append(fix)
    tracker = CoverageTracker(sensor_radius, max_hold)
    parted: frozenset[int] = frozenset()
    stands: StandWatch[int] = StandWatch()
    last: dict[int, tuple[float, float, float]] = {}  # (t, north, east) of each's last row
    for t in sorted(by_t):
        ground: dict[int, tuple[float, float]] = {}
        drives: dict[int, ConvoyDrive] = {}
        aircraft: dict[int, tuple[float, float]] = {}
        for fix in by_t[t]:
            if not (math.isfinite(fix.lat) and math.isfinite(fix.lon)):
                continue
            north, east, _ = frame.to_ned(GeoPoint(fix.lat, fix.lon))
            if fix.kind == "ground":
                ground[fix.sysid] = (north, east)
                if fix.drive is not None:
                    drives[fix.sysid] = fix.drive
            elif fix.alive and fix.airborne:
                aircraft[fix.sysid] = (north, east)
        if not ground:
            continue
        for sysid, (north, east) in ground.items():  # (its speed since its last row)
            was = last.get(sysid)
            speed = None
            if was is not None and t > was[0]:
                speed = math.dist(was[1:], (north, east)) / (t - was[0])
            stands.add(sysid, t, speed)
            last[sysid] = (t, north, east)
        ahead = None if lead is None else drives.get(lead)
        left = frozenset(s for s, d in drives.items() if s != lead and leaves(d, ahead))
        left |= stands.judge(lead, t)
        group = convoy_group(ground, lead=lead, part_m=part_m, parted=parted, apart=left)
        parted = frozenset(ground) - group
        members = [ground[s] for s in group]
        centre = (
            sum(p[0] for p in members) / len(members),
            sum(p[1] for p in members) / len(members),
        )
        tracker.update(t, centre, aircraft)
    return tracker.stats()
