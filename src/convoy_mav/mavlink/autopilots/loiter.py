"""Loiters flown at the radius planned: learn how wide an autopilot flies, command less.

A fixed-wing autopilot flies a commanded loiter with its own navigation controller
(ArduPlane's L1 and TECS, PX4's NPFG), and flies it wide: ArduPlane SITL circles a
100 m DO_REPOSITION loiter at about 118 m at 22 m/s, and a 2275 m one at 2438 m. The
paper's coverage depends on the radius (a UAV at R + 18 sees the convoy for less of
each lap), and an arc laid on the plan but flown 160 m outside takes the UAV off its
slot, so the radius is a loop to close, like the phase.

Model: a loiter commanded at radius ``c`` is flown at ``s c + k / c``.

* ``s`` is the firmware's own scaling, known from physics: ArduPlane flies every loiter
  at ``EAS2TAS^2`` times its radius (``atmosphere``), 6-7 % wider 600 m above the sea
  (the caller passes it; 1 for an autopilot that does not scale).
* ``k`` (m^2) is a property of the airframe and its tuning, ``(V T)^2`` for a lag ``T``
  at airspeed ``V``: the overshoot grows with speed and shrinks with the radius.

To fly ``R`` the command is the larger root of ``s c^2 - R c + k = 0``,
``c = (R + sqrt(R^2 - 4 s k)) / (2 s)``; below ``2 sqrt(s k)`` no command flies that
tight, and ``sqrt(k / s)``, which flies the tightest circle, is sent (the plan then asks
for more than the airframe gives, which ``feasible`` says and the service raises as an
alarm).

``k`` may be negative (an autopilot that flies tight: commanded wider). It is learnt
from telemetry while a loiter has been held long enough to settle (half a lap): each
position gives ``k_i = (rho - s c) c`` with ``rho`` its distance from the commanded
centre, folded into an exponential average. ``s`` is not learnt: a loiter held long
enough to tell it from ``k`` (one km wide, for tens of seconds) is rare in flight, so
a day much warmer than the standard atmosphere (ArduPilot takes the ground's
temperature) or ``NAVL1_LIM_BANK`` set leaves a few percent of a wide loiter's radius
uncorrected. Pure: times come in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["LoiterModel"]


@dataclass(slots=True)
class LoiterModel:
    """The learnt overshoot ``k`` of one aircraft's loiters (see the module docstring).

    Args:
        gain: Weight of one position sample in the average (samples come at the
            setpoint rate, 20 Hz: 0.01 is a time constant of 5 s).
        settle_laps: Share of a lap a loiter must be held before it is measured.
        capture: A sample further than this share of the radius off the commanded
            circle is not yet on it (a plane still turning in) and is ignored.

    Attributes:
        k: The overshoot constant, m^2 (0: loiters flown as commanded).
        samples: Positions folded in so far.
    """

    gain: float = 0.01
    settle_laps: float = 0.5
    capture: float = 0.5
    k: float = 0.0
    samples: int = 0

    def command_radius(self, radius: float, scale: float = 1.0) -> float:
        """The radius to command so that ``radius`` is flown by an autopilot that scales
        its loiters by ``scale``; if none can, ``sqrt(k / scale)``, the command that flies
        the tightest circle (``2 sqrt(scale k)``)."""
        disc = radius * radius - 4.0 * scale * self.k
        if disc < 0.0:
            return math.sqrt(self.k / scale)
        return 0.5 * (radius + math.sqrt(disc)) / scale

    def flown_radius(self, commanded: float, scale: float = 1.0) -> float:
        """Where a loiter commanded at ``commanded`` is flown, by the model."""
        return scale * commanded + self.k / commanded if commanded > 0.0 else 0.0

    def tightest(self, scale: float = 1.0) -> float:
        """The tightest loiter any command flies (m): ``2 sqrt(scale k)``, 0 if k <= 0."""
        return 2.0 * math.sqrt(max(scale * self.k, 0.0))

    def feasible(self, radius: float, scale: float = 1.0) -> bool:
        """Whether some command flies ``radius`` (``radius >= 2 sqrt(scale k)``)."""
        return radius * radius >= 4.0 * scale * self.k

    def observe(
        self,
        distance: float,
        commanded: float,
        held_s: float,
        speed: float,
        scale: float = 1.0,
    ) -> bool:
        """Fold in one position on a loiter.

        Args:
            distance: The aircraft's distance from the commanded centre (m).
            commanded: The commanded radius (m).
            held_s: How long that loiter has been commanded (s).
            speed: The aircraft's speed (m/s), for the length of a lap.
            scale: The autopilot's own scaling of that loiter (``s``).

        Returns:
            True if the sample was used.
        """
        if not (commanded > 0.0 and speed > 0.0 and math.isfinite(distance)):
            return False
        if held_s < self.settle_laps * math.tau * commanded / speed:
            return False
        if abs(distance - scale * commanded) > self.capture * commanded:
            return False
        self.k += self.gain * ((distance - scale * commanded) * commanded - self.k)
        self.samples += 1
        return True
