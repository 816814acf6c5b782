"""Setpoints on mission-time deadlines: one task for the whole fleet.

Latest-value streaming (STYLE principle 4): at every deadline ``k / rate_hz``
of mission time the streamer asks the source for each flying (or setting-up)
vehicle's setpoint *now* and sends it. Nothing is queued: a late loop skips the
deadlines it missed (counted in ``missed``) and carries on from the next one, so
an overloaded machine sends fresher setpoints less often, never a burst of
stale ones. One task for all vehicles keeps the cost per setpoint at one
function call (no per-vehicle task wake-ups).

A simulator run faster than real time is not fed faster than it can use: the
rate is halved while a vehicle would get more than ``max_wall_hz`` setpoints per
wall second (doubled back, up to ``rate_hz``, once it fits with room to spare),
never below ``MIN_RATE_HZ`` of mission time. At 100x, 20 Hz of mission time is
2,000 setpoints a wall second for each UAV: encoding them (the service) and
decoding them (the simulator) takes the CPU the planner and the physics need.
A real autopilot (1x) gets ``rate_hz`` unchanged, and so does a simulator up to
50x. Not lower: ArduPlane's adapter switches its loiters on setpoint ticks, and
flew 2-3 m farther off its path at 10 Hz than at 20.

A big fleet is not sent in one burst: its round is cut into slices of
``slice_size`` vehicles spread evenly over the period (at most ``max_slices``),
each sampled at its own instant. A thousand sends in a row would hold the event
loop for tens of milliseconds while the telemetry piles up behind them, and the
next round would start late by however long that pile takes to drain: slices
keep both bursts short, so every vehicle's own deadline is met. (It also spares
a shared radio or MAVLink router a thousand-packet burst.) A fleet of up to
``slice_size`` vehicles is one slice: the whole round at its deadline.

A host too slow for the speedup shows as rounds far apart in mission time:
``take_widest_gap`` returns the widest gap between two rounds since it was last
called, so the service can say so (PX4 leaves OFFBOARD after ``COM_OF_LOSS_T``,
1 s by default, without a setpoint) before an autopilot's failsafe does.

``stats`` keeps, per vehicle, the intervals between consecutive sends in wall
and in mission seconds (count, mean, max and the last few thousand samples for
percentiles): the benchmark's setpoint-rate accuracy and jitter.
"""

from __future__ import annotations

import logging
import math
import time
from array import array
from collections.abc import Callable, Iterable
from typing import Protocol

from convoy_mav.clock import MissionClock, Reading
from convoy_mav.types import Setpoint, VehicleStatus

__all__ = [
    "MAX_WALL_HZ",
    "MIN_RATE_HZ",
    "IntervalStats",
    "SendStats",
    "SetpointStreamer",
    "StreamTarget",
    "percentile",
]

log = logging.getLogger(__name__)

_STREAMING = (VehicleStatus.FLYING, VehicleStatus.SETTING_UP)

MIN_RATE_HZ = 5.0
"""Setpoints per mission second the rate is never halved below: five within PX4's
default offboard loss window (``COM_OF_LOSS_T`` 1 s)."""

MAX_WALL_HZ = 1000.0
"""Setpoints per wall second per vehicle above which the rate is halved."""

_ROOM = 0.75  # the rate is doubled back only if it then fits in this share of the cap


class StreamTarget(Protocol):
    """What the streamer needs of a vehicle (``convoy_mav.vehicle.Vehicle`` is one)."""

    @property
    def uid(self) -> int:
        """The UAV's id in the service (the source is asked by it; its MAVLink sysid)."""
        ...

    @property
    def status(self) -> VehicleStatus:
        """Only FLYING and SETTING_UP vehicles are sent setpoints."""
        ...

    @property
    def setpoint_lead(self) -> float:
        """Mission seconds its setpoints take to be flown: each is sampled that far
        ahead, for the instant it takes effect (``roundtrip``)."""
        ...

    def send_setpoint(self, sp: Setpoint) -> None:
        """Send one setpoint now (never blocks)."""
        ...


def percentile(values: Iterable[float], q: float) -> float:
    """The ``q``-th percentile (0..100), interpolated linearly (NaN if no values)."""
    data = sorted(values)
    if not data:
        return math.nan
    pos = min(max(q, 0.0), 100.0) / 100.0 * (len(data) - 1)
    lo = math.floor(pos)
    hi = min(lo + 1, len(data) - 1)
    return data[lo] + (data[hi] - data[lo]) * (pos - lo)


class IntervalStats:
    """Running statistics of intervals plus a ring of the most recent samples.

    Args:
        keep: How many recent samples to keep for percentiles.
    """

    __slots__ = ("_i", "_ring", "count", "keep", "max", "total")

    def __init__(self, keep: int = 2048) -> None:
        self.keep = keep
        self.count = 0
        self.total = 0.0
        self.max = 0.0
        self._ring = array("d")
        self._i = 0

    def add(self, x: float) -> None:
        """One interval (seconds)."""
        self.count += 1
        self.total += x
        self.max = max(self.max, x)
        if len(self._ring) < self.keep:
            self._ring.append(x)
        else:
            self._ring[self._i] = x
            self._i = (self._i + 1) % self.keep

    @property
    def mean(self) -> float:
        """Mean of all intervals (NaN if none)."""
        return self.total / self.count if self.count else math.nan

    def samples(self) -> list[float]:
        """The kept recent samples (unordered)."""
        return list(self._ring)

    def percentile(self, q: float) -> float:
        """The ``q``-th percentile (0..100) of the kept samples (NaN if none)."""
        return percentile(self._ring, q)


class SendStats:
    """Per-vehicle send statistics: count and inter-send intervals (wall and mission)."""

    __slots__ = ("count", "last_mission", "last_wall", "mission", "wall")

    def __init__(self, keep: int = 2048) -> None:
        self.count = 0
        self.last_wall = math.nan
        self.last_mission = math.nan
        self.wall = IntervalStats(keep)
        self.mission = IntervalStats(keep)

    def record(self, wall: float, mission: float) -> None:
        """A setpoint was sent at these times."""
        if self.count:
            self.wall.add(wall - self.last_wall)
            self.mission.add(mission - self.last_mission)
        self.count += 1
        self.last_wall = wall
        self.last_mission = mission


class SetpointStreamer:
    """Sends every streaming vehicle its latest setpoint at ``rate_hz`` of mission time.

    Args:
        vehicles: The vehicles, re-iterated at every round (pass a live view such
            as ``dict.values()`` to add vehicles while running).
        source: ``source(uid, t)`` -> the setpoint for mission time ``t`` (now plus
            the vehicle's ``setpoint_lead``), or None for nothing this round. An
            exception is logged and counted; the other vehicles still get theirs.
        clock: The mission clock.
        rate_hz: Setpoints per mission second per vehicle (at most: see ``max_wall_hz``).
        max_wall_hz: At a speedup that would send a vehicle more than this per
            wall second, the rate is halved (not below ``MIN_RATE_HZ``, nor
            below ``rate_hz`` if that is lower). None: never.
        slice_size: Vehicles per slice of a round (bigger fleets are staggered).
        max_slices: At most this many slices per period.
        wall: Wall clock for the statistics (injected for tests).

    Attributes:
        ticks: Rounds (deadlines) served.
        missed: Rounds skipped because the loop was late.
        widest_gap_s: Widest mission-time gap between two rounds over the whole run.
        rate: Setpoints per mission second now (``rate_hz``, or it halved).
        errors: Source calls that raised.
        stats: Per-uid :class:`SendStats`.
    """

    def __init__(
        self,
        vehicles: Iterable[StreamTarget],
        source: Callable[[int, float], Setpoint | None],
        clock: MissionClock,
        rate_hz: float = 20.0,
        *,
        max_wall_hz: float | None = MAX_WALL_HZ,
        slice_size: int = 50,
        max_slices: int = 20,
        wall: Callable[[], float] = time.monotonic,
    ) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0.0):
            raise ValueError(f"rate_hz must be finite and > 0, got {rate_hz!r}")
        if slice_size < 1 or max_slices < 1:
            raise ValueError(
                f"slice_size and max_slices must be >= 1, got {slice_size}, {max_slices}"
            )
        self.vehicles = vehicles
        self.source = source
        self.clock = clock
        if max_wall_hz is not None and not (math.isfinite(max_wall_hz) and max_wall_hz > 0.0):
            raise ValueError(f"max_wall_hz must be finite and > 0, got {max_wall_hz!r}")
        self.rate_hz = self.rate = rate_hz
        self.max_wall_hz = max_wall_hz
        self.slice_size = slice_size
        self.max_slices = max_slices
        self._wall = wall
        self._rank: dict[int, int] = {}  # uid -> order first seen: its slice is rank % slices
        self.ticks = 0
        self.missed = 0
        self.errors = 0
        self.widest_gap_s = 0.0
        self._recent_gap_s = 0.0  # widest since ``take_widest_gap``
        self._last_round: Reading | None = None
        self.stats: dict[int, SendStats] = {}

    async def run(self) -> None:
        """Stream until cancelled (waits for the first vehicle to set mission time)."""
        clock = self.clock
        await clock.wait_synced()
        self._set_rate(self.rate_for(clock.rate))
        period = self.period
        k = math.floor(clock.now() / period) + 1  # deadlines are whole multiples of period
        while True:
            await clock.sleep_until(k * period)
            rate = self.rate_for(clock.rate)
            if rate != self.rate:  # the speedup changed: deadlines of the new period
                self._set_rate(rate)
                period = self.period
                k = math.floor(clock.now() / period) + 1
                continue
            due = math.floor(clock.now() / period + 1e-9)
            if due < k:  # woken early: the autopilots' clock stepped back; re-anchor
                k = due + 1
                continue
            late = due - k
            if late > 0:  # missed deadlines are skipped, not sent in a burst
                self.missed += late
                k += late
            self.ticks += 1
            self._gap_to(clock.reading())
            k = await self._round(k) + 1

    def _gap_to(self, now: Reading) -> None:
        """Count the gap from the last round to one ``now``, unless the mission clock
        stepped or stood between them (``Reading.since``: a simulator that paused, a
        fleet heard again after a silence), which is no lateness of ours."""
        gap = now.since(self._last_round)
        self._last_round = now
        if gap > 0.0:
            self.widest_gap_s = max(self.widest_gap_s, gap)
            self._recent_gap_s = max(self._recent_gap_s, gap)

    def take_widest_gap(self) -> float:
        """The widest mission-time gap between two rounds since the last call (0 if none)."""
        gap, self._recent_gap_s = self._recent_gap_s, 0.0
        return gap

    def rate_for(self, speedup: float) -> float:
        """Setpoints per mission second at ``speedup`` (mission per wall second).

        Starts from the rate in force and halves or doubles it (exact in
        floating point), so a speedup near a threshold does not flip the rate
        round after round.
        """
        cap = self.max_wall_hz
        rate = self.rate
        if cap is None or not (math.isfinite(speedup) and speedup > 0.0):
            return rate
        floor = min(MIN_RATE_HZ, self.rate_hz)
        while rate * speedup > cap and rate / 2.0 >= floor - 1e-9:
            rate /= 2.0
        while rate * 2.0 <= self.rate_hz + 1e-9 and rate * 2.0 * speedup <= _ROOM * cap:
            rate *= 2.0
        return rate

    def _set_rate(self, rate: float) -> None:
        if rate != self.rate:
            log.info(
                "setpoints at %g Hz of mission time (%g configured): %.3g x speedup",
                rate,
                self.rate_hz,
                self.clock.rate,
            )
        self.rate = rate

    @property
    def period(self) -> float:
        """Mission seconds between rounds now."""
        return 1.0 / self.rate

    async def _round(self, k: int) -> int:
        """Send round ``k`` slice by slice; returns the round to continue from."""
        clock = self.clock
        slices = self.slices()
        step = self.period / len(slices)
        for i, group in enumerate(slices):
            if i:
                deadline = k * self.period + i * step
                await clock.sleep_until(deadline)
                if clock.now() < deadline - step:  # the clock stepped back: re-anchor
                    return math.floor(clock.now() / self.period)
            self.send(group)  # a late slice is sent at once: still one setpoint per round
        return k

    def slices(self) -> list[list[StreamTarget]]:
        """This round's vehicles cut into slices (rank order, one slice per offset).

        Vehicle ``i`` (in the order first seen) is in slice ``i % len(slices)``,
        so each keeps its offset in the period while the fleet size is steady.
        """
        vehicles = list(self.vehicles)
        rank = self._rank
        count = min(self.max_slices, max(1, -(-len(vehicles) // self.slice_size)))
        slices: list[list[StreamTarget]] = [[] for _ in range(count)]
        for vehicle in vehicles:
            r = rank.get(vehicle.uid)
            if r is None:
                r = rank[vehicle.uid] = len(rank)
            slices[r % count].append(vehicle)
        return slices

    def send(self, vehicles: Iterable[StreamTarget]) -> int:
        """Send each streaming vehicle of ``vehicles`` its setpoint for now; returns sends."""
        t = self.clock.now()
        wall = self._wall()
        sent = 0
        for vehicle in vehicles:
            if vehicle.status not in _STREAMING:
                continue
            uid = vehicle.uid
            try:
                sp = self.source(uid, t + vehicle.setpoint_lead)
            except Exception:
                self.errors += 1
                if self.errors == 1:
                    log.exception("setpoint source failed for UAV %d at t=%.2f", uid, t)
                continue
            if sp is None:
                continue
            vehicle.send_setpoint(sp)
            stats = self.stats.get(uid)
            if stats is None:
                stats = self.stats[uid] = SendStats()
            stats.record(wall, t)
            sent += 1
        return sent
