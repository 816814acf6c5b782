"""Which event loop the service flies on, and how an operator overrides it."""

from __future__ import annotations

import asyncio
import sys
import time
from collections.abc import Awaitable, Callable

import pytest
import uvloop

from convoy_mav.cli import main
from convoy_mav.errors import ConfigError
from convoy_mav.eventloop import (
    LOOP_ENV,
    TIMER_TICK,
    loop_factory,
    loop_name,
    run,
    sleep,
    wait_set,
)


async def _which() -> str:
    return loop_name(asyncio.get_running_loop())


def test_uvloop_is_picked_when_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(LOOP_ENV, raising=False)
    assert loop_factory() is uvloop.new_event_loop
    assert run(_which()) == "uvloop"


@pytest.mark.parametrize(("env", "expected"), [("asyncio", "asyncio"), (" UVLOOP ", "uvloop")])
def test_the_environment_chooses(monkeypatch: pytest.MonkeyPatch, env: str, expected: str) -> None:
    monkeypatch.setenv(LOOP_ENV, env)
    assert run(_which()) == expected


def test_an_explicit_choice_beats_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(LOOP_ENV, "uvloop")
    assert run(_which(), choice="asyncio") == "asyncio"


def test_without_uvloop_auto_falls_back_and_uvloop_is_a_clear_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "uvloop", None)  # import uvloop -> ImportError
    assert loop_factory("auto") is asyncio.new_event_loop
    with pytest.raises(ConfigError, match=f"{LOOP_ENV} = 'uvloop': uvloop is not installed"):
        loop_factory("uvloop")


def test_an_unknown_loop_names_the_variable_and_the_value(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(LOOP_ENV, "trio")
    with pytest.raises(ConfigError, match=f"{LOOP_ENV} = 'trio': must be auto, uvloop or asyncio"):
        loop_factory()


def test_the_command_line_reports_a_bad_loop_and_exits_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv(LOOP_ENV, "trio")
    assert main(["demo", "--duration", "10"]) == 2
    assert f"{LOOP_ENV} = 'trio'" in capsys.readouterr().err


async def _waits_in_a_loop(event: asyncio.Event, rounds: list[int]) -> None:
    """A vehicle's wait: until the event, re-armed each time, bounded each time."""
    while True:
        event.clear()
        await wait_set(event, 10.0)
        rounds.append(1)
        await asyncio.sleep(0)


@pytest.mark.parametrize("choice", ["asyncio", "uvloop"])
def test_a_cancel_that_comes_as_the_event_is_set_ends_the_wait(choice: str) -> None:
    """The event set and the task cancelled in one turn of the loop (a message in as
    the mission's task group ends): the task ends. (``asyncio.wait_for`` on 3.11
    returns instead, and the loop around it never ends.)"""

    async def scenario() -> tuple[bool, list[int]]:
        event, rounds = asyncio.Event(), list[int]()
        task = asyncio.create_task(_waits_in_a_loop(event, rounds))
        for _ in range(3):
            await asyncio.sleep(0)
        event.set()
        task.cancel()
        done, _ = await asyncio.wait({task}, timeout=1.0)
        if not done:
            task.cancel()
        return task in done and task.cancelled(), rounds

    cancelled, rounds = run(scenario(), choice=choice)
    assert cancelled and rounds == []


def test_wait_set_says_whether_the_event_came() -> None:
    async def scenario() -> tuple[bool, bool]:
        event = asyncio.Event()
        asyncio.get_running_loop().call_later(0.01, event.set)
        came = await wait_set(event, 5.0)
        return came, await wait_set(asyncio.Event(), 0.01)

    assert run(scenario(), choice="asyncio") == (True, False)


async def _wakes(nap: Callable[[float], Awaitable[None]], delay: float, span: float) -> int:
    """How often a task waiting ``delay`` at a time wakes in ``span`` wall seconds."""
    wakes = 0
    end = time.monotonic() + span
    while time.monotonic() < end:
        await nap(delay)
        wakes += 1
    return wakes


def test_uvloop_spins_on_a_sub_millisecond_wait_and_sleep_does_not() -> None:
    """uvloop rounds 0.2 ms to a zero-delay timer: tens of thousands of wakes in 50 ms."""
    spun = run(_wakes(asyncio.sleep, 0.0002, 0.05), choice="uvloop")
    napped = run(_wakes(sleep, 0.0002, 0.05), choice="uvloop")
    assert spun > 1000  # the hazard :func:`eventloop.sleep` is for (should uvloop change)
    assert napped <= 2 * 0.05 / TIMER_TICK + 5


@pytest.mark.parametrize("choice", ["uvloop", "asyncio"])
def test_sleep_waits_what_it_is_asked_and_yields_at_zero(choice: str) -> None:
    async def scenario() -> tuple[float, bool]:
        t0 = time.monotonic()
        await sleep(0.02)
        waited = time.monotonic() - t0
        other = asyncio.get_running_loop().create_future()
        asyncio.get_running_loop().call_soon(other.set_result, None)
        await sleep(0.0)  # one turn of the loop: the callback queued before it has run
        return waited, other.done()

    waited, yielded = run(scenario(), choice=choice)
    assert waited >= 0.02 - 0.002  # (uvloop's clock is whole milliseconds)
    assert yielded


def test_a_wait_set_towards_a_deadline_does_not_spin_either() -> None:
    async def wakes() -> int:
        event, count = asyncio.Event(), 0
        end = time.monotonic() + 0.05
        while time.monotonic() < end:
            await wait_set(event, 0.0002)
            count += 1
        return count

    assert run(wakes(), choice="uvloop") <= 2 * 0.05 / TIMER_TICK + 5
