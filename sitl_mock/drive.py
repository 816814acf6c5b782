"""How a rover in AUTO drives a polyline: its speed along the road at any time (pure).

ArduRover's waypoint navigation (``AR_WPNav`` on ``SCurve`` legs) brakes before each
corner and speeds up after it at ``ATC_ACCEL_MAX``, and changes leg at a corner once the
blend of the two legs would pass the corner within ``WP_RADIUS``
(``SCurve::advance_target_along_track``). Each leg's S-curve ends at rest, so the blend is
the old leg braking to a stop while the new one starts from rest, each at ``a``; it
starts ``T`` before the old leg's end, when its midpoint, ``a T² sin(θ/2) / 4`` from the
corner, is ``WP_RADIUS`` (θ the turn). At the midpoint the speed is the least,
``a T cos(θ/2)``: the corner speed ``2 cos(θ/2) sqrt(a WP_RADIUS / sin(θ/2))``, 2.38 m/s
at a 90° corner with the defaults (1 m/s², 2 m). A road drawn as a curve (short legs
each turning a little) is driven within the same acceleration: on a curve of radius ρ
no faster than ``sqrt(a ρ)``, ρ from a vertex's turn and its shorter leg
(``leg / (2 sin(θ/2))``, a circle's chord), and no faster than a leg that short
reaches from rest to rest, as each S-curve leg does. Every change of speed is an
S-curve: the acceleration reached at ``WP_JERK`` (0: the accel's value, 1 m/s³), so a
change of ``dv`` takes ``dv / a + a / j`` (``2 sqrt(dv / j)`` when too small to reach
``a``). ArduRover SITL drove the urban grid's 12-m corners (thinned to legs of 8-15 m)
so: 8 m/s braked at 0.9-1 m/s² to 2.0-2.8 m/s where the curve begins, 3.3-3.4 m/s round
it, sped up at 1 m/s² after, 16 s under 7.5 m/s a corner.

Design rules:
    * The drive is one-dimensional, along the polyline: the blend's cut of the corner
      (under ``WP_RADIUS``) is left out, its speed kept.
    * Each leg drives at its own speed (a mission's DO_CHANGE_SPEED), slower legs braked
      for before they begin; a waypoint with a hold is driven to a stop and stood at.
    * The speed profile is the usual two passes over the corners (no corner faster than
      the next can be braked for, or the last sped up from), then each leg as
      accelerate, cruise, brake; each ramp as the constant acceleration that takes its
      S-curve's time and distance (so a vertex is reached when the firmware reaches
      it), and the profile is a value computed once.
    * A speed told mid-drive (a DO_CHANGE_SPEED command: ``entered`` vertices) starts
      from the speed the rover has there, whatever the plan behind it: higher, it speeds
      up to it after; lower, it brakes to it after (``_leg_down``), evenly at the accel
      where its S-curves have no room before the next corner.
    * ``accel = inf`` is the ideal vehicle of before: corners at full speed, every
      change of speed at once.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

__all__ = ["DriveProfile", "Phase", "Ramps", "corner_speed"]


def corner_speed(turn: float, ramps: Ramps, wp_radius: float, leg: float = math.inf) -> float:
    """The least speed through a corner turning ``turn`` rad whose shorter leg is ``leg``
    metres (the module's rules), m/s."""
    half, accel = abs(turn) / 2.0, ramps.accel
    if half < 1e-9 or math.isinf(accel):
        return math.inf
    blend = 2.0 * math.cos(half) * math.sqrt(accel * wp_radius / math.sin(half))
    curve = math.sqrt(accel * leg / (2.0 * math.sin(half)))
    return min(blend, curve, ramps.peak(0.0, 0.0, leg, math.inf) if leg < math.inf else blend)


@dataclass(frozen=True, slots=True)
class Phase:
    """From ``t0`` at ``s0`` along the road, speed ``v0`` and acceleration ``a``, for ``span`` s."""

    t0: float
    s0: float
    v0: float
    a: float
    span: float

    def at(self, t: float) -> tuple[float, float]:
        """Distance along the road and speed at time ``t`` (inside the phase)."""
        dt = min(max(t - self.t0, 0.0), self.span)
        return self.s0 + self.v0 * dt + 0.5 * self.a * dt * dt, self.v0 + self.a * dt


@dataclass(frozen=True, slots=True)
class DriveProfile:
    """A drive over vertices at ``cumulative`` distances, as the phases it takes.

    ``arrivals[j]`` is when vertex ``j`` is reached (before its hold), ``duration`` the
    whole drive (one lap of a loop, whose last vertex is its first).
    """

    phases: tuple[Phase, ...]
    starts: tuple[float, ...]  # each phase's t0, for bisect
    arrivals: tuple[float, ...]
    duration: float
    length: float
    loop: bool  # a lap, driven again and again

    @classmethod
    def plan(
        cls,
        cumulative: Sequence[float],
        leg_speeds: Sequence[float],
        *,
        corners: Sequence[float],
        holds: Sequence[float],
        ramps: Ramps,
        loop: bool,
        entered: Sequence[int] = (),
    ) -> DriveProfile:
        """The drive over ``len(cumulative)`` vertices.

        Args:
            cumulative: Distance along the road of each vertex, from 0, increasing.
            leg_speeds: Top speed of each leg (vertex ``i`` to ``i + 1``), > 0.
            corners: Least speed through each vertex (``inf``: none); a loop's first
                and last vertex are one corner, the first's value is used.
            holds: Seconds stood at each vertex (0: none).
            ramps: Braking and speeding up.
            loop: The last vertex is the first: a lap, driven again and again, so it
                starts at the closing corner's speed; else from rest, to rest.
            entered: Vertices passed at their corner's speed even above the next leg's
                top (a speed told lower there: braked for after it, not before).
        """
        n = len(cumulative)
        lengths = [b - a for a, b in itertools.pairwise(cumulative)]

        def cap(j: int) -> float:
            node = 0 if loop and j == n - 1 else j  # (a loop's last vertex is its first)
            before = leg_speeds[j - 1] if j else leg_speeds[-1] if loop else 0.0
            after = leg_speeds[j] if j < n - 1 else leg_speeds[0] if loop else 0.0
            if j in entered:
                after = math.inf
            stop = 0.0 if holds[node] > 0.0 else math.inf
            return min(corners[node], before, after, stop)

        caps = [cap(j) for j in range(n)]
        reach = _reachable(caps, lengths, ramps, loop, set(entered))
        phases: list[Phase] = []
        arrivals: list[float] = []
        t = 0.0
        for j in range(n):
            arrivals.append(t)
            if holds[j] > 0.0 and not (loop and j == n - 1):
                phases.append(Phase(t, cumulative[j], 0.0, 0.0, holds[j]))
                t += holds[j]
            if j == n - 1:
                break
            ends = reach[j], reach[j + 1]
            for phase in _leg(cumulative[j], lengths[j], *ends, leg_speeds[j], ramps):
                phases.append(Phase(t, *phase))
                t += phase[3]
        starts = tuple(phase.t0 for phase in phases)
        return cls(tuple(phases), starts, tuple(arrivals), t, cumulative[-1], loop)

    def at(self, t: float) -> tuple[float, float]:
        """Distance along the road and speed at time ``t`` (the start before it; a loop's
        lap again and again, else the end after it)."""
        if t <= 0.0 or not self.phases:
            return 0.0, 0.0
        if self.loop:
            t %= self.duration
        elif t >= self.duration:
            return self.length, 0.0
        i = max(bisect.bisect_right(self.starts, t) - 1, 0)
        return self.phases[i].at(t)

    def time_at(self, arc: float) -> float:
        """When the drive first reaches ``arc`` within its first lap (before standing
        there; the start before it, the end after it)."""
        if arc <= 0.0 or not self.phases:
            return 0.0
        for phase in self.phases:
            reach = phase.v0 * phase.span + 0.5 * phase.a * phase.span**2
            if phase.s0 + reach < arc - 1e-9:
                continue
            gone = max(arc - phase.s0, 0.0)
            if phase.a == 0.0:
                dt = gone / phase.v0 if phase.v0 > 0.0 else 0.0
            else:
                root = max(phase.v0 * phase.v0 + 2.0 * phase.a * gone, 0.0)
                dt = (math.sqrt(root) - phase.v0) / phase.a
            return phase.t0 + min(max(dt, 0.0), phase.span)
        return self.duration

    def hold_began(self, t: float) -> float:
        """When the hold stood at time ``t`` began (a lap's, on a loop); ``t`` itself if
        none is stood then."""
        if t <= 0.0 or not self.phases or (not self.loop and t >= self.duration):
            return t
        lap = math.floor(t / self.duration) * self.duration if self.loop else 0.0
        i = max(bisect.bisect_right(self.starts, t - lap) - 1, 0)
        phase = self.phases[i]
        held = phase.v0 == 0.0 and phase.a == 0.0 and phase.span > 0.0
        return lap + phase.t0 if held else t


@dataclass(frozen=True, slots=True)
class Ramps:
    """How fast the speed changes: ``accel`` (m/s², ``inf``: at once) reached at ``jerk``
    (m/s³; ArduRover's ``WP_JERK``, 0 there meaning the accel's value)."""

    accel: float
    jerk: float

    def time(self, u: float, w: float) -> float:
        """Seconds from speed ``u`` to ``w`` (an S-curve: jerk, accel, jerk)."""
        dv = abs(w - u)
        a, j = self.accel, self.jerk
        return dv / a + a / j if dv >= a * a / j else 2.0 * math.sqrt(dv / j)

    def distance(self, u: float, w: float) -> float:
        """Metres from ``u`` to ``w``: the mean speed (the ramp is symmetric) times its time."""
        return 0.5 * (u + w) * self.time(u, w)

    def fastest(self, u: float, length: float) -> float:
        """The highest speed ``length`` metres can change ``u`` into (and back)."""
        lo, hi = u, u + math.sqrt(2.0 * self.accel * length) + 1.0
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self.distance(u, mid) <= length else (lo, mid)
        return lo

    def peak(self, v_in: float, v_out: float, length: float, top: float) -> float:
        """A leg's top speed: from ``v_in`` up and down to ``v_out`` within ``length``."""
        lo = max(v_in, v_out)
        hi = max(min(top, self.fastest(min(v_in, v_out), length)), lo)
        if self.distance(v_in, hi) + self.distance(hi, v_out) <= length:
            return hi
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            fits = self.distance(v_in, mid) + self.distance(mid, v_out) <= length
            lo, hi = (mid, hi) if fits else (lo, mid)
        return lo


def _reachable(
    cap: list[float], lengths: list[float], ramps: Ramps, loop: bool, entered: set[int]
) -> list[float]:
    """Each vertex's speed: its cap, and no faster than the next can be braked for over
    the leg between, or than the last can be sped up from (two passes; a loop's go
    round twice so a slow corner reaches every other); an ``entered`` one is reached at
    its cap however it was come to (the speed a rover has when told a speed there)."""
    if math.isinf(ramps.accel):
        return cap
    n = len(cap)
    v = list(cap)
    rounds = 2 if loop else 1
    for _ in range(rounds):
        for j in range(1, n):
            if j not in entered:
                v[j] = min(v[j], ramps.fastest(v[j - 1], lengths[j - 1]))
        if loop:
            v[0] = v[-1] = min(v[0], v[-1])
    for _ in range(rounds):
        for j in range(n - 2, -1, -1):
            v[j] = min(v[j], ramps.fastest(v[j + 1], lengths[j]))
        if loop:
            v[0] = v[-1] = min(v[0], v[-1])
    # Entered at its speed then, it brakes at the accel from there: to the next vertex's
    # speed if it can, else as near it as it can (braked on after it: ``_leg_down``).
    # On a loop the lap's last vertex is its first: braking on past it goes on into the
    # next lap (else the next lap would start at a speed the rover never slowed to).
    two_a = 2.0 * ramps.accel
    for k in sorted(entered):
        v[k], j = cap[k], k
        for _ in range(n):
            if j + 1 == n and loop:
                j = 0
                if v[0] >= v[-1]:
                    break
                v[0] = v[-1]
            if j + 1 >= n or v[j] ** 2 <= v[j + 1] ** 2 + two_a * lengths[j] + 1e-9:
                break
            v[j + 1] = math.sqrt(v[j] ** 2 - two_a * lengths[j])
            j += 1
    return v


def _leg(
    s0: float, length: float, v_in: float, v_out: float, top: float, ramps: Ramps
) -> list[tuple[float, float, float, float]]:
    """One leg as (s0, v0, a, span) phases: speed up to the top, cruise, brake; each
    ramp at the constant acceleration that takes its S-curve's time and distance."""
    if math.isinf(ramps.accel):
        return [(s0, top, 0.0, length / top)] if length > 0.0 else []
    if v_in > top + 1e-9 and length > 1e-6:  # (entered above its top: a speed told lower)
        return _leg_down(s0, length, v_in, v_out, top, ramps)
    peak = ramps.peak(v_in, v_out, length, top)
    up, down = ramps.distance(v_in, peak), ramps.distance(peak, v_out)
    if peak == v_in > v_out and down > length > 1e-6:  # (no room for its S-curve: told)
        return _leg_down(s0, length, v_in, v_out, v_in, ramps)
    cruise = max(length - up - down, 0.0)
    out: list[tuple[float, float, float, float]] = []
    if peak > v_in:
        span = ramps.time(v_in, peak)
        out.append((s0, v_in, (peak - v_in) / span, span))
    if cruise > 0.0:
        out.append((s0 + up, peak, 0.0, cruise / peak if peak > 0.0 else 0.0))
    if peak > v_out:
        span = ramps.time(peak, v_out)
        out.append((s0 + up + cruise, peak, (v_out - peak) / span, span))
    return out


def _leg_down(
    s0: float, length: float, v_in: float, v_out: float, top: float, ramps: Ramps
) -> list[tuple[float, float, float, float]]:
    """A leg entered above its top speed: brake to the top, cruise, brake to the end's
    speed; too short for both ramps, one even braking the whole leg (no harder than the
    accel: the speed at its start can be braked to its end's over it)."""
    first, last = ramps.distance(v_in, top), ramps.distance(top, v_out)
    if first + last > length:
        a = (v_out * v_out - v_in * v_in) / (2.0 * length)
        return [(s0, v_in, a, (v_out - v_in) / a if a < 0.0 else length / v_in)]
    span = ramps.time(v_in, top)
    out = [(s0, v_in, (top - v_in) / span, span)]
    cruise = length - first - last
    if cruise > 0.0:
        out.append((s0 + first, top, 0.0, cruise / top))
    if top > v_out:
        span = ramps.time(top, v_out)
        out.append((s0 + first + cruise, top, (v_out - top) / span, span))
    return out
