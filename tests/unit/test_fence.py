"""The fence: inside tests, the clamp (never a setpoint outside), the config's forms."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.config import SafetyConfig, parse_config
from convoy_mav.errors import ConfigError
from convoy_mav.fence import Fence, Polygon, fence_from, join_orbit, orbit_setpoint, polygon_from
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.planning import PlanRequest, make_plan
from convoy_mav.schedule import setpoint_at
from convoy_mav.types import Setpoint

SQUARE = polygon_from([(-1000, -1000), (-1000, 1000), (1000, 1000), (1000, -1000)])
HOLE = polygon_from([(100, 100), (100, 300), (300, 300), (300, 100)])
FENCE = Fence(SQUARE, (HOLE,), min_alt_m=50.0, max_alt_m=400.0, margin_m=20.0)


def _sp(n: float, e: float, up: float = 100.0, **kw: object) -> Setpoint:
    return Setpoint(0.0, n, e, -up, 10.0, 5.0, 0.0, 0.5, 0.0, **kw)  # type: ignore[arg-type]


def test_inside_outside_holes_and_the_altitude_band() -> None:
    assert FENCE.allows(_sp(0.0, 0.0))
    assert not FENCE.allows(_sp(1500.0, 0.0))
    assert not FENCE.allows(_sp(200.0, 200.0))  # in the exclusion
    assert not FENCE.allows(_sp(0.0, 0.0, up=600.0))
    assert not FENCE.allows(_sp(0.0, 0.0, up=10.0))
    # A loiter circle (ArduPlane flies arcs as loiters) must fit whole.
    assert not FENCE.allows(_sp(900.0, 0.0, center=(900.0, 0.0), radius=150.0))
    assert FENCE.allows(_sp(500.0, -500.0, center=(500.0, -500.0), radius=150.0))


def test_clamp_puts_the_setpoint_on_the_edge_flown_straight() -> None:
    out = FENCE.clamp(_sp(1500.0, 0.0, up=600.0, center=(1500.0, 0.0), radius=150.0))
    assert out.north == pytest.approx(980.0, abs=0.01) and out.east == pytest.approx(0.0)
    assert -out.down == 400.0 and out.center is None and out.radius == 0.0
    assert out.vn == pytest.approx(0.0, abs=1e-9) and abs(out.ve) == pytest.approx(
        math.hypot(10, 5)
    )
    inside = _sp(0.0, 0.0)
    assert FENCE.clamp(inside) is inside  # (untouched: the streamer counts identity)
    hole = FENCE.clamp(_sp(150.0, 200.0))  # nearest exit of the hole: its north... south edge
    assert FENCE.allows(hole) and hole.north == pytest.approx(80.0, abs=0.01)


def _star(rng: np.random.Generator, n: int, radius: float) -> Polygon:
    angles = np.sort(rng.uniform(0, 2 * math.pi, n))
    radii = rng.uniform(0.5 * radius, radius, n)
    return polygon_from(
        [(r * math.cos(a), r * math.sin(a)) for a, r in zip(angles, radii, strict=True)]
    )


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.floats(-6000, 6000),
    e=st.floats(-6000, 6000),
    up=st.floats(-100, 2000),
    radius=st.sampled_from([0.0, 80.0, 150.0]),
)
def test_clamp_never_returns_a_setpoint_outside(
    seed: int, n: float, e: float, up: float, radius: float
) -> None:
    rng = np.random.default_rng(seed)
    hole = _star(rng, 6, 300.0)
    shift = rng.uniform(-800, 800, 2)
    hole = polygon_from([(a + shift[0], b + shift[1]) for a, b in hole.vertices])
    fence = Fence(_star(rng, int(rng.integers(5, 12)), 3000.0), (hole,), 30.0, 500.0, 25.0)
    sp = _sp(n, e, up, center=(n, e) if radius else None, radius=radius)
    assert fence.allows(fence.clamp(sp))


@pytest.mark.parametrize("speed", [0.0, 6.0])
def test_every_setpoint_of_a_plan_is_kept_inside(speed: float) -> None:
    """Sampled from the paper's plans over a long stretch: clamped, each one is inside."""
    plan = make_plan(PlanRequest(150.0, 100.0, 18.0, convoy_speed=speed))
    fence = Fence(polygon_from([(-200, -200), (-200, 900), (200, 900), (200, -200)]), margin_m=30.0)
    clamped = 0
    for k in range(len(plan.vehicles)):
        for t in np.arange(0.0, 300.0, 0.5).tolist():
            sp = setpoint_at(plan, k, t, plan_origin=(0.0, 0.0), plan_t0=0.0, down=-100.0)
            out = fence.clamp(sp)
            clamped += out is not sp
            assert fence.allows(out)
    assert clamped > 0  # (the fence cuts the plans: the clamp was exercised)


@settings(max_examples=200, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.floats(-6000, 6000),
    e=st.floats(-6000, 6000),
    radius=st.sampled_from([60.0, 150.0]),
)
def test_the_hold_circle_nearest_a_convoy_outside_is_inside_whole(
    seed: int, n: float, e: float, radius: float
) -> None:
    """Wherever the convoy is, the hold circle (the turn radius) fits inside the fence,
    clear of its holes, by the margin; its setpoints are allowed and flyable."""
    rng = np.random.default_rng(seed)
    hole = _star(rng, 6, 300.0)
    fence = Fence(_star(rng, int(rng.integers(5, 12)), 3000.0), (hole,), margin_m=25.0)
    try:
        centre = fence.hold_center(n, e, radius)
    except ValueError:  # (a star too thin for the circle: the app then clamps)
        return
    assert fence.contains(*centre, radius + 25.0 - 1e-6)
    for clockwise in (True, False):
        for t in np.linspace(0.0, 120.0, 25).tolist():
            sp = orbit_setpoint(t, centre, radius, 18.0, 0.3, -100.0, clockwise=clockwise)
            assert fence.allows(sp)
            assert math.hypot(sp.vn, sp.ve) == pytest.approx(18.0)
            assert abs(sp.yaw_rate) == pytest.approx(18.0 / radius)  # (curvature 1/R)
            assert math.dist((sp.north, sp.east), centre) == pytest.approx(radius)


def test_the_hold_centre_is_the_nearest_with_room() -> None:
    """A convoy 500 m north of the square fence: the circle's centre is R + margin
    inside its north edge, straight south of the convoy."""
    centre = FENCE.hold_center(1500.0, 0.0, 150.0)
    assert centre == pytest.approx((1000.0 - 170.0, 0.0), abs=0.01)


def test_orbit_velocity_is_the_position_derivative() -> None:
    for clockwise in (True, False):
        a = orbit_setpoint(10.0, (5.0, -7.0), 150.0, 18.0, 1.0, -90.0, clockwise=clockwise)
        b = orbit_setpoint(10.001, (5.0, -7.0), 150.0, 18.0, 1.0, -90.0, clockwise=clockwise)
        assert (b.north - a.north) / 0.001 == pytest.approx(a.vn, rel=1e-3)
        assert (b.east - a.east) / 0.001 == pytest.approx(a.ve, rel=1e-3)
        assert a.yaw == pytest.approx(math.atan2(a.ve, a.vn))
        assert (a.yaw_rate > 0.0) == clockwise and a.clockwise == clockwise


@pytest.mark.parametrize(("velocity", "clockwise"), [((0.0, 18.0), True), ((0.0, -18.0), False)])
def test_a_uav_joins_the_hold_turning_its_own_way_from_abeam(
    velocity: tuple[float, float], clockwise: bool
) -> None:
    """A UAV 400 m north of the centre flying east turns clockwise (seen from above),
    flying west anticlockwise; its setpoint starts abeam of it, due north of the centre."""
    phase, cw = join_orbit(50.0, (0.0, 0.0), 150.0, 18.0, (400.0, 0.0), velocity)
    assert cw is clockwise
    sp = orbit_setpoint(50.0, (0.0, 0.0), 150.0, 18.0, phase, -100.0, clockwise=cw)
    assert (sp.north, sp.east) == pytest.approx((150.0, 0.0), abs=1e-6)
    assert sp.ve * velocity[1] > 0.0  # (the way it was already going)


def test_the_config_gives_a_fence_as_points_or_geojson(tmp_path: Path) -> None:
    ring = [[47.40, 8.54], [47.40, 8.56], [47.39, 8.56], [47.39, 8.54]]
    cfg = parse_config(
        {"mission": {"sensor_radius_m": 100.0}, "safety": {"fence": ring, "max_alt_m": 300.0}}
    )
    frame = LocalFrame(GeoPoint(47.395, 8.55))
    fence = fence_from(cfg.safety, frame)
    assert fence is not None and fence.inclusion is not None and fence.max_alt_m == 300.0
    assert fence.contains(0.0, 0.0) and not fence.contains(2000.0, 0.0)
    geo = tmp_path / "fence.geojson"
    outer = [[p[1], p[0]] for p in ring] + [[ring[0][1], ring[0][0]]]
    hole = [[8.549, 47.394], [8.551, 47.394], [8.551, 47.396], [8.549, 47.396], [8.549, 47.394]]
    polygon = {"type": "Polygon", "coordinates": [outer, hole]}
    geo.write_text(json.dumps({"type": "Feature", "geometry": polygon}))
    toml = tmp_path / "m.toml"
    toml.write_text('[mission]\nsensor_radius_m = 100.0\n[safety]\nfence_file = "fence.geojson"\n')
    from convoy_mav.config import load_config

    fenced = fence_from(load_config(toml).safety, frame)
    assert fenced is not None and len(fenced.exclusions) == 1
    assert not fenced.contains(0.0, 0.0)  # (the hole is round the centre)
    assert fence_from(SafetyConfig(), frame) is None
    for bad, needle in (
        ({"fence": [[47.0, 8.0], [47.1, 8.0]]}, "3..1000 vertices"),
        ({"fence": [[95.0, 8.0], [47.1, 8.0], [47.1, 8.1]]}, "out of range"),
        ({"min_alt_m": 300.0, "max_alt_m": 100.0}, "below max_alt_m"),
    ):
        with pytest.raises(ConfigError, match=needle):
            parse_config({"mission": {"sensor_radius_m": 1.0}, "safety": bad})
