"""Test fakes: an in-memory ground station joined to a SimVehicle through MAVLink bytes.

Every exchange goes through bytes: a pymavlink ``MAVLink`` object plays the GCS
and packs each message, the vehicle gets what a separate parser decodes from
those bytes, and every reply is packed with the vehicle's own encoder and
parsed again -- the path the UDP server takes, minus the sockets (h11 style).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.geo import GeoPoint, LocalFrame
from sitl_mock.autopilot import Personality, SimVehicle, TruthRow, VehicleSpec
from sitl_mock.clock import Speedup
from sitl_mock.kinematics import AirframeParams

WORLD = LocalFrame(GeoPoint(47.397742, 8.545594, 488.0))
GCS_SYSID, GCS_COMPID = 255, 190
PX4, AP = Personality.PX4, Personality.ARDUPILOT
DT = 0.01

Msg = Any


def make_vehicle(
    personality: Personality = PX4,
    frame: str = "copter",
    *,
    sysid: int = 1,
    home_ned: tuple[float, float, float] = (0.0, 0.0, 0.0),
    warmup_s: float = 3.0,
    speedup: Speedup | None = None,
    **kw: Any,
) -> SimVehicle:
    physics = {k: kw.pop(k) for k in list(kw) if k in AirframeParams.__dataclass_fields__}
    spec = VehicleSpec(
        sysid=sysid,
        kind="aircraft",
        personality=personality,
        airframe=AirframeParams(frame=frame, **physics),  # type: ignore[arg-type]
        home=WORLD.to_geo(*home_ned),
        warmup_s=warmup_s,
        **kw,
    )
    return SimVehicle(spec, WORLD, 0.0, speedup)


class Gcs:
    """A ground station joined to one SimVehicle through in-memory MAVLink bytes.

    ``received`` keeps every decoded message the vehicle sent, with the sim time.
    """

    def __init__(
        self,
        vehicle: SimVehicle,
        now: float = 0.0,
        *,
        system: int = GCS_SYSID,
        component: int = GCS_COMPID,
    ) -> None:
        self.vehicle = vehicle
        self.now = now
        self._gcs_tx = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
        self._gcs_rx = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
        self._veh_tx = mavlink.MAVLink(None, srcSystem=vehicle.sysid, srcComponent=vehicle.compid)
        self._veh_rx = mavlink.MAVLink(None, srcSystem=vehicle.sysid, srcComponent=vehicle.compid)
        self.received: list[tuple[float, Msg]] = []

    def _decode(self, msgs: list[Msg]) -> list[Msg]:
        out: list[Msg] = []
        for m in msgs:
            out.extend(self._gcs_rx.parse_buffer(bytes(m.pack(self._veh_tx))) or [])
        self.received.extend((self.now, m) for m in out)
        return out

    def send(self, msg: Msg) -> list[Msg]:
        """Send one message to the vehicle; its immediate replies, decoded."""
        decoded = self._veh_rx.parse_buffer(bytes(msg.pack(self._gcs_tx)))
        assert decoded is not None and len(decoded) == 1
        return self._decode(self.vehicle.handle(decoded[0], self.now))

    def command(
        self, command: int, *params: float, target: int | None = None
    ) -> tuple[Msg, list[Msg]]:
        """COMMAND_LONG; returns the COMMAND_ACK and the other replies."""
        p = [*params, *[0.0] * (7 - len(params))]
        sysid = self.vehicle.sysid if target is None else target
        replies = self.send(mavlink.MAVLink_command_long_message(sysid, 1, command, 0, *p))
        return _split_ack(replies, command)

    def command_int(
        self,
        command: int,
        frame: int,
        p: tuple[float, float, float, float],
        x: int,
        y: int,
        z: float,
    ) -> tuple[Msg, list[Msg]]:
        """COMMAND_INT; returns the COMMAND_ACK and the other replies."""
        msg = mavlink.MAVLink_command_int_message(
            self.vehicle.sysid, 1, frame, command, 0, 0, *p, x, y, z
        )
        return _split_ack(self.send(msg), command)

    def set_mode(self, main: float, sub: float = 0.0) -> Msg:
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
        return self.command(mavlink.MAV_CMD_DO_SET_MODE, base, main, sub)[0]

    def arm(self, force: bool = False) -> Msg:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196 if force else 0)[0]

    def run(
        self, seconds: float, every: Callable[[float], None] | None = None, telemetry: bool = True
    ) -> list[Msg]:
        """Advance sim time in 10 ms physics steps, as the server does.

        Args:
            seconds: Sim time to run.
            every: Called before each step with the step's end time.
            telemetry: Collect the due telemetry (off for speed in long flights).

        Returns:
            Everything the vehicle sent meanwhile (events and telemetry), decoded.
        """
        start = self.now
        out: list[Msg] = []
        for k in range(1, round(seconds / DT) + 1):
            self.now = start + k * DT
            if every is not None:
                every(self.now)
            out += self._decode(self.vehicle.step(self.now, DT))
            if telemetry:
                out += self._decode(self.vehicle.due_telemetry(self.now))
        return out

    def truth(self) -> TruthRow:
        return self.vehicle.truth(self.now)

    def heartbeat(self) -> Msg:
        """The vehicle's HEARTBEAT right now (asked for with REQUEST_MESSAGE)."""
        ack, extra = self.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HEARTBEAT)
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        return extra[0]


def _split_ack(replies: list[Msg], command: int) -> tuple[Msg, list[Msg]]:
    acks = [m for m in replies if m.get_type() == "COMMAND_ACK"]
    assert len(acks) == 1, replies
    assert acks[0].command == command
    return acks[0], [m for m in replies if m is not acks[0]]


def of_type(msgs: list[Msg], name: str) -> list[Msg]:
    return [m for m in msgs if m.get_type() == name]


def texts(msgs: list[Msg]) -> list[str]:
    return [m.text for m in of_type(msgs, "STATUSTEXT")]


def px4_mode(main: int, sub: int = 0) -> int:
    return (main << 16) | (sub << 24)


def warm_gcs(vehicle: SimVehicle) -> Gcs:
    gcs = Gcs(vehicle)
    gcs.run(vehicle.spec.warmup_s + 0.1, telemetry=False)
    return gcs


def offboard_setpoint(gcs: Gcs, z: float = -10.0) -> list[Msg]:
    ignore = 0b0000_1101_1111_1000  # position only (velocity, acceleration, yaw ignored)
    msg = mavlink.MAVLink_set_position_target_local_ned_message(
        0, gcs.vehicle.sysid, 1, mavlink.MAV_FRAME_LOCAL_NED, ignore,
        0.0, 0.0, z, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    )  # fmt: skip
    return gcs.send(msg)
