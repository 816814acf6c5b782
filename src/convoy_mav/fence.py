"""The operator's airspace: an inclusion polygon, exclusion polygons, an altitude band.

Design rules:
- Pure geometry in the mission frame (north, east metres; altitude up from the
  mission origin): the config's lat/lon vertices are converted once.
- A setpoint is inside when its point is inside the inclusion polygon, outside
  every exclusion, within the altitude band and, on an arc an autopilot may fly
  as a loiter (ArduPlane), when that whole circle is too. :meth:`Fence.clamp`
  is the streamer's last line of defence: a setpoint that is not inside is
  replaced by the nearest point ``margin_m`` inside the fence, flown as a
  straight (no loiter centre), its velocity along the fence's edge; it never
  returns a point outside (property-tested).
- A convoy outside the fence is not followed out: :meth:`Fence.hold_center` gives the
  nearest centre whose whole loiter circle is inside, and :func:`orbit_setpoint` the
  setpoints of that hold (a constant-speed circle of the turn radius: flyable by every
  airframe, each UAV at its own phase and altitude layer).
- Cheap: a fence has tens of vertices, a check is a few microseconds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

from convoy_mav.config import SafetyConfig
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.types import Setpoint

__all__ = [
    "Fence",
    "Polygon",
    "fence_from",
    "fence_items",
    "join_orbit",
    "orbit_setpoint",
    "polygon_from",
]

Point = tuple[float, float]  # (north, east)


@dataclass(frozen=True, slots=True)
class Polygon:
    """A simple polygon, vertices (north, east) in order (closed implicitly)."""

    vertices: tuple[Point, ...]

    def __post_init__(self) -> None:
        if len(self.vertices) < 3:
            raise ValueError(f"a polygon needs at least 3 vertices, got {len(self.vertices)}")
        if not all(math.isfinite(c) for v in self.vertices for c in v):
            raise ValueError("polygon vertices must be finite")
        if abs(self.area) < 1.0:
            raise ValueError("polygon has no area (vertices in a line or repeated)")

    @property
    def area(self) -> float:
        """Signed area, m² (shoelace)."""
        v = self.vertices
        return 0.5 * sum(
            v[i][0] * v[(i + 1) % len(v)][1] - v[(i + 1) % len(v)][0] * v[i][1]
            for i in range(len(v))
        )

    def edges(self) -> list[tuple[Point, Point]]:
        v = self.vertices
        return [(v[i], v[(i + 1) % len(v)]) for i in range(len(v))]

    def contains(self, n: float, e: float) -> bool:
        """Even-odd rule (a point on an edge may go either way: margins keep us clear)."""
        inside = False
        for (n1, e1), (n2, e2) in self.edges():
            if (e1 > e) != (e2 > e):
                cross = n1 + (e - e1) * (n2 - n1) / (e2 - e1)
                if n < cross:
                    inside = not inside
        return inside

    def nearest(self, n: float, e: float) -> tuple[Point, Point]:
        """The nearest point of the boundary, and the unit direction of its edge."""
        best = (math.inf, (n, e), (1.0, 0.0))
        for (n1, e1), (n2, e2) in self.edges():
            dn, de = n2 - n1, e2 - e1
            length2 = dn * dn + de * de
            f = (
                0.0
                if length2 == 0.0
                else max(0.0, min(1.0, ((n - n1) * dn + (e - e1) * de) / length2))
            )
            pn, pe = n1 + f * dn, e1 + f * de
            d = math.hypot(n - pn, e - pe)
            if d < best[0]:
                length = math.sqrt(length2) or 1.0
                best = (d, (pn, pe), (dn / length, de / length))
        return best[1], best[2]

    def distance(self, n: float, e: float) -> float:
        """Distance to the boundary, metres."""
        (pn, pe), _ = self.nearest(n, e)
        return math.hypot(n - pn, e - pe)


@dataclass(frozen=True, slots=True)
class Fence:
    """Where the UAVs may fly.

    Attributes:
        inclusion: The airspace (None: anywhere horizontally).
        exclusions: Areas inside it never to enter.
        min_alt_m, max_alt_m: Altitude band above the mission origin (None: unbounded).
        margin_m: How far inside the edges a clamped setpoint is put.
    """

    inclusion: Polygon | None = None
    exclusions: tuple[Polygon, ...] = ()
    min_alt_m: float | None = None
    max_alt_m: float | None = None
    margin_m: float = 20.0

    def contains(self, n: float, e: float, margin: float = 0.0) -> bool:
        """Is (n, e) inside, at least ``margin`` from every edge?"""
        inc = self.inclusion
        if inc is not None and not (inc.contains(n, e) and inc.distance(n, e) >= margin):
            return False
        return all(not x.contains(n, e) and x.distance(n, e) >= margin for x in self.exclusions)

    def clearance(self, n: float, e: float) -> float:
        """Distance from (n, e) to the nearest edge if inside (horizontally), else -inf."""
        inc = self.inclusion
        if inc is not None and not inc.contains(n, e):
            return -math.inf
        if any(x.contains(n, e) for x in self.exclusions):
            return -math.inf
        edges = [p.distance(n, e) for p in (inc, *self.exclusions) if p is not None]
        return min(edges, default=math.inf)

    def allows(self, sp: Setpoint) -> bool:
        """Is this setpoint (point, altitude, and its loiter circle if any) inside?"""
        if not self._altitude_ok(-sp.down):
            return False
        if sp.center is not None and sp.radius > 0.0 and not sp.hold:
            return self.contains(sp.center[0], sp.center[1], sp.radius)
        return self.contains(sp.north, sp.east)

    def clamp(self, sp: Setpoint) -> Setpoint:
        """``sp`` if allowed, else the nearest setpoint ``margin_m`` inside, flown straight."""
        if self.allows(sp):
            return sp
        n, e, along = self._inside(sp.north, sp.east)
        up = -sp.down
        if self.min_alt_m is not None:
            up = max(up, self.min_alt_m)
        if self.max_alt_m is not None:
            up = min(up, self.max_alt_m)
        speed = math.hypot(sp.vn, sp.ve)
        if along is None:  # (inside already: only the altitude or the loiter circle was out)
            vn, ve = sp.vn, sp.ve
        else:  # along the fence's edge, the way the setpoint was going
            sign = 1.0 if sp.vn * along[0] + sp.ve * along[1] >= 0.0 else -1.0
            vn, ve = sign * speed * along[0], sign * speed * along[1]
        return replace(
            sp, north=n, east=e, down=-up, vn=vn, ve=ve, vd=0.0, yaw_rate=0.0,
            yaw=math.atan2(ve, vn) if speed > 0.0 else sp.yaw, center=None, radius=0.0,
        )  # fmt: skip

    def hold_center(self, n: float, e: float, radius: float) -> Point:
        """The point nearest (n, e) whose circle of ``radius`` lies ``margin_m`` inside."""
        inner = replace(self, margin_m=self.margin_m + radius)
        cn, ce, _ = inner._inside(n, e)
        return cn, ce

    def altitude_allows(self, sp: Setpoint) -> bool:
        """Is the setpoint's altitude within the band?"""
        return self._altitude_ok(-sp.down)

    def _altitude_ok(self, up: float) -> bool:
        lo, hi = self.min_alt_m, self.max_alt_m
        return (lo is None or up >= lo) and (hi is None or up <= hi)

    def _inside(self, n: float, e: float) -> tuple[float, float, Point | None]:
        """The nearest point ``margin_m`` inside, and the edge direction it was pushed from."""
        margin = self.margin_m
        along: Point | None = None
        for _ in range(8):  # (an exclusion near the edge may push back out: settle)
            if self.contains(n, e, margin):
                return n, e, along
            inc = self.inclusion
            if inc is not None and not (inc.contains(n, e) and inc.distance(n, e) >= margin):
                (pn, pe), along = inc.nearest(n, e)
                n, e = _step_in(inc, pn, pe, along, margin, inward=True)
                continue
            for x in self.exclusions:
                if x.contains(n, e) or x.distance(n, e) < margin:
                    (pn, pe), along = x.nearest(n, e)
                    n, e = _step_in(x, pn, pe, along, margin, inward=False)
                    break
        return self._fallback(n, e, along)

    def _fallback(self, n: float, e: float, along: Point | None) -> tuple[float, float, Point]:
        """A tight corner or a thin part the pushes did not settle in: the nearest of the
        points just inside every edge (a tenth of the way along it, and so on), pushed
        across it by one and by two margins (rare; about a millisecond)."""
        margin = self.margin_m
        candidates: list[Point] = []
        for poly, inward in ((self.inclusion, True), *((x, False) for x in self.exclusions)):
            if poly is None:
                continue
            for (n1, e1), (n2, e2) in poly.edges():
                length = math.hypot(n2 - n1, e2 - e1) or 1.0
                edge = ((n2 - n1) / length, (e2 - e1) / length)
                for k in range(1, 20):
                    pn, pe = n1 + (n2 - n1) * k / 20.0, e1 + (e2 - e1) * k / 20.0
                    for depth in (margin, 2.0 * margin + 1.0):
                        candidates.append(_step_in(poly, pn, pe, edge, depth, inward=inward))
        candidates.sort(key=lambda c: math.hypot(c[0] - n, c[1] - e))
        for cn, ce in candidates:
            if self.contains(cn, ce, margin):
                return cn, ce, along or (1.0, 0.0)
        raise ValueError("the fence has no room inside its margin")


def orbit_setpoint(
    t: float,
    center: Point,
    radius: float,
    speed: float,
    phase: float,
    down: float,
    *,
    clockwise: bool = True,
) -> Setpoint:
    """The setpoint at mission time ``t`` of an orbit of ``center`` flown at ``speed``,
    at angle ``phase`` (rad clockwise from north, seen from the centre) when t = 0."""
    sign = 1.0 if clockwise else -1.0
    rate = sign * speed / radius
    angle = phase + rate * t
    north = center[0] + radius * math.cos(angle)
    east = center[1] + radius * math.sin(angle)
    vn, ve = -sign * speed * math.sin(angle), sign * speed * math.cos(angle)
    return Setpoint(
        t, north, east, down, vn, ve, 0.0, math.atan2(ve, vn), rate,
        center=center, radius=radius, clockwise=clockwise,
    )  # fmt: skip


def join_orbit(
    t: float, center: Point, radius: float, speed: float, position: Point, velocity: Point
) -> tuple[float, bool]:
    """(phase, clockwise) of the orbit of ``center`` a UAV at ``position`` joins with
    least manoeuvre: turning its current way round, its setpoint abeam of it now."""
    rn, re = position[0] - center[0], position[1] - center[1]
    clockwise = rn * velocity[1] - re * velocity[0] >= 0.0
    rate = (1.0 if clockwise else -1.0) * speed / radius
    return math.atan2(re, rn) - rate * t, clockwise


def _step_in(
    poly: Polygon, pn: float, pe: float, along: Point, margin: float, *, inward: bool
) -> Point:
    """From boundary point (pn, pe) ``margin`` across the edge, into the polygon or out of it."""
    normal = (-along[1], along[0])
    probe = (pn + normal[0] * 1e-3, pe + normal[1] * 1e-3)
    if poly.contains(*probe) != inward:
        normal = (-normal[0], -normal[1])
    return pn + normal[0] * (margin + 1e-6), pe + normal[1] * (margin + 1e-6)


def polygon_from(points: Sequence[Point]) -> Polygon:
    """A polygon from (north, east) points, a repeated closing vertex dropped."""
    pts = [(float(n), float(e)) for n, e in points]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
    return Polygon(tuple(pts))


def fence_from(safety: SafetyConfig, frame: LocalFrame) -> Fence | None:
    """The config's fence in the mission frame (None when it sets no limit)."""
    if not (safety.fence or safety.exclusions) and safety.min_alt_m is safety.max_alt_m is None:
        return None

    def local(ring: Sequence[tuple[float, float]]) -> Polygon:
        return polygon_from([frame.to_ned(GeoPoint(lat, lon))[:2] for lat, lon in ring])

    return Fence(
        inclusion=local(safety.fence) if safety.fence else None,
        exclusions=tuple(local(x) for x in safety.exclusions),
        min_alt_m=safety.min_alt_m,
        max_alt_m=safety.max_alt_m,
        margin_m=safety.fence_margin_m,
    )


def fence_items(safety: SafetyConfig) -> list[tuple[int, int, float, float]]:
    """The fence as the mission protocol uploads it: (command, vertex count, lat, lon) per
    vertex, the inclusion polygon first (MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    then _EXCLUSION per exclusion); the altitude band is the autopilot's own parameters."""
    inclusion, exclusion = 5001, 5002  # MAV_CMD_NAV_FENCE_POLYGON_VERTEX_(IN|EX)CLUSION
    out = [(inclusion, len(safety.fence), lat, lon) for lat, lon in safety.fence]
    for ring in safety.exclusions:
        out += [(exclusion, len(ring), lat, lon) for lat, lon in ring]
    return out
