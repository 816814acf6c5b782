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


async def test_collect_on_schedule_rejects_bad_settings() -> None:
    with pytest.raises(ValueError, match="period"):
        await collect_on_schedule(period=0.0)
