"""Hostile input to every pure parser: a clear, typed refusal or a result, never a crash.

Random and mutated bytes into the MAVLink codec, the CSV/GPX/tlog track and KML route
readers, the
mission config, and the MQTT payloads (hypothesis, in CI; an atheris harness for long
runs is ``benchmarks/fuzz_parsers.py``).
"""

from __future__ import annotations

import contextlib
import json
import math
from collections.abc import Callable
from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.config import parse_config
from convoy_mav.errors import ConfigError
from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.publish import topics
from convoy_mav.tracks.csvfile import parse_csv_track
from convoy_mav.tracks.gpx import parse_gpx_track
from convoy_mav.tracks.kml import kmz_document, parse_kml_points, parse_kml_track
from convoy_mav.tracks.missionfile import WPL_HEADER, parse_plan, parse_waypoints
from convoy_mav.tracks.routejson import planned_route
from convoy_mav.tracks.tlog import parse_tlog_track

FUZZ = settings(max_examples=300, deadline=None)

_GOOD = MavCodec(1, 1).pack(
    mavlink.MAVLink_global_position_int_message(
        1000, 473977420, 85455940, 588000, 100_000, 0, 0, 0, 0
    )
)


@st.composite
def mutated_frames(draw: st.DrawFn) -> bytes:
    """A valid frame with some bytes flipped, cut or appended."""
    data = bytearray(_GOOD)
    for _ in range(draw(st.integers(0, 6))):
        i = draw(st.integers(0, len(data) - 1))
        data[i] = draw(st.integers(0, 255))
    cut = draw(st.integers(0, len(data)))
    return bytes(data[:cut]) + draw(st.binary(max_size=40))


@FUZZ
@given(st.one_of(st.binary(max_size=600), mutated_frames()))
def test_codec_takes_any_bytes(data: bytes) -> None:
    codec = MavCodec()
    for msg in codec.feed_datagram(data) + codec.feed(data):
        assert msg.get_type()  # (whatever came out is a decoded message)
    assert sum(codec.counters.values()) >= 0


@FUZZ
@given(st.one_of(st.binary(max_size=800), st.text(max_size=800)))
def test_track_readers_refuse_with_a_value_error(data: bytes | str) -> None:
    raw = data if isinstance(data, bytes) else data.encode("utf-8", "surrogatepass")
    text = raw.decode("utf-8", "replace")
    parsers: list[Callable[[], object]] = [
        lambda: parse_csv_track(text.splitlines(), "fuzz.csv"),
        lambda: parse_gpx_track(raw, "fuzz.gpx"),
        lambda: parse_tlog_track(raw, "fuzz.tlog"),
        lambda: parse_kml_points(raw, "fuzz.kml"),
        lambda: parse_kml_track(raw, "fuzz.kml"),
        lambda: kmz_document(raw, "fuzz.kmz"),
        lambda: parse_waypoints(text, "fuzz.waypoints"),
        lambda: parse_waypoints(WPL_HEADER + "\n" + text, "fuzz.waypoints"),
        lambda: parse_plan(raw, "fuzz.plan"),
    ]
    for parse in parsers:
        with contextlib.suppress(ValueError):  # (a named refusal: the CLI prints one line)
            parse()


_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=12),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=20,
)
_keys = st.sampled_from(["mission", "aircraft", "convoy", "uav", "mqtt", "safety", "record"])


@FUZZ
@given(st.dictionaries(_keys, _json, max_size=5), st.floats(allow_nan=True))
@example({"mqtt": None}, 1.0)  # (once a TypeError: "password" looked for in None)
@example({"mqtt": "password"}, 1.0)  # (once refused as a password in the file)
def test_config_refuses_with_a_config_error(data: dict[str, Any], radius: float) -> None:
    doc: dict[str, Any] = {"mission": {"sensor_radius_m": radius}, **data}
    try:
        parse_config(doc)
    except ConfigError as exc:
        assert exc.key  # (names the key)


_KML = (
    "<kml><Placemark><LineString><coordinates>8.1,47.1 8.2,47.2"
    "</coordinates></LineString></Placemark></kml>"
)


@FUZZ
@given(st.integers(0, len(_KML) - 1), st.text(max_size=8), st.integers(0, 12))
def test_a_mangled_kml_route_is_read_or_refused(at: int, insert: str, cut: int) -> None:
    text = _KML[:at] + insert + _KML[at + cut :]
    with contextlib.suppress(ValueError):
        lats, lons = parse_kml_points(text, "fuzz.kml")
        assert len(lats) == len(lons) >= 2


@FUZZ
@given(_json)
def test_a_plan_of_any_shape_is_read_or_refused(mission: Any) -> None:
    """QGroundControl plans as JSON of any shape where the mission and its items go."""
    for doc in (
        {"mission": mission},
        {"mission": {"items": mission}},
        {"mission": {"items": [mission]}},
    ):
        with contextlib.suppress(ValueError):
            route = parse_plan(json.dumps(doc).encode(), "fuzz.plan")
            assert len(route.points) >= 2


_number = st.one_of(st.integers(-2, 3), st.floats(), st.booleans())
_mark = st.one_of(
    _json,
    st.lists(_number, min_size=2, max_size=2),
    st.dictionaries(st.sampled_from(["point", "seconds", "mps"]), _number),
)


@FUZZ
@given(st.one_of(_json, st.lists(_mark, max_size=4)), st.lists(_mark, max_size=4), _json, _json)
def test_a_routes_plan_of_any_shape_is_read_or_refused(
    holds: Any, speeds: Any, own: Any, circuit: Any
) -> None:
    """A JSON route's plan (holds, speeds, circuit, a point's own hold and speed) of any
    shape: read, every mark on the route and above 0, or refused with a ValueError."""
    here = {"lat": 47.2, "lon": 8.2, "hold_s": own, "mps": own}
    for doc in (
        {"points": [[47.1, 8.1], [47.2, 8.2]], "holds": holds, "speeds": speeds},
        {"points": [[47.1, 8.1], here], "circuit": circuit},
    ):
        with contextlib.suppress(ValueError):
            route = planned_route(doc)
            marks = route.holds + route.speeds
            assert all(0 <= i < 2 and math.isfinite(v) and v > 0 for i, v in marks)


@FUZZ
@given(st.one_of(st.binary(max_size=300), _json.map(json.dumps)))
def test_mqtt_payloads_refuse_with_bad_payload(payload: bytes | str) -> None:
    for parse in (topics.parse_convoy_position, topics.parse_command, topics.parse_convoy_route):
        with contextlib.suppress(topics.BadPayload):
            parse(payload)
