"""Truth log plumbing: the sampling schedule and the CSV/in-memory sinks."""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

from sitl_mock.truth import CsvTruthWriter, TruthRecorder, TruthSampler


@dataclass(frozen=True)
class _Row:  # the sinks only need a dataclass with a sysid
    t: float
    sysid: int
    north: float
    armed: bool
    mode: str


def _rows(t: float) -> list[Any]:
    return [_Row(t, 1, 1.5, True, "OFFBOARD"), _Row(t, 2, -0.25, False, "HOLD")]


def test_sampler_fires_once_per_period_on_100hz_steps() -> None:
    sampler = TruthSampler(10.0)
    fired = [k for k in range(0, 301) if sampler.due(k * 0.01)]
    assert fired == list(range(0, 301, 10))


def test_sampler_skips_missed_samples_instead_of_replaying_them() -> None:
    sampler = TruthSampler(10.0)
    assert sampler.due(0.0)
    assert sampler.due(0.55)  # late: one sample, not five
    assert not sampler.due(0.58)
    assert sampler.due(0.6)


def test_sampler_rejects_bad_rate() -> None:
    with pytest.raises(ValueError, match="rate"):
        TruthSampler(0.0)


def test_csv_writer_writes_header_then_rows_and_flushes_on_close(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "truth.csv"
    writer = CsvTruthWriter(path)
    writer.write([])
    writer.write(_rows(0.0))
    writer.write(_rows(0.1))
    writer.close()
    writer.close()  # idempotent
    with open(path, newline="") as f:
        table = list(csv.reader(f))
    assert table[0] == ["t", "sysid", "north", "armed", "mode"]
    assert table[1] == ["0.0", "1", "1.5", "1", "OFFBOARD"]
    assert table[4] == ["0.1", "2", "-0.25", "0", "HOLD"]
    assert len(table) == 5
    assert writer.rows_written == 4


def test_recorder_keeps_rows_and_filters_by_vehicle() -> None:
    rec = TruthRecorder(maxlen=3)
    rec.write(_rows(0.0))
    rec.write(_rows(0.1))
    assert len(rec.rows) == 3
    assert [r.t for r in rec.of(2)] == [0.0, 0.1]
