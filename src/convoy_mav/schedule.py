"""Plan x mission time -> setpoint: the one place the planner's frame meets the mission's.

Design rules:
- The planner works in x east, y north, headings counter-clockwise from east,
  times from its own zero (``plan_t0``), origin at the convoy at that time.
  The mission frame is NED metres from the mission origin, headings clockwise
  from north, times in mission seconds.  Both are right-handed with z
  pointing opposite ways, so the conversion is a swap plus a sign:

      north = origin_north + y      east = origin_east + x
      vn = vy                       ve = vx
      yaw = wrap(pi/2 - heading)    yaw_rate = -turn_rate

- Arc centre, radius and direction come from the sample itself
  (signed radius ``k = speed / turn_rate``): exact for the plan's arcs and
  for join loiters of any radius, with no look-up of the segment list.
- Pure: no clocks; ``t`` is passed in.
"""

from __future__ import annotations

import math

from convoy_mav.planning.dubins import Pose, wrap_angle
from convoy_mav.planning.plan import Plan, Sample, Trajectory
from convoy_mav.types import Setpoint

__all__ = [
    "POSITION_AT_HORIZON_S",
    "mission_to_planner",
    "planner_to_mission",
    "position_at",
    "sample_to_setpoint",
    "setpoint_at",
    "setpoint_on",
    "yaw_to_heading",
]

Origin = tuple[float, float]

POSITION_AT_HORIZON_S = 0.25
"""Mission s: how far :func:`position_at` is trusted to carry a setpoint sent (a
stalled stream beyond it: sample the plan again). Across a segment boundary the
error at this horizon is at most a few decimetres; at setpoint rates, millimetres."""


def yaw_to_heading(yaw: float) -> float:
    """Mission yaw (rad clockwise from north) to a planner heading (rad CCW from east).

    The map is its own inverse: ``heading_to_yaw(h) == yaw_to_heading(h)``.
    """
    return wrap_angle(math.pi / 2.0 - yaw)


def mission_to_planner(north: float, east: float, yaw: float, plan_origin: Origin) -> Pose:
    """A mission-frame pose as a planner pose relative to ``plan_origin`` (north, east)."""
    return Pose(east - plan_origin[1], north - plan_origin[0], yaw_to_heading(yaw))


def planner_to_mission(x: float, y: float, plan_origin: Origin) -> tuple[float, float]:
    """Planner (x, y) relative to ``plan_origin`` as mission (north, east)."""
    return plan_origin[0] + y, plan_origin[1] + x


def sample_to_setpoint(s: Sample, t: float, *, plan_origin: Origin, down: float) -> Setpoint:
    """Convert one planner sample to a mission setpoint at mission time ``t``.

    Args:
        s: The planned state (planner frame, planner time).
        t: Mission time the setpoint is for.
        plan_origin: Mission (north, east) of the planner origin.
        down: Altitude setpoint, metres down (negative above the origin).
    """
    n0, e0 = plan_origin  # (planner_to_mission, inlined: this runs for every setpoint sent)
    rate = s.turn_rate
    center: tuple[float, float] | None = None
    radius = 0.0
    if rate != 0.0:
        k = s.speed / rate  # signed radius: > 0 turning left (counter-clockwise)
        center = (n0 + s.y + k * math.cos(s.heading), e0 + s.x - k * math.sin(s.heading))
        radius = abs(k)
    return Setpoint(
        t, n0 + s.y, e0 + s.x, down, s.vy, s.vx, 0.0, yaw_to_heading(s.heading), -rate,
        center, radius, rate <= 0.0,
    )  # fmt: skip


def position_at(sp: Setpoint, t: float) -> tuple[float, float]:
    """Where ``sp``'s own arc (or straight) puts the UAV at mission time ``t``: (north, east).

    The arc is the setpoint's centre and turn rate (``yaw_rate``, clockwise
    positive, turns the offset from the centre by ``yaw_rate * dt`` in the
    north-east plane); a straight is its velocity. Exact while ``t`` stays on
    the segment ``sp`` was sampled on; across a segment boundary the error is
    ``v^2 |dk| dt^2 / 2`` (dk the change of curvature), millimetres for the
    tens of milliseconds between setpoints. This is how a position update is
    scored against the plan without sampling the plan again.
    """
    dt = t - sp.t
    center = sp.center
    if center is None or sp.yaw_rate == 0.0:
        return sp.north + sp.vn * dt, sp.east + sp.ve * dt
    a = sp.yaw_rate * dt
    c, s = math.cos(a), math.sin(a)
    dn, de = sp.north - center[0], sp.east - center[1]
    return center[0] + c * dn - s * de, center[1] + s * dn + c * de


def setpoint_on(
    trajectory: Trajectory, t: float, *, plan_origin: Origin, plan_t0: float, down: float
) -> Setpoint:
    """Where a planner-frame trajectory puts the UAV at mission time ``t``.

    ``trajectory`` is in planner time: it is sampled at ``t - plan_t0``.
    """
    s = trajectory.sample(t - plan_t0)
    return sample_to_setpoint(s, t, plan_origin=plan_origin, down=down)


def setpoint_at(
    plan: Plan, index: int, t: float, *, plan_origin: Origin, plan_t0: float, down: float
) -> Setpoint:
    """The setpoint of plan vehicle ``index`` at mission time ``t``.

    Args:
        plan: The plan (planner frame, origin at the convoy at planner time 0).
        index: Vehicle index in ``plan.vehicles``.
        t: Mission time.
        plan_origin: Mission (north, east) of the convoy at ``plan_t0``.
        plan_t0: Mission time of planner time 0.
        down: Altitude setpoint of this UAV, metres down.

    Raises:
        IndexError: If ``index`` is not a vehicle of the plan.
    """
    trajectory = plan.vehicles[index].trajectory
    return setpoint_on(trajectory, t, plan_origin=plan_origin, plan_t0=plan_t0, down=down)
