"""``sitl_mock`` in a process of its own, for ``demo`` and ``replay``.

Why: in one process the mock's physics and telemetry and the service share one
interpreter lock. At 40x a road mission's six aircraft and the service's flight
loop and planner wanted more than one core, so the planner fell behind its
4-s re-plans and the aircraft flew off their paths: the rehearsal measured the
machine, not the mission (``README.md``, *Speed*). In a child process the mock
runs beside the service as a real autopilot does, over UDP only, and sends its
ground truth back when the flight ends.

The child ignores SIGINT (the terminal sends it to both): the aircraft fly on
until the service has told them to loiter, then the parent stops the child. A
child whose parent died sees the pipe close and exits.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import signal
import traceback
from collections.abc import Mapping
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from types import TracebackType
from typing import Any

from convoy_mav import eventloop
from sitl_mock import MockFleet
from sitl_mock.config import MockConfig, config_from_mapping
from sitl_mock.server import Endpoint
from sitl_mock.truth import TruthRecorder

__all__ = ["MockProcess"]

log = logging.getLogger(__name__)

_START_S = 60.0  # wall s the child may take to import, bind and report its endpoints
_STOP_S = 60.0  # wall s it may take to stop and send its truth back


class MockProcessError(RuntimeError):
    """The mock's process failed (its traceback is the message)."""


class MockProcess:
    """A ``MockFleet`` with ``record_truth`` in a child process.

    Use it like the fleet for what crosses a process boundary: ``config`` and
    ``endpoints`` once entered, ``history`` (the truth) once exited. Fault
    scripts that reach into the vehicles need the fleet in-process.

    Args:
        mapping: The mock's configuration, as ``sitl_mock.config.config_from_mapping`` takes.
    """

    def __init__(self, mapping: Mapping[str, Any]) -> None:
        self._mapping = dict(mapping)
        self.config: MockConfig = config_from_mapping(self._mapping)  # fail here, not in the child
        self.endpoints: tuple[Endpoint, ...] = ()
        self.history: TruthRecorder | None = None
        self._conn: Connection | None = None
        self._proc: BaseProcess | None = None

    async def __aenter__(self) -> MockProcess:
        ctx = multiprocessing.get_context("spawn")  # never fork a process with threads and a loop
        conn, child = ctx.Pipe()
        proc = ctx.Process(
            target=_serve, args=(self._mapping, child), name="sitl-mock", daemon=True
        )
        proc.start()
        child.close()
        self._conn, self._proc = conn, proc
        try:
            reply = await self._receive(_START_S)
            if reply[0] != "ready":
                raise MockProcessError(f"sitl_mock did not start: {reply}")
            _, self.config, self.endpoints = reply
        except BaseException:
            self._kill()
            raise
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        conn = self._conn
        try:
            if conn is None:
                return
            with contextlib.suppress(OSError):  # gone already: its last word, or EOF, says why
                conn.send("stop")
            try:
                _, self.history = await self._receive(_STOP_S)
            except MockProcessError:
                if exc is None:
                    raise
        finally:
            self._kill()

    async def _receive(self, timeout: float) -> tuple[Any, ...]:
        conn = self._conn
        assert conn is not None

        def wait() -> tuple[Any, ...]:
            if not conn.poll(timeout):
                raise MockProcessError(f"sitl_mock did not answer in {timeout:g} s")
            try:
                reply: tuple[Any, ...] = conn.recv()
            except EOFError:
                code = None if self._proc is None else self._proc.exitcode
                raise MockProcessError(f"sitl_mock exited (code {code})") from None
            if reply[0] == "error":
                raise MockProcessError(f"sitl_mock failed:\n{reply[1]}")
            return reply

        return await asyncio.to_thread(wait)

    def _kill(self) -> None:
        proc, conn = self._proc, self._conn
        if conn is not None:
            conn.close()
        if proc is not None:
            proc.join(5.0)
            if proc.is_alive():
                proc.kill()
                proc.join()
        self._proc = self._conn = None


def _serve(mapping: dict[str, Any], conn: Connection) -> None:
    """The child: run the fleet until told to stop (or the parent is gone)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    logging.basicConfig(level=logging.WARNING, format="sitl-mock: %(levelname)s %(message)s")
    try:
        eventloop.run(_fly(config_from_mapping(mapping), conn))
    except BaseException:
        with contextlib.suppress(OSError):
            conn.send(("error", traceback.format_exc()))
    finally:
        conn.close()


async def _fly(config: MockConfig, conn: Connection) -> None:
    async with MockFleet(config, record_truth=True) as fleet:
        conn.send(("ready", fleet.config, fleet.endpoints))

        def until_stopped() -> None:
            with contextlib.suppress(EOFError):  # EOF: the parent is gone
                conn.recv()

        await asyncio.to_thread(until_stopped)
    conn.send(("truth", fleet.history))
