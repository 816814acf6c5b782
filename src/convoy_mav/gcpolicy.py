"""The garbage collector's policy while the fleet flies: collect on a schedule.

In flight the service makes tens of thousands of short-lived objects a second
per thousand UAVs (decoded messages and their headers, telemetry, setpoints,
timer handles) and reference counting frees them all: measured in flight, the
cyclic collector finds no garbage among them. Left to its allocation counts it
still runs, and each run is a pause of the whole flight loop: at 1000 UAVs,
CPython's default thresholds stop it for 1-2 ms thirty times a second and for
5-15 ms twice a second; a higher young-generation threshold makes the runs rarer
but longer (10-30 ms). Either way about one setpoint interval in thirty of
every UAV came out 10-30 ms long, and the p99 interval with it.

So, once the links are up, what exists then (links, vehicles, plan) is frozen
out of the collector's sight and automatic collection is off; a task collects
every ``GC_PERIOD_S`` wall seconds instead, or at once if ``GC_BACKSTOP``
tracked objects have piled up (a storm of exceptions, say). Wall seconds, not
mission seconds: what piles up is the process's allocations, whatever the speedup.

A run walks only what is not frozen, and then freezes what survived it: what
is still alive after a run is mostly the fleet's long-lived state (set-up made
most of it), so the next run walks only what is alive and younger than the
last run (each UAV's latest messages, telemetry, timers). Measured at 1000
UAVs: a routine run takes about 15 ms instead of 40-70 ms. The price: a cycle
that was alive when frozen and dies later is not found by those runs, so every
``GC_FULL_EVERY``-th run first unfreezes everything and walks it all (about
100 ms at 1000 UAVs, once in ten minutes: two setpoints late, far inside
PX4's half-second offboard timeout).
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import time
from collections.abc import Iterator

__all__ = ["GC_BACKSTOP", "GC_FULL_EVERY", "GC_PERIOD_S", "collect_on_schedule", "flight_gc"]

GC_PERIOD_S = 30.0
GC_FULL_EVERY = 20  # runs: a full walk every ten minutes at the default period
GC_BACKSTOP = 200_000  # tracked objects allocated, net, since the last collection
_LOOK_S = 1.0  # how often the backstop is looked at


@contextlib.contextmanager
def flight_gc() -> Iterator[None]:
    """Freeze what exists and switch automatic collection off, until exit.

    On exit the collector is switched back on (if it was on) and the frozen
    objects are handed back to it. Pair with :func:`collect_on_schedule`.
    """
    was_enabled = gc.isenabled()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
        gc.unfreeze()


async def collect_on_schedule(
    period: float = GC_PERIOD_S,
    backstop: int = GC_BACKSTOP,
    *,
    full_every: int = GC_FULL_EVERY,
    look: float = _LOOK_S,
) -> None:
    """Collect every ``period`` wall seconds, or sooner past ``backstop``; until cancelled.

    Each run freezes its survivors; every ``full_every``-th run walks everything.
    """
    if not (period > 0.0 and look > 0.0 and backstop >= 1 and full_every >= 1):
        raise ValueError(
            "need period > 0, look > 0, backstop >= 1, full_every >= 1; "
            f"got {period}, {look}, {backstop}, {full_every}"
        )
    last = time.monotonic()
    runs = 0
    while True:
        await asyncio.sleep(min(look, period))
        now = time.monotonic()
        if now - last >= period or gc.get_count()[0] >= backstop:
            runs += 1
            if runs % full_every == 0:
                gc.unfreeze()  # cycles that died after they were frozen
            gc.collect()
            gc.freeze()
            last = now
