"""Where a drive stood still (``tracks.stops``): clean and noisy stands, a crawl is none."""

from __future__ import annotations

import numpy as np
import pytest

from convoy_mav.tracks.roads import road_kind
from convoy_mav.tracks.stops import standstills


def test_a_generated_roads_stops_are_found_where_and_as_long_as_they_were() -> None:
    road = road_kind("stop-and-go")  # stops of 120, 120 and 30 s
    stands = standstills(road.t, road.true_north, road.true_east)
    assert [round(s.seconds) for s in stands] == pytest.approx([120, 120, 30], abs=3)
    for stand in stands:
        k = stand.index
        assert np.hypot(road.true_north[k] - stand.north, road.true_east[k] - stand.east) < 1.0


def test_a_noisy_stand_is_one_stand() -> None:
    """The urban grid's fixes (3 m of GPS noise at 1 Hz) give the stands its truth does,
    each within a few seconds, none split in two."""
    road = road_kind("urban")
    true = standstills(road.t, road.true_north, road.true_east)
    noisy = standstills(road.t, road.north, road.east)
    assert len(noisy) == len(true) == 10
    for a, b in zip(true, noisy, strict=True):
        assert abs(a.t - b.t) < 8.0 and abs(a.seconds - b.seconds) < 8.0
        assert np.hypot(a.north - b.north, a.east - b.east) < 5.0


def test_a_crawl_and_a_short_halt_are_no_stands() -> None:
    t = np.arange(0.0, 200.0)
    crawl = 2.0 * t  # 2 m/s throughout
    assert standstills(t, crawl, np.zeros_like(t)) == []
    halt = np.where(t < 50, 8.0 * t, np.where(t < 54, 400.0, 400.0 + 8.0 * (t - 54)))
    assert standstills(t, halt, np.zeros_like(t)) == []  # 4 s: not a hold
    end = np.minimum(8.0 * t, 800.0)  # parked at the end, 100 s
    (last,) = standstills(t, end, np.zeros_like(t))
    assert last.seconds == pytest.approx(99.0, abs=1.0)


def test_bad_arrays_are_refused() -> None:
    with pytest.raises(ValueError, match="lengths 3, 2, 3 differ"):
        standstills([0, 1, 2], [0, 1], [0, 1, 2])
    with pytest.raises(ValueError, match="increase strictly"):
        standstills([0, 1, 1], [0, 1, 2], [0, 1, 2])
