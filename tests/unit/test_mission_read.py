"""Reading a rover's mission (``mavlink.missionread``) and the road it drives
(``tracks.missionroute``): the protocol's turns, time-outs and refusals, when the
watch reads again, and which items make the route."""

from __future__ import annotations

import random
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.codec import MavCodec
from convoy_mav.mavlink.missionread import (
    BUSY_RETRY_S,
    MAX_TRIES,
    MIN_TIMEOUT_S,
    PARAM_TIMEOUT_S,
    PARAM_TRIES,
    RETRY_S,
    TIMEOUT_S,
    TRIES,
    MissionItem,
    MissionRead,
    MissionWatch,
)
from convoy_mav.tracks.missionroute import mission_route

ROVER = 201
MISSION = mavlink.MAV_MISSION_TYPE_MISSION
REL_INT = mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
WP = mavlink.MAV_CMD_NAV_WAYPOINT


def wire(msg: Any, sysid: int = ROVER) -> Any:
    """``msg`` as the rover sends it: packed and parsed by pymavlink."""
    sender, receiver = MavCodec(sysid, 1), MavCodec(255, 190)
    (out,) = receiver.feed_datagram(sender.pack(msg))
    return out


def item(
    seq: int, lat: float, lon: float, command: int = WP, frame: int = REL_INT, p1: float = 0.0
) -> Any:
    x, y = round(lat * 1e7), round(lon * 1e7)
    msg = mavlink.MAVLink_mission_item_int_message(
        255, 190, seq, frame, command, 0, 1, p1, 0, 0, 0, x, y, 0.0, MISSION
    )
    return wire(msg)


def count(n: int, kind: int = MISSION) -> Any:
    return wire(mavlink.MAVLink_mission_count_message(255, 190, n, kind))


def heartbeat(autopilot: int) -> Any:
    return wire(
        mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GROUND_ROVER, autopilot, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
        )
    )


def current(seq: int, total: int) -> Any:
    return wire(mavlink.MAVLink_mission_current_message(seq, total, 3, 0))


def only(out: list[Any], kind: str) -> Any:
    assert [m.get_type() for m in out] == [kind]
    return out[0]


POINTS = [(47.40, 8.54), (47.401, 8.54), (47.401, 8.542)]


def test_a_mission_is_read_item_by_item_and_the_transfer_closed() -> None:
    read = MissionRead(ROVER)
    ask = only(read.start(0.0), "MISSION_REQUEST_LIST")
    assert (ask.target_system, ask.target_component, ask.mission_type) == (ROVER, 1, MISSION)
    assert only(read.handle(count(3), 0.1), "MISSION_REQUEST_INT").seq == 0
    assert only(read.handle(item(0, *POINTS[0]), 0.2), "MISSION_REQUEST_INT").seq == 1
    assert read.handle(item(0, *POINTS[0]), 0.25) == []  # a late duplicate
    assert read.handle(item(2, *POINTS[2]), 0.26) == []  # one not asked for yet
    assert only(read.handle(item(1, *POINTS[1]), 0.3), "MISSION_REQUEST_INT").seq == 2
    ack = only(read.handle(item(2, *POINTS[2]), 0.4), "MISSION_ACK")
    assert (ack.type, ack.mission_type) == (mavlink.MAV_MISSION_ACCEPTED, MISSION)
    assert read.done and read.error is None and read.items is not None
    assert [(i.seq, round(i.lat, 7), round(i.lon, 7)) for i in read.items] == [
        (k, *p) for k, p in enumerate(POINTS)
    ]
    assert read.handle(item(2, *POINTS[2]), 0.5) == []  # done: nothing more


def test_an_empty_mission_is_read_as_no_items() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    assert only(read.handle(count(0), 0.1), "MISSION_ACK").type == mavlink.MAV_MISSION_ACCEPTED
    assert read.items == [] and read.done


def test_the_float_form_answer_is_taken() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    read.handle(count(1), 0.0)
    float_form = mavlink.MAVLink_mission_item_message(
        255, 190, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, WP, 0, 1, 0, 0, 0, 0, 47.25, 8.5, 0,
        MISSION,
    )  # fmt: skip
    legacy = wire(float_form)
    read.handle(legacy, 0.1)
    assert read.items is not None
    assert (read.items[0].lat, read.items[0].lon) == pytest.approx((47.25, 8.5))


def test_other_mission_types_and_strangers_messages_are_not_the_read() -> None:
    read = MissionRead(ROVER)
    assert read.handle(count(2), 0.0) == []  # not started
    read.start(0.0)
    assert read.handle(count(4, mavlink.MAV_MISSION_TYPE_FENCE), 0.0) == []
    assert read.count is None
    assert read.handle(current(1, 3), 0.0) == []


def test_an_unanswered_request_is_sent_again_then_given_up_on() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    assert read.poll(TIMEOUT_S * 0.9) == []
    t = 0.0
    for _ in range(TRIES - 1):
        t += TIMEOUT_S
        only(read.poll(t), "MISSION_REQUEST_LIST")
    assert not read.done
    assert read.poll(t + TIMEOUT_S) == []  # nothing was opened: nothing to cancel
    assert read.done and read.items is None
    assert read.error == f"did not answer MISSION_REQUEST_LIST ({TRIES} tries, 1.5 s apart)"


def test_a_read_given_up_half_way_is_cancelled_on_the_vehicle() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    read.handle(count(3), 0.0)
    read.handle(item(0, *POINTS[0]), 0.0)
    # (two answers are little proof of a clean link: more than the protocol's five)
    assert TRIES < read.tries_allowed <= MAX_TRIES
    t = 0.0
    for _ in range(read.tries_allowed - 1):
        t += TIMEOUT_S
        assert only(read.poll(t), "MISSION_REQUEST_INT").seq == 1
    ack = only(read.poll(t + TIMEOUT_S), "MISSION_ACK")
    assert ack.type == mavlink.MAV_MISSION_OPERATION_CANCELLED
    assert read.error is not None and "MISSION_REQUEST_INT 1 of 3" in read.error


def test_an_answer_resets_the_tries() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    for k in range(1, TRIES):
        read.poll(k * TIMEOUT_S)
    read.handle(count(1), TRIES * TIMEOUT_S)
    for k in range(1, TRIES):
        assert read.poll((TRIES + k) * TIMEOUT_S) != []
    assert not read.done


def _read_over(link_loss: float, items: int, seed: int) -> MissionRead:
    """A read of ``items`` waypoints from a rover behind a link losing ``link_loss`` of
    the datagrams each way (each drawn apart), polled every 0.1 s."""
    rng = random.Random(seed)
    mission = [item(k, 47.4 + 1e-4 * k, 8.54) for k in range(items)]
    read = MissionRead(ROVER)
    asks, t = read.start(0.0), 0.0
    while not read.done and t < 3600.0:
        answers = []
        for ask in asks:
            if rng.random() < link_loss:
                continue  # (the request lost)
            if ask.get_type() == "MISSION_REQUEST_LIST":
                answers.append(count(items))
            elif ask.get_type() == "MISSION_REQUEST_INT":
                answers.append(mission[ask.seq])
        asks = []
        for answer in answers:
            if rng.random() >= link_loss:
                asks += read.handle(answer, t)
        t += 0.1
        asks += read.poll(t)
    return read


def test_a_lossy_link_gets_the_tries_its_answer_rate_needs() -> None:
    """30 % lost each way, 44 items (ArduRover SITL's urban mission): five tries of each
    request fail one in 30, so 5 reads of these 40 came through, and the rover behind
    such a radio was never read in its flight. The tries follow the answer rate
    measured in the read: 39 of 40 (the one left failed its first request, five times,
    and the watch asks again 30 s on)."""
    reads = [_read_over(0.3, 44, seed) for seed in range(40)]
    assert sum(r.items is not None and len(r.items) == 44 for r in reads) >= 38
    assert max(r.tries_allowed for r in reads) <= MAX_TRIES
    clean = _read_over(0.0, 44, 0)
    assert clean.items is not None and clean.tries_allowed == TRIES  # (each answered at once)


def test_a_request_is_asked_again_after_three_of_the_links_round_trips() -> None:
    """Timed from the answers to first tries only: behind a radio that loses 30 %, 1.5 s
    per lost request made a read of 44 items take 70 wall s (350 mission s at 5x)."""
    read = MissionRead(ROVER)
    read.start(0.0)
    assert read.timeout == TIMEOUT_S  # (nothing timed yet)
    read.handle(count(3), 0.4)  # (0.4 s: a slow radio)
    assert read.timeout == pytest.approx(1.2)
    assert read.poll(0.4 + 1.1) == []
    assert only(read.poll(0.4 + 1.25), "MISSION_REQUEST_INT").seq == 0  # (asked again)
    read.handle(item(0, *POINTS[0]), 1.7)  # (a retry's answer: not timed)
    assert read.timeout == pytest.approx(1.2)
    read.handle(item(1, *POINTS[1]), 1.72)  # (0.02 s: the floor)
    assert read.timeout == pytest.approx(3.0 * (0.75 * 0.4 + 0.25 * 0.02))
    quick = MissionRead(ROVER)
    quick.start(0.0)
    quick.handle(count(3), 0.01)
    assert quick.timeout == MIN_TIMEOUT_S


def test_a_vehicle_that_answers_nothing_is_given_up_on_after_the_protocols_tries() -> None:
    read = _read_over(1.0, 44, 0)
    assert read.error == f"did not answer MISSION_REQUEST_LIST ({TRIES} tries, 1.5 s apart)"


def test_a_refusal_ends_the_read_with_its_reason() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    refusal = wire(
        mavlink.MAVLink_mission_ack_message(255, 190, mavlink.MAV_MISSION_DENIED, MISSION)
    )
    assert read.handle(refusal, 0.1) == []
    assert read.error == "refused the read: MAV_MISSION_DENIED (another transfer under way)"
    assert read.busy


def test_a_mission_counted_past_any_autopilot_is_refused() -> None:
    read = MissionRead(ROVER)
    read.start(0.0)
    read.handle(count(60000), 0.0)
    assert read.error is not None and "60000" in read.error


# ------------------------------------------------------------------------- the watch


def param(name: str, value: float) -> Any:
    return wire(
        mavlink.MAVLink_param_value_message(
            name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32, 2, 0
        )
    )


def drive(
    watch: MissionWatch, points: list[tuple[float, float]], now: float, wp_speed: float = 8.0
) -> list[Any]:
    """Answer the watch's read (and its parameter requests) as a rover holding ``points``
    would, its WP_SPEED ``wp_speed``; what it sent."""
    sent = watch.poll(now, now)
    log = list(sent)
    while sent:
        reply: list[Any] = []
        for msg in sent:
            if msg.get_type() == "MISSION_REQUEST_LIST":
                reply.append(count(len(points)))
            elif msg.get_type() == "MISSION_REQUEST_INT":
                reply.append(item(msg.seq, *points[msg.seq]))
            elif msg.get_type() == "PARAM_REQUEST_READ":
                asked = msg.param_id
                reply.append(param(asked, wp_speed if asked == "WP_SPEED" else 5.0))
        sent = [out for r in reply for out in watch.handle(r, now, now)]
        log += sent
    return log


def test_the_watch_reads_once_heard_then_again_only_when_the_mission_changes() -> None:
    watch = MissionWatch(ROVER)
    assert watch.poll(0.0, 0.0) == []  # not heard yet
    watch.handle(current(0, 3), 0.0, 0.0)
    assert watch.poll(0.0, 0.0) == []  # (nor from its MISSION_CURRENT: whose numbering?)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA), 0.0, 0.0)
    assert watch.ardupilot
    drive(watch, POINTS, 1.0)
    read = watch.take()
    assert read is not None and read.items is not None and len(read.items) == 3
    assert watch.take() is None  # handed over once
    assert watch.default_speed == 8.0  # (its WP_SPEED, asked alongside)
    # ArduPilot's MISSION_CURRENT leaves home out of its total: 2 is the same mission.
    watch.handle(current(1, 2), 2.0, 2.0)
    assert watch.poll(3.0, 3.0) == [] and watch.reads == 1
    watch.handle(current(1, 4), 4.0, 4.0)  # another ground station uploaded one
    assert only(watch.poll(4.0, 4.0), "MISSION_REQUEST_LIST")
    assert watch.poll(4.1, 4.1) == []  # (one read at a time)


def test_the_watch_asks_again_later_when_a_read_fails_or_finds_nothing() -> None:
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_PX4), 0.0, 0.0)
    drive(watch, [], 0.0)
    read = watch.take()
    assert read is not None and read.items == []
    assert watch.poll(RETRY_S - 1.0, RETRY_S - 1.0) == []
    only(watch.poll(RETRY_S, RETRY_S), "MISSION_REQUEST_LIST")
    for k in range(1, TRIES + 1):  # silence: the read fails
        watch.poll(RETRY_S + k * TIMEOUT_S, RETRY_S + k * TIMEOUT_S)
    failed = watch.take()
    assert failed is not None and failed.error is not None
    t = RETRY_S + TRIES * TIMEOUT_S
    assert watch.poll(t + 1.0, t + 1.0) == []
    assert only(watch.poll(t + RETRY_S, t + RETRY_S), "MISSION_REQUEST_LIST")
    assert watch.reads == 2


def test_the_wait_before_asking_again_is_mission_time_and_the_reads_own_is_the_links() -> None:
    """At 40x, 30 wall s would be 20 minutes of the convoy's drive with no route: the
    wait is the mission's. A request's time-out is the link's round trip, wall time."""
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_PX4), 0.0, 0.0)
    drive(watch, [], 0.0)  # (nothing uploaded yet)
    assert watch.take() is not None
    assert watch.poll(0.5, 20.0) == []
    only(watch.poll(0.75, RETRY_S), "MISSION_REQUEST_LIST")
    assert watch.poll(0.75 + TIMEOUT_S * 0.9, 1000.0) == []  # (not timed out: wall)
    assert only(watch.poll(0.75 + TIMEOUT_S, 1000.0), "MISSION_REQUEST_LIST")  # asked again


def test_a_read_refused_during_another_stations_upload_is_tried_again_soon() -> None:
    """ArduRover SITL denied the service's first read while the operator uploaded."""
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA), 0.0, 0.0)
    watch.handle(param("WP_SPEED", 6.0), 0.0, 0.0)
    only(watch.poll(0.0, 0.0), "MISSION_REQUEST_LIST")
    denied = mavlink.MAVLink_mission_ack_message(255, 190, mavlink.MAV_MISSION_DENIED, MISSION)
    watch.handle(wire(denied), 0.1, 0.1)
    assert watch.take() is not None
    assert watch.poll(0.1 + BUSY_RETRY_S - 0.5, 0.1 + BUSY_RETRY_S - 0.5) == []
    assert only(watch.poll(0.1 + BUSY_RETRY_S, 0.1 + BUSY_RETRY_S), "MISSION_REQUEST_LIST")


def test_an_ardupilot_rovers_default_speed_is_asked_and_the_read_waits_for_it() -> None:
    """WP_SPEED, or CRUISE_SPEED where it is 0, is AUTO's speed where no DO_CHANGE_SPEED
    says one: asked with the read, again if unanswered; the read is handed over once it
    is known, or once asked PARAM_TRIES times."""
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA), 0.0, 0.0)
    sent = [m.get_type() for m in watch.poll(0.0, 0.0)]
    assert sent == ["PARAM_REQUEST_READ", "PARAM_REQUEST_READ", "MISSION_REQUEST_LIST"]
    watch.handle(count(0), 0.1, 0.1)  # (an empty mission: the read ends at once)
    assert watch.take() is None  # (held for the speed)
    asked = watch.poll(PARAM_TIMEOUT_S, PARAM_TIMEOUT_S)
    assert [m.param_id for m in asked] == ["WP_SPEED", "CRUISE_SPEED"]
    watch.handle(param("WP_SPEED", 0.0), 1.6, 1.6)  # 0: CRUISE_SPEED's
    watch.handle(param("CRUISE_SPEED", 4.5), 1.7, 1.7)
    assert watch.default_speed == 4.5
    read = watch.take()
    assert read is not None and read.items == []
    silent = MissionWatch(ROVER)  # a firmware that never answers
    silent.handle(heartbeat(mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA), 0.0, 0.0)
    silent.poll(0.0, 0.0)
    silent.handle(count(0), 0.1, 0.1)
    for k in range(1, PARAM_TRIES):
        assert silent.take() is None
        silent.poll(k * PARAM_TIMEOUT_S, k * PARAM_TIMEOUT_S)
    assert silent.take() is not None and silent.default_speed is None
    px4 = MissionWatch(ROVER)  # (PX4's rovers: not asked)
    px4.handle(heartbeat(mavlink.MAV_AUTOPILOT_PX4), 0.0, 0.0)
    only(px4.poll(0.0, 0.0), "MISSION_REQUEST_LIST")
    assert mission_route(
        [MissionItem(0, WP, REL_INT, 47.4, 8.54), MissionItem(1, WP, REL_INT, 47.401, 8.54)],
        home_first=False,
        default_speed=4.5,
    ).speeds == ((0, 4.5),)


def test_a_total_that_never_matches_the_mission_is_not_read_for_ever() -> None:
    """MISSION_CURRENT's total of 0 means "not supported" from firmware without it: the
    mission read is checked once more, then read again only when the total changes."""
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_PX4), 0.0, 0.0)
    drive(watch, POINTS, 0.0)
    watch.handle(current(0, 0), 1.0, 1.0)
    assert only(drive(watch, POINTS, 2.0)[:1], "MISSION_REQUEST_LIST")  # once more
    for k in range(3, 10):
        watch.handle(current(0, 0), float(k), float(k))
        assert watch.poll(float(k), float(k)) == []
    assert watch.reads == 2
    watch.handle(current(0, 5), 10.0, 10.0)  # a new mission after all
    assert only(watch.poll(10.0, 10.0), "MISSION_REQUEST_LIST")


def rover_heartbeat(autopilot: int, custom_mode: int) -> Any:
    armed = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    return wire(
        mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GROUND_ROVER, autopilot, armed, custom_mode,
            mavlink.MAV_STATE_ACTIVE, 3,
        )
    )  # fmt: skip


def test_the_vehicles_answers_to_another_ground_station_are_not_the_read() -> None:
    """The operator's upload on a link the service shares (a router, or the mock): the
    vehicle's MISSION_ACK and requests to system 250 are not the service's read's."""
    read = MissionRead(ROVER)
    only(read.start(0.0), "MISSION_REQUEST_LIST")
    theirs = mavlink.MAVLink_mission_ack_message(250, 190, mavlink.MAV_MISSION_ERROR, MISSION)
    assert read.handle(wire(theirs), 0.1) == [] and not read.done
    their_count = mavlink.MAVLink_mission_count_message(250, 190, 9, MISSION)
    assert read.handle(wire(their_count), 0.1) == []
    only(read.handle(count(len(POINTS)), 0.2), "MISSION_REQUEST_INT")
    assert read.count == len(POINTS)


def test_an_ardupilot_mission_is_read_again_when_it_says_so_and_on_entering_auto() -> None:
    """A mission changed to one as long (a waypoint moved): its "Auto mission changed" (to
    every link), and AUTO entered again (where a mission uploaded meanwhile takes effect),
    are read again."""
    auto, hold = 10, 4
    watch = MissionWatch(ROVER)
    ardupilot = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
    watch.handle(rover_heartbeat(ardupilot, auto), 0.0, 0.0)
    watch.handle(param("WP_SPEED", 6.0), 0.0, 0.0)
    drive(watch, POINTS, 0.0)
    watch.handle(current(1, 2), 1.0, 1.0)
    watch.handle(rover_heartbeat(ardupilot, auto), 1.0, 1.0)
    assert watch.poll(2.0, 2.0) == []
    text = b"Auto mission changed, restarted command"
    watch.handle(
        wire(mavlink.MAVLink_statustext_message(mavlink.MAV_SEVERITY_CRITICAL, text)), 3.0, 3.0
    )
    assert drive(watch, POINTS, 3.0)[0].get_type() == "MISSION_REQUEST_LIST"
    assert watch.poll(4.0, 4.0) == [] and watch.reads == 2
    watch.handle(rover_heartbeat(ardupilot, hold), 5.0, 5.0)
    assert watch.poll(5.0, 5.0) == []
    watch.handle(rover_heartbeat(ardupilot, auto), 6.0, 6.0)
    assert drive(watch, POINTS, 6.0)[0].get_type() == "MISSION_REQUEST_LIST"
    watch.handle(rover_heartbeat(ardupilot, auto), 7.0, 7.0)
    assert watch.poll(7.0, 7.0) == [] and watch.reads == 3


def test_a_px4_mission_counted_whole_is_not_read_again() -> None:
    watch = MissionWatch(ROVER)
    watch.handle(heartbeat(mavlink.MAV_AUTOPILOT_PX4), 0.0, 0.0)
    drive(watch, POINTS, 0.0)
    watch.handle(current(0, 3), 1.0, 1.0)
    assert watch.poll(2.0, 2.0) == []


# ------------------------------------------------------------------------- the route


def items(*rows: tuple[int, int, float, float]) -> list[MissionItem]:
    """(command, frame, lat, lon) in order, numbered from 0."""
    return [
        MissionItem.from_message(item(k, lat, lon, cmd, frame))
        for k, (cmd, frame, lat, lon) in enumerate(rows)
    ]


GLOBAL = mavlink.MAV_FRAME_GLOBAL
MISSION_FRAME = mavlink.MAV_FRAME_MISSION
LOCAL = mavlink.MAV_FRAME_LOCAL_NED


def test_an_ardupilot_mission_drives_its_waypoints_and_back_home() -> None:
    route = mission_route(
        items(
            (WP, GLOBAL, 47.400, 8.540),  # home: where it was armed
            (WP, REL_INT, 47.401, 8.540),
            (mavlink.MAV_CMD_DO_CHANGE_SPEED, MISSION_FRAME, 0.0, 0.0),
            (WP, REL_INT, 0.0, 0.0),  # "here": a hold where it is
            (mavlink.MAV_CMD_NAV_SPLINE_WAYPOINT, REL_INT, 47.401, 8.542),
            (WP, REL_INT, 47.401, 8.542),  # the same point again
            (mavlink.MAV_CMD_NAV_LOITER_TIME, REL_INT, 47.402, 8.542),
            (WP, LOCAL, 120.0, 30.0),  # metres, not degrees
            (mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, MISSION_FRAME, 0.0, 0.0),
        ),
        home_first=True,
    )
    assert [(round(lat, 6), round(lon, 6)) for lat, lon in route.points] == [
        (47.401, 8.540), (47.401, 8.542), (47.402, 8.542), (47.400, 8.540)
    ]  # fmt: skip
    assert (route.skipped, route.laps) == (1, False)
    assert route.remarks() == "1 items left out (local frames, landings, surveys)"


def test_a_px4_mission_has_no_home_item_and_a_jump_makes_laps() -> None:
    route = mission_route(
        items(
            (WP, REL_INT, 47.400, 8.540),
            (WP, REL_INT, 47.401, 8.540),
            (WP, REL_INT, 47.401, 8.541),
            (mavlink.MAV_CMD_DO_JUMP, MISSION_FRAME, 0.0, 0.0),
        ),
        home_first=False,
    )
    assert len(route.points) == 3 and route.laps
    assert route.remarks() == "driven in laps (DO_JUMP)"


def test_a_jump_back_repeated_with_nothing_after_it_is_a_circuit() -> None:
    """ArduPilot: home, a way out to the patrol, its three corners (a hold at the first),
    then DO_JUMP to the first corner for ever: the route is the lap, closed."""
    jump = mavlink.MAV_CMD_DO_JUMP
    rows = [
        MissionItem(0, WP, GLOBAL, 47.400, 8.540),  # home
        MissionItem(1, WP, REL_INT, 47.401, 8.540),  # the way there
        MissionItem(2, WP, REL_INT, 47.402, 8.540, param1=20.0),  # the lap: a hold here
        MissionItem(3, WP, REL_INT, 47.402, 8.542),
        MissionItem(4, WP, REL_INT, 47.403, 8.541),
        MissionItem(5, jump, MISSION_FRAME, 0.0, 0.0, param1=2.0, param2=-1.0),
    ]
    route = mission_route(rows, home_first=True)
    assert route.circuit and route.laps
    assert route.points == ((47.402, 8.540), (47.402, 8.542), (47.403, 8.541), (47.402, 8.540))
    assert route.holds == ((0, 20.0),)
    assert route.remarks() == "a circuit driven in laps, 1 holds, 20 s"
    # Driven on after its laps, a jump never taken (a repeat of 0), or a jump forward:
    # laps of part of the route, no circuit; the route is every waypoint.
    after = [*rows, MissionItem(6, WP, REL_INT, 47.404, 8.541)]
    never = [*rows[:5], MissionItem(5, jump, MISSION_FRAME, 0.0, 0.0, param1=2.0, param2=0.0)]
    ahead = [*rows[:5], MissionItem(5, jump, MISSION_FRAME, 0.0, 0.0, param1=9.0, param2=3.0)]
    for other, n in ((after, 5), (never, 4), (ahead, 4)):
        route = mission_route(other, home_first=True)
        assert route.laps and not route.circuit and len(route.points) == n
        assert route.holds == ((1, 20.0),)


def test_a_missions_speed_changes_are_its_planned_speeds() -> None:
    """DO_CHANGE_SPEED (param2 m/s) from the waypoint before it on; -1 changes nothing;
    on a circuit, a speed lasts round the jump, and one set on the way there is in force
    round a lap that sets none."""
    speed, jump = mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_JUMP
    rows = [
        MissionItem(0, WP, REL_INT, 47.400, 8.540),
        MissionItem(1, speed, MISSION_FRAME, 0.0, 0.0, param1=1.0, param2=9.0),
        MissionItem(2, WP, REL_INT, 47.401, 8.540),
        MissionItem(3, speed, MISSION_FRAME, 0.0, 0.0, param1=1.0, param2=-1.0),
        MissionItem(4, WP, REL_INT, 47.401, 8.542),
        MissionItem(5, speed, MISSION_FRAME, 0.0, 0.0, param1=1.0, param2=3.5),
        MissionItem(6, WP, REL_INT, 47.402, 8.542),
    ]
    route = mission_route(rows, home_first=False)
    assert route.speeds == ((0, 9.0), (2, 3.5))
    assert route.remarks() == "2 speeds, 3.5-9 m/s"
    lap = mission_route(
        [*rows[:3], *rows[4:], MissionItem(7, jump, MISSION_FRAME, 0.0, 0.0, 2.0, -1.0)],
        home_first=False,
    )
    assert lap.circuit and len(lap.points) == 4  # (the lap from the second waypoint)
    assert lap.speeds == ((1, 3.5),)
    plain = mission_route(
        [*rows[:3], rows[4], rows[6], MissionItem(7, jump, MISSION_FRAME, 0.0, 0.0, 2.0, -1.0)],
        home_first=False,
    )
    assert plain.circuit and plain.speeds == ((0, 9.0),)


def test_a_mission_going_nowhere_is_no_route() -> None:
    with pytest.raises(ValueError, match=r"1 distinct point\(s\) of 2 items: no route"):
        mission_route(items((WP, GLOBAL, 47.4, 8.54), (WP, REL_INT, 47.4, 8.54)), home_first=True)
    with pytest.raises(ValueError, match="0 distinct"):
        mission_route([], home_first=False)


def test_a_missions_hold_times_are_where_the_convoy_will_stand() -> None:
    """NAV_WAYPOINT's param1 (ArduRover's hold time) and NAV_LOITER_TIME's, at their point;
    a hold "here" at the point before."""
    rows = [
        MissionItem(0, WP, REL_INT, 47.400, 8.540),
        MissionItem(1, WP, REL_INT, 47.401, 8.540, param1=30.0),
        MissionItem(2, WP, REL_INT, 0.0, 0.0, param1=15.0),  # here: at the point before
        MissionItem(3, mavlink.MAV_CMD_NAV_LOITER_TIME, REL_INT, 47.401, 8.542, param1=60.0),
        MissionItem(4, WP, REL_INT, 47.402, 8.542, param1=float("nan")),  # (no hold)
    ]
    route = mission_route(rows, home_first=False)
    assert route.holds == ((1, 45.0), (2, 60.0))
    assert route.remarks() == "2 holds, 105 s"
