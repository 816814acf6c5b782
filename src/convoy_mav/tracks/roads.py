"""Road-shaped convoy tracks: curves, bends, hairpins, roundabouts, stops, speed changes.

Design rules:
- A road is pieces laid end to end: straights and arcs (radius, signed
  turn angle). A drive along it is a speed profile over arc length: a
  cruise speed per stretch and stops (position, duration), with bounded
  acceleration and braking, as a vehicle drives.
- The track is the drive sampled at ``rate_hz`` with optional GPS noise
  (Gaussian, per axis) and optional repeated time stamps, as receivers
  record them; a seeded ``numpy.random.Generator`` makes it reproducible.
- :data:`KINDS` are the named roads ``demo`` and the tests fly; :data:`VARIANTS`
  the same kinds with other numbers; :data:`OTHERS` roads of other kinds;
  :data:`DEVIATIONS` drives that do not keep to the route planned for them;
  :func:`random_road` draws one of any kind for property tests. Pure: nothing here opens a file.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.tracks.geotrack import GeoTrack

__all__ = [
    "DEVIATIONS",
    "KINDS",
    "OTHERS",
    "VARIANTS",
    "Deviation",
    "Drive",
    "Piece",
    "RoadTrack",
    "corner",
    "drive",
    "junction",
    "random_road",
    "road_kind",
    "route_of",
    "stops_from",
]

FloatArray = npt.NDArray[np.float64]

_STEP = 0.5  # m: arc-length resolution of the laid-out road


@dataclass(frozen=True, slots=True)
class Piece:
    """A straight (``radius`` 0) or an arc of ``radius`` turning ``angle_deg`` (> 0 left)."""

    length: float = 0.0
    radius: float = 0.0
    angle_deg: float = 0.0

    @property
    def arc_length(self) -> float:
        """Length of the piece, metres."""
        if self.radius > 0.0:
            return self.radius * math.radians(abs(self.angle_deg))
        return self.length


@dataclass(frozen=True, slots=True)
class Drive:
    """How the convoy drives the road.

    Attributes:
        speeds: (from arc length, cruise speed m/s) pairs, the first from 0.
        stops: (at arc length, seconds stopped) pairs.
        accel: Acceleration and braking, m/s^2.
        end_stop_s: Seconds parked at the end of the road.
    """

    speeds: tuple[tuple[float, float], ...]
    stops: tuple[tuple[float, float], ...] = ()
    accel: float = 1.0
    end_stop_s: float = 0.0


@dataclass(frozen=True, slots=True)
class RoadTrack:
    """A generated drive: true positions (mission frame) and the fixes recorded."""

    name: str
    t: FloatArray  # fix times, s
    north: FloatArray  # recorded (noisy) positions, m
    east: FloatArray
    true_north: FloatArray  # where the convoy really was at each fix time
    true_east: FloatArray
    length_m: float
    speeds: tuple[tuple[float, float], ...] = ()  # the drive's plan: (arc length, m/s on)

    def geotrack(self, origin: GeoPoint) -> GeoTrack:
        """The recorded fixes as a WGS-84 track around ``origin``."""
        frame = LocalFrame(origin)
        points = [
            frame.to_geo(float(n), float(e)) for n, e in zip(self.north, self.east, strict=True)
        ]
        lats = [p.lat for p in points]
        lons = [p.lon for p in points]
        return GeoTrack.from_fixes([float(t) for t in self.t], lats, lons, self.name, "generated")


def _layout(pieces: Sequence[Piece], heading: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Arc length, north and east of the road every ``_STEP`` metres."""
    xs, ys, h = [0.0], [0.0], heading  # x east, y north, heading CCW from east
    for p in pieces:
        n = max(1, round(p.arc_length / _STEP))
        ds = p.arc_length / n
        dh = 0.0 if p.radius <= 0.0 else math.radians(p.angle_deg) / n
        for _ in range(n):
            mid = h + 0.5 * dh
            xs.append(xs[-1] + ds * math.cos(mid))
            ys.append(ys[-1] + ds * math.sin(mid))
            h += dh
    x, y = np.array(xs), np.array(ys)
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    return s, y, x


def _profile(drive_: Drive, length: float, dt: float) -> FloatArray:
    """Arc length against time (step ``dt``), driving ``drive_`` to the end of the road."""
    speeds = sorted(drive_.speeds)
    stops = sorted(drive_.stops)

    def cruise(s: float) -> float:
        v = speeds[0][1]
        for start, value in speeds:
            if s >= start:
                v = value
        return v

    out = [0.0]
    s, v, waited = 0.0, 0.0, 0.0
    stop_i = 0
    while s < length:
        target = cruise(s)
        # Brake for the next stop (or the end): v^2 = 2 a d.
        next_stop = stops[stop_i][0] if stop_i < len(stops) else length
        room = max(next_stop - s, 0.0)
        target = min(target, math.sqrt(2.0 * drive_.accel * room))
        if room < 0.05 and v < 0.05:
            if stop_i < len(stops):
                waited += dt
                if waited >= stops[stop_i][1]:
                    stop_i, waited = stop_i + 1, 0.0
                    s += 0.06  # pull away
                out.append(s)
                continue
            break
        v = (
            target
            if abs(target - v) <= drive_.accel * dt
            else v + math.copysign(drive_.accel * dt, target - v)
        )
        s = min(s + v * dt, next_stop if room > 0.0 else s + v * dt)
        out.append(s)
    out += [length] * int(drive_.end_stop_s / dt)
    return np.array(out)


def drive(
    name: str,
    pieces: Sequence[Piece],
    how: Drive,
    *,
    heading_deg: float = 0.0,
    rate_hz: float = 1.0,
    noise_m: float = 0.0,
    repeat_every: int = 0,
    seed: int = 0,
) -> RoadTrack:
    """The convoy driving ``pieces`` as ``how`` says, recorded at ``rate_hz``.

    Args:
        heading_deg: Compass course of the first piece.
        noise_m: GPS noise, standard deviation per axis, metres.
        repeat_every: Every this many fixes, one is stamped with the previous
            fix's time (0: never), as some receivers do.
        seed: Seed of the noise.
    """
    s_grid, n_grid, e_grid = _layout(pieces, math.radians(90.0 - heading_deg))
    dt = 0.1
    s_t = _profile(how, float(s_grid[-1]), dt)
    every = max(1, round(1.0 / (rate_hz * dt)))
    s_fix = s_t[::every]
    t = np.arange(len(s_fix)) * every * dt
    true_n = np.interp(s_fix, s_grid, n_grid)
    true_e = np.interp(s_fix, s_grid, e_grid)
    rng = np.random.default_rng(seed)
    north = true_n + rng.normal(0.0, noise_m, len(t)) if noise_m > 0 else true_n.copy()
    east = true_e + rng.normal(0.0, noise_m, len(t)) if noise_m > 0 else true_e.copy()
    stamps = t.astype(np.float64)
    if repeat_every > 0:
        for i in range(repeat_every, len(stamps), repeat_every):
            stamps[i] = stamps[i - 1]  # (a receiver stamping a fix with the last one's time)
    plan = tuple(sorted(how.speeds))
    return RoadTrack(name, stamps, north, east, true_n, true_e, float(s_grid[-1]), plan)


def _zigzag(count: int, straight: float, radius: float, angle: float) -> list[Piece]:
    pieces = [Piece(straight)]
    for i in range(count):
        pieces += [Piece(radius=radius, angle_deg=angle if i % 2 == 0 else -angle), Piece(straight)]
    return pieces


def _urban(rng: np.random.Generator, blocks: int) -> tuple[list[Piece], list[tuple[float, float]]]:
    pieces: list[Piece] = []
    stops: list[tuple[float, float]] = []
    s = 0.0
    for _ in range(blocks):
        block = float(rng.uniform(120.0, 300.0))
        pieces.append(Piece(block))
        s += block
        if rng.random() < 0.5:
            stops.append((s, float(rng.uniform(10.0, 45.0))))
        turn = float(rng.choice([-90.0, 90.0, 0.0]))
        if turn:
            corner = Piece(radius=12.0, angle_deg=turn)
            pieces.append(corner)
            s += corner.arc_length
    return pieces, stops


def corner(
    angle_deg: float, at_s: float, *, speed: float = 8.0, then_s: float = 200.0
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(t, north, east), 1-Hz fixes of a convoy driving north at ``speed`` that turns
    ``angle_deg`` at once (positive: right) at ``at_s`` and drives on ``then_s``: the
    corner nobody foresaw, for the formation's answer to it alone."""
    t = np.arange(0.0, at_s + then_s, 1.0)
    course = np.where(t <= at_s, 0.0, math.radians(angle_deg))
    north = np.concatenate([[0.0], np.cumsum(speed * np.cos(course[:-1]))])
    east = np.concatenate([[0.0], np.cumsum(speed * np.sin(course[:-1]))])
    return t, north, east


def junction(stop_s: float, angle_deg: float, at_m: float, *, speed: float = 8.0) -> RoadTrack:
    """A convoy at ``speed`` that brakes to a stop at ``at_m``, waits ``stop_s`` and then
    turns ``angle_deg`` (12-m corner, positive: left) and drives 1.6 km on: the urban
    grid's junction alone, for how the fleet meets a stop before a turn."""
    pieces = [Piece(at_m), Piece(radius=12.0, angle_deg=angle_deg), Piece(1600.0)]
    return drive("junction", pieces, Drive(((0.0, speed),), stops=((at_m, stop_s),)))


def road_kind(kind: str, *, seed: int = 0) -> RoadTrack:
    """One of :data:`KINDS`, about 15-25 minutes of driving."""
    return KINDS[kind](np.random.default_rng(seed))


def _gentle(rng: np.random.Generator) -> RoadTrack:
    return drive("gentle curves", _zigzag(8, 400.0, 1000.0, 30.0), Drive(((0.0, 8.0),)))


def _bends(rng: np.random.Generator) -> RoadTrack:
    return drive("90 deg bends", _zigzag(14, 400.0, 150.0, 90.0), Drive(((0.0, 8.0),)))


def _hairpins(rng: np.random.Generator) -> RoadTrack:
    return drive("hairpins", _zigzag(10, 300.0, 25.0, 180.0), Drive(((0.0, 6.0),), accel=0.8))


def _to_roundabout(flare: float, ring: float, angle_deg: float) -> list[Piece]:
    """1.5 km of road, then round a roundabout of radius ``ring`` (entry and exit flares
    of radius ``flare``), leaving it ``angle_deg`` round."""
    return [
        Piece(1500.0),
        Piece(radius=flare, angle_deg=-30.0),
        Piece(radius=ring, angle_deg=angle_deg),
        Piece(radius=flare, angle_deg=-30.0),
    ]


def _roundabout(rng: np.random.Generator) -> RoadTrack:
    pieces = [*_to_roundabout(15.0, 25.0, 240.0), *_to_roundabout(15.0, 25.0, 150.0)]
    how = Drive(((0.0, 10.0), (1450.0, 4.0), (1700.0, 10.0), (3150.0, 4.0), (3400.0, 10.0)))
    return drive("roundabouts", [*pieces, Piece(1500.0)], how)


def _stop_and_go(rng: np.random.Generator) -> RoadTrack:
    how = Drive(((0.0, 8.0),), stops=((1500.0, 120.0), (3500.0, 120.0), (5000.0, 30.0)))
    return drive("stop and go", [Piece(6500.0)], how)


def _urban_grid(rng: np.random.Generator) -> RoadTrack:
    pieces, stops = _urban(rng, 24)
    return drive(
        "urban grid", pieces, Drive(((0.0, 8.0),), stops=tuple(stops)), noise_m=3.0, seed=1
    )


def _roundabout_fast(rng: np.random.Generator) -> RoadTrack:
    way = _to_roundabout(12.0, 20.0, 270.0)
    # Three roundabouts, each taken at 5 m/s, 12 m/s between them.
    apart = sum(p.arc_length for p in way)
    at = [1450.0 + k * apart for k in range(3)]  # (slowing 50 m before each)
    speeds = [(0.0, 12.0)] + [p for a in at for p in ((a, 5.0), (a + 250.0, 12.0))]
    return drive("roundabouts at 12 m/s", [*way, *way, *way, Piece(1500.0)], Drive(tuple(speeds)))


def stops_from(speed: float, stop_s: float = 60.0) -> RoadTrack:
    """8 km of straight road at ``speed``, braking at 1 m/s^2 to four stops of ``stop_s``
    1.5 km apart: a fast convoy's stops, which no plan sees coming."""
    stops = tuple((1500.0 * k, stop_s) for k in range(1, 5))
    return drive(f"stops from {speed:g} m/s", [Piece(8000.0)], Drive(((0.0, speed),), stops))


def _stops_at(speed: float, stop_s: float) -> Callable[[np.random.Generator], RoadTrack]:
    return lambda rng: stops_from(speed, stop_s)


def _speeds_between(
    low: float, high: float, name: str = ""
) -> Callable[[np.random.Generator], RoadTrack]:
    """9 km of straight road in stretches at ``low`` and ``high`` m/s, twice."""

    def make(rng: np.random.Generator) -> RoadTrack:
        how = Drive(((0.0, low), (1200.0, high), (5000.0, low), (6200.0, high)))
        return drive(name or f"{low:g} and {high:g} m/s", [Piece(9000.0)], how)

    return make


def _urban_coarse(rate_hz: float, noise_m: float) -> Callable[[np.random.Generator], RoadTrack]:
    def make(rng: np.random.Generator) -> RoadTrack:
        pieces, stops = _urban(rng, 20)
        how = Drive(((0.0, 9.0),), stops=tuple(stops))
        return drive(
            "urban grid",
            pieces,
            how,
            rate_hz=rate_hz,
            noise_m=noise_m,
            seed=int(rng.integers(1 << 30)),
        )

    return make


#: The named roads: a generator of each from a random source.
KINDS: dict[str, Callable[[np.random.Generator], RoadTrack]] = {
    "gentle": _gentle,
    "bends": _bends,
    "hairpins": _hairpins,
    "roundabout": _roundabout,
    "stop-and-go": _stop_and_go,
    "speeds": _speeds_between(4.0, 12.0, "speed changes"),
    "urban": _urban_grid,
}

#: The kinds again with other numbers (the road table's ``--variants``): sharper
#: bends, wider hairpins, faster convoys (stops and slow-downs from 10-15 m/s,
#: nearer the 18 m/s of the demo's planes), coarser and noisier fixes.
VARIANTS: dict[str, Callable[[np.random.Generator], RoadTrack]] = {
    "bends 100 m at 10 m/s": lambda rng: drive(
        "bends", _zigzag(18, 300.0, 100.0, 90.0), Drive(((0.0, 10.0),))
    ),
    "hairpins 40 m at 8 m/s": lambda rng: drive(
        "hairpins", _zigzag(8, 500.0, 40.0, 180.0), Drive(((0.0, 8.0),), accel=1.0)
    ),
    "gentle 45 deg at 12 m/s": lambda rng: drive(
        "gentle", _zigzag(11, 300.0, 600.0, 45.0), Drive(((0.0, 12.0),))
    ),
    "roundabout at 12 m/s": _roundabout_fast,
    "stops of 30 s from 10 m/s": _stops_at(10.0, 30.0),
    "stops of 60 s from 12 m/s": _stops_at(12.0, 60.0),
    "2 and 14 m/s": _speeds_between(2.0, 14.0),
    "5 and 15 m/s": _speeds_between(5.0, 15.0),
    "urban, 5 m noise at 2 Hz": _urban_coarse(2.0, 5.0),
    "urban at 0.5 Hz": _urban_coarse(0.5, 3.0),
}


def _switchbacks(rng: np.random.Generator) -> RoadTrack:
    """A mountain road: fourteen 180-degree turns of 10 m radius, 120 m apart, at 5 m/s."""
    pieces = [Piece(150.0), *_zigzag(14, 120.0, 10.0, 180.0)[1:]]
    return drive("switchbacks", pieces, Drive(((0.0, 5.0),), accel=0.8))


def _dead_ends(rng: np.random.Generator) -> RoadTrack:
    """Up a road to its end and back (a 6-m turn at 2 m/s), twice: the convoy comes back
    the way it went."""
    pieces = [Piece(1200.0), Piece(radius=6.0, angle_deg=180.0), Piece(1200.0)]
    pieces += [Piece(radius=150.0, angle_deg=-90.0), Piece(800.0)]
    pieces += [Piece(radius=6.0, angle_deg=-180.0), Piece(800.0)]
    how = Drive(((0.0, 8.0), (1170.0, 2.0), (1225.0, 8.0), (3425.0, 2.0), (3480.0, 8.0)))
    return drive("dead ends", pieces, how, noise_m=2.0, seed=3)


def _walking_pace(rng: np.random.Generator) -> RoadTrack:
    """A foot patrol's pace, 1.5 m/s, round eight 8-m corners, in 3 m of GPS noise."""
    pieces = [Piece(300.0)]
    for i in range(8):
        pieces += [Piece(radius=8.0, angle_deg=90.0 if i % 3 else -90.0), Piece(200.0)]
    return drive("walking pace", pieces, Drive(((0.0, 1.5),)), noise_m=3.0, seed=4)


def _parked_first(rng: np.random.Generator) -> RoadTrack:
    """Parked 400 s where the mission starts, then 10 m/s with a 300-s stop."""
    pieces = [Piece(4000.0), Piece(radius=30.0, angle_deg=90.0), Piece(2000.0)]
    how = Drive(((0.0, 10.0),), stops=((2.0, 400.0), (2500.0, 300.0)))
    return drive("parked first", pieces, how)


def _loops(rng: np.random.Generator) -> RoadTrack:
    """A figure eight: a whole 200-m circle left, then one right, at 9 m/s."""
    pieces = [Piece(500.0), Piece(radius=200.0, angle_deg=360.0)]
    pieces += [Piece(radius=200.0, angle_deg=-360.0), Piece(1000.0)]
    return drive("figure eight", pieces, Drive(((0.0, 9.0),)), noise_m=1.0, seed=5)


def _spiral(rng: np.random.Generator) -> RoadTrack:
    """A turn that tightens, 400 m of radius down to 20 m over 1080 degrees, at 7 m/s."""
    radii = (400.0, 300.0, 220.0, 160.0, 120.0, 90.0, 70.0, 50.0, 40.0, 30.0, 25.0, 20.0)
    pieces = [Piece(400.0), *(Piece(radius=r, angle_deg=90.0) for r in radii), Piece(1500.0)]
    return drive("spiral", pieces, Drive(((0.0, 7.0),)))


def _highway(rng: np.random.Generator) -> RoadTrack:
    """12 km of highway at 13 m/s (0.72 of the demo's airspeed), one 60-s stop."""
    pieces = []
    for i in range(6):
        pieces += [Piece(2000.0), Piece(radius=800.0, angle_deg=25.0 if i % 2 else -25.0)]
    return drive("highway", pieces, Drive(((0.0, 13.0),), stops=((9000.0, 60.0),)))


def _long_stops(rng: np.random.Generator) -> RoadTrack:
    """Stops of 5 and 4 minutes on a road of two 12-m corners, in 3 m of GPS noise."""
    pieces = [Piece(1000.0), Piece(radius=12.0, angle_deg=90.0), Piece(1000.0)]
    pieces += [Piece(radius=12.0, angle_deg=-90.0), Piece(1000.0)]
    how = Drive(((0.0, 8.0),), stops=((900.0, 300.0), (2100.0, 240.0)))
    return drive("long stops", pieces, how, noise_m=3.0, seed=6)


#: Roads of kinds the planner was not built on (the road table's ``--others``): turns
#: on the spot, loops and spirals, a walking pace, a convoy parked at the start, one
#: fast for the aircraft, long stops.
OTHERS: dict[str, Callable[[np.random.Generator], RoadTrack]] = {
    "switchbacks": _switchbacks,
    "dead ends": _dead_ends,
    "walking pace": _walking_pace,
    "parked first": _parked_first,
    "figure eight": _loops,
    "spiral": _spiral,
    "highway": _highway,
    "long stops": _long_stops,
}


def random_road(rng: np.random.Generator, *, max_speed: float = 12.0, pieces: int = 8) -> RoadTrack:
    """A random road of random pieces, speeds and stops (property tests)."""
    out: list[Piece] = []
    for _ in range(pieces):
        if rng.random() < 0.4:
            out.append(Piece(float(rng.uniform(50.0, 800.0))))
        else:
            radius = float(rng.uniform(10.0, 1500.0))
            out.append(Piece(radius=radius, angle_deg=float(rng.uniform(-180.0, 180.0))))
    total = sum(p.arc_length for p in out)
    speeds = tuple(
        (float(s), float(rng.uniform(1.0, max_speed))) for s in np.sort(rng.uniform(0.0, total, 3))
    )
    stops = tuple(
        (float(s), float(rng.uniform(5.0, 120.0)))
        for s in np.sort(rng.uniform(0.0, total, int(rng.integers(0, 3))))
    )
    how = Drive(((0.0, speeds[0][1]), *speeds), stops=stops)
    return drive(
        "random", out, how, noise_m=float(rng.uniform(0.0, 3.0)), seed=int(rng.integers(1 << 30))
    )


def route_of(pieces: Sequence[Piece], *, heading_deg: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """(north, east) of the road along ``pieces``, every half metre: a route planned for it."""
    _, north, east = _layout(pieces, math.radians(90.0 - heading_deg))
    return north, east


@dataclass(frozen=True, slots=True)
class Deviation:
    """A drive and the route planned for it, which the drive does not keep to."""

    track: RoadTrack
    route_north: FloatArray
    route_east: FloatArray


# Out of town and back on the one road: north, a 90 deg right of 150 m, east; there a
# U-turn across the road (8 m) and back the same way. The route says the way out only.
_OUT = [Piece(400.0), Piece(radius=150.0, angle_deg=-90.0), Piece(800.0)]
_BACK = [Piece(radius=4.0, angle_deg=180.0), Piece(800.0), Piece(radius=150.0, angle_deg=90.0)]
_BACK.append(Piece(400.0))
# A patrol circuit of 2.99 km (900 by 500 m, 30-m corners), given as one lap.
_LAP = [Piece(900.0), Piece(radius=30.0, angle_deg=90.0), Piece(500.0)]
_LAP += [Piece(radius=30.0, angle_deg=90.0)]
_LAP *= 2


def _out_and_back(rng: np.random.Generator) -> Deviation:
    rt = drive("out and back", _OUT + _BACK, Drive(((0.0, 8.0),)), noise_m=1.0)
    return Deviation(rt, *route_of(_OUT))


def patrol(speed: float = 8.0, stop_s: float = 0.0, stop_at_m: float = 700.0) -> Deviation:
    """Three laps of the patrol circuit at ``speed``, standing ``stop_s`` at ``stop_at_m``
    round each lap (none for 0: a checkpoint a rover's mission holds at); the route is
    one lap."""
    lap = sum(p.arc_length for p in _LAP)
    stops = tuple((stop_at_m + k * lap, stop_s) for k in range(3)) if stop_s > 0.0 else ()
    name = "patrol circuit" + (f", {stop_s:g}-s stops" if stops else "")
    rt = drive(name, _LAP * 3, Drive(((0.0, speed),), stops), noise_m=1.0)
    return Deviation(rt, *route_of(_LAP))


def _patrol(rng: np.random.Generator) -> Deviation:
    return patrol()


def _detour(rng: np.random.Generator) -> Deviation:
    """A road closed 2 km on: round the block, 400 m north for 1.5 km, and back onto it."""
    turn = [Piece(radius=20.0, angle_deg=90.0), Piece(400.0), Piece(radius=20.0, angle_deg=-90.0)]
    back = [Piece(radius=20.0, angle_deg=-90.0), Piece(400.0), Piece(radius=20.0, angle_deg=90.0)]
    pieces = [Piece(2000.0), *turn, Piece(1500.0), *back, Piece(2000.0)]
    rt = drive("detour", pieces, Drive(((0.0, 8.0),)), heading_deg=90.0, noise_m=1.0)
    return Deviation(rt, *route_of([Piece(6000.0)], heading_deg=90.0))


#: Drives that leave the route planned for them (the road table's ``--deviations``).
DEVIATIONS: dict[str, Callable[[np.random.Generator], Deviation]] = {
    "out and back": _out_and_back,
    "patrol circuit, 3 laps": _patrol,
    "detour": _detour,
}
