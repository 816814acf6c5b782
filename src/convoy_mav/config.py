"""Mission configuration: TOML in, frozen dataclasses out.

Every error names the key (as a dotted TOML path, ``uav[2].sysid``) and the
offending value and is raised as ``ConfigError``, which the CLI turns into a
one-line message and exit status 2.  Unknown keys are errors too: a typo must
not silently fall back to a default.

Schema (lengths metres, speeds m/s, headings compass degrees, times mission
seconds; every number bounded: speeds <= 150 m/s, lengths <= 100 km, altitudes <= 10 km,
times <= a day)::

    [mission]
    sensor_radius_m = 100.0       # r: radius of the disk the camera sees (required)
    uavs = 5                      # planned UAV count; default: the [[uav]] entries,
                                  # or the paper's minimum when there are none
    origin = { lat = 47.397742, lon = 8.545594, alt = 488.0 }   # mission frame origin
    setpoint_rate_hz = 20.0       # setpoint stream, per UAV, in mission time (1..100)
    altitude_step_m = 5.0         # UAV i flies altitude_m + i * step (vertical separation)
    setup_timeout_s = 120.0       # give up setting a UAV up after this long
    lost_after_s = 3.0            # a UAV silent this long is declared lost (>= 0.2)
    altitude_band_m = 15.0        # a UAV counts for coverage only within this of its altitude
    end = "loiter"                # at the end: "loiter" where it is, "rtl" home, "land" there
                                  #   (an ArduPlane cannot land by command: it returns home)
    planner = "auto"              # "road": the paper's pattern laid along the road, flyable
                                  #   legs; "paper": the paper's plans, re-planned on changes;
                                  #   "auto": road when the fleet has the road's count
                                  #   (the stationary minimum + 1), else paper;
                                  #   with no route, + 2 is the road's count (logged)
    sim_speedup_floor = 5.0       # optional, simulators only: when the host falls behind
                                  #   the speedup (setpoint rounds late, planner behind),
                                  #   halve it by SIM_SPEEDUP (ArduPilot SITL, sitl_mock)
                                  #   down to this; absent: never touch it
    source_system = 255           # the service's own MAVLink ids (a ground station's by
    source_component = 190        #   convention, as QGroundControl's): give it another
                                  #   system when a GCS with these shares its links, and
                                  #   ArduPilot's MAV_GCS_SYSID where the vehicle accepts
                                  #   only its GCS (MAV_OPTIONS bit 0; SYSID_MYGCS and
                                  #   SYSID_ENFORCE in older releases)

    [aircraft]                    # defaults for every [[uav]]
    airspeed_mps = 18.0
    turn_radius_m = 150.0         # R: the radius the plan uses (keep a margin over the
    altitude_m = 100.0            #    airframe's hard limit so the autopilot can correct)

    [[uav]]                       # one per autopilot
    connection = "udpin:0.0.0.0:14540"   # pymavlink / MAVSDK style connection string
    sysid = 1
    peer = "127.0.0.1:14580"      # optional, udpin: the only sender heard (default: the
                                  #   first one, pinned while it talks)
    signing_key_file = "fleet.key"   # optional MAVLink 2 signing: 64 hex digits or a
                                  #   passphrase (or signing_key_env = "VAR"); the
                                  #   timestamps are kept in <key>.state.json (or
                                  #   signing_state = "FILE")
    # airspeed_mps / turn_radius_m / altitude_m override [aircraft]

    [convoy]
    source = "route"              # "route" (scripted), "mavlink" (ground vehicles), "mqtt"
    speed_mps = 0.0               # route: 0 is a stationary convoy
    heading_deg = 0.0             # route: compass course
    start = { north = 0.0, east = 0.0 }   # route: start point in the mission frame
    stale_after_s = 3.0           # no fresh convoy fix this long: hold + alarm
    part_m = 200.0                # optional: a ground vehicle farther than this from every
                                  #   other of the lead's group has parted from the convoy
                                  #   (stopped, sent home, gone elsewhere): it leaves the
                                  #   convoy's centroid until back within half of it
                                  #   (default twice the sensor radius; 0: never)
    route = "route.gpx"           # optional: the road the convoy will drive (GPX trk/rte,
                                  #   CSV lat,lon[,time], GeoJSON LineString, KML/KMZ path,
                                  #   a rover's mission saved as .plan or .waypoints;
                                  #   relative to this file); the road
                                  #   planner predicts along it (the convoy may still leave it)
                                  #   route = "mission": the first [[convoy.vehicle]]'s own
                                  #   mission (a rover in AUTO), read over MAVLink, again
                                  #   whenever it changes
    [[convoy.vehicle]]            # source = "mavlink": the ground vehicles' autopilots
    connection = "udpout:127.0.0.1:14544"
    sysid = 5

    [mqtt]                        # optional; without it nothing is published
    host = "127.0.0.1"
    port = 1883
    prefix = "convoy"
    tls = true                    # optional: TLS with the system trust store, or
    ca_file = "ca.crt"            #   the broker's CA (files relative to this file);
    cert_file = "client.crt"      #   a client certificate and its key
    key_file = "client.key"
    username = "service"
    password_env = "CONVOY_MQTT_PASSWORD"   # or password_file = "mqtt.pw" (first line);
                                  #   never the password itself in this file

    [record]
    tlog = "mission.tlog"         # optional MAVLink recording (an existing file is kept)
    mission = "mission.inputs"    # optional: the road planner's inputs, to replay offline
                                  #   (convoy_mav.mission.recording)

    [safety]                      # optional
    fence = [[47.40, 8.54], [47.40, 8.56], [47.39, 8.56], [47.39, 8.54]]  # inclusion
                                  #   polygon (or fence_file = "fence.geojson": a Polygon,
                                  #   its holes exclusions)
    exclusions = [[[47.395, 8.549], [47.395, 8.551], [47.396, 8.551]]]
    min_alt_m = 30.0              # altitude band above the mission origin
    max_alt_m = 400.0
    fence_margin_m = 20.0         # clamped setpoints go this far inside the edges
    min_separation_m = 30.0       # a pair closer horizontally ...
    min_vertical_separation_m = 3.0   # ... and vertically is a separation alarm
    launch_sequence = true        # UAVs near each other's pads take off one by one,
                                  #   the highest layer first (false: all at once)
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Final, Literal, cast, get_args

from convoy_mav.errors import ConfigError
from convoy_mav.geo import GeoPoint
from convoy_mav.mavlink.codec import GCS_COMPONENT, GCS_SYSTEM
from convoy_mav.mavlink.connection import ConnectionSpec
from convoy_mav.parting import default_part_m
from convoy_mav.planning.export import compass_to_planner
from convoy_mav.planning.plan import PlanRequest

__all__ = [
    "ROUTE_FROM_MISSION",
    "AircraftConfig",
    "ConvoyConfig",
    "ConvoyVehicleConfig",
    "MissionConfig",
    "MqttConfig",
    "UavConfig",
    "load_config",
    "parse_config",
    "validate_connection",
]

#: The PX4 SITL default home (Zurich), used when a config names no origin.
DEFAULT_ORIGIN = GeoPoint(47.397742, 8.545594, 488.0)


def validate_connection(text: object, key: str) -> str:
    """Check a connection string (``udpin:0.0.0.0:14540``, ``tcp:HOST:5760``, ``udp://:14540``).

    Returns:
        The string, stripped.

    Raises:
        ConfigError: Naming ``key`` when the form or the port is wrong.
    """
    if not isinstance(text, str):
        raise ConfigError(key, text, "must be a connection string like 'udpin:0.0.0.0:14540'")
    ConnectionSpec.parse(text.strip(), key)
    return text.strip()


@dataclass(frozen=True, slots=True)
class AircraftConfig:
    """Performance of a UAV (the [aircraft] defaults, or one [[uav]] entry's)."""

    airspeed_mps: float = 18.0
    turn_radius_m: float = 150.0
    altitude_m: float = 100.0


@dataclass(frozen=True, slots=True)
class UavConfig:
    """One autopilot the service drives."""

    connection: str
    sysid: int
    aircraft: AircraftConfig = AircraftConfig()
    peer: tuple[str, int] | None = None  # udpin: the only sender heard (None: the first)
    signing_key_file: str | None = None  # MAVLink 2 signing key: a file (hex or passphrase)
    signing_key_env: str | None = None  # ... or an environment variable
    signing_state: str | None = None  # timestamps kept across restarts (default: by the key)

    @property
    def signed(self) -> bool:
        """True when this UAV's link signs and accepts only signed frames."""
        return self.signing_key_file is not None or self.signing_key_env is not None


@dataclass(frozen=True, slots=True)
class ConvoyVehicleConfig:
    """One ground vehicle whose own telemetry locates the convoy."""

    connection: str
    sysid: int
    peer: tuple[str, int] | None = None  # udpin: the only sender heard (None: the first)


ConvoySource = Literal["route", "mavlink", "mqtt"]
ROUTE_FROM_MISSION: Final = "mission"
"""``[convoy] route``'s value for the lead ground vehicle's own mission."""
EndAction = Literal["loiter", "rtl", "land"]
Planner = Literal["auto", "road", "paper"]


@dataclass(frozen=True, slots=True)
class ConvoyConfig:
    """Where the convoy is, and (for a scripted route) how it moves."""

    speed_mps: float = 0.0
    heading_deg: float = 0.0
    source: ConvoySource = "route"
    start_north_m: float = 0.0
    start_east_m: float = 0.0
    stale_after_s: float = 3.0
    vehicles: tuple[ConvoyVehicleConfig, ...] = ()
    route_file: str | None = None  # the road it will drive (GPX/CSV), if known
    route_from_mission: bool = False  # ... or the lead ground vehicle's own mission
    part_m: float | None = None  # a vehicle this far from the lead's group has parted
    # from the convoy (None: twice the sensor radius, ``MissionConfig.convoy_part_m``)


@dataclass(frozen=True, slots=True)
class MqttConfig:
    """The broker status and coverage go to, and convoy fixes and commands come from."""

    host: str = "127.0.0.1"
    port: int = 1883
    prefix: str = "convoy"
    tls: bool = False  # TLS with the system trust store (or ``ca_file``)
    ca_file: str | None = None  # CA that signed the broker's certificate (implies TLS)
    cert_file: str | None = None  # client certificate (with ``key_file``)
    key_file: str | None = None
    username: str | None = None
    password_env: str | None = None  # name of the environment variable holding it
    password_file: str | None = None  # a file holding it (first line)


LatLon = tuple[float, float]


@dataclass(frozen=True, slots=True)
class SafetyConfig:
    """The operator's airspace and the UAVs' separation minima."""

    fence: tuple[LatLon, ...] = ()  # inclusion polygon (empty: none)
    exclusions: tuple[tuple[LatLon, ...], ...] = ()
    min_alt_m: float | None = None  # above the mission origin
    max_alt_m: float | None = None
    fence_margin_m: float = 20.0
    min_separation_m: float = 30.0  # horizontal ...
    min_vertical_separation_m: float = 3.0  # ... and vertical: closer in both is a conflict
    launch_sequence: bool = True  # take-offs near another's pad wait their turn (launch.py)


@dataclass(frozen=True, slots=True)
class MissionConfig:
    """A whole mission configuration."""

    sensor_radius_m: float
    aircraft: AircraftConfig = AircraftConfig()
    convoy: ConvoyConfig = ConvoyConfig()
    uav_count: int | None = None
    uav_list: tuple[UavConfig, ...] = ()
    origin: GeoPoint = DEFAULT_ORIGIN
    setpoint_rate_hz: float = 20.0
    altitude_step_m: float = 5.0
    setup_timeout_s: float = 120.0
    lost_after_s: float = 3.0
    altitude_band_m: float = 15.0
    end: EndAction = "loiter"
    planner: Planner = "auto"
    mqtt: MqttConfig | None = None
    tlog: str | None = None
    mission_recording: str | None = None
    safety: SafetyConfig = SafetyConfig()
    sim_speedup_floor: float | None = None
    source_system: int = GCS_SYSTEM
    source_component: int = GCS_COMPONENT

    @property
    def planned_uavs(self) -> int | None:
        """UAVs to plan for: the explicit count, else the listed UAVs, else the minimum."""
        if self.uav_count is not None:
            return self.uav_count
        return len(self.uav_list) or None

    @property
    def convoy_part_m(self) -> float:
        """How far from every other vehicle of the lead's group a ground vehicle has
        parted from the convoy (``parting``; 0: none ever does)."""
        part = self.convoy.part_m
        return default_part_m(self.sensor_radius_m) if part is None else part

    @property
    def plan_aircraft(self) -> AircraftConfig:
        """The performance the plan assumes: every UAV must be able to fly it.

        With mixed airframes that is the slowest airspeed and the largest turn
        radius of the fleet (the paper's results are for identical UAVs).
        """
        if not self.uav_list:
            return self.aircraft
        return AircraftConfig(
            airspeed_mps=min(u.aircraft.airspeed_mps for u in self.uav_list),
            turn_radius_m=max(u.aircraft.turn_radius_m for u in self.uav_list),
            altitude_m=self.aircraft.altitude_m,
        )

    def plan_request(self) -> PlanRequest:
        """The planner's view of this mission."""
        craft = self.plan_aircraft
        return PlanRequest(
            turn_radius=craft.turn_radius_m,
            sensor_radius=self.sensor_radius_m,
            uav_speed=craft.airspeed_mps,
            convoy_speed=self.convoy.speed_mps,
            convoy_heading=compass_to_planner(self.convoy.heading_deg),
            uavs=self.planned_uavs,
        )


# ------------------------------------------------------------------ validation helpers

_AIRCRAFT_KEYS = {"airspeed_mps", "turn_radius_m", "altitude_m"}


def _check_keys(table: Mapping[str, Any], name: str, allowed: set[str]) -> Mapping[str, Any]:
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise ConfigError(f"{name}.{unknown[0]}", table[unknown[0]], "unknown key")
    return table


def _table(
    data: Mapping[str, Any], key: str, allowed: set[str], name: str = ""
) -> Mapping[str, Any]:
    name = name or key
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ConfigError(name, value, "must be a table")
    return _check_keys(value, name, allowed)


MAX_SPEED_MPS = 150.0
"""Fastest airspeed or convoy speed a config may give, m/s."""
MAX_DISTANCE_M = 100_000.0
"""Largest radius or offset a config may give, metres."""
MAX_ALTITUDE_M = 10_000.0
"""Highest altitude a config may give, metres."""
MAX_SETPOINT_HZ = 100.0
"""Fastest setpoint stream: above it, frames only fill the radio."""
MAX_WAIT_S = 86_400.0
"""Longest time-out or hold a config may give, mission seconds."""
MIN_LOST_AFTER_S = 0.2
"""A UAV silent for less is not lost: a few telemetry periods."""


def _number(
    table: Mapping[str, Any],
    section: str,
    key: str,
    default: float | None,
    *,
    positive: bool = False,
    non_negative: bool = False,
    at_least: float | None = None,
    at_most: float | None = None,
) -> float:
    """A number setting; bounded, so that no value costs more than a mission can use."""
    name = f"{section}.{key}"
    if key not in table:
        if default is None:
            raise ConfigError(name, None, "is required")
        return default
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(name, value, "must be a number")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(name, value, "must be finite")
    if positive and value <= 0.0:
        raise ConfigError(name, value, "must be > 0")
    if non_negative and value < 0.0:
        raise ConfigError(name, value, "must be >= 0")
    if at_least is not None and value < at_least:
        raise ConfigError(name, value, f"must be >= {at_least:g}")
    if at_most is not None and value > at_most:
        raise ConfigError(name, value, f"must be <= {at_most:g}")
    return value


def _signing(entry: Mapping[str, Any], name: str) -> dict[str, str | None]:
    """``signing_key_file`` or ``signing_key_env`` (one), and ``signing_state``."""
    out: dict[str, str | None] = {}
    for key in ("signing_key_file", "signing_key_env", "signing_state"):
        value = entry.get(key)
        if value is not None and (not isinstance(value, str) or not value):
            raise ConfigError(f"{name}.{key}", value, "must be a non-empty string")
        out[key] = value
    if out["signing_key_file"] and out["signing_key_env"]:
        raise ConfigError(
            f"{name}.signing_key_env", out["signing_key_env"], "or a key file, not both"
        )
    if out["signing_state"] and not (out["signing_key_file"] or out["signing_key_env"]):
        raise ConfigError(f"{name}.signing_state", out["signing_state"], "needs a signing key")
    return out


def _peer(entry: Mapping[str, Any], name: str) -> tuple[str, int] | None:
    """``peer = "host:port"``: the one address a ``udpin`` link hears (pinned)."""
    if "peer" not in entry:
        return None
    value = entry["peer"]
    if not isinstance(value, str) or value.count(":") < 1:
        raise ConfigError(f"{name}.peer", value, 'must be "host:port"')
    if not str(entry.get("connection", "")).startswith("udpin:"):
        raise ConfigError(f"{name}.peer", value, "applies to udpin connections only")
    host, _, port = value.rpartition(":")
    host = host.strip("[]")
    if not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ConfigError(f"{name}.peer", value, 'must be "host:port" with a port in 1..65535')
    return host, int(port)


def _integer(
    table: Mapping[str, Any], name: str, key: str, lo: int, hi: int, default: int | None = None
) -> int:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise ConfigError(f"{name}.{key}", value, f"must be a whole number in {lo}..{hi}")
    return value


def _aircraft(table: Mapping[str, Any], name: str, base: AircraftConfig) -> AircraftConfig:
    return AircraftConfig(
        airspeed_mps=_number(
            table, name, "airspeed_mps", base.airspeed_mps, positive=True, at_most=MAX_SPEED_MPS
        ),
        turn_radius_m=_number(
            table, name, "turn_radius_m", base.turn_radius_m, positive=True, at_most=MAX_DISTANCE_M
        ),
        altitude_m=_number(
            table, name, "altitude_m", base.altitude_m, positive=True, at_most=MAX_ALTITUDE_M
        ),
    )


def _array_of_tables(data: Mapping[str, Any], key: str, name: str) -> Sequence[Mapping[str, Any]]:
    value = data.get(key, [])
    if not isinstance(value, list) or not all(isinstance(v, Mapping) for v in value):
        raise ConfigError(name, value, f"must be an array of tables ([[{name}]])")
    return value


def _origin(mission: Mapping[str, Any]) -> GeoPoint:
    if "origin" not in mission:
        return DEFAULT_ORIGIN
    table = _table(mission, "origin", {"lat", "lon", "alt"}, "mission.origin")
    lat = _number(table, "mission.origin", "lat", None)
    lon = _number(table, "mission.origin", "lon", None)
    if not -90.0 <= lat <= 90.0:
        raise ConfigError("mission.origin.lat", lat, "must be within -90..90 degrees")
    if not -180.0 <= lon <= 180.0:
        raise ConfigError("mission.origin.lon", lon, "must be within -180..180 degrees")
    return GeoPoint(
        lat,
        lon,
        _number(table, "mission.origin", "alt", 0.0, at_least=-500.0, at_most=MAX_ALTITUDE_M),
    )


def _uavs(data: Mapping[str, Any], base: AircraftConfig) -> tuple[UavConfig, ...]:
    out: list[UavConfig] = []
    seen: dict[int, str] = {}
    for i, entry in enumerate(_array_of_tables(data, "uav", "uav")):
        name = f"uav[{i}]"
        unknown = sorted(
            set(entry)
            - {"connection", "sysid", "peer", "airspeed_mps", "turn_radius_m", "altitude_m"}
            - {"signing_key_file", "signing_key_env", "signing_state"}
        )
        if unknown:
            raise ConfigError(f"{name}.{unknown[0]}", entry[unknown[0]], "unknown key")
        if "connection" not in entry:
            raise ConfigError(f"{name}.connection", None, "is required")
        sysid = _integer(entry, name, "sysid", 1, 254)
        if sysid in seen:
            raise ConfigError(f"{name}.sysid", sysid, f"is already used by {seen[sysid]}")
        seen[sysid] = name
        out.append(
            UavConfig(
                connection=validate_connection(entry["connection"], f"{name}.connection"),
                sysid=sysid,
                aircraft=_aircraft(entry, name, base),
                peer=_peer(entry, name),
                **_signing(entry, name),
            )
        )
    return tuple(out)


def _convoy(data: Mapping[str, Any]) -> ConvoyConfig:
    table = _table(
        data,
        "convoy",
        {
            "source", "speed_mps", "heading_deg", "start", "stale_after_s", "vehicle", "route",
            "part_m",
        },
    )  # fmt: skip
    route = table.get("route")
    if route is not None and (not isinstance(route, str) or not route):
        raise ConfigError("convoy.route", route, 'must be the path of a route file, or "mission"')
    from_mission = route == ROUTE_FROM_MISSION
    source = table.get("source", "route")
    if source not in ("route", "mavlink", "mqtt"):
        raise ConfigError("convoy.source", source, "must be 'route', 'mavlink' or 'mqtt'")
    start = _table(table, "start", {"north", "east"}, "convoy.start")
    vehicles = []
    for i, entry in enumerate(_array_of_tables(table, "vehicle", "convoy.vehicle")):
        name = f"convoy.vehicle[{i}]"
        _check_keys(entry, name, {"connection", "sysid", "peer"})
        vehicles.append(
            ConvoyVehicleConfig(
                connection=validate_connection(entry.get("connection"), f"{name}.connection"),
                sysid=_integer(entry, name, "sysid", 1, 254),
                peer=_peer(entry, name),
            )
        )
    if source == "mavlink" and not vehicles:
        raise ConfigError(
            "convoy.vehicle", [], "source 'mavlink' needs at least one [[convoy.vehicle]]"
        )
    if from_mission and source != "mavlink":
        raise ConfigError(
            "convoy.route",
            route,
            'reads the first [[convoy.vehicle]]\'s mission: it needs source = "mavlink"',
        )
    return ConvoyConfig(
        speed_mps=_number(
            table, "convoy", "speed_mps", 0.0, non_negative=True, at_most=MAX_SPEED_MPS
        ),
        heading_deg=_number(table, "convoy", "heading_deg", 0.0),
        source=source,
        start_north_m=_number(
            start, "convoy.start", "north", 0.0, at_least=-MAX_DISTANCE_M, at_most=MAX_DISTANCE_M
        ),
        start_east_m=_number(
            start, "convoy.start", "east", 0.0, at_least=-MAX_DISTANCE_M, at_most=MAX_DISTANCE_M
        ),
        stale_after_s=_number(
            table, "convoy", "stale_after_s", 3.0, positive=True, at_most=MAX_WAIT_S
        ),
        vehicles=tuple(vehicles),
        route_file=None if from_mission else route,
        route_from_mission=from_mission,
        part_m=(
            _number(table, "convoy", "part_m", None, non_negative=True, at_most=MAX_DISTANCE_M)
            if "part_m" in table
            else None
        ),
    )


def _mqtt(data: Mapping[str, Any]) -> MqttConfig | None:
    if "mqtt" not in data:
        return None
    raw = data["mqtt"]  # (never echoed: a password in it is a secret in a config file)
    if isinstance(raw, Mapping) and "password" in raw:
        raise ConfigError(
            "mqtt.password", "***", "must not be in a config file: give password_env or "
            "password_file",
        )  # fmt: skip
    table = _table(data, "mqtt", {"host", "port", "prefix", *_MQTT_SECURITY})
    host = table.get("host", "127.0.0.1")
    if not isinstance(host, str) or not host:
        raise ConfigError("mqtt.host", host, "must be a host name or address")
    prefix = table.get("prefix", "convoy")
    if not isinstance(prefix, str) or not prefix or any(c in prefix for c in "#+"):
        raise ConfigError("mqtt.prefix", prefix, "must be a topic prefix without wildcards")
    port = _integer(table, "mqtt", "port", 1, 65535) if "port" in table else 1883
    tls = table.get("tls", False)
    if not isinstance(tls, bool):
        raise ConfigError("mqtt.tls", tls, "must be true or false")
    text = {}
    for key in ("ca_file", "cert_file", "key_file", "username", "password_env", "password_file"):
        value = table.get(key)
        if value is not None and (not isinstance(value, str) or not value):
            raise ConfigError(f"mqtt.{key}", value, "must be a non-empty string")
        text[key] = value
    if (text["cert_file"] is None) != (text["key_file"] is None):
        raise ConfigError("mqtt.cert_file", text["cert_file"], "needs key_file, and the reverse")
    if text["password_env"] and text["password_file"]:
        raise ConfigError("mqtt.password_env", text["password_env"], "or password_file, not both")
    if (text["password_env"] or text["password_file"]) and not text["username"]:
        raise ConfigError("mqtt.username", None, "is required with a password")
    return MqttConfig(host=host, port=port, prefix=prefix.strip("/"), tls=tls, **text)


_MQTT_SECURITY = (
    "tls", "ca_file", "cert_file", "key_file", "username", "password_env", "password_file"
)  # fmt: skip


def _safety(data: Mapping[str, Any]) -> SafetyConfig:
    table = _table(
        data, "safety",
        {"fence", "fence_file", "exclusions", "min_alt_m", "max_alt_m", "fence_margin_m",
         "min_separation_m", "min_vertical_separation_m", "launch_sequence"},
    )  # fmt: skip
    if "fence" in table and "fence_file" in table:
        raise ConfigError("safety.fence_file", table["fence_file"], "or safety.fence, not both")
    fence: tuple[LatLon, ...] = ()
    exclusions: tuple[tuple[LatLon, ...], ...] = ()
    if "fence" in table:
        fence = _ring(table["fence"], "safety.fence")
    if "fence_file" in table:
        fence, exclusions = _geojson_fence(table["fence_file"])
    exclusions += tuple(
        _ring(ring, f"safety.exclusions[{i}]")
        for i, ring in enumerate(_list(table.get("exclusions", []), "safety.exclusions"))
    )
    lo = table.get("min_alt_m")
    hi = table.get("max_alt_m")
    min_alt = None if lo is None else _altitude(table, "min_alt_m")
    max_alt = None if hi is None else _altitude(table, "max_alt_m")
    if min_alt is not None and max_alt is not None and min_alt >= max_alt:
        raise ConfigError("safety.min_alt_m", min_alt, f"must be below max_alt_m ({max_alt:g})")
    sequence = table.get("launch_sequence", True)
    if not isinstance(sequence, bool):
        raise ConfigError("safety.launch_sequence", sequence, "must be true or false")
    return SafetyConfig(
        fence=fence,
        exclusions=exclusions,
        min_alt_m=min_alt,
        max_alt_m=max_alt,
        fence_margin_m=_number(
            table, "safety", "fence_margin_m", 20.0, non_negative=True, at_most=10_000.0
        ),
        min_separation_m=_number(
            table, "safety", "min_separation_m", 30.0, positive=True, at_most=10_000.0
        ),
        min_vertical_separation_m=_number(
            table, "safety", "min_vertical_separation_m", 3.0, positive=True, at_most=1000.0
        ),
        launch_sequence=sequence,
    )


def _altitude(table: Mapping[str, Any], key: str) -> float:
    return _number(table, "safety", key, None, at_least=-500.0, at_most=MAX_ALTITUDE_M)


def _list(value: object, key: str) -> list[Any]:
    if not isinstance(value, list):
        raise ConfigError(key, value, "must be a list")
    return value


def _ring(value: object, key: str) -> tuple[LatLon, ...]:
    """A polygon as [[lat, lon], ...]: at least 3 vertices, in range."""
    points = _list(value, key)
    out: list[LatLon] = []
    for i, p in enumerate(points):
        ok = isinstance(p, list | tuple) and len(p) == 2
        if not ok or not all(isinstance(c, int | float) and math.isfinite(c) for c in p):
            raise ConfigError(f"{key}[{i}]", p, "must be [lat, lon]")
        lat, lon = float(p[0]), float(p[1])
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise ConfigError(f"{key}[{i}]", p, "is out of range (lat -90..90, lon -180..180)")
        out.append((lat, lon))
    if len(out) > 1 and out[0] == out[-1]:
        out.pop()  # (a closing vertex repeated, as GeoJSON does)
    if not 3 <= len(out) <= 1000:
        raise ConfigError(key, len(out), "a polygon needs 3..1000 vertices")
    return tuple(out)


def _geojson_fence(path: object) -> tuple[tuple[LatLon, ...], tuple[tuple[LatLon, ...], ...]]:
    """A GeoJSON Polygon (a Feature or the first of a FeatureCollection): its outer ring is
    the inclusion fence, its holes the exclusions."""
    key = "safety.fence_file"
    if not isinstance(path, str) or not path:
        raise ConfigError(key, path, "must be the path of a GeoJSON file")
    try:
        with open(path, encoding="utf-8") as fh:
            geo = json.load(fh)
    except (OSError, ValueError) as exc:
        raise ConfigError(key, path, f"cannot be read as GeoJSON ({exc})") from exc
    if isinstance(geo, dict) and geo.get("type") == "FeatureCollection":
        features = geo.get("features") or [None]
        geo = features[0]
    if isinstance(geo, dict) and geo.get("type") == "Feature":
        geo = geo.get("geometry")
    if not (isinstance(geo, dict) and geo.get("type") == "Polygon"):
        raise ConfigError(key, path, "holds no GeoJSON Polygon")
    rings = geo.get("coordinates")
    if not isinstance(rings, list) or not rings:
        raise ConfigError(key, path, "its Polygon has no coordinates")
    as_latlon = [
        [[p[1], p[0]] if isinstance(p, list) and len(p) >= 2 else p for p in _list(r, key)]
        for r in rings
    ]  # (GeoJSON is lon, lat)
    outer = _ring(as_latlon[0], f"{key} outer ring")
    holes = tuple(_ring(r, f"{key} hole {i}") for i, r in enumerate(as_latlon[1:]))
    return outer, holes


def _end_action(mission: Mapping[str, Any]) -> EndAction:
    end = mission.get("end", "loiter")
    for action in get_args(EndAction):
        if end == action:
            return cast(EndAction, action)
    raise ConfigError("mission.end", end, "must be 'loiter', 'rtl' or 'land'")


def _planner(mission: Mapping[str, Any]) -> Planner:
    planner = mission.get("planner", "auto")
    for name in get_args(Planner):
        if planner == name:
            return cast(Planner, name)
    raise ConfigError("mission.planner", planner, "must be 'auto', 'road' or 'paper'")


def parse_config(data: Mapping[str, Any]) -> MissionConfig:
    """Validate a decoded TOML document into a ``MissionConfig``.

    Raises:
        ConfigError: Naming the first bad key and its value.
    """
    sections = {"mission", "aircraft", "convoy", "uav", "mqtt", "record", "safety"}
    unknown = sorted(set(data) - sections)
    if unknown:
        raise ConfigError(unknown[0], data[unknown[0]], "unknown section")
    mission = _table(
        data,
        "mission",
        {
            "sensor_radius_m", "uavs", "origin", "setpoint_rate_hz", "altitude_step_m",
            "setup_timeout_s", "lost_after_s", "altitude_band_m", "end", "planner",
            "sim_speedup_floor", "source_system", "source_component",
        },
    )  # fmt: skip
    aircraft = _aircraft(
        _table(data, "aircraft", _AIRCRAFT_KEYS),
        "aircraft",
        AircraftConfig(),
    )
    uav_count = mission.get("uavs")
    if uav_count is not None:
        uav_count = _integer(mission, "mission", "uavs", 1, 1000)
    record = _table(data, "record", {"tlog", "mission"})
    tlog = record.get("tlog")
    if tlog is not None and (not isinstance(tlog, str) or not tlog):
        raise ConfigError("record.tlog", tlog, "must be a file path")
    inputs = record.get("mission")
    if inputs is not None and (not isinstance(inputs, str) or not inputs):
        raise ConfigError("record.mission", inputs, "must be a file path")
    cfg = MissionConfig(
        sensor_radius_m=_number(
            mission, "mission", "sensor_radius_m", None, positive=True, at_most=MAX_DISTANCE_M
        ),
        aircraft=aircraft,
        convoy=_convoy(data),
        uav_count=uav_count,
        uav_list=_uavs(data, aircraft),
        origin=_origin(mission),
        setpoint_rate_hz=_number(
            mission, "mission", "setpoint_rate_hz", 20.0, at_least=1.0, at_most=MAX_SETPOINT_HZ
        ),
        altitude_step_m=_number(
            mission, "mission", "altitude_step_m", 5.0, non_negative=True, at_most=1000.0
        ),
        setup_timeout_s=_number(
            mission, "mission", "setup_timeout_s", 120.0, at_least=1.0, at_most=MAX_WAIT_S
        ),
        lost_after_s=_number(
            mission, "mission", "lost_after_s", 3.0, at_least=MIN_LOST_AFTER_S, at_most=MAX_WAIT_S
        ),
        altitude_band_m=_number(
            mission, "mission", "altitude_band_m", 15.0, positive=True, at_most=1000.0
        ),
        end=_end_action(mission),
        planner=_planner(mission),
        mqtt=_mqtt(data),
        tlog=tlog,
        mission_recording=inputs,
        safety=_safety(data),
        sim_speedup_floor=None
        if "sim_speedup_floor" not in mission
        else _number(mission, "mission", "sim_speedup_floor", None, at_least=0.01, at_most=1000.0),
        source_system=_integer(mission, "mission", "source_system", 1, 255, GCS_SYSTEM),
        source_component=_integer(mission, "mission", "source_component", 1, 255, GCS_COMPONENT),
    )
    speed = cfg.plan_aircraft.airspeed_mps
    if cfg.convoy.speed_mps >= speed:
        raise ConfigError(
            "convoy.speed_mps",
            cfg.convoy.speed_mps,
            f"must be below the UAVs' airspeed ({speed:g} m/s): they cannot keep up",
        )
    convoy_ids = {v.sysid for v in cfg.convoy.vehicles}
    for name, ids in (("uav", [u.sysid for u in cfg.uav_list]), ("convoy.vehicle", convoy_ids)):
        if cfg.source_system in ids:
            raise ConfigError(
                "mission.source_system", cfg.source_system, f"is also a {name}'s sysid"
            )
    for i, uav in enumerate(cfg.uav_list):
        if uav.sysid in convoy_ids:
            raise ConfigError(f"uav[{i}].sysid", uav.sysid, "is also a convoy vehicle's sysid")
    return cfg


def _near(config: str | Path, name: str | None) -> str | None:
    """A path from a config file, relative to the file's folder."""
    return name if name is None or Path(name).is_absolute() else str(Path(config).parent / name)


def load_config(path: str | Path) -> MissionConfig:
    """Read and validate a mission TOML file.

    Raises:
        ConfigError: Unreadable file, TOML syntax error, or a bad key.
    """
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except OSError as exc:
        raise ConfigError("config", str(path), f"cannot be read ({exc.strerror})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("config", str(path), f"is not valid TOML ({exc})") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(
            "config", str(path), f"is not UTF-8 text (byte {exc.start}: {exc.reason})"
        ) from exc
    safety = data.get("safety")
    if isinstance(safety, dict) and isinstance(safety.get("fence_file"), str):
        data = {**data, "safety": {**safety, "fence_file": _near(path, safety["fence_file"])}}
    cfg = parse_config(data)
    # Files named in the config are relative to it.
    cfg = replace(cfg, convoy=replace(cfg.convoy, route_file=_near(path, cfg.convoy.route_file)))
    if cfg.mqtt is not None:
        m = cfg.mqtt
        mqtt = replace(
            m,
            ca_file=_near(path, m.ca_file),
            cert_file=_near(path, m.cert_file),
            key_file=_near(path, m.key_file),
            password_file=_near(path, m.password_file),
        )
        cfg = replace(cfg, mqtt=mqtt)
    uavs = tuple(
        replace(
            u,
            signing_key_file=_near(path, u.signing_key_file),
            signing_state=_near(path, u.signing_state),
        )
        for u in cfg.uav_list
    )
    cfg = replace(cfg, uav_list=uavs)
    return cfg
