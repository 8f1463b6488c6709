"""Control tables of Dynamixel models, as data.

A :class:`Model` is everything servolab knows about one servo type: its model number as PING
reports it, its protocol, its control table (address, size, EEPROM/RAM, access, default, range,
unit) and the physical figures the emulator and the unit conversions need. Driver, emulator and
CLI all read these tables; none of them hard-codes an address.

Figures come from the ROBOTIS e-Manual pages of each model. Defaults are the factory values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from .errors import ConfigError

Area = Literal["EEPROM", "RAM"]
Access = Literal["R", "RW"]


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
    wheel_position: Literal["potentiometer", "encoder16", "turn"] = "turn"
    acceleration_unit_rpm2: float = 214.577
    firmware: int = 0
    #: instruction names the model answers; others get an instruction error
    instruction_set: frozenset[str] = frozenset()
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
    @property
    def rad_per_tick(self) -> float:
        if self.multi_turn or self.angle_range_deg >= 360.0:
            return 2.0 * math.pi / self.resolution
        return math.radians(self.angle_range_deg) / (self.resolution - 1)

    @property
    def no_load_speed(self) -> float:
        """No-load speed in rad/s at the nominal voltage."""
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0

    # -- baud rate register --------------------------------------------------------------
    def baud_from_register(self, value: int) -> int:
        """Bits per second that a value of the baud-rate register selects."""
        if self.protocol == 1:
            special = {250: 2_250_000, 251: 2_500_000, 252: 3_000_000}
            if self.name.startswith("MX") and value in special:
                return special[value]
            return 2_000_000 // (value + 1)  # ROBOTIS truncates: 34 -> 57142
        try:
            return X_SERIES_BAUDS[value]
        except KeyError:
            raise ConfigError(f"{self.name}: baud_rate register value {value} is not defined; "
                              f"use one of {sorted(X_SERIES_BAUDS)}") from None

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


_V1_BASIC = frozenset({"PING", "READ", "WRITE", "REG_WRITE", "ACTION", "RESET", "SYNC_WRITE"})
_V1_MX = _V1_BASIC | {"BULK_READ"}
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
_V2_X = frozenset({"PING", "READ", "WRITE", "REG_WRITE", "ACTION", "FACTORY_RESET", "REBOOT",
                   "CLEAR", "SYNC_READ", "SYNC_WRITE", "BULK_READ", "BULK_WRITE"}) | FAST_READS

X_SERIES_BAUDS: dict[int, int] = {
    0: 9_600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000,
    5: 3_000_000, 6: 4_000_000, 7: 4_500_000,
}

#: Operating modes of the X-series (register ``operating_mode``).
OPERATING_MODES: dict[str, int] = {
    "current": 0, "velocity": 1, "position": 3, "extended_position": 4,
    "current_based_position": 5, "pwm": 16,
}


def R(name: str, address: int, size: int, area: Area, access: Access, default: int | None = None,
      minimum: int = 0, maximum: int | None = None, unit: str = "raw",
      signed: bool = False) -> Register:
    return Register(name, address, size, area, access, default, minimum, maximum, unit, signed)


def _protocol1_table(*, number: int, max_tick: int, model_regs: list[Register],
                     extra: list[Register], temperature_limit: int = 80,
                     max_voltage: int = 190, voltage_top: int = 250, punch: int = 32,
                     punch_min: int = 32, speed_max: int = 2047,
                     multi_turn: int = 0) -> tuple[Register, ...]:
    """The control table shared by the 1.0 servos (AX/RX/EX/MX), plus model-specific rows.

    ``voltage_top`` is the top of the voltage limits' range (RX/EX 250, MX 160); ``punch`` and
    ``punch_min`` the punch default and lowest value (the e-Manual's range is 0x20..0x3FF, but
    MX-28 and EX-106+ ship with punch 0, which therefore has to stay writable). A nonzero
    ``multi_turn`` makes goal and present position signed, goals -multi_turn..multi_turn (the
    hull of joint mode's 0..max_tick and multi-turn mode's range; the angle limits keep a joint
    mode goal within 0..max_tick)."""
    goal_min, goal_max = (-multi_turn, multi_turn) if multi_turn else (0, max_tick)
    rows = [
        R("model_number", 0, 2, "EEPROM", "R", number),
        R("firmware_version", 2, 1, "EEPROM", "R", None),
        R("id", 3, 1, "EEPROM", "RW", 1, 0, 253),
        R("baud_rate", 4, 1, "EEPROM", "RW", 34, 0, 254, unit="baud"),
        R("return_delay_time", 5, 1, "EEPROM", "RW", 250, 0, 254, unit="delay_2us"),
        R("cw_angle_limit", 6, 2, "EEPROM", "RW", 0, 0, max_tick, unit="position"),
        R("ccw_angle_limit", 8, 2, "EEPROM", "RW", max_tick, 0, max_tick, unit="position"),
        R("temperature_limit", 11, 1, "EEPROM", "RW", temperature_limit, 0, 100,
          unit="temperature"),
        R("min_voltage_limit", 12, 1, "EEPROM", "RW", 60, 50, voltage_top, unit="voltage"),
        R("max_voltage_limit", 13, 1, "EEPROM", "RW", max_voltage, 50, voltage_top,
          unit="voltage"),
        R("max_torque", 14, 2, "EEPROM", "RW", 1023, 0, 1023, unit="torque_ratio"),
        R("status_return_level", 16, 1, "EEPROM", "RW", 2, 0, 2),
        R("alarm_led", 17, 1, "EEPROM", "RW", 36, 0, 127),
        R("shutdown", 18, 1, "EEPROM", "RW", 36, 0, 127),
        R("torque_enable", 24, 1, "RAM", "RW", 0, 0, 1, unit="bool"),
        R("led", 25, 1, "RAM", "RW", 0, 0, 1, unit="bool"),
        R("goal_position", 30, 2, "RAM", "RW", None, goal_min, goal_max, unit="position",
          signed=bool(multi_turn)),
        R("moving_speed", 32, 2, "RAM", "RW", None, 0, speed_max, unit="speed_sign_bit"),
        # Initial value "ADD 14&15" / "Max Torque": Max Torque's default, 1023.
        R("torque_limit", 34, 2, "RAM", "RW", 1023, 0, 1023, unit="torque_ratio"),
        R("present_position", 36, 2, "RAM", "R", None, unit="position",
          signed=bool(multi_turn)),
        R("present_speed", 38, 2, "RAM", "R", None, 0, 2047, unit="speed_sign_bit"),
        R("present_load", 40, 2, "RAM", "R", None, 0, 2047, unit="load_sign_bit"),
        R("present_voltage", 42, 1, "RAM", "R", None, unit="voltage"),
        R("present_temperature", 43, 1, "RAM", "R", None, unit="temperature"),
        R("registered", 44, 1, "RAM", "R", 0, 0, 1, unit="bool"),
        R("moving", 46, 1, "RAM", "R", 0, 0, 1, unit="bool"),
        R("lock", 47, 1, "RAM", "RW", 0, 0, 1, unit="bool"),
        R("punch", 48, 2, "RAM", "RW", punch, punch_min, 1023),
    ]
    return tuple(sorted(rows + model_regs + extra, key=lambda r: r.address))


#: RX-28 and EX-106+ control tables: compliance margin 1 and slope 32 in each direction; the
#: margin takes 0..255, the slope 0..254 in seven steps (e-Manual, Compliance Margin/Slope).
_COMPLIANCE = [
    R("cw_compliance_margin", 26, 1, "RAM", "RW", 1, 0, 255),
    R("ccw_compliance_margin", 27, 1, "RAM", "RW", 1, 0, 255),
    R("cw_compliance_slope", 28, 1, "RAM", "RW", 32, 0, 254),
    R("ccw_compliance_slope", 29, 1, "RAM", "RW", 32, 0, 254),
]

RX_28 = Model(
    name="RX-28", number=28, protocol=1, firmware=30, instruction_set=_V1_BASIC,
    registers=_protocol1_table(number=28, max_tick=1023, model_regs=_COMPLIANCE, extra=[]),
    resolution=1024, angle_range_deg=300.0, position_center=512,
    # e-Manual RX-28 Specifications: No Load Speed 85 rpm (at 18.5 V).
    speed_unit_rpm=0.111, no_load_speed_rpm=85.0, nominal_voltage=18.5,
    # e-Manual RX-28 Moving Speed (wheel mode: 0.1 % output) and Present Position (a
    # potentiometer; "cannot be used to measure the moving distance" in wheel mode).
    wheel_output_ratio=True, wheel_position="potentiometer",
)

EX_106P = Model(
    name="EX-106+", number=107, protocol=1, firmware=30, instruction_set=_V1_BASIC,
    registers=_protocol1_table(
        number=107, max_tick=4095, model_regs=_COMPLIANCE,
        extra=[R("drive_mode", 10, 1, "EEPROM", "RW", 0, 0, 3),
               # 512 means 0 mA, 10 mA a unit either side; the e-Manual gives no initial value.
               R("sensed_current", 56, 2, "RAM", "R", None, 0, 1023)],
        max_voltage=240, punch=0, punch_min=0),
    resolution=4096, angle_range_deg=250.92, position_center=2048,
    speed_unit_rpm=0.111, no_load_speed_rpm=91.0, nominal_voltage=18.5,
    # e-Manual EX-106+: Stall Torque 10.9 N*m at 18.5 V, 7 A; wheel mode Moving Speed is the
    # output ratio, and Present Position the encoder count 0..65535.
    stall_current_a=7.0, wheel_output_ratio=True, wheel_position="encoder16",
)

MX_28 = Model(
    # Firmware 40: the first with Realtime Tick(50) (e-Manual MX-28, Realtime Tick).
    name="MX-28", number=29, protocol=1, firmware=40, instruction_set=_V1_MX,
    registers=_protocol1_table(
        number=29, max_tick=4095,
        model_regs=[R("d_gain", 26, 1, "RAM", "RW", 0, 0, 254),
                    R("i_gain", 27, 1, "RAM", "RW", 0, 0, 254),
                    R("p_gain", 28, 1, "RAM", "RW", 32, 0, 254)],
        extra=[R("multi_turn_offset", 20, 2, "EEPROM", "RW", 0, -24576, 24576,
                 unit="position_offset", signed=True),
               R("resolution_divider", 22, 1, "EEPROM", "RW", 1, 1, 4),
               # 1 ms a count, back to 0 after 32767.
               R("realtime_tick", 50, 2, "RAM", "R", 0, 0, 32767),
               R("goal_acceleration", 73, 1, "RAM", "RW", 0, 0, 254)],
        # Multi-turn mode (both angle limits 4095): positions -28,672..28,672.
        max_voltage=160, voltage_top=160, punch=0, punch_min=0, multi_turn=28672),
    resolution=4096, angle_range_deg=360.0, position_center=2048,
    speed_unit_rpm=0.114, no_load_speed_rpm=55.0, nominal_voltage=12.0,
)


def _indirect_rows() -> list[Register]:
    """Indirect Address 1..56 (2 bytes, 64..661, by default pointing at their own Indirect
    Data) and Indirect Data 1..56 (1 byte): 1..28 at 168/224, 29..56 at 578/634."""
    rows = []
    for n in range(1, 57):
        k, address, data = (n - 1, 168, 224) if n <= 28 else (n - 29, 578, 634)
        rows += [R(f"indirect_address_{n}", address + 2 * k, 2, "RAM", "RW", data + k, 64, 661),
                 R(f"indirect_data_{n}", data + k, 1, "RAM", "RW", 0, 0, 255)]
    return rows


def _x_series_table(*, number: int, velocity_limit: int, has_current: bool,
                    temperature_limit: int, max_voltage: int, min_voltage: int,
                    position_p: int, position_d: int, velocity_i: int) -> tuple[Register, ...]:
    rows = [
        R("model_number", 0, 2, "EEPROM", "R", number),
        R("model_information", 2, 4, "EEPROM", "R", None),
        R("firmware_version", 6, 1, "EEPROM", "R", None),
        R("id", 7, 1, "EEPROM", "RW", 1, 0, 252),
        R("baud_rate", 8, 1, "EEPROM", "RW", 1, 0, 7, unit="baud"),
        R("return_delay_time", 9, 1, "EEPROM", "RW", 250, 0, 254, unit="delay_2us"),
        # Bits 0 (reverse), 2 (time-based profile) and 3 (torque on by goal update, V45).
        R("drive_mode", 10, 1, "EEPROM", "RW", 0, 0, 13),
        R("operating_mode", 11, 1, "EEPROM", "RW", 3, 0, 16),
        # 0..252 a secondary ID, 253..255 none (the default, 255).
        R("secondary_id", 12, 1, "EEPROM", "RW", 255, 0, 255),
        R("protocol_type", 13, 1, "EEPROM", "RW", 2, 1, 2),
        R("homing_offset", 20, 4, "EEPROM", "RW", 0, -1_044_479, 1_044_479,
          unit="position_offset", signed=True),
        R("moving_threshold", 24, 4, "EEPROM", "RW", 10, 0, 1023, unit="velocity"),
        R("temperature_limit", 31, 1, "EEPROM", "RW", temperature_limit, 0, 100,
          unit="temperature"),
        R("max_voltage_limit", 32, 2, "EEPROM", "RW", max_voltage, min_voltage, max_voltage,
          unit="voltage"),
        R("min_voltage_limit", 34, 2, "EEPROM", "RW", min_voltage, min_voltage, max_voltage,
          unit="voltage"),
        R("pwm_limit", 36, 2, "EEPROM", "RW", 885, 0, 885, unit="pwm"),
        R("velocity_limit", 44, 4, "EEPROM", "RW", velocity_limit, 0, 1023, unit="velocity"),
        R("max_position_limit", 48, 4, "EEPROM", "RW", 4095, 0, 4095, unit="position"),
        R("min_position_limit", 52, 4, "EEPROM", "RW", 0, 0, 4095, unit="position"),
        # Bit 0 torque on at startup, bit 1 RAM restore (firmware V45).
        R("startup_configuration", 60, 1, "EEPROM", "RW", 0, 0, 3),
        R("shutdown", 63, 1, "EEPROM", "RW", 52, 0, 63),
        R("torque_enable", 64, 1, "RAM", "RW", 0, 0, 1, unit="bool"),
        R("led", 65, 1, "RAM", "RW", 0, 0, 1, unit="bool"),
        R("status_return_level", 68, 1, "RAM", "RW", 2, 0, 2),
        R("registered_instruction", 69, 1, "RAM", "R", 0, 0, 1, unit="bool"),
        R("hardware_error_status", 70, 1, "RAM", "R", 0),
        R("velocity_i_gain", 76, 2, "RAM", "RW", velocity_i, 0, 16383),
        R("velocity_p_gain", 78, 2, "RAM", "RW", 100, 0, 16383),
        R("position_d_gain", 80, 2, "RAM", "RW", position_d, 0, 16383),
        R("position_i_gain", 82, 2, "RAM", "RW", 0, 0, 16383),
        R("position_p_gain", 84, 2, "RAM", "RW", position_p, 0, 16383),
        R("feedforward_2nd_gain", 88, 2, "RAM", "RW", 0, 0, 16383),
        R("feedforward_1st_gain", 90, 2, "RAM", "RW", 0, 0, 16383),
        # A host writes 0 (off, clears the error) or 1..127 (20 ms units); the motor itself
        # sets -1 when the watchdog trips.
        R("bus_watchdog", 98, 1, "RAM", "RW", 0, 0, 127, signed=True),
        R("goal_pwm", 100, 2, "RAM", "RW", None, -885, 885, unit="pwm", signed=True),
        # The e-Manual's range is +-velocity_limit, a register the user may raise to 1023;
        # the motor (and the emulator) answers 'data limit' beyond the current limit.
        R("goal_velocity", 104, 4, "RAM", "RW", None, -1023, 1023, unit="velocity",
          signed=True),
        R("profile_acceleration", 108, 4, "RAM", "RW", 0, 0, 32767, unit="acceleration"),
        R("profile_velocity", 112, 4, "RAM", "RW", 0, 0, 32767, unit="velocity"),
        R("goal_position", 116, 4, "RAM", "RW", None, -1_048_575, 1_048_575,
          unit="position", signed=True),
        # 1 ms a count, back to 0 after 32767.
        R("realtime_tick", 120, 2, "RAM", "R", None, 0, 32767),
        R("moving", 122, 1, "RAM", "R", 0, 0, 1, unit="bool"),
        R("moving_status", 123, 1, "RAM", "R", 0),
        R("present_pwm", 124, 2, "RAM", "R", None, unit="pwm", signed=True),
        R("present_velocity", 128, 4, "RAM", "R", None, unit="velocity", signed=True),
        R("present_position", 132, 4, "RAM", "R", None, unit="position", signed=True),
        R("velocity_trajectory", 136, 4, "RAM", "R", None, unit="velocity", signed=True),
        R("position_trajectory", 140, 4, "RAM", "R", None, unit="position", signed=True),
        R("present_input_voltage", 144, 2, "RAM", "R", None, unit="voltage"),
        R("present_temperature", 146, 1, "RAM", "R", None, unit="temperature"),
        R("backup_ready", 147, 1, "RAM", "R", None, 0, 1, unit="bool"),
        *_indirect_rows(),
    ]
    if has_current:
        rows += [R("current_limit", 38, 2, "EEPROM", "RW", 1193, 0, 1193, unit="current"),
                 R("goal_current", 102, 2, "RAM", "RW", None, -1193, 1193, unit="current",
                   signed=True),
                 R("present_current", 126, 2, "RAM", "R", None, unit="current", signed=True)]
    else:
        rows += [R("present_load", 126, 2, "RAM", "R", None, -1000, 1000, unit="load",
                   signed=True)]
    return tuple(sorted(rows, key=lambda r: r.address))


#: The X models are emulated at firmware 46: every V45 feature (Drive Mode bit 3, Startup
#: Configuration) and the Fast Sync/Bulk Read instructions (see FAST_READ_FIRMWARE).
XM430_W210 = Model(
    name="XM430-W210", number=1030, protocol=2, firmware=46, instruction_set=_V2_X,
    registers=_x_series_table(number=1030, velocity_limit=330, has_current=True,
                              temperature_limit=80, max_voltage=160, min_voltage=95,
                              position_p=800, position_d=0, velocity_i=1920),
    resolution=4096, angle_range_deg=360.0, position_center=2048, multi_turn=True,
    speed_unit_rpm=0.229, no_load_speed_rpm=77.0, nominal_voltage=12.0, current_unit_a=0.00269,
)

XM430_W350 = Model(
    name="XM430-W350", number=1020, protocol=2, firmware=46, instruction_set=_V2_X,
    registers=_x_series_table(number=1020, velocity_limit=200, has_current=True,
                              temperature_limit=80, max_voltage=160, min_voltage=95,
                              position_p=800, position_d=0, velocity_i=1920),
    resolution=4096, angle_range_deg=360.0, position_center=2048, multi_turn=True,
    speed_unit_rpm=0.229, no_load_speed_rpm=46.0, nominal_voltage=12.0, current_unit_a=0.00269,
)

XL430_W250 = Model(
    name="XL430-W250", number=1060, protocol=2, firmware=46, instruction_set=_V2_X,
    registers=_x_series_table(number=1060, velocity_limit=265, has_current=False,
                              temperature_limit=72, max_voltage=140, min_voltage=60,
                              position_p=640, position_d=4000, velocity_i=1000),
    resolution=4096, angle_range_deg=360.0, position_center=2048, multi_turn=True,
    # e-Manual XL430-W250 Specifications: 57 rpm at the recommended 11.1 V (61 rpm at 12 V).
    speed_unit_rpm=0.229, no_load_speed_rpm=57.0, nominal_voltage=11.1,
)

#: Operating modes each X model accepts (the register's range is only their hull).
ALLOWED_MODES: dict[str, tuple[int, ...]] = {
    "XM430-W210": (0, 1, 3, 4, 5, 16),
    "XM430-W350": (0, 1, 3, 4, 5, 16),
    "XL430-W250": (1, 3, 4, 16),
}

MODELS: dict[str, Model] = {
    m.name: m for m in (RX_28, EX_106P, MX_28, XM430_W210, XM430_W350, XL430_W250)}
BY_NUMBER: dict[int, Model] = {m.number: m for m in MODELS.values()}


def supports(model: Model, instruction: str) -> bool:
    """Whether ``model`` (at its firmware) carries out ``instruction`` (a name of
    :data:`.protocol2.INSTRUCTIONS` or :data:`.protocol1.INSTRUCTIONS`)."""
    if instruction in FAST_READS:
        return (instruction in model.instruction_set and model.protocol == 2
                and model.firmware >= FAST_READ_FIRMWARE)
    return instruction in model.instruction_set


def _key(name: str) -> str:
    return name.upper().replace("_", "-").replace("PLUS", "+").replace(" ", "")


def model(name: str) -> Model:
    """Look a model up by name, forgiving case and separators: ``rx28``, ``RX-28``,
    ``ex106+``, ``xm430-w210`` all work."""
    wanted = _key(name).replace("-", "")
    for m in MODELS.values():
        if _key(m.name).replace("-", "") == wanted:
            return m
    raise ConfigError(f"unknown Dynamixel model {name!r}; known models: {', '.join(MODELS)}")


def model_by_number(number: int) -> Model | None:
    """The model whose PING reports ``number``, or None if servolab does not know it."""
    return BY_NUMBER.get(number)
