"""One autopilot connection over asyncio: UDP in/out, TCP client or TCP server.

Data flow (each arrow is one function)::

    socket -> protocol callback -> MavCodec.feed[_datagram] -> _deliver
           -> recorder.record(frame) + on_message(msg)            (synchronous)
    MavLink.send(msg) -> MavCodec.pack -> transport (never awaited) + recorder

Schemes (see :mod:`convoy_mav.mavlink.connection`):
    ``udpout``  a connected UDP socket from an ephemeral port to host:port (the
                kernel drops datagrams from anyone else); a GCS HEARTBEAT goes
                out at open so the far end learns our address.
                ICMP "port unreachable" shows up as ``refused`` in the counters.
    ``udpin``   bind host:port; the peer is the configured ``peer``, else the first
                sender of a datagram that holds a MAVLink frame, pinned: another
                sender is refused unread (``foreign_peer``) unless the pinned one
                has been silent ``repin_after`` wall s (a restarted autopilot).
    ``tcp``     a background task connects, and reconnects after a loss with
                exponential back-off (reset once a connection delivers a message).
    ``tcpin``   a server accepting one peer at a time: a new connection replaces
                the current one (a restarted router need not wait for the old
                socket to time out).

Design rules:
    * :meth:`MavLink.send` never blocks and never raises for network trouble: no
      peer yet, a paused (full) transport or a socket error -> ``False`` and a
      counter. Encoding errors (a field out of range) are our bug and raise.
    * ``on_message`` runs synchronously inside the protocol callback: keep it
      cheap. If it raises, the error is counted and logged once per message type,
      and the link lives on.
    * Every frame sent and every frame received (as its own bytes, so the tlog
      holds whole frames even when a datagram carried several) is recorded.
    * Failing to bind/resolve at open is the peer's world refusing us:
      :class:`~convoy_mav.errors.AutopilotError` naming the connection string.
"""

from __future__ import annotations

import asyncio
import logging
import math
import socket
import time
from collections import Counter
from collections.abc import Callable
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.errors import AutopilotError
from convoy_mav.mavlink.codec import MavCodec, Message
from convoy_mav.mavlink.connection import ConnectionSpec
from convoy_mav.recording import LINK_SENT

if TYPE_CHECKING:
    from convoy_mav.recording import TlogRecorder

__all__ = ["Address", "MavLink", "gcs_heartbeat"]

log = logging.getLogger(__name__)

Address = tuple[str, int]

_CLOSE_WAIT = 1.0  # s to wait for transports to release their sockets on exit
_FOREIGN_WARN = 16  # foreign peers named in the log, per link (then only counted)


def _fmt_peer(peer: Address | None) -> str:
    return "nobody" if peer is None else f"{peer[0]}:{peer[1]}"


def _same_peer(a: Address, b: Address) -> bool:
    """Same address and port (``localhost`` and the loopback addresses are one host)."""
    if a[1] != b[1]:
        return False
    loopback = {"localhost", "127.0.0.1", "::1", "::ffff:127.0.0.1"}
    return a[0] == b[0] or (a[0] in loopback and b[0] in loopback)


def gcs_heartbeat() -> Message:
    """The HEARTBEAT a ground station sends (type GCS, no autopilot, active)."""
    return mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
    )


class MavLink:
    """One autopilot connection (it may carry several system ids, e.g. via a router).

    Args:
        spec: Where to connect/listen (a :class:`ConnectionSpec` or its string).
        on_message: Called synchronously with every decoded message of a known
            type, from any system id. Must be cheap and should not raise.
        codec: Our identity and sequence numbers (default: sysid 255, compid 190).
            Give each link its own.
        recorder: Where sent and received frames are recorded (optional).
        name: For logs and ``repr`` (default: the connection string).
        reconnect_initial: ``tcp``: first back-off delay after a failed or lost
            connection (s).
        reconnect_max: ``tcp``: back-off cap (s).
        connect_timeout: ``tcp``: give up one connection attempt after this (s).
        hello: Send a GCS HEARTBEAT as soon as a ``udpout``/``tcp`` link is up,
            so a vehicle that replies to known peers only starts talking.
        peer: ``udpin``: the only address accepted (``host``, ``port``); None: the
            first peer whose datagram decodes is pinned.
        repin_after: ``udpin`` without ``peer``: wall s the pinned peer must have been
            silent before another may take its place (an autopilot restarted on a
            new port). Until then a second peer's datagrams are dropped unread and
            counted (``foreign_peer``): nobody else on the network becomes the
            address the UAV's commands go to, or is heard as the UAV.

    Attributes:
        counters: Link-level counters (see :meth:`link_counters` for all of them).
        on_message: The callback; may be replaced while running.
    """

    def __init__(
        self,
        spec: ConnectionSpec | str,
        on_message: Callable[[Message], None],
        *,
        codec: MavCodec | None = None,
        recorder: TlogRecorder | None = None,
        name: str = "",
        reconnect_initial: float = 0.25,
        reconnect_max: float = 5.0,
        connect_timeout: float = 5.0,
        hello: bool = True,
        peer: Address | None = None,
        repin_after: float = 5.0,
    ) -> None:
        if isinstance(spec, str):
            spec = ConnectionSpec.parse(spec)
        if not 0.0 < reconnect_initial <= reconnect_max:
            raise ValueError("need 0 < reconnect_initial <= reconnect_max")
        self._spec = spec
        self.on_message = on_message
        self.codec = codec if codec is not None else MavCodec()
        self.name = name or str(spec)
        self.counters: Counter[str] = Counter()
        self._recorder = recorder
        self._reconnect_initial = reconnect_initial
        self._reconnect_max = reconnect_max
        self._connect_timeout = connect_timeout
        self._hello = hello
        self._udp: asyncio.DatagramTransport | None = None
        self._udp_closed: asyncio.Future[None] | None = None
        self._stream: _StreamProtocol | None = None
        self._server: asyncio.AbstractServer | None = None
        self._task: asyncio.Task[None] | None = None
        self._peer: Address | None = None
        self._pinned = peer
        self._repin_after = repin_after
        self._peer_heard = -math.inf  # monotonic s the pinned peer last sent a frame
        self._foreign_warned: set[Address] = set()
        self._paused = False
        self._state = "new"  # new -> open -> closed
        self._sending = False
        self._send_failed = False
        self._net_warned: set[str] = set()
        self._handler_warned: set[str] = set()

    # -- status --------------------------------------------------------------------------

    @property
    def spec(self) -> ConnectionSpec:
        """The connection this link serves."""
        return self._spec

    @property
    def peer(self) -> Address | None:
        """Where sends go now: the fixed remote, the learnt sender or the TCP peer."""
        return self._peer

    @property
    def connected(self) -> bool:
        """True when :meth:`send` has somewhere to send to."""
        return self._peer is not None and self._writable()

    @property
    def local_address(self) -> Address | None:
        """Our bound address (useful with port 0), or None when not bound."""
        sockname: Any = None
        if self._udp is not None:
            sockname = self._udp.get_extra_info("sockname")
        elif isinstance(self._server, asyncio.Server) and self._server.sockets:
            sockname = self._server.sockets[0].getsockname()
        elif self._stream is not None and self._stream.transport is not None:
            sockname = self._stream.transport.get_extra_info("sockname")
        return (str(sockname[0]), int(sockname[1])) if sockname else None

    def link_counters(self) -> dict[str, int]:
        """Every counter of this link and its codec, for operator status.

        Link: ``sent``, ``bytes_out``, ``bytes_in``, ``datagrams_in``,
        ``send_no_peer``, ``send_dropped`` (transport full), ``refused`` (nothing
        listening), ``socket_error``, ``callback_error``, ``connects``,
        ``disconnects``, ``connect_failed``, ``peer_changed``, ``peer_replaced``,
        ``foreign_peer`` (``udpin``: datagrams of a peer other than the pinned one).
        Codec: ``messages``, ``packed``, ``bad_crc``, ``bad_data``, ``unknown_id``,
        ``truncated``, ``seq_lost``, ``mavlink1``.
        """
        merged = Counter(self.codec.counters)
        merged.update(self.counters)
        return {k: v for k, v in sorted(merged.items()) if v}

    def __repr__(self) -> str:
        peer = f"{self._peer[0]}:{self._peer[1]}" if self._peer else "-"
        state = "up" if self.connected else ("waiting" if self._state == "open" else self._state)
        c, cc = self.counters, self.codec.counters
        errors = (
            c["refused"] + c["socket_error"] + c["callback_error"] + cc["bad_crc"] + cc["bad_data"]
        )
        name = "" if self.name == str(self._spec) else f"{self.name} "
        return (
            f"<MavLink {name}{self._spec} peer={peer} {state} "
            f"sent={c['sent']} recv={cc['messages']} errors={errors}>"
        )

    # -- sending -------------------------------------------------------------------------

    def send(self, msg: Message) -> bool:
        """Encode and send one message now; never blocks, never raises for the network.

        Returns:
            True if the frame was handed to the OS; False (and counted) if there
            is no peer yet, the transport is full or the socket reported an error.

        Raises:
            ValueError: ``msg`` cannot be encoded (a field out of range).
        """
        if self._peer is None or not self._writable():
            self.counters["send_no_peer"] += 1
            return False
        if self._paused:
            self.counters["send_dropped"] += 1
            return False
        frame = self.codec.pack(msg)
        self._send_failed = False
        self._sending = True
        try:
            if self._udp is not None:
                # udpout's socket is connected (address None); udpin replies to the peer.
                self._udp.sendto(frame, None if self._spec.scheme == "udpout" else self._peer)
            elif self._stream is not None and self._stream.transport is not None:
                self._stream.transport.write(frame)
        except (OSError, RuntimeError) as e:  # RuntimeError: write after the peer's EOF
            self._socket_error(e)
        finally:
            self._sending = False
        if self._send_failed:
            return False
        self.counters["sent"] += 1
        self.counters["bytes_out"] += len(frame)
        if self._recorder is not None:
            self._recorder.record(frame, link=LINK_SENT)
        return True

    def _writable(self) -> bool:
        if self._udp is not None:
            return not self._udp.is_closing()
        stream = self._stream
        return stream is not None and stream.transport is not None and not stream.closing()

    # -- lifecycle -----------------------------------------------------------------------

    async def __aenter__(self) -> MavLink:
        if self._state != "new":
            raise RuntimeError(f"{self.name}: a MavLink can be opened only once")
        self._state = "open"
        try:
            await self._open()
        except BaseException:
            await self.aclose()
            raise
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.aclose()

    async def _open(self) -> None:
        loop = asyncio.get_running_loop()
        spec = self._spec
        if spec.scheme == "tcp":
            self._task = asyncio.create_task(self._tcp_client(), name=f"mavlink[{self.name}].tcp")
            return
        try:
            if spec.scheme == "tcpin":
                self._server = await loop.create_server(
                    lambda: _StreamProtocol(self), spec.host, spec.port
                )
                log.info("%s: listening on %s", self.name, spec)
                return
            self._udp_closed = loop.create_future()
            closed = self._udp_closed
            # IPv4 unless the host is an IPv6 literal: "localhost" must reach an
            # autopilot bound to 127.0.0.1 (as mavutil does), not ::1.
            family = socket.AF_INET6 if ":" in spec.host else socket.AF_INET
            address = (spec.host, spec.port)
            outward = spec.scheme == "udpout"
            transport, _ = await loop.create_datagram_endpoint(
                lambda: _DatagramProtocol(self, closed),
                local_addr=None if outward else address,
                remote_addr=address if outward else None,
                family=family,
            )
        except OSError as e:
            verb = "reach" if spec.scheme == "udpout" else "bind"
            raise AutopilotError(
                f"{spec}: cannot {verb} ({e.strerror or e})"
                + (f" [{self.name}]" if self.name != str(spec) else "")
            ) from e
        self._udp = transport
        if spec.scheme == "udpout":
            peer = transport.get_extra_info("peername")
            self._peer = (str(peer[0]), int(peer[1]))
            if self._hello:
                self.send(gcs_heartbeat())
        else:
            log.info("%s: listening on %s", self.name, spec)

    async def aclose(self) -> None:
        """Stop reconnecting, close sockets and wait until they are released."""
        if self._state == "closed":
            return
        self._state = "closed"
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            await asyncio.wait([task])
        waits: list[asyncio.Future[Any]] = []
        stream, self._stream = self._stream, None
        if stream is not None and stream.transport is not None:
            stream.transport.close()
            waits.append(stream.closed)
        if self._udp is not None:
            self._udp.close()
            if self._udp_closed is not None:
                waits.append(self._udp_closed)
        server, self._server = self._server, None
        if server is not None:
            server.close()
            waits.append(asyncio.ensure_future(server.wait_closed()))
        self._peer = None
        if waits:
            await asyncio.wait(waits, timeout=_CLOSE_WAIT)

    # -- receiving (called by the protocols) ---------------------------------------------

    def _datagram(self, data: bytes, addr: Any) -> None:
        c = self.counters
        c["datagrams_in"] += 1
        c["bytes_in"] += len(data)
        inward = self._spec.scheme == "udpin"
        peer = (str(addr[0]), int(addr[1])) if inward else None
        if peer is not None and peer != self._peer and not self._may_pin(peer):
            c["foreign_peer"] += 1  # (dropped unread: a flood costs no decoding)
            if peer not in self._foreign_warned and len(self._foreign_warned) < _FOREIGN_WARN:
                self._foreign_warned.add(peer)
                log.warning(
                    "%s: datagrams from %s:%d refused: the link is pinned to %s",
                    self.name, *peer, _fmt_peer(self._pinned or self._peer),
                )  # fmt: skip
            return
        msgs = self.codec.feed_datagram(data, keep_unknown=True)
        if not msgs:
            return
        if peer is not None:
            if peer != self._peer:
                if self._peer is not None:
                    c["peer_changed"] += 1
                    log.warning("%s: peer %s silent; %s:%d took its place", self.name,
                                _fmt_peer(self._peer), *peer)  # fmt: skip
                else:
                    log.info("%s: peer is now %s:%d", self.name, *peer)
                self._peer = peer
            self._peer_heard = time.monotonic()
        self._deliver(msgs)

    def _may_pin(self, peer: Address) -> bool:
        """May ``peer`` become (or be) the link's peer? (Only frames that decode pin it.)"""
        if self._pinned is not None:
            return _same_peer(peer, self._pinned)
        return self._peer is None or time.monotonic() - self._peer_heard > self._repin_after

    def _deliver(self, msgs: list[Message]) -> None:
        if self._net_warned:
            self._net_warned.clear()  # the link works again: log the next outage
        recorder = self._recorder
        for msg in msgs:
            if recorder is not None:
                recorder.record(msg.get_msgbuf())
            if isinstance(msg, mavlink.MAVLink_unknown):
                continue  # recorded, counted by the codec, not dispatched
            try:
                self.on_message(msg)
            except Exception:
                self.counters["callback_error"] += 1
                kind = msg.get_type()
                if kind not in self._handler_warned:
                    self._handler_warned.add(kind)
                    log.exception("%s: handling %s failed (further ones counted)", self.name, kind)

    def _socket_error(self, exc: Exception) -> None:
        key = "refused" if isinstance(exc, ConnectionRefusedError) else "socket_error"
        self.counters[key] += 1
        if self._sending:
            self._send_failed = True
        if key not in self._net_warned:
            self._net_warned.add(key)
            log.warning("%s: %s (counted; logged again after the link recovers)", self.name, exc)

    def _stream_up(self, proto: _StreamProtocol) -> None:
        if self._state == "closed":
            assert proto.transport is not None
            proto.transport.close()
            return
        old = self._stream
        if old is not None and old.transport is not None:
            self.counters["peer_replaced"] += 1
            log.info("%s: a new connection replaces %s", self.name, self._peer)
            old.transport.close()
        assert proto.transport is not None
        peer = proto.transport.get_extra_info("peername")
        self._stream = proto
        self._peer = (str(peer[0]), int(peer[1])) if peer else None
        self._paused = False
        self.codec.reset_input()
        self.counters["connects"] += 1
        self._net_warned.clear()
        log.info("%s: connected to %s", self.name, self._peer)
        if self._hello and self._spec.scheme == "tcp":
            self.send(gcs_heartbeat())

    def _stream_data(self, proto: _StreamProtocol, data: bytes) -> None:
        if proto is not self._stream:
            return  # late bytes from a replaced connection
        self.counters["bytes_in"] += len(data)
        msgs = self.codec.feed(data, keep_unknown=True)
        if msgs:
            proto.messages += len(msgs)
            self._deliver(msgs)

    def _stream_down(self, proto: _StreamProtocol, exc: Exception | None) -> None:
        if proto is not self._stream:
            return
        self._stream = None
        self._peer = None
        self._paused = False
        self.counters["disconnects"] += 1
        if self._state != "closed":
            log.warning("%s: connection lost (%s)", self.name, exc or "closed by peer")

    def _set_paused(self, proto: object, paused: bool) -> None:
        if proto is self._stream or self._stream is None:
            self._paused = paused

    # -- tcp client ----------------------------------------------------------------------

    async def _tcp_client(self) -> None:
        """Connect, wait for the loss, back off, repeat; until cancelled."""
        loop = asyncio.get_running_loop()
        spec = self._spec
        delay = self._reconnect_initial
        while True:
            try:
                async with asyncio.timeout(self._connect_timeout):
                    _, proto = await loop.create_connection(
                        lambda: _StreamProtocol(self), spec.host, spec.port
                    )
            except (OSError, TimeoutError) as e:
                self.counters["connect_failed"] += 1
                level = logging.DEBUG if "connect" in self._net_warned else logging.WARNING
                self._net_warned.add("connect")
                log.log(level, "%s: cannot connect (%s); retrying", self.name, e or "timeout")
            else:
                await proto.closed
                if proto.messages:
                    delay = self._reconnect_initial  # it worked: come back quickly
            await asyncio.sleep(delay)
            delay = min(delay * 2.0, self._reconnect_max)


class _DatagramProtocol(asyncio.DatagramProtocol):
    """Forwards socket events of a UDP link to its :class:`MavLink`."""

    def __init__(self, link: MavLink, closed: asyncio.Future[None]) -> None:
        self.link = link
        self.closed = closed

    def datagram_received(self, data: bytes, addr: Any) -> None:
        self.link._datagram(data, addr)

    def error_received(self, exc: Exception) -> None:
        self.link._socket_error(exc)

    def connection_lost(self, exc: Exception | None) -> None:
        if not self.closed.done():
            self.closed.set_result(None)

    def pause_writing(self) -> None:
        self.link._set_paused(self, True)

    def resume_writing(self) -> None:
        self.link._set_paused(self, False)


class _StreamProtocol(asyncio.Protocol):
    """One TCP connection of a link (client or accepted); stale ones are ignored."""

    def __init__(self, link: MavLink) -> None:
        self.link = link
        self.transport: asyncio.WriteTransport | None = None
        self.closed: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.messages = 0

    def closing(self) -> bool:
        return self.transport is None or self.transport.is_closing()

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        self.transport = cast(asyncio.WriteTransport, transport)
        self.link._stream_up(self)

    def data_received(self, data: bytes) -> None:
        self.link._stream_data(self, data)

    def connection_lost(self, exc: Exception | None) -> None:
        self.link._stream_down(self, exc)
        if not self.closed.done():
            self.closed.set_result(None)

    def pause_writing(self) -> None:
        self.link._set_paused(self, True)

    def resume_writing(self) -> None:
        self.link._set_paused(self, False)
