"""MAVLink 2 signing: keys, and the timestamps that make a replayed frame worthless.

Design rules (MAVLink 2 message signing; pymavlink computes and checks the
signatures, nothing here touches frame bytes):
- A key is 32 bytes. A key file holds either 64 hex digits (the key itself)
  or a passphrase, whose SHA-256 is the key: MAVProxy's ``signing setup
  <passphrase>`` convention, so one passphrase provisions ArduPilot, PX4 and
  the service alike. The key comes from a file or an environment variable,
  never from a config file's own text.
- Our timestamps (10 us units since 2015-01-01) start from the wall clock and
  never below the last one used, so an autopilot that remembers our stream
  accepts us after a restart. The last timestamp seen on each incoming stream
  is kept too: a frame recorded and replayed later is older than it and is
  refused, also after the service restarts (``SigningState`` is saved to a
  file beside the key when the link closes, and read back at start).
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from convoy_mav.errors import ConfigError

__all__ = ["KEY_BYTES", "Signing", "SigningState", "key_from_text", "load_key", "timestamp_now"]

log = logging.getLogger(__name__)

KEY_BYTES = 32
_EPOCH_2015 = 1_420_070_400.0  # Unix time of 2015-01-01 00:00:00 UTC


def timestamp_now(wall: Callable[[], float] = time.time) -> int:
    """MAVLink signing time now: 10 us units since 2015-01-01 (UTC)."""
    return int((wall() - _EPOCH_2015) * 100_000)


def load_key(key: str, *, file: str | None = None, env: str | None = None) -> bytes:
    """The 32-byte key from a file's first line or an environment variable.

    Args:
        key: The setting's name, for errors (``uav[0].signing_key_file``).
        file, env: Where it is (exactly one).

    Raises:
        ConfigError: Unreadable, unset or empty (never showing the secret).
    """
    if (file is None) == (env is None):
        raise ConfigError(key, None, "give a key file or an environment variable (one)")
    if env is not None:
        text = os.environ.get(env, "")
        if not text:
            raise ConfigError(key, env, "is not set in the environment")
    else:
        assert file is not None
        try:
            with open(file, encoding="utf-8") as fh:
                text = fh.readline()
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(key, file, f"cannot be read ({type(exc).__name__})") from None
    if not text.strip():
        raise ConfigError(key, file or env, "holds no key")
    return key_from_text(text)


def key_from_text(text: str) -> bytes:
    """64 hex digits are the key itself; anything else is a passphrase, hashed (SHA-256)."""
    text = text.strip()
    if len(text) == 2 * KEY_BYTES and all(c in "0123456789abcdefABCDEF" for c in text):
        return bytes.fromhex(text)
    return hashlib.sha256(text.encode("utf-8")).digest()


@dataclass(slots=True)
class SigningState:
    """The timestamps to keep across restarts: ours, and each incoming stream's last.

    ``streams`` maps (link id, system id, component id) to the last timestamp
    accepted; pymavlink updates it in place as frames are checked.
    """

    timestamp: int = 0
    streams: dict[tuple[int, int, int], int] = field(default_factory=dict)

    @classmethod
    def load(cls, path: str) -> SigningState:
        """Read it back (a missing or unreadable file is a fresh state, logged)."""
        try:
            with open(path, encoding="utf-8") as fh:
                raw = json.load(fh)
            streams = {
                (int(k[0]), int(k[1]), int(k[2])): int(v)
                for k, v in ((key.split(","), value) for key, value in raw["streams"].items())
            }
            return cls(int(raw["timestamp"]), streams)
        except FileNotFoundError:
            return cls()
        except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
            log.warning("signing state %s unreadable (%s): starting afresh", path, exc)
            return cls()

    def save(self, path: str) -> None:
        """Write it atomically (a crash mid-write leaves the old file)."""
        raw = {
            "timestamp": self.timestamp,
            "streams": {f"{a},{b},{c}": t for (a, b, c), t in sorted(self.streams.items())},
        }
        tmp = f"{path}.tmp"
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(raw, fh)
        os.replace(tmp, path)


@dataclass(slots=True)
class Signing:
    """How one link signs and checks: its key, link id and timestamps.

    Attributes:
        key: The 32-byte secret.
        link_id: Our link id in the signature (0..255), one per link.
        state: Timestamps (see :class:`SigningState`), shared with the codec.
        state_file: Where ``state`` is kept across restarts (None: not kept).
    """

    key: bytes
    link_id: int = 0
    state: SigningState = field(default_factory=SigningState)
    state_file: str | None = None

    def __post_init__(self) -> None:
        if len(self.key) != KEY_BYTES:
            raise ValueError(f"a MAVLink signing key is {KEY_BYTES} bytes, got {len(self.key)}")
        if not 0 <= self.link_id <= 255:
            raise ValueError(f"link id must be in 0..255, got {self.link_id}")

    def __repr__(self) -> str:
        return f"Signing(key=***, link_id={self.link_id}, state_file={self.state_file!r})"

    @classmethod
    def from_files(cls, key: bytes, link_id: int, state_file: str | None) -> Signing:
        """A link's signing, its timestamps read back from ``state_file`` if there is one."""
        state = SigningState() if state_file is None else SigningState.load(state_file)
        return cls(key, link_id, state, state_file)

    def save(self) -> None:
        """Keep the timestamps for the next start (if a file was given); errors are logged."""
        if self.state_file is None:
            return
        try:
            self.state.save(self.state_file)
        except OSError as exc:
            log.error("signing state %s not saved (%s)", self.state_file, exc)
