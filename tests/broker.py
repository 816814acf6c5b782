"""A real mosquitto broker for MQTT tests: started on a free 127.0.0.1 port, killable.

Tests that need a broker take the ``mqtt_broker`` fixture::

    async def test_x(mqtt_broker: Broker) -> None:
        async with MqttPublisher(mqtt_broker.host, mqtt_broker.port) as pub: ...
        mqtt_broker.kill()      # SIGKILL: clients see the connection drop
        mqtt_broker.restart()   # same port, fresh state (no persistence)

When ``mosquitto`` is not installed the fixture skips with the install
command -- except under CI (``CI`` set in the environment), where a missing
broker is a broken CI image and the test fails loudly instead.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

__all__ = ["INSTALL_HINT", "Broker", "find_mosquitto", "mqtt_broker_fixture"]

INSTALL_HINT = "apt-get install -y mosquitto (Debian/Ubuntu) or brew install mosquitto (macOS)"
_SEARCH = ("/usr/sbin", "/usr/local/sbin", "/opt/homebrew/sbin", "/usr/local/opt/mosquitto/sbin")


def find_mosquitto() -> str | None:
    """Path of the ``mosquitto`` executable (Debian puts it in /usr/sbin, off most PATHs)."""
    found = shutil.which("mosquitto")
    if found:
        return found
    for folder in _SEARCH:
        candidate = Path(folder) / "mosquitto"
        if candidate.is_file() and os.access(candidate, os.X_OK):
            return str(candidate)
    return None


def _free_tcp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Broker:
    """One mosquitto process bound to ``127.0.0.1:port``, config and log in ``workdir``.

    Only ever signals the process it started itself.
    """

    host = "127.0.0.1"

    def __init__(
        self, executable: str, workdir: Path, port: int | None = None, security: str = ""
    ) -> None:
        self.executable = executable
        self.security = security  # config lines for the listener (TLS, passwords, ACL)
        self.workdir = workdir
        self.port = port if port is not None else _free_tcp_port()
        self.starts = 0
        self._proc: subprocess.Popen[bytes] | None = None

    @property
    def running(self) -> bool:
        return self._proc is not None and self._proc.poll() is None

    @property
    def log_path(self) -> Path:
        return self.workdir / f"mosquitto-{self.port}.log"

    def log_text(self) -> str:
        try:
            return self.log_path.read_text(errors="replace")
        except FileNotFoundError:
            return ""

    def start(self, timeout: float = 5.0) -> None:
        """Start mosquitto and wait until it accepts TCP connections.

        Raises:
            RuntimeError: If it exits or does not listen within ``timeout`` (log attached).
        """
        if self.running:
            return
        conf = self.workdir / f"mosquitto-{self.port}.conf"
        conf.write_text(
            f"listener {self.port} {self.host}\n"
            + (self.security or "allow_anonymous true\n")
            + "persistence false\n"
            "log_dest stderr\n"
            "log_type error\nlog_type warning\nlog_type notice\nlog_type information\n"
        )
        with self.log_path.open("ab") as log:
            self._proc = subprocess.Popen(
                [self.executable, "-c", str(conf)],
                stdin=subprocess.DEVNULL,
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        self.starts += 1
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self._proc.poll() is not None:
                raise RuntimeError(
                    f"mosquitto exited with {self._proc.returncode} on port {self.port}:\n"
                    + self.log_text()
                )
            try:
                with socket.create_connection((self.host, self.port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.02)
        self.stop()
        raise RuntimeError(
            f"mosquitto not listening on {self.port} after {timeout}s:\n{self.log_text()}"
        )

    def kill(self) -> None:
        """SIGKILL: no DISCONNECT, no goodbye; the kernel closes the sockets."""
        self._signal(signal.SIGKILL)

    def stop(self) -> None:
        """SIGTERM, then SIGKILL if it lingers."""
        if self._proc is None:
            return
        if self._proc.poll() is None:
            self._proc.send_signal(signal.SIGCONT)  # a paused broker cannot act on SIGTERM
            self._proc.terminate()
            try:
                self._proc.wait(timeout=3.0)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait(timeout=3.0)
        self._proc = None

    def pause(self) -> None:
        """SIGSTOP: a hung broker -- connections stay open, nothing is answered."""
        self._signal(signal.SIGSTOP, wait=False)

    def resume(self) -> None:
        """SIGCONT after :meth:`pause`."""
        self._signal(signal.SIGCONT, wait=False)

    def restart(self, timeout: float = 5.0) -> None:
        """Start again on the same port (mosquitto sets SO_REUSEADDR)."""
        self.stop()
        self.start(timeout)

    def _signal(self, sig: signal.Signals, *, wait: bool = True) -> None:
        if self._proc is None or self._proc.poll() is not None:
            return
        self._proc.send_signal(sig)
        if wait:
            self._proc.wait(timeout=3.0)


def _mosquitto_or_skip() -> str:
    executable = find_mosquitto()
    if executable is not None:
        return executable
    reason = f"mosquitto broker not installed; install it with: {INSTALL_HINT}"
    if os.environ.get("CI"):
        pytest.fail(f"CI is set, so MQTT tests may not be skipped: {reason}", pytrace=False)
    pytest.skip(reason)


@pytest.fixture(name="mqtt_broker")
def mqtt_broker_fixture(tmp_path: Path) -> Iterator[Broker]:
    """``mqtt_broker``: a running mosquitto on a free port of 127.0.0.1, stopped at teardown.

    Named apart from the fixture so a test module can import it without its
    parameters shadowing the import (ruff F811).
    """
    executable = _mosquitto_or_skip()
    broker = Broker(executable, tmp_path)
    for attempt in range(3):  # the free port may be taken between probe and bind
        try:
            broker.start()
            break
        except RuntimeError:
            if attempt == 2:
                raise
            broker = Broker(executable, tmp_path)
    try:
        yield broker
    finally:
        broker.stop()
