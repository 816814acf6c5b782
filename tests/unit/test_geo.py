"""Local tangent-plane geodesy."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from convoy_mav.geo import GeoPoint, LocalFrame, no_position_yet


def test_known_distances() -> None:
    frame = LocalFrame(GeoPoint(47.397742, 8.545594, 488.0))  # PX4 SITL default home
    north, east, down = frame.to_ned(GeoPoint(47.397742 + 0.001, 8.545594, 500.0))
    assert north == pytest.approx(111.2, abs=0.2)  # ~111 m per millidegree of latitude
    assert east == pytest.approx(0.0, abs=1e-9)
    assert down == pytest.approx(-12.0)
    _, east, _ = frame.to_ned(GeoPoint(47.397742, 8.545594 + 0.001, 488.0))
    assert east == pytest.approx(111.32 * math.cos(math.radians(47.397742)), abs=0.2)


@given(
    st.floats(-80.0, 80.0), st.floats(-179.0, 179.0),
    st.floats(-3000.0, 3000.0), st.floats(-3000.0, 3000.0), st.floats(-100.0, 100.0),
)  # fmt: skip
def test_round_trip(lat: float, lon: float, n: float, e: float, d: float) -> None:
    frame = LocalFrame(GeoPoint(lat, lon, 100.0))
    back = frame.to_ned(frame.to_geo(n, e, d))
    assert back == pytest.approx((n, e, d), abs=1e-6)


def test_antimeridian() -> None:
    frame = LocalFrame(GeoPoint(0.0, 179.9999, 0.0))
    p = frame.to_geo(0.0, 50.0)
    assert -180.0 <= p.lon < -179.99
    assert frame.to_ned(p)[1] == pytest.approx(50.0, abs=1e-6)


def test_no_position_yet_is_null_island_not_a_place() -> None:
    assert no_position_yet(0, 0)
    assert no_position_yet(614, 2111)  # (ArduPlane SITL's first report: metres off it)
    assert no_position_yet(-99_999, 99_999)
    assert not no_position_yet(-353_632_620, 1_491_652_370)  # CMAC
    assert not no_position_yet(0, 1_000_000)  # (on the equator, 0.1 degrees east)
