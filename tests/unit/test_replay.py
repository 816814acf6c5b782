"""``convoy-mav replay`` without flying: the scenario, the mock's track route, CLI errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from convoy_mav.cli import main
from convoy_mav.demo import Scenario, mock_mapping, replay_scenario
from convoy_mav.errors import ConfigError, PlanningError
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.planning import make_plan
from convoy_mav.tracks import GeoTrack, track_speeds
from sitl_mock.config import Lagged, config_from_mapping
from sitl_mock.ground import Track

START = GeoPoint(52.0, 4.3)
FRAME = LocalFrame(START)


def _straight(speed: float, duration: float = 300.0, heading_deg: float = 60.0) -> GeoTrack:
    """A straight drive from START, one fix every 5 s, on a clock starting at 1000 s."""
    h = math.radians(heading_deg)
    times = [5.0 * k for k in range(int(duration / 5.0) + 1)]
    points = [FRAME.to_geo(speed * t * math.cos(h), speed * t * math.sin(h)) for t in times]
    return GeoTrack(
        tuple(1000.0 + t for t in times),
        tuple(p.lat for p in points),
        tuple(p.lon for p in points),
        "drive.csv",
        "csv",
    )


def test_replay_scenario_plans_for_the_tracks_speed() -> None:
    scenario = replay_scenario(_straight(7.0))
    assert scenario.name == "replay"
    assert scenario.convoy_speed_mps == pytest.approx(7.0, rel=1e-4)
    assert scenario.heading_deg == pytest.approx(60.0, abs=0.01)
    assert scenario.track is not None and scenario.track.times[0] == 0.0
    assert make_plan(scenario.plan_request()).min_uavs == 4
    # The demo's aircraft and sensor are kept.
    assert (scenario.airspeed_mps, scenario.sensor_radius_m) == (18.0, 100.0)


def test_replay_scenario_refuses_a_convoy_as_fast_as_the_aircraft() -> None:
    with pytest.raises(
        PlanningError, match=r"drive\.csv: .*at 19\.0 m/s or faster 90 % .*airspeed of 18 m/s"
    ):
        replay_scenario(_straight(19.0))
    slow_aircraft = Scenario("replay", airspeed_mps=6.0)
    with pytest.raises(PlanningError, match="cannot keep up"):
        replay_scenario(_straight(7.0), slow_aircraft)


def test_a_convoy_that_speeds_past_the_aircraft_now_and_then_is_replayed() -> None:
    """A drive at 7 m/s with 100 s at 22 m/s (faster than the 18 m/s planes): planned for
    its 7 m/s, the fast stretch flown and alarmed, not refused."""
    t = np.arange(0.0, 1201.0)
    speed = np.where((t > 500.0) & (t <= 600.0), 22.0, 7.0)
    run = np.concatenate([[0.0], np.cumsum(speed[1:])])
    h = math.radians(60.0)
    points = [FRAME.to_geo(d * math.cos(h), d * math.sin(h)) for d in run]
    track = GeoTrack(
        tuple(t.tolist()), tuple(p.lat for p in points), tuple(p.lon for p in points), "d", "csv"
    )
    scenario = replay_scenario(track)
    assert scenario.convoy_speed_mps == pytest.approx(7.0, rel=1e-3)
    assert track_speeds(track).max_mps == pytest.approx(22.0, rel=1e-3)


def test_the_mock_drives_the_track_from_the_world_origin() -> None:
    scenario = replay_scenario(_straight(7.0))
    mapping = mock_mapping(scenario, 4, speedup=40.0, duration=300.0)
    # (at sea level: a rehearsal's --config gives the airfield's elevation)
    assert mapping["origin"] == pytest.approx([START.lat, START.lon, 0.0])
    assert mapping["ground"]["route"] == "track"
    cfg = config_from_mapping(mapping)
    assert (cfg.origin.lat, cfg.origin.lon) == pytest.approx((START.lat, START.lon))
    lead, second = (v for v in cfg.vehicles if v.kind == "ground")
    assert isinstance(lead.route, Track)
    assert isinstance(second.route, Lagged)
    assert second.route.lag == pytest.approx(20.0 / 7.0, rel=1e-3)
    h = math.radians(60.0)
    assert lead.route.position(100.0) == pytest.approx(
        (700.0 * math.cos(h), 700.0 * math.sin(h)), abs=0.01
    )
    assert (lead.home.lat, lead.home.lon) == pytest.approx((START.lat, START.lon))


@pytest.mark.parametrize(
    ("track", "key", "reason"),
    [
        ([], "ground.track", "needs"),
        ([[0, 47.0]], r"ground.track\[0\]", "expected"),
        ([[0, 47.0, 8.0], [0, 47.1, 8.0]], r"ground.track\[1\]", "does not increase"),
        ([[0, 47.0, 181.0]], r"ground.track\[0\]", "longitude"),
        ([[0, 47.0, float("nan")]], r"ground.track\[0\]", "finite"),
    ],
)
def test_mock_track_route_errors_name_the_row(track: list[object], key: str, reason: str) -> None:
    with pytest.raises(ConfigError, match=rf"{key} = .*{reason}"):
        config_from_mapping({"ground": {"count": 1, "route": "track", "track": track}})


# ------------------------------------------------------------------------------------ CLI


def _fails(argv: list[str], capsys: pytest.CaptureFixture[str], *expected: str) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.startswith("convoy-mav: error: ") and err.endswith("\n")
    assert err.count("\n") == 1, err
    assert "Traceback" not in err
    for text in expected:
        assert text in err, err
    return err


def test_cli_bad_csv_row(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("time,lat,lon\n0,52.0,4.3\n10,52.0,nan\n", encoding="utf-8")
    _fails(["replay", str(path)], capsys, f"{path}:3:", "finite")


def test_cli_gpx_without_times(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "route.gpx"
    path.write_text('<gpx>\n<rte><rtept lat="52" lon="4.3"/></rte></gpx>', encoding="utf-8")
    _fails(["replay", str(path)], capsys, f"{path}:2:", "rtept #1 has no <time>")


def test_cli_tlog_that_is_not_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "drive.tlog"
    path.write_bytes(b"\x00" * 64)
    _fails(["replay", str(path)], capsys, f"{path}: no MAVLink messages")


def test_cli_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "nowhere.gpx"
    _fails(["replay", str(path)], capsys, f"{path}: cannot read the track: No such file")


def test_cli_unknown_extension_and_format_override(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "drive.txt"
    path.write_text("0,52.0,4.3\n", encoding="utf-8")
    _fails(["replay", str(path)], capsys, f"{path}: cannot tell the track format")
    # Read as CSV it is one fix: a track of 0 s needs a duration.
    _fails(["replay", str(path), "--format", "csv"], capsys, "--duration", "spans 0 s")


def test_cli_sysid_checks(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "drive.csv"
    path.write_text("0,52.0,4.3\n10,52.0005,4.3\n", encoding="utf-8")
    _fails(["replay", str(path), "--sysid", "6"], capsys, "only apply to a tlog")
    _fails(["replay", str(path), "--sysid", "6", "0"], capsys, "--sysid = 0")


def test_cli_too_fast_track(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "fast.csv"
    north = 20.0 * 60.0  # 20 m/s for a minute
    end = FRAME.to_geo(north, 0.0)
    path.write_text(f"0,{START.lat},{START.lon}\n60,{end.lat},{end.lon}\n", encoding="utf-8")
    _fails(["replay", str(path)], capsys, f"{path}: the convoy drives at 20.0 m/s or faster 90 %")


def test_cli_bad_flight_options(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "drive.csv"
    path.write_text("0,52.0,4.3\n10,52.0005,4.3\n", encoding="utf-8")
    _fails(["replay", str(path), "--duration", "-5"], capsys, "--duration")
    _fails(["replay", str(path), "--speedup", "0"], capsys, "--speedup")
    _fails(["replay", str(path), "--uavs", "0"], capsys, "--uavs")
