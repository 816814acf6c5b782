"""Ground-truth scoring."""

from __future__ import annotations

from pathlib import Path

import pytest

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.scoring import TruthFix, read_truth_csv, score_truth

ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)
FRAME = LocalFrame(ORIGIN)


def fix(t: float, sysid: int, kind: str, north: float, east: float, alive: bool = True) -> TruthFix:
    p = FRAME.to_geo(north, east)
    return TruthFix(t, sysid, kind, p.lat, p.lon, alive)


def test_centroid_of_ground_vehicles_and_killed_aircraft() -> None:
    rows = []
    for k in range(11):
        t = float(k)
        # Two trucks 40 m apart: centroid at (0, 0); the UAV sits 15 m from it.
        rows += [fix(t, 9, "ground", 20.0, 0.0), fix(t, 10, "ground", -20.0, 0.0)]
        rows.append(fix(t, 1, "aircraft", 0.0, 15.0, alive=k < 6))
    stats = score_truth(rows, ORIGIN, sensor_radius=16.0, start=0.0)
    assert stats.elapsed_s == 10.0
    assert stats.covered_s == pytest.approx(6.0)  # covered through t = 6, killed after
    assert stats.longest_gap_s == pytest.approx(4.0)
    # The window excludes what comes before `start`.
    assert score_truth(rows, ORIGIN, 16.0, start=7.0).covered_s == 0.0


def test_read_truth_csv(tmp_path: Path) -> None:
    p = FRAME.to_geo(10.0, 0.0)
    path = tmp_path / "truth.csv"
    path.write_text(
        "t,sysid,kind,lat,lon,alt,north,east,down,vn,ve,vd,yaw,speed,yaw_rate,armed,mode\n"
        f"0.0,1,aircraft,{p.lat},{p.lon},588,10,0,-100,0,0,0,0,18,0,1,OFFBOARD\n"
        f"0.0,2,ground,{ORIGIN.lat},{ORIGIN.lon},488,0,0,0,0,0,0,0,0,0,1,GUIDED\n"
        f"0.1,1,aircraft,{p.lat},{p.lon},588,10,0,-100,0,0,0,0,18,0,0,KILLED\n"
    )
    rows = list(read_truth_csv(path))
    assert [r.kind for r in rows] == ["aircraft", "ground", "aircraft"]
    assert rows[0].alive and not rows[2].alive
    assert all(r.airborne for r in rows)  # a CSV without the column: as before


def test_an_aircraft_on_the_ground_covers_nothing(tmp_path: Path) -> None:
    """An ArduPlane armed on the runway beside the convoy sees nothing of it."""
    p = FRAME.to_geo(10.0, 0.0)
    path = tmp_path / "truth.csv"
    head = "t,sysid,kind,lat,lon,alt,north,east,down,vn,ve,vd,yaw,speed,yaw_rate,armed,mode"
    lines = [head + ",airborne"]
    for i in range(11):
        t = i * 0.1
        up = int(i >= 5)  # on the runway for half a second, then flying
        lines.append(f"{t},1,aircraft,{p.lat},{p.lon},488,10,0,0,0,0,0,0,0,0,1,GUIDED,{up}")
        lines.append(f"{t},2,ground,{ORIGIN.lat},{ORIGIN.lon},488,0,0,0,0,0,0,0,0,0,1,GUIDED,0")
    path.write_text("\n".join(lines) + "\n")
    rows = list(read_truth_csv(path))
    assert [r.airborne for r in rows if r.kind == "aircraft"] == [False] * 5 + [True] * 6
    stats = score_truth(rows, ORIGIN, 100.0, start=0.0)
    assert stats.fraction == pytest.approx(0.5, abs=0.01)
    assert rows[0].lat == pytest.approx(p.lat)


def test_the_truth_convoy_is_the_leads_group_a_parted_truck_left_out() -> None:
    """The lead drives on north at 8 m/s, its follower stands at the start; a UAV over
    the lead covers the convoy once the follower has parted (200 m off), and the
    centroid of the two (no part distance) is seen by no one by then."""
    rows = []
    for k in range(61):
        t = float(k)
        rows += [fix(t, 7, "ground", 8.0 * t, 0.0), fix(t, 8, "ground", 0.0, 0.0)]
        rows.append(fix(t, 1, "aircraft", 8.0 * t, 0.0))
    parted = score_truth(rows, ORIGIN, 100.0, start=0.0, lead=7, part_m=200.0)
    together = score_truth(rows, ORIGIN, 100.0, start=0.0)
    # Together until 200 m apart (t = 25): the centroid 100 m behind the lead, just seen.
    assert parted.fraction == pytest.approx(1.0)
    assert together.covered_s == pytest.approx(25.0, abs=1.0)
    # Led by the one that stands: the convoy is it, and the UAV over the other sees none.
    led_by_stood = score_truth(rows, ORIGIN, 100.0, start=0.0, lead=8, part_m=200.0)
    assert led_by_stood.covered_s == pytest.approx(25.0, abs=1.0)  # (the centroid, until
    # it parts: then the stood truck alone, 200 m from the UAV)


def test_a_truck_whose_mode_says_it_left_is_not_the_convoy_however_near(tmp_path: Path) -> None:
    """Its operator's HOLD while the lead drives its mission: out of the convoy at once,
    as the service parts it; the CSV's mode column says it too."""
    from dataclasses import replace

    from convoy_mav.types import ConvoyDrive

    rows = []
    for k in range(11):
        t = float(k)
        lead = replace(fix(t, 7, "ground", 0.0, 0.0), drive=ConvoyDrive.MISSION)
        held = replace(fix(t, 8, "ground", -60.0, 0.0), drive=ConvoyDrive.HELD)
        rows += [lead, held, fix(t, 1, "aircraft", 0.0, 50.0)]  # (the lead's 50 m off)
    # A camera of 55 m: the lead, 50 m off, is seen; the centroid of the two, 58 m off, not.
    assert score_truth(rows, ORIGIN, 55.0, start=0.0, lead=7, part_m=200.0).fraction == 1.0
    undriven = [replace(r, drive=None) for r in rows]  # (modes not known: together)
    assert score_truth(undriven, ORIGIN, 55.0, start=0.0, lead=7, part_m=200.0).covered_s == 0.0
    head = "t,sysid,kind,lat,lon,alt,north,east,down,vn,ve,vd,yaw,speed,yaw_rate,armed,mode"
    p = FRAME.to_geo(0.0, 0.0)
    path = tmp_path / "truth.csv"
    path.write_text(
        f"{head}\n0.0,8,ground,{p.lat},{p.lon},488,0,0,0,0,0,0,0,0,0,1,HOLD\n"
        f"0.0,9,ground,{p.lat},{p.lon},488,0,0,0,0,0,0,0,0,0,0,AUTO\n"
        f"0.0,1,aircraft,{p.lat},{p.lon},588,0,0,-100,0,0,0,0,18,0,1,AUTO\n"
    )
    drives = [r.drive for r in read_truth_csv(path)]
    assert drives == [ConvoyDrive.HELD, ConvoyDrive.HELD, None]
