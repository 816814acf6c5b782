"""The one place MAVLink messages become bytes and bytes become messages (sans-I/O).

h11 style: :meth:`MavCodec.pack` turns a pymavlink message object into a
MAVLink 2 frame carrying *our* identity and sequence number; :meth:`MavCodec.feed`
(stream) and :meth:`MavCodec.feed_datagram` (one UDP datagram) turn received bytes
into message objects. No sockets, no clock, no asyncio: the link layer owns the
I/O, and tests join two codecs through plain bytes.

Design rules:
    * Only pymavlink's generated ``common`` dialect touches bytes (no hand-packed
      structs, no ``mavutil``). Out: MAVLink 2 always. In: MAVLink 1 and 2.
    * One codec per link, so each link numbers its frames 0, 1, 2, ... on its own
      (the far end uses the sequence to count our losses).
    * Received bytes never raise: garbage, bad CRC, truncated frames and unknown
      message ids are skipped and counted (pymavlink ``robust_parsing``). A bad
      frame costs that frame; the parser resynchronises on the next start byte.
    * A UDP datagram holds whole frames, so bytes left over at its end are a
      truncated frame, not the start of the next datagram: they are dropped.
      A TCP stream keeps them until the rest arrives.
    * With a :class:`~convoy_mav.mavlink.signing.Signing` every frame we pack is
      signed, and a received frame that is unsigned, badly signed or older than
      its stream's last (a replay) is dropped and counted (``unsigned``,
      ``bad_signature``). pymavlink checks the signatures.

Counters (:attr:`MavCodec.counters`):
    ``messages``  decoded messages of known type (MAVLink 1 ones also in ``mavlink1``)
    ``packed``    frames we produced
    ``bad_crc``   frames whose checksum failed
    ``bad_data``  other malformed input: junk between frames, bad lengths or flags
    ``unknown_id`` well-formed frames of ids outside the dialect
    ``truncated`` datagrams that ended inside a frame
    ``seq_lost``  frames presumed lost: forward gaps (< 128) in a source's sequence
    ``unsigned``  frames without a signature on a signed link (dropped)
    ``bad_signature`` frames whose signature or timestamp failed (dropped)
"""

from __future__ import annotations

import struct
from collections import Counter
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.signing import Signing, timestamp_now

__all__ = [
    "GCS_COMPONENT",
    "GCS_SYSTEM",
    "MAVLINK1_MARKER",
    "MAVLINK2_MARKER",
    "MavCodec",
    "Message",
]

Message = Any  # a pymavlink MAVLink_message: the generated dialect is untyped for mypy

MAVLINK1_MARKER = 0xFE
MAVLINK2_MARKER = 0xFD

# A forward jump of the sequence by less than this is loss; larger ones are a
# reboot, a reordering or a duplicate, which are not loss.
_MAX_SEQ_GAP = 128

# Decoding one whole frame keeps no state in pymavlink (signing is off), so every
# codec shares one decoder for datagrams: a fleet's links do not each drag their
# own parser object through the CPU cache for every message.
_FRAME_DECODER = mavlink.MAVLink(None)


GCS_SYSTEM = 255
"""Our MAVLink system id: a ground station's, by convention."""
GCS_COMPONENT = 190
"""Our component id: MAV_COMP_ID_MISSIONPLANNER, as ground stations use."""


class MavCodec:
    """MAVLink 2 encoder with our identity plus a robust decoder, for one link.

    Args:
        system: Our MAVLink system id (255: a ground station, by convention).
        component: Our component id (190: MAV_COMP_ID_MISSIONPLANNER, as GCSs use).
        signing: Sign what we send and accept only signed frames (None: MAVLink 2
            unsigned, as most links fly).

    Raises:
        ValueError: An id outside 0..255.
    """

    def __init__(
        self,
        system: int = GCS_SYSTEM,
        component: int = GCS_COMPONENT,
        *,
        signing: Signing | None = None,
    ) -> None:
        for name, value in (("system", system), ("component", component)):
            if not 0 <= value <= 255:
                raise ValueError(f"MAVLink {name} id must be in 0..255, got {value}")
        self.system = system
        self.component = component
        self.counters: Counter[str] = Counter()
        self.signing = signing
        self._tx = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
        self._frames = _FRAME_DECODER  # (unsigned: stateless, shared by every codec)
        if signing is not None:
            state = signing.state
            state.timestamp = max(state.timestamp + 1, timestamp_now())
            tx = self._tx.signing
            tx.secret_key, tx.link_id, tx.timestamp = signing.key, signing.link_id, state.timestamp
            tx.sign_outgoing = True
            self._frames = self._signed_parser()
        self._rx = self._new_parser()
        self._last_seq: dict[int, int] = {}  # sysid << 8 | compid -> last seq

    def __repr__(self) -> str:
        return (
            f"MavCodec(system={self.system}, component={self.component}, "
            f"next_seq={self.next_seq}, counters={dict(self.counters)})"
        )

    # -- out -----------------------------------------------------------------------------

    @property
    def next_seq(self) -> int:
        """Sequence number the next packed frame will carry (0..255, wrapping)."""
        return int(self._tx.seq)

    def pack(self, msg: Message) -> bytes:
        """Encode ``msg`` as a MAVLink 2 frame from us; the sequence number advances.

        pymavlink stores the frame on ``msg`` too (``msg.get_msgbuf()``), so the
        same object packed by two codecs carries the last one's header.

        Raises:
            ValueError: A field does not fit its wire type (e.g. an int out of
                range). That is a bug on our side, so it is not swallowed; the
                sequence number does not advance.
        """
        try:
            frame: bytes = msg.pack(self._tx)
        except (struct.error, TypeError, ValueError, OverflowError) as e:
            self.counters["pack_error"] += 1
            raise ValueError(f"cannot encode {_type_of(msg)}: {e}") from e
        self._tx.seq = (self._tx.seq + 1) & 0xFF
        self.counters["packed"] += 1
        if self.signing is not None:
            self.signing.state.timestamp = self._tx.signing.timestamp
        return frame

    # -- in ------------------------------------------------------------------------------

    @property
    def pending(self) -> int:
        """Bytes of an incomplete frame waiting for the rest of a stream."""
        return int(self._rx.buf_len())

    def feed(self, data: bytes, *, keep_unknown: bool = False) -> list[Message]:
        """Decode bytes from a stream (TCP); an incomplete tail waits for more.

        Args:
            data: Received bytes, any split.
            keep_unknown: Also return well-formed frames of unknown ids as
                ``MAVLink_unknown`` objects (still counted), e.g. to record them.

        Returns:
            Decoded messages in arrival order; never raises on bad input.
        """
        out: list[Message] = []
        rx = self._rx
        try:
            msg = rx.parse_char(data)
            while msg is not None:
                self._sort(msg, out, keep_unknown)
                msg = rx.parse_char(b"")
        except Exception:  # pymavlink raising on hostile input: drop the buffer, go on
            self.counters["bad_data"] += 1
            self._rx = self._new_parser()
        return out

    def feed_datagram(self, data: bytes, *, keep_unknown: bool = False) -> list[Message]:
        """Decode one whole datagram (UDP); bytes left at its end are dropped.

        A datagram that is exactly one frame (what autopilots send) is decoded in
        one call by a decoder all codecs share, skipping pymavlink's byte-stream
        parser (a third of the cost); anything else goes through :meth:`feed`.

        Returns:
            Decoded messages, as :meth:`feed`.
        """
        if _frame_size(data) == len(data):
            out: list[Message] = []
            try:
                msg = self._frames.decode(bytearray(data))
            except Exception as e:  # pymavlink.MAVError: bad CRC, bad payload, signature
                self.counters[_failure(str(e), data)] += 1
                return out
            self._sort(msg, out, keep_unknown)
            return out
        out = self.feed(data, keep_unknown=keep_unknown)
        if self._rx.buf_len() > 0:
            self.counters["truncated"] += 1
            self._rx = self._new_parser()
        return out

    def reset_input(self) -> None:
        """Forget a partial frame, e.g. when a TCP connection is replaced."""
        if self._rx.buf_len() > 0:
            self.counters["truncated"] += 1
        self._rx = self._new_parser()

    # -- internals -----------------------------------------------------------------------

    def _new_parser(self) -> Any:
        parser = self._signed_parser() if self.signing is not None else mavlink.MAVLink(None)
        parser.srcSystem, parser.srcComponent = self.system, self.component
        parser.robust_parsing = True
        return parser

    def _signed_parser(self) -> Any:
        """A decoder that checks signatures against our key and the streams' timestamps."""
        assert self.signing is not None
        parser = mavlink.MAVLink(None)
        rx = parser.signing
        rx.secret_key = self.signing.key
        rx.stream_timestamps = self.signing.state.streams  # (shared: updated as frames pass)
        rx.timestamp = self.signing.state.timestamp  # a new stream may be 1 min behind it
        return parser

    def _sort(self, msg: Message, out: list[Message], keep_unknown: bool) -> None:
        """Count one parser result and keep it if it is a message."""
        counters = self.counters
        if isinstance(msg, mavlink.MAVLink_bad_data):
            counters[_failure(str(msg.reason), bytes(msg.data))] += 1
            return
        if isinstance(msg, mavlink.MAVLink_unknown):
            counters["unknown_id"] += 1
            if keep_unknown:
                out.append(msg)
            return
        counters["messages"] += 1
        header = msg.get_header()
        key = header.srcSystem << 8 | header.srcComponent
        last = self._last_seq.get(key)
        if last is not None:
            gap = (header.seq - last - 1) & 0xFF
            if 0 < gap < _MAX_SEQ_GAP:
                counters["seq_lost"] += gap
        self._last_seq[key] = header.seq
        if msg.get_msgbuf()[0] == MAVLINK1_MARKER:
            counters["mavlink1"] += 1
        out.append(msg)


def _frame_size(data: bytes) -> int:
    """Length of the frame starting ``data`` from its header (0 if no header)."""
    if len(data) < 3:
        return 0
    if data[0] == MAVLINK2_MARKER:
        if data[2] & ~mavlink.MAVLINK_IFLAG_SIGNED:
            return 0  # a flag we do not know: the stream parser judges it
        signed = data[2] & mavlink.MAVLINK_IFLAG_SIGNED
        return 12 + data[1] + (mavlink.MAVLINK_SIGNATURE_BLOCK_LEN if signed else 0)
    if data[0] == MAVLINK1_MARKER:
        return 8 + data[1]
    return 0


def _failure(reason: str, frame: bytes) -> str:
    """The counter a frame pymavlink refused goes to."""
    if "signature" in reason:
        signed = len(frame) > 2 and frame[0] == MAVLINK2_MARKER and frame[2] & 1
        return "bad_signature" if signed else "unsigned"
    return "bad_crc" if "CRC" in reason else "bad_data"


def _type_of(msg: object) -> str:
    get_type = getattr(msg, "get_type", None)
    return str(get_type()) if callable(get_type) else type(msg).__name__
