"""Test support: a non-blocking pymavlink ground station and reference circles.

Used by the integration tests as an *independent* MAVLink client of the mock
(and later of the service): it shares no code with either.
"""

from __future__ import annotations

import asyncio
import math
import random
import socket
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

__all__ = ["Circle", "MavClient", "free_udp_ports"]


def free_udp_ports(count: int = 1, host: str = "127.0.0.1") -> int:
    """First of ``count`` consecutive UDP ports free on ``host`` right now.

    Binding them all at once proves they were free; a small race remains
    between closing and the caller binding, as with any free-port helper.
    """
    rng = random.Random()
    for _ in range(200):
        base = rng.randrange(20000, 60000 - count)
        socks: list[socket.socket] = []
        try:
            for i in range(count):
                s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
                socks.append(s)
                s.bind((host, base + i))
        except OSError:
            continue
        finally:
            for s in socks:
                s.close()
        return base
    raise RuntimeError(f"no {count} consecutive free UDP ports found")


class MavClient:
    """An independent ground station: pymavlink ``udpout``, polled without blocking.

    The mock runs in the test's own event loop, so nothing here may block: every
    wait polls the socket and yields with ``asyncio.sleep``. Received messages are
    kept in :attr:`log` (in arrival order) for later checks.

    Args:
        port: The vehicle's UDP port.
        source_system: This station's system id (255: a GCS).
    """

    def __init__(self, port: int, source_system: int = 255, host: str = "127.0.0.1") -> None:
        from pymavlink import mavutil

        self.conn: Any = mavutil.mavlink_connection(
            f"udpout:{host}:{port}", source_system=source_system, source_component=190
        )
        self.mav: Any = self.conn.mav
        self.log: list[Any] = []
        self.bad = 0

    def close(self) -> None:
        """Release the socket."""
        self.conn.close()

    def hello(self) -> None:
        """Send a GCS heartbeat: the vehicle learns our address and replies to it."""
        from pymavlink.dialects.v20 import common as mavlink

        self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def poll(self) -> list[Any]:
        """Everything that has arrived since the last poll (also appended to the log)."""
        new: list[Any] = []
        while (msg := self.conn.recv_match(blocking=False)) is not None:
            if msg.get_type() == "BAD_DATA":
                self.bad += 1
            else:
                new.append(msg)
        self.log.extend(new)
        return new

    def of(self, kind: str) -> list[Any]:
        """Logged messages of one type, oldest first."""
        return [m for m in self.log if m.get_type() == kind]

    async def wait_for(
        self,
        kind: str | tuple[str, ...],
        predicate: Callable[[Any], bool] | None = None,
        timeout: float = 10.0,
        others: Sequence[MavClient] = (),
        since: int | None = None,
    ) -> Any:
        """The next message of type ``kind`` (matching ``predicate``) that arrives.

        Args:
            kind: Message type name(s).
            predicate: Extra condition on the message.
            timeout: Wall seconds before ``TimeoutError``.
            others: Further clients to keep draining while waiting.
            since: Also consider messages already logged from this index of
                :attr:`log` on (take ``len(client.log)`` before sending a request).
        """
        kinds = (kind,) if isinstance(kind, str) else kind
        backlog = self.log[since:] if since is not None else []
        async with asyncio.timeout(timeout):
            while True:
                for other in others:
                    other.poll()
                for msg in backlog + self.poll():
                    if msg.get_type() in kinds and (predicate is None or predicate(msg)):
                        return msg
                backlog = []
                await asyncio.sleep(0.001)

    async def until(
        self, done: Callable[[], bool], timeout: float = 10.0, others: Sequence[MavClient] = ()
    ) -> None:
        """Keep polling (this client and ``others``) until ``done()`` is true."""
        async with asyncio.timeout(timeout):
            while not done():
                self.poll()
                for other in others:
                    other.poll()
                await asyncio.sleep(0.002)

    async def command(
        self, command: int, *params: float, target: int = 1, timeout: float = 5.0
    ) -> Any:
        """COMMAND_LONG to ``target`` and its COMMAND_ACK."""
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        mark = len(self.log)
        self.mav.command_long_send(target, 1, command, 0, *p)
        return await self.wait_for(
            "COMMAND_ACK", lambda m: m.command == command, timeout=timeout, since=mark
        )


@dataclass(frozen=True)
class Circle:
    """A circle flown at constant speed: the reference for setpoint streams (world NED).

    Attributes:
        north, east: Centre (m).
        radius: Radius (m).
        speed: Speed along the circle (m/s).
        clockwise: Seen from above (north up, east right).
        phase: Angle of the point at t = t0, measured from north toward east (rad).
        t0: Sim time of ``phase``.
    """

    north: float
    east: float
    radius: float
    speed: float
    clockwise: bool = True
    phase: float = 0.0
    t0: float = 0.0

    @classmethod
    def through(
        cls, north: float, east: float, heading: float, radius: float, speed: float, t0: float
    ) -> Circle:
        """The clockwise circle passing through (north, east) at heading ``heading``."""
        cn = north + radius * math.cos(heading + math.pi / 2)
        ce = east + radius * math.sin(heading + math.pi / 2)
        return cls(cn, ce, radius, speed, True, heading - math.pi / 2, t0)

    def at(self, t: float) -> tuple[float, float, float, float]:
        """Reference (north, east, vn, ve) at sim time ``t``."""
        w = self.speed / self.radius * (1.0 if self.clockwise else -1.0)
        th = self.phase + w * (t - self.t0)
        n = self.north + self.radius * math.cos(th)
        e = self.east + self.radius * math.sin(th)
        v = self.radius * w
        return n, e, -v * math.sin(th), v * math.cos(th)

    def radial_error(self, north: float, east: float) -> float:
        """Distance from the centre minus the radius (m)."""
        return math.hypot(north - self.north, east - self.east) - self.radius
