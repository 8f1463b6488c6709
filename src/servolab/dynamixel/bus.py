"""The driver: a :class:`Bus` talks to the motors on one port, in SI units by register name.

``bus.read(11, "present_position")`` looks the register up in motor 11's control table, sends
one READ, checks the status packet and returns radians. Several registers of one motor go out
as one contiguous READ; many motors go out as SYNC_WRITE / SYNC_READ / BULK_READ where the
model has them, and fall back to one packet per motor where it does not (RX-28 has no
BULK_READ). On X-series firmware 46 and later, ``fast_sync_read`` / ``fast_bulk_read`` (or
``fast=True``/``None``) send FAST_SYNC_READ / FAST_BULK_READ, answered by one status packet
for all the motors. Everything is checked before the first byte is sent, so bad input writes
nothing.

**Robust.** A status is taken as the answer only if it comes from a motor asked, with the
length the instruction asks for; anything else (a late answer to an earlier instruction, a
stray packet) is counted in :attr:`BusStats.stale` and ignored. After an instruction that got
no valid answer, the next one first waits out the time in which the late answer could still
come (return delay and wire time) and throws away whatever came: a late answer is never read
as the answer to the next request. Hardware errors (overload, overheating, ...) are not failed
instructions: the data comes back, and the motor is named in :attr:`Bus.alerts` (and logged);
only an instruction error (checksum, range, access, ...) raises :class:`MotorError`.

**Fast.** What a read or a write of the same registers of the same motors repeats is worked
out once and kept (a *plan*): the instruction packet, the status packets it is answered with
and where each one's data sits, one :class:`struct.Struct` that decodes them. A reply that is
exactly as expected is checked in place (header, ID, length, checksum/CRC, error byte) and
decoded in one call; only one that is not goes through the stream parser, which finds what it
can in noise, partial and stray packets.
"""

from __future__ import annotations

import functools
import itertools
import logging
import struct
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from types import MappingProxyType
from typing import Any, overload

from . import units
from .errors import CommError, ConfigError, CorruptResponse, MotorError, NoResponse
from .models import FAST_READ_FIRMWARE, Model, Register, model, model_by_number, supports
from .packets import Instruction, Protocol, Status
from .ports import Port, open_port
from .protocol import protocol as protocol_for
from .protocol1 import Protocol1
from .protocol2 import (
    FACTORY_RESET_ALL,
    FACTORY_RESET_EXCEPT_ID,
    FACTORY_RESET_EXCEPT_ID_BAUD,
    FAST_HEAD,
    HARDWARE_ERRORS,
    Protocol2,
    crc16_at,
    fast_status_head,
    fast_status_length,
    match_fast_status,
    read_fast_status,
)
from .wire import byte_time

log = logging.getLogger(__name__)

MAX_RETURN_DELAY = 254 * 2e-6
#: Protocol 2.0 broadcast PING: how long the motors wait for the status of an ID before the
#: next ID takes its turn, 3000 us (ROBOTIS's device-side code, Dynamixel2Arduino
#: src/utility/protocol.cpp, DXL_PROCESS_BROAD_PING; the emulator's ``Emulator.ping_slot``).
BROADCAST_PING_SLOT = 0.003
#: The registers of a 1.0 motor that set its mode: both 0 is wheel mode (e-Manual, CW/CCW
#: Angle Limit).
_ANGLE_LIMITS = ("cw_angle_limit", "ccw_angle_limit")
Value = float | int
Names = str | Sequence[str]
#: Several register names. The overloads of read/sync_read/sync_write take a list or tuple
#: rather than any Sequence[str], because a str is itself a Sequence[str]: with Sequence the
#: one-name and several-names call shapes would overlap and neither could have a precise type.
NameList = list[str] | tuple[str, ...]
#: plans kept per bus before the cache starts again (a robot uses a handful)
MAX_PLANS = 4096
_INT = frozenset((int,))


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
    #: status packets thrown away: late answers to an earlier instruction, answers from a
    #: motor not asked or of the wrong length
    stale: int = 0


# -- plans: what a repeated transaction works out once --------------------------------------------
class _Replies:
    """The status packets that answer one instruction, in the order they come (ID -> number of
    data bytes), and where each sits in the reply when every one comes as expected."""

    __slots__ = ("counts", "data_at", "delays", "ends", "expect", "fast", "ids", "prefixes",
                 "single", "sizes", "starts", "states", "total")

    def __init__(self, proto: Protocol, expect: Mapping[int, int], *,
                 fast: bool = False) -> None:
        self.expect = dict(expect)
        self.ids = tuple(self.expect)
        self.counts = tuple(self.expect.values())
        #: one fast status packet (FAST_SYNC_READ / FAST_BULK_READ, protocol 2.0) for all
        self.fast = fast
        self.ends: tuple[int, ...] = ()
        if fast:
            # The packet's 8-byte head, then per motor a block ERR ID DATA CRC (4 + n bytes)
            # ending with the running CRC at ``ends[k]`` (protocol2.fast_block). Only the
            # first motor waits its return delay; the others append their block at once.
            self.sizes = tuple(4 + n for n in self.counts)
            starts = list(itertools.accumulate(self.sizes, initial=FAST_HEAD))
            self.total = starts.pop()
            self.starts = tuple(starts)
            self.data_at = tuple(start + 2 for start in starts)
            self.ends = tuple(at + n for at, n in zip(self.data_at, self.counts, strict=True))
            head = fast_status_head(fast_status_length(self.counts))
            self.prefixes: tuple[bytes, ...] = (head,)
            self.states: tuple[int, ...] = (crc16_at(head, 0, FAST_HEAD),)
            self.single = False
            self.delays = MAX_RETURN_DELAY
            return
        self.sizes = tuple(proto.status_size(n) for n in self.counts)
        starts = list(itertools.accumulate(self.sizes, initial=0))
        self.total = starts.pop()
        self.starts = tuple(starts)
        self.data_at = tuple(start + proto.params_at for start in starts)
        self.prefixes = tuple(proto.status_prefix(i, n) for i, n in self.expect.items())
        self.states = tuple(proto.prefix_state(prefix) for prefix in self.prefixes)
        self.single = len(self.ids) == 1
        self.delays = len(self.ids) * MAX_RETURN_DELAY  # the longest each answer may wait


_STRUCT_CODES = {(1, False): "B", (2, False): "H", (4, False): "I",
                 (1, True): "b", (2, True): "h", (4, True): "i"}


class _Fields:
    """Named registers of one model, read as one block: the block's (start, length), and one
    :class:`struct.Struct` that takes every value out of it at once.

    ``moded``: a register among them converts to SI by the motor's mode (moving/present
    speed of a model whose wheel mode sets the output, :attr:`.Model.wheel_output_ratio`);
    the caller then says which mode the motor is in, and ``wheel_convert`` serves wheel mode.
    """

    __slots__ = ("_order", "_struct", "convert", "length", "moded", "names", "regs", "single",
                 "start", "wheel_convert")

    def __init__(self, m: Model, names: Names) -> None:
        self.single = isinstance(names, str)
        self.names = list(dict.fromkeys([names] if isinstance(names, str) else names))
        self.regs = [m.register(n) for n in self.names]  # ConfigError for an unknown name
        if not self.regs:
            raise ConfigError(f"{m.name}: no register named to read")
        self.start, self.length = m.span(self.names)
        self.convert = [_si_decoder(m, r) for r in self.regs]
        self.moded = m.wheel_output_ratio and any(r.unit == "speed_sign_bit"
                                                  for r in self.regs)
        self.wheel_convert = ([_si_decoder(m, r, wheel=True) for r in self.regs] if self.moded
                              else self.convert)
        by_address = sorted(range(len(self.regs)), key=lambda k: self.regs[k].address)
        fmt, at = "<", self.start
        for k in by_address:
            reg = self.regs[k]
            code = _STRUCT_CODES.get((reg.size, reg.signed))
            if code is None or reg.address < at:  # no struct code, or overlapping registers
                fmt = ""
                break
            fmt += (f"{reg.address - at}x" if reg.address > at else "") + code
            at = reg.address + reg.size
        self._struct = struct.Struct(fmt) if fmt else None
        # the struct gives values in address order; the caller wants them in its own
        self._order = (None if by_address == sorted(by_address)
                       else [by_address.index(k) for k in range(len(by_address))])

    def raw(self, buf: bytes, at: int) -> Sequence[int]:
        """The raw values (in the order named) of the block that starts at ``buf[at]``."""
        if self._struct is None:
            return [r.decode(buf[at + r.address - self.start:]) for r in self.regs]
        values = self._struct.unpack_from(buf, at)
        return values if self._order is None else [values[k] for k in self._order]

    def values(self, buf: bytes, at: int, raw: bool, wheel: bool = False) -> Any:
        """One value (one name given as a str) or {name: value}, raw or in SI units (those
        of wheel mode when ``wheel``, see ``moded``)."""
        raws = self.raw(buf, at)
        values: Sequence[Value] = raws if raw else [
            v if c is None else c(v)
            for v, c in zip(raws, self.wheel_convert if wheel else self.convert, strict=True)]
        return values[0] if self.single else dict(zip(self.names, values, strict=True))


class _Read:
    """One READ of named registers of one motor: instruction bytes, reply layout, decoder."""

    __slots__ = ("fields", "model", "motor_id", "proto", "replies", "request")

    def __init__(self, proto: Protocol, motor_id: int, m: Model, fields: _Fields) -> None:
        self.proto, self.motor_id, self.model, self.fields = proto, motor_id, m, fields
        self.request = proto.encode_instruction(proto.read(motor_id, fields.start,
                                                           fields.length))
        self.replies = _Replies(proto, {motor_id: fields.length})


class _MultiRead:
    """A read of many motors: one SYNC_READ or BULK_READ (``request`` and ``replies``, one
    decoder per motor), or their fast forms (one status packet for all), or else one READ per
    motor (``reads``). ``fast``: True takes the fast form or raises ConfigError (before
    anything is sent) where a motor lacks it, None takes it where every motor has it, False
    never."""

    __slots__ = ("fields", "ids", "moded", "models", "name", "proto", "reads", "replies",
                 "request")

    def __init__(self, proto: Protocol, ids: tuple[int, ...], models: list[Model],
                 fields: list[_Fields], *, allow_sync: bool, fast: bool | None = False
                 ) -> None:
        self.proto, self.ids, self.models, self.fields = proto, ids, models, fields
        #: the motors whose SI values depend on their mode (see _Fields.moded)
        self.moded = tuple(i for i, f in zip(ids, fields, strict=True) if f.moded)
        spans = {(f.start, f.length) for f in fields}
        self.reads: list[_Read] = []
        self.request = b""
        if fast is not False:
            # FAST_SYNC_READ where SYNC_READ would go (one span for all), else FAST_BULK_READ.
            name = "FAST_SYNC_READ" if allow_sync and len(spans) == 1 else "FAST_BULK_READ"
            lacking = next(((i, m) for i, m in zip(ids, models, strict=True)
                            if m.protocol != 2 or not supports(m, name)), None)
            if lacking is None and isinstance(proto, Protocol2):
                self.name = name
                if name == "FAST_SYNC_READ":
                    start, length = spans.pop()
                    inst = proto.sync_read(start, length, ids, fast=True)
                else:
                    inst = proto.bulk_read([(i, f.start, f.length)
                                            for i, f in zip(ids, fields, strict=True)],
                                           fast=True)
                self.request = proto.encode_instruction(inst)
                self.replies = _Replies(proto, {i: f.length for i, f in
                                                zip(ids, fields, strict=True)}, fast=True)
                return
            if fast:
                if lacking is None or lacking[1].protocol != 2:
                    raise ConfigError(f"{name} exists only in protocol 2.0 (X-series firmware "
                                      f"{FAST_READ_FIRMWARE} and later); this bus speaks "
                                      f"{proto.version}.0")
                motor_id, m = lacking
                raise ConfigError(f"motor {motor_id} ({m.name}, firmware {m.firmware}) has "
                                  f"no {name}: X-series firmware {FAST_READ_FIRMWARE} and "
                                  "later only; fast=None falls back to the plain instruction")
        if (allow_sync and isinstance(proto, Protocol2) and len(spans) == 1
                and all(supports(m, "SYNC_READ") for m in models)):
            start, length = spans.pop()
            self.name = "SYNC_READ"
            self.request = proto.encode_instruction(proto.sync_read(start, length, ids))
        elif all(supports(m, "BULK_READ") for m in models):
            self.name = "BULK_READ"
            self.request = proto.encode_instruction(proto.bulk_read(
                [(i, f.start, f.length) for i, f in zip(ids, fields, strict=True)]))
        else:
            self.name = "READ"
            self.reads = [_Read(proto, i, m, f)
                          for i, m, f in zip(ids, models, fields, strict=True)]
        self.replies = _Replies(proto, {i: f.length for i, f in zip(ids, fields, strict=True)})


def _si_decoder(m: Model, reg: Register, *, wheel: bool = False
                ) -> Callable[[int], Value] | None:
    """Raw -> SI for one register, as :func:`.units.to_si` computes it (the same operations
    on the same numbers, so the same floats), with the model's scale looked up once; None
    for the kinds that stay raw. ``wheel``: the motor is in 1.0 wheel mode."""
    kind = reg.unit
    if kind in ("raw", "bool"):
        return None
    if wheel and kind == "speed_sign_bit" and m.wheel_output_ratio:
        return partial(units.wheel_speed, m)
    if kind == "position":
        center, tick = m.position_center, m.rad_per_tick
        return lambda raw: (raw - center) * tick
    if kind == "velocity":
        unit = units.velocity_unit(m)
        return lambda raw: raw * unit
    if kind in ("speed_sign_bit", "load_sign_bit"):  # 1.0: 10 bits of magnitude, bit 10 CW
        scale = units.velocity_unit(m) if kind == "speed_sign_bit" else 0.001
        return lambda raw: -(raw & 0x3FF) * scale if raw & 0x400 else (raw & 0x3FF) * scale
    if kind == "load":
        return lambda raw: raw * 0.001
    if kind == "current":
        amperes = m.current_unit_a
        return lambda raw: raw * amperes
    if kind == "pwm":
        return lambda raw: raw / 885.0
    if kind == "voltage":
        return lambda raw: raw * 0.1
    if kind == "temperature":
        return float
    return partial(units.to_si, m, reg)


def _si_encoder(m: Model, reg: Register) -> Callable[[float], int] | None:
    """SI -> raw as :func:`.units.from_si` computes it, unchecked, for the goals a control
    loop writes every cycle (position, velocity); None for other kinds."""
    if reg.unit == "position":
        center, tick = m.position_center, m.rad_per_tick
        return lambda value: round(value / tick) + center
    if reg.unit == "velocity":
        unit = units.velocity_unit(m)
        return lambda value: round(value / unit)
    return None


class _SyncWrite:
    """A SYNC_WRITE of one register on the same motors again: the packet with every ID in
    place, where each motor's value goes, its range, its struct code and its SI scale."""

    __slots__ = ("covers_level", "crc_from", "crc_state", "data_at", "high", "ids", "low",
                 "models", "packer", "proto", "si", "template")

    def __init__(self, proto: Protocol, ids: tuple[int, ...], models: list[Model],
                 reg: Register, covers_level: bool) -> None:
        self.proto, self.ids, self.models = proto, ids, models
        self.covers_level = covers_level
        self.si = (_si_encoder(models[0], reg) if all(m is models[0] for m in models)
                   else None)
        self.low, self.high = reg.raw_min, reg.raw_max
        code = _STRUCT_CODES[(reg.size, reg.signed)]
        self.packer = struct.Struct("<" + code)
        # check that every in-range value fits the code (pack_into would raise otherwise)
        self.packer.pack(self.low)
        self.packer.pack(self.high)
        blank = [(i, bytes(reg.size)) for i in ids]
        self.template = bytearray(proto.encode_instruction(
            proto.sync_write(reg.address, reg.size, blank)))
        # the parameters (after address and length fields) start where the status's data
        # would: 7 bytes of header on 1.0 (FF FF ID LEN INST ADDR LEN), 12 on 2.0
        first = 5 + 2 * proto.field_size if proto.version == 1 else 8 + 2 * proto.field_size
        self.data_at = tuple(first + k * (1 + reg.size) + 1 for k in range(len(ids)))
        self.crc_from = first
        self.crc_state = crc16_at(self.template, 0, first) if proto.version == 2 else 0

    def encode(self, values: Iterable[Any], raw: bool) -> bytes | None:
        """The packet for these values (one per motor, in the plan's ID order), or None if
        any is not a number in the register's range, or not one this plan converts (the
        caller then takes the checked path, which says what is wrong)."""
        buf = bytearray(self.template)
        pack, low, high = self.packer.pack_into, self.low, self.high
        if raw:
            for at, value in zip(self.data_at, values, strict=True):
                if type(value) is not int or not low <= value <= high:
                    return None
                pack(buf, at, value)
        else:
            convert = self.si
            if convert is None:
                return None
            for at, value in zip(self.data_at, values, strict=True):
                kind = type(value)
                if kind is not float and kind is not int:
                    return None
                try:
                    ticks = convert(value)
                except (ValueError, OverflowError):  # nan, inf
                    return None
                if not low <= ticks <= high:
                    return None
                pack(buf, at, ticks)
        if self.proto.version == 1:
            buf[-1] = ~sum(memoryview(buf)[2:-1]) & 0xFF
        else:
            if buf.find(b"\xff\xff\xfd", 7, len(buf) - 2) >= 0:
                return None  # would need byte stuffing: the general encoder does it
            crc = crc16_at(buf, self.crc_from, len(buf) - 2, self.crc_state)
            buf[-2], buf[-1] = crc & 0xFF, crc >> 8
        return bytes(buf)


@dataclass
class Bus:
    """Motors on one port, one protocol, one baud rate.

    ``protocol`` None means the port's own (an emulated bus knows its models'), else 2.
    ``retries`` is how many times a transaction that got no valid answer is sent again.
    ``timeout`` (s), when given, replaces the computed wait for a reply (wire time of the
    expected bytes + return delays + twice the adapter latency + 2 ms); a broadcast ping
    listens at least :meth:`broadcast_ping_wait` all the same.
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
        self._srl: dict[int, int] = {}
        self._alerts: dict[int, int] = {}
        #: (1.0) each motor's raw CW and CCW angle limits as last written or read: its mode
        self._limits: dict[int, tuple[int, int]] = {}
        #: each motor's REG_WRITE waiting for ACTION: (start address, block)
        self._registered: dict[int, tuple[int, bytes]] = {}
        self._plans: dict[Any, Any] = {}
        #: after a transaction that got no valid answer: until when a late one may still come
        self._quiet_until: float | None = None

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
    def _settle(self) -> None:
        """The last transaction got no valid answer: let the time in which its answer could
        still come pass, and throw away whatever came meanwhile, so that a late answer is
        never taken for the answer to the next request. (Costs nothing after a transaction
        that went well: :attr:`_quiet_until` is None then.)"""
        until, self._quiet_until = self._quiet_until, None
        if until is None:
            return
        port, clock = self.port, self.port.clock
        left = until - clock.now()
        if left > 0:
            late = port.read(1 << 16, left)
            self.stats.bytes_in += len(late)
            left = until - clock.now()
            if left > 0:
                clock.sleep(left)
        port.reset_input()

    def _send(self, data: bytes) -> None:
        """A transaction that no status answers (broadcast, or status return level < 2)."""
        with self._lock:
            if self._quiet_until is not None:
                self._settle()
            self.stats.transactions += 1
            self.port.reset_input()
            self.port.write(data)
            self.stats.bytes_out += len(data)

    def transact(self, inst: Instruction, expect: Mapping[int, int] | None = None, *,
                 check: bool = True, retries: int | None = None) -> dict[int, Status]:
        """Send ``inst`` and collect status packets from the IDs in ``expect`` (ID -> number of
        parameters each answer carries). Retries on silence or corruption; raises
        :class:`NoResponse` / :class:`CorruptResponse` when they run out, and
        :class:`MotorError` when ``check`` and a status says the instruction failed (a
        hardware error alone does not: it is recorded in :attr:`alerts`)."""
        proto = self.proto
        data = proto.encode_instruction(inst)
        if not expect:
            self._send(data)
            return {}
        replies = _Replies(proto, expect)
        statuses: dict[int, Status] = {}
        buf, data_at, errors = self._exchange(data, proto.instruction_name(inst.instruction),
                                              replies, check, retries, statuses)
        if statuses:  # the stream parser found them: as they came
            return statuses
        return {i: Status(i, errors[k] if errors else 0, buf[at:at + n])
                for k, (i, n, at) in enumerate(zip(replies.ids, replies.counts, data_at,
                                                   strict=True))}

    def _exchange(self, data: bytes, name: str, replies: _Replies, check: bool,
                  retries: int | None, statuses: dict[int, Status] | None = None, *,
                  alerts: bool = True) -> tuple[bytes, Sequence[int], Sequence[int]]:
        """Send ``data`` and take the status packets ``replies`` describes: returns the reply
        bytes, where each motor's data starts in them, and the error bytes (``()`` when all
        are 0). The fast path reads exactly the bytes expected and checks them in place; when
        they are not as expected, the stream parser looks for the packets until the timeout
        (``statuses``, when given, receives them as found). ``alerts`` False: the statuses'
        hardware-error bits are not the motors' state now (see :meth:`reboot`)."""
        port, stats, proto = self.port, self.stats, self.proto
        total = replies.total
        # How long after sending the answers can take at most: the wire time of the bytes
        # both ways, each answer's longest return delay (254 x 2 us), twice the adapter's
        # latency, and 2 ms. The timeout unless one is set; the late-answer window always.
        longest = ((len(data) + total) * 10.0 / port.baudrate + replies.delays
                   + 2 * port.latency + 0.002)
        timeout = longest if self.timeout is None else self.timeout
        attempts = 1 + (self.retries if retries is None else retries)
        with self._lock:
            for attempt in range(attempts):
                if self._quiet_until is not None:
                    self._settle()
                port.reset_input()
                port.write(data)
                sent = port.clock.now()
                buf = port.read(total, timeout)
                stats.transactions += 1
                stats.bytes_out += len(data)
                stats.bytes_in += len(buf)
                if attempt:
                    stats.retries += 1
                errors: Sequence[int] | None = None
                if len(buf) == total:
                    if replies.fast:
                        errors = match_fast_status(buf, replies.prefixes[0], replies.states[0],
                                                   replies.ids, replies.ends)
                    elif replies.single:
                        error = proto.match_status(buf, replies.prefixes[0], replies.states[0])
                        errors = () if not error else None if error < 0 else [error]
                    else:
                        errors = proto.match_statuses(buf, replies.starts, replies.sizes,
                                                      replies.prefixes, replies.states)
                if errors is None:
                    collect = self._collect_fast if replies.fast else self._collect
                    try:
                        found = collect(buf, name, replies, sent, timeout)
                    except CommError:
                        # its answer may still be on its way: keep it from the next request
                        self._quiet_until = sent + longest
                        if attempt + 1 == attempts:
                            raise
                        continue
                    if statuses is not None:
                        statuses.update(found)
                    buf, errors = self._normalise(found, replies)
                if errors or self._alerts:
                    self._note(replies.ids, errors, name, check, alerts)
                return buf, replies.data_at, errors
        raise AssertionError("unreachable")  # pragma: no cover

    def _note(self, ids: Sequence[int], errors: Sequence[int], name: str, check: bool,
              record: bool = True) -> None:
        """Record the hardware errors the statuses report (:attr:`alerts`), unless not
        ``record``, and raise :class:`MotorError` for an instruction that failed, when
        ``check``."""
        proto, alerts = self.proto, self._alerts
        for k, motor_id in enumerate(ids if record else ()):
            bits = proto.alert(errors[k]) if errors else 0
            if bits:
                if alerts.get(motor_id) != bits:  # once, when it starts or changes
                    log.warning(
                        "motor %d reports a hardware error (%s) in its %s status; the "
                        "instruction was carried out%s", motor_id,
                        "alert bit" if proto.version == 2 else ", ".join(
                            proto.error_names(bits)), name,
                        "; its hardware_error_status says which, REBOOT clears it"
                        if proto.version == 2 else "")
                alerts[motor_id] = bits
            else:
                alerts.pop(motor_id, None)
        if check and errors:
            for motor_id, error in zip(ids, errors, strict=True):
                if proto.failed(error):
                    raise MotorError(motor_id, name, proto.error_names(error), error)

    def _normalise(self, found: dict[int, Status], replies: _Replies
                   ) -> tuple[bytes, list[int] | tuple[()]]:
        """Statuses found by the parser, laid out as the fast path lays them: each motor's
        data at ``replies.data_at`` (zeros where a failed instruction brought none)."""
        buf = bytearray(replies.total)
        errors = [0] * len(replies.ids)
        for k, (motor_id, n, at) in enumerate(zip(replies.ids, replies.counts,
                                                  replies.data_at, strict=True)):
            status = found[motor_id]
            buf[at:at + len(status.params)] = status.params[:n]
            errors[k] = status.error
        return bytes(buf), errors if any(errors) else ()

    def _collect(self, first: bytes, name: str, replies: _Replies, sent: float,
                 timeout: float) -> dict[int, Status]:
        """The slow path: find the expected statuses in ``first`` and whatever else comes
        before ``deadline``. A status counts only from a motor asked (and not yet answered)
        with the data length asked for, or none when its error byte says the instruction
        failed; others are late answers to an earlier instruction or strays, and are
        dropped."""
        proto, port, clock, stats = self.proto, self.port, self.port.clock, self.stats
        expect = replies.expect
        sizes = dict(zip(replies.ids, replies.sizes, strict=True))
        deadline = sent + timeout
        parser = proto.parser()
        got: dict[int, Status] = {}
        wrong: dict[int, int] = {}  # motor asked -> data length of a status that did not fit
        chunk = first
        while True:
            for frame in parser.feed(chunk):
                try:
                    status = proto.as_status(frame)
                except ValueError:
                    stats.stale += 1
                    continue
                n = expect.get(status.id)
                if n is None or status.id in got:
                    stats.stale += 1
                elif len(status.params) == n or (not status.params
                                                 and proto.failed(status.error)):
                    got[status.id] = status
                else:
                    stats.stale += 1
                    wrong[status.id] = len(status.params)
            if len(got) == len(expect):
                return got
            remaining = deadline - clock.now()
            if remaining <= 0:
                break
            want = max(1, sum(s for i, s in sizes.items() if i not in got) - parser.pending)
            chunk = port.read(want, remaining)
            stats.bytes_in += len(chunk)
        missing = [i for i in replies.ids if i not in got]
        who = ", ".join(str(i) for i in missing)
        if parser.dropped or parser.pending or any(i in wrong for i in missing):
            stats.corrupt += 1
            detail = (f"({parser.dropped + parser.pending} bad bytes)"
                      if parser.dropped or parser.pending else
                      "(a status of " + ", ".join(f"{wrong[i]} data bytes from motor {i}"
                                                  for i in missing if i in wrong)
                      + f", expected {expect[missing[0]]}: a late answer?)")
            raise CorruptResponse(f"motor {who}: {name} got a corrupt status packet {detail} "
                                  f"at {self.baudrate} bps", motor_id=missing[0],
                                  instruction=name)
        stats.timeouts += 1
        raise NoResponse(f"motor {who}: no answer to {name} within {timeout * 1000:.1f} ms "
                         f"at {self.baudrate} bps (is it powered, at this baud rate and ID?)",
                         motor_id=missing[0], instruction=name)

    def _collect_fast(self, first: bytes, name: str, replies: _Replies, sent: float,
                      timeout: float) -> dict[int, Status]:
        """The slow path of a FAST_SYNC_READ / FAST_BULK_READ: find the one status packet
        (its head as expected, LEN included) in ``first`` and whatever else comes before the
        deadline, and take its blocks as far as they came whole and valid. The motors build
        the packet along the chain, so when one of them does not answer, the ones after it
        (which wait for its block) do not either: all are named, the first one as the cause."""
        port, clock, stats = self.port, self.port.clock, self.stats
        deadline = sent + timeout
        head, total = replies.prefixes[0], replies.total
        buf = bytearray(first)
        while True:
            at = buf.find(head)
            if at >= 0 and len(buf) - at >= total:
                break
            remaining = deadline - clock.now()
            if remaining <= 0:
                break
            chunk = port.read(max(1, total - (len(buf) - at if at >= 0 else 0)), remaining)
            stats.bytes_in += len(chunk)
            buf += chunk
        got: list[Status] = []
        broken = bool(buf)  # bytes came, but no head as expected among them
        while at >= 0:  # the head's first occurrence may be data: take the best one
            blocks, cut = read_fast_status(bytes(buf), at, replies.ids, replies.counts)
            if len(blocks) > len(got) or at == buf.find(head):
                got, broken = blocks, cut
            at = buf.find(head, at + 1)
        if len(got) == len(replies.ids):
            return {status.id: status for status in got}
        missing = replies.ids[len(got):]
        who = ", ".join(str(i) for i in missing)
        rest = ", ".join(str(i) for i in missing[1:])
        after = (f"; {'motors' if len(missing) > 2 else 'motor'} {rest} after it in the "
                 f"chain send only after its block" if rest else "")
        if broken:
            stats.corrupt += 1
            raise CorruptResponse(f"motor {who}: {name} got a corrupt status packet (the block "
                                  f"of motor {missing[0]} cut short or failing its CRC) at "
                                  f"{self.baudrate} bps{after}", motor_id=missing[0],
                                  instruction=name)
        stats.timeouts += 1
        raise NoResponse(f"motor {who}: no block in the {name} status within "
                         f"{timeout * 1000:.1f} ms at {self.baudrate} bps (is motor "
                         f"{missing[0]} powered, at this baud rate and ID?){after}",
                         motor_id=missing[0], instruction=name)

    @property
    def alerts(self) -> Mapping[int, int]:
        """Motors whose last status reported a hardware error: ID -> those error bits (a
        read-only view, kept up to date by the bus).

        A hardware error is the motor's state, not a failed instruction: the instruction was
        carried out and its data is valid (e-Manual, Protocol 1.0 "Status Packet" and Protocol
        2.0 "Error"). On 1.0 the bits say which (0x01 input voltage, 0x04 overheating, 0x20
        overload); on 2.0 only the alert bit 0x80 comes, and the motor's
        ``hardware_error_status`` register says which (:meth:`hardware_errors` reads it).
        Every status the bus takes updates it; a motor leaves it with its first status
        without them (on 2.0 after a REBOOT)."""
        return MappingProxyType(self._alerts)

    def hardware_errors(self, motor_id: int) -> tuple[str, ...]:
        """The hardware errors ``motor_id`` reports now, by name (``()`` for none): on 2.0 from
        its ``hardware_error_status`` register, on 1.0 from the error byte of a PING's
        status."""
        m = self.model_of(motor_id)
        if self.proto.version == 2 and m.has("hardware_error_status"):
            bits = int(self.read(motor_id, "hardware_error_status", raw=True))
            return tuple(name for bit, name in sorted(HARDWARE_ERRORS.items()) if bits & bit)
        v1 = self.proto.version == 1
        status = self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3},
                               check=False)[motor_id]
        return self.proto.error_names(self.proto.alert(status.error))

    # -- discovery ---------------------------------------------------------------------------
    def ping(self, motor_id: int, *, retries: int | None = None) -> PingResult:
        """PING one motor and learn its model (on 1.0 by reading its model number)."""
        self.proto.check_id(motor_id)
        v1 = self.proto.version == 1
        status = self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3},
                               check=False, retries=retries)[motor_id]
        self._limits.pop(motor_id, None)   # perhaps another motor now, or other limits
        if v1:
            # 1.0 PING carries no model number: read it (addresses 0-2), and in the same READ
            # the angle limits (6-9), which tell joint from wheel mode. A motor at status
            # return level 0 answers PING but not READ; it is found, model unknown.
            try:
                read = self.transact(self.proto.read(motor_id, 0, _PING_READ_1),
                                     {motor_id: _PING_READ_1}, check=False,
                                     retries=retries)[motor_id]
            except NoResponse:
                return PingResult(motor_id, 0, None, self.baudrate, None)
            number = int.from_bytes(read.params[0:2], "little")
            firmware: int | None = read.params[2]
            self._limits[motor_id] = (int.from_bytes(read.params[6:8], "little"),
                                      int.from_bytes(read.params[8:10], "little"))
        else:
            number = int.from_bytes(status.params[0:2], "little")
            firmware = status.params[2]
        found = _at_firmware(model_by_number(number), firmware)
        if found is not None:
            self.motors[motor_id] = found
        return PingResult(motor_id, number, firmware, self.baudrate, found)

    def broadcast_ping_wait(self) -> float:
        """How long :meth:`broadcast_ping` listens (s) at least.

        "When the Packet ID field is 0xFE (Broadcast ID): All devices send their Status
        Packet according to their arranged order" (e-Manual, Protocol 2.0, Ping): in ID
        order, each ID in its turn whether a motor has it or not. ROBOTIS's device-side code
        (Dynamixel2Arduino src/utility/protocol.cpp, DXL_PROCESS_BROAD_PING) moves on to the
        next ID as soon as it hears a status, and otherwise after :data:`BROADCAST_PING_SLOT`
        (3 ms). So each of the IDs 0..251 before ID 252 takes at most the longer of a slot
        and an answer (the longest return delay, 254 x 2 us, and a 14-byte status), and ID
        252 its own answer: with the PING's own wire time, twice the adapter latency and
        2 ms, that is the wait."""
        tick = byte_time(self.baudrate)
        proto = self.proto
        answer = proto.status_size(3) * tick + MAX_RETURN_DELAY
        ping = len(proto.encode_instruction(proto.ping(proto.broadcast_id))) * tick
        return (ping + proto.max_id * max(BROADCAST_PING_SLOT, answer) + answer
                + 2 * self.port.latency + 0.002)

    def broadcast_ping(self) -> list[PingResult]:
        """Protocol 2.0 broadcast PING: every motor answers, in one transaction (which lasts
        :meth:`broadcast_ping_wait`, enough for ID 252 to answer in its turn, or the bus's
        ``timeout`` if that is longer: a short per-transaction timeout does not cut it
        short)."""
        if self.proto.version != 2:
            raise ConfigError("broadcast ping exists only in protocol 2.0; use scan()")
        data = self.proto.encode_instruction(self.proto.ping(self.proto.broadcast_id))
        timeout = max(self.timeout or 0.0, self.broadcast_ping_wait())
        parser = self.proto.parser()
        found: dict[int, PingResult] = {}
        with self._lock:
            self._send(data)
            clock = self.port.clock
            deadline = clock.now() + timeout
            while (remaining := deadline - clock.now()) > 0:
                chunk = self.port.read(4096, remaining)
                self.stats.bytes_in += len(chunk)
                if not chunk and not clock.virtual:
                    clock.sleep(min(remaining, 0.001))  # an in-process port returns at once
                for frame in parser.feed(chunk):
                    try:
                        status = self.proto.as_status(frame)
                    except ValueError:
                        self.stats.stale += 1
                        continue
                    if len(status.params) != 3 or status.id in found:
                        self.stats.stale += 1
                        continue
                    number = int.from_bytes(status.params[0:2], "little")
                    m = _at_firmware(model_by_number(number), status.params[2])
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
            self._limits.pop(motor_id, None)
        self.motors[motor_id] = m
        if wheel_mode is not None and m.has(_ANGLE_LIMITS[1]):
            self._limits[motor_id] = (0, 0) if wheel_mode else (
                0, m.register(_ANGLE_LIMITS[1]).raw_max)

    # -- conversions -------------------------------------------------------------------------
    @staticmethod
    def _names(names: Names) -> list[str]:
        return [names] if isinstance(names, str) else list(names)

    def wheel_mode(self, motor_id: int) -> bool:
        """Whether ``motor_id`` (protocol 1.0) is in wheel mode, both angle limits 0 (e-Manual,
        CW/CCW Angle Limit): as this bus last wrote them, else read from the motor once and
        kept. False on 2.0, whose modes are its operating_mode."""
        m = self.model_of(motor_id)
        return m.protocol == 1 and m.has("cw_angle_limit") and self._wheel(motor_id)

    def _wheel(self, motor_id: int) -> bool:
        limits = self._limits.get(motor_id)
        if limits is None:
            if self.status_return_level.get(motor_id, 2) == 0:
                raise ConfigError(
                    f"motor {motor_id}: wheel or joint mode unknown and it answers no READ "
                    "(status return level 0); declare it with bus.declare(id, model, "
                    "wheel_mode=True/False) or write its angle limits through this bus")
            got = self.read(motor_id, list(_ANGLE_LIMITS), raw=True)
            limits = (int(got[_ANGLE_LIMITS[0]]), int(got[_ANGLE_LIMITS[1]]))
            self._limits[motor_id] = limits
        return limits == (0, 0)

    def _wheel_si(self, motor_id: int, m: Model, reg: Register) -> bool:
        """Whether ``reg`` of ``motor_id`` converts to SI as in wheel mode: moving/present
        speed of a model whose wheel mode sets the output (:attr:`.Model.wheel_output_ratio`),
        in wheel mode (see :func:`.units.wheel_speed`)."""
        return (reg.unit == "speed_sign_bit" and m.wheel_output_ratio
                and self._wheel(motor_id))

    def to_si(self, motor_id: int, name: str, raw: int) -> Value:
        """A raw value of register ``name`` of ``motor_id`` in SI units, as :meth:`read`
        converts it (by the motor's mode where it matters, see :meth:`wheel_mode`)."""
        m = self.model_of(motor_id)
        reg = m.register(name)
        return units.to_si(m, reg, int(raw), wheel=self._wheel_si(motor_id, m, reg))

    def from_si(self, motor_id: int, name: str, value: float) -> int:
        """The raw value :meth:`write` sends for ``value`` (SI units) in register ``name`` of
        ``motor_id``; :class:`ConfigError` when it is out of range."""
        m = self.model_of(motor_id)
        reg = m.register(name)
        return units.from_si(m, reg, value, wheel=self._wheel_si(motor_id, m, reg))

    def _encode(self, motor_id: int, m: Model, reg: Register, value: Value, raw: bool
                ) -> bytes:
        if not reg.writable:
            raise ConfigError(f"{m.name} {reg.name} is read-only")
        if raw:
            if isinstance(value, bool) or not float(value).is_integer():
                raise ConfigError(f"{m.name} {reg.name}: raw value {value!r} is not an integer")
            raw_value = int(value)
            reg.check(raw_value, m)
        else:
            raw_value = units.from_si(m, reg, value, wheel=self._wheel_si(motor_id, m, reg))
        return reg.encode(raw_value)

    # -- plans ---------------------------------------------------------------------------------
    def _plan(self, key: Any) -> Any:
        try:
            return self._plans.get(key)
        except TypeError:  # an unhashable ID or name: the checked path says what is wrong
            return None

    def _keep(self, key: Any, plan: Any) -> None:
        try:
            if len(self._plans) >= MAX_PLANS:
                self._plans.clear()
            self._plans[key] = plan
        except TypeError:
            pass

    def _read_plan(self, motor_id: int, names: Names, key: Any) -> _Read:
        m = self.model_of(motor_id)
        plan = _Read(self.proto, motor_id, m, _Fields(m, names))
        self._keep(key, plan)
        return plan

    def _multi_plan(self, requests: Sequence[tuple[int, Names]], key: Any, *,
                    allow_sync: bool, fast: bool | None = False) -> _MultiRead:
        """The plan of a read of many motors, each model learnt and each name checked."""
        ids = tuple(i for i, _ in requests)
        models = [self.model_of(i) for i in ids]
        fields = [_Fields(m, names) for m, (_, names) in zip(models, requests, strict=True)]
        plan = _MultiRead(self.proto, ids, models, fields, allow_sync=allow_sync, fast=fast)
        self._keep(key, plan)
        return plan

    def _fresh(self, plan: _MultiRead | _SyncWrite | None, ids: tuple[int, ...]) -> bool:
        """Whether a plan still holds: same protocol, every motor still the same model, and
        the IDs plain ints (``True`` would find motor 1's plan)."""
        return (plan is not None and plan.proto is self.proto
                and list(map(self.motors.get, ids)) == plan.models
                and set(map(type, ids)) <= _INT)

    # -- one motor ---------------------------------------------------------------------------
    @overload
    def read(self, motor_id: int, names: str, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value: ...

    @overload
    def read(self, motor_id: int, names: NameList, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> dict[str, Value]: ...

    def read(self, motor_id: int, names: Names, *, raw: bool = False,
             check: bool = True, retries: int | None = None) -> Value | dict[str, Value]:
        """Read one register (returns its value) or several (returns a dict), in SI units
        unless ``raw``. Several registers go out as one contiguous READ. (Moving and present
        speed of an RX-28 or EX-106+ in wheel mode: the unloaded speed, see :meth:`write`.)
        ``retries`` replaces the bus's own for this read."""
        if not isinstance(names, str | list | tuple):
            names = list(names)  # any other iterable: read it once
        key = (motor_id, names if isinstance(names, str) else tuple(names))
        plan = self._plan(key)
        if (plan is None or type(motor_id) is not int or plan.proto is not self.proto
                or self.motors.get(motor_id) is not plan.model):
            plan = self._read_plan(motor_id, names, key)
        if 0 in self._srl.values():
            self._check_reads_answered((motor_id,))
        # moving/present speed in wheel mode on AX/RX/EX: the motor's mode decides the unit
        wheel = not raw and plan.fields.moded and self._wheel(motor_id)
        buf, data_at, _ = self._exchange(plan.request, "READ", plan.replies, check, retries)
        return plan.fields.values(buf, data_at[0], raw, wheel)  # type: ignore[no-any-return]

    def write(self, motor_id: int, name: str | Mapping[str, Value], value: Value | None = None,
              *, raw: bool = False, registered: bool = False) -> None:
        """Write one register (``write(1, "goal_position", 0.5)``) or several adjacent ones
        (``write(1, {"goal_position": 0.5, "moving_speed": 1.0})``) in one WRITE.
        ``registered`` sends REG_WRITE, applied by a later :meth:`action`.

        On models whose wheel mode sets the output rather than a speed (RX-28, EX-106+:
        :attr:`.Model.wheel_output_ratio`), a moving_speed in rad/s is, in wheel mode, the
        speed of the unloaded horn (:func:`.units.wheel_speed`); the bus knows the mode from
        the angle limits it wrote, or reads them once (:meth:`wheel_mode`)."""
        m = self.model_of(motor_id)
        given: dict[str, Value | None] = dict(name) if isinstance(name, Mapping) else {name: value}
        values = {n: v for n, v in given.items() if v is not None}
        if len(values) != len(given):
            raise ConfigError(f"motor {motor_id}: write needs a value for {name!r}")
        start, block = self._block(motor_id, m, values, raw)
        level = self._level_after(motor_id, m, start, block, registered=registered)
        self.transact(self.proto.write(motor_id, start, block, registered=registered),
                      {motor_id: 0} if level >= 2 else None)
        if registered:  # the motor keeps one REG_WRITE, the last, until ACTION
            self._registered[motor_id] = (start, block)
        else:
            self._learn(motor_id, m, start, block)

    def _block(self, motor_id: int, m: Model, values: Mapping[str, Value], raw: bool
               ) -> tuple[int, bytes]:
        regs = sorted((m.register(n) for n in values), key=lambda r: r.address)
        for a, b in itertools.pairwise(regs):
            if a.address + a.size != b.address:
                raise ConfigError(f"{m.name}: {a.name} and {b.name} are not adjacent; write "
                                  "them separately")
        block = b"".join(self._encode(motor_id, m, r, values[r.name], raw) for r in regs)
        return regs[0].address, block

    def _learn(self, motor_id: int, m: Model, start: int, block: bytes) -> None:
        """What a write of ``block`` at ``start``, carried out by ``motor_id``, tells the bus
        where the block covers them: the motor's status return level, and (1.0) its angle
        limits, hence its mode."""
        end = start + len(block)
        if m.has("status_return_level"):
            reg = m.register("status_return_level")
            if start <= reg.address < end:
                self._srl[motor_id] = reg.decode(block[reg.address - start:])
        if m.protocol != 1 or not m.has(_ANGLE_LIMITS[0]):
            return
        regs = [m.register(n) for n in _ANGLE_LIMITS]
        if not any(start < r.address + r.size and r.address < end for r in regs):
            return
        known = self._limits.get(motor_id)
        limits: list[int] = []
        for k, reg in enumerate(regs):
            if start <= reg.address and reg.address + reg.size <= end:
                limits.append(reg.decode(block[reg.address - start:]))
            elif known is not None:
                limits.append(known[k])
        if len(limits) == 2:
            self._limits[motor_id] = (limits[0], limits[1])
        else:  # one written, the other unknown: read both when next needed
            self._limits.pop(motor_id, None)

    def _level_after(self, motor_id: int, m: Model, start: int, block: bytes, *,
                     registered: bool = False) -> int:
        """The status return level ``motor_id`` has once ``block`` is written at ``start``:
        the value written when the block covers the register (the motor answers that WRITE
        already by its new level), else the level the bus knows (2, the factory default,
        until told). A REG_WRITE changes nothing before its ACTION."""
        known = self._srl.get(motor_id, 2)
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
            if self._srl.get(motor_id, 2) == 0:
                raise ConfigError(f"motor {motor_id}: status return level 0 answers PING only; "
                                  "write status_return_level 1 or 2 to read it")

    @property
    def status_return_level(self) -> dict[int, int]:
        """The status return level of each motor as this bus knows it (2, the factory
        default, for motors not in it); it decides which instructions the bus waits on.

        The bus keeps it up to date from what it sends: writes of ``status_return_level``
        (WRITE, SYNC_WRITE, BULK_WRITE, and a REG_WRITE once its :meth:`action` is sent),
        :meth:`reboot` (which brings a level kept in RAM, as on the X-series, back to 2) and
        :meth:`factory_reset`. This is the bus's own dict, not a copy: set an entry to tell
        the bus of a level it cannot know (set by another program, or kept in a motor's
        EEPROM from before)."""
        return self._srl

    def action(self) -> None:
        """Broadcast ACTION: every motor applies its REG_WRITE at once (and the bus learns
        what those writes set, e.g. a status return level)."""
        self.transact(self.proto.action())
        registered, self._registered = self._registered, {}
        for motor_id, (start, block) in registered.items():
            m = self.motors.get(motor_id)
            if m is not None:
                self._learn(motor_id, m, start, block)

    def reboot(self, motor_id: int) -> None:
        """REBOOT (protocol 2.0; ``motor_id`` may be the broadcast ID): the motor starts again
        as at power-up, its RAM at factory values (the X-series' status_return_level,
        address 68, among them: back to 2), its EEPROM kept, its hardware error cleared.

        The motor sends its status before it restarts, so by the status return level it had
        before (only at level 2) and with the hardware-error alert the reboot then clears:
        the bus waits for a status only at level 2, and takes only the instruction's own
        error from it (no alert is logged or recorded)."""
        proto = self.proto
        if not isinstance(proto, Protocol2):
            raise ConfigError("REBOOT exists only in protocol 2.0")
        ids = self._targets(motor_id)
        self._reset_exchange(proto.reboot(motor_id), "REBOOT", motor_id, alerts=False)
        for i in ids:
            self._alerts.pop(i, None)
            self._registered.pop(i, None)  # RAM: a REG_WRITE waiting for ACTION is gone
            m = self.motors.get(i)
            if m is None or not m.has("status_return_level") \
                    or m.register("status_return_level").area == "RAM":
                self._srl.pop(i, None)     # the factory level, 2

    def factory_reset(self, motor_id: int, *, keep_id: bool = True,
                      keep_baud: bool = True) -> None:
        """Restore factory defaults; ``motor_id`` may be the broadcast ID.

        Protocol 1.0 RESET resets the whole control table, "to the factory default values"
        (e-Manual, Protocol 1.0, Factory Reset), whatever ``keep_id`` and ``keep_baud`` say:
        the motor is then ID 1 ("The factory default setting ID is 1", ibid., ID), at
        baud_rate 34 (57142 bps) and status return level 2. Protocol 2.0 FACTORY_RESET keeps
        the ID and baud rate (``keep_id`` and ``keep_baud``), the ID only (``keep_id``), or
        nothing (ID 1, 57600 bps).

        The bus follows: the motor is at status return level 2; where its ID changes, the
        bus forgets what it knew of the old ID and of ID 1 (model, level, mode, alerts),
        which the next access learns again. It does not follow a baud rate the reset
        changes: the motor is then heard only at its new rate (see :meth:`scan`). As for
        :meth:`reboot`, the status goes out before the reset, by the level before it."""
        proto = self.proto
        if isinstance(proto, Protocol1):
            inst, name, moves = proto.reset(motor_id), "RESET", True
        elif isinstance(proto, Protocol2):
            option = (FACTORY_RESET_EXCEPT_ID_BAUD if keep_id and keep_baud else
                      FACTORY_RESET_EXCEPT_ID if keep_id else FACTORY_RESET_ALL)
            if motor_id == proto.broadcast_id and option == FACTORY_RESET_ALL:
                # "In case of when Packet ID is a Broadcast ID 0xFE and Option is Reset All
                # 0xFF, Factory Reset Instruction(0x06) will NOT be activated" (e-Manual,
                # Protocol 2.0): sending it would change nothing but what the bus believes.
                raise ConfigError("a broadcast FACTORY_RESET of everything is ignored by the "
                                  "motors (e-Manual); reset them one ID at a time, or keep "
                                  "their IDs (keep_id=True)")
            inst, name = proto.factory_reset(motor_id, option), "FACTORY_RESET"
            moves = not keep_id
        else:
            raise ConfigError(f"FACTORY_RESET does not exist in protocol {proto.version}.0")
        ids = self._targets(motor_id)
        self._reset_exchange(inst, name, motor_id)
        for i in [*ids, 1] if moves else ids:
            self._srl.pop(i, None)
            self._registered.pop(i, None)
            self._limits.pop(i, None)
            if moves:
                self.motors.pop(i, None)
                self._alerts.pop(i, None)

    def _targets(self, motor_id: int) -> list[int]:
        """The motors an instruction to ``motor_id`` reaches, as far as the bus knows them."""
        if motor_id != self.proto.broadcast_id:
            self.proto.check_id(motor_id)
            return [motor_id]
        return sorted({*self.motors, *self._srl, *self._alerts, *self._limits,
                       *self._registered})

    def _reset_exchange(self, inst: Instruction, name: str, motor_id: int, *,
                        alerts: bool = True) -> None:
        """Send a REBOOT, FACTORY_RESET or RESET, and take its status where one comes: from
        a unicast to a motor at status return level 2 before the instruction (the status
        goes out before the motor resets)."""
        proto = self.proto
        data = proto.encode_instruction(inst)
        if motor_id == proto.broadcast_id or self._srl.get(motor_id, 2) < 2:
            self._send(data)
            return
        self._exchange(data, name, _Replies(proto, {motor_id: 0}), True, None, alerts=alerts)

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
        key: tuple[str, str, tuple[int, ...]] | None = None
        if isinstance(names, str):
            ids = tuple(values)
            key = ("sync_write", names, ids)
            plan = self._plan(key)
            if self._fresh(plan, ids):
                data = plan.encode(values.values(), raw)
                if data is not None:
                    self._send(data)
                    if plan.covers_level:  # it wrote status_return_level (raw: no SI kind)
                        for motor_id in plan.ids:
                            level = values[motor_id]
                            assert isinstance(level, int)  # the plan's encode checked it
                            self._srl[motor_id] = level
                    return
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
            start, block = self._block(motor_id, m, dict(zip(wanted, vals, strict=True)), raw)
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
        if key is not None:  # one register: the next time, through a plan
            self._keep(key, self._sync_write_plan(key[1], key[2]))
        for motor_id, block in blocks:
            self._learn(motor_id, self.motors[motor_id], layout[0], block)

    def _sync_write_plan(self, name: str, ids: tuple[int, ...]) -> _SyncWrite | None:
        """The plan of a SYNC_WRITE of ``name`` to ``ids`` like the one just sent (which
        checked the register and every value), or None where the template cannot serve."""
        models = [self.motors[i] for i in ids]
        reg = models[0].register(name)
        if (any(m.register(name) != reg for m in models) or name in _ANGLE_LIMITS
                or (reg.size, reg.signed) not in _STRUCT_CODES):
            return None  # (the angle limits: the checked path learns the motors' mode)
        covers = any(m.has("status_return_level")
                     and m.register("status_return_level").address == reg.address
                     for m in models)
        try:
            plan = _SyncWrite(self.proto, ids, models, reg, covers)
        except (struct.error, ValueError):
            return None
        expected = self.proto.encode_instruction(self.proto.sync_write(
            reg.address, reg.size, [(i, bytes(reg.size)) for i in ids]))
        return plan if len(expected) == len(plan.template) else None

    @overload
    def sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False) -> dict[int, Value]: ...

    @overload
    def sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, dict[str, Value]]: ...

    def sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, Value] | dict[int, dict[str, Value]]:
        """The same register(s) of many motors: one SYNC_READ on 2.0, one BULK_READ on 1.0
        models that have it, else one READ each. Returns {id: value} for one register name,
        {id: {name: value}} for a list of names. Motors that report a hardware error answer
        all the same: their data is returned and they are named in :attr:`alerts`.

        ``fast``: True sends FAST_SYNC_READ, one status packet for all the motors (see
        :meth:`fast_sync_read`), and raises :class:`ConfigError` before sending anything
        where a motor's model lacks it; None sends it where every motor has it and the plain
        instruction otherwise; False, the default, never. (Not None by default: the packets
        this method sends are those of the ROBOTIS SDK's GroupSyncRead.txRxPacket, which the
        bus_cycle benchmark replays byte for byte to both drivers, and what existing users
        of SYNC_READ count on; a motor on old firmware stays silent to 0x8A, and a declared
        model cannot tell the firmware a real motor runs.)"""
        ids_t = tuple(dict.fromkeys(ids))
        if not ids_t:
            return {}
        if not isinstance(names, str):
            names = tuple(names)
        key = ("sync_read", names, ids_t, fast)
        plan = self._plan(key)
        if not self._fresh(plan, ids_t):
            plan = self._multi_plan([(i, names) for i in ids_t], key, allow_sync=True,
                                    fast=fast)
        return self._run_multi(plan, raw, check)

    def bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                  check: bool = True, fast: bool | None = False
                  ) -> dict[int, dict[str, Value]]:
        """Different registers of different motors: {id: names} -> {id: {name: value}}.
        One BULK_READ where every model has it, else one contiguous READ per motor.
        ``fast`` as in :meth:`sync_read`, for FAST_BULK_READ."""
        if not requests:
            return {}
        pairs = [(i, [n] if isinstance(n, str) else list(n)) for i, n in requests.items()]
        ids = tuple(i for i, _ in pairs)
        key = ("bulk_read", tuple((i, tuple(n)) for i, n in pairs), fast)
        plan = self._plan(key)
        if not self._fresh(plan, ids):
            plan = self._multi_plan(pairs, key, allow_sync=False, fast=fast)
        return self._run_multi(plan, raw, check)

    @overload
    def fast_sync_read(self, names: str, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value]: ...

    @overload
    def fast_sync_read(self, names: NameList, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, dict[str, Value]]: ...

    def fast_sync_read(self, names: Names, ids: Iterable[int], *, raw: bool = False,
                       check: bool = True) -> dict[int, Value] | dict[int, dict[str, Value]]:
        """:meth:`sync_read` with FAST_SYNC_READ (0x8A): the motors answer with one status
        packet between them, each after the first appending its block at once, which saves
        the header and the return delay of every status packet but one. X-series firmware
        46 and later only (:data:`.models.FAST_READ_FIRMWARE`): other models are refused
        with :class:`ConfigError` before anything is sent. A motor that does not answer
        stops the chain: the :class:`NoResponse` names it, and the motors after it."""
        if isinstance(names, str):
            return self.sync_read(names, ids, raw=raw, check=check, fast=True)
        return self.sync_read(tuple(names), ids, raw=raw, check=check, fast=True)

    def fast_bulk_read(self, requests: Mapping[int, Names], *, raw: bool = False,
                       check: bool = True) -> dict[int, dict[str, Value]]:
        """:meth:`bulk_read` with FAST_BULK_READ (0x9A), as :meth:`fast_sync_read`."""
        return self.bulk_read(requests, raw=raw, check=check, fast=True)

    def _run_multi(self, plan: _MultiRead, raw: bool, check: bool) -> dict[int, Any]:
        if 0 in self._srl.values():
            self._check_reads_answered(plan.ids)
        # the motors whose speeds convert as in wheel mode (see read)
        wheel = {i for i in plan.moded if self._wheel(i)} if plan.moded and not raw else None
        if plan.reads:
            out = {}
            for read in plan.reads:
                buf, data_at, _ = self._exchange(read.request, "READ", read.replies, check,
                                                 None)
                out[read.motor_id] = read.fields.values(
                    buf, data_at[0], raw, wheel is not None and read.motor_id in wheel)
            return out
        buf, data_at, _ = self._exchange(plan.request, plan.name, plan.replies, check, None)
        if wheel:
            return {i: f.values(buf, at, raw, i in wheel)
                    for i, f, at in zip(plan.ids, plan.fields, data_at, strict=True)}
        return {i: f.values(buf, at, raw)
                for i, f, at in zip(plan.ids, plan.fields, data_at, strict=True)}

    def bulk_write(self, values: Mapping[int, Mapping[str, Value]], *,
                   raw: bool = False) -> None:
        """Different registers on different motors: {id: {name: value}}. One BULK_WRITE on
        2.0; on 1.0 (which has none) one WRITE per motor."""
        blocks = []
        for motor_id, regs in values.items():
            m = self.model_of(motor_id)
            start, block = self._block(motor_id, m, regs, raw)
            blocks.append((motor_id, m, start, block))
        proto = self.proto
        if isinstance(proto, Protocol2) and all(supports(m, "BULK_WRITE") for _, m, _, _ in blocks):
            self.transact(proto.bulk_write([(i, start, block) for i, _, start, block in blocks]))
        else:
            for motor_id, m, start, block in blocks:
                level = self._level_after(motor_id, m, start, block)
                self.transact(self.proto.write(motor_id, start, block),
                              {motor_id: 0} if level >= 2 else None)
                self._learn(motor_id, m, start, block)
            return
        for motor_id, m, start, block in blocks:
            self._learn(motor_id, m, start, block)
