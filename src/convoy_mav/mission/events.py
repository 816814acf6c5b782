"""What the mission layer reports: frozen values, consumed by the app (log, MQTT, report)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["MissionAlarm", "MissionEvent", "Phase", "PhaseChanged", "Replanned", "Returning"]

#: Where one UAV is in the mission.  ``pending``: live but not yet given a
#: join (no plan yet, or ``Mission.join`` not called); ``join``: flying its
#: timed join path; ``protect``: on its plan slot; ``lost``: removed.
Phase = Literal["pending", "join", "protect", "lost"]


def phase_at(lost: bool, arrival: float | None, t: float) -> Phase:
    """A UAV's phase at mission time ``t``: lost, no slot yet, joining or protecting."""
    if lost:
        return "lost"
    if arrival is None:
        return "pending"
    return "protect" if t >= arrival else "join"


@dataclass(frozen=True, slots=True)
class Replanned:
    """A new plan is in force from mission time ``t``.

    Attributes:
        t: Mission time of the replan (= the new plan's ``plan_t0``).
        reason: Why (one of ``convoy_mav.mission.replan.REASONS``).
        predicted_coverage: Fraction of time the new plan keeps the convoy
            seen once every UAV has joined (< 1 with fewer than ``min_uavs``).
        uav_count: UAVs the plan is for (the live ones).
        min_uavs: The paper's minimum for perpetual protection in this case.
        case: ``"trivial"``, ``"stationary"`` or ``"moving"`` (``""`` with no UAV left).
    """

    t: float
    reason: str
    predicted_coverage: float
    uav_count: int
    min_uavs: int = 0
    case: str = ""


@dataclass(frozen=True, slots=True)
class PhaseChanged:
    """UAV ``uav`` entered ``phase`` at mission time ``t`` (``protect``: its exact arrival)."""

    uav: int
    phase: Phase
    t: float


@dataclass(frozen=True, slots=True)
class Returning:
    """A UAV back from a loss, far from the fleet, flies to it on slot ``slot`` of the
    plan in force (on its own altitude layer, beside the UAV that flies it) until
    mission time ``arrival`` (inf: its first meeting is not in reach yet); the fleet
    re-phases for it only then."""

    uav: int
    t: float
    slot: int
    arrival: float


@dataclass(frozen=True, slots=True)
class MissionAlarm:
    """Something the operator must know; the mission carries on with its last plan."""

    t: float
    message: str


MissionEvent = Replanned | PhaseChanged | Returning | MissionAlarm
