"""The learnt loiter overshoot: flown = c + k / c, inverted to command what is planned."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.autopilots import ArduPlane, VehicleClass
from convoy_mav.mavlink.autopilots.loiter import LoiterModel
from convoy_mav.types import Setpoint


@given(
    k=st.floats(-2000.0, 5000.0),
    radius=st.floats(150.0, 2000.0),
)
def test_the_command_flies_the_planned_radius(k: float, radius: float) -> None:
    model = LoiterModel(k=k)
    assert model.feasible(radius)  # 150 m >= 2 sqrt(5000)
    assert model.flown_radius(model.command_radius(radius)) == pytest.approx(radius, rel=1e-9)


def test_a_radius_tighter_than_the_airframe_flies_is_flagged() -> None:
    model = LoiterModel(k=(22.0 * 1.9) ** 2)  # ArduPlane SITL at 22 m/s
    tightest = 2.0 * math.sqrt(model.k)
    assert model.feasible(tightest + 0.1) and not model.feasible(tightest - 0.1)
    assert model.command_radius(50.0) == pytest.approx(tightest / 2.0)  # the tightest command


def test_the_overshoot_is_learnt_from_a_settled_loiter_only() -> None:
    k_true, c, v = (22.0 * 1.9) ** 2, 140.0, 22.0
    flown = c + k_true / c
    model = LoiterModel()
    lap = math.tau * c / v
    assert not model.observe(flown, c, held_s=0.4 * lap, speed=v)  # still turning in
    assert not model.observe(2.0 * flown, c, held_s=lap, speed=v)  # not captured
    for _ in range(1000):  # 50 s of samples at 20 Hz
        model.observe(flown, c, held_s=lap, speed=v)
    assert model.k == pytest.approx(k_true, rel=1e-3)
    assert model.samples == 1000


def _arc(radius: float, t: float = 0.0) -> Setpoint:
    return Setpoint(t, radius, 0.0, -100.0, 0.0, 22.0, 0.0, math.pi / 2, 0.0,
                    center=(0.0, 0.0), radius=radius, clockwise=True)  # fmt: skip


def test_arduplane_says_when_the_plan_is_tighter_than_it_flies() -> None:
    plane = ArduPlane(1, 1, LocalFrame(GeoPoint(47.0, 8.0, 500.0)), VehicleClass.PLANE)
    plane.setpoint_messages(_arc(80.0), 0.0, None)
    assert plane.cannot_fly() is None  # nothing learnt yet: no verdict
    plane.model.k, plane.model.samples = 1747.0, 500  # 2 sqrt(k) = 83.6 m
    plane.setpoint_messages(_arc(150.0, 1.0), 1.0, None)
    assert plane.cannot_fly() is None
    plane.setpoint_messages(_arc(80.0, 2.0), 2.0, None)
    why = plane.cannot_fly()
    assert why is not None and "84 m" in why and "80 m" in why
    learnt = plane.learnt()
    assert learnt["loiter_overshoot_m2"] == 1747.0 and learnt["tightest_loiter_m"] == 83.6
