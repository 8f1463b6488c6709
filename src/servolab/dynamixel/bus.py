"""The driver: a :class:`Bus` talks to the motors on one port, in SI units by register name.

``bus.read(11, "present_position")`` looks the register up in motor 11's control table, sends
one READ, checks the status packet and returns radians. Several registers of one motor go out
as one contiguous READ; many motors go out as SYNC_WRITE / SYNC_READ / BULK_READ where the
model has them, and fall back to one packet per motor where it does not (RX-28 has no
BULK_READ). On X-series firmware 46 and later, ``fast_sync_read`` / ``fast_bulk_read`` (or
``fast=True``/``None``) send FAST_SYNC_READ / FAST_BULK_READ, answered by one status packet
for all the motors. Everything is checked before the first byte is sent, so bad input writes
nothing.

**Safe.** What a motor would refuse is refused before the wire, in one line that says what to
do: a value beyond the motor's mode and limits, a truth value for an angle, a register name it
does not have ("did you mean"), an EEPROM write to a 2.0 motor whose torque is on. IDs and baud
rates change through :meth:`Bus.change_id` and :meth:`Bus.change_baud`, which refuse a used ID
and follow the motor; a motor's status return level is learnt where it matters and honoured
(:meth:`Bus.contact`); :meth:`Bus.read_address` and :meth:`Bus.write_address` reach any address.

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

import contextlib
import errno
import functools
import itertools
import logging
import numbers
import os
import struct
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from types import MappingProxyType
from typing import Any, overload

from . import models as _models
from . import units
from .errors import (
    CommError,
    ConfigError,
    CorruptResponse,
    MotorError,
    NoResponse,
    PacketError,
    PortError,
    did_you_mean,
)
from .models import FAST_READ_FIRMWARE, Model, Register, model, model_by_number, supports
from .packets import BROADCAST_ID, Instruction, Protocol, Status
from .ports import MemoryPort, Port, SerialPort, open_port
from .protocol import protocol as protocol_for
from .protocol1 import Protocol1
from .protocol2 import (
    FACTORY_RESET_ALL,
    FACTORY_RESET_EXCEPT_ID,
    FACTORY_RESET_EXCEPT_ID_BAUD,
    FAST_HEAD,
    HARDWARE_ERRORS,
    MAX_LENGTH,
    PROTOCOL2,
    Protocol2,
    crc16_at,
    fast_status_head,
    fast_status_length,
    match_fast_status,
    read_fast_status,
)
from .wire import baud_matches, byte_time, wire_time

log = logging.getLogger(__name__)

MAX_RETURN_DELAY = 254 * 2e-6
#: Protocol 2.0 broadcast PING: how long the motors wait for the status of an ID before the
#: next ID takes its turn, 3000 us (ROBOTIS's device-side code, Dynamixel2Arduino
#: src/utility/protocol.cpp, DXL_PROCESS_BROAD_PING; the emulator's ``Emulator.ping_slot``).
BROADCAST_PING_SLOT = 0.003
#: What a scan adds to the wire time of a PING, its status and the longest return delay before
#: it PINGs the next ID (:meth:`Bus.ping_window`): a USB adapter hands a request to its UART
#: at the next USB frame (1 ms at full speed), and the host may be woken a little late.
SCAN_MARGIN = 0.002
#: s a motor is given to answer at its new ID or baud rate after the WRITE that set it: it may
#: take a while to store the EEPROM write (the e-Manual states no time), longer than a PING
SETTLE_WINDOW = 0.2
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
    #: the protocol version it answered in (1 or 2)
    protocol: int | None = None

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
        self.regs = [register_of(m, n) for n in self.names]  # ConfigError: unknown name
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

    __slots__ = ("covers_level", "crc_from", "crc_state", "data_at", "goal", "high", "ids",
                 "low", "models", "packer", "proto", "si", "template", "torque")

    def __init__(self, proto: Protocol, ids: tuple[int, ...], models: list[Model],
                 reg: Register, covers_level: bool) -> None:
        self.proto, self.ids, self.models = proto, ids, models
        self.covers_level = covers_level
        #: it writes torque_enable (the bus then knows it), or a goal (which may switch
        #: torque on: Drive Mode bit 3 of the X-series, every goal on 1.0)
        self.torque = reg.name == "torque_enable"
        self.goal = reg.name in _TORQUE_GOALS
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


# -- checks before the wire and commissioning ---------------------------------------------------

def register_of(m: Model, name: str) -> Register:
    """``m.register(name)``, or a one-line :class:`ConfigError` that says which names are
    close ("did you mean goal_position?") rather than listing the whole control table."""
    if isinstance(name, str) and m.has(name):
        return m.register(name)
    raise ConfigError(f"{m.name} has no register {name!r}; "
                      f"{did_you_mean(str(name), (r.name for r in m.registers))}")


def _check_type(m: Model, reg: Register, value: object) -> None:
    """A value in SI units is a real number, and a truth value only for an on/off register
    (``True`` is not 1 rad)."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":  # numpy's too
        if reg.unit == "bool":
            return
        unit = units.KINDS.get(reg.unit, "")
        raise ConfigError(f"{m.name} {reg.name}: {value!r} is a truth value, not a number"
                          f"{' in ' + unit if unit else ''}; write {int(bool(value))} if that "
                          "is meant")
    if not isinstance(value, numbers.Real):
        raise ConfigError(f"{m.name} {reg.name}: {value!r} is not a number")


#: Protocol 2.0 registers that bound what a goal may be (e-Manual, X-series: Operating
#: Mode(11), PWM Limit(36), Current Limit(38), Velocity Limit(44), Max/Min Position
#: Limit(48, 52)); all in EEPROM, so they change only by a write, which the bus sees.
_FACTS_2 = ("operating_mode", "pwm_limit", "current_limit", "velocity_limit",
            "max_position_limit", "min_position_limit")
#: Goal registers of 2.0 bounded by a limit register, symmetric (|goal| <= limit).
_GOAL_LIMITS_2 = {"goal_velocity": "velocity_limit", "goal_current": "current_limit",
                  "goal_pwm": "pwm_limit"}
#: Goal registers whose write may switch torque on: every goal on 1.0 (the emulated firmware,
#: as the seeds' programs rely on), on 2.0 with Drive Mode bit 3 (e-Manual, Drive Mode(10)).
_TORQUE_GOALS = frozenset({"goal_position", "moving_speed", "goal_velocity", "goal_current",
                           "goal_pwm"})
#: Position Control Mode, the one operating mode whose goal position the Min/Max Position
#: Limit bound (e-Manual, X-series Goal Position(116): Extended Position and
#: Current-based Position Control Mode count turns, -1 048 575..1 048 575).
_POSITION_MODE = 3
#: Rates a port is set to for a motor's baud rate register: the one within UART tolerance
#: (an RX-28's 57142 bps is spoken to at 57600, as the Dynamixel Wizard does), else the
#: motor's own.
_COMMON_RATES = (9_600, 19_200, 38_400, 57_600, 115_200, 200_000, 230_400, 250_000,
                 400_000, 460_800, 500_000, 921_600, 1_000_000, 2_000_000, 2_250_000,
                 2_500_000, 3_000_000, 4_000_000, 4_500_000)


def line_rate(bps: int) -> int:
    """The rate a port speaks to a motor at ``bps``: the common rate within UART tolerance
    (:data:`.wire.BAUD_TOLERANCE`), else ``bps`` itself."""
    best = min(_COMMON_RATES, key=lambda r: abs(r - bps))
    return best if baud_matches(best, bps) else int(bps)


def usable_rates(m: Model) -> list[int]:
    """The common baud rates (:data:`_COMMON_RATES`) model ``m`` can be set to, by its
    e-Manual table (:meth:`.Model.baud_register_for`, within UART tolerance)."""
    usable = []
    for rate in _COMMON_RATES:
        try:
            m.baud_register_for(rate)
        except ConfigError:
            continue
        usable.append(rate)
    return usable


def raw_access_limits(proto: Protocol) -> tuple[int, int, int]:
    """(address space, longest READ, longest WRITE) in bytes for raw access in ``proto``.

    Protocol 1.0: addresses and lengths are one byte, and a packet holds at most 253
    parameters (LENGTH is one byte, parameters + 2), a WRITE's address among them. Protocol
    2.0: two-byte fields, and a packet's LENGTH (instruction, parameters, CRC; a status's
    error byte among its parameters) at most :data:`.protocol2.MAX_LENGTH`, as the ROBOTIS
    SDK's buffers bound it."""
    if proto.version == 1:
        return 256, 253, 252
    return 1 << 16, MAX_LENGTH - 4, MAX_LENGTH - 5


@dataclass(frozen=True)
class _ModelFacts:
    """What the checks need to know of a model, worked out once (a control table has some
    170 registers; a write must not walk them)."""

    #: where the last EEPROM register ends: a write from there on touches RAM only
    eeprom_end: int
    #: 2.0: the registers of _FACTS_2 it has, and their span (start, end)
    facts: tuple[str, ...]
    facts_span: tuple[int, int]
    #: registers whose value is bounded by the motor's mode or limits
    goals: frozenset[str]
    #: torque_enable's address (-1: none), and the span of the goals that may switch it on
    torque: int
    goal_span: tuple[int, int]


_MODEL_FACTS: dict[int, tuple[Model, _ModelFacts]] = {}


def _facts_of(m: Model) -> _ModelFacts:
    entry = _MODEL_FACTS.get(id(m))
    if entry is not None and entry[0] is m:
        return entry[1]
    eeprom = [r.address + r.size for r in m.registers if r.area == "EEPROM"]
    goals: set[str] = set()
    facts: tuple[str, ...] = ()
    span = (0, 0)
    if m.protocol == 1 and m.has(_ANGLE_LIMITS[0]) and m.has(_ANGLE_LIMITS[1]):
        goals = {n for n in ("goal_position", "moving_speed") if m.has(n)}
    elif m.protocol == 2:
        facts = tuple(n for n in _FACTS_2 if m.has(n))
        if facts:
            regs = [m.register(n) for n in facts]
            span = (min(r.address for r in regs), max(r.address + r.size for r in regs))
        if m.has("operating_mode"):
            goals.add("operating_mode")
        if m.has("goal_position") and m.has("min_position_limit") \
                and m.has("max_position_limit") and m.has("operating_mode"):
            goals.add("goal_position")
        goals |= {g for g, limit in _GOAL_LIMITS_2.items() if m.has(g) and m.has(limit)}
    torque = m.register("torque_enable").address if m.has("torque_enable") else -1
    moving = [m.register(n) for n in _TORQUE_GOALS if m.has(n)]
    goal_span = ((min(r.address for r in moving), max(r.address + r.size for r in moving))
                 if moving else (0, 0))
    info = _ModelFacts(max(eeprom, default=0), facts, span, frozenset(goals), torque,
                       goal_span)
    _MODEL_FACTS[id(m)] = (m, info)
    return info


def _eeprom_registers(m: Model, start: int, end: int) -> list[Register]:
    """The EEPROM registers a write of ``start..end`` (end excluded) touches."""
    if start >= _facts_of(m).eeprom_end:
        return []
    return [r for r in m.registers
            if r.area == "EEPROM" and start < r.address + r.size and r.address < end]


def _near(m: Model, names: list[str], limit: int = 64) -> list[str] | None:
    """``names`` when one READ of their span costs at most ``limit`` bytes, else None."""
    if not all(m.has(n) for n in names):
        return None
    return names if m.span(names)[1] <= limit else None


def _eeprom_hint(m: Model, eeprom: Sequence[Register], exc: MotorError) -> str | None:
    """What to do when a write to EEPROM registers ``eeprom`` was refused: a 2.0 motor's
    "access" error is its torque (locked EEPROM, e-Manual Torque Enable), a 1.0 motor's
    "range" error to a value in range its Lock (e-Manual, Lock: "If Lock is set to 1, the
    power must be turned off and then turned on again")."""
    if m.protocol == 2 and "access" in exc.errors:
        return (f"{eeprom[0].name} is in EEPROM, which the motor locks while its torque is "
                "on: switch torque off first (torque_enable 0)")
    if m.protocol == 1 and "range" in exc.errors and m.has("lock"):
        return ("its EEPROM is locked if lock is 1, until it is powered off and on again "
                "(e-Manual, Lock)")
    return None


def _hinted(m: Model, eeprom: Sequence[Register], exc: MotorError) -> MotorError:
    """``exc`` with what to do, where :func:`_eeprom_hint` knows it."""
    hint = _eeprom_hint(m, eeprom, exc)
    if hint is None or exc.hint:
        return exc
    return MotorError(exc.motor_id, exc.instruction, exc.errors, exc.raw, hint)


def _refuse_commissioning(names: Iterable[str], how: str) -> None:
    """id and baud_rate go alone, through change_id / change_baud, which check and follow."""
    moved = [n for n in names if n in ("id", "baud_rate")]
    if moved:
        raise ConfigError(f"{how} of {' and '.join(moved)} with other registers or motors: "
                          "change an ID with bus.change_id (servolab id) and a baud rate with "
                          "bus.change_baud (servolab baud), one motor at a time, so that the "
                          "bus checks the ID is free and follows the motor")


def _motors(ids: Sequence[int]) -> str:
    """`` (motors 1, 2)``, `` (motor 3)``, or nothing for no ID."""
    if not ids:
        return ""
    return f" (motor{'s' if len(ids) > 1 else ''} {', '.join(map(str, ids))})"


def _model_block(m: Model, values: Mapping[str, Value], raw: bool) -> tuple[int, bytes]:
    """The block a write of ``values`` (name -> value) puts in model ``m``'s table, and its
    start, checked as far as the table alone can check it (no motor is asked): names, one
    block of adjacent registers, writable, type and range (an SI value as in joint or
    position mode), an operating mode the model has."""
    regs = sorted((register_of(m, n) for n in values), key=lambda r: r.address)
    for a, b in itertools.pairwise(regs):
        if a.address + a.size != b.address:
            raise ConfigError(f"{m.name}: {a.name} and {b.name} are not adjacent; write "
                              "them separately")
    block = b""
    for reg in regs:
        value = values[reg.name]
        if raw:
            raw_value = _checked_raw(m, reg, value)
        else:
            _writable(m, reg)
            _check_type(m, reg, value)
            raw_value = units.from_si(m, reg, value)
        allowed = _allowed_modes(m) if reg.name == "operating_mode" else None
        if allowed is not None and raw_value not in allowed:
            raise ConfigError(f"{m.name} operating_mode: {raw_value} is not one of its modes: "
                              f"{', '.join(map(str, allowed))}")
        block += reg.encode(raw_value)
    return regs[0].address, block


def _writable(m: Model, reg: Register) -> None:
    if not reg.writable:
        raise ConfigError(f"{m.name} {reg.name} is read-only")


def _checked_raw(m: Model, reg: Register, value: Value) -> int:
    """``value`` as a raw value of ``reg`` to write: writable, an integer (``True`` is not
    one), within the register's range."""
    _writable(m, reg)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not float(value).is_integer():
        raise ConfigError(f"{m.name} {reg.name}: raw value {value!r} is not an integer")
    raw_value = int(value)
    reg.check(raw_value, m)
    return raw_value


def _allowed_modes(m: Model) -> tuple[int, ...] | None:
    modes: Mapping[str, tuple[int, ...]] = getattr(_models, "ALLOWED_MODES", {})
    return modes.get(m.name)


def _permission_hint(url: str, exc: BaseException) -> str | None:
    """What to do when opening ``url`` failed for want of permission (EACCES, EPERM): on
    Linux a serial device belongs to the group dialout (uucp on Arch), which a user must
    join; None for any other failure."""
    seen: set[int] = set()
    chain: list[BaseException | None] = [exc]
    denied = False
    while chain:
        error = chain.pop()
        if error is None or id(error) in seen:
            continue
        seen.add(id(error))
        if isinstance(error, OSError) and error.errno in (errno.EACCES, errno.EPERM):
            denied = True
            break
        if "[Errno 13]" in str(error) or "Permission denied" in str(error):
            denied = True
            break
        chain += [error.__cause__, error.__context__]
    if not denied or os.name != "posix":
        return None
    group = "dialout"
    try:
        import grp

        if grp.getgrgid(os.stat(url).st_gid).gr_name == "uucp":
            group = "uucp"
    except (ImportError, OSError, KeyError):
        pass
    return (f"you may not open {url}: join the {group} group (sudo usermod -aG {group} "
            "$USER), then log out and in again")


@dataclass(frozen=True)
class Contact:
    """What :meth:`Bus.contact` learnt of a motor: how it answers."""

    id: int
    model: Model
    #: 0: PING only, 1: PING and READ, 2: every instruction (e-Manual, Status Return Level)
    status_return_level: int
    #: seconds it waits before a status (Return Delay Time, 2 us a unit); None if unread
    return_delay: float | None


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
        #: (thread, protocol): the thread holding the bus speaks that protocol meanwhile
        #: (:meth:`_speaking`); other threads see :attr:`protocol` all along
        self._speaking_as: tuple[int, Protocol] | None = None
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
        #: motors seen to answer a WRITE (status return level 2, though not in ``_srl``)
        self._answered: set[int] = set()
        #: each motor's Return Delay Time (s) as read (:meth:`contact`)
        self._delay: dict[int, float] = {}
        #: (2.0) each motor's mode and limits (_FACTS_2), raw, as read or written
        self._facts: dict[int, dict[str, int]] = {}
        #: each motor's torque_enable as this bus last wrote or read it, until a goal (which
        #: may switch it on) is written
        self._torque: dict[int, int] = {}

    # -- construction ----------------------------------------------------------------------------
    @classmethod
    def open(cls, url: str, *, protocol: int | None = None, baudrate: int | None = None,
             retries: int = 2, timeout: float | None = None, **port_options: Any) -> Bus:
        """A bus on a port named by ``url``: a serial device (``/dev/ttyUSB0``, ``COM3``, the
        pty ``servolab sim`` printed; ``baudrate`` default 57600) or emulated motors
        (``emu://rx28:11-16``, in a simulation of their own unless ``simulation=`` names one;
        see :mod:`servolab.sim.emulated` for which baud rate they run at). ``protocol`` None:
        the emulated models', or 2 on a serial port. ``port_options`` go to
        :func:`~.ports.open_port`.

        A port the user may not open (EACCES: on Linux, not in the group ``dialout``) says
        how to join the group, in the one line of its error."""
        try:
            port = open_port(url, baudrate, **port_options)
        except (ConfigError, PortError) as exc:
            hint = _permission_hint(url, exc)
            if hint is None:
                raise
            kind = type(exc) if type(exc) in (ConfigError, PortError) else ConfigError
            raise kind(f"{exc}; {hint}") from exc
        return cls(port, protocol, retries, timeout)

    @property
    def proto(self) -> Protocol:
        """The protocol object (``protocol`` as given may be a version number); to the
        thread that holds the bus to speak another one for a while (a scan of both protocols,
        a :class:`MixedBus`), that one."""
        speaking = self._speaking_as
        if speaking is not None and speaking[0] == threading.get_ident():
            return speaking[1]
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
        attempts = 1 + (self.retries if retries is None else retries)
        with self._lock:
            # How long after sending the answers can take at most: the wire time of the bytes
            # both ways, each answer's longest return delay (254 x 2 us), twice the adapter's
            # latency, and 2 ms. The timeout unless one is set; the late-answer window always.
            # Under the lock: another thread's scan may have the port at another rate.
            longest = ((len(data) + total) * 10.0 / port.baudrate + replies.delays
                       + 2 * port.latency + 0.002)
            timeout = longest if self.timeout is None else self.timeout
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
        return self._identify(motor_id, status, retries=retries)

    def _identify(self, motor_id: int, status: Status, *, retries: int | None = None,
                  keep: bool = True) -> PingResult:
        """The motor that answered a PING with ``status``, at the bus's protocol and rate.
        A 2.0 PING's status carries the model number and firmware; a 1.0 one carries
        nothing, so they are READ (addresses 0-2), and in the same READ the angle limits
        (6-9), which tell joint from wheel mode. A 1.0 motor at status return level 0
        answers PING but not READ: it is found, model unknown. ``keep``: the bus keeps the
        model (and 1.0 angle limits) in :attr:`motors`."""
        proto = self.proto
        if keep:
            self._limits.pop(motor_id, None)   # perhaps another motor now, or other limits
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
                self._limits[motor_id] = (int.from_bytes(read.params[6:8], "little"),
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
        return self._broadcast_ping(wanted, keep=True)

    def _broadcast_ping(self, wanted: set[int] | None, *, keep: bool) -> list[PingResult]:
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
            self._send(data)
            while (remaining := deadline - clock.now()) > 0:
                chunk = self.port.read(4096, remaining)
                self.stats.bytes_in += len(chunk)
                if not chunk and not clock.virtual:
                    clock.sleep(min(remaining, 0.001))  # an in-process port returns at once
                for frame in parser.feed(chunk):
                    try:
                        status = proto.as_status(frame)
                    except ValueError:
                        self.stats.stale += 1
                        continue
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
        plan = self._scan_plan(ids, baudrates, protocols, broadcast)
        original, own = self.baudrate, self.proto.version
        found: list[PingResult] = []
        # Hold the bus for the whole scan: another thread's transaction must never go out
        # at one of the scan's baud rates or protocols.
        with self._lock:
            try:
                if self._quiet_until is not None:
                    self._settle()
                for rate, version, by_broadcast, id_list in plan:
                    if self.port.baudrate != rate:
                        self.port.set_baudrate(rate)
                    self._speak(version)
                    keep = self._keeps(version, own)
                    if by_broadcast:
                        if progress:
                            progress(rate, BROADCAST_ID)
                        found += self._broadcast_ping(
                            None if id_list is None else set(id_list), keep=keep)
                        continue
                    answered = self._ping_each(id_list or (), progress)
                    found += [self._identify(i, answered[i], retries=0, keep=keep)
                              for i in sorted(answered)]
            finally:
                self._speak(None)
                if self.port.baudrate != original:
                    self.port.set_baudrate(original)
        return found

    def _speak(self, version: int | None) -> None:
        """Speak protocol ``version`` from this thread (None: the bus's own again); only
        while holding the bus."""
        self._speaking_as = (None if version is None
                             else (threading.get_ident(), protocol_for(version)))

    @contextlib.contextmanager
    def _speaking(self, version: int) -> Iterator[None]:
        """Hold the bus and speak protocol ``version`` until the block ends."""
        with self._lock:
            before = self._speaking_as
            self._speak(version)
            try:
                yield
            finally:
                self._speaking_as = before

    def _keeps(self, version: int, own: int) -> bool:
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
        plan = self._scan_plan(ids, baudrates, protocols, broadcast)
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

    def _scan_plan(self, ids: Iterable[int] | None, baudrates: Iterable[int] | None,
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
            for frame in parser.feed(chunk):
                try:
                    status = proto.as_status(frame)
                except ValueError:
                    stats.stale += 1
                    continue
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
                self._note_level(motor_id, 0)
                raise ConfigError(f"motor {motor_id} answers PING but not READ (status return "
                                  "level 0), so its model cannot be read: declare it "
                                  "(bus.declare(id, model); --model on the command line)")
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
            self._facts.pop(motor_id, None)
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
        reg = register_of(m, name)
        return units.to_si(m, reg, int(raw), wheel=self._wheel_si(motor_id, m, reg))

    def from_si(self, motor_id: int, name: str, value: float) -> int:
        """The raw value :meth:`write` sends for ``value`` (SI units) in register ``name`` of
        ``motor_id``; :class:`ConfigError` when it is out of range."""
        m = self.model_of(motor_id)
        reg = register_of(m, name)
        _check_type(m, reg, value)
        return units.from_si(m, reg, value, wheel=self._wheel_si(motor_id, m, reg))

    def _encode(self, motor_id: int, m: Model, reg: Register, value: Value, raw: bool
                ) -> bytes:
        raw_value = self._raw_value(motor_id, m, reg, value, raw)
        if reg.name in _facts_of(m).goals:
            self._check_goal(motor_id, m, reg, raw_value)
        return reg.encode(raw_value)

    def _raw_value(self, motor_id: int, m: Model, reg: Register, value: Value, raw: bool
                   ) -> int:
        """The raw value of ``value`` for ``reg``, checked: writable, a number of the right
        type (``True`` is no angle) in the register's range."""
        if raw:
            return _checked_raw(m, reg, value)
        _writable(m, reg)
        kind = type(value)
        if kind is not float and kind is not int:
            _check_type(m, reg, value)
        return units.from_si(m, reg, value, wheel=self._wheel_si(motor_id, m, reg))

    # -- what the motor's mode and limits allow --------------------------------------------------
    def _goal_bounds(self, motor_id: int, m: Model, reg: Register
                     ) -> tuple[int, int, bool] | None:
        """The raw values of ``reg`` (a goal: :attr:`_ModelFacts.goals`) that ``motor_id``
        takes as far as the bus knows its mode and limits: (low, high, known). Where it does
        not know them (``known`` False), the values that every setting of them allows (the
        factory limits, or the hull of what the limit registers can hold): a value outside
        is then worth a READ of them before it is refused. None: no bound but the
        register's own range (operating_mode's is a set, see :meth:`_check_goal`)."""
        name = reg.name
        if m.protocol == 1:
            limits = self._limits.get(motor_id)
            top = m.register(_ANGLE_LIMITS[1]).raw_max
            if name == "moving_speed":
                # joint and multi-turn mode: 0..1023, no direction bit (e-Manual, Moving Speed)
                if limits is None:
                    return 0, 0x3FF, False
                return None if limits == (0, 0) else (0, 0x3FF, True)
            if limits is None:
                return 0, top, False
            cw, ccw = limits
            if cw == ccw == 0 or (m.has("multi_turn_offset") and cw == ccw == top):
                return None     # wheel mode (goal ignored), multi-turn (its own range)
            return cw, ccw, True
        facts = self._facts.get(motor_id)
        if name == "goal_position":
            if facts is None:
                return (m.register("min_position_limit").raw_min,
                        m.register("max_position_limit").raw_max, False)
            if facts.get("operating_mode") != _POSITION_MODE:
                return None
            return facts["min_position_limit"], facts["max_position_limit"], True
        limit_name = _GOAL_LIMITS_2.get(name)
        if limit_name is None:
            return None
        if facts is None or limit_name not in facts:
            default = m.register(limit_name).default
            return None if default is None else (-default, default, False)
        return -facts[limit_name], facts[limit_name], True

    def _check_goal(self, motor_id: int, m: Model, reg: Register, raw: int) -> None:
        """Refuse, before it is sent, a value the motor would refuse in its mode or beyond
        its limits (an "angle limit" or "range" error on 1.0, "data limit" on 2.0): where the
        bus does not know them and the value is outside what every setting allows, it reads
        them once first (:meth:`_learn_goal_facts`)."""
        if reg.name == "operating_mode":
            allowed = _allowed_modes(m)
            if allowed is not None and raw not in allowed:
                names = {v: k for k, v in _models.OPERATING_MODES.items()}
                listed = ", ".join(f"{v} ({names.get(v, '?')})" for v in allowed)
                raise ConfigError(f"{m.name} operating_mode: {raw} is not one of its modes: "
                                  f"{listed}")
            return
        bounds = self._goal_bounds(motor_id, m, reg)
        if bounds is None or bounds[0] <= raw <= bounds[1]:
            return
        if not bounds[2]:
            self._learn_goal_facts(motor_id, m)
            bounds = self._goal_bounds(motor_id, m, reg)
            if bounds is None or bounds[0] <= raw <= bounds[1] or not bounds[2]:
                return   # allowed after all, or the motor answers no READ (level 0)
        raise ConfigError(self._goal_refusal(motor_id, m, reg, raw, bounds[0], bounds[1]))

    def _goal_refusal(self, motor_id: int, m: Model, reg: Register, raw: int, low: int,
                      high: int) -> str:
        """The one line that says why ``raw`` is refused, in SI units and raw."""
        def si(value: int) -> str:
            try:
                converted = units.to_si(m, reg, value)
            except ConfigError:
                return str(value)
            unit = units.KINDS.get(reg.unit, "")
            text = f"{converted:.4g}" if isinstance(converted, float) else str(converted)
            return text + (f" {unit}" if unit else "")

        head = f"motor {motor_id} ({m.name}) {reg.name}: {si(raw)} (raw {raw})"
        if m.protocol == 1 and reg.name == "moving_speed":
            cw, ccw = self._limits.get(motor_id, (0, 0))
            return (f"{head} has bit 10 set, a direction, which only wheel mode has; in "
                    f"joint mode (angle limits {cw}..{ccw}) moving_speed is 0..1023, 0 to "
                    f"{si(0x3FF)} (0: as fast as it goes): write a speed of 0 or more, or set "
                    "wheel mode first (cw_angle_limit = ccw_angle_limit = 0)")
        if m.protocol == 1:
            return (f"{head} is outside its angle limits cw_angle_limit..ccw_angle_limit = "
                    f"{si(low)}..{si(high)} (raw {low}..{high}): the motor would refuse it "
                    "(angle limit error); widen the limits first")
        if reg.name == "goal_position":
            return (f"{head} is outside its position limits min_position_limit.."
                    f"max_position_limit = {si(low)}..{si(high)} (raw {low}..{high}) in "
                    f"position control mode (operating_mode {_POSITION_MODE}): the motor would "
                    "refuse it (data limit); extended position mode (operating_mode 4) turns "
                    "further")
        limit = _GOAL_LIMITS_2[reg.name]
        return (f"{head} is beyond its {limit} {si(high)} (raw {high}): the motor would refuse "
                f"it (data limit); raise {limit} first (torque off)")

    def _learn_goal_facts(self, motor_id: int, m: Model) -> None:
        """Read what bounds ``motor_id``'s goals: (1.0) its angle limits, hence its mode;
        (2.0) its operating mode and limits. Nothing at status return level 0 (no READ is
        answered)."""
        if m.protocol == 1:
            got = self._read_or_none(motor_id, list(_ANGLE_LIMITS))
            if got is not None:
                self._limits[motor_id] = (got[_ANGLE_LIMITS[0]], got[_ANGLE_LIMITS[1]])
        else:
            names = _facts_of(m).facts
            got = self._read_or_none(motor_id, list(names)) if names else None
            if got is not None:
                self._facts[motor_id] = dict(got)
        self._plans.clear()  # sync_write plans bound their values by what the bus knows

    def _read_or_none(self, motor_id: int, names: list[str]) -> dict[str, int] | None:
        """Raw values of ``names``, or None when the motor answers no READ (status return
        level 0, known or found now by a PING it answers)."""
        if self._srl.get(motor_id) == 0:
            return None
        try:
            got = self.read(motor_id, names, raw=True)
        except CommError:
            if motor_id in self._srl or motor_id in self._answered \
                    or not self._answers(motor_id, 0):
                raise
            self._note_level(motor_id, 0)
            log.info("motor %d answers PING but not READ: status return level 0", motor_id)
            return None
        return {name: int(value) for name, value in got.items()}

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
        the angle limits it wrote, or reads them once (:meth:`wheel_mode`).

        Checked before anything is sent: the register names ("did you mean"), each value's
        type and range, what the motor's mode and limits allow (goal_position within the
        angle or position limits, moving_speed's direction only in wheel mode, goal_velocity
        within velocity_limit, ...: the bus reads them once where a value needs it), and,
        for an EEPROM register of a 2.0 motor, that its torque is off (it locks the EEPROM
        while torque is on: the bus reads torque_enable first).

        ``id`` and ``baud_rate`` go through :meth:`change_id` and :meth:`change_baud`: a used
        ID is refused, and the bus follows the motor to its new ID or rate.

        A motor whose status return level the bus does not know is taken to be at 2 (the
        factory level), and where its first WRITE gets no status the bus reads the level
        (or, when no READ is answered either, PINGs: level 0) and honours it from then on:
        a write to a motor at level 1 or 0 expects no status.

        Every motor at once (the broadcast ID, 254): :meth:`broadcast_write`."""
        if motor_id == self.proto.broadcast_id:
            raise ConfigError(f"motor ID {motor_id} is the broadcast ID: broadcast_write() "
                              "writes every motor at once, checked against each one's table")
        if name == "id" or name == "baud_rate":
            assert isinstance(name, str)
            if value is None:
                raise ConfigError(f"motor {motor_id}: write needs a value for {name!r}")
            self._commission(motor_id, name, value, raw=raw, registered=registered)
            return
        m = self.model_of(motor_id)
        given: dict[str, Value | None] = dict(name) if isinstance(name, Mapping) else {name: value}
        values = {n: v for n, v in given.items() if v is not None}
        if len(values) != len(given):
            raise ConfigError(f"motor {motor_id}: write needs a value for {name!r}")
        if len(values) > 1:
            _refuse_commissioning(values, "write")
        start, block = self._block(motor_id, m, values, raw)
        self._write_checked(motor_id, m, start, block, registered=registered)

    # -- every motor at once -----------------------------------------------------------------
    def broadcast_write(self, name: str | Mapping[str, Value], value: Value | None = None, *,
                        raw: bool = False, models: Iterable[str | Model] | None = None
                        ) -> list[int]:
        """WRITE one register (or several adjacent ones, as :meth:`write` takes them) of every
        motor at once: one instruction to the broadcast ID (254), which no motor answers
        ("Broadcast ID ... no Status Packet is returned", e-Manual, Protocol 1.0 and 2.0,
        Packet ID), so none is waited for.

        The motors may be of several models, each with its own control table, and the one
        packet carries one address and one set of bytes. So the write is checked, before
        anything is sent, against the table of every motor the bus knows in its protocol
        (found by :meth:`scan` or :meth:`ping`, or declared), as a write to each of them would
        be (register name, writable, type and range, what its mode and limits allow, and for
        an EEPROM register of a 2.0 motor, torque off), and it must come to the same address
        and bytes for all of them: goal_position 0.5 rad is raw 610 on an RX-28 and 2389 on
        an MX-28, which no single packet can say. ``models`` checks against those models'
        tables instead (motors the bus has not met; then no mode or limit, which only a
        motor can tell, is checked, and an EEPROM register is refused). A bus that knows no
        motor, given no ``models``, refuses: scan first. ``id`` (every motor would take the
        same) and ``baud_rate`` (each motor is to be followed: :meth:`change_baud`) are
        refused.

        Returns the IDs of the known motors it was checked for (``[]`` with ``models``); the
        bus learns from it for each of them what :meth:`write` learns (a status return
        level, angle limits, torque)."""
        with self._lock:
            return self._send_broadcast(self._broadcast_plan(name, value, raw, models))

    def _broadcast_plan(self, name: str | Mapping[str, Value], value: Value | None, raw: bool,
                        models: Iterable[str | Model] | None
                        ) -> list[tuple[int | None, Model, int, bytes]]:
        """:meth:`broadcast_write` checked, nothing sent: (ID or None, model, start, block) of
        each table it was checked against, all with the same start and block."""
        proto = self.proto
        given: dict[str, Value | None] = (dict(name) if isinstance(name, Mapping)
                                           else {name: value})
        values = {n: v for n, v in given.items() if v is not None}
        if not values or len(values) != len(given):
            raise ConfigError(f"broadcast write needs a value for {name!r}")
        for special in ("id", "baud_rate"):
            if special in values:
                raise ConfigError(
                    "a broadcast write of id would give every motor the same ID; change IDs "
                    "one motor at a time (change_id, servolab id)" if special == "id" else
                    "a broadcast write of baud_rate would leave the bus unable to follow "
                    "each motor; change baud rates with change_baud (servolab baud)")
        if models is not None:
            known: list[tuple[int | None, Model]] = [
                (None, m if isinstance(m, Model) else model(m)) for m in models]
            for _, m in known:
                if m.protocol != proto.version:
                    raise ConfigError(f"{m.name} speaks protocol {m.protocol}.0, this bus "
                                      f"{proto.version}.0")
        else:
            known = [(i, m) for i, m in sorted(self.motors.items())
                     if m.protocol == proto.version]
        if not known:
            raise ConfigError("broadcast write: the bus knows no motor to check the write "
                              "against (each model has its own table, and no motor answers a "
                              "broadcast to say it refused); scan() first, declare the "
                              "motors, or name their models; nothing was written")
        with self._lock:
            blocks: list[tuple[int | None, Model, int, bytes]] = []
            for motor_id, m in known:
                if motor_id is None:
                    start, block = _model_block(m, values, raw)
                else:
                    start, block = self._block(motor_id, m, values, raw)
                blocks.append((motor_id, m, start, block))
            _, _, start, block = blocks[0]
            if any((s, b) != (start, block) for _, _, s, b in blocks):
                kinds: dict[tuple[str, int, bytes], list[int]] = {}
                for i, m, s, b in blocks:
                    kinds.setdefault((m.name, s, b), []).extend(() if i is None else (i,))
                raise ConfigError(
                    f"broadcast write of {', '.join(values)}: the motors' tables disagree ("
                    + "; ".join(f"{name}{_motors(ids)}: address {s}, bytes {b.hex(' ')}"
                                for (name, s, b), ids in kinds.items())
                    + "): one packet carries one address and one value; write them one by "
                    "one or with sync_write; nothing was written")
            for motor_id, m, _, _ in blocks:
                eeprom = (_eeprom_registers(m, start, start + len(block))
                          if start < _facts_of(m).eeprom_end else [])
                if not eeprom:
                    continue
                if motor_id is None:
                    raise ConfigError(f"{m.name}: {eeprom[0].name} is in EEPROM: a broadcast "
                                      "to motors the bus has not met cannot check that their "
                                      "torque is off; scan() first; nothing was written")
                self._guard_eeprom(motor_id, m, eeprom)
        return blocks

    def _send_broadcast(self, blocks: list[tuple[int | None, Model, int, bytes]]) -> list[int]:
        """Send the WRITE :meth:`_broadcast_plan` checked, and learn from it."""
        proto = self.proto
        _, _, start, block = blocks[0]
        self.transact(proto.write(proto.broadcast_id, start, block))
        ids = [i for i, _, _, _ in blocks if i is not None]
        for motor_id, m, _, _ in blocks:
            if motor_id is not None:
                self._learn(motor_id, m, start, block)
        return ids

    def _write_checked(self, motor_id: int, m: Model, start: int, block: bytes, *,
                       registered: bool = False) -> None:
        """WRITE (or REG_WRITE) ``block`` at ``start`` to one motor, its values checked
        already: an EEPROM block only with torque off (2.0), the status awaited by the
        motor's status return level, and what the write sets learnt."""
        end = start + len(block)
        eeprom = _eeprom_registers(m, start, end) if start < _facts_of(m).eeprom_end else []
        if eeprom:
            self._guard_eeprom(motor_id, m, eeprom)
        inst = self.proto.write(motor_id, start, block, registered=registered)
        try:
            self._send_write(motor_id, m, inst,
                             self._level_after(motor_id, m, start, block,
                                               registered=registered),
                             self._level_known(motor_id, m, start, block, registered))
        except MotorError as exc:
            if not eeprom:
                raise
            raise _hinted(m, eeprom, exc) from None
        if registered:  # the motor keeps one REG_WRITE, the last, until ACTION
            self._registered[motor_id] = (start, block)
        else:
            self._learn(motor_id, m, start, block)

    def _send_write(self, motor_id: int, m: Model, inst: Instruction, level: int,
                    known: bool) -> None:
        """Send a WRITE-like instruction to one motor and take its status by the motor's
        status return level: none below 2; at 2 (known, or taken for the factory level) the
        status, retried as usual. Where the level is not known and no status comes, the bus
        finds the level out (:meth:`_probe_level`) before it retries: a motor at level 1 or
        0 heard the WRITE and rightly stayed silent."""
        if level < 2:
            self.transact(inst)
            return
        expect = {motor_id: 0}
        if known:
            self.transact(inst, expect)
            return
        try:
            self.transact(inst, expect, retries=0)
        except CommError:
            found = self._probe_level(motor_id, m)
            if found is not None and found < 2:
                return
            if self.retries == 0:
                raise
            self.transact(inst, expect, retries=self.retries - 1)
        self._answered.add(motor_id)

    def _level_known(self, motor_id: int, m: Model, start: int, block: bytes,
                     registered: bool) -> bool:
        """Whether the bus knows the status return level ``motor_id`` answers this write by
        (told, learnt, seen, or written by this very block)."""
        if motor_id in self._srl or motor_id in self._answered \
                or not m.has("status_return_level"):
            return True
        reg = m.register("status_return_level")
        return not registered and start <= reg.address < start + len(block)

    def _probe_level(self, motor_id: int, m: Model) -> int | None:
        """Find ``motor_id``'s status return level out: READ it (and the return delay, when
        near it), else PING (a motor that answers PING and not READ is at level 0). None when
        nothing answers. The bus keeps what it found."""
        names = ["status_return_level"]
        if m.has("return_delay_time"):
            names = _near(m, ["return_delay_time", "status_return_level"]) or names
        start, length = m.span(names)
        try:
            status = self.transact(self.proto.read(motor_id, start, length),
                                   {motor_id: length}, check=False)[motor_id]
        except CommError:
            if not self._answers(motor_id, 0):
                return None
            self._note_level(motor_id, 0)
            log.info("motor %d answers PING only: status return level 0 (the bus sends it "
                     "no READ and awaits no status but PING's)", motor_id)
            return 0
        if self.proto.failed(status.error) or len(status.params) != length:
            return None
        values = {n: m.register(n).decode(status.params[m.register(n).address - start:])
                  for n in names}
        if "return_delay_time" in values:
            self._delay[motor_id] = values["return_delay_time"] * 2e-6
        level = values["status_return_level"]
        self._note_level(motor_id, level)
        if level < 2:
            log.info("motor %d is at status return level %d: the bus awaits no status to "
                     "its writes", motor_id, level)
        return level

    def _note_level(self, motor_id: int, level: int) -> None:
        """Keep a status return level the bus found out (2 as seen, not as told)."""
        if level >= 2:
            self._srl.pop(motor_id, None)
            self._answered.add(motor_id)
        else:
            self._srl[motor_id] = level
            self._answered.discard(motor_id)

    def _answers(self, motor_id: int, retries: int | None = None) -> bool:
        """Whether something answers a PING of ``motor_id`` (nothing learnt from it)."""
        v1 = self.proto.version == 1
        try:
            self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3}, check=False,
                          retries=retries)
        except CommError:
            return False
        return True

    def _guard_eeprom(self, motor_id: int, m: Model, eeprom: Sequence[Register]) -> None:
        """Before a write to EEPROM: a 2.0 motor locks its EEPROM while torque is on (and
        answers "access"; e-Manual, X-series Torque Enable(64): "all Data in the EEPROM Area
        are protected from writing" while it is 1), so the bus reads torque_enable first, and
        refuses in one line. (1.0 motors lock their EEPROM by the Lock register only, which
        a refused write names: :func:`_eeprom_hint`.)"""
        if m.protocol != 2 or not m.has("torque_enable"):
            return
        if self._torque.get(motor_id) == 0:
            return      # this bus switched it off, and wrote no goal since
        names = ["torque_enable"]
        if motor_id not in self._srl and motor_id not in self._answered:
            names = _near(m, ["torque_enable", "status_return_level"], 8) or names
        got = self._read_or_none(motor_id, names)
        if got is None:
            return      # level 0: nothing to read, nothing to learn
        if "status_return_level" in got:
            self._note_level(motor_id, got["status_return_level"])
        self._torque[motor_id] = got["torque_enable"]
        if got["torque_enable"]:
            what = eeprom[0].name
            raise ConfigError(f"motor {motor_id} ({m.name}): {what} is in EEPROM, which the "
                              "motor locks while its torque is on: switch torque off first "
                              "(torque_enable 0)")

    def _block(self, motor_id: int, m: Model, values: Mapping[str, Value], raw: bool
               ) -> tuple[int, bytes]:
        regs = sorted((register_of(m, n) for n in values), key=lambda r: r.address)
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
        info = _facts_of(m)
        if info.torque >= 0 and start <= info.torque < end:
            self._torque[motor_id] = block[info.torque - start]
        elif self._torque and info.goal_span[0] < end and start < info.goal_span[1]:
            self._torque.pop(motor_id, None)    # a goal may have switched it on
        if info.facts and start < info.facts_span[1] and info.facts_span[0] < end:
            facts = self._facts.get(motor_id)
            if facts is not None:
                for name in info.facts:
                    reg = m.register(name)
                    if start <= reg.address and reg.address + reg.size <= end:
                        facts[name] = reg.decode(block[reg.address - start:])
            self._plans.clear()  # sync_write plans bound goals by them
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
        self._plans.clear()  # sync_write plans bound goals by them

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
        :meth:`factory_reset`; and it learns a level below 2 where a motor's first WRITE gets
        no status (it reads the level then, or PINGs: see :meth:`write`) or from
        :meth:`contact`. This is the bus's own dict, not a copy: set an entry to tell
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
                self._answered.discard(i)  # (or what a RAM restore brings back)
            self._torque.pop(i, None)      # off, or on by its Startup Configuration

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
        self._plans.clear()
        for i in [*ids, 1] if moves else ids:
            self._srl.pop(i, None)
            self._registered.pop(i, None)
            self._limits.pop(i, None)
            self._facts.pop(i, None)       # the limits and mode are the factory's again
            self._delay.pop(i, None)
            self._torque.pop(i, None)
            self._answered.discard(i)
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
            if names == "id" or names == "baud_rate":
                _refuse_commissioning([names], "SYNC_WRITE")
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
                    if plan.torque:
                        for motor_id in plan.ids:
                            self._torque[motor_id] = int(values[motor_id])  # type: ignore[arg-type]
                    elif plan.goal and self._torque:
                        for motor_id in plan.ids:
                            self._torque.pop(motor_id, None)
                    return
        wanted = self._names(names)
        _refuse_commissioning(wanted, "SYNC_WRITE")
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
        for motor_id, _ in blocks:
            m = self.motors[motor_id]
            if layout[0] < _facts_of(m).eeprom_end:
                eeprom = _eeprom_registers(m, layout[0], layout[0] + layout[1])
                if eeprom:
                    self._guard_eeprom(motor_id, m, eeprom)
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
                or reg.area == "EEPROM" or (reg.size, reg.signed) not in _STRUCT_CODES):
            # (the angle limits: the checked path learns the motors' mode; EEPROM: it checks
            # that their torque is off)
            return None
        covers = any(m.has("status_return_level")
                     and m.register("status_return_level").address == reg.address
                     for m in models)
        try:
            plan = _SyncWrite(self.proto, ids, models, reg, covers)
        except (struct.error, ValueError):
            return None
        expected = self.proto.encode_instruction(self.proto.sync_write(
            reg.address, reg.size, [(i, bytes(reg.size)) for i in ids]))
        if len(expected) != len(plan.template):
            return None
        for motor_id, m in zip(ids, models, strict=True):
            # what the motors' modes and limits allow, as far as the bus knows them: a value
            # beyond takes the checked path, which reads them or says why it is refused
            bounds = self._goal_bounds(motor_id, m, reg) if name in _facts_of(m).goals \
                else None
            if bounds is not None:
                plan.low, plan.high = max(plan.low, bounds[0]), min(plan.high, bounds[1])
        return plan

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
            _refuse_commissioning(regs, "BULK_WRITE")
            m = self.model_of(motor_id)
            start, block = self._block(motor_id, m, regs, raw)
            blocks.append((motor_id, m, start, block))
        proto = self.proto
        if isinstance(proto, Protocol2) and all(supports(m, "BULK_WRITE") for _, m, _, _ in blocks):
            for motor_id, m, start, block in blocks:
                eeprom = _eeprom_registers(m, start, start + len(block))
                if eeprom:
                    self._guard_eeprom(motor_id, m, eeprom)
            self.transact(proto.bulk_write([(i, start, block) for i, _, start, block in blocks]))
        else:
            for motor_id, m, start, block in blocks:
                self._write_checked(motor_id, m, start, block)
            return
        for motor_id, m, start, block in blocks:
            self._learn(motor_id, m, start, block)

    # -- commissioning: how a motor answers, its ID, its baud rate ---------------------------
    @property
    def return_delay(self) -> Mapping[int, float]:
        """Each motor's Return Delay Time (s) as the bus read it (:meth:`contact`, or the
        first write it got no status to): how long the motor waits before its status. The
        bus's timeouts allow the longest (254 x 2 us) to every motor in any case."""
        return MappingProxyType(self._delay)

    def contact(self, motor_id: int) -> Contact:
        """Learn how ``motor_id`` answers, as on first contact: its status return level
        (e-Manual, Status Return Level: 0 answers PING only, 1 PING and READ, 2 every
        instruction) and its return delay, in one READ (or a PING, where no READ is
        answered: level 0), and what bounds its goals (its mode and limits), in another.
        The bus honours the level from then on: it awaits no status a motor will not send,
        and sends no READ to a motor at level 0. (Without this call the bus learns the same
        when it first needs it: the level at the first WRITE that gets no status, mode and
        limits at the first goal beyond what the factory settings allow.)"""
        m = self.model_of(motor_id)
        with self._lock:
            level = self._probe_level(motor_id, m) if m.has("status_return_level") else 2
            if level is None:
                raise NoResponse(f"motor {motor_id}: no answer to READ or PING at "
                                 f"{self.baudrate} bps (is it powered, at this baud rate and "
                                 "ID?)", motor_id=motor_id, instruction="READ")
            if level and _facts_of(m).goals:
                self._learn_goal_facts(motor_id, m)
        delay = self._delay.get(motor_id)
        if delay is not None and self.timeout is not None and delay >= self.timeout:
            log.warning("motor %d waits %.0f us before each status, longer than this bus's "
                        "timeout (%.0f us): every transaction with it will time out; lower "
                        "its return_delay_time or the timeout", motor_id, delay * 1e6,
                        self.timeout * 1e6)
        return Contact(motor_id, m, level, delay)

    def _who(self, motor_id: int) -> PingResult | None:
        """The motor that answers at ``motor_id`` in either protocol, None when none does;
        something that answers garbled (two motors at one ID) is refused. Both protocols,
        because one wire may carry both (a 1.0 and a 2.0 motor at one ID garble each other
        as two of one protocol do)."""
        other = 1 if self.proto.version == 2 else 2
        for version in (self.proto.version, other):
            if version == other and not 0 <= motor_id <= protocol_for(other).max_id:
                continue
            try:
                with self._speaking(version):
                    return self.ping(motor_id)
            except NoResponse:
                continue
            except CorruptResponse:
                raise ConfigError(f"ID {motor_id}: something answers there, garbled (two "
                                  "motors with that ID?); nothing was written") from None
        return None

    def _settled(self, motor_id: int, window: float = SETTLE_WINDOW) -> bool:
        """Whether ``motor_id`` answers a PING within ``window`` seconds: a motor may take a
        while to store an EEPROM write and take up its new ID or rate, longer than one PING
        waits (the e-Manual states no time), so absence is judged only after the window."""
        clock = self.port.clock
        deadline = clock.now() + window
        while True:
            if self._answers(motor_id, retries=0):
                return True
            if clock.now() >= deadline:
                return False

    def change_id(self, motor_id: int, new_id: int) -> PingResult:
        """Give the motor at ``motor_id`` the ID ``new_id``, and follow it there.

        Refused with nothing written when a motor already answers at ``new_id`` (two motors
        at one ID answer together and garble each other; pypot's ``change_id`` refuses it
        too), and when none answers at ``motor_id``. A 2.0 motor must have its torque off
        (the ID is in EEPROM). The motor sends the WRITE's status from its new ID, as
        ROBOTIS's own device code does (Dynamixel2Arduino, src/utility/slave.cpp,
        ``processInstWrite``: ``txStatusPacket(id_, ...)`` after the write). The bus then
        PINGs the new ID and moves what it knows of the motor there (model, status return
        level, mode and limits, alerts). Returns that PING."""
        proto = self.proto
        proto.check_id(motor_id)
        proto.check_id(new_id)
        with self._lock:
            m = self.model_of(motor_id)
            reg = register_of(m, "id")
            reg.check(new_id, m)
            here = self.ping(motor_id)             # it must answer where it is
            if new_id == motor_id:
                return here
            m = self.motors.get(motor_id, m)
            taken = self._who(new_id)
            if taken is not None:
                raise ConfigError(f"ID {new_id} is taken: motor {new_id} ({taken.model_name}) "
                                  f"answers there at {self.baudrate} bps; nothing was written "
                                  f"to motor {motor_id}. Pick a free ID (servolab scan lists "
                                  "those in use)")
            self._guard_eeprom(motor_id, m, [reg])
            inst = proto.write(motor_id, reg.address, reg.encode(new_id))
            level = self._srl.get(motor_id, 2)
            moved = False
            for _ in range(1 + self.retries):
                try:
                    self.transact(inst, {new_id: 0} if level >= 2 else None, retries=0)
                    moved = level >= 2 or self._settled(new_id)
                except CommError:
                    moved = self._settled(new_id)
                if moved:
                    break
                refusal = self._refusal(inst, motor_id, m, reg)  # from its old ID?
                if refusal is not None:
                    raise refusal
                if self._settled(new_id):
                    moved = True
                    break
                if not self._answers(motor_id):
                    raise NoResponse(f"motor {motor_id}: after a WRITE of id {new_id} it answers "
                                     f"at neither ID {motor_id} nor {new_id} at {self.baudrate} "
                                     "bps; find it with servolab scan", motor_id=motor_id,
                                     instruction="WRITE")
            if not moved:
                self._still_there(motor_id, m, inst, f"id {new_id}")
            self._move(motor_id, new_id)
            return self.ping(new_id)

    def _refusal(self, inst: Instruction, motor_id: int, m: Model,
                 reg: Register) -> MotorError | None:
        """Why a motor still at ``motor_id`` did not take the WRITE ``inst``: the WRITE once
        more, its status awaited from the old ID, where a motor that refuses it answers (a
        locked EEPROM, an access error); None when that status says nothing is wrong or does
        not come (the motor may have moved this time)."""
        try:
            self.transact(inst, {motor_id: 0}, retries=0)
        except MotorError as exc:
            return _hinted(m, [reg], exc)
        except CommError:
            return None
        return None

    def _still_there(self, motor_id: int, m: Model, inst: Instruction, what: str) -> None:
        """A WRITE of ``what`` that left the motor where it was: its own status says why."""
        reg = m.register("id") if what.startswith("id") else m.register("baud_rate")
        try:
            self.transact(inst, {motor_id: 0})
        except MotorError as exc:
            raise _hinted(m, [reg], exc) from None
        except CommError:
            pass
        raise NoResponse(f"motor {motor_id}: the WRITE of {what} did not take: it still "
                         f"answers as before at {self.baudrate} bps", motor_id=motor_id,
                         instruction="WRITE")

    def change_baud(self, motor_id: int, baudrate: int, *, follow: bool = True) -> PingResult:
        """Set the baud rate of ``motor_id`` to ``baudrate`` bps (the register value from the
        model's e-Manual table: :meth:`.Model.baud_register_for`, within UART tolerance, so
        57600 sets an RX-28's 57142), then speak the new rate and PING the motor there.

        The motor answers the WRITE at the old rate and then changes. ``follow`` (the
        default): the bus stays at the new rate, as the motor has; motors it knew that stay
        at the old rate are named in a warning and forgotten. Otherwise the bus goes back to
        its rate and forgets the motor. A 2.0 motor must have its torque off (the baud rate
        is in EEPROM). Returns the PING at the new rate."""
        m = self.model_of(motor_id)
        register_of(m, "baud_rate")
        try:
            value = m.baud_register_for(int(baudrate))
        except ConfigError:
            raise ConfigError(f"{m.name}: {baudrate} bps is not a baud rate it can use; it "
                              f"can use {', '.join(map(str, usable_rates(m)))}") from None
        exact = m.baud_from_register(value)
        rate = int(baudrate) if baud_matches(int(baudrate), exact) else line_rate(exact)
        return self._change_baud(motor_id, m, value, rate, follow=follow)

    def _change_baud(self, motor_id: int, m: Model, value: int, rate: int, *,
                     follow: bool = True) -> PingResult:
        reg = m.register("baud_rate")
        exact = m.baud_from_register(value)
        with self._lock:
            before = self.baudrate
            if not self._answers(motor_id):
                raise NoResponse(f"motor {motor_id}: no answer to PING at {before} bps (is it "
                                 "powered, at this baud rate and ID?)", motor_id=motor_id,
                                 instruction="PING")
            self._guard_eeprom(motor_id, m, [reg])
            inst = self.proto.write(motor_id, reg.address, reg.encode(value))
            level = self._srl.get(motor_id, 2)
            for _ in range(1 + self.retries):
                try:   # answered at the old rate, then the motor changes
                    self.transact(inst, {motor_id: 0} if level >= 2 else None, retries=0)
                except MotorError as exc:
                    raise _hinted(m, [reg], exc) from None
                except CommError:
                    pass  # the status may be lost: where the motor answers tells
                self.port.set_baudrate(rate)
                if self._settled(motor_id):
                    break
                self.port.set_baudrate(before)
                if not self._answers(motor_id):
                    raise NoResponse(f"motor {motor_id}: after a WRITE of baud_rate {value} "
                                     f"({exact} bps) it answers neither at {rate} nor at "
                                     f"{before} bps; find it with servolab scan",
                                     motor_id=motor_id, instruction="WRITE")
            else:
                self._still_there(motor_id, m, inst, f"baud_rate {value}")
            result = self.ping(motor_id)
            if not follow:
                self.port.set_baudrate(before)
                self._forget(motor_id)
                return result
            left = sorted({*self.motors, *self._srl, *self._limits, *self._facts,
                           *self._alerts} - {motor_id})
            if left:
                log.warning("motor(s) %s stay at %d bps; this bus now speaks %d bps and "
                            "forgets them", ", ".join(map(str, left)), before, rate)
                for i in left:
                    self._forget(i)
            return result

    def _commission(self, motor_id: int, name: str, value: Value, *, raw: bool,
                    registered: bool) -> None:
        """A write of ``id`` or ``baud_rate`` by name: through :meth:`change_id` and
        :meth:`change_baud`."""
        if registered:
            raise ConfigError(f"motor {motor_id}: {name} as a REG_WRITE would change at an "
                              "ACTION the bus cannot follow; write it directly")
        m = self.model_of(motor_id)
        reg = register_of(m, name)
        raw_value = self._raw_value(motor_id, m, reg, value, raw)
        if name == "id":
            self.change_id(motor_id, raw_value)
            return
        exact = m.baud_from_register(raw_value)
        asked = float(value)
        rate = int(asked) if not raw and baud_matches(asked, exact) else line_rate(exact)
        self._change_baud(motor_id, m, raw_value, rate)

    def _move(self, old: int, new: int) -> None:
        """What the bus knows of the motor at ``old``, now at ``new``."""
        caches: list[dict[int, Any]] = [self.motors, self._srl, self._alerts, self._limits,
                                        self._registered, self._facts, self._delay,
                                        self._torque]
        for cache in caches:
            if old in cache:
                cache[new] = cache.pop(old)
            else:
                cache.pop(new, None)
        if old in self._answered:
            self._answered.discard(old)
            self._answered.add(new)
        else:
            self._answered.discard(new)
        self._plans.clear()

    def _forget(self, motor_id: int) -> None:
        """Everything the bus knows of ``motor_id`` (no longer on this bus as it speaks)."""
        caches: list[dict[int, Any]] = [self.motors, self._srl, self._alerts, self._limits,
                                        self._registered, self._facts, self._delay,
                                        self._torque]
        for cache in caches:
            cache.pop(motor_id, None)
        self._answered.discard(motor_id)
        self._plans.clear()

    # -- raw access by address ----------------------------------------------------------------
    def _check_span(self, address: int, size: int, *, write: bool) -> None:
        """Refuse an address or a size the protocol cannot carry (:func:`raw_access_limits`)."""
        proto = self.proto
        space, most_read, most_write = raw_access_limits(proto)
        most = most_write if write else most_read
        what = "WRITE" if write else "READ"
        for label, number in (("address", address), ("size", size)):
            if isinstance(number, bool) or not isinstance(number, int):
                raise ConfigError(f"{label} {number!r} is not an integer")
        if not 0 <= address < space:
            raise ConfigError(f"address {address} is outside protocol {proto.version}.0's "
                              f"0..{space - 1}")
        if not 1 <= size <= most:
            raise ConfigError(f"size {size}: one {what} of protocol {proto.version}.0 carries "
                              f"1..{most} bytes")
        if address + size > space:
            raise ConfigError(f"address {address} and {size} bytes run past {space - 1}, the "
                              f"last address of protocol {proto.version}.0")

    def known_model(self, motor_id: int) -> Model | None:
        """The model of ``motor_id`` when servolab has its table (declared, or learnt by a
        PING now), None for a model it does not know (a motor that does not answer raises
        :class:`NoResponse`)."""
        self.proto.check_id(motor_id)
        found = self.motors.get(motor_id)
        if found is None:
            found = self.ping(motor_id).model
        return found

    def read_address(self, motor_id: int, address: int, size: int) -> bytes:
        """``size`` raw bytes of ``motor_id``'s control table from ``address`` (one READ),
        whatever registers are there, or none servolab knows (a model it has no table for).
        The address and size are checked against the protocol first
        (:func:`raw_access_limits`); the motor answers for the rest."""
        self._check_span(address, size, write=False)
        self.proto.check_id(motor_id)
        if 0 in self._srl.values():
            self._check_reads_answered((motor_id,))
        status = self.transact(self.proto.read(motor_id, address, size),
                               {motor_id: size})[motor_id]
        return bytes(status.params)

    def write_address(self, motor_id: int, address: int, data: bytes) -> None:
        """Write raw ``data`` at ``address`` of ``motor_id``'s control table (one WRITE;
        ``motor_id`` may be the broadcast ID).

        Where the bus knows the motor's model, the bytes are checked as a write by name is:
        every register they touch they cover whole, each value writable and in range and
        allowed by the motor's mode and limits, EEPROM with torque off; ``id`` and
        ``baud_rate`` alone go through :meth:`change_id` and :meth:`change_baud`. Bytes where
        servolab's table has no register, and every byte to a model it does not know, go as
        they are: the motor answers for them."""
        data = bytes(data)
        self._check_span(address, len(data), write=True)
        proto = self.proto
        broadcast = motor_id == proto.broadcast_id
        proto.check_id(motor_id, broadcast=True)
        m = None if broadcast else self.known_model(motor_id)
        try:
            inst = proto.write(motor_id, address, data)
            proto.encode_instruction(inst)
        except PacketError as exc:
            raise ConfigError(str(exc)) from None
        end = address + len(data)
        if broadcast:  # every motor of the protocol: none may get one ID or a lost rate
            for other in _models.MODELS.values():
                if other.protocol != proto.version:
                    continue
                for name in ("id", "baud_rate"):
                    reg = other.register(name)
                    if address < reg.address + reg.size and reg.address < end:
                        raise ConfigError(f"a raw broadcast WRITE of bytes {address}..{end - 1} "
                                          f"covers {name} on the {other.name} (address "
                                          f"{reg.address}): every motor would take it; set "
                                          "IDs and rates one motor at a time (servolab id, "
                                          "servolab baud)")
        if m is None:
            level = 0 if broadcast else self._srl.get(motor_id, 2)
            self.transact(inst, {motor_id: 0} if level >= 2 else None)
            return
        regs = [r for r in m.registers if address < r.address + r.size and r.address < end]
        for reg in regs:
            if reg.address < address or reg.address + reg.size > end:
                raise ConfigError(f"{m.name}: bytes {address}..{end - 1} cover part of "
                                  f"{reg.name} ({reg.address}..{reg.address + reg.size - 1}): "
                                  f"write its {reg.size} bytes from address {reg.address}")
        special = [r for r in regs if r.name in ("id", "baud_rate")]
        if special:
            if len(regs) > 1:
                _refuse_commissioning([r.name for r in regs], "a raw WRITE")
            reg = special[0]
            self._commission(motor_id, reg.name, reg.decode(data), raw=True, registered=False)
            return
        for reg in regs:
            self._encode(motor_id, m, reg, reg.decode(data[reg.address - address:]), True)
        self._write_checked(motor_id, m, address, data)
