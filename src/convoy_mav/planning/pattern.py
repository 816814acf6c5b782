"""The paper's moving-convoy pattern in the convoy's own frame, for any speed.

Design rules:
- Section IV's UAV flies alternating maximal left/right arcs of ``2 beta``
  and meets the convoy at the end of each (Lemma 4.1, ``v = sin(beta)/beta``).
  Seen from the convoy, with ``x`` along its course and ``y`` to its left, a
  left arc flown from heading ``-beta`` is, after turning ``a = 2 beta w``
  (``w`` in [0, 1), the fraction of the half-cycle flown),

      q_x = R (sin(a - beta) + sin(beta)) - 2 R w sin(beta)
      q_y = R (cos(beta) - cos(a - beta))

  and the right arc that follows is its mirror image (``q_y -> -q_y``).
  Every speed's pattern passes through the convoy (``q = 0``) at ``w = 0``,
  so the family is continuous in speed and changing speed never moves a
  meeting point.
- A stopped convoy is the limit ``beta -> pi``: two full circles of radius R
  through the convoy (a figure eight). One UAV then sees the convoy
  ``2 asin(r / 2R) / pi`` of the time (the limit of Corollary 4.3), at most
  one UAV fewer than the optimal orbits of Theorem 3.5 need, and the same
  pattern carries on when the convoy moves off again.
- The phase runs in half-cycles (one arc each); UAV ``i`` of ``N`` flies
  ``i / N`` of a half-cycle behind UAV 0, so their covered windows tile
  every meet period (Corollary 4.3, Fig. 10).
- Pure and vectorised: arrays in, arrays out.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Sequence
from functools import cache

import numpy as np
import numpy.typing as npt

from convoy_mav.planning.moving import beta_from_speed_ratio, min_uavs_moving
from convoy_mav.planning.stationary import min_uavs

__all__ = [
    "MAX_SPEED_RATIO",
    "PatternClock",
    "beta_for_speed",
    "half_cycle_rate",
    "min_uavs_road",
    "min_uavs_stopped",
    "pattern_radius",
    "relative_offsets",
]

FloatArray = npt.NDArray[np.float64]

#: Convoy/UAV speed ratio the pattern is capped at: faster, the UAVs fall behind.
MAX_SPEED_RATIO = 0.95

#: Below this ratio the convoy counts as stopped (beta = pi exactly).
_STOPPED_RATIO = 1e-6


def beta_for_speed(convoy_speed: float, uav_speed: float) -> float:
    """Half arc angle ``beta`` for a convoy speed (Lemma 4.1); pi when stopped.

    The ratio is capped at :data:`MAX_SPEED_RATIO`. Interpolated in a table of
    Lemma 4.1's exact roots (``_beta_steps``, error below 1e-6 rad): the road
    mission asks for it thousands of times a plan.
    """
    table, slopes = _beta_steps()
    per_step = 1.0 / (uav_speed * _BETA_STEP)  # (as the clock computes it: bit for bit)
    return _beta_at(max(convoy_speed, 0.0) * per_step, table, slopes)


def _beta_at(steps: float, table: list[float], slopes: list[float]) -> float:
    """``beta`` at a speed ratio of ``steps`` grid steps (``_beta_steps``' table)."""
    if not _STOPPED_STEPS < steps < math.inf:
        return math.pi
    i = min(int(steps), len(table) - 1)
    return table[i] + (min(steps, _MAX_STEPS) - i) * slopes[i]


_BETA_STEP = 5e-4


_STOPPED_STEPS = _STOPPED_RATIO / _BETA_STEP
_MAX_STEPS = MAX_SPEED_RATIO / _BETA_STEP


@cache
def _beta_steps() -> tuple[list[float], list[float]]:
    """Lemma 4.1 solved on a grid of speed ratios, 0 to ``MAX_SPEED_RATIO`` every
    ``_BETA_STEP``: the betas, and the slope from each to the next (the last: 0)."""
    n = round(MAX_SPEED_RATIO / _BETA_STEP) + 1
    betas = [math.pi] + [beta_from_speed_ratio(i * _BETA_STEP) for i in range(1, n)]
    slopes = [b1 - b0 for b0, b1 in itertools.pairwise(betas)] + [0.0]
    return betas, slopes


@cache
def _beta_arrays() -> tuple[FloatArray, FloatArray]:
    """``_beta_steps`` as arrays."""
    table, slopes = _beta_steps()
    return np.array(table), np.array(slopes)


def half_cycle_rate(beta: float, turn_radius: float, uav_speed: float) -> float:
    """Half-cycles per second: one arc of ``2 beta`` at ``V / R`` takes ``2 R beta / V``."""
    return uav_speed / (2.0 * turn_radius * beta)


def relative_offsets(
    phase: FloatArray, beta: float | FloatArray, turn_radius: float
) -> tuple[FloatArray, FloatArray]:
    """Where the pattern puts a UAV relative to the convoy: (along, left) metres.

    Args:
        phase: Pattern phase in half-cycles (integer part even: left arc).
        beta: Half arc angle(s), rad, in (0, pi].
        turn_radius: R, metres.
    """
    half = np.floor(phase)
    w = phase - half
    a = 2.0 * beta * w
    sb, cb = np.sin(beta), np.cos(beta)
    qx = turn_radius * (np.sin(a - beta) + sb) - 2.0 * turn_radius * w * sb
    qy = turn_radius * (cb - np.cos(a - beta))
    odd = np.mod(half, 2.0) == 1.0
    return qx, np.where(odd, -qy, qy)


def min_uavs_stopped(turn_radius: float, sensor_radius: float) -> int:
    """UAVs the figure eight of a stopped convoy needs: ``ceil(pi / (2 asin(r / 2R)))``.

    The limit of Corollary 4.3 as the convoy speed goes to 0; one at most
    more than Theorem 3.5's minimum for the optimal orbits.
    """
    if sensor_radius >= 2.0 * turn_radius:
        return 1
    ratio = math.pi / (2.0 * math.asin(sensor_radius / (2.0 * turn_radius)))
    nearest = round(ratio)
    return nearest if abs(ratio - nearest) < 1e-9 else math.ceil(ratio)


def min_uavs_road(
    turn_radius: float,
    sensor_radius: float,
    uav_speed: float,
    convoy_speeds: Iterable[float] | None = None,
) -> int:
    """UAVs that keep a convoy covered over a whole speed profile.

    The largest of Corollary 4.3's counts over the speeds the convoy drives
    (a stop included when the profile has one); with no profile the convoy
    may stop anywhere, and the stopped count holds. Never below the
    stationary minimum of Theorem 3.5 when the convoy stops.
    """
    stopped = max(
        min_uavs_stopped(turn_radius, sensor_radius), min_uavs(turn_radius, sensor_radius)
    )
    if convoy_speeds is None:
        return stopped
    worst = 1
    for v in convoy_speeds:
        ratio = max(v, 0.0) / uav_speed
        if ratio <= _STOPPED_RATIO:
            worst = max(worst, stopped)
        else:
            worst = max(
                worst, min_uavs_moving(turn_radius, sensor_radius, min(ratio, MAX_SPEED_RATIO))
            )
    return worst


def pattern_radius(turn_radius: float, sensor_radius: float, uavs: int, cap: float = 1.3) -> float:
    """Radius to lay the pattern's arcs with: the widest ``uavs`` UAVs still cover a stop with.

    The paper's arcs turn at the aircraft's limit, so on a road they leave no
    turn to follow the convoy's own turns with. A fleet with a UAV to spare
    buys that turn back: N UAVs cover a stopped convoy on figure eights of
    radius ``rho`` while ``2 asin(r / 2 rho) / pi >= 1 / N``, i.e.
    ``rho <= r / (2 sin(pi / 2N))`` (taken with 5 % to spare). Never below R,
    never above ``cap`` x R.
    """
    if uavs < 1:
        raise ValueError(f"uavs must be at least 1, got {uavs}")
    widest = 0.95 * sensor_radius / (2.0 * math.sin(math.pi / (2.0 * uavs)))
    return min(max(widest, turn_radius), cap * turn_radius)


class PatternClock:
    """The pattern's state: the convoy's smoothed velocity and the pattern phase.

    The pattern is laid along the convoy's velocity low-passed over ``tau``
    seconds (its course and its speed, which sets ``beta``): a convoy's turns
    and stops then reshape the pattern gradually, and a road that winds back
    and forth (hairpins, a grid) is flown as the slower progress it makes.
    The speed is the lesser of that and the convoy's speed low-passed over
    ``speed_tau``: a stop closes the pattern into the figure eight within
    seconds instead of a whole ``tau`` later, when the convoy is parked and
    the arcs laid for a moving one no longer meet it (road table: +0.6 to
    +1.1 points of mean coverage). The phase counts half-cycles (arcs) at
    ``V / (2 R beta)`` a second.
    """

    def __init__(
        self, t: float, vx: float, vy: float, *, tau: float = 20.0, speed_tau: float = 5.0
    ) -> None:
        self.t = t
        self.fx, self.fy = vx, vy
        self.fs = math.hypot(vx, vy)
        self.phase = 0.0
        self.course = math.atan2(vy, vx) if math.hypot(vx, vy) > _COURSE_MIN_SPEED else 0.0
        self.tau = tau
        self.speed_tau = speed_tau

    def copy(self) -> PatternClock:
        """An independent copy (to forecast from)."""
        out = PatternClock(self.t, self.fx, self.fy, tau=self.tau, speed_tau=self.speed_tau)
        out.fs, out.phase, out.course = self.fs, self.phase, self.course
        return out

    @property
    def speed(self) -> float:
        """The smoothed convoy speed the pattern is laid for, m/s."""
        return min(math.hypot(self.fx, self.fy), self.fs)

    def advance(self, t: float, vx: float, vy: float, radius: float, uav_speed: float) -> None:
        """Integrate to time ``t`` with the convoy moving at (vx, vy) meanwhile.

        The clock's definition, a ``_CLOCK_STEP`` at a time (``forecast`` is the
        same over many times, vectorised): each step's phase advances at the rate
        of the beta it began with, then the velocity and speed are low-passed and
        the course and beta follow (the course held while too slow to have one).
        """
        table, slopes = _beta_steps()
        per_step = 1.0 / (uav_speed * _BETA_STEP)
        rate = uav_speed / (2.0 * radius)
        v = math.hypot(vx, vy)
        beta = _beta_at(self.speed * per_step, table, slopes)
        # Cut the span as ``forecast`` does, to the bit: a span of a nanosecond or
        # less is no step, and the clock then lands on ``t`` exactly.
        span = t - self.t
        count = math.ceil((span - _MIN_SPAN) / _CLOCK_STEP) if span > _MIN_SPAN else 0
        for k in range(count):
            dt = _CLOCK_STEP if k < count - 1 else span - (count - 1) * _CLOCK_STEP
            self.phase += rate / beta * dt
            a = -math.expm1(-dt / self.tau)
            self.fx += (vx - self.fx) * a
            self.fy += (vy - self.fy) * a
            self.fs += (v - self.fs) * -math.expm1(-dt / self.speed_tau)
            speed = self.speed
            if speed > _COURSE_MIN_SPEED:
                self.course = math.atan2(self.fy, self.fx)
            beta = _beta_at(speed * per_step, table, slopes)
        self.t = max(self.t, t)

    def state(self, uav_speed: float) -> tuple[float, float, float]:
        """(phase, course, beta) now."""
        return self.phase, self.course, beta_for_speed(self.speed, uav_speed)

    def forecast(
        self,
        times: Sequence[float] | FloatArray,
        vx: Sequence[float] | FloatArray,
        vy: Sequence[float] | FloatArray,
        radius: float,
        uav_speed: float,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(phase, course, beta) at each of ``times`` (ascending, none before ``t``), the
        convoy moving at ``(vx[k], vy[k])`` until ``times[k]``; the clock is left as is.

        What ``advance`` then ``state`` give at each time, in one vectorised pass
        over the integration steps (``_CLOCK_STEP`` each, the last of a time's
        span shorter): a re-plan forecasts some 500 of them, in the mission worker
        beside the setpoint stream, and a loop over them was half a re-plan's cost.
        """
        times = np.asarray(times, dtype=np.float64)
        # Each time's span from the one before, cut into integration steps.
        ends = np.maximum.accumulate(np.concatenate(([self.t], times)))
        spans = np.diff(ends)
        counts = np.where(
            spans > _MIN_SPAN, np.ceil((spans - _MIN_SPAN) / _CLOCK_STEP), 0.0
        ).astype(int)
        last = np.cumsum(counts) - 1  # each time's last step (-1: none yet)
        dt = np.full(int(counts.sum()), _CLOCK_STEP)
        ran = counts > 0
        dt[last[ran]] = spans[ran] - (counts[ran] - 1) * _CLOCK_STEP
        ux = np.repeat(np.asarray(vx, dtype=np.float64), counts)
        uy = np.repeat(np.asarray(vy, dtype=np.float64), counts)
        fx = _low_pass(self.fx, ux, dt / self.tau)
        fy = _low_pass(self.fy, uy, dt / self.tau)
        fs = _low_pass(self.fs, np.hypot(ux, uy), dt / self.speed_tau)
        speed = np.minimum(np.hypot(fx, fy), fs)
        moving = speed > _COURSE_MIN_SPEED
        # (the course is held while the convoy is too slow to have one)
        heading = np.where(moving, np.arctan2(fy, fx), self.course)
        held = np.maximum.accumulate(np.where(moving, np.arange(len(speed)), -1))
        course = np.concatenate(([self.course], np.where(held >= 0, heading[held], self.course)))
        beta = np.concatenate(
            (
                [beta_for_speed(self.speed, uav_speed)],
                _betas_at(speed * (1.0 / (uav_speed * _BETA_STEP))),
            )
        )
        # Each step's phase advances at the rate of the beta the step began with.
        rate = uav_speed / (2.0 * radius)
        phase = self.phase + np.concatenate(([0.0], np.cumsum(rate / beta[:-1] * dt)))
        at = last + 1
        return phase[at], course[at], beta[at]


def _low_pass(start: float, inputs: FloatArray, decay: FloatArray) -> FloatArray:
    """``f += (u - f) (1 - exp(-decay))`` over the steps, from ``start``: each value.

    In closed form, ``f_k = P_k (start + sum_j (1 - e^-d_j) u_j / P_j)`` with ``P``
    the running product of ``e^-d``, over runs short enough in decay (``_RUN_DECAY``)
    that ``1 / P`` keeps its precision.
    """
    out = np.empty_like(inputs)
    total = np.cumsum(decay)
    i, f = 0, start
    while i < len(inputs):
        base = total[i - 1] if i else 0.0
        j = max(int(np.searchsorted(total, base + _RUN_DECAY, side="right")), i + 1)
        d = decay[i:j]
        product = np.exp(-np.cumsum(d))
        out[i:j] = product * (f + np.cumsum(-np.expm1(-d) * inputs[i:j] / product))
        f, i = float(out[j - 1]), j
    return out


def _betas_at(steps: FloatArray) -> FloatArray:
    """``_beta_at`` over an array of speed ratios in grid steps."""
    table, slopes = _beta_arrays()
    index = np.floor(np.clip(steps, 0.0, len(table) - 1)).astype(int)
    beta = table[index] + (np.minimum(steps, _MAX_STEPS) - index) * slopes[index]
    return np.where((steps > _STOPPED_STEPS) & (steps < math.inf), beta, math.pi)


_RUN_DECAY = 30.0  # e-folds of a low-pass run solved at once (1 / P below e^30)


_CLOCK_STEP = 0.5  # s: integration step of the pattern clock
_MIN_SPAN = 1e-9  # s: a span no longer than this is no step (rounding, not time)
_COURSE_MIN_SPEED = 0.3  # m/s: slower, the course is held (a stopped convoy has none)
