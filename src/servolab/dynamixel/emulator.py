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
from collections.abc import Iterable
from dataclasses import dataclass, field

from . import protocol1 as p1
from . import protocol2 as p2
from .errors import ConfigError
from .models import ALLOWED_MODES, Model, Register, supports
from .motorspec import MotorSpec
from .packets import BROADCAST_ID, Instruction, Protocol, Status
from .protocol import protocol as protocol_for

BITS_PER_BYTE = 10  # start + 8 data + stop
AMBIENT_C = 25.0
THERMAL_TIME_CONSTANT_S = 300.0
STALL_HEATING_C = 60.0  # steady-state rise at 100 % load


def byte_time(baudrate: float) -> float:
    """Seconds one byte occupies the wire at ``baudrate``."""
    return BITS_PER_BYTE / baudrate


def baud_matches(a: float, b: float, tolerance: float = 0.03) -> bool:
    """Whether two UARTs at these rates understand each other (within ``tolerance``)."""
    return abs(a - b) <= tolerance * max(a, b)


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
            if not 0.0 <= value <= 1.0:
                raise ConfigError(f"faults: {name} {value} is not a probability in 0..1")
        if self.delay < 0:
            raise ConfigError(f"faults: delay {self.delay} s is negative")
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


class VirtualMotor:
    """One emulated servo: control table, physical state, and how it answers instructions."""

    def __init__(self, model: Model, motor_id: int = 1, *, baudrate: int | None = None,
                 position: float = 0.0) -> None:
        self.model = model
        self.protocol: Protocol = protocol_for(model.protocol)
        self.table = bytearray(model.table_size)
        self._load_defaults(keep=())
        self.set_raw("id", _check_id(model, motor_id))
        if baudrate is not None:
            self.set_raw("baud_rate", model.baud_register_for(baudrate))
        #: False makes the motor deaf and mute, as if its cable were cut
        self.responsive = True
        #: hardware error bits (protocol 1.0 error-byte bits or 2.0 hardware_error_status bits)
        self.hardware_error = 0
        #: torque a world applies to the horn, as a fraction of stall torque
        self.external_load = 0.0
        self.supply_voltage = model.nominal_voltage
        self.temperature = AMBIENT_C + 7.0
        # Physical state: angle in ticks (float, unbounded) and velocity in ticks/s.
        self.ticks = model.position_center + position / model.rad_per_tick
        self.tick_velocity = 0.0
        self.load = 0.0
        self._pending: tuple[int, bytes] | None = None
        self._update_sensors()
        self._hold_position()

    def _hold_position(self) -> None:
        """Set goal_position to where the horn is, as the firmware does at power-up, so that
        enabling torque does not make the motor jump."""
        self._update_sensors()
        self.set_raw("goal_position", self.get_raw("present_position"))

    # -- control table -------------------------------------------------------------------------
    def _load_defaults(self, keep: Iterable[str]) -> None:
        kept = {name: self.get_raw(name) for name in keep}
        self.table[:] = bytes(len(self.table))
        for reg in self.model.registers:
            if reg.default is not None:
                self.table[reg.address:reg.address + reg.size] = reg.encode(reg.default)
        self.set_raw("firmware_version", self.model.firmware)
        for name, value in kept.items():
            self.set_raw(name, value)

    def get_raw(self, name: str) -> int:
        reg = self.model.register(name)
        return reg.decode(self.table[reg.address:reg.address + reg.size])

    def set_raw(self, name: str, value: int) -> None:
        """Set a register directly, bypassing access rights (the motor's own firmware)."""
        reg = self.model.register(name)
        self.table[reg.address:reg.address + reg.size] = reg.encode(value)

    def _try_get(self, name: str, default: int = 0) -> int:
        return self.get_raw(name) if self.model.has(name) else default

    @property
    def id(self) -> int:
        return self.get_raw("id")

    @property
    def baudrate(self) -> int:
        return self.model.baud_from_register(self.get_raw("baud_rate"))

    @property
    def return_delay(self) -> float:
        return self.get_raw("return_delay_time") * 2e-6

    @property
    def torque_enabled(self) -> bool:
        return bool(self.get_raw("torque_enable"))

    @property
    def position(self) -> float:
        """Horn angle in rad, 0 at the model's centre tick, unbounded (counts turns)."""
        return (self.ticks - self.model.position_center) * self.model.rad_per_tick

    @property
    def velocity(self) -> float:
        """Horn speed in rad/s, counter-clockwise positive."""
        return self.tick_velocity * self.model.rad_per_tick

    @property
    def wheel_mode(self) -> bool:
        """1.0: both angle limits 0. 2.0: velocity, PWM or current mode."""
        if self.model.protocol == 1:
            return self.get_raw("cw_angle_limit") == 0 == self.get_raw("ccw_angle_limit")
        return self.get_raw("operating_mode") in (0, 1, 16)

    def inject_hardware_error(self, name: str) -> None:
        """Raise a hardware error as the real motor would: ``overload``, ``overheating``,
        ``input voltage`` (and on 2.0 ``motor encoder``, ``electrical shock``). Torque goes off
        when the model's shutdown register selects that error (the default for overload and
        overheating)."""
        table = p1.ERROR_BITS if self.model.protocol == 1 else p2.HARDWARE_ERRORS
        for bit, bit_name in table.items():
            if bit_name == name:
                self.hardware_error |= bit
                if self.get_raw("shutdown") & bit:
                    self.set_raw("torque_enable", 0)
                self._sync_hardware_register()
                return
        known = [n for n in table.values() if n not in ("range", "checksum", "instruction")]
        raise ConfigError(f"{self.model.name}: unknown hardware error {name!r}; "
                          f"use one of {', '.join(known)}")

    def clear_hardware_error(self) -> None:
        self.hardware_error = 0
        self._sync_hardware_register()

    def _sync_hardware_register(self) -> None:
        if self.model.has("hardware_error_status"):
            self.set_raw("hardware_error_status", self.hardware_error)

    # -- physics -------------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Move the horn for ``dt`` seconds under the current commands."""
        if dt <= 0:
            return
        max_speed = self.model.no_load_speed / self.model.rad_per_tick  # ticks/s
        max_speed *= max(0.0, 1.0 - abs(self.external_load))
        if not self.torque_enabled:
            self.tick_velocity = 0.0
        elif self.wheel_mode:
            self.tick_velocity = max(-max_speed, min(max_speed, self._commanded_speed()))
            self.ticks += self.tick_velocity * dt
        else:
            target = self._target_ticks()
            speed = self._commanded_speed()
            speed = max_speed if speed == 0 else min(abs(speed), max_speed)
            error = target - self.ticks
            travel = speed * dt
            if abs(error) <= travel:
                self.tick_velocity = 0.0  # arrived within this step: at rest
                self.ticks = target
            else:
                self.tick_velocity = math.copysign(speed, error)
                self.ticks += math.copysign(travel, error)
        # Load: friction and the world's torque; heat follows load with a first-order lag.
        friction = 0.04 + 0.12 * abs(self.tick_velocity) / max(1.0, max_speed)
        self.load = 0.0 if not self.torque_enabled else max(-1.0, min(1.0, math.copysign(
            friction, self.tick_velocity) if self.tick_velocity else 0.0) + self.external_load)
        steady = AMBIENT_C + 7.0 + STALL_HEATING_C * abs(self.load)
        self.temperature = steady + (self.temperature - steady) * math.exp(
            -dt / THERMAL_TIME_CONSTANT_S)
        if self.temperature > self.get_raw("temperature_limit"):
            self.inject_hardware_error("overheating")
        self._update_sensors()

    def _commanded_speed(self) -> float:
        """Commanded speed in ticks/s (signed in wheel/velocity mode)."""
        scale = self.model.speed_unit_rpm * 2 * math.pi / 60 / self.model.rad_per_tick
        if self.model.protocol == 1:
            raw = self.get_raw("moving_speed")
            magnitude = (raw & 0x3FF) * scale
            return -magnitude if raw & 0x400 else magnitude
        mode = self.get_raw("operating_mode")
        if mode == 1:
            return self.get_raw("goal_velocity") * scale
        if mode == 16:
            return self.get_raw("goal_pwm") / 885.0 * self.model.no_load_speed \
                / self.model.rad_per_tick
        if mode == 0:
            limit = max(1, self._try_get("current_limit", 1))
            return self._try_get("goal_current") / limit * self.model.no_load_speed \
                / self.model.rad_per_tick
        return self.get_raw("profile_velocity") * scale

    def _target_ticks(self) -> float:
        goal = self.get_raw("goal_position")
        if self.model.protocol == 2 and self.get_raw("operating_mode") in (3, 5):
            # One-turn position modes: the goal is an angle within the current turn.
            turn = math.floor(self.ticks / self.model.resolution) * self.model.resolution
            return turn + goal
        return float(goal)

    def _update_sensors(self) -> None:
        m = self.model
        ticks = round(self.ticks)
        if m.protocol == 1:
            present = ticks % m.resolution if self.wheel_mode else min(max(ticks, 0),
                                                                     m.resolution - 1)
            self.set_raw("present_position", present)
            scale = m.speed_unit_rpm * 2 * math.pi / 60 / m.rad_per_tick
            speed = min(1023, round(abs(self.tick_velocity) / scale))
            self.set_raw("present_speed", speed | (0x400 if self.tick_velocity < 0 and speed
                                                   else 0))
            load = min(1023, round(abs(self.load) * 1000))
            self.set_raw("present_load", load | (0x400 if self.load < 0 and load else 0))
            self.set_raw("present_voltage", round(self._voltage() * 10))
            self.set_raw("moving", int(abs(self.tick_velocity) > 0.5))
        else:
            if self.get_raw("operating_mode") in (3, 5):
                present = ticks % m.resolution
            else:
                present = (ticks + 2**31) % 2**32 - 2**31
            self.set_raw("present_position", present)
            scale = m.speed_unit_rpm * 2 * math.pi / 60 / m.rad_per_tick
            self.set_raw("present_velocity", round(self.tick_velocity / scale))
            if m.has("present_current"):
                self.set_raw("present_current", round(
                    self.load * self.get_raw("current_limit")))
            else:
                self.set_raw("present_load", round(self.load * 1000))
            self.set_raw("present_pwm", round(self.tick_velocity / max(
                1.0, m.no_load_speed / m.rad_per_tick) * 885))
            self.set_raw("present_input_voltage", round(self._voltage() * 10))
            moving = abs(self.tick_velocity) > self.get_raw("moving_threshold") * scale
            self.set_raw("moving", int(moving))
            self.set_raw("velocity_trajectory", round(self.tick_velocity / scale))
            self.set_raw("position_trajectory", present)
        self.set_raw("present_temperature", min(255, round(self.temperature)))

    def _voltage(self) -> float:
        return self.supply_voltage - 0.3 * abs(self.load)

    # -- instructions --------------------------------------------------------------------------
    def error_byte(self, error: int = 0) -> int:
        """The status error byte: the instruction's error plus standing hardware errors."""
        if self.model.protocol == 1:
            return error | self.hardware_error
        return error | (p2.ALERT if self.hardware_error else 0)

    def execute(self, inst: Instruction, name: str) -> Status:
        """Act on an instruction addressed to this motor; return the status it would send."""
        v1 = self.model.protocol == 1
        if not supports(self.model, name):
            return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else
                                                   p2.INSTRUCTION_ERROR))
        params = inst.params
        if name == "PING":
            if v1:
                return Status(self.id, self.error_byte())
            return Status(self.id, self.error_byte(), self.get_raw("model_number").to_bytes(
                2, "little") + bytes((self.get_raw("firmware_version"),)))
        if name == "READ":
            if v1 and len(params) == 2:
                address, length = params[0], params[1]
            elif not v1 and len(params) == 4:
                address = int.from_bytes(params[0:2], "little")
                length = int.from_bytes(params[2:4], "little")
            else:
                return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else p2.DATA_LENGTH))
            return self.read(address, length)
        if name in ("WRITE", "REG_WRITE"):
            split = 1 if v1 else 2
            if len(params) <= split:
                return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else p2.DATA_LENGTH))
            address = int.from_bytes(params[:split], "little")
            error = self.write(address, params[split:], registered=name == "REG_WRITE")
            return Status(self.id, self.error_byte(error))
        if name == "ACTION":
            error = 0
            if self._pending is None:
                error = p1.INSTRUCTION if v1 else 0
            else:
                address, data = self._pending
                self._pending = None
                self._set_registered(0)
                error = self.write(address, data)
            return Status(self.id, self.error_byte(error))
        if name == "RESET":
            status = Status(self.id, self.error_byte())
            self._load_defaults(keep=())
            self._hold_position()
            return status
        if name == "FACTORY_RESET":
            option = params[0] if params else p2.FACTORY_RESET_ALL
            keep = {p2.FACTORY_RESET_ALL: (), p2.FACTORY_RESET_EXCEPT_ID: ("id",),
                    p2.FACTORY_RESET_EXCEPT_ID_BAUD: ("id", "baud_rate")}.get(option)
            if keep is None:
                return Status(self.id, self.error_byte(p2.DATA_RANGE))
            status = Status(self.id, self.error_byte())
            self._load_defaults(keep=keep)
            self._hold_position()
            return status
        if name == "REBOOT":
            status = Status(self.id, self.error_byte())
            eeprom = {r.name: self.get_raw(r.name) for r in self.model.registers
                      if r.area == "EEPROM" and r.writable}
            self._load_defaults(keep=())
            for reg_name, value in eeprom.items():
                self.set_raw(reg_name, value)
            self.clear_hardware_error()
            self._hold_position()
            return status
        if name == "CLEAR":
            if params[:5] != b"\x01\x44\x58\x4c\x22" or self.torque_enabled:
                return Status(self.id, self.error_byte(p2.RESULT_FAIL if params[:1] == b"\x01"
                                                       else p2.DATA_RANGE))
            turn = math.floor(self.ticks / self.model.resolution) * self.model.resolution
            self.ticks -= turn
            self._update_sensors()
            return Status(self.id, self.error_byte())
        return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else p2.INSTRUCTION_ERROR))

    def read(self, address: int, length: int) -> Status:
        end = address + length
        if length == 0 or end > len(self.table):
            v1 = self.model.protocol == 1
            return Status(self.id, self.error_byte(p1.RANGE if v1 else p2.ACCESS))
        return Status(self.id, self.error_byte(), bytes(self.table[address:end]))

    def write(self, address: int, data: bytes, *, registered: bool = False) -> int:
        """Write ``data`` at ``address`` as the firmware would; return the error (0 if none).

        Every byte must land in a writable register, every touched register must end in its
        range, and on 2.0 the EEPROM is locked while torque is on. Nothing changes on error.
        """
        v1 = self.model.protocol == 1
        end = address + len(data)
        if end > len(self.table):
            return p1.RANGE if v1 else p2.ACCESS
        touched = self._registers_in(address, end)
        covered = sum(r.size for r in touched)
        if covered != len(data) or any(not r.writable for r in touched):
            return p1.RANGE if v1 else p2.ACCESS
        if not v1 and self.torque_enabled and any(
                r.area == "EEPROM" for r in touched):
            return p2.ACCESS
        scratch = bytearray(self.table)
        scratch[address:end] = data
        for reg in touched:
            value = reg.decode(scratch[reg.address:reg.address + reg.size])
            error = self._check_value(reg, value, scratch)
            if error:
                return error
        if registered:
            self._pending = (address, bytes(data))
            self._set_registered(1)
            return 0
        self.table[:] = scratch
        names = {r.name for r in touched}
        if names & {"operating_mode", "cw_angle_limit", "ccw_angle_limit"}:
            self._update_sensors()
        return 0

    def _registers_in(self, start: int, end: int) -> list[Register]:
        return [r for r in self.model.registers if r.address >= start and
                r.address + r.size <= end]

    def _set_registered(self, value: int) -> None:
        name = "registered" if self.model.protocol == 1 else "registered_instruction"
        self.set_raw(name, value)

    def _check_value(self, reg: Register, value: int, table: bytearray) -> int:
        v1 = self.model.protocol == 1

        def other(name: str) -> int:
            r = self.model.register(name)
            return r.decode(table[r.address:r.address + r.size])

        if not reg.raw_min <= value <= reg.raw_max:
            return p1.RANGE if v1 else p2.DATA_RANGE
        if v1:
            wheel = other("cw_angle_limit") == 0 == other("ccw_angle_limit")
            if reg.name == "goal_position" and not wheel and not (
                    other("cw_angle_limit") <= value <= other("ccw_angle_limit")):
                return p1.ANGLE_LIMIT
            if reg.name == "moving_speed" and not wheel and value > 1023:
                return p1.RANGE
            return 0
        if reg.name == "operating_mode" and value not in ALLOWED_MODES.get(
                self.model.name, (value,)):
            return p2.DATA_RANGE
        if reg.name == "goal_velocity" and abs(value) > other("velocity_limit"):
            return p2.DATA_LIMIT
        if reg.name == "goal_position" and other("operating_mode") in (3, 5) and not (
                other("min_position_limit") <= value <= other("max_position_limit")):
            return p2.DATA_LIMIT
        if reg.name == "goal_current" and abs(value) > other("current_limit"):
            return p2.DATA_LIMIT
        if reg.name == "goal_pwm" and abs(value) > other("pwm_limit"):
            return p2.DATA_LIMIT
        return 0


def _check_id(model: Model, motor_id: int) -> int:
    max_id = 253 if model.protocol == 1 else 252
    if not isinstance(motor_id, int) or not 0 <= motor_id <= max_id:
        raise ConfigError(f"{model.name}: motor ID {motor_id!r} is outside 0..{max_id}")
    return motor_id


@dataclass(frozen=True)
class Reply:
    """Status bytes an emulator puts on the wire, starting at ``start`` (seconds)."""

    start: float
    data: bytes


class Emulator:
    """The device side of one bus: a set of virtual motors on one protocol.

    ``receive`` takes the bytes the host sent, finishing at time ``t``, at the host's baud rate,
    and returns the replies with their start times. Motors whose own baud rate differs from the
    host's hear noise and stay silent, like real ones.
    """

    def __init__(self, protocol: int | Protocol, motors: Iterable[VirtualMotor] = (), *,
                 faults: Faults | None = None) -> None:
        self.protocol = protocol if isinstance(protocol, Protocol) else protocol_for(protocol)
        self.motors: list[VirtualMotor] = []
        self.faults = faults or Faults()
        self.time = 0.0
        self._parser = self.protocol.parser(keep_rejected=True)
        self.instructions_seen = 0
        for motor in motors:
            self.add(motor)

    def add(self, motor: VirtualMotor) -> VirtualMotor:
        if motor.model.protocol != self.protocol.version:
            raise ConfigError(f"{motor.model.name} speaks protocol {motor.model.protocol}.0, "
                              f"this bus protocol {self.protocol.version}.0")
        self.motors.append(motor)
        return motor

    def motor(self, motor_id: int) -> VirtualMotor:
        """The (first) motor with this ID; KeyError if there is none."""
        for m in self.motors:
            if m.id == motor_id:
                return m
        raise KeyError(f"no emulated motor with ID {motor_id}")

    def advance(self, t: float) -> None:
        """Move every motor's physics forward to time ``t``."""
        dt = t - self.time
        if dt > 0:
            for m in self.motors:
                m.step(dt)
            self.time = t

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Reply]:
        """Take the host's bytes (the last one ends at ``t``); return what goes back."""
        self.advance(t)
        replies: list[Reply] = []
        for frame in self._parser.feed(data):
            self.instructions_seen += 1
            inst = self.protocol.as_instruction(frame)
            replies += self._answer(inst, t, baudrate)
            if replies:
                t = max(t, replies[-1].start + len(replies[-1].data) * byte_time(baudrate))
        for bad in self._parser.rejected:
            replies += self._checksum_error(bad.id, t, baudrate)
        self._parser.rejected.clear()
        return replies

    def _checksum_error(self, motor_id: int, t: float, baudrate: float) -> list[Reply]:
        """A unicast packet that arrived whole but with a bad checksum/CRC: the motor with
        that ID answers with the checksum (1.0) or CRC (2.0) error, as the real ones do."""
        error = p1.CHECKSUM if self.protocol.version == 1 else p2.CRC_ERROR
        targets = [m for m in self._listening(baudrate) if m.id == motor_id]
        if not targets or motor_id == BROADCAST_ID:
            return []
        encoded = [self.protocol.encode_status(Status(m.id, m.error_byte(error)))
                   for m in targets]
        start = t + max(m.return_delay for m in targets) + self.faults.delay
        return [Reply(start, self.faults.apply(_collide(encoded)))]

    # -- who answers what ------------------------------------------------------------------
    def _listening(self, baudrate: float) -> list[VirtualMotor]:
        return [m for m in self.motors if m.responsive and baud_matches(m.baudrate, baudrate)]

    def _answer(self, inst: Instruction, t: float, baudrate: float) -> list[Reply]:
        name = self.protocol.instruction_name(inst.instruction)
        motors = self._listening(baudrate)
        v1 = self.protocol.version == 1
        if name == "SYNC_WRITE":
            self._sync_write(inst, motors)
            return []
        if name == "BULK_WRITE" and not v1:
            self._bulk_write(inst, motors)
            return []
        if name in ("SYNC_READ", "BULK_READ"):
            able = [m for m in motors if supports(m.model, name)]
            return self._chain(self._read_requests(inst, name), able, t, baudrate)
        if inst.id == BROADCAST_ID:
            if name == "PING" and not v1:
                # Broadcast ping (2.0): every motor answers, in ID order, one after another.
                order = sorted(motors, key=lambda m: m.id)
                return self._chain([(m.id, None) for m in order], order, t, baudrate,
                                   instruction="PING")
            for m in motors:
                m.execute(inst, name)
            return []
        targets = [m for m in motors if m.id == inst.id]
        statuses = [(m, m.execute(inst, name)) for m in targets]
        statuses = [(m, s) for m, s in statuses if self._returns_status(m, name)]
        if not statuses:
            return []
        encoded = [self.protocol.encode_status(s) for _, s in statuses]
        start = t + max(m.return_delay for m, _ in statuses) + self.faults.delay
        return [Reply(start, self.faults.apply(_collide(encoded)))]

    def _returns_status(self, motor: VirtualMotor, name: str) -> bool:
        level = motor.get_raw("status_return_level")
        if name == "PING":
            return True
        if name == "READ":
            return level >= 1
        return level >= 2

    def _chain(self, requests: list[tuple[int, tuple[int, int] | None]],
               motors: list[VirtualMotor], t: float, baudrate: float,
               instruction: str = "READ") -> list[Reply]:
        """Replies of a SYNC_READ, BULK_READ or broadcast ping: each motor waits for the
        status of the one before it, then its own return delay."""
        replies: list[Reply] = []
        for motor_id, block in requests:
            targets = [m for m in motors if m.id == motor_id]
            if not targets:
                # Real motors wait for the previous answer; a missing one stalls the rest
                # (1.0 BULK_READ), while 2.0 motors time out and go on. Both lose this slot.
                if self.protocol.version == 1:
                    break
                continue
            statuses = []
            for m in targets:
                if instruction == "PING":
                    status = m.execute(Instruction(m.id, p2.PING), "PING")
                else:
                    status = m.read(*block)  # type: ignore[misc]
                statuses.append((m, status))
            encoded = [self.protocol.encode_status(s) for _, s in statuses]
            start = t + max(m.return_delay for m, _ in statuses) + self.faults.delay
            data = self.faults.apply(_collide(encoded))
            replies.append(Reply(start, data))
            t = start + len(data) * byte_time(baudrate)
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
