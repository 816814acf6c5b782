"""Setpoint loss and garbage on the wire: the mock degrades like an autopilot, never dies."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from typing import TYPE_CHECKING

import pytest
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.config import MockConfig

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import MavClient

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

PX4_OFFBOARD = 6 << 16
PX4_LOITER = (4 << 16) | (3 << 24)
POS_VEL_MASK = 0b1101_1100_0000


async def test_setpoint_loss_triggers_the_loiter_failsafe(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    timeout = 1.0
    config = MockConfig.simple(1, speedup=20, base_port=0, warmup=1.0, setpoint_timeout=timeout)
    fleet = await start_mock(config)
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    await client.until(lambda: fleet.now > 1.5)
    next_t = last_sent = 0.0

    def stream() -> bool:
        nonlocal next_t, last_sent
        if fleet.now >= next_t:
            last_sent = fleet.now
            client.mav.set_position_target_local_ned_send(
                0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_VEL_MASK,
                500.0, 0.0, -40.0, 18.0, 0.0, 0.0, 0, 0, 0, 0, 0,
            )  # fmt: skip
            next_t = fleet.now + 0.1
        return fleet.now > t_until

    t_until = fleet.now + 0.5
    await client.until(stream)
    # a PX4 plane takes off in AUTO.TAKEOFF (NAV_TAKEOFF, param7 AMSL), then OFFBOARD
    assert (await client.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)).result == 0
    amsl, nan = fleet.config.origin.alt + 40.0, math.nan
    takeoff = await client.command(mavlink.MAV_CMD_NAV_TAKEOFF, -1, 0, 0, nan, nan, nan, amsl)
    assert takeoff.result == 0
    t_until = fleet.now + 12.0
    await client.until(stream, timeout=10)
    assert fleet.truth(1).down < -30.0
    assert (await client.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 6)).result == 0
    t_until = fleet.now + 5.0  # fly offboard for a while
    await client.until(stream, timeout=10)
    assert client.of("HEARTBEAT")[-1].custom_mode == PX4_OFFBOARD

    t_stop = fleet.now  # the script dies: no more setpoints
    hb = await client.wait_for("HEARTBEAT", lambda m: m.custom_mode == PX4_LOITER, timeout=5)
    t_failsafe = fleet.now
    # the timeout runs from the last setpoint, sent up to one period before t_stop
    assert t_failsafe >= last_sent + timeout
    assert t_failsafe < t_stop + timeout + 1.5  # next heartbeat after the switch (1 Hz)
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert any("Failsafe" in m.text for m in client.of("STATUSTEXT"))
    assert fleet.counters(1)["setpoint_failsafe"] == 1
    row = fleet.truth(1)
    assert row.mode == "AUTO.LOITER" and row.armed and row.down < -20.0


def _frame(msg: mavlink.MAVLink_message, sysid: int = 255, v1: bool = False) -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=190)
    return bytes(msg.pack(mav, force_mavlink1=v1))


async def test_garbage_is_counted_and_the_vehicle_still_answers(
    start_mock: StartMock, mav_client: Callable[..., MavClient]
) -> None:
    fleet = await start_mock(MockConfig.simple(2, speedup=20, base_port=0))
    client = mav_client(fleet.endpoint(1).port)
    client.hello()
    await client.wait_for("HEARTBEAT")

    ping = mavlink.MAVLink_command_long_message(
        1, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 0, mavlink.MAVLINK_MSG_ID_ATTITUDE,
        0, 0, 0, 0, 0, 0,
    )  # fmt: skip
    good = _frame(ping)
    bad_crc = good[:-2] + bytes([good[-2] ^ 0xFF, good[-1]])
    unknown = bytes([0xFD, 1, 0, 0, 7, 255, 190, 0xDE, 0xBC, 0x0A, 0x42, 0x12, 0x34])
    foreign = _frame(
        mavlink.MAVLink_command_long_message(
            7, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
        )
    )
    rng = bytes(b for b in os.urandom(200) if b not in (0xFD, 0xFE)) or b"\x00"
    port = fleet.endpoint(1).port
    for data in (rng, bad_crc, good[: len(good) // 2], unknown, foreign, b"", b"\xfd"):
        client.conn.port.sendto(data, ("127.0.0.1", port))
    before = fleet.counters(1)["messages_in"]
    await client.until(lambda: fleet.counters(1)["datagrams_in"] >= 8)

    c = fleet.counters(1)
    assert c["malformed"] == 1  # one run of junk bytes, one "bad prefix"
    assert c["bad_crc"] == 1
    assert c["truncated"] == 2  # half a frame; a lone magic byte
    assert c["unknown_id"] == 1
    assert c["foreign_sysid"] == 1
    assert c["messages_in"] == before + 1  # only the foreign command decoded
    assert not fleet.vehicles[1].armed
    assert fleet.counters(2)["datagrams_in"] == 0

    # MAVLink 1 is accepted, and the good frame after all that garbage is answered.
    mark = len(client.log)
    client.conn.port.sendto(_frame(ping, v1=True), ("127.0.0.1", port))
    ack = await client.wait_for("COMMAND_ACK", lambda m: m.command == ping.command, since=mark)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED
    reply = await client.wait_for("MESSAGE_INTERVAL", since=mark)
    assert math.isclose(reply.interval_us, 100_000)
    assert "bad_crc=1" in fleet.status_line()
