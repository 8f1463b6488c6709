"""A differential-drive base's configuration: its bus, its wheel motors and its geometry.

Everything that differs between two bases is here, never in code (seed 000's two-wheel robot
on EX-106+ in wheel mode, its 4-motor variant, a TurtleBot3 Waffle on XM430s)::

    base:
      name: seed000
      model: EX-106+          # every wheel motor's model (servolab.dynamixel.models)
      protocol: 1
      baudrate: 1000000
      wheel_radius: 0.052     # m
      wheel_separation: 0.38  # m, between the wheels' contact points
      max_linear_velocity: 0.5    # m/s   (optional: else what the motors can do)
      max_angular_velocity: 2.0   # rad/s (optional)
      motors:
        - {id: 0, side: left, direction: 1}
        - {id: 1, side: right, direction: -1}

``wheel_clamp`` (optional) says how wheel speeds past the limit come back within it:
``scaled`` (the default) scales both by one factor, so the robot keeps its path and only
slows; ``per-wheel`` clamps each on its own, as seed 002's Listing 4 does (the limit is
``max_linear_velocity`` at the wheel's rim, else the motor's no-load speed).

``drive_mode: reverse`` (optional, Protocol 2.0 motors) sets the motor's Drive Mode bit 0, so
that the motor itself turns the other way: ROBOTIS's ``turtlebot3_setup_motor.ino`` (OpenCR)
writes it on a TurtleBot3's right motor, so that a positive speed drives both wheels forward
and both encoders count up. ``direction`` is then as the motor sees it, reverse included.

``direction`` is +1 when the motor's positive speed (counter-clockwise seen from the horn,
ROBOTIS's convention) drives its wheel forwards, -1 when it is mounted mirrored. Several motors
may share a side (the 4-motor base of 000 A.2): they are driven alike.

Errors are :class:`BaseConfigError`, one line ``file:line: message`` naming the key, raised by
:mod:`servolab.configfile` before any port is opened.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ...configfile import ConfigMapping, ConfigValue, shipped, suggest
from ...configfile import load as load_config
from ...dynamixel.errors import ConfigError
from ...dynamixel.models import Model, model
from ...errors import ConfigFileError
from . import DEFAULT_BASE, SHIPPED

_TOP = ("base",)
_BASE_KEYS = ("name", "model", "protocol", "baudrate", "wheel_radius", "wheel_separation",
              "max_linear_velocity", "max_angular_velocity", "motors", "wheel_clamp")
#: How wheel speeds past the limit are brought back: ``scaled`` both by one factor (the path
#: is kept: servolab's default), ``per-wheel`` each on its own (seed 002's Listing 4).
WHEEL_CLAMPS = ("scaled", "per-wheel")
_REQUIRED = ("model", "protocol", "baudrate", "wheel_radius", "wheel_separation", "motors")
_MOTOR_KEYS = ("id", "side", "direction", "drive_mode")
_MOTOR_REQUIRED = ("id", "side", "direction")
SIDES = ("left", "right")


class BaseConfigError(ConfigFileError):
    """A base configuration file that cannot be used."""


@dataclass(frozen=True)
class WheelMotor:
    id: int
    side: str       # left | right
    direction: int  # +1: positive motor speed drives the wheel forwards; -1: mirrored
    #: Drive Mode bit 0 set ("reverse"): the motor itself turns the other way for a positive
    #: speed, as ROBOTIS's turtlebot3_setup_motor.ino sets the Waffle's right motor
    reverse: bool = False

    @property
    def mounting(self) -> int:
        """+1 when the horn turning counter-clockwise drives the wheel forwards, -1 when the
        motor is mounted mirrored: ``direction`` as the motor would see it in normal mode."""
        return -self.direction if self.reverse else self.direction


@dataclass(frozen=True)
class BaseConfig:
    """A differential-drive base (see the module docstring); SI units."""

    name: str
    model: Model
    protocol: int
    baudrate: int
    wheel_radius: float
    wheel_separation: float
    motors: tuple[WheelMotor, ...]
    max_linear_velocity: float | None = None
    max_angular_velocity: float | None = None
    path: str = ""
    #: one of :data:`WHEEL_CLAMPS`
    wheel_clamp: str = "scaled"

    @property
    def max_wheel_speed(self) -> float:
        """The fastest a wheel may turn (rad/s): the model's no-load speed."""
        return float(self.model.no_load_speed)

    def side(self, side: str) -> tuple[WheelMotor, ...]:
        return tuple(m for m in self.motors if m.side == side)


def shipped_base(name: str) -> Path:
    """The shipped configuration file of base ``name`` (one of :data:`SHIPPED`)."""
    if name not in SHIPPED:
        raise BaseConfigError(name, 0, "", f"no shipped base {name!r}; there are "
                              f"{', '.join(SHIPPED)} (or give a file)")
    return shipped(__package__ or "servolab.robots.base", f"base_{name}.yaml")


def resolve(base: str | Path | None) -> Path:
    """A base as a user names it: a shipped base's name (``turtlebot3_waffle``), a file, or
    nothing for seed 000's two-wheel robot."""
    if base is None or base == "":
        return shipped_base(DEFAULT_BASE)
    if isinstance(base, str) and base in SHIPPED:
        return shipped_base(base)
    path = Path(base)
    if not path.exists() and not path.suffix and len(path.parts) == 1:  # meant a name
        hint = suggest(str(base), SHIPPED)
        raise BaseConfigError(base, 0, "", "no such file, nor a shipped base" +
                              (f"; did you mean {hint}?" if hint else
                               f" ({', '.join(SHIPPED)})"))
    return path


#: the folder of the shipped bases: a scene's ``base:`` is looked for here too
SHIPPED_DIR = shipped_base(DEFAULT_BASE).parent
SEED_000_BASE = shipped_base("seed000")


def load(path: str | Path) -> BaseConfig:
    """Read a base configuration file (see the module docstring)."""
    top = load_config(path, what="base configuration", error=BaseConfigError)
    return parse(top, str(path))


def parse(top: ConfigValue, path: str = "") -> BaseConfig:
    mapping = top.as_mapping("a base configuration")
    mapping.check_keys(_TOP, required=_TOP)
    base = mapping.require("base").as_mapping("key 'base'")
    base.check_keys(_BASE_KEYS, required=_REQUIRED, what="base")
    model_value = base.require("model")
    try:
        wheel_model = model(model_value.as_str(nonempty=True))
    except ConfigError as exc:
        raise model_value.error(f"base.model: {exc}") from None
    if wheel_model.protocol == 1 and wheel_model.wheel_position == "potentiometer":
        raise model_value.error(f"base.model: the {wheel_model.name} reads a potentiometer in "
                                "wheel mode, not an encoder: odometry cannot count its turns")
    protocol = base.require("protocol").as_int("base.protocol")
    if protocol != wheel_model.protocol:
        raise base.require("protocol").error(
            f"base.protocol {protocol}: the {wheel_model.name} speaks Protocol "
            f"{wheel_model.protocol}.0")
    baud_value = base.require("baudrate")
    baudrate = baud_value.as_int("base.baudrate")
    try:
        wheel_model.baud_register_for(baudrate)
    except ConfigError as exc:
        raise baud_value.error(f"base.baudrate: {exc}") from None
    radius = _positive(base, "wheel_radius", "m")
    separation = _positive(base, "wheel_separation", "m")
    limits = {key: _positive(base, key, unit) if key in base else None
              for key, unit in (("max_linear_velocity", "m/s"),
                                ("max_angular_velocity", "rad/s"))}
    top_linear = wheel_model.no_load_speed * radius
    linear = limits["max_linear_velocity"]
    if linear is not None and linear > top_linear:
        raise base.require("max_linear_velocity").error(
            f"base.max_linear_velocity {linear:g} m/s is over what a {wheel_model.name} can "
            f"drive a {radius:g} m wheel at ({top_linear:.3g} m/s, its no-load speed)")
    motors = _motors(base)
    if protocol == 1 and any(m.reverse for m in motors):
        raise base.require("motors").error(
            "base.motors: drive_mode reverse needs a Protocol 2.0 motor (a 1.0 motor in wheel "
            "mode ignores Drive Mode, e-Manual): give the mirrored motor direction -1 instead")
    name_value = base.get("name")
    clamp = "scaled"
    clamp_value = base.get("wheel_clamp")
    if clamp_value is not None:
        clamp = clamp_value.as_str("base.wheel_clamp")
        if clamp not in WHEEL_CLAMPS:
            guess = suggest(clamp, WHEEL_CLAMPS)
            raise clamp_value.error(f"base.wheel_clamp must be {' or '.join(WHEEL_CLAMPS)}, "
                                    f"not {clamp!r}"
                                    + (f" (did you mean {guess!r}?)" if guess else ""))
    return BaseConfig(name_value.as_str(nonempty=True) if name_value is not None
                      else Path(path).stem, wheel_model, protocol, baudrate, radius,
                      separation, motors, linear, limits["max_angular_velocity"], path,
                      clamp)


def _positive(base: ConfigMapping, key: str, unit: str) -> float:
    value = base.require(key, "base")
    number = value.as_float(f"base.{key}")
    if not (math.isfinite(number) and number > 0):
        raise value.error(f"base.{key} must be a distance or speed > 0 {unit}, "
                          f"not {number:g}")
    return number


def _motors(base: ConfigMapping) -> tuple[WheelMotor, ...]:
    items = base.require("motors").as_list("base.motors")
    motors: list[WheelMotor] = []
    seen: set[int] = set()
    for k, item in enumerate(items):
        what = f"base.motors[{k}]"
        m = item.as_mapping(what)
        m.check_keys(_MOTOR_KEYS, required=_MOTOR_REQUIRED, what=what)
        motor_id = m.require("id").as_int(f"{what}.id")
        if not 0 <= motor_id <= 252:
            raise m.require("id").error(f"{what}.id {motor_id} is outside 0..252")
        if motor_id in seen:
            raise m.require("id").error(f"{what}.id {motor_id} is given twice")
        seen.add(motor_id)
        side = m.require("side").as_str(f"{what}.side")
        if side not in SIDES:
            raise m.require("side").error(f"{what}.side must be left or right, not {side!r}")
        direction = m.require("direction").as_int(f"{what}.direction")
        if direction not in (1, -1):
            raise m.require("direction").error(
                f"{what}.direction must be 1 or -1 (mirrored), not {direction}")
        reverse = False
        mode_value = m.get("drive_mode")
        if mode_value is not None:
            mode = mode_value.as_str(f"{what}.drive_mode")
            if mode not in ("normal", "reverse"):
                raise mode_value.error(f"{what}.drive_mode must be normal or reverse, not "
                                       f"{mode!r}")
            reverse = mode == "reverse"
        motors.append(WheelMotor(motor_id, side, direction, reverse))
    for side in SIDES:
        if not any(m.side == side for m in motors):
            raise items.error(f"base.motors: no {side} wheel motor")
    return tuple(motors)
