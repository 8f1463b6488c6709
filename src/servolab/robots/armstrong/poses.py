"""Armstrong's joints as the seed's control node groups them, and its named poses.

Table 4.1 of seed 001 groups the 21 motors into human joints, each moved along its X, Y or Z
axis (``moveMotors_left_hip_joint(x, y, z)`` drives m12, m13 and m11); Table 4.2 is the stand
pose the walking algorithm starts from. A pose here is a mapping of motor columns
(``"m14"``, the names of the motion files' header) to joint angles in **degrees**, as the seed
and its motion files write them; :func:`radians` gives the same pose in radians, what the
joint controllers take. Pure data and pure functions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from ...gait.walking import MOTOR_COLUMNS, TABLE_4_2_STAND_POSE
from ..errors import RobotValueError

#: Table 4.1: joint function -> {axis: motor column}.
JOINTS: dict[str, dict[str, str]] = {
    "neck": {"z": "m61"},
    "camera": {"x": "m62"},
    "trunk": {"x": "m51"},
    "left_shoulder": {"x": "m31", "y": "m32"},
    "left_elbow": {"x": "m33"},
    "right_shoulder": {"x": "m41", "y": "m42"},
    "right_elbow": {"x": "m43"},
    "left_hip": {"x": "m12", "y": "m13", "z": "m11"},
    "left_knee": {"x": "m14"},
    "left_ankle": {"x": "m15", "y": "m16"},
    "right_hip": {"x": "m22", "y": "m23", "z": "m21"},
    "right_knee": {"x": "m24"},
    "right_ankle": {"x": "m25", "y": "m26"},
}

#: Every motor column, in the order of the seed's motion files (Table 4.3's header).
MOTORS = MOTOR_COLUMNS

Pose = Mapping[str, float]

#: All joints at 0: every motor at its configured ``init`` (001 section 4.2.3).
ZERO_POSE: dict[str, float] = dict.fromkeys(MOTORS, 0.0)

#: Table 4.2, the initial position of the walking algorithm, degrees as printed (the gait
#: layer's table: the generators start from it).
STAND_POSE: dict[str, float] = {**ZERO_POSE, **TABLE_4_2_STAND_POSE}

#: The named poses a student can ask for by name.
POSES: dict[str, dict[str, float]] = {"zero": ZERO_POSE, "stand": STAND_POSE}


def joint_pose(joint: str, **axes: float) -> dict[str, float]:
    """The motor columns of one joint function of Table 4.1 and their angles (degrees):
    ``joint_pose("left_hip", x=-27.666, y=0.619)`` -> ``{"m12": -27.666, "m13": 0.619}``."""
    if joint not in JOINTS:
        close = [j for j in JOINTS if joint.replace("-", "_") in j]
        raise RobotValueError(f"no joint {joint!r} (Table 4.1 has {', '.join(JOINTS)})"
                              + (f"; did you mean {close[0]!r}?" if close else ""))
    motors = JOINTS[joint]
    for axis, value in axes.items():
        if axis not in motors:
            raise RobotValueError(f"joint {joint!r} moves along {', '.join(motors)}, not {axis!r}")
        if not math.isfinite(value):
            raise RobotValueError(f"joint {joint!r} {axis}: {value!r} is not a finite angle")
    return {motors[axis]: float(value) for axis, value in axes.items()}


def radians(degrees: float) -> float:
    """A joint angle in radians, what the joint controllers take (the seed's node used 3.14
    for pi; this is pi)."""
    return math.radians(degrees)


def pose_radians(pose: Pose) -> dict[str, float]:
    """A pose in radians."""
    return {motor: radians(angle) for motor, angle in pose.items()}


def interpolate(start: Pose, end: Pose, samples: int) -> npt.NDArray[np.float64]:
    """``samples`` poses from ``start`` to ``end`` (both ends included) over the motors of
    ``end``, linearly in joint angle, shape ``(samples, len(end))``: a move is never a jump.
    A motor of ``end`` missing from ``start`` starts where it ends."""
    if samples < 2:
        raise RobotValueError(f"an interpolated move needs at least 2 samples, not {samples}")
    motors = list(end)
    a = np.array([start.get(m, end[m]) for m in motors], dtype=np.float64)
    b = np.array([end[m] for m in motors], dtype=np.float64)
    t = np.linspace(0.0, 1.0, samples)[:, None]
    result: npt.NDArray[np.float64] = a + (b - a) * t
    return result
