"""Fault decisions of the mock: seeded, exact at 0 and 1, events once and in order."""

from __future__ import annotations

import itertools
import random
from typing import Any

import pytest

from sitl_mock.faults import DelayQueue, FaultInjector, FaultSpec, TimedFault, TimedMode


def test_probability_zero_and_one_are_exact_and_draw_nothing() -> None:
    rng = random.Random(1)
    state = rng.getstate()
    never = FaultInjector(FaultSpec(), rng)
    always = FaultInjector(FaultSpec(loss_to_vehicle=1.0, loss_from_vehicle=1.0), rng)
    assert not any(never.drop_to_vehicle(1) or never.drop_from_vehicle(1) for _ in range(100))
    assert all(always.drop_to_vehicle(1) and always.drop_from_vehicle(1) for _ in range(100))
    assert rng.getstate() == state


def test_loss_rate_is_close_to_the_probability_and_replays_with_the_seed() -> None:
    spec = FaultSpec(loss_to_vehicle=0.3)
    a = [FaultInjector(spec, random.Random(7)).drop_to_vehicle(1) for _ in range(1)]
    first = FaultInjector(spec, random.Random(7))
    second = FaultInjector(spec, random.Random(7))
    draws = [first.drop_to_vehicle(1) for _ in range(5000)]
    assert draws == [second.drop_to_vehicle(1) for _ in range(5000)]
    assert a[0] == draws[0]
    assert 0.27 < sum(draws) / len(draws) < 0.33


def test_loss_and_latency_only_hit_the_listed_sysids() -> None:
    spec = FaultSpec(loss_from_vehicle=1.0, latency_to_vehicle=0.5, sysids=frozenset({2}))
    inj = FaultInjector(spec, random.Random(0))
    assert not inj.drop_from_vehicle(1)
    assert inj.drop_from_vehicle(2)
    assert inj.delay_to_vehicle(1) == 0.0
    assert inj.delay_to_vehicle(2) == 0.5
    assert inj.delay_from_vehicle(2) == 0.0


def test_duplicates_and_jitter_reorder_and_repeat_datagrams() -> None:
    """Jitter draws each datagram's extra latency afresh (so they overtake each other);
    duplication delivers some twice; both replay with the seed, and draw nothing at 0."""
    spec = FaultSpec(latency_from_vehicle=0.2, duplicate=0.1, jitter=0.3)
    inj = FaultInjector(spec, random.Random(5))
    delays = [inj.delay_from_vehicle(1) for _ in range(2000)]
    assert all(0.2 <= d <= 0.5 for d in delays)
    overtaken = sum(later < earlier - 0.01 for earlier, later in itertools.pairwise(delays))
    assert overtaken > 500  # (datagrams 10 ms apart arrive out of order)
    copies = [inj.copies(1) for _ in range(5000)]
    assert set(copies) == {1, 2} and 0.08 < copies.count(2) / 5000 < 0.12
    again = FaultInjector(spec, random.Random(5))
    assert [again.delay_from_vehicle(1) for _ in range(2000)] == delays
    rng = random.Random(1)
    state = rng.getstate()
    plain = FaultInjector(FaultSpec(latency_to_vehicle=0.2), rng)
    assert plain.copies(1) == 1 and plain.delay_to_vehicle(1) == 0.2
    assert rng.getstate() == state


def test_events_fire_once_in_time_order() -> None:
    spec = FaultSpec(
        kills=(TimedFault(2, 5.0),),
        reboots=(TimedFault(1, 3.0), TimedFault(3, 5.0)),
        modes=(TimedMode(4, 4.5, "HOLD"),),
    )
    inj = FaultInjector(spec, random.Random(0))
    assert inj.due_events(2.99) == []
    assert [(e.kind, e.sysid) for e in inj.due_events(3.0)] == [("reboot", 1)]
    assert inj.due_events(4.0) == []
    late = inj.due_events(100.0)
    assert [(e.kind, e.sysid, e.at, e.mode) for e in late] == [
        ("mode", 4, 4.5, "HOLD"),
        ("kill", 2, 5.0, ""),
        ("reboot", 3, 5.0, ""),
    ]
    assert inj.due_events(1e9) == []
    with pytest.raises(ValueError, match="mode"):
        TimedMode(4, 1.0, "")


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"loss_to_vehicle": 1.5}, "loss_to_vehicle"),
        ({"loss_from_vehicle": -0.1}, "loss_from_vehicle"),
        ({"latency_to_vehicle": float("inf")}, "latency_to_vehicle"),
        ({"latency_from_vehicle": -1.0}, "latency_from_vehicle"),
        ({"duplicate": 2.0}, "duplicate"),
        ({"jitter": float("nan")}, "jitter"),
    ],
)
def test_spec_rejects_bad_values_naming_the_field(kwargs: dict[str, Any], word: str) -> None:
    with pytest.raises(ValueError, match=word):
        FaultSpec(**kwargs)


def test_timed_fault_validates() -> None:
    with pytest.raises(ValueError, match="sysid"):
        TimedFault(0, 1.0)
    with pytest.raises(ValueError, match="at"):
        TimedFault(1, -1.0)


def test_delay_queue_releases_in_due_order_fifo_on_ties() -> None:
    q: DelayQueue[str] = DelayQueue()
    q.push(2.0, "c")
    q.push(1.0, "a")
    q.push(1.0, "b")
    assert len(q) == 3
    assert q.pop_due(0.5) == []
    assert q.pop_due(1.0) == ["a", "b"]
    assert q.pop_due(10.0) == ["c"]
    q.push(1.0, "x")
    q.clear()
    assert q.pop_due(10.0) == []
