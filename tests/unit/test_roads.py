"""The generated roads: every named kind and variant is a drive as asked."""

from __future__ import annotations

import numpy as np
import pytest

from convoy_mav.tracks.roads import KINDS, VARIANTS, RoadTrack


def _roads() -> list[tuple[str, RoadTrack]]:
    rng = np.random.default_rng
    return [(k, make(rng(7))) for k, make in {**KINDS, **VARIANTS}.items()]


@pytest.mark.parametrize(("name", "road"), _roads(), ids=lambda v: v if isinstance(v, str) else "")
def test_a_road_is_a_drive_of_nine_minutes_or_more_at_road_speeds(
    name: str, road: RoadTrack
) -> None:
    t = road.t
    assert np.all(np.diff(t) >= 0.0) and t[-1] - t[0] >= 540.0
    step = np.diff(t)
    speed = np.hypot(np.diff(road.true_north), np.diff(road.true_east))[step > 0] / step[step > 0]
    assert speed.max() <= 15.0 + 1e-6  # (the fastest variant drives at 15 m/s)
    # Noise is the recorded fixes' alone: the true path is where it drove.
    off = np.hypot(road.north - road.true_north, road.east - road.true_east)
    assert np.median(off) <= 8.0
    assert road.length_m > 1000.0


def test_the_variants_are_the_kinds_with_other_numbers() -> None:
    rng = np.random.default_rng
    fast = VARIANTS["stops of 60 s from 12 m/s"](rng(7))
    step = np.diff(fast.t)
    speed = np.hypot(np.diff(fast.true_north), np.diff(fast.true_east)) / step
    assert speed.max() == pytest.approx(12.0, abs=0.05)
    assert np.sum(speed < 0.01) >= 4 * 55  # four stops of a minute
    coarse = VARIANTS["urban at 0.5 Hz"](rng(7))
    assert np.median(np.diff(coarse.t)) == pytest.approx(2.0)
