"""Which ground vehicles are the convoy: the lead's group, any parted from it left out.

A convoy's vehicles drive together, but one may part from it: stopped by its driver or
a breakdown while the rest drive on, sent home on its own, or turning off elsewhere.
The centroid of vehicles a kilometre apart is a point on none of them, and UAVs
circling it see none of them; so the convoy protected is the lead's group.

Design rules:
    * A group is the vehicles linked by a chain of gaps no longer than ``part_m``
      (single linkage): a column strung along a road is one convoy however long, and
      the order of the vehicles along it need not be known.
    * The convoy is the lead's group while the lead is heard; without it (silent, or
      not named) the largest group, a tie going to the one holding the vehicle heard
      first.
    * Hysteresis: a member stays while it is within ``part_m`` of another member, a
      parted vehicle rejoins only within ``rejoin_m`` of one, so a vehicle near the
      limit does not flap in and out, each time moving the centroid and resetting the
      convoy's velocity fit.
    * The service's default ``part_m`` is twice the sensor radius: a vehicle farther
      than that from every other is never in one camera's disk with any of them.
    * A vehicle that has stood ``STAND_S`` while the lead drove on has parted however
      near (``StandWatch``, from the speeds they report): a breakdown or a blocked road
      leaves its autopilot in its mission, so its mode says nothing.
    * A vehicle's own mode may say it before its distance does (``leaves``): held or
      sent home (RTL, SMART_RTL) by its operator or its failsafe while the lead drives
      on, it has left, however near
      (``apart``), and the convoy is not dragged back towards it for the tens of
      seconds it takes to fall 2 sensor radii behind.
    * Pure: positions and the previous answer in, the group out.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping
from typing import Generic, TypeVar

from convoy_mav.types import ConvoyDrive

__all__ = ["STAND_S", "StandWatch", "convoy_group", "default_part_m", "leaves"]

S = TypeVar("S", bound=Hashable)

_PART_RADII = 2.0  # sensor radii: the default distance at which a vehicle has parted
_REJOIN_FRACTION = 0.5  # of part_m: within this of a member, a parted vehicle rejoins
STAND_S = 15.0  # s a vehicle stands while the lead drives on before it has parted
_STAND_MPS = 0.3  # m/s: a vehicle reporting less stands (an autopilot's still estimate)
_LEAD_MPS = 1.0  # m/s: the lead reporting this or more all the window drives on (its corners too)
_MOVES_MPS = 1.0  # m/s: one judged standing that reports this drives again
_SLACK_S = 1.5  # s: a vehicle reporting about once a second, last heard within this, is heard
_RECHECK_S = 0.5  # s between judgements (each vehicle reports about once a second)
# (home by either way, straight or back along its path, is home: both going, none parts)
_HOMEWARD = {ConvoyDrive.RETRACE: ConvoyDrive.HOME}


def default_part_m(sensor_radius: float) -> float:
    """The distance from every other vehicle at which one has parted from the convoy:
    a sensor diameter, beyond which no camera sees it with any of them."""
    return _PART_RADII * sensor_radius


def leaves(follower: ConvoyDrive, lead: ConvoyDrive | None) -> bool:
    """Whether a vehicle whose mode says ``follower`` has left a convoy whose lead's says
    ``lead`` (None: not known): held, or sent home (either way home), while the lead
    does otherwise. A lead driven otherwise (MANUAL, GUIDED) says nothing of where the
    convoy goes."""
    if lead is None:
        return False
    follower, lead = _HOMEWARD.get(follower, follower), _HOMEWARD.get(lead, lead)
    return follower in (ConvoyDrive.HELD, ConvoyDrive.HOME) and lead not in (
        follower,
        ConvoyDrive.OTHER,
    )


class StandWatch(Generic[S]):
    """Which vehicles have stood ``STAND_S`` while the lead drove on, from the speeds
    they report: a breakdown, or a road blocked, with the autopilot still in its
    mission.

    Standing: every speed reported over the window under ``_STAND_MPS``; driving on:
    the lead's every one over it ``_LEAD_MPS`` or more. So a column pulling away after a
    stop parts no one: each vehicle sets off seconds after the one ahead, before the
    lead has driven a whole window. Once standing, a vehicle stays so until it reports
    ``_MOVES_MPS`` or the lead reports a stand (no flapping about the thresholds). A
    vehicle that reports no speed (a feed of positions alone, whose 3-m noise
    differenced is no speed) is never judged: it parts by its distance alone. Pure:
    times are passed in."""

    def __init__(self) -> None:
        # each vehicle's last report (t, speed), and since when its reports have been
        # under _STAND_MPS, and _LEAD_MPS or more, without a break (None: not now)
        self._last: dict[S, tuple[float, float]] = {}
        self._still_since: dict[S, float | None] = {}
        self._going_since: dict[S, float | None] = {}
        self._standing: frozenset[S] = frozenset()
        self._judged = -math.inf

    def add(self, source: S, t: float, speed: float | None) -> None:
        """The speed ``source`` reports at ``t`` (None: none, which breaks its runs)."""
        if speed is None or not math.isfinite(speed):
            self._last.pop(source, None)
            self._still_since[source] = self._going_since[source] = None
            return
        self._last[source] = (t, speed)
        still, going = self._still_since.get(source), self._going_since.get(source)
        self._still_since[source] = (t if still is None else still) if speed < _STAND_MPS else None
        self._going_since[source] = (t if going is None else going) if speed >= _LEAD_MPS else None

    def judge(self, lead: S | None, now: float) -> frozenset[S]:
        """The vehicles (never the lead) standing while ``lead`` drives on, at ``now``
        (judged again at most every ``_RECHECK_S``)."""
        if now - self._judged < _RECHECK_S:
            return self._standing
        self._judged = now
        heard = {s: v for s, (t, v) in self._last.items() if t >= now - _SLACK_S}
        if lead not in heard or heard[lead] < _STAND_MPS:  # (the lead stands, or is silent)
            self._standing = frozenset()
            return self._standing
        since = now - STAND_S  # (a run begun by then spans the window)
        going = self._going_since.get(lead)
        drives = going is not None and going <= since
        standing = set()
        for source, speed in heard.items():
            if source == lead:
                continue
            if source in self._standing:  # (until it drives again)
                stood = speed < _MOVES_MPS
            else:
                still = self._still_since.get(source)
                stood = drives and still is not None and still <= since
            if stood:
                standing.add(source)
        self._standing = frozenset(standing)
        return self._standing


def convoy_group(
    positions: Mapping[S, tuple[float, float]],
    *,
    lead: S | None,
    part_m: float,
    parted: frozenset[S] = frozenset(),
    rejoin_m: float | None = None,
    apart: frozenset[S] = frozenset(),
) -> frozenset[S]:
    """The vehicles of ``positions`` (each's ``(north, east)``, in the order first
    heard) that are the convoy; ``parted`` those that had parted before (they rejoin
    within ``rejoin_m``, default half of ``part_m``); ``apart`` those known to have left
    (``leaves``: never the lead's group, unless they are all there is). ``part_m`` 0 or
    infinite: all of them, none ever parts."""
    if not positions:
        return frozenset()
    if not (part_m > 0.0 and math.isfinite(part_m)):
        return frozenset(positions)
    kept = {s: p for s, p in positions.items() if s not in apart or s == lead}
    positions = kept or positions
    near = part_m * _REJOIN_FRACTION if rejoin_m is None else rejoin_m
    sources = list(positions)
    groups: list[list[S]] = []
    seen: set[S] = set()
    for first in sources:
        if first in seen:
            continue
        group, todo = [first], [first]
        seen.add(first)
        while todo:
            a = todo.pop()
            pa = positions[a]
            for b in sources:
                if b in seen:
                    continue
                reach = near if a in parted or b in parted else part_m
                if math.dist(pa, positions[b]) <= reach:
                    seen.add(b)
                    group.append(b)
                    todo.append(b)
        groups.append(group)
    if lead is not None and lead in positions:
        return frozenset(next(g for g in groups if lead in g))
    largest = max(len(g) for g in groups)
    return frozenset(next(g for g in groups if len(g) == largest))  # (the first heard)
