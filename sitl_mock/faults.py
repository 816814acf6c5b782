"""Fault injection for the mock: pure decisions, no sockets, no clocks.

Design rules:
    * Every random decision draws from an injected ``random.Random`` so a seed
      replays the same losses; probability 0 draws nothing and 1 always drops.
    * Times are sim seconds passed in by the caller (``now``), never read here.
    * Latency is a delay queue keyed by the sim time an item becomes due; the
      server drains it every physics step, so latency is quantised to 10 ms of
      sim time, which is finer than any autopilot stream.
    * Scheduled events (kill, reboot, an operator's mode change, a ground vehicle
      stalled) fire exactly once, in time order.
"""

from __future__ import annotations

import heapq
import itertools
import math
import random
from dataclasses import dataclass, field
from typing import Generic, Literal, TypeVar

__all__ = ["DelayQueue", "FaultEvent", "FaultInjector", "FaultSpec", "TimedFault", "TimedMode"]

T = TypeVar("T")


@dataclass(frozen=True, slots=True)
class TimedFault:
    """Something that happens to vehicle ``sysid`` at sim time ``at`` (seconds)."""

    sysid: int
    at: float

    def __post_init__(self) -> None:
        if not 1 <= self.sysid <= 255:
            raise ValueError(f"sysid must be in 1..255, got {self.sysid!r}")
        if not (math.isfinite(self.at) and self.at >= 0.0):
            raise ValueError(f"at must be a finite time >= 0 s, got {self.at!r}")


@dataclass(frozen=True, slots=True)
class TimedMode:
    """Vehicle ``sysid`` switched to ``mode`` (its firmware's name: "HOLD", "RTL",
    "AUTO.LOITER") at sim time ``at`` by its own operator's ground station: a truck held
    or sent home while the rest of the convoy drives on."""

    sysid: int
    at: float
    mode: str

    def __post_init__(self) -> None:
        TimedFault(self.sysid, self.at)  # (the same checks)
        if not self.mode or not isinstance(self.mode, str):
            raise ValueError(f"mode must be a mode's name, got {self.mode!r}")


@dataclass(frozen=True, slots=True)
class FaultSpec:
    """What the link and the vehicles should suffer.

    Attributes:
        loss_to_vehicle: Probability that a datagram sent to a vehicle is lost.
        loss_from_vehicle: Probability that a datagram a vehicle sends is lost
            (decided per destination, as independent links would).
        latency_to_vehicle: Sim seconds added before a vehicle sees a datagram.
        latency_from_vehicle: Sim seconds added before a sent datagram leaves.
        duplicate: Probability that a datagram (either way) is delivered twice.
        jitter: Up to this many sim seconds added at random to each datagram's
            latency (either way), so datagrams overtake each other: reordering.
        kills: Vehicles that stop responding and sending entirely at a time.
        reboots: Vehicles that reboot (``time_boot_ms`` restarts) at a time.
        modes: Vehicles switched to a mode by their own operator at a time.
        stalls: Ground vehicles that stop at a time and move no more, their autopilot
            driving on (a breakdown, a blocked road): ``SimVehicle.stall``.
        sysids: Vehicles that loss and latency apply to; empty means all.
        seed: Seed of the random generator deciding losses.
    """

    loss_to_vehicle: float = 0.0
    loss_from_vehicle: float = 0.0
    latency_to_vehicle: float = 0.0
    latency_from_vehicle: float = 0.0
    duplicate: float = 0.0
    jitter: float = 0.0
    kills: tuple[TimedFault, ...] = ()
    reboots: tuple[TimedFault, ...] = ()
    modes: tuple[TimedMode, ...] = ()
    stalls: tuple[TimedFault, ...] = ()
    sysids: frozenset[int] = field(default_factory=frozenset)
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("loss_to_vehicle", "loss_from_vehicle", "duplicate"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"{name} must be a probability in [0, 1], got {p!r}")
        for name in ("latency_to_vehicle", "latency_from_vehicle", "jitter"):
            s = getattr(self, name)
            if not (math.isfinite(s) and s >= 0.0):
                raise ValueError(f"{name} must be finite seconds >= 0, got {s!r}")

    def applies_to(self, sysid: int) -> bool:
        """Whether loss and latency apply to the links of vehicle ``sysid``."""
        return not self.sysids or sysid in self.sysids


@dataclass(frozen=True, slots=True)
class FaultEvent:
    """A scheduled fault that has come due."""

    kind: Literal["kill", "reboot", "mode", "stall"]
    sysid: int
    at: float
    mode: str = ""  # (a mode change's)


class FaultInjector:
    """Decides, from a :class:`FaultSpec` and a seeded RNG, what goes wrong.

    Args:
        spec: The faults to inject.
        rng: Source of randomness; pass ``random.Random(seed)`` for replay.
    """

    def __init__(self, spec: FaultSpec, rng: random.Random) -> None:
        self.spec = spec
        self._rng = rng
        pending = [FaultEvent("kill", f.sysid, f.at) for f in spec.kills]
        pending += [FaultEvent("reboot", f.sysid, f.at) for f in spec.reboots]
        pending += [FaultEvent("mode", f.sysid, f.at, f.mode) for f in spec.modes]
        pending += [FaultEvent("stall", f.sysid, f.at) for f in spec.stalls]
        # Stable: a kill and a reboot at the same instant keep config order.
        self._pending = sorted(pending, key=lambda e: e.at)

    def _draw(self, p: float) -> bool:
        if p <= 0.0:
            return False
        if p >= 1.0:
            return True
        return self._rng.random() < p

    def drop_to_vehicle(self, sysid: int) -> bool:
        """Whether the next datagram to vehicle ``sysid`` is lost."""
        return self.spec.applies_to(sysid) and self._draw(self.spec.loss_to_vehicle)

    def drop_from_vehicle(self, sysid: int) -> bool:
        """Whether the next datagram from vehicle ``sysid`` (to one peer) is lost."""
        return self.spec.applies_to(sysid) and self._draw(self.spec.loss_from_vehicle)

    def delay_to_vehicle(self, sysid: int) -> float:
        """Sim seconds a datagram to vehicle ``sysid`` is held back (latency + jitter)."""
        if not self.spec.applies_to(sysid):
            return 0.0
        return self.spec.latency_to_vehicle + self._jitter()

    def delay_from_vehicle(self, sysid: int) -> float:
        """Sim seconds a datagram from vehicle ``sysid`` is held back (latency + jitter)."""
        if not self.spec.applies_to(sysid):
            return 0.0
        return self.spec.latency_from_vehicle + self._jitter()

    def copies(self, sysid: int) -> int:
        """How many times the next datagram of vehicle ``sysid`` (either way) arrives."""
        return 2 if self.spec.applies_to(sysid) and self._draw(self.spec.duplicate) else 1

    def _jitter(self) -> float:
        j = self.spec.jitter
        return self._rng.uniform(0.0, j) if j > 0.0 else 0.0

    def due_events(self, now: float) -> list[FaultEvent]:
        """Scheduled events with ``at <= now`` not returned before, oldest first."""
        n = 0
        while n < len(self._pending) and self._pending[n].at <= now:
            n += 1
        due, self._pending = self._pending[:n], self._pending[n:]
        return due


class DelayQueue(Generic[T]):
    """Items released in due-time order; ties keep insertion order (FIFO)."""

    def __init__(self) -> None:
        self._heap: list[tuple[float, int, T]] = []
        self._counter = itertools.count()

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, due: float, item: T) -> None:
        """Hold ``item`` until sim time ``due``."""
        heapq.heappush(self._heap, (due, next(self._counter), item))

    def pop_due(self, now: float) -> list[T]:
        """Remove and return every item with ``due <= now``."""
        out: list[T] = []
        while self._heap and self._heap[0][0] <= now:
            out.append(heapq.heappop(self._heap)[2])
        return out

    def clear(self) -> None:
        """Forget everything held (a killed vehicle's backlog)."""
        self._heap.clear()
