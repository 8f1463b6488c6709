"""What the navigator thinks, as the standard ROS messages Nav2 publishes it in (pure
conversions: arrays in, message fields out; :class:`~.navigator.NavigatorNode` publishes them).

- **The costmap** (``nav_msgs/msg/OccupancyGrid`` on :data:`COSTMAP_TOPIC`): the inflated grid
  D* Lite plans on, costmap_2d's unsigned-char costs 0..255 written on the OccupancyGrid's
  scale as Nav2's ``Costmap2DPublisher`` writes them (nav2_costmap_2d/src/
  costmap_2d_publisher.cpp, its ``cost_translation_table_``; costmap_2d's values are those of
  nav2_costmap_2d/cost_values.hpp, here :mod:`servolab.planning.costmap`)::

      FREE_SPACE                    0   -> 0
      1 .. 252 (inflated band)      c   -> 1 + (97 * (c - 1)) // 251     (1 .. 98)
      INSCRIBED_INFLATED_OBSTACLE 253   -> 99
      LETHAL_OBSTACLE             254   -> 100
      NO_INFORMATION              255   -> -1

  which keeps nav_msgs/msg/OccupancyGrid's meaning of ``data`` (occupancy probability 0..100,
  -1 unknown). :func:`costmap_values` is the table, :func:`costmap_occupancy` applies it.
- **Paths** (``nav_msgs/msg/Path``): poses ``(x, y, yaw)`` in the ``map`` frame, metres and
  radians, the heading as a quaternion about z (:func:`pose_fields`, :func:`path_fields`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from ...planning.costmap import (
    FREE_SPACE,
    INSCRIBED_INFLATED_OBSTACLE,
    LETHAL_OBSTACLE,
    NO_INFORMATION,
)
from ..errors import RobotValueError

# The topics are relative, as Nav2's nodes name them: a robot alone has them at the root
# (``/global_costmap/costmap``), a robot in a namespace in it (``/robot1/global_costmap/...``).
#: Nav2's global costmap topic (nav2_costmap_2d's ``<name>/costmap``, name global_costmap)
COSTMAP_TOPIC = "global_costmap/costmap"
#: the controller's chosen trajectory, as Nav2's controller server publishes it
LOCAL_PLAN_TOPIC = "local_plan"
#: the robot's poses so far
DRIVEN_PATH_TOPIC = "path"
#: the goal being driven to (nav2's goal topic, rviz2's and Foxglove's "2D goal pose")
GOAL_TOPIC = "goal_pose"
#: a new pose joins the driven path once it is this far (m) from the last one kept
PATH_SPACING = 0.03


def costmap_values() -> npt.NDArray[np.int8]:
    """Nav2's ``cost_translation_table_``: index a costmap_2d cost 0..255, get the
    OccupancyGrid value (see the module docstring)."""
    table = np.empty(256, dtype=np.int8)
    costs = np.arange(1, INSCRIBED_INFLATED_OBSTACLE)
    table[costs] = 1 + (97 * (costs - 1)) // 251
    table[FREE_SPACE] = 0
    table[INSCRIBED_INFLATED_OBSTACLE] = 99
    table[LETHAL_OBSTACLE] = 100
    table[NO_INFORMATION] = -1
    return table


_TABLE = costmap_values()


def costmap_occupancy(costmap: npt.ArrayLike) -> npt.NDArray[np.int8]:
    """A costmap_2d grid ``[row, col]`` of costs 0..255 as OccupancyGrid ``data``: row-major
    from the origin's cell (row 0 is the map's lowest y, as the grid's own rows), int8."""
    grid = np.asarray(costmap)
    if grid.ndim != 2 or not np.issubdtype(grid.dtype, np.integer) or (
            grid.size and (grid.min() < 0 or grid.max() > 255)):
        raise RobotValueError("a costmap is a 2-D array of integer costs 0..255")
    return np.asarray(_TABLE[grid.reshape(-1).astype(np.intp)], dtype=np.int8)


def pose_fields(x: float, y: float, yaw: float = 0.0) -> dict[str, Any]:
    """A ``geometry_msgs/msg/Pose``'s fields: position (m) and the heading about z (rad)."""
    return {"position": {"x": float(x), "y": float(y)},
            "orientation": {"z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}}


def path_fields(poses: npt.ArrayLike, stamp: Any, frame: str,
                stamps: list[Any] | None = None) -> dict[str, Any]:
    """A ``nav_msgs/msg/Path``'s fields from ``(N, 3)`` poses ``(x, y, yaw)`` (or ``(N, 2)``:
    heading 0); each pose stamped with ``stamps[i]`` if given, else ``stamp``."""
    array = np.asarray(poses, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] not in (2, 3):
        raise RobotValueError(f"path poses must be (N, 2) or (N, 3), not {array.shape}")
    if stamps is not None and len(stamps) != len(array):
        raise RobotValueError(f"{len(stamps)} stamps for {len(array)} poses")
    yaws = array[:, 2] if array.shape[1] == 3 else np.zeros(len(array))
    return {"header": {"stamp": stamp, "frame_id": frame}, "poses": [
        {"header": {"stamp": stamp if stamps is None else stamps[i], "frame_id": frame},
         "pose": pose_fields(x, y, yaw)}
        for i, (x, y, yaw) in enumerate(zip(array[:, 0], array[:, 1], yaws, strict=True))]}
