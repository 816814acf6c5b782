"""Real roads end to end: generated roads driven by the mock's rovers, the service, the truth.

Over real UDP against ``sitl_mock`` at 40x, both personalities; scored from the
mock's ground truth. The road planner flies the road's count of UAVs (the
stationary minimum + 1); what it predicts must be what the truth measures.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from convoy_mav.cli import main

pytestmark = pytest.mark.integration


@pytest.mark.parametrize(
    ("road", "personality", "known"),
    [("bends", "px4", True), ("stop-and-go", "ardupilot", False)],
)
def test_a_road_is_protected_as_predicted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], road: str, personality: str, known: bool
) -> None:
    report_path = tmp_path / "r.json"
    argv = ["replay", "--road", road, "--duration", "500", "--speedup", "40"]
    argv += ["--personality", personality, "--report", str(report_path), "--quiet"]
    assert main(argv + (["--route-known"] if known else [])) == 0
    out = capsys.readouterr().out
    assert "ground truth" in out
    report = json.loads(report_path.read_text())
    assert report["uav_count"] == 6
    planner = report["planner"]
    assert planner["name"] == "road" and planner["route_known"] is known
    if known:
        assert planner["route_length_m"] > 5000.0
        assert planner["route_max_curvature_per_m"] == pytest.approx(1 / 150, rel=0.2)
    for margins in planner["flyability"].values():  # what was commanded was flyable
        assert margins["min_turn_radius_m"] >= 150.0 - 0.1
        assert margins["speed_range_mps"][0] >= 0.85 * 18.0 - 0.01
        assert margins["speed_range_mps"][1] <= 1.15 * 18.0 + 0.01
    start = report["protect_start_s"]
    assert start is not None and start < 240.0
    truth = report["truth_coverage_fraction"]
    # (the first 260-380 s of protection; the README's table has the whole roads)
    assert truth >= 0.90
    assert report["predicted_coverage"] == pytest.approx(truth, abs=0.015)
    assert report["coverage_fraction"] == pytest.approx(truth, abs=0.015)
