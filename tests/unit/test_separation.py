"""Separation conflicts by spatial hashing agree with checking every pair."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.separation import conflicts

coord = st.floats(-500.0, 500.0)


@settings(max_examples=200, deadline=None)
@given(
    st.dictionaries(st.integers(1, 300), st.tuples(coord, coord, st.floats(-120, -80)), max_size=60)
)
def test_hashing_finds_exactly_the_pairs_brute_force_finds(
    positions: dict[int, tuple[float, float, float]],
) -> None:
    found = {(c.a, c.b) for c in conflicts(positions, 40.0, 5.0)}
    brute = {
        (a, b)
        for a, b in itertools.combinations(sorted(positions), 2)
        if math.hypot(positions[a][0] - positions[b][0], positions[a][1] - positions[b][1]) < 40.0
        and abs(positions[a][2] - positions[b][2]) < 5.0
    }
    assert found == brute


def test_altitude_layers_separate_crossing_uavs() -> None:
    positions = {1: (0.0, 0.0, -100.0), 2: (5.0, 0.0, -105.0), 3: (5.0, 5.0, -101.0)}
    pairs = conflicts(positions, 30.0, 3.0)
    assert [(c.a, c.b) for c in pairs] == [(1, 3)]
    assert pairs[0].horizontal_m == pytest.approx(math.hypot(5.0, 5.0))
    with pytest.raises(ValueError):
        conflicts(positions, 0.0, 3.0)
