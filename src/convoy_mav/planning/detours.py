"""Detours: short two-arc manoeuvres that see a moving target longest.

Design rules:
- A meet-to-meet leg (``planning.meets``) aims at a point at a time. After a
  corner or a stop nobody foresaw, the pattern's next meetings can all fall
  where the convoy is not, and the UAV that can see it in the meantime is
  often one that has just met it and is flying away: no leg that *meets* the
  convoy again gets there in time (it has to come round), but a turn back
  keeps it inside the sensor disk. A detour aims at *seeing*.
- The candidates: a first arc of curvature ``k1`` flown ``d1`` seconds, then a
  second of curvature ``k2`` flown ``d2`` seconds, at one speed of the band;
  curvatures on a grid over [-1/R, 1/R] (0 included), so every candidate is
  flyable and starts on the UAV's pose (continuous position and heading).
- The score of a candidate is what it sees of the samples asked for while it
  is flown, less what the UAV would have seen of them on its own path
  meanwhile (``mine``); it ends where it ends and legs take it back to the
  pattern (the caller's business).
- Pure and vectorised: positions once per (speed, first arc, second
  curvature), the second arc's durations from prefix sums over the samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from convoy_mav.planning.dubins import Pose, Segment, Turn, arc_points
from convoy_mav.planning.meets import LegLimits

__all__ = ["Detour", "best_detour"]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

_CURVATURES = 7  # curvature grid over [-1/R, 1/R] (odd: straight included)
_FIRST_S = (0.0, 4.0, 8.0, 12.0)  # seconds the first arc is flown
_SECOND_S = (8.0, 16.0, 24.0)  # ... and the second


@dataclass(frozen=True, slots=True)
class Detour:
    """The detour kept.

    Attributes:
        segments: One or two arcs (or straights), all flown at ``speed``.
        t_end: When it ends.
        speed: m/s, inside the band.
        seen: Samples it sees, of those asked for, while it is flown.
        score: ``seen`` less the samples the UAV's own path saw meanwhile.
    """

    segments: tuple[Segment, ...]
    t_end: float
    speed: float
    seen: int
    score: int


def best_detour(
    pose: Pose,
    t: float,
    times: FloatArray,
    target: tuple[FloatArray, FloatArray],
    wanted: BoolArray,
    mine: BoolArray,
    sensor_radius: float,
    limits: LegLimits,
) -> Detour | None:
    """The two-arc detour from ``pose`` at ``t`` that sees most of the target's wanted samples.

    Args:
        pose: The UAV's pose at ``t`` (planner frame).
        t: Start time.
        times: Sample times, ascending, none before ``t``.
        target: Where the target (the convoy, as forecast) is at each of ``times``.
        wanted: Samples worth seeing (those no other UAV sees).
        mine: Wanted samples the UAV's own path sees already.
        sensor_radius: r: a sample is seen within it.
        limits: Turn radius and speed band.

    Returns:
        The best-scoring detour, or None when none scores above 0.
    """
    # (Samples past the longest detour are never flown: not laid out.)
    n_flown = int(np.searchsorted(times, t + max(_FIRST_S) + max(_SECOND_S), side="right"))
    times, wanted, mine = times[:n_flown], wanted[:n_flown], mine[:n_flown]
    target = (target[0][:n_flown], target[1][:n_flown])
    if len(times) == 0:
        return None
    tau = np.asarray(times, dtype=np.float64) - t
    lo, hi = limits.speeds
    kmax = 1.0 / limits.turn_radius
    curv = np.linspace(-kmax, kmax, _CURVATURES)
    # Rows: (speed, first arc (k1, d1); d1 = 0 once); then a second curvature k2 each.
    firsts = [(0.0, 0.0)] + [(k1, d1) for d1 in _FIRST_S if d1 > 0.0 for k1 in curv]
    heads = np.array([(v, k1, d1) for v in (lo, limits.cruise, hi) for k1, d1 in firsts])
    v, k1, d1 = (heads[:, i : i + 1] for i in range(3))
    s = v * tau[None, :]
    s1 = np.minimum(s, v * d1)
    x1, y1, h1 = arc_points(pose.x, pose.y, pose.heading, k1, s1)
    k2 = curv[None, :, None]
    x2, y2, _ = arc_points(x1[:, None, :], y1[:, None, :], h1[:, None, :], k2, (s - s1)[:, None, :])
    tx, ty = (np.asarray(a, dtype=np.float64) for a in target)
    sees = np.hypot(x2 - tx, y2 - ty) <= sensor_radius
    rows = len(heads) * _CURVATURES  # row i: heads[i // _CURVATURES], curv[i % _CURVATURES]
    gained = np.cumsum(sees & wanted, axis=2).reshape(rows, len(tau))
    lost = np.cumsum(mine & wanted)
    ends = np.repeat(heads[:, 2], _CURVATURES)  # d1 of each row
    best: tuple[int, int, int, float] | None = None  # (score, seen, row, d2)
    for d2 in _SECOND_S:
        # Samples flown: tau <= d1 + d2 (times ascending: a prefix).
        n = np.searchsorted(tau, ends + d2, side="right")
        flown = n > 0
        idx = np.maximum(n - 1, 0)
        seen_n = np.where(flown, gained[np.arange(rows), idx], 0)
        scores = seen_n - np.where(flown, lost[idx], 0)
        i = int(np.argmax(scores))
        if scores[i] > 0 and (best is None or scores[i] > best[0]):
            best = (int(scores[i]), int(seen_n[i]), i, d2)
    if best is None:
        return None
    score, seen, i, d2 = best
    vi, k1i, d1i = (float(x) for x in heads[i // _CURVATURES])
    k2i = float(curv[i % _CURVATURES])
    segments: list[Segment] = []
    start = pose
    for k, d in ((k1i, d1i), (k2i, d2)):
        if d <= 0.0:
            continue
        segment = _segment(start, k, vi, d)
        segments.append(segment)
        start = segment.at(d)
    return Detour(tuple(segments), t + d1i + d2, vi, seen, score)


def _segment(start: Pose, k: float, speed: float, duration: float) -> Segment:
    if abs(k) <= 1e-12:
        return Segment(start, Turn.STRAIGHT, 0.0, speed, duration)
    return Segment(start, Turn.LEFT if k > 0.0 else Turn.RIGHT, 1.0 / abs(k), speed, duration)
