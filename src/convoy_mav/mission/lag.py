"""How long a re-plan takes to reach the UAVs, in mission seconds, learnt as it goes.

A mission step runs beside the setpoint stream and its new paths are streamed from
the first control tick after it ends. Its lag is a tick or so plus the re-plans'
compute, a few milliseconds a UAV: nothing at real time, seconds of mission time
at a high speedup (the mock at 40x) or on a loaded host. The road mission lays new
legs that far ahead along the paths in force (``RoadMission.set_replan_lag``), so
the setpoint never jumps under a UAV. Measured in mission time, so right at any
speedup.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ReplanLag"]


@dataclass
class ReplanLag:
    """Mission seconds from a step's start to its paths being flown, fitted as ``base``
    plus ``per_uav`` for each UAV it re-planned (running means).

    Attributes:
        alpha: Weight of the newest step in the running means.
        margin: Factor on the means for the lead handed to the mission: a lead a bit
            long delays a re-plan that much; one short moves the setpoint under the UAV.
        cap: Longest lead, mission seconds (a host that stalls is handled by the
            speedup governor, not by planning ever further ahead).
    """

    alpha: float = 0.2
    margin: float = 1.25
    cap: float = 8.0
    base: float = 0.0
    per_uav: float = 0.0
    planned: int = 0  # steps that re-planned a UAV or more, folded in

    @property
    def settled(self) -> bool:
        """Whether ``per_uav`` has seen enough steps to be its host's (a few times 1/alpha)."""
        return self.planned >= 3.0 / self.alpha

    def observe(self, lag: float, plans: int) -> None:
        """Fold in one step: ``lag`` mission seconds, ``plans`` UAVs re-planned."""
        if not (math.isfinite(lag) and lag >= 0.0 and plans >= 0):
            return
        if plans == 0:
            self.base += self.alpha * (lag - self.base)
        else:
            self.per_uav += self.alpha * (max(lag - self.base, 0.0) / plans - self.per_uav)
            self.planned += 1

    def lead(self) -> tuple[float, float]:
        """``(base, per_uav)`` for the mission: the means with the margin, capped so a
        step that re-plans one UAV leads by ``cap`` at most."""
        base = min(self.margin * self.base, self.cap)
        return base, min(self.margin * self.per_uav, self.cap - base)
