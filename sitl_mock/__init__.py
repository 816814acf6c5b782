"""sitl_mock: a multi-vehicle mock autopilot speaking real MAVLink over UDP.

Layers, following the data flow (pure at the bottom, I/O on top):

- ``airframe`` / ``kinematics`` / ``ground``: Dubins physics and convoy routes (pure);
- ``autopilot`` / ``flight`` / ``personality`` / ``streams`` / ``params`` / ``messages``:
  one sans-I/O MAVLink autopilot per vehicle, PX4 or ArduPilot flavoured;
- ``server`` / ``clock`` / ``faults`` / ``truth`` / ``config`` / ``__main__``: the asyncio
  UDP edge, the shared sim clock with its speedup, fault injection, ground truth, CLI.

In-process use (tests, the demo)::

    async with MockFleet(MockConfig.simple(3, ground=1, speedup=40, base_port=0)) as fleet:
        fleet.endpoint(1).connect   # "udpout:127.0.0.1:PORT"
"""

from __future__ import annotations

from sitl_mock.config import MockConfig
from sitl_mock.server import Endpoint, MockFleet

__all__ = ["Endpoint", "MockConfig", "MockFleet"]
