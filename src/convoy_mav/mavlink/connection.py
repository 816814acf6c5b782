"""Connection strings as users write them, parsed into one frozen value.

Operators copy endpoints from pymavlink/MAVProxy (``udpin:0.0.0.0:14540``) or
from MAVSDK (``udp://:14540``); both spellings land on the same
:class:`ConnectionSpec`, whose ``str()`` is the canonical pymavlink form used in
logs and error messages. Pure: no sockets, nothing resolved here.

Accepted forms (scheme names are case-insensitive)::

    udpin:HOST:PORT     udp:HOST:PORT (= udpin, as in mavutil)    udpin://HOST:PORT
    udpout:HOST:PORT    udpout://HOST:PORT
    tcp:HOST:PORT       tcp://HOST:PORT   tcpout://HOST:PORT       (client, reconnects)
    tcpin:HOST:PORT     tcpin://HOST:PORT                          (server, one peer)
    udp://HOST:PORT     udp://:PORT  (MAVSDK: listen; an empty host is 0.0.0.0)

IPv6 hosts go in brackets: ``udpin:[::]:14540``. Listening schemes accept port 0
(the OS picks one; tests use it); client schemes need a host and a real port.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from convoy_mav.errors import ConfigError

__all__ = ["ConnectionSpec", "Scheme"]

Scheme = Literal["udpin", "udpout", "tcp", "tcpin"]

# Every accepted spelling -> canonical scheme, for "scheme:host:port" (mavutil) and
# "scheme://host:port" (MAVSDK) alike.
_COLON_SCHEMES: dict[str, Scheme] = {
    "udpin": "udpin",
    "udp": "udpin",
    "udpout": "udpout",
    "tcp": "tcp",
    "tcpout": "tcp",
    "tcpin": "tcpin",
}
_URL_SCHEMES: dict[str, Scheme] = {
    "udp": "udpin",
    "udpin": "udpin",
    "udpout": "udpout",
    "tcp": "tcp",
    "tcpout": "tcp",
    "tcpin": "tcpin",
}
_LISTENING: frozenset[str] = frozenset({"udpin", "tcpin"})
_SERIAL_HINTS = ("serial", "/dev/", "com")


@dataclass(frozen=True, slots=True)
class ConnectionSpec:
    """Where one autopilot link lives: scheme, host and port.

    Attributes:
        scheme: ``udpin`` (we listen, the peer is learnt from its datagrams),
            ``udpout`` (we send to host:port from an ephemeral port), ``tcp``
            (we connect, and reconnect on loss), ``tcpin`` (we accept one peer).
        host: Host name or address (IPv6 without brackets).
        port: TCP/UDP port; 0 only for listening schemes.
    """

    scheme: Scheme
    host: str
    port: int

    def __post_init__(self) -> None:
        if self.scheme not in _COLON_SCHEMES.values():
            raise ConfigError("connection", self.scheme, "unknown scheme")
        if not self.host or any(c.isspace() or c in "/@" for c in self.host):
            raise ConfigError("connection", self.host, "not a valid host")
        low = 0 if self.listens else 1
        if isinstance(self.port, bool) or not low <= self.port <= 65535:
            raise ConfigError("connection", self.port, f"port must be in {low}..65535")

    @property
    def listens(self) -> bool:
        """True for ``udpin``/``tcpin``: we bind and wait for the peer."""
        return self.scheme in _LISTENING

    @property
    def is_tcp(self) -> bool:
        """True for the stream schemes (``tcp``, ``tcpin``)."""
        return self.scheme in ("tcp", "tcpin")

    @classmethod
    def parse(cls, text: str, key: str = "connection") -> ConnectionSpec:
        """Parse a pymavlink/MAVProxy or MAVSDK connection string.

        Args:
            text: The string as the user wrote it.
            key: Config key reported in errors (e.g. ``uav[2].connection``).

        Returns:
            The spec; ``str(spec)`` is its canonical ``scheme:host:port`` form.

        Raises:
            ConfigError: Unknown scheme, serial device, missing/invalid host or
                port. The message names ``key`` and ``text``.
        """
        if not isinstance(text, str):
            raise ConfigError(key, text, "a connection string is text, e.g. 'udpin:0.0.0.0:14540'")
        raw = text.strip()
        low = raw.lower()
        if not raw:
            raise ConfigError(key, text, "empty; e.g. 'udpin:0.0.0.0:14540'")
        if low.startswith(_SERIAL_HINTS):
            raise ConfigError(
                key,
                text,
                "serial links are not supported; bridge to UDP (e.g. mavlink-router)",
            )
        if "://" in raw:
            name, _, rest = raw.partition("://")
            scheme = _URL_SCHEMES.get(name.lower())
            url = True
        else:
            name, sep, rest = raw.partition(":")
            scheme = _COLON_SCHEMES.get(name.lower()) if sep else None
            url = False
        if scheme is None:
            known = "udpin, udpout, udp, tcp, tcpin (or udp://, udpout://, tcp://, tcpin://)"
            raise ConfigError(key, text, f"unknown scheme {name!r}; use one of {known}")
        host, port_text = _split_host_port(rest.rstrip("/") if url else rest, key, text)
        if not host:
            if scheme not in _LISTENING:
                raise ConfigError(key, text, f"{scheme} needs a host to reach, e.g. 127.0.0.1")
            host = "0.0.0.0"
        if not (port_text.isascii() and port_text.isdigit()):
            raise ConfigError(key, text, f"port {port_text!r} is not a number")
        port = int(port_text)
        try:
            return cls(scheme, host, port)
        except ConfigError as e:  # re-raise naming the caller's key and the whole string
            raise ConfigError(key, text, e.reason) from None

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{self.scheme}:{host}:{self.port}"


def _split_host_port(rest: str, key: str, text: str) -> tuple[str, str]:
    """``host:port`` or ``[v6]:port`` -> (host, port text); the host may be empty."""
    if rest.startswith("["):
        host, bracket, tail = rest[1:].partition("]")
        if not bracket or not tail.startswith(":"):
            raise ConfigError(key, text, "expected [ipv6-address]:port")
        return host, tail[1:]
    host, sep, port_text = rest.rpartition(":")
    if not sep or not port_text:
        raise ConfigError(key, text, "expected host:port, e.g. 127.0.0.1:14540")
    if ":" in host:
        raise ConfigError(key, text, "put an IPv6 address in brackets: [::1]:14540")
    return host, port_text
