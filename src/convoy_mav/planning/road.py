"""The convoy's road as a smooth curve: arc length, heading, curvature, Frenet frame.

Design rules:
- Planner frame (x east, y north, heading counter-clockwise from +x, metres).
- Built from points as they come (a route file, or the convoy's own fixes):
  near-repeats dropped, resampled by arc length, then smoothed with a
  Gaussian of ``smooth_m`` along the curve, so GPS jitter never reaches the
  heading or the curvature (both come from the smoothed curve, never from a
  raw finite difference of fixes).
- Beyond either end the road goes on straight along its end heading: a
  convoy that drives past the last known point is still somewhere.
- Queries are closed form on the resampled grid (linear interpolation), for
  one arc length or a NumPy vector of them.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from convoy_mav.errors import PlanningError
from convoy_mav.geo import GeoPoint, LocalFrame

__all__ = ["Road", "RoadPoint", "path_lengths"]

FloatArray = npt.NDArray[np.float64]

#: Grid spacing of the resampled road, metres.
_STEP_M = 2.0


@dataclass(frozen=True, slots=True)
class RoadPoint:
    """The road at one arc length: position, heading and signed curvature (> 0 left)."""

    s: float
    x: float
    y: float
    heading: float
    curvature: float


def path_lengths(points: Iterable[tuple[float, float]]) -> list[float]:
    """The distance along a polyline to each of its points (the first 0)."""
    xy = np.asarray(list(points), dtype=np.float64).reshape(-1, 2)
    steps = np.hypot(*np.diff(xy, axis=0).T) if len(xy) > 1 else np.zeros(0)
    return [0.0, *np.cumsum(steps).tolist()] if len(xy) else []


def _resample(x: FloatArray, y: FloatArray, step: float) -> tuple[FloatArray, FloatArray]:
    seg = np.hypot(np.diff(x), np.diff(y))
    s = np.concatenate(([0.0], np.cumsum(seg)))
    n = max(2, math.ceil(s[-1] / step) + 1)
    grid = np.linspace(0.0, s[-1], n)
    return np.interp(grid, s, x), np.interp(grid, s, y)


def _smooth(v: FloatArray, sigma: float) -> FloatArray:
    """Gaussian smoothing with linear extrapolation past the ends (no pull at the ends)."""
    if sigma <= 0.0 or len(v) < 3:
        return v
    half = math.ceil(3.0 * sigma)
    k = np.arange(-half, half + 1, dtype=np.float64)
    kernel = np.exp(-0.5 * (k / sigma) ** 2)
    kernel /= kernel.sum()
    m = min(len(v) - 1, max(1, int(3.0 * sigma)))  # (a slope over a long base: noise-proof)
    head = v[0] + (v[0] - v[m]) / m * np.arange(half, 0, -1)
    tail = v[-1] + (v[-1] - v[-1 - m]) / m * np.arange(1, half + 1)
    padded = np.concatenate((head, v, tail))
    return np.convolve(padded, kernel, mode="valid")


@dataclass(frozen=True)
class Road:
    """A smooth curve with arc length, heading and curvature on a uniform grid.

    Use :meth:`from_points` to build one; the fields are the grid.

    Attributes:
        s: Arc lengths of the grid, metres from the first point (uniform).
        x, y: Positions on the grid.
        heading: Unwrapped heading on the grid, rad counter-clockwise from +x.
        curvature: Signed curvature on the grid, 1/m (> 0 turning left).
    """

    s: FloatArray
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    curvature: FloatArray
    _step: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if len(self.s) < 2:
            raise PlanningError("a road needs at least two grid points")
        object.__setattr__(self, "_step", float(self.s[1] - self.s[0]))

    @classmethod
    def from_points(cls, xs: npt.ArrayLike, ys: npt.ArrayLike, *, smooth_m: float = 15.0) -> Road:
        """The road through ``(xs, ys)`` (planner frame), smoothed over ``smooth_m``.

        Points closer than a metre to the previous one are dropped (a parked or
        crawling convoy reports the same place many times).

        Raises:
            PlanningError: If fewer than two distinct finite points remain.
        """
        px = np.asarray(xs, dtype=np.float64)
        py = np.asarray(ys, dtype=np.float64)
        ok = np.isfinite(px) & np.isfinite(py)
        px, py = px[ok], py[ok]
        keep_x: list[float] = []
        keep_y: list[float] = []
        for xi, yi in zip(px.tolist(), py.tolist(), strict=True):
            if not keep_x or math.hypot(xi - keep_x[-1], yi - keep_y[-1]) >= 1.0:
                keep_x.append(xi)
                keep_y.append(yi)
        if len(keep_x) < 2:
            raise PlanningError("a road needs two distinct points at least a metre apart")
        rx, ry = _resample(np.array(keep_x), np.array(keep_y), _STEP_M)
        sigma = smooth_m / _STEP_M
        rx, ry = _resample(_smooth(rx, sigma), _smooth(ry, sigma), _STEP_M)
        step = float(np.hypot(rx[1] - rx[0], ry[1] - ry[0]))
        s = np.arange(len(rx), dtype=np.float64) * step
        heading = np.unwrap(np.arctan2(np.gradient(ry), np.gradient(rx)))
        curvature = _smooth(np.gradient(heading, step), 2.0) if len(s) > 2 else np.zeros(2)
        return cls(s, rx, ry, heading, curvature)

    @classmethod
    def from_geo(cls, points: Iterable[tuple[float, float]], frame: LocalFrame) -> Road:
        """The road through WGS-84 ``(lat, lon)`` points, in ``frame`` (x east, y north).

        Raises:
            PlanningError: As :meth:`from_points`.
        """
        ned = [frame.to_ned(GeoPoint(lat, lon)) for lat, lon in points]
        return cls.from_points([p[1] for p in ned], [p[0] for p in ned])

    @classmethod
    def straight(cls, x: float, y: float, heading: float, length: float = 100.0) -> Road:
        """A straight road from (x, y) along ``heading`` (a convoy with no history yet)."""
        n = max(2, int(length / _STEP_M) + 1)
        s = np.linspace(0.0, length, n)
        return cls(
            s,
            x + s * math.cos(heading),
            y + s * math.sin(heading),
            np.full(n, heading),
            np.zeros(n),
        )

    @property
    def length(self) -> float:
        """Arc length of the known road, metres."""
        return float(self.s[-1])

    def point(self, s: float) -> RoadPoint:
        """The road at arc length ``s`` (straight on past either end)."""
        x, y, h, k = self.arrays(np.array([s], dtype=np.float64))
        return RoadPoint(s, float(x[0]), float(y[0]), float(h[0]), float(k[0]))

    def arrays(self, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """Vectorised :meth:`point`: (x, y, heading, curvature) at each arc length."""
        inside = np.clip(s, 0.0, self.s[-1])
        x = np.interp(inside, self.s, self.x)
        y = np.interp(inside, self.s, self.y)
        h = np.interp(inside, self.s, self.heading)
        k = np.interp(inside, self.s, self.curvature)
        beyond = s - inside  # < 0 before the start, > 0 past the end
        if np.any(beyond != 0.0):
            x = x + beyond * np.cos(h)
            y = y + beyond * np.sin(h)
            k = np.where(beyond != 0.0, 0.0, k)
        return x, y, h, k

    def frenet(
        self, s: FloatArray, d: FloatArray, *, fold: float = 0.8
    ) -> tuple[FloatArray, FloatArray]:
        """Points ``d`` metres left of the road at arc lengths ``s``.

        On the inside of a bend an offset is capped at ``fold`` times the bend's
        radius, where the offset curves would otherwise cross each other.
        """
        x, y, h, k = self.arrays(s)
        limit = fold / np.maximum(np.abs(k), 1e-9)
        inside = np.sign(d) == np.sign(k)
        d = np.where(inside & (np.abs(d) > limit), np.sign(d) * limit, d)
        return x - d * np.sin(h), y + d * np.cos(h)

    def project(
        self, x: float, y: float, near: float | None = None, window: float = 400.0
    ) -> float:
        """Arc length of the road point nearest (x, y), searched within ``window`` of ``near``.

        Past either end the straight extension is used, so the result may be
        negative or beyond :attr:`length`.
        """
        if near is None:
            lo, hi = 0, len(self.s)
        else:
            lo = max(0, int((near - window) / self._step))
            hi = min(len(self.s), int((near + window) / self._step) + 2)
            if lo >= hi:
                lo, hi = (len(self.s) - 2, len(self.s)) if near > 0 else (0, 2)
        dx = self.x[lo:hi] - x
        dy = self.y[lo:hi] - y
        i = lo + int(np.argmin(dx * dx + dy * dy))
        # Refine on the grid segment(s) next to the nearest grid point.
        best_s, best_d = float(self.s[i]), math.inf
        for j in (i - 1, i):
            if j < 0 or j + 1 >= len(self.s):
                continue
            ax, ay = self.x[j], self.y[j]
            bx, by = self.x[j + 1] - ax, self.y[j + 1] - ay
            seg2 = bx * bx + by * by
            u = 0.0 if seg2 == 0.0 else ((x - ax) * bx + (y - ay) * by) / seg2
            u = min(max(u, 0.0), 1.0)
            dist = math.hypot(ax + u * bx - x, ay + u * by - y)
            if dist < best_d:
                best_s, best_d = float(self.s[j] + u * self._step), dist
        for end, sign in ((0, -1.0), (len(self.s) - 1, 1.0)):
            if i == end:  # maybe past the end, on the straight extension
                h = self.heading[end]
                along = (x - self.x[end]) * math.cos(h) + (y - self.y[end]) * math.sin(h)
                if along * sign > 0.0:
                    return float(self.s[end] + along)
        return best_s

    def project_along(
        self, points: Iterable[tuple[float, float, float]], window: float = 100.0
    ) -> list[float]:
        """Arc lengths of (x, y, driven) points in driving order, ``driven`` the distance
        driven to each: each is looked for near the last one's arc plus the distance
        driven since, so a point of a road that comes back along itself is found on its
        own pass (the road's smoothing cuts corners: the gap is counted afresh from
        each)."""
        out: list[float] = []
        arc, run = 0.0, 0.0
        for x, y, driven in points:
            arc, run = self.project(x, y, arc + driven - run, window), driven
            out.append(arc)
        return out

    def place(
        self,
        north: Sequence[float] | FloatArray,
        east: Sequence[float] | FloatArray,
        marks: Iterable[tuple[int, float]],
    ) -> tuple[tuple[float, float], ...]:
        """(index of a point of the polyline ``north``/``east``, value) marks, in the
        polyline's order, as (arc length on this road, value): :meth:`project_along`
        with the distance driven to each point (indices outside it are left out)."""
        n = len(north)
        kept = sorted((i, value) for i, value in marks if 0 <= i < n)
        driven = path_lengths(zip(north, east, strict=True))
        arcs = self.project_along((float(east[i]), float(north[i]), driven[i]) for i, _ in kept)
        return tuple(zip(arcs, (value for _, value in kept), strict=True))

    def reversed(self) -> Road:
        """The same road driven the other way: arc length from the far end."""
        return Road(
            self.s.copy(),
            self.x[::-1].copy(),
            self.y[::-1].copy(),
            self.heading[::-1] + math.pi,
            -self.curvature[::-1],
        )

    def nearest_heading(
        self, x: float, y: float, course: float, within: float = math.radians(45.0)
    ) -> tuple[float, float] | None:
        """(arc length, distance) of the grid point nearest (x, y) anywhere on the road
        among those whose heading is within ``within`` rad of ``course``; None if none is.

        The whole road is searched, for a convoy found again after it left the road,
        drove past its end (a loop lapped) or turned back; the heading keeps it off the
        other carriageway of a road that doubles back.
        """
        ok = np.cos(self.heading - course) >= math.cos(within)
        if not ok.any():
            return None
        d2 = np.where(ok, (self.x - x) ** 2 + (self.y - y) ** 2, np.inf)
        i = int(np.argmin(d2))
        return float(self.s[i]), math.sqrt(float(d2[i]))

    def max_curvature(self, s0: float = 0.0, s1: float | None = None) -> float:
        """Largest |curvature| between arc lengths ``s0`` and ``s1`` (default: the end)."""
        hi = self.length if s1 is None else s1
        lo, up = (
            np.searchsorted(self.s, (s0, hi), side="left")[0],
            np.searchsorted(self.s, hi, side="right"),
        )
        return float(np.max(np.abs(self.curvature[lo:up]))) if up > lo else 0.0
