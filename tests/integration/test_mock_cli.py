"""``sitl-mock`` as a separate process: endpoints, a client, SIGINT, exit codes."""

from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

ROOT = Path(__file__).resolve().parents[2]
ENDPOINT = re.compile(
    r"^vehicle sysid=(\d+) kind=(\w+) personality=(\w+) frame=(\w+) "
    r"connect=udpout:127\.0\.0\.1:(\d+) listen=udpin:127\.0\.0\.1:(\d+) "
    r"mavsdk=udpout://127\.0\.0\.1:(\d+)$"
)


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT / "src"), str(ROOT), env.get("PYTHONPATH", "")]
    ).rstrip(os.pathsep)
    return env


def _command() -> list[str]:
    """The installed ``sitl-mock`` script if there is one, else ``python -m sitl_mock``."""
    script = Path(sys.executable).with_name("sitl-mock")
    return [str(script)] if script.exists() else [sys.executable, "-m", "sitl_mock"]


def _start(*args: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [*_command(), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(),
        cwd=ROOT,
    )


def _read_until_ready(proc: subprocess.Popen[str]) -> list[str]:
    assert proc.stdout is not None
    lines = []
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line.rstrip("\n"))
        if line.startswith("sitl-mock: ready"):
            return lines
    proc.kill()
    raise AssertionError(f"no ready line; got {lines!r}, stderr {proc.communicate()[1]!r}")


def _talk(port: int) -> list[Any]:
    """A blocking pymavlink client (the mock is another process): heartbeat + command."""
    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=255)
    try:
        conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=5)
        conn.mav.command_long_send(
            1, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 0, 33, 0, 0, 0, 0, 0, 0
        )
        ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=5)
        return [hb, ack]
    finally:
        conn.close()


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_cli_serves_then_stops_cleanly_on_a_signal(tmp_path: Path, sig: signal.Signals) -> None:
    from tests.mavclient import free_udp_ports

    base = free_udp_ports(3)
    truth = tmp_path / "truth.csv"
    proc = _start(
        "--aircraft", "2", "--ground", "1", "--ground-speed", "5", "--speedup", "50",
        "--base-port", str(base), "--truth", str(truth), "--personality", "px4",
    )  # fmt: skip
    try:
        lines = _read_until_ready(proc)
        eps = [m.groups() for line in lines if (m := ENDPOINT.match(line))]
        assert [(e[0], e[1], e[2]) for e in eps] == [
            ("1", "aircraft", "px4"),
            ("2", "aircraft", "px4"),
            ("3", "ground", "px4"),
        ]
        assert [int(e[4]) for e in eps] == [base, base + 1, base + 2]
        hb, ack = _talk(int(eps[0][4]))
        assert hb is not None and hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
        assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
        time.sleep(0.2)  # 10 s of sim time: a truth log worth reading
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    status = out.strip().splitlines()[-1]
    assert status.startswith("sitl-mock: t=")
    assert re.search(r"datagrams in=\d+ out=\d+ messages in=(\d+)", status)
    assert "drops: none" in status
    assert "Traceback" not in err
    with open(truth, newline="") as f:
        rows = list(csv.DictReader(f))
    assert {r["sysid"] for r in rows} == {"1", "2", "3"}
    assert float(rows[-1]["t"]) > 5.0
    ground = [r for r in rows if r["kind"] == "ground"]
    assert float(ground[-1]["north"]) > float(ground[0]["north"]) + 20.0  # the convoy drives


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--speedup", "-3"], "speedup = -3.0"),
        (["--aircraft", "many"], "--aircraft"),
        (["--kill", "1-5"], "faults.kill[0] = '1-5'"),
        (["--config", "/nonexistent/mock.toml"], "config = '/nonexistent/mock.toml'"),
    ],
)
def test_cli_bad_config_exits_2_with_one_line(args: list[str], needle: str) -> None:
    proc = subprocess.run(
        [*_command(), *args],
        check=False,
        capture_output=True,
        text=True,
        env=_env(),
        cwd=ROOT,
        timeout=30,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith("sitl-mock: error: ")
    assert needle in lines[0]
    assert proc.stdout == ""


def test_cli_bad_key_in_a_config_file(tmp_path: Path) -> None:
    config = tmp_path / "bad.toml"
    config.write_text("[aircraft]\ncount = 2\nairspeed = -4\n", encoding="utf-8")
    proc = subprocess.run(
        [*_command(), "--config", str(config)],
        check=False,
        capture_output=True,
        text=True,
        env=_env(),
        cwd=ROOT,
        timeout=30,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        "sitl-mock: error: aircraft.airspeed = -4: must be a finite number > 0"
    )
