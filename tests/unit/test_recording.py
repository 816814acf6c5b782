"""TlogRecorder: MAVProxy byte format, readable by mavutil, ordered stamps, never blocking."""

from __future__ import annotations

import asyncio
import os
import struct
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import ConfigError
from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.recording import LINK_SENT, TlogRecorder

T0 = 1_700_000_000.0  # a plausible epoch time (mavutil rejects nothing, but be realistic)


class FakeClock:
    def __init__(self, t: float = T0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


def frames(n: int, system: int = 1) -> list[bytes]:
    codec = MavCodec(system=system, component=1)
    out = []
    for i in range(n):
        out.append(
            codec.pack(
                mavlink.MAVLink_global_position_int_message(i, 470000000 + i, 85000000, 500000,
                                                            10000, 0, 0, 0, 0)
            )
        )  # fmt: skip
    return out


def read_tlog(path: Path) -> list[Any]:
    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(str(path))
    msgs = []
    try:
        while (msg := conn.recv_match()) is not None:
            msgs.append(msg)
    finally:
        conn.close()
    return msgs


async def test_bytes_are_stamp_then_frame(tmp_path: Path) -> None:
    clock = FakeClock()
    path = tmp_path / "a.tlog"
    packets = frames(3)
    async with TlogRecorder(path, clock=clock) as rec:
        for i, p in enumerate(packets):
            clock.t = T0 + i * 0.25
            rec.record(p, link=LINK_SENT if i == 1 else 0)
    data = path.read_bytes()
    offset = 0
    for i, p in enumerate(packets):
        (usec,) = struct.unpack(">Q", data[offset : offset + 8])
        assert usec >> 2 == int((T0 + i * 0.25) * 1e6) >> 2
        assert usec & 3 == (3 if i == 1 else 0)  # MAVProxy: link 3 marks what we sent
        assert data[offset + 8 : offset + 8 + len(p)] == p
        offset += 8 + len(p)
    assert offset == len(data)
    assert rec.counters["packets"] == rec.counters["written"] == 3


async def test_mavutil_reads_it_back(tmp_path: Path) -> None:
    clock = FakeClock()
    path = tmp_path / "b.tlog"
    hb = MavCodec(system=2, component=1).pack(mavlink.MAVLink_heartbeat_message(1, 12, 0, 0, 4, 3))
    async with TlogRecorder(path, clock=clock) as rec:
        for i, p in enumerate(frames(5, system=1)):
            clock.t = T0 + i
            rec.record(p)
        rec.record(hb)
    msgs = read_tlog(path)
    assert [m.get_type() for m in msgs] == ["GLOBAL_POSITION_INT"] * 5 + ["HEARTBEAT"]
    assert [m.get_srcSystem() for m in msgs] == [1] * 5 + [2]
    assert [m.lat for m in msgs[:5]] == [470000000 + i for i in range(5)]
    stamps = [m._timestamp for m in msgs]
    assert stamps[:5] == pytest.approx([T0 + i for i in range(5)], abs=1e-5)
    assert stamps == sorted(stamps)


async def test_stamps_never_go_back(tmp_path: Path) -> None:
    clock = FakeClock()
    path = tmp_path / "c.tlog"
    async with TlogRecorder(path, clock=clock) as rec:
        p = frames(1)[0]
        rec.record(p, link=LINK_SENT)
        rec.record(p, link=0)  # same 4 us, smaller link number
        clock.t = T0 - 5.0  # wall clock stepped back
        rec.record(p, link=1)
        clock.t = T0 + 1.0
        rec.record(p, link=2)
    data = path.read_bytes()
    step = 8 + len(p)
    stamps = [struct.unpack(">Q", data[i : i + 8])[0] for i in range(0, len(data), step)]
    assert stamps == sorted(stamps) and len(set(stamps)) == 4
    assert [s & 3 for s in stamps] == [3, 0, 1, 2]  # link numbers survive the correction
    assert stamps[-1] >> 2 == int((T0 + 1.0) * 1e6) >> 2


async def test_background_flush_while_open(tmp_path: Path) -> None:
    path = tmp_path / "d.tlog"
    async with TlogRecorder(path, flush_interval=0.01) as rec:
        for p in frames(4):
            rec.record(p)
        assert path.stat().st_size == 0  # record() itself does no I/O
        async with asyncio.timeout(5):
            while rec.counters["written"] < 4:
                await asyncio.sleep(0.005)
        assert path.stat().st_size == sum(8 + len(p) for p in frames(4))
        assert rec.counters["flushes"] >= 1


async def test_records_before_open_are_kept_and_after_close_dropped(tmp_path: Path) -> None:
    path = tmp_path / "e.tlog"
    rec = TlogRecorder(path)
    early = frames(2)
    for p in early:
        rec.record(p)
    async with rec:
        pass
    rec.record(early[0])
    assert rec.counters["dropped"] == 1
    assert len(path.read_bytes()) == sum(8 + len(p) for p in early)
    assert "closed" in repr(rec)
    with pytest.raises(RuntimeError):
        async with rec:
            pass


async def test_buffer_cap_drops_and_counts(tmp_path: Path) -> None:
    p = frames(1)[0]
    async with TlogRecorder(tmp_path / "f.tlog", max_buffer_bytes=3 * (8 + len(p))) as rec:
        for _ in range(10):
            rec.record(p)
    assert rec.counters["packets"] == 3 and rec.counters["dropped"] == 7


async def test_write_errors_are_counted_not_raised() -> None:
    if not os.path.exists("/dev/full"):
        pytest.skip("needs /dev/full")
    async with TlogRecorder("/dev/full") as rec:
        rec.record(frames(1)[0])
        await rec.flush()
        rec.record(frames(1)[0])
    assert rec.counters["write_errors"] >= 1
    assert rec.counters["dropped"] == 2 and rec.counters["written"] == 0


async def test_unwritable_path_is_a_config_error(tmp_path: Path) -> None:
    path = tmp_path / "missing-dir" / "g.tlog"
    with pytest.raises(ConfigError) as info:
        async with TlogRecorder(path):
            pass
    assert info.value.key == "tlog" and str(path) in str(info.value)


def test_bad_flush_interval() -> None:
    with pytest.raises(ValueError, match="flush_interval"):
        TlogRecorder("x.tlog", flush_interval=0.0)
