"""Whose is a hold: our setpoint stream's failsafe (take the UAV back) or a stranger's
mode change (respect it)? ``Vehicle.hold_is_ours``, fed the messages a link shows."""

from __future__ import annotations

from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.vehicle import Vehicle

OURS, STRANGER = 255, 200
FAILSAFE_TEXT = b"Failsafe: no offboard signal, Hold"  # (sitl_mock's PX4)


class _Link:
    def send(self, msg: Any) -> bool:
        return True


def _vehicle() -> Vehicle:
    frame = LocalFrame(GeoPoint(47.397742, 8.545594, 488.0))
    return Vehicle(2, _Link(), MissionClock(), frame, gcs_sysid=OURS)


def _text(v: Vehicle, text: bytes, t: float) -> None:
    v.handle_STATUSTEXT(mavlink.MAVLink_statustext_message(mavlink.MAV_SEVERITY_CRITICAL, text), t)


def _mode_ack(v: Vehicle, t: float, *, to: int, result: int = mavlink.MAV_RESULT_ACCEPTED) -> None:
    ack = mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_DO_SET_MODE, result, 0, 0, to, 190)
    v.handle_COMMAND_ACK(ack, t)


def test_a_hold_with_nothing_to_explain_it_is_a_pilots() -> None:
    assert not _vehicle().hold_is_ours(100.0)


@pytest.mark.parametrize("text_at", [97.0, 100.0, 102.0])
def test_a_hold_the_autopilot_blames_on_our_stream_is_ours(text_at: float) -> None:
    v = _vehicle()
    _text(v, FAILSAFE_TEXT, text_at)  # (before or just after the HEARTBEAT showing it)
    assert v.hold_is_ours(100.0)


def test_a_failsafe_text_of_minutes_ago_explains_no_hold_now() -> None:
    # Once failed safe, a UAV was fought for for ever after: the last text said so.
    v = _vehicle()
    _text(v, FAILSAFE_TEXT, 40.0)
    assert v.hold_is_ours(42.0)
    assert not v.hold_is_ours(150.0)
    _text(v, b"Takeoff detected", 60.0)  # (another text since changes nothing)
    assert not v.hold_is_ours(150.0)


def test_a_hold_soon_after_our_stream_or_the_link_came_back_is_ours() -> None:
    v = _vehicle()
    v.stream_resumed_t = 95.0
    assert v.hold_is_ours(100.0) and not v.hold_is_ours(120.0)
    v = _vehicle()
    v.recovered_t = 95.0
    assert v.hold_is_ours(100.0) and not v.hold_is_ours(120.0)
    assert not v.hold_is_ours(90.0)  # (asked of a hold before the link came back)


def test_a_strangers_mode_command_taken_makes_the_hold_its_own() -> None:
    v = _vehicle()
    v.stream_resumed_t = 95.0  # our stream has just hiccupped ...
    _text(v, FAILSAFE_TEXT, 96.0)  # ... and even failed safe
    assert v.hold_is_ours(99.0)
    _mode_ack(v, 99.0, to=STRANGER)  # another station's mode change accepted
    assert not v.hold_is_ours(100.0)
    assert not v.hold_is_ours(98.0)  # (its answer seen after the HEARTBEAT showing the hold)
    _text(v, FAILSAFE_TEXT, 109.0)  # (a later hold is judged afresh)
    assert v.hold_is_ours(110.0)
    assert v.counters["foreign_mode"] == 1


def test_only_a_strangers_accepted_mode_command_counts() -> None:
    v = _vehicle()
    v.stream_resumed_t = 95.0
    _mode_ack(v, 99.0, to=STRANGER, result=mavlink.MAV_RESULT_DENIED)
    _mode_ack(v, 99.0, to=OURS)  # (our own mode command's answer)
    assert v.hold_is_ours(100.0)
    assert v.counters["foreign_mode"] == 0
