"""What MAVLink 2 signing costs per frame: packing a setpoint, decoding telemetry.

Run with ``make bench`` (or ``pytest benchmarks/bench_signing.py --benchmark-only``);
compare the signed and unsigned medians of one run side by side.
"""

from __future__ import annotations

import hashlib

import pytest
from pymavlink.dialects.v20 import common as mavlink
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.mavlink.signing import Signing

KEY = hashlib.sha256(b"bench").digest()


def _setpoint() -> mavlink.MAVLink_set_position_target_global_int_message:
    return mavlink.MAVLink_set_position_target_global_int_message(
        1000, 1, 1, 6, 0xDC0, 473977420, 85455940, 100.0, 10.0, 5.0, 0.0, 0, 0, 0, 1.2, 0.0
    )


def _position(codec: MavCodec, boot_ms: int) -> bytes:
    return codec.pack(
        mavlink.MAVLink_global_position_int_message(
            boot_ms, 473977420, 85455940, 588000, 100000, 1000, 500, 0, 9000
        )
    )


@pytest.mark.parametrize("signed", [False, True], ids=["unsigned", "signed"])
def test_pack_a_setpoint(benchmark: BenchmarkFixture, signed: bool) -> None:
    codec = MavCodec(signing=Signing(KEY) if signed else None)
    frame = benchmark(codec.pack, _setpoint())
    assert bool(frame[2] & mavlink.MAVLINK_IFLAG_SIGNED) == signed


@pytest.mark.parametrize("signed", [False, True], ids=["unsigned", "signed"])
def test_decode_a_position(benchmark: BenchmarkFixture, signed: bool) -> None:
    autopilot = MavCodec(1, 1, signing=Signing(KEY, link_id=1) if signed else None)
    frames = [_position(autopilot, 1000 + k) for k in range(200_000)]
    service = MavCodec(signing=Signing(KEY, link_id=2) if signed else None)
    it = iter(frames)

    def decode() -> int:
        return len(service.feed_datagram(next(it)))  # (a fresh frame: no replay)

    found = benchmark.pedantic(decode, rounds=20, iterations=5000)  # type: ignore[no-untyped-call]
    assert found == 1
