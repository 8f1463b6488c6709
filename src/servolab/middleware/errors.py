"""Exceptions of the middleware.

As in :mod:`servolab.dynamixel.errors`, each message is one line that names the topic, type,
field, file, line or key at fault, so the user knows what to fix — except a bad ROS name's
(:class:`NameValidationError`), which shows the name and a caret under the bad character below
its first line, as rclpy does.
"""

from __future__ import annotations

from ..errors import ConfigFileError, ServolabError


class MiddlewareError(ServolabError):
    """Base of every error raised by :mod:`servolab.middleware`."""


class MiddlewareValueError(MiddlewareError, ValueError):
    """A value a middleware call cannot use (a timer's period, a rate, a QoS depth); the
    message names it. Refused before anything is sent."""


class MessageError(MiddlewareError, ValueError):
    """An unknown message type, or a value that does not fit a message field."""


class NameValidationError(MiddlewareError, ValueError):
    """A node name, namespace, enclave, topic or service name that breaks ROS 2's rules.

    The one exception to the one-line rule: as rclpy's ``NameValidationException`` shows it,
    the first line says which kind of name is wrong and the rule it breaks, the next two show
    the name and a caret under its first bad character::

        Invalid node name: node name must not contain characters other than alphanumerics or '_':
          'my-node'
             ^

    The parts are kept for programs: ``kind`` ("node name", "namespace", "topic name", ...),
    ``name``, ``reason`` (rcl's / rmw's rule text) and ``index`` (of the bad character);
    :attr:`summary` is one line, for messages that must stay one line (config files, tokens).
    It is a :class:`ValueError`, as every error about a value the user gave is.
    """

    def __init__(self, kind: str, name: str, reason: str, index: int) -> None:
        self.kind = kind
        self.name = name
        self.reason = reason
        self.index = index
        # Characters that would break the display (newlines, tabs) are shown escaped, and the
        # caret moved by as many columns as the escapes take.
        shown = [c if c.isprintable() else repr(c)[1:-1] for c in name]
        column = sum(len(c) for c in shown[:index])
        super().__init__(f"Invalid {kind}: {reason}:\n  '{''.join(shown)}'\n   {' ' * column}^")

    @property
    def summary(self) -> str:
        """The same in one line: ``invalid node name 'my-node': node name must ... (index 2)``."""
        return f"invalid {self.kind} {self.name!r}: {self.reason} (index {self.index})"

    def __reduce__(self) -> tuple[type[NameValidationError], tuple[str, str, str, int]]:
        return type(self), (self.kind, self.name, self.reason, self.index)


class ParameterError(MiddlewareError, ValueError):
    """An undeclared parameter, a value of the wrong type, or a bad parameter file."""


class ParameterFileError(ConfigFileError, ParameterError):
    """A ROS 2 parameter file that cannot be used; carries ``path``, ``line`` and ``key``."""


class ServiceError(MiddlewareError):
    """A service that is not there, did not answer in time, or failed in its handler."""


class LaunchError(MiddlewareError, ValueError):
    """A malformed launch file, or launch options that do not fit it."""


class LaunchFileError(ConfigFileError, LaunchError):
    """A mistake at a line of a launch file; carries ``path``, ``line`` and ``key``."""


class BagError(MiddlewareError, ValueError):
    """A bag that cannot be opened, read or written."""


class BagWriteError(MiddlewareError):
    """A bag that stopped taking what is recorded (a full disk, a folder removed): a failure
    while running, not bad input (``servolab`` exits 1)."""


class TransportError(MiddlewareError, ValueError):
    """A transport that cannot be opened (bad endpoint, Zenoh failure): bad input, refused
    before anything moves (``servolab`` exits 2)."""
