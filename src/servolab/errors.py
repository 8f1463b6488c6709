"""The root of servolab's exceptions, and the error of a configuration file.

Every error servolab raises on purpose derives from :class:`ServolabError`, so a program (and
the ``servolab`` command) catches one class and prints one line. Each layer keeps its own
branch (:class:`servolab.dynamixel.errors.DynamixelError`,
:class:`servolab.middleware.errors.MiddlewareError`); what went wrong in a file the user wrote
is a :class:`ConfigFileError`, which carries the file, line and key so that a message can point
at the bad character, as rclpy's and rosbags' do.
"""

from __future__ import annotations

from pathlib import Path


class ServolabError(Exception):
    """Base of every error servolab raises on purpose."""


class ServolabValueError(ServolabError, ValueError):
    """A value a core module (a clock, a run folder) cannot use: bad input from a program."""


class UsageError(ServolabError, ValueError):
    """A command-line argument that cannot be used (``--steps 0``), refused before anything
    moves; the message names the option and the value."""


class ConfigFileError(ServolabError, ValueError):
    """A configuration file that cannot be used: unreadable, not YAML, a duplicate or unknown
    key, or a value of the wrong kind.

    ``str(error)`` is one line, ``"<path>:<line>: <message>"``; the parts are kept as
    attributes for programs (``path``, ``line`` counted from 1, 0 when the whole file is meant,
    and ``key``, the dotted path of the value at fault, ``""`` for the file itself).
    """

    def __init__(self, path: str | Path, line: int, key: str, message: str) -> None:
        self.path = str(path)
        self.line = int(line)
        self.key = key
        self.message = message
        where = f"{self.path}:{self.line}" if self.line > 0 else self.path
        super().__init__(f"{where}: {message}")
