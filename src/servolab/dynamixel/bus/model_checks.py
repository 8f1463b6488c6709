"""What a model's control table alone says about a write, before any motor is asked.

Register names ("did you mean"), types (a truth value is no angle), writable and in range,
one block of adjacent registers, the registers that bound a goal and those in EEPROM, and
the hints a refused write gets. Pure functions of a :class:`~..models.Model`: the motor's
own mode and limits are :mod:`.guard`'s.
"""

from __future__ import annotations

import itertools
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from .. import models as _models
from .. import units
from ..errors import ConfigError, MotorError, did_you_mean
from ..models import Model, Register
from .common import Value

#: The registers of a 1.0 motor that set its mode: both 0 is wheel mode (e-Manual, CW/CCW
#: Angle Limit).
ANGLE_LIMITS = ("cw_angle_limit", "ccw_angle_limit")


def register_of(m: Model, name: str) -> Register:
    """``m.register(name)``, or a one-line :class:`ConfigError` that says which names are
    close ("did you mean goal_position?") rather than listing the whole control table."""
    if isinstance(name, str) and m.has(name):
        return m.register(name)
    raise ConfigError(f"{m.name} has no register {name!r}; "
                      f"{did_you_mean(str(name), (r.name for r in m.registers))}")


def check_type(m: Model, reg: Register, value: object) -> None:
    """A value in SI units is a real number, and a truth value only for an on/off register
    (``True`` is not 1 rad)."""
    if isinstance(value, bool) or type(value).__name__ == "bool_":  # numpy's too
        if reg.unit == "bool":
            return
        unit = units.KINDS.get(reg.unit, "")
        raise ConfigError(f"{m.name} {reg.name}: {value!r} is a truth value, not a number"
                          f"{' in ' + unit if unit else ''}; write {int(bool(value))} if that "
                          "is meant")
    if not isinstance(value, numbers.Real):
        raise ConfigError(f"{m.name} {reg.name}: {value!r} is not a number")


#: Protocol 2.0 registers that bound what a goal may be (e-Manual, X-series: Operating
#: Mode(11), PWM Limit(36), Current Limit(38), Velocity Limit(44), Max/Min Position
#: Limit(48, 52)); all in EEPROM, so they change only by a write, which the bus sees.
GOAL_FACTS_2 = ("operating_mode", "pwm_limit", "current_limit", "velocity_limit",
                "max_position_limit", "min_position_limit")
#: Goal registers of 2.0 bounded by a limit register, symmetric (|goal| <= limit).
GOAL_LIMITS_2 = {"goal_velocity": "velocity_limit", "goal_current": "current_limit",
                 "goal_pwm": "pwm_limit"}
#: Goal registers whose write may switch torque on: every goal on 1.0 (the emulated firmware,
#: as the seeds' programs rely on), on 2.0 with Drive Mode bit 3 (e-Manual, Drive Mode(10)).
TORQUE_GOALS = frozenset({"goal_position", "moving_speed", "goal_velocity", "goal_current",
                          "goal_pwm"})
#: Position Control Mode, the one operating mode whose goal position the Min/Max Position
#: Limit bound (e-Manual, X-series Goal Position(116): Extended Position and
#: Current-based Position Control Mode count turns, -1 048 575..1 048 575).
POSITION_MODE = 3

@dataclass(frozen=True)
class ModelFacts:
    """What the checks need to know of a model, worked out once (a control table has some
    170 registers; a write must not walk them)."""

    #: where the last EEPROM register ends: a write from there on touches RAM only
    eeprom_end: int
    #: 2.0: the registers of GOAL_FACTS_2 it has, and their span (start, end)
    facts: tuple[str, ...]
    facts_span: tuple[int, int]
    #: registers whose value is bounded by the motor's mode or limits
    goals: frozenset[str]
    #: torque_enable's address (-1: none), and the span of the goals that may switch it on
    torque: int
    goal_span: tuple[int, int]


_MODEL_FACTS: dict[int, tuple[Model, ModelFacts]] = {}


def facts_of(m: Model) -> ModelFacts:
    entry = _MODEL_FACTS.get(id(m))
    if entry is not None and entry[0] is m:
        return entry[1]
    eeprom = [r.address + r.size for r in m.registers if r.area == "EEPROM"]
    goals: set[str] = set()
    facts: tuple[str, ...] = ()
    span = (0, 0)
    if m.protocol == 1 and m.has(ANGLE_LIMITS[0]) and m.has(ANGLE_LIMITS[1]):
        goals = {n for n in ("goal_position", "moving_speed") if m.has(n)}
    elif m.protocol == 2:
        facts = tuple(n for n in GOAL_FACTS_2 if m.has(n))
        if facts:
            regs = [m.register(n) for n in facts]
            span = (min(r.address for r in regs), max(r.address + r.size for r in regs))
        if m.has("operating_mode"):
            goals.add("operating_mode")
        if m.has("goal_position") and m.has("min_position_limit") \
                and m.has("max_position_limit") and m.has("operating_mode"):
            goals.add("goal_position")
        goals |= {g for g, limit in GOAL_LIMITS_2.items() if m.has(g) and m.has(limit)}
    torque = m.register("torque_enable").address if m.has("torque_enable") else -1
    moving = [m.register(n) for n in TORQUE_GOALS if m.has(n)]
    goal_span = ((min(r.address for r in moving), max(r.address + r.size for r in moving))
                 if moving else (0, 0))
    info = ModelFacts(max(eeprom, default=0), facts, span, frozenset(goals), torque,
                      goal_span)
    _MODEL_FACTS[id(m)] = (m, info)
    return info


def eeprom_registers(m: Model, start: int, end: int) -> list[Register]:
    """The EEPROM registers a write of ``start..end`` (end excluded) touches."""
    if start >= facts_of(m).eeprom_end:
        return []
    return [r for r in m.registers
            if r.area == "EEPROM" and start < r.address + r.size and r.address < end]


def names_near(m: Model, names: list[str], limit: int = 64) -> list[str] | None:
    """``names`` when one READ of their span costs at most ``limit`` bytes, else None."""
    if not all(m.has(n) for n in names):
        return None
    return names if m.span(names)[1] <= limit else None


def eeprom_hint(m: Model, eeprom: Sequence[Register], exc: MotorError) -> str | None:
    """What to do when a write to EEPROM registers ``eeprom`` was refused: a 2.0 motor's
    "access" error is its torque (locked EEPROM, e-Manual Torque Enable), a 1.0 motor's
    "range" error to a value in range its Lock (e-Manual, Lock: "If Lock is set to 1, the
    power must be turned off and then turned on again")."""
    if m.protocol == 2 and "access" in exc.errors:
        return (f"{eeprom[0].name} is in EEPROM, which the motor locks while its torque is "
                "on: switch torque off first (torque_enable 0)")
    if m.protocol == 1 and "range" in exc.errors and m.has("lock"):
        return ("its EEPROM is locked if lock is 1, until it is powered off and on again "
                "(e-Manual, Lock)")
    return None


def hinted(m: Model, eeprom: Sequence[Register], exc: MotorError) -> MotorError:
    """``exc`` with what to do, where :func:`eeprom_hint` knows it."""
    hint = eeprom_hint(m, eeprom, exc)
    if hint is None or exc.hint:
        return exc
    return MotorError(exc.motor_id, exc.instruction, exc.errors, exc.raw, hint)


def refuse_commissioning(names: Iterable[str], how: str) -> None:
    """id and baud_rate go alone, through change_id / change_baud, which check and follow."""
    moved = [n for n in names if n in ("id", "baud_rate")]
    if moved:
        raise ConfigError(f"{how} of {' and '.join(moved)} with other registers or motors: "
                          "change an ID with bus.change_id (servolab id) and a baud rate with "
                          "bus.change_baud (servolab baud), one motor at a time, so that the "
                          "bus checks the ID is free and follows the motor")


def motors_named(ids: Sequence[int]) -> str:
    """`` (motors 1, 2)``, `` (motor 3)``, or nothing for no ID."""
    if not ids:
        return ""
    return f" (motor{'s' if len(ids) > 1 else ''} {', '.join(map(str, ids))})"


def model_block(m: Model, values: Mapping[str, Value], raw: bool) -> tuple[int, bytes]:
    """The block a write of ``values`` (name -> value) puts in model ``m``'s table, and its
    start, checked as far as the table alone can check it (no motor is asked): names, one
    block of adjacent registers, writable, type and range (an SI value as in joint or
    position mode), an operating mode the model has."""
    regs = sorted((register_of(m, n) for n in values), key=lambda r: r.address)
    for a, b in itertools.pairwise(regs):
        if a.address + a.size != b.address:
            raise ConfigError(f"{m.name}: {a.name} and {b.name} are not adjacent; write "
                              "them separately")
    block = b""
    for reg in regs:
        value = values[reg.name]
        if raw:
            raw_value = checked_raw(m, reg, value)
        else:
            check_writable(m, reg)
            check_type(m, reg, value)
            raw_value = units.from_si(m, reg, value)
        allowed = allowed_modes(m) if reg.name == "operating_mode" else None
        if allowed is not None and raw_value not in allowed:
            raise ConfigError(f"{m.name} operating_mode: {raw_value} is not one of its modes: "
                              f"{', '.join(map(str, allowed))}")
        block += reg.encode(raw_value)
    return regs[0].address, block


def check_writable(m: Model, reg: Register) -> None:
    if not reg.writable:
        raise ConfigError(f"{m.name} {reg.name} is read-only")


def checked_raw(m: Model, reg: Register, value: Value) -> int:
    """``value`` as a raw value of ``reg`` to write: writable, an integer (``True`` is not
    one), within the register's range."""
    check_writable(m, reg)
    if isinstance(value, bool) or not isinstance(value, numbers.Real) \
            or not float(value).is_integer():
        raise ConfigError(f"{m.name} {reg.name}: raw value {value!r} is not an integer")
    raw_value = int(value)
    reg.check(raw_value, m)
    return raw_value


def allowed_modes(m: Model) -> tuple[int, ...] | None:
    modes: Mapping[str, tuple[int, ...]] = getattr(_models, "ALLOWED_MODES", {})
    return modes.get(m.name)
