"""The road mission: flyable by construction on any road, covering on the paper's and real roads."""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from convoy_mav.convoy import ConvoyTracker
from convoy_mav.errors import PlanningError
from convoy_mav.mission.choose import choose_planner, road_fleet
from convoy_mav.mission.events import PhaseChanged, Replanned, Returning
from convoy_mav.mission.forecast import Watch
from convoy_mav.mission.road import (
    _JOIN_LAGS_S,
    FAST_CONVOY_RATIO,
    RoadMission,
    RoadSettings,
)
from convoy_mav.mission.simulate import RoadRun, fly_road
from convoy_mav.mission.view import MissionView
from convoy_mav.planning import PlanRequest
from convoy_mav.planning.dubins import Pose, Segment, Turn, wrap_angle
from convoy_mav.planning.meets import pattern_pose
from convoy_mav.planning.plan import Trajectory
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import RoadTrack, corner, junction, random_road, road_kind
from convoy_mav.types import ConvoyEstimate, Setpoint

R, r, V = 150.0, 100.0, 18.0
REQUEST = PlanRequest(R, r, V)
BAND = (0.85 * V, 1.15 * V)


Arr = npt.NDArray[np.float64]
Streams = dict[int, list[Setpoint]]


def _fly(
    t: Arr,
    north: Arr,
    east: Arr,
    uavs: int,
    *,
    route: Road | None = None,
    dt: float = 0.1,
    until: float | None = None,
    starts: dict[int, tuple[float, float, float]] | None = None,
    road_settings: RoadSettings | None = None,
    join_at: dict[int, float] | None = None,
    each: Callable[[RoadMission, float], None] | None = None,
    request: PlanRequest = REQUEST,
) -> tuple[RoadMission, Streams]:
    """Drive a RoadMission like the service does; every setpoint it would stream, per UAV
    (joining from ``starts``, default: round the convoy's first fix; as soon as the convoy
    is located, or at ``join_at``); ``each`` is called after every step."""
    ids = list(range(1, uavs + 1))
    mission = RoadMission(request, ids, down=lambda _u: -100.0, route=route, settings=road_settings)
    tracker = ConvoyTracker(window=4.0)
    k = 0
    poses = starts or {
        u: (north[0] + 300.0 * math.cos(u), east[0] + 300.0 * math.sin(u), u) for u in ids
    }
    waiting = dict(poses)
    streams: Streams = {u: [] for u in ids}
    end = float(t[-1]) if until is None else until
    for now in np.arange(0.0, end, dt).tolist():
        while k < len(t) and t[k] <= now:
            tracker.update(float(t[k]), float(north[k]), float(east[k]))
            k += 1
        est = tracker.estimate(now)
        if est is not None:
            mission.on_convoy(est)
        due = {u: p for u, p in waiting.items() if (join_at or {}).get(u, 0.0) <= now}
        if due and mission.plan is not None:
            mission.join_many(due, now)
            waiting = {u: p for u, p in waiting.items() if u not in due}
        mission.tick(now)
        for u in ids:
            sp = mission.setpoint(u, now)
            if sp is not None:
                streams[u].append(sp)
        if each is not None:
            each(mission, now)
    return mission, streams


def _assert_flyable(mission: RoadMission, streams: Streams, request: PlanRequest = REQUEST) -> None:
    turn_radius = request.turn_radius
    low, high = 0.85 * request.uav_speed, 1.15 * request.uav_speed
    assert mission.min_turn_radius >= turn_radius * (1.0 - 1e-9)
    lo, hi = mission.speed_range
    assert low - 1e-9 <= lo and hi <= high + 1e-9
    for stream in streams.values():
        for a, b in itertools.pairwise(stream):
            dt = b.t - a.t
            step = math.hypot(b.north - a.north, b.east - a.east)
            assert step <= high * dt + 1e-6  # no jump in position, across re-plans too
            turn = abs(wrap_angle(b.yaw - a.yaw))
            assert turn <= high / turn_radius * dt + 1e-6  # no jump in heading: curvature <= 1/R
            speed = math.hypot(b.vn, b.ve)
            assert low - 1e-6 <= speed <= high + 1e-6


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.booleans())
def test_every_commanded_path_is_flyable_on_random_roads(seed: int, known: bool) -> None:
    """Curvature <= 1/R, speed in the band (planes +-15 %), continuous through every
    re-plan, whatever the road does (curves of 10 m to 1.5 km radius, stops, speed changes)."""
    road = random_road(np.random.default_rng(seed), pieces=5)
    route = Road.from_points(road.true_east, road.true_north) if known else None
    mission, streams = _fly(
        road.t, road.north, road.east, road_fleet(R, r), route=route, until=240.0
    )
    assert sum(len(s) for s in streams.values()) > 1000
    _assert_flyable(mission, streams)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.integers(0, 2**31 - 1),
    st.booleans(),
    st.floats(40.0, 300.0),
    st.floats(0.4, 0.95),
    st.floats(12.0, 30.0),
)
def test_every_commanded_path_is_flyable_for_any_aircraft(
    seed: int, known: bool, turn_radius: float, camera: float, airspeed: float
) -> None:
    """The same for aircraft other than the demo's (``road_table.py --aircraft``): any
    turn radius, camera (r/R) and airspeed, the road's count of UAVs for them, a convoy
    up to 12 m/s (for the slowest of them, faster than their pattern keeps up with)."""
    request = PlanRequest(turn_radius, camera * turn_radius, airspeed)
    road = random_road(np.random.default_rng(seed), pieces=5)
    route = Road.from_points(road.true_east, road.true_north) if known else None
    uavs = road_fleet(request.turn_radius, request.sensor_radius, route=known)
    mission, streams = _fly(
        road.t, road.north, road.east, uavs, route=route, until=240.0, request=request
    )
    assert sum(len(s) for s in streams.values()) > 1000
    _assert_flyable(mission, streams, request)


@pytest.mark.parametrize("speed", [0.0, 4.0, 8.0, 12.0])
def test_parked_and_straight_convoys_are_covered_throughout(speed: float) -> None:
    t = np.arange(0.0, 900.0, 1.0)
    run = fly_road(t, speed * t * 0.6, speed * t * 0.8, REQUEST, road_fleet(R, r))
    # (joining from 300 m off a convoy driving away at 12 m/s takes the longest)
    assert run.protect_start is not None and run.protect_start < 300.0
    assert run.coverage >= 0.995 and run.longest_gap_s <= 2.0
    assert run.predicted_coverage == pytest.approx(run.coverage, abs=0.01)


def test_the_prediction_weighs_time_not_control_steps() -> None:
    """Predicted coverage samples the protect phase every 0.5 s of mission time, however
    often the mission is stepped: sampled from each step's own start, a 10-Hz loop scored
    every step as half a second, and a stretch stepped densely outweighed a sparse one
    (on the mock the step ranges from 0.1 to 4 s)."""
    t = np.arange(0.0, 400.0, 1.0)
    mission, _ = _fly(t, 0.0 * t, 0.0 * t, road_fleet(R, r), dt=0.1)
    assert mission.protect_start is not None and mission._scored_until is not None
    protected = mission._scored_until - mission.protect_start
    assert mission._scored_s == pytest.approx(protected, abs=0.5)


def _sides(streams: Streams, after: float) -> list[bool]:
    """The side (east of it) each UAV came back from, 5 s before each meeting with a convoy
    driving north at 8 m/s, in the order of the meetings after ``after``."""
    meetings = []
    for stream in streams.values():
        sps = [sp for sp in stream if sp.t >= after]
        dist = np.array([math.hypot(sp.north - 8.0 * sp.t, sp.east) for sp in sps])
        for k in range(50, len(sps) - 1):
            if dist[k] < 30.0 and dist[k] <= dist[k - 1] and dist[k] < dist[k + 1]:
                meetings.append((sps[k].t, sps[k - 50].east > 0.0))
    return [side for _, side in sorted(meetings)]


def test_consecutive_meetings_come_from_alternate_sides_of_the_convoy() -> None:
    """Every other UAV flies the mirror image of the paper's arc (``_offset``): the UAVs
    come back to the convoy from alternate sides, never three in a row from one (the
    paper's phasing brings a whole half-cycle of them, six here, from the same side)."""
    t = np.arange(0.0, 700.0, 1.0)
    mission, streams = _fly(t, 8.0 * t, 0.0 * t, 6, until=600.0)
    assert mission.protect_start is not None
    sides = _sides(streams, mission.protect_start)
    assert len(sides) >= 40 and 0 < sum(sides) < len(sides)
    assert all(len(set(sides[i : i + 3])) == 2 for i in range(len(sides) - 2))


def _unseen_s(streams: Streams, start: float, end: float, dt: float = 0.1) -> float:
    """Seconds between ``start`` and ``end`` that no commanded setpoint sees a convoy
    driving north at 8 m/s from the origin."""
    at = {u: {round(sp.t, 1): sp for sp in stream} for u, stream in streams.items()}
    unseen = 0
    for now in np.arange(start, end, dt).tolist():
        sps = [by[round(now, 1)] for by in at.values() if round(now, 1) in by]
        unseen += all(math.hypot(sp.north - 8.0 * now, sp.east) > r for sp in sps)
    return unseen * dt


_STRIP = {u: (200.0 + 10.0 * u, 400.0, math.pi) for u in range(1, 7)}
"""A fleet taking off from one strip, heading away from a road that runs north."""


def test_a_uav_left_on_the_mirror_image_of_its_pattern_goes_back_to_its_side() -> None:
    """Off the strip one UAV meets the convoy going the mirror of its pattern's way and
    (one arc after another) kept on doing so, three meetings in a row from one side
    every cycle, until a sudden corner found them all on its inside (the turning demo:
    13-16 s unseen). It goes back to its own side at a meeting on its pattern's heading,
    flyably, leaving the convoy unseen no longer than ``side_switch_cost_s``."""
    t = np.arange(0.0, 800.0, 1.0)
    joins_as_they_come = RoadSettings(join_heading_deg=180.0)
    mission, streams = _fly(
        t, 8.0 * t, 0.0 * t, 6, until=700.0, starts=_STRIP, road_settings=joins_as_they_come
    )
    assert mission.protect_start is not None and mission.protect_start < 150.0
    early = _sides(streams, mission.protect_start)
    assert any(len(set(early[i : i + 3])) == 1 for i in range(len(early) - 2))  # mirrored
    assert mission.side_switches >= 1
    late = _sides(streams, 350.0)
    assert len(late) >= 40
    assert all(len(set(late[i : i + 3])) == 2 for i in range(len(late) - 2))
    unseen = _unseen_s(streams, mission.protect_start, 700.0)
    assert unseen <= joins_as_they_come.side_switch_cost_s
    assert mission.predicted_coverage is not None and mission.predicted_coverage >= 0.99
    _assert_flyable(mission, streams)


def test_a_side_switch_is_charged_the_meeting_it_skips() -> None:
    """Going back to its side skips one of the UAV's meetings: 4-5 s of the convoy that
    no other UAV sees in this six-UAV pattern. That hole was once netted against the
    leg's own meeting at its end, which the path in force (a circle after its legs)
    never reached: switches that left 4 s unseen were taken as costing under 2 (a
    straight road on the mock: 97.6-98.9 % in 3 of 16 runs). Allowed 2 s, none is
    taken, and the UAV stays mirrored."""
    t = np.arange(0.0, 600.0, 1.0)
    strict = RoadSettings(join_heading_deg=180.0, side_switch_cost_s=2.0)
    mission, streams = _fly(
        t, 8.0 * t, 0.0 * t, 6, until=500.0, starts=_STRIP, road_settings=strict
    )
    assert mission.protect_start is not None
    assert mission.side_switches == 0
    sides = _sides(streams, 350.0)
    assert any(len(set(sides[i : i + 3])) == 1 for i in range(len(sides) - 2))  # still mirrored


_NORTH, _EAST = (8.0, 0.0), (0.0, 8.0)  # a convoy's velocity, m/s north and east


def _feed(
    mission: RoadMission, tracker: ConvoyTracker, now: float, drive: tuple[float, float] = _NORTH
) -> None:
    """The fix at ``now`` of a convoy driving straight from the origin at ``drive``, fed
    to ``mission`` as the service's control loop does."""
    tracker.update(now, drive[0] * now, drive[1] * now)
    est = tracker.estimate(now)
    if est is not None:
        mission.on_convoy(est)
    mission.tick(now)


def _joined(
    starts: dict[int, tuple[float, float, float]],
    settings: RoadSettings | None = None,
    drive: tuple[float, float] = _NORTH,
) -> tuple[RoadMission, ConvoyTracker, float]:
    """Six UAVs joining from ``starts`` as soon as that convoy is located (1-Hz fixes)."""
    mission = RoadMission(REQUEST, range(1, 7), down=lambda _u: -100.0, settings=settings)
    tracker = ConvoyTracker(window=4.0)
    now = 0.0
    while mission.plan is None:
        _feed(mission, tracker, now, drive)
        now += 1.0
    mission.join_many(starts, now)
    return mission, tracker, now


def _first_meeting(mission: RoadMission, uav: int, now: float, horizon: float) -> float:
    """The first meeting of ``uav``'s slot that a leg planned at ``now`` aims at."""
    offset = mission._offset(mission._slots[uav], len(mission.live_uavs))
    meetings = mission._forecast(now, horizon).meetings(offset, now + mission.settings.min_lead_s)
    return meetings[0]


def test_a_join_meets_the_pattern_on_its_heading() -> None:
    """A joining UAV whose legs would meet the pattern more than ``join_heading_deg`` off
    its heading meets it on its heading instead (when a leg to the same meeting fits):
    before it protects, the way to its side costs nothing. Six UAVs in a line abreast
    behind the convoy's start, flying its way."""
    starts = {u: (-200.0, 50.0 * u, 0.0) for u in range(1, 7)}
    for_each: dict[bool, RoadMission] = {}
    heading = {}
    for on in (False, True):
        mission, _, now = _joined(starts, RoadSettings(join_heading_deg=15.0 if on else 180.0))
        forecast = mission._forecast(now, 200.0)
        off = {}
        for u, slot in mission._slots.items():
            first = _first_meeting(mission, u, now, 200.0)
            traj = mission.trajectory(u)
            assert traj is not None
            s = traj.sample(mission._join_aims.get(u, first))
            laid = pattern_pose(forecast.pattern(mission._offset(slot, 6)), s.t)
            off[u] = abs(wrap_angle(s.heading - laid.heading))
        for_each[on] = mission
        heading[on] = off
    turned = [u for u in heading[False] if heading[False][u] > math.radians(15.0)]
    assert turned  # (the case arises)
    mission = for_each[True]
    aims = dict(mission._join_aims)
    assert aims  # and is met
    for u, aim in aims.items():
        assert heading[True][u] <= math.radians(1.0)
        assert mission.arrival(u) == pytest.approx(aim, abs=1e-6)  # it protects from there


def test_a_join_on_heading_keeps_its_aim_once_its_arrival_is_set() -> None:
    """A UAV joining on its heading protects from the end of that leg, set when it is
    first planned: the re-plans that follow (no longer a join's) still aim at it, so
    it arrives on its heading; one whose aim the forecast puts out of reach keeps
    the arrival it was given."""
    mission, tracker, now = _joined({u: (-200.0, 50.0 * u, 0.0) for u in range(1, 7)})
    first_aims = dict(mission._join_aims)
    assert first_aims
    last = min(first_aims.values()) - 2.0 * mission.settings.replan_every_s
    replans = mission.uav_replans
    while now < last:
        _feed(mission, tracker, now)
        now += 0.5
    assert mission.uav_replans > replans
    forecast = mission._forecast(now, 100.0)
    assert mission._join_aims  # still aimed at
    for u, aim in first_aims.items():
        assert mission.arrival(u) == aim  # it protects from there
    for u, aim in mission._join_aims.items():
        assert aim == first_aims[u]
        traj = mission.trajectory(u)
        assert traj is not None
        laid = pattern_pose(forecast.pattern(mission._offset(mission._slots[u], 6)), aim)
        assert abs(wrap_angle(traj.sample(aim).heading - laid.heading)) <= math.radians(2.0)


@pytest.mark.parametrize("north", [-400.0, 0.0, 400.0])
def test_a_join_that_would_meet_the_pattern_mirrored_waits_for_a_meeting_on_its_heading(
    north: float,
) -> None:
    """UAVs in a line across a convoy that drives east, flying south when they join: one
    whose legs would meet the pattern mirrored, with no leg on its heading fitting that
    meeting, aims at the next one. None then protects mirrored, so none has to go back
    to its side later at a skipped meeting's cost (the mock's straight road: 1-2.5 s
    unseen)."""
    starts = {u: (north, 60.0 * u - 200.0, math.pi) for u in range(1, 7)}
    mission, tracker, now = _joined(starts, drive=_EAST)
    later_aims = sum(
        aim > _first_meeting(mission, u, now, 300.0) + max(_JOIN_LAGS_S)
        for u, aim in mission._join_aims.items()
    )
    while now < 400.0:
        _feed(mission, tracker, now, _EAST)
        now += 0.5
    assert later_aims  # (the case arises)
    assert mission.protect_start is not None and mission.protect_start < 240.0
    assert mission.side_switches == 0


_CLIMB_OUT = {
    u: (450.0 + 18.0 * (u - 1), 1.4 + 9.8 * (u - 1), 0.145 - 0.023 * u) for u in range(1, 8)
}
"""Seven UAVs climbing out one after another from a strip 450 m north of the convoy's
start, where the mock's take-offs put them when they join (the replay test's flight)."""


@pytest.mark.parametrize("course_deg", range(0, 360, 30))
def test_uavs_joining_one_at_a_time_never_protect_mirrored(course_deg: int) -> None:
    """Each UAV that joins changes the pattern the others aim at, and an aim on the
    pattern's heading can fall out of reach. Its legs then met the pattern as they came,
    mirrored or on the way to it arc after arc, and 90 s into protection the UAV went
    back to its side at a skipped meeting's cost: a straight road on the mock lost
    1-3 s in most runs (98.6-99.6 %), this straight road from 3 of these 12 courses.
    An aim out of reach is now made afresh, at either of the next two meetings."""
    t = np.arange(0.0, 400.0, 1.0)
    course = math.radians(course_deg)
    mission, streams = _fly(
        t,
        8.0 * math.cos(course) * t,
        8.0 * math.sin(course) * t,
        7,
        until=330.0,
        starts=_CLIMB_OUT,
        join_at={u: 29.0 + u for u in _CLIMB_OUT},
        dt=0.2,
    )
    assert mission.protect_start is not None and mission.protect_start < 240.0
    assert mission.side_switches == 0
    assert mission.predicted_coverage == pytest.approx(1.0)
    _assert_flyable(mission, streams)


@pytest.mark.parametrize("turn_deg", [-90.0, 90.0])
def test_a_sudden_corner_either_way_leaves_no_long_gap(turn_deg: float) -> None:
    """No route: the convoy turns 90 deg at a corner nobody foresaw. With every UAV
    coming back from one side for a half-cycle, the turn away from it left the convoy
    unseen for 29 s (the other way: under 12); with alternate sides, 6.5-7 s either way;
    with detours that keep it in sight, 1-2.5 s (coverage 97.8-98.1 % -> 98.8-99.8 %).
    Re-planning the fleet at once on the change of velocity made this left turn's gap
    6.5 s again (98.4 %) while the 24 corners of ``road_table.py --corners`` went
    from 99.2 to 99.4 % on average, their longest gap 8 -> 7 s."""
    run = fly_road(*corner(turn_deg, 300.0, then_s=220.0), REQUEST, road_fleet(R, r))
    assert run.protect_start is not None and run.protect_start < 240.0
    assert run.longest_gap_s <= 7.0
    assert run.coverage >= 0.98


def _braking(speed: float, brake_at: float, end: float) -> tuple[Arr, Arr, Arr]:
    """1-Hz fixes of a convoy driving north at ``speed``, braking at 1 m/s^2 from
    ``brake_at`` to a stop, then standing until ``end``."""
    t = np.arange(0.0, end + 0.5, 1.0)
    v = np.clip(speed - np.maximum(t - brake_at, 0.0), 0.0, None)
    north = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
    return t, north, np.zeros_like(t)


@pytest.mark.parametrize("speed", [12.0, 6.0])
def test_a_convoy_faster_than_half_the_airspeed_is_told_with_how_long(speed: float) -> None:
    """``speed_ratio`` and the report's ``convoy_fast``: the seconds of the protect phase
    the convoy drove faster than ``FAST_CONVOY_RATIO`` of the airspeed, and how fast."""
    t, north, east = _braking(speed, 250.0, 330.0)
    mission, _ = _fly(t, north, east, road_fleet(R, r), dt=0.5)
    start = mission.protect_start
    assert start is not None and start < 200.0
    fast = mission.report()["convoy_fast"]
    assert fast["above_speed_ratio"] == FAST_CONVOY_RATIO
    ratio = speed / V
    assert fast["max_speed_ratio"] == pytest.approx(ratio, abs=0.02)
    if ratio >= FAST_CONVOY_RATIO:  # from the start of protection into the braking (to 262 s)
        assert 250.0 - start <= fast["seconds"] <= 262.0 - start
    else:
        assert fast["seconds"] == 0.0
    assert mission.speed_ratio is not None and mission.speed_ratio < 0.05  # (standing)


def test_on_a_straight_road_every_uav_flies_its_place_in_the_pattern() -> None:
    """``pattern_positions``: where the pattern as laid puts each UAV. On a straight road
    at constant speed the legs are the pattern's arcs, so once protecting a UAV flies its
    own place in it (and nothing is asked of a mission with no convoy yet)."""
    t = np.arange(0.0, 700.0, 1.0)
    n = road_fleet(R, r)
    idle = RoadMission(REQUEST, list(range(1, n + 1)), down=lambda _u: -100.0)
    assert idle.pattern_positions(0.0) == {}
    apart: list[float] = []

    def probe(mission: RoadMission, now: float) -> None:
        start = mission.protect_start
        if start is None or now < start + 60.0 or round(now * 10) % 20:
            return
        places = mission.pattern_positions(now)
        assert sorted(places) == list(range(1, n + 1))
        for u, (north, east) in places.items():
            sp = mission.setpoint(u, now)
            assert sp is not None
            apart.append(math.hypot(sp.north - north, sp.east - east))

    _fly(t, 8.0 * t, 0.0 * t, n, until=600.0, each=probe)
    assert len(apart) > 100 * n
    assert statistics.median(apart) < 2.0 and max(apart) < 10.0  # (measured: 0.9, 4.4 m)


def test_a_run_lists_its_unseen_stretches() -> None:
    """``RoadRun.gaps``: apart, in order, on the scoring grid, the longest the run's
    longest gap, and together the coverage's complement."""
    t, north, east = corner(-90.0, 300.0, then_s=220.0)
    run = fly_road(t, north, east, REQUEST, road_fleet(R, r))
    assert run.gaps and run.protect_start is not None
    ends = [end for _, end in run.gaps]
    starts = [start for start, _ in run.gaps]
    assert all(a < b for a, b in zip(ends, starts[1:], strict=False))  # apart, in order
    assert all(end - start >= 0.5 - 1e-9 for start, end in run.gaps)
    assert max(end - start for start, end in run.gaps) == pytest.approx(run.longest_gap_s)
    scored = np.count_nonzero(np.arange(float(t[0]), float(t[-1]), 0.5) >= run.protect_start)
    unseen = sum(end - start for start, end in run.gaps)
    assert unseen == pytest.approx((1.0 - run.coverage) * scored * 0.5)
    # The sudden corner: the pattern, its meetings on the convoy, still covered it; the
    # UAVs' legs, laid for the old course, did not.
    assert 0.0 < run.unseen_off_pattern_s <= unseen + 1e-9


@pytest.mark.parametrize("angle", [90.0, -90.0])
def test_a_junction_track_stops_where_and_as_long_as_asked_then_turns(angle: float) -> None:
    rt = junction(25.0, angle, 2400.0)
    speed = np.hypot(np.diff(rt.true_north), np.diff(rt.true_east)) / np.diff(rt.t)
    stopped = rt.t[1:][speed < 0.05]
    assert 24.0 <= len(stopped) <= 27.0  # 1-Hz fixes over the 25-s stop
    where = np.hypot(
        np.interp(stopped, rt.t, rt.true_north), np.interp(stopped, rt.t, rt.true_east)
    )
    assert np.all(np.abs(where - 2400.0) < 1.0)
    # Then 90 deg left (west of a road driven north) or right.
    course = math.degrees(
        math.atan2(rt.true_east[-1] - rt.true_east[-20], rt.true_north[-1] - rt.true_north[-20])
    )
    assert course == pytest.approx(-angle, abs=1.0)


def _fly_known_route(rt: RoadTrack) -> RoadRun:
    """``fly_road`` over a generated road, its path given as the route."""
    return fly_road(
        rt.t, rt.north, rt.east, REQUEST, road_fleet(R, r),
        true_north=rt.true_north, true_east=rt.true_east, route_known=True,
    )  # fmt: skip


@pytest.mark.parametrize("kind", ["gentle", "bends", "stop-and-go"])
def test_roads_with_a_known_route_are_covered(kind: str) -> None:
    run = _fly_known_route(road_kind(kind))
    assert run.protect_start is not None and run.protect_start < 240.0
    assert run.coverage >= 0.95
    assert run.predicted_coverage == pytest.approx(run.coverage, abs=0.01)
    assert run.min_turn_radius >= R * (1 - 1e-9)


@pytest.mark.parametrize(("angle", "at"), [(90.0, 2400.0), (-90.0, 2576.0)])
def test_a_convoy_that_stops_at_a_junction_on_its_route_is_kept_in_sight(
    angle: float, at: float
) -> None:
    """The route turns at a junction; the convoy stands there 25 s first. Keeps and fills
    are weighed against the convoy stopped short of the corner too, not only the one
    that turns it at speed (``Watch``): without, 95.0 % / 7.5 s and 94.8 % / 17.5 s."""
    run = _fly_known_route(junction(25.0, angle, at))
    assert run.coverage >= 0.975 and run.longest_gap_s <= 8.0
    assert run.predicted_coverage == pytest.approx(run.coverage, abs=0.01)


def test_hairpins_without_a_route_are_kept_in_sight_through_the_turns() -> None:
    """No route: each 180-deg hairpin is a corner nobody foresaw. The UAV that has just
    met the convoy turns back with it (a detour) instead of flying on to the pattern's
    next meeting: 81.3 % before detours, 90.0 % with them (six UAVs, one run). One run
    moves 5-10 points with the phase the formation meets the hairpins at (a change to
    the joins alone took it from 93.3 to 84.6 %), so the road's count without a route
    flies it from three starts, as ``road_table.py --no-route-count`` does."""
    rt = road_kind("hairpins")
    coverage = []
    for skip in (0.0, 11.0, 23.0):
        k = rt.t >= skip
        run = fly_road(
            rt.t[k] - skip, rt.north[k], rt.east[k], REQUEST, road_fleet(R, r, route=False),
            true_north=rt.true_north[k], true_east=rt.true_east[k],
        )  # fmt: skip
        assert run.protect_start is not None and run.protect_start < 240.0
        assert run.predicted_coverage == pytest.approx(run.coverage, abs=0.01)
        coverage.append(run.coverage)
    assert statistics.fmean(coverage) >= 0.90


def test_a_grid_that_stops_and_drives_off_is_protected_early_and_kept_in_sight() -> None:
    """Joining UAVs protect from their first meeting on time within r of their slot on
    the way. Within r/2, the last UAV to join a convoy that stops at junctions and
    drives off again chased meetings that moved at every re-plan, on time but 60-200 m
    off its slot, and protection began at 265 s (now 164 s). Standing at a junction,
    the convoy is also weighed driving off along its route (``Hedge``): without,
    90.3 %, longest gap 12 s. With the pattern laid between it standing and driving
    off (``drive_off_blend``) one stop of this grid leaves 12.5 s unseen (7 s
    without); over eleven grids the longest gap passes 10 s on one (three without)."""
    run = _fly_known_route(road_kind("urban", seed=2))
    assert run.protect_start is not None and run.protect_start < 240.0
    assert run.coverage >= 0.94 and run.longest_gap_s <= 15.0
    assert run.predicted_coverage == pytest.approx(run.coverage, abs=0.01)


def test_joins_lost_and_returned_uavs() -> None:
    t = np.arange(0.0, 600.0, 1.0)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=200.0)
    assert mission.protect_start is not None
    assert all(mission.phase(u, 200.0) == "protect" for u in range(1, 7))
    sides = {u: int(mission._offset(slot, 6)) for u, slot in mission._slots.items()}
    events = mission.on_lost(3, 200.0)
    assert any(
        isinstance(e, Replanned) and e.reason == "uav_lost" and e.uav_count == 5 for e in events
    )
    assert mission.phase(3, 200.0) == "lost" and mission.setpoint(3, 200.0) is None
    slots = sorted(mission._slots.values())
    assert slots == [0, 1, 2, 3, 4]  # the others re-spread over five slots
    # ... and most of them keep the side of the convoy they flew (the choice that does)
    kept = [int(mission._offset(slot, 5)) == sides[u] for u, slot in mission._slots.items()]
    assert sum(kept) >= 3
    events = mission.on_returned(3, 210.0)
    assert mission.phase(3, 210.0) == "pending"
    events = mission.join(3, 1700.0, 300.0, 0.0, 210.0)  # beside the convoy: at once
    assert PhaseChanged(3, "join", 210.0) in events
    assert not mission.returning_uavs and sorted(mission._slots.values()) == [0, 1, 2, 3, 4, 5]
    assert mission.setpoint(3, 211.0) is not None
    with pytest.raises(ValueError, match="not live"):
        mission.join(99, 0.0, 0.0, 0.0, 210.0)
    with pytest.raises(ValueError, match="finite"):
        mission.join(3, float("nan"), 0.0, 0.0, 210.0)


def test_a_uav_relaunched_far_behind_flies_to_the_fleet_before_the_others_respread() -> None:
    """Lost, and relaunched 2.5 km behind the convoy: the five others (as many as a stop
    needs, bar one) keep their spread while it flies to them beside a slot, on its own
    layer and out of their reckoning; at its first meeting there it is taken back and
    the fleet re-spread for six."""
    mission, tracker, now = _joined({u: (-200.0, 50.0 * u, 0.0) for u in range(1, 7)})
    while now < 200.0:
        _feed(mission, tracker, now)
        now += 1.0
    assert mission.protect_start is not None
    mission.on_lost(3, now)
    five = dict(mission._slots)
    assert sorted(five.values()) == [0, 1, 2, 3, 4]
    mission.on_returned(3, now)
    assert mission.phase(3, now) == "pending" and not mission.lost_uavs
    events = mission.join(3, 8.0 * now - 2500.0, 0.0, 0.0, now)
    returning = [e for e in events if isinstance(e, Returning)]
    assert len(returning) == 1 and returning[0].slot in five.values()
    assert not [e for e in events if isinstance(e, Replanned)]
    assert set(mission.returning_uavs) == {3} and 3 not in mission.live_uavs
    assert mission.phase(3, now) == "join" and mission.setpoint(3, now + 1.0) is not None
    view = MissionView.of(mission, lambda u: -100.0 - 10.0 * u)
    assert 3 not in view.lost and view.setpoint(3, now + 1.0) is not None
    assert {u: sl for u, sl in mission._slots.items() if u != 3} == five  # kept
    # Out of the others' reckoning: what they see of the convoy is theirs alone.
    watch = Watch(mission._forecast(now, 60.0), 40.0, r)
    expected = np.zeros(len(watch.times), dtype=bool)
    for u in mission.live_uavs:
        traj = mission.trajectory(u)
        if u != 1 and traj is not None:
            expected |= watch.sees(traj)
    assert (mission._others_see(1, now, watch, joining=True) == expected).all()
    back = None
    while now < 700.0 and back is None:
        _feed(mission, tracker, now)
        if 3 in mission.live_uavs:
            back = now
        now += 1.0
    assert back is not None, "never taken back"
    assert sorted(mission._slots.values()) == [0, 1, 2, 3, 4, 5]
    arrival = mission.arrival(3)
    assert arrival is not None and arrival <= back and mission.phase(3, back) == "protect"


def test_no_join_before_the_convoy_is_located() -> None:
    mission = RoadMission(REQUEST, [1, 2], down=lambda _u: -100.0)
    assert mission.plan is None
    with pytest.raises(PlanningError, match="not been located"):
        mission.join(1, 0.0, 0.0, 0.0, 0.0)
    with pytest.raises(ValueError, match="unique"):
        RoadMission(REQUEST, [1, 1], down=lambda _u: -100.0)


def test_planner_choice() -> None:
    assert road_fleet(R, r) == 6
    assert choose_planner("auto", 6, R, r)[0] == "road"
    plan, why = choose_planner("auto", 5, R, r)
    assert plan == "paper" and "needs 6" in why
    assert choose_planner("road", 2, R, r) == ("road", "asked for, with 2 of the 6 UAVs it needs")
    assert choose_planner("paper", 9, R, r)[0] == "paper"


def test_without_a_route_the_road_asks_for_one_uav_more() -> None:
    """The corners nobody foresees: the stationary minimum + 2 with no route. Six still
    fly the road planner (they cover any stop), and the operator is told."""
    assert road_fleet(R, r, route=False) == 7
    plan, why = choose_planner("auto", 6, R, r, route=False)
    assert plan == "road" and "with no route, 7 UAVs" in why
    assert "no route" not in choose_planner("auto", 7, R, r, route=False)[1]
    assert "no route" not in choose_planner("auto", 6, R, r, route=True)[1]
    assert choose_planner("road", 6, R, r, route=False)[1].startswith("asked for; with no route")
    assert choose_planner("auto", 5, R, r, route=False)[0] == "paper"


def test_commanded_arcs_are_the_papers_on_a_straight_road() -> None:
    """With the paper's count for a straight road there is no spare turn: the legs are
    Section IV's arcs of radius R themselves."""
    t = np.arange(0.0, 800.0, 1.0)
    mission, _ = _fly(t, 12.0 * t, 0.0 * t, 3, until=700.0)
    radii = [s.radius for u in (1, 2, 3) for s in _lead_in(mission, u) if s.turn != Turn.STRAIGHT]
    assert np.median(radii) == pytest.approx(R, rel=0.02)


def _lead_in(mission: RoadMission, uav: int) -> tuple[Segment, ...]:
    traj = mission.trajectory(uav)
    assert traj is not None
    return traj.lead_in


def _far(t0: float) -> Trajectory:
    """A circle kilometres from any convoy of these tests."""
    return Trajectory(t0, (Segment(Pose(1e5, 1e5, 0.0), Turn.LEFT, R, V, 2 * math.pi * R / V),))


def test_a_replan_never_throws_away_a_pass_no_other_uav_makes() -> None:
    t = np.arange(0.0, 600.0, 1.0)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=200.0)
    watch = Watch(mission._forecast(200.0, 60.0), 40.0, r)
    covering = []
    for u in range(1, 7):
        path = mission.trajectory(u)
        assert path is not None
        others = mission._others_see(u, 200.0, watch)
        in_force = watch.sees(path)
        assert not mission._keeps(in_force, in_force, watch, others)  # the same path: taken
        covering.append(mission._keeps(in_force, watch.sees(_far(200.0)), watch, others))
        # With the convoy seen by every other UAV all the time, nothing is kept.
        everywhere = np.ones(len(watch.times), dtype=bool)
        assert not mission._keeps(in_force, watch.sees(_far(200.0)), watch, everywhere)
    # Six UAVs tiling the convoy's time between them: most of them see some of it
    # alone over the next 40 s, and keep their pass.
    assert sum(covering) >= 4
    # A path in force that sees nothing is never kept, protecting or joining.
    for u in (1, 2):
        if u == 2:
            mission.on_lost(2, 200.0)
            mission.on_returned(2, 201.0)
            mission.join(2, 0.0, 1600.0, 0.0, 201.0)
        mission._trajectories[u] = _far(202.0)
        mission._plan_paths(202.0, [u])
        assert mission.trajectory(u) is not None
        assert mission.trajectory(u) != _far(202.0)


def test_a_hole_the_pattern_leaves_is_filled_by_a_uav_flying_to_the_convoy() -> None:
    t = np.arange(0.0, 600.0, 1.0)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=200.0)
    now = 200.0
    forecast = mission._forecast(now, 240.0)
    watch = Watch(forecast, 40.0, r)
    limits = mission._limits()
    nobody = np.zeros(len(watch.times), dtype=bool)
    filled = detours = 0
    for u in range(1, 7):
        start = mission._start(u, now, 0.0)
        assert start is not None
        pose = start.pose
        # The other UAVs gone, and this one's legs (here: a circle far off) see nothing.
        out = mission._fill(u, start, watch.sees(_far(now)), forecast, watch, nobody, limits)
        if out is None:
            continue
        filled += 1
        legs, path = out
        first = legs[0]
        assert first.on_time
        cx, cy = forecast.cx, forecast.cy
        if math.isnan(first.mean_offset):
            # A detour that keeps the convoy in sight: it sees it while flown.
            detours += 1
            flown = (watch.times >= now) & (watch.times <= first.t_end)
            assert np.any(watch.sees(path) & flown)
        else:
            # The first leg ends on the forecast convoy, at its time, flyably.
            end = first.end
            assert (
                math.hypot(
                    end.x - np.interp(first.t_end, forecast.t, cx),
                    end.y - np.interp(first.t_end, forecast.t, cy),
                )
                < 1.0
            )
        for leg in legs:
            assert BAND[0] - 1e-9 <= leg.speed <= BAND[1] + 1e-9
            assert all(seg.turn == Turn.STRAIGHT or seg.radius >= R - 1e-9 for seg in leg.segments)
        assert path.sample(now).x == pytest.approx(pose.x)
        assert watch.seconds(watch.sees(path)) > mission.settings.fill_margin_s
        # With the convoy seen all the time by the others, there is no hole to fill.
        everywhere = np.ones(len(watch.times), dtype=bool)
        assert (
            mission._fill(u, start, watch.sees(_far(now)), forecast, watch, everywhere, limits)
            is None
        )
    # Every UAV flies within a few hundred metres of the convoy: each can reach it,
    # and for some (those flying away from it) a turn back sees it longest.
    assert filled == 6
    assert 0 < detours < 6


def test_the_replan_interval_says_when_the_planner_falls_behind() -> None:
    """Stepped at 10 Hz each protecting UAV is re-planned every 4 s; stepped every
    3 s (a starved worker: one UAV a step), every 18 s, and the figure says so."""
    t = np.arange(0.0, 900.0, 1.0)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=240.0)
    assert mission.protect_start is not None
    every = mission.settings.replan_every_s
    assert mission.replan_interval_s == pytest.approx(every, abs=0.2)
    assert mission.report()["replan_interval_s"] == pytest.approx(every, abs=0.5)
    tracker = ConvoyTracker(window=4.0)
    for now in np.arange(230.0, 400.0, 1.0).tolist():
        tracker.update(now, 8.0 * now, 0.0)
        if now >= 240.0 and now % 3.0 == 0.0:
            est = tracker.estimate(now)
            assert est is not None
            mission.on_convoy(est)
    assert mission.replan_interval_s == pytest.approx(6 * 3.0, abs=0.5)
    assert mission.report()["replan_interval_s"] > every


@pytest.mark.parametrize("on_change", [1.5, 0.0])
def test_a_change_of_the_convoy_s_velocity_re_plans_every_uav_at_once(on_change: float) -> None:
    """In turn, one UAV of six is re-planned a step; a corner (the convoy's velocity
    turned 90 deg) re-plans all six at the step it shows, unless switched off."""
    t = np.arange(0.0, 600.0, 1.0)
    settings = RoadSettings(replan_on_change_mps=on_change)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=240.0, road_settings=settings)
    assert mission.protect_start is not None

    def replanned(est: ConvoyEstimate) -> int:
        mission.on_convoy(est)
        return sum(mission._planned_at[u] == est.t for u in mission._slots)

    assert replanned(ConvoyEstimate(240.0, 1920.0, 0.0, 8.0, 0.0)) <= 1  # steady: in turn
    turned = replanned(ConvoyEstimate(240.1, 1920.0, 0.8, 0.0, 8.0))
    assert turned == 6 if on_change else turned <= 1
    assert replanned(ConvoyEstimate(240.2, 1920.0, 1.6, 0.0, 8.0)) <= 1  # planned on it


def test_a_re_plan_that_takes_a_while_keeps_each_uav_on_its_path_until_flown() -> None:
    """With a lag (a host at 40x), the new legs begin that far ahead, on the path in
    force: the setpoint never moves under a UAV; at a corner the changed UAVs are
    re-planned a few a step, the nearest the convoy first."""
    t = np.arange(0.0, 600.0, 1.0)
    mission, _ = _fly(t, 8.0 * t, 0.0 * t, 6, until=240.0)
    base, per_uav = 0.1, 0.4
    mission.set_replan_lag(base, per_uav)
    x, y = mission.model.position(240.0)
    before = {u: mission.trajectory(u) for u in mission._slots}
    mission.on_convoy(ConvoyEstimate(240.0, 1920.0, 0.8, 0.0, 8.0))  # a sudden 90-deg left
    planned = [u for u in mission._slots if mission._planned_at[u] == 240.0]
    # One in its turn and, of the six changed, as many as a second of lag allows.
    assert 1 <= len(planned) <= 2
    lead = base + per_uav * len(planned)
    for u in planned:
        old, new = before[u], mission.trajectory(u)
        assert old is not None and new is not None and new is not old
        ts = np.linspace(240.0, 240.0 + lead, 41)
        a, b = old.sample_array(ts), new.sample_array(ts)
        assert np.max(np.hypot(a.x - b.x, a.y - b.y)) < 1e-6  # kept until flown
        assert new.sample(240.0 + lead + 20.0) != old.sample(240.0 + lead + 20.0)
    away = {
        u: math.hypot(p.x - x, p.y - y)
        for u in mission._slots
        if (p := mission._pose_at(u, 240.0)) is not None
    }
    assert min(away[u] for u in planned) <= min(away.values()) + 1e-9  # the nearest first
    # The next steps re-plan the rest: within a few steps every UAV flies the corner.
    for k in range(1, 6):
        mission.on_convoy(ConvoyEstimate(240.0 + k, 1920.0, 0.8 + 8.0 * k, 0.0, 8.0))
    assert all(mission._planned_v[u][0] > 7.0 for u in mission._slots)  # (x east)
    mission.set_replan_lag(0.05, 0.1)  # the report: the lag now, and the longest told
    assert mission.report()["replan_lag_s"] == {"base": 0.05, "per_uav": 0.1, "max_one_uav": 0.5}


def test_a_host_that_plans_slowly_flies_its_plans_late_not_off_them() -> None:
    """``fly_road`` with the lag of the mock at 40x: a step at a time, each step's legs
    flown after it. The prediction is still what is flown; re-plans are fewer."""
    t = np.arange(0.0, 700.0, 1.0)
    north, east = 8.0 * t, np.where(t < 400.0, 0.0, 8.0 * (t - 400.0))  # a 90-deg right
    quick = fly_road(t, north, east, REQUEST, road_fleet(R, r))
    slow = fly_road(t, north, east, REQUEST, road_fleet(R, r), replan_lag=(0.15, 0.4))
    assert slow.predicted_coverage == pytest.approx(slow.coverage, abs=0.01)
    assert slow.uav_replans < quick.uav_replans
    assert slow.coverage >= quick.coverage - 0.03


def test_a_convoy_whose_feed_pauses_is_held_where_last_seen() -> None:
    """A logger that records only on the move (the recorded drive's pauses 1400 s of
    4900): the convoy drives 300 s, parks for 120 s with no fix, drives on."""
    drive = np.arange(0.0, 301.0, 1.0)
    t = np.concatenate([drive, 420.0 + drive[:-1]])
    s = np.concatenate([8.0 * drive, 2400.0 + 8.0 * drive[:-1]])
    held = fly_road(t, 0.6 * s, 0.8 * s, REQUEST, road_fleet(R, r))
    assert held.coverage >= 0.98 and held.longest_gap_s <= 4.0
    assert held.predicted_coverage == pytest.approx(held.coverage, abs=0.01)
    # Flying on the plans in force instead: round hold circles where the legs end.
    never = RoadSettings(hold_after_s=math.inf)
    frozen = fly_road(t, 0.6 * s, 0.8 * s, REQUEST, road_fleet(R, r), settings=never)
    assert frozen.coverage < 0.9 and frozen.longest_gap_s > 30.0


def test_a_held_convoy_is_planned_for_as_stopped_and_released_by_a_fresh_fix() -> None:
    mission = RoadMission(REQUEST, [1, 2, 3, 4, 5, 6], down=lambda _u: -100.0)
    for k in range(60):
        mission.on_convoy(ConvoyEstimate(float(k), 0.0, 8.0 * k, 0.0, 8.0))
        mission.tick(float(k))
    mission.join_many({u: (300.0, 300.0 * u, 0.0) for u in range(1, 7)}, 59.0)
    last = mission.model.position(59.0)
    stale = ConvoyEstimate(59.0, 0.0, 8.0 * 59, 0.0, 8.0, stale=True)
    for now in np.arange(59.5, 63.9, 0.5).tolist():  # silent, not yet for hold_after_s
        mission.on_convoy(stale)
        mission.tick(now)
    assert mission.holds == 0
    assert mission.model.position(100.0)[0] > last[0] + 300.0  # still driving on
    for now in np.arange(64.0, 120.0, 0.5).tolist():
        mission.on_convoy(stale)
        mission.tick(now)
    assert mission.holds == 1 and mission.report()["convoy_holds"] == 1
    assert mission.model.position(200.0) == pytest.approx(last)  # parked where last seen
    assert mission.uav_replans > 6 * 10  # re-planned all along (every 4 s)
    assert mission.plan is not None
    mission.on_convoy(ConvoyEstimate(120.0, 0.0, 8.0 * 59 + 5.0, 0.0, 0.5))
    mission.tick(120.5)
    assert mission.model.position(130.0)[0] == pytest.approx(8.0 * 59 + 10.0)
    for now in np.arange(121.0, 140.0, 0.5).tolist():
        mission.tick(now)
    assert mission.holds == 2  # silent again after the one fix: a second hold
