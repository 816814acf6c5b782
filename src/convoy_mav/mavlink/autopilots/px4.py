"""PX4: OFFBOARD, entered only while setpoints flow.

PX4 refuses to switch to OFFBOARD (and to arm in it) unless position setpoints
have arrived within ``COM_OF_LOSS_T``, and leaves it (failsafe to Hold) when they
stop. A multicopter's set-up is therefore: stream setpoints first, then
MAV_CMD_DO_SET_MODE with main mode 6, then arm (it lifts off towards the setpoint).
A fixed-wing PX4 takes off only in AUTO.TAKEOFF (runway or launch detection): arm,
NAV_TAKEOFF (param7 AMSL) and the climb to the flight altitude, after which PX4
loiters; then setpoints, then OFFBOARD. Modes are packed in HEARTBEAT.custom_mode
as ``main << 16 | sub << 24`` (``px4_custom_mode.h``). Hold is AUTO.LOITER (main 4,
sub 3).

PX4 streams by profile, not by request: its onboard profile (the offboard port,
UDP 14540) sends LOCAL_POSITION_NED at 30 Hz, ATTITUDE_QUATERNION and HIGHRES_IMU
at 50, ODOMETRY at 30, VFR_HUD at 10... (``mavlink_main.cpp``), some 250 messages a
second where the service reads a dozen. Those it never reads are stopped on its
link (SET_MESSAGE_INTERVAL -1, which PX4 applies to the link it came on, so a
ground station on another port keeps them): on the mock's profile, 28 messages a
second per UAV become 14, each one decoded on the flight loop.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink.autopilots.base import (
    Autopilot,
    CommandSpec,
    Message,
    PhaseLoop,
    SetupStep,
    SpeedParams,
    VehicleClass,
    global_setpoint,
)
from convoy_mav.types import Setpoint

__all__ = ["PX4", "px4_mode_name"]

_MAIN = {
    1: "MANUAL",
    2: "ALTCTL",
    3: "POSCTL",
    4: "AUTO",
    5: "ACRO",
    6: "OFFBOARD",
    7: "STABILIZED",
    8: "RATTITUDE",
    9: "SIMPLE",
    10: "TERMINATION",
}
_AUTO_SUB = {
    1: "READY",
    2: "TAKEOFF",
    3: "LOITER",
    4: "MISSION",
    5: "RTL",
    6: "LAND",
    8: "FOLLOW_TARGET",
    9: "PRECLAND",
    10: "VTOL_TAKEOFF",
}
_UNREAD_STREAMS: Mapping[int, float] = {
    msg_id: 0.0  # (a rate of 0 stops the stream)
    for msg_id in (
        mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
        mavlink.MAVLINK_MSG_ID_ODOMETRY,
        mavlink.MAVLINK_MSG_ID_HIGHRES_IMU,
        mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION,
        mavlink.MAVLINK_MSG_ID_ALTITUDE,
        mavlink.MAVLINK_MSG_ID_VFR_HUD,
        mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET,
        mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
    )
}
"""High-rate streams of PX4's default profiles the service never reads."""

_MODES: dict[str, tuple[int, int]] = {name: (main, 0) for main, name in _MAIN.items()}
_MODES.update({f"AUTO.{name}": (4, sub) for sub, name in _AUTO_SUB.items()})


def px4_mode_name(custom_mode: int) -> str:
    """The name of a PX4 HEARTBEAT.custom_mode (``"OFFBOARD"``, ``"AUTO.MISSION"``...;
    ``"MODE(main,sub)"`` if unknown)."""
    main = (custom_mode >> 16) & 0xFF
    sub = (custom_mode >> 24) & 0xFF
    name = _MAIN.get(main)
    if name is None:
        return f"MODE({main},{sub})"
    if main == 4:
        sub_name = _AUTO_SUB.get(sub or 4)  # AUTO without a sub mode is a mission
        return f"AUTO.{sub_name}" if sub_name else f"AUTO({sub})"
    return name


class PX4(Autopilot):
    """PX4 multicopter or fixed-wing in OFFBOARD."""

    name: ClassVar[str] = "PX4"
    streams_during_setup: ClassVar[bool] = True
    stream_loss_modes: ClassVar[frozenset[str]] = frozenset(
        {"AUTO.LOITER", "POSCTL", "ALTCTL", "STABILIZED", "MANUAL"}
    )
    """COM_OBL_RC_ACT's hold and manual fallbacks. Not its return or land: a battery, RC
    or geofence failsafe chooses those too, and is respected (unless the text says)."""

    def __init__(self, sysid: int, compid: int, frame: LocalFrame, kind: VehicleClass) -> None:
        super().__init__(sysid, compid, frame, kind)
        self.phase = PhaseLoop()
        if kind is VehicleClass.PLANE:
            self.setup_steps = (
                SetupStep.ARM,
                SetupStep.TAKEOFF,
                SetupStep.SETPOINTS,
                SetupStep.MODE,
            )
            self.speed_params = SpeedParams("FW_AIRSPD_MAX", "FW_AIRSPD_MIN")
        else:
            self.setup_steps = (SetupStep.SETPOINTS, SetupStep.MODE, SetupStep.ARM, SetupStep.CLIMB)
            self.speed_params = SpeedParams("MPC_XY_VEL_MAX")  # (OFFBOARD's velocity clamp)
            self.lean_param = "MPC_TILTMAX_AIR"

    def wanted_streams(self, rates: Mapping[int, float]) -> dict[int, float]:
        """``rates``, and the profile's high-rate streams the service never reads stopped."""
        return {**_UNREAD_STREAMS, **rates}

    def mode_name(self, custom_mode: int) -> str:
        """``"OFFBOARD"``, ``"AUTO.LOITER"``... (``"MODE(main,sub)"`` if unknown)."""
        return px4_mode_name(custom_mode)

    @property
    def external_mode(self) -> str:
        return "OFFBOARD"

    @property
    def hold_mode(self) -> str:
        return "AUTO.LOITER"

    def mode_command(self, name: str) -> CommandSpec:
        main, sub = _MODES[name]
        return CommandSpec.long(
            mavlink.MAV_CMD_DO_SET_MODE,
            float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
            float(main),
            float(sub),
        )

    def takeoff_command(self, relative_alt: float, amsl: float) -> CommandSpec | None:
        """PX4 reads NAV_TAKEOFF param7 as AMSL (yaw NaN: keep the heading)."""
        nan = float("nan")
        return CommandSpec.long(mavlink.MAV_CMD_NAV_TAKEOFF, -1.0, 0, 0, nan, nan, nan, amsl)

    def setpoint_messages(
        self, sp: Setpoint, t: float, position: tuple[float, float] | None
    ) -> list[Message]:
        """One SET_POSITION_TARGET_GLOBAL_INT; planes get the phase-corrected speed."""
        scale = 1.0
        if self.kind is VehicleClass.PLANE and position is not None and not sp.hold:
            v = (sp.vn * sp.vn + sp.ve * sp.ve) ** 0.5
            if v > 1e-6:
                scale = self.phase.speed(sp, *position, t) / v
        return [global_setpoint(sp, self.frame, self.sysid, self.compid, t, speed_scale=scale)]
