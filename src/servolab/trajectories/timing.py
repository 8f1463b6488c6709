"""Time-optimal, jerk-limited timing of a joint-space move, through `ruckig`_ (Berscheid and
Kröger, "Jerk-limited Real-time Trajectory Generation with Arbitrary Target States", RSS 2021):
the fastest move from one joint position to another, every joint within its velocity,
acceleration and jerk limits, all joints starting and arriving together (ruckig's time
synchronization), at rest at both ends unless a start velocity is given.

:func:`time_optimal` computes the move once (ruckig's offline ``calculate``);
:meth:`TimedMove.sample` samples it every ``period`` s, with positions, velocities and
accelerations, the points of a ``FollowJointTrajectory`` goal: a joint_trajectory_controller
given positions and velocities interpolates cubic splines between them (quintic with the
accelerations too), so it follows ruckig's profile to within the sampling's error, not the
polyline through the positions.

Why ruckig rather than toppra: a move between two rest states needs no path to be
parameterized (toppra times a given geometric path and stops at acceleration limits: no jerk
limit), ruckig's jerk limit is what keeps a servo's gearbox from a step in torque, and it
solves in microseconds.

Pure: numbers in, arrays out; radians (or metres for a prismatic joint) and seconds.

.. _ruckig: https://github.com/pantor/ruckig
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import TrajectoryValueError

__all__ = ["MoveLimits", "TimedMove", "time_optimal"]

FloatArray = NDArray[np.float64]


def _vector(name: str, values: ArrayLike, size: int | None = None) -> FloatArray:
    """``values`` as a finite 1-D float array (of ``size``), or one line naming ``name``."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise TrajectoryValueError(f"{name} must be numbers, got {values!r:.80}") from None
    if array.ndim != 1 or (size is not None and array.shape != (size,)):
        want = f"{size} numbers" if size is not None else "a list of numbers"
        raise TrajectoryValueError(f"{name} must be {want}, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise TrajectoryValueError(f"{name} must be finite, got {array.tolist()}")
    return array


@dataclass(frozen=True)
class MoveLimits:
    """Each joint's largest speed, acceleration and jerk (units/s, /s², /s³; all > 0)."""

    velocity: tuple[float, ...]
    acceleration: tuple[float, ...]
    jerk: tuple[float, ...]

    def __post_init__(self) -> None:
        sizes = {len(self.velocity), len(self.acceleration), len(self.jerk)}
        if len(sizes) != 1 or 0 in sizes:
            raise TrajectoryValueError("velocity, acceleration and jerk limits must give one "
                                       "number a joint each, as many for every joint")
        for name in ("velocity", "acceleration", "jerk"):
            values = _vector(f"the {name} limits", getattr(self, name))
            if np.any(values <= 0):
                raise TrajectoryValueError(f"the {name} limits must be > 0, got "
                                           f"{values.tolist()}")

    @property
    def joints(self) -> int:
        return len(self.velocity)

    def scaled(self, velocity: float = 1.0, acceleration: float = 1.0) -> MoveLimits:
        """These limits with the speeds times ``velocity`` and the accelerations times
        ``acceleration`` (MoveIt's scaling factors, each in (0, 1]); the jerks unchanged."""
        for name, factor in (("velocity", velocity), ("acceleration", acceleration)):
            if not (math.isfinite(factor) and 0 < factor <= 1):
                raise TrajectoryValueError(f"the {name} scaling must be in (0, 1], got "
                                           f"{factor!r}")
        return MoveLimits(tuple(v * velocity for v in self.velocity),
                          tuple(a * acceleration for a in self.acceleration), self.jerk)


@dataclass(frozen=True)
class TimedMove:
    """A move ruckig timed: from ``start`` to ``target`` in ``duration`` s. ``profile`` is
    ruckig's trajectory (``at_time(t)`` -> positions, velocities, accelerations)."""

    start: FloatArray
    target: FloatArray
    duration: float
    profile: object

    def at(self, t: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Positions, velocities and accelerations ``t`` s after the start (held at the ends
        outside [0, duration])."""
        if t >= self.duration:
            n = len(self.target)
            return self.target.copy(), np.zeros(n), np.zeros(n)
        position, velocity, acceleration = self.profile.at_time(max(0.0, t))  # type: ignore[attr-defined]
        return (np.asarray(position, dtype=np.float64), np.asarray(velocity, dtype=np.float64),
                np.asarray(acceleration, dtype=np.float64))

    def sample(self, period: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """The move every ``period`` s after its start, and its end: times (s, the first
        ``period`` or the duration, whichever comes first: the start itself is where the
        joints are) and positions, velocities, accelerations (one row a time). The last row
        is the target at rest, at exactly the duration."""
        if not (math.isfinite(period) and period > 0):
            raise TrajectoryValueError(f"the sampling period must be a number > 0 s, got "
                                       f"{period!r}")
        count = max(1, math.ceil(self.duration / period - 1e-9))
        times = np.minimum(np.arange(1, count + 1) * period, self.duration)
        times[-1] = self.duration
        rows = [self.at(float(t)) for t in times]
        rows[-1] = (self.target.copy(), np.zeros(len(self.target)), np.zeros(len(self.target)))
        positions, velocities, accelerations = (np.array([r[i] for r in rows])
                                                for i in range(3))
        return times, positions, velocities, accelerations


def time_optimal(start: ArrayLike, target: ArrayLike, limits: MoveLimits, *,
                 start_velocity: Sequence[float] | None = None,
                 minimum_duration: float = 0.0) -> TimedMove:
    """The time-optimal jerk-limited move from ``start`` to ``target`` (one number a joint)
    within ``limits``, arriving at rest, every joint synchronized to the slowest; starting
    at rest, or at ``start_velocity``. ``minimum_duration`` (s) stretches a short move to at
    least that long. Raises :class:`TrajectoryValueError` naming what ruckig refused."""
    from ruckig import InputParameter, Result, Ruckig, Trajectory

    n = limits.joints
    q0 = _vector("the start", start, n)
    q1 = _vector("the target", target, n)
    v0 = np.zeros(n) if start_velocity is None else _vector("the start velocity",
                                                             start_velocity, n)
    if not (math.isfinite(minimum_duration) and minimum_duration >= 0):
        raise TrajectoryValueError(f"the minimum duration must be a number >= 0 s, got "
                                   f"{minimum_duration!r}")
    if np.array_equal(q0, q1) and not np.any(v0):
        return TimedMove(q0, q1, 0.0, None)
    given = InputParameter(n)
    given.current_position = q0.tolist()
    given.current_velocity = v0.tolist()
    given.current_acceleration = [0.0] * n
    given.target_position = q1.tolist()
    given.target_velocity = [0.0] * n
    given.target_acceleration = [0.0] * n
    given.max_velocity = list(limits.velocity)
    given.max_acceleration = list(limits.acceleration)
    given.max_jerk = list(limits.jerk)
    if minimum_duration > 0:
        given.minimum_duration = minimum_duration
    profile = Trajectory(n)
    result = Ruckig(n).calculate(given, profile)
    if result not in (Result.Working, Result.Finished):
        raise TrajectoryValueError(f"ruckig cannot time the move from {q0.round(4).tolist()} "
                                   f"to {q1.round(4).tolist()}: {result.name}")
    return TimedMove(q0, q1, float(profile.duration), profile)
