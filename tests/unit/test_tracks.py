"""Recorded convoy tracks: CSV, GPX and tlog readers, and the track's speeds.

tlog fixtures are written with the project's own ``TlogRecorder`` (injected clock)
and frames packed by ``MavCodec``: pymavlink's generated dialect, no hand-made bytes.
"""

from __future__ import annotations

import asyncio
import io
import itertools
import math
from collections import Counter
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.codec import MavCodec, Message
from convoy_mav.mavlink.tlog import read_tlog
from convoy_mav.recording import TlogRecorder
from convoy_mav.tracks import (
    GeoTrack,
    format_of,
    load_track,
    parse_gpx_track,
    parse_tlog_track,
    track_speeds,
)

ORIGIN = GeoPoint(47.0, 8.0)
FRAME = LocalFrame(ORIGIN)


def _geo(north: float, east: float) -> GeoPoint:
    return FRAME.to_geo(north, east)


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ------------------------------------------------------------------------- value, format


def test_geotrack_validates_and_rebases() -> None:
    with pytest.raises(ValueError, match="at least one"):
        GeoTrack((), (), ())
    with pytest.raises(ValueError, match=r"times\[1\]"):
        GeoTrack((0.0, 0.0), (47.0, 47.0), (8.0, 8.0))
    with pytest.raises(ValueError, match=r"lats\[0\]"):
        GeoTrack((0.0,), (math.nan,), (8.0,))
    with pytest.raises(ValueError, match="not a lat/lon"):
        GeoTrack((0.0,), (91.0,), (8.0,))
    track = GeoTrack((5.0, 7.5), (47.0, 47.1), (8.0, 8.0), "x.csv", "csv").rebased()
    assert track.times == (0.0, 2.5)
    assert track.epoch == 5.0
    assert track.duration == 2.5
    assert track.start == GeoPoint(47.0, 8.0)


@pytest.mark.parametrize(
    ("name", "fmt"), [("a.csv", "csv"), ("dir/B.GPX", "gpx"), ("c.tlog", "tlog")]
)
def test_format_from_the_extension(name: str, fmt: str) -> None:
    assert format_of(name) == fmt


def test_unknown_extension_asks_for_the_format(tmp_path: Path) -> None:
    path = _write(tmp_path, "track.txt", "0,47.0,8.0\n1,47.0001,8.0\n")
    with pytest.raises(ValueError, match=r"track\.txt: cannot tell the track format .*'txt'"):
        load_track(path)
    assert load_track(path, "csv").times == (0.0, 1.0)  # the override


def test_vehicle_ids_only_apply_to_a_tlog(tmp_path: Path) -> None:
    path = _write(tmp_path, "track.csv", "0,47.0,8.0\n")
    with pytest.raises(ValueError, match=r"track\.csv: vehicle system ids only apply to a tlog"):
        load_track(path, sysids=[6])


# -------------------------------------------------------------------------------- CSV


def test_csv_track_is_rebased_to_start_at_zero(tmp_path: Path) -> None:
    a, b = _geo(0.0, 0.0), _geo(300.0, -400.0)
    text = f"\ufefftime,lat,lon\n100,{a.lat!r},{a.lon!r}\n150,{b.lat!r},{b.lon!r}\n"  # Excel BOM
    track = load_track(_write(tmp_path, "convoy.csv", text))
    assert track.times == (0.0, 50.0)
    assert track.epoch == 100.0
    assert (track.source, track.format) == (str(tmp_path / "convoy.csv"), "csv")
    assert track.lats == (a.lat, b.lat)
    assert track_speeds(track).max_mps == pytest.approx(10.0, rel=1e-6)


@pytest.mark.parametrize(
    ("text", "where", "what"),
    [
        ("", "", "no data rows"),
        ("0,47.0,8.0\n1,47.0,nan\n", ":2", "finite"),
        ("0,47.0,8.0\n1,47.0\n", ":2", "got 2 field"),
        ("0,47.0,8.0\n1,forty,8.0\n", ":2", "must be numbers"),
    ],
)
def test_csv_errors_name_file_and_line(tmp_path: Path, text: str, where: str, what: str) -> None:
    path = _write(tmp_path, "convoy.csv", text)
    with pytest.raises(ValueError, match=rf"convoy\.csv{where}: .*{what}"):
        load_track(path)


@pytest.mark.parametrize(
    "text",
    [
        # exporters' names and units, other columns between
        "Latitude (deg),Longitude (deg),Altitude (m),time [s]\n"
        "47.0,8.0,400,100\n47.001,8.0,401,110\n",
        "ID,timestamp,lat_deg,lon_deg\n1,100,47.0,8.0\n2,110,47.001,8.0\n",
        # POSIX milliseconds, by name or by size
        "time_ms,lat,lon\n100000,47.0,8.0\n110000,47.001,8.0\n",
        "Time (ms),Lat,Lng\n100000,47.0,8.0\n110000,47.001,8.0\n",
        "timestamp,latitude,longitude\n1714557600000,47.0,8.0\n1714557610000,47.001,8.0\n",
        # ISO-8601 times, with a header or without, Z or an offset
        "time,lat,lon\n2024-05-01T10:00:00Z,47.0,8.0\n2024-05-01 12:00:10+02:00,47.001,8.0\n",
        "2024-05-01T10:00:00,47.0,8.0\n2024-05-01T10:00:10,47.001,8.0\n",
        # a spreadsheet's semicolons and decimal commas; tabs
        "Zeit;Lat;Lon;time\nx;47,0;8,0;100\ny;47,001;8,0;110\n",
        "time\tlat\tlon\n100\t47.0\t8.0\n110\t47.001\t8.0\n",
        "# logger v2\n\n100;47,0;8,0\n110;47,001;8,0\n",
    ],
)
def test_csv_tracks_as_loggers_and_spreadsheets_write_them(tmp_path: Path, text: str) -> None:
    track = load_track(_write(tmp_path, "convoy.csv", text))
    assert track.times == (0.0, 10.0)
    assert track.lats == (47.0, 47.001)
    assert track.lons == (8.0, 8.0)


def test_csv_times_of_one_kind_per_file(tmp_path: Path) -> None:
    mixed = "time,lat,lon\n2024-05-01T10:00:00Z,47.0,8.0\n10,47.001,8.0\n"
    with pytest.raises(ValueError, match=r"convoy\.csv:3: time '10' mixes ISO-8601 and numeric"):
        load_track(_write(tmp_path, "convoy.csv", mixed))
    bad = "time,lat,lon\nnoon,47.0,8.0\n"
    with pytest.raises(ValueError, match=r"convoy\.csv:2: time must be seconds or ISO-8601"):
        load_track(_write(tmp_path, "convoy.csv", bad))


# -------------------------------------------------------------------------------- GPX

GPX_11 = """<?xml version="1.0" encoding="UTF-8"?>
<gpx version="1.1" creator="test" xmlns="http://www.topografix.com/GPX/1/1"
     xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v1">
  <metadata><time>2020-01-01T00:00:00Z</time></metadata>
  <wpt lat="1.0" lon="1.0"><time>2020-01-01T00:00:00Z</time></wpt>
  <trk><name>convoy</name>
    <trkseg>
      <trkpt lat="{a.lat}" lon="{a.lon}"><ele>410.5</ele><time>2024-05-01T12:00:00Z</time>
        <extensions><gpxtpx:TrackPointExtension/></extensions></trkpt>
      <trkpt lat="{b.lat}" lon="{b.lon}"><time>2024-05-01T12:00:10.5Z</time></trkpt>
    </trkseg>
    <trkseg>
      <trkpt lat="{c.lat}" lon="{c.lon}"><time>2024-05-01T14:00:20+02:00</time></trkpt>
    </trkseg>
  </trk>
</gpx>
"""


def test_gpx_11_track_points_across_segments(tmp_path: Path) -> None:
    a, b, c = _geo(0.0, 0.0), _geo(0.0, 105.0), _geo(0.0, 200.0)
    path = _write(tmp_path, "drive.gpx", GPX_11.format(a=a, b=b, c=c))
    track = load_track(path)
    assert track.format == "gpx"
    assert track.times == pytest.approx((0.0, 10.5, 20.0))
    assert track.lons == pytest.approx((a.lon, b.lon, c.lon))
    assert track.epoch == pytest.approx(1714564800.0)  # 2024-05-01T12:00:00Z
    assert track_speeds(track).mean_mps == pytest.approx(10.0, rel=1e-3)
    assert track_speeds(track).heading_deg == pytest.approx(90.0)


def test_gpx_route_points_without_a_namespace() -> None:
    text = """<gpx version="1.0"><rte>
      <rtept lat="47.0" lon="8.0"><time>2024-05-01T12:00:00</time></rtept>
      <rtept lat="47.001" lon="8.0"><time>2024-05-01T12:01:00</time></rtept>
    </rte></gpx>"""
    track = parse_gpx_track(text.encode(), "route.gpx")
    assert track.times[1] - track.times[0] == 60.0
    assert track.lats == (47.0, 47.001)


_POINT = '<trkpt lat="47.0" lon="8.0"><time>2024-05-01T12:00:00Z</time></trkpt>'


def test_a_long_gpx_drive_is_parsed_as_it_is_read(tmp_path: Path) -> None:
    """Three hours at 1 Hz (2.6 MB): read in chunks, the same track as parsed whole."""
    points = "".join(
        f'<trkpt lat="{47.0 + k * 1e-5:.7f}" lon="8.0"><time>2024-05-01T'
        f"{12 + k // 3600:02d}:{k // 60 % 60:02d}:{k % 60:02d}Z</time></trkpt>\n"
        for k in range(10800)
    )
    text = f"<gpx><trk><trkseg>\n{points}</trkseg></trk></gpx>"
    path = _write(tmp_path, "long.gpx", text)
    reads: list[int] = []

    class Counted(io.BytesIO):
        def read(self, size: int | None = -1) -> bytes:
            reads.append(size or -1)
            return super().read(size)

    streamed = parse_gpx_track(Counted(text.encode()), "long.gpx")
    assert len(reads) > 10 and max(reads) < len(text) // 10  # (in chunks)
    assert streamed == parse_gpx_track(text.encode(), "long.gpx")
    assert load_track(path).times[-1] == 10799.0


@pytest.mark.parametrize(
    ("body", "where", "what"),
    [
        ("", ":1", "not well-formed GPX: no element found"),
        ('<gpx>\n<trk><trkseg>\n<trkpt lat="1"></trkseg></gpx>', ":3", "not well-formed"),
        ('<kml version="2.2"/>', ":1", "root element is <kml>, not <gpx>"),
        ("<gpx><trk/></gpx>", "", "no <trkpt> or <rtept> points"),
        (
            f'<gpx><trk><trkseg>{_POINT}\n<trkpt lat="47.1" lon="8.0"/></trkseg></trk></gpx>',
            ":2",
            "trkpt #2 has no <time>",
        ),
        ('<gpx><rte>\n<rtept lat="47" lon="8"/></rte></gpx>', ":2", "rtept #1 has no <time>"),
        ('<gpx><trk><trkseg>\n<trkpt lon="8.0"/></trkseg></trk></gpx>', ":2", "no lat attribute"),
        ('<gpx><trk><trkseg>\n<trkpt lat="x" lon="8"/></trkseg></trk></gpx>', ":2", "not a num"),
        ('<gpx><trk><trkseg>\n<trkpt lat="NaN" lon="8"/></trkseg></trk></gpx>', ":2", "finite"),
        ('<gpx><trk><trkseg>\n<trkpt lat="95" lon="8"/></trkseg></trk></gpx>', ":2", "latitude"),
        (
            '<gpx><trk><trkseg>\n<trkpt lat="47" lon="8"><time>noon</time></trkpt></trkseg></trk>'
            "</gpx>",
            ":2",
            "'noon' is not ISO-8601",
        ),
    ],
)
def test_gpx_errors_name_file_and_line(tmp_path: Path, body: str, where: str, what: str) -> None:
    path = _write(tmp_path, "drive.gpx", body)
    with pytest.raises(ValueError, match=rf"drive\.gpx{where}: .*{what}"):
        load_track(path)


# ------------------------------------------------------------------------------- tlog

Record = tuple[float, int, Message]  # (record stamp, sender sysid, message)


def _write_tlog(path: Path, records: list[Record]) -> Path:
    """Write ``records`` (sorted by stamp) through the service's own recorder."""

    async def write() -> None:
        now = [0.0]
        codecs: dict[int, MavCodec] = {}
        async with TlogRecorder(path, clock=lambda: now[0]) as recorder:
            for stamp, sysid, msg in sorted(records, key=lambda r: r[0]):
                now[0] = stamp
                codec = codecs.setdefault(sysid, MavCodec(sysid, 1))
                recorder.record(codec.pack(msg), link=3 if sysid == 255 else 0)

    asyncio.run(write())
    return path


def _heartbeat(mav_type: int) -> Message:
    return mavlink.MAVLink_heartbeat_message(
        mav_type, mavlink.MAV_AUTOPILOT_PX4, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
    )


def _fix(boot_s: float, point: GeoPoint) -> Message:
    return mavlink.MAVLink_global_position_int_message(
        round(boot_s * 1000), round(point.lat * 1e7), round(point.lon * 1e7), 0, 0, 0, 0, 0, 65535
    )


SPEEDUP = 10.0  # the vehicles' clocks run 10x faster than the recorder's stamps


def _convoy_log(end: float = 30.0) -> list[Record]:
    """Rovers 6 and 7 driving north at 5 m/s, 20 m apart, reporting out of phase.

    Rover 7 booted 100 s before rover 6 and its first report is "no fix yet" (0, 0);
    an aircraft (sysid 1) and our ground station (255) talk too.
    """

    def stamp(t: float) -> float:
        return 1000.0 + t / SPEEDUP

    records: list[Record] = [
        (stamp(0.0), 1, _heartbeat(mavlink.MAV_TYPE_FIXED_WING)),
        (stamp(0.0), 255, _heartbeat(mavlink.MAV_TYPE_GCS)),
        (stamp(0.01), 7, _fix(100.01, GeoPoint(0.0, 0.0))),
    ]
    for k in range(int(end * 5) + 1):
        t = k * 0.2
        if k % 5 == 0:
            records += [
                (stamp(t), 6, _heartbeat(mavlink.MAV_TYPE_GROUND_ROVER)),
                (stamp(t), 7, _heartbeat(mavlink.MAV_TYPE_GROUND_ROVER)),
                (stamp(t), 1, _fix(t, _geo(-500.0, 300.0 + t))),  # the aircraft: ignored
            ]
        records.append((stamp(t), 6, _fix(t, _geo(5.0 * t, 0.0))))
        t7 = t + 0.07
        records.append((stamp(t7), 7, _fix(100.0 + t7, _geo(5.0 * t7 - 20.0, 10.0))))
    records.append((stamp(10.01), 6, _fix(10.0, _geo(50.0, 0.0))))  # a duplicate: skipped
    return records


def test_tlog_convoy_is_the_centroid_of_the_ground_rovers(tmp_path: Path) -> None:
    path = _write_tlog(tmp_path / "drive.tlog", _convoy_log())
    track = parse_tlog_track(path.read_bytes(), "drive.tlog")
    assert track.format == "tlog"
    # On rover 6's clock, from rover 7's first real fix to rover 6's last, every 1 s.
    assert track.times[0] == pytest.approx(0.07, abs=1e-3)
    assert track.times[-1] == pytest.approx(30.0, abs=1e-3)
    assert track.times[1] - track.times[0] == pytest.approx(1.0)
    norths, easts = track.in_frame(FRAME)
    for t, north, east in zip(track.times, norths, easts, strict=True):
        assert (north, east) == pytest.approx((5.0 * t - 10.0, 5.0), abs=0.02)
    speeds = track_speeds(track)
    assert speeds.planning_mps == pytest.approx(5.0, abs=0.01)
    assert speeds.heading_deg == pytest.approx(0.0, abs=0.1)


def test_tlog_named_vehicles_and_rebasing(tmp_path: Path) -> None:
    path = _write_tlog(tmp_path / "drive.tlog", _convoy_log())
    track = load_track(path, sysids=[7])
    assert track.times[0] == 0.0
    assert track.epoch == pytest.approx(100.07, abs=1e-3)  # rover 7's own clock
    norths, _ = track.in_frame(FRAME)
    assert norths[0] == pytest.approx(5.0 * 0.07 - 20.0, abs=0.01)
    assert track.duration == pytest.approx(30.0, abs=1e-3)


def test_tlog_reader_counts_and_stamps(tmp_path: Path) -> None:
    records = _convoy_log(end=1.0)
    data = _write_tlog(tmp_path / "x.tlog", records).read_bytes()
    out = list(read_tlog(data))
    assert [r.number for r in out] == list(range(1, len(records) + 1))
    assert out[0].stamp == pytest.approx(1000.0)
    assert {r.link for r in out} == {0, 3}
    counters: Counter[str] = Counter()
    assert len(list(read_tlog(data[:-3], counters))) == len(records) - 1
    assert counters["truncated"] == 1


def _tlog_error(tmp_path: Path, records: list[Record], match: str, **kw: object) -> None:
    path = _write_tlog(tmp_path / "bad.tlog", records)
    with pytest.raises(ValueError, match=match):
        load_track(path, **kw)  # type: ignore[arg-type]


def test_tlog_empty_or_not_a_tlog(tmp_path: Path) -> None:
    (tmp_path / "empty.tlog").write_bytes(b"")
    with pytest.raises(ValueError, match=r"empty\.tlog: no MAVLink messages"):
        load_track(tmp_path / "empty.tlog")
    (tmp_path / "text.tlog").write_text("time,lat,lon\n0,47,8\n" * 20)
    with pytest.raises(ValueError, match=r"text\.tlog: no MAVLink messages"):
        load_track(tmp_path / "text.tlog")


def test_tlog_without_ground_vehicles(tmp_path: Path) -> None:
    records = [r for r in _convoy_log(5.0) if r[1] not in (6, 7)]
    _tlog_error(tmp_path, records, r"bad\.tlog: no ground vehicles: .*positions: 1\)")


def test_tlog_named_vehicle_without_fixes(tmp_path: Path) -> None:
    _tlog_error(tmp_path, _convoy_log(5.0), r"no GLOBAL_POSITION_INT from sysid 9", sysids=[6, 9])


def test_tlog_reboot_names_the_message(tmp_path: Path) -> None:
    records = [*_convoy_log(5.0), (1000.6, 6, _fix(0.5, _geo(30.0, 0.0)))]
    _tlog_error(tmp_path, records, r"bad\.tlog: message #\d+: sysid 6 .*went back .*reboot")


def test_tlog_fix_out_of_range(tmp_path: Path) -> None:
    bad = mavlink.MAVLink_global_position_int_message(
        9000, 950_000_000, 80_000_000, 0, 0, 0, 0, 0, 0
    )
    records = [*_convoy_log(5.0), (1000.95, 7, bad)]
    _tlog_error(tmp_path, records, r"message #\d+: sysid 7 GLOBAL_POSITION_INT: .*not a lat/lon")


def test_tlog_vehicles_that_never_overlap(tmp_path: Path) -> None:
    records: list[Record] = [
        (0.0, 6, _heartbeat(mavlink.MAV_TYPE_GROUND_ROVER)),
        (0.0, 7, _heartbeat(mavlink.MAV_TYPE_GROUND_ROVER)),
    ]
    records += [(float(t), 6, _fix(t, _geo(t, 0.0))) for t in range(10)]
    records += [(float(t), 7, _fix(t, _geo(t, 9.0))) for t in range(20, 30)]
    _tlog_error(tmp_path, records, r"fixes never overlap in time \(sysid 6 0\.0-9\.0 s")


# ----------------------------------------------------------------------------- speeds


def _track(samples: list[tuple[float, float, float]]) -> GeoTrack:
    points = [_geo(n, e) for _, n, e in samples]
    return GeoTrack(
        tuple(t for t, _, _ in samples), tuple(p.lat for p in points), tuple(p.lon for p in points)
    )


def test_speeds_of_a_straight_track() -> None:
    speeds = track_speeds(_track([(t, 0.0, 7.0 * t) for t in range(0, 301, 5)]))
    assert speeds.planning_mps == pytest.approx(7.0, rel=1e-6)
    assert speeds.max_mps == pytest.approx(7.0, rel=1e-6)
    assert speeds.heading_deg == pytest.approx(90.0)


def test_a_long_stop_sets_the_planning_speed_but_gps_jitter_does_not() -> None:
    jitter = [(float(t), 3.0 * (-1) ** t, 2.0 * (-1) ** (t // 2)) for t in range(0, 60)]
    drive = [(60.0 + t, 8.0 * t, 0.0) for t in range(1, 241)]
    speeds = track_speeds(_track(jitter + drive))  # parked 20 % of the time
    assert speeds.planning_mps < 0.5
    assert speeds.max_mps == pytest.approx(8.0, abs=0.8)
    short_stop = track_speeds(_track(jitter[:20] + [(20.0 + t, 8.0 * t, 0) for t in range(300)]))
    assert short_stop.planning_mps == pytest.approx(8.0, abs=0.01)  # 6 % parked: ignored


def test_speeds_of_one_fix_and_of_a_short_track() -> None:
    assert track_speeds(_track([(0.0, 0.0, 0.0)])).max_mps == 0.0
    short = track_speeds(_track([(0.0, 0.0, 0.0), (1.0, 3.0, 4.0), (2.0, 6.0, 8.0)]))
    assert (short.planning_mps, short.max_mps) == pytest.approx((5.0, 5.0))


def test_real_receiver_quirks_are_merged_and_counted_not_refused(tmp_path: Path) -> None:
    """Two fixes under one stamp, one earlier stamp: the CSV and GPX forms read alike."""
    csv_path = _write(
        tmp_path, "convoy.csv", "0,47.0,8.0\n1,47.0001,8.0\n1,47.0003,8.0\n0.5,47.0,8.0\n"
    )
    track = load_track(csv_path)
    assert track.times == (0.0, 1.0)
    assert track.lats[1] == pytest.approx(47.0002)
    assert (track.cleaning.merged, track.cleaning.out_of_order) == (1, 1)
    gpx = f"<gpx><trk><trkseg>{_POINT}\n{_POINT}</trkseg></trk></gpx>"
    track = load_track(_write(tmp_path, "convoy.gpx", gpx))
    assert len(track.times) == 1 and track.cleaning.merged == 1


def test_csv_rows_without_a_position_are_dropped_and_counted(tmp_path: Path) -> None:
    """A logger's rows before its receiver had a fix: a time, no latitude or longitude
    (empty or NaN); half a position is still an error."""
    text = "time,lat,lon\n0,,\n1,nan,NaN\n2,47.0,8.0\n3,47.0001,8.0\n4,,\n"
    track = load_track(_write(tmp_path, "convoy.csv", text))
    assert track.times == (0.0, 1.0)  # (rebased: the first fix at 2 s)
    assert track.cleaning.unfixed == 3 and track.cleaning.changed == 3
    assert track.cleaning.summary() == "3 rows without a position dropped"
    with pytest.raises(ValueError, match=r"no data rows with a position \(2 without\)"):
        load_track(_write(tmp_path, "nofix.csv", "time,lat,lon\n0,,\n1,,\n"))


def test_gpx_points_without_a_time_among_timed_ones_are_dropped_and_counted() -> None:
    """A point logged before the receiver knew the time, or added in an editor."""
    from convoy_mav.tracks.gpx import parse_gpx_track

    body = "".join(
        f'<trkpt lat="47.000{i}" lon="8.0">'
        + (f"<time>2024-05-01T12:00:0{i}Z</time>" if i % 2 else "")
        + "</trkpt>\n"
        for i in range(6)
    )  # fmt: skip
    track = parse_gpx_track(f"<gpx><trk><trkseg>\n{body}</trkseg></trk></gpx>", "t.gpx")
    assert track.times == (1714564801.0, 1714564803.0, 1714564805.0)
    assert track.cleaning.untimed == 3 and track.cleaning.changed == 3
    assert track.cleaning.summary() == "3 points without a time dropped"


_DRIVE = Path(__file__).resolve().parents[3] / "shared" / "tracks" / "istanbul_drive.gpx"


@pytest.mark.skipif(not _DRIVE.exists(), reason="the shared recorded drive is not beside the repo")
def test_the_recorded_drive_is_read_as_it_comes() -> None:
    """A real phone recording with fixes sharing a time stamp: read, not refused."""
    track = load_track(_DRIVE)
    assert track.cleaning.merged >= 1  # (it was refused for the pair sharing one stamp)
    assert len(track.times) > 2500 and 3600.0 < track.duration < 3800.0
    assert all(b > a for a, b in itertools.pairwise(track.times))


def test_a_route_needs_no_times(tmp_path: Path) -> None:
    """[convoy] route: GPX <rtept> without <time>, CSV lat,lon[,time], GeoJSON, JSON."""
    from convoy_mav.tracks import load_route

    def route(name: str, text: str) -> tuple[list[float], list[float]]:
        return load_route(_write(tmp_path, name, text))

    want = ([47.1, 47.2], [8.1, 8.2])
    gpx = '<gpx version="1.1"><rte><rtept lat="47.1" lon="8.1"/><rtept lat="47.2" lon="8.2"/>'
    assert route("r.gpx", gpx + "</rte></gpx>") == want
    assert route("r.csv", "# a route\n47.1,8.1\n47.2,8.2,60\n") == want
    assert route("n.csv", "lon,lat\n8.1,47.1\n8.2,47.2\n") == want
    with pytest.raises(ValueError, match=r"b.csv:1: expected columns lat,lon"):
        route("b.csv", "47.1\n")
    with pytest.raises(
        ValueError, match=r"a route is a \.gpx, \.csv, \.geojson, \.kml/\.kmz, \.plan"
    ):
        load_route(tmp_path / "x.tlog")
    drawn = (  # as geojson.io saves a line drawn on the map
        '{"type": "FeatureCollection", "features": [{"type": "Feature", "properties": {}, '
        '"geometry": {"type": "LineString", "coordinates": [[8.1, 47.1], [8.2, 47.2]]}}]}'
    )
    assert route("msr.geojson", drawn) == want
    assert route("r.json", '{"points": [[47.1, 8.1], [47.2, 8.2]]}') == want
    with pytest.raises(ValueError, match=r"r\.json: a route needs 'points'"):
        route("r.json", '{"points": [[47.1, 8.1]]}')
    with pytest.raises(ValueError, match=r"r\.json: not JSON"):
        route("r.json", "{")


KML_ROUTE = """<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2">
<Document><name>convoy</name>
  <Placemark><name>start</name><Point><coordinates>8.1,47.1,0</coordinates></Point></Placemark>
  <Placemark><name>MSR</name><LineString><tessellate>1</tessellate>
    <coordinates>
      8.1,47.1,0 8.15,47.15,0
      8.2,47.2
    </coordinates>
  </LineString></Placemark>
</Document></kml>
"""


def test_a_route_drawn_in_google_earth_or_qgroundcontrol(tmp_path: Path) -> None:
    """KML (one LineString or gx:Track; points ignored), and KMZ, the zipped KML."""
    import zipfile

    from convoy_mav.tracks import load_route

    want = ([47.1, 47.15, 47.2], [8.1, 8.15, 8.2])
    kml = tmp_path / "msr.kml"
    kml.write_text(KML_ROUTE)
    assert load_route(kml) == want
    kmz = tmp_path / "msr.kmz"
    with zipfile.ZipFile(kmz, "w") as z:
        z.writestr("files/icon.png", b"")
        z.writestr("doc.kml", KML_ROUTE)
    assert load_route(kmz) == want
    track = tmp_path / "track.kml"
    track.write_text(
        '<kml xmlns:gx="http://www.google.com/kml/ext/2.2"><Placemark><gx:Track>'
        "<when>2024-05-01T12:00:00Z</when><gx:coord>8.1 47.1 0</gx:coord>"
        "<gx:coord>8.2 47.2 0</gx:coord></gx:Track></Placemark></kml>"
    )
    assert load_route(track) == ([47.1, 47.2], [8.1, 8.2])


@pytest.mark.parametrize(
    ("text", "what"),
    [
        (KML_ROUTE.replace("</Document>", "<Placemark><LineString><coordinates>8,47 9,47"
                           "</coordinates></LineString></Placemark></Document>"),
         r"a route is one <LineString> or <gx:Track>, found 2 \(lines 5, 11\)"),
        ("<kml><Placemark><Point><coordinates>8,47</coordinates></Point></Placemark></kml>",
         "found 0"),
        (KML_ROUTE.replace("8.2,47.2", "8.2,north"), r"msr\.kml:8: coordinate '8.2,north'"),
        (KML_ROUTE.replace("8.2,47.2", "8.2,95"), r"msr\.kml:8: .*latitude"),
        (KML_ROUTE.replace("8.1,47.1,0 8.15,47.15,0\n      8.2,47.2", "8.1,47.1"),
         r"msr\.kml:5: a path needs two points or more, got 1"),
        ("<gpx/>", r"msr\.kml:1: the root element is <gpx>, not <kml>"),
        ("<kml><Document>", r"msr\.kml:1: not well-formed KML"),
    ],
)  # fmt: skip
def test_kml_route_errors_name_file_and_line(tmp_path: Path, text: str, what: str) -> None:
    from convoy_mav.tracks import load_route

    kml = tmp_path / "msr.kml"
    kml.write_text(text)
    with pytest.raises(ValueError, match=what):
        load_route(kml)


KML_DRIVE = """<?xml version="1.0" encoding="UTF-8"?>
<kml xmlns="http://www.opengis.net/kml/2.2" xmlns:gx="http://www.google.com/kml/ext/2.2">
<Document><Placemark><name>drive</name><gx:Track>
  <when>2024-05-01T12:00:00Z</when>
  <when>2024-05-01T12:00:10Z</when>
  <when>2024-05-01T14:00:20+02:00</when>
  <gx:coord>8.0 47.0 410</gx:coord>
  <gx:coord>8.0 47.001 410</gx:coord>
  <gx:coord>8.0 47.002 411</gx:coord>
</gx:Track></Placemark></Document></kml>
"""


def test_a_kml_drive_is_a_track_and_a_kmz_one_too(tmp_path: Path) -> None:
    """Phone loggers and Google Earth write a drive as a gx:Track: replayed as GPX is."""
    import zipfile

    track = load_track(_write(tmp_path, "drive.kml", KML_DRIVE))
    assert track.times == (0.0, 10.0, 20.0)
    assert track.lats == (47.0, 47.001, 47.002)
    assert track.format == "kml"
    kmz = tmp_path / "drive.kmz"
    with zipfile.ZipFile(kmz, "w") as z:
        z.writestr("doc.kml", KML_DRIVE)
    assert load_track(kmz).times == (0.0, 10.0, 20.0)
    assert format_of("x.KMZ") == "kml"


@pytest.mark.parametrize(
    ("text", "what"),
    [
        (KML_ROUTE, r"a recorded track is one <gx:Track> with <when> times, found 0"),
        (KML_DRIVE.replace("<when>2024-05-01T12:00:10Z</when>", ""),
         r"drive\.kml:3: <gx:Track> has 2 <when> for 3 <gx:coord>"),
        (KML_DRIVE.replace("2024-05-01T12:00:10Z", "noon"), r"drive\.kml:5: <when> 'noon'"),
    ],
)  # fmt: skip
def test_kml_track_errors_name_file_and_line(tmp_path: Path, text: str, what: str) -> None:
    with pytest.raises(ValueError, match=what):
        load_track(_write(tmp_path, "drive.kml", text))


def test_a_kmz_without_a_kml_inside(tmp_path: Path) -> None:
    import zipfile

    from convoy_mav.tracks import load_route

    kmz = tmp_path / "x.kmz"
    with zipfile.ZipFile(kmz, "w") as z:
        z.writestr("readme.txt", "")
    with pytest.raises(ValueError, match=r"x\.kmz: a KMZ with no \.kml document inside"):
        load_route(kmz)
    kmz.write_text("not a zip")
    with pytest.raises(ValueError, match=r"x\.kmz: not a KMZ \(zip\) file"):
        load_route(kmz)
    from convoy_mav.tracks.kml import kmz_document

    with zipfile.ZipFile(kmz, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("doc.kml", " " * 10_000)  # (a bomb, scaled down)
    with pytest.raises(ValueError, match=r"doc\.kml unzips to 10000 bytes, over the 1000"):
        kmz_document(kmz.read_bytes(), "x.kmz", max_bytes=1000)


def test_a_track_past_the_size_bound_is_refused_unread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from convoy_mav import tracks

    big = tmp_path / "huge.gpx"
    big.write_bytes(b"<gpx>" + b" " * 2048 + b"</gpx>")
    monkeypatch.setattr(tracks, "MAX_TRACK_BYTES", 1024)
    with pytest.raises(ValueError, match="exceeds the 0 MiB"):
        tracks.load_track(big)
    with pytest.raises(ValueError, match="exceeds"):
        tracks.load_route(big)
