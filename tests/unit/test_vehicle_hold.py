"""Whose is a hold: our setpoint stream's failsafe (take the UAV back) or a stranger's
mode change (respect it)? ``Vehicle.hold_is_ours``, fed the messages a link shows."""

from __future__ import annotations

from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.types import VehicleStatus
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


def test_a_failsafe_across_a_step_of_mission_time_is_ours_by_the_autopilots_clock() -> None:
    """On a loaded host after a simulator's pause, mission time can step between the
    stream-loss text and the HEARTBEAT showing the hold (14 s here): the autopilot's own
    clock, on the messages around them, still puts them a second apart."""
    uav = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)

    def heard(msg: Any) -> None:
        v.handle(uav.decode(bytearray(msg.pack(uav))))

    def position(boot_ms: int) -> Any:
        return mavlink.MAVLink_global_position_int_message(
            boot_ms, 473977420, 85455940, 538000, 50000, 0, 0, 0, 0
        )

    offboard, loiter = 6 << 16, (4 << 16) | (3 << 24)  # PX4 OFFBOARD, AUTO.LOITER
    armed = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED

    def beat(mode: int) -> Any:
        return mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, armed, mode, 4, 3
        )

    v = _vehicle()
    heard(beat(offboard))
    v._set_status(VehicleStatus.FLYING)
    heard(position(300_000))
    _text(v, FAILSAFE_TEXT, 100.0)  # (mission time before the step)
    heard(position(301_000))
    heard(beat(loiter))
    assert v.status is VehicleStatus.HOLDING
    assert v.hold_is_ours(114.0)  # (mission time after it)
    v = _vehicle()  # the same text 60 s of its own clock before the hold: no explanation
    heard(beat(offboard))
    v._set_status(VehicleStatus.FLYING)
    heard(position(300_000))
    _text(v, FAILSAFE_TEXT, 100.0)
    heard(position(360_000))
    heard(beat(loiter))
    assert not v.hold_is_ours(160.0)
