"""A road mission's inputs recorded and replayed: the same plans, to the last bit."""

from __future__ import annotations

import dataclasses
import math
import pickle
from pathlib import Path

import pytest

from convoy_mav.mission.recording import MissionRecording, load_recording
from convoy_mav.mission.road import RoadMission, RoadSettings
from convoy_mav.mission.simulate import fly_road
from convoy_mav.planning import PlanRequest
from convoy_mav.planning.road import Road
from convoy_mav.tracks.roads import corner
from convoy_mav.types import ConvoyDrive

REQUEST = PlanRequest(150.0, 100.0, 18.0)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[float, MissionRecording]:
    """A 60-degree corner nobody foresaw, flown with the mission's inputs recorded,
    saved and read back."""
    t, north, east = corner(-60.0, 300.0, then_s=120.0)
    run = fly_road(t, north, east, REQUEST, 6, record=True)
    assert run.recording is not None and run.predicted_coverage is not None
    path = tmp_path_factory.mktemp("recording") / "mission.inputs"
    run.recording.save(path)
    return run.predicted_coverage, load_recording(path)


def test_a_replay_makes_the_plans_the_flight_made(
    recorded: tuple[float, MissionRecording],
) -> None:
    predicted, recording = recorded
    methods = {method for method, _ in recording.calls}
    assert methods == {"on_convoy", "join_many", "tick"}
    assert len(recording.calls) > 1000
    replay = RoadMission.replayed(recording)
    # Predicted coverage integrates every UAV's planned path over the whole flight:
    # equal to the last bit only if every re-plan was.
    assert replay.predicted_coverage == predicted
    again = RoadMission.replayed(recording)
    assert again.uav_replans == replay.uav_replans > 0
    for u in recording.uav_ids:
        for t in (250.0, 305.0, 380.0):
            assert again.setpoint(u, t) == replay.setpoint(u, t)


def test_a_replay_until_a_time_is_the_mission_as_it_was_then(
    recorded: tuple[float, MissionRecording],
) -> None:
    _, recording = recorded
    before = RoadMission.replayed(recording, until=290.0)
    assert before.protect_start is not None and before.protect_start < 290.0
    rest = recording.calls[len(recording.inputs(until=290.0)) :]
    assert rest and all(method != "set_route" for method, _ in rest)
    for method, args in rest:
        getattr(before, method)(*args)
    assert before.predicted_coverage == RoadMission.replayed(recording).predicted_coverage


def test_a_refused_join_is_not_recorded_and_other_files_are_no_recording(
    tmp_path: Path,
) -> None:
    mission = RoadMission(REQUEST, [1, 2], down=lambda _u: -100.0, record=True)
    assert mission.recording is not None
    with pytest.raises(ValueError, match="not live"):
        mission.join_many({3: (0.0, 0.0, 0.0)}, 0.0)
    assert mission.recording.calls == []
    other = tmp_path / "other.pkl"
    other.write_bytes(pickle.dumps({"format": 99}))
    with pytest.raises(ValueError, match="not a convoy-mav mission recording"):
        load_recording(other)
    assert RoadMission(REQUEST, [1], down=lambda _u: -100.0).recording is None


def test_a_recording_from_before_a_setting_was_added_replays_with_its_default(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An older build pickled one setting fewer (the last one, added since): the replay
    gets it at its default instead of failing on it (``RoadSettings.__setstate__``)."""

    def older(self: RoadSettings) -> list[object]:
        return [getattr(self, f.name) for f in dataclasses.fields(self)][:-1]

    monkeypatch.setattr(RoadSettings, "__getstate__", older)
    recording = MissionRecording(
        REQUEST, [1, 2], {1: -100.0, 2: -100.0}, None, RoadSettings(keep_margin_s=0.75)
    )
    path = tmp_path / "old.inputs"
    recording.save(path)
    monkeypatch.undo()
    loaded = load_recording(path)
    assert loaded.settings == RoadSettings(keep_margin_s=0.75)
    assert RoadMission.replayed(loaded).settings == loaded.settings


def test_a_lag_scaled_replay_is_the_flight_on_a_host_a_little_slower(
    recorded: tuple[float, MissionRecording],
) -> None:
    """Scaled by 1 the replay is the flight; scaled, only the lags told change, and the
    re-plans start further along each UAV's path: other plans, the same inputs else."""
    predicted, recording = recorded
    assert RoadMission.replayed(recording.with_lag_scaled(1.0)).predicted_coverage == predicted
    lagged = dataclasses.replace(recording, calls=[("set_replan_lag", (0.5, 0.05))])
    lagged.calls += recording.calls
    slower = lagged.with_lag_scaled(2.0)
    assert slower.calls[0] == ("set_replan_lag", (1.0, 0.1))
    assert slower.calls[1:] == recording.calls and lagged.calls[0][1] == (0.5, 0.05)
    a, b = RoadMission.replayed(lagged), RoadMission.replayed(slower)
    assert any(a.setpoint(u, 400.0) != b.setpoint(u, 400.0) for u in recording.uav_ids)
    with pytest.raises(ValueError, match="factor"):
        recording.with_lag_scaled(math.nan)


def test_the_lead_vehicles_modes_are_recorded_and_replayed() -> None:
    """A mission's holds, its rover held by its operator through one (HOLD, then AUTO):
    the modes are inputs too, stamped with their time."""
    t, north, east = corner(-60.0, 300.0, then_s=120.0)
    route = Road.from_points(east, north)
    drives = [(150.0, ConvoyDrive.HELD), (200.0, ConvoyDrive.MISSION)]
    run = fly_road(
        t, north, east, REQUEST, 6, route=route, holds=[(400.0, 30.0)], drives=drives,
        record=True,
    )  # fmt: skip
    assert run.recording is not None
    told = [args for method, args in run.recording.calls if method == "set_drive"]
    assert [d for d, _ in told] == [ConvoyDrive.HELD, ConvoyDrive.MISSION]
    assert [when for _, when in told] == pytest.approx([150.0, 200.0], abs=0.5)
    replay = RoadMission.replayed(run.recording)
    assert replay.model.drive is ConvoyDrive.MISSION
    assert replay.predicted_coverage == run.predicted_coverage
    assert RoadMission.replayed(run.recording, until=180.0).model.drive is ConvoyDrive.HELD
