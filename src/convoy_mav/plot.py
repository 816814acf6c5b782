"""A picture of a mission: ground tracks, convoy path, sensor disks, coverage timeline.

Only the object API (``Figure``, no pyplot) is used, so no GUI backend is ever
selected and nothing needs a display; the CLI imports this module only when a
plot is asked for.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from convoy_mav.history import History

__all__ = ["convoy_speeds", "plot_mission"]

SPEED_SPAN_S = 5.0  # the convoy's speed is drawn as its chord over this long


def convoy_speeds(history: History, span: float = SPEED_SPAN_S) -> tuple[list[float], list[float]]:
    """The convoy's speed at each sample that has it, m/s: the chord from where it was
    ``span`` seconds before (at the start, since the first sample), so GPS jitter
    between samples is not drawn as speed."""
    pts = [(s.t, s.convoy) for s in history.samples if s.convoy is not None]
    if len(pts) < 2:
        return [], []
    t = np.array([p[0] for p in pts])
    north = np.array([p[1][0] for p in pts])
    east = np.array([p[1][1] for p in pts])
    before = np.maximum(t - span, t[0])
    dt = t - before
    moved = np.hypot(north - np.interp(before, t, north), east - np.interp(before, t, east))
    speed = np.divide(moved, dt, out=np.zeros_like(moved), where=dt > 0.0)
    return t[1:].tolist(), speed[1:].tolist()


def plot_mission(
    history: History,
    path: str | os.PathLike[str],
    *,
    sensor_radius: float,
    title: str = "",
    disk_instants: Sequence[float] | None = None,
    road: tuple[Sequence[float], Sequence[float]] | None = None,
    fast_mps: float | None = None,
) -> None:
    """Write a PNG: tracks and disks on the left, the coverage timeline below.

    Args:
        history: The recorded mission.
        path: Output file (PNG).
        sensor_radius: r, for the sensor disks drawn around each UAV.
        title: Figure title.
        disk_instants: Mission times at which to draw every UAV's sensor disk
            (default: three instants spread over the protect phase).
        road: The convoy's known route, (norths, easts), drawn under the tracks.
        fast_mps: A convoy speed to mark on the timeline, where the convoy's own is
            drawn: the road planner's ``FAST_CONVOY_RATIO`` of the airspeed, above which
            a stop can leave the convoy unseen (a gap after the speed crossed it).
    """
    samples = history.samples
    if not samples:
        raise ValueError("nothing to plot: the mission recorded no samples")
    fig = Figure(figsize=(10, 9), layout="constrained")
    grid = fig.add_gridspec(2, 1, height_ratios=[4, 1])
    ax = fig.add_subplot(grid[0])
    tl = fig.add_subplot(grid[1])
    if road is not None:
        ax.plot(road[1], road[0], color="0.6", lw=6, alpha=0.5, label="route", zorder=0)
    sysids = sorted({s for sample in samples for s in sample.uavs})
    cmap = colormaps["tab10"]
    for i, sysid in enumerate(sysids):
        pts = [sample.uavs[sysid] for sample in samples if sysid in sample.uavs]
        ax.plot([p[1] for p in pts], [p[0] for p in pts], lw=0.7, color=cmap(i % 10),
                label=f"UAV {sysid}")  # fmt: skip
    convoy = [s.convoy for s in samples if s.convoy is not None]
    if convoy:
        ax.plot([c[1] for c in convoy], [c[0] for c in convoy], "k-", lw=2.5, label="convoy")
    protect = [s.t for s in samples if s.protecting]
    if disk_instants is None and protect:
        t0, t1 = protect[0], protect[-1]
        disk_instants = [t0 + f * (t1 - t0) for f in (0.1, 0.5, 0.9)]
    for k, t_disk in enumerate(disk_instants or []):
        sample = min(samples, key=lambda s: abs(s.t - t_disk))
        for i, sysid in enumerate(sysids):
            if sysid in sample.uavs:
                north, east = sample.uavs[sysid]
                ax.add_patch(Circle((east, north), sensor_radius, fill=False, ls="--",
                                    color=cmap(i % 10), alpha=0.8))  # fmt: skip
        if sample.convoy is not None:
            ax.plot(sample.convoy[1], sample.convoy[0], "k*", ms=12,
                    label="convoy at disk instants" if k == 0 else None)  # fmt: skip
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="upper left", fontsize="small", ncol=2)
    ax.set_title(title or "convoy-mav mission")
    ts = [s.t for s in samples]
    tl.step(ts, [1 if s.covered else 0 for s in samples], where="post", color="tab:green")
    gaps = [0 if s.covered or not s.protecting else 1 for s in samples]
    tl.fill_between(
        ts, 0, gaps, step="post", color="tab:red", alpha=0.4, label="gap while protecting"
    )
    if protect:
        tl.axvline(protect[0], color="k", ls=":", label="protect starts")
    tl.set_yticks([0, 1], ["not seen", "seen"])
    tl.set_xlabel("mission time (s)")
    tl.legend(loc="lower right", fontsize="small")
    if fast_mps is not None and math.isfinite(fast_mps):
        st, speed = convoy_speeds(history)
        sp = tl.twinx()
        sp.plot(st, speed, color="0.35", lw=0.8, label="convoy speed")
        sp.axhline(fast_mps, color="tab:orange", ls="--", lw=1.0,
                   label=f"{fast_mps:.1f} m/s: a stop from faster can leave gaps")  # fmt: skip
        sp.set_ylabel("convoy speed (m/s)")
        sp.set_ylim(bottom=0.0, top=max([fast_mps, *speed]) * 1.15)
        sp.legend(loc="lower left", fontsize="small")
    fig.savefig(path, dpi=110)
