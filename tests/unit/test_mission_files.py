"""A rover's mission saved by a ground station as the convoy's route (``tracks.missionfile``):
QGC WPL 110 (Mission Planner, MAVProxy) and QGroundControl's ``.plan``, read through
``load_route`` as ``[convoy] route`` reads them."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from convoy_mav.config import parse_config
from convoy_mav.tracks import load_route
from convoy_mav.tracks.missionfile import parse_plan, parse_waypoints

HOME = (47.397742, 8.545594)
ROAD = [(47.3990, 8.5456), (47.3990, 8.5490), (47.4010, 8.5490)]

# As Mission Planner saves an ArduRover mission: home, a speed change, the road, RTL.
WPL = "\n".join(
    [
        "QGC WPL 110",
        f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]}\t{HOME[1]}\t488.0\t1",
        "1\t0\t3\t178\t1\t6\t-1\t0\t0\t0\t0\t1",
        *(f"{k + 2}\t0\t3\t16\t0\t0\t0\t0\t{la}\t{lo}\t0\t1" for k, (la, lo) in enumerate(ROAD)),
        "5\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1",
    ]
)


def simple(command: int, lat: float | None, lon: float | None, frame: int = 3) -> dict[str, Any]:
    return {
        "type": "SimpleItem", "command": command, "frame": frame, "autoContinue": True,
        "doJumpId": 1, "params": [0, 0, 0, None, lat, lon, 0],
    }  # fmt: skip


def plan(items: list[dict[str, Any]]) -> bytes:
    """A QGroundControl plan as it saves one (a rover's: vehicleType 10)."""
    doc = {
        "fileType": "Plan", "groundStation": "QGroundControl", "version": 1,
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "rallyPoints": {"points": [], "version": 2},
        "mission": {
            "cruiseSpeed": 8, "firmwareType": 3, "vehicleType": 10, "version": 2,
            "plannedHomePosition": [HOME[0], HOME[1], 488], "items": items,
        },
    }  # fmt: skip
    return json.dumps(doc).encode()


def rounded(points: Any) -> list[tuple[float, float]]:
    return [(round(a, 6), round(b, 6)) for a, b in points]


def test_a_waypoints_file_is_its_road_and_the_way_home() -> None:
    route = parse_waypoints(WPL, "drive.waypoints")
    assert rounded(route.points) == rounded([*ROAD, HOME])
    assert route.skipped == 0 and not route.laps
    assert route.speeds == ((0, 6.0),)  # (DO_CHANGE_SPEED 6 m/s before the first waypoint)
    spaced = WPL.replace("\t", "  ")  # (MAVProxy's files are read either way)
    assert parse_waypoints(spaced, "x.txt").points == route.points


@pytest.mark.parametrize(
    ("text", "error"),
    [
        ("QGC WPL 120\n", r"x.waypoints:1: not a waypoints file"),
        ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t47.3\t8.5\t0\n", r"x.waypoints:2: 11 fields"),
        ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnorth\t8.5\t0\t1\n", r"x.waypoints:2: a field"),
        ("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\tnan\t8.5\t0\t1\n", r"x.waypoints:2: nan"),
        (WPL.split("\n1\t")[0] + "\n", r"x.waypoints: the mission drives to 0 distinct"),
    ],
)
def test_a_bad_waypoints_file_names_its_line(text: str, error: str) -> None:
    with pytest.raises(ValueError, match=error):
        parse_waypoints(text, "x.waypoints")


def test_a_qgroundcontrol_plan_is_its_simple_items_and_home_from_the_plan() -> None:
    survey = {"type": "ComplexItem", "complexItemType": "survey", "version": 5}
    items = [
        simple(178, None, None, frame=2),  # DO_CHANGE_SPEED: no position
        *(simple(16, la, lo) for la, lo in ROAD),
        survey,
        simple(20, None, None, frame=2),  # return to launch: plannedHomePosition
    ]
    route = parse_plan(plan(items), "drive.plan")
    assert rounded(route.points) == rounded([*ROAD, HOME])
    assert route.skipped == 1 and route.remarks().startswith("1 items left out")


@pytest.mark.parametrize(
    ("data", "error"),
    [
        (b"{not json", r"p.plan: not a QGroundControl plan \(not JSON"),
        (b'{"mission": {}}', r"p.plan: not a QGroundControl plan: no mission.items"),
        (plan([{"type": "SimpleItem", "command": "16", "frame": 3, "params": []}]),
         r"p.plan: mission.items\[0\]: command and frame must be integers"),
        (plan([{**simple(16, 47.4, 8.5), "params": [0, 0, 0]}]),
         r"mission.items\[0\]: params must be a list of seven"),
        (plan([{**simple(16, 47.4, 8.5), "params": [0, 0, 0, 0, "n", 8.5, 0]}]),
         r"mission.items\[0\]: a parameter is not a number"),
        (plan([simple(16, 47.4, 8.5)]), r"p.plan: the mission drives to 1 distinct"),
    ],
)  # fmt: skip
def test_a_bad_plan_names_its_item(data: bytes, error: str) -> None:
    with pytest.raises(ValueError, match=error):
        parse_plan(data, "p.plan")


def test_route_files_saved_by_ground_stations_are_routes(tmp_path: Path) -> None:
    """``[convoy] route`` takes them as it takes a GPX: by the extension, or a .txt by its
    first line (MAVProxy's ``wp save``)."""
    (tmp_path / "a.waypoints").write_text(WPL)
    (tmp_path / "b.txt").write_text(WPL)
    (tmp_path / "c.plan").write_bytes(plan([simple(16, la, lo) for la, lo in ROAD]))
    for name, expected in (("a.waypoints", [*ROAD, HOME]), ("b.txt", [*ROAD, HOME]),
                           ("c.plan", ROAD)):  # fmt: skip
        lats, lons = load_route(tmp_path / name)
        assert rounded(zip(lats, lons, strict=True)) == rounded(expected), name
    (tmp_path / "d.txt").write_text("notes\n")
    with pytest.raises(ValueError, match=r"d.txt: cannot tell the track format"):
        load_route(tmp_path / "d.txt")


def test_a_plan_flies_as_the_route_of_a_mission(tmp_path: Path) -> None:
    from convoy_mav.app import ConvoyService

    path = tmp_path / "rover.plan"
    path.write_bytes(plan([simple(16, la, lo) for la, lo in ROAD]))
    doc = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}, "convoy": {"route": str(path)}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    service = ConvoyService(parse_config(doc))
    assert service.route is not None
    assert service.route.length == pytest.approx(262.0 + 222.0, rel=0.1)


def test_a_saved_patrol_flies_as_a_circuit_with_its_holds(tmp_path: Path) -> None:
    """A QGroundControl plan: a way out, a lap of three corners with a hold at the first,
    and a DO_JUMP back to it for ever (by its doJumpId, as QGC saves it)."""
    from convoy_mav.app import ConvoyService
    from convoy_mav.mission.road import RoadMission

    items = [simple(16, la, lo) for la, lo in ROAD]
    items.append(simple(16, 47.4010, 8.5456))
    for k, item in enumerate(items):
        item["doJumpId"] = k + 1
    items[1]["params"][0] = 30.0  # the lap's first corner: a hold of 30 s
    jump = simple(177, None, None, frame=2) | {"doJumpId": len(items) + 1}
    jump["params"][:2] = [2, -1]  # (to doJumpId 2, for ever)
    path = tmp_path / "patrol.plan"
    path.write_bytes(plan([*items, jump]))
    route = parse_plan(path.read_bytes(), "patrol.plan")
    assert route.circuit and rounded(route.points) == rounded(
        [*ROAD[1:], (47.4010, 8.5456), ROAD[1]]
    )
    assert route.holds == ((0, 30.0),)
    doc = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}, "convoy": {"route": str(path)}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    service = ConvoyService(parse_config(doc))
    assert service._route_source == "file (a circuit driven in laps, 1 holds, 30 s)"
    assert isinstance(service.mission, RoadMission)
    model = service.mission.model
    assert model._circuit and len(model._holds) == 1 and model._holds[0][0] < 10.0
