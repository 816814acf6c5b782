"""How wide a loiter is flown: s c + k / c (L1's density scaling s, the learnt overshoot
k), inverted to command what is planned."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import eas2tas_squared
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.autopilots import ArduPlane, VehicleClass
from convoy_mav.mavlink.autopilots.loiter import LoiterModel
from convoy_mav.types import Setpoint


@given(
    k=st.floats(-2000.0, 4000.0),
    radius=st.floats(150.0, 5000.0),
    scale=st.floats(1.0, 1.35),  # sea level to 3 km AMSL
)
def test_the_command_flies_the_planned_radius(k: float, radius: float, scale: float) -> None:
    model = LoiterModel(k=k)
    assert model.feasible(radius, scale)  # 150 m >= 2 sqrt(1.35 * 4000) = 147 m
    command = model.command_radius(radius, scale)
    assert model.flown_radius(command, scale) == pytest.approx(radius, rel=1e-9)
    if k >= 0.0:
        assert command <= radius  # (wider flown: commanded tighter)


def test_a_radius_tighter_than_the_airframe_flies_is_flagged() -> None:
    model = LoiterModel(k=(22.0 * 1.55) ** 2)  # ArduPlane SITL at 22 m/s
    for scale in (1.0, 1.07):
        tightest = model.tightest(scale)
        assert tightest == pytest.approx(2.0 * math.sqrt(scale * model.k))
        assert model.feasible(tightest + 0.1, scale) and not model.feasible(tightest - 0.1, scale)
        command = model.command_radius(30.0, scale)  # the tightest command
        assert model.flown_radius(command, scale) == pytest.approx(tightest)


def test_a_wide_arc_is_commanded_tighter_by_the_density_scaling() -> None:
    """ArduPlane SITL at 630 m AMSL flew a 2275 m loiter at 2438 m: the plan's 2275 m arc
    is commanded at 2275 / s, and the overshoot hardly matters that wide."""
    model = LoiterModel(k=(27.0 * 1.55) ** 2)
    scale = eas2tas_squared(630.0)
    assert model.command_radius(2275.0, scale) == pytest.approx(2275.0 / scale, abs=1.0)
    assert model.flown_radius(2275.0, scale) - 2275.0 == pytest.approx(144.0, abs=1.0)


def test_the_overshoot_is_learnt_from_a_settled_loiter_only() -> None:
    k_true, c, v, scale = (22.0 * 1.55) ** 2, 140.0, 22.0, 1.06
    flown = scale * c + k_true / c
    model = LoiterModel()
    lap = math.tau * c / v
    assert not model.observe(flown, c, held_s=0.4 * lap, speed=v, scale=scale)  # turning in
    assert not model.observe(2.0 * flown, c, held_s=lap, speed=v, scale=scale)  # not captured
    for _ in range(1000):  # 50 s of samples at 20 Hz
        model.observe(flown, c, held_s=lap, speed=v, scale=scale)
    assert model.k == pytest.approx(k_true, rel=1e-3)  # the scaling is not taken for lag
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
    # (600 m AMSL: L1 flies it 6 % wider, 2 sqrt(1.06 k) = 86 m)
    assert why is not None and "86 m" in why and "80 m" in why
    learnt = plane.learnt()
    assert learnt["loiter_overshoot_m2"] == 1747.0
    assert learnt["loiter_scale"] == pytest.approx(eas2tas_squared(600.0), abs=1e-4)
    assert learnt["tightest_loiter_m"] == pytest.approx(86.0, abs=0.1)


def test_arduplane_commands_an_arc_at_the_radius_l1_flies_as_planned() -> None:
    """The DO_REPOSITION radius of a 2000 m arc at 1000 m AMSL: 2000 / EAS2TAS^2 there."""
    plane = ArduPlane(1, 1, LocalFrame(GeoPoint(47.0, 8.0, 900.0)), VehicleClass.PLANE)
    (msg,) = plane.setpoint_messages(_arc(2000.0), 0.0, None)  # (down -100: 1000 m AMSL)
    assert msg.command == mavlink.MAV_CMD_DO_REPOSITION
    assert msg.param3 == pytest.approx(2000.0 / 1.10197, abs=0.1)
    assert plane.learnt()["loiter_scale"] == pytest.approx(1.1020, abs=1e-4)
