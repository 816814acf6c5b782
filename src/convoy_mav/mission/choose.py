"""Which planner flies a mission, and the road it is told about.

- ``road`` (``RoadMission``): the paper's pattern laid along the road, flown
  as flyable meet-to-meet legs. It needs the road's count of UAVs
  (``road_fleet``): the stationary minimum of Theorem 3.5 plus one, the spare
  turn that lets the pattern follow a convoy's curves and stops. Without a
  route the road asks for one more: nothing says where the convoy turns, and
  the fleet learns of a corner only as the convoy takes it.
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


def road_fleet(turn_radius: float, sensor_radius: float, *, route: bool = True) -> int:
    """UAVs the road planner flies with: the stationary minimum (Theorem 3.5) + 1, the
    count a convoy that may stop anywhere needs; without a ``route``, + 2.

    Without a route the fleet learns of a corner as the convoy takes it, with
    the pattern laid along the old course; a UAV more covers what that costs.
    Simulation (``benchmarks/road_table.py --no-route-count``: 14 roads of
    ``tracks.roads`` and the recorded drives, each from three start offsets,
    demo aircraft, 2026-11-28): 94.14 %
    with the stationary minimum + 1, 96.56 % with + 2 (paired, +2.42 +- 0.47
    points; hairpins 87 -> 94 %, the recorded drive 90 -> 94 %); + 3 gave 0.25
    points more on twelve of them. A one-corner road at 60 deg, sixteen phases
    of the formation (the demo's ``turning``): mean 99.63 -> 99.86 %, worst
    99.19 -> 99.64 %. With a route the corners are foreseen, and + 1 is what
    the road's bar allows.
    """
    if turn_radius <= sensor_radius:
        return 1
    return min_uavs(turn_radius, sensor_radius) + (1 if route else 2)


def choose_planner(
    planner: Planner, uavs: int, turn_radius: float, sensor_radius: float, *, route: bool = True
) -> tuple[Literal["road", "paper"], str]:
    """The planner to fly and why (a sentence for the operator); ``route``: whether the
    convoy's route is known at the start (without, the road asks for one UAV more)."""
    need = road_fleet(turn_radius, sensor_radius)
    advice = ""
    if not route and uavs < (roadless := road_fleet(turn_radius, sensor_radius, route=False)):
        advice = (
            f"; with no route, {roadless} UAVs are the road's count (one more for the turns "
            "nobody foresees)"
        )
    if planner == "road":
        why = "asked for" if uavs >= need else f"asked for, with {uavs} of the {need} UAVs it needs"
        return "road", why + advice
    if planner == "paper":
        return "paper", "asked for"
    if uavs >= need:
        return "road", f"{uavs} UAVs: at least the road's {need} (stationary minimum + 1){advice}"
    return "paper", (
        f"{uavs} UAVs: the road pattern needs {need} (stationary minimum + 1); "
        "flying the paper's plans, re-planned on every change of the convoy"
    )
