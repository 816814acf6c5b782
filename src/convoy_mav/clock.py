"""Mission time, estimated from the autopilots' own clocks.

Mission time is the autopilots' clock, not the wall clock: under ``sitl_mock``
(or a SITL run faster than real time) it runs ``speedup`` times faster than
``time.monotonic``, and nothing in the service may assume otherwise. Every
MAVLink message carrying ``time_boot_ms`` is one observation (wall time of
arrival, vehicle boot time); from them :class:`MissionClock` fits

    mission = m_a + rate * (wall - w_a)

and answers ``now()``, ``rate`` (mission seconds per wall second) and
``sleep_until(t)``, which converts a mission deadline to a wall delay.

Design rules:
    * Mission time is the boot time of the *reference* vehicle (the first one
      heard). Each vehicle's boot time is first *unwrapped* (a reboot, seen as
      ``time_boot_ms`` jumping back, re-anchors that vehicle so its unwrapped
      time continues where it was) and every other vehicle is mapped onto mission
      time with an offset: its clock less the reference's, compared in 0.1-s wall
      bins at each one's soonest packet, median over the last 10 s of bins (one-sided
      delays and simulator pauses cancel; see ``_bin``).
    * The fit is a least-squares line over a sliding window of the reference's
      observations (sub-sampled in wall time so its cost does not grow with the
      message rate), with outliers beyond 4 MADs dropped and the line refitted.
      Arrival jitter is one-sided (late packets), so the fitted line trails the
      autopilot by ``rate`` x the mean one-way delay: ~1 ms x speedup on loopback.
    * Until the window spans ``min_span`` wall seconds the slope is not trusted:
      ``rate_hint`` (or 1.0, or the last good rate) extrapolates the newest observation.
    * If the reference goes silent for ``handover_after`` mission seconds, the
      vehicle heard most recently becomes the reference, at its current offset,
      so mission time stays continuous when the reference UAV is lost.
    * If *every* vehicle goes silent that long (a paused simulator or host, whose
      clocks stood still; a ground radio down, whose clocks ran on), nothing said
      how mission time went meanwhile. If the reference speaks first, its step is
      followed as above; if another vehicle with a continuous clock (not one just
      rebooted) does, it *resyncs* mission time. It becomes the
      reference at the offset measured before the silence (offsets between
      autopilot clocks do not change while nobody listens), every stored sample
      is dropped (they straddle the silence), and the line restarts from its
      newest observation at the last measured rate. ``now()`` follows, backwards
      if the clocks stood still, and ``steps`` counts it (``sleep_until`` callers
      re-plan); ``resyncs`` counts these.
    * While nobody is heard, ``now()`` runs on for ``silence_cap`` mission seconds
      (long enough for the liveness checks to declare the vehicles lost) and then
      waits: past that, it would only be a guess, and every deadline taken from a
      guess (a mission's end, a command's time-out) would be off by the whole
      silence once the clocks are heard again. So a paused fleet costs a step back
      of at most ``silence_cap``, and a radio dropout a step forward.
      That step forward is no lateness of the service's, and is counted in
      ``silences`` when the service's loop saw the clock stand (it asked for
      ``now()`` within ``_SILENCE_SEEN`` wall seconds before the fleet was heard
      again). A loop held up by its host asks nothing meanwhile and then reads
      the packets that queued as if the fleet had just spoken: that is not
      counted, and the mission time it lost shows as the service's own.
    * The autopilot's clock may *step*: a simulator that cannot keep up pauses
      (PX4 lockstep SITL, ``sitl_mock`` slipping its clock when its host stalls),
      and then runs on from where it was. Late packets look the same one at a
      time, so a step is confirmed only when ``_STEP_CONFIRM`` consecutive packets
      of the reference, spread over ``_STEP_SPAN`` wall seconds (a stalled loop
      reads its backlog in one instant), all sit off the line by more than
      ``_step_threshold`` in the same direction and agree with each other (a
      congested queue makes delays that vary). The line is then rebuilt from
      those packets at the last measured rate, and ``steps`` counts it.
    * The autopilot's clock may change its *rate*: a simulator's speedup set
      anew in flight (ArduPilot SITL's ``SIM_SPEEDUP``, ``sitl_mock``'s too).
      The sliding fit alone takes its whole window to turn (8 wall s, mission
      time up to 28 s ahead when 40x became 20x: the new packets are its
      outliers). So a run of the reference's packets off the line one way,
      whose residuals do not agree (not a step) but lie on a line of their own
      in wall time, spread over ``_RATE_SPAN`` wall s and turning the rate by
      ``_RATE_CHANGE`` of itself or more, is a rate change: the line is rebuilt
      from those packets at their own slope, ``steps`` counts it (mission time
      moves back or on by what ran off meanwhile: a few seconds at 40x) and
      ``rate_changes`` too. A queue filling or draining is as steady for a
      moment only; it has to hold that long to be taken for one. On a loaded
      host the packets' delays scatter more than that line allows, so the
      simulator's own word is taken first: its PARAM_VALUE of ``SIM_SPEEDUP``,
      sent when it sets it (``rate_set``), restarts the line at the new rate from
      the reference's newest packet, at once.
    * One vehicle's clock never moves mission time by more than a bounded step.
      Once the rate is measured, a ``time_boot_ms`` further ahead of that
      vehicle's last one than its clock can have run (twice the rate over the
      wall time between them, plus the jitter allowance ``_AHEAD_SLACK_*``) is
      *rejected* (``observe`` says so; the caller drops the frame) and counted
      in ``rejected``: one spoofed or corrupt stamp cannot throw the mission
      clock ahead. A clock that really jumped ahead persists: after
      ``_REBOOT_CONFIRM`` agreeing packets in a row it is re-anchored like a
      reboot (its unwrapped time continues), so mission time does not jump.
    * ``now()`` never goes backwards once synchronised, except at a confirmed
      step, where it follows the autopilot (``sleep_until`` returns early so
      deadline loops re-plan). Before any observation it is 0.0 and
      ``sleep_until`` waits for the first one.
"""

from __future__ import annotations

import asyncio
import math
import statistics
import time
from collections import deque
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from enum import IntEnum

from convoy_mav import eventloop

__all__ = ["MissionClock", "Observed", "Reading"]

_REBOOT_JUMP = 1.0
"""s: a ``time_boot_ms`` this much behind the last one is a reboot, not reordering."""
_MIN_FIT_SAMPLES = 5
_DENSE_SAMPLES = 32
"""Observations kept before sub-sampling starts: a fresh clock fits its rate fast."""
_OUTLIER_MADS = 4.0
_TRIM_PASSES = 4
_RESIDUAL_FLOOR = 0.005
"""s of mission time: residuals below this are never outliers (``time_boot_ms`` is in ms)."""
_REBOOT_CONFIRM = 5
"""Consecutive packets on a new, earlier timeline that make a reboot."""
_OFFSET_REFRESH = 1.0
"""Wall s between recomputations of a vehicle's offset to the reference."""
_OFFSET_BIN = 0.1
"""Wall s of one bin of the offset estimate (each vehicle's soonest packet in it)."""
_OFFSET_BINS = 100
"""Bins kept per vehicle (10 wall s): a median over them outlasts a host's stalls."""
_REFIT_INTERVAL = 0.1
"""Wall s between refits once the rate is trusted (the fit costs ~0.2 ms)."""
_STEP_CONFIRM = 8
"""Consecutive packets of the reference off the line that confirm a clock step."""
_STEP_SPAN = 0.02
"""Wall s those packets must spread over: a backlog read in one go is not a step."""
_RATE_SPAN = 0.25
"""Wall s a run off the line must spread over to be taken for a change of rate."""
_RATE_CHANGE = 0.1
"""Smallest change of rate, as a fraction of it, taken at once (the fit follows less)."""
_RUN_KEPT = 256
"""Packets off the line kept (the newest): a long run is judged on its recent part."""
_STEP_FLOOR = 0.1
"""Mission s: the smallest step followed (the threshold grows with the rate)."""
_STEP_WALL = 0.01
"""Wall s of arrival delay, times the rate, that is still jitter rather than a step."""
_MAX_SLEEP_CHUNK = 0.25
"""Wall s: ``sleep_until`` re-reads the estimate at least this often."""
_GUESS_SLEEP_CHUNK = 0.01
"""Wall s: the same while the rate is not measured yet."""
_AHEAD_SLACK_S = 2.0
"""Mission s a stamp may run ahead of its clock's bound (``time_boot_ms`` rounding, resets)."""
_AHEAD_SLACK_WALL = 0.5
"""Wall s of arrival jitter, times the rate, a stamp may run ahead (late packet, prompt one)."""
_SILENCE_SEEN = 1.0
"""Wall s: the fleet heard again this soon after the loop saw the clock stand was silent
(a loop that asks every ``_MAX_SLEEP_CHUNK`` saw it; a stalled one did not ask)."""


class Observed(IntEnum):
    """What one ``time_boot_ms`` observation was (falsy: nothing to act on)."""

    ACCEPTED = 0
    REBOOTED = 1  # confirmed a reboot: the vehicle's clock restarted
    REJECTED = 2  # ahead of anything its clock can have run: drop the frame


@dataclass(frozen=True, slots=True)
class Reading:
    """Mission time read off the clock, with its ``breaks`` count then."""

    t: float
    breaks: int

    def since(self, before: Reading | None) -> float:
        """Mission seconds from ``before`` to this reading that were the reader's own:
        none across a break (a step followed, a silence heard out: the clock moved,
        not the reader), nor with no reading before."""
        if before is None or before.breaks != self.breaks:
            return 0.0
        return max(self.t - before.t, 0.0)


@dataclass(frozen=True, slots=True)
class _Timeline:
    """A new timeline a vehicle's stamps may have moved to (a reboot back, a jump
    ahead): taken only once ``_REBOOT_CONFIRM`` stamps in a row agree with it."""

    boot: float  # the last agreeing stamp
    wall: float  # when it came
    count: int = 1

    def then(self, boot: float, wall: float, limit: float) -> _Timeline:
        """This timeline after one more stamp: one more agreeing, or a new candidate."""
        if self.boot - _REBOOT_JUMP <= boot <= self.boot + limit:
            return _Timeline(boot, wall, self.count + 1)
        return _Timeline(boot, wall)

    @property
    def confirmed(self) -> bool:
        return self.count >= _REBOOT_CONFIRM


@dataclass(slots=True)
class _Track:
    """One vehicle's boot clock as seen from here."""

    epoch: float = 0.0  # unwrapped = boot + epoch (grows at each reboot)
    last_boot: float = -math.inf
    last_wall: float = -math.inf
    last_stored: float = -math.inf
    # Stored observations as two parallel columns of plain floats, not a deque of
    # pairs: a thousand vehicles keep a few hundred thousand of them, and pairs
    # would each be an object for the garbage collector to walk.
    walls: deque[float] = field(default_factory=deque)
    times: deque[float] = field(default_factory=deque)  # unwrapped, at those walls
    # Per wall bin of _OFFSET_BIN: its index and the soonest packet's unwrapped time
    # less the rate times its wall time into the bin (the clock at the bin's start).
    bins: deque[int] = field(default_factory=deque)
    bin_times: deque[float] = field(default_factory=deque)
    offset: float = 0.0  # mission = unwrapped + offset
    offset_wall: float = -math.inf  # wall time the offset was last computed
    behind: _Timeline | None = None  # a possible reboot, awaiting confirmation
    ahead: _Timeline | None = None  # a possible jump ahead, awaiting confirmation
    reanchored_wall: float = -math.inf  # wall time of its last reboot

    @property
    def last_unwrapped(self) -> float:
        return self.last_boot + self.epoch


class MissionClock:
    """Mission time and its rate, estimated from the vehicles' ``time_boot_ms``.

    Args:
        wall: Monotonic wall clock (injected so tests can drive it by hand).
        rate_hint: Expected mission seconds per wall second (the mock's speedup)
            for the first ``min_span`` wall seconds; None: 1.0 until measured.
        window: Wall seconds of observations the fit uses.
        min_span: Wall seconds the window must span before its slope is trusted.
        sample_spacing: Wall seconds between stored observations of one vehicle.
        handover_after: Mission seconds of silence of the reference vehicle after
            which another vehicle becomes the reference.
        silence_cap: Mission seconds ``now()`` runs on after the last vehicle was heard
            (keep it above the liveness limit, so silent vehicles are declared lost).
        sleep: Awaitable wall sleep (``eventloop.sleep``), injected for tests.

    Attributes:
        reboots: Reboots seen (``time_boot_ms`` jumping back), all vehicles.
        handovers: Times the reference vehicle changed.
        steps: Steps of the reference's clock followed (a simulator pausing),
            resyncs after a fleet-wide silence included.
        resyncs: Times mission time was taken anew after every vehicle was silent.
        silences: Times the fleet was heard again after ``now()`` had stood at
            ``silence_cap`` (mission time then runs on from the line, a step
            forward that ``steps`` does not count), resyncs included.
        rejected: Stamps rejected for running ahead of their clock, all vehicles.
        jumps: Vehicle clocks re-anchored after a confirmed jump ahead.
        rate_changes: Changes of the reference clock's rate taken at once (a
            simulator's speedup set anew), each also a step.
    """

    def __init__(
        self,
        wall: Callable[[], float] = time.monotonic,
        *,
        rate_hint: float | None = None,
        window: float = 10.0,
        min_span: float = 0.05,
        sample_spacing: float = 0.05,
        handover_after: float = 2.0,
        silence_cap: float = 10.0,
        sleep: Callable[[float], Awaitable[None]] = eventloop.sleep,
    ) -> None:
        if rate_hint is not None and not (math.isfinite(rate_hint) and rate_hint > 0.0):
            raise ValueError(f"rate_hint must be finite and > 0, got {rate_hint!r}")
        self._wall = wall
        self._sleep = sleep
        self._hint = rate_hint
        self._window = window
        self._min_span = min_span
        self._spacing = sample_spacing
        self._handover_after = handover_after
        self._silence_cap = silence_cap
        self._tracks: dict[int, _Track] = {}
        self._ref: int | None = None
        # fitted line: mission = _m_a + _rate * (wall - _w_a)
        self._w_a = 0.0
        self._m_a = 0.0
        self._rate = rate_hint if rate_hint is not None else 1.0
        self._rate_trusted = False
        self._measured: float | None = None  # the last rate a fit gave
        self._step_run: list[tuple[float, float, float]] = []  # (wall, unwrapped, residual)
        self._dirty = False
        self._fit_wall = -math.inf
        self._last_now = -math.inf
        self._heard_wall = -math.inf  # wall time any vehicle was last heard
        self._resync_due = False  # every vehicle was silent: the next one heard resyncs
        self._silence_wall = -math.inf  # when that silence began
        self._stood_wall = -math.inf  # wall time ``now()`` last found the clock standing
        self._synced = asyncio.Event()
        self.reboots = 0
        self.handovers = 0
        self.steps = 0
        self.resyncs = 0
        self.silences = 0
        self.rejected = 0
        self.jumps = 0
        self.rate_changes = 0

    # ------------------------------------------------------------------ queries
    @property
    def synced(self) -> bool:
        """True once a vehicle has been heard (mission time is defined)."""
        return self._ref is not None

    @property
    def reference(self) -> int | None:
        """System id whose boot clock mission time follows."""
        return self._ref

    @property
    def rate(self) -> float:
        """Estimated mission seconds per wall second (the speedup)."""
        self._refit()
        return self._rate

    @property
    def rate_trusted(self) -> bool:
        """True once the rate comes from a fit rather than the hint."""
        self._refit()
        return self._rate_trusted

    @property
    def breaks(self) -> int:
        """Steps followed and silences heard out so far: mission time that passed across
        one of them, between two readings, is no lateness of the service's."""
        return self.steps + self.silences

    def reading(self) -> Reading:
        """Mission time now, with the breaks so far (``Reading.since``)."""
        t = self.now()
        return Reading(t, self.breaks)

    def now(self) -> float:
        """Mission seconds now (0.0 before any vehicle was heard)."""
        if self._ref is None:
            return 0.0
        self._refit()
        wall = self._wall()
        t = self._m_a + self._rate * (min(wall, self._heard_wall) - self._w_a)
        silent = self._rate * max(wall - self._heard_wall, 0.0)
        if silent >= self._silence_cap:
            self._stood_wall = wall
        t += min(silent, self._silence_cap)
        if t < self._last_now:
            return self._last_now
        self._last_now = t
        return t

    def to_mission(self, boot_ms: float, sysid: int) -> float:
        """Mission time of a ``time_boot_ms`` stamp from vehicle ``sysid``.

        Falls back to ``now()`` for a vehicle never observed.
        """
        track = self._tracks.get(sysid)
        if track is None:
            return self.now()
        return boot_ms * 1e-3 + track.epoch + self._offset(sysid, track)

    # ------------------------------------------------------------- observation
    def observe(self, boot_ms: float, sysid: int) -> Observed:
        """One message from ``sysid`` stamped ``boot_ms`` arrived just now.

        Cheap: called for every message with a ``time_boot_ms`` field.

        Returns:
            ``REBOOTED`` if this message confirmed a reboot of ``sysid`` (its
            clock restarted; a packet reordered on the way is not one),
            ``REJECTED`` if its stamp is further ahead than ``sysid``'s clock
            can have run (the caller drops the message), else ``ACCEPTED``.
        """
        wall = self._wall()
        boot = boot_ms * 1e-3
        if not math.isfinite(boot):
            self.rejected += 1
            return Observed.REJECTED
        track = self._tracks.get(sysid)
        jumped = False
        if track is not None and boot > track.last_boot + self._ahead_limit(wall - track.last_wall):
            if not self._jump_confirmed(track, boot, wall):
                self.rejected += 1
                return Observed.REJECTED
            jumped = True
        elif track is not None:
            track.ahead = None
        if self._rate * (wall - self._heard_wall) > self._handover_after and self._ref is not None:
            self._resync_due = True
            self._silence_wall = self._heard_wall
        if self._stood_wall > self._heard_wall and wall - self._stood_wall <= _SILENCE_SEEN:
            self.silences += 1  # (the loop saw the clock stand: the fleet was silent)
        self._heard_wall = wall
        rebooted = Observed.ACCEPTED
        if track is None:
            track = self._new_track(sysid, boot, wall)
        elif jumped:
            self._reanchor(track, boot, wall)
            self.reboots -= 1  # (counted as a jump, not a reboot)
            self.jumps += 1
        elif boot < track.last_boot - _REBOOT_JUMP:
            if not self._reboot_confirmed(track, boot):
                return Observed.ACCEPTED
            self._reanchor(track, boot, wall)
            rebooted = Observed.REBOOTED
        else:
            track.behind = None
        track.last_boot = max(track.last_boot, boot)
        track.last_wall = wall
        self._bin(track, wall, boot + track.epoch)
        if self._resync_due and track.reanchored_wall < self._silence_wall:
            if sysid != self._ref:  # (a clock rebooted since says nothing of the silence)
                self._resync(sysid, track, wall, boot + track.epoch)
                return rebooted
            self._resync_due = False  # the reference first: its step is followed
        if sysid == self._ref and self._check_step(track, wall, boot + track.epoch):
            return rebooted
        walls, times = track.walls, track.times
        if len(walls) >= _DENSE_SAMPLES and wall - track.last_stored < self._spacing:
            return rebooted
        track.last_stored = wall
        walls.append(wall)
        times.append(boot + track.epoch)
        horizon = wall - self._window
        while walls[0] < horizon:
            walls.popleft()
            times.popleft()
        if sysid == self._ref or self._measured is None:
            self._dirty = True  # (no rate measured yet: another clock may give it)
        if sysid == self._ref:
            return rebooted
        assert self._ref is not None
        ref = self._tracks[self._ref]
        if self._rate * (wall - ref.last_wall) > self._handover_after and not self._resync_due:
            self._handover(sysid, track)  # (not to a clock just rebooted in a silence)
        return rebooted

    def _new_track(self, sysid: int, boot: float, wall: float) -> _Track:
        track = _Track()
        self._tracks[sysid] = track
        if self._ref is None:
            self._ref = sysid
            self._w_a, self._m_a = wall, boot
            self._synced.set()
        else:
            track.offset = self._line(wall) - boot
        return track

    def _ahead_limit(self, wall_elapsed: float) -> float:
        """Mission s a stamp may advance in ``wall_elapsed`` (inf until the rate is measured)."""
        self._refit()
        if not self._rate_trusted:
            return math.inf
        rate = self._rate
        return 2.0 * rate * max(wall_elapsed, 0.0) + rate * _AHEAD_SLACK_WALL + _AHEAD_SLACK_S

    def _jump_confirmed(self, track: _Track, boot: float, wall: float) -> bool:
        """A jump ahead is the clock's own once ``_REBOOT_CONFIRM`` stamps in a row agree,
        each no further ahead of the last than the clock can have run.

        A spoofed or corrupt stamp among the vehicle's own is isolated (the next
        genuine packet clears it); a clock that really moved stays on its new timeline.
        """
        last = track.ahead
        track.ahead = (
            _Timeline(boot, wall)
            if last is None
            else last.then(boot, wall, self._ahead_limit(wall - last.wall))
        )
        if not track.ahead.confirmed:
            return False
        track.ahead = None
        return True

    @staticmethod
    def _reboot_confirmed(track: _Track, boot: float) -> bool:
        """A jump back is a reboot once ``_REBOOT_CONFIRM`` stamps in a row agree.

        A packet reordered on the way (delivered after newer ones) is isolated
        and must not re-anchor the vehicle's clock; a reboot's timeline persists.
        """
        last = track.behind
        track.behind = _Timeline(boot, 0.0) if last is None else last.then(boot, 0.0, math.inf)
        return track.behind.confirmed

    def _reanchor(self, track: _Track, boot: float, wall: float) -> None:
        """A reboot: the unwrapped time continues at the rate from the last observation."""
        predicted = track.last_unwrapped + self._rate * (wall - track.last_wall)
        track.epoch = predicted - boot
        track.last_boot = boot
        track.bins.clear()  # (its new clock's offset is a guess until measured anew)
        track.bin_times.clear()
        track.behind = None
        track.reanchored_wall = wall
        self.reboots += 1

    def _step_threshold(self) -> float:
        return max(_STEP_FLOOR, _STEP_WALL * self._rate)

    def _check_step(self, track: _Track, wall: float, unwrapped: float) -> bool:
        """Follow the reference's clock if it has stepped; True if it just did."""
        self._refit()
        if not self._rate_trusted:
            return False
        residual = unwrapped + track.offset - self._line(wall)
        threshold = self._step_threshold()
        run = self._step_run
        if abs(residual) <= threshold:
            run.clear()
            return False
        if run and (residual > 0) != (run[-1][2] > 0):
            run.clear()  # off the other way: a new run starts here
        run.append((wall, unwrapped, residual))
        if len(run) > _RUN_KEPT:
            del run[0]
        if len(run) < _STEP_CONFIRM or wall - run[0][0] < _STEP_SPAN:
            return False
        residuals = [r for _, _, r in run[-_STEP_CONFIRM:]]
        if max(residuals) - min(residuals) > 0.5 * threshold:
            if not self._rate_changed(run, threshold):
                return False  # a queue filling or draining (congestion), not a clock that moved
            self.rate_changes += 1
        # Rebuild from the packets on the new timeline; the other vehicles' samples
        # straddle the step too (a simulator pauses them all), so they restart.
        self._restart_line(track, [w for w, _, _ in run], [u for _, u, _ in run], wall)
        return True

    def _restart_line(
        self, track: _Track, walls: list[float], times: list[float], wall: float
    ) -> None:
        """A step: the line starts anew from these observations of ``track`` (the
        reference's), at ``wall``; every other stored sample straddles what moved the
        clock, and is dropped."""
        for other in self._tracks.values():
            other.walls.clear()
            other.times.clear()
        track.walls.extend(walls)
        track.times.extend(times)
        track.last_stored = wall
        self._step_run.clear()
        self.steps += 1
        self._last_now = -math.inf
        self._refit(force=True)

    def _rate_changed(self, run: list[tuple[float, float, float]], threshold: float) -> bool:
        """Whether a run of packets off the line, in the same direction, whose residuals
        do not agree, is the clock running at a new rate: spread over ``_RATE_SPAN``
        wall s, on a line of their own (within half the step threshold) whose slope
        turns the rate by ``_RATE_CHANGE`` of itself or more, to a rate above zero."""
        walls = [w for w, _, _ in run]
        if walls[-1] - walls[0] < _RATE_SPAN:
            return False
        residuals = [r for _, _, r in run]
        a, slope = _fit([w - walls[-1] for w in walls], residuals)
        if not (math.isfinite(slope) and abs(slope) >= _RATE_CHANGE * self._rate):
            return False
        if self._rate + slope <= 0.0:
            return False
        worst = max(
            abs(r - a - slope * (w - walls[-1])) for w, r in zip(walls, residuals, strict=True)
        )
        return worst <= 0.5 * threshold

    def rate_set(self, rate: float, sysid: int) -> bool:
        """Vehicle ``sysid`` says its clock runs at ``rate`` from now on (a simulator's
        PARAM_VALUE of ``SIM_SPEEDUP``): if it is the reference and the rate is new
        (by ``_RATE_CHANGE``), the line restarts at ``rate`` from its newest packet,
        as a step (``rate_changes``). True if it did.

        The fit alone would take its window to turn, and the change-of-rate test
        (``_rate_changed``) waits for a run of packets on a clean line, which a host
        loaded enough to need a slower simulator does not give: mission time ran on
        at the old rate for a while (setpoints ahead, the convoy's fixes stale).
        """
        track = self._tracks.get(sysid)
        if (
            sysid != self._ref
            or track is None
            or not (math.isfinite(rate) and rate > 0.0)
            or abs(rate - self._rate) < _RATE_CHANGE * self._rate
        ):
            return False
        self._measured = rate  # (the fallback until the new packets span the window's minimum)
        self.rate_changes += 1
        self._restart_line(track, [track.last_wall], [track.last_unwrapped], track.last_wall)
        return True

    def _resync(self, sysid: int, track: _Track, wall: float, unwrapped: float) -> None:
        """Take mission time anew from ``sysid`` after a fleet-wide silence (see the
        module docstring): its offset from before, the line from this observation."""
        assert self._ref is not None
        self._resync_due = False
        self._tracks[self._ref].offset_wall = -math.inf
        self._ref = sysid  # (track.offset is the one measured before the silence)
        self.handovers += 1
        for other in self._tracks.values():
            other.offset_wall = -math.inf
        self.resyncs += 1
        self._restart_line(track, [wall], [unwrapped], wall)

    def _handover(self, sysid: int, track: _Track) -> None:
        assert self._ref is not None
        self._step_run.clear()
        self._tracks[self._ref].offset_wall = -math.inf  # re-measured against the new line
        track.offset = self._offset(sysid, track, force=True)
        self._ref = sysid
        self.handovers += 1
        self._refit(force=True)

    # --------------------------------------------------------------------- fit
    def _line(self, wall: float) -> float:
        return self._m_a + self._rate * (wall - self._w_a)

    def _offset(self, sysid: int, track: _Track, *, force: bool = False) -> float:
        """mission - unwrapped time of a vehicle: for the reference a constant; for
        the others measured against the reference bin by bin (``_bin``), refreshed
        about once a wall second (offsets only change slowly)."""
        if sysid == self._ref and not force:
            return track.offset
        wall = self._wall()
        every = _OFFSET_REFRESH if self._rate_trusted else 0.1 * _OFFSET_REFRESH
        if force or wall - track.offset_wall >= every:
            assert self._ref is not None
            ref = self._tracks[self._ref]
            differences = _matched_differences(ref.bins, ref.bin_times, track.bins, track.bin_times)
            if differences:
                track.offset = statistics.median(differences) + ref.offset
            track.offset_wall = wall
        return track.offset

    def _bin(self, track: _Track, wall: float, unwrapped: float) -> None:
        """Keep the soonest packet of each wall bin: where the vehicle's clock stood
        at the bin's start, as near as its packets tell.

        Two vehicles' clocks are compared bin by bin, each at its least-delayed
        packet in the bin (the newest of a backlog read after a stall), and the
        offset is the median over the last ``_OFFSET_BINS`` bins both have. Delays
        only ever add and a loaded host adds them unevenly (the sockets read after
        a stall deliver some vehicles' backlogs later than others'), and a
        simulator pausing moves every clock at once: a bin compares the vehicles
        across the same moments, so neither reaches the offset. (The median of
        each packet against the reference's fitted line, over its last 1.6 wall s,
        was 0.2-0.5 mission s off for tens of seconds on a busy host at 40x: 10 m
        of a plane.)
        """
        index = math.floor(wall / _OFFSET_BIN)
        at_start = unwrapped - self._rate * (wall - index * _OFFSET_BIN)
        bins, times = track.bins, track.bin_times
        if bins and bins[-1] == index:
            times[-1] = max(times[-1], at_start)
            return
        if bins and index < bins[-1]:
            return  # (the wall clock never goes back; a test's might)
        bins.append(index)
        times.append(at_start)
        if len(bins) > _OFFSET_BINS:
            bins.popleft()
            times.popleft()

    def _refit(self, *, force: bool = False) -> None:
        if not (self._dirty or force) or self._ref is None:
            return
        wall = self._wall()
        if not force and self._rate_trusted and wall - self._fit_wall < _REFIT_INTERVAL:
            return
        self._fit_wall = wall
        self._dirty = False
        track = self._tracks[self._ref]
        if not track.walls:
            return
        ws = list(track.walls)
        offset = track.offset
        ms = [u + offset for u in track.times]
        span = ws[-1] - ws[0]
        free = len(ws) >= _MIN_FIT_SAMPLES and span >= self._min_span
        if free:
            w_a, m_a, rate = _robust_line(ws, ms)
            free = math.isfinite(rate) and rate > 0.0
            if free:
                self._measured = rate
        if not free:  # slope unknown: extrapolate the newest observation at the fallback rate
            w_a, m_a, rate = ws[-1], ms[-1], self._fallback_rate()
        self._w_a, self._m_a, self._rate = w_a, m_a, rate
        self._rate_trusted = free

    def _fallback_rate(self) -> float:
        if self._measured is not None:
            return self._measured  # e.g. after a handover or a step: the last measured rate
        others = self._rate_of_others()
        if others is not None:
            return others
        return self._hint if self._hint is not None else 1.0

    def _rate_of_others(self) -> float | None:
        """The slope of the best-sampled other vehicle's clock, before the reference's
        own is known: one fleet's simulators run at one speedup.

        The first vehicle heard may fall silent at once (a lossy radio, ArduPlane SITL
        at 5x: one packet, then 2 wall s of nothing). Extrapolated at the hint (1.0
        for ``run``) meanwhile, mission time fell 8 s behind the others' clocks, and
        the handover to one of them stepped it on at once: two UAVs called silent for
        8 s, a set-up begun anew.
        """
        best: _Track | None = None
        for sysid, track in self._tracks.items():
            if sysid == self._ref or len(track.walls) < _MIN_FIT_SAMPLES:
                continue
            if track.walls[-1] - track.walls[0] < self._min_span:
                continue
            if best is None or len(track.walls) > len(best.walls):
                best = track
        if best is None:
            return None
        _, _, rate = _robust_line(list(best.walls), list(best.times))
        return rate if math.isfinite(rate) and rate > 0.0 else None

    # ------------------------------------------------------------------- sleep
    async def wait_synced(self) -> None:
        """Wait until the first vehicle has been heard."""
        await self._synced.wait()

    async def sleep_until(self, t_mission: float) -> None:
        """Sleep until mission time reaches ``t_mission``.

        The wall delay is (t - now) / rate, re-evaluated at least every quarter
        wall second so a changing rate estimate is followed. Returns early if the
        clock steps meanwhile (the deadline may now be far off: the caller decides).
        Before any vehicle was heard this first waits for one.
        """
        if self._ref is None:
            await self._synced.wait()
        steps = self.steps
        while steps == self.steps:
            delay = self.wall_until(t_mission)
            if delay <= 0.0:
                return
            await self._sleep(delay)

    def wall_until(self, t_mission: float) -> float:
        """Wall seconds to sleep towards mission time ``t_mission`` before looking again.

        (t - now) / rate, but at most a quarter second -- and 10 ms while the rate
        is still a guess, since a guess may be off by the whole speedup. <= 0: due.
        """
        remaining = t_mission - self.now()
        if remaining <= 0.0:
            return 0.0
        chunk = _MAX_SLEEP_CHUNK if self.rate_trusted else _GUESS_SLEEP_CHUNK
        return min(remaining / self._rate, chunk)


def _matched_differences(
    ref_bins: deque[int], ref_times: deque[float], bins: deque[int], times: deque[float]
) -> list[float]:
    """Reference time less this vehicle's, in each bin both have."""
    ref = dict(zip(ref_bins, ref_times, strict=True))
    return [ref[b] - t for b, t in zip(bins, times, strict=True) if b in ref]


def _robust_line(ws: list[float], ms: list[float]) -> tuple[float, float, float]:
    """(w_a, m_a, rate) of ``m = m_a + rate (w - w_a)`` with outliers trimmed.

    Least squares, then points further than 4 MADs from the median residual are
    dropped and the line refitted, until nothing changes (at most 4 passes: a
    burst of late packets pulls the first line towards itself). The anchor
    ``w_a`` is the newest wall time (no cancellation when evaluating now).
    """
    w_a = ws[-1]
    xs = [w - w_a for w in ws]
    keep = list(range(len(xs)))
    a, b = _fit(xs, ms)
    for _ in range(_TRIM_PASSES):
        residuals = [ms[i] - (a + b * xs[i]) for i in keep]
        centre = statistics.median(residuals)
        mad = statistics.median(abs(r - centre) for r in residuals)
        limit = max(_OUTLIER_MADS * 1.4826 * mad, _RESIDUAL_FLOOR)
        # every point is judged against the current line, so a point dropped by a
        # bad first line can come back
        kept = [i for i in range(len(xs)) if abs(ms[i] - (a + b * xs[i]) - centre) <= limit]
        if kept == keep or len(kept) < 2:
            break
        keep = kept
        a, b = _fit([xs[i] for i in keep], [ms[i] for i in keep])
    return w_a, a, b


def _fit(xs: list[float], ys: list[float]) -> tuple[float, float]:
    """Least-squares intercept and slope (slope NaN if the xs do not spread)."""
    n = len(xs)
    mx = sum(xs) / n
    my = sum(ys) / n
    sxx = sum((x - mx) * (x - mx) for x in xs)
    if sxx <= 0.0:
        return my, math.nan
    sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True))
    b = sxy / sxx
    return my - b * mx, b
