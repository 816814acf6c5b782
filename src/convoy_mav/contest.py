"""Is someone else driving this UAV? Evidence of a second controller, sans I/O.

Two services (or a service and a GCS script) streaming targets to one autopilot
fight: each flies the UAV part of the time, and neither covers the convoy. What
a link shows of the other one:

* **Its frames**, where the link is shared (a MAVLink router, a radio, one UDP
  port): commands or setpoints addressed to our vehicle from another system, or
  a GCS HEARTBEAT with our own system and component id (a second instance of
  this service). ArduPilot itself forwards another channel's GCS heartbeat only
  when its ids differ from ours, and never the commands it takes itself
  (``MAVLink_routing.cpp``), so this is not the only sign.
* **Its targets**: ArduPilot reports where it is going in
  POSITION_TARGET_GLOBAL_INT (ArduPlane ``next_WP_loc``, ArduCopter GUIDED's
  position target). A reported target that is none of the positions we sent in
  the last ``recent_s`` (nor our last few), or, before we have sent any, one that
  keeps moving, is somebody else's. For ``settle_s`` after our first target the
  autopilot may still report its own (ArduPlane's GUIDED entry point): not a sign.

One sign alone is noise (a report that crossed our newest target on the way); a
UAV is contested when ``needed`` signs fall within ``window_s``, and free again
after ``clear_s`` without one. Times are mission seconds.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

__all__ = ["ControlWatch"]

_M_PER_E7 = 0.011131949  # metres per 1e-7 degree of latitude


def _distance_m(a: tuple[int, int], b: tuple[int, int]) -> float:
    """Metres between two (lat, lon) in 1e-7 degrees (flat earth: tens of metres apart)."""
    dlat = (a[0] - b[0]) * _M_PER_E7
    dlon = (a[1] - b[1]) * _M_PER_E7 * math.cos(math.radians(a[0] * 1e-7))
    return math.hypot(dlat, dlon)


@dataclass(slots=True)
class ControlWatch:
    """Signs of another controller on one UAV (see the module docstring).

    Args:
        tolerance_m: A reported target this close to one we sent is ours.
        moved_m: Before we send any, a reported target that moves this far is driven.
        recent_s: Our targets of the last this-many seconds count as ours...
        keep: ... and so do our last ``keep`` whatever their age (a loiter re-sent
            only when it changes stays in force); a target sent again counts once.
        needed, window_s: Signs needed within the window to call it contested.
        clear_s: Quiet time after which it is free again.
        settle_s: Reports this soon after our first target are not judged.
    """

    tolerance_m: float = 30.0
    moved_m: float = 10.0
    recent_s: float = 10.0
    keep: int = 4
    needed: int = 3
    window_s: float = 10.0
    clear_s: float = 15.0
    settle_s: float = 3.0
    signs: int = 0  # every sign seen (for the report)
    reason: str | None = None  # why it is contested now, None when free
    _sent: deque[tuple[float, tuple[int, int]]] = field(default_factory=deque)
    _signs: deque[float] = field(default_factory=deque)
    _last_report: tuple[int, int] | None = None
    _last_sign_t: float = -math.inf
    _first_sent_t: float = math.inf

    @property
    def commanding(self) -> bool:
        """Have we sent it a position target yet?"""
        return bool(self._sent)

    def sent(self, t: float, lat_e7: int, lon_e7: int) -> None:
        """We commanded the UAV to (lat, lon) at mission time ``t``."""
        sent = self._sent
        if not sent:
            self._first_sent_t = t
        here = (lat_e7, lon_e7)
        if sent and sent[-1][1] == here:  # sent again (a copy, a retry): one target still,
            sent[-1] = (t, here)  # or a loiter retried four times on a lossy link
            return  # pushed the one before out, and a late report of it was "not ours"
        sent.append((t, here))
        # Kept by age, not count: a link lagging a second at 100 Hz reports a target
        # 100 sends old (a bound of 64 made it another's). Clock steps back: kept.
        while len(sent) > self.keep and t - sent[0][0] > self.recent_s:
            sent.popleft()

    def reported(self, t: float, lat_e7: int, lon_e7: int) -> bool:
        """The autopilot reports its position target; True if it is a sign."""
        here = (lat_e7, lon_e7)
        last, self._last_report = self._last_report, here
        if not self._sent:
            moving = last is not None and _distance_m(here, last) > self.moved_m
            return moving and self._sign(t, "its position target moves and is not ours")
        if t - self._first_sent_t < self.settle_s:
            return False
        sent = self._sent
        ours = any(
            _distance_m(here, p) <= self.tolerance_m
            for k, (when, p) in enumerate(reversed(sent))
            if k < self.keep or t - when <= self.recent_s
        )
        return not ours and self._sign(t, "its position target is not one we sent")

    def stranger(self, t: float, what: str) -> bool:
        """A frame of another controller seen on the link (``what`` says which)."""
        return self._sign(t, what)

    def check(self, t: float) -> str | None:
        """The reason it is contested at ``t``, or None (free again after ``clear_s``)."""
        if self.reason is not None and t - self._last_sign_t > self.clear_s:
            self.reason = None
        return self.reason

    def forget_ours(self) -> None:
        """A new session (set-up anew): our old targets say nothing of the next ones."""
        self._sent.clear()
        self._last_report = None
        self._first_sent_t = math.inf

    def _sign(self, t: float, why: str) -> bool:
        self.signs += 1
        self._last_sign_t = t
        signs = self._signs
        signs.append(t)
        while signs and t - signs[0] > self.window_s:
            signs.popleft()
        if len(signs) >= self.needed:
            self.reason = why
        return True
