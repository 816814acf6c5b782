"""The mock's geofence upload (mission protocol, MAV_MISSION_TYPE_FENCE), per firmware.

Items in turn are stored and the next one asked for; an item out of turn or after the
upload closed is answered as ArduPilot's ``MissionItemProtocol`` or PX4's
``MavlinkMissionManager`` answers it, so the service's retries meet the firmware's replies.
"""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common as mavlink

from tests.fakes import AP, GCS_COMPID, GCS_SYSID, PX4, Gcs, Msg, make_vehicle, of_type, texts

FENCE = mavlink.MAV_MISSION_TYPE_FENCE
INCLUSION = mavlink.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION
SQUARE = [(47.397, 8.545), (47.397, 8.547), (47.399, 8.547), (47.399, 8.545)]


def count(n: int, kind: int = FENCE) -> Msg:
    return mavlink.MAVLink_mission_count_message(1, 1, n, kind)


def item(seq: int, command: int = INCLUSION) -> Msg:
    lat, lon = SQUARE[seq]
    return mavlink.MAVLink_mission_item_int_message(
        1, 1, seq, mavlink.MAV_FRAME_GLOBAL, command, 0, 1, float(len(SQUARE)),
        0.0, 0.0, 0.0, round(lat * 1e7), round(lon * 1e7), 0.0, FENCE,
    )  # fmt: skip


def answer(replies: list[Msg]) -> tuple[str, int] | None:
    """The one mission reply: ("ACK", result) or ("REQUEST", seq); None if none.

    ACKs carry the mission type they answer (checked by ``fence_answer``).
    """
    acks = of_type(replies, "MISSION_ACK")
    requests = of_type(replies, "MISSION_REQUEST_INT")
    assert len(acks) + len(requests) <= 1, replies
    if acks:
        assert (acks[0].target_system, acks[0].target_component) == (GCS_SYSID, GCS_COMPID)
        return "ACK", acks[0].type
    if requests:
        assert requests[0].mission_type == FENCE
        return "REQUEST", requests[0].seq
    return None


def fence_answer(replies: list[Msg]) -> tuple[str, int] | None:
    assert all(m.mission_type == FENCE for m in of_type(replies, "MISSION_ACK"))
    return answer(replies)


def uploaded(gcs: Gcs) -> Gcs:
    """The upload in turn, checked answer by answer (as ArduPlane SITL answered it,
    ``checks/fence_protocol.py``)."""
    assert fence_answer(gcs.send(count(len(SQUARE)))) == ("REQUEST", 0)
    for seq in range(len(SQUARE)):
        replies = gcs.send(item(seq))
        last = seq == len(SQUARE) - 1
        want = ("ACK", mavlink.MAV_MISSION_ACCEPTED) if last else ("REQUEST", seq + 1)
        assert fence_answer(replies) == want
        ardupilot = gcs.vehicle.firmware.is_ardupilot
        assert texts(replies) == (["Fence Indexed OK"] if last and ardupilot else [])
    return gcs


@pytest.mark.parametrize("personality", [PX4, AP])
def test_a_fence_uploaded_in_turn_is_stored(personality: object) -> None:
    vehicle = make_vehicle(personality, "plane")  # type: ignore[arg-type]
    uploaded(Gcs(vehicle))
    assert [(m.seq, m.x, m.y) for m in vehicle.fence] == [
        (k, round(lat * 1e7), round(lon * 1e7)) for k, (lat, lon) in enumerate(SQUARE)
    ]
    assert vehicle.counters["fence_uploads"] == 1


def test_ardupilot_answers_a_copy_of_an_item_with_invalid_sequence_then_goes_on() -> None:
    gcs = Gcs(make_vehicle(AP, "plane"))
    gcs.send(count(len(SQUARE)))
    assert fence_answer(gcs.send(item(0))) == ("REQUEST", 1)
    assert fence_answer(gcs.send(item(0))) == ("ACK", mavlink.MAV_MISSION_INVALID_SEQUENCE)
    assert fence_answer(gcs.send(item(1))) == ("REQUEST", 2)  # (the upload stays open)


def test_px4_ignores_an_item_out_of_turn_during_an_upload() -> None:
    gcs = Gcs(make_vehicle(PX4, "plane"))
    gcs.send(count(len(SQUARE)))
    assert fence_answer(gcs.send(item(0))) == ("REQUEST", 1)
    assert fence_answer(gcs.send(item(0))) is None
    assert fence_answer(gcs.send(item(2))) is None
    assert fence_answer(gcs.send(item(1))) == ("REQUEST", 2)


def test_ardupilot_refuses_an_item_after_the_upload_closed() -> None:
    gcs = uploaded(Gcs(make_vehicle(AP, "plane")))
    assert fence_answer(gcs.send(item(len(SQUARE) - 1))) == ("ACK", mavlink.MAV_MISSION_ERROR)
    assert len(gcs.vehicle.fence) == len(SQUARE)  # (the fence it holds is kept)


def test_px4_accepts_the_last_item_again_and_refuses_any_other_after_the_upload() -> None:
    gcs = uploaded(Gcs(make_vehicle(PX4, "plane")))
    again = gcs.send(item(len(SQUARE) - 1))
    assert fence_answer(again) == ("ACK", mavlink.MAV_MISSION_ACCEPTED)  # (its ACK was lost)
    stray = gcs.send(item(1))
    assert fence_answer(stray) == ("ACK", mavlink.MAV_MISSION_ERROR)
    assert texts(stray) == ["IGN MISSION_ITEM: No transfer"]
    assert len(gcs.vehicle.fence) == len(SQUARE)


@pytest.mark.parametrize("personality", [PX4, AP])
def test_missions_and_non_vertex_items_are_unsupported(personality: object) -> None:
    gcs = Gcs(make_vehicle(personality, "plane"))  # type: ignore[arg-type]
    mission = gcs.send(count(3, mavlink.MAV_MISSION_TYPE_MISSION))
    assert answer(mission) == ("ACK", mavlink.MAV_MISSION_UNSUPPORTED)
    assert mission[0].mission_type == mavlink.MAV_MISSION_TYPE_MISSION
    gcs.send(count(len(SQUARE)))
    circle = item(0, mavlink.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION)
    assert fence_answer(gcs.send(circle)) == ("ACK", mavlink.MAV_MISSION_UNSUPPORTED)
    assert fence_answer(gcs.send(item(0))) == ("ACK", mavlink.MAV_MISSION_ERROR)  # (upload ended)
    assert gcs.vehicle.fence == []
