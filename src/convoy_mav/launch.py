"""Launch sequencing: who may leave the ground now, so that UAVs never climb out abreast.

A fleet set up together from homes a few metres apart (PX4's multi-vehicle SITL puts
them in a row, a field has one flight line) would climb out side by side: each UAV
flies its own altitude layer once up, but on the way up they share every altitude,
closer than the separation minima in both dimensions.

Design rules:
- A UAV may arm (which launches it: ArduPlane's TAKEOFF mode, PX4's NAV_TAKEOFF right
  after, a copter's climb) once every other UAV that moves (cleared to launch, armed
  or airborne) is either horizontally clear of its pad by ``horizontal_m``, or above
  it by ``vertical_m`` *and* bound for a higher layer, so that this one, climbing
  behind it, never climbs through it.
- Among UAVs waiting within ``horizontal_m`` of each other, the one bound for the
  highest layer goes first: each then climbs out below those already up. A UAV whose
  set-up has not reached its turn yet (still on the steps before arming) is waited for
  :data:`YIELD_S` at most: one stuck in its set-up does not ground its neighbours.
- Climb-outs do not converge: straight up (a copter: ArduCopter's NAV_TAKEOFF, a PX4
  multicopter's ``climb out`` set-up step) or straight ahead (planes in a row share one
  heading), so a pad clear now stays clear while its UAV climbs.
- A UAV cleared to launch moves until its autopilot says so: while it is still
  arming (an autopilot may refuse ARM for a while: ArduCopter's "Need Position
  Estimate" for half a minute), and :data:`CLEARED_S` after its arming ended, armed
  or given up. Otherwise a neighbour cleared in the meantime would take off beside it.
- A UAV on the ground and disarmed is not moving and holds nobody.
- Pure: a snapshot of the fleet in, the reason to hold (or None) out.
  :class:`LaunchSequence` keeps the only state, who waits and who was just cleared.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

__all__ = ["CLEARED_S", "YIELD_S", "Craft", "LaunchSequence", "hold_reason"]

CLEARED_S = 10.0
"""Mission s a UAV counts as moving after its arming ended, before its autopilot says
it is armed."""
YIELD_S = 20.0
"""Mission s a waiting UAV yields to a neighbour bound higher whose set-up is behind."""


@dataclass(frozen=True, slots=True)
class Craft:
    """One UAV as the launch sequence sees it.

    Attributes:
        sysid: The UAV's id in the service.
        north, east, down: Where it is now (mission frame, m); for a UAV on the
            ground, its pad.
        layer_m: The altitude it is bound for, m above the mission origin.
        moving: Armed or airborne (its autopilot says so).
        setting_up: Its set-up is under way and it has not armed yet: it will ask.
    """

    sysid: int
    north: float
    east: float
    down: float
    layer_m: float
    moving: bool
    setting_up: bool = False


def hold_reason(
    pad: Craft,
    moving: Iterable[Craft],
    waiting: Iterable[Craft],
    horizontal_m: float,
    vertical_m: float,
) -> str | None:
    """Why ``pad`` may not launch now, naming the UAV it waits for; None if it may.

    Args:
        pad: The UAV asking, on the ground.
        moving: Every other UAV cleared to launch, armed or airborne.
        waiting: Every other UAV waiting to launch.
        horizontal_m: Horizontal clearance from ``pad`` that frees it (m).
        vertical_m: Height above ``pad`` that frees a UAV bound higher (m).
    """
    for other in moving:
        if other.sysid == pad.sysid:
            continue
        apart = math.hypot(other.north - pad.north, other.east - pad.east)
        if not apart < horizontal_m:  # (a NaN position holds nobody: nothing says it is near)
            continue
        above = pad.down - other.down
        if other.layer_m > pad.layer_m and above >= vertical_m:
            continue
        how = "bound no higher"
        if other.layer_m > pad.layer_m:
            how = "climbing out" if other.moving else "arming"
        return f"UAV {other.sysid} {how} {apart:.0f} m from its pad, {above:.0f} m above it"
    for other in waiting:
        if other.sysid == pad.sysid or other.layer_m <= pad.layer_m:
            continue
        apart = math.hypot(other.north - pad.north, other.east - pad.east)
        if apart < horizontal_m:
            return f"UAV {other.sysid} launches first ({apart:.0f} m away, bound higher)"
    return None


class LaunchSequence:
    """The fleet's launch order, asked by each UAV's set-up before it arms.

    Args:
        fleet: The UAVs with a position now, by id (their ``moving`` from the
            autopilot); called at each :meth:`ask`.
        horizontal_m: Horizontal clearance that frees a pad (m): the separation
            minimum with a margin.
        vertical_m: Height above a pad that frees it for a UAV bound higher (m).
    """

    def __init__(
        self,
        fleet: Callable[[], Mapping[int, Craft]],
        horizontal_m: float,
        vertical_m: float,
    ) -> None:
        for name, value in (("horizontal_m", horizontal_m), ("vertical_m", vertical_m)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        self._fleet = fleet
        self.horizontal_m = horizontal_m
        self.vertical_m = vertical_m
        self._waiting: dict[int, float] = {}  # id -> mission time it first asked
        self._arming: set[int] = set()  # cleared, arming now
        self._cleared: dict[int, float] = {}  # id -> mission time its arming ended

    def ask(self, sysid: int, t: float) -> str | None:
        """May UAV ``sysid`` launch at mission time ``t``? None clears it (it then
        counts as moving until :data:`CLEARED_S` after :meth:`armed`); else why it
        holds, and it waits."""
        since = self._waiting.setdefault(sysid, t)
        fleet = self._fleet()
        pad = fleet.get(sysid)
        if pad is None:
            return "no position yet"
        self._cleared = {s: c for s, c in self._cleared.items() if t - c < CLEARED_S}
        cleared = self._arming | self._cleared.keys()
        moving = [c for s, c in fleet.items() if s != sysid and (c.moving or s in cleared)]
        yielding = t - since < YIELD_S
        waiting = [
            c
            for s, c in fleet.items()
            if s != sysid
            and not c.moving
            and s not in cleared
            and (s in self._waiting or (yielding and c.setting_up))
        ]
        why = hold_reason(pad, moving, waiting, self.horizontal_m, self.vertical_m)
        if why is None:
            del self._waiting[sysid]
            self._arming.add(sysid)
        return why

    def armed(self, sysid: int, t: float) -> None:
        """UAV ``sysid``'s arming ended at mission time ``t`` (armed, or given up): it
        counts as moving :data:`CLEARED_S` more, until its autopilot says so."""
        if sysid in self._arming:
            self._arming.discard(sysid)
            self._cleared[sysid] = t

    def withdraw(self, sysid: int) -> None:
        """UAV ``sysid`` no longer waits (its set-up ended without launching)."""
        self._waiting.pop(sysid, None)

    @property
    def waiting(self) -> frozenset[int]:
        """The UAVs waiting to launch."""
        return frozenset(self._waiting)
