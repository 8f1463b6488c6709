"""move_base's recovery behaviours, as the navigator runs them between controller cycles.

move_base (ros-planning/navigation, move_base.cpp ``executeCycle``) enters its CLEARING state
for one of three reasons -- no plan for ``planner_patience``, no valid command for
``controller_patience``, no progress of ``oscillation_distance`` for ``oscillation_timeout`` --
and runs its next recovery behaviour; the goal is given up only once every behaviour has run
and the trouble is still there. A behaviour's index goes back to the first when the trouble
that triggered it ends (a plan found, a valid command, the robot moved). The two plugins of
its default list are here:

- ``ClearCostmapRecovery`` forgets the obstacles outside a square of side ``reset_distance``
  around the robot, so that a stale obstacle a sensor no longer sees cannot keep blocking the
  plan. servolab's map is the overhead camera's, which sees the whole floor every frame and
  marks only what it sees now: nothing in it is stale, and what a clearing forgot would be
  re-marked at once. What is left of the behaviour is the fresh start: the navigator plans
  from scratch (a new D* Lite search) on the camera's latest map.
- :class:`RotateRecovery` turns the robot once, a full turn counter-clockwise on the spot, as
  rotate_recovery.cpp does (it counts half a turn, then the way back to the start heading),
  unless a pose of the turn is in collision on the costmap. rotate_recovery checks that every
  cycle; servolab checks it once, before the turn (the map does not change under a turn on
  the spot unless an obstacle appears), and ends a turn that takes more than
  :data:`ROTATE_TIMEOUT` s (a wheel that does not turn). Its speed is
  ``sqrt(2 acc_lim_th dist_left)`` within ``[min_in_place_rotational_vel,
  max_rotational_vel]``. rotate_recovery reads those from the
  ``TrajectoryPlannerROS`` namespace, which a DWA configuration does not write, so ROS runs it
  on their defaults: 3.2 rad/s², 0.4 and 1.0 rad/s, a tolerance of 0.10 rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from ...planning.costmap import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from ...planning.dwa import footprint_cost

#: rotate_recovery's defaults (rotate_recovery.cpp ``initialize``)
ROTATE_ACC_LIM = 3.2
ROTATE_MIN_VEL = 0.4
ROTATE_MAX_VEL = 1.0
ROTATE_TOLERANCE = 0.10
ROTATE_GRANULARITY = 0.017
#: servolab's own limit on one turn (s): a full turn at the slowest rate takes 16 s
ROTATE_TIMEOUT = 30.0


def angle_between(target: float, current: float) -> float:
    """``angles::shortest_angular_distance(current, target)``."""
    return math.remainder(target - current, 2.0 * math.pi)


@dataclass
class RotateRecovery:
    """One in-place turn in progress: call :meth:`command` each controller cycle with the
    robot's heading; None once the turn is done."""

    start_yaw: float
    got_180: bool = False

    def dist_left(self, yaw: float) -> float:
        if not self.got_180:
            to_180 = abs(angle_between(self.start_yaw + math.pi, yaw))
            if to_180 < ROTATE_TOLERANCE:
                self.got_180 = True
            else:
                return math.pi + to_180
        return abs(angle_between(self.start_yaw, yaw))

    def command(self, yaw: float) -> float | None:
        """The turn rate for this cycle (rad/s, positive), or None when the robot is back at
        its start heading after half a turn."""
        left = self.dist_left(yaw)
        if self.got_180 and left <= ROTATE_TOLERANCE:
            return None
        rate = math.sqrt(2.0 * ROTATE_ACC_LIM * left)
        return min(max(rate, ROTATE_MIN_VEL), ROTATE_MAX_VEL)


def can_rotate_in_place(costmap: npt.NDArray[np.uint8], cell: tuple[int, int],
                        position: tuple[float, float], footprint: npt.NDArray[np.float64] | None,
                        resolution: float, origin: tuple[float, float]) -> bool:
    """rotate_recovery's check before it turns: the footprint at every heading of the turn
    (``sim_granularity`` 0.017 rad apart) must not touch a lethal or unknown cell
    (``footprintCost`` < 0). A round robot's footprint is its centre cell: lethal, inscribed
    or unknown forbids the turn."""
    if int(costmap[cell]) >= INSCRIBED_INFLATED_OBSTACLE:
        return False
    if footprint is None:
        return True
    yaws = np.arange(0.0, 2.0 * math.pi, ROTATE_GRANULARITY)
    poses = np.column_stack((np.full_like(yaws, position[0]), np.full_like(yaws, position[1]),
                             yaws))
    cost = footprint_cost(costmap, poses, footprint, resolution=resolution, origin=origin)
    return bool(np.all(cost < LETHAL_OBSTACLE))
