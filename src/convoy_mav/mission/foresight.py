"""A convoy model that knows the convoy's true path for the next seconds: the bound
on what a better forecast could buy (simulation only).

Design rules:
- The road mission plans on ``ConvoyModel.positions`` alone; everything else
  it asks of the model (the estimate, the route, the hedges) is the service's
  own. ``Foresight`` answers ``positions`` from the convoy's true track for
  the next ``horizon`` seconds, and past that holds the truth's velocity
  (no route) or its speed along the route: what a forecast that is exact
  for ``horizon`` seconds would say. ``horizon`` 0 is the present known
  exactly (position and velocity, no tracker lag); ``inf`` the whole future.
- The gap between a road's coverage as flown and with foresight is the loss
  to the forecast; what foresight leaves is the loss to the fleet and its
  legs (``benchmarks/road_table.py --foresight``).
- Pure: the truth is arrays in, positions out.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from convoy_mav.mission.convoy_model import ConvoyModel

__all__ = ["Foresight"]

FloatArray = npt.NDArray[np.float64]

_VELOCITY_SPAN_S = 1.0  # the truth's velocity is its central difference over this


class Foresight(ConvoyModel):
    """``model``'s convoy model, forecasting from the true track for ``horizon`` seconds.

    Args:
        model: The model the mission would have planned with (its settings and route).
        t: Times of the true track, mission seconds, ascending.
        x, y: Where the convoy truly was then (planner frame: x east, y north).
        horizon: Seconds of the true future the forecast is given (>= 0, may be inf).

    Raises:
        ValueError: If ``horizon`` is negative or NaN, or the track is shorter than
            two points or its arrays differ in length.
    """

    def __init__(
        self,
        model: ConvoyModel,
        t: npt.ArrayLike,
        x: npt.ArrayLike,
        y: npt.ArrayLike,
        horizon: float,
    ) -> None:
        super().__init__(
            model.route,
            off_route_m=model.off_route_m,
            off_route_s=model.off_route_s,
            relax_s=model.relax_s,
            mean_window_s=model.mean_window_s,
        )
        if not horizon >= 0.0:
            raise ValueError(f"horizon must be >= 0, got {horizon!r}")
        self._t, self._x, self._y = (np.asarray(a, dtype=np.float64) for a in (t, x, y))
        if len(self._t) < 2 or not len(self._t) == len(self._x) == len(self._y):
            raise ValueError("the true track needs two points or more, in arrays of one length")
        self.horizon = horizon

    def _truth(self, times: FloatArray) -> tuple[FloatArray, FloatArray]:
        return np.interp(times, self._t, self._x), np.interp(times, self._t, self._y)

    def positions(self, times: npt.NDArray[np.float64]) -> tuple[FloatArray, FloatArray]:
        """Where the convoy truly is at ``times`` up to ``horizon`` past the estimate;
        later, the truth then driven on at its velocity then (along the route, if any, as
        the service's forecast does: to its end, not past it)."""
        est = self.estimate
        if est is None:
            return super().positions(times)
        edge = min(est.t + self.horizon, float(self._t[-1]))
        x, y = self._truth(np.minimum(times, edge))
        beyond = np.maximum(times - edge, 0.0)
        if not np.any(beyond > 0.0):
            return x, y
        h = 0.5 * _VELOCITY_SPAN_S
        (x0, x_edge, x1), (y0, y_edge, y1) = self._truth(np.array([edge - h, edge, edge + h]))
        vx, vy = (x1 - x0) / _VELOCITY_SPAN_S, (y1 - y0) / _VELOCITY_SPAN_S
        route = self.road
        if route is None or self._off_road:
            return x + vx * beyond, y + vy * beyond
        s_edge = route.project(float(x_edge), float(y_edge), self._s)
        heading = route.point(s_edge).heading
        along = max(0.0, vx * math.cos(heading) + vy * math.sin(heading))
        rx, ry, _, _ = route.arrays(np.minimum(s_edge + along * beyond, route.length))
        late = beyond > 0.0
        return np.where(late, rx, x), np.where(late, ry, y)

    def position(self, t: float) -> tuple[float, float]:
        """:meth:`positions` at one time."""
        x, y = self.positions(np.array([t], dtype=np.float64))
        return float(x[0]), float(y[0])
