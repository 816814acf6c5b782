"""A JSON route that carries the convoy's plan: holds, speeds and laps, as a file, an
MQTT payload and the route the service forecasts the convoy along."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from convoy_mav.config import parse_config
from convoy_mav.tracks import load_planned_route, load_route
from convoy_mav.tracks.plannedroute import PlannedRoute
from convoy_mav.tracks.routejson import parse_route_json, planned_route

POINTS = [[47.40, 8.54], [47.41, 8.54], [47.41, 8.55], [47.40, 8.55]]


def route(**plan: Any) -> dict[str, Any]:
    return {"points": POINTS, **plan}


def test_a_route_without_a_plan_is_its_road_alone() -> None:
    got = planned_route(route())
    assert got == PlannedRoute(tuple(map(tuple, POINTS)))  # type: ignore[arg-type]
    assert not got.planned and got.remarks() == ""


def test_holds_and_speeds_as_lists_or_on_their_points() -> None:
    listed = planned_route(
        route(
            holds=[{"point": 2, "seconds": 90}, [1, 30.5]], speeds=[[0, 8], {"point": 2, "mps": 12}]
        )
    )
    assert listed.holds == ((1, 30.5), (2, 90.0))
    assert listed.speeds == ((0, 8.0), (2, 12.0))
    assert listed.remarks() == "2 holds, 120 s, 2 speeds, 8-12 m/s"
    own: list[dict[str, float]] = [{"lat": la, "lon": lo} for la, lo in POINTS]
    own[0]["mps"], own[1]["hold_s"] = 8.0, 30.5
    own[2] |= {"hold_s": 90, "mps": 12}
    assert planned_route({"points": own}) == listed
    # A hold of 0 s is none (as a waypoint's hold time of 0).
    assert planned_route(route(holds=[[1, 0]])).holds == ()


def test_a_circuit_is_closed_back_to_its_first_point() -> None:
    lap = planned_route(route(circuit=True, holds=[[0, 60]]))
    assert lap.circuit and lap.laps and lap.points[-1] == lap.points[0]
    assert len(lap.points) == len(POINTS) + 1 and lap.holds == ((0, 60.0),)
    assert lap.remarks() == "a circuit driven in laps, 1 holds, 60 s"
    closed = planned_route({"points": [*POINTS, POINTS[0]], "circuit": True})
    assert len(closed.points) == len(POINTS) + 1  # (already closed: not closed twice)


def test_geojson_keeps_its_plan_in_the_features_properties() -> None:
    line = {"type": "LineString", "coordinates": [[lo, la] for la, lo in POINTS]}
    props = {"name": "MSR Tampa", "holds": [[3, 45]], "speeds": [[0, 10]], "circuit": False}
    feature = {"type": "Feature", "properties": props, "geometry": line}
    want = planned_route(route(holds=[[3, 45]], speeds=[[0, 10]]))
    assert planned_route(feature) == want
    assert planned_route({"type": "FeatureCollection", "features": [feature]}) == want
    assert planned_route({**line, "holds": [[3, 45]], "speeds": [[0, 10]]}) == want
    assert not planned_route({**feature, "properties": None}).planned


@pytest.mark.parametrize(
    ("plan", "needle"),
    [
        ({"holds": [[4, 30]]}, "holds[0]: 'point' must be an index of the route's 4 points, got 4"),
        ({"holds": [[-1, 30]]}, "got -1"),
        ({"holds": [[1.0, 30]]}, "got 1.0"),
        ({"holds": [[True, 30]]}, "got True"),
        ({"holds": [{"seconds": 30}]}, "got None"),
        ({"holds": [[1, -5]]}, "holds[0]: seconds -5 is not from 0 to 86400"),
        ({"holds": [[1, 9e7]]}, "is not from 0 to 86400"),
        ({"holds": [[1, 30], [1, 40]]}, "holds[1]: point 1 is given two holds"),
        ({"holds": [{"point": 1}]}, "missing field 'seconds'"),
        ({"holds": [[1, "30"]]}, "must be a JSON number"),
        ({"holds": [[1, 30, 2]]}, 'must be {"point": i, "seconds": x} or [i, x]'),
        ({"holds": {"1": 30}}, "'holds' must be a list, got dict"),
        ({"speeds": [[0, 0]]}, "speeds[0]: mps 0 is not above 0 to 70"),
        ({"speeds": [[0, 90]]}, "mps 90 is not above 0 to 70"),
        ({"circuit": "yes"}, "'circuit' must be true or false, got 'yes'"),
    ],
)
def test_a_plan_that_is_not_one_says_why(plan: dict[str, Any], needle: str) -> None:
    with pytest.raises(ValueError, match=re.escape(needle)):
        planned_route(route(**plan))


def test_a_points_own_key_clashing_with_the_list_is_refused() -> None:
    own: list[dict[str, float]] = [{"lat": la, "lon": lo} for la, lo in POINTS]
    own[1]["hold_s"] = 30.0
    with pytest.raises(ValueError, match=re.escape("point 1's hold_s: point 1 is given two holds")):
        planned_route({"points": own, "holds": [[1, 20]]})
    with pytest.raises(ValueError, match=re.escape("point 1's mps: mps 0 is not above 0")):
        own[1]["mps"] = 0
        planned_route({"points": own})


def test_a_route_file_brings_its_plan_and_names_itself_in_errors(tmp_path: Path) -> None:
    path = tmp_path / "msr.geojson"
    path.write_text(json.dumps(route(holds=[[2, 90]], circuit=True)))
    got = load_planned_route(path)
    assert got.holds == ((2, 90.0),) and got.circuit
    lats, _ = load_route(path)
    assert len(lats) == len(POINTS) + 1  # (the lap's drive back)
    path.write_text(json.dumps(route(speeds=[[9, 8]])))
    with pytest.raises(ValueError, match=re.escape(f"{path}: speeds[0]: 'point' must be")):
        load_planned_route(path)
    gpx = tmp_path / "road.gpx"
    gpx.write_text(
        '<gpx version="1.1"><rte>'
        + "".join(f'<rtept lat="{la}" lon="{lo}"/>' for la, lo in POINTS)
        + "</rte></gpx>"
    )
    assert not load_planned_route(gpx).planned  # (a GPX route carries the road alone)
    assert parse_route_json(json.dumps(route()), "x").points == load_planned_route(gpx).points


def test_a_json_route_file_flies_with_its_plan(tmp_path: Path) -> None:
    """``[convoy] route``: a dispatcher's route with two stops and a speed, each placed on
    the road by the distance driven to its point, and the report naming the plan."""
    from convoy_mav.app import ConvoyService
    from convoy_mav.mission.road import RoadMission

    path = tmp_path / "convoy.json"
    path.write_text(json.dumps(route(holds=[[1, 45], [3, 120]], speeds=[[2, 11]])))
    doc = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}, "convoy": {"route": str(path)}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    cfg = parse_config(doc)
    service = ConvoyService(cfg)
    assert service._route_source == "file (2 holds, 165 s, 1 speeds, 11 m/s)"
    assert isinstance(service.mission, RoadMission)
    model = service.mission.model
    (first, h1), (last, h3) = model._holds
    ((turn, pace),) = model._paces
    legs = [1112.0, 753.0, 1112.0]  # (0.01° of latitude, then of longitude at 47.41° N)
    assert (h1, h3, pace) == (45.0, 120.0, 11.0)
    assert first == pytest.approx(legs[0], abs=25.0)
    assert turn == pytest.approx(legs[0] + legs[1], abs=40.0)
    assert last == pytest.approx(sum(legs), abs=60.0)


def test_an_mqtt_route_brings_its_plan_to_the_next_mission_step() -> None:
    from convoy_mav.app import ConvoyService
    from convoy_mav.publish import topics

    doc: dict[str, Any] = {"mission": {"sensor_radius_m": 100.0, "planner": "road"}}
    doc["uav"] = [{"connection": "udpin:127.0.0.1:14540", "sysid": 1}]
    service = ConvoyService(parse_config(doc))
    o = service.config.origin
    payload = {"points": [[o.lat, o.lon], [o.lat + 0.01, o.lon]], "holds": [[1, 30]]}
    service.set_route(topics.parse_convoy_route(json.dumps(payload)))
    ((road, holds, circuit, speeds, autopilot),) = service._new_routes
    assert not circuit and speeds == () and [h for _, h in holds] == [30.0]
    assert not autopilot  # (a plan given with a route: people drive it)
    assert holds[0][0] == pytest.approx(road.length, abs=5.0)
    assert service._route_source == "MQTT convoy/route (1 holds, 30 s)"
    service._new_routes.clear()  # (taken in)
    service.set_route(topics.parse_convoy_route(json.dumps(payload)))  # (republished)
    assert not service._new_routes  # (the route in force: left as it is)
    payload["holds"] = [[1, 45]]
    service.set_route(topics.parse_convoy_route(json.dumps(payload)))  # (a longer stop)
    assert len(service._new_routes) == 1 and service._new_routes[0][1][0][1] == 45.0
    assert any("from MQTT convoy/route (1 holds, 30 s): 2 points" in e for e in service.events)
