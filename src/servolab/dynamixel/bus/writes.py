"""Writes: one motor's registers by name (WRITE, REG_WRITE and its ACTION), many motors' by
SYNC_WRITE or BULK_WRITE, every motor's at once by a broadcast WRITE.

Everything is checked before the first byte is sent (:mod:`.guard`), so bad input writes
nothing; each write's status is awaited by the motor's status return level
(:mod:`.status_return`), and what it sets is learnt. A SYNC_WRITE of one register repeated on
the same motors goes through a plan (:class:`~.plans.SyncWrite`). ``id`` and ``baud_rate``
go through :mod:`.commissioning`, which follows the motor.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping, Sequence
from typing import overload

from ..errors import ConfigError, MotorError
from ..models import Model, model, supports
from ..protocol2 import Protocol2
from .common import NameList, Names, Value
from .model_checks import (
    ANGLE_LIMITS,
    eeprom_registers,
    facts_of,
    hinted,
    model_block,
    motors_named,
    refuse_commissioning,
)
from .plans import STRUCT_CODES, SyncWrite
from .reads import Reads


class Writes(Reads):
    """Writing registers by name, to one motor, many, or all (see the module's docstring)."""

    @staticmethod
    def _name_list(names: Names) -> list[str]:
        return [names] if isinstance(names, str) else list(names)

    def check_write(self, motor_id: int, values: Mapping[str, Value], *,
                    raw: bool = False) -> None:
        """Raise what :meth:`write` of ``values`` would raise (ConfigError, one line), and
        send nothing that writes: so a caller moving several motors can refuse a goal that
        one of them would refuse before any of them moves. Like :meth:`write`, it may read
        the motor's mode and limits once where a value needs them. ``id`` and ``baud_rate``,
        which :meth:`write` hands to commissioning, are refused here."""
        plain = self._write_values(motor_id, values, None)
        if "id" in plain or "baud_rate" in plain:
            raise ConfigError(f"motor {motor_id}: check_write checks registers; id and "
                              "baud_rate are checked by change_id() and change_baud()")
        self._checked_block(motor_id, self.model_of(motor_id), plain, raw)

    def _write_values(self, motor_id: int, name: str | Mapping[str, Value],
                      value: Value | None) -> dict[str, Value]:
        """The values a write to one motor names, refused in one line where no single WRITE
        could send them: the broadcast ID, nothing to write, a name without a value, or
        ``id``/``baud_rate`` beside other registers."""
        if motor_id == self.proto.broadcast_id:
            raise ConfigError(f"motor ID {motor_id} is the broadcast ID: broadcast_write() "
                              "writes every motor at once, checked against each one's table")
        given: dict[str, Value | None] = dict(name) if isinstance(name, Mapping) else {name: value}
        values = {n: v for n, v in given.items() if v is not None}
        if len(values) != len(given):
            raise ConfigError(f"motor {motor_id}: write needs a value for {name!r}")
        if not values:
            raise ConfigError(f"motor {motor_id}: a write names no register")
        if len(values) > 1:
            refuse_commissioning(values, "write")
        return values

    def write(self, motor_id: int, name: str | Mapping[str, Value], value: Value | None = None,
              *, raw: bool = False, registered: bool = False) -> None:
        """Write one register (``write(1, "goal_position", 0.5)``) or several adjacent ones
        (``write(1, {"goal_position": 0.5, "moving_speed": 1.0})``) in one WRITE.
        ``registered`` sends REG_WRITE, applied by a later :meth:`action`.

        On models whose wheel mode sets the output rather than a speed (RX-28, EX-106+:
        :attr:`.Model.wheel_output_ratio`), a moving_speed in rad/s is, in wheel mode, the
        speed of the unloaded horn (:func:`.units.wheel_speed`); the bus knows the mode from
        the angle limits it wrote, or reads them once (:meth:`wheel_mode`).

        Checked before anything is sent: the register names ("did you mean"), each value's
        type and range, what the motor's mode and limits allow (goal_position within the
        angle or position limits, moving_speed's direction only in wheel mode, goal_velocity
        within velocity_limit, ...: the bus reads them once where a value needs it), and,
        for an EEPROM register of a 2.0 motor, that its torque is off (it locks the EEPROM
        while torque is on: the bus reads torque_enable first).

        ``id`` and ``baud_rate`` go through :meth:`change_id` and :meth:`change_baud`: a used
        ID is refused, and the bus follows the motor to its new ID or rate.

        A motor whose status return level the bus does not know is taken to be at 2 (the
        factory level), and where its first WRITE gets no status the bus reads the level
        (or, when no READ is answered either, PINGs: level 0) and honours it from then on:
        a write to a motor at level 1 or 0 expects no status.

        Every motor at once (the broadcast ID, 254): :meth:`broadcast_write`."""
        values = self._write_values(motor_id, name, value)
        (first, first_value), *others = values.items()
        if not others and first in ("id", "baud_rate"):  # given alone, or as {"id": 5}
            self._commission_by_write(motor_id, first, first_value, raw=raw,
                                      registered=registered)
            return
        m = self.model_of(motor_id)
        start, block = self._checked_block(motor_id, m, values, raw)
        self._write_block(motor_id, m, start, block, registered=registered)

    def broadcast_write(self, name: str | Mapping[str, Value], value: Value | None = None, *,
                        raw: bool = False, models: Iterable[str | Model] | None = None
                        ) -> list[int]:
        """WRITE one register (or several adjacent ones, as :meth:`write` takes them) of every
        motor at once: one instruction to the broadcast ID (254), which no motor answers
        ("Broadcast ID ... no Status Packet is returned", e-Manual, Protocol 1.0 and 2.0,
        Packet ID), so none is waited for.

        The motors may be of several models, each with its own control table, and the one
        packet carries one address and one set of bytes. So the write is checked, before
        anything is sent, against the table of every motor the bus knows in its protocol
        (found by :meth:`scan` or :meth:`ping`, or declared), as a write to each of them would
        be (register name, writable, type and range, what its mode and limits allow, and for
        an EEPROM register of a 2.0 motor, torque off), and it must come to the same address
        and bytes for all of them: goal_position 0.5 rad is raw 610 on an RX-28 and 2389 on
        an MX-28, which no single packet can say. ``models`` checks against those models'
        tables instead (motors the bus has not met; then no mode or limit, which only a
        motor can tell, is checked, and an EEPROM register is refused). A bus that knows no
        motor, given no ``models``, refuses: scan first. ``id`` (every motor would take the
        same) and ``baud_rate`` (each motor is to be followed: :meth:`change_baud`) are
        refused.

        Returns the IDs of the known motors it was checked for (``[]`` with ``models``); the
        bus learns from it for each of them what :meth:`write` learns (a status return
        level, angle limits, torque)."""
        with self._lock:
            return self._send_broadcast_write(self._check_broadcast_write(name, value, raw, models))

    def _check_broadcast_write(self, name: str | Mapping[str, Value], value: Value | None,
                               raw: bool, models: Iterable[str | Model] | None
                               ) -> list[tuple[int | None, Model, int, bytes]]:
        """:meth:`broadcast_write` checked, nothing sent: (ID or None, model, start, block) of
        each table it was checked against, all with the same start and block."""
        proto = self.proto
        given: dict[str, Value | None] = (dict(name) if isinstance(name, Mapping)
                                          else {name: value})
        values = {n: v for n, v in given.items() if v is not None}
        if not values or len(values) != len(given):
            raise ConfigError(f"broadcast write needs a value for {name!r}")
        for special in ("id", "baud_rate"):
            if special in values:
                raise ConfigError(
                    "a broadcast write of id would give every motor the same ID; change IDs "
                    "one motor at a time (change_id, servolab id)" if special == "id" else
                    "a broadcast write of baud_rate would leave the bus unable to follow "
                    "each motor; change baud rates with change_baud (servolab baud)")
        if models is not None:
            known: list[tuple[int | None, Model]] = [
                (None, m if isinstance(m, Model) else model(m)) for m in models]
            for _, m in known:
                if m.protocol != proto.version:
                    raise ConfigError(f"{m.name} speaks protocol {m.protocol}.0, this bus "
                                      f"{proto.version}.0")
        else:
            known = [(i, m) for i, m in sorted(self.motors.items())
                     if m.protocol == proto.version]
        if not known:
            raise ConfigError("broadcast write: the bus knows no motor to check the write "
                              "against (each model has its own table, and no motor answers a "
                              "broadcast to say it refused); scan() first, declare the "
                              "motors, or name their models; nothing was written")
        with self._lock:
            blocks: list[tuple[int | None, Model, int, bytes]] = []
            for motor_id, m in known:
                if motor_id is None:
                    start, block = model_block(m, values, raw)
                else:
                    start, block = self._checked_block(motor_id, m, values, raw)
                blocks.append((motor_id, m, start, block))
            _, _, start, block = blocks[0]
            if any((s, b) != (start, block) for _, _, s, b in blocks):
                kinds: dict[tuple[str, int, bytes], list[int]] = {}
                for i, m, s, b in blocks:
                    kinds.setdefault((m.name, s, b), []).extend(() if i is None else (i,))
                raise ConfigError(
                    f"broadcast write of {', '.join(values)}: the motors' tables disagree ("
                    + "; ".join(f"{name}{motors_named(ids)}: address {s}, bytes {b.hex(' ')}"
                                for (name, s, b), ids in kinds.items())
                    + "): one packet carries one address and one value; write them one by "
                    "one or with sync_write; nothing was written")
            for motor_id, m, _, _ in blocks:
                eeprom = (eeprom_registers(m, start, start + len(block))
                          if start < facts_of(m).eeprom_end else [])
                if not eeprom:
                    continue
                if motor_id is None:
                    raise ConfigError(f"{m.name}: {eeprom[0].name} is in EEPROM: a broadcast "
                                      "to motors the bus has not met cannot check that their "
                                      "torque is off; scan() first; nothing was written")
                self._require_torque_off(motor_id, m, eeprom)
        return blocks

    def _send_broadcast_write(self, blocks: list[tuple[int | None, Model, int, bytes]]
                              ) -> list[int]:
        """Send the WRITE :meth:`_check_broadcast_write` checked, and learn from it."""
        proto = self.proto
        _, _, start, block = blocks[0]
        self.transact(proto.write(proto.broadcast_id, start, block))
        ids = [i for i, _, _, _ in blocks if i is not None]
        for motor_id, m, _, _ in blocks:
            if motor_id is not None:
                self._learn_from_write(motor_id, m, start, block)
        return ids

    def _write_block(self, motor_id: int, m: Model, start: int, block: bytes, *,
                     registered: bool = False) -> None:
        """WRITE (or REG_WRITE) ``block`` at ``start`` to one motor, its values checked
        already: an EEPROM block only with torque off (2.0), the status awaited by the
        motor's status return level, and what the write sets learnt."""
        end = start + len(block)
        eeprom = eeprom_registers(m, start, end) if start < facts_of(m).eeprom_end else []
        if eeprom:
            self._require_torque_off(motor_id, m, eeprom)
        inst = self.proto.write(motor_id, start, block, registered=registered)
        try:
            level = self._level_after_write(motor_id, m, start, block, registered=registered)
            known = self._level_known_for_write(motor_id, m, start, block, registered)
            self._send_write_by_level(motor_id, m, inst, level, known)
        except MotorError as exc:
            if not eeprom:
                raise
            raise hinted(m, eeprom, exc) from None
        if registered:  # the motor keeps one REG_WRITE, the last, until ACTION
            self._memory.registered[motor_id] = (start, block)
        else:
            self._learn_from_write(motor_id, m, start, block)

    def action(self) -> None:
        """Broadcast ACTION: every motor applies its REG_WRITE at once (and the bus learns
        what those writes set, e.g. a status return level)."""
        self.transact(self.proto.action())
        registered = dict(self._memory.registered)
        self._memory.registered.clear()
        for motor_id, (start, block) in registered.items():
            m = self.motors.get(motor_id)
            if m is not None:
                self._learn_from_write(motor_id, m, start, block)

    @overload
    def sync_write(self, names: str, values: Mapping[int, Value], *,
                   raw: bool = False) -> None: ...

    @overload
    def sync_write(self, names: NameList, values: Mapping[int, Sequence[Value]], *,
                   raw: bool = False) -> None: ...

    def sync_write(self, names: Names, values: Mapping[int, Value | Sequence[Value]], *,
                   raw: bool = False) -> None:
        """One SYNC_WRITE of the same register(s) on many motors:
        ``sync_write("goal_position", {11: 0.1, 12: -0.2})`` or, for adjacent registers,
        ``sync_write(["goal_position", "moving_speed"], {11: (0.1, 2.0)})``."""
        key: tuple[str, str, tuple[int, ...]] | None = None
        if isinstance(names, str):
            if names == "id" or names == "baud_rate":
                refuse_commissioning([names], "SYNC_WRITE")
            ids = tuple(values)
            key = ("sync_write", names, ids)
            plan = self._plans.get(key)
            if self._plan_holds(plan, ids):
                data = plan.encode(values.values(), raw)
                if data is not None:
                    self._link.send_unanswered(data)
                    if plan.covers_level:  # it wrote status_return_level (raw: no SI kind)
                        for motor_id in plan.ids:
                            level = values[motor_id]
                            assert isinstance(level, int)  # the plan's encode checked it
                            self._memory.levels[motor_id] = level
                    if plan.torque:
                        for motor_id in plan.ids:
                            self._memory.torque[motor_id] = int(values[motor_id])  # type: ignore[arg-type]
                    elif plan.goal and self._memory.torque:
                        for motor_id in plan.ids:
                            self._memory.torque.pop(motor_id, None)
                    return
        wanted = self._name_list(names)
        refuse_commissioning(wanted, "SYNC_WRITE")
        blocks: list[tuple[int, bytes]] = []
        layout: tuple[int, int] | None = None
        for motor_id, value in values.items():
            m = self.model_of(motor_id)
            # One register name takes one number per motor; a list of names, a sequence each.
            if isinstance(names, str):
                if isinstance(value, Sequence):
                    raise ConfigError(f"{m.name} {names}: {value!r} is not a number")
                vals: list[Value] = [value]
            elif isinstance(value, Iterable):
                vals = list(value)
            else:
                raise ConfigError(f"motor {motor_id}: one value {value!r} for {len(wanted)} "
                                  f"registers {wanted}")
            if len(vals) != len(wanted):
                raise ConfigError(f"motor {motor_id}: {len(vals)} values for {len(wanted)} "
                                  f"registers {wanted}")
            start, block = self._checked_block(motor_id, m,
                                               dict(zip(wanted, vals, strict=True)), raw)
            if layout is None:
                layout = (start, len(block))
            elif layout != (start, len(block)):
                raise ConfigError(f"motor {motor_id} ({m.name}) keeps {wanted} at another "
                                  "address or size than the others: one SYNC_WRITE cannot "
                                  "reach them all")
            blocks.append((motor_id, block))
        if not blocks or layout is None:
            return
        for motor_id, _ in blocks:
            m = self.motors[motor_id]
            if layout[0] < facts_of(m).eeprom_end:
                eeprom = eeprom_registers(m, layout[0], layout[0] + layout[1])
                if eeprom:
                    self._require_torque_off(motor_id, m, eeprom)
        self.transact(self.proto.sync_write(layout[0], layout[1], blocks))
        if key is not None:  # one register: the next time, through a plan
            self._plans.keep(key, self._plan_sync_write(key[1], key[2]))
        for motor_id, block in blocks:
            self._learn_from_write(motor_id, self.motors[motor_id], layout[0], block)

    def _plan_sync_write(self, name: str, ids: tuple[int, ...]) -> SyncWrite | None:
        """The plan of a SYNC_WRITE of ``name`` to ``ids`` like the one just sent (which
        checked the register and every value), or None where the template cannot serve."""
        models = [self.motors[i] for i in ids]
        reg = models[0].register(name)
        if (any(m.register(name) != reg for m in models) or name in ANGLE_LIMITS
                or reg.area == "EEPROM" or (reg.size, reg.signed) not in STRUCT_CODES):
            # (the angle limits: the checked path learns the motors' mode; EEPROM: it checks
            # that their torque is off)
            return None
        covers = any(m.has("status_return_level")
                     and m.register("status_return_level").address == reg.address
                     for m in models)
        try:
            plan = SyncWrite(self.proto, ids, models, reg, covers)
        except (struct.error, ValueError):
            return None
        expected = self.proto.encode_instruction(self.proto.sync_write(
            reg.address, reg.size, [(i, bytes(reg.size)) for i in ids]))
        if len(expected) != len(plan.template):
            return None
        for motor_id, m in zip(ids, models, strict=True):
            # what the motors' modes and limits allow, as far as the bus knows them: a value
            # beyond takes the checked path, which reads them or says why it is refused
            bounds = self._goal_bounds(motor_id, m, reg) if name in facts_of(m).goals \
                else None
            if bounds is not None:
                plan.low, plan.high = max(plan.low, bounds[0]), min(plan.high, bounds[1])
        return plan

    def bulk_write(self, values: Mapping[int, Mapping[str, Value]], *,
                   raw: bool = False) -> None:
        """Different registers on different motors: {id: {name: value}}. One BULK_WRITE on
        2.0; on 1.0 (which has none) one WRITE per motor."""
        blocks = []
        for motor_id, regs in values.items():
            refuse_commissioning(regs, "BULK_WRITE")
            m = self.model_of(motor_id)
            start, block = self._checked_block(motor_id, m, regs, raw)
            blocks.append((motor_id, m, start, block))
        proto = self.proto
        if isinstance(proto, Protocol2) and all(supports(m, "BULK_WRITE") for _, m, _, _ in blocks):
            for motor_id, m, start, block in blocks:
                eeprom = eeprom_registers(m, start, start + len(block))
                if eeprom:
                    self._require_torque_off(motor_id, m, eeprom)
            self.transact(proto.bulk_write([(i, start, block) for i, _, start, block in blocks]))
        else:
            for motor_id, m, start, block in blocks:
                self._write_block(motor_id, m, start, block)
            return
        for motor_id, m, start, block in blocks:
            self._learn_from_write(motor_id, m, start, block)
