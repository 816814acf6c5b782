"""The mock keeps its pace at speed without spinning a core on the event loop's timers."""

from __future__ import annotations

import asyncio

from convoy_mav import eventloop
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet

SPEEDUP = 50.0  # 100-Hz physics: a step every 0.2 wall ms, a fifth of uvloop's timer tick
WALL_S = 0.3


def test_the_physics_waits_a_tick_between_bursts_on_uvloop_and_keeps_up() -> None:
    """Waiting the 0.2 ms to each step was a zero-delay timer on uvloop: the physics
    loop woke tens of thousands of times a second, two thirds of the mock's CPU at 25x
    (``eventloop.sleep``). It now wakes once a tick and takes the steps that are due.
    """

    async def fly() -> tuple[int, float, float]:
        async with MockFleet(MockConfig.simple(2, base_port=0, speedup=SPEEDUP)) as fleet:
            wakes, start = fleet.wakes, fleet.now
            await asyncio.sleep(WALL_S)
            await fleet.wait_until(fleet.clock.now())  # (the steps due by now are taken)
            return fleet.wakes - wakes, fleet.now - start, fleet.clock.real_time_factor()

    wakes, advanced, factor = eventloop.run(fly(), choice="uvloop")
    assert wakes <= 2 * WALL_S / eventloop.TIMER_TICK + 10
    assert advanced >= WALL_S * factor - 0.05  # every step due was flown (no slip hides one)
