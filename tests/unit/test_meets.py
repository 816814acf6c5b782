"""Meet-to-meet legs: on time when the band allows, else at the earliest later meeting."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.planning.dubins import Pose, Turn, wrap_angle
from convoy_mav.planning.meets import (
    LegLimits,
    _candidate_segments,
    _candidates,
    _leg_to,
    _positions,
    _steer,
    plan_leg,
    plan_leg_to_pose,
)
from convoy_mav.planning.plan import chain_positions

FloatArray = npt.NDArray[np.float64]
R, V = 150.0, 18.0
LIMITS = LegLimits(R, V, (0.85, 1.15))


def _moving_point(x0: float, y0: float, vx: float, vy: float):  # type: ignore[no-untyped-def]
    def where(times: FloatArray) -> tuple[FloatArray, FloatArray]:
        t = np.asarray(times, dtype=np.float64)
        return x0 + vx * t, y0 + vy * t

    return where


def _flyable(leg) -> None:  # type: ignore[no-untyped-def]
    lo, hi = LIMITS.speeds
    for seg in leg.segments:
        assert lo - 1e-9 <= seg.speed <= hi + 1e-9
        if seg.turn != Turn.STRAIGHT:
            assert seg.radius >= R - 1e-6


def test_a_reachable_meeting_is_met_on_time_at_the_pattern() -> None:
    where = _moving_point(400.0, 100.0, 8.0, 0.0)
    leg = plan_leg(Pose(0.0, 0.0, 0.0), 0.0, where, 40.0, LIMITS)
    assert leg.on_time and leg.late_s == 0.0
    assert leg.t_end == pytest.approx(40.0, abs=0.05)
    end = leg.end
    x, y = where(np.array([40.0]))
    assert math.hypot(end.x - x[0], end.y - y[0]) < 1.0
    _flyable(leg)


def test_a_late_leg_meets_at_the_earliest_feasible_later_time() -> None:
    # The meeting is 10 s away, behind the UAV: no flyable leg makes it.
    where = _moving_point(-100.0, 0.0, -8.0, 0.0)
    pose = Pose(0.0, 0.0, 0.0)
    leg = plan_leg(pose, 0.0, where, 10.0, LIMITS)
    assert leg.on_time and leg.late_s > 0.0
    assert leg.t_end == pytest.approx(10.0 + leg.late_s, abs=0.05)
    x, y = where(np.array([leg.t_end]))
    assert math.hypot(leg.end.x - x[0], leg.end.y - y[0]) < 1.0
    _flyable(leg)
    # One scan step earlier no candidate fits the band: it is the earliest.
    lo, hi = LIMITS.speeds
    tau = leg.t_end - LIMITS.late_step_s
    px, py = where(np.array([tau]))
    _, _, k2, _, total = _candidates(_steer(pose, LIMITS), (float(px[0]), float(py[0])))
    fits = (np.abs(k2) <= 1.0 / R + 1e-12) & (total <= hi * tau) & (total >= lo * tau)
    assert not fits.any()


def test_the_scan_meets_near_the_first_time_a_leg_fits_and_never_after_chasing() -> None:
    # Retargeting to where the pattern is when the leg arrives chases it: each try
    # arrives later. The scan takes (within a few steps) the first time a leg fits.
    pose = Pose(0.0, 0.0, 0.0)
    lo, hi = LIMITS.speeds
    for y0 in (-150.0, 0.0, 50.0, 200.0):
        where = _moving_point(-100.0, y0, -8.0, 3.0)
        leg = plan_leg(pose, 0.0, where, 10.0, LIMITS)
        assert leg.on_time
        first = None
        for tau in np.arange(11.0, 71.0, 1.0).tolist():
            px, py = where(np.array([tau]))
            _, _, k2, _, total = _candidates(_steer(pose, LIMITS), (float(px[0]), float(py[0])))
            if ((np.abs(k2) <= 1.0 / R + 1e-12) & (total <= hi * tau) & (total >= lo * tau)).any():
                first = tau
                break
        assert first is not None and first <= leg.t_end <= first + 3.0
        chased = _leg_to(_steer(pose, LIMITS), 0.0, 10.0, where, LIMITS, 0.0)
        for _ in range(3):
            chased = _leg_to(_steer(pose, LIMITS), 0.0, chased.t_end, where, LIMITS, 0.0)
        if chased.on_time:
            assert leg.t_end <= chased.t_end + LIMITS.late_step_s


@pytest.mark.parametrize(
    ("heading_deg", "t_meet"),
    [(0.0, 30.0), (-60.0, 45.0), (90.0, 45.0), (-120.0, 60.0), (90.0, 60.0), (180.0, 80.0)],
)
def test_a_leg_to_a_pose_meets_the_pattern_on_its_heading_on_time(
    heading_deg: float, t_meet: float
) -> None:
    """Whatever way the UAV flies now, the leg ends on the pattern, going the pattern's way
    there, at the meeting: flyable, one speed inside the band."""
    where = _moving_point(300.0, 200.0, 8.0, 0.0)  # (the pattern's heading: +x)
    pose = Pose(0.0, 0.0, math.radians(heading_deg))
    leg = plan_leg_to_pose(pose, 0.0, where, t_meet, LIMITS)
    assert leg is not None and leg.on_time
    assert leg.t_end == pytest.approx(t_meet, abs=1e-6)
    x, y = where(np.array([t_meet]))
    assert math.hypot(leg.end.x - x[0], leg.end.y - y[0]) < 1e-3
    assert abs(wrap_angle(leg.end.heading)) < 1e-6
    assert all(seg.speed == leg.speed for seg in leg.segments)
    _flyable(leg)


def test_no_leg_to_a_pose_the_band_cannot_reach_in_time() -> None:
    where = _moving_point(2000.0, 0.0, 8.0, 0.0)
    assert plan_leg_to_pose(Pose(0.0, 0.0, 0.0), 0.0, where, 60.0, LIMITS) is None


@given(
    x=st.floats(-500.0, 500.0),
    y=st.floats(-500.0, 500.0),
    heading=st.floats(-math.pi, math.pi),
    gx=st.floats(-900.0, 900.0),
    gy=st.floats(-900.0, 900.0),
    left=st.floats(5.0, 90.0),
)
@settings(max_examples=60, deadline=None)
def test_the_candidates_scored_are_the_legs_built_from_them(
    x: float, y: float, heading: float, gx: float, gy: float, left: float
) -> None:
    # The score's positions (steering part, then the arc from where it ends, in one
    # pass) are where the leg built from the same candidate is: a candidate is
    # judged on the path the UAV would fly.
    pose = Pose(x, y, heading)
    steer = _steer(pose, LIMITS)
    _, _, k2, arc, total = _candidates(steer, (gx, gy))
    rows = np.nonzero(np.abs(k2) <= 1.0 / R + 1e-12)[0][::7]
    speed = np.clip(total[rows] / left, *LIMITS.speeds)
    taus = np.linspace(0.0, left, 9)
    px, py = _positions(steer, rows, k2[rows], speed, taus)
    for j, i in enumerate(rows.tolist()):
        segments = _candidate_segments(steer, i, float(k2[i]), float(arc[i]), float(speed[j]))
        bx, by = chain_positions(segments, taus)
        # 1e-6 m, and what a segment's closed form (its radius times a difference of
        # sines) can hold of an arc of huge radius: a target a hair off the heading.
        tol = 1e-6 + 1e-15 * max(s.radius for s in segments)
        assert np.allclose(px[j], bx, atol=tol) and np.allclose(py[j], by, atol=tol)
