"""A rover's progress along its drive, held while it is told to stand.

The mock's ground routes are pure functions of sim time. A rover drives its route
only in AUTO and armed; switched to HOLD (or MANUAL with no sticks, GUIDED with no
target, or disarmed) it brakes to a stand and waits, and back in AUTO it pulls away
and drives on from where it stood, the rest of its timetable later by the time it
stood. So its position is its route's at *drive time*, which runs with sim time while
it drives and stands still while it stands. Between the two the drive time's rate
ramps (1 to 0 braking, 0 to 1 pulling away) over ``v / a`` seconds, ``v`` the route's
speed at that drive time: it brakes and pulls away at ``a`` (ArduRover's
``ATC_ACCEL_MAX``, 1 m/s² by default).

ArduRover's HOLD cuts the throttle (``ModeHold::update``) and leaves the stop to the
vehicle: SITL's rover coasts to a stand with a 2-s time constant (measured with
``checks/rover_mission.py drive --hold``: 17-18 m on and 9-10 s from 8 m/s). The mock
brakes evenly at the accel instead (32 m and 8 s): a real rover's stop is its drive
train's, which neither models.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

__all__ = ["DEFAULT_ACCEL", "Drivable", "DriveClock", "Holds"]

DEFAULT_ACCEL = 1.0
"""m/s²: ArduRover's ``ATC_ACCEL_MAX`` default (``AR_ATTCONTROL_THR_ACCEL_MAX``)."""


class Drivable(Protocol):
    """A rover's route as the clock needs it (any ``sitl_mock.ground.Route``)."""

    def velocity(self, t: float) -> tuple[float, float]: ...


@runtime_checkable
class Holds(Protocol):
    """A route with waypoints' holds (``sitl_mock.ground.Polyline``)."""

    def hold_began(self, t: float) -> float: ...


@dataclass(slots=True)
class DriveClock:
    """Drive time at each sim time: ``at(t)``; told when the rover drives: ``drive``.

    Starts driving, with drive time equal to sim time. Times passed in never go back.
    """

    accel: float = DEFAULT_ACCEL
    _t0: float = 0.0  # sim time of the last change
    _tau0: float = 0.0  # drive time then
    _rate0: float = 1.0  # its rate then
    _to: float = 1.0  # the rate it ramps to (1 driving, 0 standing)
    _slope: float = math.inf  # how fast the rate ramps, per second

    def __post_init__(self) -> None:
        if not (math.isfinite(self.accel) and self.accel > 0.0):
            raise ValueError(f"DriveClock.accel must be positive, got {self.accel!r}")

    @property
    def driving(self) -> bool:
        """Whether the rover drives (or is pulling away), not stands (or is braking)."""
        return self._to > 0.0

    def _ramp_s(self) -> float:
        """Seconds from the last change until the rate is where it ramps to."""
        return abs(self._to - self._rate0) / self._slope if self._slope < math.inf else 0.0

    def rate(self, t: float) -> float:
        """Drive seconds per sim second at ``t`` (0 standing, 1 driving)."""
        dt = max(t - self._t0, 0.0)
        ramp = self._ramp_s()
        if dt >= ramp:
            return self._to
        return self._rate0 + math.copysign(self._slope, self._to - self._rate0) * dt

    def at(self, t: float) -> float:
        """Drive time at sim time ``t``."""
        dt = max(t - self._t0, 0.0)
        ramp = self._ramp_s()
        slope = math.copysign(self._slope, self._to - self._rate0) if ramp > 0.0 else 0.0
        u = min(dt, ramp)
        tau = self._tau0 + self._rate0 * u + 0.5 * slope * u * u
        return tau + self._to * (dt - u)

    def follow(self, t: float, driving: bool, route: Drivable) -> None:
        """From sim time ``t`` the rover drives ``route`` (True) or stands (False), as
        ArduRover does: back to driving during a waypoint's hold, it stands the whole
        hold again (``AP_Mission::resume`` restarts the waypoint)."""
        if driving == self.driving:
            return
        tau = self.at(t)
        if driving and self.rate(t) == 0.0 and isinstance(route, Holds):
            self.rewind(t, tau := route.hold_began(tau))
        self.drive(t, driving, math.hypot(*route.velocity(tau)))

    def rewind(self, t: float, tau: float) -> None:
        """Standing, from sim time ``t`` at drive time ``tau`` instead (a waypoint's hold
        started again: its position is the same)."""
        if self.driving or self.rate(t) > 0.0:
            raise ValueError("only a standing rover's drive time is set back")
        self._t0, self._tau0, self._rate0 = t, tau, 0.0

    def retime(
        self, t: float, tau: float, speed_was: float, speed_now: float, moving: float | None = None
    ) -> None:
        """From sim time ``t``, drive time ``tau`` on the route retimed (a speed its
        operator told, or its mission's again): ``speed_was`` the old timetable's speed
        then, ``speed_now`` the new one's there. The rover's own speed is kept (``moving``,
        if it is not the old timetable's: a follower leaving its leader's trail), and the
        rate ramps from it at the accel, to driving or to standing as before."""
        actual = self.rate(t) * speed_was if moving is None else moving
        self._t0, self._tau0 = t, tau
        if speed_now > 0.0 and math.isfinite(speed_now):
            self._rate0 = actual / speed_now
            self._slope = self.accel / speed_now
        else:
            self._rate0, self._slope = self._to, math.inf

    def drive(self, t: float, driving: bool, speed: float) -> None:
        """From sim time ``t`` the rover drives (True) or stands (False); ``speed`` is
        its route's speed (m/s) at the drive time then: braking from it, or pulling away
        to it, takes ``speed / accel`` seconds (none at all from or to a stand)."""
        to = 1.0 if driving else 0.0
        if to == self._to:
            return
        tau, rate = self.at(t), self.rate(t)
        ramp = max(speed, 0.0) / self.accel if math.isfinite(speed) else 0.0
        self._t0, self._tau0, self._rate0, self._to = t, tau, rate, to
        self._slope = 1.0 / ramp if ramp > 0.0 else math.inf
