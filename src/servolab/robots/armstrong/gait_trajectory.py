"""A motion (the seed's CSV gait, :func:`.motions.load_motion`) as one ``FollowJointTrajectory``
goal's trajectory, for joint_trajectory_controller (:mod:`.ros2_control`).

Why one goal and not one per row: the seed's control node sends each row as a step command
and lets each movement take one loop period, 222 ms at 4.5 Hz (001 section 4.2.4.4);
joint_trajectory_controller is given where the joints must be *when*, and interpolates
between. A row's time is therefore the end of its period: row ``k`` (from 0) of repeat ``s``
is reached ``(s x rows + k + 1) / rate`` seconds after the goal starts, and the movement to
it spans the same period as the seed's step does. The first point is one period in, not at
0: the controller starts from wherever the joints are when the goal starts, and a point at 0
would be a jump to the first row.

Positions only. A motion file holds angles and no velocities; joint_trajectory_controller
does not need them on a ``position`` command interface: points with positions alone are
interpolated linearly (ros2_controllers' ``trajectory.cpp``, ``interpolate_between_points``):
each joint moves straight from row to row over the row's period (the seed's joints go there
at their controller's ``joint_speed`` and wait; both stand on each row at its time).
Velocities by finite differences would make it a cubic through every row instead, with a
nonzero velocity at the last point, which ros2_controllers refuses unless
``allow_nonzero_velocity_at_trajectory_end`` (a trajectory must end at rest) — so none are
made.

A joint's position is its URDF joint angle: ``scale x radians(motion degrees)``, ``scale``
its motor's direction (a motion's degrees are motor angles, motor angle = direction x joint
angle: :meth:`.description.Description.joint_positions`), given by the caller
(:class:`JointMap`; :func:`.ros2_control.joint_maps` makes Armstrong's). The hardware turns
that into the horn angle the seed's joint controller would write (the block's
``mechanical_reduction`` and ``mechanical_offset``). Pure: no robot, no bus.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ...gait.motionfile import MotionFile
from ...gait.walking import PLAY_RATE
from ..errors import RobotValueError

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class JointMap:
    """How one motion column becomes one joint's position (rad): ``scale x
    radians(degrees)``."""

    column: str
    joint: str
    scale: float = 1.0


@dataclass(frozen=True)
class GaitTrajectory:
    """A trajectory as a ``trajectory_msgs/JointTrajectory`` carries it: joint names, and
    each point's positions (rad, ``positions[point, joint]``) and time from the start (s)."""

    joint_names: tuple[str, ...]
    times: FloatArray
    positions: FloatArray

    @property
    def duration(self) -> float:
        """Seconds from the start to the last point."""
        return float(self.times[-1])

    def fields(self, start: float = 0.0) -> dict[str, Any]:
        """The trajectory as a message's fields (``node.message(
        "control_msgs/action/FollowJointTrajectory_Goal", trajectory=t.fields())``): no
        velocities, accelerations or efforts; the header stamps ``start`` (ROS time, s), when
        the controller starts it: 0 is as soon as it arrives."""
        whole = duration_fields(start)
        return {"header": {"stamp": whole},
                "joint_names": list(self.joint_names),
                "points": [{"positions": [float(v) for v in row],
                            "time_from_start": duration_fields(float(t))}
                           for t, row in zip(self.times, self.positions, strict=True)]}


def duration_fields(seconds: float) -> dict[str, int]:
    """``builtin_interfaces/Duration`` of ``seconds`` (>= 0), to the nanosecond."""
    total = round(seconds * 1e9)
    return {"sec": total // 1_000_000_000, "nanosec": total % 1_000_000_000}


def motion_trajectory(motion: MotionFile, joints: Sequence[JointMap], *,
                      rate: float = PLAY_RATE, steps: int = 1,
                      rows: int | None = None) -> GaitTrajectory:
    """``motion`` played ``steps`` times at ``rate`` rows a second as one trajectory of the
    ``joints`` (see the module docstring for the times and the positions); ``rows`` keeps the
    first that many rows of the whole (to send the first seconds of a gait). Refused in one
    line: a column the motion lacks, a joint named twice, a rate that is not a positive
    number, fewer than one step or row."""
    if not (math.isfinite(rate) and rate > 0):
        raise RobotValueError(f"rate must be a number > 0 rows a second, not {rate!r}")
    if steps < 1:
        raise RobotValueError(f"steps must be >= 1, not {steps}")
    if not joints:
        raise RobotValueError("a trajectory needs at least one joint")
    names = [j.joint for j in joints]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise RobotValueError(f"joint {twice[0]!r} is given twice")
    missing = [j.column for j in joints if j.column not in motion.names]
    if missing:
        raise RobotValueError(f"the motion has no column {missing[0]!r} (it has "
                              f"{', '.join(motion.names)})")
    total = steps * motion.poses
    count = total if rows is None else rows
    if not 1 <= count <= total:
        raise RobotValueError(f"rows must be 1..{total} (the motion's {motion.poses} rows x "
                              f"{steps} step(s)), not {rows}")
    degrees = np.stack([motion.column(j.column) for j in joints], axis=1)
    degrees = np.tile(degrees, (steps, 1))[:count]
    scales = np.array([j.scale for j in joints])
    positions: FloatArray = scales * np.radians(degrees)
    times: FloatArray = np.arange(1, count + 1, dtype=np.float64) / rate
    return GaitTrajectory(tuple(names), times, positions)
