"""Convoy state estimation: fixes from several sources -> one ``ConvoyEstimate``.

Design rules:
- A *source* is one ground vehicle (its MAVLink sysid) or an external feed
  (e.g. ``"mqtt"``).  Only each source's latest fix counts: the convoy
  position is the centroid of the latest fixes of the live sources.
- Velocity is the least-squares slope of the centroid samples over a sliding
  time window: robust to GPS noise, and it needs no model of the route.  A
  centroid sample is dated at the mean time of the fixes it averages.
- A ground vehicle that reports its own velocity (GLOBAL_POSITION_INT's
  vx/vy: an autopilot's estimate from GPS Doppler, not a difference of fixes)
  knows it without the slope's lag of half a window (2 s into a corner, 2 s
  into a stop).  Its reports are used while they can be trusted: steady (their
  change from one second to the next, in the median over the last 10 s, under
  ``steady_mps``) and borne out by the fixes (their mean over the window within
  ``agree_mps`` of the slope).  A feed that reports zeros, another frame, or a
  difference of 3-m-noisy fixes fails one of the two and the slope is used.
- A source silent for longer than ``stale_after`` leaves the centroid, so one
  dead truck does not freeze the convoy in place; so does one that has parted from
  the lead's group (``parting.convoy_group``: farther than ``part_m`` from every
  other), so one truck stopped while the rest drive on does not drag the convoy
  back between them.  The fixes are compared as they come (at 1 Hz, a second or
  so apart: a few tens of metres at most against a part distance of hundreds).
  A source the caller knows to have left (``keep_apart``: a follower its operator
  held or sent home while the lead drives on) is parted at once, wherever it is; so
  is one that has stood ``parting.STAND_S`` while the lead drove on, as the speeds
  they report say (``standing``: a breakdown, its autopilot still in its mission).
- Whenever the set of sources changes, the centroid jumps (it is now the centre
  of other vehicles): the sample history restarts and the last velocity is held
  until the new history spans ``min_span`` seconds, so the jump never shows up as a
  velocity.
- Bad input never raises: NaN/inf fixes and fixes older than the source's
  latest are ignored and counted.  With no fresh fix at all the last good
  estimate is held with ``stale=True`` and the caller raises its alarm.
- Pure: times are passed in (mission seconds).
"""

from __future__ import annotations

import bisect
import math
import statistics
from collections import Counter, deque
from dataclasses import dataclass, replace

from convoy_mav.parting import StandWatch, convoy_group
from convoy_mav.plausible import JumpGate
from convoy_mav.types import ConvoyEstimate

__all__ = ["ConvoyTracker", "Source"]

Source = str | int


@dataclass(frozen=True, slots=True)
class _Fix:
    t: float
    north: float
    east: float
    velocity: tuple[float, float] | None = None  # as the source reported it, m/s


_REPORT_CHANGE_S = 1.0  # a report's change is measured against the one this long before
_REPORT_CHECK_S = 10.0  # over this long, in the median, and only once this much is seen
_REPORT_MEAN_S = 1.0  # the velocity used is the reports' mean over this long


def _mean_velocity(reports: deque[tuple[float, float, float]], since: float) -> tuple[float, float]:
    """Mean (vn, ve) of the reports (oldest first) from ``since`` on, or of the newest."""
    count = sn = se = 0.0
    for t, vn, ve in reversed(reports):
        if t < since and count:
            break
        count, sn, se = count + 1.0, sn + vn, se + ve
    return sn / count, se / count


class ConvoyTracker:
    """Centroid and velocity of the convoy from the latest fix of each source.

    Args:
        stale_after: Seconds without a fix after which a source leaves the
            centroid and, when no source is left, the estimate is stale.
        window: Length of the least-squares velocity window, seconds.
        min_span: The velocity is re-estimated only once the window's samples
            span at least this long (until then the last velocity is held).
        max_speed: Fastest a ground vehicle drives, m/s: a source's fix farther
            from its last than this allows is dropped (``plausible.JumpGate``).
        steady_mps: Reported velocities whose median change over a second is larger
            are not trusted (3 m of GPS noise differenced at 1 Hz changes 7 m/s).
        agree_mps: Reported velocities whose mean over the window is farther than
            this from the fixes' slope are not trusted.
        part_m: A source farther than this from every other of the lead's group has
            parted from the convoy and leaves the centroid (0: none ever parts).
        lead: The source whose group is the convoy (None, or while it is silent:
            the largest group).

    Attributes:
        counters: ``accepted``, ``non_finite``, ``out_of_order``, ``jump``
            (farther than the convoy can drive), ``source_dropped`` (a source left
            the centroid), ``source_added``, ``source_parted`` and
            ``source_rejoined`` (left the centroid for parting from the convoy, and
            back in it), ``velocity_non_finite`` (a report's
            velocity ignored, its position kept), ``velocity_reported`` and
            ``velocity_fitted`` (estimates from the reports and from the slope).
    """

    def __init__(
        self,
        *,
        stale_after: float = 3.0,
        window: float = 10.0,
        min_span: float = 1.0,
        max_speed: float = 70.0,
        steady_mps: float = 2.0,
        agree_mps: float = 1.5,
        part_m: float = 0.0,
        lead: Source | None = None,
    ):
        for name, value in (("stale_after", stale_after), ("window", window)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not (math.isfinite(min_span) and 0.0 < min_span <= window):
            raise ValueError(f"min_span must be in (0, window], got {min_span!r}")
        if not (math.isfinite(part_m) and part_m >= 0.0):
            raise ValueError(f"part_m must be >= 0 and finite, got {part_m!r}")
        self.part_m = part_m
        self.lead = lead
        self._parted: frozenset[Source] = frozenset()
        self._apart: frozenset[Source] = frozenset()  # (kept apart by the caller's word)
        self._stands: StandWatch[Source] = StandWatch()
        self._standing: frozenset[Source] = frozenset()
        self.stale_after = stale_after
        self.window = window
        self.min_span = min_span
        self.counters: Counter[str] = Counter()
        self.max_speed = max_speed
        self.steady_mps = steady_mps
        self.agree_mps = agree_mps
        self._gates: dict[Source, JumpGate] = {}
        self._fixes: dict[Source, _Fix] = {}
        self._active: frozenset[Source] = frozenset()
        self._samples: deque[tuple[float, float, float]] = deque()
        # (t, vn, ve) of the centroid's reported velocity while every source reports
        # one, and (t, its change from the report a second before)
        self._reports: deque[tuple[float, float, float]] = deque()
        self._changes: deque[tuple[float, float]] = deque()
        self._velocity = (0.0, 0.0)
        self._last: ConvoyEstimate | None = None

    @property
    def sources(self) -> frozenset[Source]:
        """The sources in the current centroid."""
        return self._active

    @property
    def parted(self) -> frozenset[Source]:
        """Heard sources left out of the centroid for having parted from the convoy."""
        return self._parted

    @property
    def standing(self) -> frozenset[Source]:
        """Heard sources that have stood ``parting.STAND_S`` while the lead drove on."""
        return self._standing

    def keep_apart(self, source: Source, apart: bool) -> None:
        """Whether ``source`` has left the convoy by its own mode (the caller's word:
        held, or sent home, while the lead drives on), whatever its distance: from its
        next fix on it is parted, or, no longer, may rejoin within the rejoin distance."""
        self._apart = self._apart | {source} if apart else self._apart - {source}

    def apart(self, source: Source) -> float | None:
        """How far ``source``'s latest fix is from the nearest of the centroid's (None:
        it is one of them, or no other is heard), metres."""
        fix = self._fixes.get(source)
        if fix is None or source in self._active or not self._active:
            return None
        return min(
            math.hypot(fix.north - f.north, fix.east - f.east)
            for f in (self._fixes[s] for s in self._active)
        )

    def update(
        self,
        t: float,
        north: float,
        east: float,
        source: Source = 0,
        velocity: tuple[float, float] | None = None,
    ) -> bool:
        """Fold in one position fix of ``source`` at mission time ``t``, with the
        ``(vn, ve)`` it reports when it does.

        Returns:
            True if the fix was used; False if it was ignored (a NaN/inf value,
            a fix older than this source's latest one, or one already stale
            when it arrives) -- counted, never raised.
        """
        if not (math.isfinite(t) and math.isfinite(north) and math.isfinite(east)):
            self.counters["non_finite"] += 1
            return False
        previous = self._fixes.get(source)
        too_old = self._last is not None and t < self._last.t - self.stale_after
        if too_old or (previous is not None and t < previous.t):
            self.counters["out_of_order"] += 1
            return False
        gate = self._gates.get(source)
        if gate is None:
            gate = self._gates[source] = JumpGate(self.max_speed)
        if not gate.admit(t, north, east):
            self.counters["jump"] += 1
            return False
        if velocity is not None and not all(map(math.isfinite, velocity)):
            self.counters["velocity_non_finite"] += 1
            velocity = None
        self._fixes[source] = _Fix(t, north, east, velocity)
        self.counters["accepted"] += 1
        now = t if self._last is None else max(t, self._last.t)
        fresh = {
            s: (f.north, f.east) for s, f in self._fixes.items() if now - f.t <= self.stale_after
        }
        if self.part_m > 0.0:
            self._stands.add(source, t, None if velocity is None else math.hypot(*velocity))
            self._standing = self._stands.judge(self.lead, now) & frozenset(fresh)
        active = convoy_group(
            fresh,
            lead=self.lead,
            part_m=self.part_m,
            parted=self._parted,
            apart=self._apart | self._standing,
        )
        parted = frozenset(fresh) - active
        self.counters["source_parted"] += len(parted - self._parted)
        self.counters["source_rejoined"] += len(self._parted & active)
        self._parted = parted
        if active != self._active:
            self.counters["source_dropped"] += len(self._active - active)
            self.counters["source_added"] += len(active - self._active)
            self._active = active
            self._samples.clear()
            self._reports.clear()
            self._changes.clear()
        fixes = [self._fixes[s] for s in active]
        # The centroid of fixes taken at different times is where the convoy was
        # at their mean time (exactly, for a constant velocity): sampling it
        # there keeps the least-squares slope unbiased by the report schedule.
        tc = sum(f.t for f in fixes) / len(fixes)
        n = sum(f.north for f in fixes) / len(fixes)
        e = sum(f.east for f in fixes) / len(fixes)
        self._samples.append((tc, n, e))
        while self._samples and self._samples[0][0] < tc - self.window:
            self._samples.popleft()
        self._fold_reports(tc, fixes)
        fitted = self._fit_velocity()
        reported = self._reported_velocity(fitted)
        vn, ve = self._velocity = reported or fitted
        self.counters["velocity_fitted" if reported is None else "velocity_reported"] += 1
        self._last = ConvoyEstimate(now, n + vn * (now - tc), e + ve * (now - tc), vn, ve)
        return True

    def _fold_reports(self, tc: float, fixes: list[_Fix]) -> None:
        """The centroid's reported velocity at ``tc`` (when every source reports one) and
        its change from the report a second before."""
        reported = [f.velocity for f in fixes if f.velocity is not None]
        reports, changes = self._reports, self._changes
        if len(reported) < len(fixes):
            reports.clear()
            changes.clear()
            return
        vn = sum(v[0] for v in reported) / len(reported)
        ve = sum(v[1] for v in reported) / len(reported)
        j = bisect.bisect_right(reports, tc - _REPORT_CHANGE_S, key=lambda r: r[0]) - 1
        if j >= 0:
            changes.append((tc, math.hypot(vn - reports[j][1], ve - reports[j][2])))
        reports.append((tc, vn, ve))
        while reports[0][0] < tc - _REPORT_CHECK_S - _REPORT_CHANGE_S:
            reports.popleft()
        while changes and changes[0][0] < tc - _REPORT_CHECK_S:
            changes.popleft()

    def _reported_velocity(self, fitted: tuple[float, float]) -> tuple[float, float] | None:
        """The reports' recent mean, when they are steady and the fixes (whose slope is
        ``fitted``) bear them out."""
        reports = self._reports
        if not reports or reports[-1][0] - reports[0][0] < _REPORT_CHECK_S:
            return None
        newest = reports[-1][0]
        if not self._changes or statistics.median(c for _, c in self._changes) > self.steady_mps:
            return None
        start = self._samples[0][0] if self._samples else newest
        mn, me = _mean_velocity(reports, start)
        if math.hypot(mn - fitted[0], me - fitted[1]) > self.agree_mps:
            return None
        return _mean_velocity(reports, newest - _REPORT_MEAN_S)

    def _fit_velocity(self) -> tuple[float, float]:
        """Least-squares slope of the centroid samples, or the held velocity."""
        samples = self._samples
        if len(samples) < 2 or samples[-1][0] - samples[0][0] < self.min_span:
            return self._velocity
        count = len(samples)
        t_mean = sum(s[0] for s in samples) / count
        n_mean = sum(s[1] for s in samples) / count
        e_mean = sum(s[2] for s in samples) / count
        stt = stn = ste = 0.0
        for ts, ns, es in samples:
            dt = ts - t_mean
            stt += dt * dt
            stn += dt * (ns - n_mean)
            ste += dt * (es - e_mean)
        if stt <= 0.0:  # pragma: no cover - min_span > 0 guarantees a spread
            return self._velocity
        return stn / stt, ste / stt

    def estimate(self, t: float) -> ConvoyEstimate | None:
        """The convoy estimate at mission time ``t`` (None before the first good fix).

        Fresh (a fix within ``stale_after``): the centroid extrapolated to
        ``t`` with the estimated velocity.  Stale: the last good estimate held
        unchanged (its ``t`` says how old it is) with ``stale=True``.
        """
        last = self._last
        if last is None:
            return None
        age = t - last.t
        if not math.isfinite(age) or age > self.stale_after:
            return replace(last, stale=True)
        return ConvoyEstimate(
            t, last.north + last.vn * age, last.east + last.ve * age, last.vn, last.ve
        )
