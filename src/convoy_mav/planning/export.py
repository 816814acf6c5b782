"""Plain-data views of plans for JSON (the ``convoy-mav plan --json`` contract).

The keys are a public contract read by other tools and tests: add keys freely,
never rename or drop one.  Units are in the key names; headings in the
planner frame (radians counter-clockwise from east) unless a key says ``deg``.
"""

from __future__ import annotations

import math
from typing import Any

from convoy_mav.planning.dubins import Pose, Segment
from convoy_mav.planning.plan import (
    MovingDetails,
    Plan,
    StationaryDetails,
    VehiclePlan,
    min_horizontal_separation,
)
from convoy_mav.planning.stationary import EntrySolution

__all__ = [
    "FRAME_NOTE",
    "compass_to_planner",
    "entry_to_dict",
    "plan_to_dict",
    "planner_to_compass",
]

FRAME_NOTE = (
    "planner frame: x east, y north (metres), headings in radians counter-clockwise "
    "from east; origin at the convoy centroid at t = 0"
)


def compass_to_planner(degrees: float) -> float:
    """Compass course (degrees clockwise from north) to a planner heading (rad CCW from east)."""
    return math.radians(90.0 - degrees)


def planner_to_compass(heading: float) -> float:
    """Planner heading (rad CCW from east) to a compass course in [0, 360) degrees."""
    return (90.0 - math.degrees(heading)) % 360.0


def _pose(p: Pose) -> list[float]:
    return p.as_list()


def _segment(seg: Segment, t_start: float) -> dict[str, Any]:
    return {
        "t_start_s": t_start,
        "start": _pose(seg.start),
        "turn": seg.turn.letter,
        "radius_m": seg.radius,
        "speed_mps": seg.speed,
        "duration_s": seg.duration,
    }


def _vehicle(v: VehiclePlan) -> dict[str, Any]:
    traj = v.trajectory
    t = traj.t_start
    lead = []
    for seg in traj.lead_in:
        lead.append(_segment(seg, t))
        t += seg.duration
    cycle = []
    for seg in traj.cycle:
        cycle.append(_segment(seg, t))
        t += seg.duration
    return {
        "index": v.index,
        "phase_s": v.phase_s,
        "period_s": traj.period,
        "drift_m": list(traj.drift),
        "lead_in": lead,
        "segments": cycle,
    }


def _finite_or_none(x: float) -> float | None:
    return x if math.isfinite(x) else None


def plan_to_dict(plan: Plan) -> dict[str, Any]:
    """The JSON object printed by ``convoy-mav plan --json``."""
    req = plan.request
    out: dict[str, Any] = {
        "case": plan.case,
        "frame": FRAME_NOTE,
        "turn_radius_m": req.turn_radius,
        "sensor_radius_m": req.sensor_radius,
        "uav_speed_mps": req.uav_speed,
        "convoy_speed_mps": req.convoy_speed,
        "convoy_heading_deg": planner_to_compass(req.convoy_heading),
        "min_uavs": plan.min_uavs,
        "uavs": len(plan.vehicles),
        "coverage_per_uav": plan.coverage_per_uav,
        "predicted_coverage": plan.predicted_coverage,
        "min_horizontal_separation_m": _finite_or_none(min_horizontal_separation(plan)),
    }
    details = plan.details
    if isinstance(details, StationaryDetails):
        out |= {
            "entry_heading_offset_rad": details.entry_heading_offset_rad,
            "orbit_period_s": details.orbit_period_s,
            "time_inside_s": details.time_inside_s,
            "entry_times_s": list(details.entry_times_s),
        }
    elif isinstance(details, MovingDetails):
        out |= {
            "speed_ratio": details.speed_ratio,
            "beta_rad": details.beta_rad,
            "v_star": details.v_star,
            "gamma_star_rad": details.gamma_star_rad,
            "meet_period_s": details.meet_period_s,
            "phase_offsets_s": list(details.phase_offsets_s),
        }
    else:
        out["orbit_period_s"] = plan.vehicles[0].trajectory.period
    out["vehicles"] = [_vehicle(v) for v in plan.vehicles]
    return out


def entry_to_dict(
    solution: EntrySolution, turn_radius: float, sensor_radius: float
) -> dict[str, Any]:
    """The JSON object printed by ``convoy-mav plan --entry X Y HEADING --json``."""
    t = 0.0
    segments = []
    for seg in solution.segments:
        segments.append(_segment(seg, t))
        t += seg.duration
    return {
        "frame": FRAME_NOTE,
        "turn_radius_m": turn_radius,
        "sensor_radius_m": sensor_radius,
        "sequence": solution.sequence,
        "entry": _pose(solution.entry),
        "switch": None if solution.switch is None else _pose(solution.switch),
        "exit": _pose(solution.exit),
        "time_inside_s": solution.time_inside,
        "segments": segments,
    }
