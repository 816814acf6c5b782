"""Read MAVProxy-format telemetry logs (``.tlog``) from bytes (sans-I/O).

The counterpart of :mod:`convoy_mav.recording`: a tlog is a run of records,
each an 8-byte big-endian timestamp (microseconds since the Unix epoch, the two
low bits a link number) followed by one whole MAVLink 1 or 2 frame.

Design rules:
    * Bytes in, records out: no file, no clock. The caller reads the file.
    * Only pymavlink's generated dialect parses frames (no hand-unpacked headers,
      no ``mavutil``); as ``mavutil`` does, the parser is asked how many bytes the
      frame still needs, so the frame length comes from the frame itself.
    * Garbage never raises: a frame that fails its checksum or is malformed is
      skipped and counted, and the parser resynchronises on the next start byte
      (the record stamp that came with the bad frame is kept for the next good one).
"""

from __future__ import annotations

import mmap
import struct
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.codec import Message

__all__ = ["TlogRecord", "read_tlog"]

_STAMP = struct.Struct(">Q")


@dataclass(frozen=True, slots=True)
class TlogRecord:
    """One decoded message of a tlog.

    Attributes:
        number: 1-based position among the file's decoded messages (for error messages).
        stamp: Record timestamp, seconds since the Unix epoch (the recorder's clock).
        link: The stamp's two low bits: 0..2 the link received on, 3 sent by the recorder.
        msg: The pymavlink message (``get_srcSystem()``, ``get_type()``, fields).
    """

    number: int
    stamp: float
    link: int
    msg: Message


def read_tlog(
    data: bytes | mmap.mmap, counters: Counter[str] | None = None
) -> Iterator[TlogRecord]:
    """Decode every message of a tlog, in file order.

    Args:
        data: The whole file (bytes, or a read-only map of it).
        counters: If given, counts ``messages``, ``bad_data`` (frames skipped) and
            ``truncated`` (1 when the file ends inside a record).

    Yields:
        One :class:`TlogRecord` per well-formed frame of a known message type.
    """
    stats: Counter[str] = counters if counters is not None else Counter()
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    pos, number, size = 0, 0, len(data)
    while pos + _STAMP.size <= size:
        (usec,) = _STAMP.unpack_from(data, pos)
        pos += _STAMP.size
        msg: Message = None
        while msg is None or isinstance(msg, mavlink.MAVLink_bad_data | mavlink.MAVLink_unknown):
            if msg is not None:
                stats["bad_data"] += 1
            chunk = data[pos : pos + parser.bytes_needed()]
            pos += len(chunk)
            try:
                msg = parser.parse_char(chunk)
            except Exception:  # pymavlink raising on hostile input: drop its buffer, go on
                stats["bad_data"] += 1
                parser = mavlink.MAVLink(None)
                parser.robust_parsing = True
                msg = None
            if msg is None and not chunk:
                if parser.buf_len() > 0 or pos < size:
                    stats["truncated"] += 1
                return
        number += 1
        stats["messages"] += 1
        yield TlogRecord(number, usec * 1e-6, usec & 3, msg)
    if pos < size:
        stats["truncated"] += 1
