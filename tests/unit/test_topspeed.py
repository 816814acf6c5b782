"""A copter's top speed seen in flight (``mavlink/autopilots/topspeed.py``)."""

from __future__ import annotations

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.autopilots import autopilot_for
from convoy_mav.mavlink.autopilots.topspeed import TopSpeed

RATE = 10.0  # Hz: GLOBAL_POSITION_INT as the service asks for it


def _fly(learner: TopSpeed, flown: np.ndarray, asked: float, t0: float = 0.0) -> list[float]:
    """Feed one update per 0.1 s, trailing the slot by what the shortfall adds up to;
    the top speeds learnt, in order."""
    out, behind = [], 0.0
    for k, v in enumerate(flown):
        behind += (asked - v) / RATE
        got = learner.observe(t0 + k / RATE, float(v), asked, behind)
        if got is not None:
            out.append(got)
    return out


def test_a_copter_held_back_by_its_lean_is_seen_at_its_top_speed() -> None:
    """SITL's ArduCopter at ANGLE_MAX 30 degrees, asked 18 m/s: 11.1-11.5 m/s."""
    rng = np.random.default_rng(3)
    flown = 11.3 + rng.uniform(-0.2, 0.2, 300)
    learner = TopSpeed()
    learnt = _fly(learner, flown, asked=18.0)
    assert learnt and learner.top == pytest.approx(11.3, abs=0.1)
    assert len(learnt) == 1  # (the same top seen again is no news)


def test_speeding_up_from_a_hover_is_not_a_top_speed() -> None:
    """Short of its target and behind while it accelerates at 2 m/s^2: its speed still
    rises, so nothing is learnt; nor once it flies what it is asked."""
    flown = np.minimum(np.arange(0.0, 30.0, 1 / RATE) * 2.0, 18.0)
    learner = TopSpeed()
    assert _fly(learner, flown, asked=18.0) == [] and learner.top is None


def test_slower_than_asked_but_not_behind_is_not_held_back() -> None:
    learner = TopSpeed()
    for k in range(300):  # ahead of its slot: it is slowing down on purpose
        assert learner.observe(k / RATE, 11.0, 18.0, -30.0) is None
    assert learner.top is None


def test_a_top_speed_rises_when_the_copter_is_seen_faster() -> None:
    """Its lean limit raised by the operator: faster than its top by a margin."""
    learner = TopSpeed()
    _fly(learner, np.full(200, 11.0), asked=18.0)
    assert learner.top == pytest.approx(11.0)
    assert learner.observe(30.0, 11.8, 18.0, 100.0) is None  # (within the margin)
    assert learner.observe(30.1, 14.5, 18.0, 100.0) == pytest.approx(14.5)
    assert learner.top == pytest.approx(14.5)


@pytest.mark.parametrize(
    ("autopilot", "lean"),
    [
        (mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, "ANGLE_MAX"),
        (mavlink.MAV_AUTOPILOT_PX4, "MPC_TILTMAX_AIR"),
    ],
)
def test_a_copter_seen_slower_than_the_plan_says_so_and_what_to_change(
    autopilot: int, lean: str
) -> None:
    frame = LocalFrame(GeoPoint(47.0, 8.0, 400.0))
    ap = autopilot_for(autopilot, mavlink.MAV_TYPE_QUADROTOR, 1, 1, frame)
    assert ap is not None and ap.top_speed is not None
    assert ap.cannot_fly(18.0, (0.85, 1.15)) is None
    for k in range(200):
        ap.observe_flight(k / RATE, 11.5, 20.7, 5.0 + k)
    assert ap.learnt()["top_speed_mps"] == pytest.approx(11.5)
    assert ap.cannot_fly(18.0, (0.85, 1.15)) == (
        "flies no faster than 11.5 m/s (seen in flight, behind its slot), the plan asks "
        f"for up to 20.7 m/s: let it lean further ({lean}) or scale airspeed_mps by 0.56"
    )
    assert ap.cannot_fly(10.0) is None  # (a plan it flies)
    ap.on_param("MPC_XY_VEL_MAX", 25.0)  # (a limit raised: the top is seen anew)
    assert ap.top_speed.top == (None if lean == "MPC_TILTMAX_AIR" else pytest.approx(11.5))


def test_a_plane_learns_no_top_speed() -> None:
    frame = LocalFrame(GeoPoint(47.0, 8.0, 400.0))
    ap = autopilot_for(mavlink.MAV_AUTOPILOT_PX4, mavlink.MAV_TYPE_FIXED_WING, 1, 1, frame)
    assert ap is not None and ap.top_speed is None
    assert not ap.observe_flight(0.0, 10.0, 18.0, 50.0)
