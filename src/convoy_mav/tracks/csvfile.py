"""CSV convoy tracks: ``time,lat,lon`` rows (also the mock's ``csv`` ground route).

Design rules:
- CSV as loggers and spreadsheets write it is read, not refused: a comma,
  semicolon or tab between fields (the first data or header line says which),
  decimal commas when the fields are not comma-separated, a header naming the
  columns in any order with the names and units exporters use (``Latitude
  (deg)``, ``timestamp``, ``time [s]``, ``time_ms``), and times as seconds,
  POSIX milliseconds or ISO-8601 (``2024-05-01T10:00:00Z``, an offset, or none:
  UTC).
- What cannot be read is a ``ValueError`` naming the file and line; nothing is
  guessed beyond the rules above (one file keeps one kind of time).
"""

from __future__ import annotations

import csv
import itertools
import math
import re
from collections.abc import Iterable, Iterator

from convoy_mav.tracks.geotrack import GeoTrack, check_fix, iso_seconds

__all__ = ["parse_csv_points", "parse_csv_track"]

_COLUMN_NAMES = {
    **dict.fromkeys(
        ("time", "t", "timestamp", "datetime", "date_time", "utc", "time_utc", "gps_time",
         "unix_time", "epoch", "seconds", "secs", "sec", "time_s", "timestamp_s"),
        "time",
    ),
    **dict.fromkeys(("time_ms", "timestamp_ms", "ms", "millis", "epoch_ms"), "time_ms"),
    **dict.fromkeys(("lat", "latitude", "lat_deg", "latitude_deg"), "lat"),
    **dict.fromkeys(("lon", "lng", "long", "longitude", "lon_deg", "longitude_deg"), "lon"),
}  # fmt: skip
_UNIT = re.compile(r"\s*[\(\[]\s*([^\)\]]*?)\s*[\)\]]\s*$")  # "time [s]", "Latitude (deg)"
_MS_AFTER = 1e11  # a numeric time past this is POSIX milliseconds (1e11 s is year 5138)
_DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+$")
_NO_FIX = frozenset({"", "nan"})  # a row's latitude and longitude both so: no position yet

_Columns = tuple[int, int, int]  # (time, lat, lon) column; time -1: none


def _delimiter(line: str) -> str:
    """Tab or semicolon when the line has one (their decimal commas are not fields)."""
    for sep in ("\t", ";"):
        if sep in line:
            return sep
    return ","


def _rows(lines: Iterable[str]) -> Iterator[tuple[int, list[str]]]:
    """Each non-blank, non-comment row's cells, split as its first line says."""
    it = iter(lines)
    head: list[str] = []
    sep = ","
    for line in it:
        head.append(line)
        if line.strip() and not line.lstrip().startswith("#"):
            sep = _delimiter(line)
            break
    for lineno, row in enumerate(csv.reader(itertools.chain(head, it), delimiter=sep), start=1):
        cells = [c.strip() for c in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if sep != ",":
            cells = [c.replace(",", ".") if _DECIMAL_COMMA.match(c) else c for c in cells]
        yield lineno, cells


def _data_rows(
    lines: Iterable[str], name: str, need: tuple[str, ...]
) -> Iterator[tuple[int, list[str], _Columns, float]]:
    """Each data row as (line, cells, columns, time scale), past comments and a header.

    Without a header the columns are ``need`` in order (a missing time is -1).
    """
    columns = (0, 1, 2) if need[0] == "time" else (-1, 0, 1)
    scale = 1.0
    seen_row = False
    for lineno, cells in _rows(lines):
        if not seen_row:
            seen_row = True
            if not all(_is_number(c) or iso_seconds(c) is not None for c in cells[: len(need)]):
                columns, scale = _header_columns(cells, name, lineno, need)
                continue
        if len(cells) <= max(columns):
            raise ValueError(
                f"{name}:{lineno}: expected columns {','.join(need)}, got {len(cells)} field(s)"
            )
        yield lineno, cells, columns, scale


def parse_csv_points(lines: Iterable[str], name: str) -> tuple[list[float], list[float]]:
    """A route's ``lat,lon[,time]`` rows: the path only (any time column is ignored).

    A first row that is not numeric is a header naming the columns, as for tracks
    (``time`` optional). Blank lines and ``#`` comments are skipped.

    Raises:
        ValueError: A malformed row, or none; the message gives file and line.
    """
    lats: list[float] = []
    lons: list[float] = []
    for lineno, cells, columns, _ in _data_rows(lines, name, ("lat", "lon")):
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
    """Parse ``time,lat,lon`` rows (WGS-84 degrees); extra columns are ignored.

    A first row that is not numeric is a header naming the columns in any order
    (``time``/``t``/``timestamp``/``datetime``/..., ``time_ms`` for milliseconds,
    ``lat``/``latitude``, ``lon``/``lng``/``longitude``; case, a unit in brackets
    and spaces do not matter). A time is seconds, POSIX milliseconds (a number past
    1e11, or a ``ms`` column) or ISO-8601. Blank lines and lines starting with
    ``#`` are skipped; fields may be separated by commas, semicolons or tabs.

    Args:
        lines: The file's lines (an open text file will do).
        name: The file name, for messages.

    Returns:
        The track with the file's times (not rebased).

    Raises:
        ValueError: A row is malformed; the message gives file and line. Repeated,
            backward and spiking fixes are merged or dropped and counted
            (``GeoTrack.cleaning``), never refused; so are rows with no position
            (latitude and longitude both empty or NaN, as a logger writes them
            before its receiver has a fix).
    """
    times: list[float] = []
    lats: list[float] = []
    lons: list[float] = []
    unfixed = 0
    iso: bool | None = None  # the file's kind of time, from its first row
    for lineno, cells, columns, scale in _data_rows(lines, name, ("time", "lat", "lon")):
        if all(cells[i].strip().lower() in _NO_FIX for i in columns[1:]):
            unfixed += 1
            continue
        t_cell = cells[columns[0]]
        try:
            lat, lon = (float(cells[i]) for i in columns[1:])
            at = iso_seconds(t_cell) if not _is_number(t_cell) else None
            t = at if at is not None else float(t_cell) * scale
        except ValueError:
            raise ValueError(
                f"{name}:{lineno}: time must be seconds or ISO-8601, lat and lon must be numbers, "
                "got "
                f"{', '.join(repr(cells[i]) for i in columns)}"
            ) from None
        if iso is None:
            iso = at is not None
        elif iso != (at is not None):
            raise ValueError(
                f"{name}:{lineno}: time {t_cell!r} mixes ISO-8601 and numeric times in one file"
            )
        if not all(math.isfinite(v) for v in (t, lat, lon)):
            raise ValueError(f"{name}:{lineno}: time, lat and lon must be finite")
        check_fix(f"{name}:{lineno}", lat, lon)
        times.append(t)
        lats.append(lat)
        lons.append(lon)
    if not times:
        what = f" with a position ({unfixed} without)" if unfixed else ""
        raise ValueError(f"{name}: no data rows{what} (expected time,lat,lon)")
    if not iso and scale == 1.0 and min(times) > _MS_AFTER:
        times = [t / 1000.0 for t in times]  # (POSIX milliseconds)
    return GeoTrack.from_fixes(times, lats, lons, name, "csv", unfixed=unfixed)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _column_key(cell: str) -> str | None:
    """What a header cell names (``time``, ``time_ms``, ``lat``, ``lon``), or None."""
    text = cell.strip().lower()
    unit = _UNIT.search(text)
    if unit is not None:
        text = text[: unit.start()]
    key = _COLUMN_NAMES.get(re.sub(r"[\s\-]+", "_", text.strip()))
    if key == "time" and unit is not None and unit[1] == "ms":
        return "time_ms"
    return key


def _header_columns(
    cells: list[str], name: str, lineno: int, need: tuple[str, ...] = ("time", "lat", "lon")
) -> tuple[_Columns, float]:
    """The (time, lat, lon) columns a header names, and the time's scale to seconds."""
    found: dict[str, int] = {}
    scale = 1.0
    for i, cell in enumerate(cells):
        key = _column_key(cell)
        if key == "time_ms":
            key = "time"
            scale = 1e-3 if "time" not in found else scale
        if key is not None and key not in found:
            found[key] = i
    missing = [k for k in need if k not in found]
    if missing:
        raise ValueError(
            f"{name}:{lineno}: header {cells!r} lacks column(s) {', '.join(missing)} "
            f"(expected {','.join(need)})"
        )
    return (found.get("time", -1), found["lat"], found["lon"]), scale
