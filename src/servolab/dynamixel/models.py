"""Control tables of Dynamixel models, as data.

A :class:`Model` is everything servolab knows about one servo type: its model number as PING
reports it, its protocol, its control table (address, size, EEPROM/RAM, access, default, range,
unit) and the physical figures the emulator and the unit conversions need. Driver, emulator and
CLI all read these tables; none of them hard-codes an address.

Each model is one YAML file: those servolab ships live in ``model_tables/`` beside this module
(one per model, named after its e-Manual page, e.g. ``xm430-w210.yaml``), each citing the
ROBOTIS e-Manual page its figures come from; :func:`register_model` adds a lab's own. The files
are read by :mod:`servolab.configfile`, so a mistake in one is reported as ``path:line:
message`` (:class:`ModelFileError`), and every value is checked before a :class:`Model` is made
of it. docs/dynamixel.md ("Adding a model") describes the format.

Reading a file costs tens of milliseconds, so the shipped ones are read when first asked for:
:func:`model` and :func:`model_by_number` read only the file they need (an index of names and
numbers is taken from the files' ``name:`` and ``number:`` lines), and :data:`MODELS` reads a
file when one of its values is looked at.
"""

from __future__ import annotations

import functools
import itertools
import math
import re
import threading
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal, NoReturn

from ..errors import ConfigFileError
from .errors import ConfigError

if TYPE_CHECKING:
    from ..configfile import ConfigMapping, ConfigValue

Area = Literal["EEPROM", "RAM"]
Access = Literal["R", "RW"]
WheelPosition = Literal["potentiometer", "encoder16", "turn"]

#: Where the shipped model files live (package data: pyproject ships ``**/*.yaml``).
TABLES_DIR = Path(__file__).resolve().parent / "model_tables"
#: The version of the model file format this module reads (the files' ``servolab_model:``).
FORMAT_VERSION = 1


class ModelFileError(ConfigFileError, ConfigError):
    """A model file that cannot be used; ``str()`` is one line, ``path:line: message``, and
    ``path``, ``line`` and ``key`` are kept (a :class:`ConfigError` too, so callers catching
    that keep working)."""


@dataclass(frozen=True)
class Register:
    """One entry of a control table."""

    name: str
    address: int
    size: int
    area: Area
    access: Access
    default: int | None = None
    minimum: int = 0
    maximum: int | None = None
    unit: str = "raw"
    signed: bool = False

    @property
    def writable(self) -> bool:
        return self.access == "RW"

    @property
    def raw_min(self) -> int:
        return self.minimum

    @property
    def raw_max(self) -> int:
        if self.maximum is not None:
            return self.maximum
        bits = 8 * self.size
        return (1 << (bits - 1)) - 1 if self.signed else (1 << bits) - 1

    def check(self, raw: int, model: Model | None = None) -> None:
        """Raise :class:`ConfigError` if ``raw`` is outside this register's range."""
        if not self.raw_min <= raw <= self.raw_max:
            where = f"{model.name} " if model else ""
            raise ConfigError(
                f"{where}{self.name}: raw value {raw} is outside {self.raw_min}..{self.raw_max}")

    def encode(self, raw: int) -> bytes:
        return int(raw).to_bytes(self.size, "little", signed=self.signed and raw < 0)

    def decode(self, data: bytes | bytearray) -> int:
        return int.from_bytes(data[: self.size], "little", signed=self.signed)


@dataclass(frozen=True)
class Model:
    """A Dynamixel servo type: control table plus the figures behind its units and motion."""

    name: str
    number: int
    protocol: int
    registers: tuple[Register, ...] = field(repr=False)
    resolution: int                 # position ticks over ``angle_range``
    angle_range_deg: float          # angle covered by ticks 0..resolution-1 (joint mode)
    position_center: int            # tick that servolab calls 0 rad
    speed_unit_rpm: float           # rpm per unit of moving speed / goal velocity
    no_load_speed_rpm: float        # at the nominal voltage, for the emulator
    nominal_voltage: float
    multi_turn: bool = False        # X-series: present position keeps counting past one turn
    current_unit_a: float = 0.0     # A per unit of present current (0 if the model has none)
    stall_current_a: float = 0.0    # at the nominal voltage, for a sensed-current register
    #: 1.0 wheel mode: True where moving_speed sets the output ratio (AX/RX/EX: "only the
    #: output control is possible, not speed"), False where it sets a speed (MX)
    wheel_output_ratio: bool = False
    #: what present_position reads in 1.0 wheel mode: "potentiometer" (0..max over the
    #: angle range of each turn), "encoder16" (a count 0..65535 and round) or "turn" (the
    #: ticks of each turn)
    wheel_position: WheelPosition = "turn"
    acceleration_unit_rpm2: float = 214.577
    firmware: int = 0
    #: instruction names the model answers; others get an instruction error
    instruction_set: frozenset[str] = frozenset()
    stall_torque_nm: float = 0.0    # at the nominal voltage (0: the e-Manual gives none)
    #: the values of ``operating_mode`` the model takes (its register range is only their
    #: hull); empty for models without that register
    operating_modes: tuple[int, ...] = ()
    #: the baud-rate register: values with a rate of their own, (value, bps) ...
    baud_table: tuple[tuple[int, int], ...] = ()
    #: ... and for the others (Protocol 1.0) ``baud_divisor // (value + 1)``; 0: none
    baud_divisor: int = 0
    #: the bits of hardware_error_status (2.0) as (mask, name), where a model numbers them
    #: otherwise than its protocol does (the XL-320); empty: :meth:`hardware_error_bits`
    #: gives the protocol's
    hardware_errors: tuple[tuple[int, str], ...] = ()
    #: the e-Manual page the figures come from (a path in ROBOTIS-GIT/emanual)
    source: str = ""
    #: the model file it was read from ("" for a model made in code)
    path: str = field(default="", compare=False, repr=False)
    _by_name: dict[str, Register] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "_by_name", {r.name: r for r in self.registers})

    def __repr__(self) -> str:
        return f"Model({self.name!r}, number={self.number}, protocol={self.protocol})"

    # -- control table ------------------------------------------------------------------
    def register(self, name: str) -> Register:
        """The register called ``name`` (e.g. ``"goal_position"``); ConfigError if unknown."""
        try:
            return self._by_name[name]
        except KeyError:
            known = ", ".join(sorted(self._by_name))
            raise ConfigError(
                f"{self.name} has no register {name!r}; it has: {known}") from None

    def has(self, name: str) -> bool:
        return name in self._by_name

    def role(self, role: str) -> Register:
        """The register that plays ``role`` (a name of :data:`ROLES`, e.g. ``"moving_speed"``
        is Moving Speed(32) on an RX-28 and Profile Velocity(112) on an XM430); ConfigError,
        one line naming the model and what it lacks, if the model has none."""
        names = _role_names(role)
        for name in names:
            if name in self._by_name:
                return self._by_name[name]
        raise ConfigError(f"{self.name} has no {' or '.join(names)} register ({ROLE_WORDS[role]})")

    def has_role(self, role: str) -> bool:
        """Whether some register of the model plays ``role``."""
        return any(name in self._by_name for name in _role_names(role))

    def register_at(self, address: int) -> Register | None:
        for reg in self.registers:
            if reg.address == address:
                return reg
        return None

    @property
    def table_size(self) -> int:
        return max(r.address + r.size for r in self.registers)

    def span(self, names: list[str]) -> tuple[int, int]:
        """(start address, length) of the smallest contiguous block holding ``names``."""
        regs = [self.register(n) for n in names]
        start = min(r.address for r in regs)
        end = max(r.address + r.size for r in regs)
        return start, end - start

    # -- physics --------------------------------------------------------------------------
    @functools.cached_property
    def rad_per_tick(self) -> float:
        if self.multi_turn or self.angle_range_deg >= 360.0:
            return 2.0 * math.pi / self.resolution
        return math.radians(self.angle_range_deg) / (self.resolution - 1)

    @functools.cached_property
    def no_load_speed(self) -> float:
        """No-load speed in rad/s at the nominal voltage."""
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0

    def hardware_error_bits(self) -> dict[int, str]:
        """The hardware errors the model reports, mask -> name as the e-Manual spells it: on
        1.0 the status error byte's (input voltage, overheating, overload), on 2.0 the bits of
        hardware_error_status (the X-series' unless the model file lists its own)."""
        if self.hardware_errors:
            return dict(self.hardware_errors)
        if self.protocol == 1:
            from .protocol1 import ERROR_BITS
            from .protocol1 import HARDWARE_ERRORS as P1_HARDWARE

            return {bit: name for bit, name in ERROR_BITS.items() if bit & P1_HARDWARE}
        from .protocol2 import HARDWARE_ERRORS

        return dict(HARDWARE_ERRORS)

    # -- baud rate register --------------------------------------------------------------
    def baud_from_register(self, value: int) -> int:
        """Bits per second that a value of the baud-rate register selects."""
        table, divisor = dict(self.baud_table), self.baud_divisor
        if not table and not divisor:
            # A model made in code without baud data: the rates of its protocol.
            if self.protocol == 1:
                divisor = 2_000_000
                if self.name.startswith("MX"):
                    table = dict(_MX_HIGH_BAUDS)
            else:
                table = X_SERIES_BAUDS
        if value in table:
            return table[value]
        if divisor:
            return divisor // (value + 1)  # ROBOTIS truncates: 34 -> 57142
        raise ConfigError(f"{self.name}: baud_rate register value {value} is not defined; "
                          f"use one of {sorted(table)}")

    def baud_register_for(self, bps: int) -> int:
        """The register value whose rate is within 3 % of ``bps`` (UART tolerance)."""
        reg = self.register("baud_rate")
        best = min(range(reg.raw_min, reg.raw_max + 1),
                   key=lambda v: abs(self._safe_baud(v) - bps))
        if abs(self._safe_baud(best) - bps) > 0.03 * bps:
            raise ConfigError(f"{self.name}: {bps} bps is not a baud rate this model can use")
        return best

    def _safe_baud(self, value: int) -> int:
        try:
            return self.baud_from_register(value)
        except ConfigError:
            return -(10**9)

    @property
    def baud_rates(self) -> list[int]:
        reg = self.register("baud_rate")
        rates = {self._safe_baud(v) for v in range(reg.raw_min, reg.raw_max + 1)}
        return sorted(rates - {-(10**9)})


#: Fast Sync Read (0x8A) and Fast Bulk Read (0x9A): one status packet for all the motors read.
#: ROBOTIS: "DYNAMIXEL X Series only", not the MX series in 2.0 firmware (ROBOTIS forum,
#: "No response to fast sync read command with Dynamixel MX28-AR", forum.robotis.com/t/820).
#: From which firmware is less certain. A third party gives XL330 firmware v46 and later
#: (pollen-robotics/rustypot PR #122, "may need a firmware update (XL330: v46+)"); the
#: e-Manual copies at hand (ROBOTIS-GIT/emanual docs/en/dxl/protocol2.md) predate the Fast
#: instructions and give no figure for the X430 models, whose firmware in March 2022 answered
#: Fast Sync Read (an XL430-W250 "updated to the current released firmware", Dynamixel2Arduino
#: issue #95). servolab takes v46 for every X model, the one figure published: it may refuse an
#: X430 whose older firmware would answer, never send to one that stays silent.
FAST_READS = frozenset({"FAST_SYNC_READ", "FAST_BULK_READ"})
FAST_READ_FIRMWARE = 46

X_SERIES_BAUDS: dict[int, int] = {
    0: 9_600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000,
    5: 3_000_000, 6: 4_000_000, 7: 4_500_000,
}
#: Protocol 1.0 MX: the register values above 249 with a rate of their own (e-Manual, MX
#: Baud Rate, "For BPS over 250 values").
_MX_HIGH_BAUDS = ((250, 2_250_000), (251, 2_500_000), (252, 3_000_000))

#: Operating modes of the X-series and MX(2.0) (register ``operating_mode``), by the names a
#: model file lists them under.
OPERATING_MODES: dict[str, int] = {
    "current": 0, "velocity": 1, "position": 3, "extended_position": 4,
    "current_based_position": 5, "pwm": 16,
}


#: Registers by role: what the dynamixel_motor controllers ask of any motor (the role names are
#: the Protocol 1.0 register names that ROS ``dynamixel_driver`` speaks), and the register of
#: each control-table family that plays it, first match in a model's table winning. The
#: families' names are the e-Manual's, so a lab's own model file gets its roles from its
#: register names: AX/RX/EX/MX(1.0)/XL-320 have the 1.0 names; X-series and MX(2.0) have
#: Profile Velocity, Present Velocity, Present Current (Present Load on XL430/MX-28(2.0)),
#: Present Input Voltage, Goal PWM as the limit of output that works in every operating mode
#: ("in other control modes, this value is used to limit PWM value", e-Manual
#: control_table_goal_pwm: Goal Current limits only in current-based position mode, Current
#: Limit(38) only in the current modes) and Position PID gains instead of compliance.
ROLES: dict[str, tuple[str, ...]] = {
    "goal_position": ("goal_position",),
    "moving_speed": ("moving_speed", "profile_velocity"),
    "present_position": ("present_position",),
    "present_speed": ("present_speed", "present_velocity"),
    "present_load": ("present_load", "present_current"),
    "present_voltage": ("present_voltage", "present_input_voltage"),
    "present_temperature": ("present_temperature",),
    "torque_enable": ("torque_enable",),
    "moving": ("moving",),
    "torque_limit": ("torque_limit", "goal_pwm"),
    "current_limit": ("current_limit",),
    "cw_compliance_margin": ("cw_compliance_margin",),
    "ccw_compliance_margin": ("ccw_compliance_margin",),
    "cw_compliance_slope": ("cw_compliance_slope",),
    "ccw_compliance_slope": ("ccw_compliance_slope",),
    "punch": ("punch",),
    "p_gain": ("p_gain", "position_p_gain"),
    "i_gain": ("i_gain", "position_i_gain"),
    "d_gain": ("d_gain", "position_d_gain"),
}
#: Each role in words, for the one line that says a model lacks it.
ROLE_WORDS: dict[str, str] = {
    "goal_position": "goal position", "moving_speed": "moving speed or profile velocity",
    "present_position": "present position", "present_speed": "present speed or velocity",
    "present_load": "present load or current", "present_voltage": "present voltage",
    "present_temperature": "present temperature", "torque_enable": "torque enable",
    "moving": "moving flag", "torque_limit": "torque or output limit",
    "current_limit": "current limit",
    "cw_compliance_margin": "compliance margin", "ccw_compliance_margin": "compliance margin",
    "cw_compliance_slope": "compliance slope", "ccw_compliance_slope": "compliance slope",
    "punch": "compliance punch", "p_gain": "P gain", "i_gain": "I gain", "d_gain": "D gain",
}


def _role_names(role: str) -> tuple[str, ...]:
    try:
        return ROLES[role]
    except KeyError:
        raise ConfigError(f"no register role {role!r}; the roles are: "
                          f"{', '.join(ROLES)}") from None


def R(name: str, address: int, size: int, area: Area, access: Access, default: int | None = None,
      minimum: int = 0, maximum: int | None = None, unit: str = "raw",
      signed: bool = False) -> Register:
    return Register(name, address, size, area, access, default, minimum, maximum, unit, signed)


def supports(model: Model, instruction: str) -> bool:
    """Whether ``model`` (at its firmware) carries out ``instruction`` (a name of
    :data:`.protocol2.INSTRUCTIONS` or :data:`.protocol1.INSTRUCTIONS`)."""
    if instruction in FAST_READS:
        return (instruction in model.instruction_set and model.protocol == 2
                and model.firmware >= FAST_READ_FIRMWARE)
    return instruction in model.instruction_set


# -- what a register can hold when it is read ----------------------------------------------------

#: Moving Status(123) of the X-series and MX(2.0): bit 0 In-Position, bit 1 Profile Ongoing,
#: bit 3 Following Error, bits 4-5 the velocity profile; bits 2, 6 and 7 are unused, always 0
#: (e-Manual, en/dxl/control_table_movingstatus.md).
MOVING_STATUS_RESERVED = 0xC4


def width_range(reg: Register) -> tuple[int, int]:
    """Every raw value the register's bytes can hold (two's complement where signed)."""
    bits = 8 * reg.size
    return (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if reg.signed else (0, (1 << bits) - 1)


def read_limits(m: Model, reg: Register) -> tuple[int, int, int] | None:
    """What ``reg`` of ``m`` can hold when it is read, by the e-Manual: ``(lowest, highest,
    reserved)``, its raw value within lowest..highest with none of the ``reserved`` bits set;
    None when that is anything its bytes hold (nothing to check). The bus takes a read value
    outside it for a corrupt reply (:mod:`.bus.reads`).

    Not the range a host may *write* where the firmware itself sets more: Bus Watchdog(98)
    is set to -1 by the motor when it trips (control_table_buswatchdog.md), and Goal Position
    is set to Present Position at power-up (so it can hold what Present Position can).

    A read-only register with no range in its table: Present Position of a model whose
    position sensor counts within one turn reads 0 .. resolution - 1 (AX, RX, XL-320: "0 ~
    1,023"; MX in 1.0: "0 ~ 4,095", and in multi-turn mode Goal Position's -28,672 ~ 28,672,
    e-Manual MX-28 Present Position and Multi-turn), Hardware Error Status only the bits the
    model names (control_table_hardwareerrorstatus.md), Moving Status none of
    :data:`MOVING_STATUS_RESERVED`, a speed or load with a direction bit (XL-320 Present
    Speed and Load: "0 ~ 2,047", bit 10 the direction) 0 .. 2,047, a flag (Moving,
    Registered Instruction) 0 .. 1. The others are left unchecked (None), for want of a
    figure: the model number and firmware, present voltage and temperature, present PWM,
    current and velocity, the trajectories, a multi-turn or 16-bit (EX-106+ wheel mode)
    Present Position, which can be any value its bytes hold."""
    width = width_range(reg)
    low, high = width
    reserved = 0
    if reg.name == "hardware_error_status":
        known = 0
        for bit in m.hardware_error_bits():
            known |= bit
        reserved = ((1 << (8 * reg.size)) - 1) & ~known
    elif reg.name == "moving_status":
        reserved = MOVING_STATUS_RESERVED
    elif reg.maximum is not None:
        low, high = reg.raw_min, reg.raw_max
        if reg.name == "bus_watchdog":
            low = min(low, -1)
        elif reg.name == "goal_position" and m.has("present_position"):
            present = read_limits(m, m.register("present_position"))
            held = present[:2] if present is not None else width_range(
                m.register("present_position"))
            low, high = min(low, held[0]), max(high, held[1])
    elif (reg.access == "R" and reg.unit == "position" and not m.multi_turn
          and m.wheel_position != "encoder16" and reg.name == "present_position"):
        low, high = 0, m.resolution - 1
        goal = m.register("goal_position") if m.has("goal_position") else None
        if goal is not None and goal.signed and goal.maximum is not None:
            low, high = min(low, goal.raw_min), max(high, goal.raw_max)
    elif reg.unit in ("speed_sign_bit", "load_sign_bit"):
        low, high = 0, 0x7FF       # 10 bits of magnitude and the direction, bit 10
    elif reg.unit == "bool":
        low, high = 0, 1
    low, high = max(low, width[0]), min(high, width[1])
    if (low, high) == width and not reserved:
        return None
    return low, high, reserved


# -- reading a model file -----------------------------------------------------------------------

_TOP_KEYS = ("servolab_model", "name", "number", "protocol", "source", "firmware",
             "instructions", "operating_modes", "hardware_errors", "physical", "baud_rate",
             "eeprom", "ram", "indirect")
#: The names a model file may give the bits of hardware_error_status (the e-Manual's).
HARDWARE_ERROR_NAMES = ("input voltage", "overheating", "motor encoder", "electrical shock",
                        "overload")
_REQUIRED_TOP = ("servolab_model", "name", "number", "protocol", "instructions", "physical",
                 "baud_rate", "eeprom", "ram")
_PHYSICAL_KEYS = ("resolution", "angle_range_deg", "position_center", "multi_turn",
                  "speed_unit_rpm", "no_load_speed_rpm", "nominal_voltage", "current_unit_a",
                  "stall_torque_nm", "stall_current_a", "wheel_output_ratio", "wheel_position",
                  "acceleration_unit_rpm2")
_REQUIRED_PHYSICAL = ("resolution", "angle_range_deg", "position_center", "speed_unit_rpm",
                      "no_load_speed_rpm", "nominal_voltage")
_REGISTER_KEYS = ("address", "size", "access", "default", "range", "unit", "signed")
_INDIRECT_KEYS = ("first", "count", "address", "data", "range")
_WHEEL_POSITIONS = ("potentiometer", "encoder16", "turn")
#: Registers the driver and the emulator rely on in every model.
REQUIRED_REGISTERS = ("model_number", "firmware_version", "id", "baud_rate", "return_delay_time",
                      "status_return_level", "torque_enable", "goal_position",
                      "present_position", "present_temperature", "temperature_limit",
                      "shutdown")
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9+\-_.()]*\Z")
_REGISTER_NAME = re.compile(r"[a-z][a-z0-9_]*\Z")


def _fail(value: ConfigValue, message: str) -> NoReturn:
    raise value.error(message)


def _int(value: ConfigValue, what: str, low: int, high: int) -> int:
    number = value.as_int(what)
    if not low <= number <= high:
        _fail(value, f"{what}: {number} is outside {low}..{high}")
    return number


def _positive(value: ConfigValue, what: str, *, zero: bool = False) -> float:
    number = value.as_float(what)
    if number < 0 or (number == 0 and not zero):
        _fail(value, f"{what}: must be {'>= 0' if zero else '> 0'}, not {number:g}")
    return number


def _int_key(mapping: ConfigMapping, key: str, what: str, low: int, high: int) -> int:
    """A mapping's key written as an integer (``250: 2250000``)."""
    located = mapping.key_of(key)
    try:
        number = int(key, 10)
    except ValueError:
        _fail(located, f"{what}: {key!r} is not an integer")
    if not low <= number <= high:
        _fail(located, f"{what}: {number} is outside {low}..{high}")
    return number


def _range_of(value: ConfigValue, what: str, size: int, signed: bool) -> tuple[int, int]:
    items = value.as_list(what)
    if len(items) != 2:
        _fail(value, f"{what}: must be [minimum, maximum], not {len(items)} values")
    low, high = (item.as_int(what) for item in items)
    if low > high:
        _fail(value, f"{what}: minimum {low} is above maximum {high}")
    bits = 8 * size
    lowest, highest = ((-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if signed
                       else (0, (1 << bits) - 1))
    if low < lowest or high > highest:
        kind = "signed" if signed else "unsigned"
        _fail(value, f"{what}: [{low}, {high}] does not fit {size} {kind} "
              f"byte{'s' if size > 1 else ''} ({lowest}..{highest})")
    return low, high


def _register(name: str, value: ConfigValue, area: Area, protocol: int,
              units: Mapping[str, str]) -> Register:
    what = f"register {name!r}"
    if not _REGISTER_NAME.match(name):
        _fail(value, f"{what}: a register name is lower case letters, digits and '_' "
              "(the e-Manual's name in snake case, e.g. goal_position)")
    row = value.as_mapping(what)
    row.check_keys(_REGISTER_KEYS, required=("address", "size", "access"), what=what)
    top = 255 if protocol == 1 else 65535
    address = _int(row.require("address"), f"{what}: address", 0, top)
    size_value = row.require("size")
    size = size_value.as_int(f"{what}: size")
    if size not in (1, 2, 4):
        _fail(size_value, f"{what}: size must be 1, 2 or 4 bytes, not {size}")
    if address + size > top + 1:
        _fail(size_value, f"{what}: {size} bytes at {address} run past the last address "
              f"of protocol {protocol}.0 ({top})")
    access_value = row.require("access")
    access: Access
    text = access_value.as_str(f"{what}: access")
    if text == "R":
        access = "R"
    elif text == "RW":
        access = "RW"
    else:
        _fail(access_value, f"{what}: access must be R or RW, not {text!r}")
    signed = False
    if (signed_value := row.get("signed")) is not None:
        signed = signed_value.as_bool(f"{what}: signed")
    unit = "raw"
    if (unit_value := row.get("unit")) is not None:
        unit = unit_value.as_str(f"{what}: unit")
        if unit not in units:
            from ..configfile import suggest

            close = suggest(unit, units)
            _fail(unit_value, f"{what}: unknown unit {unit!r}"
                  + (f" (did you mean {close!r}?)" if close else "")
                  + f"; units: {', '.join(units)}")
    minimum, maximum = 0, None
    if (range_value := row.get("range")) is not None:
        minimum, maximum = _range_of(range_value, f"{what}: range", size, signed)
    reg = Register(name, address, size, area, access, None, minimum, maximum, unit, signed)
    default_value = row.get("default")
    if default_value is not None and default_value.plain() is not None:
        default = default_value.as_int(f"{what}: default")
        if not reg.raw_min <= default <= reg.raw_max:
            _fail(default_value, f"{what}: default {default} is outside its range "
                  f"{reg.raw_min}..{reg.raw_max} (the motor would refuse its own value)")
        reg = Register(name, address, size, area, access, default, minimum, maximum, unit,
                       signed)
    return reg


def _indirect_rows(value: ConfigValue) -> list[tuple[Register, ConfigValue]]:
    """The rows an ``indirect:`` block stands for: Indirect Address n (2 bytes, initial the
    address of Indirect Data n) and Indirect Data n (1 byte, 0..255, initial 0)."""
    rows: list[tuple[Register, ConfigValue]] = []
    for index, item in enumerate(value.as_list("indirect")):
        what = f"indirect[{index}]"
        block = item.as_mapping(what)
        block.check_keys(_INDIRECT_KEYS, required=_INDIRECT_KEYS, what=what)
        first = _int(block.require("first"), f"{what}: first", 1, 10_000)
        count = _int(block.require("count"), f"{what}: count", 1, 10_000)
        address = _int(block.require("address"), f"{what}: address", 0, 65535)
        data = _int(block.require("data"), f"{what}: data", 0, 65535)
        low, high = _range_of(block.require("range"), f"{what}: range", 2, False)
        for k in range(count):
            n = first + k
            rows.append((Register(f"indirect_address_{n}", address + 2 * k, 2, "RAM", "RW",
                                  data + k, low, high), item))
            rows.append((Register(f"indirect_data_{n}", data + k, 1, "RAM", "RW", 0, 0, 255),
                         item))
    return rows


def _baud(value: ConfigValue, protocol: int) -> tuple[tuple[tuple[int, int], ...], int]:
    spec = value.as_mapping("baud_rate")
    spec.check_keys(("divisor", "special", "table"), what="baud_rate")
    if ("table" in spec) == ("divisor" in spec):
        _fail(spec, "baud_rate: give either 'table' (register value: bps) or 'divisor' "
              "(bps = divisor // (value + 1), Protocol 1.0), not both")
    if "special" in spec and "divisor" not in spec:
        _fail(spec.key_of("special"), "baud_rate: 'special' goes with 'divisor'")
    divisor = 0
    if (divisor_value := spec.get("divisor")) is not None:
        divisor = _int(divisor_value, "baud_rate: divisor", 1, 100_000_000)
    entries: list[tuple[int, int]] = []
    for key in ("table", "special"):
        if (table_value := spec.get(key)) is None:
            continue
        table = table_value.as_mapping(f"baud_rate: {key}")
        for text, bps in table.items():
            number = _int_key(table, text, f"baud_rate: {key}", 0, 255)
            entries.append((number, _int(bps, f"baud_rate: {key}: {number}", 1, 100_000_000)))
    if "table" in spec and not entries:
        _fail(spec.require("table"), "baud_rate: the table is empty")
    return tuple(sorted(entries)), divisor


def _read(path: str | Path) -> tuple[Model, ConfigValue, ConfigValue]:
    """Read and check one model file: (model, its ``name`` value, its ``number`` value)."""
    from ..configfile import load
    from . import protocol1, protocol2
    from .units import KINDS

    root = load(path, what="Dynamixel model file", error=ModelFileError)
    top = root.as_mapping("a Dynamixel model file")
    if "servolab_model" not in top:
        _fail(top, "not a Dynamixel model file: it has no 'servolab_model: 1' "
              "(docs/dynamixel.md, \"Adding a model\")")
    top.check_keys(_TOP_KEYS, required=_REQUIRED_TOP)
    version = top.require("servolab_model")
    if version.as_int("servolab_model") != FORMAT_VERSION:
        _fail(version, f"servolab_model: format {version.plain()!r} is not one this servolab "
              f"reads ({FORMAT_VERSION})")
    name_value = top.require("name")
    name = name_value.as_str("name", nonempty=True)
    if not _NAME.match(name):
        _fail(name_value, f"name: {name!r} may hold letters, digits and + - _ . ( ) only "
              "(it is typed on command lines: rx28:1-4)")
    number_value = top.require("number")
    number = _int(number_value, "number", 0, 65535)
    protocol_value = top.require("protocol")
    protocol = protocol_value.as_int("protocol")
    if protocol not in (1, 2):
        _fail(protocol_value, f"protocol: must be 1 or 2, not {protocol}")
    source = ""
    if (source_value := top.get("source")) is not None:
        source = source_value.as_str("source")
    firmware = 0
    if (firmware_value := top.get("firmware")) is not None:
        firmware = _int(firmware_value, "firmware", 0, 255)
    known = protocol1.INSTRUCTIONS if protocol == 1 else protocol2.INSTRUCTIONS
    instructions = set()
    for item in top.require("instructions").as_list("instructions"):
        instruction = item.as_str("instructions")
        if instruction not in known:
            _fail(item, f"instructions: {instruction!r} is no Protocol {protocol}.0 "
                  f"instruction; they are: {', '.join(known)}")
        instructions.add(instruction)
    for needed in ("PING", "READ", "WRITE"):
        if needed not in instructions:
            _fail(top.require("instructions"), f"instructions: {needed} is missing (every "
                  "Dynamixel answers PING, READ and WRITE)")

    physical_value = top.require("physical")
    physical = physical_value.as_mapping("physical")
    physical.check_keys(_PHYSICAL_KEYS, required=_REQUIRED_PHYSICAL, what="physical")
    figures: dict[str, object] = {}
    for key, item in physical.items():
        what = f"physical: {key}"
        if key == "resolution":
            figures[key] = _int(item, what, 2, 1 << 24)
        elif key == "position_center":
            figures[key] = item.as_int(what)
        elif key in ("multi_turn", "wheel_output_ratio"):
            figures[key] = item.as_bool(what)
        elif key == "wheel_position":
            text = item.as_str(what)
            if text not in _WHEEL_POSITIONS:
                _fail(item, f"{what}: must be one of {', '.join(_WHEEL_POSITIONS)}, not "
                      f"{text!r}")
            figures[key] = text
        elif key == "angle_range_deg":
            degrees = _positive(item, what)
            if degrees > 360:
                _fail(item, f"{what}: {degrees:g} is more than a turn")
            figures[key] = degrees
        else:
            figures[key] = _positive(item, what, zero=key in (
                "current_unit_a", "stall_torque_nm", "stall_current_a"))
    resolution = figures["resolution"]
    assert isinstance(resolution, int)
    center = physical.require("position_center")
    if not 0 <= center.as_int() < resolution:
        _fail(center, f"physical: position_center: {center.as_int()} is not a tick of "
              f"0..{resolution - 1}")

    baud_table, baud_divisor = _baud(top.require("baud_rate"), protocol)

    registers: list[tuple[Register, ConfigValue]] = []
    areas: tuple[tuple[Area, str], ...] = (("EEPROM", "eeprom"), ("RAM", "ram"))
    for area, key in areas:
        table = top.require(key).as_mapping(key)
        registers += [(_register(reg_name, item, area, protocol, KINDS),
                       table.key_of(reg_name)) for reg_name, item in table.items()]
    if (indirect := top.get("indirect")) is not None:
        registers += _indirect_rows(indirect)
    _check_table(registers, top, name, number, protocol)
    by_name = {reg.name: reg for reg, _ in registers}

    modes: tuple[int, ...] = ()
    modes_value = top.get("operating_modes")
    if modes_value is not None:
        if "operating_mode" not in by_name:
            _fail(modes_value, "operating_modes: the model has no operating_mode register")
        values = []
        for item in modes_value.as_list("operating_modes"):
            mode = item.as_str("operating_modes")
            if mode not in OPERATING_MODES:
                _fail(item, f"operating_modes: unknown mode {mode!r}; the modes are "
                      f"{', '.join(OPERATING_MODES)}")
            values.append(OPERATING_MODES[mode])
        reg = by_name["operating_mode"]
        outside = [v for v in values if not reg.raw_min <= v <= reg.raw_max]
        if outside:
            _fail(modes_value, f"operating_modes: {outside[0]} is outside operating_mode's "
                  f"range {reg.raw_min}..{reg.raw_max}")
        modes = tuple(sorted(set(values)))
    elif "operating_mode" in by_name:
        _fail(top, "the model has an operating_mode register: list the modes it takes "
              "(operating_modes: [velocity, position, ...])")

    hardware: list[tuple[int, str]] = []
    if (hardware_value := top.get("hardware_errors")) is not None:
        if protocol != 2 or "hardware_error_status" not in by_name:
            _fail(hardware_value, "hardware_errors: name the bits of a Protocol 2.0 model's "
                  "hardware_error_status register")
        bits = hardware_value.as_mapping("hardware_errors")
        for text, item in bits.items():
            bit = _int_key(bits, text, "hardware_errors", 0, 7)
            error = item.as_str(f"hardware_errors: {bit}")
            if error not in HARDWARE_ERROR_NAMES:
                _fail(item, f"hardware_errors: {error!r} is not one of "
                      f"{', '.join(HARDWARE_ERROR_NAMES)}")
            hardware.append((1 << bit, error))

    model = Model(
        name=name, number=number, protocol=protocol,
        registers=tuple(sorted((reg for reg, _ in registers), key=lambda r: r.address)),
        firmware=firmware, instruction_set=frozenset(instructions), operating_modes=modes,
        baud_table=baud_table, baud_divisor=baud_divisor, hardware_errors=tuple(sorted(hardware)),
        source=source, path=str(path),
        **figures)  # type: ignore[arg-type]
    _check_baud(model, by_name["baud_rate"], registers, top)
    return model, name_value, number_value


def _check_table(registers: list[tuple[Register, ConfigValue]], top: ConfigMapping, name: str,
                 number: int, protocol: int) -> None:
    """Names once, no two registers sharing a byte, the registers servolab relies on there,
    and the model number where PING finds it."""
    seen: dict[str, ConfigValue] = {}
    for reg, where in registers:
        if reg.name in seen:
            _fail(where, f"register {reg.name!r} is defined twice (first on line "
                  f"{seen[reg.name].line})")
        seen[reg.name] = where
    ordered = sorted(registers, key=lambda pair: pair[0].address)
    for (a, _), (b, where) in itertools.pairwise(ordered):
        if a.address + a.size > b.address:
            _fail(where, f"register {b.name!r} (address {b.address}) overlaps {a.name!r} "
                  f"({a.size} bytes at {a.address}, line {seen[a.name].line})")
    missing = [n for n in REQUIRED_REGISTERS if n not in seen]
    if missing:
        _fail(top, f"model {name!r} has no register {missing[0]!r} (servolab needs: "
              f"{', '.join(REQUIRED_REGISTERS)})")
    by_name = {reg.name: reg for reg, _ in registers}
    mn = by_name["model_number"]
    if (mn.address, mn.size, mn.default) != (0, 2, number):
        _fail(seen["model_number"], f"model_number must be 2 bytes at address 0 with default "
              f"{number} (the model number PING reports)")
    ident = by_name["id"]
    top_id = 253 if protocol == 1 else 252
    if ident.raw_max > top_id:
        _fail(seen["id"], f"register 'id': Protocol {protocol}.0 IDs end at {top_id}, not "
              f"{ident.raw_max}")
    for reg, where in registers:
        if reg.name.startswith("indirect_data_"):
            partner = "indirect_address_" + reg.name[len("indirect_data_"):]
            if partner not in by_name:
                _fail(where, f"register {reg.name!r} has no {partner!r}")


def _check_baud(model: Model, reg: Register, registers: list[tuple[Register, ConfigValue]],
                top: ConfigMapping) -> None:
    where = next(w for r, w in registers if r is reg)
    if reg.unit != "baud":
        _fail(where, "register 'baud_rate': its unit must be baud")
    for value in range(reg.raw_min, reg.raw_max + 1):
        try:
            model.baud_from_register(value)
        except ConfigError:
            _fail(top.key_of("baud_rate"), f"baud_rate: register value {value} (in the "
                  f"register's range {reg.raw_min}..{reg.raw_max}) has no rate")


# -- the registry ------------------------------------------------------------------------------

_SECOND_FIRMWARE = re.compile(r"(\(2(\.0)?\)|[-_ ]2(\.0)?)\Z")


def _key(name: str) -> str:
    """A model name as lookups compare it: case, separators and the spelling of the 2.0
    firmware forgiven (``rx28`` = ``RX-28``; ``ex106plus`` = ``EX-106+``; ``mx-28-2``,
    ``mx28(2.0)`` and ``MX_28_2.0`` = ``MX-28(2.0)``)."""
    text = name.strip().upper().replace("PLUS", "+")
    text = _SECOND_FIRMWARE.sub("/2", text)
    return re.sub(r"[-_ ().]", "", text)


_HINT_NAME = re.compile(r"^name:[ \t]*([^\s#]+)[ \t]*(?:#.*)?$", re.MULTILINE)
_HINT_NUMBER = re.compile(r"^number:[ \t]*(\d+)[ \t]*(?:#.*)?$", re.MULTILINE)


@dataclass
class _Entry:
    """A model file: its name and number (from the index until it is read) and its model."""

    path: Path
    name: str
    number: int
    model: Model | None = None


def _add(entries: list[_Entry], entry: _Entry, name_value: ConfigValue | None,
         number_value: ConfigValue | None) -> None:
    """Add ``entry`` unless its name or number is taken (the error at its ``name`` or
    ``number`` line where the file was read, else naming the file)."""
    for other in entries:
        if _key(other.name) == _key(entry.name):
            message = f"model name {entry.name!r} is taken: {other.path} defines {other.name!r}"
            if name_value is not None:
                _fail(name_value, message)
            raise ModelFileError(entry.path, 0, "name", message)
        if other.number == entry.number:
            message = f"model number {entry.number} is {other.name}'s ({other.path})"
            if number_value is not None:
                _fail(number_value, message)
            raise ModelFileError(entry.path, 0, "number", message)
    entries.append(entry)


#: Files or directories (of ``*.yaml``) of a lab's own models that every servolab command
#: knows, separated as in PATH (``os.pathsep``).
MODEL_PATH_VARIABLE = "SERVOLAB_MODEL_PATH"


def _environment_files() -> list[Path]:
    """The model files :data:`MODEL_PATH_VARIABLE` names."""
    import os

    files: list[Path] = []
    for part in os.environ.get(MODEL_PATH_VARIABLE, "").split(os.pathsep):
        if not part.strip():
            continue
        path = Path(part).expanduser().resolve()
        if path.is_dir():
            files += sorted(path.glob("*.yaml"))
        elif path.is_file():
            files.append(path)
        else:
            raise ModelFileError(path, 0, "", f"{MODEL_PATH_VARIABLE} names {part!r}, which "
                                 "is no model file or directory")
    return files


class _Registry:
    """The known models: the shipped files (indexed on first use, each read when first
    needed) and those :func:`register_model` added."""

    def __init__(self, directory: Path) -> None:
        self._directory = directory
        self._lock = threading.RLock()
        self._entries: list[_Entry] | None = None

    def entries(self) -> list[_Entry]:
        with self._lock:
            if self._entries is None:
                entries: list[_Entry] = []
                for path in sorted(self._directory.glob("*.yaml"), key=lambda p: _key(p.stem)):
                    _add(entries, self._index(path), None, None)
                for path in _environment_files():
                    model, name_value, number_value = _read(path)
                    _add(entries, _Entry(path, model.name, model.number, model), name_value,
                         number_value)
                self._entries = entries
            return self._entries

    @staticmethod
    def _index(path: Path) -> _Entry:
        """The name and number of a file, from its top-level ``name:`` and ``number:`` lines
        (the whole file is read where they are not plain)."""
        text = path.read_text(encoding="utf-8")
        name, number = _HINT_NAME.search(text), _HINT_NUMBER.search(text)
        if name and number:
            return _Entry(path, name.group(1), int(number.group(1)))
        model, _, _ = _read(path)
        return _Entry(path, model.name, model.number, model)

    def load(self, entry: _Entry) -> Model:
        with self._lock:
            if entry.model is None:
                model, name_value, _ = _read(entry.path)
                if model.name != entry.name or model.number != entry.number:
                    _fail(name_value, f"the index took this file for {entry.name!r} (number "
                          f"{entry.number}); it defines {model.name!r} ({model.number}): "
                          "write 'name:' and 'number:' as plain top-level lines")
                entry.model = model
            return entry.model

    def find(self, name: str) -> _Entry | None:
        wanted = _key(name)
        return next((e for e in self.entries() if _key(e.name) == wanted), None)

    def exact(self, name: str) -> _Entry | None:
        return next((e for e in self.entries() if e.name == name), None)

    def numbered(self, number: int) -> _Entry | None:
        return next((e for e in self.entries() if e.number == number), None)

    def register(self, path: Path) -> Model:
        model, name_value, number_value = _read(path)
        with self._lock:
            entries = self.entries()
            same = next((e for e in entries if e.path == path), None)
            if same is not None and self.load(same) == model:
                return self.load(same)  # the same file again: nothing new
            _add(entries, _Entry(path, model.name, model.number, model), name_value,
                 number_value)
            return model

    def forget(self, name: str) -> None:
        """Drop a model :func:`register_model` added (for tests)."""
        with self._lock:
            entry = self.exact(name)
            if entry is None or entry.path.parent == self._directory:
                raise ConfigError(f"{name!r} is no registered model file")
            self.entries().remove(entry)


_REGISTRY = _Registry(TABLES_DIR)


class _Models(Mapping[str, Model]):
    """Every known model by name; a shipped file is read when its value is first asked for."""

    def __getitem__(self, name: str) -> Model:
        entry = _REGISTRY.exact(name)
        if entry is None:
            raise KeyError(name)
        return _REGISTRY.load(entry)

    def __iter__(self) -> Iterator[str]:
        return iter([e.name for e in _REGISTRY.entries()])

    def __len__(self) -> int:
        return len(_REGISTRY.entries())

    def __repr__(self) -> str:
        return f"<Dynamixel models: {', '.join(self)}>"


class _ByNumber(Mapping[int, Model]):
    """Every known model by the number PING reports."""

    def __getitem__(self, number: int) -> Model:
        entry = _REGISTRY.numbered(number)
        if entry is None:
            raise KeyError(number)
        return _REGISTRY.load(entry)

    def __iter__(self) -> Iterator[int]:
        return iter([e.number for e in _REGISTRY.entries()])

    def __len__(self) -> int:
        return len(_REGISTRY.entries())


class _AllowedModes(Mapping[str, tuple[int, ...]]):
    """The operating modes each model takes, by model name (models without an
    operating_mode register are not in it)."""

    def __getitem__(self, name: str) -> tuple[int, ...]:
        modes = MODELS[name].operating_modes
        if not modes:
            raise KeyError(name)
        return modes

    def __iter__(self) -> Iterator[str]:
        return iter([name for name, m in MODELS.items() if m.operating_modes])

    def __len__(self) -> int:
        return sum(1 for _ in self)


#: Every model servolab knows, by name: the shipped ones and those :func:`register_model`
#: added (a read-only mapping; a file is read when its model is first looked at).
MODELS: Mapping[str, Model] = _Models()
#: The same models by the number PING reports.
BY_NUMBER: Mapping[int, Model] = _ByNumber()
#: Operating modes each model accepts (the register's range is only their hull).
ALLOWED_MODES: Mapping[str, tuple[int, ...]] = _AllowedModes()


def model(name: str) -> Model:
    """Look a model up by name, forgiving case and separators: ``rx28``, ``RX-28``,
    ``ex106+``, ``xm430-w210`` all work, and ``mx28-2`` or ``mx28(2.0)`` for the 2.0
    firmware of an MX (``MX-28(2.0)``)."""
    entry = _REGISTRY.find(name)
    if entry is None:
        from ..configfile import suggest

        names = [e.name for e in _REGISTRY.entries()]
        close = suggest(name, names) or suggest(_key(name), {_key(n): n for n in names})
        hint = ""
        if close:
            hint = f" (did you mean {next((n for n in names if _key(n) == close), close)!r}?)"
        raise ConfigError(f"unknown Dynamixel model {name!r}{hint}; known models: "
                          f"{', '.join(names)}")
    return _REGISTRY.load(entry)


def model_by_number(number: int) -> Model | None:
    """The model whose PING reports ``number``, or None if servolab does not know it."""
    entry = _REGISTRY.numbered(number)
    return _REGISTRY.load(entry) if entry is not None else None


def load_model(path: str | Path) -> Model:
    """Read and check a model file without adding it to the known models (to try one out);
    a :class:`ModelFileError` (``path:line: message``) if anything in it is wrong."""
    return _read(Path(path))[0]


def register_model(path: str | Path) -> Model:
    """Read a lab's own model file (the format of the shipped ones, docs/dynamixel.md "Adding a
    model") and add it to the known models: :func:`model`, :func:`model_by_number`, the
    emulator, ``servolab`` commands run in this process and the :class:`~.bus.Bus` know it from
    now on. A :class:`ModelFileError` naming the file and line if a value is wrong, or if its
    name or model number is already taken (registering the same file twice is no clash).

    For every ``servolab`` command to know a lab's models, name their files (or directories
    of them) in the environment variable ``SERVOLAB_MODEL_PATH`` instead."""
    return _REGISTRY.register(Path(path).resolve())


# The constants of the six models servolab started with, read on first use.
_CONSTANTS = {"RX_28": "RX-28", "EX_106P": "EX-106+", "MX_28": "MX-28",
              "XM430_W210": "XM430-W210", "XM430_W350": "XM430-W350",
              "XL430_W250": "XL430-W250"}

if TYPE_CHECKING:
    RX_28: Model
    EX_106P: Model
    MX_28: Model
    XM430_W210: Model
    XM430_W350: Model
    XL430_W250: Model


def __getattr__(name: str) -> Model:
    if name in _CONSTANTS:
        return model(_CONSTANTS[name])
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
