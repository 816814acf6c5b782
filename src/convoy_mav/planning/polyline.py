"""Paths kept as polylines: simplified and their loops cut, as ArduPilot's SmartRTL
keeps a vehicle's path (``AP_SmartRTL``: ``detect_simplifications``, ``detect_loops``,
``remove_points_by_loops``).

Shared by the mock's rovers, which keep their own path so, and the service, which keeps
the path it saw the convoy's lead drive so, to forecast it driven back. Pure.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Point", "prune_loops", "simplify"]

Point = tuple[float, float]


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
