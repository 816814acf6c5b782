"""Local tangent-plane geodesy shared by the service and the mock.

Every vehicle of a mission, and the convoy, are placed in one geographic frame
whose origin the config names; each autopilot's own local NED origin (its home)
differs, so positions cross between vehicles only as latitude/longitude.

The mapping is the equirectangular projection with the WGS-84 radii of
curvature at the origin's latitude: exact at the origin and within a few
centimetres over the few kilometres a convoy mission spans, which is what
PX4's and ArduPilot's own local-frame code assume as well.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from convoy_mav.values import value

__all__ = ["GeoPoint", "LocalFrame", "no_position_yet"]

_NULL_ISLAND_DEG = 0.01

_WGS84_A = 6_378_137.0
_WGS84_E2 = 6.694_379_990_14e-3


@value
class GeoPoint:
    """A WGS-84 position: degrees and metres above mean sea level."""

    lat: float
    lon: float
    alt: float = 0.0


@dataclass(frozen=True, slots=True)
class LocalFrame:
    """A north-east-down frame tangent to the ellipsoid at ``origin``."""

    origin: GeoPoint
    # Metres per radian of latitude (meridian) and of longitude (parallel) at the
    # origin: worked out once, every setpoint and position crosses this frame.
    _radii: tuple[float, float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lat = math.radians(self.origin.lat)
        s2 = math.sin(lat) ** 2
        w = math.sqrt(1.0 - _WGS84_E2 * s2)
        meridian = _WGS84_A * (1.0 - _WGS84_E2) / w**3
        prime_vertical = _WGS84_A / w
        object.__setattr__(self, "_radii", (meridian, prime_vertical * math.cos(lat)))

    def to_ned(self, point: GeoPoint) -> tuple[float, float, float]:
        """Geodetic point to (north, east, down) metres from the origin."""
        m, p = self._radii
        north = math.radians(point.lat - self.origin.lat) * m
        d_lon = (point.lon - self.origin.lon + 180.0) % 360.0 - 180.0
        east = math.radians(d_lon) * p
        return north, east, self.origin.alt - point.alt

    def to_geo(self, north: float, east: float, down: float = 0.0) -> GeoPoint:
        """(north, east, down) metres from the origin to a geodetic point."""
        m, p = self._radii
        lat = self.origin.lat + math.degrees(north / m)
        lon = self.origin.lon + math.degrees(east / p)
        lon = (lon + 180.0) % 360.0 - 180.0
        return GeoPoint(lat, lon, self.origin.alt - down)


def no_position_yet(lat_e7: int, lon_e7: int) -> bool:
    """A GLOBAL_POSITION_INT from before the estimator has its origin: ArduPilot reports
    its local offset from (0, 0) then (metres off "null island"), PX4 zeros. Within a
    kilometre of (0, 0), in the Gulf of Guinea, is taken for that, never a position."""
    limit = _NULL_ISLAND_DEG * 1e7
    return abs(lat_e7) < limit and abs(lon_e7) < limit
