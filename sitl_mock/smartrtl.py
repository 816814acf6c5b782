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

import numpy as np

__all__ = ["SmartPath"]

_TIMEOUT_S = 15.0  # s without a point saved before it is deactivated (SMARTRTL_TIMEOUT)
_CLEANUP_TRIGGER = 50  # new points that start a simplification (SMARTRTL_CLEANUP_POINT_TRIGGER)
_CLEANUP_MARGIN = 10  # places left at which it runs low on space (SMARTRTL_CLEANUP_START_MARGIN)
_CLEANUP_MIN = 10  # new points a simplification needs when low (SMARTRTL_CLEANUP_POINT_MIN)
_LOW_NOTICE_S = 10.0  # s between "Low on space" notices
_PRUNE_DELTA = 0.99  # of the accuracy: segments nearer than this make a loop

Point = tuple[float, float]


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


def simplify(points: list[Point], epsilon: float) -> list[Point]:
    """Ramer-Douglas-Peucker: the points whose removal would move the path more than
    ``epsilon``, the ends kept (``AP_SmartRTL::detect_simplifications``)."""
    if len(points) < 3:
        return list(points)
    keep = [False] * len(points)
    keep[0] = keep[-1] = True
    xy = np.asarray(points, dtype=float)
    todo = [(0, len(points) - 1)]
    while todo:
        a, b = todo.pop()
        if b - a < 2:
            continue
        d = _point_segment(xy[a + 1 : b], xy[a], xy[b])
        k = int(np.argmax(d))
        if d[k] > epsilon:
            keep[a + 1 + k] = True
            todo += [(a, a + 1 + k), (a + 1 + k, b)]
    return [p for p, kept in zip(points, keep, strict=True) if kept]


def prune_loops(points: list[Point], delta: float) -> list[Point]:
    """The path with its loops cut (``AP_SmartRTL::detect_loops`` and
    ``remove_points_by_loops``): from the newest segment back, the first earlier segment
    (not its neighbour) nearer than ``delta`` makes a loop; of overlapping loops the
    longest is kept; each is cut, the points between going and the segments' closest
    points' midpoint taking the first's place."""
    n = len(points)
    if n < 4:
        return list(points)
    xy = np.asarray(points, dtype=float)
    loops: list[tuple[int, int, Point, float]] = []  # (start, end, midpoint, length^2)
    i = n - 1
    while i >= 4:
        js = np.arange(1, i - 1)
        dist, mids = _segment_segment(xy[i], xy[i - 1], xy[js - 1], xy[js])
        near = np.flatnonzero(dist < delta)
        if near.size:
            j = int(js[near[0]])
            mid = (float(mids[near[0], 0]), float(mids[near[0], 1]))
            loops = _add_loop(loops, j, i - 1, mid, xy)
        i -= 1
    path = list(points)
    for k in range(len(loops) - 1, -1, -1):
        start, end, mid, _ = loops[k]
        path[start] = mid
        del path[start + 1 : end + 1]
        cut = end - start
        loops[:k] = [
            (s - cut if s >= end else s, e - cut if e >= end else e, m, length)
            for s, e, m, length in loops[:k]
        ]
    return path


def _add_loop(
    loops: list[tuple[int, int, Point, float]], start: int, end: int, mid: Point, xy: np.ndarray
) -> list[tuple[int, int, Point, float]]:
    """``AP_SmartRTL::add_loop``: the new loop, unless those it overlaps are longer."""
    m = np.asarray(mid)
    steps = np.diff(xy[start : end + 1], axis=0)
    length = float(
        np.sum((m - xy[start]) ** 2) + np.sum((m - xy[end]) ** 2) + np.sum(steps * steps)
    )
    over = [lp for lp in loops if _overlap(lp, start, end)]
    if over and sum(lp[3] for lp in over) > length:
        return loops
    return [lp for lp in loops if not _overlap(lp, start, end)] + [(start, end, mid, length)]


def _overlap(loop: tuple[int, int, Point, float], start: int, end: int) -> bool:
    """``AP_SmartRTL::loops_overlap``."""
    s, e = loop[0], loop[1]
    if (s >= start and e <= end) or (start >= s and end <= e):
        return True
    return (s <= start <= e) != (s <= end <= e)


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of points ``p`` (k, 2) from the segment ``a``-``b``."""
    ab = b - a
    length2 = float(ab @ ab)
    if length2 <= 0.0:
        return np.asarray(np.hypot(*(p - a).T))
    t = np.clip((p - a) @ ab / length2, 0.0, 1.0)
    return np.asarray(np.hypot(*(p - a - t[:, None] * ab).T))


def _segment_segment(
    p1: np.ndarray, p2: np.ndarray, p3: np.ndarray, p4: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``AP_SmartRTL::segment_segment_dist`` of ``p1``-``p2`` against each of the
    segments ``p3``-``p4`` (k, 2): each parameter clamped on its own, parallel ones
    infinitely far; and the midpoints between the closest points."""
    line1 = p2 - p1
    line2 = p4 - p3
    diff = p1 - p3
    a = float(line1 @ line1)
    b = line2 @ line1
    c = np.sum(line2 * line2, axis=1)
    d = diff @ line1
    e = np.sum(line2 * diff, axis=1)
    den = a * c - b * b
    parallel = np.abs(den) <= 1e-9 * np.maximum(a * c, 1e-12)
    safe = np.where(parallel, 1.0, den)
    t1 = np.clip((b * e - c * d) / safe, 0.0, 1.0)
    t2 = np.clip((a * e - b * d) / safe, 0.0, 1.0)
    gap = diff + t1[:, None] * line1 - t2[:, None] * line2
    dist = np.where(parallel, np.inf, np.hypot(*gap.T))
    mids = (p1 + t1[:, None] * line1 + p3 + t2[:, None] * line2) / 2.0
    return dist, mids
