"""How late a setpoint takes effect: the link's round trip, timed from its answers.

Mission time is the autopilots' clock as heard here (``clock``), so it trails each
autopilot by the link's delay towards us; a setpoint sent at mission time ``t`` then
takes the delay towards the autopilot to arrive. By the autopilot's own clock it is
flown from ``t`` plus the round trip: on a telemetry link of 200 ms each way, 0.4 s
late, where an ArduPlane on the paper's arcs switches to the next arc 7 m past the
tangent point at 18 m/s (and a lost DO_REPOSITION a second later again). So the
streamer asks the plan for ``t`` plus this lead, and the setpoint arrives for the
instant it is flown. The round trip is the one time both ends agree on: a TIMESYNC
request (``tc1`` 0, ``ts1`` our time) and its answer, which PX4 and ArduPilot send back
at once with ``ts1`` echoed, once a second; and every command and its COMMAND_ACK.

Pure: times come in.
"""

from __future__ import annotations

import statistics
from collections import deque
from collections.abc import Hashable
from dataclasses import dataclass, field

__all__ = ["RoundTrip"]

_PENDING_MAX = 64  # unanswered sends kept before the stale ones are dropped


@dataclass(slots=True)
class RoundTrip:
    """Round trips of commands to one autopilot (mission seconds), and their median.

    A command sent again before its answer came (a retry, or the same command sent
    anew) makes its answer ambiguous, and no sample is taken from it; a command left
    unanswered for ``stale`` seconds was lost, and its next send is a fresh one.

    Args:
        keep: Most recent samples kept; the lead is their median (jitter and the odd
            late answer do not move it).
        cap: The largest lead given (s): a link slower than that is not flown ahead
            of, and a very late answer (a stalled host) does not make one.
        stale: Seconds after which an unanswered command counts as lost.
    """

    keep: int = 15
    cap: float = 1.0
    stale: float = 3.0
    samples: deque[float] = field(default_factory=deque)
    _pending: dict[Hashable, tuple[float, bool]] = field(default_factory=dict)
    _lead: float = 0.0  # (kept, not taken at each read: the streamer reads it every round)

    def sent(self, key: Hashable, t: float) -> None:
        """Something its answer names by ``key`` (a command's id, a TIMESYNC's ``ts1``)
        was sent at mission time ``t``."""
        pending = self._pending
        last = pending.get(key)
        again = last is not None and t - last[0] < self.stale
        pending[key] = (t, again)
        if len(pending) > _PENDING_MAX:  # (requests lost on the link: never answered)
            self._pending = {k: v for k, v in pending.items() if t - v[0] < self.stale}

    def answered(self, key: Hashable, t: float) -> float | None:
        """The answer to ``key`` came at mission time ``t``: the round trip it measures,
        or None (not ours to time: never sent, sent twice, or long ago)."""
        last = self._pending.pop(key, None)
        if last is None or last[1]:
            return None
        rtt = t - last[0]
        if not 0.0 <= rtt <= self.stale:
            return None
        self.samples.append(rtt)
        if len(self.samples) > self.keep:
            self.samples.popleft()
        self._lead = min(statistics.median(self.samples), self.cap)
        return rtt

    @property
    def lead(self) -> float:
        """The median round trip (s), at most ``cap``; 0 before any was timed."""
        return self._lead
