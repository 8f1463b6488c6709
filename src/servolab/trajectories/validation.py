"""Whether a controller accepts a trajectory: ``JointTrajectoryController::
validate_trajectory_msg`` (``src/joint_trajectory_controller.cpp``, Jazzy) over arrays.

Why a returned line and not an exception: a refused trajectory is an ordinary event for a
controller (it logs the reason, rejects the action goal, and keeps running), and the reason
is what its user needs to see. So :func:`validate_trajectory` returns None for a trajectory
the controller accepts and otherwise the line ros2_controllers logs, with the checks in the
C++'s order so the first failure is the one it names:

1. without ``allow_partial_joints_goal``, exactly as many joint names as the controller has;
2. at least one joint name; 3. at least one point (an empty trajectory is refused);
4. every name one of the controller's joints; then, *not* in the C++, no name twice (see
   below);
5. without ``allow_nonzero_velocity_at_trajectory_end``, every velocity of the last point
   within float32's epsilon of 0 (a point without velocities passes);
6. a trajectory stamped other than 0 must not end (stamp + last time_from_start) before
   ``now``; one that started in the past but ends later is accepted;
7. point by point: time_from_start strictly increasing (the first point's is not checked,
   so 0 is fine), positions one a joint, velocities and accelerations empty or one a joint,
   and no efforts.

Deliberate differences: the C++ does not check for a joint named twice, and then sorts
values into its joints through a mapping that silently overwrites one of them (and keeps a
stale value in a static buffer for the other); this refuses it. Efforts are always refused,
because this package does not carry them (the C++ accepts them when it has an ``effort``
command interface). Trajectories without positions (``allow_integration_in_goal_
trajectories``) are not supported. A time that is NaN or infinite, which a ROS message
cannot hold, is refused.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._time import to_ns, to_s
from .errors import TrajectoryValueError
from .spline import FloatArray

__all__ = ["ValidationConfig", "validate_trajectory"]

#: ``std::numeric_limits<float>::epsilon()``: the C++'s "zero" for the end velocity
_ZERO_VELOCITY = float(np.finfo(np.float32).eps)


@dataclass(frozen=True)
class ValidationConfig:
    """The controller parameters validation reads (defaults as the parameter YAML's)."""

    joints: tuple[str, ...]
    allow_partial_joints_goal: bool = False
    allow_nonzero_velocity_at_trajectory_end: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "joints", tuple(self.joints))
        if not self.joints:
            raise TrajectoryValueError("a controller needs at least one joint")
        if len(set(self.joints)) != len(self.joints):
            raise TrajectoryValueError(f"the controller's joints repeat a name: {self.joints}")


def _per_point(values: Iterable[ArrayLike] | None, count: int,
               what: str) -> list[FloatArray]:
    """One 1-D array a point (empty when not given); points may differ in length."""
    if values is None:
        return [np.zeros(0) for _ in range(count)]
    rows = [np.asarray(row, dtype=np.float64).reshape(-1) for row in values]
    if len(rows) != count:
        raise TrajectoryValueError(f"{what} has {len(rows)} points, time_from_start {count}")
    return rows


def _size_error(joint_count: int, field: FloatArray, name: str, index: int,
                allow_empty: bool) -> str | None:
    """``validate_trajectory_point_field``: the line when ``field`` is not one a joint."""
    if allow_empty and field.size == 0:
        return None
    if field.size != joint_count:
        return (f"Mismatch between joint_names size ({joint_count}) and {name} "
                f"({field.size}) at point #{index}.")
    return None


def validate_trajectory(joint_names: Sequence[str], time_from_start: ArrayLike,
                        positions: Iterable[ArrayLike],
                        velocities: Iterable[ArrayLike] | None = None,
                        accelerations: Iterable[ArrayLike] | None = None,
                        efforts: Iterable[ArrayLike] | None = None, *,
                        config: ValidationConfig, now: float,
                        start_time: float = 0.0) -> str | None:
    """None when the controller configured by ``config`` accepts the trajectory, else the
    one line it logs when refusing it.

    ``time_from_start`` has one time (s) a point; ``positions``, ``velocities``,
    ``accelerations`` and ``efforts`` one row a point, each in the order of
    ``joint_names`` and possibly empty (a field not given at that point); None for a field
    no point gives. ``start_time`` is the header stamp (s, 0 = start now) and ``now`` the
    controller's clock (s), used only when the stamp is not 0.
    """
    times = np.asarray(time_from_start, dtype=np.float64).reshape(-1)
    count = int(times.size)
    names = [str(name) for name in joint_names]
    pos = _per_point(positions, count, "positions")
    vel = _per_point(velocities, count, "velocities")
    acc = _per_point(accelerations, count, "accelerations")
    eff = _per_point(efforts, count, "efforts")
    joint_count = len(names)

    if not config.allow_partial_joints_goal and joint_count != len(config.joints):
        return "Joints on incoming trajectory don't match the controller joints."
    if joint_count == 0:
        return "Empty joint names on incoming trajectory."
    if count == 0:
        return "Empty trajectory received."
    for name in names:
        if name not in config.joints:
            return f"Incoming joint {name} doesn't match the controller's joints."
    for i, name in enumerate(names):
        if name in names[:i]:
            return f"Incoming joint {name} is named more than once."

    if not config.allow_nonzero_velocity_at_trajectory_end:
        for i, value in enumerate(vel[-1]):
            if abs(value) > _ZERO_VELOCITY:
                joint = names[i] if i < joint_count else f"#{i}"
                return f"Velocity of last trajectory point of joint {joint} is not zero: " \
                       f"{value:.15f}"

    for i, value in enumerate(times):
        if not math.isfinite(value):
            return f"time_from_start of point #{i} is not finite: {value}"
    times_ns = [to_ns(t) for t in times]
    start_ns = to_ns(start_time, "start_time")
    if start_ns != 0:
        end_ns = start_ns + times_ns[-1]
        if end_ns < to_ns(now, "now"):
            return (f"Received trajectory with non-zero start time ({to_s(start_ns):f}) "
                    f"that ends in the past ({to_s(end_ns):f})")

    for i in range(count):
        if i > 0 and times_ns[i] <= times_ns[i - 1]:
            return (f"Time between points {i - 1} and {i} is not strictly increasing, it is "
                    f"{to_s(times_ns[i - 1]):f} and {to_s(times_ns[i]):f} respectively")
        for field, name, allow_empty in ((pos[i], "positions", False),
                                         (vel[i], "velocities", True),
                                         (acc[i], "accelerations", True)):
            error = _size_error(joint_count, field, name, i, allow_empty)
            if error is not None:
                return error
        if eff[i].size:
            return ("Trajectories with effort fields are only supported for controllers using "
                    "the 'effort' command interface.")
    return None
