"""MissionClock against a hand-cranked wall clock: speedups, jitter, reboots, handover."""

from __future__ import annotations

import asyncio
import itertools
import random
from collections.abc import Mapping

import pytest

from convoy_mav.clock import MissionClock, Observed, Reading


class FakeWall:
    """A wall clock that moves only when told to."""

    def __init__(self, start: float = 1000.0) -> None:
        self.value = start

    def __call__(self) -> float:
        return self.value


class Autopilot:
    """One simulated vehicle clock: boot time = speedup x wall since its boot."""

    def __init__(self, wall: FakeWall, speedup: float, boot_offset: float = 0.0) -> None:
        self.wall = wall
        self.speedup = speedup
        self.w0 = wall.value
        self.offset = boot_offset  # mission seconds already elapsed at w0

    def mission(self, wall: float | None = None) -> float:
        w = self.wall.value if wall is None else wall
        return self.offset + self.speedup * (w - self.w0)

    def boot_ms(self, wall: float | None = None) -> int:
        return int(self.mission(wall) * 1000.0)


def feed(
    clock: MissionClock,
    wall: FakeWall,
    sources: Mapping[int, Autopilot],
    seconds: float,
    *,
    hz: float = 50.0,
    jitter: float = 0.0,
    rng: random.Random | None = None,
) -> None:
    """Advance the wall ``seconds``; each source sends ``hz`` messages per wall second.

    A message is stamped when sent and observed ``delay`` later (0..jitter wall s).
    """
    rng = rng or random.Random(1)
    steps = round(seconds * hz)
    for _ in range(steps):
        sent = wall.value + 1.0 / hz
        for sysid, ap in sources.items():
            stamp = ap.boot_ms(sent)
            wall.value = sent + (rng.uniform(0.0, jitter) if jitter else 0.0)
            clock.observe(stamp, sysid)
        wall.value = sent


@pytest.mark.parametrize("speedup", [1.0, 20.0, 40.0])
def test_rate_and_time_follow_the_autopilot(speedup: float) -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, speedup, boot_offset=12.5)
    feed(clock, wall, {1: ap}, 5.0)
    assert clock.rate == pytest.approx(speedup, rel=1e-3)
    assert clock.rate_trusted
    # at most one millisecond of time_boot_ms truncation
    assert abs(clock.now() - ap.mission()) < 2e-3
    wall.value += 0.2  # extrapolation between messages
    assert abs(clock.now() - ap.mission()) < 2e-3


@pytest.mark.parametrize("speedup", [1.0, 20.0, 40.0])
def test_jitter_costs_at_most_the_delay(speedup: float) -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, speedup)
    jitter = 0.004  # up to 4 ms of wall delay per message
    feed(clock, wall, {1: ap}, 8.0, jitter=jitter)
    assert clock.rate == pytest.approx(speedup, rel=5e-3)
    error = clock.now() - ap.mission()
    # the line trails by ~ the mean delay; never more than the worst delay
    assert -speedup * jitter - 2e-3 < error < 2e-3


def test_event_loop_stalls_are_outliers() -> None:
    """A stalled loop reads a burst of queued packets late, in order: ignored by the fit."""
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    start = wall.value
    for i in range(400):
        sent = start + 0.02 * (i + 1)
        arrival = sent
        if i % 50 in range(40, 47):  # every second a 150 ms stall: read at its end, in order
            arrival = start + 0.02 * (i - i % 50 + 47) + 0.001
        wall.value = arrival
        clock.observe(ap.boot_ms(sent), 1)
    assert clock.reboots == 0
    assert clock.rate == pytest.approx(40.0, rel=5e-3)
    assert abs(clock.now() - ap.mission()) < 0.04  # 1 ms of wall at 40x


def test_reordered_packets_are_not_reboots() -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    feed(clock, wall, {1: ap}, 1.0)
    # two packets delivered 200 ms of wall (8 mission s) late, after newer ones
    assert not clock.observe(ap.boot_ms(wall.value - 0.2), 1)
    assert not clock.observe(ap.boot_ms(wall.value - 0.18), 1)
    feed(clock, wall, {1: ap}, 1.0)
    assert clock.reboots == 0
    assert abs(clock.now() - ap.mission()) < 2e-3


def test_rate_hint_is_used_until_the_window_is_long_enough() -> None:
    wall = FakeWall()
    hinted = MissionClock(wall, rate_hint=40.0)
    blind = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    for _ in range(3):
        wall.value += 0.05
        hinted.observe(ap.boot_ms(), 1)
        blind.observe(ap.boot_ms(), 1)
    assert not hinted.rate_trusted
    assert hinted.rate == 40.0
    assert blind.rate == 1.0
    wall.value += 0.05  # between messages the hint extrapolates correctly
    assert abs(hinted.now() - ap.mission()) < 2e-3
    feed(blind, wall, {1: ap}, 1.0)
    assert blind.rate_trusted
    assert blind.rate == pytest.approx(40.0, rel=1e-3)


def test_before_any_vehicle_time_is_zero() -> None:
    clock = MissionClock(FakeWall())
    assert not clock.synced
    assert clock.now() == 0.0
    assert clock.reference is None


def test_mission_time_is_the_first_vehicles_boot_time() -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    first = Autopilot(wall, 20.0, boot_offset=100.0)
    second = Autopilot(wall, 20.0, boot_offset=3.0)  # booted 97 mission s later
    feed(clock, wall, {1: first, 2: second}, 3.0)
    assert clock.reference == 1
    assert abs(clock.now() - first.mission()) < 2e-3
    # a stamp of vehicle 2 maps onto mission time
    assert clock.to_mission(second.boot_ms(), 2) == pytest.approx(first.mission(), abs=3e-3)


@pytest.mark.parametrize("speedup", [1.0, 40.0])
def test_reboot_reanchors_without_a_jump(speedup: float) -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, speedup, boot_offset=50.0)
    feed(clock, wall, {1: ap}, 3.0)
    before = clock.now()
    true_before = ap.mission()
    # reboot: its clock restarts from 0 at this wall time
    rebooted = Autopilot(wall, speedup, boot_offset=0.0)
    told = []
    for _ in range(5):
        wall.value += 0.05
        told.append(clock.observe(rebooted.boot_ms(wall.value), 1))
    assert told.count(Observed.REBOOTED) == 1  # once, when confirmed (not on the first alone)
    assert not told[0]
    feed(clock, wall, {1: rebooted}, 1.75)
    assert clock.reboots == 1
    elapsed = speedup * 2.0
    assert clock.now() == pytest.approx(before + elapsed, abs=speedup * 0.03)
    assert clock.now() == pytest.approx(true_before + elapsed, abs=speedup * 0.03)
    assert clock.rate == pytest.approx(speedup, rel=1e-2)
    # stamps after the reboot map to continuing mission time
    assert clock.to_mission(rebooted.boot_ms(), 1) == pytest.approx(clock.now(), abs=0.01)


def test_reference_silent_hands_over_continuously() -> None:
    wall = FakeWall()
    clock = MissionClock(wall, handover_after=2.0)
    first = Autopilot(wall, 40.0, boot_offset=10.0)
    second = Autopilot(wall, 40.0, boot_offset=500.0)
    feed(clock, wall, {1: first, 2: second}, 2.0)
    last = clock.now()
    feed(clock, wall, {2: second}, 2.0)  # vehicle 1 is gone
    assert clock.reference == 2
    assert clock.handovers == 1
    # mission time keeps following vehicle 1's (dead) clock: no jump at the handover
    assert clock.now() == pytest.approx(first.mission(), abs=0.05)
    assert clock.now() > last
    assert clock.rate == pytest.approx(40.0, rel=1e-2)


def test_a_reference_heard_once_then_silent_gives_way_at_the_others_rate() -> None:
    """ArduPlane SITL at 5x behind a lossy radio: the first UAV heard sent one packet,
    then nothing for 2 wall s, while the others' clocks ran on at 5x. Mission time
    follows their rate from the first moment it is measured (not ``run``'s hint of 1.0,
    which left it 8 s behind, to be stepped on at the handover), so no clock steps."""
    wall = FakeWall()
    clock = MissionClock(wall, handover_after=2.0)  # (no hint, as ``run``)
    first, second, third = (Autopilot(wall, 5.0, boot_offset=3.064) for _ in range(3))
    clock.observe(first.boot_ms(), 1)
    assert clock.reference == 1
    behind = []  # mission time less the fleet's clocks, each 0.05 wall s
    for _ in range(40):  # 2 wall s, the first silent
        feed(clock, wall, {2: second, 3: third}, 0.05)
        behind.append(second.mission() - clock.now())
    assert clock.reference == 2 and clock.handovers == 1
    assert clock.steps == 0
    # At 1.0 until five packets of another clock span 0.05 wall s (0.3 s behind), then
    # at theirs; the handover takes the offset as it stands: no step. (Before: 0.2 s
    # behind for each 0.05 wall s, 8 s by the handover, and then a step of 8 s.)
    assert max(behind) < 0.5
    assert max(abs(b - a) for a, b in itertools.pairwise(behind[2:])) < 0.25
    assert clock.rate == pytest.approx(5.0, rel=1e-2)
    feed(clock, wall, {1: first, 2: second, 3: third}, 1.0)  # the first heard again
    stamps = first.boot_ms()
    assert clock.to_mission(stamps, 1) == pytest.approx(clock.to_mission(stamps, 2), abs=0.05)


def test_now_never_goes_backwards() -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    rng = random.Random(3)
    previous = -1.0
    for _ in range(500):
        wall.value += 0.01
        clock.observe(ap.boot_ms(wall.value - rng.uniform(0, 0.01)), 1)
        t = clock.now()
        assert t >= previous
        previous = t


def pause(wall: FakeWall, aps: dict[int, Autopilot], seconds: float) -> None:
    """The simulator stands still for ``seconds`` of wall time (a stalled host)."""
    wall.value += seconds
    for ap in aps.values():
        ap.offset -= ap.speedup * seconds


@pytest.mark.parametrize(("stall", "skip"), [(0.1, 0.0), (0.03, 0.0), (0.0, 1.5)])
def test_a_simulator_step_is_followed(stall: float, skip: float) -> None:
    """A simulator that pauses (or skips ahead) is followed within a few packets."""
    wall = FakeWall()
    clock = MissionClock(wall)
    aps = {1: Autopilot(wall, 25.0), 2: Autopilot(wall, 25.0, boot_offset=3.0)}
    feed(clock, wall, aps, 4.0, hz=100.0)
    pause(wall, aps, stall)
    for ap in aps.values():  # both run on one simulator clock
        ap.offset += skip
    feed(clock, wall, aps, 0.05, hz=100.0)  # 5 packets each: not confirmed yet
    assert clock.steps == 0
    feed(clock, wall, aps, 0.1, hz=100.0)
    assert clock.steps == 1
    assert clock.rate == pytest.approx(25.0, rel=1e-2)  # the measured rate is kept
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.05)
    feed(clock, wall, aps, 2.0, hz=100.0)
    assert clock.steps == 1
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.01)
    stamp = aps[2].boot_ms()
    assert clock.to_mission(stamp, 2) == pytest.approx(aps[1].mission(), abs=0.05)


def test_a_vehicle_read_late_for_a_while_keeps_its_offset() -> None:
    """A loaded host: for 2 wall s the second vehicle's socket is served 15 ms after
    the first's (0.6 mission s at 40x), and a simulator pause in the middle of it
    restarts the clock's line. Its stamps still map onto mission time as its prompt
    packets said: a median of its packets' delays over the last 1.6 wall s put it
    up to 0.6 s late for a wall second, 10 m of a plane."""
    wall = FakeWall()
    clock = MissionClock(wall)
    first = Autopilot(wall, 40.0, boot_offset=100.0)
    second = Autopilot(wall, 40.0, boot_offset=3.0)
    aps = {1: first, 2: second}
    feed(clock, wall, aps, 6.0)
    worst = 0.0
    for i in range(200):  # 4 wall s at 50 Hz
        if i == 50:
            pause(wall, aps, 0.1)
        sent = wall.value + 0.02
        for sysid, ap in aps.items():
            late = 0.015 if sysid == 2 and i < 100 else 0.0
            wall.value = sent + late
            clock.observe(ap.boot_ms(sent), sysid)
            wall.value = sent
        error = clock.to_mission(second.boot_ms(sent), 2) - first.mission(sent)
        worst = max(worst, abs(error))
    assert clock.steps == 1
    assert worst < 0.01  # (ms rounding of both stamps)


def set_speedup(ap: Autopilot, speedup: float) -> None:
    """The simulator's speedup set anew now: its clock runs on from where it is."""
    ap.offset, ap.w0, ap.speedup = ap.mission(), ap.wall.value, speedup


@pytest.mark.parametrize(
    ("before", "after"), [(40.0, 20.0), (40.0, 10.0), (10.0, 40.0), (1.0, 0.5)]
)
def test_a_new_speedup_is_followed_within_a_quarter_wall_second(
    before: float, after: float
) -> None:
    """A simulator's speedup set anew in flight (``SIM_SPEEDUP``): mission time is off
    by what runs off in the ``_RATE_SPAN`` (plus the step threshold's own wait), then
    on the new line, at the new rate. The fit alone turned in its whole window: 28
    mission s ahead for 8 wall s when 40x became 20x."""
    wall = FakeWall()
    clock = MissionClock(wall)
    aps = {1: Autopilot(wall, before, boot_offset=5.0), 2: Autopilot(wall, before)}
    feed(clock, wall, aps, 5.0, jitter=0.002)
    for ap in aps.values():  # (one simulator clock)
        set_speedup(ap, after)
    threshold = max(0.1, 0.01 * before)
    worst = 0.0
    for _ in range(20):
        feed(clock, wall, aps, 0.05, jitter=0.002)
        worst = max(worst, abs(clock.now() - aps[1].mission()))
    assert worst < abs(after - before) * 0.3 + threshold + after * 0.1
    assert (clock.rate_changes, clock.steps) == (1, 1)
    assert clock.rate == pytest.approx(after, rel=0.01)
    feed(clock, wall, aps, 2.0, jitter=0.002)
    assert clock.now() == pytest.approx(aps[1].mission(), abs=max(0.003 * after, 0.002))
    assert clock.to_mission(aps[2].boot_ms(), 2) == pytest.approx(aps[1].mission(), abs=0.1)
    assert (clock.rate_changes, clock.steps) == (1, 1)


def test_the_simulators_word_on_its_new_speedup_is_taken_at_once() -> None:
    """Packets that scatter too much for the change-of-rate test (a loaded host: up to
    30 ms late, 1.2 mission s at 40x): the reference's PARAM_VALUE of ``SIM_SPEEDUP``
    restarts the line at the rate it says, and mission time stays on the simulator's
    within the scatter (without it: 26 s ahead, the rate still 39 after 2 wall s).
    Another vehicle's word, or the rate in force, changes nothing."""
    wall = FakeWall()
    clock = MissionClock(wall)
    aps = {1: Autopilot(wall, 40.0, boot_offset=5.0), 2: Autopilot(wall, 40.0)}
    rng = random.Random(3)
    feed(clock, wall, aps, 5.0, jitter=0.03, rng=rng)
    assert not clock.rate_set(40.0, 1) and not clock.rate_set(20.0, 2)
    for ap in aps.values():
        set_speedup(ap, 20.0)
    assert clock.rate_set(20.0, 1)
    worst = 0.0
    for _ in range(40):
        feed(clock, wall, aps, 0.05, jitter=0.03, rng=rng)
        worst = max(worst, abs(clock.now() - aps[1].mission()))
    assert worst < 1.0
    assert clock.rate == pytest.approx(20.0, rel=0.02)
    assert (clock.rate_changes, clock.steps) == (1, 1)


def test_a_queue_filling_for_a_moment_is_no_change_of_rate() -> None:
    """A loaded host reads the reference later and later, 0.1 wall s behind at worst
    (4 mission s at 40x), then catches up: its packets drift off the line as steadily
    as a half-rate clock's would for 0.2 wall s of arrivals, but not for long enough
    to be taken for one."""
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    feed(clock, wall, {1: ap}, 5.0)
    for i in range(20):  # 0.2 wall s sent at 100 Hz: delays grow 0..0.1 s, then drain
        sent = wall.value + 0.01
        wall.value = sent + 0.01 * min(i, 20 - i)
        clock.observe(ap.boot_ms(sent), 1)
        wall.value = sent
    feed(clock, wall, {1: ap}, 1.0)
    assert (clock.rate_changes, clock.steps) == (0, 0)
    assert clock.rate == pytest.approx(40.0, rel=1e-3)


def test_small_steps_and_jitter_are_not_steps() -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 25.0)
    feed(clock, wall, {1: ap}, 4.0, hz=100.0, jitter=0.004)
    pause(wall, {1: ap}, 0.003)  # 75 ms of sim: below the threshold at 25x
    feed(clock, wall, {1: ap}, 2.0, hz=100.0, jitter=0.004)
    assert clock.steps == 0


async def test_sleep_until_returns_early_at_a_step() -> None:
    wall = FakeWall()
    ap = Autopilot(wall, 25.0)

    async def fake_sleep(dt: float) -> None:
        for _ in range(max(1, round(dt / 0.01))):
            wall.value += 0.01
            clock.observe(ap.boot_ms(), 1)
        await asyncio.sleep(0)

    clock = MissionClock(wall, sleep=fake_sleep)
    feed(clock, wall, {1: ap}, 2.0, hz=100.0)
    target = clock.now() + 10.0
    pause(wall, {1: ap}, 0.2)  # 5 s of sim time lost
    await clock.sleep_until(target)
    assert clock.steps == 1
    assert clock.now() < target  # woken early: the caller re-plans its deadline
    assert clock.now() == pytest.approx(ap.mission(), abs=0.05)


def test_bad_rate_hint_is_refused() -> None:
    with pytest.raises(ValueError, match="rate_hint"):
        MissionClock(rate_hint=0.0)


async def test_sleep_until_converts_with_the_rate() -> None:
    wall = FakeWall()
    slept: list[float] = []
    ap = Autopilot(wall, 40.0, boot_offset=5.0)

    async def fake_sleep(dt: float) -> None:  # wall passes, the vehicle keeps talking
        slept.append(dt)
        wall.value += dt
        clock.observe(ap.boot_ms(), 1)
        await asyncio.sleep(0)

    clock = MissionClock(wall, rate_hint=40.0, sleep=fake_sleep)
    feed(clock, wall, {1: ap}, 1.0)
    start = clock.now()
    await clock.sleep_until(start + 20.0)  # 20 mission s = 0.5 wall s at 40x
    assert clock.now() >= start + 20.0
    assert sum(slept) == pytest.approx(0.5, abs=0.01)
    await clock.sleep_until(start)  # in the past: returns at once
    assert sum(slept) == pytest.approx(0.5, abs=0.01)


async def test_sleep_until_waits_for_the_first_vehicle() -> None:
    clock = MissionClock(rate_hint=1000.0)
    task = asyncio.create_task(clock.sleep_until(1.0))
    await asyncio.sleep(0.01)
    assert not task.done()
    clock.observe(5000, 1)  # mission time is 5 s: already past
    await asyncio.wait_for(task, 1.0)
    assert clock.synced


# ====================================================== a whole fleet falls silent
class PausedAutopilot(Autopilot):
    """A vehicle whose clock stops while ``paused`` (a simulator or host paused)."""

    def __init__(self, wall: FakeWall, speedup: float, boot_offset: float = 0.0) -> None:
        super().__init__(wall, speedup, boot_offset)
        self.lost_wall = 0.0  # wall seconds its clock stood still

    def mission(self, wall: float | None = None) -> float:
        return super().mission(wall) - self.speedup * self.lost_wall


@pytest.mark.parametrize("speedup", [1.0, 10.0, 40.0])
@pytest.mark.parametrize("pause", [14.0, 100.0])
@pytest.mark.parametrize("clocks_run", [False, True])
@pytest.mark.parametrize("order", [(1, 2, 3), (2, 1, 3), (3, 2, 1), (2, 3, 1)])
def test_a_fleet_wide_silence_is_followed_whoever_speaks_first(
    speedup: float, pause: float, clocks_run: bool, order: tuple[int, int, int]
) -> None:
    """Every vehicle silent for ``pause`` mission seconds: a paused simulator (clocks
    stopped) or a ground radio down (clocks ran on); then they speak again, one after
    another in ``order``. Mission time must end up on the autopilots' clocks."""
    wall = FakeWall()
    clock = MissionClock(wall, rate_hint=speedup)
    aps = {i: PausedAutopilot(wall, speedup, boot_offset=100.0 * i) for i in (1, 2, 3)}
    feed(clock, wall, aps, 3.0)
    assert clock.reference == 1
    offsets = {i: 100.0 * (i - 1) for i in aps}  # mission = boot time - offset
    silence = pause / speedup
    wall.value += silence
    if not clocks_run:
        for ap in aps.values():
            ap.lost_wall += silence
    for first in order:  # one after another, a tenth of a wall second each
        feed(clock, wall, {first: aps[first]}, 0.1)
    feed(clock, wall, aps, 1.0)
    truth = aps[1].mission()
    assert clock.now() == pytest.approx(truth, abs=0.2)
    for i, ap in aps.items():  # each vehicle's stamps map onto the same mission time
        assert clock.to_mission(ap.boot_ms(), i) == pytest.approx(
            ap.mission() - offsets[i], abs=0.2
        )


def test_a_reboot_during_a_fleet_wide_silence_does_not_move_mission_time() -> None:
    wall = FakeWall()
    clock = MissionClock(wall, rate_hint=20.0)
    aps = {i: PausedAutopilot(wall, 20.0, boot_offset=100.0 * i) for i in (1, 2)}
    feed(clock, wall, aps, 3.0)
    wall.value += 14.0 / 20.0
    for ap in aps.values():
        ap.lost_wall += 14.0 / 20.0
    rebooted = Autopilot(wall, 20.0)  # vehicle 2 comes back from a reboot: clock at 0
    feed(clock, wall, {2: rebooted}, 0.5)
    feed(clock, wall, {1: aps[1], 2: rebooted}, 1.0)
    assert clock.reboots == 1
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.2)


def test_mission_time_waits_out_a_silence_past_its_cap() -> None:
    """Nobody heard: now() runs on for silence_cap (liveness needs it), then waits; the
    step back when paused clocks are heard again is at most the cap."""
    wall = FakeWall()
    clock = MissionClock(wall, rate_hint=20.0, silence_cap=10.0)
    aps = {i: PausedAutopilot(wall, 20.0, boot_offset=10.0 * i) for i in (1, 2)}
    feed(clock, wall, aps, 2.0)
    heard = clock.now()
    wall.value += 0.25  # 5 mission s: still running on
    assert clock.now() == pytest.approx(heard + 5.0, abs=0.05)
    wall.value += 5.0  # 100 mission s of silence: held at the cap
    for ap in aps.values():
        ap.lost_wall += 5.25
    assert clock.now() == pytest.approx(heard + 10.0, abs=0.05)
    feed(clock, wall, {2: aps[2]}, 0.5)  # vehicle 2 first: resynced onto the clocks
    feed(clock, wall, aps, 0.5)
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.2)


@pytest.mark.parametrize("watched", [True, False])
def test_a_silence_is_told_from_a_stalled_loop_by_whether_the_loop_saw_the_clock_stand(
    watched: bool,
) -> None:
    """A radio dropout of 30 mission s, the reference heard first again: mission time,
    held at the cap, runs on from the line (no step). With the loop asking for the time
    meanwhile it saw the clock stand: a silence. A loop held up as long asked nothing,
    and then read what queued as if the fleet had just spoken: no silence, its own
    lateness."""
    wall = FakeWall()
    clock = MissionClock(wall, rate_hint=20.0, silence_cap=10.0)
    aps = {i: Autopilot(wall, 20.0, boot_offset=10.0 * i) for i in (1, 2)}
    feed(clock, wall, aps, 2.0)
    before = clock.reading()
    for _ in range(6):  # 1.5 wall s = 30 mission s, asked every quarter second or not
        wall.value += 0.25
        if watched:
            clock.now()
    feed(clock, wall, {1: aps[1]}, 0.1)
    feed(clock, wall, aps, 0.5)
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.2)
    assert (clock.silences, clock.steps, clock.resyncs) == (int(watched), 0, 0)
    # The reader's own time across it: none when the clock stood, all of it when the
    # reader was what stood.
    after = clock.reading()
    assert after.t - before.t > 30.0
    assert after.since(before) == (0.0 if watched else pytest.approx(after.t - before.t))
    # The next short pause (under the cap) is no silence either way.
    wall.value += 0.2
    clock.now()
    feed(clock, wall, aps, 0.5)
    assert clock.silences == int(watched)


@pytest.mark.parametrize("speedup", [1.0, 40.0])
@pytest.mark.parametrize("sysid", [1, 2])  # the reference, and another vehicle
def test_a_stamp_far_ahead_is_rejected_and_moves_nothing(speedup: float, sysid: int) -> None:
    """One spoofed ``time_boot_ms`` (496 s -> 4066 s) neither throws mission time ahead
    nor, when the vehicle's own stamps resume, passes for a reboot."""
    wall = FakeWall()
    clock = MissionClock(wall)
    aps = {1: Autopilot(wall, speedup, boot_offset=496.0), 2: Autopilot(wall, speedup, 90.0)}
    feed(clock, wall, aps, 2.0)
    before = clock.now()
    wall.value += 0.01
    assert clock.observe(4_066_000, sysid) is Observed.REJECTED
    assert clock.observe(float("nan"), sysid) is Observed.REJECTED
    assert clock.now() == pytest.approx(before + 0.01 * speedup, abs=0.01 * speedup + 0.01)
    feed(clock, wall, aps, 2.0)
    assert clock.rejected == 2
    assert clock.reboots == clock.jumps == clock.steps == 0
    assert clock.now() == pytest.approx(aps[1].mission(), abs=0.02 * speedup + 0.01)
    assert clock.to_mission(aps[2].boot_ms(), 2) == pytest.approx(clock.now(), abs=0.05 * speedup)


def test_stamps_a_little_ahead_are_jitter_not_jumps() -> None:
    """A packet held up on the way, then a prompt one: the stamps step ahead of the
    wall time between their arrivals, within the jitter allowance."""
    wall = FakeWall()
    clock = MissionClock(wall)
    ap = Autopilot(wall, 40.0)
    feed(clock, wall, {1: ap}, 2.0, jitter=0.2)
    assert clock.rejected == 0


def test_a_clock_that_really_jumped_ahead_is_reanchored_without_a_jump() -> None:
    wall = FakeWall()
    clock = MissionClock(wall)
    aps = {1: Autopilot(wall, 10.0, boot_offset=50.0), 2: Autopilot(wall, 10.0, 20.0)}
    feed(clock, wall, aps, 2.0)
    before = clock.now()
    aps[2].offset += 3600.0  # vehicle 2's clock now reads an hour ahead, and stays there
    seen = []
    for _ in range(5):
        wall.value += 0.02
        seen.append(clock.observe(aps[2].boot_ms(), 2))
    assert seen[:4] == [Observed.REJECTED] * 4
    assert seen[4] is Observed.ACCEPTED
    assert clock.jumps == 1 and clock.reboots == 0
    feed(clock, wall, aps, 1.0)
    assert clock.now() == pytest.approx(before + 11.0, abs=0.2)
    assert clock.to_mission(aps[2].boot_ms(), 2) == pytest.approx(clock.now(), abs=0.2)


def test_a_reading_counts_time_since_another_only_on_one_unbroken_line() -> None:
    """``Reading.since``: mission time between two readings is the reader's own only
    when no step or silence came between them; none before a first reading, and a
    clock read back (``now()`` re-anchored) is no negative lateness."""
    assert Reading(12.0, 3).since(Reading(10.0, 3)) == 2.0
    assert Reading(12.0, 4).since(Reading(10.0, 3)) == 0.0
    assert Reading(12.0, 3).since(None) == 0.0
    assert Reading(9.0, 3).since(Reading(10.0, 3)) == 0.0
