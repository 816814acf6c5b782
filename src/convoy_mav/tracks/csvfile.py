"""CSV convoy tracks: ``time,lat,lon`` rows (also the mock's ``csv`` ground route)."""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Iterator

from convoy_mav.tracks.geotrack import GeoTrack, check_fix

__all__ = ["parse_csv_points", "parse_csv_track"]

_COLUMN_NAMES = {
    "time": "time",
    "t": "time",
    "lat": "lat",
    "latitude": "lat",
    "lon": "lon",
    "lng": "lon",
    "longitude": "lon",
}


def _data_rows(
    lines: Iterable[str], name: str, need: tuple[str, ...]
) -> Iterator[tuple[int, list[str], tuple[int, int, int]]]:
    """Each data row as (line, cells, (time, lat, lon) columns), past comments and a header.

    Without a header the columns are ``need`` in order (a missing time is -1).
    """
    columns = (0, 1, 2) if need[0] == "time" else (-1, 0, 1)
    seen_row = False
    for lineno, row in enumerate(csv.reader(lines), start=1):
        cells = [c.strip() for c in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if not seen_row:
            seen_row = True
            if not _is_number(cells[0]):
                columns = _header_columns(cells, name, lineno, need)
                continue
        if len(cells) <= max(columns):
            raise ValueError(
                f"{name}:{lineno}: expected columns {','.join(need)}, got {len(cells)} field(s)"
            )
        yield lineno, cells, columns


def parse_csv_points(lines: Iterable[str], name: str) -> tuple[list[float], list[float]]:
    """A route's ``lat,lon[,time]`` rows: the path only (any time column is ignored).

    A first row that is not numeric is a header naming the columns, as for tracks
    (``time`` optional). Blank lines and ``#`` comments are skipped.

    Raises:
        ValueError: A malformed row, or none; the message gives file and line.
    """
    lats: list[float] = []
    lons: list[float] = []
    for lineno, cells, columns in _data_rows(lines, name, ("lat", "lon")):
        try:
            lat, lon = (float(cells[i]) for i in columns[1:])
        except ValueError:
            raise ValueError(f"{name}:{lineno}: lat and lon must be numbers") from None
        if not (math.isfinite(lat) and math.isfinite(lon)):
            raise ValueError(f"{name}:{lineno}: lat and lon must be finite")
        check_fix(f"{name}:{lineno}", lat, lon)
        lats.append(lat)
        lons.append(lon)
    if not lats:
        raise ValueError(f"{name}: no data rows (expected lat,lon)")
    return lats, lons


def parse_csv_track(lines: Iterable[str], name: str) -> GeoTrack:
    """Parse ``time,lat,lon`` rows (seconds, WGS-84 degrees); extra columns are ignored.

    A first row that is not numeric is a header naming the columns (``time``/``t``,
    ``lat``/``latitude``, ``lon``/``lng``/``longitude``, any order). Blank lines and
    lines starting with ``#`` are skipped.

    Args:
        lines: The file's lines (an open text file will do).
        name: The file name, for messages.

    Returns:
        The track with the file's times (not rebased).

    Raises:
        ValueError: A row is malformed; the message gives file and line. Repeated,
            backward and spiking fixes are merged or dropped and counted
            (``GeoTrack.cleaning``), never refused.
    """
    times: list[float] = []
    lats: list[float] = []
    lons: list[float] = []
    for lineno, cells, columns in _data_rows(lines, name, ("time", "lat", "lon")):
        try:
            t, lat, lon = (float(cells[i]) for i in columns)
        except ValueError:
            raise ValueError(
                f"{name}:{lineno}: time, lat and lon must be numbers, got "
                f"{', '.join(repr(cells[i]) for i in columns)}"
            ) from None
        if not all(math.isfinite(v) for v in (t, lat, lon)):
            raise ValueError(f"{name}:{lineno}: time, lat and lon must be finite")
        check_fix(f"{name}:{lineno}", lat, lon)
        times.append(t)
        lats.append(lat)
        lons.append(lon)
    if not times:
        raise ValueError(f"{name}: no data rows (expected time,lat,lon)")
    return GeoTrack.from_fixes(times, lats, lons, name, "csv")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _header_columns(
    cells: list[str], name: str, lineno: int, need: tuple[str, ...] = ("time", "lat", "lon")
) -> tuple[int, int, int]:
    found: dict[str, int] = {}
    for i, cell in enumerate(cells):
        key = _COLUMN_NAMES.get(cell.lower())
        if key is not None and key not in found:
            found[key] = i
    missing = [k for k in need if k not in found]
    if missing:
        raise ValueError(
            f"{name}:{lineno}: header {cells!r} lacks column(s) {', '.join(missing)} "
            f"(expected {','.join(need)})"
        )
    return found.get("time", -1), found["lat"], found["lon"]
