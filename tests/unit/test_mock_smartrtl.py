"""The mock rover's SmartRTL path (``sitl_mock.smartrtl``), as ArduPilot's ``AP_SmartRTL``
keeps it: points an accuracy apart, straight runs simplified, loops cut, a buffer that
fills; and the way back, newest point first."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.planning.polyline import prune_loops, simplify
from sitl_mock import smartrtl
from sitl_mock.smartrtl import SmartPath


def _drive(path: SmartPath, corners: list[tuple[float, float]], step: float = 0.8) -> list[str]:
    """The rover driven through ``corners`` (north, east) at ``step`` m a tenth of a
    second; what the path said."""
    texts, t = [], 0.0
    path.set_home(t, *corners[0])
    for a, b in itertools.pairwise(corners):
        legs = max(1, math.ceil(math.dist(a, b) / step))
        for k in range(1, legs + 1):
            t += 0.1
            f = k / legs
            texts += path.update(t, a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))
    return texts


def _off(points: list[tuple[float, float]], n: float, e: float) -> float:
    """How far (n, e) is from the polyline through ``points``."""
    best = math.inf
    for a, b in itertools.pairwise(points):
        ab = np.subtract(b, a)
        t = np.clip(np.dot(np.subtract((n, e), a), ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        best = min(best, math.dist((n, e), tuple(np.add(a, t * ab))))
    return best


def test_the_way_back_is_the_path_simplified_newest_point_first() -> None:
    path = SmartPath()
    assert _drive(path, [(0.0, 0.0), (500.0, 0.0), (500.0, 300.0)]) == []
    way = path.way_home()
    assert way[0] == pytest.approx((500.0, 300.0), abs=2.0) and way[-1] == (0.0, 0.0)
    # (straight runs go: its ends, the corner, and where each run of 50 new points it
    # simplified began, as ArduPilot's simplification starts from the last it kept)
    assert len(way) <= 3 + math.ceil(800.0 / 2.0 / 50.0)
    drove = [(0.0, 0.0), (500.0, 0.0), (500.0, 300.0)]
    assert all(_off(drove, *p) < 1e-6 for p in way)
    assert min(math.dist(p, (500.0, 0.0)) for p in way) < 2.0
    for n in range(0, 500, 7):  # (every point it drove within half the accuracy of it)
        assert _off(way, float(n), 0.0) <= 1.0 + 1e-9


def test_a_loop_it_drove_is_cut_from_the_way_back() -> None:
    """Out east, round a block to the north and back across its own road, on south:
    the way back crosses where it crossed, not round the block."""
    path = SmartPath()
    _drive(path, [(0.0, 0.0), (0.0, 200.0), (100.0, 200.0), (100.0, 100.0), (-200.0, 100.0)])
    way = path.way_home()
    assert way[-1] == (0.0, 0.0) and max(n for n, _ in way) < 2.0  # (not round the block)
    length = sum(math.dist(a, b) for a, b in itertools.pairwise(way))
    assert length == pytest.approx(200.0 + 100.0, abs=4.0)


def test_a_path_it_cannot_keep_runs_low_then_is_deactivated_for_good() -> None:
    """A zigzag of 3-m teeth neither simplifies (half the accuracy) nor loops: 20
    places fill; it says it runs low, and 15 s with no point saved it gives up."""
    path = SmartPath(points_max=20)
    corners = [(3.0 * (k % 2), 4.0 * k) for k in range(26)]
    texts = _drive(path, corners, step=0.5)
    assert "SmartRTL Low on space!" in texts and "SmartRTL deactivated: buffer full" not in texts
    assert len(path.points) == 20 and path.active
    t = 100.0
    for k in range(200):  # (driving on, 20 s, with no place to save its points)
        t += 0.1
        texts += path.update(t, 3.0 * (k % 2), 200.0 + 4.0 * k)
    assert texts.count("SmartRTL deactivated: buffer full") == 1 and not path.active
    assert path.update(t + 1.0, 0.0, 0.0) == []


def test_a_full_path_is_searched_for_loops_only_when_it_has_new_points(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Low on space with nothing to cut, it does not search the whole path again at
    every step (ArduPilot restarts its loop search only on newly simplified points)."""
    searched = []
    real = prune_loops

    def counted(points: list[tuple[float, float]], delta: float) -> list[tuple[float, float]]:
        searched.append(len(points))
        return real(points, delta)

    monkeypatch.setattr(smartrtl, "prune_loops", counted)
    path = SmartPath(points_max=20)
    _drive(path, [(3.0 * (k % 2), 4.0 * k) for k in range(26)], step=0.5)
    before = len(searched)
    assert before > 0  # (once for each point saved while low)
    for k in range(100):  # (standing: nothing new to save, nothing new to search)
        path.update(30.0 + 0.1 * k, 3.0, 100.0)
    assert len(searched) == before


def test_on_its_way_back_the_points_it_reaches_are_taken_off() -> None:
    path = SmartPath()
    _drive(path, [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0)])
    way = path.way_home()
    path.reached(*way[0], within=2.0)
    assert path.points == way[:0:-1]  # (the one it is at, off)
    for p in way[1:-1]:
        path.reached(*p, within=2.0)
    assert path.points == [(0.0, 0.0)]
    path.reached(0.0, 0.0, within=2.0)
    assert path.points == [(0.0, 0.0)]  # (its first point stays: home for the mode)


def test_off_or_no_accuracy_it_never_starts() -> None:
    for path in (SmartPath(points_max=0), SmartPath(accuracy=0.0)):
        path.set_home(0.0, 0.0, 0.0)
        assert not path.active and path.update(1.0, 10.0, 0.0) == []


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-300, 300), st.floats(-300, 300)), min_size=2, max_size=12))
def test_the_way_back_ends_at_the_first_point_and_only_ever_shortens_the_path(
    corners: list[tuple[float, float]],
) -> None:
    """Whatever it drove: the way back starts near where it is and ends where it
    started, no longer than the path, with no two points nearer than the accuracy
    unless a cut put them there."""
    path = SmartPath()
    _drive(path, corners, step=1.5)
    raw = path.points[:]
    driven = sum(math.dist(a, b) for a, b in itertools.pairwise(raw))
    way = path.way_home()
    assert way[-1] == corners[0]
    assert math.dist(way[0], corners[-1]) <= 2.0 + 1e-9 or len(raw) == 1
    back = sum(math.dist(a, b) for a, b in itertools.pairwise(way))
    assert back <= driven + 1e-6


def test_simplify_and_prune_keep_ends_and_leave_short_paths_alone() -> None:
    assert simplify([(0.0, 0.0), (1.0, 0.0)], 1.0) == [(0.0, 0.0), (1.0, 0.0)]
    assert simplify([(0.0, 0.0), (5.0, 0.4), (10.0, 0.0)], 1.0) == [(0.0, 0.0), (10.0, 0.0)]
    assert simplify([(0.0, 0.0), (5.0, 3.0), (10.0, 0.0)], 1.0) == [
        (0.0, 0.0), (5.0, 3.0), (10.0, 0.0)
    ]  # fmt: skip
    three = [(0.0, 0.0), (10.0, 0.0), (0.0, 1.0)]
    assert prune_loops(three, 2.0) == three
