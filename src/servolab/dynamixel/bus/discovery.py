"""Discovery: finding the motors on a port and learning their models.

PING one motor, a Protocol 2.0 broadcast PING (every motor in its turn), a scan of IDs,
baud rates and protocols, and the model of a motor (declared, or learnt by a PING the first
time). A 1.0 PING carries nothing, so a READ of the model number follows it.
"""

from __future__ import annotations

import contextlib
import functools
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

from ..errors import ConfigError, CorruptResponse, NoResponse
from ..models import Model, model, model_by_number
from ..packets import BROADCAST_ID, Status
from ..ports import MemoryPort, SerialPort
from ..protocol import protocol as protocol_for
from ..protocol2 import PROTOCOL2
from ..wire import byte_time, wire_time
from .common import MAX_RETURN_DELAY
from .core import BusCore
from .link import statuses_in
from .model_checks import ANGLE_LIMITS

#: Protocol 2.0 broadcast PING: how long the motors wait for the status of an ID before the
#: next ID takes its turn, 3000 us (ROBOTIS's device-side code, Dynamixel2Arduino
#: src/utility/protocol.cpp, DXL_PROCESS_BROAD_PING; the emulator's ``Emulator.ping_slot``).
BROADCAST_PING_SLOT = 0.003
#: What a scan adds to the wire time of a PING, its status and the longest return delay before
#: it PINGs the next ID (:meth:`Bus.ping_window`): a USB adapter hands a request to its UART
#: at the next USB frame (1 ms at full speed), and the host may be woken a little late.
SCAN_MARGIN = 0.002
#: Bytes a 1.0 PING reads after it: model number, firmware, ID, baud, return delay and the CW
#: and CCW angle limits (addresses 0-9, the same on every 1.0 model).
_PING_READ_1 = 10


def _at_firmware(found: Model | None, firmware: int | None) -> Model | None:
    """The model as the motor's own firmware has it: what it supports depends on the version
    its PING reports (e.g. Fast Sync Read from firmware 46), not on the version servolab's
    table describes. One object per (model, firmware), so that motors of one model and
    firmware share the bus's precomputed plans."""
    if found is None or firmware is None or firmware == found.firmware:
        return found
    return _model_at_firmware(found, firmware)


@functools.cache
def _model_at_firmware(found: Model, firmware: int) -> Model:
    return replace(found, firmware=firmware)



@dataclass(frozen=True)
class PingResult:
    """A motor that answered a PING."""

    id: int
    model_number: int
    firmware: int | None
    baudrate: int
    model: Model | None
    #: the protocol version it answered in (1 or 2)
    protocol: int | None = None

    @property
    def model_name(self) -> str:
        return self.model.name if self.model else f"unknown model {self.model_number}"


class Discovery(BusCore):
    """Which motors answer, and which models they are (see the module's docstring)."""

    def ping(self, motor_id: int, *, retries: int | None = None) -> PingResult:
        """PING one motor and learn its model (on 1.0 by reading its model number)."""
        self.proto.check_id(motor_id)
        v1 = self.proto.version == 1
        status = self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3},
                               check=False, retries=retries)[motor_id]
        return self._identify_pinged(motor_id, status, retries=retries)

    def _identify_pinged(self, motor_id: int, status: Status, *, retries: int | None = None,
                         keep: bool = True) -> PingResult:
        """The motor that answered a PING with ``status``, at the bus's protocol and rate.
        A 2.0 PING's status carries the model number and firmware; a 1.0 one carries
        nothing, so they are READ (addresses 0-2), and in the same READ the angle limits
        (6-9), which tell joint from wheel mode. A 1.0 motor at status return level 0
        answers PING but not READ: it is found, model unknown. ``keep``: the bus keeps the
        model (and 1.0 angle limits) in :attr:`motors`."""
        proto = self.proto
        if keep:
            # perhaps another motor now, or other limits
            self._memory.angle_limits.pop(motor_id, None)
        if proto.version == 1:
            try:
                read = self.transact(proto.read(motor_id, 0, _PING_READ_1),
                                     {motor_id: _PING_READ_1}, check=False,
                                     retries=retries)[motor_id]
            except NoResponse:
                return PingResult(motor_id, 0, None, self.baudrate, None, 1)
            number = int.from_bytes(read.params[0:2], "little")
            firmware: int | None = read.params[2]
            if keep:
                self._memory.angle_limits[motor_id] = (int.from_bytes(read.params[6:8], "little"),
                                                       int.from_bytes(read.params[8:10], "little"))
        else:
            number = int.from_bytes(status.params[0:2], "little")
            firmware = status.params[2]
        found = _at_firmware(model_by_number(number), firmware)
        if found is not None and keep:
            self.motors[motor_id] = found
        return PingResult(motor_id, number, firmware, self.baudrate, found, proto.version)

    def broadcast_ping_wait(self, top: int | None = None, baudrate: int | None = None
                            ) -> float:
        """How long :meth:`broadcast_ping` listens (s) at least.

        "When the Packet ID field is 0xFE (Broadcast ID): All devices send their Status
        Packet according to their arranged order" (e-Manual, Protocol 2.0, Ping): in ID
        order, each ID in its turn whether a motor has it or not. ROBOTIS's device-side code
        (Dynamixel2Arduino src/utility/protocol.cpp, DXL_PROCESS_BROAD_PING) moves on to the
        next ID as soon as it hears a status, and otherwise after :data:`BROADCAST_PING_SLOT`
        (3 ms). So each of the IDs 0..251 before ID 252 takes at most the longer of a slot
        and an answer (the longest return delay, 254 x 2 us, and a 14-byte status), and ID
        252 its own answer: with the PING's own wire time, twice the adapter latency and
        2 ms, that is the wait. ``top``: the highest ID listened for (default 252); the IDs
        after it answer later and are not waited for. ``baudrate``: at that rate (default
        the port's)."""
        tick = byte_time(baudrate or self.baudrate)
        proto = PROTOCOL2
        answer = proto.status_size(3) * tick + MAX_RETURN_DELAY
        ping = len(proto.encode_instruction(proto.ping(proto.broadcast_id))) * tick
        last = proto.max_id if top is None else top
        return (ping + last * max(BROADCAST_PING_SLOT, answer) + answer
                + 2 * self.port.latency + 0.002)

    def broadcast_ping(self, ids: Iterable[int] | None = None) -> list[PingResult]:
        """Protocol 2.0 broadcast PING: every motor answers, in one transaction (which lasts
        :meth:`broadcast_ping_wait`, enough for ID 252 to answer in its turn, or the bus's
        ``timeout`` if that is longer: a short per-transaction timeout does not cut it
        short). ``ids``: only those are wanted, and the bus listens only until the highest
        of them has had its turn."""
        if self.proto.version != 2:
            raise ConfigError("broadcast ping exists only in protocol 2.0; use scan()")
        wanted = None
        if ids is not None:
            wanted = set(ids)
            for motor_id in wanted:
                self.proto.check_id(motor_id)
        return self._listen_to_broadcast_ping(wanted, keep=True)

    def _listen_to_broadcast_ping(self, wanted: set[int] | None, *, keep: bool) -> list[PingResult]:
        """:meth:`broadcast_ping` of the IDs ``wanted`` (None: all); ``keep``: the models
        found go to :attr:`motors`."""
        if wanted is not None and not wanted:
            return []
        proto = PROTOCOL2
        data = proto.encode_instruction(proto.ping(proto.broadcast_id))
        top = None if wanted is None else max(wanted)
        timeout = max(self.timeout or 0.0, self.broadcast_ping_wait(top))
        parser = proto.parser()
        found: dict[int, PingResult] = {}
        with self._lock:
            clock = self.port.clock
            deadline = clock.now() + timeout   # (the wait counts the PING's wire time)
            self._link.send_unanswered(data)
            while (remaining := deadline - clock.now()) > 0:
                chunk = self.port.read(4096, remaining)
                self.stats.bytes_in += len(chunk)
                if not chunk and not clock.virtual:
                    clock.sleep(min(remaining, 0.001))  # an in-process port returns at once
                for status in statuses_in(chunk, parser, proto, self.stats):
                    if len(status.params) != 3 or status.id in found:
                        self.stats.stale += 1
                        continue
                    if wanted is not None and status.id not in wanted:
                        continue
                    number = int.from_bytes(status.params[0:2], "little")
                    m = _at_firmware(model_by_number(number), status.params[2])
                    if m and keep:
                        self.motors[status.id] = m
                    found[status.id] = PingResult(status.id, number, status.params[2],
                                                  self.baudrate, m, 2)
            self.port.reset_input()   # answers of IDs after the last one wanted
        return [found[i] for i in sorted(found)]

    def ping_window(self, baudrate: int | None = None, protocol: int | None = None) -> float:
        """How long a scan waits for the answer to one PING (s) before it PINGs the next ID,
        on the bus's protocol at ``baudrate`` (default the port's): the wire time of the
        PING and of its status (10 bits a byte), the longest return delay (254 x 2 us) and
        :data:`SCAN_MARGIN`. The adapter's latency is not in it: an answer it hands over
        later is still taken, by the ID it carries, while the next PINGs go out (the wire
        itself is free by then). Where the adapter echoes or the port is a serial server
        across a network, it is (each PING then waits for its answer or its timeout, see
        :meth:`_ping_each`). The bus's ``timeout``, when set, replaces it.
        ``protocol``: in that protocol (default the bus's)."""
        if self.timeout is not None:
            return self.timeout
        proto = self.proto if protocol is None else protocol_for(protocol)
        size = (len(proto.encode_instruction(proto.ping(0)))
                + proto.status_size(0 if proto.version == 1 else 3))
        window = (wire_time(size, baudrate or self.baudrate) + MAX_RETURN_DELAY
                  + SCAN_MARGIN)
        if self.port.echo or not isinstance(self.port, SerialPort | MemoryPort):
            window += 2 * self.port.latency   # each PING waits for its answer
        return window

    def scan(self, ids: Iterable[int] | None = None, baudrates: Iterable[int] | None = None,
             *, protocols: Iterable[int] | None = None,
             progress: Callable[[int, int], None] | None = None,
             broadcast: bool | None = None) -> list[PingResult]:
        """Find the motors on the port: every ID (or ``ids``) at each baud rate of
        ``baudrates`` (default: the port's) in each protocol of ``protocols`` (default: the
        bus's own; ``(1, 2)``: both, as a bus that mixes them needs).

        Protocol 2.0 first, by one broadcast PING per rate when ``ids`` is None (or
        ``broadcast``): every motor answers it in its turn, in ID order, within
        :meth:`broadcast_ping_wait` (under 0.8 s at 57600 bps and above); with ``ids`` named
        (and ``broadcast`` not True), a PING per ID. Then Protocol 1.0, which has no
        broadcast PING, by a PING per ID, each after the one before it has had its
        :meth:`ping_window` (the wire time of PING and status, the longest return delay and
        a small margin): 254 IDs take about 1.2 s at 57600 bps and 0.7 s at 1 Mbps, what
        an adapter's latency timer adds coming once, at the end. A 1.0 motor found is then
        READ for its model number. :meth:`scan_time` says beforehand how long it takes.

        Returns the motors found, by rate (in the order given), then protocol (2.0 first),
        then ID; each :class:`PingResult` names its protocol. The models of those that speak
        the bus's protocol go to :attr:`motors`. Leaves the port at its original baud rate.
        ``progress(baud, id)`` is called before each PING (with the broadcast ID, 254, before
        a broadcast PING), for a progress display.
        """
        plan = self._scan_steps(ids, baudrates, protocols, broadcast)
        original, own = self.baudrate, self.proto.version
        found: list[PingResult] = []
        # Hold the bus for the whole scan: another thread's transaction must never go out
        # at one of the scan's baud rates or protocols.
        with self._lock:
            try:
                if self._link.quiet_until is not None:
                    self._link.wait_out_late_answers()
                for rate, version, by_broadcast, id_list in plan:
                    if self.port.baudrate != rate:
                        self.port.set_baudrate(rate)
                    self._switch_protocol(version)
                    keep = self._scan_keeps(version, own)
                    if by_broadcast:
                        if progress:
                            progress(rate, BROADCAST_ID)
                        found += self._listen_to_broadcast_ping(
                            None if id_list is None else set(id_list), keep=keep)
                        continue
                    answered = self._ping_each(id_list or (), progress)
                    found += [self._identify_pinged(i, answered[i], retries=0, keep=keep)
                              for i in sorted(answered)]
            finally:
                self._switch_protocol(None)
                if self.port.baudrate != original:
                    self.port.set_baudrate(original)
        return found

    def _scan_keeps(self, version: int, own: int) -> bool:
        """Whether a scan keeps in :attr:`motors` the motors it finds in protocol
        ``version`` (``own``: the bus's): those it speaks to."""
        return version == own

    def scan_time(self, ids: Iterable[int] | None = None,
                  baudrates: Iterable[int] | None = None, *,
                  protocols: Iterable[int] | None = None,
                  broadcast: bool | None = None) -> float:
        """How long :meth:`scan` with these arguments takes (s) when no motor answers: the
        broadcast PINGs' waits and every PING's window, and once per rate and protocol what
        the adapter's latency adds at the end. A motor that answers shortens its PING's
        window and adds its status (on 1.0 a READ too): a few ms."""
        plan = self._scan_steps(ids, baudrates, protocols, broadcast)
        total = 0.0
        for rate, version, by_broadcast, id_list in plan:
            if by_broadcast:
                if id_list is None or id_list:
                    top = None if id_list is None else max(id_list)
                    total += self.broadcast_ping_wait(top, rate)
            elif id_list:
                total += (len(id_list) * self.ping_window(rate, version)
                          + 2 * self.port.latency + SCAN_MARGIN)
        return total

    def _scan_steps(self, ids: Iterable[int] | None, baudrates: Iterable[int] | None,
                    protocols: Iterable[int] | None, broadcast: bool | None
                   ) -> list[tuple[int, int, bool, list[int] | None]]:
        """The steps of a scan, checked before anything is sent: (rate, protocol version,
        by broadcast PING, the IDs: None for all). A protocol's IDs are those of ``ids``
        that it can address; an ID none of the protocols can is refused."""
        versions = [self.proto.version] if protocols is None else sorted(
            {protocol_for(v).version for v in protocols}, reverse=True)
        if not versions:
            raise ConfigError("scan: no protocol to scan")
        id_list = None if ids is None else list(ids)
        if id_list is not None:
            widest = max((protocol_for(v) for v in versions), key=lambda p: p.max_id)
            for i in id_list:
                widest.check_id(i)
        rates = [self.baudrate] if baudrates is None else [int(b) for b in baudrates]
        for rate in rates:
            if rate <= 0:
                raise ConfigError(f"baud rate {rate} must be positive")
        plan: list[tuple[int, int, bool, list[int] | None]] = []
        for rate in rates:
            for version in versions:
                proto = protocol_for(version)
                mine = (list(range(proto.max_id + 1)) if id_list is None
                        else [i for i in id_list if i <= proto.max_id])
                by_broadcast = version == 2 and (broadcast if broadcast is not None
                                                 else id_list is None)
                plan.append((rate, version, by_broadcast,
                             None if by_broadcast and id_list is None else mine))
        return plan

    def _ping_each(self, ids: Sequence[int], progress: Callable[[int, int], None] | None
                   ) -> dict[int, Status]:
        """PING each of ``ids`` in turn, at the bus's protocol and rate; the statuses of those
        that answered, by ID.

        Each PING goes out when the one before it has been answered or its
        :meth:`ping_window` has passed: by then the wire is free, whether or not the
        adapter has handed the answer over. An answer that comes later, during the next
        PINGs' windows, is taken by the ID it carries; what is still on its way after the
        last PING is waited for once (twice the adapter's latency and
        :data:`SCAN_MARGIN`). Where the adapter echoes (or is not known yet not to), or the
        port is a serial server across a network (``socket://``, ``rfc2217://``: two PINGs
        may reach its wire together, and the first one's answer collide with the second),
        each PING is a transaction of its own instead, answered or timed out before the
        next."""
        proto, port, stats = self.proto, self.port, self.stats
        clock = port.clock
        n = 0 if proto.version == 1 else 3
        size = proto.status_size(n)
        rate = port.baudrate
        parser = proto.parser()
        found: dict[int, Status] = {}
        asked: set[int] = set()
        window = self.ping_window()
        # Only where what is written reaches the wire at once, as spaced when written.
        paced = isinstance(port, SerialPort | MemoryPort)

        def take(chunk: bytes) -> None:
            stats.bytes_in += len(chunk)
            for status in statuses_in(chunk, parser, proto, stats):
                if status.id in asked and status.id not in found and len(status.params) == n:
                    found[status.id] = status
                else:
                    stats.stale += 1

        for motor_id in ids:
            if progress:
                progress(rate, motor_id)
            inst = proto.ping(motor_id)
            if port.echo is not False or not paced:
                with contextlib.suppress(NoResponse, CorruptResponse):
                    found[motor_id] = self.transact(inst, {motor_id: n}, check=False,
                                                    retries=0)[motor_id]
                window = self.ping_window()   # the echo is known now
                continue
            data = proto.encode_instruction(inst)
            deadline = clock.now() + window   # (the window counts the PING's wire time)
            port.write(data)
            asked.add(motor_id)
            stats.transactions += 1
            stats.bytes_out += len(data)
            while motor_id not in found and (remaining := deadline - clock.now()) > 0:
                chunk = port.read(max(1, size - parser.pending), remaining)
                if not chunk:
                    break
                take(chunk)
        if asked - found.keys():
            # what the adapter still holds of the last answers
            deadline = clock.now() + 2 * port.latency + SCAN_MARGIN
            while asked - found.keys() and (remaining := deadline - clock.now()) > 0:
                chunk = port.read(size, remaining)
                if not chunk:
                    break
                take(chunk)
            stats.timeouts += len(asked - found.keys())
        if asked:
            port.reset_input()
        return found

    def model_of(self, motor_id: int) -> Model:
        """The model of ``motor_id``: declared, or learnt by a PING the first time."""
        self.proto.check_id(motor_id)
        if motor_id not in self.motors:
            result = self.ping(motor_id)
            if result.model is None and result.firmware is None and self.proto.version == 1:
                # the PING was answered, the READ of the model number that follows it not
                self._remember_level(motor_id, 0)
                raise ConfigError(f"motor {motor_id} answers PING but not READ (status return "
                                  "level 0), so its model cannot be read: declare it "
                                  "(bus.declare(id, model); --model on the command line)")
            if result.model is None:
                raise ConfigError(f"motor {motor_id}: model number {result.model_number} is "
                                  "not one servolab knows; declare it with bus.motors[id] = ...")
        return self.motors[motor_id]

    def known_model(self, motor_id: int) -> Model | None:
        """The model of ``motor_id`` when servolab has its table (declared, or learnt by a
        PING now), None for a model it does not know (a motor that does not answer raises
        :class:`NoResponse`)."""
        self.proto.check_id(motor_id)
        found = self.motors.get(motor_id)
        if found is None:
            found = self.ping(motor_id).model
        return found

    def declare(self, motor_id: int, model_name: str | Model, *,
                wheel_mode: bool | None = None) -> None:
        """Tell the bus which model ``motor_id`` is, so no PING is needed to learn it, and
        (1.0) whether it is in wheel mode, which decides how its speeds convert to SI; left
        None, the bus reads the angle limits the first time it needs them."""
        self.proto.check_id(motor_id)
        m = model_name if isinstance(model_name, Model) else model(model_name)
        if m.protocol != self.proto.version:
            raise ConfigError(f"{m.name} speaks protocol {m.protocol}.0, this bus "
                              f"{self.proto.version}.0")
        if self.motors.get(motor_id) != m:
            self._memory.angle_limits.pop(motor_id, None)
            self._memory.goal_facts.pop(motor_id, None)
        self.motors[motor_id] = m
        if wheel_mode is not None and m.has(ANGLE_LIMITS[1]):
            self._memory.angle_limits[motor_id] = (0, 0) if wheel_mode else (
                0, m.register(ANGLE_LIMITS[1]).raw_max)
