"""The kinematics layer's errors.

Every error of the pure kinematics is about a value it was given (a length that is not
positive, a foot out of reach, a wheel geometry that cannot drive the ball), so it is a
:class:`KinematicsValueError`: bad input, ``servolab`` exits 2. :class:`KinematicsError` is
there so that a program catches the layer with one class.
"""

from __future__ import annotations

import math

from ..errors import ServolabError


class KinematicsError(ServolabError):
    """Base of every error raised by :mod:`servolab.kinematics`."""


class KinematicsValueError(KinematicsError, ValueError):
    """A geometry, angle, pose or array the kinematics cannot use; the message names it."""


def finite_number(name: str, value: float) -> float:
    """``value`` as a finite float, or a :class:`KinematicsValueError` naming ``name``.

    ``math.isfinite`` on a float, not ``diffdrive.finite_array``: the control loops call this
    several times a cycle on scalars, where building a NumPy array costs ten times the check.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise KinematicsValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise KinematicsValueError(f"{name} must be finite, got {value!r}")
    return number
