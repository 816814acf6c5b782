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
    assert len(load_config(REPO / "configs" / "px4_sitl.toml").uav_list) == 3
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


SERVICE_DOC: dict[str, Any] = {
    "mission": {
        "sensor_radius_m": 100.0,
        "origin": {"lat": 47.0, "lon": 8.0, "alt": 400.0},
        "setpoint_rate_hz": 25.0,
    },
    "aircraft": {"airspeed_mps": 18.0, "turn_radius_m": 150.0},
    "uav": [
        {"connection": "udpin:0.0.0.0:14540", "sysid": 1},
        {"connection": "udpout:127.0.0.1:14541", "sysid": 2, "turn_radius_m": 160.0},
        {"connection": "tcp:127.0.0.1:5760", "sysid": 3, "airspeed_mps": 16.0},
        {"connection": "udp://:14543", "sysid": 4},
    ],
    "convoy": {
        "source": "mavlink",
        "vehicle": [{"connection": "udpout:127.0.0.1:14550", "sysid": 10}],
    },
    "mqtt": {"host": "localhost", "prefix": "fleet/convoy/"},
    "record": {"tlog": "out.tlog", "mission": "out.inputs"},
}


def test_service_sections() -> None:
    cfg = parse_config(SERVICE_DOC)
    assert [u.sysid for u in cfg.uav_list] == [1, 2, 3, 4]
    assert cfg.planned_uavs == 4
    assert cfg.origin.lat == 47.0 and cfg.origin.alt == 400.0
    assert cfg.setpoint_rate_hz == 25.0
    # Mixed airframes: the plan assumes what every UAV can fly.
    assert cfg.plan_aircraft.turn_radius_m == 160.0
    assert cfg.plan_aircraft.airspeed_mps == 16.0
    assert cfg.convoy.vehicles[0].sysid == 10
    assert cfg.mqtt is not None and cfg.mqtt.prefix == "fleet/convoy" and cfg.mqtt.port == 1883
    assert cfg.tlog == "out.tlog" and cfg.mission_recording == "out.inputs"
    assert cfg.sim_speedup_floor is None  # (a simulator's speedup is left alone)
    assert parse_config(_with("mission.sim_speedup_floor", 5)).sim_speedup_floor == 5.0
    # Our MAVLink ids: a ground station's by default, as QGroundControl's; another system
    # beside an operator's GCS on a shared link, or where ArduPilot hears only its GCS.
    assert (cfg.source_system, cfg.source_component) == (255, 190)
    ours = parse_config(_with("mission.source_system", 254))
    assert (ours.source_system, ours.source_component) == (254, 190)


def _with(path: str, value: Any) -> dict[str, Any]:
    import copy

    doc = copy.deepcopy(SERVICE_DOC)
    node: Any = doc
    parts = path.split(".")
    for part in parts[:-1]:
        node = node[int(part)] if part.isdigit() else node[part]
    node[parts[-1]] = value
    return doc


@pytest.mark.parametrize(
    ("doc", "key", "needle"),
    [
        (_with("uav.1.sysid", 1), "uav[1].sysid", "already used by uav[0]"),
        (_with("uav.0.connection", "serial:/dev/ttyUSB0"), "uav[0].connection", "serial"),
        (_with("uav.0.connection", "foo"), "uav[0].connection", "unknown scheme"),
        (_with("uav.0.connection", "udpin:0.0.0.0:99999"), "uav[0].connection", "port"),
        (_with("uav.2.sysid", 0), "uav[2].sysid", "1..254"),
        (_with("uav.0.speed", 3), "uav[0].speed", "unknown key"),
        (_with("mission.origin", {"lat": 95.0, "lon": 0.0}), "mission.origin.lat", "-90..90"),
        (_with("mqtt.prefix", "a/#"), "mqtt.prefix", "wildcards"),
        (_with("mqtt.port", 0), "mqtt.port", "1..65535"),
        (_with("convoy.vehicle", []), "convoy.vehicle", "needs a"),
        (_with("convoy.source", "radar"), "convoy.source", "must be"),
        (_with("convoy.vehicle.0.sysid", 1), "uav[0].sysid", "convoy vehicle"),
        (_with("uav", {"sysid": 1}), "uav", "array of tables"),
        (_with("mission.sim_speedup_floor", 0.0), "mission.sim_speedup_floor", ">= 0.01"),
        (_with("mission.sim_speedup_floor", "fast"), "mission.sim_speedup_floor", "a number"),
        (_with("record.mission", ""), "record.mission", "a file path"),
        (_with("mission.source_system", 0), "mission.source_system", "1..255"),
        (_with("mission.source_system", 2), "mission.source_system", "also a uav's sysid"),
        (_with("mission.source_system", 10), "mission.source_system", "convoy.vehicle's"),
        (_with("mission.source_component", 256), "mission.source_component", "1..255"),
        (_with("mission.source_component", 1.5), "mission.source_component", "whole"),
    ],
)
def test_service_errors_name_the_key(doc: dict[str, Any], key: str, needle: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse_config(doc)
    assert info.value.key == key
    assert needle in str(info.value)


def test_the_run_config_for_the_mock_matches_the_mocks_endpoints() -> None:
    """configs/mock_run.toml flies configs/mock_px4.toml's vehicles, as the README says."""
    from sitl_mock.config import config_from_mapping, load_toml

    root = Path(__file__).resolve().parents[2] / "configs"
    mock = config_from_mapping(load_toml(root / "mock_px4.toml"), str(root))
    cfg = load_config(root / "mock_run.toml")
    ports = {v.sysid: mock.port_of(v.sysid) for v in mock.vehicles}
    kinds = {v.sysid: v.kind for v in mock.vehicles}
    for uav in cfg.uav_list:
        assert kinds[uav.sysid] == "aircraft"
        assert uav.connection == f"udpout:127.0.0.1:{ports[uav.sysid]}"
    for ground in cfg.convoy.vehicles:
        assert kinds[ground.sysid] == "ground"
        assert ground.connection == f"udpout:127.0.0.1:{ports[ground.sysid]}"
    assert {u.sysid for u in cfg.uav_list} == {s for s, k in kinds.items() if k == "aircraft"}


def test_new_mission_keys_are_validated() -> None:
    base = {"mission": {"sensor_radius_m": 100.0}}
    cfg = parse_config(base)
    assert (cfg.end, cfg.altitude_band_m) == ("loiter", 15.0)
    cfg = parse_config({"mission": {"sensor_radius_m": 100.0, "end": "rtl"}})
    assert cfg.end == "rtl"
    with pytest.raises(ConfigError, match=r"mission.end = 'home': must be 'loiter', 'rtl' or"):
        parse_config({"mission": {"sensor_radius_m": 100.0, "end": "home"}})
    with pytest.raises(ConfigError, match="altitude_band_m"):
        parse_config({"mission": {"sensor_radius_m": 100.0, "altitude_band_m": -1.0}})


def test_a_mission_config_rehearses_its_own_aircraft() -> None:
    """demo/replay --config: the plan and the mock's airframes come from the config."""
    from dataclasses import replace

    from convoy_mav.demo import (
        SCENARIOS,
        mock_mapping,
        rehearsal,
        rehearsed_config,
        replay_scenario,
    )
    from convoy_mav.tracks import GeoTrack

    root = Path(__file__).resolve().parents[2] / "configs"
    mission = load_config(root / "rehearse_fast_planes.toml")
    scenario = rehearsal(SCENARIOS["moving"], mission)
    assert (scenario.airspeed_mps, scenario.turn_radius_m) == (28.0, 200.0)
    assert (scenario.sensor_radius_m, scenario.altitude_m) == (120.0, 120.0)
    assert scenario.convoy_speed_mps == SCENARIOS["moving"].convoy_speed_mps  # the road's
    mock = mock_mapping(scenario, 3, speedup=20.0, duration=60.0)
    assert mock["aircraft"]["airspeed"] == 28.0
    assert mock["aircraft"]["turn_radius"] == pytest.approx(200.0 * scenario.turn_margin)
    # the mock's world at the mission's origin: its elevation sets the air's density,
    # and so how wide a mock ArduPlane flies its loiters; a replayed track keeps its own
    # first fix, at that elevation
    o = mission.origin
    assert mock["origin"] == [o.lat, o.lon, o.alt]
    track = GeoTrack((0.0, 10.0), (-35.0, -35.001), (149.0, 149.0))
    replayed = mock_mapping(replay_scenario(track, scenario), 3, speedup=20.0, duration=60.0)
    assert replayed["origin"] == [-35.0, 149.0, o.alt]
    base = parse_config({"mission": {"sensor_radius_m": 50.0}})
    cfg = rehearsed_config(replace(base, end="rtl"), replace(mission, end="land"))
    assert (cfg.end, cfg.altitude_band_m, cfg.sensor_radius_m) == ("land", 15.0, 50.0)


def test_planner_and_route_keys(tmp_path: Path) -> None:
    cfg = parse_config({"mission": {"sensor_radius_m": 100.0}})
    assert (cfg.planner, cfg.convoy.route_file) == ("auto", None)
    cfg = parse_config({"mission": {"sensor_radius_m": 100.0, "planner": "road"}})
    assert cfg.planner == "road"
    with pytest.raises(ConfigError, match=r"mission.planner = 'fast': must be 'auto', 'road'"):
        parse_config({"mission": {"sensor_radius_m": 100.0, "planner": "fast"}})
    with pytest.raises(ConfigError, match=r"convoy\.route"):
        parse_config({"mission": {"sensor_radius_m": 100.0}, "convoy": {"route": 3}})
    # A route file is found beside the config that names it.
    (tmp_path / "sub").mkdir()
    path = tmp_path / "sub" / "m.toml"
    path.write_text('[mission]\nsensor_radius_m = 100.0\n[convoy]\nroute = "r.gpx"\n')
    assert load_config(path).convoy.route_file == str(tmp_path / "sub" / "r.gpx")


def test_the_route_may_be_the_lead_ground_vehicles_mission(tmp_path: Path) -> None:
    convoy = {
        "source": "mavlink",
        "route": "mission",
        "vehicle": [{"connection": "udpin:127.0.0.1:14600", "sysid": 201}],
    }
    cfg = parse_config({"mission": {"sensor_radius_m": 100.0}, "convoy": convoy})
    assert (cfg.convoy.route_from_mission, cfg.convoy.route_file) == (True, None)
    path = tmp_path / "m.toml"  # (not a file beside the config)
    path.write_text(
        '[mission]\nsensor_radius_m = 100.0\n[convoy]\nsource = "mavlink"\nroute = "mission"\n'
        '[[convoy.vehicle]]\nconnection = "udpin:127.0.0.1:14600"\nsysid = 201\n'
    )
    assert load_config(path).convoy.route_file is None
    with pytest.raises(ConfigError, match=r'convoy.route = .mission.: .*needs source = "mavlink"'):
        parse_config({"mission": {"sensor_radius_m": 100.0}, "convoy": {"route": "mission"}})


def test_the_part_distance_defaults_to_a_sensor_diameter_and_may_be_set_or_off() -> None:
    mission = {"sensor_radius_m": 120.0}
    assert parse_config({"mission": mission}).convoy_part_m == 240.0
    for part in (350, 0):
        cfg = parse_config({"mission": mission, "convoy": {"part_m": part}})
        assert cfg.convoy_part_m == float(part)
    for bad in (-1.0, "far", 1e9):
        with pytest.raises(ConfigError, match=r"convoy\.part_m"):
            parse_config({"mission": mission, "convoy": {"part_m": bad}})


def test_a_bad_route_file_is_a_config_error(tmp_path: Path) -> None:
    from convoy_mav.app import ConvoyService

    bad = tmp_path / "r.csv"
    bad.write_text("time,lat,lon\n0,91.0,8.0\n")
    doc = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}, "convoy": {"route": str(bad)}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    with pytest.raises(ConfigError, match=r"convoy.route .*cannot be used as a route"):
        ConvoyService(parse_config(doc))
    good = tmp_path / "g.csv"
    good.write_text("lat,lon\n47.397742,8.545594\n47.398742,8.545594\n47.398742,8.547594\n")
    doc["convoy"] = {"route": str(good)}
    service = ConvoyService(parse_config(doc))
    assert service.route is not None and service.route.length == pytest.approx(262.0, rel=0.1)
