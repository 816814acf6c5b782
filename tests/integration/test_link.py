"""MavLink over real loopback sockets: udpout to the mock, udpin, tcp, tcpin, the tlog.

Independent peers: the sitl_mock vehicles, a pymavlink ``mavutil`` ground
station (tests/mavclient.py) and tiny asyncio TCP servers/clients written here.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import socket
from collections.abc import AsyncIterator, Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import AutopilotError
from convoy_mav.mavlink import MavCodec, MavLink
from convoy_mav.mavlink.link import gcs_heartbeat
from convoy_mav.recording import TlogRecorder
from sitl_mock.config import MockConfig

if TYPE_CHECKING:
    from tests.conftest import StartMock
    from tests.mavclient import MavClient

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

Msg = Any


class Inbox:
    """The ``on_message`` of a link under test: keeps everything, waits without blocking."""

    def __init__(self) -> None:
        self.msgs: list[Msg] = []

    def __call__(self, msg: Msg) -> None:
        self.msgs.append(msg)

    def of(self, kind: str, sysid: int | None = None) -> list[Msg]:
        return [
            m
            for m in self.msgs
            if m.get_type() == kind and (sysid is None or m.get_srcSystem() == sysid)
        ]

    async def wait_for(
        self,
        kind: str,
        predicate: Callable[[Msg], bool] | None = None,
        *,
        since: int = 0,
        timeout: float = 5.0,
    ) -> Msg:
        async with asyncio.timeout(timeout):
            while True:
                for msg in self.msgs[since:]:
                    if msg.get_type() == kind and (predicate is None or predicate(msg)):
                        return msg
                await asyncio.sleep(0.005)


async def until(done: Callable[[], bool], timeout: float = 5.0) -> None:
    async with asyncio.timeout(timeout):
        while not done():
            await asyncio.sleep(0.005)


def command_long(command: int, *params: float, target: int = 1) -> Msg:
    p = [float(x) for x in params] + [0.0] * (7 - len(params))
    return mavlink.MAVLink_command_long_message(target, 1, command, 0, *p)


def _from(sysid: int) -> Callable[[Msg], bool]:
    return lambda m: bool(m.get_srcSystem() == sysid)


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


# -- udpout: the service talking to an autopilot ----------------------------------------


async def test_udpout_to_the_mock_telemetry_and_command_ack(start_mock: StartMock) -> None:
    fleet = await start_mock(MockConfig.simple(1, speedup=40, base_port=0))
    inbox = Inbox()
    async with MavLink(fleet.endpoint(1).connect, inbox, name="uav1") as link:
        assert link.peer == ("127.0.0.1", fleet.endpoint(1).port) and link.connected
        hb = await inbox.wait_for("HEARTBEAT")  # our hello made the mock learn us
        assert hb.get_srcSystem() == 1 and hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
        await inbox.wait_for("GLOBAL_POSITION_INT")
        mark = len(inbox.msgs)
        request = command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 148)  # AUTOPILOT_VERSION
        assert link.send(request)
        ack = await inbox.wait_for(
            "COMMAND_ACK", lambda m: m.command == mavlink.MAV_CMD_REQUEST_MESSAGE, since=mark
        )
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED and ack.get_srcSystem() == 1
        await inbox.wait_for("AUTOPILOT_VERSION", since=mark)
        counters = link.link_counters()
        assert counters["sent"] == 2 and counters["packed"] == 2  # hello + command
        assert counters["messages"] == len(inbox.msgs) > 5
        assert not {"bad_crc", "bad_data", "refused", "callback_error"} & set(counters)
        assert "uav1" in repr(link) and "up" in repr(link)
    assert link.peer is None and not link.connected
    assert not link.send(gcs_heartbeat())  # closed: refused politely
    assert fleet.link(1).counters["messages_in"] == 2  # the mock got both, nothing else


async def test_callback_errors_are_contained(start_mock: StartMock) -> None:
    fleet = await start_mock(MockConfig.simple(1, speedup=40, base_port=0))
    inbox = Inbox()

    def picky(msg: Msg) -> None:
        if msg.get_type() == "HEARTBEAT":
            raise RuntimeError("handler bug")
        inbox(msg)

    async with MavLink(fleet.endpoint(1).connect, picky) as link:
        await inbox.wait_for("GLOBAL_POSITION_INT")
        await until(lambda: link.counters["callback_error"] >= 2)
        await inbox.wait_for("ATTITUDE", since=len(inbox.msgs))  # still receiving


async def test_udpout_with_nobody_listening_counts_refusals() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    # the probe is closed now: nothing listens on `port`
    async with MavLink(f"udpout:127.0.0.1:{port}", Inbox()) as link:
        results = []
        for _ in range(20):
            results.append(link.send(gcs_heartbeat()))  # never raises
            await asyncio.sleep(0.005)
        # ICMP "port unreachable" comes back for nearly every datagram; one is
        # reported synchronously by the next send (-> False), the rest by the reader.
        assert link.counters["refused"] >= 10
        assert link.codec.counters["packed"] == 1 + 20  # hello + ours, all attempted
        assert link.counters["sent"] == 21 - results.count(False)
        assert link.connected  # nothing to reconnect for UDP: it keeps trying


# -- udpin: the service listening, a pymavlink peer calling in ---------------------------


async def test_udpin_pins_the_first_peer_and_refuses_a_second(
    mav_client: Callable[..., MavClient],
) -> None:
    """A second sender on a live link is refused unread, never adopted; once the
    pinned peer has been silent ``repin_after``, a new one (a restarted autopilot) may
    take its place."""
    replies = MavCodec(system=42, component=1)
    inbox = Inbox()
    links: list[MavLink] = []

    def answer(msg: Msg) -> None:
        inbox(msg)
        if msg.get_type() == "HEARTBEAT" and links:
            links[0].send(
                mavlink.MAVLink_heartbeat_message(
                    mavlink.MAV_TYPE_FIXED_WING, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 3, 3
                )
            )

    async with MavLink("udpin:127.0.0.1:0", answer, codec=replies, repin_after=0.5) as link:
        links.append(link)
        local = link.local_address
        assert local is not None and local[1] > 0
        assert link.peer is None and not link.send(gcs_heartbeat())
        assert link.counters["send_no_peer"] == 1

        a = mav_client(local[1], source_system=200)
        a.hello()
        hb = await a.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 42)
        assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
        assert inbox.of("HEARTBEAT", sysid=200)
        assert link.peer is not None and link.peer[0] == "127.0.0.1"
        first_peer = link.peer

        b = mav_client(local[1], source_system=201)  # a second sender, while a lives
        for _ in range(5):
            b.hello()
            a.hello()
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.05)
        assert link.peer == first_peer and link.counters["peer_changed"] == 0
        assert link.counters["foreign_peer"] == 5
        assert not inbox.of("HEARTBEAT", sysid=201)  # never heard as the UAV
        b.poll()
        assert not b.of("HEARTBEAT")  # and never sent the UAV's replies

        await asyncio.sleep(0.6)  # a falls silent past repin_after: b may take over
        b.hello()
        await b.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 42)
        assert link.peer != first_peer and link.counters["peer_changed"] == 1


async def test_udpin_with_a_configured_peer_hears_only_it(
    mav_client: Callable[..., MavClient],
) -> None:
    inbox = Inbox()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        expected = probe.getsockname()[1]
    async with MavLink("udpin:127.0.0.1:0", inbox, peer=("127.0.0.1", expected)) as link:
        assert link.local_address is not None
        stranger = mav_client(link.local_address[1], source_system=7)
        stranger.hello()
        await asyncio.sleep(0.1)
        assert link.peer is None and link.counters["foreign_peer"] == 1
        assert not inbox.of("HEARTBEAT")


async def test_udpin_ignores_garbage_senders() -> None:
    inbox = Inbox()
    async with MavLink("udpin:127.0.0.1:0", inbox) as link:
        assert link.local_address is not None
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as junk:
            junk.sendto(b"\x01\x02garbage\x00" * 3, link.local_address)
            frame = MavCodec(system=9).pack(gcs_heartbeat())
            junk.sendto(frame[:-3], link.local_address)  # truncated
            await until(lambda: link.counters["datagrams_in"] == 2)
            assert link.peer is None  # nothing MAVLink came from it
            assert link.codec.counters["bad_data"] >= 1
            assert link.codec.counters["truncated"] == 1
            junk.sendto(frame, link.local_address)
            await until(lambda: link.peer is not None)
        assert inbox.of("HEARTBEAT", sysid=9)


# -- tcp client: reconnect with back-off ------------------------------------------------


class EchoServer:
    """A tiny MAVLink-agnostic TCP server that writes back whatever it reads."""

    def __init__(self, port: int) -> None:
        self.port = port
        self.server: asyncio.Server | None = None
        self.writers: list[asyncio.StreamWriter] = []
        self.accepted = 0

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.accepted += 1
        self.writers.append(writer)
        with contextlib.suppress(ConnectionError):
            while data := await reader.read(4096):
                writer.write(data)
        writer.close()

    async def start(self) -> None:
        self.server = await asyncio.start_server(self._handle, "127.0.0.1", self.port)

    async def stop(self) -> None:
        assert self.server is not None
        self.server.close()
        for w in self.writers:
            w.close()
        self.writers.clear()
        await self.server.wait_closed()


@contextlib.asynccontextmanager
async def echo_server(port: int) -> AsyncIterator[EchoServer]:
    server = EchoServer(port)
    await server.start()
    try:
        yield server
    finally:
        with contextlib.suppress(Exception):
            await server.stop()


async def test_tcp_client_connects_late_and_reconnects_after_a_restart() -> None:
    port = free_tcp_port()
    inbox = Inbox()
    link = MavLink(
        f"tcp:127.0.0.1:{port}", inbox, reconnect_initial=0.02, reconnect_max=0.1, name="echo"
    )
    async with link:
        await until(lambda: link.counters["connect_failed"] >= 2)  # nobody there yet
        assert not link.connected and not link.send(gcs_heartbeat())

        server = EchoServer(port)
        await server.start()
        await until(lambda: link.connected)
        hello = await inbox.wait_for("HEARTBEAT")  # our own hello, echoed
        assert hello.get_srcSystem() == 255 and hello.get_seq() == 0
        assert link.send(command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 148))
        echoed = await inbox.wait_for("COMMAND_LONG")
        assert echoed.param1 == 148 and echoed.get_seq() == 1

        await server.stop()  # the autopilot/router goes away
        await until(lambda: not link.connected)
        assert link.counters["disconnects"] == 1
        assert not link.send(gcs_heartbeat())

        await server.start()  # ... and comes back on the same port
        # (the client's connect completes in the kernel, before the server's handler runs)
        await until(lambda: link.connected and server.accepted == 2)
        assert link.counters["connects"] == 2
        mark = len(inbox.msgs)
        assert link.send(command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 33))
        again = await inbox.wait_for("COMMAND_LONG", since=mark)
        assert again.param1 == 33
        assert again.get_seq() == 3  # hello(0), cmd(1), hello after reconnect(2), cmd(3)
        await server.stop()
    assert link.codec.counters["bad_data"] == 0 and link.codec.counters["bad_crc"] == 0


async def test_tcp_stream_split_frames_are_reassembled() -> None:
    port = free_tcp_port()
    frames = [
        MavCodec(system=3).pack(gcs_heartbeat()),
        MavCodec(system=4).pack(command_long(400, 1)),
    ]
    blob = b"".join(frames)

    async def dribble(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        for i in range(0, len(blob), 5):  # 5-byte TCP segments
            writer.write(blob[i : i + 5])
            await writer.drain()
            await asyncio.sleep(0.001)
        with contextlib.suppress(ConnectionError):
            await reader.read()
        writer.close()

    server = await asyncio.start_server(dribble, "127.0.0.1", port)
    inbox = Inbox()
    try:
        async with MavLink(f"tcp:127.0.0.1:{port}", inbox, hello=False):
            await until(lambda: len(inbox.msgs) == 2)
    finally:
        server.close()
    assert [(m.get_type(), m.get_srcSystem()) for m in inbox.msgs] == [
        ("HEARTBEAT", 3),
        ("COMMAND_LONG", 4),
    ]


# -- tcpin: one peer at a time ----------------------------------------------------------


async def test_tcpin_serves_one_peer_and_a_new_one_replaces_it() -> None:
    inbox = Inbox()
    async with MavLink("tcpin:127.0.0.1:0", inbox) as link:
        assert link.local_address is not None
        host, port = link.local_address
        assert not link.send(gcs_heartbeat())

        reader_a, writer_a = await asyncio.open_connection(host, port)
        writer_a.write(MavCodec(system=7).pack(gcs_heartbeat()))
        await inbox.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 7)
        assert link.connected and link.send(command_long(400, 1))
        codec_a = MavCodec()
        got_a = codec_a.feed(await asyncio.wait_for(reader_a.read(4096), 5))
        assert [m.get_type() for m in got_a] == ["COMMAND_LONG"]

        reader_b, writer_b = await asyncio.open_connection(host, port)
        writer_b.write(MavCodec(system=8).pack(gcs_heartbeat()))
        await inbox.wait_for("HEARTBEAT", lambda m: m.get_srcSystem() == 8)
        assert link.counters["peer_replaced"] == 1
        assert await asyncio.wait_for(reader_a.read(4096), 5) == b""  # A was closed
        assert link.send(command_long(400, 2))
        got_b = MavCodec().feed(await asyncio.wait_for(reader_b.read(4096), 5))
        assert [(m.get_type(), m.param1) for m in got_b] == [("COMMAND_LONG", 2.0)]
        for w in (writer_a, writer_b):
            w.close()
        await until(lambda: not link.connected)


# -- clear errors at open ---------------------------------------------------------------


@pytest.mark.parametrize("kind", [socket.SOCK_DGRAM, socket.SOCK_STREAM])
async def test_port_in_use_is_an_autopilot_error_naming_the_connection(kind: int) -> None:
    with socket.socket(socket.AF_INET, kind) as taken:
        taken.bind(("127.0.0.1", 0))
        if kind == socket.SOCK_STREAM:
            taken.listen()
        port = taken.getsockname()[1]
        scheme = "udpin" if kind == socket.SOCK_DGRAM else "tcpin"
        text = f"{scheme}:127.0.0.1:{port}"
        with pytest.raises(AutopilotError, match=text):
            async with MavLink(text, Inbox()):
                pass


# -- recording a session ----------------------------------------------------------------


async def test_session_tlog_reads_back_with_mavutil(start_mock: StartMock, tmp_path: Path) -> None:
    fleet = await start_mock(MockConfig.simple(1, ground=1, speedup=40, base_port=0))
    ground = next(ep for ep in fleet.endpoints if ep.kind == "ground")
    path = tmp_path / "session.tlog"
    inbox = Inbox()
    async with (
        TlogRecorder(path, flush_interval=0.05) as recorder,
        MavLink(fleet.endpoint(1).connect, inbox, recorder=recorder, name="uav1") as uav,
        MavLink(ground.connect, inbox, recorder=recorder, name="ground") as car,
    ):
        for sysid in (1, ground.sysid):
            for kind in ("HEARTBEAT", "GLOBAL_POSITION_INT"):
                await inbox.wait_for(kind, _from(sysid))
        mark = len(inbox.msgs)
        uav.send(command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, 148))
        await inbox.wait_for("COMMAND_ACK", since=mark)
        sent = uav.counters["sent"] + car.counters["sent"]
    received = len(inbox.msgs)
    assert recorder.counters["packets"] == recorder.counters["written"] == sent + received

    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(str(path))
    log: list[Msg] = []
    while (msg := conn.recv_match()) is not None:
        log.append(msg)
    conn.close()
    assert len(log) == sent + received
    assert not [m for m in log if m.get_type() == "BAD_DATA"]
    by_source = {(m.get_srcSystem(), m.get_type()) for m in log}
    for needed in [
        (1, "HEARTBEAT"),
        (1, "GLOBAL_POSITION_INT"),
        (1, "COMMAND_ACK"),
        (ground.sysid, "HEARTBEAT"),
        (ground.sysid, "GLOBAL_POSITION_INT"),
        (255, "HEARTBEAT"),
        (255, "COMMAND_LONG"),
    ]:
        assert needed in by_source, needed
    stamps = [m._timestamp for m in log]
    assert all(b >= a for a, b in itertools.pairwise(stamps))
    assert stamps[-1] - stamps[0] < 60.0  # one short session, real epoch seconds
    ours = [m for m in log if m.get_srcSystem() == 255]
    assert ours and all(m._link == 3 for m in ours)  # MAVProxy's mark for "sent"
    assert all(m._link == 0 for m in log if m.get_srcSystem() != 255)


async def test_send_never_blocks_a_stalled_peer_costs_messages() -> None:
    # A TCP peer that stops reading: once the kernel buffers and the transport's
    # high-water mark are full, send() returns False at once (counted) instead of
    # queueing without bound; when the peer reads again, sending resumes.
    loop = asyncio.get_running_loop()
    async with MavLink("tcpin:127.0.0.1:0", Inbox()) as link:
        assert link.local_address is not None
        peer = socket.socket()
        peer.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
        peer.setblocking(False)
        with peer:
            await loop.sock_connect(peer, link.local_address)
            await until(lambda: link.connected)
            hb, n = gcs_heartbeat(), 0
            while link.send(hb):
                n += 1
                assert n < 2_000_000, "the transport never pushed back"
            assert link.counters["send_dropped"] == 1 and link.connected
            assert not link.send(hb) and link.counters["send_dropped"] == 2
            drained = 0
            async with asyncio.timeout(10):
                while not link.send(hb):
                    drained += len(await loop.sock_recv(peer, 1 << 20))
            assert drained > 0 and link.counters["sent"] == n + 1
