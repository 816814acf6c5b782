"""The path the service saw the convoy's lead drive, kept as the lead keeps its own for
SMART_RTL: the way a lead sent home back along its path will drive.

ArduRover's SmartRTL (``AP_SmartRTL``) keeps the rover's path as points at least
``SRTL_ACCURACY`` (2 m) apart, simplifies every 50 new ones, cuts its loops when it runs
low on space, and, entering the mode, simplifies and cuts the whole path and drives it
back, newest point first, to the first, taking each point off as it reaches it. The
service keeps the convoy's estimated positions the same way (``polyline``'s
algorithms), so its forecast drives back the way the rover will, corners included,
rather than on along the rover's velocity. Pure: positions are passed in.

Its buffer is ten times the rover's default: a rover whose buffer filled is refused
SMART_RTL (it is deactivated), so one that drives it had room; the service's, fuller
for the noise of an estimate, simplifies harder if it ever fills, rather than forget
where the path began.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from convoy_mav.planning.polyline import Point, prune_loops, simplify

__all__ = ["DrivenPath"]

_CLEANUP_TRIGGER = 50  # new points that start a simplification (as SmartRTL's)
_PRUNE_DELTA = 0.99  # of the accuracy: segments nearer than this make a loop (as SmartRTL's)
_LOW_MARGIN = 10  # places left at which loops are cut (as SmartRTL's)


@dataclass(slots=True)
class DrivenPath:
    """(x, y) points of the lead's path in the mission frame (x east), oldest first.

    Args:
        accuracy: Metres between points (``SRTL_ACCURACY``'s default); half of it is the
            simplification's tolerance, 0.99 of it the nearness that makes a loop.
        points_max: Points kept at most.
    """

    accuracy: float = 2.0
    points_max: int = 3000
    points: list[Point] = field(default_factory=list)
    _simplified: int = 0  # points at the start already simplified

    def __post_init__(self) -> None:
        if not (math.isfinite(self.accuracy) and self.accuracy > 0.0):
            raise ValueError(f"accuracy must be positive, got {self.accuracy!r}")
        if self.points_max < 2 * _LOW_MARGIN:
            raise ValueError(f"points_max must be {2 * _LOW_MARGIN} or more, got {self.points_max}")

    def add(self, x: float, y: float) -> None:
        """The lead is here (driving, not on its way back): a point if it is
        ``accuracy`` from the last."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        points = self.points
        if points and math.dist(points[-1], (x, y)) < self.accuracy:
            return
        points.append((x, y))
        new = len(points) - self._simplified
        if new >= _CLEANUP_TRIGGER:
            self._simplify()
        if self.points_max - len(points) <= _LOW_MARGIN:
            self._make_room()

    def way_back(self) -> list[Point]:
        """The whole path simplified and its loops cut, newest point first: the way
        back, ending at the first point (where it was first seen)."""
        self._simplify()
        self.points = prune_loops(self.points, _PRUNE_DELTA * self.accuracy)
        self._simplified = len(self.points)
        return self.points[::-1]

    def reached(self, x: float, y: float, within: float) -> None:
        """On its way back the lead is here: the points it has reached (within
        ``within``, or passed: on from one towards the next) are taken off; the first
        stays."""
        points = self.points
        while len(points) > 1:
            (lx, ly), (px, py) = points[-1], points[-2]
            near = math.hypot(x - lx, y - ly) <= within
            if not near and (x - lx) * (px - lx) + (y - ly) * (py - ly) <= 0.0:
                break
            points.pop()
        self._simplified = min(self._simplified, len(points))

    def _simplify(self) -> None:
        """Simplify the points not yet simplified (from the last one that was)."""
        start = max(self._simplified - 1, 0)
        self.points = self.points[:start] + simplify(self.points[start:], 0.5 * self.accuracy)
        self._simplified = len(self.points)

    def _make_room(self) -> None:
        """Low on space: loops cut and, if a quarter of the buffer is not free then,
        simplified harder and harder until it is."""
        self.points = prune_loops(self.points, _PRUNE_DELTA * self.accuracy)
        tolerance = 0.5 * self.accuracy
        while 4 * len(self.points) > 3 * self.points_max:
            tolerance *= 2.0
            self.points = simplify(self.points, tolerance)
        self._simplified = len(self.points)
