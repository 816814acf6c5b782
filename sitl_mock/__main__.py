"""``sitl-mock``: run K mock aircraft and G ground vehicles on UDP until a signal.

Prints one line per vehicle (sysid, kind, personality, connection strings),
then ``sitl-mock: ready``; on SIGINT/SIGTERM stops cleanly, prints a status
line with traffic and drop counters, and exits 0. Configuration errors print
one line naming the key and value and exit 2.
"""

from __future__ import annotations

import argparse
import asyncio
import logging
import os
import signal
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from convoy_mav.errors import ConfigError
from sitl_mock.config import MockConfig, config_from_mapping, load_toml, merge_overrides
from sitl_mock.server import MockFleet

__all__ = ["build_config", "main"]

_PROG = "sitl-mock"


class _Parser(argparse.ArgumentParser):
    """argparse whose errors are one line and exit status 2 (no usage dump)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{_PROG}: error: {message}\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog=_PROG, description=__doc__.splitlines()[0] if __doc__ else None)
    p.add_argument("--config", metavar="FILE", help="TOML config; flags override it")
    p.add_argument("--aircraft", type=int, metavar="K", help="number of aircraft (sysids 1..K)")
    p.add_argument("--ground", type=int, metavar="G", help="number of ground vehicles")
    p.add_argument("--personality", choices=["px4", "ardupilot"])
    p.add_argument("--frame", choices=["plane", "copter"])
    p.add_argument("--airspeed", type=float, metavar="V", help="m/s")
    p.add_argument("--turn-radius", type=float, metavar="RMIN", help="minimum turn radius, m")
    p.add_argument("--speedup", type=float, metavar="S", help="sim seconds per wall second")
    p.add_argument("--base-port", type=int, metavar="P", help="sysid i listens on P+i-1")
    p.add_argument("--host", help="address to bind (default 127.0.0.1)")
    p.add_argument("--gcs", metavar="udp:HOST:PORT", help="also push all traffic here")
    p.add_argument("--truth", metavar="FILE.csv", help="write the true states here")
    p.add_argument("--truth-rate", type=float, metavar="HZ", help="truth samples per sim second")
    p.add_argument("--origin", metavar="LAT,LON,ALT", help="world origin")
    g = p.add_argument_group("convoy route")
    g.add_argument("--ground-route", choices=["stationary", "line", "polyline", "csv"])
    g.add_argument("--ground-speed", type=float, metavar="VG", help="m/s")
    g.add_argument("--ground-heading", type=float, metavar="DEG", help="cw from north")
    g.add_argument("--ground-start", metavar="N,E", help="world north,east metres")
    g.add_argument("--ground-points", metavar="N,E;N,E;...", help="polyline vertices")
    g.add_argument("--ground-csv", metavar="FILE", help="track with columns time,lat,lon")
    g.add_argument("--ground-spacing", type=float, metavar="M", help="metres between vehicles")
    g.add_argument(
        "--ground-accel",
        type=float,
        metavar="A",
        help="m/s²: a polyline's rover brakes for its corners and speeds up after, as "
        "ArduRover's ATC_ACCEL_MAX (1.0) in AUTO (default 0: at once)",
    )
    g.add_argument(
        "--ground-mission",
        action="store_true",
        default=None,
        help="the lead serves its road as its mission (a rover in AUTO)",
    )
    f = p.add_argument_group("faults")
    f.add_argument("--loss-to-vehicle", type=float, metavar="P", help="datagram loss probability")
    f.add_argument("--loss-from-vehicle", type=float, metavar="P", help="datagram loss probability")
    f.add_argument("--latency", type=float, metavar="S", help="added sim seconds, both ways")
    f.add_argument("--kill", action="append", metavar="SYSID@T", help="kill at sim time T")
    f.add_argument("--reboot", action="append", metavar="SYSID@T", help="reboot at sim time T")
    f.add_argument(
        "--mode",
        action="append",
        metavar="SYSID:MODE@T",
        help="its operator switches it to MODE (its firmware's name) at sim time T, e.g. a "
        "convoy's truck held, 3:HOLD@300, or sent home, 3:RTL@300",
    )
    f.add_argument(
        "--stall",
        action="append",
        metavar="SYSID@T",
        help="a ground vehicle stops at sim time T and moves no more, its autopilot driving "
        "on (a breakdown; ArduRover's FS_CRASH_CHECK then sends it to HOLD)",
    )
    f.add_argument("--seed", type=int, help="seed of the loss decisions")
    p.add_argument(
        "--log-level",
        type=str.upper,
        default="WARNING",
        choices=["DEBUG", "INFO", "WARNING", "ERROR"],
        help="log verbosity on stderr (default WARNING)",
    )
    return p


def _pairs(key: str, text: str) -> list[list[float]]:
    try:
        pts = [[float(x) for x in item.split(",")] for item in text.split(";") if item.strip()]
    except ValueError:
        raise ConfigError(key, text, "expected N,E;N,E;... numbers") from None
    if any(len(pt) != 2 for pt in pts):
        raise ConfigError(key, text, "expected N,E;N,E;... pairs")
    return pts


def _overrides(ns: argparse.Namespace) -> dict[str, Any]:
    """The flags that were given, in the config file's schema."""
    top = {
        "speedup": ns.speedup,
        "base_port": ns.base_port,
        "host": ns.host,
        "gcs": ns.gcs,
        "truth": os.path.abspath(ns.truth) if ns.truth else None,
        "truth_rate": ns.truth_rate,
        "origin": ns.origin,
    }
    aircraft = {
        "count": ns.aircraft,
        "personality": ns.personality,
        "frame": ns.frame,
        "airspeed": ns.airspeed,
        "turn_radius": ns.turn_radius,
    }
    ground: dict[str, Any] = {
        "count": ns.ground,
        "route": ns.ground_route,
        "speed": ns.ground_speed,
        "heading": ns.ground_heading,
        "spacing": ns.ground_spacing,
        "accel": ns.ground_accel,
        "csv": os.path.abspath(ns.ground_csv) if ns.ground_csv else None,
        "mission": ns.ground_mission,
    }
    if ns.ground_start:
        ground["start"] = _pairs("--ground-start", ns.ground_start)[0]
    if ns.ground_points:
        ground["points"] = _pairs("--ground-points", ns.ground_points)
    faults = {
        "loss_to_vehicle": ns.loss_to_vehicle,
        "loss_from_vehicle": ns.loss_from_vehicle,
        "latency": ns.latency,
        "kill": ns.kill,
        "reboot": ns.reboot,
        "mode": ns.mode,
        "stall": ns.stall,
        "seed": ns.seed,
    }
    out: dict[str, Any] = {k: v for k, v in top.items() if v is not None}
    for name, table in (("aircraft", aircraft), ("ground", ground), ("faults", faults)):
        given = {k: v for k, v in table.items() if v is not None}
        if given:
            out[name] = given
    return out


def build_config(argv: Sequence[str] | None = None) -> MockConfig:
    """Parse the command line (and the ``--config`` file it names) into a config.

    Raises:
        ConfigError: A bad key or value, named.
        SystemExit: Unparseable flags (status 2, one line).
    """
    ns = _parser().parse_args(argv)
    data: dict[str, Any] = {}
    base_dir = "."
    if ns.config:
        data = load_toml(ns.config)
        base_dir = os.path.dirname(os.path.abspath(ns.config))
    config = config_from_mapping(merge_overrides(data, _overrides(ns)), base_dir=base_dir)
    logging.basicConfig(
        level=ns.log_level,
        format="%(asctime)s %(name)s %(levelname)s %(message)s",
        stream=sys.stderr,
    )
    return config


async def _serve(config: MockConfig) -> str:
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    async with MockFleet(config) as fleet:
        for ep in fleet.endpoints:
            print(ep.describe())
        gcs = f", gcs udp:{config.gcs[0]}:{config.gcs[1]}" if config.gcs else ""
        print(f"{_PROG}: ready: {len(fleet.endpoints)} vehicles, speedup {config.speedup:g}{gcs}")
        sys.stdout.flush()
        await stop.wait()
        status = fleet.status_line()
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sitl-mock`` and ``python -m sitl_mock``; returns the exit status."""
    try:
        config = build_config(argv)
        status = asyncio.run(_serve(config))
    except ConfigError as e:
        print(f"{_PROG}: error: {e}", file=sys.stderr)
        return 2
    print(status, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
