"""Which of an autopilot's streams flow faster than they were asked for: pure arithmetic.

A stream request lost on the link leaves a stream as it was. The service notices one
unheard (``Vehicle._watch_streams``); this finds the others: a message asked for at
0.2 Hz still coming at set-up's 1 Hz because its change of rate was lost, or a whole
boot profile still flowing because the request that stopped it was lost (ArduPlane SITL
behind a radio losing 30 %: one plane of three sent 2.6 times the telemetry of the
others for the whole flight, its group stop lost; the radio's budget is what it ate).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

__all__ = ["ANSWERS", "faster_than_asked"]

ANSWERS: frozenset[str] = frozenset(
    {
        "HEARTBEAT",  # (1 Hz whatever is asked)
        "COMMAND_ACK",
        "STATUSTEXT",
        "PARAM_VALUE",
        "AUTOPILOT_VERSION",
        "PROTOCOL_VERSION",
        "MISSION_ACK",
        "MISSION_COUNT",
        "MISSION_ITEM",
        "MISSION_ITEM_INT",
        "MISSION_REQUEST",
        "MISSION_REQUEST_INT",
        "MISSION_ITEM_REACHED",
        "FENCE_POINT",
        "RALLY_POINT",
        "GPS_GLOBAL_ORIGIN",
        "PING",
        "FILE_TRANSFER_PROTOCOL",
        "LOG_ENTRY",
        "LOG_DATA",
        "BAD_DATA",
        "CAMERA_TRIGGER",  # (a camera's events: PX4 forwards each as it comes)
        "CAMERA_IMAGE_CAPTURED",
        "ADSB_VEHICLE",  # (traffic, forwarded as heard: never stopped on the service's link)
    }
)
"""Messages an autopilot sends as answers or on events, never as a stream of its own.
(TIMESYNC is both: the answers to the service's requests, and PX4's own requests, a
stream of 10 Hz in its onboard profile, ``mavlink_main.cpp``; the caller counts the
answers it asks for as that stream's rate.)"""

SLACK = 3
"""Messages a window may hold past twice the rate asked: a request's round trip of the
rate before, a burst read at once."""


def faster_than_asked(
    counts: Mapping[str, int],
    seconds: float,
    asked: Mapping[str, float],
    answers: Collection[str] = ANSWERS,
) -> list[str]:
    """The streams among ``counts`` (messages heard in a window of ``seconds``) that came
    more than twice as often as ``asked`` (Hz; absent or 0: not asked for), beyond
    :data:`SLACK`; ``answers`` are never streams.

    Twice: loss only thins a stream, and a rate the firmware rounds (ArduPilot's
    scheduler, 50 Hz loops) is off by far less; so one over it is no loss but a request
    not taken.
    """
    return sorted(
        name
        for name, n in counts.items()
        if name not in answers and n > 2.0 * asked.get(name, 0.0) * seconds + SLACK
    )
