"""Shared fixtures: free UDP ports and an in-process mock fleet.

``start_mock`` is how service tests get autopilots to talk to::

    async def test_x(start_mock):
        fleet = await start_mock(MockConfig.simple(2, speedup=50, base_port=0))
        port = fleet.endpoint(1).port          # the vehicle listens here
        await fleet.wait_until(5.0)            # sim seconds
        row = fleet.truth(1)

The fleet is closed when the test ends (sockets released, truth flushed).

The host's speed is measured once, before any test (under pytest-xdist, which
``make test`` runs, by the controller before its workers start: they inherit it), and
printed in the header (``tests/hostspeed.py``).
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from typing import TYPE_CHECKING, Any

import pytest

from tests.mavclient import MavClient, free_udp_ports

pytest_plugins = ["tests.broker"]


def pytest_configure(config: pytest.Config) -> None:
    """Measure the host once, before any test (and any xdist worker) starts."""
    if hasattr(config, "workerinput"):
        return  # (an xdist worker: it inherited the controller's figure)
    from tests.hostspeed import SLOWDOWN_ENV, measure_slowdown, slowdown

    if not os.environ.get(SLOWDOWN_ENV):  # (a figure set by hand is not measured over)
        os.environ[SLOWDOWN_ENV] = f"{measure_slowdown():.3f}"
    try:
        slowdown()  # (a figure set by hand is checked here, before any test runs)
    except ValueError as exc:
        raise pytest.UsageError(str(exc)) from None


def pytest_report_header(config: pytest.Config) -> str:
    """The host's speed, which sets every in-process flight's speedup (and so its time)."""
    from tests.hostspeed import slowdown

    return f"host: {slowdown():.2f}x slower than the reference; flight speedups divided by it"


if TYPE_CHECKING:
    from sitl_mock.server import MockFleet

StartMock = Callable[..., Awaitable["MockFleet"]]


@pytest.fixture
def free_port() -> int:
    """One free UDP port on 127.0.0.1."""
    return free_udp_ports(1)


@pytest.fixture
async def start_mock() -> AsyncIterator[StartMock]:
    """Factory fixture: ``await start_mock(config, **MockFleet kwargs)`` -> a running fleet."""
    # Imported here so test modules that never start a mock don't load it.
    from sitl_mock.config import MockConfig
    from sitl_mock.server import MockFleet

    async with contextlib.AsyncExitStack() as stack:

        async def start(config: MockConfig | None = None, **kwargs: Any) -> MockFleet:
            cfg = config if config is not None else MockConfig.simple(1, base_port=0, speedup=20)
            return await stack.enter_async_context(MockFleet(cfg, **kwargs))

        yield start


@pytest.fixture
def mav_client() -> Iterator[Callable[..., MavClient]]:
    """Factory fixture: ``mav_client(port)`` -> a :class:`MavClient`, closed at teardown."""
    from pymavlink import mavutil  # noqa: F401 - slow first import, done before the mock runs

    clients: list[MavClient] = []

    def make(port: int, source_system: int = 255) -> MavClient:
        client = MavClient(port, source_system)
        clients.append(client)
        return client

    yield make
    for client in clients:
        client.close()
