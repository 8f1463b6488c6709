"""The simulation layer's errors.

Value errors are bad input (a physics step of 0, a slip above 1, a scene file's bad key),
refused before the simulation runs: ``servolab`` exits 2 for them.
"""

from __future__ import annotations

from ..errors import ServolabError


class SimError(ServolabError):
    """Base of every error raised by :mod:`servolab.sim`."""


class SimulationError(SimError, ValueError):
    """A simulation used the wrong way: a bad step length, a world added twice, a parameter
    of a world out of range; the message names it."""
