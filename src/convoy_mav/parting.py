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
from typing import TypeVar

from convoy_mav.types import ConvoyDrive

__all__ = ["convoy_group", "default_part_m", "leaves"]

S = TypeVar("S", bound=Hashable)

_PART_RADII = 2.0  # sensor radii: the default distance at which a vehicle has parted
_REJOIN_FRACTION = 0.5  # of part_m: within this of a member, a parted vehicle rejoins
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
