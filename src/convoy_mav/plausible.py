"""Positions no vehicle can have reached: dropped, unless the vehicle keeps saying so.

Design rules:
- A fix farther from the last accepted one than ``max_speed`` x the time
  between them (plus ``slack_m``, a GPS glitch's worth) cannot be the
  vehicle's own: a spoofed or corrupt frame among its own, or an absurd
  value. It is dropped.
- A vehicle that really moved that far (an estimator reset, a position
  corrected by hand) keeps reporting from there: ``confirm`` such fixes in
  a row that agree with each other are taken, and the gate follows.
- NaN or infinite values are never reachable. Pure: times are the fixes' own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["JumpGate"]


@dataclass(frozen=True, slots=True)
class _Point:
    t: float
    x: float
    y: float
    z: float


class JumpGate:
    """Admits the fixes of one vehicle that it can have flown or driven to.

    Args:
        max_speed: Fastest the vehicle can move, m/s.
        slack_m: Distance allowed on top, metres.
        confirm: Agreeing far fixes in a row that move the gate.
    """

    def __init__(self, max_speed: float, *, slack_m: float = 50.0, confirm: int = 5) -> None:
        if not (math.isfinite(max_speed) and max_speed > 0.0):
            raise ValueError(f"max_speed must be positive and finite, got {max_speed!r}")
        self.max_speed = max_speed
        self.slack_m = slack_m
        self.confirm = confirm
        self._last: _Point | None = None
        self._pending: _Point | None = None
        self._count = 0
        self.rejected = 0

    def admit(self, t: float, x: float, y: float, z: float = 0.0) -> bool:
        """Is this fix (time s, position m) one the vehicle can have reached? Counts drops."""
        p = _Point(t, x, y, z)
        if not all(map(math.isfinite, (t, x, y, z))):
            self.rejected += 1
            return False
        if self._last is None or not self._far(self._last, p):
            self._last, self._pending, self._count = p, None, 0
            return True
        pending = self._pending
        self._count = 1 if pending is None or self._far(pending, p) else self._count + 1
        self._pending = p
        if self._count < self.confirm:
            self.rejected += 1
            return False
        self._last, self._pending, self._count = p, None, 0
        return True

    def seed(self, t: float, x: float, y: float, z: float = 0.0) -> None:
        """Take this fix as the last, unjudged (an estimator still settling: its jumps are
        its own, not a forger's)."""
        if all(map(math.isfinite, (t, x, y, z))):
            self._last, self._pending, self._count = _Point(t, x, y, z), None, 0

    def _far(self, a: _Point, b: _Point) -> bool:
        dist = math.hypot(b.x - a.x, b.y - a.y, b.z - a.z)
        return not dist <= self.max_speed * abs(b.t - a.t) + self.slack_m
