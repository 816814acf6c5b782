"""When to replan: convoy motion changes, detected with hysteresis.

Design rules:
- The current plan assumes a ``ConvoyMotion``: the convoy at ``origin`` at
  ``t0`` and then stationary or moving at a constant velocity.  Each fresh
  ``ConvoyEstimate`` is compared with that assumption:

  =====================  ==================================================
  plan assumes           replan when (reason)
  =====================  ==================================================
  stationary             speed > ``start_speed`` (``convoy_started``)
  moving                 speed < ``stop_speed`` (``convoy_stopped``);
                         course off by > ``heading_tol`` (``heading_change``);
                         speed off by > ``speed_tol`` of the planned speed
                         (``speed_change``)
  either                 centroid farther than ``position_tol`` from where
                         the plan expects it (``position_drift``)
  =====================  ==================================================

- Hysteresis, so noise never causes replan storms: the start and stop
  thresholds differ (0.5 vs 0.2 m/s); a condition must hold without a break
  for ``confirm_s``; and the replan waits until the velocity estimate has
  been steady for ``settle_s`` (or the condition has held ``max_wait_s``), so
  a turn or an acceleration still in progress -- which a sliding-window
  velocity estimate shows as a ramp -- is replanned once, on its final value.
  After a replan the reference is the new estimate.
- Stale estimates are never evidence: they reset the pending condition.
- The first plan (no reference yet) is made the same way, once estimates
  have been fresh for ``confirm_s`` and steady.
- Pure: the estimates carry their time.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from convoy_mav.errors import ConfigError
from convoy_mav.planning.dubins import wrap_angle
from convoy_mav.types import ConvoyEstimate

__all__ = [
    "REASONS",
    "ChangeDetector",
    "ConvoyMotion",
    "ReplanDecision",
    "ReplanThresholds",
]

#: Every reason a ``Replanned`` event can carry.
REASONS = (
    "initial",
    "convoy_started",
    "convoy_stopped",
    "heading_change",
    "speed_change",
    "position_drift",
    "uav_lost",
)


@dataclass(frozen=True, slots=True)
class ReplanThresholds:
    """Thresholds of the replan rules (all configurable).

    Attributes:
        start_speed: m/s; a stationary plan is replaced above this speed.
        stop_speed: m/s; a moving plan is replaced below this speed (< start_speed).
        heading_tol: rad; course change that triggers a replan.
        speed_tol: Relative speed change that triggers a replan (0.2 = 20 %).
        position_tol: m; centroid error against the plan's prediction that
            triggers a replan; None: a quarter of the sensor radius.
        confirm_s: s a condition must hold continuously.
        settle_s: s the velocity estimate must have been steady before replanning.
        settle_tol: steady means every estimate of the last ``settle_s`` is
            within ``max(settle_tol * speed, settle_min)`` of the latest.
        settle_min: m/s, floor of that band.
        max_wait_s: s after which a confirmed change is replanned even if the
            estimate is not steady.
    """

    start_speed: float = 0.5
    stop_speed: float = 0.2
    heading_tol: float = math.radians(15.0)
    speed_tol: float = 0.2
    position_tol: float | None = None
    confirm_s: float = 2.0
    settle_s: float = 1.0
    settle_tol: float = 0.05
    settle_min: float = 0.1
    max_wait_s: float = 10.0

    def __post_init__(self) -> None:
        for name in ("start_speed", "stop_speed", "heading_tol", "speed_tol", "settle_min"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ConfigError(name, value, "must be positive and finite")
        for name in ("confirm_s", "settle_s", "settle_tol", "max_wait_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ConfigError(name, value, "must be finite and >= 0")
        if self.position_tol is not None and not (
            math.isfinite(self.position_tol) and self.position_tol > 0.0
        ):
            raise ConfigError("position_tol", self.position_tol, "must be positive and finite")
        if self.stop_speed >= self.start_speed:
            raise ConfigError(
                "stop_speed", self.stop_speed, f"must be below start_speed ({self.start_speed:g})"
            )
        if self.max_wait_s < self.confirm_s:
            raise ConfigError("max_wait_s", self.max_wait_s, "must be at least confirm_s")


@dataclass(frozen=True, slots=True)
class ConvoyMotion:
    """What a plan assumes the convoy does: at ``origin`` at ``t0``, then constant velocity.

    Attributes:
        t0: Mission time of the anchor.
        north, east: Convoy centroid at ``t0`` (mission frame).
        vn, ve: Planned velocity, m/s (zero for a stationary plan).
    """

    t0: float
    north: float
    east: float
    vn: float = 0.0
    ve: float = 0.0

    @property
    def moving(self) -> bool:
        """True for a moving-convoy plan."""
        return self.vn != 0.0 or self.ve != 0.0

    @property
    def speed(self) -> float:
        """Planned speed, m/s."""
        return math.hypot(self.vn, self.ve)

    @property
    def course(self) -> float:
        """Planned course, rad clockwise from north (0 when stationary)."""
        return math.atan2(self.ve, self.vn) if self.moving else 0.0

    def position(self, t: float) -> tuple[float, float]:
        """Where the plan expects the convoy at mission time ``t``."""
        dt = t - self.t0
        return self.north + self.vn * dt, self.east + self.ve * dt

    def advanced(self, t: float) -> ConvoyMotion:
        """The same motion re-anchored at mission time ``t``."""
        north, east = self.position(t)
        return ConvoyMotion(t, north, east, self.vn, self.ve)


@dataclass(frozen=True, slots=True)
class ReplanDecision:
    """A replan is due.

    Attributes:
        reason: One of ``REASONS``.
        motion: The motion the new plan should assume (anchored at the estimate).
    """

    reason: str
    motion: ConvoyMotion


class ChangeDetector:
    """Compares convoy estimates with the planned motion; says when to replan.

    Args:
        thresholds: The rules' thresholds.
        position_tol: Resolved position tolerance, metres (``thresholds``'
            value, or the caller's default when that is None).
    """

    def __init__(self, thresholds: ReplanThresholds, position_tol: float) -> None:
        if not (math.isfinite(position_tol) and position_tol > 0.0):
            raise ConfigError("position_tol", position_tol, "must be positive and finite")
        self.thresholds = thresholds
        self.position_tol = position_tol
        self.reference: ConvoyMotion | None = None
        self.pending: str | None = None
        self._since: float | None = None
        self._history: deque[ConvoyEstimate] = deque()

    def set_reference(self, motion: ConvoyMotion) -> None:
        """The plan now assumes ``motion``: pending conditions restart."""
        self.reference = motion
        self.pending = None
        self._since = None

    def condition(self, est: ConvoyEstimate) -> str | None:
        """The replan reason ``est`` shows against the reference (no hysteresis)."""
        ref = self.reference
        th = self.thresholds
        if ref is None:
            return "initial"
        speed = est.speed
        if not ref.moving:
            if speed > th.start_speed:
                return "convoy_started"
        else:
            if speed < th.stop_speed:
                return "convoy_stopped"
            course = math.atan2(est.ve, est.vn)
            if abs(wrap_angle(course - ref.course)) > th.heading_tol:
                return "heading_change"
            if abs(speed - ref.speed) > th.speed_tol * ref.speed:
                return "speed_change"
        north, east = ref.position(est.t)
        if math.hypot(est.north - north, est.east - east) > self.position_tol:
            return "position_drift"
        return None

    def _steady(self, est: ConvoyEstimate) -> bool:
        th = self.thresholds
        history = self._history
        if not history or history[0].t > est.t - th.settle_s:
            return th.settle_s == 0.0
        band = max(th.settle_tol * est.speed, th.settle_min)
        return all(math.hypot(h.vn - est.vn, h.ve - est.ve) <= band for h in history)

    def observe(self, est: ConvoyEstimate) -> ReplanDecision | None:
        """Fold in one estimate; a decision when a replan is due, else None."""
        th = self.thresholds
        if est.stale or not all(map(math.isfinite, (est.t, est.north, est.east, est.vn, est.ve))):
            self.pending, self._since = None, None
            self._history.clear()
            return None
        history = self._history
        history.append(est)
        # keep the newest estimate at or before t - settle_s, so coverage is known
        while len(history) > 1 and history[1].t <= est.t - th.settle_s:
            history.popleft()
        reason = self.condition(est)
        if reason is None:
            self.pending, self._since = None, None
            return None
        if self._since is None:
            self._since = est.t
        self.pending = reason
        held = est.t - self._since
        if held < th.confirm_s or not (self._steady(est) or held >= th.max_wait_s):
            return None
        moving = (
            est.speed > th.start_speed if self.reference is None else reason != "convoy_stopped"
        )
        if reason == "position_drift" and self.reference is not None:
            moving = self.reference.moving
        if not moving:
            return ReplanDecision(reason, ConvoyMotion(est.t, est.north, est.east))
        vn, ve = est.vn, est.ve
        if reason == "position_drift":
            vn, ve = self._long_baseline(est)
        return ReplanDecision(reason, ConvoyMotion(est.t, est.north, est.east, vn, ve))

    def _long_baseline(self, est: ConvoyEstimate) -> tuple[float, float]:
        """Velocity for a drift replan: from the plan's anchor to now, if it agrees.

        A drift without a speed or course change means the planned velocity
        was slightly off (a sliding-window estimate is noisy).  The average
        velocity since the anchor is far more precise over a long baseline;
        it is used when it agrees with the window estimate within half the
        speed and course tolerances (the convoy really held its course).
        """
        ref = self.reference
        th = self.thresholds
        assert ref is not None
        span = est.t - ref.t0
        if span <= 0.0:
            return est.vn, est.ve
        vn, ve = (est.north - ref.north) / span, (est.east - ref.east) / span
        speed = math.hypot(vn, ve)
        course = math.atan2(ve, vn)
        same_course = abs(wrap_angle(course - math.atan2(est.ve, est.vn))) <= th.heading_tol / 2
        same_speed = abs(speed - est.speed) <= th.speed_tol / 2 * est.speed
        return (vn, ve) if same_course and same_speed else (est.vn, est.ve)
