"""Reading a vehicle's mission over MAVLink's mission protocol (sans-I/O).

A ground vehicle driving a mission (an ArduRover or PX4 rover in AUTO) knows the road it
will take; its mission is the convoy's route. :class:`MissionRead` is the download side
of the protocol (https://mavlink.io/en/services/mission.html) as a state machine:
messages in, messages to send out, no sockets and no clock of its own.

Design rules:
    * MISSION_REQUEST_LIST, then MISSION_REQUEST_INT for each item in turn, then a
      MISSION_ACK that closes the transfer on the vehicle's side. An item out of turn (a
      late duplicate) is ignored; a MISSION_ACK with an error ends the read with the
      vehicle's reason.
    * Timeouts are the protocol's (1.5 s, five tries for each request) and run on the
      caller's ``now``: a network wait is a wall-clock wait whatever the mission's speedup.
      A link that has lost answers in this read gets the tries its answer rate needs
      (``tries_allowed``): five at 30 % loss each way fail one item in 30, and a read of
      44 items four times in five (ArduRover SITL behind such a radio was never read).
      Once answers have been timed, a request is asked again after three of the link's
      round trips rather than 1.5 s (``timeout``): a lost request no longer costs a
      second and a half each, 70 wall s for those 44 items, 350 mission s at 5x.
    * A MISSION_ITEM (the float form) in answer is taken as well: firmware older than
      MAVLink 2's INT requests answers so.
    * The items are kept as sent; what they mean for the convoy is
      :func:`convoy_mav.tracks.missionroute.mission_route`'s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from convoy_mav.mavlink.autopilots.base import param_request_message
from convoy_mav.mavlink.codec import GCS_SYSTEM, Message
from convoy_mav.mavlink.rovermode import rover_mode
from convoy_mav.types import ConvoyDrive

__all__ = ["MissionItem", "MissionRead", "MissionWatch", "ParamAsks"]

TIMEOUT_S = 1.5
MIN_TIMEOUT_S = 0.2  # ... at the least, however quick the link's round trips
TRIES = 5
MAX_TRIES = 20  # ... on a lossy link (``MissionRead.tries_allowed``)
ITEM_MISS = 1e-6  # the chance of giving up on one request a lossy link's tries allow
MAX_ITEMS = 2000  # a rover's mission is hundreds of items at most: more is refused unread


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One mission item in the INT form's units: ``lat``/``lon`` degrees (0, 0: none)."""

    seq: int
    command: int
    frame: int
    lat: float
    lon: float
    param1: float = 0.0
    param2: float = 0.0

    @classmethod
    def from_message(cls, msg: Message) -> MissionItem:
        """From a MISSION_ITEM_INT (degrees e7) or a MISSION_ITEM (degrees)."""
        scale = 1e-7 if msg.get_type() == "MISSION_ITEM_INT" else 1.0
        return cls(
            int(msg.seq), int(msg.command), int(msg.frame), msg.x * scale, msg.y * scale,
            float(msg.param1), float(msg.param2),
        )  # fmt: skip


class MissionRead:
    """One download of a vehicle's mission (``mission_type``: MAV_MISSION_TYPE_MISSION,
    or its rally points, MAV_MISSION_TYPE_RALLY).

    Drive it with :meth:`start`, :meth:`handle` for every message from that vehicle, and
    :meth:`poll` now and then; each returns the messages to send. It ends ``done`` with
    :attr:`items`, or with :attr:`error` in words. The vehicle's answers to another ground
    station (its operator's upload, on a link or a router that carries both) are not
    this read's: a mission message addressed to a system other than ``own`` is left out.
    """

    def __init__(
        self,
        target_system: int,
        target_component: int = 1,
        *,
        own: int = GCS_SYSTEM,
        mission_type: int = mavlink.MAV_MISSION_TYPE_MISSION,
    ) -> None:
        self.target = (target_system, target_component)
        self.own = own
        self.mission_type = mission_type
        self.items: list[MissionItem] | None = None  # when done and read
        self.error: str | None = None  # when done and failed
        self.busy = False  # ... refused as another transfer was under way
        self._count: int | None = None
        self._got: list[MissionItem] = []
        self._sent_at = 0.0
        self._tries = 0
        self._answered = 0  # requests answered in this read
        self._spent = 0  # ... and the tries they took
        self._round_trip: float | None = None  # s, smoothed, of requests answered at once
        self.started = False

    @property
    def done(self) -> bool:
        return self.items is not None or self.error is not None

    @property
    def count(self) -> int | None:
        """Items the vehicle said it holds (None before its MISSION_COUNT)."""
        return self._count

    @property
    def timeout(self) -> float:
        """Seconds before a request is asked again: three of the link's round trips, as
        the answers to first tries timed them (a retry's answer may be the first
        try's, so it is not timed), ``MIN_TIMEOUT_S`` to ``TIMEOUT_S``; ``TIMEOUT_S``
        before any was timed."""
        if self._round_trip is None:
            return TIMEOUT_S
        return min(max(3.0 * self._round_trip, MIN_TIMEOUT_S), TIMEOUT_S)

    @property
    def tries_allowed(self) -> int:
        """Tries of one request before the read gives up: the protocol's ``TRIES`` on a
        link that answers the first, and on a lossy one as many as its answer rate so far
        needs to fail one request in ``1 / ITEM_MISS``, ``MAX_TRIES`` at most. The rate
        counts one answered try and one lost beforehand: a few quick answers are no
        proof of a clean link. A vehicle that answered nothing of this read gets
        ``TRIES``: it may not serve missions at all."""
        if self._answered == 0:
            return TRIES
        rate = (self._answered + 1) / (self._spent + 2)
        needed = math.ceil(math.log(ITEM_MISS) / math.log(1.0 - rate))
        return min(max(needed, TRIES), MAX_TRIES)

    def start(self, now: float) -> list[Message]:
        self.started = True
        return self._ask(now, first=True)

    def handle(self, msg: Message, now: float) -> list[Message]:
        """A message from the vehicle; what to send in answer (often nothing)."""
        if self.done or not self.started:
            return []
        kind = msg.get_type()
        if getattr(msg, "mission_type", 0) != self.mission_type:
            return []
        if getattr(msg, "target_system", 0) not in (0, self.own):
            return []  # (to another ground station)
        if kind == "MISSION_COUNT" and self._count is None:
            if msg.count > MAX_ITEMS:
                return self._fail(f"says it holds {msg.count} items (at most {MAX_ITEMS} read)")
            self._count = int(msg.count)
            self._took(now)
            if self._count == 0:
                self.items = []
                return [self._ack(mavlink.MAV_MISSION_ACCEPTED)]
            return self._ask(now, first=True)
        if kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and self._count is not None:
            if msg.seq != len(self._got):
                return []  # a late duplicate, or one we did not ask for yet
            self._got.append(MissionItem.from_message(msg))
            self._took(now)
            if len(self._got) < self._count:
                return self._ask(now, first=True)
            self.items = self._got
            return [self._ack(mavlink.MAV_MISSION_ACCEPTED)]
        if kind == "MISSION_ACK" and msg.type != mavlink.MAV_MISSION_ACCEPTED:
            entry = mavlink.enums["MAV_MISSION_RESULT"].get(msg.type)
            why = f"refused the read: {entry.name if entry else msg.type}"
            # ArduPilot denies a read while another ground station uploads (the
            # operator's own, say): MissionItemProtocol's "transfer in progress".
            self.busy = msg.type == mavlink.MAV_MISSION_DENIED
            return self._fail(why + (" (another transfer under way)" if self.busy else ""))
        return []

    def poll(self, now: float) -> list[Message]:
        """Ask again when an answer is overdue; give up after the protocol's tries."""
        if self.done or not self.started or now - self._sent_at < self.timeout:
            return []
        if self._tries >= self.tries_allowed:
            what = (
                "MISSION_REQUEST_LIST"
                if self._count is None
                else f"MISSION_REQUEST_INT {len(self._got)} of {self._count}"
            )
            tries = f"{self._tries} tries, {self.timeout:.3g} s apart"
            return self._fail(f"did not answer {what} ({tries})")
        return self._ask(now, first=False)

    def _took(self, now: float) -> None:
        """The request under way was answered, after ``_tries`` tries."""
        self._answered += 1
        self._spent += self._tries
        if self._tries == 1:
            rtt, was = now - self._sent_at, self._round_trip
            self._round_trip = rtt if was is None else 0.75 * was + 0.25 * rtt

    def _ask(self, now: float, *, first: bool) -> list[Message]:
        self._sent_at = now
        self._tries = 1 if first else self._tries + 1
        system, component = self.target
        kind = self.mission_type
        if self._count is None:
            return [mavlink.MAVLink_mission_request_list_message(system, component, kind)]
        seq = len(self._got)
        return [mavlink.MAVLink_mission_request_int_message(system, component, seq, kind)]

    def _ack(self, result: int) -> Message:
        system, component = self.target
        return mavlink.MAVLink_mission_ack_message(system, component, result, self.mission_type)

    def _fail(self, why: str) -> list[Message]:
        self.error = why
        if self._count is None:
            return []
        return [self._ack(mavlink.MAV_MISSION_OPERATION_CANCELLED)]


RETRY_S = 30.0  # mission s after a failed read, or an empty mission, before asking again
BUSY_RETRY_S = 3.0  # ... after one refused while another transfer was under way
# ArduRover's speed in AUTO where no DO_CHANGE_SPEED says one (WP_SPEED; 0: CRUISE_SPEED's).
SPEED_PARAMS = ("WP_SPEED", "CRUISE_SPEED")
PARAM_TIMEOUT_S = 1.5  # before asking again for a parameter not answered
PARAM_TRIES = 3  # ... and then the read is handed over without it
_CHANGED = "mission changed"  # (ArduRover's and ArduCopter's "Auto mission changed, ...")


class ParamAsks:
    """Parameters of a vehicle asked by PARAM_REQUEST_READ, again each ``PARAM_TIMEOUT_S``
    while unanswered, ``PARAM_TRIES`` times at most (then the caller's defaults stand)."""

    def __init__(self, target: tuple[int, int], names: tuple[str, ...]) -> None:
        self.target = target
        self.names = names
        self.values: dict[str, float] = {}  # (finite values answered, by name)
        self.tries = 0
        self._next = 0.0

    @property
    def settled(self) -> bool:
        """All answered, or asked as often as they will be."""
        return len(self.values) == len(self.names) or self.tries >= PARAM_TRIES

    def take(self, msg: Message) -> bool:
        """Keep a PARAM_VALUE of one of them (True: it was)."""
        if msg.get_type() != "PARAM_VALUE" or msg.param_id not in self.names:
            return False
        value = float(msg.param_value)
        if math.isfinite(value):
            self.values[msg.param_id] = value
        return True

    def ask(self, now: float) -> list[Message]:
        """The requests due at ``now`` (those still unanswered)."""
        if self.settled or now < self._next:
            return []
        self.tries += 1
        self._next = now + PARAM_TIMEOUT_S
        system, component = self.target
        return [
            param_request_message(system, component, name)
            for name in self.names
            if name not in self.values
        ]


class MissionWatch:
    """Keeps a vehicle's mission read: once heard, again whenever it changes.

    A change is what MISSION_CURRENT says: its ``total`` differs from the items read (an
    upload from another ground station, a mission cleared; ArduPilot's ``total`` leaves
    its home item out, ``GCS_MAVLINK::send_mission_current``). A waypoint moved is the
    same count, and MISSION_CURRENT's ``mission_id`` (PX4's CRC32 of the mission) is not
    in pymavlink's dialect: so the mission is read again when the vehicle says it changed
    as it ran (ArduPilot's "Auto mission changed, ..." to every link, ``ModeAuto::update``)
    and each time it enters its mission mode (AUTO), where a mission uploaded meanwhile
    takes effect; a read that finds the same mission changes nothing
    (``ConvoyService.set_route``). A failed read is tried
    again after ``RETRY_S`` (``BUSY_RETRY_S`` when refused during another station's
    transfer, as the operator's upload); so is an empty mission, which a rover has
    before its operator uploads one. Those waits are mission time, given to
    :meth:`poll` (at 40x, 30 wall s would be 20 minutes of the convoy's drive without
    its route); the protocol's own time-outs are the link's, wall time, as ``now``.
    :meth:`take` hands over each finished read once.
    Nothing is read before the vehicle's HEARTBEAT says its firmware: ArduPilot's item 0
    is home, PX4's a waypoint, and the default speed below is ArduPilot's.

    Of an ArduPilot rover it also asks the speed it drives AUTO at where its mission sets
    none (``SPEED_PARAMS``, PARAM_REQUEST_READ): :attr:`default_speed`, and the first
    read is handed over once they are answered (or asked ``PARAM_TRIES`` times).
    PX4's rovers keep theirs under other names per rover module: not asked.
    """

    def __init__(
        self, target_system: int, target_component: int = 1, *, own: int = GCS_SYSTEM
    ) -> None:
        self.target = (target_system, target_component)
        self.own = own  # (our system id: the vehicle's answers to others are not ours)
        self.read: MissionRead | None = None
        self.reads = 0  # finished, good or not
        self.ardupilot = False  # (its item 0 is home)
        self._heard = False  # a HEARTBEAT: which firmware numbers the mission (home first)
        self._total: int | None = None  # as MISSION_CURRENT last said
        self.current: int | None = None  # the item it drives to, as MISSION_CURRENT last said
        self._held: int | None = None  # items of the last read, as MISSION_CURRENT counts
        self._total_read: int | None = None  # MISSION_CURRENT's total when it was read
        self._stale = False  # the vehicle said it changed, or entered its mission mode
        self._mode: ConvoyDrive | None = None  # (its HEARTBEAT's, for the last)
        self._next_try = -math.inf  # mission s
        self._finished: MissionRead | None = None
        self.default_speed: float | None = None  # m/s, AUTO's where no item says one
        self._asks = ParamAsks(self.target, SPEED_PARAMS)

    def handle(self, msg: Message, now: float, mission: float) -> list[Message]:
        """A message from the vehicle; what to send in answer (``now`` wall s, ``mission``
        mission s: see :meth:`poll`)."""
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self._heard = True
            self.ardupilot = msg.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
            mode = rover_mode(msg)
            drive = None if mode is None else mode.drive
            if drive is ConvoyDrive.MISSION and self._mode not in (None, drive):
                self._stale = True  # (into AUTO: a mission uploaded meanwhile runs now)
            self._mode = drive
        elif kind == "MISSION_CURRENT":
            if msg.total != self._total and self._total is not None:
                self._next_try = -math.inf  # changed: read it now
            self._total = int(msg.total)
            self.current = int(msg.seq)
        elif kind == "STATUSTEXT" and _CHANGED in str(msg.text).lower():
            self._stale, self._next_try = True, -math.inf
        elif self._asks.take(msg):
            wp, cruise = (self._asks.values.get(name, math.nan) for name in SPEED_PARAMS)
            speed = wp if wp > 0.0 else cruise  # (WP_SPEED 0: CRUISE_SPEED is AUTO's)
            self.default_speed = speed if math.isfinite(speed) and speed > 0.0 else None
        read = self.read
        if read is None:
            return []
        out = read.handle(msg, now)
        self._finish_if_done(mission)
        return out

    @property
    def _params_done(self) -> bool:
        """The default speed known, or not to be asked (not ArduPilot), or given up."""
        wp = self._asks.values.get(SPEED_PARAMS[0])
        return not self.ardupilot or (wp is not None and wp > 0.0) or self._asks.settled

    def _ask_params(self, now: float) -> list[Message]:
        if not self._heard or self._params_done:
            return []
        return self._asks.ask(now)

    def poll(self, now: float, mission: float) -> list[Message]:
        """Start a read when one is due; time the one under way out; ask for the
        default speed until answered (``now`` wall s, ``mission`` mission s)."""
        asks = self._ask_params(now)
        read = self.read
        if read is not None:
            out = read.poll(now)
            self._finish_if_done(mission)
            return asks + out
        # A total that is not the read's count, and not what it said at the read (firmware
        # that sends 0, "not supported", has its mission read once more, not for ever).
        total = self._total
        changed = total is not None and total not in (self._held, self._total_read)
        changed = changed or self._stale
        due = not self._held or changed
        if self._heard and due and mission >= self._next_try:
            self.read = MissionRead(*self.target, own=self.own)
            self._stale = False
            return asks + self.read.start(now)
        return asks

    def take(self) -> MissionRead | None:
        """The read finished since the last call (with its items or its error), once;
        held while the default speed is still being asked."""
        if not self._params_done:
            return None
        done, self._finished = self._finished, None
        return done

    def _finish_if_done(self, mission: float) -> None:
        read = self.read
        if read is None or not read.done:
            return
        self.read, self._finished = None, read
        self.reads += 1
        # Failed, or nothing uploaded yet (home alone): ask again later, or when it changes.
        held = None if read.items is None else max(0, len(read.items) - self.ardupilot)
        self._held, self._total_read = held, self._total
        wait = BUSY_RETRY_S if read.busy else RETRY_S
        self._next_try = -math.inf if held else mission + wait
