"""Section III of the paper: stationary convoy, fixed and free entry."""

from __future__ import annotations

import math

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from convoy_mav.errors import InfeasibleEntryError, PlanningError
from convoy_mav.planning import (
    Pose,
    Segment,
    Turn,
    coverage_per_uav,
    min_uavs,
    optimal_entry_states,
    optimal_path_from_entry,
    orbit_cycle,
    time_inside_optimal,
    wrap_angle,
)
from convoy_mav.planning.stationary import _first_exit_angle

R_FIG5, r_FIG5 = 1.5, 1.0  # Fig. 5: R = 1.5 r


def _fig5_entry(x0: float, r: float = r_FIG5) -> Pose:
    """Entry on the lower half of the circle, heading pi/2 (north), as in Fig. 5."""
    return Pose(x0, -math.sqrt(r * r - x0 * x0), math.pi / 2)


@pytest.mark.parametrize(
    ("x0", "expected"),
    [
        (-0.95, "R"),
        (-0.8, "R"),
        (-0.68, "R"),  # just left of -r^2/R = -0.667
        (-0.66, "LR"),
        (-0.4, "LR"),
        (-0.05, "LR"),
        (0.05, "RL"),
        (0.4, "RL"),
        (0.66, "RL"),
        (0.68, "L"),  # just right of r^2/R
        (0.8, "L"),
        (0.95, "L"),
    ],
)
def test_fig5_regions(x0: float, expected: str) -> None:
    """Fig. 5: LR on (-r²/R, 0], RL on [0, r²/R), L on [r²/R, r), R otherwise."""
    assert optimal_path_from_entry(_fig5_entry(x0), R_FIG5, r_FIG5).sequence == expected


def test_fig5_boundaries_tie() -> None:
    # At x0 = 0 the LR and RL paths are mirror images of equal length.
    sol = optimal_path_from_entry(_fig5_entry(0.0), R_FIG5, r_FIG5)
    assert sol.sequence in {"LR", "RL"}
    left = optimal_path_from_entry(_fig5_entry(-1e-9), R_FIG5, r_FIG5)
    right = optimal_path_from_entry(_fig5_entry(1e-9), R_FIG5, r_FIG5)
    assert left.time_inside == pytest.approx(right.time_inside, rel=1e-6)
    # At x0 = ±r²/R the switch happens at the entry and the path is globally optimal
    # ("the solid path" of Fig. 5): its length is 2 R asin(r/R).
    edge = optimal_path_from_entry(_fig5_entry(-(r_FIG5**2) / R_FIG5), R_FIG5, r_FIG5)
    assert edge.time_inside == pytest.approx(time_inside_optimal(R_FIG5, r_FIG5), rel=1e-9)


def test_switch_point_on_line_through_origin_and_exit() -> None:
    """Lemma 3.2 / eq. (27): origin, switch point and exit point are collinear."""
    for x0 in (-0.6, -0.3, 0.2, 0.5):
        sol = optimal_path_from_entry(_fig5_entry(x0), R_FIG5, r_FIG5)
        assert sol.switch is not None
        cross = sol.switch.x * sol.exit.y - sol.switch.y * sol.exit.x
        assert cross == pytest.approx(0.0, abs=1e-9)
        # eq. (24): heading at the switch mirrors the exit heading about the exit radial.
        psi = math.atan2(sol.exit.y, sol.exit.x)
        assert wrap_angle(sol.switch.heading - psi) == pytest.approx(
            -wrap_angle(sol.exit.heading - psi), abs=1e-9
        )


def test_theorem_3_5_optimum_and_entry_states() -> None:
    R, r = 150.0, 100.0
    best = 2 * R * math.asin(r / R)
    assert time_inside_optimal(R, r) == pytest.approx(best)
    assert time_inside_optimal(R, r, speed=18.0) == pytest.approx(best / 18.0)
    for rotation in (0.0, 1.0, -2.5):
        for entry in optimal_entry_states(R, r, rotation):
            sol = optimal_path_from_entry(entry, R, r)
            assert sol.time_inside == pytest.approx(best, rel=1e-9)
            assert sol.sequence in {"L", "R"}
            # eq. (36): entry, origin and exit on one line, headings mirrored.
            cross = entry.x * sol.exit.y - entry.y * sol.exit.x
            assert cross == pytest.approx(0.0, abs=1e-6)
            assert math.hypot(entry.x + sol.exit.x, entry.y + sol.exit.y) == pytest.approx(
                0, abs=1e-6
            )


def test_optimal_orbit_is_a_circle_through_a_diameter() -> None:
    """Definition 3.2: radius R, chord inside the convoy circle is a diameter."""
    R, r, V = 300.0, 100.0, 20.0
    inside, outside = orbit_cycle(R, r, V, 0.4, Turn.RIGHT)
    assert inside.duration == pytest.approx(2 * R * math.asin(r / R) / V)
    assert inside.duration + outside.duration == pytest.approx(2 * math.pi * R / V)
    # Entry and exit are antipodal on the convoy circle.
    assert math.hypot(inside.start.x, inside.start.y) == pytest.approx(r)
    assert (inside.end.x, inside.end.y) == pytest.approx((-inside.start.x, -inside.start.y))
    # The lap closes.
    end = outside.end
    assert (end.x, end.y) == pytest.approx((inside.start.x, inside.start.y), abs=1e-9)
    # The orbit centre is sqrt(R^2 - r^2) from the centroid.
    assert math.hypot(*inside.center) == pytest.approx(math.sqrt(R * R - r * r))


@pytest.mark.parametrize(
    ("R_over_r", "expected"),
    [(1.5, 5), (2.0, 6), (3.0, 10), (10.0, 32), (1.0001, 3), (1 / math.sin(math.pi / 4), 4)],
)
def test_corollary_3_7_counts(R_over_r: float, expected: int) -> None:
    assert min_uavs(R_over_r * 100.0, 100.0) == expected
    assert min_uavs(R_over_r * 100.0, 100.0) == math.ceil(math.pi / math.asin(1 / R_over_r) - 1e-9)


def test_trivial_case_counts() -> None:
    assert min_uavs(80.0, 100.0) == 1
    assert coverage_per_uav(80.0, 100.0) == 1.0
    assert coverage_per_uav(200.0, 100.0) == pytest.approx(math.asin(0.5) / math.pi)


@pytest.mark.parametrize(
    ("entry", "match"),
    [
        (Pose(-0.5, -0.8, 1.57), "not on the convoy circle"),
        (Pose(0.6, 0.8, 1.57), "does not point into"),
        (Pose(-1.0, 0.0, math.pi / 2), "does not point into"),  # tangent
        (Pose(math.nan, 0.0, 0.0), "finite"),
    ],
)
def test_infeasible_entries_rejected(entry: Pose, match: str) -> None:
    with pytest.raises(InfeasibleEntryError, match=match):
        optimal_path_from_entry(entry, 1.5, 1.0)


def test_fixed_entry_needs_R_above_r() -> None:
    with pytest.raises(PlanningError, match="indefinitely"):
        optimal_path_from_entry(Pose(-1, 0, 0), 0.5, 1.0)


def test_entry_slightly_off_circle_is_snapped() -> None:
    sol = optimal_path_from_entry(Pose(-0.6, -0.8005, 1.5), 1.5, 1.0)
    assert math.hypot(sol.entry.x, sol.entry.y) == pytest.approx(1.0, abs=1e-12)


def _best_one_switch(entry: Pose, R: float, r: float, steps: int) -> float:
    """Brute force: every one-switch bang-bang path on a grid of switch times."""
    best = 0.0
    for first in (Turn.LEFT, Turn.RIGHT):
        center = Segment(entry, first, R, 1.0, 0.0).center
        sweep = _first_exit_angle(center, R, first, (entry.x, entry.y), r, from_boundary=True)
        assert sweep is not None
        t_exit = sweep * R
        best = max(best, t_exit)  # no switch at all
        for k in range(1, steps):
            t = t_exit * k / steps
            p = Segment(entry, first, R, 1.0, t).end
            second = Turn(-first)
            c2 = Segment(p, second, R, 1.0, 0.0).center
            sweep2 = _first_exit_angle(c2, R, second, (p.x, p.y), r, from_boundary=False)
            assert sweep2 is not None
            if sweep2 > 2 * math.pi - 1e-6:  # numerically on the boundary heading out
                sweep2 = 0.0
            best = max(best, t + sweep2 * R)
    return best


@settings(max_examples=150, deadline=None)
@given(
    ratio=st.floats(1.01, 6.0),
    position=st.floats(-math.pi, math.pi),
    offset=st.floats(-1.55, 1.55),
)
def test_no_one_switch_path_beats_the_planner(ratio: float, position: float, offset: float) -> None:
    """Property: from random feasible entries, brute force never stays inside longer."""
    r = 1.0
    R = ratio * r
    entry = Pose(math.cos(position), math.sin(position), position + math.pi + offset)
    sol = optimal_path_from_entry(entry, R, r)
    brute = _best_one_switch(entry, R, r, steps=400)
    assert brute <= sol.time_inside * (1 + 1e-9) + 1e-9
    # ...and the grid gets close to it, so the planner's answer is achievable.
    assert brute >= sol.time_inside - 2 * (2 * math.pi * R) / 400
    # The returned path is continuous, stays inside, and ends on the circle.
    for seg in sol.segments:
        for k in range(21):
            p = seg.at(seg.duration * k / 20)
            assert math.hypot(p.x, p.y) <= r * (1 + 1e-9)
    assert math.hypot(sol.exit.x, sol.exit.y) == pytest.approx(r, abs=1e-9)
    assume(sol.switch is not None)
    assert sol.segments[0].end.x == pytest.approx(sol.segments[1].start.x)
