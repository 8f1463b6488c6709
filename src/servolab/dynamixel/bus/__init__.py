"""The driver: a :class:`Bus` talks to the motors on one port, in SI units by register name.

``bus.read(11, "present_position")`` looks the register up in motor 11's control table, sends
one READ, checks the status packet and returns radians. Several registers of one motor go out
as one contiguous READ; many motors go out as SYNC_WRITE / SYNC_READ / BULK_READ where the
model has them, and fall back to one packet per motor where it does not (RX-28 has no
BULK_READ). On X-series firmware 46 and later, ``fast_sync_read`` / ``fast_bulk_read`` (or
``fast=True``/``None``) send FAST_SYNC_READ / FAST_BULK_READ, answered by one status packet
for all the motors. Everything is checked before the first byte is sent, so bad input writes
nothing.

**Safe.** What a motor would refuse is refused before the wire, in one line that says what to
do: a value beyond the motor's mode and limits, a truth value for an angle, a register name it
does not have ("did you mean"), an EEPROM write to a 2.0 motor whose torque is on. IDs and baud
rates change through :meth:`Bus.change_id` and :meth:`Bus.change_baud`, which refuse a used ID
and follow the motor; a motor's status return level is learnt where it matters and honoured
(:meth:`Bus.contact`); :meth:`Bus.read_address` and :meth:`Bus.write_address` reach any address.

**Robust.** A status is taken as the answer only if it comes from a motor asked, with the
length the instruction asks for; anything else (a late answer to an earlier instruction, a
stray packet) is counted in :attr:`BusStats.stale` and ignored. After an instruction that got
no valid answer, the next one first waits out the time in which the late answer could still
come (return delay and wire time) and throws away whatever came: a late answer is never read
as the answer to the next request. Hardware errors (overload, overheating, ...) are not failed
instructions: the data comes back, and the motor is named in :attr:`Bus.alerts` (and logged);
only an instruction error (checksum, range, access, ...) raises :class:`MotorError`. A status
that passed its checksum/CRC is still checked for what no motor sends (an error bit its
protocol keeps at 0, a read value its register cannot hold, :func:`~..models.read_limits`):
Protocol 1.0's 8-bit additive checksum lets two flips that cancel in its sum through, which
Protocol 2.0's CRC-16 does not. Such a reply is counted in :attr:`BusStats.implausible`,
retried, and raises :class:`CorruptResponse` when the retries run out; it is never returned.
A flip pair that leaves a value in range only a second reply can catch:
:attr:`Bus.confirm_reads`.

**Fast.** What a read or a write of the same registers of the same motors repeats is worked
out once and kept (a *plan*): the instruction packet, the status packets it is answered with
and where each one's data sits, one :class:`struct.Struct` that decodes them. A reply that is
exactly as expected is checked in place (header, ID, length, checksum/CRC, error byte) and
decoded in one call; only one that is not goes through the stream parser, which finds what it
can in noise, partial and stray packets.

**Parts.** One module per job, :class:`Bus` (:mod:`.facade`) the one class on top: the link
(:mod:`.link`: a transaction, its lock, late answers, hardware-error alerts), discovery
(:mod:`.discovery`: PING, broadcast PING, scan, models), the status return level
(:mod:`.status_return`), the guard (:mod:`.guard`, on the table-only checks of
:mod:`.model_checks`), reads and writes (:mod:`.reads`, :mod:`.writes`) through plans
(:mod:`.plans`), commissioning (:mod:`.commissioning`: ID, baud rate, REBOOT, factory reset)
and raw access by address (:mod:`.raw`). What the bus learns of each motor is one
:class:`~.memory.MotorMemory`.
"""

from __future__ import annotations

from .commissioning import SETTLE_WINDOW, line_rate, usable_rates
from .common import MAX_RETURN_DELAY, NameList, Names, Value, log
from .discovery import BROADCAST_PING_SLOT, SCAN_MARGIN, PingResult
from .facade import Bus
from .link import BusStats
from .model_checks import register_of
from .plans import MAX_PLANS
from .raw import raw_access_limits
from .status_return import Contact

__all__ = [
    "BROADCAST_PING_SLOT",
    "MAX_PLANS",
    "MAX_RETURN_DELAY",
    "SCAN_MARGIN",
    "SETTLE_WINDOW",
    "Bus",
    "BusStats",
    "Contact",
    "NameList",
    "Names",
    "PingResult",
    "Value",
    "line_rate",
    "log",
    "raw_access_limits",
    "register_of",
    "usable_rates",
]
