"""``@value``: frozen-dataclass semantics (bar the run-time guard) at a plain one's cost."""

from __future__ import annotations

import dataclasses

from convoy_mav.geo import GeoPoint
from convoy_mav.types import Setpoint
from convoy_mav.values import value


@value
class _Point:
    x: float
    y: float = 0.0


def test_a_value_is_a_slotted_dataclass_equal_and_hashed_by_its_fields() -> None:
    a, b = _Point(1.0, 2.0), _Point(1.0, 2.0)
    assert a == b and hash(a) == hash(b) and len({a, b, _Point(1.0)}) == 2
    assert not hasattr(a, "__dict__")
    assert dataclasses.replace(a, y=3.0) == _Point(1.0, 3.0)
    assert repr(a) == "_Point(x=1.0, y=2.0)"


def test_hot_values_stay_hashable() -> None:
    sp = Setpoint(1.0, 2.0, 3.0, -4.0, 5.0, 6.0, 0.0, 0.1, 0.0, center=(1.0, 2.0))
    assert {GeoPoint(47.0, 8.0, 500.0), GeoPoint(47.0, 8.0, 500.0)} == {GeoPoint(47.0, 8.0, 500.0)}
    assert hash(sp) == hash(dataclasses.replace(sp))
