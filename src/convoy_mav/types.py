"""Values that cross the service's layers: setpoints, telemetry, convoy estimates.

Design rules:
- Everything is in the *mission frame*: north-east-down metres from the mission's
  geographic origin (``convoy_mav.geo.LocalFrame``), headings in radians clockwise
  from north, times in mission seconds (the autopilots' clock, not wall time).
- The planner's frame (x east, y north, heading counter-clockwise from east) is
  converted exactly once, in ``convoy_mav.schedule``.
- Immutable and slotted; the ones created at setpoint and telemetry rates are
  ``@value`` classes (frozen to the type checker, cheap to create).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from convoy_mav.values import value

__all__ = ["ConvoyDrive", "ConvoyEstimate", "Setpoint", "Telemetry", "VehicleStatus"]


@value
class Setpoint:
    """What one UAV should be doing at one instant.

    Attributes:
        t: Mission time the setpoint is for, seconds.
        north, east, down: Position in the mission frame, metres.
        vn, ve, vd: Velocity feed-forward, m/s.
        yaw: Course along the path, rad clockwise from north.
        yaw_rate: Turn rate, rad/s, positive clockwise (NED convention).
        center: (north, east) of the arc being flown, or None on a straight.
        radius: Radius of that arc, metres (0 on a straight).
        clockwise: Direction of that arc seen from above.
        hold: True when the service wants the UAV to loiter where it is
            (pause, shutdown) rather than fly the plan.
    """

    t: float
    north: float
    east: float
    down: float
    vn: float
    ve: float
    vd: float
    yaw: float
    yaw_rate: float
    center: tuple[float, float] | None = None
    radius: float = 0.0
    clockwise: bool = True
    hold: bool = False


class VehicleStatus(StrEnum):
    """Where a UAV is in its life with the service."""

    CONNECTING = "connecting"  # no heartbeat yet
    WAITING_FIX = "waiting_fix"  # heartbeat, but no usable position yet
    SETTING_UP = "setting_up"  # mode / arm / take-off in progress
    FLYING = "flying"  # accepting and flying setpoints
    HOLDING = "holding"  # told to loiter (pause or shutdown)
    LOST = "lost"  # silent for longer than the liveness timeout
    FAILED = "failed"  # set-up gave up; the reason was reported


@value
class Telemetry:
    """The latest digest of one vehicle's state, in the mission frame.

    Attributes:
        sysid: MAVLink system id.
        t: Mission time of the sample, seconds.
        north, east, down: Position, metres.
        vn, ve, vd: Ground velocity, m/s.
        yaw: Heading, rad clockwise from north.
        lat, lon, alt: The same position as WGS-84 degrees and metres AMSL.
    """

    sysid: int
    t: float
    north: float
    east: float
    down: float
    vn: float
    ve: float
    vd: float
    yaw: float
    lat: float
    lon: float
    alt: float


class ConvoyDrive(StrEnum):
    """What drives the convoy's lead vehicle now, as its autopilot's mode says."""

    MISSION = "mission"  # its mission (AUTO): the plan read from it holds
    HELD = "held"  # it stands until told otherwise (HOLD, disarmed)
    OTHER = "other"  # a driver or another command (MANUAL, GUIDED): no plan holds
    HOME = "home"  # its way home (RTL): straight there, where it stands; no plan holds
    RETRACE = "retrace"  # its way home back along the path it drove (SMART_RTL): no plan holds


@dataclass(frozen=True, slots=True)
class ConvoyEstimate:
    """Where the convoy centroid is and how it moves, as far as the service knows.

    Attributes:
        t: Mission time of the estimate, seconds.
        north, east: Centroid, metres in the mission frame.
        vn, ve: Velocity, m/s: the vehicles' own reports or the slope of their fixes
            (``ConvoyTracker``).
        stale: True when no fresh, finite input arrived recently: the numbers
            are the last good estimate held, and an alarm is raised.
    """

    t: float
    north: float
    east: float
    vn: float
    ve: float
    stale: bool = False

    @property
    def speed(self) -> float:
        """Ground speed, m/s."""
        return float((self.vn * self.vn + self.ve * self.ve) ** 0.5)
