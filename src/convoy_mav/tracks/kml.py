"""KML and KMZ: a path drawn in Google Earth or QGroundControl, or a logged drive.

Ground-station and map users keep roads as KML: QGroundControl imports and exports
polylines as KML, Google Earth saves a drawn path as a ``<LineString>`` (``.kml``,
or zipped with its icons as ``.kmz``). A route is the one ``<LineString>``'s
``<coordinates>`` (``lon,lat[,alt]`` tuples separated by white space, KML's
order), or a ``<gx:Track>``'s ``<gx:coord>`` (``lon lat alt``). More than one
path is refused with the count, as nothing says which the convoy will drive.
A recorded track (:func:`parse_kml_track`, ``convoy-mav replay``) is one
``<gx:Track>``, whose ``<when>`` times pair with its ``<gx:coord>`` in order, as
phone loggers and Google Earth write a drive. Parsed with expat, as GPX is, so an
error names its line. Pure: bytes in (:func:`kmz_document` unzips a KMZ's).
"""

from __future__ import annotations

import io
import math
import zipfile
from dataclasses import dataclass, field
from xml.parsers import expat

from convoy_mav.tracks.geotrack import GeoTrack, check_fix, iso_seconds
from convoy_mav.tracks.xmlfeed import feed_xml

__all__ = ["MAX_KML_BYTES", "is_zip", "kmz_document", "parse_kml_points", "parse_kml_track"]

_PATHS = ("LineString", "Track")  # (gx:Track's local name)
_TEXTS = {("LineString", "coordinates"), ("Track", "coord"), ("Track", "when")}


MAX_KML_BYTES = 64 << 20
"""Largest KML document unzipped from a KMZ (a route is kilobytes; a zip bomb is not)."""


def kmz_document(data: bytes, name: str, max_bytes: int = MAX_KML_BYTES) -> bytes:
    """The KML document inside a KMZ: ``doc.kml``, else its first ``.kml`` file.

    Raises:
        ValueError: Not a zip file, one with no ``.kml`` inside, or one whose document
            unzips to more than ``max_bytes``.
    """
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as kmz:
            names = [n for n in kmz.namelist() if n.lower().endswith(".kml")]
            if not names:
                raise ValueError(f"{name}: a KMZ with no .kml document inside")
            info = kmz.getinfo("doc.kml" if "doc.kml" in names else names[0])
            if info.file_size > max_bytes:
                raise ValueError(
                    f"{name}: {info.filename} unzips to {info.file_size} bytes, over the "
                    f"{max_bytes} a KML document may be"
                )
            return kmz.read(info)  # (no more than file_size is read)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, RuntimeError) as e:
        raise ValueError(f"{name}: not a KMZ (zip) file that can be read: {e}") from None


@dataclass
class _Path:
    kind: str  # "LineString" or "Track"
    line: int
    points: list[tuple[float, float]] = field(default_factory=list)
    whens: list[tuple[int, str]] = field(default_factory=list)  # (line, text)


def is_zip(data: bytes) -> bool:
    """Whether ``data`` is a zip file (a KMZ), by its signature."""
    return data[:4] == b"PK\x03\x04"


def parse_kml_points(data: bytes | str, name: str) -> tuple[list[float], list[float]]:
    """The route a KML document holds: (lats, lons), in order.

    Raises:
        ValueError: Malformed XML, not KML, no path or more than one, a path of
            under two points, or a coordinate that is not a number or out of range;
            ``file:line:`` first.
    """
    path = _one(
        _kml_paths(data, name),
        name,
        "a route is one <LineString> or <gx:Track>",
        "keep the road the convoy will drive",
    )
    return [p[0] for p in path.points], [p[1] for p in path.points]


def parse_kml_track(data: bytes | str, name: str) -> GeoTrack:
    """The recorded track a KML document holds: its one ``<gx:Track>``, timed by its
    ``<when>`` (ISO-8601), times not rebased.

    Raises:
        ValueError: As :func:`parse_kml_points`, and a path without times (a
            ``<LineString>`` is a route, not a drive), or ``<when>`` and ``<gx:coord>``
            counts that differ, or a time that is not ISO-8601.
    """
    tracks = [p for p in _kml_paths(data, name) if p.kind == "Track"]
    path = _one(
        tracks,
        name,
        "a recorded track is one <gx:Track> with <when> times",
        "keep the drive to replay",
    )
    if len(path.whens) != len(path.points):
        raise ValueError(
            f"{name}:{path.line}: <gx:Track> has {len(path.whens)} <when> for "
            f"{len(path.points)} <gx:coord>; each point needs its time"
        )
    times = []
    for line, text in path.whens:
        seconds = iso_seconds(text)
        if seconds is None:
            raise ValueError(f"{name}:{line}: <when> {text!r} is not ISO-8601")
        times.append(seconds)
    lats, lons = [p[0] for p in path.points], [p[1] for p in path.points]
    return GeoTrack.from_fixes(times, lats, lons, name, "kml")


def _one(paths: list[_Path], name: str, what: str, keep: str) -> _Path:
    """The one path of ``paths`` (two points or more), else ``what`` was expected, and
    which to ``keep`` when there are several."""
    if len(paths) != 1:
        lines = ", ".join(str(p.line) for p in paths)
        raise ValueError(
            f"{name}: {what}, found {len(paths)}" + (f" (lines {lines}); {keep}" if paths else "")
        )
    path = paths[0]
    if len(path.points) < 2:
        raise ValueError(
            f"{name}:{path.line}: a path needs two points or more, got {len(path.points)}"
        )
    return path


def _kml_paths(data: bytes | str, name: str) -> list[_Path]:
    """Every ``<LineString>`` and ``<gx:Track>`` of a KML document, in order."""
    parser = expat.ParserCreate(namespace_separator=" ")
    paths: list[_Path] = []
    stack: list[str] = []
    text: list[str] | None = None
    text_line = 0

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal text, text_line
        local = tag.rpartition(" ")[2]
        if not stack and local != "kml":
            raise ValueError(f"{name}:1: the root element is <{local}>, not <kml>")
        if local in _PATHS:
            paths.append(_Path(local, parser.CurrentLineNumber))
        elif stack and (stack[-1], local) in _TEXTS:
            text, text_line = [], parser.CurrentLineNumber
        stack.append(local)

    def end(tag: str) -> None:
        nonlocal text
        local = stack.pop()
        if text is None or local not in ("coordinates", "coord", "when"):
            return
        joined, text = "".join(text), None
        path = paths[-1]
        if local == "when":
            path.whens.append((text_line, joined.strip()))
        elif local == "coord":  # gx:coord: "lon lat alt", one point
            path.points.append(_point(f"{name}:{text_line}", joined.split()))
        else:
            for i, row in enumerate(joined.split("\n")):  # "lon,lat[,alt] lon,lat[,alt] ..."
                where = f"{name}:{text_line + i}"
                path.points.extend(_point(where, t.split(",")) for t in row.split())

    def chars(data: str) -> None:
        if text is not None:
            text.append(data)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    feed_xml(parser, data, name, "KML")
    return paths


def _point(where: str, fields: list[str]) -> tuple[float, float]:
    """(lat, lon) of KML's ``lon, lat[, alt]``."""
    if len(fields) < 2:
        raise ValueError(f"{where}: coordinate {','.join(fields)!r} needs lon,lat")
    try:
        lon, lat = float(fields[0]), float(fields[1])
    except ValueError:
        raise ValueError(f"{where}: coordinate {','.join(fields)!r} is not numbers") from None
    if not (math.isfinite(lat) and math.isfinite(lon)):
        raise ValueError(f"{where}: coordinate {','.join(fields)!r} must be finite")
    check_fix(where, lat, lon)
    return lat, lon
