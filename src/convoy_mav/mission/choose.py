"""Which planner flies a mission, and the road it is told about.

- ``road`` (``RoadMission``): the paper's pattern laid along the road, flown
  as flyable meet-to-meet legs. It needs the road's count of UAVs
  (``road_fleet``): the stationary minimum of Theorem 3.5 plus one, the spare
  turn that lets the pattern follow a convoy's curves and stops.
- ``paper`` (``Mission``): the paper's plans for a parked or straight-line
  convoy, re-planned and re-joined when the convoy changes course or speed:
  optimal for the paper's cases with its minimum count, and what a fleet too
  small for the road flies.
- ``auto`` picks ``road`` when the fleet has the road's count, else ``paper``.
"""

from __future__ import annotations

from typing import Literal

from convoy_mav.config import Planner
from convoy_mav.planning.stationary import min_uavs

__all__ = ["choose_planner", "road_fleet"]


def road_fleet(turn_radius: float, sensor_radius: float) -> int:
    """UAVs the road planner flies with: the stationary minimum (Theorem 3.5) + 1."""
    if turn_radius <= sensor_radius:
        return 1
    return min_uavs(turn_radius, sensor_radius) + 1


def choose_planner(
    planner: Planner, uavs: int, turn_radius: float, sensor_radius: float
) -> tuple[Literal["road", "paper"], str]:
    """The planner to fly and why (a sentence for the operator)."""
    need = road_fleet(turn_radius, sensor_radius)
    if planner == "road":
        why = "asked for" if uavs >= need else f"asked for, with {uavs} of the {need} UAVs it needs"
        return "road", why
    if planner == "paper":
        return "paper", "asked for"
    if uavs >= need:
        return "road", f"{uavs} UAVs: at least the road's {need} (stationary minimum + 1)"
    return "paper", (
        f"{uavs} UAVs: the road pattern needs {need} (stationary minimum + 1); "
        "flying the paper's plans, re-planned on every change of the convoy"
    )
