"""The Plan value: cases, phasing, exact sampling and predicted coverage."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.errors import PlanningError
from convoy_mav.planning import (
    MovingDetails,
    Plan,
    PlanRequest,
    Pose,
    Segment,
    StationaryDetails,
    Trajectory,
    Turn,
    make_plan,
    min_horizontal_separation,
)

REQUESTS = [
    PlanRequest(150.0, 100.0, 18.0),
    PlanRequest(300.0, 100.0, 20.0),
    PlanRequest(300.0, 100.0, 20.0, uavs=4),
    PlanRequest(150.0, 100.0, 18.0, convoy_speed=6.0, convoy_heading=0.8),
    PlanRequest(150.0, 100.0, 18.0, convoy_speed=2.0),
    PlanRequest(150.0, 100.0, 18.0, convoy_speed=16.0),
    PlanRequest(400.0, 100.0, 25.0, convoy_speed=5.0, uavs=3),
    PlanRequest(80.0, 100.0, 15.0),
    PlanRequest(80.0, 100.0, 15.0, uavs=3),
]


def _simulated_coverage(plan: Plan, laps: float = 6.0, n: int = 60_000) -> float:
    period = max(v.trajectory.period for v in plan.vehicles)
    ts = np.linspace(0.0, laps * period, n, endpoint=False)
    vx, vy = plan.convoy_velocity
    seen = np.zeros(n, dtype=bool)
    for v in plan.vehicles:
        s = v.trajectory.sample_array(ts)
        seen |= np.hypot(s.x - vx * ts, s.y - vy * ts) <= plan.request.sensor_radius * (1 + 1e-9)
    return float(seen.mean())


@pytest.mark.parametrize(
    "req", REQUESTS, ids=lambda r: f"R{r.turn_radius}-vg{r.convoy_speed}-n{r.uavs}"
)
def test_predicted_coverage_matches_sampled_flight(req: PlanRequest) -> None:
    plan = make_plan(req)
    assert len(plan.vehicles) == (req.uavs or plan.min_uavs)
    assert _simulated_coverage(plan) == pytest.approx(plan.predicted_coverage, abs=2e-3)
    if req.uavs is None:
        assert plan.predicted_coverage == 1.0


@pytest.mark.parametrize("req", REQUESTS[:3], ids=str)
def test_one_uav_fewer_leaves_gaps(req: PlanRequest) -> None:
    full = make_plan(req)
    short = make_plan(
        PlanRequest(req.turn_radius, req.sensor_radius, req.uav_speed, uavs=full.min_uavs - 1)
    )
    assert short.predicted_coverage < 1.0
    assert short.predicted_coverage == pytest.approx((full.min_uavs - 1) * full.coverage_per_uav)
    assert _simulated_coverage(short) == pytest.approx(short.predicted_coverage, abs=2e-3)


def test_stationary_phasing_and_orientations() -> None:
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0))
    assert plan.case == "stationary"
    d = plan.details
    assert isinstance(d, StationaryDetails)
    assert d.entry_heading_offset_rad == pytest.approx(math.asin(100 / 150))
    assert d.orbit_period_s == pytest.approx(2 * math.pi * 150 / 18)
    n = plan.min_uavs
    assert d.entry_times_s == pytest.approx([d.orbit_period_s * i / n for i in range(n)])
    centers = set()
    for v, t_i in zip(plan.vehicles, d.entry_times_s, strict=True):
        # Each UAV is on the convoy circle, heading in, at its entry time.
        s = v.sample(t_i)
        assert math.hypot(s.x, s.y) == pytest.approx(100.0)
        assert (s.x * math.cos(s.heading) + s.y * math.sin(s.heading)) < 0
        cx, cy = v.trajectory.cycle[0].center
        centers.add((round(cx, 6), round(cy, 6)))
    assert len(centers) == n  # distinct orbit orientations
    assert min_horizontal_separation(plan) > 0.5 * 150.0


def test_moving_plan_meets_convoy_periodically() -> None:
    req = PlanRequest(150.0, 100.0, 18.0, convoy_speed=6.0, convoy_heading=0.8)
    plan = make_plan(req)
    d = plan.details
    assert isinstance(d, MovingDetails)
    assert d.meet_period_s == pytest.approx(2 * 150.0 * d.beta_rad / 18.0)
    for v in plan.vehicles:
        # Initial heading phi - beta (Lemma 4.1), first primitive L.
        assert v.trajectory.cycle[0].turn == Turn.LEFT
        assert v.trajectory.cycle[0].start.heading == pytest.approx(0.8 - d.beta_rad)
        for k in range(-2, 6):
            t = v.phase_s + k * d.meet_period_s
            s = v.sample(t)
            cx, cy = plan.convoy_position(t)
            assert math.hypot(s.x - cx, s.y - cy) == pytest.approx(0.0, abs=1e-6)


def test_moving_single_uav_when_fast_enough() -> None:
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0, convoy_speed=16.0))
    assert isinstance(plan.details, MovingDetails)
    assert plan.details.gamma_star_rad is None
    assert plan.min_uavs == 1
    assert plan.coverage_per_uav == 1.0


@settings(max_examples=60, deadline=None)
@given(
    R=st.floats(20.0, 600.0),
    r_frac=st.floats(0.05, 1.5),
    V=st.floats(5.0, 40.0),
    v_frac=st.one_of(st.just(0.0), st.floats(0.02, 0.97)),
    heading=st.floats(-math.pi, math.pi),
)
def test_sampling_is_continuous_at_uav_speed_with_bounded_turn_rate(
    R: float, r_frac: float, V: float, v_frac: float, heading: float
) -> None:
    plan = make_plan(PlanRequest(R, R * r_frac, V, convoy_speed=V * v_frac, convoy_heading=heading))
    limit = V / R
    for v in plan.vehicles[:4]:
        period = v.trajectory.period
        dt = period / 3000.0
        ts = np.arange(-period, 2.5 * period, dt)
        s = v.trajectory.sample_array(ts)
        assert np.allclose(np.hypot(s.vx, s.vy), V)
        assert np.all(np.abs(s.turn_rate) <= limit * (1 + 1e-12))
        steps = np.hypot(np.diff(s.x), np.diff(s.y))
        assert np.all(steps <= V * dt * (1 + 1e-6))  # no jumps, ever
        # heading changes no faster than V/R either
        dh = np.angle(np.exp(1j * np.diff(s.heading)))
        assert np.all(np.abs(dh) <= limit * dt * (1 + 1e-6))


def test_scalar_and_vector_sampling_agree() -> None:
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0, convoy_speed=6.0, convoy_heading=-2.0))
    traj = plan.vehicles[2].trajectory
    ts = np.linspace(-100.0, 500.0, 257)
    arr = traj.sample_array(ts)
    for i, t in enumerate(ts):
        s = traj.sample(float(t))
        assert (s.x, s.y, s.vx, s.vy, s.turn_rate) == pytest.approx(
            (arr.x[i], arr.y[i], arr.vx[i], arr.vy[i], arr.turn_rate[i]), abs=1e-9
        )


def test_trajectory_with_lead_in() -> None:
    lead = (Segment(Pose(-500.0, 0.0, 0.0), Turn.STRAIGHT, 0.0, 10.0, 20.0),)
    orbit = (Segment(Pose(-300.0, 0.0, 0.0), Turn.LEFT, 100.0, 10.0, 2 * math.pi * 10.0),)
    traj = Trajectory(5.0, orbit, lead_in=lead)
    assert traj.cycle_start == 25.0
    assert traj.sample(0.0).x == -500.0  # before the start: hold the first pose
    assert traj.sample(15.0).x == pytest.approx(-400.0)
    assert traj.sample(25.0).x == pytest.approx(-300.0)
    arr = traj.sample_array(np.array([0.0, 15.0, 25.0, 25.0 + 2 * math.pi * 10.0]))
    assert arr.x == pytest.approx([-500.0, -400.0, -300.0, -300.0])


@given(
    st.integers(0, 8),
    st.floats(-300.0, 600.0),
    st.floats(0.0, 400.0),
    st.booleans(),
)
@settings(max_examples=150, deadline=None)
def test_a_span_of_a_trajectory_as_segments_is_the_trajectory(
    index: int, t0: float, span: float, with_lead_in: bool
) -> None:
    # A moving plan's alternating arcs (drift per lap), with a lead-in or without one
    # (then its cycle runs backwards before t_start too).
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0, convoy_speed=6.0, convoy_heading=0.8))
    traj = plan.vehicles[index % len(plan.vehicles)].trajectory
    if with_lead_in:
        first = traj.cycle[0].start
        back = first.translated(-180.0 * math.cos(first.heading), -180.0 * math.sin(first.heading))
        lead = (Segment(back, Turn.STRAIGHT, 0.0, 18.0, 10.0),)
        traj = Trajectory(20.0, traj.cycle, lead_in=lead, drift=traj.drift)
    t1 = t0 + span
    segments = traj.segments_between(t0, t1)
    begins = max(t0, traj.t_start) if with_lead_in else t0
    assert sum(s.duration for s in segments) == pytest.approx(max(t1 - begins, 0.0), abs=1e-6)
    if not segments:
        return
    # Continuous, and where the trajectory is at every instant of the span.
    last = segments[-1]
    drift = (last.end.x - last.start.x, last.end.y - last.start.y)
    kept = Trajectory(begins, (last,), lead_in=segments[:-1], drift=drift)
    ts = np.linspace(begins, t1, 97, endpoint=False)
    got, want = kept.sample_array(ts), traj.sample_array(ts)
    assert np.max(np.hypot(got.x - want.x, got.y - want.y)) < 1e-6
    assert np.max(np.abs(np.angle(np.exp(1j * (got.heading - want.heading))))) < 1e-9
    end, there = last.end, traj.sample(t1)
    assert math.hypot(end.x - there.x, end.y - there.y) < 1e-6


def test_no_span_has_no_segments() -> None:
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0))
    traj = plan.vehicles[0].trajectory
    assert traj.segments_between(10.0, 10.0) == ()
    assert traj.segments_between(10.0, 5.0) == ()


def test_trajectory_rejects_discontinuities() -> None:
    a = Segment(Pose(0.0, 0.0, 0.0), Turn.STRAIGHT, 0.0, 1.0, 10.0)
    b = Segment(Pose(50.0, 0.0, 0.0), Turn.STRAIGHT, 0.0, 1.0, 10.0)
    with pytest.raises(PlanningError, match="continuous"):
        Trajectory(0.0, (a, b), drift=(60.0, 0.0))
    with pytest.raises(PlanningError, match="close"):
        Trajectory(0.0, (a,))


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"turn_radius": 0.0}, "turn_radius"),
        ({"sensor_radius": -1.0}, "sensor_radius"),
        ({"uav_speed": math.inf}, "uav_speed"),
        ({"convoy_speed": 20.0}, "cannot keep up"),
        ({"convoy_speed": math.nan}, "convoy_speed"),
        ({"uavs": 0}, "uavs"),
    ],
)
def test_plan_request_validation(kwargs: dict[str, float], match: str) -> None:
    base: dict[str, float] = {"turn_radius": 150.0, "sensor_radius": 100.0, "uav_speed": 18.0}
    base.update(kwargs)
    with pytest.raises(PlanningError, match=match):
        PlanRequest(**base)  # type: ignore[arg-type]
