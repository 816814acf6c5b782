"""Fleet scale: convoy-mav and MAVSDK-Python flying the same mock fleet, side by side.

For each fleet size N, a fresh ``sitl-mock`` process (N PX4 planes, real time,
physics at 20 Hz so the mock itself keeps up at N = 1000) is flown once by
convoy-mav's flight loop (``fleet_convoy.py``) and once by MAVSDK-Python 4.x
(``fleet_mavsdk.py``: one ``Mavsdk`` with a connection per vehicle,
``set_position_velocity_ned`` at 20 Hz), each in this process while the mock
runs in its own. Reported per client: CPU cores this process used, setpoint
rate and inter-send interval (p50, and p99 as the median and the worst over
vehicles), telemetry rate and telemetry-to-monitor latency.

Clients: ``convoy-mav`` flies on the loop the service picks (uvloop where
installed, see ``convoy_mav.eventloop``), ``convoy-mav-asyncio`` on asyncio's
own loop, ``mavsdk`` on asyncio's loop as its documentation does.

These machines are noisy: ``--repeat K`` flies each client K times, each
against a fresh fleet and interleaved with the other clients, prints every run,
and the final table holds the median of each column over the K runs.

Run: ``python benchmarks/bench_fleet.py [N ...] [--seconds S] [--clients ...]
[--repeat K] [--json FILE]`` (``make bench-fleet`` runs the README's figures).
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import dataclasses
import json
import logging
import math
import os
import statistics
import sys
from collections.abc import AsyncIterator, Awaitable, Callable, Sequence
from typing import Any

from fleet_convoy import run_convoy_mav
from fleet_light import start_light_fleet
from fleet_mavsdk import ClientResult, MockPorts, find_free_ports, run_mavsdk, start_mock_process

from convoy_mav import eventloop

Runner = Callable[..., Awaitable[ClientResult]]
CLIENTS: dict[str, Runner] = {
    "convoy-mav": run_convoy_mav,
    "convoy-mav-asyncio": run_convoy_mav,
    "mavsdk": run_mavsdk,
}
LOOPS = {"convoy-mav": None, "convoy-mav-asyncio": "asyncio"}  # None: the service's pick
_EXIT_GRACE_S = 30.0  # wall s a client process may take to exit once it printed its result


def _fmt(x: float | None, spec: str) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def table(results: Sequence[ClientResult]) -> str:
    """A Markdown table of the results (the README's format)."""
    head = (
        "| N | client | flying | set-up s | cores | cores/vehicle | rate Hz | "
        "interval p50 ms | p99 ms (median / worst) | telemetry Hz | "
        "telemetry→monitor p50 / p99 ms |"
    )
    rows = [head, "|" + "---|" * 11]
    for r in results:
        rows.append(
            f"| {r.vehicles} | {r.client} | {r.flying} | {r.setup_s:.1f} | {_fmt(r.cores, '.3f')} "
            f"| {_fmt(r.cores / r.vehicles, '.5f')} | {_fmt(r.rate_hz_median, '.2f')} "
            f"| {_fmt(r.interval_p50_ms, '.1f')} "
            f"| {_fmt(r.interval_p99_ms_median, '.1f')} / {_fmt(r.interval_p99_ms, '.1f')} "
            f"| {_fmt(r.telemetry_hz_median, '.1f')} "
            f"| {_fmt(r.telemetry_latency_p50_ms, '.1f')} / "
            f"{_fmt(r.telemetry_latency_p99_ms, '.1f')} |"
        )
    return "\n".join(rows)


@contextlib.asynccontextmanager
async def fleet(n: int, kind: str) -> AsyncIterator[MockPorts]:
    """A fresh fleet of ``n`` PX4 planes: the mock, or the light fake fleet."""
    if kind == "mock":
        async with start_mock_process(n) as ports:
            yield ports
        return
    base = find_free_ports(n)
    async with start_light_fleet(n, base):
        yield MockPorts(list(range(base, base + n)), 250)


async def run(
    sizes: Sequence[int],
    clients: Sequence[str],
    seconds: float,
    light_from: int,
    repeat: int = 1,
) -> list[ClientResult]:
    """Every client against a fresh fleet of every size, ``repeat`` times; medians."""
    results: list[ClientResult] = []
    for n in sizes:
        runs: dict[str, list[ClientResult]] = {name: [] for name in clients}
        for _ in range(repeat):
            for name in clients:  # interleaved: a noisy spell hits every client alike
                # MAVSDK waits for health the light fleet does not model (it never
                # arms there): it always flies the mock.
                kind = "light" if n >= light_from and name in LOOPS else "mock"
                async with fleet(n, kind) as ports:
                    result = await _isolated(name, ports, seconds)
                result = dataclasses.replace(result, notes=f"{kind} fleet; {result.notes}")
                runs[name].append(result)
                print(table([result]).splitlines()[-1], flush=True)
        results.extend(median_result(r) for r in runs.values())
    return results


def median_result(runs: Sequence[ClientResult]) -> ClientResult:
    """Each numeric column's median over ``runs`` (one run: itself)."""
    if len(runs) == 1:
        return runs[0]
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(ClientResult):
        values = [getattr(r, f.name) for r in runs]
        if isinstance(values[0], int | float) and not isinstance(values[0], bool):
            finite = [v for v in values if v is not None and not math.isnan(v)]
            fields[f.name] = statistics.median(finite) if finite else math.nan
        else:
            fields[f.name] = values[0]
    fields["client"] = f"{runs[0].client}, median of {len(runs)}"
    fields["notes"] = " | ".join(r.notes for r in runs)
    return ClientResult(**fields)


async def _isolated(name: str, ports: MockPorts, seconds: float) -> ClientResult:
    """Run one client in a process of its own: its CPU time is its alone, and no
    thread of an earlier client (MAVSDK's are native) lingers into the next.

    The client prints its result as soon as it has one; a process still busy
    ``_EXIT_GRACE_S`` after that (MAVSDK-Python's blocking calls queued in the
    loop's executor can take many minutes to drain at 1000 vehicles) is killed,
    and the row says so.
    """
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        __file__,
        "_one",
        name,
        str(ports[0]),
        str(len(ports)),
        str(ports.per_process),
        str(seconds),
        stdout=asyncio.subprocess.PIPE,
    )
    assert proc.stdout is not None
    result: ClientResult | None = None
    while result is None and (line := await proc.stdout.readline()):
        if line.startswith(b"{"):
            result = ClientResult(**json.loads(line))
    try:
        async with asyncio.timeout(_EXIT_GRACE_S):
            await proc.communicate()
    except TimeoutError:
        proc.kill()
        await proc.wait()
        if result is not None:
            note = f"process killed {_EXIT_GRACE_S:g} s after its result (teardown hung)"
            return dataclasses.replace(result, notes=f"{result.notes}; {note}")
    if result is None or proc.returncode != 0:
        raise RuntimeError(f"{name} client exited with {proc.returncode}")
    return result


async def _fly(client: Runner, ports: MockPorts, seconds: float) -> None:
    result = await client(ports, seconds=seconds)
    # Printed from inside the loop: the parent has its row before the loop's teardown.
    print(json.dumps(dataclasses.asdict(result)), flush=True)


def _one(argv: Sequence[str]) -> int:
    """``_one CLIENT BASE_PORT N PER_PROCESS SECONDS``: fly an existing fleet, print JSON."""
    name, base, n, per_process, seconds = argv
    ports = MockPorts(list(range(int(base), int(base) + int(n))), int(per_process))
    logging.basicConfig(level=logging.ERROR)
    fly = _fly(CLIENTS[name], ports, float(seconds))
    if name in LOOPS:
        eventloop.run(fly, choice=LOOPS[name])
    else:
        asyncio.run(fly)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv[:1] == ["_one"]:
        return _one(argv[1:])
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=[10, 100, 500, 1000])
    parser.add_argument("--seconds", type=float, default=20.0, help="measured window, wall s")
    parser.add_argument("--clients", nargs="+", choices=sorted(CLIENTS), default=list(CLIENTS))
    parser.add_argument("--json", metavar="FILE", help="also write the results as JSON")
    parser.add_argument(
        "--repeat", type=int, default=1, metavar="K", help="runs per client and size (medians)"
    )
    parser.add_argument(
        "--light-from",
        type=int,
        default=500,
        metavar="N",
        help="fleets of N or more planes are the light fake fleet, not the mock",
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.ERROR)  # per-vehicle set-up chatter, N times over
    print(f"{os.cpu_count()} cores, Python {sys.version.split()[0]}", flush=True)
    if args.repeat < 1:
        parser.error("--repeat must be >= 1")
    results = asyncio.run(run(args.sizes, args.clients, args.seconds, args.light_from, args.repeat))
    print(table(results))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as fh:
            json.dump([dataclasses.asdict(r) for r in results], fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
