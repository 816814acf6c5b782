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
        """Integrate to time ``t`` with the convoy moving at (vx, vy) meanwhile."""
        self.forecast([t], [vx], [vy], radius, uav_speed, keep=True)

    def state(self, uav_speed: float) -> tuple[float, float, float]:
        """(phase, course, beta) now."""
        return self.phase, self.course, beta_for_speed(self.speed, uav_speed)

    def forecast(
        self,
        times: Sequence[float],
        vx: Sequence[float],
        vy: Sequence[float],
        radius: float,
        uav_speed: float,
        *,
        keep: bool = False,
    ) -> tuple[list[float], list[float], list[float]]:
        """(phase, course, beta) at each of ``times`` (ascending, none before ``t``), the
        convoy moving at ``(vx[k], vy[k])`` until ``times[k]``; the clock is left as is
        unless ``keep`` (then it is at the last time: ``advance``).

        What ``advance`` then ``state`` give at each time, in one pass: a
        re-plan forecasts some 500 steps, in the mission worker beside the
        setpoint stream.
        """
        t, fx, fy, fs, phase, course = self.t, self.fx, self.fy, self.fs, self.phase, self.course
        tau, speed_tau = self.tau, self.speed_tau
        a_step = 1.0 - math.exp(-_CLOCK_STEP / tau)
        s_step = 1.0 - math.exp(-_CLOCK_STEP / speed_tau)
        hypot = math.hypot
        # beta_for_speed, its table fetched once (some 400 steps a forecast).
        table, slopes = _beta_steps()
        per_step = 1.0 / (uav_speed * _BETA_STEP)
        rate = uav_speed / (2.0 * radius)
        speed = min(hypot(fx, fy), fs)
        beta = _beta_at(speed * per_step, table, slopes)
        phases: list[float] = []
        courses: list[float] = []
        betas: list[float] = []
        for tk, vxk, vyk in zip(times, vx, vy, strict=True):
            vk = hypot(vxk, vyk)
            while t < tk - 1e-9:
                dt = min(_CLOCK_STEP, tk - t)
                if dt == _CLOCK_STEP:
                    a, b = a_step, s_step
                else:
                    a, b = 1.0 - math.exp(-dt / tau), 1.0 - math.exp(-dt / speed_tau)
                phase += rate / beta * dt
                fx += (vxk - fx) * a
                fy += (vyk - fy) * a
                fs += (vk - fs) * b
                speed = min(hypot(fx, fy), fs)
                if speed > _COURSE_MIN_SPEED:
                    course = math.atan2(fy, fx)
                beta = _beta_at(speed * per_step, table, slopes)
                t += dt
            phases.append(phase)
            courses.append(course)
            betas.append(beta)
        if keep:
            self.t, self.fx, self.fy, self.fs, self.phase, self.course = (
                t,
                fx,
                fy,
                fs,
                phase,
                course,
            )
        return phases, courses, betas


_CLOCK_STEP = 0.5  # s: integration step of the pattern clock
_COURSE_MIN_SPEED = 0.3  # m/s: slower, the course is held (a stopped convoy has none)
