"""Ground-vehicle routes of the mock: pure functions of sim time."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock.ground import (
    Polyline,
    Route,
    Stationary,
    StraightLine,
    Track,
    load_csv_track,
)

FRAME = LocalFrame(GeoPoint(47.397742, 8.545594, 488.0))


def test_every_route_satisfies_the_protocol() -> None:
    routes = [
        Stationary(1.0, 2.0),
        StraightLine(0.0, 0.0, 5.0, 0.0),
        Polyline(((0.0, 0.0), (10.0, 0.0)), 1.0),
        Track((0.0, 1.0), (0.0, 1.0), (0.0, 0.0)),
    ]
    for route in routes:
        assert isinstance(route, Route)


def test_stationary() -> None:
    route = Stationary(-3.0, 4.5)
    assert route.position(123.0) == (-3.0, 4.5)
    assert route.velocity(123.0) == (0.0, 0.0)
    with pytest.raises(ValueError, match="north"):
        Stationary(math.nan, 0.0)


def test_straight_line_position_and_velocity() -> None:
    route = StraightLine(100.0, -50.0, speed=10.0, heading=math.pi / 2)  # due east
    assert route.position(0.0) == (100.0, -50.0)
    assert route.position(3.0) == pytest.approx((100.0, -20.0))
    assert route.position(-1.0) == pytest.approx((100.0, -60.0))
    assert route.velocity(7.0) == pytest.approx((0.0, 10.0))
    with pytest.raises(ValueError, match="speed"):
        StraightLine(0.0, 0.0, -1.0, 0.0)
    with pytest.raises(ValueError, match="heading"):
        StraightLine(0.0, 0.0, 1.0, math.inf)


def test_polyline_drives_the_legs_at_constant_speed_and_stops_at_the_end() -> None:
    route = Polyline(((0.0, 0.0), (30.0, 0.0), (30.0, 40.0)), speed=5.0)
    assert route.length == pytest.approx(70.0)
    assert route.position(-2.0) == (0.0, 0.0)
    assert route.velocity(-2.0) == (0.0, 0.0)
    assert route.position(3.0) == pytest.approx((15.0, 0.0))
    assert route.velocity(3.0) == pytest.approx((5.0, 0.0))
    assert route.position(6.0) == pytest.approx((30.0, 0.0))  # at the corner, on the next leg
    assert route.velocity(6.0) == pytest.approx((0.0, 5.0))
    assert route.position(10.0) == pytest.approx((30.0, 20.0))
    assert route.position(14.0) == (30.0, 40.0)
    assert route.position(1000.0) == (30.0, 40.0)
    assert route.velocity(14.0) == (0.0, 0.0)
    assert route.velocity(1000.0) == (0.0, 0.0)


def test_polyline_loop_closes_and_wraps() -> None:
    square = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0))
    route = Polyline(square, speed=2.0, loop=True)
    assert route.length == pytest.approx(40.0)  # the closing leg counts
    assert route.position(17.5) == pytest.approx((0.0, 5.0))  # on the closing leg
    assert route.velocity(17.5) == pytest.approx((0.0, -2.0))
    assert route.position(20.0 + 2.5) == pytest.approx(route.position(2.5))
    assert route.position(20.0 * 7 + 11.0) == pytest.approx(route.position(11.0))


def test_polyline_degenerate_cases() -> None:
    single = Polyline(((5.0, 6.0),), speed=3.0, loop=True)
    assert single.position(10.0) == (5.0, 6.0)
    assert single.velocity(10.0) == (0.0, 0.0)
    parked = Polyline(((0.0, 0.0), (10.0, 0.0)), speed=0.0)
    assert parked.position(10.0) == (0.0, 0.0)  # speed 0: never leaves the start
    repeated = Polyline(((0.0, 0.0), (0.0, 0.0), (0.0, 10.0), (0.0, 10.0)), speed=1.0)
    assert repeated.length == pytest.approx(10.0)
    assert repeated.velocity(5.0) == pytest.approx((0.0, 1.0))
    with pytest.raises(ValueError, match="at least one"):
        Polyline((), speed=1.0)
    with pytest.raises(ValueError, match="speed"):
        Polyline(((0.0, 0.0),), speed=-1.0)
    with pytest.raises(ValueError, match=r"points\[1\]"):
        Polyline(((0.0, 0.0), (math.nan, 1.0)), speed=1.0)


def test_track_interpolates_and_holds_its_ends() -> None:
    track = Track((10.0, 20.0, 40.0), (0.0, 100.0, 100.0), (0.0, 0.0, -60.0))
    assert track.position(0.0) == (0.0, 0.0)
    assert track.velocity(0.0) == (0.0, 0.0)
    assert track.position(15.0) == pytest.approx((50.0, 0.0))
    assert track.velocity(15.0) == pytest.approx((10.0, 0.0))
    assert track.position(20.0) == pytest.approx((100.0, 0.0))
    assert track.velocity(20.0) == pytest.approx((0.0, -3.0))
    assert track.position(30.0) == pytest.approx((100.0, -30.0))
    assert track.position(40.0) == (100.0, -60.0)
    assert track.position(99.0) == (100.0, -60.0)
    assert track.velocity(40.0) == (0.0, 0.0)


def test_track_validates() -> None:
    with pytest.raises(ValueError, match="at least one"):
        Track((), (), ())
    with pytest.raises(ValueError, match="same length"):
        Track((0.0, 1.0), (0.0,), (0.0, 1.0))
    with pytest.raises(ValueError, match=r"times\[2\]"):
        Track((0.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"easts\[0\]"):
        Track((0.0,), (0.0,), (math.inf,))


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "convoy.csv"
    path.write_text(text, encoding="utf-8")
    return path


def test_load_csv_track_without_header_uses_the_local_frame(tmp_path: Path) -> None:
    a = FRAME.to_geo(0.0, 0.0)
    b = FRAME.to_geo(300.0, -400.0)
    path = _write(tmp_path, f"0,{a.lat!r},{a.lon!r}\n50,{b.lat!r},{b.lon!r}\n")
    track = load_csv_track(path, FRAME)
    assert track.times == (0.0, 50.0)
    assert track.position(25.0) == pytest.approx((150.0, -200.0), abs=1e-6)
    assert track.velocity(25.0) == pytest.approx((6.0, -8.0), abs=1e-7)


def test_load_csv_track_header_comments_and_column_order(tmp_path: Path) -> None:
    b = FRAME.to_geo(-120.0, 80.0)
    text = (
        "# recorded convoy\n"
        "Longitude, Latitude, alt, Time\n"
        "\n"
        f"{FRAME.origin.lon!r},{FRAME.origin.lat!r},488,5\n"
        f"{b.lon!r},{b.lat!r},488,15\n"
    )
    track = load_csv_track(str(_write(tmp_path, text)), FRAME)
    assert track.times == (5.0, 15.0)
    assert track.position(15.0) == pytest.approx((-120.0, 80.0), abs=1e-6)


def test_a_route_with_a_repeated_stamp_is_driven_not_refused(tmp_path: Path) -> None:
    """The mock reads routes as the service reads tracks: repeated stamps merged."""
    track = load_csv_track(str(_write(tmp_path, "0,47.4,8.5\n\n0,47.41,8.5\n5,47.4,8.5\n")), FRAME)
    assert track.times == (0.0, 5.0)


@pytest.mark.parametrize(
    ("text", "line", "what"),
    [
        ("time,lat,lon\n0,47.4,8.5\n1,47.4\n", 3, "got 2 field"),
        ("0,47.4,8.5\n1,north,8.5\n", 2, "must be numbers"),
        ("0,47.4,8.5\n1,95,8.5\n", 2, "latitude"),
        ("0,47.4,8.5\n1,47.4,200\n", 2, "longitude"),
        ("0,47.4,8.5\n1,47.4,nan\n", 2, "finite"),
        ("# c\nwhen,lat,lon\n0,47.4,8.5\n", 2, "lacks column"),
    ],
)
def test_load_csv_track_names_file_and_line_of_a_bad_row(
    tmp_path: Path, text: str, line: int, what: str
) -> None:
    path = _write(tmp_path, text)
    with pytest.raises(ValueError, match=rf"convoy\.csv:{line}: .*{what}"):
        load_csv_track(path, FRAME)


def test_load_csv_track_needs_rows(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no data rows"):
        load_csv_track(_write(tmp_path, "time,lat,lon\n# nothing yet\n"), FRAME)
