"""The Mission state machine: plan, joins, phases, replans, lost UAVs."""

from __future__ import annotations

import math

import pytest

from convoy_mav.errors import PlanningError
from convoy_mav.mission import (
    Mission,
    MissionAlarm,
    MissionEvent,
    MissionView,
    PhaseChanged,
    Replanned,
    ReplanThresholds,
    Returning,
)
from convoy_mav.planning import PlanRequest
from convoy_mav.schedule import setpoint_at
from convoy_mav.types import ConvoyEstimate

REQUEST = PlanRequest(150.0, 100.0, 18.0)
IDS = (11, 12, 13, 14, 15)


def _down(uav: int) -> float:
    return -100.0 - 10.0 * (uav - 11)


def _feed(
    mission: Mission, t0: float, t1: float, vn: float = 0.0, ve: float = 0.0, dt: float = 0.1
) -> list[MissionEvent]:
    """Estimates of a convoy at (500, -200) + v t, every ``dt``."""
    events: list[MissionEvent] = []
    for k in range(round((t1 - t0) / dt)):
        t = t0 + k * dt
        est = ConvoyEstimate(t, 500.0 + vn * t, -200.0 + ve * t, vn, ve)
        events += mission.on_convoy(est)
    return events


def _joined_mission(ids: tuple[int, ...] = IDS) -> tuple[Mission, list[MissionEvent]]:
    mission = Mission(REQUEST, ids, down=_down)
    events = _feed(mission, 0.0, 3.0)
    for k, uav in enumerate(ids):
        events += mission.join(uav, -400.0 + 50 * k, 300.0, 0.5 * k, 3.0)
    return mission, events


def test_nothing_to_fly_before_the_convoy_is_located() -> None:
    mission = Mission(REQUEST, IDS, down=_down)
    assert mission.plan is None and mission.predicted_coverage is None
    assert mission.setpoint(11, 0.0) is None
    assert mission.phase(11, 0.0) == "pending"
    assert mission.convoy_position(0.0) is None
    assert mission.joined_at is None
    with pytest.raises(PlanningError):
        mission.join(11, 0.0, 0.0, 0.0, 0.0)
    stale = ConvoyEstimate(5.0, 0.0, 0.0, 0.0, 0.0, stale=True)
    assert all(mission.on_convoy(stale) == [] for _ in range(100))
    assert mission.plan is None


def test_first_plan_and_joins() -> None:
    mission, events = _joined_mission()
    plan = mission.plan
    assert plan is not None and plan.case == "stationary" and len(plan.vehicles) == 5
    first = events[0]
    assert isinstance(first, Replanned) and first.t == pytest.approx(2.0)
    assert first == Replanned(first.t, "initial", 1.0, 5, 5, "stationary")
    assert mission.plan_origin == (500.0, -200.0) and mission.plan_t0 == pytest.approx(2.0)
    assert sorted(mission.assignment(u) for u in IDS) == [0, 1, 2, 3, 4]  # type: ignore[type-var]
    assert [e for e in events if isinstance(e, PhaseChanged)] == [
        PhaseChanged(u, "join", 3.0) for u in IDS
    ]
    for k, uav in enumerate(IDS):
        sp = mission.setpoint(uav, 3.0)
        assert sp is not None
        assert (sp.north, sp.east, sp.down) == pytest.approx((-400.0 + 50 * k, 300.0, _down(uav)))
        assert sp.yaw == pytest.approx(0.5 * k)
        assert mission.phase(uav, 3.0) == "join"
    arrivals = {u: mission.arrival(u) for u in IDS}
    last = max(a for a in arrivals.values() if a is not None)
    assert mission.joined_at == last
    assert mission.protect_start is None
    later = _feed(mission, 3.0, last + 1.0)
    protect = [e for e in later if isinstance(e, PhaseChanged)]
    assert sorted(protect, key=lambda e: e.t) == protect
    assert {(e.uav, e.t) for e in protect} == {(u, arrivals[u]) for u in IDS}
    assert all(e.phase == "protect" for e in protect)
    assert mission.protect_start == last
    assert all(mission.phase(u, last) == "protect" for u in IDS)
    # on its slot after arrival: the plan's setpoint for its vehicle index
    uav = IDS[2]
    index = mission.assignment(uav)
    assert index is not None
    expected = setpoint_at(
        plan,
        index,
        last + 30.0,
        plan_origin=mission.plan_origin,
        plan_t0=mission.plan_t0,
        down=_down(uav),
    )
    got = mission.setpoint(uav, last + 30.0)
    assert got is not None
    assert (got.north, got.east) == pytest.approx((expected.north, expected.east), abs=1e-3)


def test_a_replan_keeps_every_setpoint_continuous() -> None:
    mission, _ = _joined_mission()
    _feed(mission, 3.0, 120.0)
    before = {u: mission.setpoint(u, 126.0) for u in IDS}
    events = _feed(mission, 120.0, 135.0, vn=4.0, ve=4.0)  # the convoy drives off
    replans = [e for e in events if isinstance(e, Replanned)]
    assert [e.reason for e in replans] == ["convoy_started"]
    t_r = replans[0].t
    assert 122.0 <= t_r <= 124.0
    assert mission.plan is not None and mission.plan.case == "moving"
    assert mission.plan_t0 == pytest.approx(t_r)
    assert mission.plan_origin == pytest.approx((500.0 + 4.0 * t_r, -200.0 + 4.0 * t_r))
    assert mission.plan.request.convoy_heading == pytest.approx(math.pi / 4)
    assert {e.uav for e in events if isinstance(e, PhaseChanged) and e.phase == "join"} == set(IDS)
    for uav in IDS:
        assert mission.phase(uav, t_r) == "join"
        old, new = before[uav], mission.setpoint(uav, t_r)
        assert old is not None and new is not None
        # the old trajectory was sampled at 126 s; compare positions at t_r
        assert math.hypot(new.north - old.north, new.east - old.east) <= 18.0 * (126.0 - t_r) + 1e-6
        step = mission.setpoint(uav, t_r + 0.1)
        assert step is not None
        assert math.hypot(step.north - new.north, step.east - new.east) <= 1.8 + 1e-6
    assert mission.protect_start is not None  # the first protect phase is remembered
    assert mission.joined_at is not None and mission.joined_at > t_r
    assert mission.convoy_position(t_r + 10.0) == pytest.approx(
        (500.0 + 4.0 * (t_r + 10.0), -200.0 + 4.0 * (t_r + 10.0))
    )


def test_replan_continuity_exact() -> None:
    mission, _ = _joined_mission()
    _feed(mission, 3.0, 60.0)
    t = 60.0
    # the pose each UAV is planned to have just before the change
    planned = {u: mission.setpoint(u, t) for u in IDS}
    mission.on_lost(IDS[0], t)
    for uav in IDS[1:]:
        old, new = planned[uav], mission.setpoint(uav, t)
        assert old is not None and new is not None
        assert (new.north, new.east, new.vn, new.ve) == pytest.approx(
            (old.north, old.east, old.vn, old.ve), abs=1e-6
        )


def test_losing_a_uav_rephases_the_rest() -> None:
    mission, _ = _joined_mission()
    _feed(mission, 3.0, 200.0)
    events = mission.on_lost(13, 200.0)
    replans = [e for e in events if isinstance(e, Replanned)]
    assert len(replans) == 1
    lost = replans[0]
    assert (lost.reason, lost.uav_count, lost.min_uavs) == ("uav_lost", 4, 5)
    assert lost.predicted_coverage == pytest.approx(4 * math.asin(100 / 150) / math.pi)
    assert mission.predicted_coverage == lost.predicted_coverage
    assert mission.live_uavs == (11, 12, 14, 15) and mission.lost_uavs == (13,)
    assert mission.phase(13, 200.0) == "lost" and mission.setpoint(13, 200.0) is None
    assert sorted(mission.assignment(u) for u in mission.live_uavs) == [0, 1, 2, 3]  # type: ignore[type-var]
    assert mission.plan_origin == pytest.approx((500.0, -200.0))  # the same convoy anchor
    assert mission.on_lost(13, 201.0) == []
    assert mission.on_lost(99, 201.0) == []
    with pytest.raises(ValueError):
        mission.join(13, 0.0, 0.0, 0.0, 201.0)
    # losing everybody leaves no plan and nothing to fly
    for uav in (11, 12, 14):
        mission.on_lost(uav, 202.0)
    events = mission.on_lost(15, 203.0)
    assert events[-1] == Replanned(203.0, "uav_lost", 0.0, 0)
    assert mission.plan is None and not mission.live_uavs


def test_a_returned_uav_near_the_fleet_is_planned_back_in_at_once_and_rejoins() -> None:
    mission, _ = _joined_mission()
    _feed(mission, 3.0, 200.0)
    mission.on_lost(13, 200.0)
    assert mission.on_returned(11, 250.0) == []  # not lost: nothing to do
    assert not [e for e in mission.on_returned(13, 250.0) if isinstance(e, Replanned)]
    # flying again, it waits for its join, which decides how it is taken back
    assert set(mission.returning_uavs) == {13} and mission.lost_uavs == ()
    assert mission.phase(13, 250.0) == "pending" and mission.setpoint(13, 250.0) is None
    events = mission.join(13, 600.0, -100.0, 0.3, 250.0)  # beside the convoy
    replans = [e for e in events if isinstance(e, Replanned)]
    assert [(r.reason, r.uav_count) for r in replans] == [("uav_returned", 5)]
    assert not [e for e in events if isinstance(e, Returning)]
    assert mission.predicted_coverage == pytest.approx(1.0)
    assert mission.live_uavs == (11, 12, 14, 15, 13) and not mission.returning_uavs
    # the others re-phase at once; the returned UAV joins the free slot
    assert sorted(mission.assignment(u) for u in IDS) == [0, 1, 2, 3, 4]  # type: ignore[type-var]
    assert mission.phase(13, 250.0) == "join"
    arrival = mission.arrival(13)
    assert arrival is not None and arrival - 250.0 <= mission.shadow_after_s
    assert mission.phase(13, arrival + 1.0) == "protect"


def test_a_returned_uav_far_behind_flies_to_the_fleet_before_the_others_rephase() -> None:
    """Relaunched from its pad 6 km behind a parked convoy, the returned UAV would take
    minutes to join: re-phased for it at once, the others would leave its slot empty
    all that while. The five others cover the convoy fully (the paper's minimum), so
    it flies to the fleet on a slot of the plan in force; the others keep their plan,
    and re-phase for six only once it is there."""
    ids = (11, 12, 13, 14, 15, 16)
    mission, _ = _joined_mission(ids)
    _feed(mission, 3.0, 200.0)
    mission.on_lost(13, 200.0)
    five = mission.predicted_coverage
    assert five == pytest.approx(1.0)
    others = (11, 12, 14, 15, 16)
    before = {u: mission.setpoint(u, 300.0) for u in others}
    mission.on_returned(13, 250.0)
    events = mission.join(13, 500.0 - 6000.0, -200.0, 0.0, 250.0)
    returning = [e for e in events if isinstance(e, Returning)]
    assert len(returning) == 1 and not [e for e in events if isinstance(e, Replanned)]
    there = returning[0].arrival
    assert there - 250.0 > mission.shadow_after_s
    assert set(mission.returning_uavs) == {13} and mission.live_uavs == others
    assert mission.phase(13, 250.0) == "join" and mission.arrival(13) == there
    assert mission.predicted_coverage == five  # the plan for five stays in force
    assert mission.plan is not None and len(mission.plan.vehicles) == 5
    assert {u: mission.setpoint(u, 300.0) for u in others} == before
    view = MissionView.of(mission, _down)  # what the service streams from
    assert view.phase(13, 250.0) == "join" and view.setpoint(13, 250.0) is not None
    assert 13 not in view.lost
    # on its way it flies its own layer, on the slot it shares
    sp = mission.setpoint(13, there)
    shared = next(u for u in others if mission.assignment(u) == returning[0].slot)
    mate = mission.setpoint(shared, there)
    assert sp is not None and mate is not None and sp.down == _down(13)
    assert math.hypot(sp.north - mate.north, sp.east - mate.east) < 1.0
    # there: taken back, and every UAV re-phased for six from where it flies
    events = mission.tick(there + 0.05)
    replans = [e for e in events if isinstance(e, Replanned)]
    assert [(r.reason, r.uav_count) for r in replans] == [("uav_returned", 6)]
    assert list(mission.live_uavs) == [*others, 13] and not mission.returning_uavs
    assert mission.predicted_coverage == pytest.approx(1.0)
    assert sorted(mission.assignment(u) for u in ids) == [0, 1, 2, 3, 4, 5]  # type: ignore[type-var]
    after = mission.setpoint(13, there + 0.05)
    assert after is not None and math.hypot(after.north - sp.north, after.east - sp.east) < 5.0
    arrival = mission.arrival(13)
    assert arrival is not None and arrival - there < mission.shadow_after_s


def test_a_returned_uav_far_behind_is_planned_back_in_at_once_when_it_is_needed() -> None:
    """Four of five do not cover the convoy fully: the plan has holes with the returned
    UAV's slot empty or without it, and the fleet is re-planned for five at once."""
    mission, _ = _joined_mission()
    _feed(mission, 3.0, 200.0)
    mission.on_lost(13, 200.0)
    assert mission.predicted_coverage is not None and mission.predicted_coverage < 1.0
    mission.on_returned(13, 250.0)
    events = mission.join(13, 500.0 - 6000.0, -200.0, 0.0, 250.0)
    replans = [e for e in events if isinstance(e, Replanned)]
    assert [(r.reason, r.uav_count) for r in replans] == [("uav_returned", 5)]
    assert not [e for e in events if isinstance(e, Returning)]
    arrival = mission.arrival(13)
    assert arrival is not None and arrival - 250.0 > mission.shadow_after_s


def test_a_returning_uav_lost_again_or_alone_is_handled() -> None:
    mission, _ = _joined_mission((11, 12, 13, 14, 15, 16))
    _feed(mission, 3.0, 200.0)
    mission.on_lost(13, 200.0)
    mission.on_returned(13, 250.0)
    mission.join(13, -5500.0, -200.0, 0.0, 250.0)
    assert set(mission.returning_uavs) == {13}
    assert mission.on_lost(13, 260.0) == []  # lost again on its way
    assert not mission.returning_uavs and mission.lost_uavs == (13,)
    assert mission.phase(13, 260.0) == "lost" and mission.setpoint(13, 260.0) is None
    mission.on_returned(13, 270.0)
    mission.join(13, -5500.0, -200.0, 0.0, 270.0)
    # a re-plan on the way (the convoy drives off) sends it to the new plan's fleet
    _feed(mission, 270.0, 300.0, vn=5.0)
    assert set(mission.returning_uavs) == {13} and mission.phase(13, 300.0) == "join"
    # the whole fleet lost: the returning UAV is the fleet, planned for at once
    for uav in (11, 12, 14, 15, 16):
        mission.on_lost(uav, 301.0)
    assert mission.live_uavs == (13,) and not mission.returning_uavs
    assert mission.plan is not None and mission.phase(13, 301.0) == "join"


def test_lost_before_the_plan_shrinks_the_first_plan() -> None:
    mission = Mission(REQUEST, IDS, down=_down)
    assert mission.on_lost(12, 0.5) == []
    events = _feed(mission, 0.0, 3.0)
    assert [e.uav_count for e in events if isinstance(e, Replanned)] == [4]
    assert mission.awaiting_join == (11, 13, 14, 15)


def test_rejoin_from_an_actual_pose_keeps_the_slot_set_consistent() -> None:
    mission, _ = _joined_mission()
    slot = mission.assignment(12)
    mission.join(12, 1000.0, 1000.0, 1.0, 10.0)
    assignments = [mission.assignment(u) for u in IDS]
    assert sorted(assignments) == [0, 1, 2, 3, 4]  # type: ignore[type-var]
    assert mission.assignment(12) == slot  # the only free slot is its own


def test_join_many_shares_the_slots_out_jointly() -> None:
    poses = {u: (-400.0 + 50 * k, 300.0, 0.5 * k) for k, u in enumerate(IDS)}
    one_by_one, _ = _joined_mission()  # the same poses, one join() after another
    jointly = Mission(REQUEST, IDS, down=_down)
    _feed(jointly, 0.0, 3.0)
    events = jointly.join_many(poses, 3.0)
    assert [e for e in events if isinstance(e, PhaseChanged)] == [
        PhaseChanged(u, "join", 3.0) for u in IDS
    ]
    assert sorted(jointly.assignment(u) for u in IDS) == [0, 1, 2, 3, 4]  # type: ignore[type-var]
    joint, sequential = jointly.joined_at, one_by_one.joined_at
    assert joint is not None and sequential is not None
    assert joint <= sequential + 1e-6
    with pytest.raises(ValueError):
        jointly.join_many({11: (0.0, 0.0, math.inf)}, 5.0)
    with pytest.raises(ValueError):
        jointly.join_many({11: (0.0, 0.0)}, 5.0)  # type: ignore[dict-item]


def test_a_convoy_too_fast_raises_an_alarm_and_keeps_the_plan() -> None:
    mission, _ = _joined_mission()
    plan = mission.plan
    events = _feed(mission, 3.0, 12.0, vn=25.0)
    alarms = [e for e in events if isinstance(e, MissionAlarm)]
    assert len(alarms) == 1 and "convoy speed" in alarms[0].message
    assert mission.plan is plan


def test_altitude_comes_from_the_callable() -> None:
    mission, _ = _joined_mission()
    for uav in IDS:
        sp = mission.setpoint(uav, 50.0)
        assert sp is not None and sp.down == _down(uav) and sp.vd == 0.0


def test_thresholds_default_position_tolerance_is_a_quarter_of_r() -> None:
    mission = Mission(REQUEST, IDS, down=_down)
    assert mission.detector.position_tol == 25.0
    mission = Mission(REQUEST, IDS, down=_down, thresholds=ReplanThresholds(position_tol=7.0))
    assert mission.detector.position_tol == 7.0


@pytest.mark.parametrize("ids", [(), (1, 1)])
def test_bad_uav_lists(ids: tuple[int, ...]) -> None:
    with pytest.raises(ValueError):
        Mission(REQUEST, ids, down=_down)


def test_join_refuses_non_finite_poses() -> None:
    mission, _ = _joined_mission()
    with pytest.raises(ValueError):
        mission.join(11, math.nan, 0.0, 0.0, 5.0)
