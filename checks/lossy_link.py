"""A lossy, laggy radio between real autopilots and the service: UDP relays on 127.0.0.1.

    python checks/lossy_link.py --speedup 5 [--loss 0.3] [--latency 0.2] [--jitter 0.1]
        [--duplicate 0.05] [--seed 3] AUTOPILOT_PORT:SERVICE_PORT ...

For each pair, the autopilot (ArduPilot SITL's ``--serial0 udpclient:127.0.0.1:
AUTOPILOT_PORT``) sends to this relay, which sends on to the service's
``udpin:127.0.0.1:SERVICE_PORT`` from a socket of its own and carries the service's
answers back to wherever the autopilot last sent from. Every datagram, either way, may
be lost, is held back by the latency plus up to the jitter (so datagrams overtake each
other) and may arrive twice: the faults ``sitl_mock`` puts on its own links
(``sitl_mock.faults.FaultInjector``, one seeded draw per decision), here put between
real firmware and the service, so what the mock's links taught can be checked against
it (``LINK=... checks/ardupilot_sitl.sh``).

Latency and jitter are simulated seconds, as the mock's: held back ``1 / speedup`` of
that in wall time, for a simulator run at ``--speedup``. Prints each link's counts when
stopped (SIGINT or SIGTERM).
"""

from __future__ import annotations

import argparse
import asyncio
import random
import signal
from collections import Counter
from typing import cast

from sitl_mock.faults import FaultInjector, FaultSpec

Address = tuple[str, int]


class _Side(asyncio.DatagramProtocol):
    """One socket of a relay: what comes in goes out through the other side."""

    def __init__(self, relay: Relay, from_vehicle: bool) -> None:
        self.relay = relay
        self.from_vehicle = from_vehicle
        self.transport: asyncio.DatagramTransport | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        # (3.11's selector transport does not derive from DatagramTransport)
        self.transport = cast(asyncio.DatagramTransport, transport)

    def datagram_received(self, data: bytes, addr: Address) -> None:
        self.relay.carry(data, addr, self.from_vehicle)


class Relay:
    """One autopilot's link: its side listens on ``vehicle_port``, the service's side
    sends to ``service_port`` (and hears the answers) from a port of its own."""

    def __init__(
        self, vehicle_port: int, service_port: int, faults: FaultInjector, speedup: float
    ) -> None:
        self.vehicle_port = vehicle_port
        self.service = ("127.0.0.1", service_port)
        self.faults = faults
        self.speedup = speedup
        self.vehicle: Address | None = None  # where the autopilot last sent from
        self.counts: Counter[str] = Counter()
        self._vehicle_side = _Side(self, from_vehicle=True)
        self._service_side = _Side(self, from_vehicle=False)

    async def open(self) -> None:
        loop = asyncio.get_running_loop()
        await loop.create_datagram_endpoint(
            lambda: self._vehicle_side, local_addr=("127.0.0.1", self.vehicle_port)
        )
        await loop.create_datagram_endpoint(lambda: self._service_side, local_addr=("127.0.0.1", 0))

    def carry(self, data: bytes, addr: Address, from_vehicle: bool) -> None:
        """Pass a datagram on, or lose it; each copy held back by its own draw."""
        way = "up" if from_vehicle else "down"
        self.counts[f"{way}_in"] += 1
        if from_vehicle:
            self.vehicle = addr
            lost = self.faults.drop_from_vehicle(0)
            side, to = self._service_side, self.service
        else:
            lost = self.faults.drop_to_vehicle(0)
            side, to = self._vehicle_side, self.vehicle  # type: ignore[assignment]
        if lost or to is None:
            self.counts[f"{way}_lost"] += 1
            return
        loop = asyncio.get_running_loop()
        held = self.faults.delay_from_vehicle if from_vehicle else self.faults.delay_to_vehicle
        for _ in range(self.faults.copies(0)):
            loop.call_later(held(0) / self.speedup, self._send, side, data, to, way)

    def _send(self, side: _Side, data: bytes, to: Address, way: str) -> None:
        if side.transport is not None and not side.transport.is_closing():
            side.transport.sendto(data, to)
            self.counts[f"{way}_out"] += 1


def _pair(text: str) -> tuple[int, int]:
    vehicle, _, service = text.partition(":")
    try:
        return int(vehicle), int(service)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected AUTOPILOT_PORT:SERVICE_PORT, got {text!r}"
        ) from None


async def _main(args: argparse.Namespace) -> None:
    spec = FaultSpec(
        loss_to_vehicle=args.loss,
        loss_from_vehicle=args.loss,
        latency_to_vehicle=args.latency,
        latency_from_vehicle=args.latency,
        duplicate=args.duplicate,
        jitter=args.jitter,
        seed=args.seed,
    )
    relays = [
        Relay(v, s, FaultInjector(spec, random.Random(args.seed * 1000 + k)), args.speedup)
        for k, (v, s) in enumerate(args.pairs)
    ]
    for relay in relays:
        await relay.open()
    print(f"relaying {len(relays)} links: {spec}", flush=True)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await stop.wait()
    for relay in relays:
        print(f"{relay.vehicle_port} -> {relay.service[1]}: {dict(relay.counts)}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", type=_pair, nargs="+", metavar="AUTOPILOT_PORT:SERVICE_PORT")
    parser.add_argument("--speedup", type=float, default=1.0, help="the simulators' speedup")
    parser.add_argument("--loss", type=float, default=0.3, help="each way")
    parser.add_argument("--latency", type=float, default=0.2, help="sim s, each way")
    parser.add_argument("--jitter", type=float, default=0.1, help="sim s, at most")
    parser.add_argument("--duplicate", type=float, default=0.05)
    parser.add_argument("--seed", type=int, default=3)
    asyncio.run(_main(parser.parse_args()))


if __name__ == "__main__":
    main()
