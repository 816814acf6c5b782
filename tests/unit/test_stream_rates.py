"""Streams flowing faster than asked: a rate request or a stop lost on the link."""

from __future__ import annotations

from convoy_mav.mavlink.streams import ANSWERS, SLACK, faster_than_asked


def test_a_stream_at_its_rate_thinned_by_loss_is_no_finding() -> None:
    counts = {"GLOBAL_POSITION_INT": 100, "ATTITUDE": 2, "SYS_STATUS": 1}
    asked = {"GLOBAL_POSITION_INT": 10.0, "ATTITUDE": 0.2, "SYS_STATUS": 0.2}
    assert faster_than_asked(counts, 10.0, asked) == []


def test_a_rate_change_lost_leaves_the_stream_too_fast() -> None:
    # (asked 0.2 Hz in flight, still at set-up's 1 Hz; 30 % of it lost)
    assert faster_than_asked({"ATTITUDE": 7}, 10.0, {"ATTITUDE": 0.2}) == []  # (2 x 2 + 3)
    assert faster_than_asked({"ATTITUDE": 8}, 10.0, {"ATTITUDE": 0.2}) == ["ATTITUDE"]


def test_a_stop_lost_leaves_streams_never_asked_for() -> None:
    counts = {"TERRAIN_REPORT": 7, "VIBRATION": 6, "AHRS": SLACK, "LOCAL_POSITION_NED": 0}
    found = faster_than_asked(counts, 10.0, {"LOCAL_POSITION_NED": 0.0})
    assert found == ["TERRAIN_REPORT", "VIBRATION"]


def test_answers_are_never_streams() -> None:
    counts = dict.fromkeys(ANSWERS, 50)
    assert faster_than_asked(counts, 10.0, {}) == []
    assert {"HEARTBEAT", "COMMAND_ACK", "PARAM_VALUE"} <= ANSWERS


def test_px4s_own_timesync_stream_is_told_from_the_answers_to_ours() -> None:
    """PX4's onboard profile sends TIMESYNC requests of its own at 10 Hz; the answers to
    the service's (1 Hz, repeated now and then) are no finding."""
    asked = {"TIMESYNC": 1.0}
    assert faster_than_asked({"TIMESYNC": 11}, 10.0, asked) == []
    assert faster_than_asked({"TIMESYNC": 110}, 10.0, asked) == ["TIMESYNC"]
