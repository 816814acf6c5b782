"""MAVProxy-format telemetry logs (``.tlog``) written without blocking the event loop.

A tlog is the plain concatenation of records, each an 8-byte big-endian
timestamp (microseconds since the Unix epoch) followed by one whole MAVLink
frame. ``pymavlink.mavutil.mavlink_connection("x.tlog")``, MAVExplorer and
MAVProxy read it; ``msg._timestamp`` there is this stamp in seconds.

As MAVProxy does, the two low bits of each stamp carry the link number: 0..2
for frames received (the link they came in on), 3 for frames we sent. Stamps
are kept non-decreasing even if the wall clock steps back or two links
interleave within the same 4 us, so readers that assume ordered time are safe.

Design rules:
    * :meth:`TlogRecorder.record` is called from protocol callbacks on the event
      loop: it only appends to an in-memory list (no I/O, no locks).
    * One named background task swaps the buffer out and writes it with
      ``asyncio.to_thread`` every ``flush_interval`` seconds; leaving the context
      stops the task and does a final flush, so nothing recorded is lost.
    * A slow or full disk never stalls flight: past ``max_buffer_bytes`` new
      records are dropped and counted; write errors are logged once and counted.
    * An earlier flight's tlog is never overwritten: if the path exists, the
      recording goes to the first free ``<stem>-<n>.tlog`` beside it (``path``
      says which, and the log), so a run that fails to start, or a second run
      with the same ``--tlog``, loses nothing.
"""

from __future__ import annotations

import asyncio
import errno
import logging
import os
import struct
import time
from collections import Counter
from collections.abc import Callable
from types import TracebackType
from typing import BinaryIO

from convoy_mav.errors import ConfigError
from convoy_mav.eventloop import wait_set

__all__ = ["LINK_SENT", "TlogRecorder"]

log = logging.getLogger(__name__)

LINK_SENT = 3  # MAVProxy's link number for frames we sent (low two bits of the stamp)
_STAMP = struct.Struct(">Q")


class TlogRecorder:
    """Buffers timestamped MAVLink frames and writes them to a ``.tlog`` file.

    Use as an async context manager (``async with TlogRecorder(path) as rec``);
    records made before entering are kept and written once it is open.

    Args:
        path: The file to create (truncated if it exists).
        clock: Seconds since the epoch; injectable for tests and replays.
        flush_interval: Wall seconds between background writes.
        max_buffer_bytes: Cap on unwritten data; beyond it records are dropped.

    Raises:
        ConfigError: On entering, if the file cannot be created (key ``tlog``).

    Attributes:
        counters: ``packets``/``bytes`` recorded, ``written`` packets, ``flushes``,
            ``dropped`` (buffer full or recorder closed), ``write_errors``.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        clock: Callable[[], float] = time.time,
        flush_interval: float = 0.5,
        max_buffer_bytes: int = 64 * 1024 * 1024,
    ) -> None:
        if not flush_interval > 0.0:
            raise ValueError(f"flush_interval must be > 0, got {flush_interval}")
        self.path = os.fspath(path)
        self.counters: Counter[str] = Counter()
        self._clock = clock
        self._flush_interval = flush_interval
        self._max_buffer = max_buffer_bytes
        self._chunks: list[bytes] = []  # stamp, frame, stamp, frame, ...
        self._buffered = 0
        self._pending_packets = 0
        self._last_stamp = 0
        self._file: BinaryIO | None = None
        self._task: asyncio.Task[None] | None = None
        self._stop = asyncio.Event()
        self._closed = False
        self._warned_write = False

    def __repr__(self) -> str:
        state = "closed" if self._closed else ("open" if self._file is not None else "new")
        return (
            f"TlogRecorder({self.path!r}, {state}, packets={self.counters['packets']}, "
            f"written={self.counters['written']}, dropped={self.counters['dropped']})"
        )

    # -- hot path (event loop) -----------------------------------------------------------

    def record(self, packet: bytes | bytearray, *, link: int = 0) -> None:
        """Queue one whole MAVLink frame with the current time; cheap, never blocks.

        Args:
            packet: The frame's bytes (``msg.get_msgbuf()`` or what was sent).
            link: 0..2 for a frame received on that link, :data:`LINK_SENT` (3)
                for a frame we sent, as MAVProxy marks them.
        """
        if self._closed or self._buffered + len(packet) > self._max_buffer:
            self.counters["dropped"] += 1
            return
        stamp = (int(self._clock() * 1e6) & ~3) | (link & 3)
        if stamp < self._last_stamp:  # clock stepped back or a smaller link id in the same 4 us
            stamp = ((self._last_stamp & ~3) + 4) | (link & 3)
        self._last_stamp = stamp
        self._chunks.append(_STAMP.pack(stamp))
        self._chunks.append(bytes(packet))
        self._buffered += len(packet) + 8
        self._pending_packets += 1
        self.counters["packets"] += 1
        self.counters["bytes"] += len(packet)

    # -- lifecycle -----------------------------------------------------------------------

    async def __aenter__(self) -> TlogRecorder:
        if self._file is not None or self._closed:
            raise RuntimeError("a TlogRecorder can be entered only once")
        try:
            self._file, path = await asyncio.to_thread(_open_new, self.path)
        except OSError as e:
            raise ConfigError("tlog", self.path, f"cannot write: {e.strerror or e}") from e
        if path != self.path:
            log.warning("tlog %s exists (an earlier flight): recording to %s", self.path, path)
            self.path = path
        self._task = asyncio.create_task(self._flush_loop(), name=f"tlog[{self.path}].flush")
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.aclose()

    async def aclose(self) -> None:
        """Stop the flush task, write everything still buffered and close the file."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        task, self._task = self._task, None
        if task is not None:
            # Not cancelled: it finishes the write in progress and flushes once more.
            # asyncio.wait does not raise the task's outcome, only our own cancellation.
            await asyncio.wait([task])
            if not task.cancelled() and task.exception() is not None:
                log.error("tlog %s: flush task failed", self.path, exc_info=task.exception())
        if self._file is not None:
            await self.flush()
            f, self._file = self._file, None
            try:
                await asyncio.to_thread(f.close)
            except OSError as e:  # the buffered tail could not be written either
                self.counters["write_errors"] += 1
                log.error("tlog %s: closing failed (%s)", self.path, e)

    async def flush(self) -> None:
        """Write what is buffered now (in a worker thread)."""
        if self._file is None or not self._chunks:
            return
        chunks, self._chunks = self._chunks, []
        packets, self._pending_packets = self._pending_packets, 0
        self._buffered = 0
        try:
            await asyncio.to_thread(_write_all, self._file, chunks)
        except OSError as e:
            self.counters["write_errors"] += 1
            self.counters["dropped"] += packets
            if not self._warned_write:
                self._warned_write = True
                log.error("tlog %s: write failed (%s); recording goes on", self.path, e)
            return
        self.counters["written"] += packets
        self.counters["flushes"] += 1

    async def _flush_loop(self) -> None:
        while not self._stop.is_set():
            await wait_set(self._stop, self._flush_interval)
            await self.flush()


def _open_new(path: str) -> tuple[BinaryIO, str]:
    """A new file at ``path``, or at the first free ``<stem>-<n><ext>`` beside it.

    (A device or a pipe at ``path`` is written to as it is: it holds no earlier flight.)
    """
    if os.path.exists(path) and not os.path.isfile(path):
        return open(path, "ab"), path
    stem, ext = os.path.splitext(path)
    for n in range(1000):
        candidate = path if n == 0 else f"{stem}-{n}{ext}"
        try:
            return open(candidate, "xb"), candidate
        except FileExistsError:
            continue
    raise FileExistsError(errno.EEXIST, "1000 tlogs of that name already exist", path)


def _write_all(f: BinaryIO, chunks: list[bytes]) -> None:
    f.write(b"".join(chunks))
    f.flush()
