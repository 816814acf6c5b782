"""MAVLink 2 signing in the codec: signed out, only good signatures in, no replays."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import ConfigError
from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.mavlink.signing import Signing, SigningState, load_key

KEY = hashlib.sha256(b"convoy test passphrase").digest()


def _heartbeat() -> mavlink.MAVLink_heartbeat_message:
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 3, 3
    )


def _pair(key: bytes = KEY) -> tuple[MavCodec, MavCodec]:
    autopilot = MavCodec(1, 1, signing=Signing(key, link_id=1))
    service = MavCodec(255, 190, signing=Signing(KEY, link_id=2))
    return autopilot, service


def test_signed_frames_pass_and_carry_a_signature() -> None:
    autopilot, service = _pair()
    frame = autopilot.pack(_heartbeat())
    assert frame[2] & mavlink.MAVLINK_IFLAG_SIGNED
    assert len(frame) == 12 + 9 + mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
    msgs = service.feed_datagram(frame)
    assert [m.get_type() for m in msgs] == ["HEARTBEAT"]
    assert service.feed(autopilot.pack(_heartbeat()))[0].get_type() == "HEARTBEAT"  # (stream)


def test_unsigned_badly_signed_and_replayed_frames_are_dropped_and_counted() -> None:
    _, service = _pair()
    assert service.feed_datagram(MavCodec(1, 1).pack(_heartbeat())) == []
    stranger, _ = _pair(key=hashlib.sha256(b"a guess").digest())
    assert service.feed_datagram(stranger.pack(_heartbeat())) == []
    assert service.counters["unsigned"] == 1 and service.counters["bad_signature"] == 1
    autopilot, _ = _pair()
    frame = autopilot.pack(_heartbeat())
    assert len(service.feed_datagram(frame)) == 1
    assert service.feed_datagram(frame) == []  # the same frame again: a replay
    assert service.counters["bad_signature"] == 2
    # The stream parser (TCP) refuses them too.
    assert service.feed(MavCodec(1, 1).pack(_heartbeat())) == []
    assert service.counters["unsigned"] + service.counters["bad_signature"] == 4


def test_a_frame_replayed_after_a_restart_is_refused(tmp_path: Path) -> None:
    state_file = str(tmp_path / "uav1.signing.json")
    autopilot = MavCodec(1, 1, signing=Signing(KEY, link_id=1))
    first = MavCodec(255, 190, signing=Signing.from_files(KEY, 2, state_file))
    recorded = autopilot.pack(_heartbeat())
    assert len(first.feed_datagram(recorded)) == 1
    sent_ts = first.signing.state.timestamp if first.signing else 0
    first.pack(_heartbeat())
    assert first.signing is not None
    first.signing.save()
    # The service restarts: the recorded frame is replayed at it.
    second = MavCodec(255, 190, signing=Signing.from_files(KEY, 2, state_file))
    assert second.feed_datagram(recorded) == []
    assert second.counters["bad_signature"] == 1
    assert len(second.feed_datagram(autopilot.pack(_heartbeat()))) == 1  # fresh ones pass
    assert second.signing is not None and second.signing.state.timestamp > sent_ts


def test_keys_come_from_a_file_or_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    hexkey = tmp_path / "hex.key"
    hexkey.write_text(KEY.hex() + "\n")
    assert load_key("k", file=str(hexkey)) == KEY
    phrase = tmp_path / "phrase.key"
    phrase.write_text("convoy test passphrase\n")
    assert load_key("k", file=str(phrase)) == KEY  # MAVProxy: SHA-256 of the passphrase
    monkeypatch.setenv("UAV1_KEY", KEY.hex())
    assert load_key("k", env="UAV1_KEY") == KEY
    monkeypatch.delenv("UAV1_KEY")
    with pytest.raises(ConfigError, match="not set"):
        load_key("k", env="UAV1_KEY")
    assert "***" in repr(Signing(KEY)) and KEY.hex() not in repr(Signing(KEY))
    assert SigningState.load(str(tmp_path / "missing.json")) == SigningState()
