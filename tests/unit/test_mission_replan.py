"""Replan rules: start/stop/turn/speed/drift with hysteresis; stale input is no evidence."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from convoy_mav.errors import ConfigError
from convoy_mav.mission.replan import ChangeDetector, ConvoyMotion, ReplanThresholds
from convoy_mav.types import ConvoyEstimate

State = tuple[float, float, float, float]  # north, east, vn, ve


def _run(
    det: ChangeDetector, t0: float, t1: float, state: Callable[[float], State], dt: float = 0.1
) -> list[tuple[float, str, ConvoyMotion]]:
    out = []
    for k in range(round((t1 - t0) / dt)):
        t = t0 + k * dt
        n, e, vn, ve = state(t)
        decision = det.observe(ConvoyEstimate(t, n, e, vn, ve))
        if decision is not None:
            out.append((t, decision.reason, decision.motion))
            det.set_reference(decision.motion)
    return out


def _heading(speed: float, course_deg: float) -> Callable[[float], State]:
    c = math.radians(course_deg)

    def state(t: float) -> State:
        return (
            speed * t * math.cos(c),
            speed * t * math.sin(c),
            speed * math.cos(c),
            speed * math.sin(c),
        )

    return state


def _still(t: float) -> State:
    return 0.0, 0.0, 0.0, 0.0


def test_first_plan_waits_for_a_confirmed_steady_estimate() -> None:
    det = ChangeDetector(ReplanThresholds(), position_tol=25.0)
    decisions = _run(det, 0.0, 10.0, _still)
    assert [(round(t, 1), why) for t, why, _ in decisions] == [(2.0, "initial")]
    assert not decisions[0][2].moving
    det = ChangeDetector(ReplanThresholds(), position_tol=25.0)
    decisions = _run(det, 0.0, 10.0, _heading(6.0, 45.0))
    motion = decisions[0][2]
    assert decisions[0][1] == "initial" and motion.moving
    assert motion.speed == pytest.approx(6.0) and motion.course == pytest.approx(math.pi / 4)


def test_start_and_stop_with_hysteresis() -> None:
    det = ChangeDetector(ReplanThresholds(), position_tol=1e6)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0))

    def speed_profile(t: float) -> State:
        if t < 10.0:
            v = 0.0
        elif t < 11.0:
            v = 3.0  # a 1 s blip: not confirmed
        elif t < 20.0:
            v = 0.3  # between the thresholds: nothing happens
        elif t < 40.0:
            v = 1.0  # moving: started
        elif t < 60.0:
            v = 0.3  # below start but above stop: keep the moving plan
        else:
            v = 0.1  # stopped
        return 0.0, 0.0, v, 0.0

    decisions = _run(det, 0.0, 80.0, speed_profile)
    reasons = [(why, m.moving) for _, why, m in decisions]
    assert reasons == [("convoy_started", True), ("speed_change", True), ("convoy_stopped", False)]
    started, slowed, stopped = (t for t, _, _ in decisions)
    assert 22.0 <= started <= 23.5  # confirm_s 2 + settle
    assert 42.0 <= slowed <= 43.5  # 1.0 -> 0.3 m/s is a 70 % speed change
    assert 62.0 <= stopped <= 63.5


@pytest.mark.parametrize(
    ("course", "speed", "expected"),
    [
        (10.0, 6.0, None),
        (-14.0, 6.0, None),
        (20.0, 6.0, "heading_change"),
        (-25.0, 6.0, "heading_change"),
        (0.0, 6.8, None),
        (0.0, 7.5, "speed_change"),
        (0.0, 4.5, "speed_change"),
    ],
)
def test_heading_and_speed_thresholds(course: float, speed: float, expected: str | None) -> None:
    det = ChangeDetector(ReplanThresholds(), position_tol=1e6)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0, 6.0, 0.0))
    decisions = _run(det, 0.0, 30.0, _heading(speed, course))
    assert [why for _, why, _ in decisions] == ([] if expected is None else [expected])
    if expected:
        motion = decisions[0][2]
        assert motion.speed == pytest.approx(speed)
        assert math.degrees(motion.course) == pytest.approx(course)


def test_a_ramp_is_replanned_once_on_its_final_value() -> None:
    # A windowed velocity estimate shows a turn as a ramp: 0 -> 60 deg over 5 s.
    det = ChangeDetector(ReplanThresholds(), position_tol=1e6)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0, 6.0, 0.0))

    def turning(t: float) -> State:
        c = math.radians(60.0 * min(max(t - 5.0, 0.0) / 5.0, 1.0))
        return 0.0, 0.0, 6.0 * math.cos(c), 6.0 * math.sin(c)

    decisions = _run(det, 0.0, 40.0, turning)
    assert [why for _, why, _ in decisions] == ["heading_change"]
    t, _, motion = decisions[0]
    assert 10.0 <= t <= 11.5
    assert math.degrees(motion.course) == pytest.approx(60.0)


def test_unsteady_estimates_are_replanned_after_max_wait() -> None:
    det = ChangeDetector(ReplanThresholds(max_wait_s=6.0), position_tol=1e6)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0))

    def wobbling(t: float) -> State:
        return 0.0, 0.0, 3.0 + 2.0 * math.sin(3.0 * t), 0.0

    decisions = _run(det, 0.0, 20.0, wobbling)
    assert [why for _, why, _ in decisions][:1] == ["convoy_started"]
    assert decisions[0][0] == pytest.approx(6.0, abs=0.15)


def test_noise_around_a_threshold_does_not_storm() -> None:
    det = ChangeDetector(ReplanThresholds(), position_tol=1e6)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0, 6.0, 0.0))

    def noisy(t: float) -> State:  # course flips across 15 deg every 0.5 s
        c = math.radians(16.0 if int(t / 0.5) % 2 else 13.0)
        return 0.0, 0.0, 6.0 * math.cos(c), 6.0 * math.sin(c)

    assert _run(det, 0.0, 300.0, noisy) == []


def test_stale_estimates_never_trigger_and_reset_the_pending_condition() -> None:
    det = ChangeDetector(ReplanThresholds(), position_tol=25.0)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0))
    for k in range(100):
        assert det.observe(ConvoyEstimate(k * 0.1, 500.0, 0.0, 5.0, 0.0, stale=True)) is None
    assert det.pending is None
    for k in range(15):
        assert det.observe(ConvoyEstimate(10.0 + k * 0.1, 0.0, 0.0, 5.0, 0.0)) is None
    assert det.pending == "convoy_started"
    det.observe(ConvoyEstimate(11.6, 0.0, 0.0, 5.0, 0.0, stale=True))
    assert det.pending is None
    assert det.observe(ConvoyEstimate(11.7, math.nan, 0.0, 5.0, 0.0)) is None


def test_position_drift_uses_the_long_baseline_velocity() -> None:
    # The plan assumed 6.0 m/s north but the convoy does 6.1 m/s: a 25 m drift
    # after 250 s.  The replan takes the velocity measured anchor-to-now.
    det = ChangeDetector(ReplanThresholds(), position_tol=25.0)
    det.set_reference(ConvoyMotion(0.0, 10.0, 20.0, 6.0, 0.0))

    def drifting(t: float) -> State:
        return 10.0 + 6.1 * t, 20.0, 5.9, 0.05  # a noisy window estimate

    decisions = _run(det, 0.0, 300.0, drifting)
    t, why, motion = decisions[0]
    assert why == "position_drift"
    assert 25.0 / 0.1 + 2.0 <= t <= 25.0 / 0.1 + 3.5
    assert (motion.vn, motion.ve) == pytest.approx((6.1, 0.0), abs=1e-9)
    assert (motion.north, motion.east) == pytest.approx((10.0 + 6.1 * t, 20.0))
    # a stationary plan drifting is re-anchored, still stationary
    det = ChangeDetector(ReplanThresholds(), position_tol=25.0)
    det.set_reference(ConvoyMotion(0.0, 0.0, 0.0))
    decisions = _run(det, 0.0, 200.0, lambda t: (0.2 * t, 0.0, 0.2, 0.0))
    assert decisions[0][1] == "position_drift" and not decisions[0][2].moving


def test_convoy_motion() -> None:
    m = ConvoyMotion(10.0, 1.0, 2.0, 3.0, -4.0)
    assert m.moving and m.speed == 5.0
    assert m.course == pytest.approx(math.atan2(-4.0, 3.0))
    assert m.position(12.0) == (7.0, -6.0)
    a = m.advanced(12.0)
    assert (a.t0, a.north, a.east, a.vn) == (12.0, 7.0, -6.0, 3.0)
    still = ConvoyMotion(0.0, 1.0, 1.0)
    assert not still.moving and still.course == 0.0 and still.position(99.0) == (1.0, 1.0)


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [
        ({"start_speed": 0.0}, "start_speed"),
        ({"stop_speed": 0.6}, "stop_speed"),
        ({"heading_tol": math.nan}, "heading_tol"),
        ({"confirm_s": -1.0}, "confirm_s"),
        ({"position_tol": 0.0}, "position_tol"),
        ({"max_wait_s": 1.0}, "max_wait_s"),
    ],
)
def test_bad_thresholds_name_the_key(kwargs: dict[str, float], key: str) -> None:
    with pytest.raises(ConfigError) as info:
        ReplanThresholds(**kwargs)
    assert info.value.key == key
