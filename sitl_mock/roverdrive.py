"""A rover's drive along its route: when it drives, and the speed it is told (pure).

A mock rover's position is its route's at drive time (``DriveClock``): the drive time
stands while the rover is told to stand. A speed told (DO_CHANGE_SPEED, in AUTO) is the
same road retimed (``Polyline.with_speed_from``), in force until the mission's next
DO_CHANGE_SPEED: then the plan's own again, entered at the speed the rover has. And
ArduRover entering AUTO again drives WP_SPEED until the next (``AR_WPNav::init`` sets
its speed from the parameter, and ``AP_Mission::resume`` runs no DO command again).
PX4 entering its mission again forgets a told speed (``MissionBase::on_activation``:
``reset_cruising_speed``) and replays the mission's last speed item before the waypoint
it drives to (``replayCachedSpeedChangeItems``): the plan's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from sitl_mock.driveclock import DEFAULT_ACCEL, DriveClock
from sitl_mock.ground import Lagged, Polyline, Route

__all__ = ["RoverDrive"]


@dataclass(slots=True)
class RoverDrive:
    """The route ``plan`` as driven: ``route`` (retimed by a speed told) at drive time
    ``clock.at(t) - lag`` (a follower drives its leader's road ``lag`` s behind it: a
    ``Lagged`` plan). Times passed in never go back."""

    plan: Route
    route: Route = field(init=False)
    lag: float = field(init=False, default=0.0)
    wp_speed: float = field(init=False, default=0.0)  # (its plan's, ArduRover's WP_SPEED)
    clock: DriveClock = field(init=False)
    _told_until: float = field(init=False, default=math.inf)  # (drive time: plan's again)
    _await_auto: bool = field(init=False, default=False)  # (a new plan: stands until AUTO)

    def __post_init__(self) -> None:
        plan = self.plan
        if isinstance(plan, Lagged):
            self.lag = plan.lag
            plan = plan.inner
        self.route = plan
        accel = plan.accel if isinstance(plan, Polyline) and plan.accel > 0.0 else DEFAULT_ACCEL
        self.clock = DriveClock(accel)
        # The speed its plan drives where no DO_CHANGE_SPEED says (0: a route with none of
        # its own, a recorded track): the plan's, not a loop's told for every lap.
        self.wp_speed = float(plan.speed) if isinstance(plan, Polyline) else 0.0

    def at(self, t: float) -> float:
        """Drive time on ``route`` at sim time ``t``."""
        return self.clock.at(t) - self.lag

    def state(self, t: float) -> tuple[float, float, float, float]:
        """(north, east, vn, ve) at sim time ``t``."""
        tau, rate = self.at(t), self.clock.rate(t)
        n, e = self.route.position(tau)
        vn, ve = self.route.velocity(tau)
        return n, e, vn * rate, ve * rate

    def follow(self, t: float, driving: bool, *, reset_speed: bool) -> None:
        """From sim time ``t`` it drives (armed in AUTO) or stands. Entering AUTO again,
        ``reset_speed`` (ArduRover): WP_SPEED until the mission's next speed; else (PX4)
        the mission's own speed there, a told one forgotten. A speed told gives way where
        the mission's next one comes. A plan set to wait (``drive_anew``) waits for AUTO
        to be entered."""
        if self._await_auto:
            self._await_auto = driving
            driving = False
        route, clock = self.route, self.clock
        if isinstance(route, Polyline):
            if driving and not clock.driving and reset_speed:
                self.tell(t, self.wp_speed)
            elif driving and not clock.driving and route.told is not None:
                self._give_way(t, route, route.as_planned())
            elif route.told is not None and self.at(t) >= self._told_until:
                self._give_way(t, route, route.after_told())
        clock.follow(t, driving, Lagged(self.route, self.lag) if self.lag else self.route)

    def speed_set(self, t: float) -> float:
        """The speed its navigation is set to drive at, at sim time ``t``: told, else its
        plan's there (0: a route that takes none, a recorded track's)."""
        route = self.route
        if not isinstance(route, Polyline):
            return 0.0
        return route.told[1] if route.told is not None else route.planned_speed(self.at(t))

    def finished(self, t: float) -> bool:
        """Whether at sim time ``t`` it has driven its plan to the end."""
        return isinstance(self.route, Polyline) and self.route.finished(self.at(t))

    def drive_anew(
        self,
        t: float,
        plan: Polyline,
        *,
        wait: bool = False,
        arc: float = 0.0,
        wp_speed: float | None = None,
        moving: float | None = None,
    ) -> None:
        """From sim time ``t`` its plan is ``plan`` (a mission uploaded), from where the
        rover is: its start, or ``arc`` metres along its first leg (the rest of a mission
        laid on); entered at the speed it has (``moving``; None: its route's), changing at
        its accel. ``wait``: it stands until AUTO is next entered (its mission over, in
        AUTO). ``wp_speed``: its WP_SPEED from now on (None: the plan's speed; a return
        home keeps the one it had)."""
        self._await_auto = wait
        route, tau_was = self.route, self.at(t)
        speed_was = math.hypot(*route.velocity(tau_was))
        moving = self.clock.rate(t) * speed_was if moving is None else moving
        self.plan, self.lag = plan, 0.0
        self.wp_speed = float(plan.speed) if wp_speed is None else wp_speed
        tau0 = plan.time_at(arc)
        told, tau = plan.with_speed_from(tau0, plan.planned_speed(tau0), moving)
        now_speed = math.hypot(*told.velocity(tau))
        self.clock.retime(t, tau, speed_was, now_speed, moving)
        if wait:  # (its mission over, it stands: at once)
            self.clock.drive(t, False, 0.0)
        self.route = told
        self._told_until = told.told_until(tau)

    def _give_way(self, t: float, route: Polyline, after: Polyline) -> None:
        """A told speed gives way to ``after`` (its own plan from here), entered at the
        speed it has."""
        tau = route.moment_on(after, self.at(t))
        self.tell(t, after.planned_speed(tau), after, tau)

    def tell(
        self, t: float, speed: float, on: Polyline | None = None, tau: float | None = None
    ) -> bool:
        """From sim time ``t`` drive at ``speed`` until the mission's next speed, on the
        route driven or on ``on`` (the same road, at its drive time ``tau``); False: a
        route that takes no speed (a recorded track's, or none)."""
        route, clock = self.route, self.clock
        if not isinstance(route, Polyline) or not speed > 0.0:
            return False
        tau_was = self.at(t)
        if on is None and route.told is None and route.planned_speed(tau_was) == speed:
            return True  # (the speed it drives at already)
        speed_was = math.hypot(*route.velocity(tau_was))
        moving = clock.rate(t) * speed_was
        on, tau = (route, tau_was) if on is None or tau is None else (on, tau)
        told, tau = on.with_speed_from(tau, speed, moving)
        clock.retime(t, tau + self.lag, speed_was, math.hypot(*told.velocity(tau)))
        self.route = told
        self._told_until = told.told_until(tau)
        return True
