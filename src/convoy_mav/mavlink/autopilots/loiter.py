"""Loiters flown at the radius planned: learn how wide an autopilot flies, command less.

A fixed-wing autopilot flies a commanded loiter with its own navigation controller
(ArduPlane's L1 and TECS, PX4's NPFG), and flies it wide: ArduPlane SITL circles a
100 m DO_REPOSITION loiter at about 118 m at 22 m/s. The paper's coverage depends on
the radius (a UAV at R + 18 sees the convoy for less of each lap), so the radius is a
loop to close, like the phase.

Model: a loiter commanded at radius ``c`` is flown at ``c + k / c``, with ``k`` (m^2)
a property of the airframe and its tuning, ``(V T)^2`` for a lag ``T`` at airspeed
``V``: the overshoot grows with speed and shrinks with the radius. To fly ``R`` the
command is the larger root of ``c^2 - R c + k = 0``, ``c = (R + sqrt(R^2 - 4k)) / 2``;
below ``2 sqrt(k)`` no command flies that tight, and ``sqrt(k)``, which flies the
tightest circle, is sent (the plan then asks for more than the airframe gives, which
``feasible`` says and the service raises as an alarm).

``k`` may be negative (an autopilot that flies tight: commanded wider). It is
learnt from telemetry while a loiter has been held long enough to settle
(half a lap): each position gives ``k_i = (rho - c) c`` with ``rho`` its distance
from the commanded centre, folded into an exponential average. Pure: times come in.
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

    def command_radius(self, radius: float) -> float:
        """The radius to command so that ``radius`` is flown; if none can, ``sqrt(k)``,
        the command that flies the tightest circle (``2 sqrt(k)``)."""
        disc = radius * radius - 4.0 * self.k
        if disc < 0.0:
            return math.sqrt(self.k)
        return 0.5 * (radius + math.sqrt(disc))

    def flown_radius(self, commanded: float) -> float:
        """Where a loiter commanded at ``commanded`` is flown, by the model."""
        return commanded + self.k / commanded if commanded > 0.0 else 0.0

    def feasible(self, radius: float) -> bool:
        """Whether some command flies ``radius`` (``radius >= 2 sqrt(k)``)."""
        return radius * radius >= 4.0 * self.k

    def observe(
        self,
        distance: float,
        commanded: float,
        held_s: float,
        speed: float,
    ) -> bool:
        """Fold in one position on a loiter.

        Args:
            distance: The aircraft's distance from the commanded centre (m).
            commanded: The commanded radius (m).
            held_s: How long that loiter has been commanded (s).
            speed: The aircraft's speed (m/s), for the length of a lap.

        Returns:
            True if the sample was used.
        """
        if not (commanded > 0.0 and speed > 0.0 and math.isfinite(distance)):
            return False
        if held_s < self.settle_laps * math.tau * commanded / speed:
            return False
        if abs(distance - commanded) > self.capture * commanded:
            return False
        self.k += self.gain * ((distance - commanded) * commanded - self.k)
        self.samples += 1
        return True
