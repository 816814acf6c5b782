"""Cost of laying an uploaded rover mission out, in the mock's loop (``sitl_mock.uploaded``).

An operator's patrol that jumps back for ever is laid ``CHUNK`` (200) waypoints at a
time and laid on before the rover gets to the last; each lay runs in the mock's loop
and stalls every vehicle while it runs. Side by side, 200 against the 5000 a first
version laid at once (and laid again at every speed mark, as a told speed retimes the
road).

Run: ``.venv/bin/python -m pytest benchmarks/bench_mock_missions.py --benchmark-only``.
"""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import common as mavlink
from pytest_benchmark.fixture import BenchmarkFixture

from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock import uploaded
from sitl_mock.mission import waypoint_item
from sitl_mock.uploaded import UploadedMission

_WORLD = LocalFrame(GeoPoint(47.397742, 8.545594, 488.0))
_LAP = ((0.0, 0.0), (500.0, 0.0), (500.0, 350.0), (250.0, 350.0), (250.0, 600.0), (0.0, 600.0))


def _patrol() -> list[mavlink.MAVLink_mission_item_int_message]:
    """Home, 8 m/s, the city circuit's six corners (6 m/s from the fourth), jump for ever."""
    home = _WORLD.to_geo(0.0, 0.0, 0.0)
    items = [waypoint_item(0, home, (1, 1), home=True)]

    def speed(v: float) -> mavlink.MAVLink_mission_item_int_message:
        return mavlink.MAVLink_mission_item_int_message(
            1, 1, len(items), mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_CHANGE_SPEED,
            0, 1, 1.0, v, -1.0, 0.0, 0, 0, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip

    items.append(speed(8.0))
    for k, (n, e) in enumerate(_LAP):
        items.append(waypoint_item(len(items), _WORLD.to_geo(n, e, 0.0), (1, 1)))
        if k == 3:
            items.append(speed(6.0))
    jump = mavlink.MAVLink_mission_item_int_message(
        1, 1, len(items), mavlink.MAV_FRAME_MISSION, mavlink.MAV_CMD_DO_JUMP,
        0, 1, 2.0, -1.0, 0.0, 0.0, 0, 0, 0.0, mavlink.MAV_MISSION_TYPE_MISSION,
    )  # fmt: skip
    items.append(jump)
    return items


@pytest.mark.parametrize("chunk", [200, 5000])
def test_laying_a_patrol_out_and_entering_it_at_speed(
    benchmark: BenchmarkFixture, monkeypatch: pytest.MonkeyPatch, chunk: int
) -> None:
    """``UploadedMission.of`` and the retimed road the rover enters it by
    (``Polyline.with_speed_from``): what one lay costs the mock's loop."""
    monkeypatch.setattr(uploaded, "CHUNK", chunk)
    items = _patrol()
    home = _WORLD.to_geo(0.0, 0.0, 0.0)

    def lay() -> int:
        mission = UploadedMission.of(
            items, home_first=True, world=_WORLD, start=(100.0, 0.0), home=home,
            speed=8.0, accel=1.0, speed_now=8.0,
        )  # fmt: skip
        drive = mission.drive
        assert drive is not None
        drive.with_speed_from(0.0, 8.0, 8.0)
        return len(drive.vertices)

    assert benchmark(lay) == chunk + 1
