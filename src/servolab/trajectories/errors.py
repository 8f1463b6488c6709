"""The trajectories layer's errors.

What a trajectory *message* gets wrong (an unknown joint, times that do not increase) is not
an exception here: :func:`~servolab.trajectories.validation.validate_trajectory` returns it as
a line, as ros2_controllers logs it and refuses the goal, because a controller refuses a bad
goal and keeps running. The exceptions are for a program that calls this package wrongly
(arrays of the wrong shape, a tolerance of -123, sampling before the state before the
trajectory is known): bugs of the caller, reported where they happen.
"""

from __future__ import annotations

from ..errors import ServolabError


class TrajectoryError(ServolabError):
    """Base of every error raised by :mod:`servolab.trajectories`; also a trajectory that
    cannot be sampled yet (no state before it where one is needed)."""


class TrajectoryValueError(TrajectoryError, ValueError):
    """An array, time or tolerance the trajectory code cannot use; the message names it."""
