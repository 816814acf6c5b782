"""The service parts a follower from the convoy when its mode, or its distance, says so."""

from __future__ import annotations

from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.app import ConvoyService
from convoy_mav.config import parse_config
from convoy_mav.mavlink.rovermode import drive_of
from convoy_mav.parting import STAND_S, convoy_group, leaves
from convoy_mav.types import ConvoyDrive
from tests.unit.test_app_route import _road_doc

LEAD, FOLLOWER = 60, 61
_AUTO, _HOLD, _RTL, _SMART_RTL, _MANUAL = 10, 4, 11, 12, 0


def test_a_follower_leaves_when_held_or_sent_home_while_the_lead_does_otherwise() -> None:
    m, h, home, other = ConvoyDrive.MISSION, ConvoyDrive.HELD, ConvoyDrive.HOME, ConvoyDrive.OTHER
    assert leaves(h, m) and leaves(home, m) and leaves(home, h) and leaves(h, home)
    assert not leaves(h, h) and not leaves(home, home)  # (the whole convoy held, or home)
    assert not leaves(m, h) and not leaves(other, m)  # (it drives on, or a driver has it)
    assert not leaves(h, other) and not leaves(h, None)  # (the lead's way not known)
    assert drive_of("AUTO", True) is m and drive_of("AUTO", False) is h
    assert drive_of("AUTO.RTL", True) is home and drive_of("MANUAL", True) is other
    # Back along its path (SMART_RTL, a failsafe's action) is home as well for a follower;
    # for a lead, a drive of its own that leaves a held follower behind.
    back = drive_of("SMART_RTL", True)
    assert back is ConvoyDrive.RETRACE and leaves(back, m) and leaves(h, back)
    assert not leaves(back, home) and not leaves(home, back) and not leaves(back, back)


def test_one_known_to_have_left_is_apart_however_near_unless_it_is_all_there_is() -> None:
    near = {1: (0.0, 0.0), 2: (20.0, 0.0), 3: (40.0, 0.0)}
    assert convoy_group(near, lead=1, part_m=200.0, apart=frozenset({2})) == {1, 3}
    assert convoy_group(near, lead=1, part_m=200.0, apart=frozenset({1})) == set(near)
    assert convoy_group({2: (0.0, 0.0)}, lead=1, part_m=200.0, apart=frozenset({2})) == {2}
    assert convoy_group(near, lead=1, part_m=0.0, apart=frozenset({2})) == set(near)


def _heartbeat(sysid: int, custom: int) -> Any:
    """An armed ArduRover's HEARTBEAT from ``sysid``, as it comes off its link."""
    armed = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    msg = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, armed, custom, 4, 3
    )
    msg.pack(mavlink.MAVLink(None, srcSystem=sysid, srcComponent=1))
    return msg


def _convoy_service(monkeypatch: pytest.MonkeyPatch) -> tuple[ConvoyService, list[float]]:
    """A service flying the road with the lead and its follower, whose clock reads
    ``now[0]`` (set by the test)."""
    vehicles = [
        {"connection": f"udpin:127.0.0.1:{14600 + k}", "sysid": s}
        for k, s in enumerate((LEAD, FOLLOWER))
    ]
    doc = {**_road_doc(), "convoy": {"source": "mavlink", "vehicle": vehicles}}
    service = ConvoyService(parse_config(doc))
    now = [0.0]
    monkeypatch.setattr(type(service.clock), "now", lambda self: now[0])
    return service, now


def test_the_service_parts_a_follower_its_mode_says_left_and_takes_it_back(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held while the lead drives its mission: parted 3 s after its HEARTBEAT first said
    so (not at once: a convoy held as a whole is heard one vehicle at a time), however
    near, with the alarm saying why; the lead held too, it is back in the convoy."""
    service, now = _convoy_service(monkeypatch)

    def heard(t: float, lead: int, follower: int) -> None:
        now[0] = t
        service._route(LEAD, _heartbeat(LEAD, lead))
        service._route(FOLLOWER, _heartbeat(FOLLOWER, follower))
        # (a fix each, 20 m apart: only a mode can part them)
        service._convoy_fix(t, 8.0 * t, 0.0, LEAD, None)
        service._convoy_fix(t, 8.0 * t - 20.0, 0.0, FOLLOWER, None)

    heard(0.0, _AUTO, _AUTO)
    heard(1.0, _AUTO, _HOLD)
    heard(2.0, _AUTO, _HOLD)
    assert service.tracker.sources == {LEAD, FOLLOWER}
    heard(4.0, _AUTO, _HOLD)
    assert service.tracker.sources == {LEAD} and service.tracker.parted == {FOLLOWER}
    (alarm,) = service.alarms
    assert alarm["kind"] == "convoy_parted" and alarm["active"]
    published: list[tuple[str, Any]] = []

    class _Publisher:
        def publish(self, subtopic: str, payload: Any, retain: bool = False) -> None:
            published.append((subtopic, payload))

    service.publisher = _Publisher()
    service._publish_state(4.0)
    (status,) = [p for topic, p in published if topic == "status"]
    assert f"convoy_parted:{FOLLOWER}" in status["alarms"]  # (in force, over MQTT)
    why = "in HOLD: it stands while the lead drives its mission"
    assert alarm["message"] == (
        f"ground vehicle {FOLLOWER} parted from the convoy ({why}): the UAVs protect "
        "the rest, not it"
    )
    # The lead held as well: the convoy stands as a whole, the follower back in it.
    heard(5.0, _HOLD, _HOLD)
    assert service.tracker.sources == {LEAD, FOLLOWER}
    assert [a["active"] for a in service.alarms] == [True, False]
    assert service.alarms[1]["message"] == f"ground vehicle {FOLLOWER} rejoined the convoy"
    # A driver takes the lead (MANUAL): where it goes is not known, no one parts.
    for t in (6.0, 7.0, 8.0, 9.0, 10.0):
        heard(t, _MANUAL, _RTL)
    assert service.tracker.sources == {LEAD, FOLLOWER}
    # Its failsafe sends it home back along its path while the lead drives on.
    for t in (11.0, 12.0, 13.0, 14.0, 15.0):
        heard(t, _AUTO, _SMART_RTL)
    assert service.tracker.sources == {LEAD} and service.tracker.parted == {FOLLOWER}
    back = "in SMART_RTL: it drives home back along its path while the lead drives its mission"
    assert service.alarms[-1]["message"] == (
        f"ground vehicle {FOLLOWER} parted from the convoy ({back}): the UAVs protect "
        "the rest, not it"
    )
    parts = service._planner_report()["convoy_parted"]
    assert [p["event"] for p in parts] == ["parted", "rejoined", "parted"]
    # (from the follower's last fix, taken before the lead's 2 s on: 20 + 16 m)
    assert parts[0]["why"] == why and parts[0]["apart_m"] == pytest.approx(36.0)


def test_a_follower_that_stands_while_the_lead_drives_on_in_auto_parts_and_is_said_why(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A breakdown: both in AUTO (their modes say nothing), the follower's reported
    speed 0 from 10 s while the lead's is 8 m/s: parted a window later, 20 m + 8 m/s
    of it behind, with the alarm saying why."""
    service, now = _convoy_service(monkeypatch)
    for k in range(40):
        t = now[0] = float(k)
        service._route(LEAD, _heartbeat(LEAD, _AUTO))
        service._route(FOLLOWER, _heartbeat(FOLLOWER, _AUTO))
        service._convoy_fix(t, 8.0 * t, 0.0, LEAD, (8.0, 0.0))
        stood = t >= 10.0
        north = 8.0 * min(t, 10.0) - 20.0
        service._convoy_fix(t, north, 0.0, FOLLOWER, (0.0 if stood else 8.0, 0.0))
    (parted,) = service._planner_report()["convoy_parted"]
    assert 10.0 + STAND_S <= parted["t"] <= 11.0 + STAND_S, parted
    why = f"it has stood {STAND_S:.0f} s while the lead drove on"
    assert parted["why"] == why and parted["apart_m"] < 200.0, parted
    (alarm,) = service.alarms
    assert f"ground vehicle {FOLLOWER} parted from the convoy ({why})" in alarm["message"]
