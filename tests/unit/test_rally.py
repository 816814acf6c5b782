"""Where ArduPilot's RTL takes a ground vehicle (``mavlink.rally``): the rule among its
rally points and home, and the read of the points and their two parameters."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.missionread import PARAM_TIMEOUT_S, PARAM_TRIES, TIMEOUT_S, TRIES
from convoy_mav.mavlink.rally import RallyRead, rtl_destination
from tests.unit.test_mission_read import ROVER, wire

RALLY = mavlink.MAV_MISSION_TYPE_RALLY
HOME = (0.0, 0.0)


@pytest.mark.parametrize(
    ("here", "rallies", "limit_km", "incl_home", "goes"),
    [
        ((600.0, 0.0), [], 0.5, True, HOME),  # (none: home)
        ((600.0, 0.0), [(400.0, 0.0)], 0.5, True, (400.0, 0.0)),  # (nearer than home)
        ((600.0, 0.0), [(900.0, 0.0), (400.0, 0.0)], 0.5, True, (400.0, 0.0)),  # (nearest)
        ((100.0, 0.0), [(400.0, 0.0)], 0.5, True, HOME),  # (home nearer)
        ((100.0, 0.0), [(400.0, 0.0)], 0.5, False, (400.0, 0.0)),  # (home not weighed)
        ((1200.0, 0.0), [(600.0, 0.0)], 0.5, True, HOME),  # (beyond RALLY_LIMIT_KM)
        ((1200.0, 0.0), [(600.0, 0.0)], 0.0, True, (600.0, 0.0)),  # (0: no limit)
    ],
)
def test_rtl_goes_where_ardupilots_rally_rule_says(
    here: tuple[float, float],
    rallies: list[tuple[float, float]],
    limit_km: float,
    incl_home: bool,
    goes: tuple[float, float],
) -> None:
    assert rtl_destination(here, HOME, rallies, limit_km, incl_home) == goes


coords = st.floats(-3000.0, 3000.0)
points = st.tuples(coords, coords)


@given(points, st.lists(points, max_size=6), st.floats(0.0, 5.0), st.booleans())
def test_rtl_goes_home_or_to_a_rally_point_never_farther_than_allowed(
    here: tuple[float, float], rallies: list[tuple[float, float]], limit_km: float, incl: bool
) -> None:
    goes = rtl_destination(here, HOME, rallies, limit_km, incl)
    assert goes == HOME or goes in rallies
    if goes != HOME:
        far = ((goes[0] - here[0]) ** 2 + (goes[1] - here[1]) ** 2) ** 0.5
        assert limit_km == 0.0 or far <= limit_km * 1000.0
        assert all(far <= ((p[0] - here[0]) ** 2 + (p[1] - here[1]) ** 2) ** 0.5 for p in rallies)


def _rally_item(seq: int, lat: float, lon: float, command: int = 0) -> Any:
    msg = mavlink.MAVLink_mission_item_int_message(
        255, 190, seq, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        command or mavlink.MAV_CMD_NAV_RALLY_POINT, 0, 0, 0, 0, 0, 0,
        round(lat * 1e7), round(lon * 1e7), 0.0, RALLY,
    )  # fmt: skip
    return wire(msg)


def _param(name: str, value: float) -> Any:
    return wire(
        mavlink.MAVLink_param_value_message(
            name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32, 300, 1
        )
    )


def _kinds(out: list[Any]) -> list[str]:
    return [m.get_type() for m in out]


def test_a_rally_read_takes_the_points_and_both_parameters() -> None:
    read = RallyRead(ROVER, own=255)
    out = read.start(0.0)
    assert _kinds(out) == ["MISSION_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_REQUEST_READ"]
    assert out[0].mission_type == RALLY
    # (the mission's own answers are another read's)
    mission = wire(mavlink.MAVLink_mission_count_message(255, 190, 4, 0))
    assert read.handle(mission, 0.1) == []
    out = read.handle(wire(mavlink.MAVLink_mission_count_message(255, 190, 2, RALLY)), 0.1)
    assert _kinds(out) == ["MISSION_REQUEST_INT"] and out[0].seq == 0
    assert out[0].mission_type == RALLY
    read.handle(_rally_item(0, 47.40, 8.55), 0.2)
    out = read.handle(_rally_item(1, 47.41, 8.56), 0.3)
    assert _kinds(out) == ["MISSION_ACK"] and out[0].mission_type == RALLY
    assert not read.done  # (its parameters not answered yet)
    read.handle(_param("RALLY_LIMIT_KM", 2.0), 0.4)
    read.handle(_param("RALLY_INCL_HOME", 0.0), 0.4)
    assert read.done and read.error is None
    assert read.points == [pytest.approx((47.40, 8.55)), pytest.approx((47.41, 8.56))]
    assert read.limit_km == 2.0 and read.incl_home is False


def test_a_rally_read_unanswered_fails_and_unanswered_parameters_take_rovers_defaults() -> None:
    read = RallyRead(ROVER, own=255)
    read.start(0.0)
    now = 0.0
    for _ in range(TRIES + PARAM_TRIES):
        now += max(TIMEOUT_S, PARAM_TIMEOUT_S) + 0.01
        read.poll(now)
    assert read.done and read.error is not None and "did not answer" in read.error
    assert read.points == [] and read.limit_km == 0.5 and read.incl_home is True


def test_a_rally_read_refused_says_why_and_its_answered_parameters_still_count() -> None:
    """Firmware built without rally points refuses the read (MISSION_ACK, unsupported)."""
    read = RallyRead(ROVER, own=255)
    read.start(0.0)
    unsupported = mavlink.MAV_MISSION_UNSUPPORTED
    read.handle(wire(mavlink.MAVLink_mission_ack_message(255, 190, unsupported, RALLY)), 0.1)
    assert not read.done  # (its parameters not answered yet)
    read.handle(_param("RALLY_LIMIT_KM", 0.0), 0.2)
    read.handle(_param("RALLY_INCL_HOME", 1.0), 0.2)
    assert read.done and read.error is not None and "MAV_MISSION_UNSUPPORTED" in read.error
    assert read.points == [] and read.limit_km == 0.0
    # (the mission's own refusal is another read's)
    other = RallyRead(ROVER, own=255)
    other.start(0.0)
    other.handle(wire(mavlink.MAVLink_mission_ack_message(255, 190, unsupported, 0)), 0.1)
    assert other.error is None
