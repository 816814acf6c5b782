"""The convoy model given the true future: the bound on what a better forecast buys."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convoy_mav.mission.choose import road_fleet
from convoy_mav.mission.convoy_model import ConvoyModel
from convoy_mav.mission.foresight import Foresight
from convoy_mav.mission.simulate import RoadRun, fly_road
from convoy_mav.planning import PlanRequest
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import junction
from convoy_mav.types import ConvoyEstimate

# A convoy driving east at 8 m/s for 50 s, then north at 5 m/s (a corner at (400, 0)).
T = np.arange(0.0, 101.0)
X = np.where(T <= 50.0, 8.0 * T, 400.0)
Y = np.where(T <= 50.0, 0.0, 5.0 * (T - 50.0))
ROUTE = Road.from_points(X, Y, smooth_m=1.0)


def test_the_whole_future_is_the_truth() -> None:
    model = Foresight(ConvoyModel(), T, X, Y, math.inf)
    model.observe(ConvoyEstimate(40.0, 3.0, 330.0, 0.5, 7.0))  # (an estimate a bit off)
    times = np.array([40.0, 45.0, 60.0, 90.0])
    x, y = model.positions(times)
    np.testing.assert_allclose(x, [320.0, 360.0, 400.0, 400.0])
    np.testing.assert_allclose(y, [0.0, 0.0, 50.0, 200.0])
    assert model.position(60.0) == pytest.approx((400.0, 50.0))


def test_the_present_known_exactly_is_driven_on_at_the_true_velocity() -> None:
    """Horizon 0: the estimate's lag and noise are gone, the corner ahead is not seen."""
    model = Foresight(ConvoyModel(), T, X, Y, 0.0)
    model.observe(ConvoyEstimate(40.0, 3.0, 330.0, 0.5, 7.0))
    x, y = model.positions(np.array([40.0, 50.0, 60.0]))
    np.testing.assert_allclose(x, [320.0, 400.0, 480.0])
    np.testing.assert_allclose(y, [0.0, 0.0, 0.0], atol=1e-9)


def test_past_its_horizon_a_routed_convoy_drives_on_along_the_route() -> None:
    """Ten seconds of truth, then the truth's speed then (8 m/s), along the route: round
    the corner at (400, 0) and north, not on east past it."""
    model = Foresight(ConvoyModel(ROUTE), T, X, Y, 10.0)
    model.observe(ConvoyEstimate(35.0, 0.0, 280.0, 0.0, 8.0))
    x, y = model.positions(np.array([40.0, 45.0, 55.0, 60.0]))
    np.testing.assert_allclose(x, [320.0, 360.0, 400.0, 400.0], atol=1.0)
    np.testing.assert_allclose(y, [0.0, 0.0, 40.0, 80.0], atol=2.0)


def test_past_its_horizon_a_routed_convoy_stops_at_the_routes_end() -> None:
    """The truth's speed along the route carries the convoy to the route's end, where
    the service's forecast stops it too (its destination), not straight on past it."""
    model = Foresight(ConvoyModel(ROUTE), T, X, Y, 10.0)
    model.observe(ConvoyEstimate(80.0, 150.0, 400.0, 5.0, 0.0))
    x, y = model.positions(np.array([90.0, 110.0, 200.0]))
    end = ROUTE.point(ROUTE.length)
    np.testing.assert_allclose(x, [400.0, end.x, end.x], atol=1.0)
    np.testing.assert_allclose(y, [200.0, end.y, end.y], atol=1.0)
    assert end.y == pytest.approx(250.0, abs=1.0)


def test_without_an_estimate_it_forecasts_as_the_model_does() -> None:
    model = Foresight(ConvoyModel(), T, X, Y, 5.0)
    x, y = model.positions(np.array([0.0, 1.0]))
    np.testing.assert_array_equal(x, [0.0, 0.0])
    np.testing.assert_array_equal(y, [0.0, 0.0])


@pytest.mark.parametrize(
    ("horizon", "t", "x", "y"),
    [
        (-1.0, T, X, Y),
        (math.nan, T, X, Y),
        (1.0, T[:1], X[:1], Y[:1]),
        (1.0, T, X[:-1], Y),
    ],
)
def test_a_bad_horizon_or_truth_is_refused(
    horizon: float, t: np.ndarray, x: np.ndarray, y: np.ndarray
) -> None:
    with pytest.raises(ValueError, match=r"horizon|true track"):
        Foresight(ConvoyModel(), t, x, y, horizon)


def test_given_the_future_the_fleet_closes_the_gap_at_an_unforeseen_junction() -> None:
    """No route: a 10-s stop, then a 90-deg turn. The service's own forecast leaves the
    convoy unseen 15.5 s after it; with its future known the same fleet and legs see it
    throughout but for 0.5 s: that loss is the forecast's, not the fleet's."""
    request = PlanRequest(150.0, 100.0, 18.0)
    road = junction(10.0, 90.0, 2576.0)
    uavs = road_fleet(request.turn_radius, request.sensor_radius)

    def fly(foresight_s: float | None) -> RoadRun:
        return fly_road(
            road.t, road.north, road.east, request, uavs, true_north=road.true_north,
            true_east=road.true_east, foresight_s=foresight_s,
        )  # fmt: skip

    flown, foreseen = fly(None), fly(math.inf)
    assert foreseen.protect_start is not None
    assert foreseen.coverage >= 0.99 and foreseen.longest_gap_s <= 2.0
    assert foreseen.coverage > flown.coverage
