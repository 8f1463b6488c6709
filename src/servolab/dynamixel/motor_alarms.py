"""An emulated servo's alarms: the hardware errors its firmware finds (input voltage,
overheating, overload), what the shutdown register makes of them, and the bus watchdog.

A mixin of :class:`~.virtual_motor.VirtualMotor`, which owns the state these read (its table,
its plant, its clock); kept apart because it is the part of the firmware that decides when a
motor stops, and each rule here cites the e-Manual's words for it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .errors import ConfigError
from .models import Model
from .plant import ServoPlant

if TYPE_CHECKING:
    from .emulator import Emulator

#: How far below Temperature Limit a 1.0 servo must cool before its status packets stop
#: reporting the overheating it found (°C). ROBOTIS publish no figure; the e-Manual asks for
#: 20 minutes of cooling after a temperature shutdown (Temperature Limit, caution). Without a
#: margin the error would last one physics step: once the shutdown has cut the output, the
#: windings cool at once (:mod:`.plant`), and a host polling at 10 Hz would never see it.
OVERHEATING_HYSTERESIS_C = 5.0
#: How long a load must beat the motor's output before the firmware calls it an overload,
#: s. The e-Manual says only "persistent load that exceeds maximum output" (X-series,
#: Shutdown(63), bit 5) and "the current load cannot be controlled" (RX-28, Alarm
#: Shutdown); a second is assumed: a joint saturating for a moment as it accelerates or
#: lands a step is not overloaded, one pushed against a wall for a second is.
OVERLOAD_TIME_S = 1.0
#: Bus Watchdog(98) counts in 20 ms units (e-Manual, Bus Watchdog(98)).
_WATCHDOG_UNIT_S = 0.020


def hardware_bit(model: Model, name: str) -> int:
    """The bit of hardware error ``name`` (as the e-Manual spells it) on ``model``."""
    table = model.hardware_error_bits()
    for bit, bit_name in table.items():
        if bit_name == name:
            return bit
    known = list(table.values())
    raise ConfigError(f"{model.name}: unknown hardware error {name!r}; "
                      f"use one of {', '.join(known)}")


class Alarms:
    """The alarm rules over a motor's state (see the module docstring)."""

    if TYPE_CHECKING:   # what the motor it is mixed into provides
        model: Model
        hardware_error: int
        _plant: ServoPlant
        _emulator: Emulator | None
        _dx: bool
        _supply_voltage: float
        _temperature_limit: float
        _max_output: float
        _overheating_bit: int
        _overload_bit: int
        _too_hot: bool
        _overloaded: bool
        _stall_step: int | None
        _watchdog_tripped: bool
        _watchdog_hold: bool
        _heard_step: int

        def get_raw(self, name: str) -> int: ...
        def _set_raw(self, name: str, value: int) -> None: ...
        def _si(self, name: str) -> float: ...
        def _try_get(self, name: str, default: int = 0) -> int: ...
        def sync(self) -> None: ...

    def _check_voltage(self) -> None:
        """Input Voltage Error while the supply is outside Min/Max Voltage Limit (e-Manual,
        Min/Max Voltage Limit). A 1.0 servo reports the condition as it stands; an X-series
        keeps the bit in Hardware Error Status until a REBOOT."""
        if not self.model.has("min_voltage_limit"):
            return
        bit = hardware_bit(self.model, "input voltage")
        low, high = self._si("min_voltage_limit"), self._si("max_voltage_limit")
        outside = not low <= self._supply_voltage <= high
        if outside and not self.hardware_error & bit:
            self._hardware_error(bit)
        elif not outside and self.hardware_error & bit and self.model.protocol == 1:
            self.hardware_error &= ~bit
            self._sync_hardware_register()

    def inject_hardware_error(self, name: str) -> None:
        """Raise a hardware error as the real motor would: ``overload``, ``overheating``,
        ``input voltage`` (and on 2.0 ``motor encoder``, ``electrical shock``). Torque goes off
        when the model's shutdown register selects that error (the default for overload and
        overheating)."""
        self.sync()
        self._hardware_error(hardware_bit(self.model, name))

    def _hardware_error(self, bit: int) -> None:
        self.hardware_error |= bit
        if self.get_raw("shutdown") & bit:
            if self._dx:
                # 1.0: "the motor output becomes 0 % by resetting the value of Torque
                # Limit(34) to 0"; torque enable stays, and writing a torque limit other than
                # 0 lets the motor run again (e-Manual, Alarm Shutdown and Torque Limit).
                self._set_raw("torque_limit", 0)
            else:
                # X-series: "Torque Enable(64) is cleared to '0' ... REBOOT is the only method
                # to reset Torque Enable(64) to '1' after the shutdown" (e-Manual, Shutdown).
                self._set_raw("torque_enable", 0)
        self._sync_hardware_register()

    def _shut_down(self) -> bool:
        """An X-series motor stopped by a shutdown error, until a REBOOT."""
        return not self._dx and bool(self.hardware_error & self.get_raw("shutdown"))

    def clear_hardware_error(self) -> None:
        self.hardware_error = 0
        self._too_hot = self._overloaded = False
        self._stall_step = None     # a stall after a REBOOT counts afresh
        self._sync_hardware_register()
        self._check_voltage()       # a supply still out of its limits is an error again

    def _sync_hardware_register(self) -> None:
        if self.model.has("hardware_error_status"):
            self._set_raw("hardware_error_status", self.hardware_error)

    def _watchdog_deadline(self) -> int | None:
        """The step at which the bus watchdog stops the motor, or None while it is not armed.

        It watches "the communication interval ... when Torque Enable(64) is '1'", in units of
        20 ms (e-Manual, Bus Watchdog(98))."""
        period = self._try_get("bus_watchdog")
        emulator = self._emulator
        if (period <= 0 or self._watchdog_tripped or emulator is None
                or not emulator.dt > 0 or not self.get_raw("torque_enable")):
            return None
        return self._heard_step + math.ceil(period * _WATCHDOG_UNIT_S / emulator.dt - 1e-9)

    def _watchdog_trip(self) -> None:
        """No instruction for longer than the bus watchdog: the motor stops and Bus
        Watchdog(98) reads -1 until a host writes 0 (e-Manual, Bus Watchdog(98)). It stays
        stopped until a new goal comes: clearing the error alone does not send it on toward a
        goal from before the silence (the e-Manual's example writes a new goal)."""
        self._watchdog_tripped = True
        self._watchdog_hold = True
        self._set_raw("bus_watchdog", -1)

    def _overload_step(self, now: int, dt: float) -> int | None:
        """The step on which a stall that holds now becomes an overload (None: no stall),
        counting from the step it was first seen on."""
        if not self._overload_due():
            self._stall_step = None
            return None
        if self._stall_step is None:
            self._stall_step = now
        return self._stall_step + max(1, math.ceil(OVERLOAD_TIME_S / dt - 1e-9))

    def _overload_due(self) -> bool:
        """The motor gives torque and the plant is stalled by a load its torque limit cannot
        hold — "Overload Error: when the current load cannot be controlled with the set
        maximum torque" (e-Manual, RX-28 Alarm Shutdown) — and the firmware has yet to say
        so, or (1.0) a host gave the motor its torque limit back while the load still beats
        it. (A motor whose torque limit is 0 is not trying: no overload.) A world's plant
        takes part when it has a ``stalled`` attribute, as :class:`~.plant.KinematicServo`
        does."""
        plant = self._plant
        if not (getattr(plant, "stalled", False) and plant.command.torque_limit > 0):
            return False
        if plant.command.torque_limit < self._max_output:
            return False  # held at a goal current the host asked for: not an overload
        bit = self._overload_bit
        if not self.hardware_error & bit:
            return True
        return self.model.protocol == 1 and bool(self.get_raw("shutdown") & bit)

    def _overload(self) -> None:
        """The overload error, found by the firmware: a bit of every status error byte (1.0)
        or of Hardware Error Status (2.0), and a shutdown when the shutdown register selects
        it (RX-28 default 0x24: overheating and overload; e-Manual, Alarm Shutdown)."""
        self._hardware_error(self._overload_bit)
        self._overloaded = True

    def _unloaded(self) -> None:
        """A 1.0 servo reports overload while the load it cannot control lasts (as it does
        overheating); an X-series keeps it in Hardware Error Status until a REBOOT. After a
        1.0 shutdown (torque limit 0) a load that still pushes keeps the condition."""
        if (self._overloaded and self.model.protocol == 1
                and not getattr(self._plant, "stalled", False)):
            self.hardware_error &= ~self._overload_bit
            self._overloaded = False

    def _cooled_down(self, overheating: int) -> None:
        """A 1.0 servo reports overheating while it lasts (its status error byte is the
        condition now) — until it has cooled :data:`OVERHEATING_HYSTERESIS_C` below the
        limit; an X-series keeps it in Hardware Error Status until a REBOOT."""
        if (self._too_hot and self.model.protocol == 1 and self._plant.temperature
                <= self._temperature_limit - OVERHEATING_HYSTERESIS_C):
            self.hardware_error &= ~overheating
            self._too_hot = False

    def _check_alarms(self) -> None:
        """Overheating and overload, found (or over) on the plant as it is now."""
        overheating = self._overheating_bit
        plant = self._plant
        if (plant.temperature > self._temperature_limit
                and not self.hardware_error & overheating):
            self._hardware_error(overheating)
            self._too_hot = True
        emulator = self._emulator
        if emulator is not None and emulator.dt > 0:
            # (seen after a step: the stall held during it, from the step before)
            due = self._overload_step(emulator.steps - 1, emulator.dt)
            if due is not None and emulator.steps >= due:
                self._overload()
        elif getattr(plant, "stalled", False) and self._overload_due():
            self._overload()    # (a motor off any bus has no clock: at once)
        if self._too_hot:
            self._cooled_down(overheating)
        if self._overloaded:
            self._unloaded()
