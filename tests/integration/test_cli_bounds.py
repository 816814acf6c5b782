"""The CLI against absurd inputs and lost outputs: one line and exit 2, nothing overwritten.

Every input past a bound is refused before it costs anything (issue: "bounded
everything, killable always, nothing lost"); an output that cannot be written
is found before the flight; a plot that fails after it does not take the report
with it; an earlier flight's tlog is never overwritten.
"""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from convoy_mav import cli, plot
from tests.hostspeed import slowdown

pytestmark = pytest.mark.integration

MISSION = """
[mission]
sensor_radius_m = 100.0
{extra}
[aircraft]
airspeed_mps = 18.0
turn_radius_m = 150.0
altitude_m = {altitude}
[[uav]]
connection = "udpin:127.0.0.1:{port}"
sysid = 1
"""


def _config(tmp_path: Path, extra: str = "", altitude: str = "100.0", port: int = 14999) -> str:
    path = tmp_path / "mission.toml"
    path.write_text(MISSION.format(extra=extra, altitude=altitude, port=port), encoding="utf-8")
    return str(path)


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert cli.main(argv) == cli.EXIT_USAGE
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith("convoy-mav: error: ")
    return err[0]


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["demo", "--speedup", "1e9"], "--speedup = 1000000000.0: must be > 0 and <= 1000"),
        (["demo", "--speedup", "0"], "--speedup = 0.0"),
        (["demo", "--duration", "-5"], "--duration = -5.0"),
        (["demo", "--duration", "1e12"], "--duration = 1000000000000.0"),
        (["replay", "--road", "bends", "--duration", "nan"], "--duration = nan"),
        (["demo", "--uavs", "100000"], "--uavs = 100000: must be 1..200"),
        (["demo", "--report", "/nonexistent/dir/r.json"], "does not exist"),
        (["demo", "--plot", "mission.txt"], "--plot = 'mission.txt': must end in one of"),
        (["demo", "--tlog", "/"], "--tlog = '/': is a directory"),
    ],
)
def test_flags_past_a_bound_are_one_line_and_exit_2(
    argv: list[str], needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert needle in _refused(argv, capsys)


@pytest.mark.parametrize(
    ("extra", "altitude", "needle"),
    [
        ("setpoint_rate_hz = 1e9", "100.0", "setpoint_rate_hz = 1000000000.0: must be <= 100"),
        ("lost_after_s = 1e-9", "100.0", "mission.lost_after_s = 1e-09: must be >= 0.2"),
        ("", "1e9", "aircraft.altitude_m = 1000000000.0: must be <= 10000"),
    ],
)
def test_config_values_past_a_bound_are_one_line_and_exit_2(
    tmp_path: Path, extra: str, altitude: str, needle: str, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _config(tmp_path, extra, altitude)
    assert needle in _refused(["run", "--config", config, "--duration", "5"], capsys)


def test_run_with_a_negative_duration_and_a_non_utf8_config(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert "--duration = -5.0" in _refused(
        ["run", "--config", _config(tmp_path), "--duration", "-5"], capsys
    )
    latin = tmp_path / "latin1.toml"
    latin.write_bytes(b"# V\xe9hicules\n[mission]\nsensor_radius_m = 100.0\n")
    assert "is not UTF-8 text" in _refused(["run", "--config", str(latin)], capsys)


def test_a_failed_plot_keeps_the_report_and_an_old_tlog(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken_plot(*args: object, **kwargs: object) -> None:
        raise RuntimeError("no display, no fonts, no luck")

    monkeypatch.setattr(plot, "plot_mission", broken_plot)
    report, tlog = tmp_path / "report.json", tmp_path / "mission.tlog"
    tlog.write_bytes(b"an earlier flight")
    argv = ["demo", "--scenario", "stationary", "--duration", "40", "--speedup", "40", "-q"]
    status = cli.main(
        [*argv, "--report", str(report), "--plot", str(tmp_path / "m.png"), "--tlog", str(tlog)]
    )
    assert status == cli.EXIT_OUTPUT
    assert "plot" in capsys.readouterr().err
    written = json.loads(report.read_text())
    assert tlog.read_bytes() == b"an earlier flight"
    assert written["tlog"] == str(tmp_path / "mission-1.tlog")
    assert (tmp_path / "mission-1.tlog").stat().st_size > 1000


def test_a_run_that_cannot_bind_leaves_the_tlog_alone(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        tlog = tmp_path / "precious.tlog"
        tlog.write_bytes(b"x" * 4096)
        config = _config(tmp_path, port=port)
        status = cli.main(["run", "--config", config, "--duration", "5", "--tlog", str(tlog)])
    assert status == cli.EXIT_USAGE
    assert tlog.read_bytes() == b"x" * 4096


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_run_nobody_answers_ends_on_a_signal(tmp_path: Path, sig: signal.Signals) -> None:
    """The sync wait (no autopilot has spoken) ends on SIGINT and SIGTERM, at once.

    The signal is sent once the process has had time to start and take its handlers
    (2 s on the reference host, longer on a slower one: at 3.6x slower, a fixed 2 s
    signalled it while it still imported matplotlib, and the signal's default action
    ended it)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "convoy_mav", "run", "--config", _config(tmp_path),
         "--duration", "60", "-q"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    time.sleep(2.0 * slowdown())
    sent = time.monotonic()
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=10)
    assert time.monotonic() - sent < 2.0, (out, err)
    assert proc.returncode == 0, err
    assert "never protected" in out


def test_plan_refuses_a_plan_that_leaves_the_fence(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "fenced.toml"
    config.write_text(
        "[mission]\nsensor_radius_m = 100.0\n[aircraft]\nairspeed_mps = 18.0\n"
        "turn_radius_m = 150.0\n[safety]\n"
        "fence = [[47.3990, 8.5400], [47.3990, 8.5500], [47.3960, 8.5500], [47.3960, 8.5400]]\n",
        encoding="utf-8",
    )
    line = _refused(["plan", "--config", str(config)], capsys)
    assert "UAV 1's path leaves the fence at 47.39" in line
    roomy = config.read_text().replace("47.3990", "47.4200").replace("47.3960", "47.3700")
    config.write_text(roomy.replace("8.5400", "8.5000").replace("8.5500", "8.5900"))
    assert cli.main(["plan", "--config", str(config)]) == 0
