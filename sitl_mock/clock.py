"""Simulated time shared by every vehicle of one mock process.

Sim time runs ``speedup`` times faster than a monotonic wall clock, so a test
can fly minutes of mission in seconds while every vehicle still sees one
consistent timeline. The wall clock is injected (``time_source``): tests pass a
hand-cranked :class:`ManualTime` and never sleep.

The speedup can be set anew while it runs (``set_speedup``, the ``SIM_SPEEDUP``
parameter): sim time goes on from where it is, at the new rate.

When the physics cannot keep up (too many vehicles for one core at a high
speedup) the server *slips* the clock instead of spiralling: sim time is
shifted back to where the physics actually is, and the achieved real-time
factor is reported. Slips are counted so nobody mistakes them for speed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Protocol

__all__ = ["ManualTime", "SimClock", "Speedup", "TimeSource"]

TimeSource = Callable[[], float]
"""A monotonic clock in wall seconds (``time.monotonic`` by default)."""


class Speedup(Protocol):
    """What a vehicle's ``SIM_SPEEDUP`` parameter reads and sets: its mock's clock."""

    @property
    def speedup(self) -> float:
        """Sim seconds per wall second."""
        ...

    def set_speedup(self, speedup: float) -> None:
        """Run at ``speedup`` from now on (ValueError if not finite and > 0)."""
        ...


class ManualTime:
    """A wall clock that only moves when told to: deterministic tests."""

    def __init__(self, start: float = 0.0) -> None:
        self.value = start

    def __call__(self) -> float:
        return self.value

    def advance(self, seconds: float) -> None:
        """Move wall time forward by ``seconds`` (must be >= 0)."""
        if not seconds >= 0.0:
            raise ValueError(f"cannot move time backwards: {seconds!r}")
        self.value += seconds


class SimClock:
    """Sim seconds since start = ``speedup`` x wall seconds since start - slips.

    Args:
        speedup: Sim seconds per wall second; finite and > 0.
        time_source: Monotonic wall clock; injected so tests control it.
    """

    def __init__(self, speedup: float = 1.0, time_source: TimeSource = time.monotonic) -> None:
        if not (math.isfinite(speedup) and speedup > 0.0):
            raise ValueError(f"speedup must be finite and > 0, got {speedup!r}")
        self._speedup = speedup
        self._source = time_source
        self._wall_start = time_source()
        self._slipped = 0.0
        self._rebased = 0.0  # sim s that keep sim time continuous across speedup changes
        self.slips = 0

    @property
    def speedup(self) -> float:
        """Requested sim seconds per wall second."""
        return self._speedup

    @property
    def slipped(self) -> float:
        """Total sim seconds given up because the physics fell behind."""
        return self._slipped

    def wall_elapsed(self) -> float:
        """Wall seconds since the clock started."""
        return self._source() - self._wall_start

    def now(self) -> float:
        """Current sim time in seconds."""
        return self._speedup * self.wall_elapsed() + self._rebased - self._slipped

    def set_speedup(self, speedup: float) -> None:
        """Run at ``speedup`` from now on; sim time goes on from where it is.

        Raises:
            ValueError: ``speedup`` is not finite and > 0.
        """
        if not (math.isfinite(speedup) and speedup > 0.0):
            raise ValueError(f"speedup must be finite and > 0, got {speedup!r}")
        self._rebased += (self._speedup - speedup) * self.wall_elapsed()
        self._speedup = speedup

    def wall_until(self, t_sim: float) -> float:
        """Wall seconds until sim time reaches ``t_sim`` (<= 0 if already past)."""
        return (t_sim - self.now()) / self._speedup

    def slip(self, sim_seconds: float) -> None:
        """Set sim time back by ``sim_seconds`` so a late simulation need not catch up."""
        if sim_seconds > 0.0:
            self._slipped += sim_seconds
            self.slips += 1

    def real_time_factor(self) -> float:
        """Achieved sim seconds per wall second since start (speedup minus slips)."""
        wall = self.wall_elapsed()
        return self.now() / wall if wall > 0.0 else self._speedup
