"""MQTT topics and payloads: pure builders, encoding, and validation of operator input."""

from __future__ import annotations

import contextlib
import json
import math
import re
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.coverage import CoverageSample, CoverageStats
from convoy_mav.errors import ConfigError
from convoy_mav.publish import topics
from convoy_mav.publish.topics import BadPayload
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.types import Telemetry, VehicleStatus

WALL = 1_714_564_800.25  # 2024-05-01T12:00:00.250Z


def roundtrip(payload: dict[str, Any]) -> Any:
    """What a subscriber decodes: strict JSON (no NaN tokens allowed)."""

    def reject(token: str) -> None:
        raise AssertionError(f"non-JSON constant {token} on the wire")

    return json.loads(topics.encode(payload), parse_constant=reject)


def test_topic_names() -> None:
    assert topics.topic("convoy", topics.STATUS) == "convoy/status"
    assert topics.topic("a/b", topics.vehicle_topic(7)) == "a/b/vehicle/7"
    assert topics.topic("convoy", topics.CONVOY_POSITION) == "convoy/convoy/position"
    assert topics.topic("convoy", topics.COMMAND) == "convoy/command"
    assert (topics.COVERAGE, topics.ALARM) == ("coverage", "alarm")


@pytest.mark.parametrize("bad", ["", "convoy/#", "a/+/b", "/convoy", "convoy/", "a//b", "x\0"])
def test_bad_prefix_names_key_and_value(bad: str) -> None:
    with pytest.raises(ConfigError) as info:
        topics.validate_prefix(bad)
    assert info.value.key == "mqtt.prefix"
    assert info.value.value == bad


@pytest.mark.parametrize("bad", ["", "status/#", "vehicle/+", "/status", "status/"])
def test_bad_subtopic_rejected(bad: str) -> None:
    with pytest.raises(ValueError, match="subtopic"):
        topics.validate_subtopic(bad)


def test_iso_timestamp_utc_milliseconds() -> None:
    assert topics.iso_timestamp(WALL) == "2024-05-01T12:00:00.250Z"
    assert topics.iso_timestamp(0.0) == "1970-01-01T00:00:00.000Z"


def test_encode_replaces_non_finite_with_null() -> None:
    data = topics.encode({"a": math.nan, "b": [1.5, math.inf], "c": {"d": -math.inf}, "e": 2})
    assert json.loads(data) == {"a": None, "b": [1.5, None], "c": {"d": None}, "e": 2}
    assert b" " not in topics.encode({"a": 1, "b": [1, 2]})  # compact


def test_encode_rejects_unserialisable() -> None:
    with pytest.raises(TypeError):
        topics.encode({"a": object()})


def test_status_payload_counts_states() -> None:
    states = {1: VehicleStatus.FLYING, 2: VehicleStatus.FLYING, 3: VehicleStatus.LOST}
    p = roundtrip(
        topics.status_payload(
            t=123.4567,
            wall=WALL,
            phase="protecting",
            uptime_s=60.0,
            vehicles=states,
            alarms=["uav_lost"],
        )
    )
    assert p["t"] == 123.457 and p["ts"] == "2024-05-01T12:00:00.250Z"
    assert p["phase"] == "protecting" and p["paused"] is False and p["uptime_s"] == 60.0
    assert p["uavs"]["total"] == 3 and p["uavs"]["flying"] == 2 and p["uavs"]["lost"] == 1
    assert p["uavs"]["connecting"] == 0 and set(p["uavs"]) == {"total"} | {
        s.value for s in VehicleStatus
    }
    assert p["alarms"] == ["uav_lost"]


def test_status_payload_before_mission_clock() -> None:
    p = roundtrip(
        topics.status_payload(t=None, wall=WALL, phase="starting", uptime_s=0.1, vehicles={})
    )
    assert p["t"] is None and p["uavs"]["total"] == 0 and p["alarms"] == []


def test_vehicle_payload_with_telemetry() -> None:
    tel = Telemetry(
        3, 10.0, 100.123, -20.5, -80.0, 12.0, 5.0, 0.0, 0.5, 47.3977421, 8.5455938, 568.0
    )
    p = roundtrip(
        topics.vehicle_payload(
            sysid=3,
            t=10.2,
            wall=WALL,
            state=VehicleStatus.FLYING,
            telemetry=tel,
            mode="OFFBOARD",
            firmware="px4",
            phase="protect",
            tracking_error_m=math.nan,
            statustext="ready",
        )
    )
    assert p["sysid"] == 3 and p["state"] == "flying" and p["mode"] == "OFFBOARD"
    assert p["firmware"] == "px4" and p["phase"] == "protect" and p["statustext"] == "ready"
    assert p["position"] == {
        "lat": 47.3977421,
        "lon": 8.5455938,
        "alt": 568.0,
        "north": 100.12,
        "east": -20.5,
        "down": -80.0,
    }
    assert p["velocity"] == {"vn": 12.0, "ve": 5.0, "vd": 0.0}
    assert p["yaw"] == 0.5 and p["telemetry_t"] == 10.0
    assert p["tracking_error_m"] is None  # NaN -> null, never a NaN token


def test_vehicle_payload_without_telemetry() -> None:
    p = roundtrip(topics.vehicle_payload(sysid=2, t=None, wall=WALL, state="connecting"))
    assert p["state"] == "connecting"
    assert p["position"] is None and p["velocity"] is None and p["yaw"] is None
    assert p["mode"] is None and p["tracking_error_m"] is None


def test_coverage_payload() -> None:
    stats = CoverageStats(100.0, 99.5, 0.5, 0.0, 1, {1: 60.0, 2: 50.0}, 0.0)
    sample = CoverageSample(140.0, True, (1, 2), 12.345)
    p = roundtrip(
        topics.coverage_payload(
            t=140.0, wall=WALL, stats=stats, sample=sample, predicted=1.0, protect_start_s=40.0
        )
    )
    assert p["covered"] is True and p["covering"] == [1, 2] and p["nearest_m"] == 12.35
    assert p["fraction"] == 0.995 and p["elapsed_s"] == 100.0 and p["covered_s"] == 99.5
    assert p["longest_gap_s"] == 0.5 and p["current_gap_s"] == 0.0 and p["gaps"] == 1
    assert p["predicted"] == 1.0 and p["protect_start_s"] == 40.0


def test_coverage_payload_before_protect_and_no_uav() -> None:
    sample = CoverageSample(3.0, False, (), math.inf)
    p = roundtrip(topics.coverage_payload(t=3.0, wall=WALL, stats=None, sample=sample))
    assert p["covered"] is False and p["nearest_m"] is None and p["fraction"] is None
    assert p["elapsed_s"] == 0.0 and p["gaps"] == 0 and p["protect_start_s"] is None


def test_alarm_payload() -> None:
    p = roundtrip(
        topics.alarm_payload(
            t=50.0,
            wall=WALL,
            seq=4,
            kind="gap_closed",
            message="convoy seen again after 1.2 s",
            severity="info",
            data={"duration_s": 1.2, "bad": math.nan},
        )
    )
    assert p["seq"] == 4 and p["kind"] == "gap_closed" and p["severity"] == "info"
    assert p["sysid"] is None and p["data"] == {"duration_s": 1.2, "bad": None}
    with pytest.raises(ValueError, match="severity"):
        topics.alarm_payload(t=0.0, wall=WALL, seq=1, kind="x", message="x", severity="bad")


# ----------------------------------------------------------------- convoy position input


@pytest.mark.parametrize(
    ("raw", "expected"),
    [
        (b'{"lat": 47.39, "lon": 8.54}', {"lat": 47.39, "lon": 8.54}),
        ('{"lat": -10, "lon": 170, "t": 12.5}', {"lat": -10.0, "lon": 170.0, "t": 12.5}),
        (
            b'{"north": 100, "east": -3.5, "source": "gps1"}',
            {"north": 100.0, "east": -3.5, "source": "gps1"},
        ),
        (
            b'{"north": 1, "east": 2, "source": 7, "extra": "ignored"}',
            {"north": 1.0, "east": 2.0, "source": 7},
        ),
        (b'{"latitude": 47.39, "longitude": 8.54}', {"lat": 47.39, "lon": 8.54}),
        (  # an OwnTracks location, as its app publishes it: each phone is a source
            b'{"_type": "location", "lat": 47.39, "lon": 8.54, "tst": 1714557600, "tid": "t1"}',
            {"lat": 47.39, "lon": 8.54, "source": "t1"},
        ),
        (
            b'{"lat": 47.39, "lng": 8.54, "source": "truck"}',
            {"lat": 47.39, "lon": 8.54, "source": "truck"},
        ),
        (  # the vehicle's own velocity, m/s north and east
            b'{"north": 1, "east": 2, "vn": 3, "ve": -4.5}',
            {"north": 1.0, "east": 2.0, "velocity": (3.0, -4.5)},
        ),
        (  # OwnTracks: 36 km/h on a course of 90 degrees is 10 m/s east
            b'{"_type": "location", "lat": 47.39, "lon": 8.54, "vel": 36, "cog": 90}',
            {"lat": 47.39, "lon": 8.54, "velocity": pytest.approx((0.0, 10.0))},
        ),
        (  # (vel and cog are OwnTracks' own: elsewhere they are not a velocity)
            b'{"lat": 47.39, "lon": 8.54, "vel": 36, "cog": 90}',
            {"lat": 47.39, "lon": 8.54},
        ),
    ],
)
def test_convoy_position_accepted(raw: bytes | str, expected: dict[str, Any]) -> None:
    fix = topics.parse_convoy_position(raw)
    assert fix == expected
    assert all(type(fix[k]) is float for k in ("lat", "lon", "north", "east", "t") if k in fix)


@pytest.mark.parametrize(
    ("raw", "reason"),
    [
        (b"", "not JSON"),
        (b"not json", "not JSON"),
        (b"\xff\xfe", "not UTF-8"),
        (b"[1, 2]", "must be a JSON object"),
        (b'"47,8"', "must be a JSON object"),
        (b"{}", "missing position"),
        (b'{"t": 1}', "missing position"),
        (b'{"lat": 47.0}', "missing field 'lon'"),
        (b'{"east": 1.0}', "missing field 'north'"),
        (b'{"lat": NaN, "lon": 8.0}', "'lat' is not finite"),
        (b'{"north": 1.0, "east": Infinity}', "'east' is not finite"),
        (b'{"north": 1.0, "east": -Infinity}', "'east' is not finite"),
        (b'{"north": 1e400, "east": 0}', "'north' is not finite"),
        (b'{"lat": "47.0", "lon": 8.0}', "'lat' must be a JSON number"),
        (b'{"lat": null, "lon": 8.0}', "'lat' must be a JSON number"),
        (b'{"lat": true, "lon": 8.0}', "'lat' must be a JSON number"),
        (b'{"lat": 91.0, "lon": 8.0}', "'lat' out of range"),
        (b'{"lat": 47.0, "lon": -180.5}', "'lon' out of range"),
        (b'{"lat": 47.0, "lon": 8.0, "north": 1.0}', "not both"),
        (b'{"north": 1.0, "east": 2.0, "t": NaN}', "'t' is not finite"),
        (b'{"north": 1.0, "east": 2.0, "source": [1]}', "'source' must be"),
        (b'{"north": 1.0, "east": 2.0, "vn": 1.0}', "both vn and ve"),
        (b'{"north": 1.0, "east": 2.0, "vn": 1.0, "ve": NaN}', "'ve' is not finite"),
        (b'{"north": 1.0, "east": 2.0, "vn": "3", "ve": 0}', "'vn' must be a JSON number"),
        (b"{" + b" " * topics.MAX_INPUT_BYTES + b"}", "exceeds"),
        (b"[" * 5000 + b"]" * 5000, "exceeds"),
    ],
)
def test_convoy_position_rejected_with_reason(raw: bytes, reason: str) -> None:
    with pytest.raises(BadPayload, match=reason):
        topics.parse_convoy_position(raw)


def test_deep_nesting_is_a_bad_payload_not_a_crash() -> None:
    raw = b"[" * 2000 + b"]" * 2000  # under the size limit, deep enough to trouble a parser
    with pytest.raises(BadPayload):
        topics.parse_convoy_position(raw)


@settings(deadline=None)
@given(st.binary(max_size=200))
def test_convoy_position_never_raises_anything_else(raw: bytes) -> None:
    try:
        fix = topics.parse_convoy_position(raw)
    except BadPayload:
        return
    assert all(math.isfinite(v) for k, v in fix.items() if k != "source")


@settings(deadline=None)
@given(
    st.dictionaries(
        st.sampled_from(["lat", "lon", "north", "east", "t", "source"]),
        st.one_of(
            st.floats(),
            st.integers(),
            st.text(alphabet="a1.", max_size=3),
            st.none(),
            st.booleans(),
        ),
    )
)
def test_convoy_position_fuzzed_objects(obj: dict[str, Any]) -> None:
    raw = json.dumps(obj).encode()  # may contain NaN/Infinity tokens: those must be refused
    try:
        fix = topics.parse_convoy_position(raw)
    except BadPayload as exc:
        assert str(exc)
        return
    assert ("lat" in fix) != ("north" in fix)
    assert all(math.isfinite(v) for k, v in fix.items() if k != "source")


# ----------------------------------------------------------------- command input


@pytest.mark.parametrize(
    ("raw", "expected"),
    [
        (b"pause", "pause"),
        (b"  RESUME\n", "resume"),
        ('{"command": "pause"}', "pause"),
        (b'{"command": " Resume "}', "resume"),
        (b'"pause"', "pause"),
    ],
)
def test_command_accepted(raw: bytes | str, expected: str) -> None:
    assert topics.parse_command(raw) == expected


@pytest.mark.parametrize(
    ("raw", "reason"),
    [
        (b"", "unknown command ''"),
        (b"land", "unknown command 'land'"),
        (b'{"command": "takeoff"}', "unknown command 'takeoff'"),
        (b'{"cmd": "pause"}', "missing field 'command'"),
        (b'{"command": 1}', "must be a string"),
        (b'{"command": "pause"', "not JSON"),
        (b"\xff", "not UTF-8"),
        (b"x" * (topics.MAX_INPUT_BYTES + 1), "exceeds"),
    ],
)
def test_command_rejected_with_reason(raw: bytes, reason: str) -> None:
    with pytest.raises(BadPayload, match=reason):
        topics.parse_command(raw)


@settings(deadline=None)
@given(st.binary(max_size=100))
def test_command_never_raises_anything_else(raw: bytes) -> None:
    with contextlib.suppress(BadPayload):
        assert topics.parse_command(raw) in topics.COMMANDS


def test_vehicle_payload_says_whether_and_why_not_a_uav_counts() -> None:
    counting = topics.vehicle_payload(
        sysid=3, t=5.0, wall=0.0, state="flying", why_not_counted=None
    )
    assert counting["counted"] is True and counting["why_not_counted"] is None
    grounded = topics.vehicle_payload(
        sysid=3, t=5.0, wall=0.0, state="flying", why_not_counted="on ground"
    )
    assert grounded["counted"] is False and grounded["why_not_counted"] == "on ground"
    json.dumps(grounded, allow_nan=False)


def test_a_route_comes_as_points_or_geojson() -> None:
    want = PlannedRoute(((47.1, 8.1), (47.2, 8.2)))
    assert topics.parse_convoy_route('{"points": [[47.1, 8.1], [47.2, 8.2]]}') == want
    assert (
        topics.parse_convoy_route(
            b'{"points": [{"lat": 47.1, "lon": 8.1}, {"lat": 47.2, "lon": 8.2}]}'
        )
        == want
    )
    geojson = '{"type": "LineString", "coordinates": [[8.1, 47.1], [8.2, 47.2]]}'
    assert topics.parse_convoy_route(geojson) == want  # (GeoJSON is lon, lat)
    feature = f'{{"type": "Feature", "properties": {{"name": "MSR"}}, "geometry": {geojson}}}'
    assert topics.parse_convoy_route(feature) == want
    assert (
        topics.parse_convoy_route(f'{{"type": "FeatureCollection", "features": [{feature}]}}')
        == want
    )
    named = '{"points": [{"latitude": 47.1, "lng": 8.1}, {"latitude": 47.2, "longitude": 8.2}]}'
    assert topics.parse_convoy_route(named) == want
    point = '{"type": "Feature", "geometry": {"type": "Point", "coordinates": [8.1, 47.1]}}'
    for bad, needle in [
        (point, "geometry must be a LineString, got 'Point'"),
        (
            f'{{"type": "FeatureCollection", "features": [{feature}, {feature}]}}',
            "exactly one feature, got 2",
        ),
        ('{"points": [{"lat": 47.1}, {"lat": 47.2, "lon": 8.2}]}', "missing field 'lon'"),
        ("[1, 2]", "JSON object"),
        ('{"points": [[47.1, 8.1]]}', "2.."),
        ('{"points": [[47.1, 8.1], [95.0, 8.2]]}', "out of range"),
        ('{"points": [[47.1, 8.1], [NaN, 8.2]]}', "not finite"),
        ('{"points": [[47.1, 8.1], "x"]}', "must be [lat, lon]"),
        ("not json", "not JSON"),
    ]:
        with pytest.raises(topics.BadPayload, match=re.escape(needle)):
            topics.parse_convoy_route(bad)
    with pytest.raises(topics.BadPayload, match="exceeds"):
        topics.parse_convoy_route(b" " * (topics.MAX_ROUTE_BYTES + 1))


async def test_a_route_over_mqtt_reaches_the_road_planner() -> None:
    """Retained or not, a valid route is handed on; a bad one is counted, never raised."""
    from convoy_mav.app import ConvoyService
    from convoy_mav.config import parse_config
    from convoy_mav.publish.mqtt import MqttPublisher

    doc: dict[str, Any] = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    service = ConvoyService(parse_config(doc))
    publisher = MqttPublisher("127.0.0.1", 1883, "convoy", on_route=service.set_route)
    o = service.config.origin
    route = {"points": [[o.lat, o.lon], [o.lat + 0.01, o.lon], [o.lat + 0.01, o.lon + 0.01]]}
    publisher.dispatch("convoy/convoy/route", json.dumps(route), retain=True)
    publisher.dispatch("convoy/convoy/route", "{}")
    assert publisher.counters["routes_received"] == 1 and publisher.counters["bad_input"] == 1
    assert service.route is None  # taken in at the next mission step, in its thread
    service._mission_step(0.0, None, [], [], {}, set(), (0.0, 0.0))
    assert service.route is not None and service.route.length == pytest.approx(1860, rel=0.05)
    assert any(
        "convoy route received from MQTT convoy/route: 3 points" in e for e in service.events
    )
