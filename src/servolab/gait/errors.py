"""The gait layer's errors.

Value errors are bad input (a gait parameter out of range, a foot out of reach, a motion
file's bad line), refused before anything moves: ``servolab`` exits 2 for them.
"""

from __future__ import annotations

from ..errors import ServolabError


class GaitError(ServolabError):
    """Base of every error raised by :mod:`servolab.gait`."""


class GaitValueError(GaitError, ValueError):
    """Gait parameters, a motion or its limits that cannot be used; the message names the
    value."""


class UnknownMotorError(GaitValueError, KeyError):
    """A motor a motion does not have. A KeyError too, as a lookup by name is, but shown as
    its one-line message (a KeyError would show it quoted)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""
