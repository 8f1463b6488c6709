"""An emulated motor's control table: its bytes as the model lays them out, and the checks a
write must pass that depend on the table alone (every byte in a writable register, whole
items only, each value in its range and within the limits other registers set).

What a write may do given the motor's *state* — the EEPROM locked while torque is on, the
goals read-only after a bus watchdog error, torque switched on by a goal — is the firmware's
(:class:`~.virtual_motor.VirtualMotor`); the table knows only its bytes. It is the piece of the
emulated firmware a test can check alone against the e-Manual's tables.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass

from . import protocol1 as p1
from . import protocol2 as p2
from .models import ALLOWED_MODES, Model, Register


@dataclass(frozen=True)
class Write:
    """A write the table accepts byte by byte: the table as it would be after it
    (``scratch``), the registers it touches, and their names."""

    scratch: bytearray
    touched: tuple[Register, ...]
    names: frozenset[str]


class ControlTable:
    """The bytes of one motor's control table (``data``), read and written by register name
    or by address as the instructions do."""

    def __init__(self, model: Model) -> None:
        self.model = model
        self.data = bytearray(model.table_size)
        self._layout = _layout(model)
        self._fields = _fields(model)
        #: the AX-style table (angle limits select wheel mode): every 1.0 model and the XL-320
        self.dx = model.has("cw_angle_limit")

    def get(self, name: str) -> int:
        # (the firmware reads a register dozens of times an instruction: straight from the
        # field's bytes, without building its Register's view)
        try:
            start, end, signed = self._fields[name]
        except KeyError:
            self.model.register(name)   # raises the one-line error naming what it has
            raise
        return int.from_bytes(self.data[start:end], "little", signed=signed)

    def put(self, name: str, value: int) -> None:
        """Set a register's raw value, bypassing access rights (the firmware's own write)."""
        # (by the field's bytes, as get: the same bytes Register.encode gives)
        try:
            start, end, signed = self._fields[name]
        except KeyError:
            self.model.register(name)   # raises the one-line error naming what it has
            raise
        self.data[start:end] = int(value).to_bytes(end - start, "little",
                                                   signed=signed and value < 0)

    def load_defaults(self, keep: Mapping[str, int] | None = None) -> None:
        """The table as at power-up: the factory defaults and the firmware version, the
        registers in ``keep`` set to their values, and (AX/RX/EX/MX) Torque Limit(34) from
        Max Torque(14): "When the power is turned on, Torque Limit(34) is reset to the value
        of Max Torque(14)" (e-Manual, Torque Limit)."""
        self.data[:] = bytes(len(self.data))
        for reg in self.model.registers:
            if reg.default is not None:
                self.data[reg.address:reg.address + reg.size] = reg.encode(reg.default)
        self.put("firmware_version", self.model.firmware)
        for name, value in (keep or {}).items():
            self.put(name, value)
        if self.model.has("max_torque"):
            self.put("torque_limit", self.get("max_torque"))

    def read(self, address: int, length: int) -> bytes | None:
        """``length`` bytes from ``address`` (None: past the table's end); Indirect Data n
        reads the byte its Indirect Address n points at (e-Manual, Indirect Address and
        Indirect Data)."""
        end = address + length
        if length == 0 or end > len(self.data):
            return None
        data = bytearray(self.data[address:end])
        layout = self._layout
        if layout.indirect and address <= layout.indirect_end and end > layout.indirect_start:
            for data_address, target in self._indirect_targets(address, end):
                data[data_address - address] = self.data[target]
        return bytes(data)

    def stage(self, address: int, data: bytes) -> Write | int:
        """The table after writing ``data`` at ``address`` (bytes to Indirect Data go on to
        the address their Indirect Address names), or the error code the motor answers:
        a byte outside every register or in a read-only one (1.0: range error; 2.0: access
        error), part of an item only (2.0: data length error: e.g. 2 bytes of the 4 of
        goal_position). Nothing is changed: :meth:`check` checks the values, :meth:`commit`
        writes them."""
        v1 = self.model.protocol == 1
        range_error = p1.RANGE if v1 else p2.ACCESS
        end = address + len(data)
        if end > len(self.data):
            return range_error
        assigned = dict(zip(range(address, end), data, strict=True))
        layout = self._layout
        if layout.indirect and address <= layout.indirect_end and end > layout.indirect_start:
            for data_address, target in self._indirect_targets(address, end):
                assigned[target] = assigned[data_address]
        at = layout.at
        touched_set: set[Register] = set()
        for a in assigned:
            reg = at[a]
            if reg is None:
                return range_error
            touched_set.add(reg)
        touched = tuple(sorted(touched_set, key=lambda r: r.address))
        for reg in touched:
            if any(a not in assigned for a in range(reg.address, reg.address + reg.size)):
                return range_error if v1 else p2.DATA_LENGTH
            if not reg.writable:
                return range_error
        scratch = bytearray(self.data)
        for a, byte in assigned.items():
            scratch[a] = byte
        return Write(scratch, touched, frozenset(r.name for r in touched))

    def check(self, write: Write) -> int:
        """The error a motor answers for the values of ``write`` (0: none): each touched
        register's value within its range and the limits the rest of the table sets, as it
        will be after the write (:func:`check_value`)."""
        scratch = write.scratch
        for reg in write.touched:
            value = reg.decode(scratch[reg.address:reg.address + reg.size])
            error = check_value(self.model, reg, value, scratch)
            if error:
                return error
        return 0

    def commit(self, write: Write) -> None:
        self.data[:] = write.scratch

    def _indirect_targets(self, start: int, end: int) -> list[tuple[int, int]]:
        """(indirect data address, the address it stands for) for indirect data in
        start..end."""
        table = self.data
        out = []
        for data_address, pointer in self._layout.indirect:
            if start <= data_address < end:
                target = table[pointer] | table[pointer + 1] << 8
                if target < len(table):
                    out.append((data_address, target))
        return out


def check_value(model: Model, reg: Register, value: int, table: bytearray) -> int:
    """The error a motor answers for ``value`` in ``reg`` with the rest of the table as
    ``table`` (0: none): out of the register's range; on the AX-style table a goal position
    outside the angle limits in joint mode (angle limit error) or a moving speed above 1023
    there; on the X-series an operating mode the model lacks, and a goal beyond its limit
    register (Velocity Limit, the position limits in Position Control Mode, Current Limit,
    PWM Limit: data limit error) — e-Manual, each register's page."""
    v1 = model.protocol == 1

    def other(name: str) -> int:
        r = model.register(name)
        return r.decode(table[r.address:r.address + r.size])

    if not reg.raw_min <= value <= reg.raw_max:
        return p1.RANGE if v1 else p2.DATA_RANGE
    if model.has("cw_angle_limit"):
        cw, ccw = other("cw_angle_limit"), other("ccw_angle_limit")
        if model.has("control_mode"):
            wheel, multi_turn = other("control_mode") == 1, False
        else:
            wheel, multi_turn = angle_limit_modes(model, cw, ccw)
        # In multi-turn mode the register's own range (±28 672) is the limit.
        if reg.name == "goal_position" and not wheel and not multi_turn and not (
                cw <= value <= ccw):
            return p1.ANGLE_LIMIT if v1 else p2.DATA_LIMIT
        if reg.name == "moving_speed" and not wheel and value > 1023:
            return p1.RANGE if v1 else p2.DATA_RANGE
        return 0
    if reg.name == "operating_mode" and value not in ALLOWED_MODES.get(model.name, (value,)):
        return p2.DATA_RANGE
    if reg.name == "goal_velocity" and abs(value) > other("velocity_limit"):
        return p2.DATA_LIMIT
    if reg.name == "goal_position" and other("operating_mode") == 3 and not (
            other("min_position_limit") <= value <= other("max_position_limit")):
        return p2.DATA_LIMIT
    if reg.name == "goal_current" and abs(value) > other("current_limit"):
        return p2.DATA_LIMIT
    if reg.name == "goal_pwm" and abs(value) > other("pwm_limit"):
        return p2.DATA_LIMIT
    return 0


def angle_limit_modes(model: Model, cw: int, ccw: int) -> tuple[bool, bool]:
    """(wheel mode, multi-turn mode) of a 1.0 servo with these angle limits: wheel when both
    are 0, multi-turn (MX-28) when both are 4095 (e-Manual, CW/CCW Angle Limit)."""
    top = model.register("ccw_angle_limit").raw_max
    return (cw == ccw == 0, model.has("multi_turn_offset") and cw == ccw == top)


@dataclass(frozen=True)
class _Layout:
    """What the table looks up on every write, per model: the register each byte belongs
    to, and where the indirect data are and where their addresses are kept."""

    at: tuple[Register | None, ...]
    indirect: tuple[tuple[int, int], ...]   # (Indirect Data n, address of Indirect Address n)
    indirect_start: int
    indirect_end: int                       # the last Indirect Data address (inclusive)


@functools.cache
def _fields(model: Model) -> dict[str, tuple[int, int, bool]]:
    """Each register's bytes and sign, by name: (start, end, signed)."""
    return {r.name: (r.address, r.address + r.size, r.signed) for r in model.registers}


@functools.cache
def _layout(model: Model) -> _Layout:
    at: list[Register | None] = [None] * model.table_size
    for reg in model.registers:
        for a in range(reg.address, reg.address + reg.size):
            at[a] = reg
    indirect = tuple(sorted(
        (reg.address, model.register("indirect_address_" + reg.name[len("indirect_data_"):])
         .address)
        for reg in model.registers if reg.name.startswith("indirect_data_")))
    data = [d for d, _ in indirect]
    return _Layout(tuple(at), indirect, min(data, default=0), max(data, default=-1))
