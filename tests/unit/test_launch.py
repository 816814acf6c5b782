"""The launch sequence: who may leave the ground, so that no two UAVs climb out abreast."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from convoy_mav.config import parse_config
from convoy_mav.errors import ConfigError
from convoy_mav.launch import CLEARED_S, YIELD_S, Craft, LaunchSequence, hold_reason
from convoy_mav.separation import conflicts

H, V = 45.0, 6.0  # the service's clearances for the default minima (30 m, 3 m)


def craft(
    sysid: int,
    east: float,
    layer: float,
    *,
    up: float = 0.0,
    north: float = 0.0,
    moving: bool = False,
    setting_up: bool = False,
) -> Craft:
    return Craft(sysid, north, east, -up, layer, moving, setting_up)


def test_a_lone_pad_is_clear() -> None:
    assert hold_reason(craft(1, 0.0, 100.0), [], [], H, V) is None


def test_a_neighbour_on_its_runway_holds_the_pad_until_clear_of_it() -> None:
    pad = craft(1, 0.0, 100.0)
    rolling = craft(2, 10.0, 105.0, moving=True)
    why = hold_reason(pad, [rolling], [], H, V)
    assert why is not None and "UAV 2" in why
    away = craft(2, 10.0, 105.0, north=H, moving=True)  # 46 m off: clear
    assert hold_reason(pad, [away], [], H, V) is None


def test_a_neighbour_above_frees_the_pad_only_if_it_is_bound_higher() -> None:
    pad = craft(1, 0.0, 100.0)
    higher = craft(2, 10.0, 105.0, up=V, moving=True)
    assert hold_reason(pad, [higher], [], H, V) is None
    lower = craft(2, 10.0, 95.0, up=50.0, moving=True)  # the pad's climb would cross it
    why = hold_reason(pad, [lower], [], H, V)
    assert why is not None and "bound no higher" in why
    not_yet = craft(2, 10.0, 105.0, up=V - 0.5, moving=True)
    assert hold_reason(pad, [not_yet], [], H, V) is not None


def test_among_waiting_neighbours_the_highest_layer_goes_first() -> None:
    pad = craft(1, 0.0, 100.0)
    higher = craft(2, 10.0, 105.0)
    why = hold_reason(pad, [], [higher], H, V)
    assert why is not None and "UAV 2 launches first" in why
    assert hold_reason(higher, [], [pad], H, V) is None
    far = craft(2, H + 1.0, 105.0)
    assert hold_reason(pad, [], [far], H, V) is None


def test_a_position_that_is_not_a_number_holds_nobody() -> None:
    pad = craft(1, 0.0, 100.0)
    assert hold_reason(pad, [craft(2, math.nan, 105.0, moving=True)], [], H, V) is None


class Fleet:
    """A fleet on a row of pads 10 m apart, moved by hand."""

    def __init__(self, n: int) -> None:
        self.crafts = {s: craft(s, 10.0 * (s - 1), 90.0 + 5.0 * s, setting_up=True) for s in
                       range(1, n + 1)}  # fmt: skip

    def __call__(self) -> dict[int, Craft]:
        return dict(self.crafts)

    def launch(self, sysid: int, up: float) -> None:
        c = self.crafts[sysid]
        self.crafts[sysid] = Craft(sysid, c.north, c.east, -up, c.layer_m, True, False)


def test_a_row_launches_from_the_top_layer_down_each_once_the_last_is_above() -> None:
    fleet = Fleet(4)
    seq = LaunchSequence(fleet, H, V)
    order: list[int] = []
    t = 0.0
    for _ in range(40):
        for s in (1, 2, 3, 4):  # (the lowest asks first: arrival order does not decide)
            if s not in order and seq.ask(s, t) is None:
                order.append(s)
        for s in order:  # every launched UAV climbs 4 m/s
            c = fleet.crafts[s]
            fleet.launch(s, min(-c.down + 2.0, c.layer_m))
        t += 0.5
    assert order == [4, 3, 2, 1]
    assert not seq.waiting


def test_a_cleared_uav_counts_as_moving_while_it_arms_and_until_its_autopilot_says_so() -> None:
    fleet = Fleet(2)
    seq = LaunchSequence(fleet, H, V)
    assert seq.ask(2, 0.0) is None  # cleared; its autopilot refuses ARM for 40 s
    for t in (0.1, CLEARED_S + 0.2, YIELD_S + 0.1, 39.9):
        why = seq.ask(1, t)
        assert why is not None and "UAV 2 arming 10 m from its pad" in why, t
    seq.armed(2, 40.0)  # armed: moving until its autopilot says so, or CLEARED_S
    assert seq.ask(1, 40.0 + CLEARED_S - 0.1) is not None
    fleet.launch(2, 1.0)  # its autopilot says armed, 1 m up
    why = seq.ask(1, 40.0 + CLEARED_S + 0.1)
    assert why is not None and "UAV 2 climbing out" in why
    fleet.launch(2, V)
    assert seq.ask(1, 40.0 + CLEARED_S + 0.2) is None


def test_a_uav_that_never_armed_holds_its_neighbours_cleared_s_more_then_a_while_only() -> None:
    fleet = Fleet(2)
    seq = LaunchSequence(fleet, H, V)
    assert seq.ask(2, 0.0) is None
    seq.armed(2, 1.0)  # its set-up gave up arming (refused to the end): not moving
    seq.armed(1, 1.0)  # (a UAV never cleared: nothing to end)
    assert seq.ask(1, 1.0 + CLEARED_S - 0.1) is not None
    # No longer moving, it is a neighbour bound higher behind in its set-up, waited
    # for until YIELD_S from UAV 1's first ask.
    why = seq.ask(1, 1.0 + CLEARED_S + 0.1)
    assert why is not None and "UAV 2 launches first" in why
    assert seq.ask(1, 1.0 + CLEARED_S + YIELD_S) is None


def test_a_neighbour_behind_in_its_set_up_is_waited_for_a_while_only() -> None:
    fleet = Fleet(2)  # UAV 2, bound higher, never asks (stuck in its set-up)
    seq = LaunchSequence(fleet, H, V)
    why = seq.ask(1, 0.0)
    assert why is not None and "UAV 2" in why and seq.waiting == {1}
    assert seq.ask(1, YIELD_S - 0.1) is not None
    assert seq.ask(1, YIELD_S) is None
    seq.withdraw(1)
    assert not seq.waiting


def test_a_uav_with_no_position_waits_and_says_so() -> None:
    seq = LaunchSequence(dict, H, V)
    assert seq.ask(3, 0.0) == "no position yet"
    seq.withdraw(3)
    assert not seq.waiting


@pytest.mark.parametrize("h, v", [(0.0, 6.0), (45.0, -1.0), (math.inf, 6.0), (45.0, math.nan)])
def test_clearances_must_be_positive_and_finite(h: float, v: float) -> None:
    with pytest.raises(ValueError):
        LaunchSequence(dict, h, v)


@settings(max_examples=150, deadline=None)
@given(
    n=st.integers(2, 7),
    spacing=st.floats(0.0, 60.0),
    climb=st.floats(1.0, 6.0),
    speed=st.floats(0.0, 25.0),
    step=st.sampled_from([0.0, 5.0, 10.0]),
    asks=st.permutations(range(1, 8)),
    refusals=st.lists(st.sampled_from([0.0, 0.0, 3.0, 15.0, 40.0]), min_size=7, max_size=7),
)
def test_climb_outs_sequenced_so_never_lose_separation(
    n: int,
    spacing: float,
    climb: float,
    speed: float,
    step: float,
    asks: list[int],
    refusals: list[float],
) -> None:
    """A row of pads (any spacing), each UAV climbing out straight ahead (planes, at
    ``speed``) or straight up (copters, speed 0) at one rate to its layer, asking in
    any order, its autopilot refusing ARM for 0-40 s once cleared: no pair ever
    closer than the minima (30 m, 3 m) in both. With every layer the same
    (``altitude_step_m`` 0), a copter hovering over its pad holds its neighbours'
    pads (in flight it would fly off to its slot; here it stays)."""
    layers = {s: 90.0 + step * s for s in range(1, n + 1)}
    cleared: dict[int, float] = {}  # id -> mission time it was cleared
    launched: dict[int, float] = {}  # id -> mission time it armed
    t, dt = 0.0, 0.25

    def position(s: int, now: float) -> tuple[float, float, float]:
        since = now - launched[s] if s in launched else 0.0
        up = min(climb * since, layers[s])
        return speed * since, spacing * (s - 1), -up

    def fleet() -> dict[int, Craft]:
        out = {}
        for s, layer in layers.items():
            north, east, down = position(s, t)
            out[s] = Craft(s, north, east, down, layer, s in launched, s not in launched)
        return out

    seq = LaunchSequence(fleet, H, V)
    order = [s for s in asks if s <= n]
    horizon = 800.0 if step else 200.0  # (one layer for all: some wait for good)
    while t < horizon and len(launched) < n:
        for s in order:
            if s not in cleared and seq.ask(s, t) is None:
                cleared[s] = t
            if s in cleared and s not in launched and t >= cleared[s] + refusals[s - 1]:
                launched[s] = t  # its autopilot armed at last
                seq.armed(s, t)
        t += dt
        airborne = {s: position(s, t) for s in launched if t > launched[s]}
        assert not conflicts(airborne, 30.0, 3.0), (t, launched)
    assert len(launched) == n or not step


def test_the_sequence_is_on_unless_the_config_turns_it_off() -> None:
    mission = {"sensor_radius_m": 100.0}
    assert parse_config({"mission": mission}).safety.launch_sequence
    off = parse_config({"mission": mission, "safety": {"launch_sequence": False}})
    assert not off.safety.launch_sequence
    with pytest.raises(ConfigError, match=r"safety\.launch_sequence.*true or false"):
        parse_config({"mission": mission, "safety": {"launch_sequence": "yes"}})
