"""The status return level: which instructions a motor answers, learnt where it matters.

"0: PING only, 1: PING and READ, 2: every instruction" (e-Manual, Status Return Level). The
bus takes a motor it has not met to be at 2, the factory level; where its first WRITE gets no
status it reads the level (or PINGs: level 0) and honours it from then on, awaiting no status
a motor will not send and sending no READ to one that answers PING only. What the bus knows
of each motor's level is in its :class:`~.memory.MotorMemory`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from ..errors import CommError, ConfigError, NoResponse
from ..models import Model
from ..packets import Instruction
from .common import log
from .discovery import Discovery
from .model_checks import facts_of, names_near


@dataclass(frozen=True)
class Contact:
    """What :meth:`Bus.contact` learnt of a motor: how it answers."""

    id: int
    model: Model
    #: 0: PING only, 1: PING and READ, 2: every instruction (e-Manual, Status Return Level)
    status_return_level: int
    #: seconds it waits before a status (Return Delay Time, 2 us a unit); None if unread
    return_delay: float | None


class StatusReturn(Discovery):
    """Learning and honouring each motor's status return level (see the module's
    docstring), and its return delay (:meth:`contact`)."""

    def _read_raw_unless_level_0(self, motor_id: int, names: list[str]) -> dict[str, int] | None:
        """Raw values of ``names``, or None when the motor answers no READ (status return
        level 0, known or found now by a PING it answers)."""
        if self._memory.levels.get(motor_id) == 0:
            return None
        try:
            got = self.read(motor_id, names, raw=True)
        except CommError:
            if motor_id in self._memory.levels or motor_id in self._memory.answered \
                    or not self._answers_ping(motor_id, 0):
                raise
            self._remember_level(motor_id, 0)
            log.info("motor %d answers PING but not READ: status return level 0", motor_id)
            return None
        return {name: int(value) for name, value in got.items()}

    def _send_write_by_level(self, motor_id: int, m: Model, inst: Instruction, level: int,
                             known: bool) -> None:
        """Send a WRITE-like instruction to one motor and take its status by the motor's
        status return level: none below 2; at 2 (known, or taken for the factory level) the
        status, retried as usual. Where the level is not known and no status comes, the bus
        finds the level out (:meth:`_find_status_return_level`) before it retries: a motor at
        level 1 or 0 heard the WRITE and rightly stayed silent."""
        if level < 2:
            self.transact(inst)
            return
        expect = {motor_id: 0}
        if known:
            self.transact(inst, expect)
            return
        try:
            self.transact(inst, expect, retries=0)
        except CommError:
            found = self._find_status_return_level(motor_id, m)
            if found is not None and found < 2:
                return
            if self.retries == 0:
                raise
            self.transact(inst, expect, retries=self.retries - 1)
        self._memory.answered.add(motor_id)

    def _level_known_for_write(self, motor_id: int, m: Model, start: int, block: bytes,
                               registered: bool) -> bool:
        """Whether the bus knows the status return level ``motor_id`` answers this write by
        (told, learnt, seen, or written by this very block)."""
        if motor_id in self._memory.levels or motor_id in self._memory.answered \
                or not m.has("status_return_level"):
            return True
        reg = m.register("status_return_level")
        return not registered and start <= reg.address < start + len(block)

    def _find_status_return_level(self, motor_id: int, m: Model) -> int | None:
        """Find ``motor_id``'s status return level out: READ it (and the return delay, when
        near it), else PING (a motor that answers PING and not READ is at level 0). None when
        nothing answers. The bus keeps what it found."""
        names = ["status_return_level"]
        if m.has("return_delay_time"):
            names = names_near(m, ["return_delay_time", "status_return_level"]) or names
        start, length = m.span(names)
        try:
            status = self.transact(self.proto.read(motor_id, start, length),
                                   {motor_id: length}, check=False)[motor_id]
        except CommError:
            if not self._answers_ping(motor_id, 0):
                return None
            self._remember_level(motor_id, 0)
            log.info("motor %d answers PING only: status return level 0 (the bus sends it "
                     "no READ and awaits no status but PING's)", motor_id)
            return 0
        if self.proto.failed(status.error) or len(status.params) != length:
            return None
        values = {n: m.register(n).decode(status.params[m.register(n).address - start:])
                  for n in names}
        if "return_delay_time" in values:
            self._memory.return_delays[motor_id] = values["return_delay_time"] * 2e-6
        level = values["status_return_level"]
        self._remember_level(motor_id, level)
        if level < 2:
            log.info("motor %d is at status return level %d: the bus awaits no status to "
                     "its writes", motor_id, level)
        return level

    def _remember_level(self, motor_id: int, level: int) -> None:
        """Keep a status return level the bus found out (2 as seen, not as told)."""
        if level >= 2:
            self._memory.levels.pop(motor_id, None)
            self._memory.answered.add(motor_id)
        else:
            self._memory.levels[motor_id] = level
            self._memory.answered.discard(motor_id)

    def _answers_ping(self, motor_id: int, retries: int | None = None) -> bool:
        """Whether something answers a PING of ``motor_id`` (nothing learnt from it)."""
        v1 = self.proto.version == 1
        try:
            self.transact(self.proto.ping(motor_id), {motor_id: 0 if v1 else 3}, check=False,
                          retries=retries)
        except CommError:
            return False
        return True

    def _level_after_write(self, motor_id: int, m: Model, start: int, block: bytes, *,
                           registered: bool = False) -> int:
        """The status return level ``motor_id`` has once ``block`` is written at ``start``:
        the value written when the block covers the register (the motor answers that WRITE
        already by its new level), else the level the bus knows (2, the factory default,
        until told). A REG_WRITE changes nothing before its ACTION."""
        known = self._memory.levels.get(motor_id, 2)
        if registered or not m.has("status_return_level"):
            return known
        reg = m.register("status_return_level")
        if start <= reg.address < start + len(block):
            return reg.decode(block[reg.address - start:])
        return known

    def _refuse_reads_at_level_0(self, ids: Iterable[int]) -> None:
        """Refuse, before anything is sent, to READ a motor whose status return level is 0:
        it answers PING only (e-Manual, Status Return Level), so the read could only time
        out."""
        for motor_id in ids:
            if self._memory.levels.get(motor_id, 2) == 0:
                raise ConfigError(f"motor {motor_id}: status return level 0 answers PING only; "
                                  "write status_return_level 1 or 2 to read it")

    @property
    def status_return_level(self) -> dict[int, int]:
        """The status return level of each motor as this bus knows it (2, the factory
        default, for motors not in it); it decides which instructions the bus waits on.

        The bus keeps it up to date from what it sends: writes of ``status_return_level``
        (WRITE, SYNC_WRITE, BULK_WRITE, and a REG_WRITE once its :meth:`action` is sent),
        :meth:`reboot` (which brings a level kept in RAM, as on the X-series, back to 2) and
        :meth:`factory_reset`; and it learns a level below 2 where a motor's first WRITE gets
        no status (it reads the level then, or PINGs: see :meth:`write`) or from
        :meth:`contact`. This is the bus's own dict, not a copy: set an entry to tell
        the bus of a level it cannot know (set by another program, or kept in a motor's
        EEPROM from before)."""
        return self._memory.levels

    @property
    def return_delay(self) -> Mapping[int, float]:
        """Each motor's Return Delay Time (s) as the bus read it (:meth:`contact`, or the
        first write it got no status to): how long the motor waits before its status. The
        bus's timeouts allow the longest (254 x 2 us) to every motor in any case."""
        return MappingProxyType(self._memory.return_delays)

    def contact(self, motor_id: int) -> Contact:
        """Learn how ``motor_id`` answers, as on first contact: its status return level
        (e-Manual, Status Return Level: 0 answers PING only, 1 PING and READ, 2 every
        instruction) and its return delay, in one READ (or a PING, where no READ is
        answered: level 0), and what bounds its goals (its mode and limits), in another.
        The bus honours the level from then on: it awaits no status a motor will not send,
        and sends no READ to a motor at level 0. (Without this call the bus learns the same
        when it first needs it: the level at the first WRITE that gets no status, mode and
        limits at the first goal beyond what the factory settings allow.)"""
        m = self.model_of(motor_id)
        with self._lock:
            level = (self._find_status_return_level(motor_id, m)
                     if m.has("status_return_level") else 2)
            if level is None:
                raise NoResponse(f"motor {motor_id}: no answer to READ or PING at "
                                 f"{self.baudrate} bps (is it powered, at this baud rate and "
                                 "ID?)", motor_id=motor_id, instruction="READ")
            if level and facts_of(m).goals:
                self._read_goal_limits(motor_id, m)
        delay = self._memory.return_delays.get(motor_id)
        if delay is not None and self.timeout is not None and delay >= self.timeout:
            log.warning("motor %d waits %.0f us before each status, longer than this bus's "
                        "timeout (%.0f us): every transaction with it will time out; lower "
                        "its return_delay_time or the timeout", motor_id, delay * 1e6,
                        self.timeout * 1e6)
        return Contact(motor_id, m, level, delay)
