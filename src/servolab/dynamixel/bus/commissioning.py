"""Commissioning: a motor's ID and baud rate, REBOOT and factory reset, and the bus follows.

:meth:`Commissioning.change_id` refuses an ID in use and moves what the bus knows of the
motor to its new ID; :meth:`Commissioning.change_baud` sets the register value of the
model's e-Manual table and follows the motor to its new rate; a reset forgets what it puts
back to the factory's. A WRITE of ``id`` or ``baud_rate`` by name or by address comes here.
"""

from __future__ import annotations

from ..errors import CommError, ConfigError, CorruptResponse, MotorError, NoResponse
from ..models import Model, Register
from ..packets import Instruction
from ..protocol import protocol as protocol_for
from ..protocol1 import Protocol1
from ..protocol2 import (
    FACTORY_RESET_ALL,
    FACTORY_RESET_EXCEPT_ID,
    FACTORY_RESET_EXCEPT_ID_BAUD,
    Protocol2,
)
from ..wire import baud_matches
from .common import Value, log
from .discovery import PingResult
from .link import Replies
from .model_checks import hinted, register_of
from .writes import Writes

#: s a motor is given to answer at its new ID or baud rate after the WRITE that set it: it may
#: take a while to store the EEPROM write (the e-Manual states no time), longer than a PING
SETTLE_WINDOW = 0.2
#: Rates a port is set to for a motor's baud rate register: the one within UART tolerance
#: (an RX-28's 57142 bps is spoken to at 57600, as the Dynamixel Wizard does), else the
#: motor's own.
COMMON_RATES = (9_600, 19_200, 38_400, 57_600, 115_200, 200_000, 230_400, 250_000,
                400_000, 460_800, 500_000, 921_600, 1_000_000, 2_000_000, 2_250_000,
                2_500_000, 3_000_000, 4_000_000, 4_500_000)


def line_rate(bps: int) -> int:
    """The rate a port speaks to a motor at ``bps``: the common rate within UART tolerance
    (:data:`.wire.BAUD_TOLERANCE`), else ``bps`` itself."""
    best = min(COMMON_RATES, key=lambda r: abs(r - bps))
    return best if baud_matches(best, bps) else int(bps)


def usable_rates(m: Model) -> list[int]:
    """The common baud rates (:data:`COMMON_RATES`) model ``m`` can be set to, by its
    e-Manual table (:meth:`.Model.baud_register_for`, within UART tolerance)."""
    usable = []
    for rate in COMMON_RATES:
        try:
            m.baud_register_for(rate)
        except ConfigError:
            continue
        usable.append(rate)
    return usable


class Commissioning(Writes):
    """Changing what identifies a motor on the wire, and following it (see the module's
    docstring)."""

    def reboot(self, motor_id: int) -> None:
        """REBOOT (protocol 2.0; ``motor_id`` may be the broadcast ID): the motor starts again
        as at power-up, its RAM at factory values (the X-series' status_return_level,
        address 68, among them: back to 2), its EEPROM kept, its hardware error cleared.

        The motor sends its status before it restarts, so by the status return level it had
        before (only at level 2) and with the hardware-error alert the reboot then clears:
        the bus waits for a status only at level 2, and takes only the instruction's own
        error from it (no alert is logged or recorded)."""
        proto = self.proto
        if not isinstance(proto, Protocol2):
            raise ConfigError("REBOOT exists only in protocol 2.0")
        ids = self._motors_reached(motor_id)
        self._send_reset(proto.reboot(motor_id), "REBOOT", motor_id, alerts=False)
        for i in ids:
            self._memory.alerts.pop(i, None)
            self._memory.registered.pop(i, None)  # RAM: a REG_WRITE waiting for ACTION is gone
            m = self.motors.get(i)
            if m is None or not m.has("status_return_level") \
                    or m.register("status_return_level").area == "RAM":
                self._memory.levels.pop(i, None)     # the factory level, 2
                self._memory.answered.discard(i)  # (or what a RAM restore brings back)
            self._memory.torque.pop(i, None)      # off, or on by its Startup Configuration

    def factory_reset(self, motor_id: int, *, keep_id: bool = True,
                      keep_baud: bool = True) -> None:
        """Restore factory defaults; ``motor_id`` may be the broadcast ID.

        Protocol 1.0 RESET resets the whole control table, "to the factory default values"
        (e-Manual, Protocol 1.0, Factory Reset), whatever ``keep_id`` and ``keep_baud`` say:
        the motor is then ID 1 ("The factory default setting ID is 1", ibid., ID), at
        baud_rate 34 (57142 bps) and status return level 2. Protocol 2.0 FACTORY_RESET keeps
        the ID and baud rate (``keep_id`` and ``keep_baud``), the ID only (``keep_id``), or
        nothing (ID 1, 57600 bps).

        The bus follows: the motor is at status return level 2; where its ID changes, the
        bus forgets what it knew of the old ID and of ID 1 (model, level, mode, alerts),
        which the next access learns again. It does not follow a baud rate the reset
        changes: the motor is then heard only at its new rate (see :meth:`scan`). As for
        :meth:`reboot`, the status goes out before the reset, by the level before it."""
        proto = self.proto
        if isinstance(proto, Protocol1):
            inst, name, moves = proto.reset(motor_id), "RESET", True
        elif isinstance(proto, Protocol2):
            option = (FACTORY_RESET_EXCEPT_ID_BAUD if keep_id and keep_baud else
                      FACTORY_RESET_EXCEPT_ID if keep_id else FACTORY_RESET_ALL)
            if motor_id == proto.broadcast_id and option == FACTORY_RESET_ALL:
                # "In case of when Packet ID is a Broadcast ID 0xFE and Option is Reset All
                # 0xFF, Factory Reset Instruction(0x06) will NOT be activated" (e-Manual,
                # Protocol 2.0): sending it would change nothing but what the bus believes.
                raise ConfigError("a broadcast FACTORY_RESET of everything is ignored by the "
                                  "motors (e-Manual); reset them one ID at a time, or keep "
                                  "their IDs (keep_id=True)")
            inst, name = proto.factory_reset(motor_id, option), "FACTORY_RESET"
            moves = not keep_id
        else:
            raise ConfigError(f"FACTORY_RESET does not exist in protocol {proto.version}.0")
        ids = self._motors_reached(motor_id)
        self._send_reset(inst, name, motor_id)
        self._plans.clear()
        for i in [*ids, 1] if moves else ids:
            self._memory.forget_settings(i)  # the limits and mode are the factory's again
            if moves:
                self.motors.pop(i, None)
                self._memory.alerts.pop(i, None)

    def _motors_reached(self, motor_id: int) -> list[int]:
        """The motors an instruction to ``motor_id`` reaches, as far as the bus knows them."""
        if motor_id != self.proto.broadcast_id:
            self.proto.check_id(motor_id)
            return [motor_id]
        return sorted(self._memory.known_ids(self.motors))

    def _send_reset(self, inst: Instruction, name: str, motor_id: int, *,
                    alerts: bool = True) -> None:
        """Send a REBOOT, FACTORY_RESET or RESET, and take its status where one comes: from
        a unicast to a motor at status return level 2 before the instruction (the status
        goes out before the motor resets)."""
        proto = self.proto
        data = proto.encode_instruction(inst)
        if motor_id == proto.broadcast_id or self._memory.levels.get(motor_id, 2) < 2:
            self._link.send_unanswered(data)
            return
        self._link.exchange(data, name, Replies(proto, {motor_id: 0}), True, None, alerts=alerts)

    def _who_answers_at(self, motor_id: int) -> PingResult | None:
        """The motor that answers at ``motor_id`` in either protocol, None when none does;
        something that answers garbled (two motors at one ID) is refused. Both protocols,
        because one wire may carry both (a 1.0 and a 2.0 motor at one ID garble each other
        as two of one protocol do)."""
        other = 1 if self.proto.version == 2 else 2
        for version in (self.proto.version, other):
            if version == other and not 0 <= motor_id <= protocol_for(other).max_id:
                continue
            try:
                with self._in_protocol(version):
                    return self.ping(motor_id)
            except NoResponse:
                continue
            except CorruptResponse:
                raise ConfigError(f"ID {motor_id}: something answers there, garbled (two "
                                  "motors with that ID?); nothing was written") from None
        return None

    def _answers_within(self, motor_id: int, window: float = SETTLE_WINDOW) -> bool:
        """Whether ``motor_id`` answers a PING within ``window`` seconds: a motor may take a
        while to store an EEPROM write and take up its new ID or rate, longer than one PING
        waits (the e-Manual states no time), so absence is judged only after the window."""
        clock = self.port.clock
        deadline = clock.now() + window
        while True:
            if self._answers_ping(motor_id, retries=0):
                return True
            if clock.now() >= deadline:
                return False

    def change_id(self, motor_id: int, new_id: int) -> PingResult:
        """Give the motor at ``motor_id`` the ID ``new_id``, and follow it there.

        Refused with nothing written when a motor already answers at ``new_id`` (two motors
        at one ID answer together and garble each other; pypot's ``change_id`` refuses it
        too), and when none answers at ``motor_id``. A 2.0 motor must have its torque off
        (the ID is in EEPROM). The motor sends the WRITE's status from its new ID, as
        ROBOTIS's own device code does (Dynamixel2Arduino, src/utility/slave.cpp,
        ``processInstWrite``: ``txStatusPacket(id_, ...)`` after the write). The bus then
        PINGs the new ID and moves what it knows of the motor there (model, status return
        level, mode and limits, alerts). Returns that PING."""
        proto = self.proto
        proto.check_id(motor_id)
        proto.check_id(new_id)
        with self._lock:
            m = self.model_of(motor_id)
            reg = register_of(m, "id")
            reg.check(new_id, m)
            here = self.ping(motor_id)             # it must answer where it is
            if new_id == motor_id:
                return here
            m = self.motors.get(motor_id, m)
            taken = self._who_answers_at(new_id)
            if taken is not None:
                raise ConfigError(f"ID {new_id} is taken: motor {new_id} ({taken.model_name}) "
                                  f"answers there at {self.baudrate} bps; nothing was written "
                                  f"to motor {motor_id}. Pick a free ID (servolab scan lists "
                                  "those in use)")
            self._require_torque_off(motor_id, m, [reg])
            inst = proto.write(motor_id, reg.address, reg.encode(new_id))
            level = self._memory.levels.get(motor_id, 2)
            moved = False
            for _ in range(1 + self.retries):
                try:
                    self.transact(inst, {new_id: 0} if level >= 2 else None, retries=0)
                    moved = level >= 2 or self._answers_within(new_id)
                except CommError:
                    moved = self._answers_within(new_id)
                if moved:
                    break
                refusal = self._refusal_from_old_id(inst, motor_id, m, reg)  # from its old ID?
                if refusal is not None:
                    raise refusal
                if self._answers_within(new_id):
                    moved = True
                    break
                if not self._answers_ping(motor_id):
                    raise NoResponse(f"motor {motor_id}: after a WRITE of id {new_id} it answers "
                                     f"at neither ID {motor_id} nor {new_id} at {self.baudrate} "
                                     "bps; find it with servolab scan", motor_id=motor_id,
                                     instruction="WRITE")
            if not moved:
                self._raise_write_not_taken(motor_id, m, inst, f"id {new_id}")
            self._rekey_after_id_change(motor_id, new_id)
            return self.ping(new_id)

    def _refusal_from_old_id(self, inst: Instruction, motor_id: int, m: Model,
                             reg: Register) -> MotorError | None:
        """Why a motor still at ``motor_id`` did not take the WRITE ``inst``: the WRITE once
        more, its status awaited from the old ID, where a motor that refuses it answers (a
        locked EEPROM, an access error); None when that status says nothing is wrong or does
        not come (the motor may have moved this time)."""
        try:
            self.transact(inst, {motor_id: 0}, retries=0)
        except MotorError as exc:
            return hinted(m, [reg], exc)
        except CommError:
            return None
        return None

    def _raise_write_not_taken(self, motor_id: int, m: Model, inst: Instruction, what: str) -> None:
        """A WRITE of ``what`` that left the motor where it was: its own status says why."""
        reg = m.register("id") if what.startswith("id") else m.register("baud_rate")
        try:
            self.transact(inst, {motor_id: 0})
        except MotorError as exc:
            raise hinted(m, [reg], exc) from None
        except CommError:
            pass
        raise NoResponse(f"motor {motor_id}: the WRITE of {what} did not take: it still "
                         f"answers as before at {self.baudrate} bps", motor_id=motor_id,
                         instruction="WRITE")

    def change_baud(self, motor_id: int, baudrate: int, *, follow: bool = True) -> PingResult:
        """Set the baud rate of ``motor_id`` to ``baudrate`` bps (the register value from the
        model's e-Manual table: :meth:`.Model.baud_register_for`, within UART tolerance, so
        57600 sets an RX-28's 57142), then speak the new rate and PING the motor there.

        The motor answers the WRITE at the old rate and then changes. ``follow`` (the
        default): the bus stays at the new rate, as the motor has; motors it knew that stay
        at the old rate are named in a warning and forgotten. Otherwise the bus goes back to
        its rate and forgets the motor. A 2.0 motor must have its torque off (the baud rate
        is in EEPROM). Returns the PING at the new rate."""
        m = self.model_of(motor_id)
        register_of(m, "baud_rate")
        try:
            value = m.baud_register_for(int(baudrate))
        except ConfigError:
            raise ConfigError(f"{m.name}: {baudrate} bps is not a baud rate it can use; it "
                              f"can use {', '.join(map(str, usable_rates(m)))}") from None
        exact = m.baud_from_register(value)
        rate = int(baudrate) if baud_matches(int(baudrate), exact) else line_rate(exact)
        return self._write_baud_and_follow(motor_id, m, value, rate, follow=follow)

    def _write_baud_and_follow(self, motor_id: int, m: Model, value: int, rate: int, *,
                               follow: bool = True) -> PingResult:
        reg = m.register("baud_rate")
        exact = m.baud_from_register(value)
        with self._lock:
            before = self.baudrate
            if not self._answers_ping(motor_id):
                raise NoResponse(f"motor {motor_id}: no answer to PING at {before} bps (is it "
                                 "powered, at this baud rate and ID?)", motor_id=motor_id,
                                 instruction="PING")
            self._require_torque_off(motor_id, m, [reg])
            inst = self.proto.write(motor_id, reg.address, reg.encode(value))
            level = self._memory.levels.get(motor_id, 2)
            for _ in range(1 + self.retries):
                try:   # answered at the old rate, then the motor changes
                    self.transact(inst, {motor_id: 0} if level >= 2 else None, retries=0)
                except MotorError as exc:
                    raise hinted(m, [reg], exc) from None
                except CommError:
                    pass  # the status may be lost: where the motor answers tells
                self.port.set_baudrate(rate)
                if self._answers_within(motor_id):
                    break
                self.port.set_baudrate(before)
                if not self._answers_ping(motor_id):
                    raise NoResponse(f"motor {motor_id}: after a WRITE of baud_rate {value} "
                                     f"({exact} bps) it answers neither at {rate} nor at "
                                     f"{before} bps; find it with servolab scan",
                                     motor_id=motor_id, instruction="WRITE")
            else:
                self._raise_write_not_taken(motor_id, m, inst, f"baud_rate {value}")
            result = self.ping(motor_id)
            if not follow:
                self.port.set_baudrate(before)
                self._forget_motor(motor_id)
                return result
            memory = self._memory
            left = sorted({*self.motors, *memory.levels, *memory.angle_limits,
                           *memory.goal_facts, *memory.alerts} - {motor_id})
            if left:
                log.warning("motor(s) %s stay at %d bps; this bus now speaks %d bps and "
                            "forgets them", ", ".join(map(str, left)), before, rate)
                for i in left:
                    self._forget_motor(i)
            return result

    def _commission_by_write(self, motor_id: int, name: str, value: Value, *, raw: bool,
                             registered: bool) -> None:
        """A write of ``id`` or ``baud_rate`` by name: through :meth:`change_id` and
        :meth:`change_baud`."""
        if registered:
            raise ConfigError(f"motor {motor_id}: {name} as a REG_WRITE would change at an "
                              "ACTION the bus cannot follow; write it directly")
        m = self.model_of(motor_id)
        reg = register_of(m, name)
        raw_value = self._checked_raw_value(motor_id, m, reg, value, raw)
        if name == "id":
            self.change_id(motor_id, raw_value)
            return
        exact = m.baud_from_register(raw_value)
        asked = float(value)
        rate = int(asked) if not raw and baud_matches(asked, exact) else line_rate(exact)
        self._write_baud_and_follow(motor_id, m, raw_value, rate)

    def _rekey_after_id_change(self, old: int, new: int) -> None:
        """What the bus knows of the motor at ``old``, now at ``new``."""
        self._memory.rekey_after_id_change(old, new, self.motors)
        self._plans.clear()

    def _forget_motor(self, motor_id: int) -> None:
        """Everything the bus knows of ``motor_id`` (no longer on this bus as it speaks)."""
        self._memory.forget(motor_id, self.motors)
        self._plans.clear()
