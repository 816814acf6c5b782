"""Coverage arithmetic: is the convoy inside some UAV's sensor disk, and for how long.

Design rules:
- Pure: positions and times come in as values, statistics and events go out.
  The async monitor feeds it live telemetry; the test harness feeds it the
  mock's ground truth; both get the same numbers from the same code.
- Sample-and-hold: the state observed at one update holds until the next one.
  Updates further apart than ``max_hold`` are not trusted: the interval is
  counted as uncovered (a silent fleet protects nobody) and reported.
- Positions are in any common metric frame (north/east metres).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = [
    "CoverageEvent",
    "CoverageSample",
    "CoverageStats",
    "CoverageTracker",
    "GapClosed",
    "GapOpened",
]

Point = tuple[float, float]


@dataclass(frozen=True, slots=True)
class CoverageSample:
    """What one update saw.

    Attributes:
        t: Time of the update, seconds.
        covered: Whether at least one UAV was within the sensor radius.
        covering: Ids of the UAVs within the sensor radius.
        nearest_m: Distance from the convoy to the nearest UAV (inf if none).
    """

    t: float
    covered: bool
    covering: tuple[int, ...]
    nearest_m: float


@dataclass(frozen=True, slots=True)
class GapOpened:
    """The convoy just left every sensor disk."""

    t: float


@dataclass(frozen=True, slots=True)
class GapClosed:
    """The convoy is seen again after a gap of ``duration`` seconds."""

    t: float
    duration: float


CoverageEvent = GapOpened | GapClosed


@dataclass(frozen=True, slots=True)
class CoverageStats:
    """Totals since tracking began.

    Attributes:
        elapsed_s: Time tracked.
        covered_s: Time at least one UAV saw the convoy.
        longest_gap_s: Longest uncovered stretch (including one still open).
        current_gap_s: Length of the gap in progress (0 when covered).
        gaps: Number of gaps that opened.
        time_inside_s: Per UAV id, time the convoy was inside its sensor disk.
        stale_s: Time counted as uncovered because updates came too far apart.
    """

    elapsed_s: float
    covered_s: float
    longest_gap_s: float
    current_gap_s: float
    gaps: int
    time_inside_s: Mapping[int, float]
    stale_s: float

    @property
    def fraction(self) -> float:
        """Covered fraction of the tracked time (1.0 before any time has passed)."""
        return self.covered_s / self.elapsed_s if self.elapsed_s > 0.0 else 1.0

    def time_inside_fraction(self, uav: int) -> float:
        """Fraction of the tracked time the convoy was inside ``uav``'s disk."""
        if self.elapsed_s <= 0.0:
            return 0.0
        return self.time_inside_s.get(uav, 0.0) / self.elapsed_s


@dataclass
class CoverageTracker:
    """Accumulates coverage from a stream of (time, convoy, UAV positions) updates.

    Args:
        sensor_radius: r, metres: a UAV sees the convoy when within r of it.
        max_hold: Longest interval, seconds, over which one update's state is held.
    """

    sensor_radius: float
    max_hold: float = 1.0
    _last: CoverageSample | None = field(default=None, init=False)
    _start: float | None = field(default=None, init=False)
    _covered: float = field(default=0.0, init=False)
    _stale: float = field(default=0.0, init=False)
    _gap_start: float | None = field(default=None, init=False)
    _longest_gap: float = field(default=0.0, init=False)
    _gaps: int = field(default=0, init=False)
    _inside: dict[int, float] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sensor_radius) and self.sensor_radius > 0.0):
            raise ValueError(f"sensor_radius must be positive and finite, got {self.sensor_radius}")
        if not (math.isfinite(self.max_hold) and self.max_hold > 0.0):
            raise ValueError(f"max_hold must be positive and finite, got {self.max_hold}")

    def observe(self, t: float, convoy: Point, uavs: Mapping[int, Point]) -> CoverageSample:
        """What the sensors see at time ``t`` (no bookkeeping): a pure query."""
        covering: list[int] = []
        nearest = math.inf
        cx, cy = convoy
        for uav, (x, y) in uavs.items():
            d = math.hypot(x - cx, y - cy)
            if not math.isfinite(d):
                continue
            nearest = min(nearest, d)
            if d <= self.sensor_radius:
                covering.append(uav)
        return CoverageSample(t, bool(covering), tuple(sorted(covering)), nearest)

    def update(
        self, t: float, convoy: Point, uavs: Mapping[int, Point]
    ) -> tuple[CoverageSample, list[CoverageEvent]]:
        """Fold in one update; return what it saw and any gap events it caused.

        Updates must come in non-decreasing time; an out-of-order or
        non-finite time is ignored (the previous sample is returned).

        Raises:
            ValueError: Never for bad positions: a NaN position counts as absent.
        """
        if not math.isfinite(t) or (self._last is not None and t < self._last.t):
            return (self._last or CoverageSample(t, False, (), math.inf)), []
        sample = self.observe(t, convoy, uavs)
        events: list[CoverageEvent] = []
        prev = self._last
        if prev is None:
            self._start = t
        else:
            dt = t - prev.t
            held = min(dt, self.max_hold)
            if prev.covered:
                self._covered += held
                for uav in prev.covering:
                    self._inside[uav] = self._inside.get(uav, 0.0) + held
            if dt > self.max_hold:
                self._stale += dt - held
                if prev.covered:  # the stale stretch opened a gap at prev.t + max_hold
                    self._open_gap(prev.t + held, events)
        if sample.covered:
            if self._gap_start is not None:
                duration = t - self._gap_start
                self._longest_gap = max(self._longest_gap, duration)
                events.append(GapClosed(t, duration))
                self._gap_start = None
        else:
            self._open_gap(t, events)
        self._last = sample
        return sample, events

    def _open_gap(self, t: float, events: list[CoverageEvent]) -> None:
        if self._gap_start is None:
            self._gap_start = t
            self._gaps += 1
            events.append(GapOpened(t))

    def stats(self, now: float | None = None) -> CoverageStats:
        """Totals so far; with ``now``, a gap still open is measured up to ``now``."""
        if self._last is None or self._start is None:
            return CoverageStats(0.0, 0.0, 0.0, 0.0, 0, {}, 0.0)
        end = self._last.t if now is None else max(now, self._last.t)
        current = 0.0 if self._gap_start is None else end - self._gap_start
        return CoverageStats(
            elapsed_s=self._last.t - self._start,
            covered_s=self._covered,
            longest_gap_s=max(self._longest_gap, current),
            current_gap_s=current,
            gaps=self._gaps,
            time_inside_s=dict(self._inside),
            stale_s=self._stale,
        )
