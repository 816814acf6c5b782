"""The convoy is the lead's group: a vehicle that parts from it leaves the centroid."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.convoy import ConvoyTracker
from convoy_mav.parting import STAND_S, StandWatch, convoy_group, default_part_m


def test_a_column_strung_out_along_a_road_is_one_convoy_however_long() -> None:
    column = {k: (150.0 * k, 0.0) for k in range(6)}  # (750 m long, 150 m gaps)
    assert convoy_group(column, lead=0, part_m=200.0) == frozenset(column)
    # In any order heard, and with the lead at its tail.
    shuffled = {k: column[k] for k in (3, 5, 0, 4, 1, 2)}
    assert convoy_group(shuffled, lead=5, part_m=200.0) == frozenset(column)


def test_a_vehicle_beyond_the_part_distance_from_every_other_has_parted() -> None:
    positions = {7: (0.0, 0.0), 8: (30.0, 0.0), 9: (-400.0, 0.0)}
    assert convoy_group(positions, lead=7, part_m=200.0) == {7, 8}
    # The lead's group is the convoy even when smaller: the lead stopped, the rest on.
    positions = {7: (0.0, 0.0), 8: (500.0, 0.0), 9: (530.0, 0.0)}
    assert convoy_group(positions, lead=7, part_m=200.0) == {7}
    # Without the lead: the largest group; a tie to the group heard first.
    assert convoy_group(positions, lead=None, part_m=200.0) == {8, 9}
    assert convoy_group(positions, lead=6, part_m=200.0) == {8, 9}  # (6 not heard)
    assert convoy_group({9: (900.0, 0.0), 7: (0.0, 0.0)}, lead=None, part_m=200.0) == {9}


def test_a_parted_vehicle_rejoins_only_well_within_the_part_distance() -> None:
    """Hysteresis: half the part distance, so one near the limit does not flap."""
    positions = {1: (0.0, 0.0), 2: (150.0, 0.0)}
    assert convoy_group(positions, lead=1, part_m=200.0) == {1, 2}
    assert convoy_group(positions, lead=1, part_m=200.0, parted=frozenset({2})) == {1}
    closer = {1: (0.0, 0.0), 2: (99.0, 0.0)}
    assert convoy_group(closer, lead=1, part_m=200.0, parted=frozenset({2})) == {1, 2}
    rejoin = convoy_group(positions, lead=1, part_m=200.0, parted=frozenset({2}), rejoin_m=160.0)
    assert rejoin == {1, 2}


def test_without_a_part_distance_every_vehicle_is_the_convoy() -> None:
    positions = {1: (0.0, 0.0), 2: (5000.0, 0.0)}
    assert convoy_group(positions, lead=1, part_m=0.0) == {1, 2}
    assert convoy_group(positions, lead=1, part_m=math.inf) == {1, 2}
    assert convoy_group({}, lead=1, part_m=200.0) == frozenset()
    assert default_part_m(100.0) == 200.0


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-2000.0, 2000.0), st.floats(-2000.0, 2000.0)), min_size=1, max_size=8
    ),
    st.floats(10.0, 500.0),
    st.booleans(),
)
def test_the_group_is_linked_and_nothing_outside_is_near_it(
    points: list[tuple[float, float]], part_m: float, led: bool
) -> None:
    """Every member is within part_m of another (or alone); every other vehicle is
    farther than part_m from every member; the lead, if heard, is in it."""
    positions = dict(enumerate(points))
    group = convoy_group(positions, lead=0 if led else None, part_m=part_m)
    assert group and (0 in group or not led)
    for a in group:
        others = [math.dist(positions[a], positions[b]) for b in group if b != a]
        assert not others or min(others) <= part_m
    for b in set(positions) - group:
        assert all(math.dist(positions[a], positions[b]) > part_m for a in group)


def test_the_tracker_leaves_a_parted_truck_out_of_the_centroid_and_says_so() -> None:
    """Two trucks drive on north at 8 m/s; the third stops at t = 10 s. Past 200 m
    from the others it has parted: the convoy is the two, its velocity theirs again."""
    tracker = ConvoyTracker(window=4.0, part_m=200.0, lead=1)
    t = 0.0
    while t <= 60.0 + 1e-9:
        for sysid, behind in ((1, 0.0), (2, 20.0), (3, 40.0)):
            moving = 8.0 * t - behind
            north = moving if sysid != 3 else min(moving, 8.0 * 10.0 - behind)
            tracker.update(t, north, 0.0, source=sysid, velocity=None)
        t += 1.0
    assert tracker.sources == {1, 2} and tracker.parted == {3}
    assert tracker.counters["source_parted"] == 1
    est = tracker.estimate(60.0)
    assert est is not None
    assert est.north == pytest.approx(8.0 * 60.0 - 10.0)  # (the two's centroid)
    assert est.vn == pytest.approx(8.0)
    apart = tracker.apart(3)
    assert apart == pytest.approx(8.0 * 60.0 - 20.0 - 40.0)
    assert tracker.apart(1) is None
    # It drives on again and catches up: within 100 m of the others it is back in.
    for k in range(1, 200):
        t = 60.0 + k
        for sysid, behind in ((1, 0.0), (2, 20.0)):
            tracker.update(t, 8.0 * t - behind, 0.0, source=sysid)
        tracker.update(t, min(40.0 + 16.0 * k, 8.0 * t - 40.0), 0.0, source=3)
        if tracker.sources == {1, 2, 3}:
            break
    assert tracker.parted == frozenset() and tracker.counters["source_rejoined"] == 1
    assert tracker.apart(3) is None


def test_a_tracker_without_a_part_distance_keeps_every_truck() -> None:
    tracker = ConvoyTracker(window=4.0)
    for k in range(5):
        tracker.update(float(k), 0.0, 0.0, source=1)
        tracker.update(float(k), 3000.0, 0.0, source=2)
    assert tracker.sources == {1, 2} and tracker.parted == frozenset()
    with pytest.raises(ValueError, match="part_m"):
        ConvoyTracker(part_m=-1.0)


def _watched(
    speeds: dict[int, Callable[[float], float]], seconds: float, *, seed: int = 0
) -> list[tuple[float, frozenset[int]]]:
    """Each vehicle reporting its speed at time t (``speeds[sysid](t)``, with an
    autopilot's few cm/s of noise) at 1 Hz; the watch's answer each second, the lead 1."""
    rng = random.Random(seed)
    watch: StandWatch[int] = StandWatch()
    out = []
    for k in range(round(seconds) + 1):
        t = float(k)
        for sysid, speed in speeds.items():
            watch.add(sysid, t, abs(speed(t) + rng.gauss(0.0, 0.05)))
        out.append((t, watch.judge(1, t)))
    return out


def _brakes(at: float, top: float = 8.0) -> Callable[[float], float]:
    """At ``top`` m/s, braking at 1 m/s^2 to a stand from ``at``."""
    return lambda t: top if t <= at else max(top - (t - at), 0.0)


def _sets_off(at: float, top: float = 8.0) -> Callable[[float], float]:
    """Standing, then off at 1 m/s^2 to ``top`` m/s from ``at``."""
    return lambda t: min(max(t - at, 0.0), top)


def test_a_truck_that_stands_while_the_lead_drives_on_has_parted_fifteen_seconds_on() -> None:
    """A breakdown: the follower brakes to a stand from 30 s (at 38 s), the lead drives
    on; once it has reported a stand for the whole window it has parted, and stays so
    while it stands, and creeps."""
    creeps = _brakes(30.0)
    answers = _watched({1: lambda t: 8.0, 2: lambda t: creeps(t) if t < 80.0 else 0.6}, 120.0)
    first = next(t for t, standing in answers if 2 in standing)
    assert 37.7 + STAND_S <= first <= 38.0 + STAND_S + 1.0, first
    assert all(standing == {2} for t, standing in answers if t >= first)


def test_it_drives_again_or_the_lead_stops_and_it_stands_apart_no_more() -> None:
    def stalled(t: float) -> float:
        return _brakes(30.0)(t) if t < 80.0 else _sets_off(80.0)(t)

    answers = dict(_watched({1: lambda t: 8.0, 2: stalled}, 120.0))
    assert 2 in answers[80.0] and answers[82.0] == frozenset()  # (1 m/s reported at 81 s)
    waits = dict(_watched({1: _brakes(70.0), 2: _brakes(30.0)}, 120.0))
    assert 2 in waits[70.0] and waits[79.0] == frozenset()  # (the lead stands as well)


def test_a_column_pulling_away_from_a_stop_or_stopped_as_one_parts_no_one() -> None:
    """Stopped as one for a minute (the lead too: no one drives on), then off again at
    1 m/s^2, each vehicle 3 s after the one ahead, the sixth 15 s after the lead."""

    def member(k: int) -> Callable[[float], float]:
        return lambda t: _brakes(50.0)(t) if t < 120.0 else _sets_off(120.0 + 3.0 * k)(t)

    column = {k + 1: member(k) for k in range(6)}
    assert all(not standing for _, standing in _watched(column, 300.0))


def test_without_the_lead_heard_or_a_speed_reported_no_one_stands_apart() -> None:
    watch: StandWatch[int] = StandWatch()
    for k in range(30):
        watch.add(2, float(k), 0.0)
        watch.add(3, float(k), 8.0)
        watch.add(4, float(k), None)  # (a feed of positions alone)
    assert watch.judge(1, 29.0) == frozenset() and watch.judge(None, 31.0) == frozenset()
    for k in range(30, 50):
        watch.add(1, float(k), 8.0)
        watch.add(4, float(k), None)
    assert watch.judge(1, 49.0) == frozenset()  # (2 reports nothing since 29 s)


def test_the_tracker_parts_a_stalled_truck_near_the_rest() -> None:
    """Stalled 20 m behind the lead (both reporting their velocity), it has parted a
    window after it stood, 140 m back, long before 200 m (some 25 s sooner)."""
    tracker = ConvoyTracker(window=4.0, part_m=200.0, lead=1)
    parted_at = None
    for k in range(60):
        t = float(k)
        tracker.update(t, 8.0 * t, 0.0, source=1, velocity=(8.0, 0.0))
        stood = t >= 30.0
        tracker.update(
            t, min(8.0 * t - 20.0, 220.0), 0.0, source=2, velocity=(0.0 if stood else 8.0, 0.0)
        )
        if parted_at is None and tracker.parted == {2}:
            parted_at = t
    assert parted_at is not None and 30.0 + STAND_S <= parted_at <= 31.0 + STAND_S, parted_at
    assert tracker.standing == {2} and tracker.sources == {1}
    assert tracker.counters["source_parted"] == 1
