"""Cleaning recorded tracks: repeats merged, backward stamps and single-fix spikes dropped."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.tracks.cleaning import MAX_CONVOY_SPEED_MPS, TrackCleaning, clean_fixes

FRAME = LocalFrame(GeoPoint(41.0, 29.0))


def _road(n: int, speed: float = 12.0) -> tuple[list[float], list[float], list[float]]:
    """A convoy driving north-east at ``speed``, one fix a second."""
    ts, la, lo = [], [], []
    for i in range(n):
        g = FRAME.to_geo(0.7 * speed * i, 0.7 * speed * i)
        ts.append(float(i))
        la.append(g.lat)
        lo.append(g.lon)
    return ts, la, lo


def test_a_clean_track_is_untouched() -> None:
    ts, la, lo = _road(30)
    (t2, la2, lo2), cleaning = clean_fixes(ts, la, lo)
    assert (list(t2), list(la2), list(lo2)) == (ts, la, lo)
    assert cleaning == TrackCleaning() and cleaning.changed == 0


def test_a_single_fix_spike_is_dropped_but_a_real_jump_is_kept() -> None:
    ts, la, lo = _road(30)
    g = FRAME.to_geo(5000.0, -3000.0)  # one fix 5 km off: multipath
    la[10], lo[10] = g.lat, g.lon
    (t2, _, _), cleaning = clean_fixes(ts, la, lo)
    assert cleaning.spikes == 1 and 10.0 not in t2 and len(t2) == 29
    # a log gap with a real move (a tunnel): fast, but the next fixes agree: kept
    ts, la, lo = _road(30)
    for i in range(15, 30):
        ts[i] += 100.0  # 100 s without fixes, then the road goes on from further up
        g = FRAME.to_geo(8.4 * i + 1200.0, 8.4 * i + 1200.0)
        la[i], lo[i] = g.lat, g.lon
    (_, _, _), cleaning = clean_fixes(ts, la, lo)
    assert cleaning.spikes == 0


@given(
    repeats=st.lists(st.integers(1, 38), max_size=8, unique=True),
    spikes=st.lists(st.integers(2, 37), max_size=3, unique=True),
    backwards=st.lists(st.integers(2, 37), max_size=3, unique=True),
)
def test_any_mix_of_quirks_gives_increasing_plausible_fixes(
    repeats: list[int], spikes: list[int], backwards: list[int]
) -> None:
    ts, la, lo = _road(40)
    rows = list(zip(ts, la, lo, strict=True))
    for i in spikes:
        if all(abs(i - j) > 2 for j in spikes if j != i):  # single spikes only
            g = FRAME.to_geo(4000.0 + 10 * i, -4000.0)
            rows[i] = (rows[i][0], g.lat, g.lon)
    out: list[tuple[float, float, float]] = []
    for i, row in enumerate(rows):
        out.append(row)
        if i in repeats:
            out.append(row)  # a repeated stamp
        if i in backwards:
            out.append((row[0] - 0.5, row[1], row[2]))  # an earlier stamp after it
    (t2, la2, lo2), cleaning = clean_fixes(*map(list, zip(*out, strict=True)))
    assert all(b > a for a, b in itertools.pairwise(t2))
    assert cleaning.merged == len(repeats)
    assert cleaning.out_of_order == len(backwards)
    ne = [FRAME.to_ned(GeoPoint(a, b)) for a, b in zip(la2, lo2, strict=True)]
    for k in range(1, len(t2)):  # what is left drives like a convoy
        dist = math.dist(ne[k][:2], ne[k - 1][:2])
        assert dist <= MAX_CONVOY_SPEED_MPS * (t2[k] - t2[k - 1]) + 1e-6


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="max_speed"):
        clean_fixes([0.0], [41.0], [29.0], max_speed=0.0)
    with pytest.raises(ValueError, match="same length"):
        clean_fixes([0.0, 1.0], [41.0], [29.0])
