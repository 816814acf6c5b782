"""The convoy and the pattern over a re-plan's horizon, and what a path sees of them.

Design rules:
- One ``Forecast`` per re-plan: the convoy's predicted path (``ConvoyModel``)
  and the pattern clock run forward over it (``PatternClock.forecast``), on a
  ``FORECAST_STEP`` grid and interpolated between; every UAV re-planned then
  reads the same one.
- A ``Watch`` is the forecast convoy over the next seconds, sampled every
  ``KEEP_STEP``: what the road mission weighs one path against another by
  (keeping a path in force, filling a hole). With a route and a sharp corner
  ahead, it holds two convoys, sample by sample: the one that drives round
  the corner and one that stops short of it (``ConvoyModel.stopping_short``),
  once they part within its horizon; a path is worth the seconds it sees of
  each, added. The pattern and the legs follow the first: a hedge in the
  choices, not in the plan.
- Pure: values in, arrays out.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from convoy_mav.mission.convoy_model import ConvoyModel
from convoy_mav.planning.meets import Where
from convoy_mav.planning.pattern import PatternClock, relative_offsets
from convoy_mav.planning.plan import Trajectory

__all__ = ["FORECAST_STEP", "KEEP_STEP", "Forecast", "Watch"]

FloatArray = npt.NDArray[np.float64]

FORECAST_STEP = 0.5  # s
KEEP_STEP = 1.0  # s: resolution of the comparison of a path in force with its re-plan


class Forecast:
    """The pattern's clock and the convoy's path over a horizon, on a grid (interpolated)."""

    def __init__(
        self,
        clock: PatternClock,
        model: ConvoyModel,
        t: float,
        horizon: float,
        radius: float,
        V: float,
        *,
        stopping: tuple[float, float] | None = None,
    ) -> None:
        n = max(2, math.ceil(horizon / FORECAST_STEP) + 1)
        self.t: FloatArray = (t + FORECAST_STEP * np.arange(n)).astype(np.float64)
        self.cx, self.cy = model.positions(self.t)
        # The convoy stopped short of the next corner sharper than stopping[0] (1/m),
        # stopping[1] metres before it: the other course a Watch weighs paths on.
        self.short = None if stopping is None else model.stopping_short(self.t, *stopping)
        vx = np.gradient(self.cx, FORECAST_STEP)
        vy = np.gradient(self.cy, FORECAST_STEP)
        phase, course, beta = clock.forecast(self.t.tolist(), vx.tolist(), vy.tolist(), radius, V)
        self.phase = np.array(phase)
        self.course = np.unwrap(np.array(course))
        self.beta = np.array(beta)
        self.radius = radius

    def pattern(self, offset: float) -> Where:
        """Where the pattern puts the UAV of phase ``offset`` at given times (vectorised)."""

        def where(times: FloatArray) -> tuple[FloatArray, FloatArray]:
            t = self.t
            cx, cy = self.convoy(times)
            ph = np.interp(times, t, self.phase) + offset
            co = np.interp(times, t, self.course)
            be = np.interp(times, t, self.beta)
            qx, qy = relative_offsets(ph, be, self.radius)
            c, s = np.cos(co), np.sin(co)
            return cx + c * qx - s * qy, cy + s * qx + c * qy

        return where

    def convoy(self, times: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Where the convoy is forecast at given times (vectorised, a ``Where``)."""
        return np.interp(times, self.t, self.cx), np.interp(times, self.t, self.cy)

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
        short = None if forecast.short is None else [a[:k:every] for a in forecast.short]
        if short is not None and not (
            np.array_equal(short[0], self.cx) and np.array_equal(short[1], self.cy)
        ):
            # Each time twice (still ascending): the convoy driving on, then stopped short.
            self.times = np.repeat(self.times, 2)
            self.cx = np.column_stack([self.cx, short[0]]).reshape(-1)
            self.cy = np.column_stack([self.cy, short[1]]).reshape(-1)
        self.r = sensor_radius

    def sees(self, path: Trajectory) -> npt.NDArray[np.bool_]:
        """Samples of the convoy within the sensor radius of ``path``."""
        s = path.sample_array(self.times)
        return np.asarray(np.hypot(s.x - self.cx, s.y - self.cy) <= self.r)

    def seconds(self, seen: npt.NDArray[np.bool_]) -> float:
        """Seconds of convoy ``seen`` covers (of each course, added, when two)."""
        return KEEP_STEP * float(np.count_nonzero(seen))
