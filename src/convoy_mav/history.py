"""A decimated record of a mission, for reports and plots.

Pure: the app appends a sample at most every ``interval`` mission seconds. Memory
is bounded whatever the run's length: past ``max_samples`` every other sample is
dropped and the interval doubled, so a day's mission keeps the whole day, coarser.
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
    max_samples: int = 20_000
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
        if len(self.samples) > self.max_samples:
            self.samples = self.samples[::2]
            self.interval *= 2.0
