"""One segment of a joint trajectory: the state between two waypoints, all joints at once.

Follows ``Trajectory::interpolate_between_points`` of ros2_controllers'
``joint_trajectory_controller`` (``src/trajectory.cpp``, Jazzy), so that a controller built
on this package commands what the ROS controller would command for the same trajectory:

* positions only on both ends: linear (velocity = the slope, acceleration 0);
* positions and velocities on both ends: cubic Hermite;
* positions, velocities and accelerations on both ends: quintic.

A field counts only if *both* ends have it, so the lowest common degree is used (one end
with accelerations and one without: cubic). One combination the C++ has no branch for:
accelerations on both ends but velocities missing on one of them. There ros2_controllers
leaves its output at its freshly zeroed values, so position, velocity and acceleration are
all 0; :class:`SplineKind.UNCOVERED` names that case and this module reproduces it rather
than guess (``trajectory.hpp``'s comment says "lowest common specification", which would be
linear). A sample outside the segment is clamped to its nearest end and always interpolated
linearly, as the C++ does (so the velocity there is the chord's slope, not the end's).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import TrajectoryValueError

__all__ = ["FloatArray", "PointState", "SplineKind", "interpolate_between_points",
           "interpolate_segment", "spline_kind"]

FloatArray = NDArray[np.float64]


def _vector(values: ArrayLike | None, size: int | None, what: str) -> FloatArray | None:
    """``values`` as a 1-D float array of ``size`` (any size when None), or None when not
    given: an empty field of a ROS point means "not given", so an empty array does too."""
    if values is None:
        return None
    array = np.array(values, dtype=np.float64)
    if array.ndim != 1:
        raise TrajectoryValueError(f"{what} must be one value a joint (1-D), got shape "
                                   f"{array.shape}")
    if array.size == 0:
        return None
    if size is not None and array.size != size:
        raise TrajectoryValueError(f"{what} has {array.size} values for {size} joints")
    return array


@dataclass(frozen=True, init=False)
class PointState:
    """A waypoint or a sampled state: one value a joint for each field given.

    ``velocities`` or ``accelerations`` of None (or empty) mean "not given", as an empty
    field of ``trajectory_msgs/JointTrajectoryPoint`` does; which fields are given decides
    the spline's degree. The arrays are copies, read-only, so a state can be shared.
    """

    positions: FloatArray
    velocities: FloatArray | None
    accelerations: FloatArray | None

    def __init__(self, positions: ArrayLike, velocities: ArrayLike | None = None,
                 accelerations: ArrayLike | None = None) -> None:
        pos = _vector(positions, None, "positions")
        if pos is None:
            raise TrajectoryValueError("a state needs positions (one a joint)")
        vel = _vector(velocities, pos.size, "velocities")
        acc = _vector(accelerations, pos.size, "accelerations")
        for array in (pos, vel, acc):
            if array is not None:
                array.flags.writeable = False
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "velocities", vel)
        object.__setattr__(self, "accelerations", acc)

    @property
    def joint_count(self) -> int:
        """How many joints the state has values for."""
        return int(self.positions.size)

    def as_arrays(self) -> tuple[FloatArray, FloatArray, FloatArray]:
        """(positions, velocities, accelerations), zeros for a field not given: what a
        command interface is written from (the C++ resizes missing fields with zeros)."""
        zeros = np.zeros(self.joint_count)
        return (self.positions,
                zeros if self.velocities is None else self.velocities,
                zeros if self.accelerations is None else self.accelerations)


class SplineKind(Enum):
    """Which polynomial ros2_controllers fits between two states."""

    LINEAR = "linear"
    CUBIC = "cubic"
    QUINTIC = "quintic"
    #: accelerations on both ends, velocities not: the C++ has no branch and outputs zeros
    UNCOVERED = "uncovered"


def spline_kind(state_a: PointState, state_b: PointState) -> SplineKind:
    """The polynomial for a segment from ``state_a`` to ``state_b``: a field counts when both
    ends have it (``has_velocity``/``has_accel`` of ``interpolate_between_points``)."""
    has_velocity = state_a.velocities is not None and state_b.velocities is not None
    has_accel = state_a.accelerations is not None and state_b.accelerations is not None
    if not has_velocity and not has_accel:
        return SplineKind.LINEAR
    if has_velocity and not has_accel:
        return SplineKind.CUBIC
    if has_velocity and has_accel:
        return SplineKind.QUINTIC
    return SplineKind.UNCOVERED


def _powers(x: float, n: int) -> list[float]:
    """``[1, x, x**2, ..., x**n]`` by repeated products, the C++'s ``generate_powers``."""
    out = [1.0]
    for _ in range(n):
        out.append(out[-1] * x)
    return out


def interpolate_segment(state_a: PointState, state_b: PointState, elapsed: float,
                        duration: float) -> PointState:
    """The state ``elapsed`` seconds into a segment of ``duration`` seconds from ``state_a``
    to ``state_b``; all joints at once.

    The result always has positions, velocities and accelerations (zeros where the degree
    gives none). ``elapsed`` below 0 or above ``duration`` is clamped to that end and the
    segment is then treated as linear, as ros2_controllers does. A zero ``duration`` keeps
    only the start's terms (no division by zero), again as the C++ does.
    """
    if state_a.joint_count != state_b.joint_count:
        raise TrajectoryValueError(f"segment ends have {state_a.joint_count} and "
                                   f"{state_b.joint_count} joints")
    kind = spline_kind(state_a, state_b)
    elapsed = float(elapsed)
    duration = float(duration)
    if elapsed < 0.0:
        elapsed, kind = 0.0, SplineKind.LINEAR
    if elapsed > duration:
        elapsed, kind = duration, SplineKind.LINEAR

    zeros = np.zeros(state_a.joint_count)
    if kind is SplineKind.UNCOVERED:
        return PointState(zeros, zeros, zeros)

    t = _powers(elapsed, 5)
    big_t = _powers(duration, 5)
    moving = duration != 0.0
    p0, p1 = state_a.positions, state_b.positions

    if kind is SplineKind.LINEAR:
        slope = (p1 - p0) / duration if moving else zeros
        return PointState(p0 + t[1] * slope, t[0] * slope, zeros)

    assert state_a.velocities is not None and state_b.velocities is not None
    v0, v1 = state_a.velocities, state_b.velocities
    if kind is SplineKind.CUBIC:
        c2 = c3 = zeros
        if moving:
            c2 = (3.0 * (p1 - p0) - (2.0 * v0 + v1) * big_t[1]) / big_t[2]
            c3 = (2.0 * (p0 - p1) + (v0 + v1) * big_t[1]) / big_t[3]
        return PointState(p0 + t[1] * v0 + t[2] * c2 + t[3] * c3,
                          v0 + t[1] * 2.0 * c2 + t[2] * 3.0 * c3,
                          t[0] * 2.0 * c2 + t[1] * 6.0 * c3)

    assert state_a.accelerations is not None and state_b.accelerations is not None
    a0, a1 = state_a.accelerations, state_b.accelerations
    c2 = 0.5 * a0
    c3 = c4 = c5 = zeros
    if moving:
        # the quintic whose value, slope and curvature match both ends (textbook closed form)
        dp = p1 - p0
        c3 = (20.0 * dp - (12.0 * v0 + 8.0 * v1) * big_t[1]
              - (3.0 * a0 - a1) * big_t[2]) / (2.0 * big_t[3])
        c4 = (-30.0 * dp + (16.0 * v0 + 14.0 * v1) * big_t[1]
              + (3.0 * a0 - 2.0 * a1) * big_t[2]) / (2.0 * big_t[4])
        c5 = (12.0 * dp - 6.0 * (v0 + v1) * big_t[1]
              - (a0 - a1) * big_t[2]) / (2.0 * big_t[5])
    return PointState(
        p0 + t[1] * v0 + t[2] * c2 + t[3] * c3 + t[4] * c4 + t[5] * c5,
        v0 + t[1] * 2.0 * c2 + t[2] * 3.0 * c3 + t[3] * 4.0 * c4 + t[4] * 5.0 * c5,
        t[0] * 2.0 * c2 + t[1] * 6.0 * c3 + t[2] * 12.0 * c4 + t[3] * 20.0 * c5)


def interpolate_between_points(time_a: float, state_a: PointState, time_b: float,
                               state_b: PointState, sample_time: float) -> PointState:
    """The state at ``sample_time`` (s) on the segment from ``state_a`` at ``time_a`` to
    ``state_b`` at ``time_b``: ``Trajectory::interpolate_between_points`` with times in
    seconds. See :func:`interpolate_segment` for the degree and the clamping."""
    return interpolate_segment(state_a, state_b, float(sample_time) - float(time_a),
                               float(time_b) - float(time_a))
