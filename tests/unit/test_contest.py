"""Telling another controller's targets from ours (``convoy_mav.contest``)."""

from __future__ import annotations

from convoy_mav.contest import ControlWatch

HERE = (473_977_000, 85_455_000)  # (lat, lon) in 1e-7 degrees, near Zurich
E7_PER_M = 1.0 / 0.011131949  # 1e-7 degrees of latitude per metre


def _north(p: tuple[int, int], metres: float) -> tuple[int, int]:
    return p[0] + round(metres * E7_PER_M), p[1]


def test_our_own_targets_are_never_a_sign() -> None:
    w = ControlWatch()
    for k in range(60):
        target = _north(HERE, 40.0 * k)
        w.sent(float(k), *target)
        assert not w.reported(k + 0.5, *target)
        assert not w.reported(k + 0.9, *_north(target, 20.0))  # (within the tolerance)
    assert w.check(60.0) is None and w.signs == 0


def test_a_link_seconds_behind_a_fast_stream_reports_our_own_targets() -> None:
    """At 100 Hz (``setpoint_rate_hz``' top) a link lagging 3 s reports a target 300
    sends old, 54 m behind our newest: ours while it is within ``recent_s``."""
    w = ControlWatch()
    for k in range(1500):  # 15 s along a road at 18 m/s
        w.sent(k / 100, *_north(HERE, 0.18 * k))
    now = 14.99
    assert not w.reported(now, *_north(HERE, 0.18 * 1200))  # sent 3 s ago
    assert w.reported(now, *_north(HERE, 0.18 * 300))  # 12 s ago: past recent_s


def test_a_loiter_sent_once_stays_ours_however_old() -> None:
    """ArduPlane's loiter is re-sent only when it changes: still ours a minute on."""
    w = ControlWatch()
    w.sent(0.0, *HERE)
    assert not any(w.reported(t, *HERE) for t in range(4, 60))
    assert w.check(60.0) is None


def test_the_loiter_before_stays_ours_however_often_the_next_is_sent_again() -> None:
    """A lossy link: the next arc's loiter is sent, copied and retried five times in
    3 s, and a report of the arc before arrives late. Counted by sends, the one before
    was pushed out of ``keep`` and the report taken for another controller's."""
    w = ControlWatch()
    before, after = HERE, _north(HERE, 300.0)  # (the paper's arcs: centres 2R apart)
    w.sent(0.0, *before)
    for t in (30.0, 30.1, 31.1, 32.1, 33.1):
        w.sent(t, *after)
    assert not w.reported(33.3, *before)
    assert not w.reported(33.5, *after)
    assert w.signs == 0


def test_anothers_targets_make_it_contested_then_free_again() -> None:
    w = ControlWatch()
    w.sent(0.0, *HERE)
    far = _north(HERE, 500.0)
    assert not w.reported(1.0, *far)  # (settling: the autopilot's own entry point)
    assert w.reported(4.0, *far) and w.check(4.0) is None  # one sign is noise
    assert w.reported(5.0, *far)
    assert w.reported(6.0, *far)
    assert w.check(6.0) == "its position target is not one we sent"
    w.sent(7.0, *HERE)
    assert not w.reported(8.0, *HERE)
    assert w.check(20.0) is not None  # (quiet for 14 s only)
    assert w.check(21.5) is None
    assert w.signs == 3


def test_signs_spread_out_are_not_a_contest() -> None:
    w = ControlWatch()
    w.sent(0.0, *HERE)
    far = _north(HERE, 500.0)
    for t in (10.0, 25.0, 40.0, 55.0):  # one stray report every 15 s
        assert w.reported(t, *far)
        w.sent(t + 0.1, *HERE)
    assert w.check(56.0) is None


def test_before_we_command_a_target_that_keeps_moving_is_driven() -> None:
    w = ControlWatch()
    assert not w.commanding
    assert not w.reported(0.0, *HERE)  # (a parked target: a service gone, a hold)
    assert not w.reported(1.0, *HERE)
    for k in range(2, 5):
        assert w.reported(float(k), *_north(HERE, 30.0 * k))
    assert w.check(4.0) == "its position target moves and is not ours"


def test_a_stranger_on_the_link_is_a_sign_and_forgetting_starts_anew() -> None:
    w = ControlWatch()
    for t in (1.0, 1.1, 1.2):
        assert w.stranger(t, "system 42 sends it COMMAND_LONG")
    assert w.check(1.2) == "system 42 sends it COMMAND_LONG"
    w.sent(2.0, *HERE)
    assert w.commanding
    w.forget_ours()
    assert not w.commanding
