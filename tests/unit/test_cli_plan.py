"""The ``convoy-mav plan`` command: JSON contract, human table and clear errors."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from convoy_mav.cli import main

REPO = Path(__file__).resolve().parents[2]


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["plan", *argv, "--json"]) == 0
    out = capsys.readouterr().out
    data = json.loads(out)
    assert isinstance(data, dict)
    return data


def test_stationary_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_json(capsys, "--turn-radius", "150", "--sensor-radius", "100", "--uav-speed", "18")
    assert out["case"] == "stationary"
    assert out["min_uavs"] == 5
    assert out["coverage_per_uav"] == pytest.approx(math.asin(2 / 3) / math.pi)
    assert out["entry_heading_offset_rad"] == pytest.approx(math.asin(2 / 3))
    assert out["orbit_period_s"] == pytest.approx(2 * math.pi * 150 / 18)
    assert out["entry_times_s"] == pytest.approx([out["orbit_period_s"] * i / 5 for i in range(5)])
    assert out["predicted_coverage"] == 1.0
    assert len(out["vehicles"]) == 5
    for v, t in zip(out["vehicles"], out["entry_times_s"], strict=True):
        assert v["phase_s"] == pytest.approx(t)
        assert {"t_start_s", "start", "turn", "radius_m", "speed_mps", "duration_s"} <= set(
            v["segments"][0]
        )
        assert sum(s["duration_s"] for s in v["segments"]) == pytest.approx(out["orbit_period_s"])


def test_moving_json_contract(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_json(
        capsys,
        "--turn-radius", "150", "--sensor-radius", "100", "--uav-speed", "18",
        "--convoy-speed", "6", "--convoy-heading", "45",
    )  # fmt: skip
    assert out["case"] == "moving"
    assert math.sin(out["beta_rad"]) / out["beta_rad"] == pytest.approx(6 / 18)
    assert out["v_star"] == pytest.approx(
        math.sqrt(2 * 100 * 150 - 100**2) / (150 * math.acos(1 - 100 / 150))
    )
    assert out["gamma_star_rad"] is not None
    assert out["min_uavs"] == math.ceil(out["beta_rad"] / out["gamma_star_rad"])
    assert out["meet_period_s"] == pytest.approx(2 * 150 * out["beta_rad"] / 18)
    assert out["convoy_heading_deg"] == pytest.approx(45.0)
    assert [v["segments"][0]["turn"] for v in out["vehicles"]] == ["L"] * out["min_uavs"]


def test_moving_fast_convoy_gamma_null(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_json(
        capsys,
        "--turn-radius",
        "150",
        "--sensor-radius",
        "100",
        "--uav-speed",
        "18",
        "--convoy-speed",
        "16",
    )
    assert out["gamma_star_rad"] is None
    assert out["min_uavs"] == 1


def test_uavs_flag_reports_predicted_coverage(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_json(capsys, "--turn-radius", "150", "--sensor-radius", "100", "--uavs", "3")
    assert out["uavs"] == 3
    assert out["predicted_coverage"] == pytest.approx(3 * math.asin(2 / 3) / math.pi)


def test_trivial_case(capsys: pytest.CaptureFixture[str]) -> None:
    out = run_json(capsys, "--turn-radius", "50", "--sensor-radius", "100")
    assert out["case"] == "trivial"
    assert out["min_uavs"] == 1
    assert out["coverage_per_uav"] == 1.0


def test_entry_mode_with_negative_values(capsys: pytest.CaptureFixture[str]) -> None:
    r = math.hypot(0.5, 0.8)
    out = run_json(
        capsys,
        "--turn-radius",
        str(1.5 * r),
        "--sensor-radius",
        str(r),
        "--entry",
        "-0.5",
        "-0.8",
        "1.57",
    )
    assert out["sequence"] in {"L", "R", "LR", "RL"}
    assert out["entry"][:2] == pytest.approx([-0.5, -0.8])
    assert len(out["exit"]) == 3
    assert out["time_inside_s"] > 0
    assert (out["switch"] is None) == (len(out["sequence"]) == 1)


def test_entry_mode_fig5(capsys: pytest.CaptureFixture[str]) -> None:
    y = -math.sqrt(1 - 0.3**2)
    out = run_json(
        capsys,
        "--turn-radius",
        "1.5",
        "--sensor-radius",
        "1",
        "--entry",
        "-0.3",
        str(y),
        str(math.pi / 2),
    )
    assert out["sequence"] == "LR"
    sx, sy, _ = out["switch"]
    ex, ey, _ = out["exit"]
    assert sx * ey - sy * ex == pytest.approx(0.0, abs=1e-9)


def test_human_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["plan", "--config", str(REPO / "configs" / "moving.toml")]) == 0
    text = capsys.readouterr().out
    assert "moving" in text and "minimum UAVs" in text and "gamma*" in text
    assert (
        main(
            [
                "plan",
                "--turn-radius",
                "1.5",
                "--sensor-radius",
                "1",
                "--entry",
                "-0.6",
                "-0.8",
                "1.5",
            ]
        )
        == 0
    )
    assert "sequence" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--turn-radius", "-1", "--sensor-radius", "1"], "--turn-radius = -1.0"),
        (["--turn-radius", "0", "--sensor-radius", "1"], "--turn-radius = 0.0"),
        (["--turn-radius", "1", "--sensor-radius", "nan"], "--sensor-radius = nan"),
        (
            [
                "--turn-radius",
                "150",
                "--sensor-radius",
                "100",
                "--uav-speed",
                "10",
                "--convoy-speed",
                "12",
            ],
            "--convoy-speed = 12.0",
        ),
        (
            ["--turn-radius", "150", "--sensor-radius", "100", "--convoy-speed", "-1"],
            "--convoy-speed = -1.0",
        ),
        (
            ["--turn-radius", "1.5", "--sensor-radius", "1", "--entry", "0.5", "0.5", "0"],
            "not on the convoy circle",
        ),
        (
            ["--turn-radius", "1.5", "--sensor-radius", "1", "--entry", "0.6", "0.8", "1.0"],
            "does not point into",
        ),
        (
            ["--turn-radius", "1.5", "--sensor-radius", "1", "--entry", "-0.6", "nan", "1.0"],
            "--entry Y = nan",
        ),
        (["--sensor-radius", "1"], "--turn-radius"),
        (["--turn-radius", "150", "--sensor-radius", "100", "--uavs", "0"], "--uavs = 0"),
        (["--config", "/nonexistent.toml"], "cannot be read"),
    ],
)
def test_bad_input_is_one_line_exit_2(
    capsys: pytest.CaptureFixture[str], argv: list[str], needle: str
) -> None:
    assert main(["plan", *argv]) == 2
    err = capsys.readouterr().err
    assert needle in err
    assert err.count("\n") == 1
    assert "Traceback" not in err


def test_console_script_exit_codes() -> None:
    """The installed entry point: usage errors are one line, status 2, no traceback."""
    proc = subprocess.run(
        [sys.executable, "-m", "convoy_mav", "plan", "--turn-radius", "abc"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1
    assert "invalid float value: 'abc'" in proc.stderr
    demo = str(REPO / "configs" / "demo.toml")
    ok = subprocess.run(
        [sys.executable, "-m", "convoy_mav", "plan", "--config", demo, "--json"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert json.loads(ok.stdout)["min_uavs"] == 5


@pytest.mark.parametrize(("source", "needle"), [("0", "= 0"), ("1", "not the vehicle's")])
def test_sign_setup_refuses_a_source_system_it_cannot_speak_as(
    capsys: pytest.CaptureFixture[str], source: str, needle: str
) -> None:
    """Our system id for the signing set-up: 1..255, and not the vehicle's own (checked
    before any link is opened or key read)."""
    argv = ["sign-setup", "--connection", "udpout:127.0.0.1:14550", "--sysid", "1"]
    argv += ["--signing-key-file", "/nonexistent.key", "--source-system", source]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--source-system" in err and needle in err and err.count("\n") == 1
