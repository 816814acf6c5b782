"""The standard atmosphere: ArduPlane scales its loiters by its density ratio."""

from __future__ import annotations

import math

import pytest

from convoy_mav.atmosphere import density_ratio, eas2tas, eas2tas_squared, l1_loiter_scale


@pytest.mark.parametrize(
    ("amsl", "ratio"),
    [(0.0, 1.0), (1000.0, 0.90748), (3000.0, 0.74215), (11000.0, 0.29707)],  # ISA tables
)
def test_the_density_ratio_is_the_standard_atmospheres(amsl: float, ratio: float) -> None:
    assert density_ratio(amsl) == pytest.approx(ratio, abs=5e-5)
    assert eas2tas_squared(amsl) == pytest.approx(1.0 / ratio, rel=1e-4)
    assert eas2tas(amsl) == pytest.approx(math.sqrt(1.0 / ratio), rel=1e-4)


def test_air_thins_with_altitude() -> None:
    heights = [-500.0, 0.0, 500.0, 2000.0, 8000.0]
    ratios = [density_ratio(h) for h in heights]
    assert ratios == sorted(ratios, reverse=True)


@pytest.mark.parametrize("amsl", [math.nan, math.inf, -600.0, 12000.0])
def test_an_altitude_outside_the_troposphere_is_refused(amsl: float) -> None:
    with pytest.raises(ValueError, match="AMSL"):
        density_ratio(amsl)


@pytest.mark.parametrize("amsl", [math.nan, -600.0, 12000.0])
def test_l1_leaves_a_loiter_unscaled_where_the_model_has_no_answer(amsl: float) -> None:
    assert l1_loiter_scale(amsl) == 1.0
    assert l1_loiter_scale(1000.0) == eas2tas_squared(1000.0)
