"""The truth log: what every vehicle *really* did, for checking the service.

A client only sees telemetry (rounded, rate-limited, possibly lost); tests and
post-flight analysis want the simulator's own state. Rows are the autopilot
layer's ``TruthRow`` dataclasses, sampled at a fixed sim-time rate and handed to
a sink: a CSV file (buffered, flushed on close, so the event loop never waits
on the disk) or an in-memory recorder for tests.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import sys
from array import array
from collections.abc import Sequence
from typing import IO, TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from sitl_mock.autopilot import TruthRow

__all__ = ["CsvTruthWriter", "TruthRecorder", "TruthSampler", "TruthSink"]

_BUFFER_BYTES = 1 << 16


class TruthSink(Protocol):
    """Where sampled truth rows go."""

    def write(self, rows: Sequence[TruthRow]) -> None:
        """Accept one sample instant's rows (one per vehicle)."""

    def close(self) -> None:
        """Flush and release resources; called once on shutdown."""


class TruthSampler:
    """Says when the next truth sample is due, at a fixed sim-time rate.

    Sampling happens on physics steps, so a 10 Hz log of a 100 Hz simulation
    lands exactly on every tenth step. If the caller was late by more than one
    period the missed samples are skipped, not replayed with stale state.

    Args:
        rate_hz: Samples per sim second; finite and > 0.
        start: Sim time of the first sample.
    """

    def __init__(self, rate_hz: float, start: float = 0.0) -> None:
        if not (math.isfinite(rate_hz) and rate_hz > 0.0):
            raise ValueError(f"truth rate must be finite and > 0 Hz, got {rate_hz!r}")
        self.period = 1.0 / rate_hz
        self._k = 0
        self._start = start

    def due(self, now: float) -> bool:
        """True (once per period) when a sample should be taken at ``now``."""
        # Half a microsecond of slack: float sums of 0.01 s steps land a hair early.
        if now + 5e-7 < self._start + self._k * self.period:
            return False
        self._k = max(self._k + 1, math.floor((now - self._start) / self.period + 1e-6) + 1)
        return True


class CsvTruthWriter:
    """Truth rows to a CSV file with a header naming the ``TruthRow`` fields.

    Args:
        path: File to create (truncated if it exists); parent directories are
            created.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        parent = os.path.dirname(os.fspath(path))
        if parent:
            os.makedirs(parent, exist_ok=True)
        self.path = path
        self._file: IO[str] = open(  # noqa: SIM115 - closed in close()
            path, "w", newline="", encoding="utf-8", buffering=_BUFFER_BYTES
        )
        self._csv = csv.writer(self._file)
        self._fields: tuple[str, ...] | None = None
        self.rows_written = 0

    def write(self, rows: Sequence[TruthRow]) -> None:
        """Append rows; the header is written before the first one."""
        if not rows:
            return
        if self._fields is None:
            self._fields = tuple(f.name for f in dataclasses.fields(rows[0]))
            self._csv.writerow(self._fields)
        names = self._fields
        self._csv.writerows([_cell(getattr(row, n)) for n in names] for row in rows)
        self.rows_written += len(rows)

    def close(self) -> None:
        """Flush everything to disk and close the file (idempotent)."""
        if not self._file.closed:
            self._file.flush()
            self._file.close()


class TruthRecorder:
    """Truth rows kept in memory (the last ``maxlen`` of them, if given), in columns.

    A mission's truth is hundreds of thousands of rows; as dataclass objects each holds
    its own float objects (about 560 bytes a row), as columns of machine floats about
    120, so a long run scored in-process does not grow the process by the hundred MiB.
    ``rows`` builds the row objects when asked.
    """

    def __init__(self, maxlen: int | None = None) -> None:
        self.maxlen = maxlen
        self._type: type | None = None
        self._names: tuple[str, ...] = ()
        self._columns: list[array[float] | array[int] | list[str]] = []
        self._bools: tuple[bool, ...] = ()  # which columns hold booleans (kept as 0/1)
        self._count = 0

    def write(self, rows: Sequence[TruthRow]) -> None:
        """Keep the rows."""
        if not rows:
            return
        if self._type is None:
            self._type = type(rows[0])
            self._names = tuple(f.name for f in dataclasses.fields(rows[0]))
            self._columns = [_column(getattr(rows[0], n)) for n in self._names]
            self._bools = tuple(isinstance(getattr(rows[0], n), bool) for n in self._names)
        for name, column in zip(self._names, self._columns, strict=True):
            values = [getattr(row, name) for row in rows]
            if isinstance(column, list):
                column.extend(sys.intern(v) for v in values)
            else:
                column.extend(values)
        self._count += len(rows)
        if self.maxlen is not None and self._count > 2 * self.maxlen:
            self._trim()

    def _trim(self) -> None:
        assert self.maxlen is not None
        cut = self._count - self.maxlen
        for column in self._columns:
            del column[:cut]
        self._count = self.maxlen

    @property
    def rows(self) -> list[TruthRow]:
        """Every row kept, oldest first (the last ``maxlen``)."""
        if self._type is None:
            return []
        start = 0 if self.maxlen is None else max(0, self._count - self.maxlen)
        make = self._type
        return [make(*values) for values in zip(*(c[start:] for c in self._columns), strict=True)]

    @property
    def nbytes(self) -> int:
        """Bytes the columns hold (string cells: their pointers; the strings are shared)."""
        return sum(
            c.itemsize * len(c) if isinstance(c, array) else 8 * len(c) for c in self._columns
        )

    def close(self) -> None:
        """Nothing to release; rows stay readable."""

    def of(self, sysid: int) -> list[TruthRow]:
        """Rows of one vehicle, oldest first."""
        return [r for r in self.rows if r.sysid == sysid]


def _column(value: object) -> array[float] | array[int] | list[str]:
    if isinstance(value, str):
        return []
    if isinstance(value, bool | int):
        return array("q")
    return array("d")


def _cell(value: object) -> object:
    """CSV cell: booleans as 0/1 so every numeric column parses as a number."""
    if isinstance(value, bool):
        return int(value)
    if isinstance(value, float):
        return repr(value)
    return value
