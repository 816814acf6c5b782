"""The path the service saw the convoy's lead drive (``mission.retrace.DrivenPath``), kept
as ArduRover keeps its own for SMART_RTL; and a convoy whose lead is sent home back along
it, flown in simulation."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.mission.retrace import DrivenPath
from convoy_mav.mission.simulate import fly_road
from convoy_mav.planning.plan import PlanRequest
from convoy_mav.planning.road import path_lengths
from convoy_mav.tracks.roads import Drive, Piece, drive
from convoy_mav.types import ConvoyDrive


def path_length(points: list[tuple[float, float]]) -> float:
    """Metres along the polyline through ``points``."""
    return path_lengths(points)[-1]


def _drive(path: DrivenPath, corners: list[tuple[float, float]], step: float = 0.8) -> None:
    """The lead seen driving through ``corners`` (x, y), an estimate every ``step`` m."""
    path.add(*corners[0])
    for a, b in itertools.pairwise(corners):
        legs = max(1, math.ceil(math.dist(a, b) / step))
        for k in range(1, legs + 1):
            f = k / legs
            path.add(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]))


def _off(point: tuple[float, float], corners: list[tuple[float, float]]) -> float:
    """How far ``point`` is from the polyline through ``corners``."""
    best = math.inf
    p = np.asarray(point)
    for a, b in itertools.pairwise(np.asarray(corners, dtype=float)):
        ab = b - a
        u = min(max(float((p - a) @ ab) / float(ab @ ab), 0.0), 1.0)
        best = min(best, float(np.hypot(*(p - a - u * ab))))
    return best


def test_the_way_back_is_the_path_simplified_newest_point_first() -> None:
    path = DrivenPath()
    corners = [(0.0, 0.0), (400.0, 0.0), (400.0, 300.0), (150.0, 300.0)]
    _drive(path, corners)
    way = path.way_back()
    assert way[0] == pytest.approx(corners[-1], abs=path.accuracy) and way[-1] == (0.0, 0.0)
    assert len(way) <= 20  # (simplified every 50 points: not 500 points)
    assert all(_off(p, corners) < 1.0 for p in way)
    assert path_length(way) == pytest.approx(400.0 + 300.0 + 250.0, abs=3.0)


def test_points_are_an_accuracy_apart_and_bad_positions_are_dropped() -> None:
    path = DrivenPath(accuracy=5.0)
    for k in range(40):
        path.add(0.3 * k, 0.0)  # (12 m crawled in 40 estimates)
    path.add(math.nan, 3.0)
    path.add(20.0, math.inf)
    assert path.points == [(0.0, 0.0), (5.1, 0.0), (10.2, 0.0)]
    with pytest.raises(ValueError, match="accuracy"):
        DrivenPath(accuracy=0.0)
    with pytest.raises(ValueError, match="points_max"):
        DrivenPath(points_max=5)


def test_a_loop_round_a_block_is_cut_from_the_way_back() -> None:
    """Round a block and on across its first side: the way back crosses there and goes
    straight home, as the rover's SmartRTL does (its loops cut entering the mode)."""
    path = DrivenPath()
    block = [(0.0, 0.0), (300.0, 0.0), (300.0, 200.0), (150.0, 200.0), (150.0, -100.0)]
    _drive(path, block)
    way = path.way_back()
    assert path_length(way) == pytest.approx(100.0 + 150.0, abs=3.0)  # (not 950 m)
    assert way[-1] == (0.0, 0.0)


def test_points_reached_on_the_way_back_are_taken_off_the_first_staying() -> None:
    path = DrivenPath()
    _drive(path, [(0.0, 0.0), (400.0, 0.0), (400.0, 300.0)])
    path.way_back()
    path.reached(400.0, 310.0, 5.0)  # (turning round beyond its newest point: nothing)
    assert path.points[-1] == pytest.approx((400.0, 300.0), abs=path.accuracy)
    path.reached(401.0, 120.0, 5.0)  # (down the second leg: the points it passed are off)
    assert path.points[-1][0] == pytest.approx(400.0) and 0.0 < path.points[-1][1] < 120.0
    path.reached(100.0, 0.5, 5.0)
    assert path.points == [(0.0, 0.0)]
    path.reached(0.0, 0.0, 5.0)
    assert path.points == [(0.0, 0.0)]


def test_an_hour_of_winding_road_stays_inside_its_buffer() -> None:
    """Every 50 new points are simplified; low on space, loops are cut and then it
    simplifies harder: the buffer never overflows and the way back still ends home."""
    path = DrivenPath(points_max=200)
    rng = np.random.default_rng(3)
    x = y = heading = 0.0
    path.add(x, y)
    for _ in range(36_000):  # (an hour at 8 m/s, an estimate every 0.1 s, turning at random)
        heading += float(rng.normal(0.0, 0.05))
        x, y = x + 0.8 * math.cos(heading), y + 0.8 * math.sin(heading)
        path.add(x, y)
        assert len(path.points) < path.points_max - 9
    way = path.way_back()
    assert way[-1] == (0.0, 0.0) and math.dist(way[0], (x, y)) < 3.0


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.floats(-300.0, 300.0), st.floats(-300.0, 300.0)), min_size=2, max_size=12)
)
def test_any_way_back_runs_from_where_it_is_to_its_first_point_and_is_no_longer(
    corners: list[tuple[float, float]],
) -> None:
    path = DrivenPath()
    _drive(path, corners)
    driven = path_length(path.points)
    way = path.way_back()
    assert way[-1] == corners[0]
    assert math.dist(way[0], corners[-1]) < path.accuracy
    assert path_length(way) <= driven + 1e-6


# --------------------------------------------- the lead sent home back along its path

# Out through an urban block, 2.15 km at 8 m/s; there a U-turn and back along the same
# road to where it set off, where it stands.
_OUT = [Piece(600.0), Piece(radius=12.0, angle_deg=90.0), Piece(250.0)]
_OUT += [Piece(radius=12.0, angle_deg=-90.0), Piece(400.0), Piece(radius=12.0, angle_deg=-90.0)]
_OUT += [Piece(300.0), Piece(radius=12.0, angle_deg=90.0), Piece(300.0)]
_BACK = [Piece(radius=4.0, angle_deg=180.0)]
_BACK += [Piece(p.length, p.radius, -p.angle_deg) for p in reversed(_OUT)]


def test_a_convoy_sent_home_back_along_its_path_is_forecast_round_its_corners() -> None:
    """Its lead told SMART_RTL as it turns round (heard a second later): forecast back
    along the path it was seen to drive, the fleet meets it at each corner on the way;
    forecast from its own velocity (as a driver's drive, or no mode heard) the corners
    come unforeseen (simulation, 7 UAVs, no route: 96.2 % and 5-s gaps, now 99.6 %)."""
    rt = drive("there and back", _OUT + _BACK, Drive(((0.0, 8.0),), end_stop_s=60.0), noise_m=1.0)
    driven = path_lengths(zip(rt.true_north.tolist(), rt.true_east.tolist(), strict=True))
    turn = float(rt.t[np.searchsorted(driven, sum(p.arc_length for p in _OUT))])
    request = PlanRequest(150.0, 100.0, 18.0)
    runs = {
        drive_: fly_road(
            rt.t,
            rt.north,
            rt.east,
            request,
            7,
            true_north=rt.true_north,
            true_east=rt.true_east,
            drives=[(turn + 1.0, drive_, None)],
        )
        for drive_ in (ConvoyDrive.OTHER, ConvoyDrive.RETRACE)
    }
    back, own = runs[ConvoyDrive.RETRACE], runs[ConvoyDrive.OTHER]
    assert back.coverage >= 0.99 and back.longest_gap_s <= 2.0, back
    assert back.coverage >= own.coverage + 0.02, (back.coverage, own.coverage)
    assert back.predicted_coverage == pytest.approx(back.coverage, abs=0.01)
