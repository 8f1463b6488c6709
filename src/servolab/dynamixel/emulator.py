"""Emulated Dynamixel motors that answer on the bus byte for byte and move.

A :class:`VirtualMotor` holds a real control table (EEPROM and RAM with the model's factory
defaults) and a physical state (angle, velocity, load, temperature). An :class:`Emulator` is the
device side of one bus: it parses instruction packets with the same protocol code the driver
uses, lets every addressed motor act on them exactly as the real model does (return delay,
status return level, silence on broadcast, collisions between equal IDs, silence on a baud
mismatch) and returns the status bytes with the time each is on the wire.

The emulator never sleeps. Time comes from outside (``advance(t)``, or the arrival time of each
instruction), so the same motors run on a virtual clock in tests and on the wall clock behind a
pseudo-terminal.
"""

from __future__ import annotations

import math
import random
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

from . import protocol1 as p1
from . import protocol2 as p2
from .errors import ConfigError
from .models import supports
from .motorspec import MotorSpec
from .packets import BROADCAST_ID, Instruction, Protocol, Status
from .protocol import protocol as protocol_for
from .virtual_motor import VirtualMotor
from .wire import baud_matches, byte_time

__all__ = ["Emulator", "Faults", "Reply", "VirtualMotor", "build_emulator"]

#: Instructions after which a motor is at its factory (or EEPROM) settings.
_RESETS = frozenset({"REBOOT", "FACTORY_RESET", "RESET"})

#: Instructions that address several motors whatever their packet's ID says.
_MULTI_MOTOR = frozenset({"SYNC_WRITE", "SYNC_READ", "BULK_READ", "BULK_WRITE",
                          "FAST_SYNC_READ", "FAST_BULK_READ"})


@dataclass
class Faults:
    """Faults the emulator injects into its answers, for tests of the driver's error paths.

    Rates are probabilities per status byte; ``delay`` postpones every answer (seconds).
    """

    drop_rate: float = 0.0
    corrupt_rate: float = 0.0
    delay: float = 0.0
    seed: int = 0
    _rng: random.Random = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("drop_rate", "corrupt_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:  # (nan fails this too)
                raise ConfigError(f"faults: {name} {value} is not a probability in 0..1")
        if not (math.isfinite(self.delay) and self.delay >= 0):
            raise ConfigError(f"faults: delay {self.delay} s is not a finite time >= 0")
        self._rng = random.Random(self.seed)

    @property
    def active(self) -> bool:
        return bool(self.drop_rate or self.corrupt_rate or self.delay)

    def apply(self, data: bytes) -> bytes:
        if not (self.drop_rate or self.corrupt_rate):
            return data
        out = bytearray()
        for byte in data:
            if self._rng.random() < self.drop_rate:
                continue
            if self._rng.random() < self.corrupt_rate:
                byte ^= 1 << self._rng.randrange(8)
            out.append(byte)
        return bytes(out)


@dataclass(frozen=True)
class Reply:
    """Status bytes an emulator puts on the wire, starting at ``start`` (seconds)."""

    start: float
    data: bytes

    def __init__(self, start: float, data: bytes) -> None:
        # (as packets.Instruction's: one per answer)
        fields = self.__dict__
        fields["start"], fields["data"] = start, data


class Emulator:
    """The device side of one bus: a set of virtual motors on one protocol, or on both.

    ``receive`` takes the bytes the host sent, finishing at time ``t``, at the host's baud rate,
    and returns the replies with their start times. Motors whose own baud rate differs from the
    host's hear noise and stay silent, like real ones.

    ``protocol`` None makes a bus that mixes Protocol 1.0 and 2.0 motors, as DynamixelSDK's
    ``protocol_combined`` example drives one: each motor's firmware parses the line in its own
    protocol, so every byte reaches both and each protocol's motors answer only the packets of
    theirs (a 2.0 packet, ``FF FF FD 00 ...``, is no 1.0 packet: ID 253 with LENGTH 0; a 1.0
    packet lacks the 2.0 header). It is built of one emulator per protocol (:attr:`sides`),
    which share the bus's faults and are stepped with it; :attr:`motors` lists them all.

    The emulator does not keep time. Its owner (a :class:`servolab.sim.Simulation`) calls
    :meth:`step` once per physics step and moves time to ``t`` before handing it bytes.
    """

    def __init__(self, protocol: int | Protocol | None, motors: Iterable[VirtualMotor] = (), *,
                 faults: Faults | None = None) -> None:
        self.faults = faults or Faults()
        #: a mixed bus (``protocol`` None): the emulator of each protocol's motors, by version
        self.sides: dict[int, Emulator] = {}
        if protocol is None:
            self.sides = {v: Emulator(v, faults=self.faults) for v in (1, 2)}
        #: the bus's protocol; on a mixed bus 2.0, which a host speaks to it first (its
        #: broadcast PING finds the 2.0 motors at once)
        self.protocol = (protocol if isinstance(protocol, Protocol)
                         else protocol_for(2 if protocol is None else protocol))
        self.motors: list[VirtualMotor] = []
        #: physics steps taken, and their length (s; nan before the first)
        self.steps = 0
        self.dt = math.nan
        self._eager: list[VirtualMotor] = []  # motors whose plant a world steps
        self._by_id: dict[int, list[VirtualMotor]] | None = None  # None: to be rebuilt
        self._by_secondary: dict[int, list[VirtualMotor]] = {}
        self._parser = self.protocol.parser(keep_rejected=True)
        self.instructions_seen = 0
        #: partly received packets dropped after ``idle_timeout`` of silence
        self.partial_packets_dropped = 0
        self._heard_until = -math.inf  # when the last byte received ended
        for motor in motors:
            self.add(motor)

    @property
    def mixed(self) -> bool:
        """Whether this bus holds motors of both protocols (see :attr:`sides`)."""
        return bool(self.sides)

    def add(self, motor: VirtualMotor) -> VirtualMotor:
        if self.sides:
            self.sides[motor.model.protocol].add(motor)   # (refuses a motor on a bus)
            self.motors.append(motor)
            return motor
        if motor.model.protocol != self.protocol.version:
            raise ConfigError(f"{motor.model.name} speaks protocol {motor.model.protocol}.0, "
                              f"this bus protocol {self.protocol.version}.0")
        if motor._emulator is not None:
            raise ConfigError(f"motor {motor.id} is already on an emulated bus")
        motor._emulator = self
        motor._steps_done = self.steps
        self.motors.append(motor)
        self._by_id = None
        if motor._needs_duty():
            self._eager.append(motor)
        return motor

    def unplug(self, motor_id: int) -> VirtualMotor:
        """Take the (first) motor with this ID off the bus, as a pulled cable or a dead
        motor would leave it: from now on it hears and answers nothing. Returns it (its
        state is kept; :meth:`add` puts it back)."""
        motor = self.motor(motor_id)
        if self.sides:
            side = self.sides[motor.model.protocol]
            side.motors.remove(motor)
            if motor in side._eager:
                side._eager.remove(motor)
            side._by_id = None
        self.motors.remove(motor)
        if motor in self._eager:
            self._eager.remove(motor)
        motor._emulator = None
        self._by_id = None
        return motor

    def motor(self, motor_id: int) -> VirtualMotor:
        """The (first) motor with this ID; a :class:`ConfigError` if there is none."""
        for m in self.motors:
            if m.id == motor_id:
                return m
        raise ConfigError(f"no emulated motor with ID {motor_id}")

    def step(self, dt: float) -> None:
        """One physics step of ``dt`` seconds has passed. The motors' own plants catch up when
        next looked at; the firmware of motors whose plant a world steps does its per-step
        duty now (the world has stepped their plants already)."""
        if self.sides:
            for side in self.sides.values():
                side.step(dt)
            self.dt = dt
            self.steps += 1
            return
        if dt != self.dt and self.steps and self.motors:
            for m in self.motors:
                m.sync()  # a new step length: settle what the old one owes first
        self.dt = dt
        self.steps += 1
        for m in self._eager:
            m._after_step(self.steps)

    # -- the line: what the firmware's receiver does with the host's bytes ---------------------
    #: Seconds of silence after which the motors drop a packet they have only partly received
    #: and look for a new header. ROBOTIS publish no figure for the servos' own firmware. Their
    #: device-side parser in Dynamixel2Arduino (src/utility/protocol.cpp, commit 0f9999d:
    #: ``dxlInit`` sets ``rx_timeout = 500*1000`` µs and ``dxlRxPacket1_0/2_0`` go back to
    #: IDLE when ``micros() - prev_time > rx_timeout`` before taking a byte; DynamixelShield's
    #: src/util/dxl.cpp the same) uses 500 ms, longer than the ROBOTIS SDK's own packet timeout
    #: (2 x LATENCY_TIMER 16 ms + 2 ms + the status's wire time, port_handler.setPacketTimeout):
    #: with it a truncated header would swallow a dozen of the SDK's retries. servolab uses
    #: 10 ms: twice Python's 5 ms thread switch interval (a pause the pty server itself can put
    #: between two reads of one packet), and well under the SDK's 34 ms, so that the retry after
    #: a transaction that timed out always starts a fresh packet.
    idle_timeout: float = 0.010
    #: Protocol 2.0 broadcast PING: how long the motors wait for the status of an ID that does
    #: not answer before the next ID takes its turn (see :meth:`_chain`).
    ping_slot: float = 0.003

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Reply]:
        """Take the host's bytes (the last one ends at ``t``); return what goes back.

        As a servo's firmware does, the motors first drop a packet they were partway through
        if the line was silent for more than :attr:`idle_timeout` before these bytes began
        (``t - len(data) * byte_time(baudrate)``), and resynchronise on the next header.

        A motor never answers late: every packet that completes is acted on, but only the one
        the host's last byte completes is answered, at ``t`` plus the return delay. A status
        to an earlier packet would have been on the wire while the host was still sending
        (the bus is half duplex: it is lost in the collision), and a packet the parser finds
        inside junk that had swallowed it is long stale. When the last byte completes a packet
        with a bad checksum/CRC, the motors were inside that one: its checksum error is the
        answer, whatever the parser then finds within it.

        On a mixed bus each protocol's motors take the bytes in their own protocol (see the
        class), and what both answer goes back in the order it starts.
        """
        data = bytes(data)
        if not data:
            return []
        if self.sides:
            heard: list[Reply] = []
            for side in self.sides.values():
                heard += side.receive(data, t, baudrate)
            self._heard_until = t
            self._count_sides()
            return sorted(heard, key=lambda reply: reply.start)
        self.idle(t - len(data) * byte_time(baudrate))
        self._heard_until = t
        parser = self._parser
        stale = parser.feed(data[:-1])          # packets the host sent more bytes after
        parser.rejected.clear()
        last = parser.feed(data[-1:])           # what the last byte completes, first
        rejected = [bad.id for bad in parser.rejected]
        parser.rejected.clear()
        frames = stale + last
        self.instructions_seen += len(frames)
        replies: list[Reply] = []
        for i, frame in enumerate(frames):
            answers = self._answer(self.protocol.as_instruction(frame), t, baudrate)
            if i == len(stale) and not rejected:
                replies = answers
        if rejected:
            replies = self._checksum_error(rejected[0], t, baudrate)
        return replies

    def idle(self, t: float) -> None:
        """The line has been silent from the last byte received until ``t``: if longer than
        :attr:`idle_timeout`, drop the packet the motors were partway through (the owner of a
        real-time line calls this when nothing comes; :meth:`receive` does it by itself)."""
        if self.sides:
            for side in self.sides.values():
                side.idle(t)
            self._count_sides()
            return
        if self._parser.pending and t - self._heard_until > self.idle_timeout:
            self._parser.reset()
            self.partial_packets_dropped += 1

    @property
    def idle_deadline(self) -> float | None:
        """When the packet the motors are partway through is dropped if no byte comes (the
        first time :meth:`idle` drops it is any time after this); None when there is none."""
        if self.sides:
            deadlines = [d for side in self.sides.values()
                         if (d := side.idle_deadline) is not None]
            return min(deadlines, default=None)
        return self._heard_until + self.idle_timeout if self._parser.pending else None

    def _count_sides(self) -> None:
        """A mixed bus's counters: the sum of its sides'."""
        sides = self.sides.values()
        self.instructions_seen = sum(side.instructions_seen for side in sides)
        self.partial_packets_dropped = sum(side.partial_packets_dropped for side in sides)

    def _checksum_error(self, motor_id: int, t: float, baudrate: float) -> list[Reply]:
        """A unicast packet that arrived whole but with a bad checksum/CRC: the motor with
        that ID answers with the checksum (1.0) or CRC (2.0) error, as the real ones do."""
        error = p1.CHECKSUM if self.protocol.version == 1 else p2.CRC_ERROR
        targets = [m for m in self._listening(baudrate) if m.id == motor_id]
        if not targets or motor_id == BROADCAST_ID:
            return []
        return [self._reply([(m, Status(m.id, m.error_byte(error))) for m in targets], t)]

    def _reply(self, statuses: Sequence[tuple[VirtualMotor, Status]], t: float) -> Reply:
        """What the motors answering at once put on the wire after ``t``: each after its
        return delay (the slowest sets the start), their bytes ANDed where they overlap, plus
        any injected fault."""
        if len(statuses) == 1:  # (the usual one motor: its delay, its bytes alone)
            motor, status = statuses[0]
            delay, sent = motor.return_delay, self.protocol.encode_status(status)
        else:
            delay = max(m.return_delay for m, _ in statuses)
            sent = _collide([self.protocol.encode_status(status) for _, status in statuses])
        return Reply(t + delay + self.faults.delay, self.faults.apply(sent))

    # -- who answers what ------------------------------------------------------------------
    def _with_id(self, motor_id: int) -> list[VirtualMotor]:
        if self._by_id is None:
            self._index()
            assert self._by_id is not None
        return self._by_id.get(motor_id, [])

    def _with_secondary_id(self, motor_id: int) -> list[VirtualMotor]:
        """Motors that take ``motor_id`` as their Secondary ID: those whose own ID it is not
        ("ID(7) has a greater priority", e-Manual, Secondary ID(12))."""
        if self._by_id is None:
            self._index()
        return self._by_secondary.get(motor_id, [])

    def _index(self) -> None:
        self._by_id = {}
        self._by_secondary = {}
        for m in self.motors:
            self._by_id.setdefault(m.id, []).append(m)
            if m._secondary_id is not None and m._secondary_id != m.id:
                self._by_secondary.setdefault(m._secondary_id, []).append(m)

    def _listening(self, baudrate: float, motors: list[VirtualMotor] | None = None
                   ) -> list[VirtualMotor]:
        return [m for m in (self.motors if motors is None else motors)
                if m.responsive and baud_matches(m._baudrate, baudrate)]

    def _answer(self, inst: Instruction, t: float, baudrate: float) -> list[Reply]:
        name = self.protocol.instruction_name(inst.instruction)
        unicast = inst.id != BROADCAST_ID and name not in _MULTI_MOTOR
        # A unicast instruction concerns the motors with its ID only: ask only them whether
        # they can hear it (a 20-motor bus answers READs without looking at 19 of them).
        motors = self._listening(baudrate, self._with_id(inst.id) if unicast else self.motors)
        v1 = self.protocol.version == 1
        if name == "SYNC_WRITE":
            self._sync_write(inst, motors)
            return []
        if name == "BULK_WRITE" and not v1:
            self._bulk_write(inst, motors)
            return []
        if name in ("SYNC_READ", "BULK_READ", "FAST_SYNC_READ", "FAST_BULK_READ"):
            fast = name.startswith("FAST_")
            if fast and v1:
                return []
            requests = self._read_requests(inst, name.removeprefix("FAST_"))
            asked = {motor_id for motor_id, _ in requests}
            for m in motors:
                if m.id in asked:
                    m._heard()   # whether or not its turn comes: it received the packet
            # Status return level 0 answers PING only: a motor there keeps its slot silent;
            # for the fast forms, a motor whose model or firmware lacks the instruction sends
            # no block (and so stops the chain, see _fast_chain).
            able = [m for m in motors if supports(m.model, name) and m._status_level >= 1]
            if fast:
                return self._fast_chain(requests, able, t, baudrate)
            return self._chain(requests, able, t, baudrate)
        if inst.id == BROADCAST_ID:
            if name == "PING" and not v1:
                # Broadcast ping (2.0): every ID up to the highest present has its turn, in
                # ID order; an ID nobody answers for costs a ping_slot of silence.
                top = max((m.id for m in motors), default=-1)
                return self._chain([(i, None) for i in range(top + 1)], motors, t, baudrate)
            for m in motors:
                m.execute(inst, name)
            return []
        if unicast and not v1:
            # Motors with this Secondary ID act on the instruction (RAM only) and never
            # answer it (e-Manual, Secondary ID(12)).
            for m in self._listening(baudrate, self._with_secondary_id(inst.id)):
                m.execute(inst, name, secondary=True)
        # (a unicast's motors come from the ID index: they are all the targets)
        targets = motors if unicast else [m for m in motors if m.id == inst.id]
        # The status of a REBOOT or reset goes out before the motor resets, so it follows
        # the status return level from before; a WRITE is answered by the level it leaves.
        if name in _RESETS:
            before = [self._returns_status(m, name) for m in targets]
            statuses = [(m, m.execute(inst, name)) for m in targets]
            statuses = [(m, st) for (m, st), answered in zip(statuses, before, strict=True)
                        if answered]
        else:
            # (each motor's execute changes only its own level: asked right after it)
            statuses = []
            for m in targets:
                status = m.execute(inst, name)
                if self._returns_status(m, name):
                    statuses.append((m, status))
        if not statuses:
            return []
        return [self._reply(statuses, t)]

    def _returns_status(self, motor: VirtualMotor, name: str) -> bool:
        """Whether ``motor`` answers a unicast ``name`` by its Status Return Level: 0 "PING
        Instruction only", 1 "PING and READ Instruction", 2 "all Instructions" (e-Manual,
        Status Return Level, the one page for 1.0 and 2.0 models: ROBOTIS-GIT/emanual
        _includes/en/dxl/control_table/status_return_level.md). SYNC_READ and BULK_READ,
        reads too, follow READ (see :meth:`_answer`); a broadcast READ or WRITE is answered
        by no level."""
        level = motor._status_level
        if name == "PING":
            return True
        if name == "READ":
            return level >= 1
        return level >= 2

    def _chain(self, requests: Sequence[tuple[int, tuple[int, int] | None]],
               motors: list[VirtualMotor], t: float, baudrate: float) -> list[Reply]:
        """Replies of a SYNC_READ, BULK_READ or broadcast ping: each motor waits for the
        status of the one before it, then its own return delay. ``requests`` are (id, block)
        pairs: the (address, length) each motor reads, or None for a PING.

        Broadcast PING (2.0): the e-Manual says only that "all devices send their Status
        Packet according to their arranged order" (Protocol 2.0, Ping). ROBOTIS's device-side
        code has the order: Dynamixel2Arduino (src/utility/protocol.cpp, commit 0f9999d,
        ``DXL_PROCESS_BROAD_PING``) counts IDs from 1 after the ping, moves to ID k + 1 as
        soon as it hears ID k's status and otherwise every 3000 µs, and answers when the count
        reaches its own ID. So motor k starts at the end of the ping plus, for each lower ID,
        that ID's return delay and status (14 bytes) if it answers or ``ping_slot`` (3 ms) if
        not, plus its own return delay. The SDK's wait for a broadcast ping allows exactly
        that per ID (protocol2_packet_handler.broadcastPing: 14 bytes x 252 + 3 ms x 252 +
        16 ms). ID 0, which that counter reaches only when it wraps, answers first here and
        costs no slot when absent."""
        replies: list[Reply] = []
        for motor_id, block in requests:
            targets = [m for m in motors if m.id == motor_id]
            if not targets:
                # Real motors wait for the previous answer; a missing one stalls the rest
                # (1.0 BULK_READ), while 2.0 motors time out and go on. Both lose this slot;
                # a silent ID in a broadcast ping costs ping_slot.
                if self.protocol.version == 1:
                    break
                if block is None and motor_id > 0:
                    t += self.ping_slot
                continue
            statuses = []
            for m in targets:
                if block is None:
                    status = m.execute(Instruction(m.id, p2.PING), "PING")
                else:
                    status = m.read(*block)
                statuses.append((m, status))
            reply = self._reply(statuses, t)
            replies.append(reply)
            t = reply.start + len(reply.data) * byte_time(baudrate)
        return replies

    def _fast_chain(self, requests: Sequence[tuple[int, tuple[int, int]]],
                    motors: list[VirtualMotor], t: float, baudrate: float) -> list[Reply]:
        """The reply to a FAST_SYNC_READ or FAST_BULK_READ: one status packet, built along the
        chain (the layout: :func:`.protocol2.fast_block`). ``requests`` are (id, (address,
        length)) in the order of the instruction.

        Timing. The first motor of the request sends the packet's head and its block after its
        return delay, as it would its own status; every next motor appends its block the moment
        the block before it has ended, without a return delay of its own. ROBOTIS publish no
        timing for these instructions; this follows what is published about them: one status
        packet, whose LEN the first motor gives for all blocks and whose running CRC each motor
        continues from the bytes before its own (so each must hear them, and the packet is one
        unbroken frame to the SDK, whose rxPacket waits for LEN bytes under a single packet
        timeout), and the report that with them "return delays do not compound with n_servos"
        (pollen-robotics/rustypot PR #122, a third-party host driver of 0x8A). No gap between
        blocks either: none is published, and a motor that took one would leave the line idle
        in mid-packet.

        A motor of the request that is absent (or silent: status return level 0, a model or
        firmware without the instruction) sends nothing, and the motor after it, which waits
        for that block to go on from, never starts: the chain stops there and the host gets a
        packet cut short after the last block sent. (How long a real motor waits before it
        gives up is not published; none of them answers late here.) Two motors with one ID
        send together and the line carries the AND of their bytes, whose CRC the next motor
        then goes on from, having heard nothing else."""
        lengths = [length for _, (_, length) in requests]
        head = p2.fast_status_head(p2.fast_status_length(lengths))
        crc = 0
        replies: list[Reply] = []
        tick = byte_time(baudrate)
        for motor_id, (address, length) in requests:
            targets = [m for m in motors if m.id == motor_id]
            if not targets:
                break
            pieces = []
            for m in targets:
                status = m.read(address, length)
                # A read that failed (an access error) brings no data; the block keeps its
                # length all the same, so the motors after it still find where it ends.
                data = status.params.ljust(length, b"\0")
                pieces.append(p2.fast_block(head, crc, status.error, m.id, data))
            sent = _collide(pieces)
            crc = p2.crc16(sent, crc)
            if not replies:
                t += max(m.return_delay for m in targets) + self.faults.delay
            replies.append(Reply(t, self.faults.apply(sent)))
            t += len(sent) * tick  # the next motor heard the whole block (faults: the host's)
            head = b""
        return replies

    def _read_requests(self, inst: Instruction, name: str) -> list[tuple[int, tuple[int, int]]]:
        params = inst.params
        if self.protocol.version == 1:
            # BULK_READ 1.0: 0x00, then (length, id, address) triples
            body = params[1:]
            return [(body[i + 1], (body[i + 2], body[i])) for i in range(0, len(body) - 2, 3)]
        if name == "SYNC_READ":
            address = int.from_bytes(params[0:2], "little")
            length = int.from_bytes(params[2:4], "little")
            return [(motor_id, (address, length)) for motor_id in params[4:]]
        return [(params[i], (int.from_bytes(params[i + 1:i + 3], "little"),
                             int.from_bytes(params[i + 3:i + 5], "little")))
                for i in range(0, len(params) - 4, 5)]

    def _sync_write(self, inst: Instruction, motors: list[VirtualMotor]) -> None:
        params = inst.params
        split = 1 if self.protocol.version == 1 else 2
        address = int.from_bytes(params[0:split], "little")
        length = int.from_bytes(params[split:2 * split], "little")
        body = params[2 * split:]
        step = 1 + length
        for i in range(0, len(body) - length, step):
            for m in motors:
                if m.id == body[i] and supports(m.model, "SYNC_WRITE"):
                    m.write(address, body[i + 1:i + step])

    def _bulk_write(self, inst: Instruction, motors: list[VirtualMotor]) -> None:
        params = inst.params
        i = 0
        while i + 5 <= len(params):
            motor_id = params[i]
            address = int.from_bytes(params[i + 1:i + 3], "little")
            length = int.from_bytes(params[i + 3:i + 5], "little")
            data = params[i + 5:i + 5 + length]
            for m in motors:
                if m.id == motor_id:
                    m.write(address, data)
            i += 5 + length


def _collide(packets: list[bytes]) -> bytes:
    """Two motors answering at once drive the line together: on the idle-high TTL/RS-485
    bus of a Dynamixel chain the result is the bitwise AND of what each sent."""
    if len(packets) == 1:
        return packets[0]
    size = max(len(p) for p in packets)
    out = bytearray(b"\xff" * size)
    for packet in packets:
        for i, byte in enumerate(packet):
            out[i] &= byte
    return bytes(out)


def build_emulator(spec: MotorSpec, *, faults: Faults | None = None) -> Emulator:
    """An emulator holding the motors of ``spec``, each at the spec's (or factory) baud rate."""
    emulator = Emulator(spec.protocol, faults=faults)
    for entry in spec.motors:
        emulator.add(VirtualMotor(entry.model, entry.id, baudrate=spec.baudrate,
                                  position=entry.position))
    return emulator
