"""Dubins motion primitives and the Dubins shortest path between two poses.

Design rules:
- The planning frame is the paper's: x east, y north, heading in radians
  counter-clockwise from +x, lengths in metres, speeds in m/s.  The bridge
  converts to NED only at the MAVLink edge.
- A primitive is a ``Segment``: a start pose, a turn direction (+1 left,
  -1 right, 0 straight), a radius, a speed and a duration.  Positions inside a
  segment are evaluated in closed form (exact arcs), never integrated, so
  sampling is exact at any time and any rate.
- Everything here is pure: no clocks, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np
import numpy.typing as npt

__all__ = [
    "DubinsPath",
    "Pose",
    "Segment",
    "Turn",
    "arc_points",
    "dubins_shortest_path",
    "dubins_word_lengths",
    "dubins_word_path",
    "wrap_angle",
]

FloatArray = npt.NDArray[np.float64]

TWO_PI = 2.0 * math.pi


def wrap_angle(angle: float) -> float:
    """Wrap an angle to (-pi, pi]."""
    wrapped = math.fmod(angle + math.pi, TWO_PI)
    if wrapped <= 0.0:
        wrapped += TWO_PI
    return wrapped - math.pi


def arc_points(
    x0: FloatArray | float,
    y0: FloatArray | float,
    h0: FloatArray | float,
    k: FloatArray | float,
    s: FloatArray | float,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Position and heading after ``s`` metres at signed curvature ``k`` from ``(x0, y0, h0)``
    (numpy broadcasting; ``k = 0``: straight).

    The chord form of eq. (28): ``s sinc(k s / 2)`` along the mean heading
    ``h0 + k s / 2``, exact on arcs and straights alike with no branch, so a
    planner scores thousands of candidate arcs in one pass.
    """
    half = 0.5 * np.asarray(k) * np.asarray(s)
    chord = s * np.sinc(half / np.pi)
    mid = h0 + half
    return x0 + chord * np.cos(mid), y0 + chord * np.sin(mid), h0 + 2.0 * half


def _mod2pi(angle: float) -> float:
    """Wrap an angle to [0, 2 pi)."""
    wrapped = math.fmod(angle, TWO_PI)
    return wrapped + TWO_PI if wrapped < 0.0 else wrapped


class Turn(IntEnum):
    """Direction of a motion primitive: the sign of the turn rate."""

    RIGHT = -1
    STRAIGHT = 0
    LEFT = 1

    @property
    def letter(self) -> str:
        """The paper's letter for the primitive: ``L``, ``R`` or ``S``."""
        return {Turn.LEFT: "L", Turn.RIGHT: "R", Turn.STRAIGHT: "S"}[self]


@dataclass(frozen=True, slots=True)
class Pose:
    """A planar state ``q = [x, y, theta]`` of eq. (1)."""

    x: float
    y: float
    heading: float

    def rotated(self, angle: float) -> Pose:
        """The paper's rotation of a state: rotate (x, y) and add ``angle`` to the heading."""
        c, s = math.cos(angle), math.sin(angle)
        return Pose(c * self.x - s * self.y, s * self.x + c * self.y, self.heading + angle)

    def translated(self, dx: float, dy: float) -> Pose:
        """The same state moved by (dx, dy)."""
        return Pose(self.x + dx, self.y + dy, self.heading)

    def as_list(self) -> list[float]:
        """``[x, y, heading]`` with the heading wrapped to (-pi, pi]."""
        return [self.x, self.y, wrap_angle(self.heading)]


@dataclass(frozen=True, slots=True)
class Segment:
    """One motion primitive of the Dubins vehicle (eq. 1, eq. 28).

    Attributes:
        start: Pose at the start of the segment.
        turn: +1 turns maximally left, -1 maximally right, 0 flies straight.
        radius: Turn radius in metres (ignored for straight segments).
        speed: Constant forward speed in m/s.
        duration: Time the primitive is flown, in seconds.
    """

    start: Pose
    turn: Turn
    radius: float
    speed: float
    duration: float
    # Constants of eq. (28) for this segment, worked out once: every setpoint of
    # every UAV samples a segment (tens of thousands a second for a big fleet).
    _rate: float = field(init=False, repr=False, compare=False)
    _k: float = field(init=False, repr=False, compare=False)
    _sin0: float = field(init=False, repr=False, compare=False)
    _cos0: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not (self.duration >= 0.0 and math.isfinite(self.duration)):
            raise ValueError(f"segment duration must be finite and >= 0, got {self.duration!r}")
        if not (self.speed > 0.0 and math.isfinite(self.speed)):
            raise ValueError(f"segment speed must be finite and > 0, got {self.speed!r}")
        straight = self.turn == Turn.STRAIGHT
        if not straight and not (self.radius > 0.0 and math.isfinite(self.radius)):
            raise ValueError(f"arc radius must be finite and > 0, got {self.radius!r}")
        k = 0.0 if straight else float(self.turn) * self.radius
        set_ = object.__setattr__
        set_(self, "_k", k)
        set_(self, "_rate", 0.0 if straight else self.speed / k)
        set_(self, "_sin0", math.sin(self.start.heading))
        set_(self, "_cos0", math.cos(self.start.heading))

    @property
    def turn_rate(self) -> float:
        """Signed turn rate ``omega`` in rad/s (|omega| = V/R on arcs)."""
        return self._rate

    @property
    def length(self) -> float:
        """Path length in metres."""
        return self.speed * self.duration

    @property
    def center(self) -> tuple[float, float]:
        """Centre of the arc (undefined for straight segments)."""
        if self.turn == Turn.STRAIGHT:
            raise ValueError("a straight segment has no centre")
        h = self.start.heading
        k = self.turn * self.radius
        return self.start.x - k * math.sin(h), self.start.y + k * math.cos(h)

    def at(self, tau: float) -> Pose:
        """Closed-form pose ``tau`` seconds after the segment start (eq. 28)."""
        return Pose(*self.state(tau))

    def state(self, tau: float) -> tuple[float, float, float]:
        """``(x, y, heading)`` ``tau`` seconds after the start: :meth:`at` as a tuple."""
        p = self.start
        rate = self._rate
        if rate == 0.0:
            d = self.speed * tau
            return p.x + d * self._cos0, p.y + d * self._sin0, p.heading
        k = self._k
        h = p.heading + rate * tau
        return p.x + k * (math.sin(h) - self._sin0), p.y - k * (math.cos(h) - self._cos0), h

    @property
    def end(self) -> Pose:
        """Pose at the end of the segment."""
        return self.at(self.duration)


@dataclass(frozen=True, slots=True)
class DubinsPath:
    """A shortest path between two poses: three primitives named by ``word``."""

    word: str
    segments: tuple[Segment, Segment, Segment]

    @property
    def duration(self) -> float:
        """Time to fly the whole path, in seconds."""
        return sum(s.duration for s in self.segments)

    @property
    def length(self) -> float:
        """Length of the whole path, in metres."""
        return sum(s.length for s in self.segments)


_LETTER_TURN = {"L": Turn.LEFT, "R": Turn.RIGHT, "S": Turn.STRAIGHT}


def _word_params(word: str, a: float, b: float, d: float) -> tuple[float, float, float] | None:
    """Normalised lengths (t, p, q) of one Dubins word, or None if it does not exist.

    ``a``/``b`` are the start and goal headings relative to the line joining the
    poses and ``d`` their distance over the radius (the standard Dubins
    normalisation, as in LaValle, *Planning Algorithms*, sec. 15.3.1).
    """
    sa, sb, ca, cb = math.sin(a), math.sin(b), math.cos(a), math.cos(b)
    cab = math.cos(a - b)
    if word == "LSL":
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sa - sb)
        if p2 < 0.0:
            return None
        phi = math.atan2(cb - ca, d + sa - sb)
        return _mod2pi(phi - a), math.sqrt(p2), _mod2pi(b - phi)
    if word == "RSR":
        p2 = 2.0 + d * d - 2.0 * cab + 2.0 * d * (sb - sa)
        if p2 < 0.0:
            return None
        phi = math.atan2(ca - cb, d - sa + sb)
        return _mod2pi(a - phi), math.sqrt(p2), _mod2pi(phi - b)
    if word == "LSR":
        p2 = -2.0 + d * d + 2.0 * cab + 2.0 * d * (sa + sb)
        if p2 < 0.0:
            return None
        p = math.sqrt(p2)
        phi = math.atan2(-ca - cb, d + sa + sb) - math.atan2(-2.0, p)
        return _mod2pi(phi - a), p, _mod2pi(phi - b)
    if word == "RSL":
        p2 = d * d - 2.0 + 2.0 * cab - 2.0 * d * (sa + sb)
        if p2 < 0.0:
            return None
        p = math.sqrt(p2)
        phi = math.atan2(ca + cb, d - sa - sb) - math.atan2(2.0, p)
        return _mod2pi(a - phi), p, _mod2pi(b - phi)
    if word == "RLR":
        c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sa - sb)) / 8.0
        if abs(c) > 1.0:
            return None
        p = _mod2pi(TWO_PI - math.acos(c))
        t = _mod2pi(a - math.atan2(ca - cb, d - sa + sb) + p / 2.0)
        return t, p, _mod2pi(a - b - t + p)
    if word == "LRL":
        c = (6.0 - d * d + 2.0 * cab + 2.0 * d * (sb - sa)) / 8.0
        if abs(c) > 1.0:
            return None
        p = _mod2pi(TWO_PI - math.acos(c))
        t = _mod2pi(-a - math.atan2(ca - cb, d + sa - sb) + p / 2.0)
        return t, p, _mod2pi(b - a - t + p)
    raise ValueError(f"unknown Dubins word {word!r}")


DUBINS_WORDS = ("LSL", "RSR", "LSR", "RSL", "RLR", "LRL")


def _normalise(start: Pose, goal: Pose, radius: float) -> tuple[float, float, float]:
    """The standard Dubins normalisation ``(a, b, d)`` of a start/goal pair."""
    dx, dy = goal.x - start.x, goal.y - start.y
    d = math.hypot(dx, dy) / radius
    theta = math.atan2(dy, dx) if d > 0.0 else 0.0
    return _mod2pi(start.heading - theta), _mod2pi(goal.heading - theta), d


def _check_radius_speed(radius: float, speed: float) -> None:
    if not (radius > 0.0 and math.isfinite(radius)):
        raise ValueError(f"turn radius must be finite and > 0, got {radius!r}")
    if not (speed > 0.0 and math.isfinite(speed)):
        raise ValueError(f"speed must be finite and > 0, got {speed!r}")


def dubins_word_lengths(start: Pose, goal: Pose, radius: float) -> dict[str, float]:
    """Length in metres of every Dubins word that joins ``start`` to ``goal``.

    A cheap closed-form screen (no segments are built, nothing is verified by
    propagation): words that do not exist for this pair are left out.  Each
    word's length is continuous in the poses except where one of its arcs
    wraps between 0 and a full turn; timed joins scan it for exact lengths.
    Use ``dubins_word_path`` to build (and verify) the chosen word.
    """
    _check_radius_speed(radius, 1.0)
    a, b, d = _normalise(start, goal, radius)
    out: dict[str, float] = {}
    for word in DUBINS_WORDS:
        params = _word_params(word, a, b, d)
        if params is not None:
            out[word] = (params[0] + params[1] + params[2]) * radius
    return out


def dubins_word_path(
    start: Pose, goal: Pose, word: str, radius: float, speed: float
) -> DubinsPath | None:
    """The path of one Dubins ``word`` from ``start`` to ``goal``, or None.

    None when the word does not exist for this pair, or when propagating it
    in closed form does not land on the goal (so a formula slip can never
    return a path that ends elsewhere).

    Raises:
        ValueError: If radius or speed are not positive and finite, or the
            word is not one of the six.
    """
    _check_radius_speed(radius, speed)
    a, b, d = _normalise(start, goal, radius)
    params = _word_params(word, a, b, d)
    if params is None:
        return None
    pose = start
    segments: list[Segment] = []
    for letter, normalised in zip(word, params, strict=True):
        seg = Segment(pose, _LETTER_TURN[letter], radius, speed, normalised * radius / speed)
        segments.append(seg)
        pose = seg.end
    tolerance = 1e-6 * max(radius, d * radius)
    miss = math.hypot(pose.x - goal.x, pose.y - goal.y)
    if miss > tolerance or abs(wrap_angle(pose.heading - goal.heading)) > 1e-6:
        return None
    return DubinsPath(word, (segments[0], segments[1], segments[2]))


def dubins_shortest_path(start: Pose, goal: Pose, radius: float, speed: float) -> DubinsPath:
    """The shortest path of bounded curvature from ``start`` to ``goal`` (Dubins 1957).

    All six words are tried; each candidate is checked by propagating it in
    closed form and must land on the goal, so a formula slip can never return
    a path that ends elsewhere.

    Args:
        start: Initial pose.
        goal: Final pose.
        radius: Minimum turn radius R, metres.
        speed: Forward speed, m/s (sets the segments' durations).

    Returns:
        The shortest of the six candidate words.

    Raises:
        ValueError: If radius or speed are not positive and finite.
    """
    _check_radius_speed(radius, speed)
    best: DubinsPath | None = None
    for word in DUBINS_WORDS:
        candidate = dubins_word_path(start, goal, word, radius, speed)
        if candidate is None:
            continue
        if best is None or candidate.duration < best.duration:
            best = candidate
    if best is None:  # pragma: no cover - some word always exists (Dubins 1957)
        raise ValueError("no Dubins path found")
    return best
