"""Exceptions of the Dynamixel layer.

Every error names what it is about (motor ID, instruction, register, value) in one line, so a
user reading a traceback knows what to fix without opening the code.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

from ..errors import ConfigFileError, ServolabError


def did_you_mean(name: str, known: Iterable[str], *, what: str = "register") -> str:
    """The end of a one-line "no such name" message: the closest of ``known`` (difflib, as
    Python's own "Did you mean" does), else the names that contain ``name``, else how many
    there are, never the whole list (an X-series table has some 170 registers)."""
    names = sorted(set(known))
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.6)
    if not close:
        word = name.lower()
        close = [n for n in names if word and word in n][:5]
    if close:
        listed = close[0] if len(close) == 1 else ", ".join(close[:-1]) + " or " + close[-1]
        return f"did you mean {listed}?"
    return f"no {what} name is close to it (it has {len(names)}; see its e-Manual page)"


class DynamixelError(ServolabError):
    """Base of every error raised by :mod:`servolab.dynamixel`."""


class ConfigError(DynamixelError, ValueError):
    """Bad input from the user: unknown model or register, value out of range, bad ID or baud.

    Raised before anything is sent, so nothing is written to a motor.
    """


class MotorSpecFileError(ConfigFileError, ConfigError):
    """A motor spec YAML file that cannot be used; carries ``path``, ``line`` and ``key``
    (a :class:`ConfigError` too, so callers catching that keep working)."""


class PacketError(DynamixelError, ValueError):
    """A packet that cannot be encoded or decoded (wrong header, length, checksum or CRC)."""


class PortError(DynamixelError):
    """The port itself failed: reading or writing the serial device gave an I/O error (the
    USB adapter unplugged, the device gone). Nothing more can go through it; the message
    names the port and what to do."""


class CommError(DynamixelError):
    """The bus did not deliver a valid answer: timeout or corrupt status packet."""

    def __init__(self, message: str, *, motor_id: int | None = None,
                 instruction: str | None = None) -> None:
        super().__init__(message)
        self.motor_id = motor_id
        self.instruction = instruction


class NoResponse(CommError):
    """No status packet arrived before the timeout (motor absent, wrong baud, or cable)."""


class CorruptResponse(CommError):
    """Bytes arrived but no valid status packet from the expected motor could be found: none
    with a right checksum/CRC, or only ones whose content cannot be true (an error bit the
    protocol keeps at 0, a read value outside what its register holds), which passed the
    checksum by chance (see :class:`~.bus.link.Link`)."""


class MotorError(DynamixelError):
    """The motor answered with error bits set in its status packet.

    ``errors`` holds the bit names as the e-Manual spells them, e.g. ``("overload",)``.
    ``hint``, when the driver knows the likely cause, says what to do; it ends the message.
    """

    def __init__(self, motor_id: int, instruction: str, errors: tuple[str, ...],
                 raw: int, hint: str | None = None) -> None:
        self.motor_id = motor_id
        self.instruction = instruction
        self.errors = errors
        self.raw = raw
        self.hint = hint
        names = ", ".join(errors) if errors else f"0x{raw:02X}"
        super().__init__(f"motor {motor_id}: {instruction} answered with error {names}"
                         + (f": {hint}" if hint else ""))
