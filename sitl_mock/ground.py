"""Where the mock's ground vehicles (the convoy) are at any sim time.

Design rules:
    * A route is a pure function of sim time ``t`` (s): world NED ``(north, east)`` and
      ground velocity ``(vn, ve)``; no state, so replay and speed-up are free.
    * Before ``t = 0`` and after its end a finite route holds still (velocity 0);
      ``StraightLine`` alone is a line through its point at ``t = 0``, both ways.
    * Values are validated on construction and errors name the field (or the file and
      line number), so a typo in a scenario fails loudly instead of driving nowhere.
"""

from __future__ import annotations

import bisect
import itertools
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Protocol, runtime_checkable

from convoy_mav.geo import LocalFrame
from convoy_mav.tracks import GeoTrack, parse_csv_track
from sitl_mock.drive import DriveProfile, Ramps, corner_speed

__all__ = [
    "Lagged",
    "Polyline",
    "Route",
    "Stationary",
    "StraightLine",
    "Track",
    "load_csv_track",
    "track_from_geo",
]


_SAME_POINT_M = 1e-6  # m: consecutive points nearer than this are one (a denormal leg: none)


@runtime_checkable
class Route(Protocol):
    """A ground vehicle's motion as a function of sim time."""

    def position(self, t: float) -> tuple[float, float]:
        """World ``(north, east)`` in metres at sim time ``t``."""
        ...

    def velocity(self, t: float) -> tuple[float, float]:
        """Ground velocity ``(vn, ve)`` in m/s at sim time ``t``."""
        ...


def _check_finite(owner: str, name: str, value: float) -> None:
    if not math.isfinite(value):
        raise ValueError(f"{owner}.{name} must be finite, got {value!r}")


@dataclass(frozen=True, slots=True)
class Stationary:
    """A vehicle parked at one point."""

    north: float
    east: float

    def __post_init__(self) -> None:
        _check_finite("Stationary", "north", self.north)
        _check_finite("Stationary", "east", self.east)

    def position(self, t: float) -> tuple[float, float]:
        """Always the same point."""
        return self.north, self.east

    def velocity(self, t: float) -> tuple[float, float]:
        """Always at rest."""
        return 0.0, 0.0


@dataclass(frozen=True, slots=True)
class StraightLine:
    """Constant velocity: at ``(north, east)`` when ``t = 0``, heading rad cw from north."""

    north: float
    east: float
    speed: float
    heading: float

    def __post_init__(self) -> None:
        for name in ("north", "east", "speed", "heading"):
            _check_finite("StraightLine", name, getattr(self, name))
        if self.speed < 0.0:
            raise ValueError(f"StraightLine.speed must be >= 0, got {self.speed!r}")

    def position(self, t: float) -> tuple[float, float]:
        """The point reached after ``t`` seconds (before it for negative ``t``)."""
        vn, ve = self.velocity(t)
        return self.north + vn * t, self.east + ve * t

    def velocity(self, t: float) -> tuple[float, float]:
        """The same velocity at every time."""
        return self.speed * math.cos(self.heading), self.speed * math.sin(self.heading)


@dataclass(frozen=True, slots=True)
class Lagged:
    """A route followed ``lag`` seconds behind: the convoy's later vehicles."""

    inner: Route
    lag: float

    def position(self, t: float) -> tuple[float, float]:
        """World (north, east) of the leader ``lag`` seconds earlier."""
        return self.inner.position(t - self.lag)

    def velocity(self, t: float) -> tuple[float, float]:
        """World (vn, ve) of the leader ``lag`` seconds earlier."""
        return self.inner.velocity(t - self.lag)


@dataclass(frozen=True, slots=True)
class Polyline:
    """Drive through ``points`` at ``speed`` from ``t = 0``, as a rover in AUTO drives
    its waypoints (``sitl_mock.drive``).

    Without ``loop`` the vehicle stops at the last point; with it, it drives back to
    the first one and starts over. Repeated consecutive points (within a micrometre)
    are skipped.

    ``accel`` (m/s², ArduRover's ``ATC_ACCEL_MAX``; 0: none) brakes it before each corner
    to the speed it passes it at within ``wp_radius`` (``WP_RADIUS``), and speeds it up
    after, each change of speed reaching it at ``jerk`` (m/s³, ``WP_JERK``; 0: the
    accel's value); without it every corner is taken at full speed. ``holds`` are ``(point
    index, seconds)`` stood at a point (a waypoint's hold time), ``speeds`` ``(point
    index, m/s)`` driven from a point on (a DO_CHANGE_SPEED), ``speed`` before any.
    ``told`` is ``(arc length within the lap, m/s, m/s)``: a speed its operator
    commanded there, and the speed it drove at then, in force until the next of
    ``speeds`` (``with_speed_from``).
    """

    points: tuple[tuple[float, float], ...]
    speed: float
    loop: bool = False
    accel: float = 0.0
    wp_radius: float = 2.0
    jerk: float = 0.0
    holds: tuple[tuple[int, float], ...] = ()
    speeds: tuple[tuple[int, float], ...] = ()
    told: tuple[float, float, float] | None = None
    _nodes: tuple[tuple[float, float], ...] = field(init=False, repr=False, compare=False)
    _cumulative: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _drive: DriveProfile | None = field(init=False, repr=False, compare=False)
    _own: tuple[int, ...] = field(init=False, repr=False, compare=False)  # (_drive's vertices
    # of its own, for a told speed)
    _told_at: int | None = field(init=False, repr=False, compare=False)  # (_drive's index)
    _told_end: int | None = field(init=False, repr=False, compare=False)  # (_drive's index)
    vertex_holds: dict[int, float] = field(init=False, repr=False, compare=False)
    vertex_speeds: dict[int, float] = field(init=False, repr=False, compare=False)  # (a
    # lap's first vertex has the speed each lap starts at, if it changes speed at all)

    def __post_init__(self) -> None:
        if not self.points:
            raise ValueError("Polyline.points must hold at least one point")
        for name in ("speed", "accel", "wp_radius", "jerk"):
            _check_finite("Polyline", name, getattr(self, name))
            if getattr(self, name) < 0.0:
                raise ValueError(f"Polyline.{name} must be >= 0, got {getattr(self, name)!r}")
        nodes: list[tuple[float, float]] = []
        node_of: list[int] = []  # each point's vertex (a repeated point is its first's)
        for i, point in enumerate(self.points):
            if len(point) != 2 or not all(math.isfinite(c) for c in point):
                raise ValueError(f"Polyline.points[{i}] must be two finite numbers, got {point!r}")
            node = (float(point[0]), float(point[1]))
            if not nodes or math.dist(node, nodes[-1]) > _SAME_POINT_M:
                nodes.append(node)
            node_of.append(len(nodes) - 1)
        if self.loop and len(nodes) > 1:
            if math.dist(nodes[-1], nodes[0]) > _SAME_POINT_M:
                nodes.append(nodes[0])
            else:  # (closed by its points: the last is the first vertex)
                node_of = [0 if k == len(nodes) - 1 else k for k in node_of]
        cumulative = [0.0]
        for (n0, e0), (n1, e1) in itertools.pairwise(nodes):
            cumulative.append(cumulative[-1] + math.hypot(n1 - n0, e1 - e0))
        holds = _marks("holds", self.holds, node_of, lambda v: v >= 0.0)
        speeds = _marks("speeds", self.speeds, node_of, lambda v: v > 0.0)
        if self.loop and speeds and 0 not in speeds:
            speeds[0] = speeds[max(speeds)]  # (a lap starts at the speed the last one left)
        object.__setattr__(self, "_nodes", tuple(nodes))
        object.__setattr__(self, "_cumulative", tuple(cumulative))
        object.__setattr__(self, "vertex_holds", holds)
        object.__setattr__(self, "vertex_speeds", speeds)
        if self.told is not None:
            arc, speed, now = self.told
            told_ok = 0.0 <= arc <= cumulative[-1] and math.isfinite(speed) and speed > 0.0
            if not (told_ok and now >= 0.0):
                raise ValueError(
                    f"Polyline.told must be (arc, m/s > 0, m/s >= 0), got {self.told!r}"
                )
        drive: DriveProfile | None = None
        own: tuple[int, ...] = ()
        at: int | None = None
        end: int | None = None
        if cumulative[-1] > 0.0 and self.speed > 0.0:
            drive, own, at, end = _drive(nodes, cumulative, self, holds, speeds)
        object.__setattr__(self, "_told_at", at)
        object.__setattr__(self, "_drive", drive)
        object.__setattr__(self, "_own", own)
        object.__setattr__(self, "_told_end", end)

    @property
    def length(self) -> float:
        """Length of one pass (with the closing leg when looping), metres."""
        return self._cumulative[-1]

    def time_at(self, arc: float) -> float:
        """The drive time it first reaches ``arc`` metres along its first pass (before
        standing there)."""
        return self._drive.time_at(arc) if self._drive is not None else 0.0

    def finished(self, tau: float) -> bool:
        """Whether at drive time ``tau`` it has driven its last point and held there (a
        loop never has; nor a road it cannot drive)."""
        drive = self._drive
        return drive is not None and not self.loop and tau >= drive.duration

    @property
    def vertices(self) -> tuple[tuple[float, float], ...]:
        """The points driven through, repeats skipped (a loop's closed on its first);
        ``vertex_holds`` and ``vertex_speeds`` are indexed by them."""
        return self._nodes

    @property
    def arrivals(self) -> tuple[float, ...]:
        """When each vertex is first reached, before its hold (empty: a route that stands)."""
        if self._drive is None:
            return ()
        arrivals = self._drive.arrivals
        return tuple(a for k, a in enumerate(arrivals) if k not in self._own)

    def with_speed_from(
        self, tau: float, speed: float, now: float | None = None
    ) -> tuple[Polyline, float]:
        """The same road driven at ``speed`` from where it is at drive time ``tau`` until
        its next speed mark, and the drive time of that place and moment on it.

        ArduRover's DO_CHANGE_SPEED command (``AR_WPNav::set_speed_max``) sets the speed
        its waypoint navigation drives at until the mission's next DO_CHANGE_SPEED, or
        until it enters AUTO again (``AR_WPNav::init``: WP_SPEED). A loop without speed
        marks keeps it every lap. Any speed told before is replaced. ``now`` is the
        rover's speed then (None: its drive's), from which it changes at its accel: so
        its own plan's speed there, told, is the plan entered at the rover's speed.
        """
        base = self.as_planned()
        drive = base._drive
        if drive is None or not math.isfinite(tau):
            return self, tau
        laps, arc, held = self._place(tau)
        at = bisect.bisect_left(base._cumulative, arc - 1e-6)
        on = at < len(base._cumulative) and abs(base._cumulative[at] - arc) <= 1e-6
        if base.loop and at == len(base._nodes) - 1:
            at = 0  # (a lap's end is its start)
        if on and at in base.vertex_speeds:  # (at a speed mark: its own comes as it leaves)
            speed = base.vertex_speeds[at]
        here = math.hypot(*self.velocity(tau)) if now is None else now
        told = replace(base, told=(arc, speed, here))
        drive, k = told._drive, told._told_at
        if drive is not None and k is not None:  # (there, at its speed then)
            return told, laps * drive.duration + drive.arrivals[k] + held
        return told, told._moment(laps, arc, held)

    def planned_speed(self, tau: float) -> float:
        """The speed its plan sets for where it is at drive time ``tau`` (its last speed
        mark's, else ``speed``), told or not."""
        if self._drive is None:
            return self.speed
        _, arc, _ = self._place(tau)
        j = bisect.bisect_right(self._cumulative, arc + 1e-6) - 1
        marks = [k for k in self.vertex_speeds if k <= j]
        return self.vertex_speeds[max(marks)] if marks else self.speed

    def as_planned(self) -> Polyline:
        """The road without a speed its operator told (``with_speed_from``)."""
        return self if self.told is None else replace(self, told=None)

    def told_until(self, tau: float) -> float:
        """The drive time, ``tau`` or after, at which a told speed gives way to the next
        speed mark (inf: it never does)."""
        drive, end = self._drive, self._told_end
        if drive is None or end is None or self.told is None:
            return math.inf
        at = drive.arrivals[end]
        if not self.loop:
            return at if at >= tau else math.inf
        lap = math.floor((tau - at) / drive.duration) + 1 if tau > at else 0
        return at + lap * drive.duration

    def after_told(self) -> Polyline:
        """The road as driven once a told speed gives way: as planned, but a loop with
        no speed marks, which keeps the told speed every lap."""
        base = self.as_planned()
        if self.told is not None and self.loop and not self.vertex_speeds:
            return replace(base, speed=self.told[1])
        return base

    def moment_on(self, other: Polyline, tau: float) -> float:
        """The drive time on ``other`` (the same road, other speeds) of the place and
        moment this drive is at at drive time ``tau``: the lap, the arc, and how long it
        has stood there."""
        if self._drive is None or other._drive is None:
            return tau
        return other._moment(*self._place(tau))

    def _place(self, tau: float) -> tuple[int, float, float]:
        """(laps done, arc length within the lap, seconds into a stand there) at drive
        time ``tau``."""
        drive = self._drive
        assert drive is not None
        laps = 0
        if drive.loop and tau > 0.0:
            laps = math.floor(tau / drive.duration)
            tau -= laps * drive.duration
        arc, speed = drive.at(tau)
        began = drive.hold_began(tau)
        return laps, arc, (tau - began) if speed == 0.0 and tau > 0.0 else 0.0

    def _moment(self, laps: int, arc: float, held: float) -> float:
        """The drive time at ``arc`` in lap ``laps``, ``held`` s into a stand there."""
        drive = self._drive
        assert drive is not None
        return laps * drive.duration + drive.time_at(arc) + held

    def hold_began(self, t: float) -> float:
        """When the hold stood at ``t`` began (``t`` if none is): where a rover that its
        operator held during a waypoint's hold starts it again, back in AUTO."""
        return t if self._drive is None else self._drive.hold_began(t)

    def _locate(self, t: float) -> tuple[int, float, float] | None:
        """Segment index, distance along it and speed at ``t``; None when standing still
        at the start or the end."""
        drive = self._drive
        if t <= 0.0 or drive is None or (not self.loop and t >= drive.duration):
            return None
        s, v = drive.at(t)
        cumulative = self._cumulative
        i = min(bisect.bisect_right(cumulative, s) - 1, len(cumulative) - 2)
        return i, s - cumulative[i], v

    def position(self, t: float) -> tuple[float, float]:
        """Where the vehicle is: the first point before ``t = 0``, the last after the end."""
        where = self._locate(t)
        if where is None:
            ended = t > 0.0 and self._drive is not None and not self.loop
            return self._nodes[-1] if ended else self._nodes[0]
        i, along, _ = where
        (n0, e0), (n1, e1) = self._nodes[i], self._nodes[i + 1]
        f = along / (self._cumulative[i + 1] - self._cumulative[i])
        return n0 + f * (n1 - n0), e0 + f * (e1 - e0)

    def velocity(self, t: float) -> tuple[float, float]:
        """Along the current leg at the drive's speed; zero before the start, at a hold
        and after the end."""
        where = self._locate(t)
        if where is None:
            return 0.0, 0.0
        i, _, v = where
        (n0, e0), (n1, e1) = self._nodes[i], self._nodes[i + 1]
        f = v / (self._cumulative[i + 1] - self._cumulative[i])
        return f * (n1 - n0), f * (e1 - e0)


def _marks(
    name: str,
    marks: tuple[tuple[int, float], ...],
    node_of: list[int],
    valid: Callable[[float], bool],
) -> dict[int, float]:
    """``(point index, value)`` pairs by vertex, each checked (the error names the entry)."""
    out: dict[int, float] = {}
    for k, mark in enumerate(marks):
        try:
            index, value = int(mark[0]), float(mark[1])
        except (TypeError, ValueError, IndexError):
            raise ValueError(
                f"Polyline.{name}[{k}] must be (point index, number), got {mark!r}"
            ) from None
        if index != mark[0] or not 0 <= index < len(node_of):
            raise ValueError(f"Polyline.{name}[{k}]: no point {mark[0]!r} (0..{len(node_of) - 1})")
        if not (math.isfinite(value) and valid(value)):
            raise ValueError(f"Polyline.{name}[{k}]: {value!r} is out of range")
        if node_of[index] in out:
            raise ValueError(f"Polyline.{name}[{k}]: point {index} is given twice")
        out[node_of[index]] = value
    return out


def _drive(
    nodes: list[tuple[float, float]],
    cumulative: list[float],
    line: Polyline,
    holds: dict[int, float],
    speeds: dict[int, float],
) -> tuple[DriveProfile, tuple[int, ...], int | None, int | None]:
    """The drive over the vertices: each leg's speed (the last set before it), each
    corner's least speed (its turn), each hold; and a speed told (``line.told``): from
    a vertex of the drive's own at its arc (unless one is there), passed at the speed it
    had (braked after it when the speed told is lower), to the next speed mark (on a loop
    with none, to its next vertex: ``after_told`` keeps it every lap). With the drive's
    indices of its own vertices, of the one told at, and of the mark (None: never)."""
    n = len(nodes)
    legs, speed = [], line.speed
    for j in range(n - 1):
        speed = speeds.get(j, speed)
        legs.append(speed)
    accel = line.accel if line.accel > 0.0 else math.inf
    ramps = Ramps(accel, line.jerk if line.jerk > 0.0 else accel)
    corners = [math.inf] * n
    for j in range(n):
        a, b = (j - 1, j) if 0 < j < n - 1 else (n - 2, 0) if line.loop and n > 2 else (-1, -1)
        if a >= 0:
            turn = _heading(nodes[b], nodes[b + 1]) - _heading(nodes[a], nodes[a + 1])
            turn = (turn + math.pi) % (2.0 * math.pi) - math.pi
            leg = min(cumulative[a + 1] - cumulative[a], cumulative[b + 1] - cumulative[b])
            corners[j] = corner_speed(turn, ramps, line.wp_radius, leg)
    stands = [holds.get(0 if line.loop and j == n - 1 else j, 0.0) for j in range(n)]
    arcs, marks = list(cumulative), set(speeds)
    inserted: list[int] = []
    entered: tuple[int, ...] = ()
    end = None
    if line.told is not None:
        arc, pace, now = line.told
        i = bisect.bisect_right(arcs, arc + 1e-6) - 1  # (the vertex at it, or before it)
        if i >= n - 1:  # (at the end: a loop's is its start)
            i = 0 if line.loop else n - 1
        k = i  # (the vertex it is told at: one of its own mid-leg, passed at its speed now)
        if i < n - 1 and arc - arcs[i] > 1e-6:
            k = i + 1
            _split(arcs, legs, corners, stands, k, arc, now)
            marks = {j + (j > i) for j in marks}
            inserted.append(k)
        else:
            corners[k] = min(corners[k], now)
        entered = (k, len(arcs) - 1) if line.loop and k == 0 else (k,)
        ends = [j for j in sorted(marks) if j > k]
        for j in range(k, ends[0] if ends else len(legs)):
            legs[j] = pace
        if not ends and line.loop and marks:  # (on into the next lap, to its first mark)
            first = min(marks)
            for j in range(first):
                legs[j] = pace
            ends = [first]
        elif line.loop and not marks:  # (every lap: from its next vertex, ``after_told``)
            ends = [k + 1]
        if k > 0 or line.loop:  # (however fast it was planned to come, it comes at its speed)
            legs[k - 1] = max(legs[k - 1], now)
        end = ends[0] if ends else None
    profile = DriveProfile.plan(
        arcs, legs, corners=corners, holds=stands, ramps=ramps, loop=line.loop, entered=entered
    )
    return profile, tuple(inserted), entered[0] if entered else None, end


def _split(
    arcs: list[float],
    legs: list[float],
    corners: list[float],
    stands: list[float],
    at: int,
    arc: float,
    cap: float,
) -> None:
    """A vertex of the drive's own at ``arc`` (index ``at``): no turn, no hold, passed
    no faster than ``cap``; the leg it splits keeps its speed on both sides."""
    arcs.insert(at, arc)
    legs.insert(at, legs[at - 1])
    corners.insert(at, cap)
    stands.insert(at, 0.0)


def _heading(a: tuple[float, float], b: tuple[float, float]) -> float:
    return math.atan2(b[1] - a[1], b[0] - a[0])


@dataclass(frozen=True, slots=True)
class Track:
    """A recorded trajectory: linear interpolation between samples, ends held.

    Args:
        times: Strictly increasing sim times (s).
        norths: World north of each sample (m).
        easts: World east of each sample (m).
    """

    times: tuple[float, ...]
    norths: tuple[float, ...]
    easts: tuple[float, ...]

    def __post_init__(self) -> None:
        for name in ("times", "norths", "easts"):
            values = tuple(float(v) for v in getattr(self, name))
            for i, v in enumerate(values):
                if not math.isfinite(v):
                    raise ValueError(f"Track.{name}[{i}] must be finite, got {v!r}")
            object.__setattr__(self, name, values)
        if not self.times:
            raise ValueError("Track needs at least one sample")
        if not len(self.times) == len(self.norths) == len(self.easts):
            raise ValueError(
                "Track.times, norths and easts must have the same length, got "
                f"{len(self.times)}, {len(self.norths)}, {len(self.easts)}"
            )
        for i in range(1, len(self.times)):
            if self.times[i] <= self.times[i - 1]:
                raise ValueError(
                    f"Track.times must increase strictly: times[{i}] = {self.times[i]!r} "
                    f"after {self.times[i - 1]!r}"
                )

    def _segment(self, t: float) -> int:
        """Index i with times[i] <= t < times[i+1], or -1 outside the samples."""
        times = self.times
        if t < times[0] or t >= times[-1]:
            return -1
        return bisect.bisect_right(times, t) - 1

    def position(self, t: float) -> tuple[float, float]:
        """Interpolated position; the first/last sample outside the recorded span."""
        i = self._segment(t)
        if i < 0:
            j = 0 if t < self.times[0] else -1
            return self.norths[j], self.easts[j]
        f = (t - self.times[i]) / (self.times[i + 1] - self.times[i])
        n = self.norths[i] + f * (self.norths[i + 1] - self.norths[i])
        e = self.easts[i] + f * (self.easts[i + 1] - self.easts[i])
        return n, e

    def velocity(self, t: float) -> tuple[float, float]:
        """Velocity of the current interval; zero outside the recorded span."""
        i = self._segment(t)
        if i < 0:
            return 0.0, 0.0
        span = self.times[i + 1] - self.times[i]
        return (
            (self.norths[i + 1] - self.norths[i]) / span,
            (self.easts[i + 1] - self.easts[i]) / span,
        )


def track_from_geo(track: GeoTrack, frame: LocalFrame) -> Track:
    """A recorded :class:`~convoy_mav.tracks.GeoTrack` in the mock's world frame.

    Times are kept as they are: they are sim times (rebase the track first to
    start it at ``t = 0``).
    """
    norths, easts = track.in_frame(frame)
    return Track(track.times, norths, easts)


def load_csv_track(path: str | os.PathLike[str], frame: LocalFrame) -> Track:
    """Read a recorded convoy track from CSV into the mock's world frame.

    Rows are ``time,lat,lon`` (seconds of sim time, WGS-84 degrees); the format
    (header, comments, extra columns) is :func:`convoy_mav.tracks.parse_csv_track`'s.

    Args:
        path: The CSV file.
        frame: The mock's world frame; positions are returned as its north/east.

    Returns:
        The track, interpolated linearly between rows.

    Raises:
        ValueError: A row is malformed or out of order; the message gives file and line.
        OSError: The file cannot be read.
    """
    name = os.fspath(path)
    with open(name, newline="", encoding="utf-8-sig") as handle:
        return track_from_geo(parse_csv_track(handle, name), frame)
