"""Which of an autopilot's STATUSTEXTs explain a refused command."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.vehicle import refusal_reason

_CRITICAL, _WARNING, _INFO = (
    mavlink.MAV_SEVERITY_CRITICAL,
    mavlink.MAV_SEVERITY_WARNING,
    mavlink.MAV_SEVERITY_INFO,
)


def test_nothing_said_is_no_reason() -> None:
    assert refusal_reason([]) is None


def test_the_serious_texts_in_order_each_once() -> None:
    said = [
        (_INFO, "EKF3 IMU1 origin set"),
        (_CRITICAL, "Arm: Gyros inconsistent"),
        (_CRITICAL, "Arm: Need Position Estimate"),
        (_INFO, "Field Elevation Set: 584m"),
        (_CRITICAL, "Arm: Gyros inconsistent"),  # (said again by a second check)
    ]
    assert refusal_reason(said) == "Arm: Gyros inconsistent; Arm: Need Position Estimate"
    # ArduPilot refusing a mode: why (NOTICE), then that it failed (WARNING)
    said = [
        (mavlink.MAV_SEVERITY_NOTICE, "No Mission. Can't set AUTO."),
        (_WARNING, "Flight mode change failed"),
    ]
    assert refusal_reason(said) == "No Mission. Can't set AUTO.; Flight mode change failed"


def test_with_nothing_serious_the_latest_text_is_the_reason() -> None:
    said = [(_INFO, "EKF3 IMU0 origin set"), (_INFO, "Throttle too high")]
    assert refusal_reason(said) == "Throttle too high"
