"""Value types of the mock's flight physics: airframe limits, aircraft state, guidance.

Kept apart from ``kinematics`` (the integrator and guidance laws) so the autopilot
layer and tests can build and read these values without the physics; everything
here is re-exported from ``sitl_mock.kinematics``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "AircraftState",
    "AirframeParams",
    "Frame",
    "Guidance",
    "Idle",
    "Loiter",
    "Takeoff",
    "TrackTarget",
]

Frame = Literal["plane", "copter"]


@dataclass(frozen=True, slots=True)
class AirframeParams:
    """Physical limits of one airframe; the autopilot layer never changes them.

    Attributes:
        frame: ``"plane"`` (cannot hover, constant airspeed) or ``"copter"``.
        airspeed: Plane cruise airspeed; copter maximum horizontal airspeed (m/s).
        min_turn_radius: The turn-rate bound is ``speed / min_turn_radius`` (m).
        max_climb_rate: Vertical speed limit, both ways (m/s).
        altitude_time_constant: First-order altitude response toward the target (s).
        max_accel: Limit on airspeed changes (m/s^2).
        min_airspeed_ratio: Plane airspeed never goes below this times ``airspeed``.
        max_airspeed_ratio: Plane airspeed never goes above this times ``airspeed``.
        wind_north: Constant wind toward the north (m/s).
        wind_east: Constant wind toward the east (m/s).
        loiter_lag: T (s) of the navigation controller flying a loiter: a plane
            circles at ``R + (V T)^2 / R`` for a circle of radius R at airspeed V, as
            ArduPlane's L1 controller flies its loiters wide (T = 1.55 s, with the
            firmware's density scaling of R: ``Firmware.loiter_scale``). 0: loiters
            flown exactly (copters).

    Raises:
        ValueError: A field is out of range; the message names it.
    """

    frame: Frame = "plane"
    airspeed: float = 18.0
    min_turn_radius: float = 80.0
    max_climb_rate: float = 4.0
    altitude_time_constant: float = 2.0
    max_accel: float = 2.0
    min_airspeed_ratio: float = 0.6
    max_airspeed_ratio: float = 1.5
    wind_north: float = 0.0
    wind_east: float = 0.0
    loiter_lag: float = 0.0

    def __post_init__(self) -> None:
        if self.frame not in ("plane", "copter"):
            raise ValueError(f"frame must be 'plane' or 'copter', got {self.frame!r}")
        for name in (
            "airspeed",
            "min_turn_radius",
            "max_climb_rate",
            "altitude_time_constant",
            "max_accel",
            "min_airspeed_ratio",
            "max_airspeed_ratio",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be positive and finite, got {value!r}")
        if not (math.isfinite(self.loiter_lag) and self.loiter_lag >= 0.0):
            raise ValueError(f"loiter_lag must be >= 0 and finite, got {self.loiter_lag!r}")
        for name in ("wind_north", "wind_east"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
        if self.min_airspeed_ratio > 1.0:
            raise ValueError(f"min_airspeed_ratio must be <= 1, got {self.min_airspeed_ratio!r}")
        if self.max_airspeed_ratio < 1.0:
            raise ValueError(f"max_airspeed_ratio must be >= 1, got {self.max_airspeed_ratio!r}")


@dataclass(slots=True)
class AircraftState:
    """Where an aircraft is and how it moves; owned and mutated by its ``Aircraft``.

    Attributes:
        north: World NED position (m).
        east: World NED position (m).
        down: World NED position (m), positive below the origin.
        yaw: Direction of the air-relative velocity, rad clockwise from north in (-pi, pi].
        speed: Horizontal airspeed (m/s); climb is independent of it.
        yaw_rate: Turn rate actually applied during the last step (rad/s).
        climb_rate: Mean vertical speed of the last step, positive up (m/s).
        airborne: False on the ground, where wind does not move the aircraft.
    """

    north: float
    east: float
    down: float
    yaw: float
    speed: float
    yaw_rate: float = 0.0
    climb_rate: float = 0.0
    airborne: bool = False

    def velocity_ned(self, params: AirframeParams) -> tuple[float, float, float]:
        """Ground velocity (vn, ve, vd): air velocity plus the wind when airborne."""
        vn = self.speed * math.cos(self.yaw)
        ve = self.speed * math.sin(self.yaw)
        if self.airborne:
            vn += params.wind_north
            ve += params.wind_east
        return vn, ve, -self.climb_rate


@dataclass(frozen=True, slots=True)
class TrackTarget:
    """A position/velocity setpoint (SET_POSITION_TARGET_*); ``None`` fields are ignored.

    Position and velocity count only when both horizontal components are given;
    non-finite values (MAVLink's NaN "unused") count as ``None``. With a velocity the
    aircraft tracks a reference that starts at the position (if any) and moves at
    that velocity, turning at the rate implied by consecutive velocity targets; a
    plane flies the velocity's magnitude as airspeed (clamped). With a position only,
    planes circle it clockwise at ``min_turn_radius`` and copters fly there and hover.
    With neither, the horizontal guidance in force stays. ``down`` beats ``vd``; with
    neither, an altitude target stays and a climb rate stops. ``yaw`` and
    ``yaw_rate`` are ignored: a plane's nose is its course, and this model gives a
    copter no nose apart from its velocity.
    """

    north: float | None = None
    east: float | None = None
    down: float | None = None
    vn: float | None = None
    ve: float | None = None
    vd: float | None = None
    yaw: float | None = None
    yaw_rate: float | None = None


@dataclass(frozen=True, slots=True)
class Loiter:
    """Circle a point (DO_REPOSITION, failsafe, hold); a copter with radius 0 hovers.

    The radius is raised to ``min_turn_radius`` for planes, and for copters unless it
    is 0, since no aircraft here can fly a tighter circle.

    Raises:
        ValueError: A field is not finite or the radius is negative.
    """

    north: float
    east: float
    down: float
    radius: float
    clockwise: bool = True

    def __post_init__(self) -> None:
        for name in ("north", "east", "down", "radius"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ValueError(f"Loiter.{name} must be finite, got {value!r}")
        if self.radius < 0.0:
            raise ValueError(f"Loiter.radius must be >= 0, got {self.radius!r}")


@dataclass(frozen=True, slots=True)
class Takeoff:
    """Climb to ``down``: a copter vertically, a plane straight ahead and then loiter.

    Raises:
        ValueError: ``down`` is not finite.
    """

    down: float

    def __post_init__(self) -> None:
        if not math.isfinite(self.down):
            raise ValueError(f"Takeoff.down must be finite, got {self.down!r}")


@dataclass(frozen=True, slots=True)
class Idle:
    """Motors off on the ground; in the air, land (plane: glide straight down to it)."""


Guidance = TrackTarget | Loiter | Takeoff | Idle
