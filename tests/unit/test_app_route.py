"""The scripted convoy of ``convoy.source = "route"`` sets off with the mission.

Mission time is the reference autopilot's boot clock: against autopilots powered up
an hour before, a route timed from boot would start 3600 s x speed down the road.
"""

from __future__ import annotations

import time
from dataclasses import replace
from types import SimpleNamespace
from typing import Any

import pytest

from convoy_mav.app import ConvoyService, _without_setpoints
from convoy_mav.config import MissionConfig, parse_config
from convoy_mav.mission.road import RoadMission
from convoy_mav.types import ConvoyEstimate


def test_the_scripted_route_starts_when_the_mission_does() -> None:
    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0},
            "uav": [{"connection": "udpin:127.0.0.1:14560", "sysid": 1}],
            "convoy": {
                "source": "route", "speed_mps": 5.0, "heading_deg": 90.0,
                "start": {"north": 20.0, "east": -30.0},
            },
        }
    )  # fmt: skip
    service = ConvoyService(cfg)
    boot = 3600.0  # the autopilots have been up for an hour
    for k in range(21):  # the control loop's first two seconds of the mission
        service._scripted_convoy(boot + 0.1 * k)
    est = service.tracker.estimate(boot + 2.0)
    assert est is not None
    assert (est.north, est.east) == pytest.approx((20.0, -30.0 + 5.0 * 2.0), abs=0.05)
    assert service._report().route_start_s == boot


def _road_doc() -> dict[str, Any]:
    """Six planes on the road planner (nothing listens at their ports)."""
    uavs = [{"connection": f"udpin:127.0.0.1:{14560 + i}", "sysid": i + 1} for i in range(6)]
    return {
        "mission": {"sensor_radius_m": 100.0, "planner": "road"},
        "aircraft": {"airspeed_mps": 18.0, "turn_radius_m": 150.0},
        "uav": uavs,
    }


def _road_config() -> MissionConfig:
    """Six planes on the road planner (nothing listens at their ports)."""
    return parse_config(_road_doc())


def test_a_planner_falling_behind_is_said_once_and_its_catching_up_too(
    caplog: pytest.LogCaptureFixture,
) -> None:
    service = ConvoyService(_road_config())
    mission = service.mission
    assert isinstance(mission, RoadMission)
    every = mission.settings.replan_every_s
    for k, lag in enumerate((every, 2.5 * every, 2.6 * every, every)):
        mission.replan_interval_s = lag
        service._check_planner(10.0 * k)
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        f"planner behind: each UAV re-planned every {2.5 * every:.1f} mission s instead of "
        f"{every:g} (the host is short of CPU at this speedup)"
    ]
    assert [e.split(" ", 1)[1].split(":")[0] for e in service.events[-2:]] == [
        "planner behind",
        "planner caught up",
    ]


def test_re_plans_flown_late_are_warned_once_with_the_remedy_and_noted_after(
    caplog: pytest.LogCaptureFixture,
) -> None:
    service = ConvoyService(_road_config(), rate_hint=40.0)
    fit = service._replan_lag
    fit.base, fit.per_uav = 0.14, 0.45  # (too few steps yet to say)
    service._check_planner(0.0)
    assert not service._warned
    fit.planned = 15
    # One look every 10 mission s, (base, per UAV): on time; late (40x on two cores); a
    # little better but still late (above half the bar); on time for 30 s; late; on time
    # for 60 s; late again.
    looks = [(0.1, 0.01), (0.14, 0.45), (0.1, 0.1), (0.1, 0.0), (0.1, 0.0), (0.1, 0.0)]
    looks += [(0.14, 0.3)] + [(0.1, 0.0)] * 6 + [(0.14, 0.3)]
    for k, (base, per_uav) in enumerate(looks):
        fit.base, fit.per_uav = base, per_uav
        service._check_planner(10.0 * k)
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        "re-plans late: a re-planned UAV flies its new legs 0.59 mission s after the step "
        "that laid them, at 40x; coverage pays for it on winding roads: lower the speedup "
        "(to about 8.2x on this host)"  # (0.1 s past the tick, of the 0.49 s at 40x)
    ]
    said = [e.split(" ", 1)[1] for e in service.events if "re-plans" in e]
    assert [e.split(":")[0] for e in said] == [
        "re-plans late",  # t=10
        "re-plans on time again",  # t=120: 60 s after the last late look (t=60)
        "re-plans late",  # t=130: news again, in the events only
    ]
    assert said[1] == "re-plans on time again: 0.10 mission s for 60 s"


def test_re_plans_flown_late_under_a_speedup_governor_say_the_simulator_is_slowed(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """``demo`` and ``replay`` let the service slow the mock (``sim_speedup_floor``): the
    remedy is then its own doing, not the operator's."""
    config = replace(_road_config(), sim_speedup_floor=5.0)
    service = ConvoyService(config, rate_hint=40.0)
    fit = service._replan_lag
    fit.base, fit.per_uav, fit.planned = 0.14, 0.45, 15
    service._check_planner(0.0)
    assert service._replans_past() == pytest.approx(0.49)
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert warned == [
        "re-plans late: a re-planned UAV flies its new legs 0.59 mission s after the step "
        "that laid them, at 40x; coverage pays for it on winding roads: slowing the "
        "simulator (towards about 8.2x, not below 5x)"
    ]


def test_setpoint_rounds_far_apart_are_warned_once_with_the_remedy_and_noted_after(
    caplog: pytest.LogCaptureFixture,
) -> None:
    uavs = [{"connection": f"udpin:127.0.0.1:{14560 + i}", "sysid": i + 1} for i in range(2)]
    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0},
            "aircraft": {"airspeed_mps": 18.0, "turn_radius_m": 150.0},
            "uav": uavs,
        }
    )
    service = ConvoyService(cfg, rate_hint=40.0)
    service._check_setpoints(0.0)  # (not streaming yet: nothing to say)
    # One look every 10 mission s: late, on time for 30 s, late, on time for 60 s, late.
    gaps = [0.05, 1.2, 0.1, 0.1, 0.1, 0.9, 0.0, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1, 0.7, 0.1]
    looks = iter(gaps)
    service.streamer = SimpleNamespace(take_widest_gap=lambda: next(looks))  # type: ignore[assignment]
    for k in range(len(gaps)):
        service._check_setpoints(10.0 * k)
    warned = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert len(warned) == 1
    assert warned[0].startswith("setpoints late: 1.20 mission s between two rounds at 40x")
    assert warned[0].endswith("the host is short of CPU at this speedup: lower it")
    said = [e.split(" ", 1)[1] for e in service.events if "setpoints" in e]
    assert [e.split(":")[0] for e in said] == [
        "setpoints late",  # t=10
        "setpoints on time again",  # t=110: 60 s after the last late look (t=50)
        "setpoints late",  # t=130: news again, in the events only
    ]
    assert said[1].endswith("for 60 s") and said[2].startswith("setpoints late: 0.70")
    # In real time there is no speedup to lower.
    real_time = ConvoyService(cfg, rate_hint=1.0)
    real_time.streamer = SimpleNamespace(take_widest_gap=lambda: 0.8)  # type: ignore[assignment]
    real_time._check_setpoints(0.0)
    assert real_time.events[-1].endswith("the host is short of CPU (real time)")
    # What the late rounds cost is said for the fleet's own autopilots.
    assert "(PX4 leaves OFFBOARD after 1 s without one)" in warned[0]  # (none heard yet)
    assert "PX4 leaves OFFBOARD" in _without_setpoints({"ArduCopter", "PX4"})
    ardupilot = _without_setpoints({"ArduCopter", "ArduPlane"})
    assert "PX4" not in ardupilot and "GUID_TIMEOUT" in ardupilot


def test_a_convoy_too_fast_for_the_pattern_is_alarmed_until_it_slows() -> None:
    """``convoy_fast`` is raised when the convoy's low-passed speed reaches
    ``FAST_CONVOY_RATIO`` of the airspeed (18 m/s here: 9 m/s), and cleared once it has
    stayed below 0.9 of that (8.1 m/s) for 30 s: a stretch at 8.5 m/s between two fast
    ones, or 15 s at 6 m/s, is one alarm, not two."""
    service = ConvoyService(_road_config())
    mission = service.mission
    assert isinstance(mission, RoadMission)
    t, north = 0.0, 0.0
    phases = ((6.0, 40.0), (12.0, 40.0), (8.5, 40.0), (12.0, 40.0), (6.0, 15.0), (12.0, 30.0))
    for speed, seconds in (*phases, (6.0, 60.0)):
        for _ in range(int(seconds / 0.5)):
            t += 0.5
            north += 0.5 * speed
            mission.on_convoy(ConvoyEstimate(t, north, 0.0, speed, 0.0))
            service._check_convoy_speed(t)
    raised = [a for a in service.alarms if a["kind"] == "convoy_fast"]
    assert [a["active"] for a in raised] == [True, False]
    # (the pattern's speed: the velocity low-passed over 20 s, 6 -> 12 m/s reaches 9 in
    # 14 s; its speed over 5 s, 12 -> 6 m/s is under 8.1 in 5 s, then the 30-s hold)
    assert 50.0 < raised[0]["t"] < 60.0 and 235.0 < raised[1]["t"] < 245.0
    assert raised[0]["message"].startswith("convoy at 9.0 m/s, 0.5 of the airspeed or more:")
    assert raised[1]["message"].startswith("convoy slowed to 6.")


def test_a_convoy_that_outruns_the_uavs_is_alarmed_too() -> None:
    """``convoy_outruns`` from the top of the speed band (18 x 1.15 = 20.7 m/s), on top
    of ``convoy_fast``; both cleared as the convoy slows back to 6 m/s."""
    service = ConvoyService(_road_config())
    mission = service.mission
    assert isinstance(mission, RoadMission)
    t, north = 0.0, 0.0
    for speed in [6.0] * 80 + [25.0] * 160 + [6.0] * 160:
        t += 0.5
        north += 0.5 * speed
        mission.on_convoy(ConvoyEstimate(t, north, 0.0, speed, 0.0))
        service._check_convoy_speed(t)
    said = [(a["kind"], a["active"]) for a in service.alarms if a["kind"].startswith("convoy_")]
    assert said == [
        ("convoy_fast", True),
        ("convoy_outruns", True),
        ("convoy_outruns", False),
        ("convoy_fast", False),
    ]
    outruns = next(a for a in service.alarms if a["kind"] == "convoy_outruns")
    assert "faster than the UAVs fly (20.7 m/s at most)" in outruns["message"]


def test_a_missions_holds_are_placed_on_its_road_each_on_its_own_pass() -> None:
    """Out and back along one street, a hold at the far end and one on the way back at
    the point passed on the way out: each is placed on its own pass of the road."""
    from convoy_mav.geo import LocalFrame
    from convoy_mav.tracks.plannedroute import PlannedRoute

    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0, "planner": "road"},
            "uav": [{"connection": "udpin:127.0.0.1:14560", "sysid": 1}],
        }
    )
    service = ConvoyService(cfg)
    frame = LocalFrame(cfg.origin)
    ne = [(0.0, 0.0), (400.0, 0.0), (800.0, 0.0), (800.0, 60.0), (400.0, 60.0), (0.0, 60.0)]
    geo = [frame.to_geo(n, e) for n, e in ne]
    points = [(g.lat, g.lon) for g in geo]
    plan = PlannedRoute(tuple(points), holds=((2, 30.0), (4, 45.0)), speeds=((3, 6.0),))
    service.set_route(plan, source="a test")
    ((road, holds, circuit, speeds, _),) = service._new_routes
    assert [round(h) for _, h in holds] == [30, 45] and not circuit
    ((turn, pace),) = speeds  # (from the far end's second corner, on the way back)
    assert pace == 6.0 and turn == pytest.approx(860.0, abs=15.0)
    (far, _), (back, _) = holds
    assert far == pytest.approx(800.0, abs=10.0)  # (the road cuts its corners a little)
    # On the way back, 400 m from the far end along the road (which cuts the U-turn's
    # corners: 1,660 m drawn, shorter driven), not the way out's 400.
    assert road.length - back == pytest.approx(400.0, abs=10.0)
    assert road.length == pytest.approx(1660.0, abs=40.0)


def test_every_mode_the_lead_rover_changes_to_between_two_mission_steps_is_told_in_order(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A HOLD then AUTO heard within one step both reach the road mission (the last
    alone would leave a held hold unrestarted)."""
    from pymavlink.dialects.v20 import common as mavlink

    from convoy_mav.types import ConvoyDrive

    rover = {"connection": "udpin:127.0.0.1:14600", "sysid": 60}
    doc = {**_road_doc(), "convoy": {"source": "mavlink", "vehicle": [rover]}}
    service = ConvoyService(parse_config(doc))
    mission = service.mission
    assert isinstance(mission, RoadMission)
    told: list[tuple[ConvoyDrive | None, float]] = []
    real = mission.set_drive

    def set_drive(
        drive: ConvoyDrive | None, t: float, home: tuple[float, float] | None = None
    ) -> None:
        told.append((drive, t))
        real(drive, t, home)

    monkeypatch.setattr(mission, "set_drive", set_drive)
    armed = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    for custom in (10, 4, 4, 10):  # AUTO, HOLD (heard twice: one change), AUTO
        heartbeat = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, armed, custom, 4, 3
        )
        service._lead_heartbeat(60, heartbeat)
    service._mission_step(5.0, None, [], [], {}, set(), (0.0, 0.0))
    assert told == [(ConvoyDrive.MISSION, 5.0), (ConvoyDrive.HELD, 5.0), (ConvoyDrive.MISSION, 5.0)]
    assert mission.model.drive is ConvoyDrive.MISSION
    assert [mode for _, mode in service.convoy_modes] == ["AUTO", "HOLD", "AUTO"]
    service._mission_step(6.0, None, [], [], {}, set(), (0.0, 0.0))
    assert len(told) == 3  # (each told once)


def _lead_service() -> tuple[ConvoyService, RoadMission, list[Any]]:
    """A road service whose convoy is one ArduRover (system 60) heard over MAVLink, and
    what it sends that rover."""
    rover = {"connection": "udpin:127.0.0.1:14600", "sysid": 60}
    doc = {**_road_doc(), "convoy": {"source": "mavlink", "vehicle": [rover]}}
    service = ConvoyService(parse_config(doc))
    mission = service.mission
    assert isinstance(mission, RoadMission)
    sent: list[Any] = []

    class _Link:
        def send(self, msg: Any) -> None:
            sent.append(msg)

    service._ground_links = [_Link()]  # type: ignore[list-item]
    return service, mission, sent


def _rover_heartbeat(custom: int) -> Any:
    """An armed ArduRover's HEARTBEAT in mode ``custom`` (10 AUTO, 11 RTL)."""
    from pymavlink.dialects.v20 import common as mavlink

    armed = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, armed, custom, 4, 3
    )


def test_a_lead_rover_sent_home_is_forecast_straight_to_the_home_it_says() -> None:
    """RTL: its HOME_POSITION asked for (until heard, and on each RTL), and the road
    mission told the way home, also when home is heard after the mode."""
    from pymavlink.dialects.v20 import common as mavlink

    from convoy_mav.types import ConvoyDrive

    service, mission, sent = _lead_service()

    def heartbeat(custom: int) -> None:
        service._lead_heartbeat(60, _rover_heartbeat(custom))

    def asked() -> int:
        home = mavlink.MAVLINK_MSG_ID_HOME_POSITION
        return sum(getattr(m, "param1", None) == home for m in sent)

    heartbeat(10)  # AUTO: home unknown, asked for
    heartbeat(11)  # RTL: asked again; no home to go to yet
    assert asked() == 2
    asks = []
    for beat in range(1, 80):  # (unanswered: asked less and less often)
        before = asked()
        heartbeat(11)
        if asked() > before:
            asks.append(beat)
    assert asks == [2, 5, 10, 19, 36, 69]
    n = asked()
    service._mission_step(5.0, None, [], [], {}, set(), (0.0, 0.0))
    assert mission.model.drive is ConvoyDrive.HOME and mission.model._going is None
    where = service.frame.to_geo(120.0, -40.0, 0.0)  # (north, east)
    home = mavlink.MAVLink_home_position_message(
        round(where.lat * 1e7), round(where.lon * 1e7), 0, 0.0, 0.0, 0.0, [1, 0, 0, 0],
        0.0, 0.0, 0.0,
    )  # fmt: skip
    service._lead_home_heard(home)
    service._mission_step(6.0, None, [], [], {}, set(), (0.0, 0.0))
    going = mission.model._going
    assert going is not None and going == pytest.approx((-40.0, 120.0), abs=0.01)  # (x, y)
    heartbeat(11)  # (RTL again: no change, home known: not asked)
    assert asked() == n
    heartbeat(10)  # (AUTO again: no mission read, no waypoint to drive back to)
    service._mission_step(7.0, None, [], [], {}, set(), (0.0, 0.0))
    assert mission.model.drive is ConvoyDrive.MISSION and mission.model._going is None
    assert mission.model._rejoin is None
    events = [e for e in service.events if "ground vehicle 60 in RTL" in e]
    assert events and "not known yet" in events[0], events
    # Seen driving elsewhere (ConvoyModel.astray), and back on its way: each said once.
    for astray in (True, True, False):
        mission.model.astray = astray
        service._check_convoy_way()
    said = [e for e in service.events if "ground vehicle 60 " in e and "forecast to" in e]
    assert len(said) == 2 and "drives elsewhere" in said[0] and "again" in said[1], said


def test_a_lead_ardurover_sent_home_is_forecast_to_the_rally_point_its_firmware_picks() -> None:
    """RTL on an ArduPilot lead: its rally points and RALLY_ parameters read, and the
    road mission told the nearest point (nearer than home, within RALLY_LIMIT_KM) as
    where it goes, from where it was sent home; a failed read leaves it going home."""
    from pymavlink.dialects.v20 import common as mavlink

    service, mission, sent = _lead_service()
    heartbeat = _rover_heartbeat

    def geo(north: float, east: float) -> tuple[int, int]:
        at = service.frame.to_geo(north, east, 0.0)
        return round(at.lat * 1e7), round(at.lon * 1e7)

    service._lead_home = (0.0, 0.0)
    service._ground_xy[60] = (600.0, 200.0)  # (x, y: east, north)
    service._lead_heartbeat(60, heartbeat(10))  # AUTO
    sent.clear()
    service._lead_heartbeat(60, heartbeat(11))  # RTL: its rally points asked for
    rally = mavlink.MAV_MISSION_TYPE_RALLY
    asked = [m for m in sent if getattr(m, "mission_type", None) == rally]
    assert [m.get_type() for m in asked] == ["MISSION_REQUEST_LIST"]
    service._mission_step(5.0, None, [], [], {}, set(), (0.0, 0.0))
    assert mission.model._going == (0.0, 0.0)  # (home, until the points are read)

    def answer(msg: Any) -> None:
        msg.pack(mavlink.MAVLink(None, 60, 1))  # (as heard: its sender's ids)
        service._route(60, msg)

    answer(mavlink.MAVLink_mission_count_message(255, 190, 2, rally))
    points = ((900.0, 900.0), (200.0, 350.0))  # (north, east): 1.1 km off, 250 m off
    rel, point = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_CMD_NAV_RALLY_POINT
    for seq, (north, east) in enumerate(points):
        lat, lon = geo(north, east)
        answer(
            mavlink.MAVLink_mission_item_int_message(
                255, 190, seq, rel, point, 0, 0, 0, 0, 0, 0, lat, lon, 0.0, rally
            )
        )
    real = mavlink.MAV_PARAM_TYPE_REAL32
    for name, value in (("RALLY_LIMIT_KM", 0.5), ("RALLY_INCL_HOME", 1.0)):
        answer(mavlink.MAVLink_param_value_message(name.encode(), value, real, 300, 1))
    service._mission_step(6.0, None, [], [], {}, set(), (0.0, 0.0))
    going = mission.model._going
    assert going is not None and going == pytest.approx((350.0, 200.0), abs=0.1)
    said = [e for e in service.events if "rally point 2 of 2, 250 m off" in e]
    assert said and "forecast straight there" in said[0], service.events
    # Sent home again, unanswered: the read given up, said, and home the destination.
    service._lead_heartbeat(60, heartbeat(10))
    service._lead_heartbeat(60, heartbeat(11))
    read = service._rally
    assert read is not None
    for k in range(1, 12):
        service._rally_sends(read.poll(time.monotonic() + 2.0 * k))
    assert service._rally is None
    assert any("rally points not read" in e for e in service.events), service.events
    service._mission_step(7.0, None, [], [], {}, set(), (0.0, 0.0))
    assert mission.model._going == (0.0, 0.0)


def test_a_lead_rover_back_in_auto_after_smart_rtl_resumes_its_mission_as_after_rtl(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """AUTO after SMART_RTL restarts the item it was driving to, as after RTL
    (``AP_Mission::resume``): the road mission is told the waypoint it drives back to;
    after a driver's mode (MANUAL), none is."""
    from convoy_mav.types import ConvoyDrive

    service, _, _ = _lead_service()
    monkeypatch.setattr(service, "_resumed_at", lambda: (250.0, -30.0))
    for custom in (10, 12, 10, 0, 10):  # AUTO, SMART_RTL, AUTO, MANUAL, AUTO
        service._lead_heartbeat(60, _rover_heartbeat(custom))
    told = [(drive, where) for drive, where in service._new_drives]
    assert told == [
        (ConvoyDrive.MISSION, None),
        (ConvoyDrive.RETRACE, None),
        (ConvoyDrive.MISSION, (250.0, -30.0)),
        (ConvoyDrive.OTHER, None),
        (ConvoyDrive.MISSION, None),
    ]
    said = [e for e in service.events if "ground vehicle 60 in SMART_RTL" in e]
    assert said and "forecast back along the path it was seen to drive" in said[0], said
