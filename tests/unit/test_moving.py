"""Section IV of the paper: a convoy moving on a straight line."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.errors import PlanningError
from convoy_mav.planning import (
    beta_from_speed_ratio,
    coverage_fraction_moving,
    gamma_star,
    max_separation,
    min_uavs_moving,
    separation,
    v_star,
)


@settings(max_examples=200, deadline=None)
@given(st.floats(1e-4, 1 - 1e-6))
def test_lemma_4_1_beta_solves_sinc(v: float) -> None:
    beta = beta_from_speed_ratio(v)
    assert 0.0 < beta < math.pi
    assert math.sin(beta) / beta == pytest.approx(v, rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("v", [0.0, -0.1, 1.0, 1.5, math.nan])
def test_beta_rejects_ratios_outside_open_unit_interval(v: float) -> None:
    with pytest.raises(PlanningError):
        beta_from_speed_ratio(v)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.01, 3.1), st.floats(1.0, 500.0))
def test_max_separation_is_d_of_half_beta(beta: float, R: float) -> None:
    """d(beta/2) = R (1 - cos beta), and it is the maximum of d on [0, beta]."""
    assert separation(beta / 2, beta, R) == pytest.approx(R * (1 - math.cos(beta)), rel=1e-9)
    assert max_separation(beta, R) == pytest.approx(R * (1 - math.cos(beta)))
    grid = np.linspace(0.0, beta, 101)
    values = [separation(float(g), beta, R) for g in grid]
    assert max(values) <= max_separation(beta, R) * (1 + 1e-9)
    assert separation(0.0, beta, R) == pytest.approx(0.0, abs=1e-9)
    assert separation(beta, beta, R) == pytest.approx(0.0, abs=1e-9 * R)


def test_meets_convoy_at_end_of_primitive() -> None:
    # Lemma 4.1: after an arc of 2 beta the UAV is back on the convoy.
    for v in (0.1, 0.5, 0.9):
        beta = beta_from_speed_ratio(v)
        assert separation(beta, beta, 100.0) == pytest.approx(0.0, abs=1e-7)


@pytest.mark.parametrize("R_over_r", [1.1, 1.5, 2.0, 5.0, 10.0])
def test_theorem_4_2_v_star(R_over_r: float) -> None:
    """eq. (42): at V_G = V*_G the farthest excursion is exactly r."""
    r = 100.0
    R = R_over_r * r
    vs = v_star(R, r)
    assert vs == pytest.approx(math.sqrt(2 * r * R - r * r) / (R * math.acos(1 - r / R)))
    beta = beta_from_speed_ratio(vs)
    assert beta == pytest.approx(math.acos(1 - r / R), rel=1e-9)
    assert max_separation(beta, R) == pytest.approx(r, rel=1e-9)
    # Just faster: one UAV suffices.  Just slower: it does not.
    assert min_uavs_moving(R, r, vs * 1.001) == 1
    assert gamma_star(beta_from_speed_ratio(vs * 1.001), R, r) is None
    assert min_uavs_moving(R, r, vs * 0.98) >= 2


def test_v_star_when_sensor_disk_exceeds_twice_R() -> None:
    assert v_star(10.0, 25.0) == 0.0


@settings(max_examples=200, deadline=None)
@given(st.floats(1.05, 10.0), st.floats(0.02, 0.98))
def test_gamma_star_solves_eq_45(R_over_r: float, v: float) -> None:
    r = 1.0
    R = R_over_r
    beta = beta_from_speed_ratio(v)
    g = gamma_star(beta, R, r)
    if max_separation(beta, R) <= r:
        assert g is None
        assert min_uavs_moving(R, r, v) == 1
        return
    assert g is not None
    assert 0.0 < g < beta
    assert separation(g / 2, beta, R) == pytest.approx(r, rel=1e-9)
    assert min_uavs_moving(R, r, v) == math.ceil(beta / g - 1e-9)
    assert coverage_fraction_moving(R, r, v) == pytest.approx(g / beta)


def test_corollary_4_3_counts_examples() -> None:
    # R = 150 m, r = 100 m, V = 18 m/s; convoys at 2, 6 and 12 m/s.
    counts = [min_uavs_moving(150.0, 100.0, vg / 18.0) for vg in (2.0, 6.0, 12.0)]
    assert counts == [5, 4, 3]
    # Slower convoys need at least as many UAVs (beta grows, gamma* shrinks relative to it).
    ratios = np.linspace(0.05, 0.95, 40)
    series = [min_uavs_moving(150.0, 100.0, float(v)) for v in ratios]
    assert all(a >= b for a, b in itertools.pairwise(series))
