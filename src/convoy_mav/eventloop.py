"""The event loop the service flies on: uvloop where it is installed, asyncio's otherwise.

Why: at a thousand UAVs the flight loop handles about 13 000 datagrams and 400
timer wake-ups a second, and asyncio's selector loop spends a share of that in
Python per datagram (readiness bookkeeping, one ``recvfrom`` per callback).
uvloop does the same in C on libuv. Measured side by side on the fleet
benchmark it takes 23 % less CPU at 100 UAVs and 2 % less at 1000, where the
service's own Python dominates (README, "Fleet scale"). The service is
otherwise the same code on either loop: the end-to-end tests fly it on both.

uvloop's timers have millisecond resolution. Nothing here depends on finer:
``MissionClock.sleep_until`` looks at mission time again after every wake-up.
But uvloop rounds a delay to whole milliseconds, so a wait of under half a
millisecond is a timer due at once: a loop that waits so towards a deadline
spins a core until it is due. At 25x the mock's 100-Hz physics has a step every
0.4 wall ms, and it spent two thirds of its CPU so. Such waits go through
:func:`sleep` (or :func:`wait_set`), which wait one tick (1 ms) instead.

Bounded waits go through :func:`wait_set` (or ``asyncio.timeout``), never
``asyncio.wait_for``: on Python 3.11 that swallows a cancellation which arrives as
the awaited thing completes (CPython gh-86296), and a loop around it then runs on
after its task group was cancelled.

``CONVOY_MAV_LOOP=asyncio`` in the environment forces asyncio's loop (to
compare, or to rule uvloop out when something looks wrong); ``uvloop`` insists
on uvloop and fails if it is not installed; unset or ``auto`` picks.
"""

from __future__ import annotations

import asyncio
import os
from collections.abc import Callable, Coroutine
from typing import Any, TypeVar

from convoy_mav.errors import ConfigError

__all__ = ["LOOP_ENV", "TIMER_TICK", "loop_factory", "loop_name", "run", "sleep", "wait_set"]

LOOP_ENV = "CONVOY_MAV_LOOP"
TIMER_TICK = 0.001  # wall seconds: uvloop's (libuv's) timer resolution
T = TypeVar("T")


def loop_factory(choice: str | None = None) -> Callable[[], asyncio.AbstractEventLoop]:
    """The factory of the loop to fly on (``choice``: auto, uvloop, asyncio; default: env).

    Raises:
        ConfigError: An unknown choice, or ``uvloop`` asked for and not installed.
    """
    raw = choice if choice is not None else os.environ.get(LOOP_ENV, "")
    choice = raw.strip().lower() or "auto"
    if choice not in ("auto", "uvloop", "asyncio"):
        raise ConfigError(LOOP_ENV, raw, "must be auto, uvloop or asyncio")
    if choice != "asyncio":
        try:
            import uvloop  # noqa: PLC0415 (optional: asyncio serves without it)
        except ImportError as e:
            if choice == "uvloop":
                raise ConfigError(LOOP_ENV, raw, "uvloop is not installed") from e
        else:
            return uvloop.new_event_loop
    return asyncio.new_event_loop


def loop_name(loop: asyncio.AbstractEventLoop) -> str:
    """The loop's kind, for logs and reports: ``uvloop`` or ``asyncio``."""
    return "uvloop" if type(loop).__module__.startswith("uvloop") else "asyncio"


def run(main: Coroutine[Any, Any, T], *, choice: str | None = None) -> T:
    """``asyncio.run(main)`` on the loop :func:`loop_factory` picks."""
    try:
        factory = loop_factory(choice)
    except ConfigError:
        main.close()  # never started: no "coroutine was never awaited" on the way out
        raise
    with asyncio.Runner(loop_factory=factory) as runner:
        return runner.run(main)


async def sleep(seconds: float) -> None:
    """``asyncio.sleep(seconds)``, but a positive wait lasts one timer tick at least.

    ``seconds`` <= 0 yields to the loop once, as ``asyncio.sleep(0)``. A wait of
    a fraction of a tick wakes up to that fraction late instead of spinning.
    """
    await asyncio.sleep(_a_tick_at_least(seconds))


def _a_tick_at_least(seconds: float) -> float:
    """A positive wall delay raised to one timer tick; 0 or less as it is."""
    return seconds if seconds <= 0.0 else max(seconds, TIMER_TICK)


async def wait_set(event: asyncio.Event, timeout: float) -> bool:
    """Wait at most ``timeout`` wall seconds for ``event``; whether it is set.

    Not ``asyncio.wait_for``: on 3.11, a cancel that comes as the event is set is
    swallowed, and the vehicles' waits loop on every message. On a busy host at
    40x that kept a mission's task group from ever ending (the service flying on
    past its duration, 3 runs in about 35). A positive timeout lasts a timer tick
    at least, as :func:`sleep`: callers wait towards a deadline in a loop.
    """
    try:
        async with asyncio.timeout(_a_tick_at_least(timeout)):
            await event.wait()
    except TimeoutError:
        return event.is_set()
    return True
