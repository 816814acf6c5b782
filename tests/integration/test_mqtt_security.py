"""MQTT with TLS, passwords and an ACL, against a real mosquitto.

The broker is set up as the README's Security section says: TLS on its only
listener, no anonymous clients, a password per user, and an ACL that lets only
the operator publish commands and convoy positions. The service's publisher
connects with its own user over TLS and hears the operator; a client without a
password, with a wrong one, or without TLS never gets to publish a command.
"""

from __future__ import annotations

import asyncio
import datetime
import getpass
import ipaddress
import os
import ssl
import subprocess
from collections.abc import Iterator
from pathlib import Path

import aiomqtt
import pytest
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from convoy_mav.config import MqttConfig
from convoy_mav.errors import ConfigError
from convoy_mav.publish import MqttPublisher
from convoy_mav.publish.security import mqtt_security
from tests.broker import Broker, find_mosquitto

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

PREFIX = "convoy"
ACL = f"""
user service
topic write {PREFIX}/status
topic write {PREFIX}/coverage
topic write {PREFIX}/alarm
topic write {PREFIX}/vehicle/#
topic read {PREFIX}/command
topic read {PREFIX}/convoy/#

user operator
topic readwrite {PREFIX}/#
"""
PASSWORDS = {"service": "s3rvice-pw", "operator": "0perator-pw"}


def _key() -> ec.EllipticCurvePrivateKey:
    return ec.generate_private_key(ec.SECP256R1())


def _write_pem(path: Path, key: ec.EllipticCurvePrivateKey, cert: x509.Certificate) -> None:
    path.with_suffix(".key").write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        )
    )
    path.with_suffix(".crt").write_bytes(cert.public_bytes(serialization.Encoding.PEM))


def _certificates(folder: Path) -> None:
    """ca.crt, and server.crt/.key for 127.0.0.1 signed by it."""
    now = datetime.datetime.now(datetime.UTC)
    ca_key, server_key = _key(), _key()
    ca_name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "convoy-mav test CA")])
    ca = (
        x509.CertificateBuilder()
        .subject_name(ca_name).issuer_name(ca_name).public_key(ca_key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=1))
        .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    server = (
        x509.CertificateBuilder()
        .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "127.0.0.1")]))
        .issuer_name(ca_name).public_key(server_key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5))
        .not_valid_after(now + datetime.timedelta(days=1))
        .add_extension(
            x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]),
            critical=False,
        )
        .sign(ca_key, hashes.SHA256())
    )  # fmt: skip
    _write_pem(folder / "ca", ca_key, ca)
    _write_pem(folder / "server", server_key, server)


@pytest.fixture(name="secure_broker")
def secure_broker_fixture(tmp_path: Path) -> Iterator[Broker]:
    executable = find_mosquitto()
    if executable is None:
        pytest.skip("mosquitto not installed")
    _certificates(tmp_path)
    passwd = tmp_path / "passwd"
    for user, password in PASSWORDS.items():
        subprocess.run(
            ["mosquitto_passwd", "-b", *(["-c"] if user == "service" else []), str(passwd),
             user, password],
            check=True, capture_output=True,
        )  # fmt: skip
    os.chmod(passwd, 0o600)
    (tmp_path / "acl").write_text(ACL)
    broker = Broker(
        executable,
        tmp_path,
        security=(
            f"cafile {tmp_path / 'ca.crt'}\ncertfile {tmp_path / 'server.crt'}\n"
            f"keyfile {tmp_path / 'server.key'}\nallow_anonymous false\n"
            f"password_file {passwd}\nacl_file {tmp_path / 'acl'}\n"
            # (as root, mosquitto would drop to its own user, who cannot read tmp_path)
            f"user {getpass.getuser()}\n"
        ),
    )
    broker.start()
    try:
        yield broker
    finally:
        broker.stop()


def _tls(folder: Path) -> ssl.SSLContext:
    return ssl.create_default_context(cafile=str(folder / "ca.crt"))


async def test_only_the_authenticated_operator_commands_the_service(
    secure_broker: Broker, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CONVOY_MQTT_PASSWORD", PASSWORDS["service"])
    cfg = MqttConfig(
        secure_broker.host, secure_broker.port, PREFIX, ca_file=str(tmp_path / "ca.crt"),
        username="service", password_env="CONVOY_MQTT_PASSWORD",
    )  # fmt: skip
    secure = mqtt_security(cfg)
    assert secure.tls and "s3rvice" not in repr(secure)
    commands: list[str] = []
    async with MqttPublisher(
        cfg.host, cfg.port, PREFIX, on_command=commands.append,
        username=secure.username, password=secure.password, tls_context=secure.tls_context,
    ) as pub:  # fmt: skip
        async with asyncio.timeout(5):
            await pub.wait_connected()
        host, port = secure_broker.host, secure_broker.port

        # Strangers: no password, a wrong one, no TLS. None of them gets in.
        for kwargs in (
            {"tls_context": _tls(tmp_path)},
            {"tls_context": _tls(tmp_path), "username": "operator", "password": "guess"},
            {"username": "operator", "password": PASSWORDS["operator"]},
        ):
            with pytest.raises(aiomqtt.MqttError):
                async with asyncio.timeout(5):
                    async with aiomqtt.Client(host, port, timeout=3, **kwargs) as stranger:
                        await stranger.publish(f"{PREFIX}/command", "pause")
        # The service's own user may not command itself either (the ACL drops it).
        async with aiomqtt.Client(
            host, port, username="service", password=PASSWORDS["service"],
            tls_context=_tls(tmp_path),
        ) as service_user:  # fmt: skip
            await service_user.publish(f"{PREFIX}/command", "pause", qos=1)
        # The operator may.
        async with aiomqtt.Client(
            host, port, username="operator", password=PASSWORDS["operator"],
            tls_context=_tls(tmp_path),
        ) as operator:  # fmt: skip
            await operator.publish(f"{PREFIX}/command", "resume", qos=1)
        async with asyncio.timeout(5):
            while not commands:
                await asyncio.sleep(0.01)
        await asyncio.sleep(0.2)
    assert commands == ["resume"]


def test_secrets_are_never_in_the_config_or_its_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from convoy_mav.config import parse_config

    with pytest.raises(ConfigError) as info:
        parse_config({"mission": {"sensor_radius_m": 1.0}, "mqtt": {"password": "hunter2"}})
    assert "hunter2" not in str(info.value) and "password_env" in str(info.value)
    monkeypatch.delenv("NOPE", raising=False)
    with pytest.raises(ConfigError, match="is not set"):
        mqtt_security(MqttConfig(username="u", password_env="NOPE"))
    secret = tmp_path / "pw"
    secret.write_text("hunter2\n")
    assert mqtt_security(MqttConfig(username="u", password_file=str(secret))).password == "hunter2"
    with pytest.raises(ConfigError) as bad:
        mqtt_security(MqttConfig(ca_file=str(secret)))  # not a certificate
    assert "hunter2" not in str(bad.value)
