"""Mission TOML: every error names the key and the value."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from convoy_mav.config import load_config, parse_config
from convoy_mav.errors import ConfigError

REPO = Path(__file__).resolve().parents[2]


def test_bundled_configs_load() -> None:
    demo = load_config(REPO / "configs" / "demo.toml")
    assert demo.sensor_radius_m == 100.0
    req = load_config(REPO / "configs" / "moving.toml").plan_request()
    assert req.convoy_speed == 6.0
    assert req.convoy_heading == pytest.approx(math.radians(45.0))  # compass 45 = planner 45


def test_compass_heading_converted_to_planner_frame() -> None:
    cfg = parse_config(
        {"mission": {"sensor_radius_m": 50}, "convoy": {"speed_mps": 3, "heading_deg": 90}}
    )
    assert cfg.plan_request().convoy_heading == pytest.approx(0.0)  # east


@pytest.mark.parametrize(
    ("doc", "key", "value"),
    [
        ({}, "mission.sensor_radius_m", None),
        ({"mission": {"sensor_radius_m": -5}}, "mission.sensor_radius_m", -5.0),
        ({"mission": {"sensor_radius_m": "big"}}, "mission.sensor_radius_m", "big"),
        ({"mission": {"sensor_radius_m": 10, "uavs": 0}}, "mission.uavs", 0),
        ({"mission": {"sensor_radius_m": 10, "uavz": 3}}, "mission.uavz", 3),
        (
            {"mission": {"sensor_radius_m": 10}, "aircraft": {"turn_radius_m": math.nan}},
            "aircraft.turn_radius_m",
            math.nan,
        ),
        (
            {"mission": {"sensor_radius_m": 10}, "convoy": {"speed_mps": 30}},
            "convoy.speed_mps",
            30.0,
        ),
        ({"mission": {"sensor_radius_m": 10}, "extra": {}}, "extra", {}),
        ({"mission": 3}, "mission", 3),
    ],
)
def test_errors_name_key_and_value(doc: dict[str, Any], key: str, value: object) -> None:
    with pytest.raises(ConfigError) as info:
        parse_config(doc)
    assert info.value.key == key
    if isinstance(value, float) and math.isnan(value):
        assert math.isnan(info.value.value)  # type: ignore[arg-type]
    else:
        assert info.value.value == value
    assert key in str(info.value)


def test_toml_syntax_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[mission\nsensor_radius_m = 1\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(bad)
