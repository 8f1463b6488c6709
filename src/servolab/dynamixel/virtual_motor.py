"""One emulated Dynamixel's firmware: its control table (:mod:`.control_table`), how it
answers instructions, the registers it commands its plant with and reads back from it, and
its alarms.

The plant (:mod:`.plant`) is the physics; the feedback laws' gains are read by
:mod:`.gains`; the X-series profile by :mod:`.profile_generator`. The bus side — parsing
packets, timing, collisions — is the :class:`~.emulator.Emulator`'s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING

from . import gains, units
from . import protocol1 as p1
from . import protocol2 as p2
from .control_table import ControlTable, angle_limit_modes
from .errors import ConfigError
from .models import Model, supports
from .motor_alarms import Alarms, hardware_bit
from .packets import BROADCAST_ID, Instruction, Protocol, Status
from .plant import (
    Compliance,
    KinematicServo,
    PositionPid,
    ServoCommand,
    ServoPlant,
    VelocityPi,
)
from .profile_generator import POSITION_MODES, ProfileGenerator, Registers
from .protocol import protocol as protocol_for

if TYPE_CHECKING:
    from .emulator import Emulator

#: Registers only the joint's command is made of: the feedback laws' gains (which the
#: firmware keeps decoded until one changes) and the goals and limits. After a change of
#: these alone, which leaves torque as it was, the firmware re-plans the joint without
#: decoding the rest of the table (a gait's goals come twenty motors at a time, several times
#: a second).
_COMMAND_ONLY = gains.REGISTERS | {
    "goal_position", "moving_speed", "torque_limit", "goal_velocity", "goal_pwm",
    "goal_current", "profile_velocity", "profile_acceleration"}
#: Registers whose value the firmware keeps decoded or commands the joint with: a change
#: of any of them, however made, refreshes both.
_SETTINGS = _COMMAND_ONLY | {
    "id", "baud_rate", "homing_offset", "temperature_limit", "return_delay_time",
    "status_return_level", "torque_enable", "cw_angle_limit", "ccw_angle_limit",
    "operating_mode", "pwm_limit", "current_limit", "drive_mode", "secondary_id",
    "bus_watchdog", "min_voltage_limit", "max_voltage_limit", "multi_turn_offset",
    "resolution_divider"}
#: The registers the firmware writes from its sensors (:meth:`VirtualMotor._update_sensors`):
#: none is a setting, so they go straight into the table.
_READINGS = frozenset({
    "present_position", "present_speed", "sensed_current", "moving", "realtime_tick",
    "position_trajectory", "moving_status"})
assert _READINGS.isdisjoint(_SETTINGS)
#: One register's name as the set of names changed, for :meth:`VirtualMotor._set_raw`.
_ALONE = {name: frozenset((name,)) for name in _SETTINGS}

#: Protocol 1.0: writing either of these switches torque on (the seeds' programs rely on it:
#: seed 000 drives its EX-106+ wheels with a SYNC_WRITE of moving_speed alone, and ROS
#: dynamixel_motor's joint controllers write goal_position without ever writing torque_enable).
_TORQUE_ON_1 = frozenset({"goal_position", "moving_speed"})
#: X-series goal registers: what Drive Mode bit 3 (Torque On by Goal Update, firmware V45)
#: reacts to, and what a bus watchdog error makes read-only (e-Manual, Drive Mode(10) and
#: Bus Watchdog(98)).
_GOALS_2 = frozenset({"goal_position", "goal_velocity", "goal_current", "goal_pwm"})
#: Firmware from which Drive Mode bit 3 exists on the X-series (e-Manual, Drive Mode(10)).
_TORQUE_ON_BY_GOAL_FIRMWARE = 45
#: Firmware from which a broadcast FACTORY_RESET with option 0xFF (reset all) is ignored
#: (e-Manual, Protocol 2.0, Factory Reset, firmware v42 and above).
_BROADCAST_RESET_ALL_IGNORED_FROM = 42
#: A Secondary ID of 253 or more switches the secondary ID off (e-Manual, Secondary ID(12)).
_SECONDARY_OFF = 253


class VirtualMotor(Alarms):
    """One emulated servo's firmware: its control table, how it answers instructions, and
    the registers it reads from and commands to its :class:`~.plant.ServoPlant`.

    The plant is the motor's own :class:`~.plant.KinematicServo` unless a world puts its own in
    with :meth:`attach_plant`. Time comes from the :class:`~.emulator.Emulator` the motor is
    on, whose owner steps it; the motor catches its default plant up only when something
    looks at it (an instruction, a property), which gives exactly what stepping every step
    would.
    """

    def __init__(self, model: Model, motor_id: int = 1, *, baudrate: int | None = None,
                 position: float = 0.0) -> None:
        self.model = model
        self.protocol: Protocol = protocol_for(model.protocol)
        #: the AX-style control table (angle limits, moving speed, torque limit): every 1.0
        #: model, and the XL-320 on 2.0; the X-series table (operating_mode) otherwise
        self._table = ControlTable(model)
        #: each sensor register _show has written: (start, end, signed, SI -> raw, the
        #: register's size when every reading fits it, else 0)
        self._sensors: dict[str, tuple[int, int, bool, Callable[[float], int], int]] = {}
        self._laws: tuple[Compliance | None, PositionPid | None, VelocityPi | None] | None = None
        self._dx = self._table.dx
        self._load_defaults(keep=())
        self._set_raw("id", _check_id(model, motor_id))
        if baudrate is not None:
            self._set_raw("baud_rate", model.baud_register_for(baudrate))
        #: False makes the motor deaf and mute, as if its cable were cut
        self.responsive = True
        #: hardware error bits (protocol 1.0 error-byte bits or 2.0 hardware_error_status bits)
        self.hardware_error = 0
        self._supply_voltage = model.nominal_voltage
        self._plant: ServoPlant = KinematicServo(model.no_load_speed, position)
        #: the X-series profile generator (unused by the AX-style table)
        self._profiles = ProfileGenerator(model.firmware)
        self._lazy = True           # the default plant: caught up on demand
        self._offset_ticks = 0.0    # turns the firmware no longer counts (2.0 CLEAR)
        self._emulator: Emulator | None = None
        self._steps_done = 0
        self._stale = True          # present_* registers need refreshing from the plant
        self._pending: tuple[int, bytes] | None = None
        self._joint_before = True   # (1.0) joint mode as _table_changed last saw it
        self._heard_step = 0        # the step of the last instruction that reached the motor
        self._too_hot = False       # overheating found by the firmware (not injected)
        self._overloaded = False    # overload found by the firmware (not injected)
        self._stall_step: int | None = None  # the step since which a load beats the output
        self._watchdog_tripped = False
        self._watchdog_hold = False  # stopped by the bus watchdog until a new goal comes
        self._max_output = 1.0      # (2.0) PWM and Current Limit's share of stall torque
        self._mode_before = self._torque_before = -1   # (2.0) what _table_changed last saw
        self._has_watchdog = model.has("bus_watchdog")
        # (what the model has is fixed: looked up once, not at every read)
        self._has_sensed_current = model.has("sensed_current")
        self._has_present_current = model.has("present_current")
        self._has_realtime_tick = model.has("realtime_tick")
        self._overheating_bit = hardware_bit(model, "overheating")
        self._overload_bit = hardware_bit(model, "overload")
        self._table_changed()       # (in mode 3 at power-up: the count within one turn)
        self._hold_position()

    def _hold_position(self) -> None:
        """Set goal_position to where the horn is, as the firmware does at power-up, so that
        enabling torque does not make the motor jump. (Also after a reset, which may have
        changed the mode the position is read in: decode the table first.)"""
        self._table_changed()
        self._update_sensors()
        self._set_raw("goal_position", self.get_raw("present_position"))

    # -- control table -------------------------------------------------------------------------
    def _load_defaults(self, keep: Iterable[str]) -> None:
        """The table as at power-up: factory defaults (but the registers in ``keep``)."""
        self._laws = None   # the gains are the defaults' now
        self._table.load_defaults({name: self.get_raw(name) for name in keep})
        self._watchdog_tripped = self._watchdog_hold = False
        self._pending = None    # a REG_WRITE does not survive a reset or REBOOT

    @property
    def table(self) -> bytearray:
        """The control table's bytes (:class:`~.control_table.ControlTable`); the present_*
        registers as of the last read (:attr:`sensed_step`): :meth:`sync` first for now."""
        return self._table.data

    def get_raw(self, name: str) -> int:
        """A register's raw value as the table holds it (a present_* one as of the last
        read: :attr:`table`)."""
        return self._table.get(name)

    def set_raw(self, name: str, value: int) -> None:
        """Set a register directly, bypassing access rights, as the motor's own firmware
        would — now: the joint is brought up to the present step first, so the change acts
        from here on and not in the past."""
        self.sync()
        self._set_raw(name, value)

    def _set_raw(self, name: str, value: int) -> None:
        self._table.put(name, value)
        if name in _SETTINGS:
            self._table_changed(_ALONE[name])

    def _si(self, name: str) -> float:
        return units.to_si(self.model, self.model.register(name), self.get_raw(name))

    def _show(self, name: str, value: float) -> None:
        """Write a sensor register from an SI value (saturating, as the hardware does)."""
        try:
            start, end, signed, reading, fits = self._sensors[name]
        except KeyError:
            # (once per register: the model's scales and the register's bounds are fixed,
            # and every read shows half a dozen of them)
            reg = self.model.register(name)
            # (units.reader clamps to what the register holds, but a sign-bit reading,
            # 0..0x7FF, fits only two bytes or more)
            sign_bit = reg.unit in ("speed_sign_bit", "load_sign_bit")
            start, end, signed, reading, fits = self._sensors[name] = (
                reg.address, reg.address + reg.size, reg.signed, units.reader(self.model, reg),
                reg.size if reg.size >= 2 or not sign_bit else 0)
        raw = reading(value)
        data = self._table.data
        # A reading that fits its register: the bytes Register.encode gives (two's complement,
        # little-endian) stored one by one, without the copy a slice assignment makes.
        if fits == 1:
            data[start] = raw & 0xFF
        elif fits == 2:
            data[start], data[start + 1] = raw & 0xFF, raw >> 8 & 0xFF
        else:   # as Register.encode
            data[start:end] = raw.to_bytes(end - start, "little", signed=signed and raw < 0)

    def _try_get(self, name: str, default: int = 0) -> int:
        return self.get_raw(name) if self.model.has(name) else default

    def _table_changed(self, names: AbstractSet[str] | None = None) -> None:
        """Registers changed (``names``; None: any): refresh what the firmware keeps decoded
        and tell the plant."""
        if names is None or not names.isdisjoint(gains.REGISTERS):
            self._laws = None
        if (names is not None and names <= _COMMAND_ONLY and hasattr(self, "_plant")
                and self.get_raw("torque_enable") == self._torque_before):
            self._plant.command = self._command()
            self._stale = True
            return
        m = self.model
        v1 = self._dx   # the AX-style table
        motor_id = self.get_raw("id")
        secondary_id = self._try_get("secondary_id", _SECONDARY_OFF)
        secondary = secondary_id if secondary_id < _SECONDARY_OFF else None
        emulator = getattr(self, "_emulator", None)
        if emulator is not None and (getattr(self, "_id", motor_id), getattr(
                self, "_secondary_id", secondary)) != (motor_id, secondary):
            emulator._by_id = None  # the bus's ID index is out of date
        self._id = motor_id
        self._secondary_id = secondary
        self._baudrate = m.baud_from_register(self.get_raw("baud_rate"))
        self._temperature_limit = float(self.get_raw("temperature_limit"))
        self._return_delay = self._si("return_delay_time")
        self._status_level = self.get_raw("status_return_level")
        mode = -1 if v1 else self.get_raw("operating_mode")
        if v1 and m.has("control_mode"):
            # XL-320: Control Mode(11) 1 is wheel mode, 2 joint mode (e-Manual XL-320)
            wheel, self._multi_turn = self.get_raw("control_mode") == 1, False
        elif v1:
            wheel, self._multi_turn = angle_limit_modes(
                m, self.get_raw("cw_angle_limit"), self.get_raw("ccw_angle_limit"))
        else:
            wheel = mode in (0, 1, 16)
            self._multi_turn = False
        drive = self._try_get("drive_mode")
        # Drive Mode bit 0 reverses the direction; EX-106+ and MX-106 ignore it in wheel mode
        # (e-Manual, Drive Mode(10)).
        reverse = bool(drive & 0x01) and not (v1 and wheel)
        if hasattr(self, "_plant") and getattr(self, "_sign", 1) != (-1 if reverse else 1):
            self._offset_ticks = -self._offset_ticks  # the count mirrors about the centre
        self._sign = -1 if reverse else 1
        self._torque_on_goal = (not v1 and bool(drive & 0x08)
                                and m.firmware >= _TORQUE_ON_BY_GOAL_FIRMWARE)
        joint = v1 and not wheel and not self._multi_turn
        if joint and hasattr(self, "_plant") and not getattr(self, "_joint_before", True):
            # (getattr: the first calls come from __init__, before the attribute is set)
            # Back in joint mode (from wheel or multi-turn) a 1.0 servo reads its
            # potentiometer or absolute encoder, which knows no turns: the firmware's angle is
            # the horn's within one turn from here on.
            angle = units.ticks_position(m, self._firmware_ticks(self._plant.position))
            self._offset_ticks += (angle - math.remainder(angle, 2 * math.pi)) \
                / m.rad_per_tick
        self._wheel = wheel
        self._joint_before = joint
        # Only Position Control Mode (3) is confined to one turn: Extended Position (4) and
        # Current-based Position (5) count turns, goals -1 048 575..1 048 575 (e-Manual,
        # Goal Position(116)).
        self._one_turn = mode == 3
        torque = self.get_raw("torque_enable")
        if not v1 and hasattr(self, "_plant") and mode == 3 and (
                self._mode_before != 3 or (torque and not self._torque_before)):
            # Present Position counts turns (4 bytes) whatever the mode, but "will be reset to
            # an absolute position value within one full rotation ... when the Operating
            # Mode(11) is changed to Position Control Mode [and] when torque is turned on in
            # Position Control Mode" (e-Manual, Present Position note).
            self._drop_turns()
        self._mode_before, self._torque_before = mode, torque
        # Present Position = Actual Position + Homing Offset; in the one-turn position mode
        # a homing offset outside -1024..1024 is ignored (e-Manual, Homing Offset(20)).
        homing = self._try_get("homing_offset")
        self._homing = homing if not self._one_turn or -1024 <= homing <= 1024 else 0
        if self._try_get("bus_watchdog") >= 0:
            self._watchdog_tripped = False  # 0 written: the bus watchdog error is cleared
        if hasattr(self, "_plant"):
            self._check_voltage()
            self._plant.command = self._command()
            self._stale = True

    @property
    def id(self) -> int:
        return self._id

    @property
    def baudrate(self) -> int:
        return self._baudrate

    @property
    def return_delay(self) -> float:
        return self._return_delay

    @property
    def torque_enabled(self) -> bool:
        return bool(self.get_raw("torque_enable"))

    @property
    def wheel_mode(self) -> bool:
        """1.0: both angle limits 0. 2.0: velocity, PWM or current mode."""
        return self._wheel

    # -- the joint -----------------------------------------------------------------------------
    @property
    def plant(self) -> ServoPlant:
        """The joint, brought up to the present step first."""
        self.sync()
        return self._plant

    def attach_plant(self, plant: ServoPlant) -> None:
        """Put a world's plant in place of the motor's own: from the next step the world steps
        it, the firmware commands it and reads every present_* register from it."""
        self.sync()
        plant.command = self._plant.command
        self._plant = plant
        self._stale = True
        was_lazy, self._lazy = self._lazy, False
        if was_lazy and self._emulator is not None and self._needs_duty():
            self._emulator._eager.append(self)

    def _needs_duty(self) -> bool:
        """Whether the firmware must look at its world's plant every step: yes, unless the
        plant says when its temperature or stall changes (``reports_changes``: it calls
        :meth:`plant_changed`) and the motor has no bus watchdog to count steps for."""
        return not self._lazy and (self._has_watchdog
                                   or not getattr(self._plant, "reports_changes", False))

    def plant_changed(self) -> None:
        """A world's plant whose temperature or stall changed says so (a plant with
        ``reports_changes``): the firmware's alarm checks run now, as they would on the step
        it happened."""
        self._check_alarms()

    @property
    def position(self) -> float:
        """Horn angle in rad, 0 at the model's centre tick, unbounded (counts turns)."""
        return units.ticks_position(self.model, self.ticks)

    @property
    def ticks(self) -> float:
        """Horn angle as present_position counts it: ticks, unbounded and unrounded (the
        homing offset added, the turns a CLEAR dropped taken away)."""
        return self._present_ticks(self.plant.position)

    def _drop_turns(self) -> None:
        """From now on count the horn's angle within one turn, 0..resolution-1 (before the
        homing offset): what an X-series does at power-up, REBOOT, and on entering
        Position Control Mode or switching torque on in it."""
        ticks = self._firmware_ticks(self._plant.position)
        self._offset_ticks += math.floor(ticks / self.model.resolution) * self.model.resolution

    def _firmware_ticks(self, joint: float) -> float:
        """The count the firmware keeps for a joint angle: mirrored in reverse mode, less the
        turns a CLEAR (or a return to joint mode) dropped."""
        return units.position_ticks(self.model, self._sign * joint) - self._offset_ticks

    def _present_ticks(self, joint: float) -> float:
        # "In the case of Reverse Mode ... the sign of Homing Offset value will not be
        # reversed" (e-Manual, Homing Offset(20)): the offset is added after the mirror.
        return self._firmware_ticks(joint) + self._homing

    @property
    def velocity(self) -> float:
        """Horn speed in rad/s, counter-clockwise positive."""
        return self.plant.velocity

    @property
    def load(self) -> float:
        """Load as a signed fraction of stall torque."""
        return self.plant.effort

    @property
    def temperature(self) -> float:
        """Winding temperature, °C, as present_temperature shows it (rounded there).

        Settable on the motor's own plant: the windings are that warm from now on and the
        thermal model goes on from there, so a test can start a motor near its Temperature
        Limit (``motor.temperature = 78.0``) and see the overheating error come through the
        real model. The firmware looks at the temperature once a physics step: a value set
        above the limit is an overheating error from the next step on."""
        return self.plant.temperature

    @temperature.setter
    def temperature(self, celsius: float) -> None:
        self._own_plant("set its temperature").temperature = celsius
        self._stale = True

    @property
    def thermal_time_constant(self) -> float:
        """The lag (s) of the default plant's winding temperature
        (:attr:`.plant.KinematicServo.thermal_time_constant`, 300 s unless set): set it
        shorter to see a motor warm up in seconds of virtual time. Acts from now on."""
        return self._own_plant("read its thermal time constant").thermal_time_constant

    @thermal_time_constant.setter
    def thermal_time_constant(self, seconds: float) -> None:
        self._own_plant("set its thermal time constant").thermal_time_constant = seconds

    def _own_plant(self, action: str) -> KinematicServo:
        """The motor's own plant, brought up to now; a world's plant is the world's to set."""
        plant = self.plant
        if not isinstance(plant, KinematicServo):
            raise ConfigError(f"motor {self.id}: its plant belongs to a world; {action} "
                              "through the world")
        return plant

    @property
    def external_load(self) -> float:
        """Torque a world applies to the horn of the default plant, as a fraction of stall
        torque (negative pushes clockwise)."""
        plant = self.plant
        return plant.external_load if isinstance(plant, KinematicServo) else 0.0

    @external_load.setter
    def external_load(self, load: float) -> None:
        self._own_plant("apply loads").external_load = load

    @property
    def supply_voltage(self) -> float:
        return self._supply_voltage

    @supply_voltage.setter
    def supply_voltage(self, volts: float) -> None:
        self.sync()
        self._supply_voltage = float(volts)
        self._check_voltage()
        self._stale = True

    # -- time ----------------------------------------------------------------------------------
    @property
    def sensed_step(self) -> int:
        """The physics step the present_* registers show: the firmware samples its joint when
        a read reaches it (READ, SYNC_READ, BULK_READ: what a host sees of them) or
        :meth:`sync` is called, from the state the last step left."""
        return self._sensed_step

    def sync(self) -> None:
        """Bring the joint and the present_* registers up to the emulator's current step."""
        self._sync_joint()
        if self._stale:
            self._update_sensors()

    def _sync_joint(self) -> None:
        """Bring the joint up to the emulator's current step, and leave the present_*
        registers to the next read: an instruction that only writes needs the joint where
        it is now (a new command acts from this step on), not its readings."""
        emulator = self._emulator
        if emulator is not None and emulator.steps > self._steps_done:
            if self._lazy:
                # (a model without Bus Watchdog(98) has no deadline: not looked up each time)
                deadline = self._watchdog_deadline() if self._has_watchdog else None
                if deadline is not None and deadline <= emulator.steps:
                    # The bus watchdog fires on its own step: move the joint to it first.
                    self._catch_up(max(0, deadline - self._steps_done), emulator.dt)
                    self._steps_done = max(self._steps_done, deadline)
                    self._watchdog_trip()
                self._catch_up(emulator.steps - self._steps_done, emulator.dt)
            self._steps_done = emulator.steps
            self._stale = True

    def _heard(self) -> None:
        """An instruction reached the motor: the bus watchdog counts from now."""
        if self._emulator is not None:
            self._heard_step = self._emulator.steps

    def _catch_up(self, steps: int, dt: float) -> None:
        """Step the default plant ``steps`` steps, stopping where it overheats or finds itself
        overloaded, so that the shutdown happens on the step it would on the motor (what
        :meth:`_after_step` does after each step of a world's plant)."""
        plant = self._plant
        assert isinstance(plant, KinematicServo)
        overheating = self._overheating_bit
        now = self._steps_done
        while steps > 0:
            limit = math.inf if self.hardware_error & overheating else self._temperature_limit
            # A stall (constant while the command and the load are) is an overload once it
            # has lasted OVERLOAD_TIME_S: step to that step, no further, to find it there.
            due = self._overload_step(now, dt)
            chunk = steps if due is None else max(1, min(steps, due - now))
            taken = plant.advance(chunk, dt, temperature_limit=limit)
            steps -= taken
            now += taken
            self._steps_done = now  # (the alarms below act, and plan, on the step they fall)
            if plant.temperature > limit:
                self._hardware_error(overheating)
                self._too_hot = True
                # (its shutdown may change the command; else the stall, which does not
                # depend on the step, and so the step it overloads on, are as found above)
                due = self._overload_step(now, dt)
            if due is not None and now >= due:
                self._overload()
        # (each only when its error stands, as _check_alarms calls them)
        if self._too_hot:
            self._cooled_down(overheating)
        if self._overloaded:
            self._unloaded()

    def _after_step(self, steps: int) -> None:
        """A world stepped this motor's plant: the firmware's per-step duty."""
        self._steps_done = steps
        self._stale = True
        if self._has_watchdog:  # (a world may step twenty motors a millisecond: the checks
            deadline = self._watchdog_deadline()  # that cannot apply are skipped)
            if deadline is not None and steps >= deadline:
                self._watchdog_trip()
        self._check_alarms()

    def _command(self) -> ServoCommand:
        """The registers as the joint sees them: torque, the goal and the limits, in SI."""
        m = self.model
        sign = self._sign
        torque = bool(self.get_raw("torque_enable"))
        if self._dx:
            limit = self._max_output = self._si("torque_limit")
            if self.wheel_mode:
                if not m.wheel_output_ratio:
                    return ServoCommand(torque, True, goal_velocity=self._si("moving_speed"),
                                        torque_limit=limit)
                # Wheel mode on AX/RX/EX: moving_speed is the output in 0.1 % steps, bit 10
                # clockwise; "only the output control is possible, not speed" (e-Manual,
                # Moving Speed). Unloaded, the horn turns at that share of the no-load speed.
                speed = units.wheel_speed(m, self.get_raw("moving_speed"))
                return ServoCommand(torque, True, goal_velocity=speed, torque_limit=limit)
            compliance, pid, _ = self._feedback_laws()
            return ServoCommand(torque, False, goal_position=self._goal_angle(),
                                profile_velocity=abs(self._si("moving_speed")),
                                torque_limit=limit, compliance=compliance, pid=pid)
        mode = self.get_raw("operating_mode")
        # Effort: PWM Limit(36) caps the output, and on current-sensing models Current Limit(38)
        # the current, so the torque: a current is a share of the stall torque through the
        # torque constant (see _current_share). In Current-based Position mode Goal
        # Current(102) "sets a limit to current" (e-Manual, Goal Current(102)); there, and in
        # Current Control Mode, a load the goal current cannot hold is what was asked, not an
        # overload: only the motor's own maximum (PWM and Current Limit) overloads it.
        limit = self._si("pwm_limit")
        if m.has("current_limit"):
            limit = min(limit, self._current_share("current_limit"))
        self._max_output = limit
        if mode == 5:
            limit = min(limit, abs(self._current_share("goal_current")))
        if self._watchdog_hold:
            # The bus watchdog stopped the motor: it holds still until a new goal (and the
            # profile it was following is gone).
            self._profiles.reset()
            return ServoCommand(torque, mode in (0, 1, 16), torque_limit=limit,
                                goal_position=self._plant.position)
        velocity = self._profiles.plan(
            self._profile_registers(mode, torque), self._plant.position, self._plant.velocity,
            self._now())
        trajectory = self._profiles.trajectory
        if mode == 1:
            return ServoCommand(torque, True, goal_velocity=sign * self._si("goal_velocity"),
                                torque_limit=limit, trajectory=trajectory,
                                velocity_pi=self._feedback_laws()[2])
        if mode == 16:
            # PWM Control Mode: the goal is a voltage, "directly controlling the supplying
            # voltage to the motor" (e-Manual, Position PID Gain note): its share of the no-load
            # speed, which a load moves along the torque-speed line (voltage_control)
            return ServoCommand(torque, True, torque_limit=limit, voltage_control=True,
                                goal_velocity=sign * self._si("goal_pwm") * m.no_load_speed)
        if mode == 0:
            # Current Control Mode: a torque demand. The horn turns the way it asks, as fast
            # as the motor can against the load, while the load is below it; a load above it
            # holds the horn (the default plant: stalled at the goal's torque, no further).
            share = self._current_share("goal_current")
            return ServoCommand(torque, True, torque_limit=min(limit, abs(share)),
                                torque_control=True,
                                goal_velocity=sign * math.copysign(m.no_load_speed, share)
                                if share else 0.0)
        compliance, pid, _ = self._feedback_laws()
        return ServoCommand(torque, False, goal_position=self._goal_angle(),
                            profile_velocity=velocity, torque_limit=limit,
                            compliance=compliance, pid=pid, trajectory=trajectory)

    def _feedback_laws(self) -> tuple[Compliance | None, PositionPid | None, VelocityPi | None]:
        """The position and velocity laws in SI, from the gain registers (:mod:`.gains`),
        decoded again only after one of those changed."""
        laws = self._laws
        if laws is None:
            m, get = self.model, self.get_raw
            laws = self._laws = (gains.compliance(m, get), gains.position_pid(m, get),
                                 gains.velocity_pi(m, get))
        return laws

    def _current_share(self, name: str) -> float:
        """The current register ``name`` as a share of the stall torque: torque = Kt x current,
        with the torque constant Kt = stall torque / stall current, the e-Manual's two
        specification figures at the rated voltage (XM430-W350: 4.1 N m at 2.3 A), so a
        current is its share of the stall current. (A DC motor's torque is proportional to
        its current; the no-load current that friction takes is in the plant's friction.)"""
        return self._si(name) / self.model.stall_current_a

    def _profile_registers(self, mode: int, torque: bool) -> Registers:
        """What decides the X-series profile, read from the table (SI in the joint's own
        direction where a plan needs it)."""
        return Registers(
            mode=mode, torque=torque, drive_mode=self._try_get("drive_mode"),
            goal_position=self.get_raw("goal_position"),
            goal_angle=self._goal_angle() if mode in POSITION_MODES else 0.0,
            goal_velocity=self._sign * self._si("goal_velocity"),
            profile_velocity_raw=self.get_raw("profile_velocity"),
            profile_acceleration_raw=self.get_raw("profile_acceleration"),
            profile_velocity=self._si("profile_velocity"),
            profile_acceleration=self._si("profile_acceleration"))

    def _now(self) -> float:
        """The motor's time, s: its steps on the emulator's clock (0 off a bus)."""
        emulator = self._emulator
        return self._steps_done * emulator.dt if emulator is not None else 0.0

    def _goal_angle(self) -> float:
        """goal_position as an angle of the joint (in Position Control Mode the count was
        brought within one turn when the mode or the torque came on, see :meth:`_drop_turns`,
        so a goal 0..4095 is an angle within that turn)."""
        goal = float(self.get_raw("goal_position"))
        if self._multi_turn:
            # Present Position = (Real Position / Resolution Divider) + Multi-turn Offset
            # (e-Manual, MX-28 Resolution Divider(22)); goals are in the same units.
            goal = (goal - self._try_get("multi_turn_offset")) \
                * self._try_get("resolution_divider", 1)
        firmware = units.ticks_position(self.model, goal + self._offset_ticks - self._homing)
        return self._sign * firmware

    def _update_sensors(self) -> None:
        m = self.model
        plant = self._plant
        # The present_* registers are no settings (_READINGS): written straight into the
        # table, with nothing the firmware keeps decoded to refresh (see _set_raw).
        put = self._table.put
        velocity, load = self._sign * plant.velocity, self._sign * plant.effort
        ticks = round(self._present_ticks(plant.position))
        voltage = self._supply_voltage - 0.3 * abs(load)
        if self._dx:
            if self._wheel:
                present = wheel_position(m, ticks)
            elif self._multi_turn:
                # MX-28 multi-turn: -28 672..28 672, "(Real Position / Resolution Divider) +
                # Multi-turn Offset" (e-Manual, MX-28 Angle Limit and Resolution Divider(22)).
                present = ticks // self._try_get("resolution_divider", 1) \
                    + self._try_get("multi_turn_offset")
                span = m.register("goal_position")       # ±28 672 in this mode
                present = max(span.raw_min, min(span.raw_max, present))
            else:
                # (min(max(ticks, 0), resolution - 1) by comparisons: the builtins parse their
                # keywords at every call)
                present = ticks if ticks > 0 else 0
                top = m.resolution - 1
                present = present if present < top else top
            put("present_position", present)
            if self._wheel and m.wheel_output_ratio:
                # In wheel mode present speed is the output the firmware drives, 0.1 % per
                # unit: "if it is set to 512, it means that the torque is controlled by 50 %
                # of the maximum torque" (e-Manual, EX-106+ Present Speed), so a load that
                # slows the horn does not change it.
                driving = self.get_raw("torque_enable") and self.get_raw("torque_limit")
                put("present_speed", self.get_raw("moving_speed") if driving else 0)
            else:
                self._show("present_speed", velocity)
            self._show("present_load", load)
            self._show("present_voltage", voltage)
            if self._has_sensed_current:
                # 512 is 0 mA; below it the motor pushes CCW, above it CW, 10 mA per unit
                # (e-Manual, EX-106+ Sensed Current).
                amps = load * m.stall_current_a
                put("sensed_current", max(0, min(1023, 512 - round(amps / 0.01))))
            put("moving", int(abs(velocity) > 0.5 * m.rad_per_tick))
        else:
            present = (ticks + 2**31) % 2**32 - 2**31
            put("present_position", present)
            self._show("present_velocity", velocity)
            if self._has_present_current:
                # the current that gives the motor's torque: torque / Kt (see _current_share)
                self._show("present_current", load * m.stall_current_a)
            else:
                self._show("present_load", load)
            # the voltage the motor gets: Goal PWM itself in PWM Control Mode; else the
            # share its plant runs it on (``drive``), or from a plant without one what its
            # torque and its back-EMF take (a DC motor: PWM share = torque share + speed /
            # no-load speed); within PWM Limit(36) either way
            pwm_limit = self._si("pwm_limit")
            drive = getattr(plant, "drive", None)
            applied = (self._si("goal_pwm") if self.get_raw("operating_mode") == 16
                       and self.get_raw("torque_enable") else
                       self._sign * drive if drive is not None
                       else load + velocity / m.no_load_speed)
            self._show("present_pwm", max(-pwm_limit, min(pwm_limit, applied)))
            self._show("present_input_voltage", voltage)
            put("moving", int(abs(velocity) > self._si("moving_threshold")))
            self._show_trajectory(ticks)
        if self._has_realtime_tick and self._emulator is not None and self._steps_done:
            # Realtime Tick: milliseconds, 0..32767, then again from 0 (e-Manual).
            elapsed_ms = self._steps_done * self._emulator.dt * 1000.0
            put("realtime_tick", int(elapsed_ms) % 32768)
        self._show("present_temperature", plant.temperature)
        self._stale = False
        self._sensed_step = self._steps_done

    def _show_trajectory(self, present_ticks: int) -> None:
        """Velocity Trajectory(136), Position Trajectory(140) and Moving Status(123): the
        profile generator's desired trajectory now and how the horn keeps to it (e-Manual,
        Profile Velocity(112): "Target velocity trajectory and target position trajectory
        from Profile are stored at Velocity Trajectory(136) and Position Trajectory(140)")."""
        now = self._now()
        profiles = self._profiles
        desired = profiles.desired(now)
        mode = self.get_raw("operating_mode")
        goal_ticks = self._present_ticks(self._goal_angle())
        desired_ticks: float | None = None
        if desired is not None:
            desired_ticks = self._present_ticks(desired[0])
            trajectory = (round(desired_ticks), self._sign * desired[1])
        elif mode in POSITION_MODES and self.get_raw("torque_enable"):
            trajectory = (round(goal_ticks), 0.0)    # a step: the goal at once
        else:
            trajectory = (present_ticks, self._sign * self._plant.velocity)
        self._table.put("position_trajectory", (trajectory[0] + 2**31) % 2**32 - 2**31)
        self._show("velocity_trajectory", trajectory[1])
        self._table.put("moving_status", profiles.moving_status(
            now, goal_ticks, present_ticks, desired_ticks))

    # -- instructions --------------------------------------------------------------------------
    def error_byte(self, error: int = 0) -> int:
        """The status error byte: the instruction's error plus standing hardware errors."""
        if self.model.protocol == 1:
            return error | self.hardware_error
        return error | (p2.ALERT if self.hardware_error else 0)

    def execute(self, inst: Instruction, name: str, *, secondary: bool = False) -> Status:
        """Act on an instruction addressed to this motor; return the status it would send.
        ``secondary``: it came to the motor's Secondary ID, which may change RAM only."""
        self._sync_joint()
        self._heard()
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
            # read() without its sync and _heard: the joint is synced and the motor has heard
            # the instruction (above), so only the readings may be left to refresh
            if self._stale:
                self._update_sensors()
            return self._read_table(address, length)
        if name in ("WRITE", "REG_WRITE"):
            split = 1 if v1 else 2
            if len(params) <= split:
                return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else p2.DATA_LENGTH))
            address = int.from_bytes(params[:split], "little")
            error = self.write(address, params[split:], registered=name == "REG_WRITE",
                               secondary=secondary)
            return Status(self.id, self.error_byte(error))
        if name == "ACTION":
            error = 0
            if self._pending is None:
                # Nothing registered: an instruction error on both protocols (the Protocol
                # 2.0 error table: "Action has been used without Reg Write").
                error = p1.INSTRUCTION if v1 else p2.INSTRUCTION_ERROR
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
            if (inst.id == BROADCAST_ID and option == p2.FACTORY_RESET_ALL
                    and self.model.firmware >= _BROADCAST_RESET_ALL_IGNORED_FROM):
                # "In case of when Packet ID is a Broadcast ID 0xFE and Option is Reset All
                # 0xFF, Factory Reset Instruction(0x06) will NOT be activated" (e-Manual,
                # Protocol 2.0, Factory Reset): a broadcast cannot wipe every ID on the bus.
                return Status(self.id, self.error_byte())
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
                self._set_raw(reg_name, value)
            self.clear_hardware_error()
            self._drop_turns()          # "when rebooted", as at power-up (Present Position)
            self._hold_position()
            return status
        if name == "CLEAR":
            if params[:5] != b"\x01\x44\x58\x4c\x22" or self.torque_enabled:
                return Status(self.id, self.error_byte(p2.RESULT_FAIL if params[:1] == b"\x01"
                                                       else p2.DATA_RANGE))
            # As at REBOOT: the count within one turn, the homing offset still added to it
            # (e-Manual, Present Position note).
            self._drop_turns()
            self._table_changed()
            return Status(self.id, self.error_byte())
        return Status(self.id, self.error_byte(p1.INSTRUCTION if v1 else p2.INSTRUCTION_ERROR))

    def read(self, address: int, length: int) -> Status:
        self.sync()
        self._heard()
        return self._read_table(address, length)

    def _read_table(self, address: int, length: int) -> Status:
        """The status of a READ of a synced table (:meth:`read` but the sync)."""
        data = self._table.read(address, length)
        if data is None:
            v1 = self.model.protocol == 1
            return Status(self.id, self.error_byte(p1.RANGE if v1 else p2.ACCESS))
        return Status(self.id, self.error_byte(), data)

    def write(self, address: int, data: bytes, *, registered: bool = False,
              secondary: bool = False) -> int:
        """Write ``data`` at ``address`` as the firmware would; return the error (0 if none).

        Every byte must land in a writable register, every touched register must end in its
        range, and on 2.0 the EEPROM is locked while torque is on (and to a Secondary ID); on
        1.0 the Lock register locks it. Bytes written to Indirect Data go on to the address
        their Indirect Address names. Nothing changes on error.
        """
        self._sync_joint()
        self._heard()
        m = self.model
        v1 = m.protocol == 1
        staged = self._table.stage(address, data)
        if isinstance(staged, int):
            return staged   # a byte outside every register, read-only, or part of an item
        names = staged.names
        eeprom = any(r.area == "EEPROM" for r in staged.touched)
        if not v1 and eeprom and (secondary or self.torque_enabled):
            return p2.ACCESS
        if m.has("lock") and self.get_raw("lock") and (eeprom or "lock" in names):
            # "If Lock is set to 1, the power must be turned off and then turned on again to
            # change into 0" (e-Manual, Lock); a locked address answers a range error (AX-12
            # manual, example 20).
            return p1.RANGE
        if self._watchdog_tripped and (names & _GOALS_2 or (
                "bus_watchdog" in names and staged.scratch[m.register("bus_watchdog").address])):
            # After a bus watchdog error the goals are read-only, a Data Range Error; "If the
            # value of Bus Watchdog(98) is changed to '0', Bus Watchdog Error will be cleared"
            # (e-Manual, Bus Watchdog(98)): 0 is the only way out.
            return p2.DATA_RANGE
        error = self._table.check(staged)
        if error:
            return error
        if registered:
            self._pending = (address, bytes(data))
            self._set_registered(1)
            return 0
        self._table.commit(staged)
        if names & _GOALS_2:
            self._watchdog_hold = False     # a new goal after a bus watchdog stop
        self._torque_rules(names)
        self._table_changed(names)
        return 0

    def _torque_rules(self, written: frozenset[str]) -> None:
        """What a write does to torque besides what it wrote."""
        torque = self.model.register("torque_enable")
        if self.model.protocol == 1:
            # Protocol 1.0: a goal position or moving speed switches torque on.
            if written & _TORQUE_ON_1 and "torque_enable" not in written:
                self.table[torque.address] = 1
            return
        if self._shut_down():
            self.table[torque.address] = 0   # only a REBOOT brings torque back
        elif (self._torque_on_goal and written & _GOALS_2
              and "torque_enable" not in written):
            # Drive Mode bit 3: "If the value of Torque Enable(64) is '0' and the command is
            # given, the Torque Enable(64) switches to '1'" (e-Manual, Drive Mode(10)).
            self.table[torque.address] = 1

    def _set_registered(self, value: int) -> None:
        name = "registered" if self.model.protocol == 1 else "registered_instruction"
        self._set_raw(name, value)


def wheel_position(model: Model, ticks: int) -> int:
    """present_position of a 1.0 model in wheel mode, for the unbounded count ``ticks``
    (:attr:`~.models.Model.wheel_position` says which sensor the model has).

    EX-106+: the encoder count, 0..65535 and round again (e-Manual, EX-106+ Present Position:
    "If it is decreased when the value is 0, it becomes 65535"). AX/RX: a potentiometer that
    reads 0..1023 over 300° of each turn; in the 60° it cannot read, servolab reports the
    nearer end of the track (the e-Manual says only that the value cannot be used to measure
    distance there). MX: the magnetic encoder's 0..4095 of each turn.
    """
    if model.wheel_position == "encoder16":
        return ticks % 65536
    if model.wheel_position == "potentiometer":
        per_tick = model.angle_range_deg / (model.resolution - 1)
        angle = (ticks * per_tick) % 360.0
        if angle <= model.angle_range_deg:
            return min(model.resolution - 1, round(angle / per_tick))
        gap = 360.0 - model.angle_range_deg
        return model.resolution - 1 if angle - model.angle_range_deg < gap / 2 else 0
    return ticks % model.resolution


def _check_id(model: Model, motor_id: int) -> int:
    max_id = 253 if model.protocol == 1 else 252
    if not isinstance(motor_id, int) or not 0 <= motor_id <= max_id:
        raise ConfigError(f"{model.name}: motor ID {motor_id!r} is outside 0..{max_id}")
    return motor_id


