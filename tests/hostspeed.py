"""How fast this host runs the service's code: the end-to-end tests' speedups follow it.

A speedup sets the wall time a mission second gets. The mock flown in the test's own
process shares the interpreter with the service, so at 25x a mission second is 40 ms
of one interpreter for six aircraft, two ground vehicles, the flight loop and the
planner. The suite's speedups were chosen on a host where a convoy fix
(``ConvoyTracker.update``, the README's road benchmark) takes 9.4 us; on one where it
took 23 us the same flights missed setpoints by over a mission second, PX4's
offboard-loss failsafe fired, and stationary and signed fleets fell to 12-95 %: a
host too slow for the speedup, not a fault of the service (the same missions flown by
the CLI, the mock in a process of its own, covered 100 %). So the in-process
end-to-end tests divide their speedups by how much slower than that host this one is
(never raise them): unchanged on a host as fast, and at least 20x there.

The session measures the host once, before any test starts, and hands the figure down
(``SLOWDOWN_ENV``, ``tests/conftest.py``; the header prints it): under pytest-xdist the
controller, before its workers start. Measured in each worker, it was read while the
workers collected the suite beside one another: in one run every flight then took 1.7
times as long as in a serial run, and the two workers finished in 11:40 against the
serial 12:18.
"""

from __future__ import annotations

import functools
import math
import os
import statistics
import time

from convoy_mav.convoy import ConvoyTracker

__all__ = ["SLOWDOWN_ENV", "host_speedup", "measure_slowdown", "slowdown"]

SLOWDOWN_ENV = "CONVOY_MAV_TEST_SLOWDOWN"  # set by ``pytest_configure`` (or by hand)

REFERENCE_FIX_S = 9.4e-6  # a convoy fix on the host the suite's speedups were chosen on
_FIXES = 200
_ROUNDS = 41


@functools.cache
def slowdown() -> float:
    """How many times slower than the reference host this one is (>= 1): the figure the
    session measured at its start, else measured here."""
    handed = os.environ.get(SLOWDOWN_ENV)
    if not handed:
        return measure_slowdown()
    try:
        value = float(handed)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise ValueError(f"{SLOWDOWN_ENV}={handed!r}: not a finite number (try 1.5)")
    return max(1.0, value)


def measure_slowdown() -> float:
    """How many times slower than the reference host this one folds a convoy fix (>= 1).

    The slowest tenth of short rounds, against the benchmark's median: a host whose
    speed comes and goes (one took 11 us at best and 26 us in the median) is as slow as
    its slow spells, and a flight needs its time every mission second, late in a long
    test session too (with the median, 1.6-2.9 there, the muted convoy still flew 42 %
    in the suite and 100 % alone).
    """
    rounds = []
    tracker = ConvoyTracker(window=4.0)
    t = 0.0
    for _ in range(_ROUNDS):
        start = time.perf_counter()
        for _ in range(_FIXES):
            t += 0.1
            tracker.update(t, 8.0 * t, 0.0, 5)
        rounds.append((time.perf_counter() - start) / _FIXES)
    return max(1.0, statistics.quantiles(rounds, n=10)[-1] / REFERENCE_FIX_S)


def host_speedup(speedup: float) -> float:
    """``speedup`` for an in-process end-to-end flight on this host."""
    return speedup / slowdown()
