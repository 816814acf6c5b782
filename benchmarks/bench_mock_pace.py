"""What the mock costs paced at a speedup, as `demo`, `replay` and `sitl-mock` run it.

``bench_mock_realtime.py`` steps the physics flat out; this one runs the mock's own
paced loop (:meth:`MockFleet._physics`: a step whenever the sim clock has reached it,
a wait for the next one otherwise) on uvloop, each aircraft streaming its default
telemetry to a local sink, and reports the CPU it takes per sim second and how
often the loop woke.

Side by side, the wait the loop used until 2026-12-02 (``asyncio.sleep`` of the
time to the next step: on uvloop, a wait under half a millisecond is a zero-delay
timer, so at 25x and above the loop spun between steps) and the one it uses now
(``eventloop.sleep``: one timer tick at least, then every step that is due).

Run: ``python benchmarks/bench_mock_pace.py [--aircraft N] [--seconds WALL] [SPEEDUP ...]``.
"""

from __future__ import annotations

import argparse
import asyncio
import socket
import sys
import time
from unittest import mock

from convoy_mav import eventloop
from sitl_mock.config import MockConfig
from sitl_mock.server import MockFleet

WAITS = {"tick (now)": eventloop.sleep, "asyncio.sleep (before)": asyncio.sleep}


async def _measure(
    aircraft: int, speedup: float, wall_seconds: float
) -> tuple[float, float, float]:
    """(share of a core, achieved speedup, loop wake-ups per wall second) of one run."""
    sink = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sink.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    sink.bind(("127.0.0.1", 0))
    host, port = sink.getsockname()
    config = MockConfig.simple(aircraft, base_port=0, speedup=speedup, gcs=f"udp:{host}:{port}")
    try:
        async with MockFleet(config) as fleet:
            await asyncio.sleep(0.5)  # settle: boot, first streams
            sim0, cpu0, wakes = fleet.now, time.process_time(), fleet.wakes
            start = time.monotonic()
            await asyncio.sleep(wall_seconds)
            wall = time.monotonic() - start
            cpu = time.process_time() - cpu0
            return cpu / wall, (fleet.now - sim0) / wall, (fleet.wakes - wakes) / wall
    finally:
        sink.close()


def main(argv: list[str] | None = None) -> int:
    """Print the table: one row per speedup, both waits side by side."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    p.add_argument("speedups", nargs="*", type=float, default=[10.0, 25.0, 40.0, 100.0])
    p.add_argument("--aircraft", type=int, default=6)
    p.add_argument("--seconds", type=float, default=3.0, help="wall seconds per measurement")
    args = p.parse_args(argv)
    names = list(WAITS)
    print(f"{args.aircraft} aircraft on uvloop, {args.seconds:g} wall s each; share of a core:")
    print("| speedup | " + " | ".join(names) + " | ratio |")
    print("|---:|" + "---:|" * (len(names) + 1))
    for speedup in args.speedups:
        cells, shares = [], []
        for name in names:
            with mock.patch.object(eventloop, "sleep", WAITS[name]):  # (the mock's wait)
                share, achieved, wakes = eventloop.run(
                    _measure(args.aircraft, speedup, args.seconds), choice="uvloop"
                )
            shares.append(share)
            cells.append(f"{100 * share:.0f} % at {achieved:.0f}x ({wakes:,.0f} wakes/s)")
        print(f"| {speedup:g} | " + " | ".join(cells) + f" | {shares[1] / shares[0]:.1f}× |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
