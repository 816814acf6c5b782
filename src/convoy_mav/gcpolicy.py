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
tracked objects have piled up (a storm of exceptions, say). A scheduled run
walks everything not frozen (tens of ms at 1000 UAVs): one long interval per
UAV per period, which is below the 99th percentile as long as the period holds
more than a hundred setpoints. Wall seconds, not mission seconds: what piles up
is the process's allocations, whatever the speedup.
"""

from __future__ import annotations

import asyncio
import contextlib
import gc
import time
from collections.abc import Iterator

__all__ = ["GC_BACKSTOP", "GC_PERIOD_S", "collect_on_schedule", "flight_gc"]

GC_PERIOD_S = 30.0
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
    period: float = GC_PERIOD_S, backstop: int = GC_BACKSTOP, *, look: float = _LOOK_S
) -> None:
    """Collect every ``period`` wall seconds, or sooner past ``backstop``; until cancelled."""
    if not (period > 0.0 and look > 0.0 and backstop >= 1):
        raise ValueError(
            f"need period > 0, look > 0, backstop >= 1; got {period}, {look}, {backstop}"
        )
    last = time.monotonic()
    while True:
        await asyncio.sleep(min(look, period))
        now = time.monotonic()
        if now - last >= period or gc.get_count()[0] >= backstop:
            gc.collect()
            last = now
