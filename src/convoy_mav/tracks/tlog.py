"""Convoy tracks from a MAVLink telemetry log: the ground vehicles' centroid."""

from __future__ import annotations

import bisect
import math
import mmap
import statistics
from collections.abc import Collection
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame, no_position_yet
from convoy_mav.mavlink.tlog import read_tlog
from convoy_mav.tracks.geotrack import GeoTrack

__all__ = ["TLOG_STEP_S", "parse_tlog_track"]

TLOG_STEP_S = 1.0
"""Sample spacing of a convoy track rebuilt from a tlog (s of the vehicles' clock)."""
_REBOOT_JUMP_S = 1.0
"""A ``time_boot_ms`` this far behind the vehicle's previous one is a reboot."""


@dataclass(frozen=True, slots=True)
class _Fix:
    number: int  # tlog message number
    stamp: float  # record stamp, s
    boot: float  # vehicle time_boot_ms, s
    north: float
    east: float


def parse_tlog_track(
    data: bytes | mmap.mmap,
    name: str,
    *,
    sysids: Collection[int] = (),
    step: float = TLOG_STEP_S,
) -> GeoTrack:
    """The convoy's track from its ground vehicles' GLOBAL_POSITION_INT in a tlog.

    The convoy's vehicles are ``sysids``, or else every system whose HEARTBEAT
    says ``MAV_TYPE_GROUND_ROVER``. At each time the convoy is the centroid of
    those vehicles, each interpolated linearly between its two fixes around that
    time (the centroid of the *latest* fixes would jump whenever vehicles report
    out of phase); the track spans the time every one of them has reported (last
    first fix to first last fix), sampled every ``step`` seconds. Fixes at
    near (0, 0), the "no position yet" of PX4 and ArduPilot (``no_position_yet``), and repeated or
    reordered ones (``time_boot_ms`` not increasing) are skipped.

    Time is the vehicles' own ``time_boot_ms``, not the record stamps. The stamps
    are the recording ground station's wall clock: under a simulator running
    faster than real time (``sitl_mock`` at speedup 40) they squeeze the drive
    40-fold, and they carry network and scheduling jitter. ``time_boot_ms`` is
    when the vehicle took the fix, on the clock the service itself flies by. The
    first vehicle heard is the reference; every other one is put on its clock
    with an offset (median over its fixes of the reference's boot time, found by
    interpolating the reference's fixes at the fix's record stamp, or
    extrapolating them at their mean rate outside them, minus its own), so
    vehicles booted at different times line up. The stamps serve only that
    alignment.

    Args:
        data: The tlog's bytes (or a map of the file).
        name: The file name, for messages.
        sysids: The convoy's vehicles (default: every ground rover).
        step: Sample spacing of the result, seconds.

    Returns:
        The centroid track, times on the reference vehicle's boot clock (not rebased).

    Raises:
        ValueError: No messages, no ground vehicles, a named vehicle without fixes,
            a fix outside lat/lon range or a reboot (``message #N``), or vehicles
            whose fixes never overlap in time.
    """
    if not (math.isfinite(step) and step > 0.0):
        raise ValueError(f"step must be a finite number > 0, got {step!r}")
    rovers: set[int] = set()
    raw: dict[int, list[tuple[int, float, float, float, float]]] = {}
    messages = 0
    for record in read_tlog(data):
        messages += 1
        msg = record.msg
        kind = msg.get_type()
        if kind == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_GROUND_ROVER:
            rovers.add(msg.get_srcSystem())
        elif kind == "GLOBAL_POSITION_INT" and not no_position_yet(msg.lat, msg.lon):
            raw.setdefault(msg.get_srcSystem(), []).append(
                (
                    record.number,
                    record.stamp,
                    msg.time_boot_ms * 1e-3,
                    msg.lat * 1e-7,
                    msg.lon * 1e-7,
                )
            )
    if not messages:
        raise ValueError(f"{name}: no MAVLink messages (not a tlog, or empty)")
    if sysids:
        missing = sorted(s for s in set(sysids) if s not in raw)
        if missing:
            raise ValueError(
                f"{name}: no GLOBAL_POSITION_INT from sysid {', '.join(map(str, missing))}"
            )
        chosen = sorted(set(sysids))
    else:
        chosen = sorted(s for s in rovers if s in raw)
        if not chosen:
            heard = ", ".join(map(str, sorted(raw))) or "none"
            raise ValueError(
                f"{name}: no ground vehicles: no system with a MAV_TYPE_GROUND_ROVER "
                f"heartbeat reports GLOBAL_POSITION_INT (systems with positions: {heard}); "
                "name the convoy's vehicles by system id"
            )
    first = raw[chosen[0]][0]
    frame = LocalFrame(GeoPoint(first[3], first[4]))
    fixes = {s: _vehicle_fixes(raw[s], s, frame, name) for s in chosen}
    timelines = _align(fixes)
    lo = max(times[0] for times, _ in timelines.values())
    hi = min(times[-1] for times, _ in timelines.values())
    if lo > hi:
        spans = ", ".join(
            f"sysid {s} {times[0]:.1f}-{times[-1]:.1f} s" for s, (times, _) in timelines.items()
        )
        raise ValueError(f"{name}: the ground vehicles' fixes never overlap in time ({spans})")
    count = math.floor((hi - lo) / step + 1e-9) + 1
    grid = [lo + i * step for i in range(count)]
    if hi - grid[-1] > 1e-6 * step:
        grid.append(hi)
    lats: list[float] = []
    lons: list[float] = []
    for t in grid:
        points = [_interpolate(times, f, t) for times, f in timelines.values()]
        north = statistics.fmean(p[0] for p in points)
        east = statistics.fmean(p[1] for p in points)
        geo = frame.to_geo(north, east)
        lats.append(geo.lat)
        lons.append(geo.lon)
    return GeoTrack(tuple(grid), tuple(lats), tuple(lons), name, "tlog")


def _vehicle_fixes(
    rows: list[tuple[int, float, float, float, float]], sysid: int, frame: LocalFrame, name: str
) -> list[_Fix]:
    out: list[_Fix] = []
    for number, stamp, boot, lat, lon in rows:
        where = f"{name}: message #{number}: sysid {sysid} GLOBAL_POSITION_INT"
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ValueError(f"{where}: ({lat:.7f}, {lon:.7f}) is not a lat/lon")
        if out and boot <= out[-1].boot:
            if out[-1].boot - boot >= _REBOOT_JUMP_S:
                raise ValueError(
                    f"{where}: time_boot_ms went back from {out[-1].boot:.3f} s to "
                    f"{boot:.3f} s (a reboot); cut the log there or leave that vehicle out"
                )
            continue  # a duplicate or a late packet
        north, east, _ = frame.to_ned(GeoPoint(lat, lon))
        out.append(_Fix(number, stamp, boot, north, east))
    return out


def _align(fixes: dict[int, list[_Fix]]) -> dict[int, tuple[list[float], list[_Fix]]]:
    """Each vehicle's fix times on the reference vehicle's boot clock (see parse_tlog_track)."""
    ref_id = min(fixes, key=lambda s: fixes[s][0].number)
    ref = fixes[ref_id]
    numbers = [f.number for f in ref]
    stamps = ref[-1].stamp - ref[0].stamp
    rate = (ref[-1].boot - ref[0].boot) / stamps if stamps > 0.0 else 1.0  # boot s per stamp s

    def ref_boot_at(fix: _Fix) -> float:
        """The reference's boot time when ``fix`` was recorded."""
        j = bisect.bisect_left(numbers, fix.number)
        if 0 < j < len(ref):  # between two reference fixes: interpolate by stamp
            a, b = ref[j - 1], ref[j]
            if b.stamp <= a.stamp:
                return a.boot
            f = min(1.0, max(0.0, (fix.stamp - a.stamp) / (b.stamp - a.stamp)))
            return a.boot + f * (b.boot - a.boot)
        near = ref[0] if j == 0 else ref[-1]  # outside: extrapolate at the mean rate
        return near.boot + rate * (fix.stamp - near.stamp)

    out: dict[int, tuple[list[float], list[_Fix]]] = {}
    for sysid, own in fixes.items():
        offset = 0.0 if sysid == ref_id else statistics.median(ref_boot_at(f) - f.boot for f in own)
        out[sysid] = ([f.boot + offset for f in own], own)
    return out


def _interpolate(times: list[float], fixes: list[_Fix], t: float) -> tuple[float, float]:
    j = bisect.bisect_right(times, t)
    if j == 0:
        return fixes[0].north, fixes[0].east
    if j == len(times):
        return fixes[-1].north, fixes[-1].east
    a, b = fixes[j - 1], fixes[j]
    f = (t - times[j - 1]) / (times[j] - times[j - 1])
    return a.north + f * (b.north - a.north), a.east + f * (b.east - a.east)
