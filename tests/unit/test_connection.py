"""ConnectionSpec.parse: pymavlink and MAVSDK spellings, canonical form, clear errors."""

from __future__ import annotations

import pytest

from convoy_mav.errors import ConfigError
from convoy_mav.mavlink.connection import ConnectionSpec


@pytest.mark.parametrize(
    ("text", "scheme", "host", "port"),
    [
        ("udpin:0.0.0.0:14540", "udpin", "0.0.0.0", 14540),
        ("udpout:127.0.0.1:14540", "udpout", "127.0.0.1", 14540),
        ("udp:0.0.0.0:14550", "udpin", "0.0.0.0", 14550),  # mavutil: udp = listen
        ("tcp:127.0.0.1:5760", "tcp", "127.0.0.1", 5760),
        ("tcpin:0.0.0.0:5760", "tcpin", "0.0.0.0", 5760),
        ("udp://:14540", "udpin", "0.0.0.0", 14540),  # MAVSDK listen, any address
        ("udp://192.168.1.5:14540", "udpin", "192.168.1.5", 14540),
        ("udpin://0.0.0.0:14540", "udpin", "0.0.0.0", 14540),
        ("udpout://10.0.0.2:14557", "udpout", "10.0.0.2", 14557),
        ("tcp://127.0.0.1:5760", "tcp", "127.0.0.1", 5760),
        ("tcpout://sitl.local:5760", "tcp", "sitl.local", 5760),
        ("tcpin://:5760", "tcpin", "0.0.0.0", 5760),
        ("  UDPOUT:localhost:14550 ", "udpout", "localhost", 14550),
        ("udpin::14540", "udpin", "0.0.0.0", 14540),
        ("udpin:[::]:14540", "udpin", "::", 14540),
        ("tcp://[::1]:5760/", "tcp", "::1", 5760),
        ("udpin:127.0.0.1:0", "udpin", "127.0.0.1", 0),  # listening on a free port
    ],
)
def test_parse_accepts_common_spellings(text: str, scheme: str, host: str, port: int) -> None:
    spec = ConnectionSpec.parse(text)
    assert (spec.scheme, spec.host, spec.port) == (scheme, host, port)


@pytest.mark.parametrize(
    ("text", "canonical"),
    [
        ("udp://:14540", "udpin:0.0.0.0:14540"),
        ("tcp://127.0.0.1:5760", "tcp:127.0.0.1:5760"),
        ("udpin:[::]:14540", "udpin:[::]:14540"),
        ("UDPOUT:host:1", "udpout:host:1"),
    ],
)
def test_str_is_canonical_and_round_trips(text: str, canonical: str) -> None:
    spec = ConnectionSpec.parse(text)
    assert str(spec) == canonical
    assert ConnectionSpec.parse(str(spec)) == spec


def test_properties() -> None:
    assert ConnectionSpec.parse("udpin:0.0.0.0:1").listens
    assert ConnectionSpec.parse("tcpin:0.0.0.0:1").listens
    assert not ConnectionSpec.parse("udpout:h:1").listens
    assert ConnectionSpec.parse("tcp:h:1").is_tcp
    assert not ConnectionSpec.parse("udp://:1").is_tcp


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "empty"),
        ("udpbcast:0.0.0.0:14550", "unknown scheme"),
        ("serial:/dev/ttyACM0:57600", "serial"),
        ("/dev/ttyUSB0", "serial"),
        ("udpin:0.0.0.0", "host:port"),
        ("udpin:0.0.0.0:", "host:port"),
        ("udpin:0.0.0.0:abc", "not a number"),
        ("udpin:0.0.0.0:+5", "not a number"),
        ("udpin:0.0.0.0:65536", "0..65535"),
        ("udpout:127.0.0.1:0", "1..65535"),
        ("udpout::14540", "needs a host"),
        ("tcp://:5760", "needs a host"),
        ("udp://::1:5", "brackets"),
        ("udpin:[::1:5", "ipv6"),
        ("udpin:a b:5", "valid host"),
        ("14540", "unknown scheme"),
    ],
)
def test_parse_rejects_with_key_and_value(text: str, reason: str) -> None:
    with pytest.raises(ConfigError) as info:
        ConnectionSpec.parse(text, key="uav[2].connection")
    err = info.value
    assert err.key == "uav[2].connection"
    assert err.value == text
    assert reason.lower() in err.reason.lower()
    assert "uav[2].connection" in str(err) and repr(text) in str(err)


def test_non_string_is_a_config_error() -> None:
    with pytest.raises(ConfigError) as info:
        ConnectionSpec.parse(14540)  # type: ignore[arg-type]
    assert info.value.key == "connection"


def test_direct_construction_is_validated() -> None:
    with pytest.raises(ConfigError):
        ConnectionSpec("udpout", "127.0.0.1", 0)
    with pytest.raises(ConfigError):
        ConnectionSpec("serial", "x", 1)  # type: ignore[arg-type]
    assert ConnectionSpec("udpin", "0.0.0.0", 0).port == 0
