"""The kinematics layer's errors.

Every error of the pure kinematics is about a value it was given (a length that is not
positive, a foot out of reach, a wheel geometry that cannot drive the ball), so it is a
:class:`KinematicsValueError`: bad input, ``servolab`` exits 2. :class:`KinematicsError` is
there so that a program catches the layer with one class.
"""

from __future__ import annotations

from ..errors import ServolabError


class KinematicsError(ServolabError):
    """Base of every error raised by :mod:`servolab.kinematics`."""


class KinematicsValueError(KinematicsError, ValueError):
    """A geometry, angle, pose or array the kinematics cannot use; the message names it."""
