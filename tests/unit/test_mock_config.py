"""Mock config: TOML + flags -> MockConfig, and errors that name key and value."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from convoy_mav.errors import ConfigError
from convoy_mav.geo import LocalFrame
from sitl_mock.__main__ import build_config
from sitl_mock.autopilot import Personality
from sitl_mock.config import (
    DEFAULT_ORIGIN,
    Lagged,
    MockConfig,
    config_from_mapping,
    load_toml,
    merge_overrides,
    parse_geo,
    parse_udp_address,
)
from sitl_mock.ground import Polyline, Stationary, StraightLine

_CONFIGS = Path(__file__).resolve().parents[2] / "configs"


def test_defaults_one_px4_plane_at_the_origin() -> None:
    cfg = config_from_mapping({})
    assert len(cfg.vehicles) == 1
    v = cfg.vehicles[0]
    assert (v.sysid, v.kind, v.personality) == (1, "aircraft", Personality.PX4)
    assert v.airframe.frame == "plane"
    assert v.home == LocalFrame(DEFAULT_ORIGIN).to_geo(0.0, 0.0, 0.0)
    assert cfg.port_of(1) == 14540
    assert cfg.gcs is None
    assert cfg.truth_path is None


def test_aircraft_homes_form_a_row_and_ports_follow_sysids() -> None:
    cfg = MockConfig.simple(3, base_port=15000)
    world = LocalFrame(cfg.origin)
    easts = [world.to_ned(v.home)[1] for v in cfg.vehicles]
    assert easts == pytest.approx([0.0, 10.0, 20.0], abs=1e-6)
    assert [cfg.port_of(v.sysid) for v in cfg.vehicles] == [15000, 15001, 15002]
    assert MockConfig.simple(2, base_port=0).port_of(2) == 0


def test_per_vehicle_entries_override_defaults_and_cli_overrides_both() -> None:
    data: dict[str, Any] = {
        "aircraft": {
            "count": 2,
            "airspeed": 20.0,
            "vehicle": [
                {"sysid": 2, "airspeed": 15.0, "personality": "ardupilot", "home_ned": [5, 6]}
            ],
        }
    }
    cfg = config_from_mapping(data)
    assert [v.airframe.airspeed for v in cfg.vehicles] == [20.0, 15.0]
    assert cfg.vehicles[1].personality == Personality.ARDUPILOT
    n, e, _ = LocalFrame(cfg.origin).to_ned(cfg.vehicles[1].home)
    assert (n, e) == pytest.approx((5.0, 6.0), abs=1e-6)
    merged = merge_overrides(data, {"aircraft": {"airspeed": 25.0}, "speedup": 4})
    cfg2 = config_from_mapping(merged)
    assert [v.airframe.airspeed for v in cfg2.vehicles] == [25.0, 25.0]
    assert cfg2.vehicles[1].personality == Personality.ARDUPILOT
    assert cfg2.speedup == 4.0
    assert data["aircraft"]["vehicle"][0]["airspeed"] == 15.0  # input untouched


def test_ground_vehicles_follow_the_aircraft_sysids_and_start_on_their_route() -> None:
    cfg = MockConfig.simple(
        2, ground=3, ground_speed=5.0, ground_heading=90.0, ground_start=[100, 0], base_port=0
    )
    ground = [v for v in cfg.vehicles if v.kind == "ground"]
    assert [v.sysid for v in ground] == [3, 4, 5]
    world = LocalFrame(cfg.origin)
    lead = ground[0].route
    assert isinstance(lead, StraightLine)
    assert lead.heading == pytest.approx(math.pi / 2)
    for v in ground:
        assert v.route is not None
        n, e, _ = world.to_ned(v.home)
        assert (n, e) == pytest.approx(v.route.position(0.0), abs=1e-6)
    second = ground[1].route
    assert isinstance(second, Lagged)
    assert second.lag == pytest.approx(20.0 / 5.0)
    assert second.position(10.0) == pytest.approx(lead.position(6.0))


def test_ground_route_kinds() -> None:
    still = MockConfig.simple(0, ground=2, base_port=0).vehicles
    assert isinstance(still[0].route, Stationary)
    assert isinstance(still[1].route, Stationary)
    assert still[1].route.position(0.0) == pytest.approx((-20.0, 0.0))
    poly = config_from_mapping(
        {"ground": {"count": 1, "route": "polyline", "points": [[0, 0], [100, 0]], "speed": 4}}
    )
    assert isinstance(poly.vehicles[-1].route, Polyline)


def test_csv_track_route_relative_to_the_config_file(tmp_path: Path) -> None:
    world = LocalFrame(DEFAULT_ORIGIN)
    p0, p1 = world.to_geo(0.0, 0.0), world.to_geo(100.0, 0.0)
    (tmp_path / "track.csv").write_text(
        f"time,lat,lon\n0,{p0.lat},{p0.lon}\n20,{p1.lat},{p1.lon}\n", encoding="utf-8"
    )
    cfg = config_from_mapping(
        {"ground": {"count": 2, "csv": "track.csv"}, "aircraft": {"count": 0}},
        base_dir=str(tmp_path),
    )
    lead, second = (v.route for v in cfg.vehicles)
    assert lead is not None and second is not None
    assert lead.position(10.0) == pytest.approx((50.0, 0.0), abs=0.01)
    assert isinstance(second, Lagged)
    assert second.lag == pytest.approx(20.0 / 5.0)  # 20 m spacing at the track's 5 m/s


def test_faults_from_strings_and_tables() -> None:
    cfg = config_from_mapping(
        {
            "faults": {
                "loss_from_vehicle": 0.25,
                "latency": 0.2,
                "kill": [{"sysid": 1, "at": 30.0}],
                "reboot": ["1@12.5"],
                "seed": 3,
            }
        }
    )
    f = cfg.faults
    assert f.loss_from_vehicle == 0.25
    assert (f.latency_to_vehicle, f.latency_from_vehicle) == (0.2, 0.2)
    assert [(k.sysid, k.at) for k in f.kills] == [(1, 30.0)]
    assert [(r.sysid, r.at) for r in f.reboots] == [(1, 12.5)]
    assert f.seed == 3


@pytest.mark.parametrize(
    ("data", "key", "value"),
    [
        ({"speedup": 0}, "speedup", "0"),
        ({"speedup": "fast"}, "speedup", "'fast'"),
        ({"spedup": 2}, "spedup", "2"),
        ({"aircraft": {"count": -1}}, "aircraft.count", "-1"),
        ({"aircraft": {"personality": "inav"}}, "aircraft.personality", "'inav'"),
        ({"aircraft": {"frame": "heli"}}, "aircraft.frame", "'heli'"),
        ({"aircraft": {"vehicle": [{"sysid": 3}]}}, "aircraft.vehicle[0].sysid", "3"),
        ({"aircraft": {"vehicle": [{"turn_radius": -5}]}}, "aircraft.vehicle[0].turn_radius", "-5"),
        ({"origin": [95, 0]}, "origin", "[95, 0]"),
        ({"gcs": "udp:localhost"}, "gcs", "'udp:localhost'"),
        ({"ground": {"count": 1, "route": "spiral"}}, "ground.route", "'spiral'"),
        ({"ground": {"count": 1, "route": "polyline"}}, "ground.points", "None"),
        ({"faults": {"loss_to_vehicle": 2}}, "faults.loss_to_vehicle", "2"),
        ({"faults": {"kill": ["1-30"]}}, "faults.kill[0]", "'1-30'"),
        ({"base_port": 70000}, "base_port", "70000"),
    ],
)
def test_errors_name_the_key_and_the_bad_value(data: dict[str, Any], key: str, value: str) -> None:
    with pytest.raises(ConfigError) as info:
        config_from_mapping(data)
    message = str(info.value)
    assert message.startswith(f"{key} = {value}"), message
    assert "\n" not in message


def test_load_toml_errors_name_the_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("speedup = = 3\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"bad\.toml.*invalid TOML"):
        load_toml(bad)
    with pytest.raises(ConfigError, match=r"missing\.toml"):
        load_toml(tmp_path / "missing.toml")


def test_parsers() -> None:
    assert parse_geo("origin", "47.1, 8.2, 400") == parse_geo("origin", [47.1, 8.2, 400.0])
    assert parse_geo("origin", "47.1,8.2").alt == 0.0
    assert parse_udp_address("gcs", "udp:127.0.0.1:14550") == ("127.0.0.1", 14550)
    assert parse_udp_address("gcs", "udpout://10.0.0.2:1") == ("10.0.0.2", 1)
    assert parse_udp_address("gcs", "localhost:9") == ("localhost", 9)


def test_cli_flags_override_the_file(tmp_path: Path) -> None:
    cfg = build_config(
        [
            "--config",
            str(_CONFIGS / "mock_px4.toml"),
            "--aircraft",
            "2",
            "--speedup",
            "30",
            "--turn-radius",
            "60",
            "--kill",
            "2@40",
            "--mode",
            "1:AUTO.RTL@50",
            "--stall",
            "9@60",
            "--truth",
            str(tmp_path / "t.csv"),
            "--origin",
            "10,20,30",
        ]
    )
    assert cfg.speedup == 30.0
    assert sum(v.kind == "aircraft" for v in cfg.vehicles) == 2
    assert all(v.airframe.min_turn_radius == 60.0 for v in cfg.vehicles if v.kind == "aircraft")
    assert [(k.sysid, k.at) for k in cfg.faults.kills] == [(2, 40.0)]
    assert [(m.sysid, m.mode, m.at) for m in cfg.faults.modes] == [(1, "AUTO.RTL", 50.0)]
    assert [(f.sysid, f.at) for f in cfg.faults.stalls] == [(9, 60.0)]  # (warned of when due)
    assert cfg.truth_path == str(tmp_path / "t.csv")
    assert (cfg.origin.lat, cfg.origin.lon, cfg.origin.alt) == (10.0, 20.0, 30.0)


@pytest.mark.parametrize("name", ["mock_px4.toml", "mock_ardupilot.toml"])
def test_example_configs_load(name: str) -> None:
    cfg = build_config(["--config", str(_CONFIGS / name)])
    assert cfg.vehicles
    assert any(v.kind == "ground" for v in cfg.vehicles)
