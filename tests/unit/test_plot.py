"""The mission plot is written and is a real PNG."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from convoy_mav.history import History
from convoy_mav.plot import convoy_speeds, plot_mission


def test_history_decimates() -> None:
    h = History(interval=1.0)
    for k in range(50):
        h.record(k * 0.1, (0.0, 0.0), {1: (0.0, 0.0)}, True, True)
    assert [s.t for s in h.samples] == pytest.approx([0.0, 1.0, 2.0, 3.0, 4.0])


def test_plot_writes_png(tmp_path: Path) -> None:
    h = History(interval=0.5)
    for k in range(200):
        t = k * 0.5
        uav = (150 * math.cos(t / 8), 150 * math.sin(t / 8))
        covered = math.hypot(*uav) < 160
        h.record(t, (t, 0.0), {1: uav, 2: (-uav[0], uav[1])}, covered, t > 10)
    out = tmp_path / "mission.png"
    plot_mission(h, out, sensor_radius=100.0, title="test")
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(data) > 10_000


def test_the_convoy_speed_drawn_is_its_chord_over_five_seconds(tmp_path: Path) -> None:
    """12 m/s north with 3 m of jitter between samples, then parked: drawn as 12 m/s
    within the jitter's share of the chord (a sample-to-sample difference would draw
    up to 24 m/s), then 0 once the chord is all parked; and with the mark, a PNG."""
    h = History(interval=0.5)
    rng = np.random.default_rng(1)
    for k in range(400):
        t = 0.5 * k
        north = 12.0 * min(t, 100.0) + rng.uniform(-1.5, 1.5)
        h.record(t, (north, 0.0), {1: (north, 0.0)}, True, t > 10)
    times, speeds = convoy_speeds(h)
    assert len(times) == len(speeds) == 399
    ts, v = np.array(times), np.array(speeds)
    assert np.all(np.abs(v[(ts >= 5.0) & (ts <= 100.0)] - 12.0) <= 0.61)  # (3 m over 5 s)
    assert np.all(v[ts >= 105.0] <= 0.61)
    out = tmp_path / "fast.png"
    plot_mission(h, out, sensor_radius=100.0, fast_mps=9.0)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_refuses_empty_history(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="nothing to plot"):
        plot_mission(History(), tmp_path / "x.png", sensor_radius=1.0)


def test_history_stays_bounded_however_long_the_run() -> None:
    h = History(interval=0.5, max_samples=1000)
    for k in range(200_000):  # a day of mission at 2 Hz, and more
        h.record(0.5 * k, (0.0, 0.0), {1: (1.0, 2.0)}, True, True)
    assert len(h.samples) <= 1000
    assert h.samples[0].t == 0.0 and h.samples[-1].t > 0.5 * 200_000 - 2 * h.interval
    gaps = {round(b.t - a.t, 6) for a, b in zip(h.samples, h.samples[1:], strict=False)}
    assert len(gaps) <= 2  # (evenly spaced: one step, the newest ones at the next finer)
