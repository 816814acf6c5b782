"""A rover's SmartRTL (ArduRover's ``ModeSmartRTL``): home back along the path it drove.

ArduPilot's ``AP_SmartRTL`` keeps the vehicle's path as points at least
``SRTL_ACCURACY`` (2 m) apart, from where its position was first good or it last armed,
``SRTL_POINTS`` (300) at most. Every 50 new points it simplifies them (Ramer-Douglas-
Peucker within half the accuracy); with 10 places or fewer left it cuts loops (two
segments, not neighbours, nearer than 0.99 of the accuracy: the points between go, the
pair's midpoint stays), and says "SmartRTL Low on space!" (at most every 10 s). A path it
could not save a point to for 15 s is deactivated for good ("SmartRTL deactivated:
buffer full"), and the mode is refused from then. Entering SMART_RTL it simplifies and
cuts the whole path and drives it back, newest point first, to the first, saving none
on the way and taking each point off as it reaches it: switched out on the way, the
path left is what it has not driven back. Pure: the mock steps it with the rover's
position.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from convoy_mav.planning.polyline import Point, prune_loops, simplify

__all__ = ["SmartPath"]

_TIMEOUT_S = 15.0  # s without a point saved before it is deactivated (SMARTRTL_TIMEOUT)
_CLEANUP_TRIGGER = 50  # new points that start a simplification (SMARTRTL_CLEANUP_POINT_TRIGGER)
_CLEANUP_MARGIN = 10  # places left at which it runs low on space (SMARTRTL_CLEANUP_START_MARGIN)
_CLEANUP_MIN = 10  # new points a simplification needs when low (SMARTRTL_CLEANUP_POINT_MIN)
_LOW_NOTICE_S = 10.0  # s between "Low on space" notices
_PRUNE_DELTA = 0.99  # of the accuracy: segments nearer than this make a loop


@dataclass(slots=True)
class SmartPath:
    """A rover's SmartRTL path: (north, east) points, the first its home for the mode.

    Args:
        accuracy: ``SRTL_ACCURACY``, m.
        points_max: ``SRTL_POINTS`` (0: SmartRTL off).
    """

    accuracy: float = 2.0
    points_max: int = 300
    active: bool = False
    points: list[Point] = field(default_factory=list)
    _simplified: int = 0  # points at the start already simplified
    _pruned: int = -1  # how many points it held when last searched for loops
    _saved_t: float = 0.0  # when a point was last saved (or found needless)
    _low_t: float = -math.inf  # when it last said it runs low on space

    def set_home(self, t: float, north: float, east: float) -> None:
        """The path starts anew here (its position first good, or armed)."""
        if self.points_max <= 0 or not self.accuracy > 0.0:
            return
        self.points = [(north, east)]
        self._simplified, self._saved_t, self.active = 0, t, True

    def update(self, t: float, north: float, east: float) -> list[str]:
        """The rover is here at sim time ``t`` (not in SMART_RTL); what it says."""
        if not self.active:
            return []
        texts = []
        last = self.points[-1] if self.points else None
        if last is not None and math.dist(last, (north, east)) < self.accuracy:
            self._saved_t = t
        elif len(self.points) < self.points_max:
            self.points.append((north, east))
            self._saved_t = t
        elif t - self._saved_t > _TIMEOUT_S:
            self.active = False
            return ["SmartRTL deactivated: buffer full"]
        new = len(self.points) - self._simplified
        low = self.points_max - len(self.points) <= _CLEANUP_MARGIN
        if new >= _CLEANUP_TRIGGER or (low and new >= _CLEANUP_MIN):
            self._simplify()
        elif low and self._pruned != len(self.points):  # (new points since: search again)
            self.points = prune_loops(self.points, _PRUNE_DELTA * self.accuracy)
            self._simplified = min(self._simplified, len(self.points))
            self._pruned = len(self.points)
        if len(self.points) >= self.points_max - 9 and t - self._low_t > _LOW_NOTICE_S:
            self._low_t = t
            texts.append("SmartRTL Low on space!")
        return texts

    def way_home(self) -> list[Point]:
        """The whole path simplified and its loops cut (the mode's thorough cleanup),
        newest point first: the way back, ending at its first point."""
        self._simplify()
        self.points = prune_loops(self.points, _PRUNE_DELTA * self.accuracy)
        self._simplified = len(self.points)
        return self.points[::-1]

    def reached(self, north: float, east: float, within: float) -> None:
        """On its way back, the rover is here: the points it has reached within
        ``within`` metres are taken off (the first, its home, stays)."""
        while len(self.points) > 1 and math.dist(self.points[-1], (north, east)) <= within:
            self.points.pop()
        self._simplified = min(self._simplified, len(self.points))

    def _simplify(self) -> None:
        """Simplify the points not yet simplified (from the last one that was)."""
        start = max(self._simplified - 1, 0)
        tail = simplify(self.points[start:], 0.5 * self.accuracy)
        self.points = self.points[:start] + tail
        self._simplified = len(self.points)
