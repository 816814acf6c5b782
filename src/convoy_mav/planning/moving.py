"""Convoy protection for a convoy moving on a straight line (Section IV of the paper).

Design rules:
- Speeds enter as the ratio ``v = V_G / V`` of convoy speed to UAV speed; the
  paper's unit-speed results hold unchanged for that ratio.
- The UAV flies alternating maximal left/right arcs of angle ``2 beta`` and
  meets the convoy at the end of every arc (Lemma 4.1: ``v = sin(beta)/beta``).
- ``beta`` and ``gamma*`` come from monotone scalar equations, solved here by a
  safeguarded Newton/bisection iteration to machine precision (no SciPy).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from convoy_mav.errors import PlanningError

__all__ = [
    "beta_from_speed_ratio",
    "coverage_fraction_moving",
    "gamma_star",
    "max_separation",
    "min_uavs_moving",
    "separation",
    "v_star",
]


def _check_geometry(turn_radius: float, sensor_radius: float) -> None:
    for name, value in (("turn radius", turn_radius), ("sensor radius", sensor_radius)):
        if not (math.isfinite(value) and value > 0.0):
            raise PlanningError(f"{name} must be a positive finite number, got {value!r}")


def _bisect(f: Callable[[float], float], lo: float, hi: float) -> float:
    """Root of a function with a sign change on [lo, hi], to machine precision."""
    f_lo = f(lo)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        f_mid = f(mid)
        if (f_mid > 0.0) == (f_lo > 0.0):
            lo, f_lo = mid, f_mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def beta_from_speed_ratio(speed_ratio: float) -> float:
    """Solve Lemma 4.1, ``v = sin(beta)/beta``, for ``beta`` in (0, pi).

    ``sinc`` is strictly decreasing on (0, pi), so the root is unique.

    Raises:
        PlanningError: If the ratio is not in (0, 1): a convoy at least as fast
            as the UAVs cannot be circled, and a stopped one is the stationary case.
    """
    if not math.isfinite(speed_ratio) or speed_ratio <= 0.0:
        raise PlanningError(
            f"convoy/UAV speed ratio must be positive for the moving case, got {speed_ratio!r}"
        )
    if speed_ratio >= 1.0:
        raise PlanningError(
            f"convoy speed is {speed_ratio:g} x the UAV speed: the UAVs must be faster "
            "than the convoy (Section IV assumes V_G < V)"
        )
    return _bisect(lambda b: math.sin(b) / b - speed_ratio, 1e-12, math.pi)


def separation(gamma: float, beta: float, turn_radius: float) -> float:
    """Distance ``d(gamma)`` between UAV and convoy after an arc of ``2 gamma`` (eq. 43-45).

    ``p_a = 2R sin(g) [cos(b - g), -sin(b - g)]`` and
    ``p_c = [2R (g / b) sin(b), 0]`` in the frame where the convoy heads along +x.
    """
    R = turn_radius
    ax = 2.0 * R * math.sin(gamma) * math.cos(beta - gamma)
    ay = -2.0 * R * math.sin(gamma) * math.sin(beta - gamma)
    cx = 2.0 * R * gamma / beta * math.sin(beta) if beta > 0.0 else 2.0 * R * gamma
    return math.hypot(ax - cx, ay)


def max_separation(beta: float, turn_radius: float) -> float:
    """``d(beta/2) = R (1 - cos beta)``: the farthest the UAV gets from the convoy."""
    return turn_radius * (1.0 - math.cos(beta))


def v_star(turn_radius: float, sensor_radius: float) -> float:
    """Theorem 4.2 (eq. 42): the slowest convoy one UAV can protect, as a ratio of UAV speed.

    ``V*_G = sqrt(2 r R - r^2) / (R acos(1 - r/R))``; for ``r >= 2R`` every
    arc stays within r of the convoy and any speed works (returns 0).
    """
    _check_geometry(turn_radius, sensor_radius)
    R, r = turn_radius, sensor_radius
    if r >= 2.0 * R:
        return 0.0
    return math.sqrt(2.0 * r * R - r * r) / (R * math.acos(1.0 - r / R))


def gamma_star(beta: float, turn_radius: float, sensor_radius: float) -> float | None:
    """Solve ``d(gamma*/2) = r`` (eq. 45, Corollary 4.3) for gamma* in (0, beta).

    Returns None when one UAV suffices (``d(beta/2) <= r``, Theorem 4.2): then
    the UAV never leaves the convoy circle and there is no gamma*.
    """
    _check_geometry(turn_radius, sensor_radius)
    if max_separation(beta, turn_radius) <= sensor_radius:
        return None
    # d is increasing on [0, beta/2] (concave with d(0) = 0 and its maximum at beta/2).
    half = _bisect(lambda g: separation(g, beta, turn_radius) - sensor_radius, 0.0, 0.5 * beta)
    return 2.0 * half


def min_uavs_moving(turn_radius: float, sensor_radius: float, speed_ratio: float) -> int:
    """Corollary 4.3: ``N = ceil(beta / gamma*)``, or 1 when ``v >= V*_G`` (Theorem 4.2)."""
    beta = beta_from_speed_ratio(speed_ratio)
    g = gamma_star(beta, turn_radius, sensor_radius)
    if g is None:
        return 1
    ratio = beta / g
    nearest = round(ratio)
    return nearest if abs(ratio - nearest) < 1e-9 else math.ceil(ratio)


def coverage_fraction_moving(turn_radius: float, sensor_radius: float, speed_ratio: float) -> float:
    """Fraction of time one UAV sees the moving convoy: ``gamma*/beta`` (or 1)."""
    beta = beta_from_speed_ratio(speed_ratio)
    g = gamma_star(beta, turn_radius, sensor_radius)
    return 1.0 if g is None else g / beta
