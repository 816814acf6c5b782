"""A convoy's following vehicles drive where their leader drove, a time gap behind it.

A follower given its leader's road with a time lag (``ground.Lagged``) drives that road
whatever the leader does: held, told a speed, or sent a mission its operator changed,
the leader goes one way and the followers the other, and the convoy parts. A real
convoy's drivers follow the vehicle ahead. So the leader's driven path is recorded as
it goes (:class:`Trail`: its positions, their arc length and when it was there), and
each follower (:class:`Follower`) drives that path as drivers keep their distance: where
the leader was ``lag`` seconds ago (a time gap: the two-second rule), but never nearer
to it than a standstill distance, speeding up and braking within its accel. So on the
leader's own road it drives exactly what the lagged road drove; where the leader stops,
it stops behind it. A follower that leaves the convoy (sent home by its own operator)
hands those behind it on to its own leader's path (:meth:`Trail.hand_over`): they keep
their place in the column, as the drivers behind a truck that turns off follow the one
ahead of it. Pure: the mock steps both.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

__all__ = ["Follower", "Handover", "Trail"]

_MOVED = 1e-3  # m: a sample nearer than this to the last adds nothing
_KEEP_MARGIN_S = 30.0  # s of trail kept past the longest lag behind it
_GAIN_SHARE = 0.9  # of the accel a follower's closing speed falls at, as it closes


@dataclass(frozen=True, slots=True)
class Handover:
    """A follower left its leader's path where its own trail's arc was ``at`` and its arc
    on its leader's ``onto`` was ``onto_at``, ``lag`` s behind it: the vehicles behind it
    follow ``onto`` from there (an arc ``x`` of the trail left is ``x - at + onto_at``
    of ``onto``: the same road up to there), ``lag`` s further behind."""

    onto: Trail
    at: float
    onto_at: float
    lag: float


@dataclass(slots=True)
class Trail:
    """The path a vehicle drove: samples (north, east) with their arc length ``s`` and
    sim time ``t``. A vehicle standing adds none: it was where it last moved to."""

    keep_s: float = 0.0  # s of path kept behind the newest sample (its followers' lags)
    # Its followers: none of the path behind the rearmost of them is dropped (one held
    # or stalled falls ever further behind, and stays where it is on it).
    readers: list[Follower] = field(default_factory=list)
    handed_over: Handover | None = None  # (its vehicle left the column: see hand_over)
    _t: list[float] = field(default_factory=list)
    _s: list[float] = field(default_factory=list)
    _n: list[float] = field(default_factory=list)
    _e: list[float] = field(default_factory=list)

    @property
    def started(self) -> bool:
        """True once it has a sample."""
        return bool(self._s)

    @property
    def s(self) -> float:
        """Arc length driven so far (0 before any sample)."""
        return self._s[-1] if self._s else 0.0

    def record(self, t: float, north: float, east: float) -> None:
        """The vehicle is at (north, east) at sim time ``t`` (never earlier than before)."""
        if self._s:
            step = math.hypot(north - self._n[-1], east - self._e[-1])
            if step < _MOVED:
                return
            s = self._s[-1] + step
        else:
            s = 0.0
        self._t.append(t)
        self._s.append(s)
        self._n.append(north)
        self._e.append(east)
        cut = bisect.bisect_left(self._t, t - self.keep_s - _KEEP_MARGIN_S) - 1
        if self.readers:
            rearmost = min(r.s for r in self.readers)
            cut = min(cut, bisect.bisect_right(self._s, rearmost) - 2)
        if cut > 1024:  # (pruned in batches: one list copy per thousand samples)
            del self._t[:cut], self._s[:cut], self._n[:cut], self._e[:cut]

    def hand_over(self, onto: Trail, onto_at: float, lag: float) -> None:
        """Its vehicle leaves the column where it last recorded, ``onto_at`` along its
        leader's path ``onto`` then, ``lag`` s behind that leader: its followers follow
        ``onto`` from now."""
        self.handed_over = Handover(onto, self.s, onto_at, lag)
        onto.keep_s = max(onto.keep_s, self.keep_s + lag)

    def s_at(self, t: float) -> float:
        """Arc length it had driven at sim time ``t`` (0 before its first sample)."""
        i = bisect.bisect_right(self._t, t) - 1
        if i < 0:
            return self._s[0] if self._s else 0.0
        if i == len(self._t) - 1:
            return self._s[i]
        f = (t - self._t[i]) / (self._t[i + 1] - self._t[i])
        return self._s[i] + f * (self._s[i + 1] - self._s[i])

    def at(self, s: float) -> tuple[float, float, float, float]:
        """(north, east) at arc length ``s`` (clamped to the path), and the unit tangent
        (tn, te) there ((0, 0) on a path with no length yet)."""
        if not self._s:
            raise ValueError("an empty trail has no points")
        ss = self._s
        if len(ss) == 1:
            return self._n[0], self._e[0], 0.0, 0.0
        s = min(max(s, ss[0]), ss[-1])
        i = min(max(bisect.bisect_right(ss, s) - 1, 0), len(ss) - 2)
        length = ss[i + 1] - ss[i]
        f = (s - ss[i]) / length
        dn, de = self._n[i + 1] - self._n[i], self._e[i + 1] - self._e[i]
        return self._n[i] + f * dn, self._e[i] + f * de, dn / length, de / length


@dataclass(slots=True)
class Follower:
    """A vehicle driving ``trail`` ``lag`` seconds behind its leader, never nearer than
    ``standstill`` metres of path to it.

    Args:
        trail: The leader's.
        lag: Seconds behind it (> 0).
        standstill: Metres of path it stops short of the leader.
        accel: m/s² it speeds up and brakes at (it never runs past its target, though).
        catch_up: m/s it drives at most above the leader's speed then, closing on it
            (after it stood while the leader drove on).
    """

    trail: Trail
    lag: float
    standstill: float = 5.0
    accel: float = 1.0
    catch_up: float = 3.0
    s: float = 0.0  # arc length along the trail where it is (it waits at its start)
    v: float = 0.0  # its speed
    _target: float = 0.0  # where the leader was its lag before its last step
    _lead: float = 0.0  # and the leader's speed, then

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lag) and self.lag > 0.0):
            raise ValueError(f"lag must be finite and > 0, got {self.lag!r}")
        self.trail.keep_s = max(self.trail.keep_s, self.lag)
        self.trail.readers.append(self)

    def step(self, t: float, dt: float, driving: bool) -> None:
        """On to sim time ``t``, ``dt`` s after its last step: it drives (armed in its
        mission mode) or brakes to a stand."""
        self._rejoin(t - dt)
        trail = self.trail
        short = trail.s - self.standstill  # (the nearest it comes to the leader)
        lagged = trail.s_at(t - self.lag)
        target = max(min(lagged, short), 0.0)
        lead = max(lagged - self._target, 0.0) / dt  # (the leader's speed, then)
        swing = lead - self._lead  # (and its change of speed)
        self._target, self._lead = lagged, lead
        wanted, room = 0.0, math.inf
        if driving:  # (there, but no faster than it can brake short of the leader,
            # were the leader to brake as hard: the room, and the leader's speed now)
            ahead = (trail.s - trail.s_at(t - dt)) / dt
            room = math.sqrt(2.0 * self.accel * max(short - self.s, 0.0) + ahead * ahead)
            # (the gap's error closed no faster than it can brake out of closing it)
            err = max(target - self.s, 0.0)
            gain = _GAIN_SHARE * self.accel / self.catch_up
            closing = min(math.sqrt(2.0 * self.accel * err), gain * err)
            wanted = lead + min(closing, self.catch_up)
        # (it drives the leader's changes of speed as the leader drove them, and its own
        # within its accel: standing while the leader drove on, it pulls away at it)
        was = self.v + swing if driving else self.v
        v = max(min(max(wanted, was - self.accel * dt), was + self.accel * dt, room), 0.0)
        s = self.s + v * dt
        if s > target:  # (never past where it is to be: the leader stopped short)
            s = max(target, self.s)
            v = (s - self.s) / dt
        self.s, self.v = s, v

    def leave(self, own: Trail | None) -> None:
        """Its vehicle leaves the column where it is: it holds its leader's path back no
        more, and the vehicles behind it (on ``own``, its vehicle's path) follow its
        leader on (``Trail.hand_over``)."""
        self.trail.readers.remove(self)
        if own is not None:
            own.hand_over(self.trail, self.s, self.lag)

    def _rejoin(self, before: float) -> None:
        """The vehicle it follows left the column: it follows that one's leader, where
        it is on the same road, its lag the two lags (its place in the column kept), and
        where that leader was its lag before its last step (``before``) its last target."""
        while (h := self.trail.handed_over) is not None:
            self.trail.readers.remove(self)
            self.trail, self.lag = h.onto, self.lag + h.lag
            self.trail.readers.append(self)
            self.s = max(self.s + h.onto_at - h.at, 0.0)
            self._target = self.trail.s_at(before - self.lag)

    def state(self, ahead: float = 0.0) -> tuple[float, float, float, float]:
        """(north, east, vn, ve) where it is, or ``ahead`` s after its last step at its
        speed (the mock steps it at 10 Hz, and reports it between)."""
        n, e, tn, te = self.trail.at(self.s + self.v * ahead)
        return n, e, self.v * tn, self.v * te
