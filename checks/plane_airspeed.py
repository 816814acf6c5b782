"""What an ArduPlane flies when told an airspeed: VFR_HUD's airspeed against its ground speed.

    python checks/plane_airspeed.py [CONNECTION] [SPEED ...]

Against one ArduPlane SITL instance, no wind (``arduplane --model plane --defaults
Tools/autotest/models/plane.parm --home LAT,LON,ALT,0``; CONNECTION defaults to its
``tcp:127.0.0.1:5760``): TAKEOFF mode to 100 m, GUIDED, a 400-m loiter round home, then
each SPEED (default 14 18 22 m/s) by DO_CHANGE_SPEED for 200 s of its own time. Prints the
medians of the second half: VFR_HUD airspeed, ground speed, their ratio, and the
standard atmosphere's ``EAS2TAS`` at that altitude. ArduPlane's airspeeds are equivalent
airspeeds, so a real plane's ratio is ``EAS2TAS``; SITL's is ``EAS2TAS^2`` (its simulated
pitot divides by ``EAS2TAS`` twice, ``SITL_State::_update_airspeed``): 1.068-1.071 at
684 m AMSL on 2026-12-02, against 1.034.
"""

from __future__ import annotations

import math
import statistics
import sys
import time

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.atmosphere import eas2tas

_TAKEOFF, _GUIDED = 13, 15  # ArduPlane custom modes
_HOLD_S = 200.0  # autopilot seconds at each speed
_ALT_M = 100.0  # above home
_RADIUS_M = 400.0
_USAGE = "python checks/plane_airspeed.py [CONNECTION] [SPEED ...]"


def _command(link: mavutil.mavfile, command: int, *params: float) -> None:
    padded = [*params, *([0.0] * (7 - len(params)))]
    link.mav.command_long_send(link.target_system, link.target_component, command, 0, *padded)


def _take_off(link: mavutil.mavfile) -> mavlink.MAVLink_global_position_int_message:
    """TKOFF_ALT, TAKEOFF mode and ARM until armed; GUIDED once 90 % up: the fix then."""
    for msg_id, hz in ((mavlink.MAVLINK_MSG_ID_VFR_HUD, 4.0),
                       (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 4.0)):  # fmt: skip
        _command(link, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz)
    link.mav.param_set_send(
        link.target_system, link.target_component, b"TKOFF_ALT", _ALT_M,
        mavlink.MAV_PARAM_TYPE_REAL32,
    )  # fmt: skip
    deadline = time.monotonic() + 300.0
    while True:
        _command(link, mavlink.MAV_CMD_DO_SET_MODE, 1.0, _TAKEOFF)
        _command(link, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0)
        beat = link.recv_match(type="HEARTBEAT", blocking=True, timeout=3.0)
        if beat is not None and beat.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED:
            break
        if time.monotonic() > deadline:
            sys.exit("not armed within 300 s (its position estimate?)")
    while True:
        fix = link.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=10.0)
        if fix is None:
            sys.exit("no GLOBAL_POSITION_INT")
        if fix.relative_alt >= 900.0 * _ALT_M:  # (mm)
            _command(link, mavlink.MAV_CMD_DO_SET_MODE, 1.0, _GUIDED)
            return fix


def _fly(link: mavutil.mavfile, home: mavlink.MAVLink_global_position_int_message,
         speed: float) -> tuple[float, float, float]:  # fmt: skip
    """(airspeed, ground speed, AMSL) medians over the second half of ``_HOLD_S``."""
    link.mav.command_int_send(
        link.target_system, link.target_component, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1.0, 0.0, _RADIUS_M, 0.0, home.lat, home.lon,
        _ALT_M,
    )  # fmt: skip
    _command(link, mavlink.MAV_CMD_DO_CHANGE_SPEED, 0.0, speed, -1.0)
    rows: list[tuple[float, float, float, float]] = []  # (boot s, airspeed, ground, amsl)
    air = math.nan
    start: float | None = None
    while start is None or rows[-1][0] - start < _HOLD_S:
        msg = link.recv_match(type=["VFR_HUD", "GLOBAL_POSITION_INT"], blocking=True, timeout=10)
        if msg is None:
            sys.exit("telemetry stopped")
        if msg.get_type() == "VFR_HUD":
            air = msg.airspeed
            continue
        t = msg.time_boot_ms / 1000.0
        start = t if start is None else start
        rows.append((t, air, math.hypot(msg.vx, msg.vy) / 100.0, msg.alt / 1000.0))
    half = [r for r in rows if r[0] - start >= _HOLD_S / 2 and math.isfinite(r[1])]

    def median(k: int) -> float:
        return statistics.median(r[k] for r in half)

    return median(1), median(2), median(3)


def main(argv: list[str]) -> None:
    connection = argv[0] if argv and ":" in argv[0] else "tcp:127.0.0.1:5760"
    speeds = []
    for arg in argv:
        if ":" in arg:
            continue
        try:
            speed = float(arg)
        except ValueError:
            speed = math.nan
        if not (math.isfinite(speed) and speed > 0.0):
            sys.exit(f"{arg!r}: not an airspeed (m/s > 0); usage: {_USAGE}")
        speeds.append(speed)
    speeds = speeds or [14.0, 18.0, 22.0]
    link = mavutil.mavlink_connection(connection, source_system=255)
    link.wait_heartbeat()
    home = _take_off(link)
    print("told m/s  VFR_HUD airspeed  ground speed  ratio  AMSL m  EAS2TAS there")
    for speed in speeds:
        air, ground, amsl = _fly(link, home, speed)
        scale = eas2tas(amsl)
        print(f"{speed:8.1f}  {air:16.2f}  {ground:12.2f}  {ground / air:5.3f}  {amsl:6.0f}  "
              f"{scale:.3f}")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
