"""The ``Plan`` value: what every UAV flies, as time-stamped primitives.

Design rules:
- A vehicle's path is a ``Trajectory``: optional lead-in segments (a join
  path, later) followed by a cycle of segments repeated forever, each lap
  translated by ``drift`` (non-zero when the convoy moves).  That represents
  the paper's orbits and alternating arcs exactly, for any mission length,
  in a few segments.
- Sampling is closed form and O(log n) per sample; ``sample_array`` does the
  same for a whole vector of times with NumPy, for plotting and scoring.
- Times are mission seconds; frames are the planner's (x east, y north,
  heading counter-clockwise from +x), origin at the convoy centroid at t = 0.
"""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import numpy.typing as npt

from convoy_mav.errors import PlanningError
from convoy_mav.planning.dubins import Pose, Segment, Turn
from convoy_mav.planning.moving import (
    beta_from_speed_ratio,
    gamma_star,
    v_star,
)
from convoy_mav.planning.stationary import coverage_per_uav, min_uavs, orbit_cycle
from convoy_mav.values import value

__all__ = [
    "MovingDetails",
    "Plan",
    "PlanRequest",
    "Sample",
    "SampleArray",
    "StationaryDetails",
    "Trajectory",
    "VehiclePlan",
    "make_plan",
    "min_horizontal_separation",
]

FloatArray = npt.NDArray[np.float64]
Case = Literal["trivial", "stationary", "moving"]

#: Largest position jump tolerated where one segment hands over to the next.
_CONTINUITY_TOLERANCE = 1e-6


@value
class Sample:
    """A vehicle's planned state at one instant."""

    t: float
    x: float
    y: float
    heading: float
    vx: float
    vy: float
    turn_rate: float

    @property
    def speed(self) -> float:
        """Ground speed along the plan, m/s."""
        return math.hypot(self.vx, self.vy)


@dataclass(frozen=True, slots=True)
class SampleArray:
    """Planned states at many instants (one array entry per time)."""

    t: FloatArray
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    vx: FloatArray
    vy: FloatArray
    turn_rate: FloatArray


def _check_chain(segments: tuple[Segment, ...], what: str) -> None:
    for before, after in itertools.pairwise(segments):
        end = before.end
        gap = math.hypot(end.x - after.start.x, end.y - after.start.y)
        if gap > _CONTINUITY_TOLERANCE * max(1.0, before.radius):
            raise PlanningError(f"{what}: segments are not continuous (gap {gap:.3g} m)")


@dataclass(frozen=True)
class Trajectory:
    """Lead-in segments, then ``cycle`` repeated forever with ``drift`` per lap.

    Before ``t_start`` a trajectory without lead-in extends its cycle backwards
    (the UAV was already flying the pattern); one with a lead-in holds its
    first pose.

    Attributes:
        t_start: Mission time at which the first segment begins.
        cycle: Segments of one lap (at least one, total duration > 0).
        lead_in: Segments flown once before the first lap.
        drift: (dx, dy) by which each lap is translated from the previous one.
    """

    t_start: float
    cycle: tuple[Segment, ...]
    lead_in: tuple[Segment, ...] = ()
    drift: tuple[float, float] = (0.0, 0.0)
    _lead_times: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _cycle_times: tuple[float, ...] = field(init=False, repr=False, compare=False)
    _arrays: dict[str, FloatArray] = field(init=False, repr=False, compare=False)
    _lead_arrays: dict[str, FloatArray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not self.cycle:
            raise PlanningError("a trajectory needs at least one cycle segment")
        chain = self.lead_in + self.cycle
        _check_chain(chain, "trajectory")
        end = self.cycle[-1].end
        first = self.cycle[0].start
        gap = math.hypot(end.x - first.x - self.drift[0], end.y - first.y - self.drift[1])
        if gap > _CONTINUITY_TOLERANCE * max(1.0, self.cycle[0].radius):
            raise PlanningError(f"trajectory cycle does not close up to its drift (gap {gap:.3g})")
        lead_times = [0.0]
        for seg in self.lead_in:
            lead_times.append(lead_times[-1] + seg.duration)
        cycle_times = [0.0]
        for seg in self.cycle:
            cycle_times.append(cycle_times[-1] + seg.duration)
        if cycle_times[-1] <= 0.0:
            raise PlanningError("trajectory cycle has zero duration")
        object.__setattr__(self, "_lead_times", tuple(lead_times))
        object.__setattr__(self, "_cycle_times", tuple(cycle_times))
        object.__setattr__(self, "_arrays", _segment_arrays(self.cycle, cycle_times))
        object.__setattr__(self, "_lead_arrays", _segment_arrays(self.lead_in, lead_times))

    @property
    def period(self) -> float:
        """Duration of one lap of the cycle, seconds."""
        return self._cycle_times[-1]

    @property
    def cycle_start(self) -> float:
        """Mission time at which the first lap begins (after the lead-in)."""
        return self.t_start + self._lead_times[-1]

    def sample(self, t: float) -> Sample:
        """The planned state at mission time ``t``."""
        if self.lead_in and t < self.cycle_start:
            tau = max(0.0, t - self.t_start)
            i = min(bisect.bisect_right(self._lead_times, tau) - 1, len(self.lead_in) - 1)
            return _sample_segment(self.lead_in[i], t, tau - self._lead_times[i], 0.0, 0.0)
        lap, tau = divmod(t - self.cycle_start, self.period)
        i = min(bisect.bisect_right(self._cycle_times, tau) - 1, len(self.cycle) - 1)
        dx, dy = lap * self.drift[0], lap * self.drift[1]
        return _sample_segment(self.cycle[i], t, tau - self._cycle_times[i], dx, dy)

    def segments_between(self, t0: float, t1: float) -> tuple[Segment, ...]:
        """The path from ``t0`` to ``t1`` as segments (cut where the span cuts them;
        laps translated by their drift): what a re-plan keeps flying before its new
        legs begin. A lead-in's pose held before ``t_start`` is no motion: the
        segments then begin at ``t_start``."""
        out: list[Segment] = []

        def cut(seg: Segment, begins: float, dx: float, dy: float) -> None:
            lo, hi = max(t0, begins), min(t1, begins + seg.duration)
            if hi > lo:
                pose = seg.at(lo - begins).translated(dx, dy)
                out.append(Segment(pose, seg.turn, seg.radius, seg.speed, hi - lo))

        for seg, into in zip(self.lead_in, self._lead_times, strict=False):
            cut(seg, self.t_start + into, 0.0, 0.0)
        lap = math.floor((t0 - self.cycle_start) / self.period)
        if self.lead_in:
            lap = max(lap, 0)
        while (begins := self.cycle_start + lap * self.period) < t1:
            dx, dy = lap * self.drift[0], lap * self.drift[1]
            for seg, into in zip(self.cycle, self._cycle_times, strict=False):
                cut(seg, begins + into, dx, dy)
            lap += 1
        return tuple(out)

    def positions(self, times: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """The planned positions at every time of ``times`` (``sample_array``'s x and y,
        without the velocities: what a coverage check asks, many times a re-plan)."""
        _, x, y, _, _, _ = self._states_at(times)
        return x, y

    def sample_array(self, times: npt.ArrayLike) -> SampleArray:
        """The planned states at every time of ``times`` (vectorised ``sample``)."""
        t, x, y, heading, speed, rate = self._states_at(times)
        return SampleArray(t, x, y, heading, speed * np.cos(heading), speed * np.sin(heading), rate)

    def _states_at(
        self, times: npt.ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        t = np.asarray(times, dtype=np.float64)
        lap = np.floor((t - self.cycle_start) / self.period)
        tau = (t - self.cycle_start) - lap * self.period
        x, y, heading, speed, rate = _states(self._arrays, tau)
        x = x + lap * self.drift[0]
        y = y + lap * self.drift[1]
        if self.lead_in:
            lead = t < self.cycle_start
            if lead.any():
                tau_in = np.maximum(t[lead] - self.t_start, 0.0)
                lx, ly, lh, lv, lr = _states(self._lead_arrays, tau_in)
                x[lead], y[lead], heading[lead], speed[lead], rate[lead] = lx, ly, lh, lv, lr
        return t, x, y, heading, speed, rate


def chain_positions(
    segments: tuple[Segment, ...], taus: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Positions ``taus`` seconds into a chain of segments (past its end, on its last)."""
    times = list(itertools.accumulate((seg.duration for seg in segments), initial=0.0))
    x, y, _, _, _ = _states(_segment_arrays(segments, times), taus)
    return x, y


def _states(
    a: dict[str, FloatArray], tau: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Position, heading, speed and turn rate ``tau`` seconds into a chain of segments
    (``_segment_arrays``); past its end, on its last segment."""
    idx = np.clip(np.searchsorted(a["t0"], tau, side="right") - 1, 0, len(a["t0"]) - 1)
    dt = tau - a["t0"][idx]
    turn = a["turn"][idx]
    h0 = a["h0"][idx]
    rate = a["rate"][idx]
    heading = h0 + rate * dt
    k = np.where(turn != 0.0, turn * a["radius"][idx], 0.0)
    straight = a["speed"][idx] * dt
    is_arc = turn != 0.0
    x = a["x0"][idx] + np.where(is_arc, k * (np.sin(heading) - np.sin(h0)), straight * np.cos(h0))
    y = a["y0"][idx] + np.where(is_arc, -k * (np.cos(heading) - np.cos(h0)), straight * np.sin(h0))
    return x, y, heading, a["speed"][idx].copy(), rate.copy()


def _segment_arrays(cycle: tuple[Segment, ...], times: list[float]) -> dict[str, FloatArray]:
    return {
        "t0": np.array(times[:-1], dtype=np.float64),
        "x0": np.array([s.start.x for s in cycle], dtype=np.float64),
        "y0": np.array([s.start.y for s in cycle], dtype=np.float64),
        "h0": np.array([s.start.heading for s in cycle], dtype=np.float64),
        "turn": np.array([float(s.turn) for s in cycle], dtype=np.float64),
        "radius": np.array([s.radius for s in cycle], dtype=np.float64),
        "speed": np.array([s.speed for s in cycle], dtype=np.float64),
        "rate": np.array([s.turn_rate for s in cycle], dtype=np.float64),
    }


def _sample_segment(seg: Segment, t: float, tau: float, dx: float, dy: float) -> Sample:
    x, y, heading = seg.state(tau)
    v = seg.speed
    return Sample(
        t, x + dx, y + dy, heading, v * math.cos(heading), v * math.sin(heading), seg.turn_rate
    )


@dataclass(frozen=True, slots=True)
class VehiclePlan:
    """One UAV's share of the plan: its phase and its trajectory."""

    index: int
    phase_s: float
    trajectory: Trajectory

    def sample(self, t: float) -> Sample:
        """The planned state at mission time ``t``."""
        return self.trajectory.sample(t)


@dataclass(frozen=True, slots=True)
class StationaryDetails:
    """Numbers of the stationary case (Theorem 3.5, Corollary 3.7)."""

    entry_heading_offset_rad: float  # asin(r/R), eq. (37)
    orbit_period_s: float  # 2 pi R / V
    time_inside_s: float  # 2 R asin(r/R) / V
    entry_times_s: tuple[float, ...]  # 2 pi R i / (N V)


@dataclass(frozen=True, slots=True)
class MovingDetails:
    """Numbers of the moving case (Lemma 4.1, Theorem 4.2, Corollary 4.3)."""

    speed_ratio: float  # V_G / V
    beta_rad: float  # sin(beta)/beta = V_G / V
    v_star: float  # eq. (42), as a ratio of UAV speed
    gamma_star_rad: float | None  # d(gamma*/2) = r; None when one UAV suffices
    meet_period_s: float  # 2 R beta / V: time between two meetings with the convoy
    phase_offsets_s: tuple[float, ...]


@dataclass(frozen=True, slots=True)
class PlanRequest:
    """What the planner is asked: geometry, speeds and (optionally) a UAV count.

    Attributes:
        turn_radius: Minimum UAV turn radius R, metres.
        sensor_radius: Radius r of the disk the camera sees, metres.
        uav_speed: UAV airspeed V, m/s.
        convoy_speed: Convoy speed V_G, m/s (0: stationary).
        convoy_heading: Convoy course in the planner frame (rad, CCW from +x/east).
        uavs: Number of UAVs to plan for; None plans the minimum.
    """

    turn_radius: float
    sensor_radius: float
    uav_speed: float = 1.0
    convoy_speed: float = 0.0
    convoy_heading: float = 0.0
    uavs: int | None = None

    def __post_init__(self) -> None:
        for name in ("turn_radius", "sensor_radius", "uav_speed"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0.0):
                raise PlanningError(f"{name} must be a positive finite number, got {value!r}")
        if not (math.isfinite(self.convoy_speed) and self.convoy_speed >= 0.0):
            raise PlanningError(f"convoy_speed must be finite and >= 0, got {self.convoy_speed!r}")
        if not math.isfinite(self.convoy_heading):
            raise PlanningError(f"convoy_heading must be finite, got {self.convoy_heading!r}")
        if self.uavs is not None and self.uavs < 1:
            raise PlanningError(f"uavs must be at least 1, got {self.uavs!r}")
        if self.convoy_speed >= self.uav_speed:
            raise PlanningError(
                f"convoy speed {self.convoy_speed:g} m/s is not below the UAV speed "
                f"{self.uav_speed:g} m/s: the UAVs cannot keep up (Section IV needs V_G < V)"
            )


@dataclass(frozen=True, slots=True)
class Plan:
    """The whole mission plan: the case, the paper's numbers and every UAV's path.

    Attributes:
        request: What was asked.
        case: ``"trivial"`` (R <= r), ``"stationary"`` or ``"moving"``.
        min_uavs: The paper's minimum UAV count for perpetual protection.
        coverage_per_uav: Fraction of time one UAV sees the convoy.
        predicted_coverage: Fraction of time at least one of the planned UAVs does.
        vehicles: One ``VehiclePlan`` per UAV.
        details: Case-specific numbers (None in the trivial case).
    """

    request: PlanRequest
    case: Case
    min_uavs: int
    coverage_per_uav: float
    predicted_coverage: float
    vehicles: tuple[VehiclePlan, ...]
    details: StationaryDetails | MovingDetails | None

    @property
    def convoy_velocity(self) -> tuple[float, float]:
        """Convoy velocity (vx, vy) in the planner frame, m/s."""
        v, h = self.request.convoy_speed, self.request.convoy_heading
        return v * math.cos(h), v * math.sin(h)

    def convoy_position(self, t: float) -> tuple[float, float]:
        """Where the planner expects the convoy centroid at mission time ``t``."""
        vx, vy = self.convoy_velocity
        return vx * t, vy * t


def min_horizontal_separation(plan: Plan, samples_per_period: int = 2000) -> float:
    """Smallest horizontal distance between any two planned UAVs over one period, metres.

    Sampled (not closed form) over the longest vehicle period; UAVs are meant
    to be stacked at distinct altitudes as well, so this is a figure for the
    operator, not a constraint of the plan.
    """
    if len(plan.vehicles) < 2:
        return math.inf
    period = max(v.trajectory.period for v in plan.vehicles)
    ts = np.linspace(0.0, 2.0 * period, 2 * samples_per_period, endpoint=False)
    xy = [v.trajectory.sample_array(ts) for v in plan.vehicles]
    best = math.inf
    for i, a in enumerate(xy):
        for b in xy[i + 1 :]:
            best = min(best, float(np.min(np.hypot(a.x - b.x, a.y - b.y))))
    return best


def _union_fraction(n: int, per_uav: float) -> float:
    """Covered fraction of n evenly phased windows each ``per_uav`` of the period."""
    return min(1.0, n * per_uav)


def _plan_trivial(req: PlanRequest) -> Plan:
    """R <= r: orbit the centroid at radius R; every UAV always sees the convoy."""
    n = req.uavs or 1
    R, V = req.turn_radius, req.uav_speed
    period = 2.0 * math.pi * R / V
    vehicles = []
    for i in range(n):
        angle = 2.0 * math.pi * i / n
        start = Pose(R * math.cos(angle), R * math.sin(angle), angle + math.pi / 2.0)
        traj = Trajectory(0.0, (Segment(start, Turn.LEFT, R, V, period),))
        vehicles.append(VehiclePlan(i, period * i / n, traj))
    return Plan(req, "trivial", 1, 1.0, 1.0, tuple(vehicles), None)


def _plan_stationary(req: PlanRequest) -> Plan:
    """Optimal convoy-protection orbits, evenly phased (Theorem 3.5, Corollary 3.7).

    UAV i enters the convoy circle at ``2 pi R i / (N V)`` on the clockwise
    optimal orbit rotated by ``-2 pi i / N`` about the centroid: every UAV has
    its own circle and entry direction (the convoy is seen from all sides),
    and because the fan turns the same way as the orbits, consecutive UAVs
    trail each other almost as far apart as on one shared circle (measured:
    0.195 R vs 0.196 R for R/r = 10, 0.88 R vs 1.18 R for R/r = 1.5).
    """
    R, r, V = req.turn_radius, req.sensor_radius, req.uav_speed
    n_min = min_uavs(R, r)
    n = req.uavs or n_min
    a = math.asin(r / R)
    period = 2.0 * math.pi * R / V
    entry_times = tuple(period * i / n for i in range(n))
    vehicles = []
    for i, t_i in enumerate(entry_times):
        cycle = orbit_cycle(R, r, V, -2.0 * math.pi * i / n, Turn.RIGHT)
        vehicles.append(VehiclePlan(i, t_i, Trajectory(t_i, cycle)))
    per_uav = coverage_per_uav(R, r)
    details = StationaryDetails(a, period, 2.0 * R * a / V, entry_times)
    return Plan(
        req, "stationary", n_min, per_uav, _union_fraction(n, per_uav), tuple(vehicles), details
    )


def _plan_moving(req: PlanRequest) -> Plan:
    """Alternating L/R arcs of angle 2 beta meeting the convoy (Section IV).

    UAV 0 starts on the convoy at t = 0 with heading ``phi - beta`` (Lemma 4.1)
    and turns left first; UAV i is the same pattern delayed by
    ``i T / N`` (T the meet period) and shifted along the convoy's line, so it
    meets the convoy at ``i T / N + k T`` and the N covered windows of length
    ``2 R gamma* / V`` tile every meet period (Corollary 4.3, Fig. 10).
    """
    R, r, V = req.turn_radius, req.sensor_radius, req.uav_speed
    ratio = req.convoy_speed / V
    beta = beta_from_speed_ratio(ratio)
    g = gamma_star(beta, R, r)
    n_min = 1 if g is None else _ceil_ratio(beta / g)
    n = req.uavs or n_min
    meet = 2.0 * R * beta / V
    phi = req.convoy_heading
    ux, uy = math.cos(phi), math.sin(phi)
    vg = req.convoy_speed
    drift = (2.0 * meet * vg * ux, 2.0 * meet * vg * uy)
    offsets = tuple(meet * i / n for i in range(n))
    vehicles = []
    for i, t_i in enumerate(offsets):
        start = Pose(vg * t_i * ux, vg * t_i * uy, phi - beta)
        left = Segment(start, Turn.LEFT, R, V, meet)
        right = Segment(left.end, Turn.RIGHT, R, V, meet)
        vehicles.append(VehiclePlan(i, t_i, Trajectory(t_i, (left, right), drift=drift)))
    per_uav = 1.0 if g is None else g / beta
    details = MovingDetails(ratio, beta, v_star(R, r), g, meet, offsets)
    return Plan(
        req, "moving", n_min, per_uav, _union_fraction(n, per_uav), tuple(vehicles), details
    )


def _ceil_ratio(ratio: float) -> int:
    nearest = round(ratio)
    return nearest if abs(ratio - nearest) < 1e-9 else math.ceil(ratio)


def make_plan(request: PlanRequest) -> Plan:
    """Plan a mission: pick the paper's case and build every UAV's trajectory.

    Raises:
        PlanningError: If the request has no plan (bad numbers, convoy too fast).
    """
    if request.convoy_speed > 0.0:
        return _plan_moving(request)
    if request.turn_radius <= request.sensor_radius:
        return _plan_trivial(request)
    return _plan_stationary(request)
