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
from collections.abc import Callable
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


def wheel_speed(model: Model, raw: int) -> float:
    """A 1.0 wheel-mode moving/present speed of a model whose wheel mode sets the output
    (:attr:`~.models.Model.wheel_output_ratio`, AX/RX/EX) as rad/s: the share of the output
    it gives (0.1 % a unit, 1023 = 100 %, bit 10 = clockwise; e-Manual, Moving Speed and
    EX-106+ Present Speed) times the model's no-load speed.

    That is the speed of the *unloaded* horn: "In Wheel Mode, only the output control is
    possible, not speed" (e-Manual, Moving Speed), so under load the horn turns slower than
    the figure written, and present_speed reads the output the firmware applies, not the
    horn's speed."""
    share = (raw & 0x3FF) / 1023
    return -share * model.no_load_speed if raw & 0x400 else share * model.no_load_speed


def wheel_speed_raw(model: Model, value: float) -> int:
    """The inverse of :func:`wheel_speed`: ``round(|value| / no_load_speed * 1023)``, bit 10
    when negative; :class:`ConfigError` beyond full output (a faster unloaded speed cannot be
    asked for)."""
    magnitude = round(abs(value) / model.no_load_speed * 1023)
    if not magnitude <= 0x3FF:   # (nan fails too)
        raise ConfigError(f"{model.name} moving_speed: {value} rad/s in wheel mode is more than "
                          f"full output gives unloaded ({model.no_load_speed:.3f} rad/s)")
    return magnitude | 0x400 if value < 0 and magnitude else magnitude


def to_si(model: Model, register: Register, raw: int, *, wheel: bool = False) -> float:
    """Convert a raw register value (already sign-extended where signed) to SI.

    ``wheel``: the motor is in 1.0 wheel mode (both angle limits 0); on the models where that
    makes moving/present speed an output ratio (:attr:`~.models.Model.wheel_output_ratio`)
    they convert by :func:`wheel_speed`. It changes nothing elsewhere."""
    kind = register.unit
    if kind in ("raw", "bool"):
        return raw
    if kind == "position":
        return (raw - model.position_center) * model.rad_per_tick
    if kind == "position_offset":
        return raw * model.rad_per_tick
    if kind == "speed_sign_bit":
        if wheel and model.wheel_output_ratio:
            return wheel_speed(model, raw)
        return _sign_bit_to_si(raw, velocity_unit(model))
    if kind == "velocity":
        return raw * velocity_unit(model)
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


def position_ticks(model: Model, position: float) -> float:
    """The encoder count of an angle, unbounded and unrounded: what the firmware counts as the
    horn turns (``position`` in rad from the model's centre tick)."""
    return position / model.rad_per_tick + model.position_center


def ticks_position(model: Model, ticks: float) -> float:
    """The angle (rad) of an unbounded encoder count; the inverse of :func:`position_ticks`."""
    return (ticks - model.position_center) * model.rad_per_tick


def tick_span(model: Model, ticks: float) -> float:
    """An angle of ``ticks`` encoder counts, in rad (a width, not a position: compliance
    margins and slopes)."""
    return ticks * model.rad_per_tick


def velocity_unit(model: Model) -> float:
    """rad/s per unit of the model's speed registers (moving speed, goal/present velocity)."""
    return model.speed_unit_rpm * RPM


def reading(model: Model, register: Register, value: float) -> int:
    """The raw value a sensor register shows for an SI ``value``: rounded, and held at what
    the register can hold (a servo's present speed, load or voltage saturates; it does not
    fail).

    The emulated firmware writes every present_* register through here (by :func:`reader`),
    so the readings and the driver's :func:`to_si` use the same scales."""
    return reader(model, register)(value)


def reader(model: Model, register: Register) -> Callable[[float], int]:
    """:func:`reading` of one register of one model, as a function of the SI value alone:
    the model's scale and the register's bounds looked up once, then the same operations on
    the same numbers (the emulated firmware shows a dozen registers at every read)."""
    kind = register.unit
    if kind in ("speed_sign_bit", "load_sign_bit"):
        scale = velocity_unit(model) if kind == "speed_sign_bit" else 0.001

        def sign_bit(value: float) -> int:
            # (min() by a comparison: the builtin parses its keywords at every call)
            magnitude = round(abs(value) / scale)
            if magnitude > 0x3FF:
                magnitude = 0x3FF
            return magnitude | 0x400 if value < 0 and magnitude else magnitude

        return sign_bit
    bits = 8 * register.size  # what the register can hold, not what a host may write to it
    low, high = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if register.signed else (
        0, (1 << bits) - 1)
    if register.maximum is not None:  # a sensor with a range of its own: Present Load's
        low, high = max(low, register.raw_min), min(high, register.raw_max)  # -1000 ~ 1000
    # (below, max(low, min(high, raw)) by comparisons, as those builtins parse their keywords at
    # every call: the same value, a tie kept as the builtins keep it)
    if kind in ("raw", "bool", "temperature"):

        def rounded(value: float) -> int:   # (_raw's arithmetic for these kinds)
            raw = round(float(value))
            raw = raw if raw < high else high
            return raw if raw > low else low

        return rounded
    linear = _scale(model, kind)
    if linear is None:
        return lambda value: max(low, min(high, _raw(model, register, float(value))))
    divisor, offset = linear

    def divided(value: float) -> int:   # (_raw's arithmetic, bit for bit)
        raw = round(float(value) / divisor) + offset
        raw = raw if raw < high else high
        return raw if raw > low else low

    return divided


def _scale(model: Model, kind: str) -> tuple[float, int] | None:
    """(the SI value of one unit, the raw value of SI 0) of the kinds whose raw value is
    round(value / unit) + offset; None for the others."""
    if kind == "position":
        return model.rad_per_tick, model.position_center
    if kind == "position_offset":
        return model.rad_per_tick, 0
    if kind == "velocity":
        return velocity_unit(model), 0
    if kind == "acceleration":
        return model.acceleration_unit_rpm2 * RPM / 60.0, 0
    if kind == "load":
        return 0.001, 0
    if kind == "current":
        return model.current_unit_a, 0
    if kind == "voltage":
        return 0.1, 0
    if kind == "delay_2us":
        return 2e-6, 0
    return None


def _raw(model: Model, register: Register, value: float) -> int:
    """SI -> raw for the kinds without a sign bit, unchecked."""
    kind = register.unit
    scale = _scale(model, kind)
    if scale is not None:
        return round(value / scale[0]) + scale[1]
    if kind in ("raw", "bool", "temperature"):
        return round(value)
    if kind == "torque_ratio":
        return round(value * 1023.0)
    if kind == "pwm":
        return round(value * 885.0)
    if kind == "baud":
        return model.baud_register_for(int(value))
    raise ConfigError(f"register {register.name!r}: unknown unit kind {kind!r}")


def from_si(model: Model, register: Register, value: float, *, wheel: bool = False) -> int:
    """Convert an SI value to the raw register value, or raise :class:`ConfigError` when the
    value is not a finite number or falls outside the register's range.

    ``wheel`` as in :func:`to_si`: a wheel-mode moving speed on a model whose wheel mode sets
    the output converts by :func:`wheel_speed_raw` (the unloaded speed, at most the no-load
    speed)."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ConfigError(
            f"{model.name} {register.name}: {value!r} is not a number") from None
    if not math.isfinite(value):
        raise ConfigError(f"{model.name} {register.name}: {value!r} is not a finite number")
    kind = register.unit
    if kind in ("raw", "bool") and value != int(value):
        raise ConfigError(f"{model.name} {register.name}: {value!r} is not a whole number")
    if kind == "speed_sign_bit" and wheel and model.wheel_output_ratio:
        raw = wheel_speed_raw(model, value)
    elif kind == "speed_sign_bit":
        raw = _si_to_sign_bit(value, velocity_unit(model))
        if round(abs(value) / velocity_unit(model)) > 0x3FF:
            raw = register.raw_max + 1  # the magnitude does not fit its 10 bits
    elif kind == "load_sign_bit":
        raw = _si_to_sign_bit(value, 0.001)
        if round(abs(value) / 0.001) > 0x3FF:
            raw = register.raw_max + 1
    elif kind in ("raw", "bool"):
        raw = int(value)
    else:
        raw = _raw(model, register, value)
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
