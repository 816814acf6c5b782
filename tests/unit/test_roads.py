"""The generated roads: every named kind and variant is a drive as asked."""

from __future__ import annotations

import numpy as np
import pytest

from convoy_mav.tracks.roads import KINDS, OTHERS, VARIANTS, RoadTrack


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


def _speeds(road: RoadTrack) -> np.ndarray:
    return np.hypot(np.diff(road.true_north), np.diff(road.true_east)) / np.diff(road.t)


def test_the_variants_are_the_kinds_with_other_numbers() -> None:
    rng = np.random.default_rng
    fast = VARIANTS["stops of 60 s from 12 m/s"](rng(7))
    speed = _speeds(fast)
    assert speed.max() == pytest.approx(12.0, abs=0.05)
    assert np.sum(speed < 0.01) >= 4 * 55  # four stops of a minute
    coarse = VARIANTS["urban at 0.5 Hz"](rng(7))
    assert np.median(np.diff(coarse.t)) == pytest.approx(2.0)


def _turned_deg(road: RoadTrack) -> np.ndarray:
    """The course, unwrapped, degrees, where it drives."""
    dn, de = np.diff(road.true_north), np.diff(road.true_east)
    moving = np.hypot(dn, de) > 0.5
    return np.degrees(np.unwrap(np.arctan2(dn[moving], de[moving])))


def test_the_other_roads_are_what_they_say() -> None:
    """Roads of other kinds (``--others``): each a drive of 7 minutes or more, and its
    own shape."""
    roads = {k: make(np.random.default_rng(7)) for k, make in OTHERS.items()}
    for name, road in roads.items():
        assert road.t[-1] >= 420.0 and road.length_m > 1000.0, name
        assert _speeds(road).max() <= 13.0 + 1e-6, name
    switchbacks = _turned_deg(roads["switchbacks"])
    assert np.ptp(switchbacks) == pytest.approx(180.0, abs=5.0)  # (back and forth, 14 times)
    assert np.sum(np.abs(np.diff(switchbacks))) == pytest.approx(14 * 180.0, rel=0.05)
    loops = _turned_deg(roads["figure eight"])
    assert loops.max() - loops[0] == pytest.approx(360.0, abs=5.0)
    assert loops[-1] == pytest.approx(loops[0], abs=5.0)  # (and as far round the other way)
    assert np.ptp(_turned_deg(roads["spiral"])) == pytest.approx(1080.0, abs=5.0)
    assert _speeds(roads["walking pace"]).max() == pytest.approx(1.5, abs=0.01)
    assert np.all(_speeds(roads["parked first"])[4:400] == 0.0)  # (2 m on, then 400 s)
    assert _speeds(roads["highway"]).max() == pytest.approx(13.0, abs=0.01)
    assert np.sum(_speeds(roads["long stops"]) == 0.0) >= 530  # (5 and 4 minutes)
    ends = roads["dead ends"]  # (back down the road it went up: 12 m across at the turn)
    gone = np.hypot(ends.true_north - ends.true_north[0], ends.true_east - ends.true_east[0])
    assert gone.max() >= 1200.0 and gone[np.argmax(gone) :].min() < 15.0
    assert _speeds(ends)[np.argmax(gone)] < 2.5  # (turned on the spot slowly)
