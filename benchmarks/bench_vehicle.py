"""What one telemetry message costs the flight loop: ``Vehicle.handle`` of a recognised UAV.

Run with ``make bench`` (or ``pytest benchmarks/bench_vehicle.py --benchmark-only``).
Every message of every UAV goes through it (10 Hz of GLOBAL_POSITION_INT each, 1000 UAVs
in ``make bench-fleet-1000``): the clock's observation, the jump gate, the position into
the mission frame, the count of its stream (``Vehicle._watch_rates``). One round is 1000
fresh messages, parsed beforehand: the figure per message is the median over 1000.
"""

from __future__ import annotations

from typing import Any

from pymavlink.dialects.v20 import common as mavlink
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.clock import MissionClock
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.vehicle import Vehicle

BATCH = 1000


class _Sink:
    def send(self, msg: Any) -> bool:
        return True


class _Wall:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def _parsed(msg: Any, sender: mavlink.MAVLink) -> Any:
    return mavlink.MAVLink(None).parse_buffer(bytes(msg.pack(sender)))[0]


def test_a_position_through_vehicle_handle(benchmark: BenchmarkFixture) -> None:
    wall = _Wall()
    clock = MissionClock(wall, rate_hint=1.0)
    vehicle = Vehicle(1, _Sink(), clock, LocalFrame(GeoPoint(47.0, 8.0, 400.0)), altitude=100.0)
    sender = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    beat = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 4, 3
    )
    vehicle.handle(_parsed(beat, sender))
    sent = [0]

    def batch() -> tuple[tuple[list[Any]], dict[str, Any]]:
        msgs = []
        for _ in range(BATCH):
            k = sent[0] = sent[0] + 1
            gpi = mavlink.MAVLink_global_position_int_message(
                100 * k, 470_000_000 + 10 * k, 80_000_000, 500_000, 100_000, 1800, 0, 0, 9000
            )
            msgs.append(_parsed(gpi, sender))
        return (msgs,), {}

    def handle(msgs: list[Any]) -> None:
        for msg in msgs:
            wall.t += 0.1
            vehicle.handle(msg)

    benchmark.pedantic(handle, setup=batch, rounds=30)  # type: ignore[no-untyped-call]
    assert vehicle.telemetry is not None
    assert vehicle.received == 1 + 30 * BATCH  # (the HEARTBEAT, then 30 rounds)
