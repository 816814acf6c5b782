"""The autopilot's pure parts: stream scheduler, parameter table, firmware tables."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as mavlink

from sitl_mock.params import Knob, ParamDef, ParamTable
from sitl_mock.personality import Behaviour, Personality, firmware_for
from sitl_mock.streams import AIRCRAFT_DEFAULT_INTERVALS, StreamScheduler

HB = mavlink.MAVLINK_MSG_ID_HEARTBEAT
GPI = mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
ATT = mavlink.MAVLINK_MSG_ID_ATTITUDE


def _emissions(s: StreamScheduler, msg_id: int, until: float, dt: float = 0.01) -> list[float]:
    times = []
    for k in range(1, round(until / dt) + 1):
        if msg_id in s.due(k * dt):
            times.append(round(k * dt, 6))
    return times


# ================================================================== streams
def test_scheduler_emits_on_fixed_deadlines_from_boot() -> None:
    s = StreamScheduler({HB: 1.0, GPI: 0.25}, now=0.0)
    assert _emissions(s, GPI, 1.0) == [0.01, 0.25, 0.5, 0.75, 1.0]


def test_scheduler_skips_missed_periods_instead_of_bursting() -> None:
    s = StreamScheduler({GPI: 0.1}, now=0.0)
    assert s.due(0.0) == [GPI]
    assert s.due(5.0) == [GPI]  # five seconds late: one message, not fifty
    assert s.due(5.05) == []
    assert s.due(5.1) == [GPI]


def test_scheduler_disabled_start_keeps_only_always_on() -> None:
    s = StreamScheduler(AIRCRAFT_DEFAULT_INTERVALS, now=0.0, enabled=False)
    assert s.due(0.0) == [HB]
    assert s.interval(GPI) is None and s.interval_us(GPI) == -1
    assert s.interval_us(9999) == 0  # not available at all


def test_scheduler_interval_changes_and_restart() -> None:
    s = StreamScheduler({HB: 1.0, ATT: 0.1}, now=0.0)
    s.due(0.0)
    s.set_interval(ATT, 0.5, now=0.02)  # due sooner of "next" (0.1) and now + 0.5
    assert s.due(0.1) == [ATT] and s.due(0.5) == [] and s.due(0.6) == [ATT]
    assert s.set_message_interval(ATT, -1, now=1.0) and s.interval(ATT) is None
    assert s.set_message_interval(ATT, 0, now=1.0) and s.interval(ATT) == 0.1
    assert not s.set_message_interval(ATT, -5, now=1.0)
    assert not s.set_message_interval(GPI, 1000, now=1.0)  # not streamable here
    s.restart(2.0, enabled=False)
    assert s.due(2.0) == [HB]
    with pytest.raises(ValueError, match="interval"):
        s.set_interval(ATT, 0.0, 2.0)
    with pytest.raises(KeyError):
        s.set_interval(GPI, 1.0, 2.0)


def test_request_data_stream_sets_groups() -> None:
    s = StreamScheduler(AIRCRAFT_DEFAULT_INTERVALS, now=0.0, enabled=False)
    s.request_data_stream(mavlink.MAV_DATA_STREAM_EXTRA1, 5, 1, now=0.0)
    assert s.interval(ATT) == pytest.approx(0.2)
    assert s.interval(GPI) is None
    s.request_data_stream(mavlink.MAV_DATA_STREAM_EXTRA1, 0, 1, now=0.0)  # no change
    assert s.interval(ATT) == pytest.approx(0.2)
    s.request_data_stream(mavlink.MAV_DATA_STREAM_ALL, 2, 1, now=0.0)
    assert s.interval(GPI) == pytest.approx(0.5) and s.interval(ATT) == pytest.approx(0.5)
    s.request_data_stream(mavlink.MAV_DATA_STREAM_ALL, 2, 0, now=0.0)
    assert s.interval(GPI) is None and s.interval(HB) == 1.0


def test_stream_groups_switch_on_what_the_firmware_does() -> None:
    """ArduPilot 4.7: asking for positions brings LOCAL_POSITION_NED too; no group holds
    EXTENDED_SYS_STATE (only SET_MESSAGE_INTERVAL starts it); stopping all groups and
    then asking for single messages gives exactly those (what the service does)."""
    s = StreamScheduler(AIRCRAFT_DEFAULT_INTERVALS, now=0.0, enabled=False)
    local = mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED
    ext = mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE
    s.request_data_stream(mavlink.MAV_DATA_STREAM_POSITION, 10, 1, now=0.0)
    assert s.interval(GPI) == pytest.approx(0.1) and s.interval(local) == pytest.approx(0.1)
    s.request_data_stream(mavlink.MAV_DATA_STREAM_ALL, 1, 1, now=0.0)
    assert s.interval(ext) is None
    s.request_data_stream(mavlink.MAV_DATA_STREAM_ALL, 0, 0, now=0.0)
    assert s.set_message_interval(GPI, 100_000, now=0.0)
    assert s.set_message_interval(ext, 5_000_000, now=0.0)
    on = {m for m in AIRCRAFT_DEFAULT_INTERVALS if s.interval(m) is not None}
    assert on == {HB, GPI, ext}


# =================================================================== params
def test_param_table_lookup_scaling_and_limits() -> None:
    table = ParamTable(
        [
            ParamDef("WPNAV_SPEED", Knob.AIRSPEED, scale=100.0, minimum=0.5),
            ParamDef("X", Knob.WARMUP),
        ]
    )
    assert table.lookup("WPNAV_SPEED") == 0
    assert table.lookup("WPNAV_SPEED\x00\x00") == 0
    assert table.lookup("", 1) == 1 and table.lookup("", 2) is None
    assert table.lookup("NOPE") is None
    assert table.to_physical(0, 1250.0) == pytest.approx(12.5)
    with pytest.raises(ValueError, match="WPNAV_SPEED must be >= 50"):
        table.to_physical(0, 10.0)
    with pytest.raises(ValueError, match="finite"):
        table.to_physical(0, math.nan)
    msg = table.param_value(0, 12.5)
    assert (msg.param_value, msg.param_count, msg.param_index) == (1250.0, 2, 0)
    with pytest.raises(ValueError, match="unique"):
        ParamTable([ParamDef("A", Knob.WARMUP), ParamDef("A", Knob.SYSID)])
    with pytest.raises(ValueError, match="16"):
        ParamDef("A_VERY_LONG_PARAMETER", Knob.WARMUP)


def test_param_set_reports_the_value_in_force() -> None:
    table = ParamTable(
        [ParamDef("T", Knob.SETPOINT_TIMEOUT), ParamDef("ID", Knob.SYSID, read_only=True)]
    )
    values = {Knob.SETPOINT_TIMEOUT: 1.0, Knob.SYSID: 3.0}

    def put(knob: Knob, value: float) -> None:
        if value > 10.0:
            raise ValueError("too long")
        values[knob] = value

    ok = table.set("T", 2.0, values.__getitem__, put)
    assert ok is not None and ok[0].param_value == 2.0 and ok[1] is None
    refused = table.set("T", 20.0, values.__getitem__, put)
    assert refused is not None and refused[0].param_value == 2.0 and "too long" in str(refused[1])
    ro = table.set("ID", 9.0, values.__getitem__, put)
    assert ro is not None and ro[0].param_value == 3.0
    assert table.set("NOPE", 1.0, values.__getitem__, put) is None


# ================================================================ firmwares
def test_px4_custom_mode_encoding() -> None:
    fw = firmware_for(Personality.PX4, "copter")
    offboard = fw.mode("OFFBOARD")
    assert offboard.custom_mode == 6 << 16 and offboard.behaviour is Behaviour.EXTERNAL
    assert fw.decode_mode((4 << 16) | (3 << 24)) == fw.mode("AUTO.LOITER")
    assert fw.decode_mode(4 << 16) == fw.mode("AUTO.MISSION")  # AUTO without sub: mission
    assert fw.decode_mode((3 << 16) | (7 << 24)) == fw.mode("POSCTL")  # sub ignored
    assert fw.decode_do_set_mode(4.0, 2.0) == fw.mode("AUTO.TAKEOFF")
    assert fw.decode_do_set_mode(42.0, 0.0) is None
    assert fw.decode_do_set_mode(math.nan, 0.0) is None


@pytest.mark.parametrize(
    ("frame", "numbers"),
    [
        ("copter", {"STABILIZE": 0, "GUIDED": 4, "LOITER": 5, "RTL": 6, "LAND": 9, "BRAKE": 17}),
        (
            "plane",
            {
                "MANUAL": 0,
                "CIRCLE": 1,
                "AUTO": 10,
                "RTL": 11,
                "LOITER": 12,
                "TAKEOFF": 13,
                "GUIDED": 15,
            },
        ),
        ("rover", {"MANUAL": 0, "HOLD": 4, "AUTO": 10, "GUIDED": 15}),
    ],
)
def test_ardupilot_mode_numbers(frame: str, numbers: dict[str, int]) -> None:
    fw = firmware_for(Personality.ARDUPILOT, frame)  # type: ignore[arg-type]
    for name, number in numbers.items():
        assert fw.mode(name).custom_mode == number
        assert fw.decode_mode(number) == fw.mode(name)
        assert fw.decode_do_set_mode(float(number), 0.0) == fw.mode(name)


def test_loiter_circle_conventions() -> None:
    ap = firmware_for(Personality.ARDUPILOT, "plane")
    assert ap.loiter_circle(150.0, 0.0, 80.0) == (150.0, True)
    assert ap.loiter_circle(150.0, 1.0, 80.0) == (150.0, False)  # param4 != 0: CCW
    assert ap.loiter_circle(-150.0, math.nan, 80.0) == (80.0, True)  # radius must be > 0
    px4 = firmware_for(Personality.PX4, "plane")
    assert px4.loiter_circle(-120.0, math.nan, 80.0) == (120.0, False)
    assert px4.loiter_circle(math.nan, math.nan, 80.0) == (80.0, True)


def test_refusals_speak_each_firmware() -> None:
    px4 = firmware_for(Personality.PX4, "plane")
    ap = firmware_for(Personality.ARDUPILOT, "plane")
    assert px4.reject_result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    assert ap.reject_result == mavlink.MAV_RESULT_FAILED
    assert px4.arm_denied_text("x").startswith("Arming denied!")
    assert ap.arm_denied_text("x") == "Arm: x"  # ArduPilot 4.5+: "Arm:" on a refusal
    assert "Offboard" in px4.mode_denied_text(px4.mode("OFFBOARD"), "no offboard signal")
    assert ap.mode_denied_text(ap.mode("GUIDED"), "requires position") == (
        "Mode change to GUIDED failed: requires position"
    )
    assert px4.streams_on_boot and not ap.streams_on_boot
