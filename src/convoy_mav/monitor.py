"""The coverage monitor: live coverage, tracking error and alarms from telemetry.

Design rules:
- Pure and synchronous: the app calls ``update`` on a fixed mission-time tick
  with the latest telemetry and convoy estimate, and ``track`` with each
  position update as it arrives; nothing here waits or sleeps.
- The tracking error is scored per telemetry update, against the plan at the
  telemetry's own time: every position counts once (a tick would count a stale
  one again and miss ones that came between), and a big fleet's plans are
  sampled as their telemetry trickles in, not all at once on the tick.
- Coverage is counted from the protect phase on (joining UAVs are not yet
  expected to cover); before that only the live "covered now?" is reported.
- Coverage is scored at the telemetry's own times (``stamped.StampedCoverage``):
  each instant is decided from the fixes around it, a few seconds late at most, so
  a host stall neither over- nor under-claims what the UAVs saw meanwhile. The
  live "covered now?" is the latest fixes' (carried to the tick).
- Only a UAV that can see counts: heard (not lost), airborne by its autopilot's
  word, within its altitude band and on its protecting slot. ``why_not_counted``
  is the one rule, and its answer is what the report and MQTT show.
- Alarms are edge-triggered values: raised once when a condition starts, and
  a matching clear when it ends, so publishers and logs are not flooded.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field

from convoy_mav.coverage import (
    CoverageEvent,
    CoverageSample,
    CoverageStats,
    CoverageTracker,
    GapClosed,
    GapOpened,
)
from convoy_mav.stamped import StampedCoverage, StampedSample
from convoy_mav.types import ConvoyEstimate, Telemetry

__all__ = ["Alarm", "Monitor", "MonitorSnapshot", "VehicleScore", "sees", "why_not_counted"]

_ERROR_BIN_M = 0.25
"""Tracking errors are kept as a histogram of this resolution (for the median)."""


def why_not_counted(
    *,
    status: str,
    airborne: bool,
    altitude_error: float | None,
    band: float,
    phase: str,
) -> str | None:
    """Why a UAV does not count towards coverage now; None if it does.

    A UAV being set up again (after a link outage or a setpoint failsafe) or holding
    still counts while it is airborne in its band on its slot: it sees what it sees.

    Args:
        status: Its driver's status (``flying``, ``lost``, ``holding``...).
        airborne: The autopilot says it is flying (``Vehicle.airborne``).
        altitude_error: Its altitude minus its planned altitude (m), None if unknown.
        band: How far off its altitude a UAV still sees what the plan assumes (m).
        phase: Its mission phase (``protect``, ``join``, ``pending``, ``lost``).

    Returns:
        ``"lost"``, ``"connecting"`` or ``"failed"``, ``"on ground"``,
        ``"climbing"`` (below its band), ``"above its altitude band"``, ``"joining"``
        or ``"not assigned"``; None when it counts.
    """
    if status == "lost" or phase == "lost":
        return "lost"
    if status in ("connecting", "failed"):  # (never set up, or gave up: nothing to trust)
        return status
    if not airborne:
        return "on ground"
    off_band = _band_reason(altitude_error, band)
    if off_band is not None:
        return off_band
    if phase == "join":
        return "joining"
    if phase != "protect":
        return "not assigned"
    return None


def sees(*, airborne: bool, altitude_error: float | None, band: float) -> bool:
    """Does a UAV see what the plan assumes, wherever it is in the plan: airborne and in
    its altitude band (the part of ``why_not_counted`` that is not the plan's)?"""
    return airborne and _band_reason(altitude_error, band) is None


def _band_reason(altitude_error: float | None, band: float) -> str | None:
    """Why a UAV's altitude (minus its planned one, m) is off its band; None if in it."""
    if altitude_error is None or not math.isfinite(altitude_error):
        return "no position"
    if altitude_error < -band:
        return "climbing"
    if altitude_error > band:
        return "above its altitude band"
    return None


@dataclass(frozen=True, slots=True)
class Alarm:
    """An operator-facing condition that started (``active``) or ended."""

    t: float
    kind: str  # "gap", "prediction_missed", "convoy_stale"
    active: bool
    message: str


@dataclass(frozen=True, slots=True)
class VehicleScore:
    """One UAV's share of the protect phase."""

    sysid: int
    time_in_circle_fraction: float
    mean_tracking_error_m: float | None
    tracking_error_m: float | None  # latest
    median_tracking_error_m: float | None = None


@dataclass(frozen=True, slots=True)
class MonitorSnapshot:
    """Everything the monitor knows at one tick."""

    t: float
    covered: bool
    covering: tuple[int, ...]
    protect_start: float | None
    stats: CoverageStats
    predicted_coverage: float
    vehicles: tuple[VehicleScore, ...]
    sample: CoverageSample | None = None


@dataclass
class _Tracking:
    total: float = 0.0
    count: int = 0
    latest: float | None = None
    bins: Counter[int] = field(default_factory=Counter)  # error // _ERROR_BIN_M -> count

    def median(self) -> float | None:
        """The median error, to the histogram's resolution (the bin's centre)."""
        if not self.count:
            return None
        seen = 0
        for b in sorted(self.bins):
            seen += self.bins[b]
            if 2 * seen >= self.count:
                return (b + 0.5) * _ERROR_BIN_M
        return None


@dataclass
class Monitor:
    """Coverage since the protect phase began, per-UAV scores and alarms.

    Args:
        sensor_radius: r, metres.
        predicted_coverage: What the plan promises; a shortfall of more than
            ``prediction_margin`` (after ``prediction_grace`` seconds of protect)
            raises ``prediction_missed``.
        max_hold: Longest interval one telemetry sample stands for (seconds).
        fresh_s: A UAV's telemetry counts at a tick only if stamped (its own
            ``time_boot_ms``) at most this long before it: a host stall or a slow
            link leaves old positions, which say nothing of now. Fresh ones are
            carried forward to the tick along their velocity.
        step: The control tick, mission s: the grid coverage is decided on.
    """

    sensor_radius: float
    predicted_coverage: float = 1.0
    prediction_margin: float = 0.02
    prediction_grace: float = 60.0
    max_hold: float = 1.0
    fresh_s: float = 1.0
    step: float = 0.1
    _tracker: CoverageTracker | None = field(default=None, init=False)
    _stamped: StampedCoverage | None = field(default=None, init=False)
    _protect_start: float | None = field(default=None, init=False)
    _tracking: dict[int, _Tracking] = field(default_factory=dict, init=False)
    _active: set[str] = field(default_factory=set, init=False)
    _last: CoverageSample | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        self._stamped = StampedCoverage(self.sensor_radius, self.step, fresh_s=self.fresh_s)

    def start_protect(self, t: float) -> None:
        """Begin counting coverage at mission time ``t`` (every UAV has joined)."""
        self._protect_start = t
        self._tracker = CoverageTracker(self.sensor_radius, self.max_hold)
        self._tracking.clear()
        assert self._stamped is not None
        self._stamped.start(t)

    def fix(self, tel: Telemetry) -> None:
        """Each position of each UAV as it arrives (coverage is judged at its stamp)."""
        assert self._stamped is not None
        self._stamped.fix(tel.sysid, tel.t, tel.north, tel.east, tel.vn, tel.ve)

    def end(self, t: float) -> None:
        """The mission ends at ``t``: coverage is counted up to it and no further."""
        assert self._stamped is not None
        self._stamped.end(t)

    def finish(self) -> None:
        """Count the instants up to the end still waiting for their fixes (the stamped
        monitor decides a few seconds behind): the report spans the whole protect phase."""
        assert self._stamped is not None
        if self._tracker is None:
            return
        self._count(self._stamped.flush())

    def restart_protect(self, t: float, predicted_coverage: float) -> None:
        """A replan changed the promise: keep the totals, compare against the new figure."""
        self.predicted_coverage = predicted_coverage
        if self._protect_start is None:
            self.start_protect(t)

    @property
    def active(self) -> frozenset[str]:
        """Kinds of the alarms in force now."""
        return frozenset(self._active)

    @property
    def protect_start(self) -> float | None:
        """Mission time the protect phase began, or None while joining."""
        return self._protect_start

    def update(
        self,
        t: float,
        convoy: ConvoyEstimate | None,
        telemetry: Mapping[int, Telemetry],
    ) -> list[Alarm]:
        """Fold in one tick; return the alarms that started or ended.

        Args:
            t: Mission time of the tick.
            convoy: The convoy estimate (None before the first fix: nothing is covered).
            telemetry: Latest telemetry of each live UAV (lost UAVs left out).
        """
        alarms: list[Alarm] = []
        if convoy is None:
            return alarms
        self._edge(t, "convoy_stale", convoy.stale, "convoy position is stale", alarms)
        positions = {}
        for sysid, tel in telemetry.items():
            age = t - tel.t
            if age <= self.fresh_s and math.isfinite(tel.north) and math.isfinite(tel.east):
                lead = max(age, 0.0)  # (a stamp ahead of the tick: where it is)
                positions[sysid] = (tel.north + tel.vn * lead, tel.east + tel.ve * lead)
        centre = (convoy.north, convoy.east)
        tracker = self._tracker
        if tracker is None:
            self._last = CoverageTracker(self.sensor_radius).observe(t, centre, positions)
            return alarms
        self._last = tracker.observe(t, centre, positions)
        assert self._stamped is not None
        for ev in self._count(self._stamped.tick(t, centre, frozenset(telemetry))):
            if isinstance(ev, GapOpened):
                alarms.append(Alarm(ev.t, "gap", True, "convoy not seen by any UAV"))
                self._active.add("gap")
            elif isinstance(ev, GapClosed):
                alarms.append(
                    Alarm(ev.t, "gap", False, f"convoy seen again after {ev.duration:.1f} s")
                )
                self._active.discard("gap")
        stats = tracker.stats()
        assert self._protect_start is not None
        if t - self._protect_start >= self.prediction_grace:
            missed = stats.fraction < self.predicted_coverage - self.prediction_margin
            self._edge(
                t,
                "prediction_missed",
                missed,
                f"coverage {100 * stats.fraction:.1f} % below predicted "
                f"{100 * self.predicted_coverage:.1f} %",
                alarms,
            )
        return alarms

    def _count(self, decided: list[StampedSample]) -> list[CoverageEvent]:
        """Decided instants into the protect phase's totals; the gap events they make."""
        assert self._tracker is not None
        events: list[CoverageEvent] = []
        for d in decided:
            events += self._tracker.update(d.t, d.convoy, d.uavs)[1]
        return events

    def track(self, tel: Telemetry, north: float, east: float) -> float | None:
        """Score one position update against where the plan wanted the UAV then.

        ``north``, ``east``: the planned position at ``tel.t`` (mission frame).
        Counted from the protect phase on (before it, a joining UAV is expected
        off its slot). Returns the horizontal error in metres, or None if it was
        not counted (joining, or a non-finite position).
        """
        if self._tracker is None:
            return None
        err = math.hypot(tel.north - north, tel.east - east)
        if not math.isfinite(err):
            return None
        rec = self._tracking.get(tel.sysid)
        if rec is None:
            rec = self._tracking[tel.sysid] = _Tracking()
        rec.total += err
        rec.count += 1
        rec.latest = err
        rec.bins[int(err / _ERROR_BIN_M)] += 1
        return err

    def _edge(self, t: float, kind: str, active: bool, message: str, out: list[Alarm]) -> None:
        if active and kind not in self._active:
            self._active.add(kind)
            out.append(Alarm(t, kind, True, message))
        elif not active and kind in self._active:
            self._active.discard(kind)
            out.append(Alarm(t, kind, False, f"cleared: {message}"))

    def snapshot(self, t: float) -> MonitorSnapshot:
        """The monitor's view at mission time ``t``."""
        stats = (
            self._tracker.stats(now=t)
            if self._tracker is not None
            else CoverageStats(0.0, 0.0, 0.0, 0.0, 0, {}, 0.0)
        )
        sysids = sorted(set(self._tracking) | set(stats.time_inside_s))
        scores = tuple(
            VehicleScore(
                sysid=s,
                time_in_circle_fraction=stats.time_inside_fraction(s),
                mean_tracking_error_m=(
                    self._tracking[s].total / self._tracking[s].count
                    if s in self._tracking and self._tracking[s].count
                    else None
                ),
                tracking_error_m=self._tracking[s].latest if s in self._tracking else None,
                median_tracking_error_m=(
                    self._tracking[s].median() if s in self._tracking else None
                ),
            )
            for s in sysids
        )
        last = self._last
        return MonitorSnapshot(
            t=t,
            covered=bool(last and last.covered),
            covering=last.covering if last else (),
            protect_start=self._protect_start,
            stats=stats,
            predicted_coverage=self.predicted_coverage,
            vehicles=scores,
            sample=last,
        )
