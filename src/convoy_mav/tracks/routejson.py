"""JSON routes: the road a convoy will drive, as planners and map tools write it.

One reader for the MQTT ``<prefix>/convoy/route`` payload and a ``[convoy] route``
file (``.geojson``/``.json``), so a route drawn in a map tool is taken either way:
``{"points": [[lat, lon], ...]}``, ``{"points": [{"lat": .., "lon": ..}, ...]}``
(``latitude``, ``lng``, ``longitude`` too), or GeoJSON, whose order is lon, lat:
a ``LineString``, a ``Feature`` holding one, or a ``FeatureCollection`` holding
exactly one. Pure: values in, points out; a bad route is a ``ValueError`` saying why.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from typing import Any

__all__ = ["MAX_ROUTE_POINTS", "json_number", "parse_route_json", "route_points", "with_geo_keys"]

MAX_ROUTE_POINTS = 100_000
_GEO_ALIASES = {"latitude": "lat", "lng": "lon", "longitude": "lon"}


def parse_route_json(text: str | bytes, name: str) -> tuple[list[float], list[float]]:
    """A JSON route file's (lats, lons).

    Raises:
        ValueError: Not JSON, or not a route (:func:`route_points`); ``name:`` first.
    """
    try:
        obj = json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise ValueError(f"{name}: not JSON: {exc}") from None
    try:
        points = route_points(obj)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None
    return [p[0] for p in points], [p[1] for p in points]


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
