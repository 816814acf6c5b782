"""The convoy forecast over a re-plan's horizon, and the watch that weighs paths on it."""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt
import pytest

from convoy_mav.mission.convoy_model import ConvoyModel
from convoy_mav.mission.forecast import KEEP_STEP, Forecast, Hedge, Watch
from convoy_mav.planning.dubins import Pose, Segment, Turn
from convoy_mav.planning.pattern import PatternClock
from convoy_mav.planning.plan import Trajectory
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import junction
from convoy_mav.types import ConvoyDrive, ConvoyEstimate

CORNER_AT = 600.0  # m up the junction's road (north), where it turns 90 deg left (west)
JUNCTION = junction(25.0, 90.0, CORNER_AT)
ROUTE = Road.from_points(JUNCTION.true_east, JUNCTION.true_north)
SHARP = 0.04  # 1/m: the junction's 12-m corner, not the road's straights


def _model(route: Road | None, along: float, speed: float) -> ConvoyModel:
    """A convoy ``along`` metres up the junction's road (north), at ``speed`` m/s."""
    model = ConvoyModel(route)
    model.observe(ConvoyEstimate(0.0, along, 0.0, speed, 0.0))
    return model


def test_a_convoy_may_stop_short_of_the_sharp_corner_ahead() -> None:
    times = np.arange(0.0, 120.0, 0.5)
    model = _model(ROUTE, 200.0, 8.0)
    on_x, on_y = model.positions(times)
    short = model.stopping_short(times, SHARP, 5.0)
    assert short is not None
    sx, sy = short
    # The same convoy until it reaches the corner, then parked short of it, while the
    # route's convoy turns it (west) and drives on.
    before = times < 40.0
    assert np.allclose(sx[before], on_x[before]) and np.allclose(sy[before], on_y[before])
    assert np.ptp(sx[times > 60.0]) == 0.0 and np.ptp(sy[times > 60.0]) == 0.0
    parked = ROUTE.project(float(sx[-1]), float(sy[-1]))
    assert CORNER_AT - 25.0 < parked < CORNER_AT
    assert on_x[-1] < -300.0 < sx[-1]


def test_no_other_course_without_a_sharp_corner_within_reach() -> None:
    times = np.arange(0.0, 120.0, 0.5)
    assert _model(None, 200.0, 8.0).stopping_short(times, SHARP, 5.0) is None  # no route
    assert _model(ROUTE, 200.0, 0.0).stopping_short(times, SHARP, 5.0) is None  # stopped
    soon = np.arange(0.0, 20.0, 0.5)  # 160 m: not as far as the corner
    assert _model(ROUTE, 200.0, 8.0).stopping_short(soon, SHARP, 5.0) is None
    straight = Road.straight(0.0, 0.0, 0.0, 5000.0)
    model = ConvoyModel(straight)
    model.observe(ConvoyEstimate(0.0, 0.0, 100.0, 0.0, 8.0))  # (east, along the road)
    assert model.stopping_short(times, SHARP, 5.0) is None
    # In the corner already, the convoy turns it: no other sharp corner follows.
    inside = _model(ROUTE, CORNER_AT + 2.0, 8.0)
    assert inside.stopping_short(times, SHARP, 5.0) is None


HEDGE = Hedge(SHARP, 5.0, 1.5, 1.0, 0.5)


def _forecast(model: ConvoyModel, *, hedged: bool) -> Forecast:
    clock = PatternClock(0.0, 0.0, 8.0)
    return Forecast(clock, model, 0.0, 120.0, 183.0, 18.0, hedge=HEDGE if hedged else None)


def test_a_watch_weighs_paths_on_both_courses_once_they_part() -> None:
    near = _forecast(_model(ROUTE, 500.0, 8.0), hedged=True)  # the corner 12 s ahead
    assert near.other is not None
    watch = Watch(near, 40.0, 100.0)
    assert len(watch.times) == 2 * (round(40.0 / KEEP_STEP) + 1)
    assert np.all(np.diff(watch.times) >= 0.0)
    # A UAV circling where the convoy parks sees that course, not the one driving on.
    x, y = near.other[0][-1], near.other[1][-1]
    lap = 2.0 * np.pi * 60.0 / 18.0
    circle = Segment(Pose(float(x) + 60.0, float(y), np.pi / 2), Turn.LEFT, 60.0, 18.0, lap)
    seen = watch.sees(Trajectory(0.0, (circle,)))
    parked_course = seen[1::2]
    assert parked_course[-5:].all() and not seen[0::2][-5:].any()
    assert watch.seconds(seen) == pytest.approx(KEEP_STEP * int(np.count_nonzero(seen)))
    # Far from the corner the courses agree over the watch: one course, as without.
    far = Watch(_forecast(_model(ROUTE, 100.0, 8.0), hedged=True), 40.0, 100.0)
    plain = Watch(_forecast(_model(ROUTE, 100.0, 8.0), hedged=False), 40.0, 100.0)
    assert np.array_equal(far.times, plain.times) and np.array_equal(far.cx, plain.cx)


def test_a_standing_convoy_may_drive_off_along_its_route() -> None:
    times = np.arange(0.0, 60.0, 0.5)
    model = _model(ROUTE, 200.0, 8.0)  # driving: its speed is what it drives off back up to
    model.observe(ConvoyEstimate(10.0, 280.0, 0.0, 0.9, 0.0))  # standing (GPS noise: 0.9 m/s)
    off = model.driving_off(times + 10.0, 1.5, 1.0)
    assert off is not None
    gone = np.array([ROUTE.project(float(x), float(y)) for x, y in zip(*off, strict=True)]) - 280.0
    # Up to 8 m/s at 1 m/s^2 (32 m in 8 s), then 8 m/s along the route, round its corner.
    assert gone[times == 8.0][0] == pytest.approx(32.0, abs=0.5)
    assert gone[-1] == pytest.approx(32.0 + 8.0 * (times[-1] - 8.0), abs=1.0)
    assert off[0][-1] < -50.0  # west: past the corner at 600 m


def test_no_drive_off_course_when_driving_off_route_or_never_seen_driving() -> None:
    times = np.arange(0.0, 60.0, 0.5)
    assert _model(ROUTE, 200.0, 8.0).driving_off(times, 1.5, 1.0) is None  # driving
    assert _model(ROUTE, 200.0, 0.0).driving_off(times, 1.5, 1.0) is None  # never drove
    assert _model(None, 200.0, 0.0).driving_off(times, 1.5, 1.0) is None  # no route
    with pytest.raises(ValueError, match="accel"):
        _model(ROUTE, 200.0, 0.0).driving_off(times, 1.5, 0.0)


def test_a_watch_weighs_the_drive_off_course_at_its_weight() -> None:
    model = _model(ROUTE, 200.0, 8.0)
    model.observe(ConvoyEstimate(0.0, 280.0, 0.0, 0.0, 0.0))  # stopped, 320 m short of the corner
    hedged = _forecast(model, hedged=True)
    assert hedged.other is not None and hedged.other_weight == 0.5
    watch = Watch(hedged, 40.0, 100.0)
    # A UAV circling over where the convoy stands sees that course throughout and the
    # drive-off course until it has pulled away: seconds of the second count half.
    lap = 2.0 * np.pi * 60.0 / 18.0
    circle = Segment(Pose(60.0, 280.0, np.pi / 2), Turn.LEFT, 60.0, 18.0, lap)
    seen = watch.sees(Trajectory(0.0, (circle,)))
    standing, driving = seen[0::2], seen[1::2]
    assert standing.all() and driving[:5].all() and not driving[-5:].any()
    half = KEEP_STEP * (np.count_nonzero(standing) + 0.5 * np.count_nonzero(driving))
    assert watch.seconds(seen) == pytest.approx(half)
    # Without the hedge: the standing convoy alone, every second whole.
    plain = Watch(_forecast(model, hedged=False), 40.0, 100.0)
    assert len(plain.times) == len(watch.times) // 2
    assert plain.seconds(plain.sees(Trajectory(0.0, (circle,)))) == KEEP_STEP * len(plain.times)


def test_a_standing_convoy_s_pattern_is_laid_between_standing_and_driving_off() -> None:
    model = _model(ROUTE, 200.0, 8.0)
    model.observe(ConvoyEstimate(0.0, 280.0, 0.0, 0.0, 0.0))  # stopped, 320 m short of the corner
    blend = Hedge(SHARP, 5.0, 1.5, 1.0, 0.5, drive_off_blend=0.5)
    forecast = Forecast(PatternClock(0.0, 0.0, 0.0), model, 0.0, 120.0, 183.0, 18.0, hedge=blend)
    assert forecast.other is not None
    ox, oy = forecast.other
    # The convoy as forecast stands; the pattern's centre is halfway to it driving off.
    assert np.ptp(forecast.cy) == 0.0
    assert np.allclose(forecast.py, 0.5 * (forecast.cy + oy))
    assert np.allclose(forecast.px, 0.5 * (forecast.cx + ox))
    # Every meeting is at the centre; one within ~30 s sees the convoy either way.
    near = 0
    for offset in np.linspace(0.0, 1.0, 6, endpoint=False):
        pattern = forecast.pattern(float(offset))
        for tm in forecast.meetings(float(offset), 3.0):
            ux, uy = (float(a[0]) for a in pattern(np.array([tm])))
            cx, cy = (float(a[0]) for a in forecast.centre(np.array([tm])))
            assert np.hypot(ux - cx, uy - cy) < 1.0
            if tm <= 28.0:
                near += 1
                k = round(tm / 0.5)
                assert np.hypot(ux - forecast.cx[k], uy - forecast.cy[k]) <= 100.0
                assert np.hypot(ux - ox[k], uy - oy[k]) <= 100.0
    assert near >= 2
    # Unblended (and the watch either way): the standing convoy.
    plain = Forecast(PatternClock(0.0, 0.0, 0.0), model, 0.0, 120.0, 183.0, 18.0, hedge=HEDGE)
    assert np.array_equal(plain.px, plain.cx) and np.array_equal(plain.py, plain.cy)
    assert np.array_equal(Watch(forecast, 40.0, 100.0).cy, Watch(plain, 40.0, 100.0).cy)


def test_a_driving_convoy_s_pattern_is_laid_round_it_as_forecast() -> None:
    blend = Hedge(SHARP, 5.0, 1.5, 1.0, 0.5, drive_off_blend=0.5)
    near = Forecast(
        PatternClock(0.0, 0.0, 8.0), _model(ROUTE, 500.0, 8.0), 0.0, 120.0, 183.0, 18.0, hedge=blend
    )
    assert near.other is not None  # (it may stop short of the corner: not blended)
    assert np.array_equal(near.px, near.cx) and np.array_equal(near.py, near.cy)


STRAIGHT = Road.straight(0.0, 0.0, 0.0, 20000.0)  # east from the origin


def _driven(
    speeds: list[tuple[float, float]],
    *,
    relax_s: float = 30.0,
    holds: list[tuple[float, float]] | None = None,
    paces: list[tuple[float, float]] | None = None,
) -> ConvoyModel:
    """A convoy along ``STRAIGHT`` that drove each (seconds, m/s) in turn, an estimate a
    second; with ``holds``, the route's planned holds (arc length, seconds), and with
    ``paces`` its planned speeds (arc length, m/s from there)."""
    model = ConvoyModel(STRAIGHT, relax_s=relax_s, mean_window_s=120.0)
    if holds is not None or paces is not None:
        model.set_route(STRAIGHT, holds or (), speeds=paces or ())
    t = along = 0.0
    for seconds, speed in speeds:
        for _ in range(round(seconds)):
            model.observe(ConvoyEstimate(t, 0.0, along, 0.0, speed))
            t, along = t + 1.0, along + speed
    return model


def _ahead(model: ConvoyModel, dt: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Metres along ``STRAIGHT`` the model puts the convoy ``dt`` after its estimate."""
    est = model.estimate
    assert est is not None
    x, _ = model.positions(est.t + dt)
    return np.asarray(x - est.east)


def test_a_convoy_faster_than_its_recent_mean_is_forecast_to_slow_to_it() -> None:
    model = _driven([(90.0, 4.0), (40.0, 12.0)])  # the last 120 s: 4 m/s, then 12
    mean = model.mean_speed
    assert mean is not None and 4.0 < mean < 12.0
    dt = np.array([0.5, 10.0, 30.0, 120.0, 600.0])
    gone = _ahead(model, dt)
    expected = mean * dt + (12.0 - mean) * 30.0 * (1.0 - np.exp(-dt / 30.0))
    assert gone == pytest.approx(expected, abs=1e-6)
    # At its own speed at first, at the mean in the end, never faster than either.
    assert gone[0] == pytest.approx(6.0, abs=0.05)
    assert np.diff(gone[-2:])[0] / 480.0 == pytest.approx(mean, rel=1e-3)
    assert (gone < 12.0 * dt).all() and (np.diff(gone) > 0).all()
    # The same forecast one point at a time.
    est = model.estimate
    assert est is not None
    assert model.position(est.t + 30.0)[0] == pytest.approx(est.east + gone[2])


def test_a_steady_or_slowing_convoy_is_forecast_at_its_speed() -> None:
    dt = np.arange(0.0, 300.0, 5.0)
    steady = _driven([(200.0, 10.0)])
    assert _ahead(steady, dt) == pytest.approx(10.0 * dt)
    # Slower than its mean (a queue): it may stay so, never forecast back up.
    slowed = _driven([(100.0, 12.0), (10.0, 2.0)])
    assert _ahead(slowed, dt) == pytest.approx(2.0 * dt)
    # Relaxation off: held at its speed, as with no route.
    held = _driven([(90.0, 4.0), (40.0, 12.0)], relax_s=0.0)
    assert _ahead(held, dt) == pytest.approx(12.0 * dt)
    # Seen for less than a window: its start is not its pace.
    started = _driven([(60.0, 4.0), (40.0, 12.0)])
    assert started.mean_speed is None
    assert _ahead(started, dt) == pytest.approx(12.0 * dt)


def test_the_mean_speed_forgets_what_is_older_than_its_window() -> None:
    model = _driven([(100.0, 2.0), (200.0, 12.0)])  # the slow part left the window
    assert model.mean_speed == pytest.approx(12.0)
    assert _ahead(model, np.array([60.0])) == pytest.approx([720.0])
    for bad in ({"relax_s": -1.0}, {"mean_window_s": 0.0}, {"relax_s": math.nan}):
        with pytest.raises(ValueError, match="must be"):
            ConvoyModel(STRAIGHT, **bad)


# ----------------------------------------------------------------- planned holds


def _holding(hold_at: float, hold_s: float, speeds: list[tuple[float, float]]) -> ConvoyModel:
    """``_driven`` on a route with one planned hold."""
    return _driven(speeds, holds=[(hold_at, hold_s), (1e9, 0.0)])  # (no hold of 0 s)


def test_a_convoy_driving_to_a_planned_hold_is_forecast_to_brake_stand_and_pull_away() -> None:
    model = _holding(500.0, 60.0, [(10.0, 8.0)])  # at 72 m, 8 m/s, the hold 428 m on
    dt = np.arange(0.0, 160.0, 1.0)
    arc = _ahead(model, dt) + 72.0
    # 428 m at 8 m/s, the last 32 m braking at 1 m/s^2: stopped at 500 m 57.5 s on ...
    assert arc[50] == pytest.approx(72.0 + 8.0 * 50.0, abs=0.5)
    assert np.all(np.abs(arc[58:117] - 500.0) < 1e-6)
    # ... stands its 60 s, then pulls away at 1 m/s^2 up to the 8 m/s it drove at.
    assert arc[120] > 500.0 and arc[159] - arc[158] == pytest.approx(8.0, abs=0.01)
    assert np.all(np.diff(arc) >= -1e-9)  # never backwards
    plain = _driven([(10.0, 8.0)])  # without the plan: on at its speed (relaxed to its mean)
    assert _ahead(plain, dt)[100] > 700.0


def test_standing_at_a_planned_hold_the_convoy_goes_when_its_time_is_up() -> None:
    model = _holding(80.0, 60.0, [(10.0, 8.0), (20.0, 0.0)])  # there, standing 20 s
    dt = np.arange(0.0, 80.0, 1.0)
    arc = _ahead(model, dt)
    # Standing since the estimate at t = 10 (the 20th is t = 29): 60 s from t = 10.
    assert np.all(np.abs(arc[:41]) < 1e-6)
    assert arc[45] > 0.5
    # Its driving off now is still weighed (the plan's time against the tracker's).
    assert model.driving_off(model.estimate.t + dt, 1.5, 1.0) is not None  # type: ignore[union-attr]


def test_a_hold_stood_at_and_left_is_not_planned_again() -> None:
    model = _holding(80.0, 30.0, [(10.0, 8.0), (30.0, 0.0), (2.0, 4.0)])
    dt = np.arange(0.0, 60.0, 1.0)
    arc = _ahead(model, dt)
    assert arc[30] > 100.0  # driving on: no second stand at 80 m


@pytest.mark.parametrize("circuit", [True, False])
def test_a_hold_on_a_circuit_given_as_one_lap_is_planned_again_on_every_lap(circuit: bool) -> None:
    # A 1.6-km square circuit given as one lap, its hold of 30 s 600 m round; the convoy
    # drives it at 8 m/s and stands its 30 s there each lap. Known as a circuit (a DO_JUMP
    # mission's) it is lapped at once; else it is found again on the next lap.
    corners = [(0.0, 0.0), (400.0, 0.0), (400.0, 400.0), (0.0, 400.0), (0.0, 0.0)]
    pairs = list(itertools.pairwise(corners))
    xs = np.concatenate([np.linspace(a[0], b[0], 81)[:-1] for a, b in pairs] + [[0.0]])
    ys = np.concatenate([np.linspace(a[1], b[1], 81)[:-1] for a, b in pairs] + [[0.0]])
    lap = Road.from_points(xs, ys)
    hold = lap.project(400.0, 200.0)
    model = ConvoyModel(lap)
    model.set_route(lap, [(hold, 30.0)], circuit=circuit)
    t, run = 0.0, 0.0  # (seconds, metres driven)

    def drive(seconds: float, speed: float) -> None:
        nonlocal t, run
        for _ in range(round(seconds)):
            x, y, h, _ = lap.arrays(np.array([run % lap.length]))
            v = (speed * math.cos(h[0]), speed * math.sin(h[0]))
            model.observe(ConvoyEstimate(t, float(y[0]), float(x[0]), v[1], v[0]))
            t, run = t + 1.0, run + speed

    drive(hold / 8.0, 8.0)
    drive(30.0, 0.0)  # its hold, lap 1
    drive((lap.length - hold + 450.0) / 8.0, 8.0)  # round to 450 m into lap 2
    est = model.estimate
    assert est is not None and math.hypot(est.east - 400.0, est.north - 50.0) < 10.0
    assert model.counters["laps" if circuit else "found_again"] == 1
    # Forecast to stand at the hold (150 m on) from about 19 s to 49 s on, not drive past.
    x, y = model.positions(est.t + np.array([25.0, 45.0, 80.0]))
    assert math.hypot(x[0] - 400.0, y[0] - 200.0) < 5.0
    assert math.hypot(x[1] - 400.0, y[1] - 200.0) < 5.0
    assert y[2] > 300.0


def test_a_circuit_closing_on_a_straight_is_lapped_at_its_end() -> None:
    # The lap starts and ends half-way along a side: past the end, the straight on
    # from it is the next lap's first metres, as near; it is the next lap.
    corners = [(200.0, 0.0), (400.0, 0.0), (400.0, 400.0), (0.0, 400.0), (0.0, 0.0), (200.0, 0.0)]
    pairs = list(itertools.pairwise(corners))
    xs = np.concatenate([np.linspace(a[0], b[0], 41)[:-1] for a, b in pairs] + [[200.0]])
    ys = np.concatenate([np.linspace(a[1], b[1], 41)[:-1] for a, b in pairs] + [[0.0]])
    lap = Road.from_points(xs, ys)
    model = ConvoyModel(lap)
    model.set_route(lap, circuit=True)
    for k, x in enumerate(np.arange(150.0, 260.0, 8.0)):  # east along the bottom side
        model.observe(ConvoyEstimate(float(k), 0.0, float(x), 0.0, 8.0))
        assert model.motion is not None and model.motion.on_route
    assert model.counters["laps"] == 1 and model.counters["found_again"] == 0
    x, _ = model.positions(np.array([13.0 + 10.0]))
    assert x[0] == pytest.approx(254.0 + 80.0, abs=2.0)  # (on round the lap, not parked)


def test_a_circuit_is_forecast_round_into_its_next_lap() -> None:
    square = [(0.0, 0.0), (400.0, 0.0), (400.0, 400.0), (0.0, 400.0), (0.0, 0.0)]
    pairs = list(itertools.pairwise(square))
    xs = np.concatenate([np.linspace(a[0], b[0], 81)[:-1] for a, b in pairs] + [[0.0]])
    ys = np.concatenate([np.linspace(a[1], b[1], 81)[:-1] for a, b in pairs] + [[0.0]])
    lap = Road.from_points(xs, ys)
    near_end = ConvoyEstimate(0.0, 50.0, 0.0, -8.0, 0.0)  # 50 m short of the end, south
    for circuit, where in ((True, (0.0 + 8.0 * 20.0 - 50.0, 0.0)), (False, (0.0, 0.0))):
        model = ConvoyModel(lap)
        model.set_route(lap, circuit=circuit)
        model.observe(near_end)
        x, y = model.positions(np.array([20.0]))  # 160 m on: round the corner, or parked
        assert math.hypot(x[0] - where[0], y[0] - where[1]) < 15.0


def test_a_planned_speed_change_ahead_is_driven_from_its_place() -> None:
    dt = np.arange(0.0, 120.0, 1.0)
    # At 4 m/s from 0 m (t = 9: at 36 m), 12 m/s planned from 500 m: 4 m/s to there
    # (116 s on), then up at 1 m/s^2 to 12.
    faster = _driven([(10.0, 4.0)], relax_s=0.0, paces=[(0.0, 4.0), (500.0, 12.0)])
    arc = _ahead(faster, dt) + 36.0
    assert arc[100] == pytest.approx(436.0, abs=0.5)
    assert arc[119] - arc[118] > 4.5
    # At 12 m/s, 4 m/s planned from 500 m: on at 12 to there (32.7 s on), then down at
    # 1 m/s^2 to 4 (8 s, 64 m), on at 4.
    slower = _driven([(10.0, 12.0)], relax_s=0.0, paces=[(500.0, 4.0)])
    arc = _ahead(slower, dt) + 108.0
    assert arc[30] == pytest.approx(468.0, abs=0.5)
    assert np.diff(arc)[45:] == pytest.approx(4.0, abs=0.01)
    assert arc[60] == pytest.approx(564.0 + 4.0 * (60.0 - 40.67), abs=1.0)  # (0.25-s grid)
    # A planned speed in force: driving at 6 m/s where 10 is planned, it speeds up to it.
    rising = _driven([(10.0, 6.0)], relax_s=0.0, paces=[(0.0, 10.0)])
    arc = _ahead(rising, dt)
    assert arc[10] == pytest.approx(6.0 * 4.0 + 0.5 * 16.0 + 10.0 * 6.0, abs=0.5)


def test_a_hold_pulls_away_to_the_planned_speed_from_it() -> None:
    paces = [(0.0, 5.0), (200.0, 10.0)]
    model = _driven([(20.0, 5.0)], relax_s=0.0, holds=[(200.0, 20.0)], paces=paces)
    dt = np.arange(0.0, 120.0, 1.0)
    arc = _ahead(model, dt) + 95.0
    # 105 m at 5 m/s (braking the last 12.5 m), 20 s held, then up to 10 m/s.
    assert np.all(np.abs(arc[25:40] - 200.0) < 1e-6)
    assert arc[119] - arc[118] == pytest.approx(10.0, abs=0.01)


def test_a_hold_is_not_planned_for_a_convoy_off_its_route_or_without_a_plan() -> None:
    off = _holding(500.0, 60.0, [(10.0, 8.0)])
    off.observe(ConvoyEstimate(10.0, 200.0, 88.0, 0.0, 8.0))  # 200 m off the road
    off.observe(ConvoyEstimate(16.0, 200.0, 136.0, 0.0, 8.0))
    x, _ = off.positions(np.array([16.0 + 100.0]))
    assert x[0] == pytest.approx(136.0 + 800.0)  # its own velocity


# ------------------------------------------------------- the lead vehicle's mode


def test_told_to_stand_at_a_planned_hold_it_stands_on_and_back_in_auto_the_hold_restarts() -> None:
    model = _holding(80.0, 60.0, [(10.0, 8.0), (20.0, 0.0)])  # standing there 20 s
    dt = np.arange(0.0, 200.0, 1.0)
    assert _ahead(model, dt)[45] > 0.5  # (its plan: away 60 s after it stopped)
    model.set_drive(ConvoyDrive.HELD)  # its operator: HOLD
    assert model.drive is ConvoyDrive.HELD
    assert np.all(np.abs(_ahead(model, dt)) < 1e-6)  # stands until told otherwise
    model.set_drive(ConvoyDrive.MISSION)  # AUTO again: the waypoint's hold starts again
    arc = _ahead(model, dt)
    assert np.all(np.abs(arc[:60]) < 1e-6) and arc[65] > 0.5


@pytest.mark.parametrize("drive", [ConvoyDrive.OTHER, ConvoyDrive.RETRACE])
def test_driven_otherwise_its_plan_is_set_aside_and_its_speed_not_learnt(
    drive: ConvoyDrive,
) -> None:
    """A driver (MANUAL), or its way home back along its path (SMART_RTL): forecast as
    if no speed were planned (from its own velocity, or back along its path)."""
    dt = np.arange(0.0, 120.0, 1.0)
    planned = _driven([(10.0, 5.0)], paces=[(0.0, 10.0)])
    plain = _driven([(10.0, 5.0)])
    assert _ahead(planned, dt)[60] > _ahead(plain, dt)[60] + 100.0  # (to its 10 m/s)
    planned.set_drive(drive)
    plain.set_drive(drive)
    assert _ahead(planned, dt) == pytest.approx(_ahead(plain, dt))
    keeps = ConvoyModel(STRAIGHT)
    keeps.set_route(STRAIGHT, keeps_speed=True)
    keeps.set_drive(drive)
    for t in range(200):
        keeps.observe(ConvoyEstimate(float(t), 0.0, 6.0 * t, 0.0, 6.0))
    assert not keeps._driven  # (a driver's speeds are not the rover's)


def test_sent_home_it_is_forecast_straight_there_and_standing_whatever_its_route() -> None:
    dt = np.arange(0.0, 200.0, 1.0)
    model = _driven([(10.0, 8.0)])  # (along STRAIGHT, x = 80 m, at 8 m/s)
    est = model.estimate
    assert est is not None
    model.set_drive(ConvoyDrive.HOME, (est.east + 300.0, est.north + 400.0))  # (53° off)
    x, y = model.positions(est.t + dt)
    far = np.hypot(x - est.east, y - est.north)
    assert far[10] == pytest.approx(80.0) and far[60] == pytest.approx(480.0)  # (8 m/s)
    assert np.allclose((x - est.east) * 400.0, (y - est.north) * 300.0)  # (straight)
    assert x[100] == pytest.approx(est.east + 300.0) and y[199] == pytest.approx(est.north + 400.0)
    # Home behind it (127° off): on its way braking at 1 m/s² to 2 m/s (6 s, 30 m), round
    # there, then straight home speeding up again at 1 m/s² to 8 m/s.
    model.set_drive(ConvoyDrive.HOME, (est.east - 300.0, est.north + 400.0))
    x, y = model.positions(est.t + dt)
    assert np.allclose(y[:7], est.north) and x[3] == pytest.approx(est.east + 19.5)
    turn = (est.east + 30.0, est.north)
    assert (x[6], y[6]) == pytest.approx(turn)
    far = np.hypot(x - turn[0], y - turn[1])
    assert far[12] == pytest.approx(30.0) and far[62] == pytest.approx(430.0)
    assert np.allclose((x[6:] - turn[0]) * 400.0, (y[6:] - turn[1]) * -330.0)  # (straight)
    assert x[199] == pytest.approx(est.east - 300.0) and y[199] == pytest.approx(est.north + 400.0)
    assert model.motion is not None and model.motion.on_route is False
    assert model.driving_off(est.t + dt, 1.5, 1.0) is None
    assert model.stopping_short(est.t + dt, 0.04, 5.0) is None
    # Home not known: as off its route, from its own velocity; back in AUTO, its route.
    model.set_drive(ConvoyDrive.HOME)
    x, _ = model.positions(est.t + dt)
    assert x[10] == pytest.approx(est.east + est.ve * 10.0)
    model.set_drive(ConvoyDrive.MISSION, (0.0, 0.0))  # (a destination only in HOME)
    assert model._going is None


@pytest.mark.parametrize("route", [True, False])
def test_braking_on_its_way_round_it_is_forecast_home_at_the_speed_it_drove(route: bool) -> None:
    """Sent home heading away at 8 m/s (along its route, or with none), it brakes on its
    way: each estimate then still turns it round, and after the turn it is forecast to
    speed up to the 8 m/s it drove before it was sent home, not to the braking's speeds
    it was seen at (ArduRover SITL: 8 m/s again 13 s after it was told)."""
    model = _driven([(10.0, 8.0)])
    if not route:
        model = ConvoyModel(None)
        for k in range(10):
            model.observe(ConvoyEstimate(float(k), 0.0, 8.0 * k, 0.0, 8.0))
    est = model.estimate
    assert est is not None
    home = (est.east - 500.0, 0.0)  # (behind it, along the route)
    model.set_drive(ConvoyDrive.HOME, home)
    t, east = est.t, est.east
    for speed in (7.0, 6.0, 5.0, 4.0):  # (braking at 1 m/s^2, still heading away)
        t, east = t + 1.0, east + speed + 0.5
        model.observe(ConvoyEstimate(t, 0.0, east, 0.0, speed))
    x, _ = model.positions(t + np.arange(0.0, 80.0, 1.0))
    # 4 -> 2 m/s over 2 s (6 m on), round, then 2 -> 8 m/s over 6 s (30 m), then 8 m/s.
    assert x.max() == pytest.approx(east + 6.0)
    assert x[8] == pytest.approx(east + 6.0 - 30.0) and x[18] == pytest.approx(east - 104.0)
    assert x[-1] == pytest.approx(home[0])


def test_sent_home_but_driving_elsewhere_it_is_forecast_from_its_own_velocity() -> None:
    """Its turn round at 15 m/s (13 s of braking) is not taken for driving elsewhere;
    driving on at 90° to its way home past it (a rally point nearer than home) is, after
    5 s: it is forecast from its own velocity, and home again once it heads there."""
    model = ConvoyModel(None)
    for k in range(10):
        model.observe(ConvoyEstimate(float(k), 0.0, 15.0 * k, 0.0, 15.0))
    home = (-2000.0, 0.0)
    model.set_drive(ConvoyDrive.HOME, home)
    t, east, speed = 9.0, 135.0, 15.0
    for _ in range(12):  # (braking on its way, still heading away: its turn round)
        t, speed = t + 1.0, speed - 1.0
        east += speed + 0.5
        model.observe(ConvoyEstimate(t, 0.0, east, 0.0, speed))
    assert not model.astray
    north = 0.0
    for k in range(15):  # (then north at 8 m/s: 90° off its way home)
        t, north = t + 1.0, north + 8.0
        model.observe(ConvoyEstimate(t, north, east, 8.0, 0.0))
        # (looked at from 18 s after the RTL, its 13 s of braking + 5 s: 5 s more)
        assert model.astray == (k >= 11), k
    assert model.counters["astray"] == 1
    model.set_drive(ConvoyDrive.HOME, home)  # (told the same again: still astray)
    assert model.astray
    x, y = model.positions(t + np.array([0.0, 10.0]))
    assert (x[1], y[1]) == pytest.approx((east, north + 80.0))
    far = math.hypot(home[0] - east, home[1] - north)
    ux, uy = (home[0] - east) / far, (home[1] - north) / far
    model.observe(ConvoyEstimate(t + 1.0, north, east, 8.0 * uy, 8.0 * ux))  # (home again)
    assert not model.astray
    x, y = model.positions(t + 1.0 + np.array([0.0, 10.0]))
    gone = 8.0 * 7.0 + 0.5 * 7.0**2 + 15.0 * 3.0  # (8 -> 15 m/s, its speed before RTL)
    assert (x[1], y[1]) == pytest.approx((east + gone * ux, north + gone * uy))
    # Told where it goes (a rally point read, north of it): watched anew, forecast there.
    model.set_drive(ConvoyDrive.HOME, (east, north + 500.0))
    model.observe(ConvoyEstimate(t + 2.0, north, east, 8.0, 0.0))
    assert not model.astray
    x, y = model.positions(t + 2.0 + np.array([0.0, 10.0]))
    assert (x[1], y[1]) == pytest.approx((east, north + gone))


# East 400 m, then north 300 m, at 8 m/s: the path the lead is seen to drive.
_L = [(0.0, 0.0), (400.0, 0.0), (400.0, 300.0)]


def _off_l(x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """How far each (x, y) is from ``_L`` and its straight run on north."""
    first = np.hypot(np.clip(x, 0.0, 400.0) - x, y)
    second = np.hypot(x - 400.0, np.clip(y, 0.0, 400.0) - y)
    return np.asarray(np.minimum(first, second))


def _drove_l() -> tuple[ConvoyModel, float]:
    """A convoy with no route seen driving ``_L``, an estimate a second: the model, and
    the time of its last estimate."""
    model = ConvoyModel(None)
    t = 0.0
    for a, b in itertools.pairwise(_L):
        legs = round(math.dist(a, b) / 8.0)
        vx, vy = (b[0] - a[0]) / legs, (b[1] - a[1]) / legs
        for k in range(legs):
            model.observe(ConvoyEstimate(t, a[1] + vy * k, a[0] + vx * k, vy, vx))
            t += 1.0
    model.observe(ConvoyEstimate(t, 300.0, 400.0, 8.0, 0.0))
    return model, t


def test_sent_home_back_along_its_path_it_is_forecast_round_its_corners_to_its_start() -> None:
    """SMART_RTL: it brakes on its way and turns round (as to go home), then drives back
    along the path it was seen to drive at its speed, round its corner, to where it was
    first seen, and stands there."""
    model, t = _drove_l()
    model.set_drive(ConvoyDrive.RETRACE)
    assert model.motion is not None and model.motion.on_route is None
    dt = np.arange(0.0, 150.0, 0.5)
    x, y = model.positions(t + dt)
    assert np.all(_off_l(x, y) < 6.0)  # (its corner rounded by the 15-m smoothing)
    assert y.max() == pytest.approx(300.0 + 30.0, abs=3.0)  # (8 -> 2 m/s at 1 m/s^2: 30 m)
    assert np.hypot(x - 400.0, y).min() < 10.0  # (round its corner)
    home = np.hypot(x, y) < 1.0
    assert home[-1] and np.all(home[np.argmax(home) :])  # (there, and standing)
    # 30 m braking, 730 m back from 2 m/s up to 8 at 1 m/s^2: home 6 + 3 + 95 s on.
    assert dt[np.argmax(home)] == pytest.approx(6.0 + 3.0 + (730.0 - 15.0) / 8.0, abs=3.0)


def test_a_rover_seen_to_take_its_corners_slowly_takes_those_of_its_way_back_so() -> None:
    """Its firmware slows for a sharp corner whatever mode drives it: seen to take its
    route's at 2.4 m/s (``CornerHabit``), it is forecast through the corner of its way
    back at about that, and home some 6 s later than at its speed."""
    fast, t = _drove_l()
    slow, _ = _drove_l()
    slow.corner_habit.samples.extend([2.4, 2.4])
    dt = np.arange(0.0, 150.0, 0.25)
    homes = []
    for model in (fast, slow):
        model.set_drive(ConvoyDrive.RETRACE)
        x, y = model.positions(t + dt)
        home = np.hypot(x, y) < 1.0
        homes.append(float(dt[np.argmax(home)]))
        corner = np.hypot(x - 400.0, y) < 10.0
        speed = np.hypot(np.diff(x), np.diff(y)) / 0.25
        assert np.all(_off_l(x, y) < 6.0)
        if model is slow:
            assert speed[corner[1:]].min() < 3.0
        else:
            assert speed[corner[1:]].min() > 7.9
    assert 4.0 < homes[1] - homes[0] < 10.0, homes


def test_on_its_way_back_it_is_forecast_on_from_where_it_is_or_from_its_velocity_astray() -> None:
    """Driving back down its second leg it is forecast on along its path from there (not
    turned round again); 5 s heading elsewhere, from its own velocity; told otherwise,
    the way back is dropped."""
    model, t = _drove_l()
    model.set_drive(ConvoyDrive.RETRACE)
    for north in np.arange(296.0, 100.0, -8.0):  # (turned round: south at 8 m/s)
        t += 1.0
        model.observe(ConvoyEstimate(t, float(north), 400.0, -8.0, 0.0))
    est = model.estimate
    assert est is not None
    x, y = model.positions(est.t + np.array([10.0, 30.0]))
    assert (x[0], y[0]) == pytest.approx((400.0, est.north - 80.0), abs=2.0)
    assert y[1] == pytest.approx(0.0, abs=6.0) and x[1] < 400.0 - 100.0  # (round the corner)
    for k in range(6):  # (then east, off its path: astray after 5 s)
        t += 1.0
        model.observe(ConvoyEstimate(t, est.north, 400.0 + 8.0 * (k + 1), 0.0, 8.0))
    assert model.astray
    x, y = model.positions(t + np.array([10.0]))
    assert (x[0], y[0]) == pytest.approx((448.0 + 80.0, est.north))
    model.set_drive(ConvoyDrive.OTHER)  # (a driver takes it)
    assert model._retrace is None and not model.astray


def test_sent_home_again_it_drives_back_what_it_had_not_yet_and_what_it_drove_since() -> None:
    """Out of SMART_RTL halfway back down its second leg, then east 100 m, then SMART_RTL
    again: back west the 100 m, then on to the next point of its path it had not reached
    and home from there, not up to where it first turned round (the points it reached
    are off its path; the rover's own, which takes off each point as it sets off for it,
    goes back to the one after)."""
    model, t = _drove_l()
    model.set_drive(ConvoyDrive.RETRACE)
    for north in np.arange(296.0, 150.0, -8.0):
        t += 1.0
        model.observe(ConvoyEstimate(t, float(north), 400.0, -8.0, 0.0))
    model.set_drive(ConvoyDrive.OTHER)
    for east in np.arange(408.0, 501.0, 8.0):  # (a driver takes it east)
        t += 1.0
        model.observe(ConvoyEstimate(t, 152.0, float(east), 0.0, 8.0))
    model.set_drive(ConvoyDrive.RETRACE)
    x, y = model.positions(t + np.arange(0.0, 120.0, 0.5))
    assert y.max() < 152.0 + 8.0  # (never back up to 300 m)
    assert np.all(x < 496.0 + 31.0) and np.hypot(x - 400.0, y).min() < 10.0  # (turned round)
    assert np.hypot(x, y).min() < 1.0


def test_back_in_auto_after_rtl_it_drives_straight_to_its_waypoint_then_its_route_on() -> None:
    """The waypoint it was driving to is found on the pass it was driving (the route
    crosses it again later), and a hold planned there is stood before it drives on."""
    xs = np.array([0.0, 500.0, 1000.0, 1000.0, 500.0, 500.0])  # (east) crossing (500, 0)
    ys = np.array([0.0, 0.0, 0.0, 500.0, 500.0, -500.0])  # (north) at 500 m and 2500 m
    road = Road.from_points(xs, ys)
    model = ConvoyModel(road)
    model.set_route(road, holds=[(road.project(500.0, 0.0, 100.0), 20.0)])
    for t in range(38):  # (east at 8 m/s to 296 m)
        model.observe(ConvoyEstimate(float(t), 0.0, 8.0 * t, 0.0, 8.0))
    model.set_drive(ConvoyDrive.HOME, (0.0, 0.0))
    for t in range(38, 80):  # (home, then standing there)
        east = max(0.0, 296.0 - 8.0 * (t - 37))
        model.observe(ConvoyEstimate(float(t), 0.0, east, 0.0, -8.0 if east > 0.0 else 0.0))
    model.set_drive(ConvoyDrive.MISSION, (500.0, 0.0))
    est = model.estimate
    assert est is not None and model._rejoin is not None
    assert model._rejoin[2] == pytest.approx(500.0, abs=15.0)  # (not 2500 m on)
    assert model.motion is not None and model.motion.on_route is False
    dt = np.arange(0.0, 140.0, 1.0)
    x, y = model.positions(est.t + dt)
    # From a stand to 8 m/s at 1 m/s^2, 500 m east by about 66 s; 20 s held there; on east.
    assert np.all(np.abs(y) < 1.0)
    assert x[8] == pytest.approx(32.0, abs=1.0)
    assert np.all(np.abs(x[72:85] - 500.0) < 15.0)
    assert x[130] > 600.0 and np.all(np.diff(x) >= -1e-6)
    # There: on its route again, its pass, its way.
    for t in range(80, 150):
        model.observe(ConvoyEstimate(float(t), 0.0, min(500.0, 0.5 * (t - 80) ** 2), 0.0, 8.0))
    assert model._rejoin is None and model._s == pytest.approx(500.0, abs=30.0)


def _rover(
    drive: list[tuple[float, float]], paces: list[tuple[float, float]], *, keeps: bool = True
) -> ConvoyModel:
    """A rover along ``STRAIGHT`` with ``paces`` planned (arc, m/s), driven by its
    autopilot (``keeps``) or by people, that drove each (seconds, m/s) in turn, an
    estimate every 0.2 s (its own velocity: steady to the centimetre)."""
    model = ConvoyModel(STRAIGHT, relax_s=30.0)
    model.set_route(STRAIGHT, speeds=paces, keeps_speed=keeps)
    t, x = 0.0, 0.0
    for seconds, speed in drive:
        for _ in range(round(seconds / 0.2)):
            model.observe(ConvoyEstimate(t, 0.0, x, 0.0, speed))
            t, x = t + 0.2, x + 0.2 * speed
    return model


def test_a_rover_seen_to_keep_a_speed_not_its_plans_is_forecast_at_it_to_the_next_change() -> None:
    """An operator's DO_CHANGE_SPEED to 5 m/s where the mission plans 8 (and 6 from 1.5 km)."""
    paces = [(0.0, 8.0), (1500.0, 6.0)]
    dt = np.arange(0.0, 300.0, 0.5)
    rover = _rover([(40.0, 8.0), (4.0, 5.0)], paces)  # (320 m at 8, then 4 s at 5)
    assert rover.kept is None  # (a moment's speed is not a kept one)
    assert _ahead(rover, dt)[200] > 8.0 * 90.0  # (back up to the plan's 8 m/s)
    rover = _rover([(40.0, 8.0), (20.0, 5.0)], paces)  # (at 5 m/s for 20 s: 420 m)
    assert rover.kept == pytest.approx(5.0)
    ahead = _ahead(rover, dt)
    at_change = 1500.0 - 420.0  # (1080 m on: the plan's 6 m/s from there)
    reach = np.flatnonzero(ahead < at_change)
    assert ahead[40] == pytest.approx(5.0 * 20.0, abs=1.0)  # (20 s on: 100 m, at 5)
    assert dt[reach[-1]] == pytest.approx(at_change / 5.0, abs=1.0)
    assert ahead[-1] - ahead[-21] == pytest.approx(6.0 * 10.0, abs=1.0)  # (the plan's 6)
    ((_, kept, plan),) = rover.kept_log
    assert kept == pytest.approx(5.0) and plan == 8.0
    # Past the plan's change it keeps the plan's own; seen at the plan's speed, it is
    # forecast at the plan's again.
    past = _rover([(40.0, 8.0), (240.0, 5.0)], paces)  # (1520 m: past 1500 m)
    assert past.kept is None and past.kept_log[-1][1] is None
    back = _rover([(40.0, 8.0), (20.0, 5.0), (20.0, 8.0)], paces)
    assert back.kept is None


def test_a_kept_speed_is_a_rovers_not_a_drivers_and_not_before_a_drive_is_steady() -> None:
    paces = [(0.0, 8.0)]
    people = _rover([(40.0, 8.0), (30.0, 5.0)], paces, keeps=False)
    assert people.kept is None  # (people keep no plan: it relaxes)
    wobbly = ConvoyModel(STRAIGHT)
    wobbly.set_route(STRAIGHT, speeds=paces, keeps_speed=True)
    x = 0.0
    for k in range(400):  # (5 m/s give or take 1: traffic, not a speed told)
        speed = 5.0 + math.sin(k / 3.0)
        wobbly.observe(ConvoyEstimate(0.2 * k, 0.0, x, 0.0, speed))
        x += 0.2 * speed
    assert wobbly.kept is None
    # Told, then back in AUTO after a HOLD: ArduRover drives WP_SPEED again, seen anew.
    told = _rover([(40.0, 8.0), (20.0, 5.0)], paces)
    assert told.kept == pytest.approx(5.0)
    told.set_drive(ConvoyDrive.HELD)
    told.set_drive(ConvoyDrive.MISSION)
    assert told.kept is None


def test_a_rover_slowed_by_a_curve_keeps_no_speed_of_its_own() -> None:
    """A curve taken at the lateral acceleration's speed is the road's doing: 30 m of
    radius, sqrt(1 m/s^2 x 30 m) = 5.5 m/s where the plan says 8."""
    arc = np.linspace(0.0, math.pi, 120)
    bend = Road.from_points(
        [30.0 * math.sin(a) for a in arc] + [0.0] * 50,
        [30.0 * (1.0 - math.cos(a)) for a in arc] + list(np.linspace(62.0, 2000.0, 50)),
    )
    model = ConvoyModel(bend)
    model.set_route(bend, speeds=[(0.0, 8.0)], keeps_speed=True)
    for k in range(90):  # (18 s round the half circle at 5 m/s)
        p = bend.point(5.0 * 0.2 * k)
        vn, ve = 5.0 * math.sin(p.heading), 5.0 * math.cos(p.heading)
        model.observe(ConvoyEstimate(0.2 * k, p.y, p.x, vn, ve))
    assert model.kept is None
