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


_UAV = mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
_ARMED = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
_OFFBOARD, _LOITER = 6 << 16, (4 << 16) | (3 << 24)  # PX4 OFFBOARD, AUTO.LOITER
_POSCTL, _RTL = 3 << 16, (4 << 16) | (5 << 24)  # PX4 POSCTL, AUTO.RTL
_GUIDED, _AP_LOITER = 15, 12  # ArduPlane GUIDED, LOITER


def _heard(v: Vehicle, msg: Any) -> None:
    v.handle(_UAV.decode(bytearray(msg.pack(_UAV))))


def _position(boot_ms: int) -> Any:
    return mavlink.MAVLink_global_position_int_message(
        boot_ms, 473977420, 85455940, 538000, 50000, 0, 0, 0, 0
    )


def _beat(
    mode: int, status: int = mavlink.MAV_STATE_ACTIVE, autopilot: int = mavlink.MAV_AUTOPILOT_PX4
) -> Any:
    px4 = autopilot == mavlink.MAV_AUTOPILOT_PX4
    kind = mavlink.MAV_TYPE_QUADROTOR if px4 else mavlink.MAV_TYPE_FIXED_WING  # (ArduPlane)
    return mavlink.MAVLink_heartbeat_message(kind, autopilot, _ARMED, mode, status, 3)


def _flying(autopilot: int = mavlink.MAV_AUTOPILOT_PX4) -> Vehicle:
    v = _vehicle()
    _heard(v, _beat(_OFFBOARD if autopilot == mavlink.MAV_AUTOPILOT_PX4 else _GUIDED,
                    autopilot=autopilot))  # fmt: skip
    v._set_status(VehicleStatus.FLYING)
    return v


def test_a_failsafe_across_a_step_of_mission_time_is_ours_by_the_autopilots_clock() -> None:
    """On a loaded host after a simulator's pause, mission time can step between the
    stream-loss text and the HEARTBEAT showing the hold (14 s here): the autopilot's own
    clock, on the messages around them, still puts them a second apart."""
    v = _flying()
    _heard(v, _position(300_000))
    _text(v, FAILSAFE_TEXT, 100.0)  # (mission time before the step)
    _heard(v, _position(301_000))
    _heard(v, _beat(_LOITER))
    assert v.status is VehicleStatus.HOLDING
    assert v.hold_is_ours(114.0)  # (mission time after it)
    v = _flying()  # the same text 60 s of its own clock before the hold: no explanation
    _heard(v, _position(300_000))
    _text(v, FAILSAFE_TEXT, 100.0)
    _heard(v, _position(360_000))
    _heard(v, _beat(_LOITER))
    assert not v.hold_is_ours(160.0)


@pytest.mark.parametrize("mode", [_LOITER, _POSCTL], ids=["AUTO.LOITER", "POSCTL"])
def test_a_px4_that_holds_in_a_failsafe_is_ours_though_its_text_was_lost(mode: int) -> None:
    """The soak's lossy link (30 % each way) lost the one stream-loss STATUSTEXT of three
    PX4 planes: each was taken for a pilot's and left holding for the rest of the hour
    (72 % covered). The HEARTBEAT that shows the hold says MAV_STATE_CRITICAL, PX4's
    ``vehicle_status.failsafe``, every second."""
    v = _flying()
    _heard(v, _beat(mode, mavlink.MAV_STATE_CRITICAL))
    assert v.status is VehicleStatus.HOLDING
    assert v.hold_is_ours(v.clock.now())
    assert v.hold_is_ours(v.clock.now() + 3.0)  # (as the service judges it, 3 s on)


def test_a_pilots_hold_is_reported_active_and_stays_the_pilots() -> None:
    v = _flying()
    _heard(v, _beat(_LOITER, mavlink.MAV_STATE_ACTIVE))
    assert v.status is VehicleStatus.HOLDING
    assert not v.hold_is_ours(v.clock.now())


def test_a_failsafe_that_returns_the_uav_or_another_firmwares_is_not_taken_for_ours() -> None:
    """A PX4 sent home in a failsafe (its battery, RC or geofence action, as COM_OBL_RC_ACT
    may choose too) is respected, and so is an ArduPilot's (a lost GUIDED stream changes
    no mode there: its failsafes are the battery's, the GCS link's...)."""
    v = _flying()
    _heard(v, _beat(_RTL, mavlink.MAV_STATE_CRITICAL))
    assert v.status is VehicleStatus.HOLDING and not v.hold_is_ours(v.clock.now())
    ardupilot = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    v = _flying(ardupilot)
    _heard(v, _beat(_AP_LOITER, mavlink.MAV_STATE_CRITICAL, ardupilot))
    assert v.status is VehicleStatus.HOLDING and not v.hold_is_ours(v.clock.now())


def test_another_stations_mode_command_outweighs_a_failsafe_heartbeat() -> None:
    v = _flying()
    _heard(v, _beat(_LOITER, mavlink.MAV_STATE_CRITICAL))
    _mode_ack(v, v.clock.now(), to=STRANGER)
    assert not v.hold_is_ours(v.clock.now())
