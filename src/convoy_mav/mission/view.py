"""An immutable snapshot of a Mission: what every UAV flies, readable from any thread.

The service computes replans and joins off its event loop (they take tens of
milliseconds for a handful of UAVs, which at a 40x simulator speedup is longer
than PX4's one-second offboard timeout).  The streamer and the monitor read this
snapshot instead of the live Mission, and the control loop swaps in a new one
after each mission step: a single attribute assignment, so readers always see
one consistent plan (origin, time base and trajectories from the same replan).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

from convoy_mav.mission.events import Phase, phase_at
from convoy_mav.planning.plan import Trajectory
from convoy_mav.schedule import setpoint_on
from convoy_mav.types import Setpoint

__all__ = ["MissionLike", "MissionView", "SlotView"]


class _Motion(Protocol):
    @property
    def speed(self) -> float: ...


class MissionLike(Protocol):
    """What a snapshot reads of a mission (``Mission`` and ``RoadMission`` both have it)."""

    @property
    def live_uavs(self) -> tuple[int, ...]: ...
    @property
    def lost_uavs(self) -> tuple[int, ...]: ...
    @property
    def returning_uavs(self) -> tuple[int, ...]: ...
    @property
    def plan_origin(self) -> tuple[float, float]: ...
    @property
    def plan_t0(self) -> float: ...
    @property
    def predicted_coverage(self) -> float | None: ...
    @property
    def protect_start(self) -> float | None: ...
    @property
    def motion(self) -> _Motion | None: ...
    def trajectory(self, uav: int) -> Trajectory | None: ...
    def arrival(self, uav: int) -> float | None: ...


@dataclass(frozen=True, slots=True)
class SlotView:
    """One UAV's assignment: its trajectory (planner frame) and arrival time."""

    trajectory: Trajectory
    arrival: float  # mission time it reaches its slot (end of the join)
    down: float  # its flight altitude, NED metres


@dataclass(frozen=True, slots=True)
class MissionView:
    """The plan in force and each UAV's slot, frozen at one mission step."""

    plan_origin: tuple[float, float] = (0.0, 0.0)
    plan_t0: float = 0.0
    slots: Mapping[int, SlotView] = field(default_factory=dict)
    lost: frozenset[int] = frozenset()
    predicted_coverage: float | None = None
    protect_start: float | None = None
    convoy_speed: float | None = None  # what the plan in force assumes, m/s

    @classmethod
    def of(cls, mission: MissionLike, down: Callable[[int], float]) -> MissionView:
        """Snapshot a ``Mission`` (call from the thread that owns it)."""
        slots = {}
        for uav in (*mission.live_uavs, *mission.returning_uavs):
            traj = mission.trajectory(uav)
            arrival = mission.arrival(uav)
            if traj is not None and arrival is not None:
                slots[uav] = SlotView(traj, arrival, down(uav))
        return cls(
            plan_origin=mission.plan_origin,
            plan_t0=mission.plan_t0,
            slots=slots,
            lost=frozenset(mission.lost_uavs),
            predicted_coverage=mission.predicted_coverage,
            protect_start=mission.protect_start,
            convoy_speed=None if mission.motion is None else mission.motion.speed,
        )

    def setpoint(self, uav: int, t: float) -> Setpoint | None:
        """What ``uav`` flies at mission time ``t`` (None: no slot yet, or lost)."""
        slot = self.slots.get(uav)
        if slot is None:
            return None
        return setpoint_on(
            slot.trajectory, t, plan_origin=self.plan_origin, plan_t0=self.plan_t0, down=slot.down
        )

    def phase(self, uav: int, t: float) -> Phase:
        """``pending``, ``join``, ``protect`` or ``lost`` at mission time ``t``."""
        slot = self.slots.get(uav)
        return phase_at(uav in self.lost, None if slot is None else slot.arrival, t)
