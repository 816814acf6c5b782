"""The :class:`GeoTrack` value every track format reads into, and its speeds.

Design rules:
    * A value: frozen, validated on construction (finite, lat/lon in range, times
      strictly increasing), so every reader ends in the same checks.
    * Times are the source's clock until :meth:`GeoTrack.rebased` puts the first
      fix at ``t = 0`` (``epoch`` keeps what was subtracted).
    * Speeds are measured over windows, not between samples: GPS jitter and the
      ripple of a centroid of several vehicles would otherwise read as speed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from datetime import UTC, datetime

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.tracks.cleaning import TrackCleaning, clean_fixes

__all__ = [
    "PLANNING_PERCENTILE",
    "SPEED_WINDOW_S",
    "GeoTrack",
    "TrackSpeeds",
    "check_fix",
    "iso_seconds",
    "track_speeds",
]


_CLEAN = TrackCleaning()


@dataclass(frozen=True, slots=True)
class GeoTrack:
    """Where the convoy was when: strictly increasing times and WGS-84 fixes.

    Attributes:
        times: Seconds on the source's clock (0 at the first fix once rebased).
        lats: Latitude of each fix, degrees.
        lons: Longitude of each fix, degrees.
        source: The file it came from (for messages and reports).
        format: ``"csv"``, ``"gpx"``, ``"tlog"`` or ``""``.
        epoch: Source-clock time of ``t = 0`` (what :meth:`rebased` subtracted).
        cleaning: What reading the file merged and dropped (``cleaning.clean_fixes``).
    """

    times: tuple[float, ...]
    lats: tuple[float, ...]
    lons: tuple[float, ...]
    source: str = ""
    format: str = ""
    epoch: float = 0.0
    cleaning: TrackCleaning = _CLEAN

    def __post_init__(self) -> None:
        for name in ("times", "lats", "lons"):
            values = tuple(float(v) for v in getattr(self, name))
            for i, v in enumerate(values):
                if not math.isfinite(v):
                    raise ValueError(f"GeoTrack.{name}[{i}] must be finite, got {v!r}")
            object.__setattr__(self, name, values)
        if not self.times:
            raise ValueError("GeoTrack needs at least one fix")
        if not len(self.times) == len(self.lats) == len(self.lons):
            raise ValueError(
                "GeoTrack.times, lats and lons must have the same length, got "
                f"{len(self.times)}, {len(self.lats)}, {len(self.lons)}"
            )
        for i, (lat, lon) in enumerate(zip(self.lats, self.lons, strict=True)):
            if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
                raise ValueError(f"GeoTrack fix {i} ({lat!r}, {lon!r}) is not a lat/lon")
        for i in range(1, len(self.times)):
            if self.times[i] <= self.times[i - 1]:
                raise ValueError(
                    f"GeoTrack.times must increase strictly: times[{i}] = {self.times[i]!r} "
                    f"after {self.times[i - 1]!r}"
                )

    @classmethod
    def from_fixes(
        cls,
        times: list[float],
        lats: list[float],
        lons: list[float],
        source: str,
        fmt: str,
        *,
        untimed: int = 0,
        unfixed: int = 0,
    ) -> GeoTrack:
        """A track from fixes as a receiver recorded them: repeated time stamps merged,
        backward ones and single-fix spikes dropped (``cleaning.clean_fixes``);
        ``untimed``: points the parser dropped for having no time, ``unfixed`` for
        having no position, counted."""
        (ts, la, lo), cleaning = clean_fixes(times, lats, lons)
        cleaning = replace(cleaning, untimed=untimed, unfixed=unfixed)
        return cls(ts, la, lo, source, fmt, cleaning=cleaning)

    @property
    def duration(self) -> float:
        """Seconds from the first fix to the last."""
        return self.times[-1] - self.times[0]

    @property
    def start(self) -> GeoPoint:
        """The first fix."""
        return GeoPoint(self.lats[0], self.lons[0])

    def rebased(self) -> GeoTrack:
        """The same track with ``t = 0`` at the first fix (``epoch`` keeps the shift)."""
        t0 = self.times[0]
        if t0 == 0.0:
            return self
        return replace(self, times=tuple(t - t0 for t in self.times), epoch=self.epoch + t0)

    def in_frame(self, frame: LocalFrame) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Each fix as ``(norths, easts)`` metres in ``frame``."""
        ned = [frame.to_ned(GeoPoint(a, b)) for a, b in zip(self.lats, self.lons, strict=True)]
        return tuple(p[0] for p in ned), tuple(p[1] for p in ned)


def iso_seconds(text: str) -> float | None:
    """POSIX seconds of an ISO-8601 time (``Z``, an offset, or none: UTC), else None."""
    try:
        when = datetime.fromisoformat(text)
    except ValueError:
        return None
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return when.timestamp()


def check_fix(where: str, lat: float, lon: float) -> None:
    """Raise ``ValueError`` starting with ``where`` unless (lat, lon) is in range."""
    if not -90.0 <= lat <= 90.0:
        raise ValueError(f"{where}: latitude {lat!r} outside [-90, 90]")
    if not -180.0 <= lon <= 180.0:
        raise ValueError(f"{where}: longitude {lon!r} outside [-180, 180]")


SPEED_WINDOW_S = 10.0
"""Speeds are measured over windows this long: GPS jitter and sampling ripple average out."""
PLANNING_PERCENTILE = 0.10
"""The planning speed is the convoy's speed this fraction of the time is slower than."""


@dataclass(frozen=True, slots=True)
class TrackSpeeds:
    """How fast a track moves, measured over windows of ``SPEED_WINDOW_S``.

    Attributes:
        planning_mps: Time-weighted ``PLANNING_PERCENTILE`` quantile of the window
            speeds: the convoy is at least this fast 90 % of the time.
        max_mps: The fastest window.
        mean_mps: Net distance over all windows / duration.
        heading_deg: Compass course of the first window that moves (0 if none does).
    """

    planning_mps: float
    max_mps: float
    mean_mps: float
    heading_deg: float


def track_speeds(
    track: GeoTrack,
    window: float = SPEED_WINDOW_S,
    percentile: float = PLANNING_PERCENTILE,
) -> TrackSpeeds:
    """Window speeds of a track: consecutive spans of >= ``window`` s, net displacement.

    Each window's speed is its net displacement over its duration (a GPS fix
    wobbling at a standstill adds path length, not displacement). A last span
    shorter than half a window joins the one before it. A track shorter than a
    window is one window; a single fix does not move.
    """
    frame = LocalFrame(track.start)
    norths, easts = track.in_frame(frame)
    times = track.times
    bounds = [0]
    for i in range(1, len(times)):
        if times[i] - times[bounds[-1]] >= window:
            bounds.append(i)
    if bounds[-1] != len(times) - 1:
        if len(bounds) > 1 and times[-1] - times[bounds[-1]] < window / 2:
            bounds[-1] = len(times) - 1
        else:
            bounds.append(len(times) - 1)
    spans: list[tuple[float, float]] = []  # (speed, duration)
    heading = 0.0
    moved = False
    distance = 0.0
    for a, b in itertools.pairwise(bounds):
        dn, de = norths[b] - norths[a], easts[b] - easts[a]
        length = math.hypot(dn, de)
        spans.append((length / (times[b] - times[a]), times[b] - times[a]))
        distance += length
        if not moved and length > 0.0:
            moved = True
            heading = math.degrees(math.atan2(de, dn)) % 360.0
    if not spans:
        return TrackSpeeds(0.0, 0.0, 0.0, 0.0)
    total = sum(d for _, d in spans)
    cumulative = 0.0
    planning = spans[-1][0]
    for speed, duration in sorted(spans):
        cumulative += duration
        if cumulative >= percentile * total:
            planning = speed
            break
    return TrackSpeeds(planning, max(s for s, _ in spans), distance / total, heading)
