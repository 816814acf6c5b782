"""How many mock aircraft one core simulates in real time.

Runs the server's own step loop (:meth:`MockFleet.step`: physics at 100 Hz,
default telemetry streams, pymavlink encoding and one ``sendto`` per message to
a local sink socket) as fast as it goes, with every aircraft armed and flying,
and reports the real-time factor: sim seconds per wall second. A factor >= 1
means the fleet runs at ``--speedup 1`` on one core; the achievable speedup is
that factor.

Run: ``python benchmarks/bench_mock_realtime.py [N ...] [--seconds WALL]``.
"""

from __future__ import annotations

import argparse
import asyncio
import socket
import sys
import time
from dataclasses import dataclass
from math import nan

from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet


@dataclass(frozen=True)
class Result:
    """One benchmark row."""

    aircraft: int
    rtf: float
    messages_per_sim_s: float
    datagrams_per_wall_s: float
    us_per_vehicle_step: float


def _frame(msg: object, gcs: object) -> bytes:
    buf: bytes = msg.pack(gcs)  # type: ignore[attr-defined]
    gcs.seq = (gcs.seq + 1) % 256  # type: ignore[attr-defined]
    return buf


async def _measure(n: int, wall_seconds: float) -> Result:
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)
    sink.bind(("127.0.0.1", 0))
    addr = sink.getsockname()
    gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    config = MockConfig.simple(n, base_port=0, warmup=1.0)
    try:
        async with MockFleet(config, run_physics=False) as fleet:
            hello = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
            )
            for sysid in fleet.vehicles:
                # The sink "sends" a heartbeat: every vehicle now replies to it.
                fleet.link(sysid).datagram_received(_frame(hello, gcs), addr)
            while fleet.now < 1.5:
                fleet.step()
            for sysid in fleet.vehicles:
                link = fleet.link(sysid)
                arm = mavlink.MAVLink_command_long_message(
                    sysid, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
                )
                takeoff = mavlink.MAVLink_command_long_message(
                    sysid, 1, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, nan, nan, nan, nan
                )
                link.datagram_received(_frame(arm, gcs), addr)
                link.datagram_received(_frame(takeoff, gcs), addr)
            while fleet.now < 30.0:  # climb out and settle into the post-takeoff loiter
                fleet.step()
            flying = sum(row.down < -10.0 for row in fleet.truth_rows())
            sent0 = fleet.counters()["messages_out"]
            out0 = fleet.counters()["datagrams_out"]
            t_sim0 = fleet.now
            start = time.perf_counter()
            while time.perf_counter() - start < wall_seconds:
                for _ in range(10):
                    fleet.step()
            wall = time.perf_counter() - start
            sim = fleet.now - t_sim0
            sent = fleet.counters()["messages_out"] - sent0
            datagrams = fleet.counters()["datagrams_out"] - out0
            if flying < n:
                print(f"  note: only {flying}/{n} aircraft airborne", file=sys.stderr)
            steps = sim / fleet.dt
            return Result(n, sim / wall, sent / sim, datagrams / wall, wall / (steps * n) * 1e6)
    finally:
        sink.close()


def main(argv: list[str] | None = None) -> int:
    """Print a table of real-time factors."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    p.add_argument("aircraft", nargs="*", type=int, default=[10, 50, 200])
    p.add_argument("--seconds", type=float, default=3.0, help="wall seconds per measurement")
    args = p.parse_args(argv)
    print(
        f"{'aircraft':>8} {'real-time factor':>17} {'msgs/sim-s':>11} "
        f"{'sendto/wall-s':>14} {'us/vehicle-step':>16}"
    )
    for n in args.aircraft:
        r = asyncio.run(_measure(n, args.seconds))
        print(
            f"{r.aircraft:>8} {r.rtf:>17.2f} {r.messages_per_sim_s:>11.0f} "
            f"{r.datagrams_per_wall_s:>14.0f} {r.us_per_vehicle_step:>16.1f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
