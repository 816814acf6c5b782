"""The scripted convoy of ``convoy.source = "route"`` sets off with the mission.

Mission time is the reference autopilot's boot clock: against autopilots powered up
an hour before, a route timed from boot would start 3600 s x speed down the road.
"""

from __future__ import annotations

import pytest

from convoy_mav.app import ConvoyService
from convoy_mav.config import parse_config


def test_the_scripted_route_starts_when_the_mission_does() -> None:
    cfg = parse_config(
        {
            "mission": {"sensor_radius_m": 100.0},
            "uav": [{"connection": "udpin:127.0.0.1:14560", "sysid": 1}],
            "convoy": {
                "source": "route", "speed_mps": 5.0, "heading_deg": 90.0,
                "start": {"north": 20.0, "east": -30.0},
            },
        }
    )  # fmt: skip
    service = ConvoyService(cfg)
    boot = 3600.0  # the autopilots have been up for an hour
    for k in range(21):  # the control loop's first two seconds of the mission
        service._scripted_convoy(boot + 0.1 * k)
    est = service.tracker.estimate(boot + 2.0)
    assert est is not None
    assert (est.north, est.east) == pytest.approx((20.0, -30.0 + 5.0 * 2.0), abs=0.05)
    assert service._report().route_start_s == boot
