"""Which telemetry message is due when: the stream scheduler of one simulated vehicle.

A real autopilot sends each telemetry message on its own interval, which a ground
station changes with MAV_CMD_SET_MESSAGE_INTERVAL (PX4 and ArduPilot) or with the
older REQUEST_DATA_STREAM stream groups (ArduPilot). This module keeps only the
bookkeeping -- one interval and one next-due time per message id -- and knows
nothing of message contents, so the autopilot asks it "what is due at ``now``?"
and builds exactly those messages.

Design rules:
    * Pure: times are sim seconds passed in; no clock is read.
    * Deadlines advance by whole intervals, so a 10 Hz stream sampled by a 100 Hz
      physics loop emits exactly every tenth step; a caller late by more than one
      interval gets one message, not a burst of stale ones.
    * ``None`` means disabled; an interval is always > 0 otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from pymavlink.dialects.v20 import common as mavlink

__all__ = [
    "AIRCRAFT_DEFAULT_INTERVALS",
    "ARDUPILOT_STREAM_GROUPS",
    "GROUND_DEFAULT_INTERVALS",
    "StreamScheduler",
]

_SLACK = 5e-7
"""s: float sums of 0.01 s steps land a hair before an exact deadline."""

AIRCRAFT_DEFAULT_INTERVALS: Mapping[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.1,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 0.1,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 0.1,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: 0.25,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 2.0,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_TIMESYNC: 0.1,
}
"""Default intervals (s) of an aircraft: roughly PX4's onboard-UDP profile (the position
target is sent only by the ArduPilot personality: ``FlightState.reported_target``; the
TIMESYNC requests of its own, 10 Hz, only by PX4's: in no ArduPilot group)."""

GROUND_DEFAULT_INTERVALS: Mapping[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 1.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 0.1,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 0.1,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 2.0,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,
}
"""Default intervals (s) of a ground vehicle: a convoy member reports where it is (and
a rover driving a mission which item it drives to)."""

ARDUPILOT_STREAM_GROUPS: Mapping[int, tuple[int, ...]] = {
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: (
        mavlink.MAVLINK_MSG_ID_SYS_STATUS,
        mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
        mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT,
        mavlink.MAVLINK_MSG_ID_MISSION_CURRENT,
    ),
    mavlink.MAV_DATA_STREAM_POSITION: (
        mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
        mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
    ),
    mavlink.MAV_DATA_STREAM_EXTRA1: (mavlink.MAVLINK_MSG_ID_ATTITUDE,),
    mavlink.MAV_DATA_STREAM_EXTRA2: (mavlink.MAVLINK_MSG_ID_VFR_HUD,),
    mavlink.MAV_DATA_STREAM_EXTRA3: (
        mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
        mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
    ),
    # Groups whose messages the mock does not produce: accepted, nothing changes.
    mavlink.MAV_DATA_STREAM_RAW_SENSORS: (),
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: (),
    mavlink.MAV_DATA_STREAM_RAW_CONTROLLER: (),
}
"""ArduPilot's REQUEST_DATA_STREAM groups (``GCS_MAVLink_Parameters.cpp`` of 4.7, its
SRn_* parameters), restricted to the messages the mock produces. As in the firmware,
a group switches on *every* member (asking for positions brings LOCAL_POSITION_NED
too), and EXTENDED_SYS_STATE is in no group: only SET_MESSAGE_INTERVAL starts it.
``MAV_DATA_STREAM_ALL`` means every group."""


class StreamScheduler:
    """Per-message intervals and next-due times for one vehicle's telemetry.

    Args:
        defaults: Message id -> default interval (s); what "interval 0" restores and
            what ``enabled=True`` starts with. Only these ids can be scheduled.
        now: Sim time of creation (boot).
        enabled: Start with every default stream on (PX4) or only those listed in
            ``always_on`` (ArduPilot, which streams nothing until asked).
        always_on: Message ids that run at their default from boot regardless
            (HEARTBEAT).
    """

    def __init__(
        self,
        defaults: Mapping[int, float],
        now: float,
        *,
        enabled: bool = True,
        always_on: Iterable[int] = (mavlink.MAVLINK_MSG_ID_HEARTBEAT,),
    ) -> None:
        for msg_id, interval in defaults.items():
            _check_interval(msg_id, interval)
        self._defaults = dict(defaults)
        self._always_on = frozenset(always_on)
        self._interval: dict[int, float | None] = {}
        self._next: dict[int, float] = {}
        self.restart(now, enabled=enabled)

    @property
    def supported(self) -> frozenset[int]:
        """Message ids this scheduler can stream."""
        return frozenset(self._defaults)

    def default_interval(self, msg_id: int) -> float | None:
        """The default interval (s) of ``msg_id``, or ``None`` if it is not streamable."""
        return self._defaults.get(msg_id)

    def interval(self, msg_id: int) -> float | None:
        """Current interval (s) of ``msg_id``; ``None`` when disabled or unsupported."""
        return self._interval.get(msg_id)

    def restart(self, now: float, *, enabled: bool) -> None:
        """Back to boot configuration (a reboot forgets every interval change)."""
        self._interval.clear()
        self._next.clear()
        for msg_id, interval in self._defaults.items():
            on = enabled or msg_id in self._always_on
            self._interval[msg_id] = interval if on else None
            if on:
                self._next[msg_id] = now

    def set_interval(self, msg_id: int, interval: float | None, now: float) -> None:
        """Stream ``msg_id`` every ``interval`` seconds from ``now`` on (``None``: stop).

        The first message is due at once, as an autopilot answers a rate request
        immediately.

        Raises:
            KeyError: ``msg_id`` is not streamable.
            ValueError: ``interval`` is not a positive finite number.
        """
        if msg_id not in self._defaults:
            raise KeyError(msg_id)
        if interval is None:
            self._interval[msg_id] = None
            self._next.pop(msg_id, None)
            return
        _check_interval(msg_id, interval)
        was = self._interval[msg_id]
        self._interval[msg_id] = interval
        if was is None or msg_id not in self._next:
            self._next[msg_id] = now
        else:
            # Keep the phase if already due sooner; never wait longer than one interval.
            self._next[msg_id] = min(self._next[msg_id], now + interval)

    def reset_default(self, msg_id: int, now: float) -> None:
        """Restore the default interval of ``msg_id`` (SET_MESSAGE_INTERVAL with 0)."""
        self.set_interval(msg_id, self._defaults[msg_id], now)

    def interval_us(self, msg_id: int) -> int:
        """MESSAGE_INTERVAL.interval_us: microseconds, -1 when off, 0 when not available."""
        if msg_id not in self._defaults:
            return 0
        interval = self._interval[msg_id]
        return -1 if interval is None else round(interval * 1e6)

    def set_message_interval(self, msg_id: int, interval_us: float, now: float) -> bool:
        """MAV_CMD_SET_MESSAGE_INTERVAL: -1 disables, 0 restores the default.

        Returns:
            False (the command is to be DENIED) for an unknown message or a bad value.
        """
        if msg_id not in self._defaults or not math.isfinite(interval_us):
            return False
        if interval_us == -1.0:
            self.set_interval(msg_id, None, now)
        elif interval_us == 0.0:
            self.reset_default(msg_id, now)
        elif interval_us > 0.0:
            self.set_interval(msg_id, interval_us * 1e-6, now)
        else:
            return False
        return True

    def request_data_stream(
        self, stream_id: int, rate_hz: int, start_stop: int, now: float
    ) -> None:
        """ArduPilot REQUEST_DATA_STREAM: set a whole group (or all) to ``rate_hz``.

        As ArduPilot does: ``start_stop`` 0 stops the group, a rate of 0 with
        ``start_stop`` 1 changes nothing, unknown groups are ignored.
        """
        if stream_id == mavlink.MAV_DATA_STREAM_ALL:
            groups = list(ARDUPILOT_STREAM_GROUPS.values())
        elif stream_id in ARDUPILOT_STREAM_GROUPS:
            groups = [ARDUPILOT_STREAM_GROUPS[stream_id]]
        else:
            return
        if start_stop == 0:
            interval: float | None = None
        elif rate_hz > 0:
            interval = 1.0 / rate_hz
        else:
            return
        for group in groups:
            for msg_id in group:
                if msg_id in self._defaults:
                    self.set_interval(msg_id, interval, now)

    def due(self, now: float) -> list[int]:
        """Message ids due at ``now``, in table order; their deadlines move on."""
        out: list[int] = []
        for msg_id, deadline in self._next.items():
            if now + _SLACK < deadline:
                continue
            interval = self._interval[msg_id]
            assert interval is not None
            following = deadline + interval
            if following <= now + _SLACK:  # late by more than a period: skip, don't burst
                following = now + interval
            self._next[msg_id] = following
            out.append(msg_id)
        return out


def _check_interval(msg_id: int, interval: float) -> None:
    if not (math.isfinite(interval) and interval > 0.0):
        raise ValueError(f"interval of message {msg_id} must be > 0 s, got {interval!r}")
