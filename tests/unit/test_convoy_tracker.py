"""ConvoyTracker: centroid of sources, least-squares velocity, bad and stale input."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

import pytest

from convoy_mav.convoy import ConvoyTracker


def _feed_two_trucks(
    tracker: ConvoyTracker, t0: float, t1: float, vn: float, ve: float, rate: float = 5.0
) -> None:
    """Two trucks 20 m apart (east), reporting alternately at ``rate`` Hz each."""
    k = 0
    while t0 + k / (2 * rate) <= t1 + 1e-9:
        t = t0 + k / (2 * rate)
        n, e = 100.0 + vn * t, -50.0 + ve * t
        offset = 10.0 if k % 2 == 0 else -10.0
        assert tracker.update(t, n, e + offset, source=k % 2 + 3)
        k += 1


def test_no_estimate_before_the_first_fix() -> None:
    assert ConvoyTracker().estimate(5.0) is None


def test_centroid_and_exact_velocity_of_a_constant_velocity_convoy() -> None:
    tr = ConvoyTracker(window=5.0)
    _feed_two_trucks(tr, 0.0, 8.0, vn=3.0, ve=-4.0)
    est = tr.estimate(8.0)
    assert est is not None and not est.stale
    assert tr.sources == {3, 4}
    assert (est.vn, est.ve) == pytest.approx((3.0, -4.0), abs=1e-9)
    assert est.speed == pytest.approx(5.0)
    # the centroid of the latest fixes (0.1 s apart) is dated at their mean time
    # and brought to the newest fix's time: exact for a constant velocity
    assert est.north == pytest.approx(100.0 + 3.0 * 8.0, abs=1e-9)
    assert est.east == pytest.approx(-50.0 - 4.0 * 8.0, abs=1e-9)
    # extrapolated with the velocity when asked a little later
    later = tr.estimate(9.0)
    assert later is not None and not later.stale and later.t == 9.0
    assert later.north - est.north == pytest.approx(est.vn)
    assert later.east - est.east == pytest.approx(est.ve)


def test_single_stationary_source() -> None:
    tr = ConvoyTracker()
    for k in range(30):
        tr.update(k * 0.2, 5.0, 7.0, source="mqtt")
    est = tr.estimate(6.0)
    assert est is not None
    assert (est.north, est.east, est.vn, est.ve, est.stale) == (5.0, 7.0, 0.0, 0.0, False)


def test_nan_and_inf_are_ignored_and_counted() -> None:
    tr = ConvoyTracker()
    assert tr.update(0.0, 1.0, 2.0)
    assert not tr.update(0.5, math.nan, 2.0)
    assert not tr.update(0.6, 1.0, math.inf)
    assert not tr.update(math.nan, 1.0, 2.0)
    assert tr.counters["non_finite"] == 3
    assert tr.counters["accepted"] == 1
    est = tr.estimate(1.0)
    assert est is not None and (est.north, est.east) == (1.0, 2.0)


def test_out_of_order_fixes_are_ignored_and_counted() -> None:
    tr = ConvoyTracker(stale_after=3.0)
    assert tr.update(10.0, 1.0, 1.0, source=1)
    assert not tr.update(9.0, 5.0, 5.0, source=1)  # older than source 1's latest
    assert tr.update(9.5, 3.0, 3.0, source=2)  # another source, slightly behind: used
    assert not tr.update(5.0, 3.0, 3.0, source=7)  # already stale on arrival
    assert tr.counters["out_of_order"] == 2
    est = tr.estimate(10.0)
    assert est is not None and (est.north, est.east) == (2.0, 2.0)


def test_stale_holds_the_last_good_estimate_then_recovers() -> None:
    tr = ConvoyTracker(stale_after=2.0, window=4.0)
    for k in range(21):
        tr.update(k * 0.1, 2.0 * k * 0.1, 0.0)
    fresh = tr.estimate(2.0)
    assert fresh is not None and fresh.vn == pytest.approx(2.0)
    held = tr.estimate(4.5)  # 2.5 s without a fix
    assert held is not None and held.stale
    assert (held.t, held.north, held.east, held.vn) == pytest.approx(
        (2.0, fresh.north, fresh.east, 2.0)
    )
    assert tr.estimate(math.nan) is not None
    tr.update(5.0, 10.0, 0.0)
    again = tr.estimate(5.0)
    assert again is not None and not again.stale and again.north == 10.0


def test_a_silent_source_leaves_the_centroid_without_a_velocity_jump() -> None:
    tr = ConvoyTracker(stale_after=1.0, window=4.0, min_span=1.0)
    vn = 2.0
    for k in range(60):  # trucks A (north + 10) and B (north - 10), B dies at t = 3
        t = k * 0.1
        tr.update(t, vn * t + 10.0, 0.0, source="A")
        if t < 3.0:
            tr.update(t, vn * t - 10.0, 0.0, source="B")
        est = tr.estimate(t)
        assert est is not None
        if t > 1.0:
            # the centroid jumps by 10 m when B drops out; the velocity never does
            assert est.vn == pytest.approx(vn, abs=1e-6), t
    assert tr.sources == {"A"}
    assert tr.counters["source_dropped"] == 1
    est = tr.estimate(5.9)
    assert est is not None and est.north == pytest.approx(vn * 5.9 + 10.0)


def test_velocity_by_least_squares_is_robust_to_noise() -> None:
    rng = random.Random(7)
    tr = ConvoyTracker(window=10.0)
    for k in range(200):
        t = k * 0.1
        tr.update(t, 6.0 * t + rng.gauss(0.0, 1.5), -1.0 * t + rng.gauss(0.0, 1.5))
    est = tr.estimate(19.9)
    assert est is not None
    assert est.vn == pytest.approx(6.0, abs=0.15)
    assert est.ve == pytest.approx(-1.0, abs=0.15)


def test_velocity_follows_a_turn_within_one_window() -> None:
    tr = ConvoyTracker(window=3.0)
    for k in range(100):  # north at 5 m/s, then east at 5 m/s from t = 5
        t = k * 0.1
        n = 5.0 * min(t, 5.0)
        e = 5.0 * max(t - 5.0, 0.0)
        tr.update(t, n, e)
    est = tr.estimate(9.9)
    assert est is not None and (est.vn, est.ve) == pytest.approx((0.0, 5.0), abs=1e-6)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"stale_after": 0.0},
        {"window": math.nan},
        {"window": 2.0, "min_span": 3.0},
        {"part_m": math.inf},
    ],
)
def test_bad_parameters_are_refused(kwargs: dict[str, float]) -> None:
    with pytest.raises(ValueError):
        ConvoyTracker(**kwargs)  # type: ignore[arg-type]


def _corner(
    tracker: ConvoyTracker,
    report: Callable[[float, float, float], tuple[float, float] | None],
    until: float = 20.0,
    rate: float = 10.0,
) -> None:
    """A vehicle north at 8 m/s, then east at 8 m/s from t = 15, fixed at ``rate`` Hz;
    ``report(t, vn, ve)`` is the velocity it reports with each fix."""
    for k in range(int(until * rate) + 1):
        t = k / rate
        n, e = 8.0 * min(t, 15.0), 8.0 * max(t - 15.0, 0.0)
        vn, ve = (8.0, 0.0) if t < 15.0 else (0.0, 8.0)
        assert tracker.update(t, n, e, source=1, velocity=report(t, vn, ve))


def test_a_vehicles_own_velocity_turns_with_it_where_the_slope_lags() -> None:
    fitted, reported = ConvoyTracker(window=4.0), ConvoyTracker(window=4.0)
    _corner(fitted, lambda t, vn, ve: None, until=16.0)
    _corner(reported, lambda t, vn, ve: (vn, ve), until=16.0)
    lagging, turned = fitted.estimate(16.0), reported.estimate(16.0)
    assert lagging is not None and turned is not None
    assert lagging.vn > 5.0  # a second into the corner the 4-s slope still heads north
    assert (turned.vn, turned.ve) == pytest.approx((0.0, 8.0), abs=1e-9)
    assert reported.counters["velocity_reported"] > 0
    assert fitted.counters["velocity_reported"] == 0


def test_reports_are_trusted_only_after_ten_seconds_of_them() -> None:
    tr = ConvoyTracker(window=4.0)
    _corner(tr, lambda t, vn, ve: (vn, ve) if t >= 8.0 else None, until=17.0)
    est = tr.estimate(17.0)
    assert est is not None and est.vn > 1.0  # 9 s of reports: still the slope
    assert tr.counters["velocity_reported"] == 0


def test_reports_of_a_differenced_noisy_track_are_not_trusted() -> None:
    rng = random.Random(3)

    def noisy(t: float, vn: float, ve: float) -> tuple[float, float]:
        return vn + rng.gauss(0.0, 4.2), ve + rng.gauss(0.0, 4.2)  # 3 m of noise, 1 Hz

    tr = ConvoyTracker(window=4.0)
    _corner(tr, noisy, until=14.0, rate=1.0)
    assert tr.counters["velocity_reported"] == 0
    assert tr.counters["velocity_fitted"] == 15


@pytest.mark.parametrize("wrong", [(0.0, 0.0), (0.0, 8.0), (800.0, 0.0)])
def test_reports_the_fixes_do_not_bear_out_are_not_trusted(wrong: tuple[float, float]) -> None:
    """Zeros (a GPS with no velocity), another frame, centimetres as metres."""
    tr = ConvoyTracker(window=4.0)
    _corner(tr, lambda t, vn, ve: wrong, until=14.0)
    est = tr.estimate(14.0)
    assert est is not None and (est.vn, est.ve) == pytest.approx((8.0, 0.0), abs=1e-6)
    assert tr.counters["velocity_reported"] == 0


def test_a_non_finite_velocity_is_dropped_and_its_position_kept() -> None:
    tr = ConvoyTracker()
    assert tr.update(0.0, 1.0, 2.0, velocity=(math.nan, 0.0))
    assert tr.counters["velocity_non_finite"] == 1
    est = tr.estimate(0.0)
    assert est is not None and (est.north, est.east) == (1.0, 2.0)


def test_reports_count_only_while_every_source_reports() -> None:
    tr = ConvoyTracker(window=4.0)
    for k in range(200):
        t = k * 0.1
        tr.update(t, 8.0 * t + 5.0, 0.0, source="A", velocity=(8.0, 0.0))
        tr.update(t, 8.0 * t - 5.0, 0.0, source="B")  # (a tracker with no velocity)
    assert tr.counters["velocity_reported"] == 0
