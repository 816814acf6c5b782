"""Plan x time -> setpoint: the planner-to-mission frame conversion, exactly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convoy_mav.planning import PlanRequest, Pose, Segment, Trajectory, Turn, make_plan
from convoy_mav.schedule import (
    mission_to_planner,
    planner_to_mission,
    position_at,
    setpoint_at,
    setpoint_on,
    yaw_to_heading,
)
from convoy_mav.types import Setpoint

R, r, V = 150.0, 100.0, 18.0
ORIGIN = (1000.0, 2000.0)  # mission (north, east) of the planner origin


def test_stationary_entry_matches_hand_computed_values() -> None:
    # UAV 0 of the stationary plan starts at the optimal entry state of eq. (37):
    # planner (x, y, heading) = (-r, 0, asin(r/R)), turning right on radius R.
    plan = make_plan(PlanRequest(R, r, V))
    a = math.asin(r / R)
    sp = setpoint_at(plan, 0, 50.0, plan_origin=ORIGIN, plan_t0=50.0, down=-120.0)
    assert sp.t == 50.0
    assert sp.north == pytest.approx(1000.0, abs=1e-9)  # origin north + y (0)
    assert sp.east == pytest.approx(1900.0, abs=1e-9)  # origin east + x (-100)
    assert (sp.down, sp.vd) == (-120.0, 0.0)
    assert sp.vn == pytest.approx(V * math.sin(a))  # vn = vy = 12
    assert sp.vn == pytest.approx(12.0)
    assert sp.ve == pytest.approx(V * math.cos(a))  # ve = vx
    assert sp.yaw == pytest.approx(math.pi / 2 - a)
    assert sp.yaw_rate == pytest.approx(V / R)  # right turn: clockwise, positive in NED
    assert sp.clockwise is True
    assert sp.radius == pytest.approx(R)
    # Centre of a right turn lies R to the right of the heading: (x + R sin h, y - R cos h)
    # = (-100 + 150 * 2/3, -150 * sqrt(5)/3) = (0, -111.80...) in the planner frame.
    assert sp.center is not None
    assert sp.center[0] == pytest.approx(1000.0 - 50.0 * math.sqrt(5.0))
    assert sp.center[1] == pytest.approx(2000.0, abs=1e-9)
    assert not sp.hold


def test_straight_and_left_segments() -> None:
    north = Segment(Pose(10.0, 20.0, math.pi / 2), Turn.STRAIGHT, R, V, 10.0)
    left = Segment(north.end, Turn.LEFT, R, V, 5.0)
    back = Segment(left.end, Turn.RIGHT, R, V, 5.0)
    traj = Trajectory(0.0, (north, left, back), drift=(back.end.x - 10.0, back.end.y - 20.0))
    sp = setpoint_on(traj, 3.0, plan_origin=(0.0, 0.0), plan_t0=1.0, down=-5.0)
    # Flying due north in the planner frame: yaw 0, vn = V, no arc.
    assert (sp.north, sp.east) == pytest.approx((20.0 + 2.0 * V, 10.0))
    assert (sp.vn, sp.ve) == pytest.approx((V, 0.0), abs=1e-12)
    assert sp.yaw == pytest.approx(0.0, abs=1e-12)
    assert (sp.yaw_rate, sp.center, sp.radius) == (0.0, None, 0.0)
    # Start of the left arc: counter-clockwise, centre R to the west (planner -x).
    sp = setpoint_on(traj, 11.0, plan_origin=(0.0, 0.0), plan_t0=1.0, down=-5.0)
    assert sp.clockwise is False
    assert sp.yaw_rate == pytest.approx(-V / R)
    assert sp.center == pytest.approx((20.0 + 10.0 * V, 10.0 - R))
    assert sp.radius == pytest.approx(R)


def test_yaw_conversion_is_its_own_inverse_and_wrapped() -> None:
    for heading in np.linspace(-3 * math.pi, 3 * math.pi, 37):
        yaw = yaw_to_heading(float(heading))
        assert -math.pi < yaw <= math.pi
        back = yaw_to_heading(yaw)
        assert math.cos(back - heading) == pytest.approx(1.0)
    assert yaw_to_heading(0.0) == pytest.approx(math.pi / 2)  # east (planner 0) -> yaw 90 deg
    assert yaw_to_heading(math.pi / 2) == pytest.approx(0.0)  # north -> yaw 0
    pose = mission_to_planner(1030.0, 1990.0, 0.25, ORIGIN)
    assert (pose.x, pose.y) == pytest.approx((-10.0, 30.0))
    assert planner_to_mission(pose.x, pose.y, ORIGIN) == pytest.approx((1030.0, 1990.0))


@pytest.mark.parametrize(
    "request_",
    [PlanRequest(R, r, V), PlanRequest(R, r, V, convoy_speed=6.0, convoy_heading=0.8)],
    ids=["stationary", "moving"],
)
def test_velocity_and_yaw_rate_integrate_to_position_and_yaw(request_: PlanRequest) -> None:
    plan = make_plan(request_)
    dt = 0.005
    ts = np.arange(100.0, 100.0 + 2.2 * plan.vehicles[1].trajectory.period, dt)
    sps = [setpoint_at(plan, 1, float(t), plan_origin=ORIGIN, plan_t0=37.0, down=0.0) for t in ts]
    n = np.array([s.north for s in sps])
    e = np.array([s.east for s in sps])
    vn = np.array([s.vn for s in sps])
    ve = np.array([s.ve for s in sps])
    yaw = np.unwrap(np.array([s.yaw for s in sps]))
    rate = np.array([s.yaw_rate for s in sps])
    # trapezoidal integration of the feed-forward reproduces the positions
    assert np.max(np.abs(n[1:] - n[:-1] - 0.5 * dt * (vn[1:] + vn[:-1]))) < 1e-3
    assert np.max(np.abs(e[1:] - e[:-1] - 0.5 * dt * (ve[1:] + ve[:-1]))) < 1e-3
    assert abs((n[-1] - n[0]) - np.trapezoid(vn, dx=dt)) < 0.05
    assert abs((e[-1] - e[0]) - np.trapezoid(ve, dx=dt)) < 0.05
    # yaw is the course of the velocity, and the yaw rate integrates to it
    assert np.allclose(np.cos(yaw), vn / V) and np.allclose(np.sin(yaw), ve / V)
    assert abs((yaw[-1] - yaw[0]) - np.trapezoid(rate, dx=dt)) < 1e-2
    # the arc centre is at the radius from the UAV, on the side it turns to
    for s in sps[::97]:
        assert s.center is not None
        assert math.hypot(s.north - s.center[0], s.east - s.center[1]) == pytest.approx(R)
        to_center = math.atan2(s.center[1] - s.east, s.center[0] - s.north)
        side = math.sin(to_center - s.yaw)  # > 0: centre to the right (clockwise)
        assert (side > 0) == s.clockwise == (s.yaw_rate > 0)


def test_setpoint_at_is_setpoint_on_the_vehicle_trajectory() -> None:
    plan = make_plan(PlanRequest(R, r, V, uavs=3))
    for i in range(3):
        a = setpoint_at(plan, i, 12.5, plan_origin=ORIGIN, plan_t0=2.5, down=-1.0)
        b = setpoint_on(
            plan.vehicles[i].trajectory, 12.5, plan_origin=ORIGIN, plan_t0=2.5, down=-1.0
        )
        assert a == b
        s = plan.vehicles[i].sample(10.0)
        assert (a.north, a.east) == pytest.approx((ORIGIN[0] + s.y, ORIGIN[1] + s.x))
    with pytest.raises(IndexError):
        setpoint_at(plan, 3, 0.0, plan_origin=ORIGIN, plan_t0=0.0, down=0.0)


@pytest.mark.parametrize(
    "request_",
    [
        PlanRequest(R, r, V, uavs=3),
        PlanRequest(R, r, V, convoy_speed=6.0, convoy_heading=0.8),
        PlanRequest(R, r, V, convoy_speed=14.0, convoy_heading=-2.0),
    ],
    ids=["stationary", "moving", "moving-fast"],
)
def test_position_at_moves_a_setpoint_along_its_own_arc(request_: PlanRequest) -> None:
    """Scoring a position update from the last setpoint sent equals sampling the plan."""
    plan = make_plan(request_)
    period = plan.vehicles[0].trajectory.period
    errors = []
    for t in np.linspace(50.0, 50.0 + 2.0 * period, 400):
        for dt in (-0.05, -0.01, 0.02, 0.05, 0.25):
            sent = setpoint_at(plan, 0, float(t), plan_origin=ORIGIN, plan_t0=3.0, down=0.0)
            truth = setpoint_at(plan, 0, float(t) + dt, plan_origin=ORIGIN, plan_t0=3.0, down=0.0)
            north, east = position_at(sent, float(t) + dt)
            errors.append(math.hypot(north - truth.north, east - truth.east))
    # exact on a segment; across a boundary v^2 |dk| dt^2 / 2 (<= 0.2 m at dt = 0.25 s)
    assert float(np.median(errors)) < 1e-9
    assert max(errors) < 0.5 * V**2 * (2.0 / R) * 0.25**2 + 1e-9


def test_position_at_on_a_straight_and_when_holding() -> None:
    straight = Setpoint(10.0, 5.0, 7.0, -50.0, 3.0, -4.0, 0.0, 0.0, 0.0)
    assert position_at(straight, 12.0) == pytest.approx((11.0, -1.0))
    hold = Setpoint(10.0, 5.0, 7.0, -50.0, 0.0, 0.0, 0.0, 1.0, 0.0, hold=True)
    assert position_at(hold, 99.0) == (5.0, 7.0)
