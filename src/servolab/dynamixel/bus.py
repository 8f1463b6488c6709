"""The driver: a :class:`Bus` talks to the motors on one port, in SI units by register name.

``bus.read(11, "present_position")`` looks the register up in motor 11's control table, sends
one READ, checks the status packet and returns radians. Several registers of one motor go out
as one contiguous READ; many motors go out as SYNC_WRITE / SYNC_READ / BULK_READ where the
model has them, and fall back to one packet per motor where it does not (RX-28 has no
BULK_READ). Everything is checked before the first byte is sent, so bad input writes nothing.
"""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, overload

from . import units
from .errors import ConfigError, CorruptResponse, MotorError, NoResponse
from .models import Model, Register, model, model_by_number, supports
from .packets import Instruction, Protocol, Status
from .ports import Port, open_port
from .protocol import protocol as protocol_for
from .protocol1 import Protocol1
from .protocol2 import (
    FACTORY_RESET_ALL,
    FACTORY_RESET_EXCEPT_ID,
    FACTORY_RESET_EXCEPT_ID_BAUD,
    Protocol2,
)
from .wire import byte_time

MAX_RETURN_DELAY = 254 * 2e-6
Value = float | int
Names = str | Sequence[str]
#: Several register names. The overloads of read/sync_read/sync_write take a list or tuple
#: rather than any Sequence[str], because a str is itself a Sequence[str]: with Sequence the
#: one-name and several-names call shapes would overlap and neither could have a precise type.
NameList = list[str] | tuple[str, ...]


@dataclass(frozen=True)
class PingResult:
    """A motor that answered a PING."""

    id: int
    model_number: int
    firmware: int | None
    baudrate: int
    model: Model | None

    @property
    def model_name(self) -> str:
        return self.model.name if self.model else f"unknown model {self.model_number}"


@dataclass
class BusStats:
    """Counters a user can print to see how healthy the wire is."""

    transactions: int = 0
    retries: int = 0
    timeouts: int = 0
    corrupt: int = 0
    bytes_out: int = 0
    bytes_in: int = 0


@dataclass
class Bus:
    """Motors on one port, one protocol, one baud rate.

    ``protocol`` None means the port's own (an emulated bus knows its models'), else 2.
    ``retries`` is how many times a transaction that got no valid answer is sent again.
    ``timeout`` (s), when given, replaces the computed wait for a reply (wire time of the
    expected bytes + return delays + twice the adapter latency + 2 ms).
    """

    port: Port
    protocol: Protocol | int | None = None
    retries: int = 2
    timeout: float | None = None
    motors: dict[int, Model] = field(default_factory=dict)
    stats: BusStats = field(default_factory=BusStats)

    def __post_init__(self) -> None:
        if self.protocol is None:
            self.protocol = self.port.protocol or 2
        if not isinstance(self.protocol, Protocol):
            self.protocol = protocol_for(self.protocol)
        self._proto: Protocol = self.protocol
        if self.retries < 0:
            raise ConfigError(f"retries {self.retries} must be 0 or more")
        if self.timeout is not None and self.timeout <= 0:
            raise ConfigError(f"timeout {self.timeout} s must be positive")
        self._lock = threading.RLock()

    # -- construction ----------------------------------------------------------------------------
    @classmethod
    def open(cls, url: str, *, protocol: int | None = None, baudrate: int | None = None,
             retries: int = 2, timeout: float | None = None, **port_options: Any) -> Bus:
        """A bus on a port named by ``url``: a serial device (``/dev/ttyUSB0``, ``COM3``, the
        pty ``servolab sim`` printed; ``baudrate`` default 57600) or emulated motors
        (``emu://rx28:11-16``, in a simulation of their own unless ``simulation=`` names one;
        see :mod:`servolab.sim.emulated` for which baud rate they run at). ``protocol`` None:
        the emulated models', or 2 on a serial port. ``port_options`` go to
        :func:`~.ports.open_port`."""
        return cls(open_port(url, baudrate, **port_options), protocol, retries, timeout)

    @property
    def proto(self) -> Protocol:
        """The protocol object (``protocol`` as given may be a version number)."""
        if self.protocol is not self._proto:  # reassigned since: decode it again
            self._proto = (self.protocol if isinstance(self.protocol, Protocol)
                           else protocol_for(self.protocol or 2))
        return self._proto

    @property
    def baudrate(self) -> int:
        return self.port.baudrate

    @property
    def emulator(self) -> Any:
        """The emulated bus behind the port, or None on a real one (for tests and worlds;
        the driver itself never looks)."""
        return getattr(self.port, "emulator", None)

    def close(self) -> None:
        self.port.close()

    def __enter__(self) -> Bus:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- transactions ------------------------------------------------------------------------
    def _wait_for(self, n_bytes_out: int, replies: int, n_bytes_in: int) -> float:
        if self.timeout is not None:
            return self.timeout
        tick = byte_time(self.port.baudrate)
        return ((n_bytes_out + n_bytes_in) * tick + replies * MAX_RETURN_DELAY
                + 2 * self.port.latency + 0.002)

    def transact(self, inst: Instruction, expect: Mapping[int, int] | None = None, *,
                 check: bool = True, retries: int | None = None) -> dict[int, Status]:
        """Send ``inst`` and collect status packets from the IDs in ``expect`` (ID -> number of
        parameters each answer carries). Retries on silence or corruption; raises
        :class:`NoResponse` / :class:`CorruptResponse` when they run out, and
        :class:`MotorError` for error bits when ``check``."""
        expect = dict(expect or {})
        name = self.proto.instruction_name(inst.instruction)
        data = self.proto.encode_instruction(inst)
        attempts = 1 + (self.retries if retries is None else retries)
        with self._lock:
            for attempt in range(attempts):
                self.stats.transactions += 1
                if attempt:
                    self.stats.retries += 1
                self.port.reset_input()
                self.port.write(data)
                self.stats.bytes_out += len(data)
                if not expect:
                    return {}
                try:
                    got = self._collect(name, len(data), expect)
                except (NoResponse, CorruptResponse):
                    if attempt + 1 == attempts:
                        raise
                    continue
                if check:
                    for status in got.values():
                        if status.error:
                            raise MotorError(status.id, name, self.proto.error_names(
                                status.error), status.error)
                return got
        raise AssertionError("unreachable")  # pragma: no cover

    def _collect(self, name: str, n_out: int, expect: dict[int, int]) -> dict[int, Status]:
        parser = self.proto.parser()
        sizes = {i: self.proto.status_size(n) for i, n in expect.items()}
        timeout = self._wait_for(n_out, len(expect), sum(sizes.values()))
        clock = self.port.clock
        deadline = clock.now() + timeout
        got: dict[int, Status] = {}
        while len(got) < len(expect):
            remaining = deadline - clock.now()
            if remaining <= 0:
                break
            want = max(1, sum(s for i, s in sizes.items() if i not in got) - parser.pending)
            chunk = self.port.read(want, remaining)
            self.stats.bytes_in += len(chunk)
            for frame in parser.feed(chunk):
                try:
                    status = self.proto.as_status(frame)
                except ValueError:
                    continue
                if status.id in expect and status.id not in got:
                    if len(status.params) != expect[status.id] and not status.error:
                        raise CorruptResponse(
                            f"motor {status.id}: {name} status has {len(status.params)} data "
                            f"bytes, expected {expect[status.id]}", motor_id=status.id,
                            instruction=name)
                    got[status.id] = status
        if len(got) < len(expect):
            missing = sorted(set(expect) - set(got))
            who = ", ".join(str(i) for i in missing)
            if parser.dropped or parser.pending:
                self.stats.corrupt += 1
                raise CorruptResponse(
                    f"motor {who}: {name} got a corrupt status packet "
                    f"({parser.dropped + parser.pending} bad bytes) at {self.baudrate} bps",
                    motor_id=missing[0], instruction=name)
            self.stats.timeouts += 1
            raise NoResponse(f"motor {who}: no answer to {name} within {timeout * 1000:.1f} ms "
                             f"at {self.baudrate} bps (is it powered, at this baud rate and "
                             f"ID?)", motor_id=missing[0], instruction=name)
        return got

    # -- discovery ---------------------------------------------------------------------------
    def ping(self, motor_id: int, *, retries: int | None = None) -> PingResult:
        """PING one motor and learn its model (on 1.0 by reading its model number)."""
        self.proto.check_id(motor_id)
        v1 = self.proto.version == 1
        status = self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3},
                               check=False, retries=retries)[motor_id]
        if v1:
            # 1.0 PING carries no model number: read it (addresses 0-2). A motor at status
            # return level 0 answers PING but not READ; it is found, model unknown.
            try:
                read = self.transact(self.proto.read(motor_id, 0, 3), {motor_id: 3},
                                     check=False, retries=retries)[motor_id]
            except NoResponse:
                return PingResult(motor_id, 0, None, self.baudrate, None)
            number = int.from_bytes(read.params[0:2], "little")
            firmware: int | None = read.params[2]
        else:
            number = int.from_bytes(status.params[0:2], "little")
            firmware = status.params[2]
        found = model_by_number(number)
        if found is not None:
            self.motors[motor_id] = found
        return PingResult(motor_id, number, firmware, self.baudrate, found)

    def broadcast_ping(self) -> list[PingResult]:
        """Protocol 2.0 broadcast PING: every motor answers, in one transaction."""
        if self.proto.version != 2:
            raise ConfigError("broadcast ping exists only in protocol 2.0; use scan()")
        data = self.proto.encode_instruction(self.proto.ping(self.proto.broadcast_id))
        slot = self.proto.status_size(3) * byte_time(self.baudrate) + MAX_RETURN_DELAY
        timeout = self.timeout or (self.proto.max_id + 1) * slot + 2 * self.port.latency + 0.002
        parser = self.proto.parser()
        found: dict[int, PingResult] = {}
        with self._lock:
            self.port.reset_input()
            self.port.write(data)
            deadline = self.port.clock.now() + timeout
            while (remaining := deadline - self.port.clock.now()) > 0:
                for frame in parser.feed(self.port.read(4096, remaining)):
                    status = self.proto.as_status(frame)
                    if len(status.params) == 3 and status.id not in found:
                        number = int.from_bytes(status.params[0:2], "little")
                        m = model_by_number(number)
                        if m:
                            self.motors[status.id] = m
                        found[status.id] = PingResult(status.id, number, status.params[2],
                                                      self.baudrate, m)
        return [found[i] for i in sorted(found)]

    def scan(self, ids: Iterable[int] | None = None, baudrates: Iterable[int] | None = None,
             *, progress: Callable[[int, int], None] | None = None) -> list[PingResult]:
        """Find motors as the Dynamixel Wizard does: ping every ID at every baud rate.

        Leaves the port at its original baud rate. ``progress(baud, id)`` is called before
        each ping, for a progress display.
        """
        ids = list(range(self.proto.max_id + 1) if ids is None else ids)
        for i in ids:
            self.proto.check_id(i)
        rates = [self.baudrate] if baudrates is None else [int(b) for b in baudrates]
        for rate in rates:
            if rate <= 0:
                raise ConfigError(f"baud rate {rate} must be positive")
        original = self.baudrate
        found: list[PingResult] = []
        # Hold the bus for the whole scan: another thread's transaction must never go out
        # at one of the scan's baud rates.
        with self._lock:
            try:
                for rate in rates:
                    self.port.set_baudrate(rate)
                    for motor_id in ids:
                        if progress:
                            progress(rate, motor_id)
                        try:
                            found.append(self.ping(motor_id, retries=0))
                        except (NoResponse, CorruptResponse):
                            continue
            finally:
                self.port.set_baudrate(original)
        return found

    def model_of(self, motor_id: int) -> Model:
        """The model of ``motor_id``: declared, or learnt by a PING the first time."""
        self.proto.check_id(motor_id)
        if motor_id not in self.motors:
            result = self.ping(motor_id)
            if result.model is None:
                raise ConfigError(f"motor {motor_id}: model number {result.model_number} is "
                                  "not one servolab knows; declare it with bus.motors[id] = ...")
        return self.motors[motor_id]

    def declare(self, motor_id: int, model_name: str | Model) -> None:
        """Tell the bus which model ``motor_id`` is, so no PING is needed to learn it."""
        self.proto.check_id(motor_id)
        m = model_name if isinstance(model_name, Model) else model(model_name)
        if m.protocol != self.proto.version:
            raise ConfigError(f"{m.name} speaks protocol {m.protocol}.0, this bus "
                              f"{self.proto.version}.0")
        self.motors[motor_id] = m

    # -- conversions -------------------------------------------------------------------------
    @staticmethod
    def _names(names: Names) -> list[str]:
        return [names] if isinstance(names, str) else list(names)

    def _encode(self, m: Model, reg: Register, value: Value, raw: bool) -> bytes:
        if not reg.writable:
            raise ConfigError(f"{m.name} {reg.name} is read-only")
        if raw:
            if isinstance(value, bool) or not float(value).is_integer():
                raise ConfigError(f"{m.name} {reg.name}: raw value {value!r} is not an integer")
            raw_value = int(value)
            reg.check(raw_value, m)
        else:
            raw_value = units.from_si(m, reg, value)
        return reg.encode(raw_value)

    @staticmethod
    def _decode(m: Model, reg: Register, block: bytes, start: int, raw: bool) -> Value:
        value = reg.decode(block[reg.address - start:])
        return value if raw else units.to_si(m, reg, value)

    def _unpack(self, m: Model, names: list[str], block: bytes, start: int,
                raw: bool) -> dict[str, Value]:
        return {n: self._decode(m, m.register(n), block, start, raw) for n in names}

    # -- one motor ---------------------------------------------------------------------------
    @overload
    def read(self, motor_id: int, names: str, *, raw: bool = False,
             check: bool = True) -> Value: ...

    @overload
    def read(self, motor_id: int, names: NameList, *, raw: bool = False,
             check: bool = True) -> dict[str, Value]: ...

    def read(self, motor_id: int, names: Names, *, raw: bool = False,
             check: bool = True) -> Value | dict[str, Value]:
        """Read one register (returns its value) or several (returns a dict), in SI units
        unless ``raw``. Several registers go out as one contiguous READ."""
        m = self.model_of(motor_id)
        wanted = self._names(names)
        start, length = m.span(wanted)
        self._check_reads_answered([motor_id])
        status = self.transact(self.proto.read(motor_id, start, length), {motor_id: length},
                               check=check)[motor_id]
        values = self._unpack(m, wanted, status.params, start, raw)
        return values[wanted[0]] if isinstance(names, str) else values

    def write(self, motor_id: int, name: str | Mapping[str, Value], value: Value | None = None,
              *, raw: bool = False, registered: bool = False) -> None:
        """Write one register (``write(1, "goal_position", 0.5)``) or several adjacent ones
        (``write(1, {"goal_position": 0.5, "moving_speed": 1.0})``) in one WRITE.
        ``registered`` sends REG_WRITE, applied by a later :meth:`action`."""
        m = self.model_of(motor_id)
        given: dict[str, Value | None] = dict(name) if isinstance(name, Mapping) else {name: value}
        values = {n: v for n, v in given.items() if v is not None}
        if len(values) != len(given):
            raise ConfigError(f"motor {motor_id}: write needs a value for {name!r}")
        start, block = self._block(m, values, raw)
        level = self._level_after(motor_id, m, start, block, registered=registered)
        self.transact(self.proto.write(motor_id, start, block, registered=registered),
                      {motor_id: 0} if level >= 2 else None)
        self.status_return_level[motor_id] = level

    def _block(self, m: Model, values: Mapping[str, Value], raw: bool) -> tuple[int, bytes]:
        regs = sorted((m.register(n) for n in values), key=lambda r: r.address)
        for a, b in itertools.pairwise(regs):
            if a.address + a.size != b.address:
                raise ConfigError(f"{m.name}: {a.name} and {b.name} are not adjacent; write "
                                  "them separately")
        block = b"".join(self._encode(m, r, values[r.name], raw) for r in regs)
        return regs[0].address, block

    def _level_after(self, motor_id: int, m: Model, start: int, block: bytes, *,
                     registered: bool = False) -> int:
        """The status return level ``motor_id`` has once ``block`` is written at ``start``:
        the value written when the block covers the register (the motor answers that WRITE
        already by its new level), else the level the bus knows (2, the factory default,
        until told). A REG_WRITE changes nothing before its ACTION."""
        known = self.status_return_level.get(motor_id, 2)
        if registered or not m.has("status_return_level"):
            return known
        reg = m.register("status_return_level")
        if start <= reg.address < start + len(block):
            return reg.decode(block[reg.address - start:])
        return known

    def _check_reads_answered(self, ids: Iterable[int]) -> None:
        """Refuse, before anything is sent, to READ a motor whose status return level is 0:
        it answers PING only (e-Manual, Status Return Level), so the read could only time
        out."""
        for motor_id in ids:
            if self.status_return_level.get(motor_id, 2) == 0:
                raise ConfigError(f"motor {motor_id}: status return level 0 answers PING only; "
                                  "write status_return_level 1 or 2 to read it")

    @property
    def status_return_level(self) -> dict[int, int]:
        """The status return level of each motor as this bus last wrote it (2, the factory
        default, for motors not in it); it decides which instructions the bus waits on."""
        if not hasattr(self, "_srl"):
            self._srl: dict[int, int] = {}
        return self._srl

    def action(self) -> None:
        """Broadcast ACTION: every motor applies its REG_WRITE at once."""
        self.transact(self.proto.action())

    def reboot(self, motor_id: int) -> None:
        proto = self.proto
        if not isinstance(proto, Protocol2):
            raise ConfigError("REBOOT exists only in protocol 2.0")
        # The status goes out before the reboot, so it still carries the hardware-error alert
        # that the reboot clears: only the instruction's own error counts.
        status = self.transact(proto.reboot(motor_id), {motor_id: 0}, check=False)[motor_id]
        if status.error & 0x7F:
            raise MotorError(motor_id, "REBOOT", self.proto.error_names(status.error & 0x7F),
                             status.error)

    def factory_reset(self, motor_id: int, *, keep_id: bool = True,
                      keep_baud: bool = True) -> None:
        """Restore factory defaults (1.0 RESET resets everything, ID and baud too)."""
        proto = self.proto
        if isinstance(proto, Protocol1):
            self.transact(proto.reset(motor_id), {motor_id: 0})
            return
        if not isinstance(proto, Protocol2):
            raise ConfigError(f"FACTORY_RESET does not exist in protocol {proto.version}.0")
        option = (FACTORY_RESET_EXCEPT_ID_BAUD if keep_id and keep_baud else
                  FACTORY_RESET_EXCEPT_ID if keep_id else FACTORY_RESET_ALL)
        self.transact(proto.factory_reset(motor_id, option), {motor_id: 0})

    # -- many motors ---------------------------------------------------------------------------
    @overload
    def sync_write(self, names: str, values: Mapping[int, Value], *,
                   raw: bool = False) -> None: ...

    @overload
    def sync_write(self, names: NameList, values: Mapping[int, Sequence[Value]], *,
                   raw: bool = False) -> None: ...

    def sync_write(self, names: Names, values: Mapping[int, Value | Sequence[Value]], *,
                   raw: bool = False) -> None:
        """One SYNC_WRITE of the same register(s) on many motors:
        ``sync_write("goal_position", {11: 0.1, 12: -0.2})`` or, for adjacent registers,
        ``sync_write(["goal_position", "moving_speed"], {11: (0.1, 2.0)})``."""
        wanted = self._names(names)
        blocks: list[tuple[int, bytes]] = []
        layout: tuple[int, int] | None = None
        for motor_id, value in values.items():
            m = self.model_of(motor_id)
            # One register name takes one number per motor; a list of names, a sequence each.
            if isinstance(names, str):
                if isinstance(value, Sequence):
                    raise ConfigError(f"{m.name} {names}: {value!r} is not a number")
                vals: list[Value] = [value]
            elif isinstance(value, Iterable):
                vals = list(value)
            else:
                raise ConfigError(f"motor {motor_id}: one value {value!r} for {len(wanted)} "
                                  f"registers {wanted}")
            if len(vals) != len(wanted):
                raise ConfigError(f"motor {motor_id}: {len(vals)} values for {len(wanted)} "
                                  f"registers {wanted}")
            start, block = self._block(m, dict(zip(wanted, vals, strict=True)), raw)
            if layout is None:
                layout = (start, len(block))
            elif layout != (start, len(block)):
                raise ConfigError(f"motor {motor_id} ({m.name}) keeps {wanted} at another "
                                  "address or size than the others: one SYNC_WRITE cannot "
                                  "reach them all")
            blocks.append((motor_id, block))
        if not blocks or layout is None:
            return
        self.transact(self.proto.sync_write(layout[0], layout[1], blocks))
        for motor_id, block in blocks:
            self.status_return_level[motor_id] = self._level_after(
                motor_id, self.model_of(motor_id), layout[0], block)

    @overload
    def sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True) -> dict[int, Value]: ...

    @overload
    def sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True) -> dict[int, dict[str, Value]]: ...

    def sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True) -> dict[int, Value] | dict[int, dict[str, Value]]:
        """The same register(s) of many motors: one SYNC_READ on 2.0, one BULK_READ on 1.0
        models that have it, else one READ each. Returns {id: value} for one register name,
        {id: {name: value}} for a list of names."""
        ids = list(ids)
        wanted = self._names(names)
        models = {i: self.model_of(i) for i in ids}
        if not ids:
            return {}
        self._check_reads_answered(ids)
        spans = {m.span(wanted) for m in models.values()}
        proto = self.proto
        out: dict[int, dict[str, Value]]
        if isinstance(proto, Protocol2) and len(spans) == 1 and all(
                supports(m, "SYNC_READ") for m in models.values()):
            start, length = spans.pop()
            got = self.transact(proto.sync_read(start, length, ids),
                                {i: length for i in ids}, check=check)
            out = {i: self._unpack(models[i], wanted, got[i].params, start, raw) for i in ids}
        else:
            out = self.bulk_read({i: wanted for i in ids}, raw=raw, check=check)
        if isinstance(names, str):
            return {i: v[names] for i, v in out.items()}
        return out

    def bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                  check: bool = True) -> dict[int, dict[str, Value]]:
        """Different registers of different motors: {id: names} -> {id: {name: value}}.
        One BULK_READ where every model has it, else one contiguous READ per motor."""
        plan = []
        for motor_id, names in requests.items():
            m = self.model_of(motor_id)
            wanted = self._names(names)
            plan.append((motor_id, m, wanted, *m.span(wanted)))
        if not plan:
            return {}
        self._check_reads_answered(requests)
        if all(supports(m, "BULK_READ") for _, m, *_ in plan):
            inst = self.proto.bulk_read([(i, start, n) for i, _, _, start, n in plan])
            got = self.transact(inst, {i: n for i, _, _, _, n in plan}, check=check)
            return {i: self._unpack(m, w, got[i].params, start, raw)
                    for i, m, w, start, _ in plan}
        out = {}
        for motor_id, m, wanted, start, length in plan:
            status = self.transact(self.proto.read(motor_id, start, length),
                                   {motor_id: length}, check=check)[motor_id]
            out[motor_id] = self._unpack(m, wanted, status.params, start, raw)
        return out

    def bulk_write(self, values: Mapping[int, Mapping[str, Value]], *,
                   raw: bool = False) -> None:
        """Different registers on different motors: {id: {name: value}}. One BULK_WRITE on
        2.0; on 1.0 (which has none) one WRITE per motor."""
        blocks = []
        for motor_id, regs in values.items():
            m = self.model_of(motor_id)
            start, block = self._block(m, regs, raw)
            blocks.append((motor_id, m, start, block))
        proto = self.proto
        if isinstance(proto, Protocol2) and all(supports(m, "BULK_WRITE") for _, m, _, _ in blocks):
            self.transact(proto.bulk_write([(i, start, block) for i, _, start, block in blocks]))
        else:
            for motor_id, m, start, block in blocks:
                level = self._level_after(motor_id, m, start, block)
                self.transact(self.proto.write(motor_id, start, block),
                              {motor_id: 0} if level >= 2 else None)
                self.status_return_level[motor_id] = level
            return
        for motor_id, m, start, block in blocks:
            self.status_return_level[motor_id] = self._level_after(motor_id, m, start, block)
