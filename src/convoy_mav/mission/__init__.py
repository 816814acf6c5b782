"""Mission logic on top of the planner (pure): joins, replans, phases.

- ``join.py``: timed constant-speed Dubins joins onto a moving plan slot.
- ``replan.py``: when the convoy's motion departs from the plan's (with hysteresis).
- ``mission.py``: the ``Mission`` state machine the service drives.
- ``events.py``: what it reports (``Replanned``, ``PhaseChanged``, ``Returning``,
  ``MissionAlarm``).
"""

from __future__ import annotations

from convoy_mav.mission.events import (
    MissionAlarm,
    MissionEvent,
    Phase,
    PhaseChanged,
    Replanned,
    Returning,
)
from convoy_mav.mission.join import Join, earliest_arrival, plan_join, rotated_cycle, slot_pose
from convoy_mav.mission.mission import Mission
from convoy_mav.mission.replan import (
    REASONS,
    ChangeDetector,
    ConvoyMotion,
    ReplanDecision,
    ReplanThresholds,
)
from convoy_mav.mission.view import MissionView, SlotView

__all__ = [
    "REASONS",
    "ChangeDetector",
    "ConvoyMotion",
    "Join",
    "Mission",
    "MissionAlarm",
    "MissionEvent",
    "MissionView",
    "Phase",
    "PhaseChanged",
    "ReplanDecision",
    "ReplanThresholds",
    "Replanned",
    "Returning",
    "SlotView",
    "earliest_arrival",
    "plan_join",
    "rotated_cycle",
    "slot_pose",
]
