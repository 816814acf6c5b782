"""Convoy fixes over MQTT reach the tracker as the vehicles that sent them.

Several trackers publish on one topic: each ``source`` is its own vehicle (the convoy
is the centroid of their latest fixes), and the velocity a fix carries goes with it.
"""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.config import parse_config
from convoy_mav.publish.topics import parse_convoy_position


def _service(now: list[float]) -> ConvoyService:
    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0},
            "uav": [{"connection": "udpin:127.0.0.1:14560", "sysid": 1}],
            "convoy": {"source": "mqtt"},
            "mqtt": {"host": "127.0.0.1"},
        }
    )
    service = ConvoyService(cfg)
    service.clock = SimpleNamespace(synced=True, now=lambda: now[0])  # type: ignore[assignment]
    return service


def test_two_trackers_on_one_topic_are_two_vehicles_with_their_velocities() -> None:
    now = [0.0]
    service = _service(now)
    for k in range(121):  # two trucks 20 m apart driving east at 6 m/s, 10 Hz, 12 s
        now[0] = t = 0.1 * k
        for name, north in (("lead", 10.0), ("tail", -10.0)):
            raw = f'{{"north": {north}, "east": {6.0 * t}, "t": {t}, "source": "{name}",'
            service._on_mqtt_convoy(parse_convoy_position(raw + ' "vn": 0, "ve": 6}'))
    assert service.tracker.sources == {"mqtt:lead", "mqtt:tail"}
    est = service.tracker.estimate(12.0)
    assert est is not None
    assert (est.north, est.east, est.vn, est.ve) == pytest.approx((0.0, 72.0, 0.0, 6.0))
    assert service.tracker.counters["velocity_reported"] > 0
    assert service.tracker.counters["jump"] == 0
