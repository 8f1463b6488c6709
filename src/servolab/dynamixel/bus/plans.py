"""Plans: what a read or a write of the same registers of the same motors repeats, worked
out once and kept by the bus (:class:`PlanCache`).

A plan holds the instruction packet, the status packets it is answered with and where each
one's data sits, and one :class:`struct.Struct` that decodes them. A reply that is exactly as
expected is checked in place and decoded in one call; only one that is not goes through the
stream parser (:mod:`.link`). A SYNC_WRITE plan (:class:`SyncWrite`) keeps the packet with
every ID in place and fills in the values, falling back to the checked path for anything it
does not convert.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable, Sequence
from functools import partial
from typing import Any

from .. import units
from ..errors import ConfigError
from ..models import FAST_READ_FIRMWARE, Model, Register, read_limits, supports
from ..packets import Protocol
from ..protocol2 import Protocol2, crc16_at
from .common import Names, Value
from .link import Plausible, Replies
from .model_checks import TORQUE_GOALS, register_of

#: plans kept per bus before the cache starts again (a robot uses a handful)
MAX_PLANS = 4096


STRUCT_CODES = {(1, False): "B", (2, False): "H", (4, False): "I",
                (1, True): "b", (2, True): "h", (4, True): "i"}


class Fields:
    """Named registers of one model, read as one block: the block's (start, length), and one
    :class:`struct.Struct` that takes every value out of it at once.

    ``moded``: a register among them converts to SI by the motor's mode (moving/present
    speed of a model whose wheel mode sets the output, :attr:`.Model.wheel_output_ratio`);
    the caller then says which mode the motor is in, and ``wheel_convert`` serves wheel mode.
    """

    __slots__ = ("_order", "_struct", "convert", "holds", "length", "limits", "moded",
                 "model_name", "names", "regs", "single", "start", "wheel_convert")

    def __init__(self, m: Model, names: Names) -> None:
        self.single = isinstance(names, str)
        self.names = list(dict.fromkeys([names] if isinstance(names, str) else names))
        self.regs = [register_of(m, n) for n in self.names]  # ConfigError: unknown name
        if not self.regs:
            raise ConfigError(f"{m.name}: no register named to read")
        self.model_name = m.name
        #: (place among the values, lowest, highest, reserved bits) of each register whose
        #: value can be checked when it is read (:func:`.models.read_limits`)
        self.limits = [(k, *held) for k, reg in enumerate(self.regs)
                       if (held := read_limits(m, reg)) is not None]
        self.start, self.length = m.span(self.names)
        self.convert = [si_decoder(m, r) for r in self.regs]
        self.moded = m.wheel_output_ratio and any(r.unit == "speed_sign_bit"
                                                  for r in self.regs)
        self.wheel_convert = ([si_decoder(m, r, wheel=True) for r in self.regs] if self.moded
                              else self.convert)
        by_address = sorted(range(len(self.regs)), key=lambda k: self.regs[k].address)
        fmt, at = "<", self.start
        for k in by_address:
            reg = self.regs[k]
            code = STRUCT_CODES.get((reg.size, reg.signed))
            if code is None or reg.address < at:  # no struct code, or overlapping registers
                fmt = ""
                break
            fmt += (f"{reg.address - at}x" if reg.address > at else "") + code
            at = reg.address + reg.size
        self._struct = struct.Struct(fmt) if fmt else None
        # the struct gives values in address order; the caller wants them in its own
        self._order = (None if by_address == sorted(by_address)
                       else [by_address.index(k) for k in range(len(by_address))])
        #: whether the block at ``buf[at]`` holds only values its registers can hold:
        #: ``holds(buf, at)``, one unpack of the registers checked (None: nothing to check)
        self.holds = self._holds() if self.limits else None

    def raw(self, buf: bytes, at: int) -> Sequence[int]:
        """The raw values (in the order named) of the block that starts at ``buf[at]``."""
        if self._struct is None:
            return [r.decode(buf[at + r.address - self.start:]) for r in self.regs]
        values = self._struct.unpack_from(buf, at)
        return values if self._order is None else [values[k] for k in self._order]

    def _holds(self) -> Callable[[bytes, int], bool]:
        """:attr:`holds`, as fast as it can be: what every read of the plan pays. A range
        0 .. 2^n - 1 (most: 1023, 2047, a flag's 0..1) and reserved bits are bits that must be
        0, all tested at once on the block as one integer; other ranges are compared."""
        forbidden = bytearray(self.length)
        ranged = []
        for k, low, high, reserved in self.limits:
            reg = self.regs[k]
            if low == 0 and high >= 0 and not high & (high + 1):
                at = reg.address - self.start
                bits = ((1 << 8 * reg.size) - 1) & ~high | reserved
                for i, byte in enumerate(bits.to_bytes(reg.size, "little")):
                    forbidden[at + i] |= byte
            else:
                ranged.append((k, low, high, reserved))
        mask, length = int.from_bytes(forbidden, "little"), self.length
        compare = self._compare(ranged) if ranged else None
        if compare is None:
            return lambda buf, at: not int.from_bytes(buf[at:at + length], "little") & mask
        if not mask:
            return compare
        return lambda buf, at: (not int.from_bytes(buf[at:at + length], "little") & mask
                                and compare(buf, at))

    def _compare(self, limits: list[tuple[int, int, int, int]]) -> Callable[[bytes, int], bool]:
        """Whether the block at ``buf[at]`` holds the ``limits``' registers within their
        ranges: one unpack of those registers, compared."""
        fmt, at = "<", self.start
        bounds = []
        for k, low, high, reserved in sorted(limits, key=lambda lim: self.regs[lim[0]].address):
            reg = self.regs[k]
            code = STRUCT_CODES.get((reg.size, reg.signed))
            if code is None or reg.address < at:   # no struct code, or overlapping registers
                return lambda buf, at: self.implausible(buf, at) is None
            fmt += (f"{reg.address - at}x" if reg.address > at else "") + code
            at = reg.address + reg.size
            bounds.append((low, high, reserved))
        unpack = struct.Struct(fmt).unpack_from
        if len(bounds) == 1 and not bounds[0][2]:
            low, high, _ = bounds[0]
            return lambda buf, at: low <= unpack(buf, at)[0] <= high

        def within(buf: bytes, at: int) -> bool:
            for value, (low, high, reserved) in zip(unpack(buf, at), bounds, strict=True):
                if not low <= value <= high or value & reserved:
                    return False
            return True

        return within

    def implausible(self, buf: bytes, at: int) -> str | None:
        """What cannot be true of the block that starts at ``buf[at]``: a value outside what
        its register can hold (:attr:`limits`), in words; None when every value can be."""
        raws = self.raw(buf, at)
        for k, low, high, reserved in self.limits:
            value = raws[k]
            if value & reserved:
                return (f"{self.names[k]} 0x{value:02X}, whose bits 0x{value & reserved:02X} "
                        f"the {self.model_name} keeps at 0")
            if not low <= value <= high:
                return (f"{self.names[k]} {value}, outside {low}..{high}, what it holds on the "
                        f"{self.model_name}")
        return None

    def values(self, buf: bytes, at: int, raw: bool, wheel: bool = False) -> Any:
        """One value (one name given as a str) or {name: value}, raw or in SI units (those
        of wheel mode when ``wheel``, see ``moded``)."""
        raws = self.raw(buf, at)
        values: Sequence[Value] = raws if raw else [
            v if c is None else c(v)
            for v, c in zip(raws, self.wheel_convert if wheel else self.convert, strict=True)]
        return values[0] if self.single else dict(zip(self.names, values, strict=True))


class Read:
    """One READ of named registers of one motor: instruction bytes, reply layout, decoder."""

    __slots__ = ("fields", "model", "motor_id", "plausible", "proto", "replies", "request")

    def __init__(self, proto: Protocol, motor_id: int, m: Model, fields: Fields) -> None:
        self.proto, self.motor_id, self.model, self.fields = proto, motor_id, m, fields
        self.request = proto.encode_instruction(proto.read(motor_id, fields.start,
                                                           fields.length))
        self.replies = Replies(proto, {motor_id: fields.length})
        #: what the link checks of a reply (:class:`.link.Plausible`); None: nothing to
        #: check (every value the registers' bytes hold can be true)
        self.plausible: Plausible | None = None
        holds, failed = fields.holds, proto.failed
        if holds is not None:
            def plausible(buf: bytes, data_at: Sequence[int], errors: Sequence[int]
                          ) -> tuple[int, str] | None:
                at = data_at[0]
                if holds(buf, at) or (errors and failed(errors[0])):  # (failed: no data)
                    return None
                doubt = fields.implausible(buf, at)
                return None if doubt is None else (motor_id, doubt)

            self.plausible = plausible


class MultiRead:
    """A read of many motors: one SYNC_READ or BULK_READ (``request`` and ``replies``, one
    decoder per motor), or their fast forms (one status packet for all), or else one READ per
    motor (``reads``). ``fast``: True takes the fast form or raises ConfigError (before
    anything is sent) where a motor lacks it, None takes it where every motor has it, False
    never."""

    __slots__ = ("_checked", "fields", "ids", "moded", "models", "name", "plausible", "proto",
                 "reads", "replies", "request")

    def __init__(self, proto: Protocol, ids: tuple[int, ...], models: list[Model],
                 fields: list[Fields], *, allow_sync: bool, fast: bool | None = False
                 ) -> None:
        self.proto, self.ids, self.models, self.fields = proto, ids, models, fields
        #: (place, motor, its fields, their check) of each motor whose data can be checked
        self._checked = [(k, motor_id, f, f.holds) for k, (motor_id, f) in
                         enumerate(zip(ids, fields, strict=True)) if f.holds is not None]
        #: as :attr:`Read.plausible`, for the one instruction (``reads`` have their own)
        self.plausible: Plausible | None = self._plausible if self._checked else None
        #: the motors whose SI values depend on their mode (see Fields.moded)
        self.moded = tuple(i for i, f in zip(ids, fields, strict=True) if f.moded)
        spans = {(f.start, f.length) for f in fields}
        self.reads: list[Read] = []
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
                self.replies = Replies(proto, {i: f.length for i, f in
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
            self.reads = [Read(proto, i, m, f)
                          for i, m, f in zip(ids, models, fields, strict=True)]
        self.replies = Replies(proto, {i: f.length for i, f in zip(ids, fields, strict=True)})

    def _plausible(self, buf: bytes, data_at: Sequence[int], errors: Sequence[int]
                   ) -> tuple[int, str] | None:
        failed = self.proto.failed
        for k, motor_id, fields, holds in self._checked:
            at = data_at[k]
            if holds(buf, at) or (errors and failed(errors[k])):  # (failed: no data)
                continue
            doubt = fields.implausible(buf, at)
            if doubt is not None:
                return motor_id, doubt
        return None


def si_decoder(m: Model, reg: Register, *, wheel: bool = False
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


def si_encoder(m: Model, reg: Register) -> Callable[[float], int] | None:
    """SI -> raw as :func:`.units.from_si` computes it, unchecked, for the goals a control
    loop writes every cycle (position, velocity); None for other kinds."""
    if reg.unit == "position":
        center, tick = m.position_center, m.rad_per_tick
        return lambda value: round(value / tick) + center
    if reg.unit == "velocity":
        unit = units.velocity_unit(m)
        return lambda value: round(value / unit)
    return None


class SyncWrite:
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
        self.goal = reg.name in TORQUE_GOALS
        self.si = (si_encoder(models[0], reg) if all(m is models[0] for m in models)
                   else None)
        self.low, self.high = reg.raw_min, reg.raw_max
        code = STRUCT_CODES[(reg.size, reg.signed)]
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


class PlanCache:
    """The plans a bus has worked out, by what they do (a key of the call's arguments). What
    changes a plan's outcome (a motor's mode or limits, its ID, a reset) clears it all: a
    robot uses a handful of plans, which are worked out again at the next call."""

    __slots__ = ("_plans",)

    def __init__(self) -> None:
        self._plans: dict[Any, Any] = {}

    def get(self, key: Any) -> Any:
        try:
            return self._plans.get(key)
        except TypeError:  # an unhashable ID or name: the checked path says what is wrong
            return None

    def keep(self, key: Any, plan: Any) -> None:
        try:
            if len(self._plans) >= MAX_PLANS:
                self._plans.clear()
            self._plans[key] = plan
        except TypeError:
            pass

    def clear(self) -> None:
        self._plans.clear()
