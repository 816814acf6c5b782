"""A light fake fleet: N PX4 planes that speak MAVLink and fly perfectly, in one process.

At N = 1000 the full mock (physics, failsafes, parameters, one asyncio protocol
per vehicle) needs more than one of the benchmark machine's two cores, and the
client under test would be measured starved. This fleet keeps the protocol the
client sees -- pymavlink frames, one UDP port and one boot clock per vehicle,
PX4's HEARTBEAT modes, COMMAND_ACKs for DO_SET_MODE (OFFBOARD refused until
setpoints stream, as PX4 does), arming, SET_MESSAGE_INTERVAL streams, a 3D fix --
built from ``sitl_mock``'s own message builders and PX4 personality, and drops
the physics: a vehicle is wherever its last SET_POSITION_TARGET_GLOBAL_INT put
it. One selector loop, non-blocking sockets, a heap of stream deadlines.

Run: ``python benchmarks/fleet_light.py N [--base-port P] [--per-process K]``;
prints ``fleet-light: ready`` once every socket is bound, and on SIGTERM a
status line with its CPU time and message counts.
"""

from __future__ import annotations

import argparse
import contextlib
import heapq
import math
import os
import selectors
import signal
import socket
import sys
import time
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.codec import MavCodec
from sitl_mock.autopilot import SENSORS
from sitl_mock.messages import Command, Snapshot, build_telemetry
from sitl_mock.personality import Personality, firmware_for

__all__ = ["LightFleet", "start_light_fleet"]

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)  # sitl_mock's default world origin
FIRMWARE = firmware_for(Personality.PX4, "plane")
OFFBOARD = FIRMWARE.mode("OFFBOARD")
LOITER = FIRMWARE.mode("AUTO.LOITER")
FRESH_S = 0.5  # PX4 accepts OFFBOARD only while setpoints arrive this recently
DEFAULT_STREAMS = {mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0}
_SETPOINT = mavlink.MAVLINK_MSG_ID_SET_POSITION_TARGET_GLOBAL_INT


class _Vehicle:
    """One plane's protocol state (no physics: it is where it was told to be)."""

    __slots__ = (
        "alt",
        "armed",
        "codec",
        "custom_mode",
        "home",
        "lat",
        "lon",
        "peer",
        "setpoint_t",
        "sock",
        "streams",
        "sysid",
        "ve",
        "vn",
        "yaw",
    )

    def __init__(self, sysid: int, sock: socket.socket, home: GeoPoint) -> None:
        self.sysid = sysid
        self.sock = sock
        self.codec = MavCodec(sysid, 1)
        self.peer: Any = None
        self.home = home
        self.lat, self.lon, self.alt = home.lat, home.lon, home.alt
        self.vn = self.ve = self.yaw = 0.0
        self.armed = False
        self.custom_mode = LOITER.custom_mode
        self.setpoint_t = -math.inf
        self.streams: dict[int, float] = dict(DEFAULT_STREAMS)  # msg id -> interval s

    def snapshot(self, boot_ms: int) -> Snapshot:
        mode = OFFBOARD if self.custom_mode == OFFBOARD.custom_mode else LOITER
        return Snapshot(
            time_boot_ms=boot_ms, unix_usec=int(time.time() * 1e6),
            lat=self.lat, lon=self.lon, alt=self.alt, relative_alt=self.alt - self.home.alt,
            x=0.0, y=0.0, z=0.0, vn=self.vn, ve=self.ve, vd=0.0,
            roll=0.0, pitch=0.0, yaw=self.yaw, yaw_rate=0.0, airspeed=math.hypot(self.vn, self.ve),
            throttle=50, home=self.home, home_local=(0.0, 0.0, 0.0), home_set=True,
            mav_type=FIRMWARE.mav_type, autopilot=FIRMWARE.autopilot,
            base_mode=FIRMWARE.base_mode(mode, self.armed), custom_mode=self.custom_mode,
            system_status=FIRMWARE.system_status(self.armed, self.armed, False),
            sensors_present=SENSORS, sensors_health=SENSORS, gps_fix=mavlink.GPS_FIX_TYPE_3D_FIX,
            satellites=12, battery_remaining=90, battery_voltage=16.0, battery_current=5.0,
            battery_consumed_mah=100.0,
            landed_state=(mavlink.MAV_LANDED_STATE_IN_AIR if self.armed
                          else mavlink.MAV_LANDED_STATE_ON_GROUND),
        )  # fmt: skip


class LightFleet:
    """N fake planes on ports ``base_port ..``; sysid ``i % per_process + 1``."""

    def __init__(self, n: int, base_port: int, per_process: int = 250) -> None:
        self.t0 = time.monotonic()
        self.selector = selectors.DefaultSelector()
        self.vehicles: list[_Vehicle] = []
        self.due: list[tuple[float, int, int]] = []  # (wall, vehicle index, msg id)
        self.counters = {"in": 0, "out": 0, "setpoints": 0, "commands": 0}
        frame = LocalFrame(ORIGIN)
        for i in range(n):
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
            sock.bind(("127.0.0.1", base_port + i))
            sock.setblocking(False)
            home = frame.to_geo(0.0, 10.0 * i, 0.0)
            self.vehicles.append(_Vehicle(i % per_process + 1, sock, home))
            self.selector.register(sock, selectors.EVENT_READ, i)
        for i in range(n):  # vehicles booted at different instants: streams not in lockstep
            heapq.heappush(self.due, (self.t0 + i / n, i, mavlink.MAVLINK_MSG_ID_HEARTBEAT))

    def boot_ms(self, now: float) -> int:
        return int((now - self.t0) * 1000.0)

    def run(self, stop: list[bool]) -> None:
        """Serve until ``stop[0]`` is set (by the signal handler)."""
        while not stop[0]:
            timeout = max(0.0, self.due[0][0] - time.monotonic()) if self.due else 0.1
            for key, _ in self.selector.select(min(timeout, 0.1)):
                self._read(key.data)
            self._send_due(time.monotonic())

    def _read(self, index: int) -> None:
        vehicle = self.vehicles[index]
        for _ in range(64):
            try:
                data, addr = vehicle.sock.recvfrom(2048)
            except BlockingIOError:
                return
            vehicle.peer = addr
            for msg in vehicle.codec.feed_datagram(data):
                self.counters["in"] += 1
                self._handle(index, vehicle, msg)

    def _handle(self, index: int, vehicle: _Vehicle, msg: Any) -> None:
        msg_id = msg.get_msgId()
        if msg_id == _SETPOINT:
            self.counters["setpoints"] += 1
            vehicle.setpoint_t = time.monotonic()
            if vehicle.armed and vehicle.custom_mode == OFFBOARD.custom_mode:
                vehicle.lat, vehicle.lon = msg.lat_int * 1e-7, msg.lon_int * 1e-7
                vehicle.alt = vehicle.home.alt + msg.alt
                vehicle.vn, vehicle.ve, vehicle.yaw = msg.vx, msg.vy, msg.yaw
        elif msg_id == mavlink.MAVLINK_MSG_ID_COMMAND_LONG:
            self.counters["commands"] += 1
            self._command(index, vehicle, Command.from_long(msg, alt_relative=False))

    def _command(self, index: int, vehicle: _Vehicle, cmd: Command) -> None:
        result = mavlink.MAV_RESULT_ACCEPTED
        if cmd.command == mavlink.MAV_CMD_DO_SET_MODE:
            mode = FIRMWARE.decode_do_set_mode(cmd.p2, cmd.p3)
            fresh = time.monotonic() - vehicle.setpoint_t < FRESH_S
            if mode is None or (mode is OFFBOARD and not fresh):
                result = mavlink.MAV_RESULT_DENIED
            else:
                vehicle.custom_mode = mode.custom_mode
        elif cmd.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
            vehicle.armed = cmd.p1 >= 0.5
        elif cmd.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
            msg_id, interval_us = int(cmd.p1), cmd.p2
            if msg_id not in _BUILDABLE:
                result = mavlink.MAV_RESULT_UNSUPPORTED
            elif interval_us < 0:
                vehicle.streams.pop(msg_id, None)
            elif interval_us > 0:
                first = msg_id not in vehicle.streams
                vehicle.streams[msg_id] = interval_us * 1e-6
                if first:  # first one at once, as PX4 does; then on its own phase
                    heapq.heappush(self.due, (time.monotonic(), index, msg_id))
        elif cmd.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            if int(cmd.p1) in _BUILDABLE:
                self._emit(vehicle, int(cmd.p1), time.monotonic())
            else:
                result = mavlink.MAV_RESULT_UNSUPPORTED
        ack = mavlink.MAVLink_command_ack_message(
            cmd.command, result, 0, 0, cmd.src_system, cmd.src_component
        )
        self._send(vehicle, ack)

    def _send_due(self, now: float) -> None:
        due = self.due
        while due and due[0][0] <= now:
            at, index, msg_id = heapq.heappop(due)
            vehicle = self.vehicles[index]
            interval = vehicle.streams.get(msg_id)
            if interval is None:
                continue  # stream stopped
            self._emit(vehicle, msg_id, time.monotonic())  # stamped as it leaves
            nxt = at + interval
            heapq.heappush(due, (nxt if nxt > now else now + interval, index, msg_id))

    def _emit(self, vehicle: _Vehicle, msg_id: int, now: float) -> None:
        if vehicle.peer is None:
            return  # like a SITL: talks once someone has talked to it
        msg = build_telemetry(msg_id, vehicle.snapshot(self.boot_ms(now)))
        if msg is not None:
            self._send(vehicle, msg)

    def _send(self, vehicle: _Vehicle, msg: Any) -> None:
        with contextlib.suppress(OSError):  # a full buffer costs the message, not the loop
            vehicle.sock.sendto(vehicle.codec.pack(msg), vehicle.peer)
            self.counters["out"] += 1


_BUILDABLE = frozenset(
    {
        mavlink.MAVLINK_MSG_ID_HEARTBEAT,
        mavlink.MAVLINK_MSG_ID_SYS_STATUS,
        mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
        mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
        mavlink.MAVLINK_MSG_ID_ATTITUDE,
        mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
        mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
        mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
        mavlink.MAVLINK_MSG_ID_HOME_POSITION,
    }
)


@contextlib.asynccontextmanager
async def start_light_fleet(n: int, base_port: int, per_process: int = 250) -> AsyncIterator[str]:
    """Run the fleet in a subprocess; yields once it is ready, then its status line."""
    import asyncio

    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        str(Path(__file__)),
        str(n),
        "--base-port",
        str(base_port),
        "--per-process",
        str(per_process),
        stdout=asyncio.subprocess.PIPE,
        stdin=asyncio.subprocess.DEVNULL,
    )
    assert proc.stdout is not None
    status: list[str] = []
    try:
        async with asyncio.timeout(60.0):
            while not (line := await proc.stdout.readline()).startswith(b"fleet-light: ready"):
                if not line:
                    raise RuntimeError("fleet_light.py exited before it was ready")
        yield f"fleet-light pid {proc.pid}"
    finally:
        if proc.returncode is None:
            proc.terminate()
        with contextlib.suppress(TimeoutError):
            async with asyncio.timeout(10.0):
                status = (await proc.stdout.read()).decode(errors="replace").splitlines()
                await proc.wait()
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
        for text in status:
            print(text, file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n", type=int)
    parser.add_argument("--base-port", type=int, default=14540)
    parser.add_argument("--per-process", type=int, default=250, help="sysid space size")
    args = parser.parse_args(argv)
    fleet = LightFleet(args.n, args.base_port, args.per_process)
    stop = [False]

    def on_signal(*_: object) -> None:
        stop[0] = True

    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    print(f"fleet-light: ready: {args.n} planes on {args.base_port}..", flush=True)
    fleet.run(stop)
    cpu = os.times()
    wall = time.monotonic() - fleet.t0
    print(
        f"fleet-light: {wall:.1f} s, {(cpu.user + cpu.system) / wall:.3f} cores, "
        + " ".join(f"{k}={v}" for k, v in fleet.counters.items()),
        flush=True,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
