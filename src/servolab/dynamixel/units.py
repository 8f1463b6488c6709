"""Conversions between raw register values and SI units.

Each register of a control table names one of the *kinds* below; the model supplies the scale
(ticks per radian, rpm per speed unit, ...). This module is the only place where ticks become
radians, so a unit bug has one place to live.

SI here means: radians, rad/s, rad/s², seconds, volts, amperes, degrees Celsius (as the e-Manual
and ``sensor_msgs/Temperature`` report it) and dimensionless fractions for load, torque limit
and PWM (1.0 = 100 %).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .errors import ConfigError

if TYPE_CHECKING:
    from .models import Model, Register

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm

#: The kinds of unit a register may have, each with its SI unit (for messages and docs).
KINDS: dict[str, str] = {
    "raw": "",
    "bool": "",
    "position": "rad",            # absolute: 0 rad at the model's centre tick
    "position_offset": "rad",     # relative (homing offset, multi-turn offset)
    "speed_sign_bit": "rad/s",    # 1.0: magnitude 0..1023, bit 10 = clockwise (negative)
    "velocity": "rad/s",          # 2.0: signed 32-bit
    "acceleration": "rad/s^2",
    "load_sign_bit": "",          # 1.0: magnitude 0..1023 (0.1 %), bit 10 = clockwise
    "load": "",                   # 2.0: signed, 0.1 %
    "torque_ratio": "",           # 1.0 max torque / torque limit: 1023 = 100 %
    "pwm": "",                    # 2.0: 885 = 100 %
    "current": "A",
    "voltage": "V",
    "temperature": "degC",
    "delay_2us": "s",
    "baud": "bps",
}


def _sign_bit_to_si(raw: int, scale: float) -> float:
    magnitude = raw & 0x3FF
    return -magnitude * scale if raw & 0x400 else magnitude * scale


def _si_to_sign_bit(value: float, scale: float) -> int:
    magnitude = round(abs(value) / scale)
    return magnitude | 0x400 if value < 0 and magnitude else magnitude


def to_si(model: Model, register: Register, raw: int) -> float:
    """Convert a raw register value (already sign-extended where signed) to SI."""
    kind = register.unit
    if kind in ("raw", "bool"):
        return raw
    if kind == "position":
        return (raw - model.position_center) * model.rad_per_tick
    if kind == "position_offset":
        return raw * model.rad_per_tick
    if kind == "speed_sign_bit":
        return _sign_bit_to_si(raw, model.speed_unit_rpm * RPM)
    if kind == "velocity":
        return raw * model.speed_unit_rpm * RPM
    if kind == "acceleration":
        return raw * model.acceleration_unit_rpm2 * RPM / 60.0
    if kind == "load_sign_bit":
        return _sign_bit_to_si(raw, 0.001)
    if kind == "load":
        return raw * 0.001
    if kind == "torque_ratio":
        return raw / 1023.0
    if kind == "pwm":
        return raw / 885.0
    if kind == "current":
        return raw * model.current_unit_a
    if kind == "voltage":
        return raw * 0.1
    if kind == "temperature":
        return float(raw)
    if kind == "delay_2us":
        return raw * 2e-6
    if kind == "baud":
        return float(model.baud_from_register(raw))
    raise ConfigError(f"register {register.name!r}: unknown unit kind {kind!r}")


def from_si(model: Model, register: Register, value: float) -> int:
    """Convert an SI value to the raw register value, or raise :class:`ConfigError` when the
    value is not a finite number or falls outside the register's range."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{model.name} {register.name}: {value!r} is not a number") from None
    if not math.isfinite(value):
        raise ConfigError(f"{model.name} {register.name}: {value!r} is not a finite number")
    kind = register.unit
    if kind in ("raw", "bool"):
        if value != int(value):
            raise ConfigError(f"{model.name} {register.name}: {value!r} is not a whole number")
        raw = int(value)
    elif kind == "position":
        raw = round(value / model.rad_per_tick) + model.position_center
    elif kind == "position_offset":
        raw = round(value / model.rad_per_tick)
    elif kind == "speed_sign_bit":
        raw = _si_to_sign_bit(value, model.speed_unit_rpm * RPM)
        if round(abs(value) / (model.speed_unit_rpm * RPM)) > 0x3FF:
            raw = register.raw_max + 1  # the magnitude does not fit its 10 bits
    elif kind == "velocity":
        raw = round(value / (model.speed_unit_rpm * RPM))
    elif kind == "acceleration":
        raw = round(value / (model.acceleration_unit_rpm2 * RPM / 60.0))
    elif kind == "load_sign_bit":
        raw = _si_to_sign_bit(value, 0.001)
        if round(abs(value) / 0.001) > 0x3FF:
            raw = register.raw_max + 1
    elif kind == "load":
        raw = round(value / 0.001)
    elif kind == "torque_ratio":
        raw = round(value * 1023.0)
    elif kind == "pwm":
        raw = round(value * 885.0)
    elif kind == "current":
        raw = round(value / model.current_unit_a)
    elif kind == "voltage":
        raw = round(value / 0.1)
    elif kind == "temperature":
        raw = round(value)
    elif kind == "delay_2us":
        raw = round(value / 2e-6)
    elif kind == "baud":
        raw = model.baud_register_for(int(value))
    else:
        raise ConfigError(f"register {register.name!r}: unknown unit kind {kind!r}")
    if not register.raw_min <= raw <= register.raw_max:
        if kind.endswith("sign_bit"):
            top = to_si(model, register, min(register.raw_max, 0x3FF))
            lo, hi = (-top if register.raw_max > 0x3FF else 0.0), top
        else:
            lo = to_si(model, register, register.raw_min)
            hi = to_si(model, register, register.raw_max)
        unit = KINDS.get(kind, "")
        raise ConfigError(
            f"{model.name} {register.name}: {value:g}{' ' + unit if unit else ''} is outside "
            f"{min(lo, hi):.6g}..{max(lo, hi):.6g}{' ' + unit if unit else ''} "
            f"(raw {raw} is outside {register.raw_min}..{register.raw_max})")
    return raw
