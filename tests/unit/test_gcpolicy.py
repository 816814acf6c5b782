"""The flight loop's collector policy: off on allocation counts, on a schedule instead."""

from __future__ import annotations

import asyncio
import gc
import weakref

import pytest

from convoy_mav.gcpolicy import collect_on_schedule, flight_gc


class _Node:
    other: object = None


def _garbage_cycles(n: int) -> list[weakref.ref[_Node]]:
    """``n`` unreachable two-node cycles; weak references tell when they are reclaimed."""
    refs = []
    for _ in range(n):
        a, b = _Node(), _Node()
        a.other, b.other = b, a
        refs.append(weakref.ref(a))
    return refs


async def _reclaimed(refs: list[weakref.ref[_Node]]) -> None:
    async with asyncio.timeout(5.0):
        while any(r() is not None for r in refs):
            await asyncio.sleep(0.01)


def test_flight_gc_freezes_disables_and_restores() -> None:
    assert gc.isenabled()
    keep = [_Node() for _ in range(10)]
    with flight_gc():
        assert not gc.isenabled()
        assert gc.get_freeze_count() >= len(keep)
    assert gc.isenabled()
    assert gc.get_freeze_count() == 0


def test_flight_gc_restores_after_an_error_and_leaves_a_disabled_collector_off() -> None:
    with pytest.raises(RuntimeError), flight_gc():
        raise RuntimeError("boom")
    assert gc.isenabled()
    gc.disable()
    try:
        with flight_gc():
            pass
        assert not gc.isenabled()
    finally:
        gc.enable()


async def test_the_schedule_reclaims_cycles_made_in_flight() -> None:
    with flight_gc():
        refs = _garbage_cycles(1000)
        await asyncio.sleep(0.05)
        assert all(r() is not None for r in refs)  # nothing collects on allocation counts
        task = asyncio.create_task(collect_on_schedule(period=0.05, look=0.01))
        try:
            await _reclaimed(refs)
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)


async def test_the_backstop_collects_before_the_period() -> None:
    with flight_gc():
        gc.collect()
        task = asyncio.create_task(collect_on_schedule(period=3600.0, backstop=500, look=0.01))
        try:
            await _reclaimed(_garbage_cycles(300))  # 600 tracked objects: past the backstop
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)


async def test_a_run_freezes_its_survivors_and_the_full_sweep_finds_what_died_frozen() -> None:
    with flight_gc():
        keep = [_Node() for _ in range(100)]
        frozen = gc.get_freeze_count()
        task = asyncio.create_task(collect_on_schedule(period=0.02, full_every=1000, look=0.01))
        try:
            async with asyncio.timeout(5.0):
                while gc.get_freeze_count() < frozen + len(keep):
                    await asyncio.sleep(0.01)
            # A cycle alive when a run froze it, dropped later: the routine runs
            # no longer walk it...
            cycles = [_Node() for _ in range(2)]
            cycles[0].other, cycles[1].other = cycles[1], cycles[0]
            await asyncio.sleep(0.1)  # a few runs: it is frozen now
            ref = weakref.ref(cycles[0])
            del cycles
            await asyncio.sleep(0.1)
            assert ref() is not None
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        # ...the full sweep does.
        task = asyncio.create_task(collect_on_schedule(period=0.02, full_every=1, look=0.01))
        try:
            await _reclaimed([ref])
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        assert keep


async def test_collect_on_schedule_rejects_bad_settings() -> None:
    with pytest.raises(ValueError, match="period"):
        await collect_on_schedule(period=0.0)
    with pytest.raises(ValueError, match="full_every"):
        await collect_on_schedule(full_every=0)
