"""Pure planning core: the paper's optimal convoy-protection geometry.

Nothing in this package touches sockets, clocks or asyncio; every function
takes its inputs as values and returns values (frozen dataclasses).
"""

from __future__ import annotations

from convoy_mav.planning.dubins import (
    DubinsPath,
    Pose,
    Segment,
    Turn,
    dubins_shortest_path,
    wrap_angle,
)
from convoy_mav.planning.moving import (
    beta_from_speed_ratio,
    coverage_fraction_moving,
    gamma_star,
    max_separation,
    min_uavs_moving,
    separation,
    v_star,
)
from convoy_mav.planning.plan import (
    MovingDetails,
    Plan,
    PlanRequest,
    Sample,
    SampleArray,
    StationaryDetails,
    Trajectory,
    VehiclePlan,
    make_plan,
    min_horizontal_separation,
)
from convoy_mav.planning.stationary import (
    EntrySolution,
    check_entry,
    coverage_per_uav,
    min_uavs,
    optimal_entry_states,
    optimal_path_from_entry,
    orbit_cycle,
    time_inside_optimal,
)

__all__ = [
    "DubinsPath",
    "EntrySolution",
    "MovingDetails",
    "Plan",
    "PlanRequest",
    "Pose",
    "Sample",
    "SampleArray",
    "Segment",
    "StationaryDetails",
    "Trajectory",
    "Turn",
    "VehiclePlan",
    "beta_from_speed_ratio",
    "check_entry",
    "coverage_fraction_moving",
    "coverage_per_uav",
    "dubins_shortest_path",
    "gamma_star",
    "make_plan",
    "max_separation",
    "min_horizontal_separation",
    "min_uavs",
    "min_uavs_moving",
    "optimal_entry_states",
    "optimal_path_from_entry",
    "orbit_cycle",
    "separation",
    "time_inside_optimal",
    "v_star",
    "wrap_angle",
]
