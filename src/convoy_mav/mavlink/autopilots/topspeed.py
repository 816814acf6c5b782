"""A multicopter's top speed, learnt from its own telemetry while it falls behind.

A multicopter's speed is bounded by how far it may lean, not by a speed parameter
alone: ArduCopter flies a GUIDED velocity target as sent whatever ``WPNAV_SPEED`` is,
and stops accelerating where drag balances its lean at ``ANGLE_MAX`` (SITL's quad,
30 degrees: 11.5 m/s); PX4 clamps at ``MPC_XY_VEL_MAX`` but leans no further than
``MPC_TILTMAX_AIR`` either. Neither top speed is a parameter the service can read.
So it is seen: a copter asked to fly faster than it does, trailing its slot, at a
speed that no longer rises, is flying as fast as it can. Pure (no I/O): fed each
position update in the protect phase by the service.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

__all__ = ["TopSpeed"]


@dataclass
class TopSpeed:
    """The fastest a copter flies, once seen saturated for ``window_s``.

    A sample is *saturated* when the copter trails its setpoint along the path by more
    than ``behind_m`` and flies slower than asked by more than ``short_mps`` (and
    ``short_frac`` of the asked speed). A run of saturated samples ``window_s`` long
    whose flown speed varies by less than ``flat_mps`` (no longer accelerating: a
    copter speeding up from a hover is short of its target too) is the top speed:
    the run's mean. The largest such is kept; a copter later seen faster than it
    (its lean limit raised) has it raised too.

    Attributes:
        top: The top speed learnt (m/s), None until seen.
    """

    window_s: float = 10.0
    behind_m: float = 10.0
    short_mps: float = 1.0
    short_frac: float = 0.05
    flat_mps: float = 1.0
    top: float | None = None
    _run: deque[tuple[float, float]] = field(default_factory=deque, init=False, repr=False)

    def forget(self) -> None:
        """What held it back was changed (its speed limit raised): see it again."""
        self.top = None
        self._run.clear()

    def observe(self, t: float, flown: float, asked: float, behind: float) -> float | None:
        """Fold in one update: ``flown`` and ``asked`` horizontal speeds (m/s), how far
        it trails its setpoint (m, ``along_track_error``). Returns the top speed when
        this update learnt a new one, else None."""
        top = self.top
        if top is not None and flown > top + self.flat_mps:
            self.top = flown  # (faster than its "top": whatever held it back is gone)
            self._run.clear()
            return flown
        short = asked - flown > max(self.short_mps, self.short_frac * asked)
        if not (short and behind > self.behind_m):
            self._run.clear()
            return None
        run = self._run
        run.append((t, flown))
        while run and t - run[0][0] > self.window_s:
            run.popleft()
        if t - run[0][0] < 0.9 * self.window_s:
            return None
        speeds = [s for _, s in run]
        if max(speeds) - min(speeds) >= self.flat_mps:
            return None
        mean = sum(speeds) / len(speeds)
        if top is not None and mean <= top + 0.5 * self.flat_mps:
            return None  # (no news: the same top, seen again)
        self.top = mean
        return mean
