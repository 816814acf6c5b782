"""MavCodec: golden packets, round trips between two codecs, and hostile input.

Two codecs are joined through plain bytes (h11 style); no sockets.
"""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.codec import MavCodec

# Pinned once from pymavlink 2.4.50 (see test_golden_heartbeat_crc_is_independently_right).
GOLDEN_HEARTBEAT_SEQ0 = bytes.fromhex("fd09000000ffbe0000000000000006080004033d48")
GOLDEN_HEARTBEAT_SEQ1 = bytes.fromhex("fd09000001ffbe0000000000000006080004032dc6")
GOLDEN_COMMAND_LONG = bytes.fromhex(
    "fd2000000001014c00000000144300000000000000000000000000000000000000000000000000020101c692"
)
HEARTBEAT_CRC_EXTRA = 50


def gcs_heartbeat() -> Any:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
    )


def vehicle_heartbeat(custom_mode: int = 6 << 16) -> Any:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 129, custom_mode, 4, 3
    )


def position(lat: int = 473977420, lon: int = 85455940) -> Any:
    return mavlink.MAVLink_global_position_int_message(
        1234, lat, lon, 538000, 50000, 180, -20, 3, 9000
    )


def x25(data: bytes) -> int:
    """MAVLink's CRC-16/MCRF4XX, written from the spec (independent of pymavlink)."""
    crc = 0xFFFF
    for byte in data:
        tmp = byte ^ (crc & 0xFF)
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


# -- golden packets --------------------------------------------------------------------


def test_golden_heartbeat_bytes_and_sequence() -> None:
    codec = MavCodec(system=255, component=190)
    assert codec.next_seq == 0
    assert codec.pack(gcs_heartbeat()) == GOLDEN_HEARTBEAT_SEQ0
    assert codec.pack(gcs_heartbeat()) == GOLDEN_HEARTBEAT_SEQ1
    assert codec.next_seq == 2
    assert codec.counters["packed"] == 2


def test_golden_heartbeat_crc_is_independently_right() -> None:
    frame = GOLDEN_HEARTBEAT_SEQ0
    assert frame[0] == 0xFD and frame[1] == 9  # MAVLink 2, 9-byte payload
    assert (frame[4], frame[5], frame[6]) == (0, 255, 190)  # seq, sysid, compid
    assert frame[7:10] == b"\x00\x00\x00"  # msgid 0
    assert frame[10:19] == bytes([0, 0, 0, 0, 6, 8, 0, 4, 3])  # custom_mode u32 first (sorted)
    crc = x25(frame[1:-2] + bytes([HEARTBEAT_CRC_EXTRA]))
    assert frame[-2:] == crc.to_bytes(2, "little")


def test_golden_command_long_truncates_trailing_zeros() -> None:
    codec = MavCodec(system=1, component=1)
    msg = mavlink.MAVLink_command_long_message(1, 1, 512, 0, 148, 0, 0, 0, 0, 0, 0)
    frame = codec.pack(msg)
    assert frame == GOLDEN_COMMAND_LONG
    assert frame[1] == 32  # 33-byte payload; the trailing confirmation=0 is cut (MAVLink 2)


def test_sequence_wraps_and_is_per_codec() -> None:
    a, b = MavCodec(), MavCodec()
    seqs = [a.pack(gcs_heartbeat())[4] for _ in range(260)]
    assert seqs[:3] == [0, 1, 2] and seqs[255] == 255 and seqs[256:] == [0, 1, 2, 3]
    assert b.pack(gcs_heartbeat())[4] == 0  # another link has its own numbering


def test_pack_error_is_a_value_error_and_keeps_the_sequence() -> None:
    codec = MavCodec()
    bad = mavlink.MAVLink_heartbeat_message(300, 8, 0, 0, 4, 3)  # uint8 field out of range
    with pytest.raises(ValueError, match="HEARTBEAT"):
        codec.pack(bad)
    assert codec.next_seq == 0 and codec.counters["pack_error"] == 1


def test_bad_identity_is_rejected() -> None:
    with pytest.raises(ValueError, match="system"):
        MavCodec(system=256)
    with pytest.raises(ValueError, match="component"):
        MavCodec(component=-1)


# -- round trips -----------------------------------------------------------------------


def test_round_trip_between_two_codecs() -> None:
    vehicle, gcs = MavCodec(system=7, component=1), MavCodec()
    sent = [vehicle_heartbeat(), position(), position(lat=-1, lon=-2)]
    frames = [vehicle.pack(m) for m in sent]
    got = gcs.feed_datagram(b"".join(frames))  # several frames in one datagram
    assert [m.get_type() for m in got] == [
        "HEARTBEAT",
        "GLOBAL_POSITION_INT",
        "GLOBAL_POSITION_INT",
    ]
    assert [m.get_srcSystem() for m in got] == [7, 7, 7]
    assert [m.get_seq() for m in got] == [0, 1, 2]
    assert got[0].custom_mode == 6 << 16 and got[0].autopilot == mavlink.MAV_AUTOPILOT_PX4
    assert (got[2].lat, got[2].lon, got[2].vx) == (-1, -2, 180)
    assert [bytes(m.get_msgbuf()) for m in got] == frames  # whole frames, for the tlog
    assert gcs.counters["messages"] == 3 and gcs.counters["seq_lost"] == 0


def test_stream_split_at_every_byte() -> None:
    tx = MavCodec(system=3)
    frames = b"".join(tx.pack(m) for m in (vehicle_heartbeat(), position()))
    for cut in range(len(frames) + 1):
        rx = MavCodec()
        got = rx.feed(frames[:cut]) + rx.feed(frames[cut:])
        assert [m.get_type() for m in got] == ["HEARTBEAT", "GLOBAL_POSITION_INT"], cut
        assert rx.pending == 0


def test_byte_by_byte_stream() -> None:
    tx, rx = MavCodec(system=3), MavCodec()
    frame = tx.pack(position())
    got = [m for b in frame for m in rx.feed(bytes([b]))]
    assert len(got) == 1 and got[0].lat == 473977420


def test_mavlink1_is_accepted() -> None:
    v1 = mavlink.MAVLink(None, srcSystem=9, srcComponent=1)
    frame = vehicle_heartbeat().pack(v1, force_mavlink1=True)
    assert frame[0] == 0xFE
    rx = MavCodec()
    (msg,) = rx.feed_datagram(frame)
    assert msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == 9
    assert rx.counters["mavlink1"] == 1 and rx.counters["messages"] == 1


def test_sequence_gaps_count_as_lost() -> None:
    tx, rx = MavCodec(system=5), MavCodec()
    frames = [tx.pack(position()) for _ in range(10)]
    for i, frame in enumerate(frames):
        if i not in (3, 4, 8):
            rx.feed_datagram(frame)
    assert rx.counters["seq_lost"] == 3
    rx.feed_datagram(frames[9])  # a duplicate is not loss
    assert rx.counters["seq_lost"] == 3


# -- hostile input ---------------------------------------------------------------------


def test_bad_crc_is_counted_and_the_next_frame_survives() -> None:
    tx, rx = MavCodec(system=2), MavCodec()
    bad = bytearray(tx.pack(position()))
    bad[15] ^= 0x40  # flip a payload bit: the checksum no longer matches
    good = tx.pack(vehicle_heartbeat())
    got = rx.feed(bytes(bad) + good)
    assert [m.get_type() for m in got] == ["HEARTBEAT"]
    assert rx.counters["bad_crc"] == 1 and rx.counters["messages"] == 1


def test_garbage_before_and_between_frames() -> None:
    tx, rx = MavCodec(system=2), MavCodec()
    data = b"\x00hello\x13" + tx.pack(position()) + b"junk!" + tx.pack(vehicle_heartbeat())
    got = rx.feed_datagram(data)
    assert [m.get_type() for m in got] == ["GLOBAL_POSITION_INT", "HEARTBEAT"]
    assert rx.counters["bad_data"] == 2


def test_truncated_datagram_does_not_poison_the_next() -> None:
    tx, rx = MavCodec(system=2), MavCodec()
    frame = tx.pack(position())
    assert rx.feed_datagram(frame[:-5]) == []
    assert rx.counters["truncated"] == 1 and rx.pending == 0
    (msg,) = rx.feed_datagram(tx.pack(vehicle_heartbeat()))
    assert msg.get_type() == "HEARTBEAT"


def test_stream_keeps_a_partial_frame_and_reset_drops_it() -> None:
    tx, rx = MavCodec(system=2), MavCodec()
    frame = tx.pack(position())
    assert rx.feed(frame[:7]) == [] and rx.pending == 7
    rx.reset_input()  # e.g. a new TCP connection
    assert rx.pending == 0 and rx.counters["truncated"] == 1
    assert [m.get_type() for m in rx.feed(tx.pack(vehicle_heartbeat()))] == ["HEARTBEAT"]


def test_unknown_message_id_is_counted_and_optionally_kept() -> None:
    from pymavlink.dialects.v20 import ardupilotmega  # AHRS2 (178) is not in common

    apm = ardupilotmega.MAVLink(None, srcSystem=1, srcComponent=1)
    frame = ardupilotmega.MAVLink_ahrs2_message(0.1, 0.2, 0.3, 10.0, 1, 2).pack(apm)
    rx = MavCodec()
    assert rx.feed_datagram(frame) == []
    assert rx.counters["unknown_id"] == 1 and rx.counters["messages"] == 0
    (kept,) = rx.feed_datagram(frame, keep_unknown=True)
    assert isinstance(kept, mavlink.MAVLink_unknown) and bytes(kept.get_msgbuf()) == frame
    assert rx.counters["unknown_id"] == 2


def test_invalid_incompat_flags_are_bad_data() -> None:
    tx, rx = MavCodec(system=2), MavCodec()
    frame = bytearray(tx.pack(vehicle_heartbeat()))
    frame[2] = 0x80  # an incompatibility flag nobody defined
    assert rx.feed_datagram(bytes(frame)) == []
    assert rx.counters["bad_data"] == 1


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=600))
def test_random_bytes_never_raise(data: bytes) -> None:
    rx = MavCodec()
    for msg in rx.feed(data) + rx.feed_datagram(data):
        assert isinstance(msg, mavlink.MAVLink_message)
        assert not isinstance(msg, (mavlink.MAVLink_bad_data, mavlink.MAVLink_unknown))


_NO_MARKERS = st.binary(max_size=80).map(lambda b: b.replace(b"\xfd", b"").replace(b"\xfe", b""))


@settings(max_examples=100, deadline=None)
@given(_NO_MARKERS, _NO_MARKERS, st.integers(0, 2**31 - 1))
def test_frames_survive_surrounding_junk(before: bytes, after: bytes, lat: int) -> None:
    tx, rx = MavCodec(system=4), MavCodec()
    got = rx.feed_datagram(before + tx.pack(position(lat=lat)) + after)
    assert [(m.get_type(), m.lat) for m in got] == [("GLOBAL_POSITION_INT", lat)]
    assert rx.counters["bad_data"] == (1 if before else 0) + (1 if after else 0)


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_any_single_corruption_costs_at_most_that_datagram(data: st.DataObject) -> None:
    tx, rx = MavCodec(system=4), MavCodec()
    frame = bytearray(tx.pack(position()))
    index = data.draw(st.integers(0, len(frame) - 1))
    frame[index] ^= data.draw(st.integers(1, 255))
    rx.feed_datagram(bytes(frame))  # whatever it makes of it, no exception
    (msg,) = rx.feed_datagram(tx.pack(vehicle_heartbeat()))
    assert msg.get_type() == "HEARTBEAT"


# -- purity ----------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_a_stream_resynchronises_after_any_corruption(data: st.DataObject) -> None:
    # In a stream a corrupted length byte can swallow up to one maximal frame
    # (280 bytes) of what follows; after that the parser is back in step.
    tx, rx = MavCodec(system=4), MavCodec()
    frames = [tx.pack(gcs_heartbeat()) for _ in range(16)]  # 21 bytes each
    first = bytearray(frames[0])
    index = data.draw(st.integers(0, len(first) - 1))
    first[index] ^= data.draw(st.integers(1, 255))
    got = rx.feed(bytes(first) + b"".join(frames[1:]))
    seqs = [m.get_seq() for m in got]
    assert seqs[-2:] == [14, 15]
    assert seqs == sorted(seqs) and all(1 <= s <= 15 for s in seqs)
