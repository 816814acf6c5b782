"""Mock configuration: a TOML file plus command-line overrides -> :class:`MockConfig`.

The file and the flags speak one schema (a nested mapping), so the CLI is just
another layer merged on top of the file before validation. Every error is a
:class:`~convoy_mav.errors.ConfigError` naming the dotted key and the offending
value; unknown keys are errors too, so a typo never silently means "default".

Schema (every key optional)::

    speedup = 1.0                     # sim seconds per wall second
    base_port = 14540                 # sysid i listens on base_port + i - 1 (0: any free port)
    host = "127.0.0.1"
    origin = [47.397742, 8.545594, 488.0]   # world NED origin (lat, lon, alt)
    gcs = "udp:127.0.0.1:14550"       # also push all traffic here
    truth = "out/truth.csv"           # truth log file
    truth_rate = 10.0                 # Hz of sim time
    physics_rate = 100.0              # Hz of sim time

    [aircraft]                        # defaults for every aircraft
    count = 1
    personality = "px4"               # or "ardupilot"
    frame = "plane"                   # or "copter"
    airspeed = 18.0
    turn_radius = 80.0
    max_climb_rate = 4.0
    loiter_lag = 1.55                 # s: planes fly a loiter of radius R at R + (V lag)^2 / R
                                      # (ArduPlane's L1 overshoot; 0: exact; copters: exact)
    wind = [0.0, 0.0]                 # north, east m/s
    warmup = 3.0                      # s of sim time before arming is allowed
    setpoint_timeout = 1.0
    home_spacing = 10.0               # m between default homes (a row to the east)

    [[aircraft.vehicle]]              # per-aircraft overrides
    sysid = 2
    airspeed = 15.0
    home = [47.3978, 8.5457, 488.0]   # or home_ned = [north, east, down]

    [ground]
    count = 0
    route = "line"                    # stationary | line | polyline | csv | track
    start = [0.0, 0.0]                # world north, east (m)
    speed = 5.0
    heading = 90.0                    # degrees cw from north
    points = [[0, 0], [500, 0]]       # polyline vertices, world north/east (m)
    loop = false
    accel = 0.0                       # polyline: m/s² braking for corners and speeding up
                                      #   after (ArduRover's ATC_ACCEL_MAX, 1.0; 0: none)
    wp_radius = 2.0                   # polyline: m, a corner is passed within (WP_RADIUS)
    jerk = 0.0                        # polyline: m/s³ the accel is reached at (WP_JERK;
                                      #   0: the accel's value)
    holds = [[2, 30.0]]               # polyline: [point index, seconds] stood at a point
    speeds = [[1, 4.0]]               # polyline: [point index, m/s] driven from it on
    csv = "track.csv"                 # time,lat,lon (relative to this file)
    track = [[0.0, 47.3977, 8.5456], [60.0, 47.4019, 8.5456]]  # the csv's rows, inline
    spacing = 20.0                    # m between successive ground vehicles (on a road,
                                      #   polyline, csv or track: each drives the path the
                                      #   one ahead drove, the time this takes at the
                                      #   road's speed behind it, stopping a quarter of it
                                      #   short of it)
    mission = false                   # the lead serves its road as its mission (polyline,
                                      #   csv, track: a rover in AUTO), read over MAVLink

    [faults]
    loss_to_vehicle = 0.0
    loss_from_vehicle = 0.0
    latency = 0.0                     # both directions, sim s (or latency_to/from_vehicle)
    duplicate = 0.0                   # probability a datagram arrives twice (both ways)
    jitter = 0.0                      # up to this many sim s more latency: reordering
    kill = [{ sysid = 2, at = 30.0 }] # or ["2@30"]
    reboot = ["1@20"]
    mode = ["8:HOLD@300"]             # or [{ sysid = 8, at = 300.0, mode = "HOLD" }]: its
                                      #   operator switches it to that mode (its firmware's
                                      #   name), e.g. a truck held, or sent home (RTL)
    sysids = []                       # loss/latency/duplicates/jitter only for these (empty: all)
    seed = 0
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, TypeVar

from convoy_mav.errors import ConfigError
from convoy_mav.geo import GeoPoint, LocalFrame
from convoy_mav.mavlink.signing import key_from_text
from convoy_mav.tracks import GeoTrack
from sitl_mock.autopilot import Personality, VehicleSpec
from sitl_mock.faults import FaultSpec, TimedFault, TimedMode
from sitl_mock.ground import (
    Lagged,
    Polyline,
    Route,
    Stationary,
    StraightLine,
    Track,
    load_csv_track,
    track_from_geo,
)
from sitl_mock.kinematics import AirframeParams, Frame
from sitl_mock.personality import firmware_for

__all__ = [
    "DEFAULT_BASE_PORT",
    "DEFAULT_ORIGIN",
    "Lagged",
    "MockConfig",
    "config_from_mapping",
    "load_toml",
    "merge_overrides",
    "parse_geo",
    "parse_udp_address",
]

DEFAULT_BASE_PORT = 14540
DEFAULT_ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)  # PX4 SITL's default home (Zurich)

_TOP_KEYS = {
    "speedup",
    "base_port",
    "host",
    "origin",
    "gcs",
    "truth",
    "truth_rate",
    "physics_rate",
    "aircraft",
    "ground",
    "faults",
}
_LOITER_LAG_S = 1.55
"""s: a plane's default loiter overshoot, fitted to ArduPlane SITL at 630 m AMSL with its
density scaling (``Firmware.loiter_scale``): 100 m flown at 118 m at 22 m/s, 300 m at
326 m at 27 m/s."""
_AIRCRAFT_KEYS = {
    "personality",
    "frame",
    "airspeed",
    "turn_radius",
    "max_climb_rate",
    "loiter_lag",
    "wind",
    "warmup",
    "setpoint_timeout",
    "signing_key",
}
_VEHICLE_KEYS = _AIRCRAFT_KEYS | {"sysid", "home", "home_ned"}
_GROUND_KEYS = {
    "count",
    "mission",
    "route",
    "start",
    "speed",
    "heading",
    "points",
    "loop",
    "accel",
    "wp_radius",
    "jerk",
    "holds",
    "speeds",
    "csv",
    "track",
    "spacing",
    "personality",
    "warmup",
}
_T = TypeVar("_T")

_FAULT_KEYS = {
    "loss_to_vehicle",
    "loss_from_vehicle",
    "latency",
    "latency_to_vehicle",
    "latency_from_vehicle",
    "duplicate",
    "jitter",
    "kill",
    "reboot",
    "mode",
    "stall",
    "sysids",
    "seed",
}


@dataclass(frozen=True, slots=True)
class MockConfig:
    """Everything one mock process needs, validated.

    Attributes:
        vehicles: Aircraft (sysids 1..K) then ground vehicles, in sysid order.
        origin: World NED origin shared by every vehicle and the convoy route.
        speedup: Sim seconds per wall second.
        host: Address every vehicle socket binds to.
        base_port: Vehicle ``sysid`` listens on ``base_port + sysid - 1``; 0 binds
            each vehicle to a free port (tests), reported in the endpoints.
        gcs: Fixed ``(host, port)`` that also receives all traffic, or None.
        truth_path: CSV truth log file, or None.
        truth_rate: Truth samples per sim second.
        physics_rate: Physics steps per sim second (fixed step).
        faults: Link and vehicle faults to inject.
    """

    vehicles: tuple[VehicleSpec, ...]
    origin: GeoPoint = DEFAULT_ORIGIN
    speedup: float = 1.0
    host: str = "127.0.0.1"
    base_port: int = DEFAULT_BASE_PORT
    gcs: tuple[str, int] | None = None
    truth_path: str | None = None
    truth_rate: float = 10.0
    physics_rate: float = 100.0
    faults: FaultSpec = field(default_factory=FaultSpec)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speedup) and self.speedup > 0):
            raise ConfigError("speedup", self.speedup, "must be a finite number > 0")
        for key in ("truth_rate", "physics_rate"):
            v = getattr(self, key)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(key, v, "must be a finite rate > 0 Hz")
        sysids = [v.sysid for v in self.vehicles]
        if len(set(sysids)) != len(sysids):
            raise ConfigError("vehicles", sysids, "system ids must be unique")
        if self.base_port and not 1 <= self.base_port + max(sysids, default=1) - 1 <= 65535:
            raise ConfigError("base_port", self.base_port, "vehicle ports must fit in 1..65535")

    def port_of(self, sysid: int) -> int:
        """The UDP port vehicle ``sysid`` listens on (0: chosen at bind time)."""
        return self.base_port + sysid - 1 if self.base_port else 0

    @classmethod
    def simple(cls, aircraft: int = 1, ground: int = 0, **overrides: Any) -> MockConfig:
        """A config from the schema's defaults and top-level/aircraft keyword overrides.

        Handy for tests: ``MockConfig.simple(2, speedup=50, base_port=0,
        personality="ardupilot")``. Keys of the ``[aircraft]`` table apply to
        every aircraft; other keys are top-level.
        """
        data: dict[str, Any] = {"aircraft": {"count": aircraft}, "ground": {"count": ground}}
        for key, value in overrides.items():
            if key in _AIRCRAFT_KEYS or key == "home_spacing":
                data["aircraft"][key] = value
            elif key in _GROUND_KEYS - {"count"} or key.startswith("ground_"):
                data["ground"][key.removeprefix("ground_")] = value
            else:
                data[key] = value
        return config_from_mapping(data)


def load_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a TOML config file.

    Raises:
        ConfigError: The file is missing, unreadable or not valid TOML.
    """
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise ConfigError("config", os.fspath(path), e.strerror or str(e)) from e
    except tomllib.TOMLDecodeError as e:
        raise ConfigError("config", os.fspath(path), f"invalid TOML: {e}") from e


def merge_overrides(data: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Lay command-line ``overrides`` (same schema) over file ``data``.

    Tables merge key by key. An aircraft key set on the command line also
    replaces that key in every ``[[aircraft.vehicle]]`` entry: the flag means
    "all aircraft".
    """
    merged: dict[str, Any] = dict(data)
    for key, value in overrides.items():
        old = merged.get(key)
        if isinstance(value, Mapping) and isinstance(old, Mapping):
            merged[key] = merge_overrides(old, value)
        else:
            merged[key] = value
    aircraft_cli = overrides.get("aircraft")
    aircraft = merged.get("aircraft")
    if isinstance(aircraft_cli, Mapping) and isinstance(aircraft, dict):
        entries = aircraft.get("vehicle")
        if isinstance(entries, list):
            aircraft["vehicle"] = [
                {k: v for k, v in e.items() if k not in aircraft_cli} if isinstance(e, dict) else e
                for e in entries
            ]
    return merged


def config_from_mapping(data: Mapping[str, Any], base_dir: str = ".") -> MockConfig:
    """Validate a schema mapping (file merged with flags) into a :class:`MockConfig`.

    Args:
        data: The nested mapping described in the module docstring.
        base_dir: Directory relative paths in the mapping are resolved against
            (the config file's directory).

    Raises:
        ConfigError: Naming the first bad key and its value.
    """
    top = _Table(data, "")
    top.check_keys(_TOP_KEYS)
    origin = parse_geo("origin", top.get("origin", DEFAULT_ORIGIN))
    world = LocalFrame(origin)

    aircraft = _Table(top.table("aircraft"), "aircraft")
    aircraft.check_keys(_AIRCRAFT_KEYS | {"count", "home_spacing", "vehicle"})
    n_air = aircraft.integer("count", 1, lo=0, hi=250)
    entries = _vehicle_entries(aircraft, n_air)
    spacing = aircraft.number("home_spacing", 10.0, lo=0.0)
    vehicles: list[VehicleSpec] = []
    for sysid in range(1, n_air + 1):
        entry = entries.get(sysid, _Table({}, f"aircraft.vehicle[sysid={sysid}]"))
        vehicles.append(_aircraft_spec(sysid, aircraft, entry, world, spacing))

    ground = _Table(top.table("ground"), "ground")
    ground.check_keys(_GROUND_KEYS)
    n_ground = ground.integer("count", 0, lo=0, hi=250 - n_air)
    if n_ground:
        default_personality = aircraft.text("personality", "px4")
        vehicles += _ground_specs(ground, n_ground, n_air, world, base_dir, default_personality)

    truth = top.get("truth")
    if truth is not None and not isinstance(truth, str | os.PathLike):
        raise ConfigError("truth", truth, "must be a file path")
    gcs_raw = top.get("gcs")
    faults = _faults(_Table(top.table("faults"), "faults"))
    _check_modes(faults.modes, vehicles)
    _check_stalls(faults.stalls, vehicles)
    return MockConfig(
        vehicles=tuple(vehicles),
        origin=origin,
        speedup=top.number("speedup", 1.0, lo=1e-6),
        host=top.text("host", "127.0.0.1"),
        base_port=top.integer("base_port", DEFAULT_BASE_PORT, lo=0, hi=65535),
        gcs=None if gcs_raw is None else parse_udp_address("gcs", gcs_raw),
        truth_path=None if truth is None else _resolve(os.fspath(truth), base_dir),
        truth_rate=top.number("truth_rate", 10.0, lo=1e-6),
        physics_rate=top.number("physics_rate", 100.0, lo=1.0),
        faults=faults,
    )


def parse_geo(key: str, value: object) -> GeoPoint:
    """``"lat,lon[,alt]"``, a 2/3-element list, or a GeoPoint -> GeoPoint."""
    if isinstance(value, GeoPoint):
        return value
    parts: list[object]
    if isinstance(value, str):
        parts = [p.strip() for p in value.split(",")]
    elif isinstance(value, list | tuple):
        parts = list(value)
    else:
        raise ConfigError(key, value, "expected LAT,LON[,ALT]")
    try:
        nums = [float(p) for p in parts]  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ConfigError(key, value, "expected LAT,LON[,ALT] numbers") from None
    if len(nums) not in (2, 3) or not all(math.isfinite(x) for x in nums):
        raise ConfigError(key, value, "expected LAT,LON[,ALT] finite numbers")
    if not (-90.0 <= nums[0] <= 90.0 and -180.0 <= nums[1] <= 180.0):
        raise ConfigError(key, value, "latitude must be in [-90, 90], longitude in [-180, 180]")
    return GeoPoint(nums[0], nums[1], nums[2] if len(nums) == 3 else 0.0)


def parse_udp_address(key: str, value: object) -> tuple[str, int]:
    """``"udp:HOST:PORT"`` (also ``udpout:``, ``udp://``, bare ``HOST:PORT``) -> (host, port)."""
    if not isinstance(value, str):
        raise ConfigError(key, value, "expected udp:HOST:PORT")
    text = value
    for prefix in ("udp://", "udpout://", "udp:", "udpout:"):
        if text.startswith(prefix):
            text = text[len(prefix) :]
            break
    host, sep, port_text = text.rpartition(":")
    if not sep or not host or not port_text.isdigit() or not 1 <= int(port_text) <= 65535:
        raise ConfigError(key, value, "expected udp:HOST:PORT with a port in 1..65535")
    return host, int(port_text)


# --------------------------------------------------------------------------- helpers


class _Table:
    """Typed, key-naming access to one table of the mapping."""

    def __init__(self, data: Mapping[str, Any], prefix: str) -> None:
        self.data = data
        self.prefix = prefix

    def key(self, name: str) -> str:
        return f"{self.prefix}.{name}" if self.prefix else name

    def get(self, name: str, default: Any = None) -> Any:
        return self.data.get(name, default)

    def check_keys(self, allowed: set[str]) -> None:
        for name in self.data:
            if name not in allowed:
                raise ConfigError(self.key(name), self.data[name], "unknown key")

    def table(self, name: str) -> Mapping[str, Any]:
        value = self.data.get(name, {})
        if not isinstance(value, Mapping):
            raise ConfigError(self.key(name), value, "must be a table")
        return value

    def number(
        self, name: str, default: float, lo: float | None = None, *, positive: bool = False
    ) -> float:
        value = self.data.get(name, default)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ConfigError(self.key(name), value, "must be a number")
        x = float(value)
        if not math.isfinite(x) or (lo is not None and x < lo) or (positive and x <= 0.0):
            bound = " > 0" if positive else (f" >= {lo:g}" if lo is not None else "")
            raise ConfigError(self.key(name), value, f"must be a finite number{bound}")
        return x

    def integer(self, name: str, default: int, lo: int, hi: int) -> int:
        value = self.data.get(name, default)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ConfigError(self.key(name), value, f"must be an integer in {lo}..{hi}")
        return value

    def text(self, name: str, default: str) -> str:
        value = self.data.get(name, default)
        if not isinstance(value, str):
            raise ConfigError(self.key(name), value, "must be a string")
        return value

    def flag(self, name: str, default: bool) -> bool:
        value = self.data.get(name, default)
        if not isinstance(value, bool):
            raise ConfigError(self.key(name), value, "must be true or false")
        return value

    def pair(self, name: str, default: tuple[float, float]) -> tuple[float, float]:
        value = self.data.get(name, default)
        try:
            a, b = (float(v) for v in value)
        except (TypeError, ValueError):
            raise ConfigError(self.key(name), value, "must be a pair of numbers") from None
        if not (math.isfinite(a) and math.isfinite(b)):
            raise ConfigError(self.key(name), value, "must be finite")
        return a, b


def _vehicle_entries(aircraft: _Table, count: int) -> dict[int, _Table]:
    raw = aircraft.get("vehicle", [])
    if not isinstance(raw, list):
        raise ConfigError("aircraft.vehicle", raw, "must be an array of tables")
    entries: dict[int, _Table] = {}
    for i, entry in enumerate(raw):
        prefix = f"aircraft.vehicle[{i}]"
        if not isinstance(entry, Mapping):
            raise ConfigError(prefix, entry, "must be a table")
        t = _Table(entry, prefix)
        t.check_keys(_VEHICLE_KEYS)
        sysid = t.integer("sysid", i + 1, lo=1, hi=250)
        if sysid > count:
            raise ConfigError(t.key("sysid"), sysid, f"beyond aircraft.count = {count}")
        if sysid in entries:
            raise ConfigError(t.key("sysid"), sysid, "listed twice")
        entries[sysid] = t
    return entries


def _pick(name: str, entry: _Table, defaults: _Table) -> _Table:
    """The table that decides ``name``: the vehicle's own entry, else the defaults."""
    return entry if name in entry.data else defaults


def _aircraft_spec(
    sysid: int, defaults: _Table, entry: _Table, world: LocalFrame, spacing: float
) -> VehicleSpec:
    def num(name: str, default: float, *, positive: bool = True) -> float:
        return _pick(name, entry, defaults).number(name, default, lo=0.0, positive=positive)

    personality = _personality(_pick("personality", entry, defaults), "personality", "px4")
    frame_table = _pick("frame", entry, defaults)
    frame = frame_table.text("frame", "plane")
    if frame not in ("plane", "copter"):
        raise ConfigError(frame_table.key("frame"), frame, "must be 'plane' or 'copter'")
    frame_kind: Frame = "plane" if frame == "plane" else "copter"
    wind_n, wind_e = _pick("wind", entry, defaults).pair("wind", (0.0, 0.0))
    airframe = AirframeParams(
        frame=frame_kind,
        airspeed=num("airspeed", 18.0),
        min_turn_radius=num("turn_radius", 80.0),
        max_climb_rate=num("max_climb_rate", 4.0),
        loiter_lag=num("loiter_lag", _LOITER_LAG_S, positive=False),
        wind_north=wind_n,
        wind_east=wind_e,
    )
    if "home" in entry.data:
        home = parse_geo(entry.key("home"), entry.get("home"))
    elif "home_ned" in entry.data:
        values = entry.get("home_ned")
        ok = isinstance(values, list) and len(values) in (2, 3)
        if not ok or not all(isinstance(v, int | float) and math.isfinite(v) for v in values):
            raise ConfigError(
                entry.key("home_ned"), values, "expected [north, east(, down)] metres"
            )
        home = world.to_geo(*(float(v) for v in values))
    else:
        home = world.to_geo(0.0, (sysid - 1) * spacing, 0.0)  # a row, like PX4 multi-SITL
    return VehicleSpec(
        sysid=sysid,
        kind="aircraft",
        personality=personality,
        airframe=airframe,
        home=home,
        warmup_s=num("warmup", 3.0, positive=False),
        setpoint_timeout_s=num("setpoint_timeout", 1.0),
        signing_key=_signing_key(_pick("signing_key", entry, defaults)),
    )


def _signing_key(table: _Table) -> bytes | None:
    """``signing_key``: 64 hex digits, or a passphrase (its SHA-256, as MAVProxy's)."""
    if "signing_key" not in table.data:
        return None
    text = table.get("signing_key")
    if not isinstance(text, str) or not text.strip():
        raise ConfigError(table.key("signing_key"), "***", "must be hex digits or a passphrase")
    return key_from_text(text)


def _personality(table: _Table, name: str, default: str) -> Personality:
    value = table.text(name, default)
    try:
        return Personality(value)
    except ValueError:
        choices = ", ".join(repr(p.value) for p in Personality)
        raise ConfigError(table.key(name), value, f"must be one of {choices}") from None


def _ground_specs(
    g: _Table, count: int, first_sysid: int, world: LocalFrame, base_dir: str, personality: str
) -> list[VehicleSpec]:
    speed = g.number("speed", 0.0, lo=0.0)
    default = next((k for k in ("csv", "track") if k in g.data), "")
    kind = g.text("route", default or ("line" if speed > 0 else "stationary"))
    start = g.pair("start", (0.0, 0.0))
    spacing = g.number("spacing", 20.0, lo=0.0)
    route: Route
    if kind == "stationary":
        route = Stationary(*start)
    elif kind == "line":
        heading = math.radians(g.number("heading", 0.0))
        route = StraightLine(start[0], start[1], speed, heading)
    elif kind == "polyline":
        route = _polyline(g, speed)
    elif kind == "csv":
        path = g.get("csv")
        if not isinstance(path, str):
            raise ConfigError(g.key("csv"), path, "route 'csv' needs a track file path")
        try:
            route = load_csv_track(_resolve(path, base_dir), world)
        except (OSError, ValueError) as e:
            raise ConfigError(g.key("csv"), path, str(e)) from None
    elif kind == "track":
        route = track_from_geo(_inline_track(g), world)
    else:
        raise ConfigError(g.key("route"), kind, "must be stationary, line, polyline, csv or track")
    for name in ("accel", "wp_radius", "jerk", "holds", "speeds"):
        if name in g.data and kind != "polyline":
            raise ConfigError(g.key(name), g.data[name], f"is a polyline's, not route {kind}'s")
    lead_speed = speed if kind not in ("csv", "track") else _track_speed(route)
    mission = g.flag("mission", False)
    road = kind in ("polyline", "csv", "track")  # (a road to drive, and to drive behind)
    if mission and not road:
        raise ConfigError(
            g.key("mission"), True, f"needs a road: route polyline, csv or track, not {kind}"
        )
    specs: list[VehicleSpec] = []
    for j in range(count):
        member: Route = route
        trails = j > 0 and spacing > 0 and lead_speed > 0 and road
        if j and kind == "stationary":
            member = Stationary(start[0] - j * spacing, start[1])
        elif j and lead_speed > 0:
            member = Lagged(route, j * spacing / lead_speed)  # (its start, and its own
            # road if it drives no road behind its leader)
        north, east = member.position(0.0)
        specs.append(
            VehicleSpec(
                sysid=first_sysid + j + 1,
                kind="ground",
                personality=_personality(g, "personality", personality),
                home=world.to_geo(north, east, 0.0),
                route=member,
                warmup_s=g.number("warmup", 3.0, lo=0.0),
                mission=mission and j == 0,
                # on a road, the path the one ahead drove (sitl_mock.trail), the time its
                # spacing takes behind it, stopping short of it by a quarter of it
                follows=first_sysid + j if trails else None,
                lag_s=spacing / lead_speed if trails else 0.0,
                standstill_m=spacing / 4.0 if trails else 0.0,
            )
        )
    return specs


def _polyline(g: _Table, speed: float) -> Polyline:
    """A polyline route, its drive (corners, holds and speeds) checked by key."""
    points = _points(g)
    marks = {name: _marks(g, name, len(points)) for name in ("holds", "speeds")}
    for k, (index, mps) in enumerate(marks["speeds"]):
        if mps <= 0.0:
            raise ConfigError(f"{g.key('speeds')}[{k}]", [index, mps], "its speed must be > 0")
    return Polyline(
        points,
        speed,
        g.flag("loop", False),
        accel=g.number("accel", 0.0, lo=0.0),
        wp_radius=g.number("wp_radius", 2.0, positive=True),
        jerk=g.number("jerk", 0.0, lo=0.0),
        holds=marks["holds"],
        speeds=marks["speeds"],
    )


def _marks(g: _Table, name: str, count: int) -> tuple[tuple[int, float], ...]:
    """``[[point index, number], ...]``: each a point of the polyline, each point once."""
    raw = g.get(name, [])
    if not isinstance(raw, list):
        raise ConfigError(g.key(name), raw, "must be a list of [point index, number]")
    out: list[tuple[int, float]] = []
    for k, mark in enumerate(raw):
        key = f"{g.key(name)}[{k}]"
        if not (isinstance(mark, list) and len(mark) == 2 and isinstance(mark[0], int)):
            raise ConfigError(key, mark, "must be [point index, number]")
        if isinstance(mark[0], bool) or not 0 <= mark[0] < count:
            raise ConfigError(key, mark, f"no point {mark[0]!r} (0..{count - 1})")
        value = _Table({"v": mark[1]}, key).number("v", 0.0, lo=0.0)
        if any(index == mark[0] for index, _ in out):
            raise ConfigError(key, mark, f"point {mark[0]} is given twice")
        out.append((mark[0], value))
    return tuple(out)


def _points(g: _Table) -> tuple[tuple[float, float], ...]:
    raw = g.get("points")
    if not isinstance(raw, list) or len(raw) < 2:
        raise ConfigError(g.key("points"), raw, "route 'polyline' needs >= 2 [north, east] points")
    return tuple(
        _Table({"p": p}, f"{g.key('points')}[{i}]").pair("p", (0, 0)) for i, p in enumerate(raw)
    )


def _inline_track(g: _Table) -> GeoTrack:
    """``track = [[time, lat, lon], ...]``: the CSV route's rows, inline."""
    raw = g.get("track")
    if not isinstance(raw, list) or not raw:
        raise ConfigError(g.key("track"), raw, "route 'track' needs [[time, lat, lon], ...] rows")
    rows: list[tuple[float, float, float]] = []
    for i, row in enumerate(raw):
        key = f"{g.key('track')}[{i}]"
        ok = isinstance(row, list | tuple) and len(row) == 3
        if not ok or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in row
        ):
            raise ConfigError(key, row, "expected [time, lat, lon] finite numbers")
        t, lat, lon = (float(v) for v in row)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ConfigError(key, row, "latitude must be in [-90, 90], longitude in [-180, 180]")
        if rows and t <= rows[-1][0]:
            raise ConfigError(key, row, f"time does not increase (previous {rows[-1][0]!r})")
        rows.append((t, lat, lon))
    times, lats, lons = zip(*rows, strict=True)
    return GeoTrack(times, lats, lons)


def _track_speed(route: Route) -> float:
    """Mean speed of a recorded track, to turn the convoy spacing into a time lag."""
    if isinstance(route, Track) and len(route.times) >= 2:
        length = sum(
            math.dist((route.norths[i], route.easts[i]), (route.norths[i + 1], route.easts[i + 1]))
            for i in range(len(route.times) - 1)
        )
        duration = route.times[-1] - route.times[0]
        return length / duration if duration > 0 else 0.0
    return 0.0


def _entries(f: _Table, name: str, parse: Callable[[object], _T]) -> tuple[_T, ...]:
    """A fault list's entries (one alone is a list of one), each parsed by ``parse``; a
    bad one is a ConfigError naming it."""
    raw = f.get(name, [])
    if not isinstance(raw, list):
        raw = [raw]
    out: list[_T] = []
    for i, item in enumerate(raw):
        try:
            out.append(parse(item))
        except (TypeError, ValueError) as e:
            raise ConfigError(f"{f.key(name)}[{i}]", item, str(e)) from None
    return tuple(out)


def _timed(item: object) -> TimedFault:
    """``"SYSID@TIME"`` or ``{sysid, at}``."""
    if isinstance(item, str):
        sysid_text, sep, at_text = item.partition("@")
        if not sep:
            raise ValueError("expected SYSID@TIME")
        return TimedFault(int(sysid_text), float(at_text))
    if isinstance(item, Mapping) and set(item) == {"sysid", "at"}:
        return TimedFault(int(item["sysid"]), float(item["at"]))
    raise ValueError("expected SYSID@TIME or {sysid, at}")


def _timed_mode(item: object) -> TimedMode:
    """``"SYSID:MODE@TIME"`` or ``{sysid, at, mode}``."""
    if isinstance(item, str):
        head, sep, at_text = item.partition("@")
        sysid_text, colon, mode = head.partition(":")
        if not (sep and colon):
            raise ValueError("expected SYSID:MODE@TIME")
        return TimedMode(int(sysid_text), float(at_text), mode)
    if isinstance(item, Mapping) and set(item) == {"sysid", "at", "mode"}:
        return TimedMode(int(item["sysid"]), float(item["at"]), str(item["mode"]))
    raise ValueError("expected SYSID:MODE@TIME or {sysid, at, mode}")


def _check_modes(modes: tuple[TimedMode, ...], vehicles: list[VehicleSpec]) -> None:
    """Each mode change names a mode its vehicle's firmware has (a vehicle not in the
    fleet is warned of when it comes due, as a kill is)."""
    specs = {v.sysid: v for v in vehicles}
    for i, change in enumerate(modes):
        spec = specs.get(change.sysid)
        if spec is None:
            continue
        kind = "rover" if spec.kind == "ground" else spec.airframe.frame
        firmware = firmware_for(spec.personality, kind)
        try:
            firmware.mode(change.mode)
        except KeyError:
            names = ", ".join(m.name for m in firmware.modes)
            raise ConfigError(
                f"faults.mode[{i}]", change.mode, f"is no mode of sysid {change.sysid}'s "
                f"{spec.personality.value} {kind}: {names}",
            ) from None  # fmt: skip


def _check_stalls(stalls: tuple[TimedFault, ...], vehicles: list[VehicleSpec]) -> None:
    """Each stall names a ground vehicle (one not in the fleet is warned of when it
    comes due): an aircraft does not stall on a road."""
    kinds = {v.sysid: v.kind for v in vehicles}
    for i, stall in enumerate(stalls):
        if kinds.get(stall.sysid, "ground") != "ground":
            raise ConfigError(
                f"faults.stall[{i}]", stall.sysid, "is no ground vehicle: only one stalls"
            )


def _faults(f: _Table) -> FaultSpec:
    f.check_keys(_FAULT_KEYS)
    latency = f.number("latency", 0.0, lo=0.0)
    sysids = f.get("sysids", [])
    if not isinstance(sysids, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) for s in sysids
    ):
        raise ConfigError(f.key("sysids"), sysids, "must be a list of system ids")
    for name in ("loss_to_vehicle", "loss_from_vehicle", "duplicate"):
        p = f.number(name, 0.0, lo=0.0)
        if p > 1.0:
            raise ConfigError(f.key(name), f.get(name), "must be a probability in [0, 1]")
    return FaultSpec(
        loss_to_vehicle=f.number("loss_to_vehicle", 0.0, lo=0.0),
        loss_from_vehicle=f.number("loss_from_vehicle", 0.0, lo=0.0),
        latency_to_vehicle=f.number("latency_to_vehicle", latency, lo=0.0),
        latency_from_vehicle=f.number("latency_from_vehicle", latency, lo=0.0),
        duplicate=f.number("duplicate", 0.0, lo=0.0),
        jitter=f.number("jitter", 0.0, lo=0.0),
        kills=_entries(f, "kill", _timed),
        reboots=_entries(f, "reboot", _timed),
        modes=_entries(f, "mode", _timed_mode),
        stalls=_entries(f, "stall", _timed),
        sysids=frozenset(sysids),
        seed=f.integer("seed", 0, lo=0, hi=2**63 - 1),
    )


def _resolve(path: str, base_dir: str) -> str:
    return path if os.path.isabs(path) else os.path.normpath(os.path.join(base_dir, path))
