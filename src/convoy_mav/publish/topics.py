"""MQTT topic names, JSON payload builders, and validation of what operators send us.

Design rules:
- Pure: no asyncio, socket, MQTT or clock. Times come in as values: ``t`` is
  mission time (the autopilots' clock, seconds), ``wall`` is wall-clock epoch
  seconds, turned into the ISO 8601 ``ts`` field. The adapter
  (:mod:`convoy_mav.publish.mqtt`) moves these bytes; this module decides them.
- Plain JSON: numbers are JSON numbers, never strings; a value that is unknown
  or not finite (NaN, inf) is ``null`` -- ``NaN`` is not JSON and breaks most
  consumers. Units are SI (metres, seconds, m/s), angles in radians clockwise
  from north, positions in the mission frame (NED metres from the mission
  origin) and WGS-84 degrees.
- Incoming payloads are untrusted: the parsers either return a normalised value
  or raise :class:`BadPayload` whose message says what was wrong. The adapter
  counts and logs those; nothing a client publishes can crash the service.

Topics (all under a configurable ``<prefix>``, default ``convoy``; tables in
Markdown so they can go into the README as they are):

| topic | dir | retained | payload |
|---|---|---|---|
| `<prefix>/status` | out | yes | service phase, uptime, UAV counts, active alarms |
| `<prefix>/vehicle/<sysid>` | out | yes | one UAV: state, mode, position, tracking error |
| `<prefix>/coverage` | out | yes | covered now, fraction, gaps, predicted coverage |
| `<prefix>/alarm` | out | no | one event (gap opened, UAV lost, stale convoy...) |
| `<prefix>/convoy/position` | in | ignored | an external convoy fix |
| `<prefix>/command` | in | ignored | an operator command: pause / resume |
| `<prefix>/convoy/route` | in | used | the road the convoy will drive (road planner) |

Every outgoing payload is a JSON object carrying `t` (mission seconds: the
autopilots' clock; null while it is not known yet) and `ts` (wall time, ISO 8601
UTC with milliseconds, e.g. `"2024-05-01T12:00:00.250Z"`). Unknown or
non-finite numbers are `null`. Publishing keeps only the latest value per
topic: while the broker is away, older values are dropped, not queued.

`<prefix>/status`

| field | type | meaning |
|---|---|---|
| `t`, `ts` | number/null, string | mission time, wall time |
| `phase` | string | `starting` `joining` `protecting` `paused` `stopping` `stopped` `offline` |
| `paused` | bool | an operator pause is in force (all UAVs loiter) |
| `uptime_s` | number | wall seconds since the service started |
| `uavs` | object | `total`, plus a count per vehicle `state` (see vehicle below) |
| `alarms` | array of string | in force (`gap`, `uav_lost:<sysid>`, `convoy_parted:<sysid>`...) |

`<prefix>/vehicle/<sysid>`

| field | type | meaning |
|---|---|---|
| `t`, `ts` | number/null, string | mission time, wall time of this report |
| `sysid` | int | MAVLink system id (also in the topic) |
| `state` | string | `connecting` `waiting_fix` `setting_up` `flying` `holding` `lost` `failed` |
| `mode` | string/null | autopilot flight mode as it reports it |
| `firmware` | string/null | `px4` or `ardupilot` once recognised |
| `phase` | string/null | mission phase: `pending` `join` `protect` `lost` (null: no plan) |
| `position` | object/null | `lat` `lon` (deg), `alt` (m AMSL), `north` `east` `down` (m, NED) |
| `velocity` | object/null | `vn`, `ve`, `vd` (m/s, NED) |
| `yaw` | number/null | heading, rad clockwise from north |
| `telemetry_t` | number/null | mission time of the telemetry sample (its age: `t - telemetry_t`) |
| `tracking_error_m` | number/null | horizontal distance to the planned position, m |
| `statustext` | string/null | the autopilot's latest STATUSTEXT |
| `counted` | bool | it counts for coverage now (heard, airborne, in its band, on slot) |
| `why_not_counted` | string/null | why not (``monitor.why_not_counted``): `on ground`... |

`<prefix>/coverage`

| field | type | meaning |
|---|---|---|
| `t`, `ts` | number/null, string | mission time, wall time |
| `covered` | bool/null | convoy within r of at least one UAV right now (null: no sample yet) |
| `covering` | array of int | sysids whose sensor disk holds the convoy |
| `nearest_m` | number/null | distance from the convoy to the nearest UAV, m |
| `fraction` | number/null | covered fraction since the protect phase began (null before) |
| `elapsed_s` | number | mission seconds tracked since protect began |
| `covered_s` | number | of which covered |
| `current_gap_s` | number | length of the gap in progress (0 when covered) |
| `longest_gap_s` | number | longest gap so far, including an open one |
| `gaps` | int | number of gaps opened |
| `predicted` | number/null | coverage fraction the current plan predicts |
| `protect_start_s` | number/null | mission time the protect phase began |

`<prefix>/alarm` (not retained; one message per event)

| field | type | meaning |
|---|---|---|
| `t`, `ts` | number/null, string | mission time, wall time of the event |
| `seq` | int | 1, 2, 3... per service run: a jump means alarms were overwritten unsent |
| `kind` | string | `gap` `prediction_missed` `convoy_stale` `uav_lost` `uav_failed` `mission` |
| `severity` | string | `warning` when the condition starts, `info` when it ends |
| `message` | string | human-readable text |
| `sysid` | int/null | the vehicle concerned, if any |
| `data` | object | `active`: true when the condition starts, false when it clears |

`<prefix>/convoy/position` (input): either `{"lat": deg, "lon": deg}` or
`{"north": m, "east": m}` (mission frame), each optionally with `"t"` (mission
seconds of the fix), `"source"` (string or integer id when several trackers
report: the convoy is the centroid of each one's latest fix) and the vehicle's
own ground velocity, `"vn"` and `"ve"` in m/s (an OwnTracks location's `vel`,
km/h, and `cog`, degrees, are read as such). Fields must be JSON numbers and
finite; latitude in [-90, 90], longitude in [-180, 180]; unknown fields are
ignored; both forms at once, or half of one (or of the velocity), are rejected.
Example: `{"lat": 47.3977, "lon": 8.5456, "t": 812.4}`.

`<prefix>/command` (input): `{"command": "pause"}` / `{"command": "resume"}`,
or the plain strings `pause` / `resume` (case and surrounding blanks ignored).
`pause`: all UAVs loiter where they are; `resume`: rejoin the plan.

Rejected input is counted (`bad_input`) and logged with the reason, never
raised. Retained messages on the two input topics are ignored: a retained
`pause` would otherwise re-pause the fleet at every reconnect.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from typing import Any, Final

from convoy_mav.coverage import CoverageSample, CoverageStats
from convoy_mav.errors import ConfigError, ConvoyError
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.tracks.routejson import json_number, planned_route, with_geo_keys
from convoy_mav.types import Telemetry, VehicleStatus

__all__ = [
    "ALARM",
    "COMMAND",
    "COMMANDS",
    "CONVOY_POSITION",
    "COVERAGE",
    "MAX_INPUT_BYTES",
    "STATUS",
    "BadPayload",
    "alarm_payload",
    "coverage_payload",
    "encode",
    "iso_timestamp",
    "offline_payload",
    "parse_command",
    "parse_convoy_position",
    "status_payload",
    "topic",
    "validate_prefix",
    "validate_subtopic",
    "vehicle_payload",
    "vehicle_topic",
]

STATUS: Final = "status"
COVERAGE: Final = "coverage"
ALARM: Final = "alarm"
CONVOY_POSITION: Final = "convoy/position"
CONVOY_ROUTE: Final = "convoy/route"
COMMAND: Final = "command"
MAX_ROUTE_BYTES: Final = 1 << 20  # 1 MiB: some 25 000 points, a day's drive at 1 Hz
COMMANDS: Final = ("pause", "resume")
MAX_LOCAL_M: Final = 1_000_000.0  # |north|, |east| of a fix: the mission frame spans 1000 km
MAX_MISSION_S: Final = 10_000_000.0  # a fix's mission time: some 115 days
MAX_INPUT_BYTES: Final = 4096  # a convoy fix is ~60 bytes; anything huge is not one
SEVERITIES: Final = ("info", "warning", "critical")


class BadPayload(ConvoyError, ValueError):
    """An incoming MQTT payload is not what the documented schema allows.

    The message is the reason, written for the operator's log.
    """


# --------------------------------------------------------------------------- topics


def validate_prefix(prefix: str, key: str = "mqtt.prefix") -> str:
    """Check a topic prefix: non-empty levels, no wildcards, no leading/trailing ``/``.

    Raises:
        ConfigError: Naming ``key`` and the bad value.
    """
    if not isinstance(prefix, str) or not prefix:
        raise ConfigError(key, prefix, "must be a non-empty string")
    _check_levels(prefix, key)
    return prefix


def validate_subtopic(subtopic: str) -> str:
    """Check a topic below the prefix (``status``, ``vehicle/3``...).

    Raises:
        ValueError: If empty, containing wildcards or NUL, or with empty levels.
    """
    if not isinstance(subtopic, str) or not subtopic:
        raise ValueError(f"subtopic must be a non-empty string, got {subtopic!r}")
    _check_levels(subtopic, "subtopic")
    return subtopic


def _check_levels(text: str, key: str) -> None:
    if any(c in text for c in "#+\0"):
        raise ConfigError(key, text, "must not contain the wildcards '#', '+' or NUL")
    if any(level == "" for level in text.split("/")):
        raise ConfigError(key, text, "must not start or end with '/' nor contain '//'")
    if len(text.encode()) > 1024:
        raise ConfigError(key, text, "longer than 1024 bytes")


def topic(prefix: str, subtopic: str) -> str:
    """The full topic name: ``<prefix>/<subtopic>``."""
    return f"{prefix}/{subtopic}"


def vehicle_topic(sysid: int) -> str:
    """Subtopic of one vehicle's state: ``vehicle/<sysid>``."""
    return f"vehicle/{int(sysid)}"


# --------------------------------------------------------------------------- encoding


def iso_timestamp(wall: float) -> str:
    """Epoch seconds -> ISO 8601 UTC with milliseconds and a ``Z`` suffix."""
    stamp = datetime.fromtimestamp(wall, UTC)
    return stamp.strftime("%Y-%m-%dT%H:%M:%S.") + f"{stamp.microsecond // 1000:03d}Z"


def _num(value: float | None, digits: int = 3) -> float | None:
    """A finite number rounded for the wire, else None (JSON null)."""
    if value is None:
        return None
    x = float(value)
    return round(x, digits) if math.isfinite(x) else None


def _sanitise(value: Any) -> Any:
    """Copy of a JSON-able structure with non-finite floats replaced by None."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): _sanitise(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_sanitise(v) for v in value]
    return value


def encode(payload: Mapping[str, Any]) -> bytes:
    """Serialise a payload to compact UTF-8 JSON; NaN/inf become null.

    Raises:
        TypeError: If the payload holds something JSON cannot represent.
    """
    try:
        text = json.dumps(payload, separators=(",", ":"), allow_nan=False)
    except ValueError:  # a NaN/inf somewhere: the slow path fixes it
        text = json.dumps(_sanitise(payload), separators=(",", ":"), allow_nan=False)
    return text.encode()


def _header(t: float | None, wall: float) -> dict[str, Any]:
    return {"t": _num(t), "ts": iso_timestamp(wall)}


# --------------------------------------------------------------------------- builders


def offline_payload() -> dict[str, Any]:
    """``<prefix>/status`` as the broker publishes it when the service vanished (last will).

    No time fields: the broker sends it when it notices, long after it was written.
    """
    return {"phase": "offline", "paused": False, "alarms": ["service_offline"]}


def status_payload(
    *,
    t: float | None,
    wall: float,
    phase: str,
    uptime_s: float,
    vehicles: Mapping[int, VehicleStatus | str],
    alarms: Sequence[str] = (),
    paused: bool = False,
) -> dict[str, Any]:
    """``<prefix>/status``: the service at a glance.

    Args:
        t: Mission time, or None before the mission clock is known.
        wall: Wall-clock epoch seconds.
        phase: Service phase name.
        uptime_s: Wall seconds since the service started.
        vehicles: State of each UAV by sysid; counted per state.
        alarms: Kinds of the currently active alarms.
        paused: Whether an operator pause is in force.
    """
    uavs: dict[str, int] = {"total": len(vehicles)}
    uavs.update({state.value: 0 for state in VehicleStatus})
    for state in vehicles.values():
        key = str(state.value if isinstance(state, VehicleStatus) else state)
        uavs[key] = uavs.get(key, 0) + 1
    return {
        **_header(t, wall),
        "phase": phase,
        "paused": bool(paused),
        "uptime_s": _num(uptime_s),
        "uavs": uavs,
        "alarms": [str(a) for a in alarms],
    }


def vehicle_payload(
    *,
    sysid: int,
    t: float | None,
    wall: float,
    state: VehicleStatus | str,
    telemetry: Telemetry | None = None,
    mode: str | None = None,
    firmware: str | None = None,
    phase: str | None = None,
    tracking_error_m: float | None = None,
    statustext: str | None = None,
    why_not_counted: str | None = "not flying",
) -> dict[str, Any]:
    """``<prefix>/vehicle/<sysid>``: one UAV's state as the service sees it."""
    position: dict[str, float | None] | None = None
    velocity: dict[str, float | None] | None = None
    yaw: float | None = None
    telemetry_t: float | None = None
    if telemetry is not None:
        position = {
            "lat": _num(telemetry.lat, 7),
            "lon": _num(telemetry.lon, 7),
            "alt": _num(telemetry.alt, 2),
            "north": _num(telemetry.north, 2),
            "east": _num(telemetry.east, 2),
            "down": _num(telemetry.down, 2),
        }
        velocity = {
            "vn": _num(telemetry.vn, 2),
            "ve": _num(telemetry.ve, 2),
            "vd": _num(telemetry.vd, 2),
        }
        yaw = _num(telemetry.yaw, 4)
        telemetry_t = _num(telemetry.t)
    return {
        **_header(t, wall),
        "sysid": int(sysid),
        "state": str(state.value if isinstance(state, VehicleStatus) else state),
        "mode": mode,
        "firmware": firmware,
        "phase": phase,
        "position": position,
        "velocity": velocity,
        "yaw": yaw,
        "telemetry_t": telemetry_t,
        "tracking_error_m": _num(tracking_error_m, 2),
        "statustext": statustext,
        "counted": why_not_counted is None,
        "why_not_counted": why_not_counted,
    }


def coverage_payload(
    *,
    t: float | None,
    wall: float,
    stats: CoverageStats | None,
    sample: CoverageSample | None = None,
    predicted: float | None = None,
    protect_start_s: float | None = None,
) -> dict[str, Any]:
    """``<prefix>/coverage``: what the coverage monitor knows right now.

    Args:
        t: Mission time.
        wall: Wall-clock epoch seconds.
        stats: Totals since the protect phase began (None before it began).
        sample: The latest observation (who covers the convoy now), if any.
        predicted: Coverage fraction the current plan predicts.
        protect_start_s: Mission time the protect phase began.
    """
    started = stats is not None and stats.elapsed_s > 0.0
    return {
        **_header(t, wall),
        "covered": None if sample is None else bool(sample.covered),
        "covering": [] if sample is None else [int(u) for u in sample.covering],
        "nearest_m": None if sample is None else _num(sample.nearest_m, 2),
        "fraction": _num(stats.fraction, 5) if stats is not None and started else None,
        "elapsed_s": _num(stats.elapsed_s) if stats is not None else 0.0,
        "covered_s": _num(stats.covered_s) if stats is not None else 0.0,
        "current_gap_s": _num(stats.current_gap_s) if stats is not None else 0.0,
        "longest_gap_s": _num(stats.longest_gap_s) if stats is not None else 0.0,
        "gaps": int(stats.gaps) if stats is not None else 0,
        "predicted": _num(predicted, 5),
        "protect_start_s": _num(protect_start_s),
    }


def alarm_payload(
    *,
    t: float | None,
    wall: float,
    seq: int,
    kind: str,
    message: str,
    severity: str = "warning",
    sysid: int | None = None,
    data: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """``<prefix>/alarm``: one event.

    Raises:
        ValueError: If ``severity`` is not one of ``info``, ``warning``, ``critical``
            (our misuse, found by the first test that raises the alarm).
    """
    if severity not in SEVERITIES:
        raise ValueError(f"severity must be one of {SEVERITIES}, got {severity!r}")
    return {
        **_header(t, wall),
        "seq": int(seq),
        "kind": kind,
        "severity": severity,
        "message": message,
        "sysid": None if sysid is None else int(sysid),
        "data": _sanitise(dict(data)) if data else {},
    }


# --------------------------------------------------------------------------- parsers


def _load(payload: bytes | str) -> Any:
    """Decode an incoming payload as JSON, with a reason on failure."""
    if len(payload) > MAX_INPUT_BYTES:
        raise BadPayload(f"payload of {len(payload)} bytes exceeds {MAX_INPUT_BYTES}")
    try:
        text = payload.decode() if isinstance(payload, bytes | bytearray) else payload
    except UnicodeDecodeError as exc:
        raise BadPayload(f"payload is not UTF-8: {exc.reason} at byte {exc.start}") from None
    try:
        return json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise BadPayload(f"payload is not JSON: {exc}") from None


def _number(obj: Mapping[str, Any], key: str) -> float:
    """A required finite JSON number field."""
    try:
        return json_number(obj, key)
    except ValueError as exc:
        raise BadPayload(str(exc)) from None


def parse_convoy_position(payload: bytes | str) -> dict[str, Any]:
    """Validate ``<prefix>/convoy/position``: ``lat``/``lon`` (or ``latitude``, ``lng``,
    ``longitude``, as trackers publish them) or ``north``/``east``; other fields ignored,
    but for an OwnTracks location's ``tid``, the source when none is named.

    Returns:
        ``{"lat", "lon"}`` or ``{"north", "east"}`` as floats, plus ``"t"`` (float),
        ``"source"`` (str or int) and ``"velocity"`` (``(vn, ve)``, m/s) when given.

    Raises:
        BadPayload: Not JSON, not an object, missing/NaN/inf/non-number fields,
            out-of-range latitude, longitude, north/east or time, or both/neither
            position forms.
    """
    obj = _load(payload)
    if not isinstance(obj, dict):
        raise BadPayload(f"convoy position must be a JSON object, got {type(obj).__name__}")
    obj = with_geo_keys(obj)
    if "source" not in obj and obj.get("_type") == "location" and "tid" in obj:
        obj["source"] = obj["tid"]  # (OwnTracks: each phone's tracker id is one vehicle)
    geo = {"lat", "lon"} & obj.keys()
    local = {"north", "east"} & obj.keys()
    if geo and local:
        raise BadPayload("give either lat/lon or north/east, not both")
    if not geo and not local:
        raise BadPayload("missing position: expected fields lat/lon or north/east")
    out: dict[str, Any] = {}
    if geo:
        lat, lon = _number(obj, "lat"), _number(obj, "lon")
        if not -90.0 <= lat <= 90.0:
            raise BadPayload(f"field 'lat' out of range [-90, 90]: {lat}")
        if not -180.0 <= lon <= 180.0:
            raise BadPayload(f"field 'lon' out of range [-180, 180]: {lon}")
        out["lat"], out["lon"] = lat, lon
    else:
        north, east = _number(obj, "north"), _number(obj, "east")
        if not (abs(north) <= MAX_LOCAL_M and abs(east) <= MAX_LOCAL_M):
            limit = f"|x| <= {MAX_LOCAL_M:.0f} m"
            raise BadPayload(f"north/east out of range ({limit}): {north}, {east}")
        out["north"], out["east"] = north, east
    if "t" in obj:
        t = _number(obj, "t")
        if not 0.0 <= t <= MAX_MISSION_S:
            raise BadPayload(f"field 't' out of range [0, {MAX_MISSION_S:.0f}] s: {t}")
        out["t"] = t
    if "source" in obj:
        source = obj["source"]
        if isinstance(source, bool) or not isinstance(source, str | int):
            raise BadPayload(f"field 'source' must be a string or integer, got {source!r}")
        out["source"] = source
    velocity = _velocity(obj)
    if velocity is not None:
        out["velocity"] = velocity
    return out


_KMH: Final = 1.0 / 3.6


def _velocity(obj: Mapping[str, Any]) -> tuple[float, float] | None:
    """The vehicle's own ground velocity (north, east) in m/s, when the fix carries it:
    ``vn``/``ve``, or an OwnTracks location's ``vel`` (km/h) and ``cog`` (deg)."""
    local = {"vn", "ve"} & obj.keys()
    if local:
        if len(local) == 1:
            raise BadPayload("give both vn and ve (m/s), or neither")
        vn, ve = _number(obj, "vn"), _number(obj, "ve")
    elif obj.get("_type") == "location" and {"vel", "cog"} <= obj.keys():
        speed, course = _number(obj, "vel") * _KMH, math.radians(_number(obj, "cog"))
        vn, ve = speed * math.cos(course), speed * math.sin(course)
    else:
        return None
    return vn, ve  # (the tracker judges it against the fixes: ``ConvoyTracker``)


def parse_convoy_route(payload: bytes | str) -> PlannedRoute:
    """Validate ``<prefix>/convoy/route``: the road the convoy will drive, in order,
    and the convoy's plan on it if it carries one.

    The forms of a JSON route (``tracks.routejson``): ``{"points": [[lat, lon], ...]}``,
    ``{"points": [{"lat": .., "lon": ..}, ...]}`` or GeoJSON (a ``LineString``, or a
    ``Feature`` or one-feature ``FeatureCollection`` of one); its plan: ``holds``,
    ``speeds`` and ``circuit`` (``tracks.routejson.planned_route``). Retained messages
    are used: a route published before the service started is the route, and one
    published again (a stop added, a speed changed) replaces it.

    Returns:
        The (lat, lon) points, and the plan.

    Raises:
        BadPayload: Malformed JSON, under two points, a non-finite or out-of-range
            coordinate, a plan that is not one, or a payload over ``MAX_ROUTE_BYTES``.
    """
    if len(payload) > MAX_ROUTE_BYTES:
        raise BadPayload(f"route of {len(payload)} bytes exceeds {MAX_ROUTE_BYTES}")
    try:
        obj = json.loads(payload)
    except (ValueError, UnicodeDecodeError) as exc:
        raise BadPayload(f"not JSON: {exc}") from None
    try:
        return planned_route(obj)
    except ValueError as exc:
        raise BadPayload(str(exc)) from None


def parse_command(payload: bytes | str) -> str:
    """Validate ``<prefix>/command``: JSON ``{"command": ...}`` or a plain string.

    Returns:
        One of :data:`COMMANDS` (lower case).

    Raises:
        BadPayload: Unknown command or malformed payload.
    """
    if len(payload) > MAX_INPUT_BYTES:
        raise BadPayload(f"payload of {len(payload)} bytes exceeds {MAX_INPUT_BYTES}")
    try:
        text = payload.decode() if isinstance(payload, bytes | bytearray) else payload
    except UnicodeDecodeError as exc:
        raise BadPayload(f"payload is not UTF-8: {exc.reason} at byte {exc.start}") from None
    stripped = text.strip()
    value: Any = stripped
    if stripped[:1] in ("{", '"'):
        value = _load(stripped)
        if isinstance(value, dict):
            if "command" not in value:
                raise BadPayload("missing field 'command'")
            value = value["command"]
        if not isinstance(value, str):
            raise BadPayload(f"command must be a string, got {value!r}")
    command = str(value).strip().lower()
    if command not in COMMANDS:
        shown = command if len(command) <= 40 else command[:40] + "..."
        raise BadPayload(f"unknown command {shown!r} (expected one of {', '.join(COMMANDS)})")
    return command
