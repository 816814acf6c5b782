"""JSON routes: the road a convoy will drive, as planners and map tools write it.

One reader for the MQTT ``<prefix>/convoy/route`` payload and a ``[convoy] route``
file (``.geojson``/``.json``), so a route drawn in a map tool is taken either way:
``{"points": [[lat, lon], ...]}``, ``{"points": [{"lat": .., "lon": ..}, ...]}``
(``latitude``, ``lng``, ``longitude`` too), or GeoJSON, whose order is lon, lat:
a ``LineString``, a ``Feature`` holding one, or a ``FeatureCollection`` holding
exactly one. Pure: values in, points out; a bad route is a ``ValueError`` saying why.

A route may also carry the convoy's plan on it (:func:`planned_route`), as a rover's
mission does with its holds, DO_CHANGE_SPEEDs and DO_JUMP: a convoy whose command post
knows where it will stop, how long, and how fast it drives between, says so with the
route, and the UAVs are where it will be when it stops or speeds up. Keys (in GeoJSON,
the Feature's ``properties``; points are counted from 0 in the order given):

- ``"holds": [{"point": 4, "seconds": 90}, ...]`` (or ``[[4, 90], ...]``): it stands
  at that point so long;
- ``"speeds": [{"point": 0, "mps": 8}, ...]`` (or ``[[0, 8], ...]``): it drives at that
  speed from that point on;
- ``"circuit": true``: the points are one lap, driven round and round; the lap is
  closed by the drive back to its first point;
- a ``{"lat": .., "lon": ..}`` point may carry its own ``"hold_s"`` and ``"mps"``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

from convoy_mav.tracks.plannedroute import PlannedRoute, PointMarks, closed_lap

__all__ = [
    "MAX_HOLD_S",
    "MAX_ROUTE_POINTS",
    "MAX_SPEED_MPS",
    "json_number",
    "parse_route_json",
    "planned_route",
    "route_points",
    "with_geo_keys",
]

MAX_ROUTE_POINTS = 100_000
MAX_HOLD_S = 86_400.0
"""The longest hold a route may plan: a day (longer is milliseconds taken for seconds)."""
MAX_SPEED_MPS = 70.0
"""The fastest a route may plan a ground convoy to drive, m/s (252 km/h)."""
#: A plan's lists: (the value's key in an entry, a point's own key for it, the highest
#: value, whether 0 is one).
_PLAN_KEYS = {
    "holds": ("seconds", "hold_s", MAX_HOLD_S, True),
    "speeds": ("mps", "mps", MAX_SPEED_MPS, False),
}
_GEO_ALIASES = {"latitude": "lat", "lng": "lon", "longitude": "lon"}


def parse_route_json(text: str | bytes, name: str) -> PlannedRoute:
    """A JSON route file's points, and its plan if it has one (:func:`planned_route`).

    Raises:
        ValueError: Not JSON, or not a route; ``name:`` first.
    """
    try:
        obj = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: not JSON: {exc}") from None
    try:
        return planned_route(obj)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def planned_route(obj: Any) -> PlannedRoute:
    """A decoded JSON route's points (:func:`route_points`) and the plan it carries
    (the module's keys; none: an empty plan).

    Raises:
        ValueError: Not a route, or a plan that is not one: a point index out of the
            route, a point given two holds or two speeds, a hold below 0 or over
            ``MAX_HOLD_S``, a speed not above 0 or over ``MAX_SPEED_MPS``, a
            ``circuit`` that is not true or false.
    """
    points = route_points(obj)
    fields = _plan_fields(obj)
    raw = obj.get("points")  # (its points' own keys, in the points form)
    own = [p if isinstance(p, dict) else {} for p in raw] if isinstance(raw, list) else []
    holds = _marks(fields, own, "holds", len(points))
    speeds = _marks(fields, own, "speeds", len(points))
    circuit = fields.get("circuit", False)
    if not isinstance(circuit, bool):
        raise ValueError(f"'circuit' must be true or false, got {circuit!r}")
    if circuit:
        points = closed_lap(points)
    return PlannedRoute(tuple(points), laps=circuit, holds=holds, circuit=circuit, speeds=speeds)


def _plan_fields(obj: Mapping[str, Any]) -> Mapping[str, Any]:
    """Where a JSON route keeps its plan: a GeoJSON Feature's ``properties``, else the
    route object itself (``route_points`` has checked the forms)."""
    if obj.get("type") == "FeatureCollection":
        obj = obj["features"][0]
    if obj.get("type") == "Feature":
        props = obj.get("properties")
        return props if isinstance(props, dict) else {}
    return obj


def _marks(
    fields: Mapping[str, Any], own: list[dict[str, Any]], name: str, count: int
) -> PointMarks:
    """One of a plan's lists (``holds``, ``speeds``) and its points' own keys, as
    (point index, value) by index; a hold of 0 s is none."""
    value_key, point_key, top, zero_ok = _PLAN_KEYS[name]
    marks: dict[int, float] = {}

    def put(i: Any, value: float, where: str) -> None:
        if isinstance(i, bool) or not isinstance(i, int) or not 0 <= i < count:
            raise ValueError(
                f"{where}: 'point' must be an index of the route's {count} points, got {i!r}"
            )
        low_ok = value >= 0.0 if zero_ok else value > 0.0
        if not low_ok or value > top:
            bound = "from 0" if zero_ok else "above 0"
            raise ValueError(f"{where}: {value_key} {value:g} is not {bound} to {top:g}")
        if i in marks:
            raise ValueError(f"{where}: point {i} is given two {name}")
        if value > 0.0:
            marks[i] = value

    entries = fields.get(name, [])
    if not isinstance(entries, list):
        raise ValueError(f"{name!r} must be a list, got {type(entries).__name__}")
    for k, entry in enumerate(entries):
        where = f"{name}[{k}]"
        if isinstance(entry, dict):
            put(entry.get("point"), json_number(entry, value_key), where)
        elif isinstance(entry, list) and len(entry) == 2:
            put(entry[0], json_number({value_key: entry[1]}, value_key), where)
        else:
            raise ValueError(
                f'{where} must be {{"point": i, "{value_key}": x}} or [i, x], got {entry!r}'
            )
    for i, point in enumerate(own):
        if point_key in point:
            put(i, json_number(point, point_key), f"point {i}'s {point_key}")
    return tuple(sorted(marks.items()))


def route_points(obj: Any) -> list[tuple[float, float]]:
    """The (lat, lon) points of a decoded JSON route, in order.

    Raises:
        ValueError: Not one of the forms above, under two or over ``MAX_ROUTE_POINTS``
            points, a non-numeric, non-finite or out-of-range coordinate.
    """
    if not isinstance(obj, dict):
        raise ValueError(f"a route must be a JSON object, got {type(obj).__name__}")
    obj = _geojson_line(obj)
    if obj.get("type") == "LineString":
        raw, lon_first = obj.get("coordinates"), True
    else:
        raw, lon_first = obj.get("points"), False
    if not isinstance(raw, list) or not 2 <= len(raw) <= MAX_ROUTE_POINTS:
        raise ValueError(
            f"a route needs 'points' (or GeoJSON 'coordinates'): 2..{MAX_ROUTE_POINTS}"
        )
    out = []
    for i, p in enumerate(raw):
        if isinstance(p, dict):
            named = with_geo_keys(p)
            lat, lon = json_number(named, "lat"), json_number(named, "lon")
        elif isinstance(p, list) and len(p) >= 2:
            a, b = json_number({"0": p[0]}, "0"), json_number({"1": p[1]}, "1")
            lat, lon = (b, a) if lon_first else (a, b)
        else:
            raise ValueError(f"route point {i} must be [lat, lon] or {{lat, lon}}, got {p!r}")
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ValueError(f"route point {i} out of range: lat {lat}, lon {lon}")
        out.append((lat, lon))
    return out


def json_number(obj: Mapping[str, Any], key: str) -> float:
    """A required finite JSON number field (``ValueError`` saying which, and why)."""
    if key not in obj:
        raise ValueError(f"missing field {key!r}")
    value = obj[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"field {key!r} must be a JSON number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"field {key!r} is not finite ({value!r})")
    return x


def with_geo_keys(obj: Mapping[str, Any]) -> dict[str, Any]:
    """``obj`` with ``latitude``/``lng``/``longitude`` also under ``lat``/``lon``, as
    trackers and map tools name them (a ``lat`` or ``lon`` of its own wins)."""
    return {**{_GEO_ALIASES[k]: v for k, v in obj.items() if k in _GEO_ALIASES}, **obj}


def _geojson_line(obj: dict[str, Any]) -> dict[str, Any]:
    """A GeoJSON Feature's, or a one-feature FeatureCollection's, geometry; else ``obj``."""
    if obj.get("type") == "FeatureCollection":
        features = obj.get("features")
        if not isinstance(features, list) or len(features) != 1:
            count = len(features) if isinstance(features, list) else "no"
            raise ValueError(f"a route FeatureCollection needs exactly one feature, got {count}")
        obj = features[0] if isinstance(features[0], dict) else {}
    if obj.get("type") == "Feature":
        geometry = obj.get("geometry")
        if not isinstance(geometry, dict) or geometry.get("type") != "LineString":
            kind = geometry.get("type") if isinstance(geometry, dict) else None
            raise ValueError(f"a route Feature's geometry must be a LineString, got {kind!r}")
        return geometry
    return obj
