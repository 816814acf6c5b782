"""``convoy-mav replay`` end to end: a recorded GPX drive, the mock, the service, the truth.

The mock's ground vehicles drive the track; the service is not told it and finds
the convoy from their GLOBAL_POSITION_INT, as against real rovers. The tlog the
run records is then read back as a track: it must reproduce the mock's route.
"""

from __future__ import annotations

import json
import math
import statistics
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

from convoy_mav.cli import main
from convoy_mav.demo import mock_mapping, replay_scenario
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.tracks import load_track, parse_tlog_track, track_speeds
from sitl_mock.config import config_from_mapping
from tests.hostspeed import host_speedup

pytestmark = pytest.mark.integration

START = GeoPoint(52.0, 4.3)  # far from the mock's default origin: the origin must follow
SPEED = 8.0
HEADING_DEG = 60.0
DURATION = 360.0
SPEEDUP = host_speedup(25.0)


def _write_gpx(path: Path) -> None:
    frame = LocalFrame(START)
    h = math.radians(HEADING_DEG)
    t0 = datetime(2024, 5, 1, 12, 0, tzinfo=UTC)
    points = []
    for k in range(int(DURATION / 5.0) + 1):
        t = 5.0 * k
        p = frame.to_geo(SPEED * t * math.cos(h), SPEED * t * math.sin(h))
        when = (t0 + timedelta(seconds=t)).strftime("%Y-%m-%dT%H:%M:%SZ")
        points.append(f'<trkpt lat="{p.lat:.8f}" lon="{p.lon:.8f}"><time>{when}</time></trkpt>')
    path.write_text(
        '<?xml version="1.0"?>\n<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">'
        "<trk><trkseg>\n" + "\n".join(points) + "\n</trkseg></trk></gpx>\n",
        encoding="utf-8",
    )


def test_replay_gpx_end_to_end_and_the_tlog_round_trip(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    gpx, report_path, tlog = tmp_path / "drive.gpx", tmp_path / "r.json", tmp_path / "r.tlog"
    _write_gpx(gpx)
    argv = ["replay", str(gpx), "--speedup", str(SPEEDUP), "--report", str(report_path)]
    argv.append("--fixed-speedup")  # (held: a re-plan's lag would halve it on a slow host)
    assert main([*argv, "--tlog", str(tlog), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "ground truth" in out and f"report written to {report_path}" in out

    report = json.loads(report_path.read_text())
    assert report["scenario"] == "replay"
    assert report["track"] == str(gpx)
    assert report["track_format"] == "gpx"
    assert report["track_duration_s"] == pytest.approx(DURATION)
    assert report["track_planning_speed_mps"] == pytest.approx(SPEED, rel=1e-3)
    # a road with no route: the stationary minimum + 2 (the road planner, ``road_fleet``)
    assert report["uav_count"] == 7
    # The service's own estimate: the convoy's speed while it drove, and at the end
    # (which may fall a moment after the track's last fix, where the convoy stops).
    assert report["planner"]["convoy_speed_range_mps"][1] == pytest.approx(SPEED, rel=0.05)
    assert 0.75 * SPEED <= report["convoy_speed_mps"] <= 1.05 * SPEED
    assert report["end_s"] == pytest.approx(DURATION, abs=5.0)  # default: the track's length
    # Protection declared within the 240 s of the convoy's first fix that a road allows
    # (138-140 s on a quiet host; 193 s once on a CI host running 1.5 times slower).
    start = report["protect_start_s"]
    assert start is not None and start <= 240.0 and report["end_s"] - start > 100.0
    assert report["truth_coverage_fraction"] >= 0.99
    assert report["coverage_fraction"] == pytest.approx(report["truth_coverage_fraction"], abs=0.01)

    # Round trip: the recorded ground vehicles, read back as a track, are the mock's route.
    mock = config_from_mapping(
        mock_mapping(replay_scenario(load_track(gpx)), 4, speedup=SPEEDUP, duration=DURATION)
    )
    routes = [v.route for v in mock.vehicles if v.kind == "ground" and v.route is not None]
    assert len(routes) == 2
    replayed = parse_tlog_track(tlog.read_bytes(), str(tlog))
    assert replayed.duration > DURATION - 10.0
    norths, easts = replayed.in_frame(LocalFrame(mock.origin))
    errors = []
    for t, north, east in zip(replayed.times, norths, easts, strict=True):
        expected = [r.position(t) for r in routes]
        centroid = (
            statistics.fmean(p[0] for p in expected),
            statistics.fmean(p[1] for p in expected),
        )
        errors.append((t, math.dist((north, east), centroid)))
    # (the follower drives its leader's path a gap behind, not its road a time behind:
    # it sets off from a stand, accelerating, and has caught up within a minute)
    settled = max(e for t, e in errors if t > 60.0)
    assert settled < 3.0 and max(e for _, e in errors) < 15.0, f"worst {settled:.2f} m"
    assert track_speeds(load_track(tlog)).planning_mps == pytest.approx(SPEED, rel=0.02)


@pytest.mark.parametrize(
    ("fast_m", "said"),
    [
        (1312.0, "of the airspeed, faster than the UAVs fly (20.7 m/s at most)"),
        (730.0, "0.68 of the airspeed: a stop from faster than 0.5 of it"),
    ],
)
def test_a_track_faster_than_the_aircraft_now_and_then_is_flown_with_a_note(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], fast_m: float, said: str
) -> None:
    """A minute at 21.9 or 12.2 m/s, then one at 7 m/s (planned for: slower than the
    18 m/s planes 90 % of the time): flown, and said beforehand."""
    frame = LocalFrame(START)
    rows = [(0.0, 0.0), (60.0, fast_m), (120.0, fast_m + 420.0)]
    path = tmp_path / "fast.csv"
    lines = [f"{t},{p.lat:.8f},{p.lon:.8f}" for t, d in rows for p in [frame.to_geo(d, 0.0)]]
    path.write_text("time,lat,lon\n" + "\n".join(lines) + "\n", encoding="utf-8")
    report = tmp_path / "r.json"
    argv = ["replay", str(path), "--duration", "2", "--speedup", "10", "--report", str(report)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert said in out, out
    assert json.loads(report.read_text())["track_planning_speed_mps"] < 18.0
