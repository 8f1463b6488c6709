"""Exceptions of the middleware.

As in :mod:`servolab.dynamixel.errors`, each message is one line that names the topic, type,
field, file, line or key at fault, so the user knows what to fix.
"""

from __future__ import annotations

from ..errors import ConfigFileError, ServolabError


class MiddlewareError(ServolabError):
    """Base of every error raised by :mod:`servolab.middleware`."""


class MessageError(MiddlewareError, ValueError):
    """An unknown message type, or a value that does not fit a message field."""


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


class TransportError(MiddlewareError):
    """A transport that cannot be opened (bad endpoint, Zenoh failure)."""
