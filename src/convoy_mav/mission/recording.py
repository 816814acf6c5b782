"""A road mission's inputs, recorded as they come and replayed offline.

The road planner is pure: the same inputs, in the same order, give the same
plans to the last bit, whatever the host or the speedup of the flight that
made them. So a flight's planning can be reproduced without the flight: the
convoy estimates, joins, losses, returns, ticks, routes and lead vehicle's modes a ``RoadMission``
was fed, each with its arguments, replayed into a new one
(``RoadMission.replayed``). That answers why a
UAV flew where it did (step through the replay, look at any re-plan), and checks
that a change meant to leave the plans alone (a faster planner) does: the
replay's predicted coverage and paths are then the recording's.

What the host did is in the inputs, not lost: a loaded host steps the mission
less often, and the recording has the estimates at the times it was stepped.

Recordings are pickles (the inputs are the planner's own values): load only
your own.
"""

from __future__ import annotations

import math
import pickle
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from convoy_mav.planning import PlanRequest
from convoy_mav.planning.road import Road

if TYPE_CHECKING:
    from convoy_mav.mission.road import RoadSettings

__all__ = ["INPUTS", "MissionRecording", "load_recording"]

INPUTS = (
    "on_convoy",
    "join_many",
    "on_lost",
    "on_returned",
    "tick",
    "set_route",
    "set_replan_lag",
    "set_drive",
)
"""The ``RoadMission`` methods that take the world in: all a replay needs."""

_FORMAT = 1


@dataclass
class MissionRecording:
    """How a ``RoadMission`` was made, and every input it took, in order.

    Attributes:
        request: The mission's geometry and speeds.
        uav_ids: Its UAVs.
        downs: Each UAV's altitude setpoint (metres down) when recording began.
        route: The route it was made with, if any.
        settings: Its settings.
        calls: (method, positional arguments) of each input, in the order taken.
    """

    request: PlanRequest
    uav_ids: list[int]
    downs: dict[int, float]
    route: Road | None
    settings: RoadSettings
    calls: list[tuple[str, tuple[Any, ...]]] = field(default_factory=list)

    def add(self, method: str, args: Sequence[Any]) -> None:
        """Note one input (``method`` one of ``INPUTS``)."""
        self.calls.append((method, tuple(args)))

    def inputs(self, until: float | None = None) -> list[tuple[str, tuple[Any, ...]]]:
        """The inputs in order (those stamped after ``until``, if given, left out)."""
        if until is None:
            return list(self.calls)
        out = []
        for method, args in self.calls:
            if _stamp(method, args) > until:
                break
            out.append((method, args))
        return out

    def with_lag_scaled(self, factor: float) -> MissionRecording:
        """The same inputs, every re-plan lag told (``set_replan_lag``) ``factor`` times
        as long: the flight as it might have gone on a host a little faster or slower.

        A road mission's choices are discrete (which leg, keep or fill, which meeting),
        so a change this small as a 1 % longer lag sends some plans another way and the
        mission on from there: replays at factors about 1 give the spread of one flight's
        coverage, which a single flight cannot (``benchmarks/road_table.py --spread``).

        Raises:
            ValueError: If ``factor`` is negative or not finite.
        """
        if not (math.isfinite(factor) and factor >= 0.0):
            raise ValueError(f"factor must be finite and >= 0, got {factor!r}")
        calls = [
            (m, tuple(factor * a for a in args) if m == "set_replan_lag" else args)
            for m, args in self.calls
        ]
        return replace(self, calls=calls)

    def save(self, path: str | Path) -> None:
        """Write the recording (a pickle)."""
        with open(path, "wb") as fh:
            pickle.dump({"format": _FORMAT, "recording": self}, fh)


def load_recording(path: str | Path) -> MissionRecording:
    """Read a recording ``MissionRecording.save`` wrote.

    Raises:
        ValueError: If the file is no recording of this format.
    """
    with open(path, "rb") as fh:
        data = pickle.load(fh)  # (the user's own recording: see the module)
    if not (isinstance(data, dict) and data.get("format") == _FORMAT):
        raise ValueError(f"{path}: not a convoy-mav mission recording (format {_FORMAT})")
    recording = data["recording"]
    if not isinstance(recording, MissionRecording):
        raise ValueError(f"{path}: not a convoy-mav mission recording")
    return recording


def _stamp(method: str, args: tuple[Any, ...]) -> float:
    """Mission time of an input (a route or a lag has none: -inf, always replayed)."""
    if method == "on_convoy":
        return float(args[0].t)
    if method in ("join_many", "on_lost", "on_returned"):
        return float(args[1])
    if method == "tick":
        return float(args[0])
    if method == "set_drive":
        return float(args[1])
    return float("-inf")
