"""Pin the mock's flight physics: the yardstick the product's coverage is judged by."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sitl_mock.kinematics import (
    Aircraft,
    AircraftState,
    AirframeParams,
    Guidance,
    Idle,
    Loiter,
    Takeoff,
    TrackTarget,
)

PLANE = AirframeParams()  # 18 m/s, R_min 80 m
COPTER = AirframeParams(frame="copter", airspeed=12.0, min_turn_radius=5.0)


def wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def flying(params: AirframeParams, **state: float) -> Aircraft:
    """An aircraft already in the air at 50 m, flying north at cruise (copter: hovering)."""
    values: dict[str, float] = {"north": 0.0, "east": 0.0, "down": -50.0, "yaw": 0.0}
    values["speed"] = params.airspeed if params.frame == "plane" else 0.0
    values.update(state)
    return Aircraft(params, AircraftState(**values, airborne=True), ground_down=0.0)


def fly(
    ac: Aircraft, seconds: float, dt: float = 0.01, each: Callable[[], None] | None = None
) -> None:
    for _ in range(round(seconds / dt)):
        ac.step(dt)
        if each is not None:
            each()


def circle_ref(t: float, radius: float, speed: float) -> tuple[float, float, float, float]:
    """A clockwise reference circle about the origin: north, east, vn, ve at time t."""
    w = speed / radius
    th = w * t
    return (
        radius * math.cos(th),
        radius * math.sin(th),
        -speed * math.sin(th),
        speed * math.cos(th),
    )


def track_circle(
    ac: Aircraft, radius: float, speed: float, seconds: float, dt: float = 0.01, t0: float = 0.0
) -> list[tuple[float, float]]:
    """Stream 20 Hz pos+vel targets sampled from the circle; per step (tracking error, radius)."""
    out: list[tuple[float, float]] = []
    t, next_cmd = t0, t0
    s = ac.state
    for _ in range(round(seconds / dt)):
        if t >= next_cmd - 1e-9:
            n, e, vn, ve = circle_ref(t, radius, speed)
            ac.command(TrackTarget(north=n, east=e, down=-50.0, vn=vn, ve=ve))
            next_cmd += 0.05
        ac.step(dt)
        t += dt
        n, e, _, _ = circle_ref(t, radius, speed)
        out.append((math.hypot(s.north - n, s.east - e), math.hypot(s.north, s.east)))
    return out


# ---------------------------------------------------------------- value types


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("airspeed", 0.0),
        ("airspeed", math.nan),
        ("min_turn_radius", -1.0),
        ("max_climb_rate", math.inf),
        ("altitude_time_constant", 0.0),
        ("max_accel", -2.0),
        ("min_airspeed_ratio", 1.2),
        ("max_airspeed_ratio", 0.9),
        ("wind_north", math.nan),
        ("wind_east", math.inf),
    ],
)
def test_airframe_params_reject_bad_fields_by_name(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        AirframeParams(**{field: value})  # type: ignore[arg-type]


def test_airframe_params_reject_unknown_frame() -> None:
    with pytest.raises(ValueError, match="frame"):
        AirframeParams(frame="blimp")  # type: ignore[arg-type]


def test_guidance_values_validate() -> None:
    with pytest.raises(ValueError, match="radius"):
        Loiter(0.0, 0.0, -50.0, -1.0)
    with pytest.raises(ValueError, match="north"):
        Loiter(math.nan, 0.0, -50.0, 10.0)
    with pytest.raises(ValueError, match="down"):
        Takeoff(math.inf)


def test_velocity_ned_adds_wind_only_in_the_air() -> None:
    params = AirframeParams(wind_north=3.0, wind_east=-4.0)
    state = AircraftState(0.0, 0.0, 0.0, yaw=math.pi / 2, speed=10.0, climb_rate=2.0)
    vn, ve, vd = state.velocity_ned(params)
    assert (vn, ve, vd) == pytest.approx((0.0, 10.0, -2.0), abs=1e-12)
    state.airborne = True
    assert state.velocity_ned(params) == pytest.approx((3.0, 6.0, -2.0), abs=1e-12)


def test_step_rejects_negative_dt_and_ignores_zero() -> None:
    ac = flying(PLANE)
    with pytest.raises(ValueError, match="dt"):
        ac.step(-0.01)
    with pytest.raises(ValueError, match="dt"):
        ac.step(math.nan)
    ac.step(0.0)
    assert (ac.state.north, ac.state.east) == (0.0, 0.0)


def test_set_speed_validates_and_clamps() -> None:
    ac = flying(PLANE)
    with pytest.raises(ValueError, match="speed"):
        ac.set_speed(-1.0)
    ac.set_speed(1000.0)
    ac.command(Loiter(0.0, 0.0, -50.0, 200.0))
    fly(ac, 30.0, dt=0.1)
    assert ac.state.speed == pytest.approx(PLANE.max_airspeed_ratio * PLANE.airspeed)


# ------------------------------------------------------------ turn-rate bound

_coord = st.floats(-2000.0, 2000.0)
_vel = st.floats(-30.0, 30.0)
_maybe = st.one_of(st.none(), st.just(math.nan))


@st.composite
def guidance(draw: st.DrawFn) -> Guidance:
    kind = draw(st.sampled_from(["track", "track", "loiter", "takeoff", "idle"]))
    if kind == "track":
        return TrackTarget(
            north=draw(st.one_of(_maybe, _coord)),
            east=draw(st.one_of(_maybe, _coord)),
            down=draw(st.one_of(_maybe, st.floats(-300.0, 10.0))),
            vn=draw(st.one_of(_maybe, _vel)),
            ve=draw(st.one_of(_maybe, _vel)),
            vd=draw(st.one_of(_maybe, st.floats(-10.0, 10.0))),
        )
    if kind == "loiter":
        return Loiter(
            draw(_coord),
            draw(_coord),
            draw(st.floats(-300.0, 0.0)),
            draw(st.floats(0.0, 300.0)),
            draw(st.booleans()),
        )
    if kind == "takeoff":
        return Takeoff(draw(st.floats(-300.0, 0.0)))
    return Idle()


@settings(max_examples=200, deadline=None)
@given(
    frame=st.sampled_from(["plane", "copter"]),
    wind=st.tuples(st.floats(-8.0, 8.0), st.floats(-8.0, 8.0)),
    airborne=st.booleans(),
    yaw=st.floats(-math.pi, math.pi),
    plan=st.lists(
        st.tuples(guidance(), st.floats(0.005, 0.5), st.integers(1, 200)), min_size=1, max_size=5
    ),
)
def test_turn_rate_bound_holds_at_every_step(
    frame: str,
    wind: tuple[float, float],
    airborne: bool,
    yaw: float,
    plan: list[tuple[Guidance, float, int]],
) -> None:
    params = AirframeParams(
        frame=frame,  # type: ignore[arg-type]
        airspeed=15.0,
        min_turn_radius=60.0 if frame == "plane" else 8.0,
        wind_north=wind[0],
        wind_east=wind[1],
    )
    speed = params.airspeed if airborne and frame == "plane" else 0.0
    state = AircraftState(0.0, 0.0, -100.0 if airborne else 0.0, yaw, speed, airborne=airborne)
    ac = Aircraft(params, state, ground_down=0.0)
    vmin = params.min_airspeed_ratio * params.airspeed if frame == "plane" else 0.0
    vmax = params.max_airspeed_ratio * params.airspeed if frame == "plane" else params.airspeed
    for command, dt, steps in plan:
        ac.command(command)
        for _ in range(steps):
            y0, v0, n0, e0 = state.yaw, state.speed, state.north, state.east
            was_airborne = state.airborne
            ac.step(dt)
            landed = was_airborne and not state.airborne  # touchdown zeroes the speed
            bound = (v0 if landed else min(v0, state.speed)) / params.min_turn_radius
            assert abs(state.yaw_rate) <= bound * (1.0 + 1e-12) + 1e-15
            if not landed:
                assert abs(state.yaw_rate) <= ac.max_turn_rate * (1.0 + 1e-12) + 1e-15
            turned = wrap(state.yaw - y0)
            if frame == "plane" or v0 > 0.0:  # a copter at rest may point anywhere
                assert abs(turned - state.yaw_rate * dt) < 1e-9
            assert state.down <= ac.ground_down + 1e-12
            assert abs(state.climb_rate) <= params.max_climb_rate * (1.0 + 1e-9)
            if state.airborne:
                assert vmin - 1e-9 <= state.speed <= vmax + 1e-9
                assert abs(state.speed - v0) <= params.max_accel * dt + 1e-9 or v0 < vmin
                flew = was_airborne or state.airborne  # lift-off and landing steps too
                moved = math.hypot(
                    state.north - n0 - wind[0] * dt * flew, state.east - e0 - wind[1] * dt * flew
                )
                assert moved <= max(v0, state.speed) * dt * (1.0 + 1e-12) + 1e-12
            else:
                assert state.speed == 0.0
                if not landed:
                    assert (state.north, state.east) == (n0, e0)


# ------------------------------------------------------------ exact Dubins arcs


@pytest.mark.parametrize("dt", [0.01, 0.1, 0.5])
@pytest.mark.parametrize("clockwise", [True, False])
def test_saturated_turn_is_an_exact_circle_of_min_radius(dt: float, clockwise: bool) -> None:
    ac = flying(PLANE)
    s = ac.state
    # Fly due south while heading north: the wanted course is behind, so the turn saturates.
    ac.command(TrackTarget(vn=-18.0, ve=1e-3 if clockwise else -1e-3))
    ac.step(dt)
    side = 1.0 if clockwise else -1.0
    radius = s.speed / ac.max_turn_rate
    assert radius == pytest.approx(PLANE.min_turn_radius)
    assert s.yaw_rate == pytest.approx(side * ac.max_turn_rate)
    centre = (s.north - side * radius * math.sin(s.yaw), s.east + side * radius * math.cos(s.yaw))
    # Most of a half turn at the bound, checked against the centre found after one step.
    steps = round(0.7 * math.pi / (ac.max_turn_rate * dt))
    for _ in range(steps):
        ac.step(dt)
        assert math.hypot(s.north - centre[0], s.east - centre[1]) == pytest.approx(
            radius, abs=1e-6
        )
        assert abs(s.yaw_rate) == pytest.approx(ac.max_turn_rate)


def test_arc_integration_does_not_depend_on_step_size() -> None:
    finals = []
    for dt in (0.01, 0.25):
        ac = flying(PLANE)
        ac.command(Loiter(0.0, 400.0, -50.0, 80.0))
        fly(ac, 20.0, dt)
        finals.append((ac.state.north, ac.state.east, ac.state.yaw))
    # Guidance is sampled at different rates, so paths differ a little, not by dt * speed.
    assert finals[0][0] == pytest.approx(finals[1][0], abs=0.25)
    assert finals[0][1] == pytest.approx(finals[1][1], abs=0.25)


# ---------------------------------------------------------- tracking a moving circle


@pytest.mark.parametrize("offset", [50.0, -50.0])
def test_plane_converges_onto_a_commanded_moving_circle(offset: float) -> None:
    radius = 1.2 * PLANE.min_turn_radius
    n0, e0, vn0, ve0 = circle_ref(0.0, radius, PLANE.airspeed)
    ac = flying(PLANE, north=n0 + offset, east=e0, yaw=math.atan2(ve0, vn0))
    samples = track_circle(ac, radius, PLANE.airspeed, seconds=90.0)
    last_lap = samples[-3350:]  # one lap is 2 pi 96 / 18 = 33.5 s
    assert max(abs(r - radius) / radius for _, r in last_lap) < 0.02
    assert max(err for err, _ in last_lap) < 3.0
    assert max(abs(r - radius) for _, r in samples[:300]) > 20.0  # it really started off


@pytest.mark.parametrize("dt", [0.05, 0.1])
def test_circle_tracking_holds_at_coarser_steps(dt: float) -> None:
    radius = 1.2 * PLANE.min_turn_radius
    n0, e0, vn0, ve0 = circle_ref(0.0, radius, PLANE.airspeed)
    ac = flying(PLANE, north=n0 + 50.0, east=e0, yaw=math.atan2(ve0, vn0))
    samples = track_circle(ac, radius, PLANE.airspeed, seconds=90.0, dt=dt)
    last_lap = samples[-round(33.5 / dt) :]
    assert max(abs(r - radius) / radius for _, r in last_lap) < 0.02
    assert max(err for err, _ in last_lap) < 3.0


def test_copter_converges_onto_a_moving_circle_in_wind() -> None:
    params = AirframeParams(
        frame="copter", airspeed=12.0, min_turn_radius=2.0, wind_north=-3.0, wind_east=1.0
    )
    radius, speed = 30.0, 6.0
    ac = flying(params, north=radius + 60.0)
    samples = track_circle(ac, radius, speed, seconds=70.0)
    tail = samples[-3000:]
    assert max(err for err, _ in tail) < 0.5
    assert max(abs(r - radius) / radius for _, r in tail) < 0.02


def test_plane_tracks_a_ground_line_in_crosswind_by_crabbing() -> None:
    params = AirframeParams(wind_east=6.0)
    ac = flying(params, east=-40.0)
    s = ac.state
    t = 0.0
    for _ in range(1200):  # 60 s of 20 Hz targets along the north axis at 18 m/s
        ac.command(TrackTarget(north=18.0 * t, east=0.0, down=-50.0, vn=18.0, ve=0.0))
        fly(ac, 0.05)
        t += 0.05
    vn, ve, _ = s.velocity_ned(params)
    assert abs(s.east) < 0.5  # on the line
    assert ve == pytest.approx(0.0, abs=0.05)  # ground track along it...
    assert s.yaw == pytest.approx(-math.asin(6.0 / 18.0), abs=0.01)  # ...nose into the wind
    assert s.speed == pytest.approx(18.0)  # constant airspeed, so the ground speed drops
    assert vn == pytest.approx(math.sqrt(18.0**2 - 6.0**2), abs=0.05)
    assert 18.0 * t - s.north > 50.0  # and it falls behind a reference moving at 18 m/s


def test_reference_is_extrapolated_between_targets_and_repeats_are_ignored() -> None:
    ac = flying(PLANE, east=0.0)
    target = TrackTarget(north=0.0, east=0.0, down=-50.0, vn=18.0, ve=0.0)
    ac.command(target)
    for _ in range(500):
        ac.command(target)  # a duplicate does not drag the reference back
        ac.step(0.01)
    assert ac.state.north == pytest.approx(90.0, abs=1e-6)
    assert ac.state.east == pytest.approx(0.0, abs=1e-9)


# ------------------------------------------------------ velocity / position targets


def test_plane_velocity_target_sets_course_and_clamped_airspeed() -> None:
    params = AirframeParams(wind_north=4.0)
    ac = flying(params)
    ac.command(TrackTarget(vn=0.0, ve=-10.0))  # fly west at 10 m/s: below the plane's min
    fly(ac, 40.0, dt=0.02)
    vn, ve, _ = ac.state.velocity_ned(params)
    assert math.atan2(ve, vn) == pytest.approx(-math.pi / 2, abs=1e-3)  # ground course
    assert ac.state.speed == pytest.approx(params.min_airspeed_ratio * params.airspeed)


def test_copter_velocity_target_sets_ground_velocity() -> None:
    params = AirframeParams(frame="copter", airspeed=12.0, min_turn_radius=5.0, wind_east=3.0)
    ac = flying(params)
    ac.command(TrackTarget(vn=-6.0, ve=4.0))
    fly(ac, 20.0, dt=0.02)
    vn, ve, _ = ac.state.velocity_ned(params)
    assert (vn, ve) == pytest.approx((-6.0, 4.0), abs=1e-6)
    ac.command(TrackTarget(vn=0.0, ve=0.0))
    fly(ac, 20.0, dt=0.02)
    vn, ve, _ = ac.state.velocity_ned(params)
    assert (vn, ve) == pytest.approx((0.0, 0.0), abs=1e-6)  # stands still against the wind


@pytest.mark.parametrize("wind", [(0.0, 0.0), (4.0, -3.0)])
def test_copter_flies_to_a_point_and_hovers(wind: tuple[float, float]) -> None:
    params = AirframeParams(
        frame="copter", airspeed=12.0, min_turn_radius=5.0, wind_north=wind[0], wind_east=wind[1]
    )
    ac = flying(params, yaw=2.0)
    ac.command(TrackTarget(north=-150.0, east=80.0, down=-30.0))
    peak = 0.0

    def watch() -> None:
        nonlocal peak
        peak = max(peak, ac.state.speed)

    fly(ac, 60.0, each=watch)
    s = ac.state
    assert math.hypot(s.north + 150.0, s.east - 80.0) < 0.1
    assert s.down == pytest.approx(-30.0, abs=0.01)
    assert peak == pytest.approx(12.0)
    vn, ve, _ = s.velocity_ned(params)
    assert math.hypot(vn, ve) < 0.05
    assert s.speed == pytest.approx(math.hypot(*wind), abs=0.05)


def test_plane_position_target_is_flown_to_then_circled_at_min_radius() -> None:
    ac = flying(PLANE)
    ac.command(TrackTarget(north=-600.0, east=300.0))
    radii: list[float] = []
    fly(ac, 150.0, each=lambda: radii.append(math.hypot(ac.state.north + 600, ac.state.east - 300)))
    lap = radii[-2800:]  # one lap at 80 m is 28 s
    assert max(abs(r - PLANE.min_turn_radius) for r in lap) < 0.5
    assert ac.state.yaw_rate > 0.0  # clockwise
    assert ac.state.speed == pytest.approx(PLANE.airspeed)


def test_nan_fields_count_as_absent() -> None:
    ac = flying(PLANE)
    ac.command(TrackTarget(north=math.nan, east=0.0, down=-80.0, vn=math.nan, ve=5.0))
    fly(ac, 10.0, dt=0.05)
    assert ac.state.yaw_rate == 0.0  # nothing horizontal to steer by: keeps flying north
    assert ac.state.down < -75.0


# ------------------------------------------------------------------------ loiter


@pytest.mark.parametrize("clockwise", [True, False])
@pytest.mark.parametrize("frame", ["plane", "copter"])
def test_loiter_direction_and_radius(clockwise: bool, frame: str) -> None:
    params = PLANE if frame == "plane" else COPTER
    radius = 120.0 if frame == "plane" else 40.0
    ac = flying(params, north=-500.0, east=200.0, yaw=1.0)
    ac.command(Loiter(100.0, -50.0, -60.0, radius, clockwise=clockwise))
    fly(ac, 120.0)
    s = ac.state
    bearing0 = math.atan2(s.east + 50.0, s.north - 100.0)
    for _ in range(100):
        ac.step(0.01)
        assert math.hypot(s.north - 100.0, s.east + 50.0) == pytest.approx(radius, rel=0.01)
    swept = wrap(math.atan2(s.east + 50.0, s.north - 100.0) - bearing0)
    assert (swept > 0.0) == clockwise  # clockwise seen from above: bearing increases
    assert (s.yaw_rate > 0.0) == clockwise
    assert s.speed == pytest.approx(params.airspeed)
    assert s.down == pytest.approx(-60.0, abs=0.01)


def test_plane_loiter_radius_is_raised_to_min_turn_radius() -> None:
    ac = flying(PLANE)
    ac.command(Loiter(300.0, 0.0, -50.0, 10.0))
    fly(ac, 100.0, dt=0.05)
    assert math.hypot(ac.state.north - 300.0, ac.state.east) == pytest.approx(80.0, rel=0.01)


@pytest.mark.parametrize("clockwise", [True, False])
def test_a_plane_far_off_its_loiter_flies_straight_at_the_centre(clockwise: bool) -> None:
    """ArduPlane's L1 capture law beyond its L1 distance (``update_loiter``): SITL's
    planes flew 0.5 deg off the bearing to a loiter 600 m ahead in the median; the
    mock's vector field alone, 13 deg."""
    ac = flying(PLANE, yaw=2.0)
    ac.command(Loiter(1500.0, 400.0, -50.0, 150.0, clockwise=clockwise))
    fly(ac, 15.0)  # (turned onto its way)
    s = ac.state
    offsets = []
    while math.hypot(s.north - 1500.0, s.east - 400.0) > 150.0 + 4.0 * 150.0:
        ac.step(0.01)
        offsets.append(abs(wrap(s.yaw - math.atan2(400.0 - s.east, 1500.0 - s.north))))
    assert len(offsets) > 1000 and max(offsets) < math.radians(0.5)
    fly(ac, 120.0)  # and then onto the circle as before
    assert math.hypot(s.north - 1500.0, s.east - 400.0) == pytest.approx(150.0, rel=0.01)


def test_a_plane_follows_a_carrot_onto_its_line() -> None:
    """A straight leg as ArduPlane is told to fly one: a loiter 600 m ahead on the line,
    moved on each 60 m (the service's carrot). Pursuing it, the plane closes on the line
    as SITL's did (2.4 m off in the median); the vector field alone held it 26 m off."""
    ac = flying(PLANE, east=40.0)  # (40 m off the line)
    s = ac.state
    carrot = -math.inf
    off = []
    for _ in range(round(150.0 / 0.01)):
        if s.north + 600.0 - carrot >= 60.0:
            carrot = s.north + 600.0
            ac.command(Loiter(carrot, 0.0, -50.0, 150.0))
        ac.step(0.01)
        off.append(abs(s.east))
    assert all(b <= a + 1e-6 for a, b in itertools.pairwise(off[500:])), "never drifts off"
    assert off[-1] < 2.0, off[-1]


def test_copter_loiter_radius_zero_holds_position() -> None:
    ac = flying(COPTER, north=30.0, east=-20.0)
    ac.command(Loiter(0.0, 0.0, -40.0, 0.0))
    fly(ac, 40.0)
    assert math.hypot(ac.state.north, ac.state.east) < 0.1
    assert ac.state.speed < 1e-6


def test_saturated_turn_in_wind_drifts_downwind() -> None:
    params = AirframeParams(wind_north=5.0)
    ac = flying(params)
    course = math.radians(170.0)  # far to the right: a long turn at the bound
    ac.command(TrackTarget(vn=18.0 * math.cos(course), ve=18.0 * math.sin(course)))
    s = ac.state
    r = params.min_turn_radius

    def centre() -> tuple[float, float]:
        return s.north - r * math.sin(s.yaw), s.east + r * math.cos(s.yaw)

    ac.step(0.01)
    c0 = centre()
    fly(ac, 4.0)
    c1 = centre()
    assert abs(s.yaw_rate) == pytest.approx(ac.max_turn_rate)
    # The air-relative circle is exact; its centre is carried by the wind.
    assert (c1[0] - c0[0], c1[1] - c0[1]) == pytest.approx((20.0, 0.0), abs=1e-6)


@pytest.mark.parametrize(("radius", "feasible"), [(140.0, True), (80.0, False)])
def test_plane_loiter_in_wind_is_held_only_where_the_turn_allows(
    radius: float, feasible: bool
) -> None:
    # Downwind the ground speed is 23 m/s: a ground circle needs radius >= 80 (23/18)^2.
    params = AirframeParams(wind_north=5.0)
    ac = flying(params)
    ac.command(Loiter(300.0, 300.0, -50.0, radius))
    fly(ac, 150.0)
    s = ac.state
    radii: list[float] = []
    fly(ac, 60.0, each=lambda: radii.append(math.hypot(s.north - 300.0, s.east - 300.0)))
    if feasible:
        assert max(abs(x - radius) for x in radii) < 0.5
    else:
        assert max(radii) > 1.5 * radius  # blown wide on the downwind side...
        assert max(radii) < 2.5 * radius  # ...but it comes back
        assert min(radii) > 0.95 * radius


# ---------------------------------------------------------------------- altitude


def test_altitude_follows_a_first_order_lag() -> None:
    ac = flying(PLANE)
    ac.command(Loiter(0.0, 300.0, -56.0, 100.0))  # 6 m up: below the rate-limited regime
    tc = PLANE.altitude_time_constant
    fly(ac, tc)
    assert ac.state.down == pytest.approx(-56.0 + 6.0 * math.exp(-1.0), abs=1e-9)


def test_climb_rate_limit_and_step_size_independence() -> None:
    downs: list[float] = []
    for dt in (0.01, 0.7):
        ac = flying(COPTER)
        ac.command(TrackTarget(down=-150.0))
        rates: list[float] = []
        for _ in range(round(14.0 / dt)):
            ac.step(dt)
            rates.append(ac.state.climb_rate)
        assert max(rates) == pytest.approx(COPTER.max_climb_rate)
        downs.append(ac.state.down)
    # 100 m at 4 m/s is 25 s: still climbing flat out after 14 s, 56 m higher.
    assert downs[0] == pytest.approx(-106.0, abs=1e-9)
    assert downs[1] == pytest.approx(downs[0], abs=1e-9)
    ac = flying(COPTER)
    ac.command(TrackTarget(down=-60.0))
    fly(ac, 0.5)
    edge = COPTER.max_climb_rate * COPTER.altitude_time_constant  # 8 m: lag takes over
    t_sat = (10.0 - edge) / COPTER.max_climb_rate
    expected = -60.0 + edge * math.exp(-(0.5 - t_sat) / COPTER.altitude_time_constant)
    assert ac.state.down == pytest.approx(expected, abs=1e-9)


def test_vertical_velocity_target_sets_climb_rate() -> None:
    ac = flying(COPTER)
    ac.command(TrackTarget(vd=-2.0))
    fly(ac, 5.0)
    assert ac.state.down == pytest.approx(-60.0, abs=1e-9)
    assert ac.state.climb_rate == pytest.approx(2.0)
    ac.command(TrackTarget(vd=9.0))  # clamped to the climb-rate limit
    fly(ac, 1.0)
    assert ac.state.climb_rate == pytest.approx(-COPTER.max_climb_rate)
    ac.command(TrackTarget(vn=1.0, ve=0.0))  # no altitude: holds the one it has now
    fly(ac, 3.0)
    assert ac.state.down == pytest.approx(-56.0, abs=1e-9)
    assert ac.state.climb_rate == 0.0


def test_nobody_goes_below_the_ground() -> None:
    ac = flying(COPTER, down=-5.0)
    ac.command(TrackTarget(down=40.0))
    assert ac.target_down == 0.0
    downs: list[float] = []
    fly(ac, 15.0, each=lambda: downs.append(ac.state.down))
    assert max(downs) <= 0.0
    assert downs[-1] == pytest.approx(0.0, abs=0.01)
    assert ac.state.airborne  # only Idle lands


# ------------------------------------------------------------- ground and takeoff


@pytest.mark.parametrize("params", [PLANE, COPTER])
def test_idle_on_the_ground_nothing_moves_even_in_wind(params: AirframeParams) -> None:
    windy = AirframeParams(frame=params.frame, wind_north=10.0, wind_east=10.0)
    ac = Aircraft(windy, AircraftState(5.0, 6.0, -2.0, yaw=1.0, speed=3.0))
    assert isinstance(ac.guidance, Idle)
    for command in (Idle(), TrackTarget(north=100.0, east=0.0, down=-50.0, vn=5.0, ve=0.0)):
        ac.command(command)
        fly(ac, 5.0)
        s = ac.state
        assert (s.north, s.east, s.down, s.yaw) == (5.0, 6.0, -2.0, 1.0)
        assert (s.speed, s.climb_rate, s.airborne) == (0.0, 0.0, False)


def test_copter_takeoff_climbs_vertically_then_hovers() -> None:
    ac = Aircraft(COPTER, AircraftState(10.0, 20.0, 0.0, yaw=0.3, speed=0.0))
    ac.command(Takeoff(-30.0))
    fly(ac, 5.0)
    assert ac.state.airborne
    assert not ac.takeoff_complete
    assert ac.state.climb_rate == pytest.approx(COPTER.max_climb_rate)
    fly(ac, 15.0)
    s = ac.state
    assert ac.takeoff_complete
    assert (s.north, s.east, s.speed) == (10.0, 20.0, 0.0)
    assert s.down == pytest.approx(-30.0, abs=0.01)


def test_plane_takeoff_climbs_out_along_heading_then_loiters() -> None:
    heading = 0.7
    ac = Aircraft(PLANE, AircraftState(0.0, 0.0, -10.0, yaw=heading, speed=0.0))
    assert ac.ground_down == -10.0
    ac.command(Takeoff(-110.0))
    done_at: list[float] = []
    t = 0.0
    while not ac.takeoff_complete:
        ac.step(0.01)
        t += 0.01
        s = ac.state
        assert s.airborne
        assert s.yaw == heading  # straight climb-out
        assert s.speed == PLANE.airspeed
        assert math.atan2(s.east, s.north) == pytest.approx(heading)
    done_at.append(t)
    assert ac.state.down <= -105.0  # within 5 % of the 100 m climb
    # 92 m at 4 m/s, then the first-order lag from 8 m to 5 m off: no jump.
    assert done_at[0] == pytest.approx(23.0 + 2.0 * math.log(8.0 / 5.0), abs=0.02)
    # Then a clockwise circle of min radius, entered tangentially.
    s = ac.state
    centre = (s.north - 80.0 * math.sin(heading), s.east + 80.0 * math.cos(heading))
    for _ in range(2000):
        ac.step(0.01)
        assert math.hypot(s.north - centre[0], s.east - centre[1]) == pytest.approx(80.0, abs=0.05)
    assert s.yaw_rate == pytest.approx(ac.max_turn_rate)
    assert s.down == pytest.approx(-110.0, abs=0.01)


def test_plane_never_slower_than_min_airspeed_and_glides_down_on_idle() -> None:
    ac = flying(PLANE, speed=2.0)  # spawned too slow: it is flying, so it is at least vmin
    vmin = PLANE.min_airspeed_ratio * PLANE.airspeed
    ac.set_speed(0.0)
    ac.command(Loiter(0.0, 500.0, -50.0, 100.0))
    speeds: list[float] = []
    fly(ac, 20.0, each=lambda: speeds.append(ac.state.speed))
    assert min(speeds) == pytest.approx(vmin)
    ac.command(Idle())
    fly(ac, 40.0, each=lambda: speeds.append(ac.state.speed))
    s = ac.state
    assert not s.airborne  # glided down and landed
    assert s.down == 0.0
    assert s.speed == 0.0
    assert min(v for v in speeds if v > 0.0) == pytest.approx(vmin)


def test_copter_lands_in_place_on_idle() -> None:
    ac = flying(COPTER, down=-20.0)
    ac.command(Idle())
    fly(ac, 20.0)
    s = ac.state
    assert (s.airborne, s.down, s.north, s.east) == (False, 0.0, 0.0, 0.0)


def test_recommanding_every_step_is_the_same_as_commanding_once() -> None:
    # The autopilot layer re-derives its guidance every step and commands it again.
    once, every = flying(PLANE), flying(PLANE)
    takeoff = Aircraft(COPTER, AircraftState(0.0, 0.0, 0.0, 0.0, 0.0))
    target = TrackTarget(north=0.0, east=100.0, down=-60.0, vn=0.0, ve=18.0)
    once.command(target)
    takeoff.command(Takeoff(-10.0))
    for _ in range(3000):
        every.command(TrackTarget(north=0.0, east=100.0, down=-60.0, vn=0.0, ve=18.0))
        takeoff.command(Takeoff(-10.0))  # a retransmitted takeoff does not restart it
        once.step(0.01)
        every.step(0.01)
        takeoff.step(0.01)
    assert (once.state.north, once.state.east) == (every.state.north, every.state.east)
    assert takeoff.takeoff_complete


def test_an_aircraft_created_in_the_air_starts_idle_and_so_lands() -> None:
    ac = flying(COPTER, down=-3.0, north=7.0)
    assert isinstance(ac.guidance, Idle)
    assert ac.target_down == 0.0
    fly(ac, 10.0)
    assert (ac.state.airborne, ac.state.north, ac.state.down) == (False, 7.0, 0.0)
