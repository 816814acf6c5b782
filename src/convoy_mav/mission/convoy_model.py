"""Where the convoy will be: a known route driven at the estimated speed, or its track extended.

Design rules:
- Planner frame (x east, y north); mission time.
- With a route (``convoy_mav.planning.road.Road``) the convoy's arc length is
  its estimated position projected on the route (searched near the last
  one, so a route that doubles back is not confused), and it is predicted
  to drive on along the route. A convoy farther than
  ``off_route_m`` from the route for ``off_route_s`` has left it: it is
  then predicted like a convoy with no route until it is back on it.
- A route is a road, not a timetable: the convoy may drive it the other way
  (out and back on a route given one way), lap it (a patrol circuit given as
  one lap), or come back onto it far from where it left (a detour). Driving
  against the route, past its end, or off it (``left_route``: not a chord
  cut across a bend, nor a spike of the fixes; the recorded drive ends near
  where it began), the convoy is looked for on the whole route, either way
  round when it drives against it, among the stretches heading its way, and
  found again there (``Road.nearest_heading``). Searched only near the last
  place, it was predicted standing, then down a road it had left (out and
  back on a route given one way, in simulation: 82.4 %, now 99.3 %; with no
  route, 97.2 % with a UAV more).
- The end of a route is where the convoy is going: it is forecast to stop
  there (its destination, or where it turns back), not to drive on straight
  past it; once past it, or 25 m off the route heading away from it (a turn
  the route does not take), it is forecast from its own velocity at once.
- Along a route its speed is forecast to relax, with time constant
  ``relax_s``, to its mean over the last ``mean_window_s`` (stops
  included): the mean of an Ornstein-Uhlenbeck speed. A convoy in traffic
  does not hold its speed: faster than its recent mean, it will slow for
  the next queue, junction or corner, where and when no route says. Held at
  its speed, every meeting half a minute ahead lies too far on, and the
  legs planned for them arrive where the convoy is not (the recorded drive,
  route known, simulation: 94.0 % held, 99.3 % with the true future, the
  loss all at speed changes). Never up: a convoy slower than its mean may
  stay so (a queue) for as long as it likes, and one standing has its
  drive-off weighed apart (``driving_off``). Nor before the convoy has been
  seen a whole window: its start from standing is not its pace, and a
  forecast relaxed to it put the joining UAVs' meetings short.
- With no route the convoy is predicted to go on at its estimated velocity
  (the tracker's least-squares slope, never a raw difference of fixes), held:
  that speed is a chord's, and dips in every bend (relaxed, hairpins without
  a route lost 5.6 points).
- A route says where the road turns, not whether the convoy will stop before
  it does: at a junction it may stand for a minute first. ``stopping_short``
  is that other course, the convoy stopped just short of the next sharp
  corner ahead, for the mission to weigh its choices against both. Nor, once
  it stands, when it will drive off again: ``driving_off`` is the convoy
  pulling away along the route now, back up to the speed it last drove at.
- A route may come with the convoy's plan of where it stands and how long
  (``holds``: a rover's mission's hold times, ``tracks.missionroute``). Then
  along the route the convoy is forecast to brake into each hold ahead, stand
  its time and pull away again (at ``HOLD_ACCEL``, up to the speed it last
  drove at); standing at one, to pull away once its time is up, counted from
  when it stopped. Its driving off now is still weighed (``driving_off``): the
  plan's time is the rover's, the stop's start is the tracker's, seconds
  apart (without it, simulated urban grids lost 0.7-1 point to the holds).
  A hold stood at is done while the convoy is past it: found again before it
  (the next lap of a patrol given as one lap), it holds there again.
- A route may come with the speeds the convoy plans (``speeds``: a rover's
  mission's DO_CHANGE_SPEEDs): driving, it is forecast to take up each from its
  arc on (at ``HOLD_ACCEL``, up or down, as the firmware changes speed at the
  waypoint), at the one in force now if it drives slower or faster, and to pull
  away from a hold to the one in force there. Standing where no hold is planned,
  it is forecast standing as without a plan (the drive-off is weighed apart).
- A convoy keeping a planned speed may still take the route's sharp corners
  slower, as a rover in AUTO does (``CornerHabit``, ``mission.corners``): seen to
  take them under ``CORNER_RATIO`` of the plan's speed, it is forecast to slow for
  the corners ahead as it did for those behind, and one slow in a corner (from
  ``_STANDING_MPS``, not ``_CRUISING_MPS``) to speed up to the plan's speed again.
- A route driven by an autopilot (a rover's mission: ``set_route(keeps_speed=True)``)
  is driven at the rover's own speed where its plan sets none (a PX4 rover's default,
  not asked): ``cruise``, learnt from the drive once the rover is seen to brake for
  its corners as an autopilot does, is then the planned speed there.
- A rover keeps the speed it is told, not its plan's (``kept``): an operator's
  DO_CHANGE_SPEED, a WP_SPEED changed, or ArduRover back in AUTO at WP_SPEED, each in
  force until the mission's next DO_CHANGE_SPEED. So a route driven by an autopilot,
  seen to hold a steady speed (``KEPT_WINDOW_S`` within ``KEPT_SPREAD_MPS``, no curve
  near that would slow it) clearly off the plan's there (``KEPT_OFF_MPS``, and 10 %),
  is forecast at that speed until its next planned speed change; seen back at the
  plan's, at the plan's. Driven by people the plan's speeds stay a plan (they relax).
- What drives the lead vehicle, as its autopilot's mode says (``set_drive``; not said,
  its mission). Told to stand (HOLD, disarmed) at a planned hold, it is not forecast to
  pull away when the hold's time is up: it stands until its operator says otherwise;
  back in its mission there, the hold starts again (ArduRover restarts the waypoint).
  Driven otherwise (MANUAL, GUIDED, RTL), the plan is set aside and its speeds are not
  learnt as the rover's: a driver keeps none of them. Braking and pulling away are
  still forecast from its fixes: forecast from the mode (at once, seconds before the
  fixes show them) they measured no better in simulation (``docs/road-planner.md``).
  Sent home, it is forecast there: straight to its home (RTL), or back along the path
  it was seen to drive (SMART_RTL: ``mission.retrace``, kept as the rover keeps its
  own), turned round first if it must be and slowed through the corners as learnt.
- A route known to be a circuit (``circuit``: a rover's mission that jumps
  back to its first waypoint, DO_JUMP, closed by the drive back there) is
  lapped: past its end the convoy is on the next lap at once, not driving
  off it, and forecast round it and into the next lap's holds; a new lap
  plans every hold again. Only when said: a route that ends near where it
  began is more often a destination (home) than a lap.
- Pure: estimates carry their time.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from convoy_mav.errors import PlanningError
from convoy_mav.mission.corners import CornerHabit, warp
from convoy_mav.mission.retrace import DrivenPath
from convoy_mav.planning.road import Road
from convoy_mav.types import ConvoyDrive, ConvoyEstimate

__all__ = ["HOLD_ACCEL", "KEPT_WINDOW_S", "ConvoyModel", "RoadMotion"]

FloatArray = npt.NDArray[np.float64]

_MOVING_MPS = 0.5  # slower along the route, a convoy has no corner to stop short of
_CORNER_FROM_M = 5.0  # a corner nearer than this ahead: the convoy is turning it
_CORNER_STEP_M = 2.0  # the route's curvature is searched every ... metres
_CRUISING_MPS = 3.0  # along the route at least this fast, the convoy is driving (not creeping)
_LOST_S = 1.0  # off the route, past its end or against it this long: look on all of it
_REFIND_NEAR_M = 10.0  # past the end or against it, a place this little farther off will do
_REFIND_JUMP_M = 100.0  # ... if it is this far along the route from where the convoy was
_TURNING_OFF_M = 25.0  # this far off the route and heading away from it ...
_TURNING_OFF_RAD = math.radians(45.0)  # ... by more than this: it is leaving the route
_STANDING_MPS = 1.5  # slower along the route, the convoy stands (3 m of GPS noise: ~1 m/s)
_HOLD_NEAR_M = 20.0  # standing this near a planned hold, it is holding there
_REJOINED_M = 25.0  # back to its route: this near the point it drives to, it is on it
_TURN_ACCEL = 1.0  # m/s^2: turned round (RTL) or pulling away, it speeds up at this
_TURN_ROUND_RAD = math.radians(60.0)  # its way this far off its heading: it turns round ...
_TURN_ROUND_MPS = 2.0  # ... braking at _TURN_ACCEL along its heading to this first
_ASTRAY_S = 5.0  # s: on its own way, past its turn round, heading elsewhere this long ...
_RETRACE_AIM_M = 10.0  # back along its path: it heads for the point this far on along it
_RETRACE_NEAR_M = 100.0  # ... its place on that way searched this near the last
_RETRACED_M = 5.0  # ... and the points of its path it passes this near are taken off
_HOLD_BEHIND_M = 5.0  # a hold not stood at is still ahead until this far behind
HOLD_ACCEL = 1.0  # m/s^2: braking into a planned hold and pulling away from it
_PLAN_STEP = 0.25  # s: the timetable's grid
_WRAP_M = 100.0  # on a circuit this near its end, the convoy may be on the next lap
_WRAP_TIE_M = 1.0  # ... there if this much nearer (or, past the end, no farther)
CORNER_RATIO = 0.6  # corners taken slower than this of the planned speed are forecast so
CRUISE_WINDOW_S = 120.0  # s: a rover keeping its speed: learnt over this much driving ...
CRUISE_MIN_S = 30.0  # ... once it has driven this long
CRUISE_QUANTILE = 75.0  # ... the speed it drives at this much of the time or less
KEPT_WINDOW_S = 6.0  # s: a rover driving this long at one speed keeps it ...
KEPT_SPREAD_MPS = 0.6  # ... within this (its own velocity: 0.1 m/s; 3 m of GPS noise: none)
KEPT_OFF_MPS = 0.7  # ... and, this far off its plan's (and 10 % of it), was told it
_KEPT_KEPT = 200  # the kept speeds noted for the report


@dataclass(frozen=True, slots=True)
class RoadMotion:
    """What the model says of the convoy now (for reports and the mission view)."""

    t: float
    speed: float  # m/s along its predicted path
    on_route: bool | None  # None: no route was given


def _on(route: Road, s: float, est: ConvoyEstimate) -> tuple[float, float]:
    """How far the estimate is from ``route`` at arc length ``s``, and its speed along it."""
    p = route.point(s)
    along = est.ve * math.cos(p.heading) + est.vn * math.sin(p.heading)
    return math.hypot(p.x - est.east, p.y - est.north), along


def _since(times: npt.NDArray[np.float64], est: ConvoyEstimate) -> FloatArray:
    """Seconds from the estimate to each of ``times`` (none before it)."""
    return np.maximum(times - est.t, 0.0)


class ConvoyModel:
    """The convoy's predicted path from its estimates and, if known, its route.

    Args:
        route: The route the convoy is expected to drive, or None.
        off_route_m: Farther than this from the route, the convoy may have left it.
        off_route_s: ... for this long, and it has.
        relax_s: Along the route, a convoy faster than its recent mean speed is
            forecast to relax to it with this time constant, s (0: held).
        mean_window_s: ... its mean over this many seconds.
        corner_curvature: A stretch of the route sharper than this (1/m) is a corner,
            which a convoy keeping a planned speed may be seen to take slower
            (``CornerHabit``).

    Raises:
        ValueError: If ``relax_s`` is negative or ``mean_window_s`` not positive.
    """

    def __init__(
        self,
        route: Road | None = None,
        *,
        off_route_m: float = 60.0,
        off_route_s: float = 5.0,
        relax_s: float = 0.0,
        mean_window_s: float = 90.0,
        corner_curvature: float = 0.04,
        kept_window_s: float = KEPT_WINDOW_S,
    ) -> None:
        if not (math.isfinite(relax_s) and relax_s >= 0.0):
            raise ValueError(f"relax_s must be >= 0, got {relax_s!r}")
        if not (math.isfinite(mean_window_s) and mean_window_s > 0.0):
            raise ValueError(f"mean_window_s must be positive, got {mean_window_s!r}")
        self.route = route
        self._roads = (route, None if route is None else route.reversed())
        self._reversed = False  # the convoy drives the route the other way
        self._lost_since: float | None = None
        self._leaving = False  # off the route and heading away from it
        self.off_route_m = off_route_m
        self.off_route_s = off_route_s
        self.relax_s = relax_s
        self.mean_window_s = mean_window_s
        self.kept_window_s = kept_window_s
        # (t, speed along the route) over the last mean_window_s, and its integral.
        self._speeds: deque[tuple[float, float]] = deque()
        self._distance = 0.0
        self._first_speed_t: float | None = None
        self._est: ConvoyEstimate | None = None
        self._s = 0.0  # arc length on the route
        self._along = 0.0  # speed along the route
        self._cruise: float | None = None  # the last speed along it while driving
        self._way_top = 0.0  # m/s: its speed (or cruise) when sent home: its own way's top
        self._holds: tuple[tuple[float, float], ...] = ()  # planned: (arc on route, s)
        self._circuit = False  # the route is one lap of a circuit driven round and round
        self._paces: tuple[tuple[float, float], ...] = ()  # planned: (arc on route, m/s on)
        self._keeps_speed = False  # a rover in AUTO: where none is planned, it keeps its own
        self._driven: deque[tuple[float, float]] = deque()  # (t, speed along) while driving
        self._learnt: tuple[float, float | None] = (math.nan, None)  # (t, cruise) cached
        self._drive: ConvoyDrive | None = None  # what drives it (None: not said)
        self._going: tuple[float, float] | None = None  # (x, y) it drives straight to, home
        self._rejoin: tuple[float, float, float] | None = None  # (x, y, arc): back to its route
        self._left: tuple[float, float, float] | None = None  # (arc, x, y) where sent home
        self._path = DrivenPath()  # the path it was seen to drive, as it keeps it for SMART_RTL
        self._retrace: Road | None = None  # back along that path (RETRACE), and how far on
        self._retrace_s = 0.0
        # On a way of its own (home, back to its route): from when, how long its turn
        # round may take, and since when it has driven elsewhere (``_check_way``).
        self._way_from = (math.nan, 0.0)
        self._astray_since: float | None = None
        self.astray = False
        self._steady: deque[tuple[float, float, float]] = deque()  # (t, arc, speed) driving
        self._kept: tuple[float, float] | None = None  # (from arc, m/s) in place of the plan's
        self.kept_log: list[tuple[float, float | None, float | None]] = []  # (t, kept, plan)
        self._holding: int | None = None  # the hold it stands at (index)
        self._held: set[int] = set()  # holds stood at and left
        self._stood_since: float | None = None  # standing (along the route) since
        self._off_since: float | None = None
        self.left_route = False
        self.counters = {
            "left_route": 0, "back_on_route": 0, "found_again": 0, "laps": 0, "astray": 0
        }  # fmt: skip
        self.corner_habit = CornerHabit(corner_curvature, standing_mps=_STANDING_MPS)

    @property
    def estimate(self) -> ConvoyEstimate | None:
        """The latest estimate folded in."""
        return self._est

    @property
    def road(self) -> Road | None:
        """The route as the convoy drives it (reversed if it drives it the other way)."""
        return self._roads[self._reversed]

    @property
    def _off_road(self) -> bool:
        """Predicted from its own velocity, not the route: it has left the route, is
        leaving it, or has driven past its end (where the route says nothing)."""
        road = self.road
        return self.left_route or self._leaving or (road is not None and self._s > road.length)

    @property
    def _own_way(self) -> bool:
        """On a way of its own, off its route: home, back along its path, or back to it."""
        return self._going is not None or self._retrace is not None or self._rejoin is not None

    @property
    def motion(self) -> RoadMotion | None:
        """Speed and route status now, None before the first estimate."""
        est = self._est
        if est is None:
            return None
        if self.route is None:
            return RoadMotion(est.t, est.speed, None)
        if self._own_way:  # (off its route)
            return RoadMotion(est.t, est.speed, False)
        off = self._off_road
        return RoadMotion(est.t, est.speed if off else self._along, not off)

    def set_route(
        self,
        route: Road,
        holds: Sequence[tuple[float, float]] = (),
        *,
        circuit: bool = False,
        speeds: Sequence[tuple[float, float]] = (),
        keeps_speed: bool = False,
    ) -> None:
        """A new route (the convoy is found on it afresh at the next estimate), where
        along it the convoy plans to stand and how long: (arc length, seconds), whether
        it is one lap of a circuit (its end where it began) driven in laps, the speeds it
        plans to drive: (arc length, m/s from there on), and whether it keeps a speed of
        its own where none is planned (a rover driving the route as its mission, at a
        default speed the service could not read: ``cruise``)."""
        self._holds = tuple(sorted((float(a), float(h)) for a, h in holds if h > 0.0))
        self._paces = tuple(sorted((float(a), float(v)) for a, v in speeds if v > 0.0))
        self._keeps_speed = keeps_speed
        self._learnt = (math.nan, None)
        self._keep(None, math.nan)
        self._steady.clear()
        self._circuit = circuit
        self._holding, self._held = None, set()
        self._rejoin = None  # (a point of the route before)
        self.route = route
        self._roads = (route, route.reversed())
        self._reversed = False
        self._lost_since = None
        self._off_since = None
        self.left_route = False
        est, self._est = self._est, None
        if est is not None:
            self.observe(est)

    def set_drive(
        self, drive: ConvoyDrive | None, destination: tuple[float, float] | None = None
    ) -> None:
        """What drives the convoy's lead vehicle from now on (its mode; None: not said,
        as its mission). Back in its mission while standing at a planned hold, the hold
        starts again, as ArduRover restarts the waypoint it stands at. On its way home
        (``HOME``) to ``destination`` (x, y: the lead's home), it is forecast to drive
        straight there and stand, whatever its route (``ModeRTL``); not knowing where
        home is, from its own velocity, as off its route. On its way home back along its
        path (``RETRACE``), back along the path it was seen to drive, to its first point,
        and stand there (``ModeSmartRTL``). Back in its mission with a
        ``destination`` (the waypoint it was driving to when sent home), straight to it
        and on along the route from there, as ``AP_Mission::resume`` drives it."""
        was, self._drive = self._drive, drive
        going, self._going = self._going, destination if drive is ConvoyDrive.HOME else None
        self._rejoin = None
        route, est = self.route, self._est  # (its mission's way: AUTO drives it so)
        if drive is not was and est is not None:  # (a way of its own starts here)
            turn = max(0.0, est.speed - _TURN_ROUND_MPS) / _TURN_ACCEL
            self._way_from = (est.t, turn + _ASTRAY_S)
        if drive is not was or self._going != going:  # (where it goes is new: watched anew)
            self._astray_since, self.astray = None, False
        homeward = (ConvoyDrive.HOME, ConvoyDrive.RETRACE)
        if drive in homeward and was not in homeward:
            on = route is not None and not (self._off_road or self._reversed)
            self._left = (self._s, est.east, est.north) if on and est is not None else None
            self._way_top = max(0.0 if est is None else est.speed, self._cruise or 0.0)
        if drive is ConvoyDrive.RETRACE and was is not ConvoyDrive.RETRACE:
            self._retrace, self._retrace_s = self._way_back(), 0.0
        elif drive is not ConvoyDrive.RETRACE:
            self._retrace = None
        if drive is ConvoyDrive.MISSION and destination is not None and route is not None:
            self._rejoin = (*destination, self._rejoin_arc(route, destination))
        back = drive is ConvoyDrive.MISSION and was not in (None, ConvoyDrive.MISSION)
        if back and est is not None and self._holding is not None:
            self._stood_since = est.t
        if back:  # (a speed told is gone: ArduRover drives WP_SPEED again, seen anew)
            self._keep(None, math.nan if est is None else est.t)

    def _rejoin_arc(self, road: Road, point: tuple[float, float]) -> float:
        """Where along ``road`` the waypoint ``point`` it drives back to is: on the pass
        it was driving when sent home (a road that comes back along itself passes the
        same point more than once), within the straight distance to it of where it left."""
        left = self._left
        if left is None:
            return road.project(*point, None)
        arc, x, y = left
        return road.project(*point, arc, window=math.dist((x, y), point) + _REJOINED_M)

    def _way_back(self) -> Road | None:
        """The way back along the path it was seen to drive, from where it is (its
        newest point) to the first: None if it was seen to drive none."""
        way = self._path.way_back()
        if len(way) < 2:
            return None
        xs, ys = zip(*way, strict=True)
        try:
            return Road.from_points(xs, ys)
        except PlanningError:  # (points within a metre of each other: it drove nowhere)
            return None

    def _retrace_goal(self) -> tuple[float, float] | None:
        """Back along its path: the point a little on along that way it heads for."""
        road = self._retrace
        if road is None:
            return None
        p = road.point(min(self._retrace_s + _RETRACE_AIM_M, road.length))
        return p.x, p.y

    def _check_way(self, est: ConvoyEstimate) -> None:
        """Whether the convoy drives the way of its own it is forecast to (home, or back
        to its route). Past the time its turn round takes (braking from its speed then at
        ``_TURN_ACCEL``, plus ``_ASTRAY_S``), ``_ASTRAY_S`` s driving at ``_CRUISING_MPS``
        or more over ``_TURNING_OFF_RAD`` off the way there is ``astray``: a rally point
        nearer than home, a home moved, a mode read wrong. It is then forecast from its
        own velocity (and back on its route, by its route) until it heads there again."""
        goal = self._going or self._retrace_goal()
        goal = goal or (None if self._rejoin is None else self._rejoin[:2])
        since, grace = self._way_from
        if goal is None or not est.t - since > grace or est.speed < _CRUISING_MPS:
            self._astray_since = None
            return
        way = math.atan2(goal[1] - est.north, goal[0] - est.east)
        if abs(math.remainder(way - math.atan2(est.vn, est.ve), math.tau)) <= _TURNING_OFF_RAD:
            self._astray_since, self.astray = None, False
            return
        if self._astray_since is None:
            self._astray_since = est.t
        if not self.astray and est.t - self._astray_since >= _ASTRAY_S:
            self.astray = True
            self.counters["astray"] += 1
            self._rejoin = None  # (its route is watched as any drive's on it)

    @property
    def drive(self) -> ConvoyDrive | None:
        """What drives the lead vehicle, as last said (None: never said)."""
        return self._drive

    @property
    def _plan_holds(self) -> bool:
        """The convoy keeps its plan: it drives its mission, or stands where it was told
        to (it will drive its mission on from there), or nobody said otherwise."""
        return self._drive not in (ConvoyDrive.OTHER, ConvoyDrive.HOME, ConvoyDrive.RETRACE)

    def observe(self, est: ConvoyEstimate) -> None:
        """Fold in a fresh estimate (stale ones say nothing new: skip them)."""
        if est.stale or not all(map(math.isfinite, (est.north, est.east, est.vn, est.ve))):
            return
        first = self._est is None
        self._est = est
        if self._drive is ConvoyDrive.RETRACE:
            self._path.reached(est.east, est.north, _RETRACED_M)
            road = self._retrace
            if road is not None:
                on = road.project(est.east, est.north, self._retrace_s, _RETRACE_NEAR_M)
                self._retrace_s = min(max(self._retrace_s, on), road.length)
        else:
            self._path.add(est.east, est.north)
        self._check_way(est)
        rejoin = self._rejoin
        if (
            rejoin is not None
            and math.hypot(est.east - rejoin[0], est.north - rejoin[1]) < _REJOINED_M
        ):
            # At the point it drove back to: on its route again, there, its way.
            self._rejoin, self._s, self._reversed = None, rejoin[2], False
            self._lost_since = self._off_since = None
            self.left_route = self._leaving = False
        route = self.road
        if route is None:
            return
        x, y = est.east, est.north
        s = route.project(x, y, None if first else self._s)
        if self._circuit and not first and s > route.length - _WRAP_M:
            s = self._next_lap(route, x, y, s, est)
        off, along = _on(route, s, est)
        against = along <= -_CRUISING_MPS
        beyond = not 0.0 <= s <= route.length
        if not (est.speed >= _CRUISING_MPS and (self.left_route or beyond or against)):
            self._lost_since = None
        elif self._lost_since is None:
            self._lost_since = est.t
        elif est.t - self._lost_since >= _LOST_S:
            course = math.atan2(est.vn, est.ve)
            found = self._found_again(x, y, course, s, off, beyond or against, against)
            if found is not None:
                s, route = found
                off, along = _on(route, s, est)
                self._lost_since = None
        self._s = s
        if self._held:  # back before a hold it has stood at (a lap): it holds there again
            self._held = {k for k in self._held if self._holds[k][0] <= s + _HOLD_NEAR_M}
        self._along = max(0.0, along)
        self._leaving = (
            est.speed >= _CRUISING_MPS
            and off > _TURNING_OFF_M
            and along < est.speed * math.cos(_TURNING_OFF_RAD)
        )
        if self._along >= _CRUISING_MPS and not self._own_way:
            self._cruise = self._along  # (not off its route on a way of its own)
        if self._along >= _STANDING_MPS:
            self._stood_since = None
            if self._holding is not None:  # pulled away: that hold is done
                self._held.add(self._holding)
                self._holding = None
        else:
            if self._stood_since is None:
                self._stood_since = est.t
            if self._holding is None and not self._reversed:
                near = [
                    k
                    for k, (arc, _) in enumerate(self._holds)
                    if k not in self._held and self._apart(arc, s) <= _HOLD_NEAR_M
                ]
                self._holding = near[0] if near else None
        self._note_speed(est.t, self._along)
        self._watch_kept(est)
        if self._along >= _CRUISING_MPS and self._plan_holds:
            driven = self._driven
            driven.append((est.t, self._along))
            while driven[0][0] < est.t - CRUISE_WINDOW_S:
                driven.popleft()
        if off > self.off_route_m:
            if self._off_since is None:
                self._off_since = est.t
            if not self.left_route and est.t - self._off_since >= self.off_route_s:
                self.left_route = True
                self.counters["left_route"] += 1
        else:
            self._off_since = None
            if self.left_route:
                self.left_route = False
                self.counters["back_on_route"] += 1
        road = self.road
        if road is not None and not self._off_road:
            self.corner_habit.observe(est.t, road, self._s, self._along)

    def _next_lap(self, route: Road, x: float, y: float, s: float, est: ConvoyEstimate) -> float:
        """``s`` near the end of a circuit, or where the next lap has the convoy (on
        it, not before its start) if that is nearer, or as near once past the end (a lap
        closing on a straight): a new lap (every hold planned again)."""
        s0 = route.project(x, y, 0.0, _WRAP_M)
        d0, d = _on(route, s0, est)[0], _on(route, s, est)[0]
        past = s > route.length and d0 <= d + _WRAP_TIE_M
        if s0 < 0.0 or not (d0 < d - _WRAP_TIE_M or past):
            return s
        self._held.clear()
        self.counters["laps"] += 1
        return s0

    def _apart(self, a: float, b: float) -> float:
        """Metres between two arc lengths (round the circuit the shorter way)."""
        d = abs(a - b)
        road = self.road
        return min(d, road.length - d) if self._circuit and road is not None else d

    def _lapped(self, route: Road, arcs: FloatArray, *, end: bool = True) -> FloatArray:
        """Arc lengths on ``route`` for ones driven on from here: round the circuit, or
        stopped at the route's end (where the convoy is going; ``end``, else straight on)."""
        if self._circuit:
            return np.mod(arcs, route.length)
        return np.minimum(arcs, route.length) if end else arcs

    def _found_again(
        self,
        x: float,
        y: float,
        course: float,
        s: float,
        off: float,
        lost_way: bool,
        either_way: bool,
    ) -> tuple[float, Road] | None:
        """Where the convoy is found again on the whole route (either way round if
        ``either_way``): its arc length and the route the way it drives it (now
        :attr:`road`); None to keep ``s``.

        A place counts if it is within ``off_route_m`` and, to be taken over ``s``, half
        as far off as ``s`` is, or (``lost_way``: past the end or driving against the
        route) no more than ``_REFIND_NEAR_M`` farther; and it is another place: the
        other way round, or ``_REFIND_JUMP_M`` along the route from ``s``.
        """
        best: tuple[float, float, bool] | None = None
        for reverse, road in enumerate(self._roads):
            if road is None or (not either_way and reverse != self._reversed):
                continue
            hit = road.nearest_heading(x, y, course)
            if hit is not None and (best is None or hit[1] < best[1]):
                best = (hit[0], hit[1], bool(reverse))
        if best is None:
            return None
        s_new, off_new, reverse = best
        if off_new > self.off_route_m:
            return None
        if not (off_new <= 0.5 * off or (lost_way and off_new <= off + _REFIND_NEAR_M)):
            return None
        if reverse == self._reversed and abs(s_new - s) < _REFIND_JUMP_M:
            return None
        self._reversed = reverse
        self.counters["found_again"] += 1
        road = self.road
        assert road is not None
        return s_new, road

    def _note_speed(self, t: float, speed: float) -> None:
        """Add a speed along the route to the trailing window (trapezoids, O(1) each)."""
        speeds = self._speeds
        if self._first_speed_t is None:
            self._first_speed_t = t
        if speeds:
            t0, v0 = speeds[-1]
            self._distance += 0.5 * (v0 + speed) * (t - t0)
        speeds.append((t, speed))
        while len(speeds) > 1 and speeds[1][0] <= t - self.mean_window_s:
            (t0, v0), (t1, v1) = speeds.popleft(), speeds[0]
            self._distance -= 0.5 * (v0 + v1) * (t1 - t0)

    @property
    def mean_speed(self) -> float | None:
        """Mean speed along the route over the last ``mean_window_s``; None until the
        convoy has been seen that long (its start from standing is not its pace)."""
        speeds = self._speeds
        first = self._first_speed_t
        if first is None or speeds[-1][0] - first < self.mean_window_s:
            return None
        span = speeds[-1][0] - speeds[0][0]
        return self._distance / span if span > 0.0 else None

    def ahead(self, dt: FloatArray) -> FloatArray:
        """Metres the convoy is forecast to drive along the route in ``dt`` seconds:
        ``m dt + (v - m) relax_s (1 - exp(-dt / relax_s))`` from its speed ``v`` and its
        recent mean ``m``, when ``v > m``; ``v dt`` otherwise."""
        v = self._along
        mean = self.mean_speed
        tau = self.relax_s
        if tau <= 0.0 or mean is None or mean >= v:
            return v * dt
        return mean * dt - (v - mean) * tau * np.expm1(-dt / tau)

    def position(self, t: float) -> tuple[float, float]:
        """Predicted (x, y) at time ``t`` (>= the latest estimate's time)."""
        est = self._est
        if est is None:
            return 0.0, 0.0
        x, y = self.positions(np.array([t]))
        return float(x[0]), float(y[0])

    def positions(self, times: npt.NDArray[np.float64]) -> tuple[FloatArray, FloatArray]:
        """:meth:`position` at every time of ``times`` (each >= the latest estimate's)."""
        est = self._est
        if est is None:
            return np.zeros(len(times)), np.zeros(len(times))
        dt = _since(times, est)
        if self._going is not None or self._retrace is not None:
            if self.astray:
                return est.east + est.ve * dt, est.north + est.vn * dt
            if self._retrace is not None:
                return self._retracing(est, dt, self._retrace)
            return self._homeward(est, dt)
        road = self.road
        if self._rejoin is not None and self.route is not None:
            return self._rejoining(est, dt, self.route, self._rejoin)
        if road is None or self._off_road:
            return est.east + est.ve * dt, est.north + est.vn * dt
        x, y, _, _ = road.arrays(self._lapped(road, self._arcs(dt)))
        return x, y

    def _homeward(self, est: ConvoyEstimate, dt: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Its own way to where it is going (``set_drive``), and standing there."""
        assert self._going is not None
        x, y, _, _ = self._way(est, self._going, dt)
        return x, y

    def _retracing(
        self, est: ConvoyEstimate, dt: FloatArray, way: Road
    ) -> tuple[FloatArray, FloatArray]:
        """Back along the path it was seen to drive (``set_drive``): its own way
        (``_way``: turned round if it must) to the point it heads for on that path, then
        on along it at the speed of its own way, standing at its end, its first point.
        A rover that was seen to take its route's corners slowly (``CornerHabit``)
        takes the corners of its way back so too: its firmware slows for them whatever
        mode drives it."""
        goal_s = min(self._retrace_s + _RETRACE_AIM_M, way.length)
        goal = way.point(goal_s)
        x, y, gone, far = self._way(est, (goal.x, goal.y), dt)
        past = gone > far
        if not past.any():
            return x, y
        arcs = goal_s + gone - far
        corner = self.corner_habit.speed
        top = max(est.speed, self._cruise or 0.0, self._way_top)
        if corner is not None and corner < CORNER_RATIO * top:
            grid = np.arange(0.0, float(np.max(dt)) + _PLAN_STEP, _PLAN_STEP)
            _, _, ahead, _ = self._way(est, (goal.x, goal.y), grid)
            timetable = goal_s + np.maximum(ahead - far, 0.0)
            cap = self.corner_habit.cap(way, corner, HOLD_ACCEL)
            arcs = np.interp(dt, grid, warp(timetable, _PLAN_STEP, cap, 0.0))
        x[past], y[past], _, _ = way.arrays(np.minimum(arcs[past], way.length))
        return x, y

    def _way(
        self, est: ConvoyEstimate, goal: tuple[float, float], dt: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, float]:
        """Where (x, y) a convoy driving its own way to ``goal`` is ``dt`` s on, how far
        along that way, and its length. Heading more than ``_TURN_ROUND_RAD`` away from
        the goal, it first brakes along its heading to ``_TURN_ROUND_MPS`` and turns there,
        as ArduRover SITL sent home 111° off its heading at 8 m/s did (braking at about
        1 m/s², through the turn at 1.7 m/s, 29 m on; the forecast straight home from
        where it was told was 60-90 m off it 5-10 s on); then straight there (``_gone``)."""
        gx, gy = goal
        v0, x0, y0 = est.speed, est.east, est.north
        brake_s = brake_m = 0.0
        if v0 > _TURN_ROUND_MPS:
            heading = math.atan2(est.vn, est.ve)
            off = math.remainder(math.atan2(gy - y0, gx - x0) - heading, math.tau)
            if abs(off) > _TURN_ROUND_RAD:
                brake_s = (v0 - _TURN_ROUND_MPS) / _TURN_ACCEL
                brake_m = 0.5 * (v0 + _TURN_ROUND_MPS) * brake_s
        ux, uy = (est.ve / v0, est.vn / v0) if brake_m > 0.0 else (0.0, 0.0)
        tx, ty = x0 + ux * brake_m, y0 + uy * brake_m  # (where it turns)
        dx, dy = gx - tx, gy - ty
        far = math.hypot(dx, dy)
        braking = dt < brake_s
        early = np.minimum(dt, brake_s)
        along = v0 * early - 0.5 * _TURN_ACCEL * early**2
        v1 = _TURN_ROUND_MPS if brake_m > 0.0 else v0
        turned = self._gone(v1, np.maximum(dt - brake_s, 0.0))
        share = np.minimum(turned, far) / max(far, 1e-6)
        x = np.where(braking, x0 + ux * along, tx + dx * share)
        y = np.where(braking, y0 + uy * along, ty + dy * share)
        return x, y, np.where(braking, along, brake_m + turned), brake_m + max(far, 1e-6)

    def _gone(self, v0: float, dt: FloatArray) -> FloatArray:
        """Metres driven in ``dt`` s on a way of its own (home, or back to its route):
        from ``v0`` up to the last speed it drove at (before it was sent home, whatever
        it braked to for the turn round), at ``_TURN_ACCEL`` (it turns round, or pulls
        away from a stand)."""
        top = max(v0, self._cruise or 0.0, self._way_top)
        ramp = (top - v0) / _TURN_ACCEL
        up = v0 * dt + 0.5 * _TURN_ACCEL * dt**2
        return np.where(dt < ramp, up, v0 * ramp + 0.5 * _TURN_ACCEL * ramp**2 + top * (dt - ramp))

    def _rejoining(
        self, est: ConvoyEstimate, dt: FloatArray, road: Road, rejoin: tuple[float, float, float]
    ) -> tuple[FloatArray, FloatArray]:
        """Its own way to the point of its route it drives back to (``_way``), then on
        along the route from there by its plan's timetable (``_arcs``: a hold there stood,
        its speeds driven), as if it were there now at the speed it gets there at."""
        gx, gy, arc = rejoin
        x, y, gone, far = self._way(est, (gx, gy), dt)
        past = gone > far
        if not past.any():
            return x, y
        grid = np.arange(0.0, float(dt[-1]) + _PLAN_STEP, _PLAN_STEP)
        _, _, reach, _ = self._way(est, (gx, gy), grid)
        k = min(int(np.searchsorted(reach, far)), len(grid) - 1)
        arrive = float(grid[k])
        speed = float(reach[k] - reach[k - 1]) / _PLAN_STEP if k > 0 else est.speed
        saved = (self._s, self._along, self._holding, self._reversed)
        self._s, self._along, self._holding, self._reversed = arc, speed, None, False
        try:
            arcs = self._arcs(np.maximum(dt[past] - arrive, 0.0))
        finally:
            self._s, self._along, self._holding, self._reversed = saved
        x[past], y[past], _, _ = road.arrays(self._lapped(road, arcs))
        return x, y

    def _hold_here(self) -> tuple[float, float] | None:
        """Standing at a planned hold: (its arc, seconds of it left, 0 once overstayed)."""
        est, since, k = self._est, self._stood_since, self._holding
        if est is None or since is None or k is None:
            return None
        arc, seconds = self._holds[k]
        if self._drive is ConvoyDrive.HELD:  # (told to stand: until told otherwise)
            return arc, math.inf
        return arc, max(0.0, seconds - (est.t - since))

    def _pace_at(self, arc: float) -> float | None:
        """The planned speed in force at ``arc`` (the last change at or before it; on a
        circuit, before the lap's first, the lap's last); where none is, the speed a
        convoy that keeps its own was seen to (``cruise``), else None (and None while
        the plan is set aside, ``set_drive``). A speed the rover keeps instead
        (``kept``) is in force from where it was seen to the plan's next change."""
        if not self._plan_holds:
            return None
        kept = self._kept
        if kept is not None and kept[0] <= arc and not self._changes_between(kept[0], arc):
            return kept[1]
        return self._planned_pace(arc)

    def _planned_pace(self, arc: float) -> float | None:
        """The plan's speed in force at ``arc`` (``_pace_at``, whatever the rover keeps)."""
        paces = self._paces
        k = bisect.bisect_right(paces, (arc, math.inf))
        if k:
            return paces[k - 1][1]
        if self._circuit and paces:
            return paces[-1][1]
        return self.cruise

    def _changes_between(self, a: float, b: float) -> bool:
        """Whether the plan changes speed after arc ``a`` and at or before ``b`` (on a
        circuit, the next lap's changes too)."""
        arcs = [arc for arc, _ in self._paces]
        if self._circuit and self.road is not None:
            arcs += [arc + self.road.length for arc in arcs]
        return any(a < arc <= b for arc in arcs)

    @property
    def kept(self) -> float | None:
        """The speed the rover was seen to keep in place of its plan's, in force until
        the plan's next change of speed (None: it keeps the plan's, or nothing is known)."""
        return None if self._kept is None else self._kept[1]

    def _keep(self, kept: tuple[float, float] | None, t: float) -> None:
        """From now on the rover keeps ``kept`` (from arc, m/s), or its plan (None)."""
        if kept == self._kept:
            return
        self._kept = kept
        if len(self.kept_log) < _KEPT_KEPT and math.isfinite(t):
            plan = self._planned_pace(self._s) if kept is not None else None
            self.kept_log.append((t, None if kept is None else kept[1], plan))

    def _watch_kept(self, est: ConvoyEstimate) -> None:
        """Whether the rover keeps a speed of its own in place of its plan's (``kept``):
        a route driven by an autopilot, driving steadily on it where no curve slows it."""
        steady, road = self._steady, self.road
        kept = self._kept
        if kept is not None and road is not None and self._s < kept[0] - _WRAP_M:
            # (on the next lap of a circuit: from there, a lap back; else found elsewhere)
            kept = (kept[0] - road.length, kept[1]) if self._circuit else None
            self._kept = kept
        if kept is not None and self._changes_between(kept[0], self._s):
            self._keep(kept := None, est.t)  # (the plan's next speed: its own again)
        moving = self._along >= _CRUISING_MPS and self._plan_holds and not self._off_road
        window = self.kept_window_s
        if not (self._keeps_speed and moving and road is not None and window > 0.0) or (
            self._reversed
        ):
            steady.clear()
            return
        steady.append((est.t, self._s, self._along))
        while steady[0][0] < est.t - window:
            steady.popleft()
        t0, s0, _ = steady[0]
        speeds = [v for _, _, v in steady]
        if est.t - t0 < 0.9 * window or max(speeds) - min(speeds) > KEPT_SPREAD_MPS:
            return
        speed = sum(speeds) / len(speeds)
        plan = self._planned_pace(self._s)
        if plan is None or self._changes_between(s0, self._s):
            return
        fastest = max(speed, plan)
        if road.max_curvature(s0, self._s + fastest**2 / (2.0 * HOLD_ACCEL)) > (
            HOLD_ACCEL / fastest**2
        ):
            return  # (a curve that would slow it, near or ahead: its speed says nothing)
        if abs(speed - plan) <= max(KEPT_OFF_MPS, 0.1 * plan):
            self._keep(None, est.t)
        elif kept is None or abs(speed - kept[1]) > KEPT_SPREAD_MPS:
            self._keep((s0, speed), est.t)

    @property
    def cruise(self) -> float | None:
        """The speed a convoy that keeps its own (``set_route(keeps_speed=True)``) drives
        at: of its speeds along the route while driving over the last
        ``CRUISE_WINDOW_S``, the ``CRUISE_QUANTILE``-th percentile (its corners, its
        braking and pulling away are the slower rest), once it has driven
        ``CRUISE_MIN_S`` and been seen to take the route's sharp corners under
        ``CORNER_RATIO`` of it, as an autopilot does; None otherwise. (A convoy that
        keeps no such speed, a recorded drive replayed as a mission, lost 3-8 points on
        roundabouts, speed changes and the recorded drives when forecast at it.)"""
        driven, est, corner = self._driven, self._est, self.corner_habit.speed
        if not self._keeps_speed or est is None or not driven or corner is None:
            return None
        if self._learnt[0] == est.t:
            return self._learnt[1]
        speed = None
        if driven[-1][0] - driven[0][0] >= CRUISE_MIN_S:
            speed = float(np.percentile([v for _, v in driven], CRUISE_QUANTILE))
            if corner >= CORNER_RATIO * speed:
                speed = None
        self._learnt = (est.t, speed)
        return speed

    def _plan_ahead(self) -> list[tuple[float, float, float]]:
        """The plan's events ahead, by arc: (arc, seconds held, 0 for a speed change;
        planned speed from there, nan for a hold), the next lap's too on a circuit."""
        s = self._s
        events = [
            (a, h, math.nan)
            for k, (a, h) in enumerate(self._holds)
            if k not in self._held and k != self._holding and a > s - _HOLD_BEHIND_M
        ]
        events += [(a, 0.0, v) for a, v in self._paces if a > s]
        road = self.road
        if self._circuit and road is not None:  # and the next lap's
            lap = road.length
            events += [(a + lap, h, math.nan) for a, h in self._holds]
            events += [(a + lap, 0.0, v) for a, v in self._paces]
        return sorted(events, key=lambda e: (e[0], e[1] == 0.0))

    def _arcs(self, dt: FloatArray) -> FloatArray:
        """Arc length along the road ``dt`` seconds after the estimate: ``ahead``, or with
        a plan (holds, speeds) the timetable it makes (module rules)."""
        base = self._s + self.ahead(dt)
        road = self.road
        planned = self._holds or self._paces or self.cruise is not None
        if not (planned and self._plan_holds) or self._reversed or len(dt) == 0 or road is None:
            return base
        here = self._hold_here()
        events = self._plan_ahead()
        corner = self.corner_speed
        # (slow in a corner it takes slowly, it is driving: back up to the plan's speed)
        driving = self._along >= (_CRUISING_MPS if corner is None else _STANDING_MPS)
        now = self._pace_at(self._s) if driving else None
        if here is None and not events and now is None:
            return base
        end = float(np.max(dt))
        grid = np.arange(0.0, end + 2.0 * _PLAN_STEP, _PLAN_STEP)
        arc = np.empty_like(grid)
        a = HOLD_ACCEL

        def cruise_at(where: float) -> float:
            """The speed it pulls away to from a hold: planned, or the last it drove at."""
            pace = self._pace_at(where)
            return pace if pace is not None else self._cruise or self.mean_speed or 0.0

        def move(tau: FloatArray) -> FloatArray:
            """Driving from ``t0``: as forecast, or from ``origin`` at ``v0`` changing at
            ``a`` to ``v1`` and on at that."""
            if forecast:
                return self._s + self.ahead(tau)
            ramp = abs(v1 - v0) / a
            acc = math.copysign(a, v1 - v0)
            up = np.where(
                tau < ramp,
                v0 * tau + 0.5 * acc * tau**2,
                v0 * ramp + 0.5 * acc * ramp**2 + v1 * (tau - ramp),
            )
            return origin + up

        t0, origin, v0, v1, forecast = 0.0, self._s, self._along, self._along, now is None
        if now is not None:
            v1 = now
        if here is not None:
            arc[grid < here[1]] = origin
            t0, v0, v1, forecast = here[1], 0.0, cruise_at(origin), False
        for at_arc, seconds, pace in events:
            top = self._along if forecast else v1
            later = grid >= t0
            f = move(grid[later] - t0)
            # To a hold it brakes evenly, to stand at its arc (harder when nearer than the
            # braking distance; at once when on it or past it); a new speed it takes up
            # from its arc on, as the firmware runs DO_CHANGE_SPEED at the waypoint.
            brake = top * top / (2.0 * a) if seconds > 0.0 else 0.0
            hit = np.flatnonzero(f >= at_arc - brake)
            if len(hit) == 0:
                break
            t_hit = float(grid[later][hit[0]])
            before = later & (grid < t_hit)
            arc[before] = f[: int(np.count_nonzero(before))]
            at = float(f[hit[0]])
            forecast = False
            if seconds <= 0.0:
                t0, origin, v0, v1 = t_hit, at, top, pace
                continue
            stop = max(at_arc, at)
            t_stop = t_hit + (2.0 * (stop - at) / top if top > 0.0 else 0.0)
            braking = (grid >= t_hit) & (grid < t_stop)
            if t_stop > t_hit:
                tau = grid[braking] - t_hit
                arc[braking] = at + top * tau - 0.5 * (top / (t_stop - t_hit)) * tau**2
            arc[(grid >= t_stop) & (grid < t_stop + seconds)] = stop
            t0, origin, v0, v1 = t_stop + seconds, stop, 0.0, cruise_at(stop)
        later = grid >= t0
        arc[later] = move(grid[later] - t0)
        if corner is not None:
            cap = self.corner_habit.cap(road, corner, HOLD_ACCEL)
            arc = warp(arc, _PLAN_STEP, cap, road.length if self._circuit else 0.0)
        return np.interp(dt, grid, arc)

    @property
    def corner_speed(self) -> float | None:
        """The speed the convoy is forecast to take the route's sharp corners at: as it
        has been seen to (``CornerHabit``), where that is under ``CORNER_RATIO`` of the
        speed its plan has in force; None otherwise (at its speed)."""
        pace = self._pace_at(self._s)
        seen = self.corner_habit.speed
        if pace is None or seen is None or seen >= CORNER_RATIO * pace:
            return None
        return seen

    def stopping_short(
        self, times: npt.NDArray[np.float64], curvature: float, short_m: float
    ) -> tuple[FloatArray, FloatArray] | None:
        """:meth:`positions` for a convoy that stops ``short_m`` before the next corner of
        the route sharper than ``curvature`` (1/m), if it gets there by the last of
        ``times``; None without a route, off it, (nearly) stopped, or with no such corner
        within reach.
        """
        est = self._est
        route = self.road
        if est is None or route is None or self._off_road or self._along < _MOVING_MPS:
            return None
        if self._own_way:
            return None
        s = self._s + self.ahead(_since(times, est))
        ahead = np.arange(self._s, float(s[-1]) + short_m, _CORNER_STEP_M)
        _, _, _, k = route.arrays(self._lapped(route, ahead, end=False))
        sharp = np.abs(k) >= curvature
        if sharp[ahead < self._s + _CORNER_FROM_M].any():
            # In a corner (or at it) already, the convoy turns it: the next one counts.
            first = int(np.argmax(sharp))
            out = np.flatnonzero(~sharp[first:])
            sharp[: first + (int(out[0]) if len(out) else len(sharp))] = False
        corners = np.flatnonzero(sharp)
        if len(corners) == 0:
            return None
        stop = float(ahead[corners[0]]) - short_m
        x, y, _, _ = route.arrays(self._lapped(route, np.minimum(s, max(stop, self._s)), end=False))
        return x, y

    def driving_off(
        self, times: npt.NDArray[np.float64], below_mps: float, accel: float
    ) -> tuple[FloatArray, FloatArray] | None:
        """:meth:`positions` for a convoy slower than ``below_mps`` along its route that
        pulls away now, at ``accel`` (m/s^2) up to the speed it last drove at; None
        without a route, off it, faster, or never seen driving.

        ``below_mps`` is well above zero: in 3 m of GPS noise the tracker's velocity of
        a parked convoy is about 1 m/s.

        Raises:
            ValueError: If ``accel`` is not positive.
        """
        if not accel > 0.0:
            raise ValueError(f"accel must be positive, got {accel!r}")
        est = self._est
        route = self.road
        cruise = self._cruise
        if est is None or route is None or self._off_road or cruise is None:
            return None
        if self._own_way:
            return None
        if self._along >= below_mps:
            return None
        dt = _since(times, est)
        ramp = cruise / accel  # s to cruise
        gone = np.where(dt < ramp, 0.5 * accel * dt**2, 0.5 * cruise * ramp + cruise * (dt - ramp))
        x, y, _, _ = route.arrays(self._lapped(route, self._s + gone, end=False))
        return x, y

    def velocity(self) -> tuple[float, float]:
        """Estimated velocity (vx, vy) now."""
        est = self._est
        return (0.0, 0.0) if est is None else (est.ve, est.vn)
