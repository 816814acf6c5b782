"""Recorded convoy tracks: CSV, GPX, KML and tlog files -> one :class:`GeoTrack` value.

``convoy-mav replay`` drives the mock's ground vehicles along a track recorded
elsewhere; the mock's ``csv`` ground route reads the same CSV format. Four
formats, one value (times + WGS-84 samples):

    CSV   ``time,lat,lon`` rows (degrees; seconds, POSIX milliseconds or ISO-8601),
          optional header naming the columns in any order as exporters do, comma,
          semicolon or tab, ``#`` comments (:func:`parse_csv_track`).
    GPX   1.0/1.1 ``<trkpt lat lon><time>ISO-8601</time>``, or ``<rtept>`` when
          there is no ``<trkpt>``; points without a time among timed ones are dropped
          and counted (:func:`parse_gpx_track`).
    KML   one ``<gx:Track>`` (``<when>`` and ``<gx:coord>`` pairs), or a KMZ holding it
          (:func:`parse_kml_track`).
    tlog  The ground vehicles' GLOBAL_POSITION_INT in a MAVLink telemetry log,
          the convoy being their centroid (:func:`parse_tlog_track`).

Design rules:
    * Parsing is pure: the ``parse_*`` functions take text or bytes and a name for
      messages; :func:`load_track` alone opens a file.
    * Bad input is a ``ValueError`` whose message starts with ``file:line:`` (CSV,
      GPX) or ``file: message #N:`` (tlog) and says what is wrong. What real
      receivers record is not bad input: fixes sharing a time stamp are merged,
      backward stamps and single-fix spikes dropped, each counted in
      ``GeoTrack.cleaning`` (:mod:`convoy_mav.tracks.cleaning`); nothing else is
      guessed or dropped.
    * Parsers keep the source's clock (CSV seconds, POSIX seconds, vehicle boot
      seconds); :meth:`GeoTrack.rebased` (done by :func:`load_track`) starts it at 0.
"""

from __future__ import annotations

import contextlib
import mmap
import os
from collections.abc import Collection, Iterator
from typing import BinaryIO, Literal

from convoy_mav.tracks.csvfile import parse_csv_points, parse_csv_track
from convoy_mav.tracks.geotrack import GeoTrack, TrackSpeeds, track_speeds
from convoy_mav.tracks.gpx import parse_gpx_points, parse_gpx_track
from convoy_mav.tracks.kml import is_zip, kmz_document, parse_kml_points, parse_kml_track
from convoy_mav.tracks.missionfile import WPL_HEADER, parse_plan, parse_waypoints
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.tracks.routejson import parse_route_json
from convoy_mav.tracks.tlog import parse_tlog_track

__all__ = [
    "FORMATS",
    "GeoTrack",
    "TrackFormat",
    "TrackSpeeds",
    "format_of",
    "load_planned_route",
    "load_route",
    "load_track",
    "parse_csv_track",
    "parse_gpx_track",
    "parse_tlog_track",
    "track_speeds",
]

TrackFormat = Literal["csv", "gpx", "kml", "tlog"]
FORMATS: tuple[TrackFormat, ...] = ("csv", "gpx", "kml", "tlog")


def format_of(path: str | os.PathLike[str]) -> TrackFormat:
    """The track format a file name's extension says.

    Raises:
        ValueError: An extension other than ``.csv``, ``.gpx`` or ``.tlog``.
    """
    name = os.fspath(path)
    ext = os.path.splitext(name)[1].lower().lstrip(".")
    if ext == "kmz":
        return "kml"  # (zipped: read either way)
    for fmt in FORMATS:
        if ext == fmt:
            return fmt
    raise ValueError(
        f"{name}: cannot tell the track format from the extension {ext or '(none)'!r}; "
        "expected .csv, .gpx, .kml/.kmz or .tlog (or name the format)"
    )


MAX_TRACK_BYTES = 512 << 20
"""Largest track or route file read (512 MiB: days of tlog): bigger is refused unread.
Files are streamed (CSV by line, GPX by expat in chunks, tlog memory-mapped): what is
kept is the fixes, not the file."""


@contextlib.contextmanager
def _mapped(handle: BinaryIO) -> Iterator[bytes | mmap.mmap]:
    """A read-only map of the file (an empty file cannot be mapped: it is no bytes)."""
    if os.fstat(handle.fileno()).st_size == 0:
        yield b""
        return
    with mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as data:
        yield data


def _check_size(name: str) -> None:
    size = os.path.getsize(name)
    if size > MAX_TRACK_BYTES:
        raise ValueError(
            f"{name}: {size / (1 << 20):.0f} MiB exceeds the {MAX_TRACK_BYTES >> 20} MiB a "
            "track may be (cut it to the drive to replay)"
        )


def load_route(path: str | os.PathLike[str]) -> tuple[list[float], list[float]]:
    """Read a route, the road a convoy will drive: (lats, lons), in order, times ignored
    (:func:`load_planned_route`'s points).

    Raises:
        ValueError: A malformed file, or one that is no route's format.
        OSError: The file cannot be read.
    """
    points = load_planned_route(path).points
    return [p[0] for p in points], [p[1] for p in points]


def load_planned_route(path: str | os.PathLike[str]) -> PlannedRoute:
    """Read a route, and the convoy's plan on it where the file can carry one.

    A rover's mission as a ground station saves it: QGroundControl's ``.plan``, or a
    ``.waypoints`` (``.txt``) file in QGC WPL 110 (Mission Planner, MAVProxy;
    ``tracks.missionfile``): the waypoints it drives, with its holds, speeds and laps.
    JSON (``.geojson``/``.json``: a GeoJSON LineString as map tools export it, or
    ``{"points": [[lat, lon], ...]}``, the MQTT route's forms, with a plan if it has
    one: ``tracks.routejson``). The road alone: GPX ``<trkpt>`` or ``<rtept>`` (no
    ``<time>`` needed), CSV ``lat,lon[,time]``, or KML/KMZ (one ``<LineString>`` or
    ``<gx:Track>``, ``tracks.kml``).

    Raises:
        ValueError: A malformed file, or one that is not a mission, GPX, CSV, JSON or KML.
        OSError: The file cannot be read.
    """
    name = os.fspath(path)
    ext = os.path.splitext(name)[1].lower()
    if ext in (".plan", ".waypoints", ".geojson", ".json", ".kml", ".kmz") or (
        ext == ".txt" and _is_waypoints(name)
    ):
        _check_size(name)
        with open(name, "rb") as handle:
            data = handle.read()
        if ext == ".plan":
            return parse_plan(data, name)
        if ext in (".geojson", ".json"):
            return parse_route_json(data, name)
        if ext in (".kml", ".kmz"):
            return _road_only(*parse_kml_points(_kml_bytes(data, name), name))
        return parse_waypoints(data.decode("utf-8-sig", errors="replace"), name)
    kind = format_of(name)
    if kind not in ("csv", "gpx"):
        raise ValueError(
            f"{name}: a route is a .gpx, .csv, .geojson, .kml/.kmz, .plan or .waypoints "
            f"file, not a {kind}"
        )
    _check_size(name)
    if kind == "csv":
        with open(name, newline="", encoding="utf-8-sig") as handle:
            return _road_only(*parse_csv_points(handle, name))
    with open(name, "rb") as binary:
        return _road_only(*parse_gpx_points(binary, name))


def _road_only(lats: list[float], lons: list[float]) -> PlannedRoute:
    return PlannedRoute(tuple(zip(lats, lons, strict=True)))


def _is_waypoints(name: str) -> bool:
    """A ``.txt`` that is a waypoints file (MAVProxy saves them so): by its first line."""
    with open(name, "rb") as handle:
        return handle.read(len(WPL_HEADER)).decode("ascii", errors="replace") == WPL_HEADER


def _kml_bytes(data: bytes, name: str) -> bytes:
    """A KML document's bytes, unzipped when they are a KMZ's (by name or signature)."""
    return kmz_document(data, name) if name.lower().endswith(".kmz") or is_zip(data) else data


def load_track(
    path: str | os.PathLike[str],
    fmt: TrackFormat | None = None,
    *,
    sysids: Collection[int] = (),
) -> GeoTrack:
    """Read a recorded convoy track, times rebased to start at 0.

    Args:
        path: A CSV, GPX, KML/KMZ or tlog file.
        fmt: Its format (default: from the extension, see :func:`format_of`).
        sysids: tlog only: the convoy's vehicles (default: every ground rover).

    Raises:
        ValueError: The file is malformed or holds no usable track; the message
            names the file and the line (message number for a tlog).
        OSError: The file cannot be read.
    """
    name = os.fspath(path)
    kind = fmt or format_of(name)
    if sysids and kind != "tlog":
        raise ValueError(f"{name}: vehicle system ids only apply to a tlog, not a {kind} track")
    _check_size(name)
    if kind == "csv":
        with open(name, newline="", encoding="utf-8-sig") as handle:
            track = parse_csv_track(handle, name)
    elif kind == "gpx":
        with open(name, "rb") as binary:
            track = parse_gpx_track(binary, name)
    elif kind == "kml":
        with open(name, "rb") as binary:
            track = parse_kml_track(_kml_bytes(binary.read(), name), name)
    else:  # (mapped, not read: the pages a tlog's records are decoded from come and go)
        with open(name, "rb") as binary, _mapped(binary) as data:
            track = parse_tlog_track(data, name, sysids=sysids)
    return track.rebased()
