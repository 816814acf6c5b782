"""``RoundTrip``: how far ahead setpoints are sampled, from commands and their answers."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.roundtrip import RoundTrip

REPOSITION, SPEED = mavlink.MAV_CMD_DO_REPOSITION, mavlink.MAV_CMD_DO_CHANGE_SPEED


def test_no_answer_yet_no_lead() -> None:
    rt = RoundTrip()
    rt.sent(REPOSITION, 10.0)
    assert rt.lead == 0.0
    assert rt.answered(SPEED, 10.4) is None  # (never sent: a stranger's, or a late one)


def test_the_lead_is_the_median_round_trip() -> None:
    rt = RoundTrip(keep=5)
    for i, rtt in enumerate([0.4, 0.45, 2.5, 0.42, 0.41, 0.43, 0.44]):  # one late answer
        rt.sent(SPEED, 10.0 * i)
        assert rt.answered(SPEED, 10.0 * i + rtt) == pytest.approx(rtt)
    assert len(rt.samples) == 5
    assert rt.lead == pytest.approx(0.43)


def test_an_answer_to_a_command_sent_twice_is_not_timed() -> None:
    rt = RoundTrip()
    rt.sent(REPOSITION, 10.0)
    rt.sent(REPOSITION, 11.0)  # (retried: the first send's answer may be this one)
    assert rt.answered(REPOSITION, 11.1) is None
    assert rt.lead == 0.0
    rt.sent(REPOSITION, 20.0)  # (answered since: a fresh send)
    assert rt.answered(REPOSITION, 20.3) == pytest.approx(0.3)


def test_a_command_long_unanswered_was_lost_and_the_next_send_is_timed() -> None:
    rt = RoundTrip(stale=3.0)
    rt.sent(REPOSITION, 10.0)  # (lost, or its answer was)
    rt.sent(REPOSITION, 14.0)
    assert rt.answered(REPOSITION, 14.2) == pytest.approx(0.2)


def test_the_lead_is_capped_and_absurd_answers_dropped() -> None:
    rt = RoundTrip(cap=1.0, stale=3.0)
    rt.sent(SPEED, 10.0)
    assert rt.answered(SPEED, 9.0) is None  # (the clock stepped back)
    for i in range(3):
        rt.sent(SPEED, 20.0 * i)
        rt.answered(SPEED, 20.0 * i + 1.8)  # a slow satellite link
    assert rt.lead == 1.0
