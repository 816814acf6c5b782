"""The MQTT connection's TLS context and credentials, from ``[mqtt]``.

Design rules:
- A password never lives in a config file: it comes from an environment
  variable (``password_env``) or a file (``password_file``, first line), read
  when the service starts. Errors name the setting, never the secret.
- TLS: ``ca_file`` (the broker's CA) or the system trust store (``tls = true``);
  a client certificate with ``cert_file`` and ``key_file``. The broker's host
  name is checked against its certificate, as a browser would.
"""

from __future__ import annotations

import os
import ssl
from dataclasses import dataclass

from convoy_mav.config import MqttConfig
from convoy_mav.errors import ConfigError

__all__ = ["MqttSecurity", "mqtt_security"]


@dataclass(frozen=True, slots=True)
class MqttSecurity:
    """What the client presents: credentials (``password`` kept out of ``repr``) and TLS."""

    username: str | None = None
    password: str | None = None
    tls_context: ssl.SSLContext | None = None

    def __repr__(self) -> str:
        secret = None if self.password is None else "***"
        return f"MqttSecurity(username={self.username!r}, password={secret}, tls={self.tls})"

    @property
    def tls(self) -> bool:
        """True when the connection is encrypted."""
        return self.tls_context is not None


def mqtt_security(cfg: MqttConfig) -> MqttSecurity:
    """Read the password and build the TLS context ``cfg`` asks for.

    Raises:
        ConfigError: A password variable unset or empty, a file unreadable, a
            certificate or key that does not load (named, the secret never shown).
    """
    return MqttSecurity(cfg.username, _password(cfg), _tls_context(cfg))


def _password(cfg: MqttConfig) -> str | None:
    if cfg.password_env is not None:
        value = os.environ.get(cfg.password_env)
        if not value:
            raise ConfigError(
                "mqtt.password_env", cfg.password_env, "is not set in the environment"
            )
        return value
    if cfg.password_file is not None:
        try:
            with open(cfg.password_file, encoding="utf-8") as fh:
                value = fh.readline().rstrip("\r\n")
        except (OSError, UnicodeDecodeError) as exc:
            reason = f"cannot be read ({type(exc).__name__})"
            raise ConfigError("mqtt.password_file", cfg.password_file, reason) from None
        if not value:
            raise ConfigError("mqtt.password_file", cfg.password_file, "is empty")
        return value
    return None


def _tls_context(cfg: MqttConfig) -> ssl.SSLContext | None:
    if not (cfg.tls or cfg.ca_file or cfg.cert_file):
        return None
    try:
        context = ssl.create_default_context(cafile=cfg.ca_file)
    except (OSError, ssl.SSLError) as exc:
        raise ConfigError("mqtt.ca_file", cfg.ca_file, f"cannot be used ({exc})") from exc
    if cfg.cert_file is not None:
        try:
            context.load_cert_chain(cfg.cert_file, cfg.key_file)
        except (OSError, ssl.SSLError) as exc:
            raise ConfigError(
                "mqtt.cert_file", cfg.cert_file, f"with its key cannot be used ({exc})"
            ) from exc
    return context
