"""The operator's log: INFO on stderr, written by a thread of its own.

The flight loop must never wait on logging: a terminal that scrolls slowly or a
pipe nobody reads would otherwise stall setpoints. Records go into a queue
(``QueueHandler``: an append, no I/O) and a ``QueueListener`` thread writes them.
"""

from __future__ import annotations

import contextlib
import logging
import logging.handlers
import queue
import sys
from collections.abc import Iterator

__all__ = ["operator_log"]

_FORMAT = "%(levelname)-7s %(message)s"


@contextlib.contextmanager
def operator_log(level: int) -> Iterator[None]:
    """Route every ``convoy_mav`` and ``sitl_mock`` record at ``level`` and above to
    stderr through a queue; on exit the queue is drained and the handlers restored."""
    records: queue.SimpleQueue[logging.LogRecord] = queue.SimpleQueue()
    writer = logging.StreamHandler(sys.stderr)
    writer.setFormatter(logging.Formatter(_FORMAT))
    listener = logging.handlers.QueueListener(records, writer)
    root = logging.getLogger()
    saved = root.handlers[:], root.level
    root.handlers = [logging.handlers.QueueHandler(records)]
    root.setLevel(logging.WARNING)  # other libraries: warnings only
    ours = [logging.getLogger(name) for name in ("convoy_mav", "sitl_mock")]
    saved_levels = [lg.level for lg in ours]
    for lg in ours:
        lg.setLevel(level)
    listener.start()
    try:
        yield
    finally:
        listener.stop()
        root.handlers, _ = saved
        root.setLevel(saved[1])
        for lg, old in zip(ours, saved_levels, strict=True):
            lg.setLevel(old)
