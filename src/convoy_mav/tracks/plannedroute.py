"""A route with the convoy's plan on it: where it stands, how fast it drives, and
whether it laps (pure value).

Three sources give more than the road: a rover's mission (live, or saved by a ground
station: :mod:`convoy_mav.tracks.missionroute`) and a JSON route that carries a plan
(:mod:`convoy_mav.tracks.routejson`, a file or MQTT ``<prefix>/convoy/route``). The road
model forecasts the convoy along the route by this timetable
(``ConvoyModel.set_route``); a route from GPX, CSV or KML carries none.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SAME_POINT_DEG", "PlannedRoute", "PointMarks", "closed_lap"]

SAME_POINT_DEG = 5e-6
"""Points nearer than this (degrees, ~0.5 m) are one point of the road."""

PointMarks = tuple[tuple[int, float], ...]
"""(index in the route's points, value) pairs, by index."""


@dataclass(frozen=True, slots=True)
class PlannedRoute:
    """The road (lat, lon) in order, what was left out, and the convoy's plan on it."""

    points: tuple[tuple[float, float], ...]
    skipped: int = 0  # items the road leaves out (local frames, landings, a plan's surveys)
    laps: bool = False  # a DO_JUMP repeats part of it
    holds: PointMarks = ()  # (index in points, seconds it stands there)
    circuit: bool = False  # the points are one lap, closed, driven round and round
    speeds: PointMarks = ()  # (index in points, m/s from there on)
    autopilot: bool = False  # an autopilot drives it (a mission in AUTO): at a speed of
    # its own where none is planned, kept but for its corners, stops and speed changes

    @property
    def planned(self) -> bool:
        """Whether it says more than the road: holds, speeds, laps or an autopilot."""
        return bool(self.holds or self.speeds or self.circuit or self.autopilot)

    def remarks(self) -> str:
        """What the points alone do not say ("" when nothing)."""
        said = []
        if self.circuit:
            said.append("a circuit driven in laps")
        elif self.laps:
            said.append("driven in laps (DO_JUMP)")
        if self.holds:
            total = sum(seconds for _, seconds in self.holds)
            said.append(f"{len(self.holds)} holds, {total:.0f} s")
        if self.speeds:
            lo, hi = min(v for _, v in self.speeds), max(v for _, v in self.speeds)
            span = f"{lo:g} m/s" if lo == hi else f"{lo:g}-{hi:g} m/s"
            said.append(f"{len(self.speeds)} speeds, {span}")
        if self.skipped:
            said.append(f"{self.skipped} items left out (local frames, landings, surveys)")
        return ", ".join(said)


def closed_lap(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """``points`` as a closed lap: the drive back to the first point added unless the
    last is already there."""
    start, end = points[0], points[-1]
    if max(abs(start[0] - end[0]), abs(start[1] - end[1])) >= SAME_POINT_DEG:
        return [*points, start]
    return points
