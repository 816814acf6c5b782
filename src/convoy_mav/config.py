"""Mission configuration: TOML in, frozen dataclasses out.

Every error names the key (as a dotted TOML path) and the offending value and
is raised as ``ConfigError``, which the CLI turns into a one-line message and
exit status 2.  Unknown keys are errors too: a typo must not silently fall
back to a default.

Schema (all lengths metres, speeds m/s, headings compass degrees)::

    [mission]
    sensor_radius_m = 100.0     # r: radius of the disk the camera sees
    uavs = 5                    # optional; default the paper's minimum

    [aircraft]                  # defaults for every UAV
    airspeed_mps = 18.0
    turn_radius_m = 150.0       # R: minimum turn radius at that airspeed
    altitude_m = 100.0          # above home

    [convoy]
    speed_mps = 0.0             # 0: stationary convoy (Section III)
    heading_deg = 0.0           # compass course: 0 north, 90 east
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from convoy_mav.errors import ConfigError
from convoy_mav.planning.export import compass_to_planner
from convoy_mav.planning.plan import PlanRequest

__all__ = ["AircraftConfig", "ConvoyConfig", "MissionConfig", "load_config", "parse_config"]


@dataclass(frozen=True, slots=True)
class AircraftConfig:
    """Performance every UAV of the mission shares."""

    airspeed_mps: float = 18.0
    turn_radius_m: float = 150.0
    altitude_m: float = 100.0


@dataclass(frozen=True, slots=True)
class ConvoyConfig:
    """How the convoy moves (for planning; live sources come later)."""

    speed_mps: float = 0.0
    heading_deg: float = 0.0


@dataclass(frozen=True, slots=True)
class MissionConfig:
    """A whole mission configuration."""

    sensor_radius_m: float
    aircraft: AircraftConfig = AircraftConfig()
    convoy: ConvoyConfig = ConvoyConfig()
    uavs: int | None = None

    def plan_request(self) -> PlanRequest:
        """The planner's view of this mission."""
        return PlanRequest(
            turn_radius=self.aircraft.turn_radius_m,
            sensor_radius=self.sensor_radius_m,
            uav_speed=self.aircraft.airspeed_mps,
            convoy_speed=self.convoy.speed_mps,
            convoy_heading=compass_to_planner(self.convoy.heading_deg),
            uavs=self.uavs,
        )


def _table(data: Mapping[str, Any], key: str, allowed: set[str]) -> Mapping[str, Any]:
    value = data.get(key, {})
    if not isinstance(value, Mapping):
        raise ConfigError(key, value, "must be a table")
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise ConfigError(f"{key}.{unknown[0]}", value[unknown[0]], "unknown key")
    return value


def _number(
    table: Mapping[str, Any],
    section: str,
    key: str,
    default: float | None,
    *,
    positive: bool = False,
    non_negative: bool = False,
) -> float:
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
    return value


def parse_config(data: Mapping[str, Any]) -> MissionConfig:
    """Validate a decoded TOML document into a ``MissionConfig``.

    Raises:
        ConfigError: Naming the first bad key and its value.
    """
    unknown = sorted(set(data) - {"mission", "aircraft", "convoy"})
    if unknown:
        raise ConfigError(unknown[0], data[unknown[0]], "unknown section")
    mission = _table(data, "mission", {"sensor_radius_m", "uavs"})
    aircraft = _table(data, "aircraft", {"airspeed_mps", "turn_radius_m", "altitude_m"})
    convoy = _table(data, "convoy", {"speed_mps", "heading_deg"})
    uavs = mission.get("uavs")
    if uavs is not None and (isinstance(uavs, bool) or not isinstance(uavs, int) or uavs < 1):
        raise ConfigError("mission.uavs", uavs, "must be a whole number >= 1")
    defaults = AircraftConfig()
    cfg = MissionConfig(
        sensor_radius_m=_number(mission, "mission", "sensor_radius_m", None, positive=True),
        aircraft=AircraftConfig(
            airspeed_mps=_number(
                aircraft, "aircraft", "airspeed_mps", defaults.airspeed_mps, positive=True
            ),
            turn_radius_m=_number(
                aircraft, "aircraft", "turn_radius_m", defaults.turn_radius_m, positive=True
            ),
            altitude_m=_number(
                aircraft, "aircraft", "altitude_m", defaults.altitude_m, positive=True
            ),
        ),
        convoy=ConvoyConfig(
            speed_mps=_number(convoy, "convoy", "speed_mps", 0.0, non_negative=True),
            heading_deg=_number(convoy, "convoy", "heading_deg", 0.0),
        ),
        uavs=uavs,
    )
    if cfg.convoy.speed_mps >= cfg.aircraft.airspeed_mps:
        raise ConfigError(
            "convoy.speed_mps",
            cfg.convoy.speed_mps,
            f"must be below aircraft.airspeed_mps ({cfg.aircraft.airspeed_mps:g}): "
            "the UAVs cannot keep up with a faster convoy",
        )
    return cfg


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
    return parse_config(data)
