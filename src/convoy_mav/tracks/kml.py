"""KML and KMZ routes: a path drawn in Google Earth or QGroundControl, as a route.

Ground-station and map users keep roads as KML: QGroundControl imports and exports
polylines as KML, Google Earth saves a drawn path as a ``<LineString>`` (``.kml``,
or zipped with its icons as ``.kmz``). A route is the one ``<LineString>``'s
``<coordinates>`` (``lon,lat[,alt]`` tuples separated by white space, KML's
order), or a ``<gx:Track>``'s ``<gx:coord>`` (``lon lat alt``). More than one
path is refused with the count, as nothing says which the convoy will drive.
Parsed with expat, as GPX is, so an error names its line; pure but for
:func:`kmz_document`, which takes the zipped bytes.
"""

from __future__ import annotations

import io
import math
import zipfile
from xml.parsers import expat

from convoy_mav.tracks.geotrack import check_fix

__all__ = ["MAX_KML_BYTES", "kmz_document", "parse_kml_points"]

_PATHS = ("LineString", "Track")  # (gx:Track's local name)


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
                    f"{max_bytes} a route may be"
                )
            return kmz.read(info)  # (no more than file_size is read)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, NotImplementedError, RuntimeError) as e:
        raise ValueError(f"{name}: not a KMZ (zip) file that can be read: {e}") from None


def parse_kml_points(data: bytes | str, name: str) -> tuple[list[float], list[float]]:
    """The route a KML document holds: (lats, lons), in order.

    Raises:
        ValueError: Malformed XML, not KML, no path or more than one, a path of
            under two points, or a coordinate that is not a number or out of range;
            ``file:line:`` first.
    """
    parser = expat.ParserCreate(namespace_separator=" ")
    paths: list[tuple[int, list[tuple[float, float]]]] = []  # (line, points)
    stack: list[str] = []
    text: list[str] | None = None
    text_line = 0

    def start(tag: str, attrs: dict[str, str]) -> None:
        nonlocal text, text_line
        local = tag.rpartition(" ")[2]
        if not stack and local != "kml":
            raise ValueError(f"{name}:1: the root element is <{local}>, not <kml>")
        if local in _PATHS:
            paths.append((parser.CurrentLineNumber, []))
        elif (local == "coordinates" and stack and stack[-1] == "LineString") or (
            local == "coord" and stack and stack[-1] == "Track"
        ):
            text, text_line = [], parser.CurrentLineNumber
        stack.append(local)

    def end(tag: str) -> None:
        nonlocal text
        local = stack.pop()
        if text is None or local not in ("coordinates", "coord"):
            return
        joined, text = "".join(text), None
        if local == "coord":  # gx:coord: "lon lat alt", one point
            paths[-1][1].append(_point(f"{name}:{text_line}", joined.split()))
            return
        for i, row in enumerate(joined.split("\n")):  # "lon,lat[,alt] lon,lat[,alt] ..."
            where = f"{name}:{text_line + i}"
            paths[-1][1].extend(_point(where, t.split(",")) for t in row.split())

    def chars(data: str) -> None:
        if text is not None:
            text.append(data)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        reason = expat.ErrorString(e.code)
        raise ValueError(f"{name}:{e.lineno}: not well-formed KML: {reason}") from None
    if len(paths) != 1:
        lines = ", ".join(str(line) for line, _ in paths)
        raise ValueError(
            f"{name}: a route is one <LineString> or <gx:Track>, found {len(paths)}"
            + (f" (lines {lines}); keep the road the convoy will drive" if paths else "")
        )
    line, points = paths[0]
    if len(points) < 2:
        raise ValueError(f"{name}:{line}: a route needs two points or more, got {len(points)}")
    return [p[0] for p in points], [p[1] for p in points]


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
