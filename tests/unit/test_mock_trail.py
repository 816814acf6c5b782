"""A convoy's followers drive the path their leader drove, a time gap behind it and
never nearer than a standstill distance (``sitl_mock.trail``): held, told a speed or
sent elsewhere, the convoy stays one."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sitl_mock.trail import Follower, Trail

DT = 0.1
LAG = 2.5  # s: 20 m at 8 m/s


def _drive(
    leader: list[tuple[float, float]], *, driving: bool = True
) -> tuple[Trail, Follower, list[tuple[float, float, float, float]]]:
    """The leader's (north, east) each step from t = 0; the follower's states."""
    trail = Trail()
    follower = Follower(trail, LAG, 5.0)
    states = []
    for k, (n, e) in enumerate(leader):
        t = k * DT
        trail.record(t, n, e)
        if k:
            follower.step(t, DT, driving)
        states.append(follower.state())
    return trail, follower, states


def _line(speed: float, seconds: float, start: float = 0.0) -> list[tuple[float, float]]:
    return [(start + speed * DT * k, 0.0) for k in range(round(seconds / DT) + 1)]


def test_a_follower_drives_where_its_leader_was_its_lag_ago() -> None:
    # the leader pulls away at 1 m/s^2 to 8 m/s, then holds it
    path, n, v = [], 0.0, 0.0
    for _ in range(600):
        path.append((n, 0.0))
        v = min(v + 1.0 * DT, 8.0)
        n += v * DT
    _, _, states = _drive(path)
    lagged = round(LAG / DT)
    # (it sets off once the leader is its standstill distance ahead, and soon drives
    # exactly where the leader was LAG s before)
    assert all(s[0] == 0.0 for s in states[: lagged + 7])
    for k in range(200, len(path)):
        assert states[k][0] == pytest.approx(path[k - lagged][0], abs=1e-6)
    assert states[-1][2] == pytest.approx(8.0)


def test_where_its_leader_stops_it_stops_the_standstill_short_of_it() -> None:
    path, n, v = _line(8.0, 30.0), 240.0, 8.0
    while v > 0.0:  # (braking at 1 m/s^2 to a stand at 272 m)
        v = max(v - 1.0 * DT, 0.0)
        n += v * DT
        path.append((n, 0.0))
    path += [(n, 0.0)] * round(60.0 / DT)
    _, _, states = _drive(path)
    assert states[-1] == pytest.approx((n - 5.0, 0.0, 0.0, 0.0), abs=1e-6)
    assert all(s[0] <= n - 5.0 + 1e-9 for s in states)
    speeds = [s[2] for s in states][round(2 * LAG / DT) :]  # (past the leader's start)
    # (no jolt past 3 m/s^2 as it closes and brakes; in its last metres it creeps to a stand)
    assert all(abs(b - a) <= 0.3 + 1e-9 or a < 1.5 for a, b in itertools.pairwise(speeds))


def test_a_follower_not_driving_brakes_and_stands_then_catches_up() -> None:
    trail, follower, _ = _drive(_line(8.0, 30.0))
    at, t = follower.s, 30.0
    for _ in range(round(20.0 / DT)):  # held, while its leader drives on
        t += DT
        trail.record(t, 8.0 * t, 0.0)
        follower.step(t, DT, driving=False)
    assert follower.v == 0.0 and follower.s - at == pytest.approx(8.0**2 / 2, abs=2.0)
    top = 0.0
    for _ in range(round(150.0 / DT)):  # driving again: it catches up to its lag
        t += DT
        trail.record(t, 8.0 * t, 0.0)
        follower.step(t, DT, driving=True)
        top = max(top, follower.v)
    assert trail.s - follower.s == pytest.approx(8.0 * LAG, abs=0.1)
    assert follower.v == pytest.approx(8.0, abs=1e-6)
    assert top <= 8.0 + 3.0 + 1e-9  # (closing at most 3 m/s faster)


def test_a_follower_turns_where_its_leader_turned() -> None:
    path = _line(8.0, 25.0) + [(200.0, 8.0 * DT * k) for k in range(1, 500)]
    _, _, states = _drive(path)
    n, e, vn, ve = states[-1]
    assert (n, e) == pytest.approx((200.0, 8.0 * DT * 499 - 8.0 * LAG), abs=1e-6)
    assert (vn, ve) == pytest.approx((0.0, 8.0), abs=1e-6)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(0.0, 15.0), st.floats(-math.pi, math.pi), st.floats(0.5, 20.0)),
        min_size=1,
        max_size=8,
    ),
    st.floats(0.5, 10.0),
)
def test_a_follower_stays_on_the_path_behind_its_leader_whatever_it_drives(
    legs: list[tuple[float, float, float]], lag: float
) -> None:
    """Legs of (speed, heading, seconds), stops included: the follower is on the
    leader's path, never within its standstill distance, never faster than its catch-up
    over the leader's fastest."""
    trail = Trail()
    follower = Follower(trail, lag, 5.0)
    n = e = t = 0.0
    trail.record(t, n, e)
    top = 0.0
    for speed, heading, seconds in legs:
        top = max(top, speed)
        for _ in range(round(seconds / DT)):
            t += DT
            n += speed * DT * math.cos(heading)
            e += speed * DT * math.sin(heading)
            trail.record(t, n, e)
            follower.step(t, DT, True)
            assert follower.s <= max(trail.s - 5.0, 0.0) + 1e-9
            assert 0.0 <= follower.v <= top + 3.0 + 1e-9
            fn, fe, *_ = follower.state(0.05)
            assert math.isfinite(fn) and math.isfinite(fe)


def test_the_vehicles_behind_one_that_leaves_drive_on_behind_its_leader() -> None:
    """A column of three; the middle one leaves (sent home by its own operator) on a
    straight road before the leader's corner: the last keeps its place behind the
    leader, round the corner, with no jump in speed, and never follows the one gone."""
    lead, middle = Trail(), Trail()
    gone = Follower(lead, LAG, 5.0)
    last = Follower(middle, LAG, 5.0)
    speeds, t, left = [0.0], 0.0, None
    for k in range(1, round(120.0 / DT)):
        t = k * DT
        n, e = (8.0 * t, 0.0) if t <= 60.0 else (480.0, 8.0 * (t - 60.0))
        lead.record(t, n, e)
        if left is None and t >= 40.0:  # (it leaves, from where it last was)
            gone.leave(middle)
            left = gone.state()[:2]
        if left is None:
            gone.step(t, DT, True)
            gn, ge, *_ = gone.state()
        else:  # (on its own way, back west of the road)
            gn, ge = left[0], left[1] - 8.0 * (t - 40.0)
        middle.record(t, gn, ge)
        last.step(t, DT, True)
        speeds.append(last.v)
    ln, le, vn, ve = last.state()
    # (where the leader was its two lags ago: round the corner, east)
    assert last.trail is lead and last.lag == pytest.approx(2 * LAG)
    assert lead.readers == [last]  # (the one gone holds the leader's path back no more)
    assert (ln, le) == pytest.approx((480.0, 8.0 * (t - 60.0 - 2 * LAG)), abs=1e-6)
    assert (vn, ve) == pytest.approx((0.0, 8.0), abs=1e-6)
    jumps = [abs(b - a) for a, b in itertools.pairwise(speeds[round(20.0 / DT) :])]
    assert max(jumps) <= 1.0 * DT + 1e-9  # (past the column's start, at 8 m/s at once)


def test_a_long_drive_keeps_only_the_trail_its_followers_need() -> None:
    trail = Trail()
    follower = Follower(trail, 4.0)
    for k in range(100_000):
        trail.record(0.1 * k, 0.8 * k, 0.0)
        if k:
            follower.step(0.1 * k, 0.1, True)
    assert len(trail._s) < 1500  # (pruned: 4 s lag and 30 s kept, at 10 samples a second)
    assert trail.s_at(0.1 * 99_999 - 4.0) == pytest.approx(0.8 * 99_999 - 32.0)


def test_a_follower_held_for_long_stays_where_it_stood() -> None:
    """Held (or stalled) while its leader drives on for an hour: the path behind it is
    kept, so it stands where it stood, not moved on to where the trail was cut."""
    trail = Trail()
    follower = Follower(trail, 4.0)
    for k in range(1, 36_000):
        t = 0.1 * k
        trail.record(t, 0.8 * k, 0.0)
        follower.step(t, 0.1, t < 60.0)
        if k == 700:
            stood = follower.state()
    assert follower.state() == stood and follower.v == 0.0
