"""Links that lose the one message that matters, or lag, against sitl_mock's autopilots
over real UDP: a stream request, the HEARTBEATs that show an arming, a round trip.

Each case drops exactly that (the rest of the link is clean), so what the vehicle does
without it is deterministic; ``test_service_faults`` and ``benchmarks/soak.py`` fly
the random losses.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import pytest
from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.clock import MissionClock
from convoy_mav.geo import LocalFrame
from convoy_mav.mavlink import MavLink
from convoy_mav.types import VehicleStatus
from convoy_mav.vehicle import EventKind, Vehicle, VehicleEvent
from sitl_mock.config import MockConfig
from tests.hostspeed import host_speedup
from tests.integration.test_vehicle import has_status, running, sim_sleep, until

if TYPE_CHECKING:
    from sitl_mock.server import MockFleet
    from tests.conftest import StartMock

pytestmark = [pytest.mark.integration, pytest.mark.timeout(60)]

SPEEDUP = host_speedup(40.0)
_MSG_NAMES = {i: c.msgname for i, c in mavlink.mavlink_map.items()}
ALTITUDE = 60.0


class DroppingLink:
    """A vehicle's link that loses the messages ``lose(msg)`` picks on their way out."""

    def __init__(self, link: MavLink, lose: Callable[[Any], bool]) -> None:
        self.link, self.lose = link, lose
        self.lost: list[Any] = []

    def send(self, msg: Any) -> bool:
        if self.lose(msg):
            self.lost.append(msg)
            return True  # (gone on the link: the sender cannot know)
        return self.link.send(msg)


def _interval_request(msg: Any, msg_id: int) -> bool:
    return (
        msg.get_type() == "COMMAND_LONG"
        and msg.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
        and int(msg.param1) == msg_id
    )


async def _plane(start_mock: StartMock) -> tuple[MockFleet, MockConfig]:
    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality="ardupilot", frame="plane",
        airspeed=18.0, turn_radius=80.0, warmup=1.0,
    )  # fmt: skip
    return await start_mock(config, record_truth=True), config


async def test_a_stream_request_lost_on_the_link_is_asked_again(start_mock: StartMock) -> None:
    """Lost on the link: the set-up's SET_MESSAGE_INTERVAL for GPS_RAW_INT (the stop of
    ArduPilot's boot groups sent with it arrived), and the flight's for
    GLOBAL_POSITION_INT. Before, set-up could wait its whole time-out for a fix it was
    never sent ("no position fix within 120 s (GPS fix type 1)"), and the flight
    rates went out behind another stop, so a plane whose position request was lost
    flew blind until the whole set was asked for again. Now a message unheard for a
    few of its periods is asked for again, alone, and only the first request of a
    set-up stops the groups."""
    fleet, config = await _plane(start_mock)
    await sim_sleep(fleet, 2.0)  # (warm: positions come at once)
    asked: dict[int, int] = {}
    sent: list[Any] = []

    def lose(msg: Any) -> bool:
        sent.append(msg)
        for msg_id, nth in ((mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, 1),
                            (mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 2)):  # fmt: skip
            if _interval_request(msg, msg_id):
                asked[msg_id] = asked.get(msg_id, 0) + 1
                return asked[msg_id] == nth
        return False

    events: list[VehicleEvent] = []
    fixes: list[float] = []
    mav = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    link = DroppingLink(mav, lose)
    vehicle = Vehicle(
        1, link, MissionClock(rate_hint=SPEEDUP), LocalFrame(config.origin),
        on_event=events.append, altitude=ALTITUDE, setup_timeout=60.0,
        on_telemetry=lambda tel: fixes.append(tel.t),
    )  # fmt: skip
    async with mav, running(vehicle.run()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=20)
        flying = vehicle.clock.now()
        await sim_sleep(fleet, 12.0)
    assert len(link.lost) == 2
    assert vehicle.counters["streams_asked_again"] >= 1
    stops = [m for m in sent if m.get_type() == "REQUEST_DATA_STREAM"]
    assert len(stops) == 1  # (the set-up's first request)
    in_flight = [t for t in fixes if t >= flying]
    assert max(b - a for a, b in itertools.pairwise(in_flight)) < 1.0
    assert not [e for e in events if e.kind is EventKind.FAILED]
    sim = fleet.vehicles[1]
    for msg_id in vehicle.firmware.wanted_streams(vehicle.flight_stream_rates):  # type: ignore[union-attr]
        assert sim.message_interval_us(msg_id) > 0, msg_id  # every stream flows in flight


async def test_streams_left_flowing_by_lost_requests_are_slowed_again(
    start_mock: StartMock,
) -> None:
    """Lost on the link: the stop of ArduPlane's boot groups (every member at 1 Hz) and
    the flight's slowing of ATTITUDE (1 Hz at set-up, 0.2 in flight). Nothing went
    unheard, so nothing was asked again: ArduPlane SITL behind a lossy radio sent one
    plane's whole boot profile, 2.6 times the others' telemetry, for the whole flight.
    Now a stream flowing more than twice as fast as asked is asked again, message by
    message (SET_MESSAGE_INTERVAL, -1 to stop), with no group stop to race."""
    fleet, config = await _plane(start_mock)
    await sim_sleep(fleet, 2.0)
    attitude = 0

    def lose(msg: Any) -> bool:
        nonlocal attitude
        if msg.get_type() == "REQUEST_DATA_STREAM":
            return True
        if _interval_request(msg, mavlink.MAVLINK_MSG_ID_ATTITUDE):
            attitude += 1
            return attitude == 2  # (the flight's)
        return False

    events: list[VehicleEvent] = []
    heard: list[str] = []

    def handle(msg: Any) -> None:
        heard.append(msg.get_type())
        vehicle.handle(msg)

    mav = MavLink(fleet.endpoint(1).connect, handle)
    link = DroppingLink(mav, lose)
    vehicle = Vehicle(
        1, link, MissionClock(rate_hint=SPEEDUP), LocalFrame(config.origin),
        on_event=events.append, altitude=ALTITUDE, setup_timeout=60.0,
    )  # fmt: skip
    sim = fleet.vehicles[1]
    boot_only = [
        mavlink.MAVLINK_MSG_ID_VFR_HUD,
        mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
        mavlink.MAVLINK_MSG_ID_SYSTEM_TIME,
        mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
    ]
    async with mav, running(vehicle.run()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=20)
        await sim_sleep(fleet, 25.0)
    assert [m.get_type() for m in link.lost] == ["REQUEST_DATA_STREAM", "COMMAND_LONG"]
    assert all(_MSG_NAMES[m] in heard for m in boot_only)  # (the stop was lost: they flowed)
    assert all(sim.message_interval_us(m) == -1 for m in boot_only)
    assert sim.message_interval_us(mavlink.MAVLINK_MSG_ID_ATTITUDE) == 5_000_000
    assert vehicle.counters["streams_stopped"] >= len(boot_only)  # (never asked for)
    assert vehicle.counters["streams_asked_again"] >= 1  # (ATTITUDE's rate)
    for msg_id in vehicle.firmware.wanted_streams(vehicle.flight_stream_rates):  # type: ignore[union-attr]
        assert sim.message_interval_us(msg_id) > 0, msg_id  # (what is wanted still flows)
    assert not [e for e in events if e.kind is EventKind.FAILED]


async def test_an_arming_whose_heartbeats_are_lost_climbs_before_guided(
    start_mock: StartMock,
) -> None:
    """The arming's COMMAND_ACK comes, and the HEARTBEATs that would show it armed are
    lost for 4 s. Before, the take-off's wait took "not armed" for a disarm and set-up
    went on to GUIDED with the plane a few metres up in its TAKEOFF climb: it loitered
    there, and set-up gave up at 'take off' with "Armed" the autopilot's last word.
    Now GUIDED is sent only once the climb to the flight altitude is done."""
    fleet, config = await _plane(start_mock)
    armed_at: float | None = None

    def heard(msg: Any) -> None:
        nonlocal armed_at
        if (
            armed_at is None
            and msg.get_type() == "COMMAND_ACK"
            and msg.command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM
            and msg.result == mavlink.MAV_RESULT_ACCEPTED
        ):
            armed_at = fleet.now
        lost = armed_at is not None and fleet.now - armed_at < 4.0
        if not (lost and msg.get_type() == "HEARTBEAT"):
            vehicle.handle(msg)

    events: list[VehicleEvent] = []
    link = MavLink(fleet.endpoint(1).connect, heard)
    vehicle = Vehicle(
        1, link, MissionClock(rate_hint=SPEEDUP), LocalFrame(config.origin),
        on_event=events.append, altitude=ALTITUDE, setup_timeout=60.0,
    )  # fmt: skip
    guided: list[float] = []  # the truth's height whenever it is in GUIDED during set-up

    async def watch() -> None:
        while vehicle.status is not VehicleStatus.FLYING:
            row = fleet.truth(1)
            if row.mode == "GUIDED":
                guided.append(-row.down)
            await sim_sleep(fleet, 0.2)

    async with link, running(vehicle.run(), watch()):
        await until(lambda: has_status(vehicle, VehicleStatus.FLYING), timeout=20)
    assert armed_at is not None
    assert guided and min(guided) > 0.9 * ALTITUDE, guided[:5]
    assert not [e for e in events if e.kind is EventKind.FAILED]


@pytest.mark.parametrize("latency", [0.0, 0.15])
async def test_the_setpoint_lead_is_the_links_round_trip(
    start_mock: StartMock, latency: float
) -> None:
    """Mission time trails the autopilot by the link's delay towards us, and a setpoint
    takes the delay towards it to arrive: it is flown a round trip late, and is sampled
    that far ahead. The round trip is timed by TIMESYNC (once a second, answered by
    PX4 and ArduPilot alike), so it follows the link in flight, with no command sent."""
    config = MockConfig.simple(
        1, speedup=SPEEDUP, base_port=0, personality="px4", frame="plane",
        airspeed=18.0, turn_radius=80.0, warmup=1.0, faults={"latency": latency},
    )  # fmt: skip
    fleet = await start_mock(config)
    link = MavLink(fleet.endpoint(1).connect, lambda m: vehicle.handle(m))  # noqa: PLW0108
    vehicle = Vehicle(
        1, link, MissionClock(rate_hint=SPEEDUP), LocalFrame(config.origin), altitude=ALTITUDE
    )
    async with link, running(vehicle.run()):
        await sim_sleep(fleet, 15.0)
    assert len(vehicle.round_trip.samples) >= 10
    # (the mock's 10-ms physics step and the loopback, at this speedup, come on top)
    assert 2 * latency <= vehicle.setpoint_lead < 2 * latency + 0.1
