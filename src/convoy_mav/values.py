"""``@value``: the frozen dataclass of the flight loop's hot values, minus its cost.

A frozen dataclass sets each field through ``object.__setattr__`` when it is
created: a 13-field :class:`~convoy_mav.types.Setpoint` costs 1.2 µs that way
against 0.2 µs for a plain one. The flight loop creates several such values per
vehicle per setpoint and per telemetry message (a thousand UAVs: ~70 000 a
second), so the hot ones (setpoints, telemetry, plan samples, geographic points)
are declared with ``@value`` instead:

- to the type checker (PEP 681 ``dataclass_transform(frozen_default=True)``) a
  ``@value`` class is a frozen dataclass: assigning a field is a mypy error;
- at run time it is a slotted dataclass hashed by its fields like a frozen one
  (``unsafe_hash``), equal by fields, usable with ``dataclasses.replace``;
  only the run-time guard against assignment is left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar, dataclass_transform

__all__ = ["value"]

T = TypeVar("T")


@dataclass_transform(frozen_default=True)
def value(cls: type[T]) -> type[T]:
    """Declare ``cls`` a hot immutable value (see the module docstring)."""
    return dataclass(slots=True, unsafe_hash=True)(cls)
