"""The robots layer's errors: what a robot refuses, and what goes wrong while it runs.

Value errors are bad input (a move the base cannot make, a duration of 0 s), refused before
anything moves: ``servolab`` exits 2 for them. A :class:`RobotError` that is not a value error
is a failure at run time (a goal not reached): exit 1 (:mod:`servolab.harness`). A robot's
configuration files have their own :class:`~servolab.errors.ConfigFileError` subclasses,
which name the file, line and key.
"""

from __future__ import annotations

from ..errors import ServolabError


class RobotError(ServolabError):
    """A robot failed while it ran; the message says what and what to do."""


class RobotValueError(RobotError, ValueError):
    """A value a robot cannot use, refused before anything moves; the message names it."""
