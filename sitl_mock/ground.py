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
import csv
import itertools
import math
import os
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

from convoy_mav.geo import GeoPoint, LocalFrame

__all__ = [
    "Polyline",
    "Route",
    "Stationary",
    "StraightLine",
    "Track",
    "load_csv_track",
]


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
class Polyline:
    """Drive through ``points`` at constant ``speed`` from ``t = 0``.

    Without ``loop`` the vehicle stops at the last point; with it, it drives back to
    the first one and starts over. Repeated consecutive points are skipped.
    """

    points: tuple[tuple[float, float], ...]
    speed: float
    loop: bool = False
    _nodes: tuple[tuple[float, float], ...] = field(init=False, repr=False, compare=False)
    _cumulative: tuple[float, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.points:
            raise ValueError("Polyline.points must hold at least one point")
        _check_finite("Polyline", "speed", self.speed)
        if self.speed < 0.0:
            raise ValueError(f"Polyline.speed must be >= 0, got {self.speed!r}")
        nodes: list[tuple[float, float]] = []
        for i, point in enumerate(self.points):
            if len(point) != 2 or not all(math.isfinite(c) for c in point):
                raise ValueError(f"Polyline.points[{i}] must be two finite numbers, got {point!r}")
            node = (float(point[0]), float(point[1]))
            if not nodes or node != nodes[-1]:
                nodes.append(node)
        if self.loop and len(nodes) > 1 and nodes[-1] != nodes[0]:
            nodes.append(nodes[0])
        cumulative = [0.0]
        for (n0, e0), (n1, e1) in itertools.pairwise(nodes):
            cumulative.append(cumulative[-1] + math.hypot(n1 - n0, e1 - e0))
        object.__setattr__(self, "_nodes", tuple(nodes))
        object.__setattr__(self, "_cumulative", tuple(cumulative))

    @property
    def length(self) -> float:
        """Length of one pass (with the closing leg when looping), metres."""
        return self._cumulative[-1]

    def _locate(self, t: float) -> tuple[int, float] | None:
        """Segment index and distance along it at time ``t``; None when standing still."""
        total = self._cumulative[-1]
        if t <= 0.0 or total == 0.0 or self.speed == 0.0:
            return None
        s = self.speed * t
        if self.loop:
            s %= total
        elif s >= total:
            return None
        i = bisect.bisect_right(self._cumulative, s) - 1
        return i, s - self._cumulative[i]

    def position(self, t: float) -> tuple[float, float]:
        """Where the vehicle is: the first point before ``t = 0``, the last after the end."""
        where = self._locate(t)
        if where is None:
            ended = t > 0.0 and self.speed > 0.0 and not self.loop
            return self._nodes[-1] if ended else self._nodes[0]
        i, along = where
        (n0, e0), (n1, e1) = self._nodes[i], self._nodes[i + 1]
        f = along / (self._cumulative[i + 1] - self._cumulative[i])
        return n0 + f * (n1 - n0), e0 + f * (e1 - e0)

    def velocity(self, t: float) -> tuple[float, float]:
        """Along the current leg at ``speed``; zero before the start and after the end."""
        where = self._locate(t)
        if where is None:
            return 0.0, 0.0
        i = where[0]
        (n0, e0), (n1, e1) = self._nodes[i], self._nodes[i + 1]
        f = self.speed / (self._cumulative[i + 1] - self._cumulative[i])
        return f * (n1 - n0), f * (e1 - e0)


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


_COLUMN_NAMES = {
    "time": "time",
    "t": "time",
    "lat": "lat",
    "latitude": "lat",
    "lon": "lon",
    "lng": "lon",
    "longitude": "lon",
}


def load_csv_track(path: str | os.PathLike[str], frame: LocalFrame) -> Track:
    """Read a recorded convoy track from CSV into the mock's world frame.

    Rows are ``time,lat,lon`` (seconds of sim time, WGS-84 degrees); extra columns
    are ignored. A first row that is not numeric is a header naming the columns
    (``time``/``t``, ``lat``/``latitude``, ``lon``/``lng``/``longitude``, any order).
    Blank lines and lines starting with ``#`` are skipped.

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
    times: list[float] = []
    norths: list[float] = []
    easts: list[float] = []
    columns = (0, 1, 2)
    seen_row = False
    with open(name, newline="", encoding="utf-8") as handle:
        for lineno, row in enumerate(csv.reader(handle), start=1):
            cells = [c.strip() for c in row]
            if not any(cells) or cells[0].startswith("#"):
                continue
            if not seen_row:
                seen_row = True
                if not _is_number(cells[0]):
                    columns = _header_columns(cells, name, lineno)
                    continue
            if len(cells) <= max(columns):
                raise ValueError(
                    f"{name}:{lineno}: expected columns time,lat,lon, got {len(cells)} field(s)"
                )
            try:
                t, lat, lon = (float(cells[i]) for i in columns)
            except ValueError:
                raise ValueError(
                    f"{name}:{lineno}: time, lat and lon must be numbers, got "
                    f"{', '.join(repr(cells[i]) for i in columns)}"
                ) from None
            if not all(math.isfinite(v) for v in (t, lat, lon)):
                raise ValueError(f"{name}:{lineno}: time, lat and lon must be finite")
            if not -90.0 <= lat <= 90.0:
                raise ValueError(f"{name}:{lineno}: latitude {lat!r} outside [-90, 90]")
            if not -180.0 <= lon <= 180.0:
                raise ValueError(f"{name}:{lineno}: longitude {lon!r} outside [-180, 180]")
            if times and t <= times[-1]:
                raise ValueError(
                    f"{name}:{lineno}: time {t!r} does not increase (previous {times[-1]!r})"
                )
            n, e, _ = frame.to_ned(GeoPoint(lat, lon))
            times.append(t)
            norths.append(n)
            easts.append(e)
    if not times:
        raise ValueError(f"{name}: no data rows (expected time,lat,lon)")
    return Track(tuple(times), tuple(norths), tuple(easts))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _header_columns(cells: list[str], name: str, lineno: int) -> tuple[int, int, int]:
    found: dict[str, int] = {}
    for i, cell in enumerate(cells):
        key = _COLUMN_NAMES.get(cell.lower())
        if key is not None and key not in found:
            found[key] = i
    missing = [k for k in ("time", "lat", "lon") if k not in found]
    if missing:
        raise ValueError(
            f"{name}:{lineno}: header {cells!r} lacks column(s) {', '.join(missing)} "
            "(expected time,lat,lon)"
        )
    return found["time"], found["lat"], found["lon"]
