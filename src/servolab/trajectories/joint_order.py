"""A trajectory's joints made the controller's: missing joints held, columns in its order.

Follows ``JointTrajectoryController::fill_partial_goal`` and ``sort_to_local_joint_order``
(``src/joint_trajectory_controller.cpp``, Jazzy), which the controller applies, in that
order, to every trajectory it has accepted before sampling it. Why: with
``allow_partial_joints_goal`` a trajectory may name only some joints, in any order; the
controller's joints it does not name hold where they are commanded (positions) with zero
velocity and acceleration, and sampling then works on one column a controller joint.

The C++ holds a missing joint at its position *command* (or the position state without a
position command interface) and skips a NaN one, leaving that point short; here the caller
passes the hold positions and a NaN is refused instead. Sorting refuses names that are not
a permutation of the controller's joints, where the C++ logs a warning and leaves the
values unsorted (or writes out of bounds).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .errors import TrajectoryValueError
from .spline import FloatArray

__all__ = ["JointArrays", "fill_partial_goal", "sort_to_local_joint_order"]


@dataclass(frozen=True, init=False)
class JointArrays:
    """A trajectory's values by joint: one column a name of ``joint_names``, one row a point;
    ``velocities``/``accelerations`` None when the trajectory gives none."""

    joint_names: tuple[str, ...]
    positions: FloatArray
    velocities: FloatArray | None
    accelerations: FloatArray | None

    def __init__(self, joint_names: Sequence[str], positions: ArrayLike,
                 velocities: ArrayLike | None = None,
                 accelerations: ArrayLike | None = None) -> None:
        names = tuple(str(n) for n in joint_names)
        pos = np.array(positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[1] != len(names):
            raise TrajectoryValueError(f"positions must have shape (points, {len(names)}), "
                                       f"got {pos.shape}")
        fields: list[FloatArray | None] = [pos]
        for values, what in ((velocities, "velocities"), (accelerations, "accelerations")):
            if values is None:
                fields.append(None)
                continue
            array = np.array(values, dtype=np.float64)
            if array.shape != pos.shape:
                raise TrajectoryValueError(f"{what} must have shape {pos.shape}, got "
                                           f"{array.shape}")
            fields.append(array)
        for field in fields:
            if field is not None:
                field.flags.writeable = False
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "positions", fields[0])
        object.__setattr__(self, "velocities", fields[1])
        object.__setattr__(self, "accelerations", fields[2])


def fill_partial_goal(arrays: JointArrays, controller_joints: Sequence[str],
                      hold_positions: ArrayLike) -> JointArrays:
    """``arrays`` with a column appended for each controller joint it does not name, in the
    controller's order: position ``hold_positions[joint]`` at every point, velocity and
    acceleration 0 where the trajectory gives those fields.

    ``hold_positions`` has one value a controller joint, in the controller's order (the
    C++ reads the position command interface). As in the C++, a trajectory naming as many
    joints as the controller has is returned unchanged.
    """
    joints = tuple(controller_joints)
    hold = np.asarray(hold_positions, dtype=np.float64)
    if hold.shape != (len(joints),):
        raise TrajectoryValueError(f"hold_positions must have one value for each of the "
                                   f"{len(joints)} controller joints, got shape {hold.shape}")
    if len(arrays.joint_names) == len(joints):
        return arrays
    missing = [i for i, joint in enumerate(joints) if joint not in arrays.joint_names]
    if np.isnan(hold[missing]).any():
        raise TrajectoryValueError("a joint missing from the trajectory has no position to "
                                   "hold (NaN)")
    points = arrays.positions.shape[0]
    zeros = np.zeros((points, len(missing)))

    def extended(values: FloatArray | None) -> FloatArray | None:
        return None if values is None else np.hstack([values, zeros])

    return JointArrays(arrays.joint_names + tuple(joints[i] for i in missing),
                       np.hstack([arrays.positions, np.tile(hold[missing], (points, 1))]),
                       extended(arrays.velocities), extended(arrays.accelerations))


def sort_to_local_joint_order(arrays: JointArrays,
                              controller_joints: Sequence[str]) -> JointArrays:
    """``arrays`` with its columns in the order of ``controller_joints``; its names must be
    those joints, each once (fill a partial trajectory first)."""
    joints = tuple(controller_joints)
    if sorted(arrays.joint_names) != sorted(joints) or len(set(joints)) != len(joints):
        raise TrajectoryValueError(f"cannot sort joints {arrays.joint_names} into the "
                                   f"controller's {joints}: not the same joints, each once")
    order = [arrays.joint_names.index(joint) for joint in joints]

    def sorted_columns(values: FloatArray | None) -> FloatArray | None:
        return None if values is None else values[:, order]

    return JointArrays(joints, arrays.positions[:, order], sorted_columns(arrays.velocities),
                       sorted_columns(arrays.accelerations))
