"""The guard: what a motor would refuse is refused before the wire, in one line.

A value beyond the motor's mode and limits (goal_position outside the angle or position
limits, moving_speed's direction outside wheel mode, goal_velocity beyond velocity_limit,
...), a truth value for an angle, an EEPROM write to a 2.0 motor whose torque is on. Where
the bus does not know the mode and limits and a value is outside what every setting allows,
it reads them once first. What a write sets (mode, limits, torque, status return level) the
bus learns here too (:meth:`Guard._learn_from_write`), and SI conversions that depend on the
mode (1.0 wheel mode) are worked out here.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

from .. import models as _models
from .. import units
from ..errors import ConfigError
from ..models import Model, Register
from .common import Value
from .model_checks import (
    ANGLE_LIMITS,
    GOAL_LIMITS_2,
    POSITION_MODE,
    allowed_modes,
    check_type,
    check_writable,
    checked_raw,
    facts_of,
    names_near,
    register_of,
)
from .status_return import StatusReturn


class Guard(StatusReturn):
    """Checks against what the bus knows of each motor's mode, limits and torque (see the
    module's docstring)."""

    def wheel_mode(self, motor_id: int) -> bool:
        """Whether ``motor_id`` (protocol 1.0) is in wheel mode, both angle limits 0 (e-Manual,
        CW/CCW Angle Limit): as this bus last wrote them, else read from the motor once and
        kept. False on 2.0, whose modes are its operating_mode."""
        m = self.model_of(motor_id)
        return m.protocol == 1 and m.has("cw_angle_limit") and self._in_wheel_mode(motor_id)

    def _in_wheel_mode(self, motor_id: int) -> bool:
        limits = self._memory.angle_limits.get(motor_id)
        if limits is None:
            if self.status_return_level.get(motor_id, 2) == 0:
                raise ConfigError(
                    f"motor {motor_id}: wheel or joint mode unknown and it answers no READ "
                    "(status return level 0); declare it with bus.declare(id, model, "
                    "wheel_mode=True/False) or write its angle limits through this bus")
            got = self.read(motor_id, list(ANGLE_LIMITS), raw=True)
            limits = (int(got[ANGLE_LIMITS[0]]), int(got[ANGLE_LIMITS[1]]))
            self._memory.angle_limits[motor_id] = limits
        return limits == (0, 0)

    def _converts_as_wheel(self, motor_id: int, m: Model, reg: Register) -> bool:
        """Whether ``reg`` of ``motor_id`` converts to SI as in wheel mode: moving/present
        speed of a model whose wheel mode sets the output (:attr:`.Model.wheel_output_ratio`),
        in wheel mode (see :func:`.units.wheel_speed`)."""
        return (reg.unit == "speed_sign_bit" and m.wheel_output_ratio
                and self._in_wheel_mode(motor_id))

    def to_si(self, motor_id: int, name: str, raw: int) -> Value:
        """A raw value of register ``name`` of ``motor_id`` in SI units, as :meth:`read`
        converts it (by the motor's mode where it matters, see :meth:`wheel_mode`)."""
        m = self.model_of(motor_id)
        reg = register_of(m, name)
        return units.to_si(m, reg, int(raw), wheel=self._converts_as_wheel(motor_id, m, reg))

    def from_si(self, motor_id: int, name: str, value: float) -> int:
        """The raw value :meth:`write` sends for ``value`` (SI units) in register ``name`` of
        ``motor_id``; :class:`ConfigError` when it is out of range."""
        m = self.model_of(motor_id)
        reg = register_of(m, name)
        check_type(m, reg, value)
        return units.from_si(m, reg, value, wheel=self._converts_as_wheel(motor_id, m, reg))

    def _checked_encoding(self, motor_id: int, m: Model, reg: Register, value: Value, raw: bool
                ) -> bytes:
        raw_value = self._checked_raw_value(motor_id, m, reg, value, raw)
        if reg.name in facts_of(m).goals:
            self._check_goal(motor_id, m, reg, raw_value)
        return reg.encode(raw_value)

    def _checked_raw_value(self, motor_id: int, m: Model, reg: Register, value: Value, raw: bool
                   ) -> int:
        """The raw value of ``value`` for ``reg``, checked: writable, a number of the right
        type (``True`` is no angle) in the register's range."""
        if raw:
            return checked_raw(m, reg, value)
        check_writable(m, reg)
        kind = type(value)
        if kind is not float and kind is not int:
            check_type(m, reg, value)
        return units.from_si(m, reg, value, wheel=self._converts_as_wheel(motor_id, m, reg))

    # -- what the motor's mode and limits allow ------------------------------------------------
    def _goal_bounds(self, motor_id: int, m: Model, reg: Register
                     ) -> tuple[int, int, bool] | None:
        """The raw values of ``reg`` (a goal: :attr:`ModelFacts.goals`) that ``motor_id``
        takes as far as the bus knows its mode and limits: (low, high, known). Where it does
        not know them (``known`` False), the values that every setting of them allows (the
        factory limits, or the hull of what the limit registers can hold): a value outside
        is then worth a READ of them before it is refused. None: no bound but the
        register's own range (operating_mode's is a set, see :meth:`_check_goal`)."""
        name = reg.name
        if m.protocol == 1:
            limits = self._memory.angle_limits.get(motor_id)
            top = m.register(ANGLE_LIMITS[1]).raw_max
            if name == "moving_speed":
                # joint and multi-turn mode: 0..1023, no direction bit (e-Manual, Moving Speed)
                if limits is None:
                    return 0, 0x3FF, False
                return None if limits == (0, 0) else (0, 0x3FF, True)
            if limits is None:
                return 0, top, False
            cw, ccw = limits
            if cw == ccw == 0 or (m.has("multi_turn_offset") and cw == ccw == top):
                return None     # wheel mode (goal ignored), multi-turn (its own range)
            return cw, ccw, True
        facts = self._memory.goal_facts.get(motor_id)
        if name == "goal_position":
            if facts is None:
                return (m.register("min_position_limit").raw_min,
                        m.register("max_position_limit").raw_max, False)
            if facts.get("operating_mode") != POSITION_MODE:
                return None
            return facts["min_position_limit"], facts["max_position_limit"], True
        limit_name = GOAL_LIMITS_2.get(name)
        if limit_name is None:
            return None
        if facts is None or limit_name not in facts:
            default = m.register(limit_name).default
            return None if default is None else (-default, default, False)
        return -facts[limit_name], facts[limit_name], True

    def _check_goal(self, motor_id: int, m: Model, reg: Register, raw: int) -> None:
        """Refuse, before it is sent, a value the motor would refuse in its mode or beyond
        its limits (an "angle limit" or "range" error on 1.0, "data limit" on 2.0): where the
        bus does not know them and the value is outside what every setting allows, it reads
        them once first (:meth:`_read_goal_limits`)."""
        if reg.name == "operating_mode":
            allowed = allowed_modes(m)
            if allowed is not None and raw not in allowed:
                names = {v: k for k, v in _models.OPERATING_MODES.items()}
                listed = ", ".join(f"{v} ({names.get(v, '?')})" for v in allowed)
                raise ConfigError(f"{m.name} operating_mode: {raw} is not one of its modes: "
                                  f"{listed}")
            return
        bounds = self._goal_bounds(motor_id, m, reg)
        if bounds is None or bounds[0] <= raw <= bounds[1]:
            return
        if not bounds[2]:
            self._read_goal_limits(motor_id, m)
            bounds = self._goal_bounds(motor_id, m, reg)
            if bounds is None or bounds[0] <= raw <= bounds[1] or not bounds[2]:
                return   # allowed after all, or the motor answers no READ (level 0)
        raise ConfigError(self._goal_refusal(motor_id, m, reg, raw, bounds[0], bounds[1]))

    def _goal_refusal(self, motor_id: int, m: Model, reg: Register, raw: int, low: int,
                      high: int) -> str:
        """The one line that says why ``raw`` is refused, in SI units and raw."""
        def si(value: int) -> str:
            try:
                converted = units.to_si(m, reg, value)
            except ConfigError:
                return str(value)
            unit = units.KINDS.get(reg.unit, "")
            text = f"{converted:.4g}" if isinstance(converted, float) else str(converted)
            return text + (f" {unit}" if unit else "")

        head = f"motor {motor_id} ({m.name}) {reg.name}: {si(raw)} (raw {raw})"
        if m.protocol == 1 and reg.name == "moving_speed":
            cw, ccw = self._memory.angle_limits.get(motor_id, (0, 0))
            return (f"{head} has bit 10 set, a direction, which only wheel mode has; in "
                    f"joint mode (angle limits {cw}..{ccw}) moving_speed is 0..1023, 0 to "
                    f"{si(0x3FF)} (0: as fast as it goes): write a speed of 0 or more, or set "
                    "wheel mode first (cw_angle_limit = ccw_angle_limit = 0)")
        if m.protocol == 1:
            return (f"{head} is outside its angle limits cw_angle_limit..ccw_angle_limit = "
                    f"{si(low)}..{si(high)} (raw {low}..{high}): the motor would refuse it "
                    "(angle limit error); widen the limits first")
        if reg.name == "goal_position":
            return (f"{head} is outside its position limits min_position_limit.."
                    f"max_position_limit = {si(low)}..{si(high)} (raw {low}..{high}) in "
                    f"position control mode (operating_mode {POSITION_MODE}): the motor would "
                    "refuse it (data limit); extended position mode (operating_mode 4) turns "
                    "further")
        limit = GOAL_LIMITS_2[reg.name]
        return (f"{head} is beyond its {limit} {si(high)} (raw {high}): the motor would refuse "
                f"it (data limit); raise {limit} first (torque off)")

    def _read_goal_limits(self, motor_id: int, m: Model) -> None:
        """Read what bounds ``motor_id``'s goals: (1.0) its angle limits, hence its mode;
        (2.0) its operating mode and limits. Nothing at status return level 0 (no READ is
        answered)."""
        if m.protocol == 1:
            got = self._read_raw_unless_level_0(motor_id, list(ANGLE_LIMITS))
            if got is not None:
                self._memory.angle_limits[motor_id] = (got[ANGLE_LIMITS[0]], got[ANGLE_LIMITS[1]])
        else:
            names = facts_of(m).facts
            got = self._read_raw_unless_level_0(motor_id, list(names)) if names else None
            if got is not None:
                self._memory.goal_facts[motor_id] = dict(got)
        self._plans.clear()  # sync_write plans bound their values by what the bus knows

    def _require_torque_off(self, motor_id: int, m: Model, eeprom: Sequence[Register]) -> None:
        """Before a write to EEPROM: a 2.0 motor locks its EEPROM while torque is on (and
        answers "access"; e-Manual, X-series Torque Enable(64): "all Data in the EEPROM Area
        are protected from writing" while it is 1), so the bus reads torque_enable first, and
        refuses in one line. (1.0 motors lock their EEPROM by the Lock register only, which
        a refused write names: :func:`eeprom_hint`.)"""
        if m.protocol != 2 or not m.has("torque_enable"):
            return
        if self._memory.torque.get(motor_id) == 0:
            return      # this bus switched it off, and wrote no goal since
        names = ["torque_enable"]
        if motor_id not in self._memory.levels and motor_id not in self._memory.answered:
            names = names_near(m, ["torque_enable", "status_return_level"], 8) or names
        got = self._read_raw_unless_level_0(motor_id, names)
        if got is None:
            return      # level 0: nothing to read, nothing to learn
        if "status_return_level" in got:
            self._remember_level(motor_id, got["status_return_level"])
        self._memory.torque[motor_id] = got["torque_enable"]
        if got["torque_enable"]:
            what = eeprom[0].name
            raise ConfigError(f"motor {motor_id} ({m.name}): {what} is in EEPROM, which the "
                              "motor locks while its torque is on: switch torque off first "
                              "(torque_enable 0)")

    def _checked_block(self, motor_id: int, m: Model, values: Mapping[str, Value], raw: bool
               ) -> tuple[int, bytes]:
        regs = sorted((register_of(m, n) for n in values), key=lambda r: r.address)
        for a, b in itertools.pairwise(regs):
            if a.address + a.size != b.address:
                raise ConfigError(f"{m.name}: {a.name} and {b.name} are not adjacent; write "
                                  "them separately")
        block = b"".join(self._checked_encoding(motor_id, m, r, values[r.name], raw) for r in regs)
        return regs[0].address, block

    def _learn_from_write(self, motor_id: int, m: Model, start: int, block: bytes) -> None:
        """What a write of ``block`` at ``start``, carried out by ``motor_id``, tells the bus
        where the block covers them: the motor's status return level, and (1.0) its angle
        limits, hence its mode."""
        end = start + len(block)
        if m.has("status_return_level"):
            reg = m.register("status_return_level")
            if start <= reg.address < end:
                self._memory.levels[motor_id] = reg.decode(block[reg.address - start:])
        info = facts_of(m)
        if info.torque >= 0 and start <= info.torque < end:
            self._memory.torque[motor_id] = block[info.torque - start]
        elif self._memory.torque and info.goal_span[0] < end and start < info.goal_span[1]:
            self._memory.torque.pop(motor_id, None)    # a goal may have switched it on
        if info.facts and start < info.facts_span[1] and info.facts_span[0] < end:
            facts = self._memory.goal_facts.get(motor_id)
            if facts is not None:
                for name in info.facts:
                    reg = m.register(name)
                    if start <= reg.address and reg.address + reg.size <= end:
                        facts[name] = reg.decode(block[reg.address - start:])
            self._plans.clear()  # sync_write plans bound goals by them
        if m.protocol != 1 or not m.has(ANGLE_LIMITS[0]):
            return
        regs = [m.register(n) for n in ANGLE_LIMITS]
        if not any(start < r.address + r.size and r.address < end for r in regs):
            return
        known = self._memory.angle_limits.get(motor_id)
        limits: list[int] = []
        for k, reg in enumerate(regs):
            if start <= reg.address and reg.address + reg.size <= end:
                limits.append(reg.decode(block[reg.address - start:]))
            elif known is not None:
                limits.append(known[k])
        if len(limits) == 2:
            self._memory.angle_limits[motor_id] = (limits[0], limits[1])
        else:  # one written, the other unknown: read both when next needed
            self._memory.angle_limits.pop(motor_id, None)
        self._plans.clear()  # sync_write plans bound goals by them
