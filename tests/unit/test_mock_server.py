"""The mock's UDP edge without sockets: a fake transport, a hand-cranked clock.

``MockFleet`` builds its vehicles and links on construction; a test hands each
link a recording transport (``connection_made``) and feeds it datagrams, then
steps the physics by hand. Everything is synchronous and deterministic.
"""

from __future__ import annotations

import itertools
import random
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import ConfigError
from sitl_mock.clock import ManualTime, SimClock
from sitl_mock.config import MockConfig
from sitl_mock.server import Endpoint, MockFleet, VehicleLink

GCS = ("127.0.0.1", 9)
PEER_A = ("127.0.0.1", 40001)
PEER_B = ("127.0.0.1", 40002)


class FakeTransport:
    """Records what a link sends; never closes unless told."""

    def __init__(self) -> None:
        self.sent: list[tuple[bytes, tuple[str, int]]] = []
        self.closing = False

    def sendto(self, data: bytes, addr: tuple[str, int]) -> None:
        self.sent.append((data, addr))

    def is_closing(self) -> bool:
        return self.closing

    def to(self, addr: tuple[str, int]) -> list[Any]:
        """Decoded messages sent to ``addr``."""
        parser = mavlink.MAVLink(None)
        out: list[Any] = []
        for data, dest in self.sent:
            if dest == addr:
                out += parser.parse_buffer(data) or []
        return out


def frame(msg: Any, sysid: int = 255, v1: bool = False, seq: int = 0) -> bytes:
    mav = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=190)
    mav.seq = seq
    return bytes(msg.pack(mav, force_mavlink1=v1))


def hello() -> bytes:
    return frame(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))


def arm(target: int = 1) -> Any:
    return mavlink.MAVLink_command_long_message(
        target, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
    )


def make(
    *, aircraft: int = 1, speedup: float = 10.0, **overrides: Any
) -> tuple[MockFleet, ManualTime, dict[int, FakeTransport]]:
    wall = ManualTime()
    config = MockConfig.simple(aircraft, base_port=0, warmup=1.0, **overrides)
    fleet = MockFleet(
        config,
        clock=SimClock(speedup, wall),
        run_physics=False,
        record_truth=True,
        rng=random.Random(0),
    )
    transports = {}
    for sysid in fleet.vehicles:
        transports[sysid] = FakeTransport()
        fleet.link(sysid).connection_made(transports[sysid])  # type: ignore[arg-type]
    return fleet, wall, transports


def run(fleet: MockFleet, seconds: float) -> None:
    for _ in range(round(seconds / fleet.dt)):
        fleet.step()


def test_telemetry_goes_to_the_gcs_address_and_to_every_peer_that_sent() -> None:
    fleet, _, tx = make(gcs="udp:127.0.0.1:9")
    run(fleet, 1.0)
    assert tx[1].to(GCS) and not tx[1].to(PEER_A)
    link = fleet.link(1)
    link.datagram_received(hello(), PEER_A)
    link.datagram_received(hello(), PEER_B)
    tx[1].sent.clear()
    run(fleet, 1.0)
    kinds = [m.get_type() for m in tx[1].to(PEER_A)]
    assert kinds == [m.get_type() for m in tx[1].to(PEER_B)]
    assert kinds == [m.get_type() for m in tx[1].to(GCS)]
    assert kinds.count("ATTITUDE") == 10  # 10 Hz of sim time
    assert fleet.peers(1) == [PEER_A, PEER_B]


def test_replies_go_to_every_peer_with_per_vehicle_sequence_numbers() -> None:
    fleet, _, tx = make(aircraft=2)
    run(fleet, 1.5)  # past the warm-up
    link = fleet.link(1)
    link.datagram_received(hello(), PEER_B)
    link.datagram_received(frame(arm()), PEER_A)
    for peer in (PEER_A, PEER_B):
        acks = [m for m in tx[1].to(peer) if m.get_type() == "COMMAND_ACK"]
        assert [(a.command, a.result) for a in acks] == [(400, mavlink.MAV_RESULT_ACCEPTED)]
    assert fleet.vehicles[1].armed and not fleet.vehicles[2].armed
    run(fleet, 1.0)
    msgs = tx[1].to(PEER_A)
    seqs = [m.get_seq() for m in msgs]
    assert all((b - a) % 256 == 1 for a, b in itertools.pairwise(seqs))
    assert {m.get_srcSystem() for m in msgs} == {1}
    assert tx[2].sent == []  # vehicle 2 has no peers


def test_mavlink1_is_accepted() -> None:
    fleet, _, _ = make()
    run(fleet, 1.5)
    fleet.link(1).datagram_received(frame(arm(), v1=True), PEER_A)
    assert fleet.vehicles[1].armed
    assert fleet.counters(1)["messages_in"] == 1


def test_every_kind_of_garbage_is_counted_and_parsing_recovers() -> None:
    fleet, _, tx = make()
    link = fleet.link(1)
    good = frame(arm())
    unknown = bytes([0xFD, 1, 0, 0, 7, 255, 190, 0xDE, 0xBC, 0x0A, 0x42, 0x12, 0x34])
    garbage = [
        b"\x01\x02\x03hello",
        good[:-1] + bytes([good[-1] ^ 0x55]),
        good[:7],
        unknown,
        frame(arm(target=9)),
        b"",
    ]
    for data in garbage:
        link.datagram_received(data, PEER_A)
    c = fleet.counters(1)
    assert (c["malformed"], c["bad_crc"], c["truncated"], c["unknown_id"]) == (1, 1, 1, 1)
    assert c["foreign_sysid"] == 1
    assert c["datagrams_in"] == 6
    run(fleet, 1.5)
    link.datagram_received(good, PEER_A)  # same peer, fresh parser state: decoded
    assert fleet.vehicles[1].armed
    line = fleet.status_line()
    for word in ("bad_crc=1", "malformed=1", "truncated=1", "unknown_id=1", "foreign_sysid=1"):
        assert word in line
    assert tx[1].to(PEER_A)


def test_a_failing_handler_is_counted_and_the_link_lives_on(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fleet, _, tx = make()
    link = fleet.link(1)

    def boom(msg: Any, now: float) -> list[Any]:
        raise RuntimeError("bug")

    monkeypatch.setattr(link.vehicle, "handle", boom)
    link.datagram_received(hello(), PEER_A)
    link.datagram_received(hello(), PEER_A)
    assert fleet.counters(1)["handler_error"] == 2
    run(fleet, 0.5)
    assert tx[1].to(PEER_A)


def test_peer_list_is_bounded() -> None:
    fleet, _, _ = make()
    for port in range(100):
        fleet.link(1).datagram_received(hello(), ("127.0.0.1", 50000 + port))
    peers = fleet.peers(1)
    assert len(peers) == 16
    assert peers[-1] == ("127.0.0.1", 50099)


def test_loss_to_vehicle_drops_before_parsing() -> None:
    fleet, _, _ = make(faults={"loss_to_vehicle": 1.0})
    fleet.link(1).datagram_received(hello(), PEER_A)
    c = fleet.counters(1)
    assert (c["lost_to_vehicle"], c["messages_in"]) == (1, 0)
    assert fleet.peers(1) == []  # a lost datagram teaches the vehicle nothing


def test_a_deaf_link_drops_what_comes_in_and_still_sends() -> None:
    fleet, _, transports = make()
    link = fleet.link(1)
    link.datagram_received(hello(), PEER_A)  # (a peer, then the uplink goes down)
    link.deaf = True
    link.datagram_received(frame(arm()), PEER_A)
    c = fleet.counters(1)
    assert (c["deaf"], c["messages_in"]) == (1, 1)
    transports[1].sent.clear()
    run(fleet, 1.1)  # (its heartbeat and telemetry still go out)
    assert any(m.get_type() == "HEARTBEAT" for m in transports[1].to(PEER_A))
    link.deaf = False
    link.datagram_received(frame(arm()), PEER_A)
    assert fleet.counters(1)["messages_in"] == 2


def test_latency_holds_datagrams_for_sim_time_both_ways() -> None:
    fleet, _, tx = make(faults={"latency_to_vehicle": 0.5, "latency_from_vehicle": 0.25})
    run(fleet, 1.5)
    link = fleet.link(1)
    link.datagram_received(frame(arm()), PEER_A)
    assert not fleet.vehicles[1].armed
    run(fleet, 0.49)
    assert not fleet.vehicles[1].armed
    run(fleet, 0.02)
    assert fleet.vehicles[1].armed  # handled 0.5 s late...
    assert not [m for m in tx[1].to(PEER_A) if m.get_type() == "COMMAND_ACK"]
    run(fleet, 0.26)
    assert [m for m in tx[1].to(PEER_A) if m.get_type() == "COMMAND_ACK"]  # ...ACK 0.25 s later


def test_scheduled_kill_silences_and_reboot_restarts() -> None:
    fleet, _, tx = make(aircraft=2, faults={"kill": ["1@2"], "reboot": ["2@3"]})
    fleet.link(1).datagram_received(hello(), PEER_A)
    fleet.link(2).datagram_received(hello(), PEER_A)
    run(fleet, 2.0)
    assert not fleet.is_alive(1)
    n1 = len(tx[1].sent)
    fleet.link(1).datagram_received(frame(arm()), PEER_A)
    run(fleet, 2.0)
    assert len(tx[1].sent) == n1
    assert fleet.counters(1)["killed"] == 1
    assert fleet.truth(1).mode == "KILLED"
    att = [m for m in tx[2].to(PEER_A) if m.get_type() == "ATTITUDE"]
    stamps = [m.time_boot_ms for m in att]
    i = next(i for i in range(1, len(stamps)) if stamps[i] < stamps[i - 1])
    assert stamps[i - 1] >= 2900 and stamps[i] <= 10
    fleet.reboot(1)  # a reboot brings a killed vehicle back
    assert fleet.is_alive(1)


def test_catch_up_steps_in_bursts_then_slips_when_hopelessly_behind() -> None:
    fleet, wall, _ = make(speedup=10.0)
    assert fleet.max_lag < 1.0  # under the setpoint-loss timeout: a stall pauses the sim
    wall.advance(0.02)  # 0.2 s of sim time due: within max_lag, caught up in bursts
    assert fleet.catch_up(max_steps=10) == 10
    assert fleet.catch_up(max_steps=10) == 10
    assert fleet.now == pytest.approx(0.2)
    assert fleet.catch_up() == 0
    wall.advance(100.0)  # 1000 s due: far beyond max_lag
    assert fleet.catch_up() == 1
    assert fleet.clock.slips == 1
    assert fleet.clock.now() == pytest.approx(fleet.now)
    assert fleet.clock.real_time_factor() < 0.1


def test_truth_history_is_sampled_at_the_truth_rate() -> None:
    fleet, _, _ = make(aircraft=2, truth_rate=5.0)
    run(fleet, 2.0)
    assert fleet.history is not None
    times = sorted({r.t for r in fleet.history.rows})
    assert times == pytest.approx([0.01, 0.2, 0.4, 0.6, 0.8, 1.0, 1.2, 1.4, 1.6, 1.8, 2.0])
    assert len(fleet.history.of(2)) == len(times)


def test_endpoint_strings() -> None:
    ep = Endpoint(3, "aircraft", "px4", "plane", "127.0.0.1", 14542)
    assert ep.connect == "udpout:127.0.0.1:14542"
    assert ep.listen == "udpin:127.0.0.1:14542"
    assert ep.mavsdk == "udpout://127.0.0.1:14542"
    assert "sysid=3 kind=aircraft personality=px4" in ep.describe()
    fleet, _, _ = make(aircraft=2, ground=1)
    assert [e.port for e in fleet.endpoints] == [0, 0, 0]
    assert fleet.endpoint(3).frame == "rover"


def test_link_ignores_sends_on_a_closing_transport() -> None:
    fleet, _, tx = make()
    link: VehicleLink = fleet.link(1)
    link.datagram_received(hello(), PEER_A)
    tx[1].closing = True
    run(fleet, 1.0)
    assert tx[1].sent == []


def test_a_scheduled_mode_change_is_its_operators_and_the_firmware_takes_it() -> None:
    """``[faults] mode``: the follower of a convoy held by its own operator at 5 s (a
    SET_MODE from system 250, as any ground station's) brakes to a stand while its
    leader drives on; a mode its firmware has not is refused when the config is read."""
    road: dict[str, Any] = {"route": "line", "speed": 8.0, "spacing": 20.0}
    ground = {f"ground_{k}": v for k, v in {**road, "personality": "ardupilot"}.items()}
    fleet, _, tx = make(aircraft=0, ground=2, faults={"mode": ["2:HOLD@5"]}, **ground)
    lead, follower = sorted(fleet.vehicles)
    assert follower == 2
    fleet.link(follower).datagram_received(hello(), PEER_A)
    run(fleet, 15.0)
    held, driving = fleet.truth(follower), fleet.truth(lead)
    assert held.mode == "HOLD" and held.speed == 0.0, held
    assert driving.mode == "AUTO" and driving.speed > 7.0, driving
    acks = [m for m in tx[follower].to(PEER_A) if m.get_type() == "COMMAND_ACK"]
    assert not acks  # (the ack went to the operator's station, not to the link's peers)
    with pytest.raises(ConfigError, match=r"faults\.mode\[0\].*no mode of sysid 2"):
        MockConfig.simple(0, ground=2, faults={"mode": ["2:LOITERING@5"]}, **ground)
    with pytest.raises(ConfigError, match=r"faults\.mode\[0\].*SYSID:MODE@TIME"):
        MockConfig.simple(0, ground=2, faults={"mode": ["2@5"]}, **ground)


@pytest.mark.parametrize(("check", "mode", "armed"), [(0, "AUTO", True), (1, "HOLD", True)])
def test_a_stalled_truck_stands_and_its_crash_check_sends_it_to_hold(
    check: int, mode: str, armed: bool
) -> None:
    """``[faults] stall``: the follower stalls at 5 s (a breakdown) and brakes to a stand
    while its leader drives on. Its firmware drives on in AUTO (FS_CRASH_CHECK 0, Rover's
    default), or, with FS_CRASH_CHECK 1, says "Crash: Going to HOLD" 2 s after it stands
    and holds. Only a ground vehicle stalls."""
    road: dict[str, Any] = {"route": "line", "speed": 8.0, "spacing": 20.0}
    ground = {f"ground_{k}": v for k, v in {**road, "personality": "ardupilot"}.items()}
    fleet, _, tx = make(aircraft=0, ground=2, faults={"stall": ["2@5"]}, **ground)
    lead, follower = sorted(fleet.vehicles)
    fleet.link(follower).datagram_received(hello(), PEER_A)
    fleet.vehicles[follower].handle(
        mavlink.MAVLink_param_set_message(follower, 1, b"FS_CRASH_CHECK", float(check), 9), 0.0
    )
    run(fleet, 5.0)
    assert fleet.truth(follower).speed > 7.0
    run(fleet, 20.0)
    stood, driving = fleet.truth(follower), fleet.truth(lead)
    assert stood.mode == mode and stood.armed is armed and stood.speed == 0.0, stood
    assert driving.mode == "AUTO" and driving.speed > 7.0, driving
    texts = [m.text for m in tx[follower].to(PEER_A) if m.get_type() == "STATUSTEXT"]
    assert texts.count("Crash: Going to HOLD") == check, texts
    run(fleet, 10.0)
    assert (fleet.truth(follower).north, fleet.truth(follower).east) == (stood.north, stood.east)
    with pytest.raises(ConfigError, match=r"faults\.stall\[0\].*no ground vehicle"):
        MockConfig.simple(1, ground=1, faults={"stall": ["1@5"]}, **ground)
