"""GPX 1.0/1.1 convoy tracks: ``<trkpt>`` (or ``<rtept>``) with ``<time>``."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import BinaryIO
from xml.parsers import expat

from convoy_mav.tracks.geotrack import GeoTrack, check_fix, iso_seconds
from convoy_mav.tracks.xmlfeed import feed_xml

__all__ = ["parse_gpx_track"]


@dataclass(slots=True)
class _GpxPoint:
    kind: str  # "trkpt" or "rtept"
    number: int  # 1-based among points of its kind
    line: int
    lat: str | None
    lon: str | None
    time: str | None = None


def parse_gpx_points(data: bytes | str | BinaryIO, name: str) -> tuple[list[float], list[float]]:
    """A route's points: the ``<trkpt>`` of a GPX file, else its ``<rtept>``; times ignored.

    Raises:
        ValueError: As :func:`parse_gpx_track`, but a point needs no ``<time>``.
    """
    lats: list[float] = []
    lons: list[float] = []
    for p in _gpx_points(data, name):
        lat, lon = _latlon(p, name)
        lats.append(lat)
        lons.append(lon)
    return lats, lons


def _latlon(p: _GpxPoint, name: str) -> tuple[float, float]:
    """A point's checked coordinates (``file:line:`` in the error)."""
    where, what = f"{name}:{p.line}", f"{p.kind} #{p.number}"
    lat = _gpx_coordinate(where, what, "lat", p.lat)
    lon = _gpx_coordinate(where, what, "lon", p.lon)
    check_fix(where, lat, lon)
    return lat, lon


def parse_gpx_track(data: bytes | str | BinaryIO, name: str) -> GeoTrack:
    """Parse a GPX 1.0/1.1 file: its ``<trkpt>`` (all tracks and segments, in order).

    Without any ``<trkpt>`` the ``<rtept>`` of its routes are used, which must then
    carry times too. Namespaces are matched by local name, so GPX 1.0, 1.1 and
    un-namespaced files read alike; ``<time>`` is ISO-8601 (``Z`` or an offset;
    none means UTC). Parsed with expat, the parser ``xml.etree`` itself uses,
    because expat reports the line of each point for error messages; a file
    object is parsed as it is read (a long drive is never held whole).

    Returns:
        The track, times in POSIX seconds (not rebased).

    Raises:
        ValueError: Malformed XML, no points, a point without ``lat``/``lon``, or
            fewer than two with a ``<time>``; ``file:line:`` first. Points without a
            time among timed ones, and repeated, backward and spiking fixes, are
            dropped or merged and counted (``GeoTrack.cleaning``), not refused.
    """
    chosen = _gpx_points(data, name)
    times: list[float] = []
    lats: list[float] = []
    lons: list[float] = []
    untimed: _GpxPoint | None = None  # the first point without a time
    for p in chosen:
        lat, lon = _latlon(p, name)
        where, what = f"{name}:{p.line}", f"{p.kind} #{p.number}"
        if p.time is None:
            untimed = untimed or p
            continue
        times.append(_iso_seconds(where, what, p.time))
        lats.append(lat)
        lons.append(lon)
    if untimed is not None and len(times) < 2:
        raise ValueError(
            f"{name}:{untimed.line}: {untimed.kind} #{untimed.number} has no <time>: replaying "
            "a track needs when the convoy was at each point"
            + ("" if times else " (no point has one; as a route it needs none)")
        )
    dropped = len(chosen) - len(times)
    return GeoTrack.from_fixes(times, lats, lons, name, "gpx", untimed=dropped)


def _gpx_points(data: bytes | str | BinaryIO, name: str) -> list[_GpxPoint]:
    """The ``<trkpt>`` of a GPX file (else its ``<rtept>``), with their lines."""
    parser = expat.ParserCreate(namespace_separator=" ")
    points: list[_GpxPoint] = []
    counts = {"trkpt": 0, "rtept": 0}
    stack: list[str] = []
    text: list[str] | None = None
    root: list[str] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal text
        local = tag.rpartition(" ")[2]
        if not stack:
            root.append(local)
        if local in counts:
            counts[local] += 1
            line = parser.CurrentLineNumber
            points.append(_GpxPoint(local, counts[local], line, attrs.get("lat"), attrs.get("lon")))
        elif local == "time" and stack and stack[-1] in counts:
            text = []
        stack.append(local)

    def end(tag: str) -> None:
        nonlocal text
        stack.pop()
        if text is not None and tag.rpartition(" ")[2] == "time":
            points[-1].time = "".join(text).strip()
            text = None

    def chars(data: str) -> None:
        if text is not None:
            text.append(data)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    feed_xml(parser, data, name, "GPX")
    if root and root[0] != "gpx":
        raise ValueError(f"{name}:1: the root element is <{root[0]}>, not <gpx>")
    kind = "trkpt" if counts["trkpt"] else "rtept"
    chosen = [p for p in points if p.kind == kind]
    if not chosen:
        raise ValueError(f"{name}: no <trkpt> or <rtept> points")
    return chosen


def _gpx_coordinate(where: str, what: str, attr: str, value: str | None) -> float:
    if value is None:
        raise ValueError(f"{where}: {what} has no {attr} attribute")
    try:
        x = float(value)
    except ValueError:
        raise ValueError(f"{where}: {what} {attr}={value!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"{where}: {what} {attr}={value!r} must be finite")
    return x


def _iso_seconds(where: str, what: str, text: str) -> float:
    seconds = iso_seconds(text)
    if seconds is None:
        raise ValueError(f"{where}: {what} time {text!r} is not ISO-8601")
    return seconds
