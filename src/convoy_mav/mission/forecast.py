"""The convoy and the pattern over a re-plan's horizon, and what a path sees of them.

Design rules:
- One ``Forecast`` per re-plan: the convoy's predicted path (``ConvoyModel``)
  and the pattern clock run forward over it (``PatternClock.forecast``), on a
  ``FORECAST_STEP`` grid and interpolated between; every UAV re-planned then
  reads the same one.
- A ``Watch`` is the forecast convoy over the next seconds, sampled every
  ``KEEP_STEP``: what the road mission weighs one path against another by
  (keeping a path in force, filling a hole). With a route it can hold two
  convoys, sample by sample, once they part within its horizon (``Hedge``):
  the forecast one and the other course the route leaves open. Driving
  towards a sharp corner, the convoy may stop short of it (a junction,
  ``ConvoyModel.stopping_short``); standing, it may drive off along the
  route (``ConvoyModel.driving_off``). A path is worth the seconds it sees
  of the first, plus those of the other at the other's weight. The pattern
  and the legs follow the first: a hedge in the choices ...
- ... and, for a standing convoy, in the plan too: the pattern is laid
  round a point ``drive_off_blend`` of the way from the convoy standing to
  it driving off now (``centre``). At the midpoint a meeting sees the convoy
  either way while the two lie within 2r of each other: some 30 s of
  meetings ahead at 8 m/s, more than a re-plan's interval. Laid round the
  standing convoy alone, every meeting jumps forward when it pulls away, and
  the legs planned for them are late together (urban grids with a route,
  eleven seeds: 93.4 -> 94.3 % in simulation). Driving, the stop short of a
  corner is not blended: it cost as much on the grids as it gained.
- Pure: values in, arrays out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from convoy_mav.mission.convoy_model import ConvoyModel
from convoy_mav.planning.meets import Where
from convoy_mav.planning.pattern import PatternClock, relative_offsets
from convoy_mav.planning.plan import Trajectory

__all__ = ["FORECAST_STEP", "KEEP_STEP", "Forecast", "Hedge", "Watch"]

FloatArray = npt.NDArray[np.float64]

FORECAST_STEP = 0.5  # s
KEEP_STEP = 1.0  # s: resolution of the comparison of a path in force with its re-plan


@dataclass(frozen=True, slots=True)
class Hedge:
    """The other course a ``Watch`` weighs paths on, with a route (``RoadSettings``).

    Attributes:
        corner_curvature: Moving, the convoy may stop short of the next corner sharper
            than this, 1/m (0: never) ...
        corner_short_m: ... this many metres short of it; weighed as the forecast is.
        drive_off_below_mps: Slower than this along the route, the convoy may drive off
            (0: never) ...
        drive_off_accel: ... at this acceleration, m/s^2, up to its last driving speed;
        drive_off_weight: ... a second of it is worth this many of the forecast's;
        drive_off_blend: ... the pattern is laid this fraction of the way from the
            convoy standing to it driving off (0: round the standing convoy).
    """

    corner_curvature: float
    corner_short_m: float
    drive_off_below_mps: float
    drive_off_accel: float
    drive_off_weight: float
    drive_off_blend: float = 0.0


class Forecast:
    """The pattern's clock and the convoy's path over a horizon, on a grid (interpolated).

    ``cx``, ``cy``: the convoy as forecast; ``px``, ``py``: the centre the pattern
    is laid round (the same unless a standing convoy's drive-off is blended in).
    """

    def __init__(
        self,
        clock: PatternClock,
        model: ConvoyModel,
        t: float,
        horizon: float,
        radius: float,
        V: float,
        *,
        hedge: Hedge | None = None,
    ) -> None:
        n = max(2, math.ceil(horizon / FORECAST_STEP) + 1)
        self.t: FloatArray = (t + FORECAST_STEP * np.arange(n)).astype(np.float64)
        self.cx, self.cy = model.positions(self.t)
        # The other course a Watch weighs paths on, and what a second of it is worth.
        self.other: tuple[FloatArray, FloatArray] | None = None
        self.other_weight = 1.0
        self.px, self.py = self.cx, self.cy
        if hedge is not None:
            self._hedge(model, hedge)
        vx = np.gradient(self.px, FORECAST_STEP)
        vy = np.gradient(self.py, FORECAST_STEP)
        self.phase, course, self.beta = clock.forecast(self.t, vx, vy, radius, V)
        self.course = np.unwrap(course)
        self.radius = radius

    def _hedge(self, model: ConvoyModel, hedge: Hedge) -> None:
        if hedge.drive_off_below_mps > 0.0 and hedge.drive_off_weight > 0.0:
            off = model.driving_off(self.t, hedge.drive_off_below_mps, hedge.drive_off_accel)
            if off is not None:
                self.other, self.other_weight = off, hedge.drive_off_weight
                f = hedge.drive_off_blend
                self.px = (1.0 - f) * self.cx + f * off[0]
                self.py = (1.0 - f) * self.cy + f * off[1]
                return
        if hedge.corner_curvature > 0.0:
            self.other = model.stopping_short(self.t, hedge.corner_curvature, hedge.corner_short_m)

    def pattern(self, offset: float) -> Where:
        """Where the pattern puts the UAV of phase ``offset`` at given times (vectorised)."""

        def where(times: FloatArray) -> tuple[FloatArray, FloatArray]:
            t = self.t
            cx, cy = self.centre(times)
            ph = np.interp(times, t, self.phase) + offset
            co = np.interp(times, t, self.course)
            be = np.interp(times, t, self.beta)
            qx, qy = relative_offsets(ph, be, self.radius)
            c, s = np.cos(co), np.sin(co)
            return cx + c * qx - s * qy, cy + s * qx + c * qy

        return where

    def centre(self, times: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Where the pattern is laid round at given times (vectorised, a ``Where``): the
        convoy as forecast, or a standing one's blend with its driving off."""
        return np.interp(times, self.t, self.px), np.interp(times, self.t, self.py)

    def meetings(self, offset: float, after: float) -> list[float]:
        """Times after ``after`` at which ``phase + offset`` crosses a whole number."""
        ph = self.phase + offset
        whole = np.floor(ph)
        k = np.nonzero(whole[1:] > whole[:-1])[0] + 1  # steps that cross one
        # The crossing, interpolated inside its step.
        f = (whole[k] - ph[k - 1]) / np.maximum(ph[k] - ph[k - 1], 1e-12)
        times = self.t[k - 1] + f * FORECAST_STEP
        return [float(tm) for tm in times if tm > after]


class Watch:
    """The forecast convoy over the next ``horizon`` seconds, sampled every ``KEEP_STEP``,
    and which of those samples a path sees."""

    def __init__(self, forecast: Forecast, horizon: float, sensor_radius: float) -> None:
        k = min(len(forecast.t), int(horizon / FORECAST_STEP) + 1)
        every = max(1, round(KEEP_STEP / FORECAST_STEP))
        self.times, self.cx, self.cy = (a[:k:every] for a in (forecast.t, forecast.cx, forecast.cy))
        # What a sample is worth, seconds (None: KEEP_STEP each).
        self.worth: FloatArray | None = None
        other = None if forecast.other is None else [a[:k:every] for a in forecast.other]
        if other is not None and not (
            np.array_equal(other[0], self.cx) and np.array_equal(other[1], self.cy)
        ):
            # Each time twice (still ascending): the forecast convoy, then the other.
            self.times = np.repeat(self.times, 2)
            self.cx = np.column_stack([self.cx, other[0]]).reshape(-1)
            self.cy = np.column_stack([self.cy, other[1]]).reshape(-1)
            if forecast.other_weight != 1.0:
                self.worth = np.tile([KEEP_STEP, KEEP_STEP * forecast.other_weight], len(other[0]))
        self.r = sensor_radius
        # Paths seen already (by identity; the path is held so its id stays its own):
        # a step that re-plans several UAVs asks of each other UAV's path each time.
        self._seen: dict[int, tuple[Trajectory, npt.NDArray[np.bool_]]] = {}

    def sees(self, path: Trajectory) -> npt.NDArray[np.bool_]:
        """Samples of the convoy within the sensor radius of ``path`` (read-only)."""
        hit = self._seen.get(id(path))
        if hit is not None and hit[0] is path:
            return hit[1]
        x, y = path.positions(self.times)
        seen = np.hypot(x - self.cx, y - self.cy) <= self.r
        seen.flags.writeable = False
        self._seen[id(path)] = (path, seen)
        return seen

    def seconds(self, seen: npt.NDArray[np.bool_]) -> float:
        """Seconds of convoy ``seen`` covers (of each course at its weight, added, when two)."""
        if self.worth is None:
            return KEEP_STEP * float(np.count_nonzero(seen))
        return float(np.sum(self.worth[seen]))
