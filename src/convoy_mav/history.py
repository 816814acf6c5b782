"""A decimated record of a mission, for reports and plots.

Pure: the app appends a sample at most every ``interval`` mission seconds;
memory stays bounded for long runs (a 2-hour mission at 2 Hz is 14 400 rows).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

__all__ = ["History", "HistorySample"]


@dataclass(frozen=True, slots=True)
class HistorySample:
    """Where everything was at one instant (mission frame, metres)."""

    t: float
    convoy: tuple[float, float] | None
    uavs: Mapping[int, tuple[float, float]]
    covered: bool
    protecting: bool


@dataclass
class History:
    """Samples at most every ``interval`` seconds of mission time."""

    interval: float = 0.5
    samples: list[HistorySample] = field(default_factory=list)

    def record(
        self,
        t: float,
        convoy: tuple[float, float] | None,
        uavs: Mapping[int, tuple[float, float]],
        covered: bool,
        protecting: bool,
    ) -> None:
        """Keep this sample if ``interval`` has passed since the last one kept."""
        if self.samples and t - self.samples[-1].t < self.interval:
            return
        self.samples.append(HistorySample(t, convoy, dict(uavs), covered, protecting))
