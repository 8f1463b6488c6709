"""move_base's rotate recovery as servolab runs it (ros-planning/navigation:
rotate_recovery.cpp)."""

from __future__ import annotations

import math

import numpy as np

from servolab.planning.costmap import INSCRIBED_INFLATED_OBSTACLE, LETHAL_OBSTACLE
from servolab.robots.navigation.recovery import (
    ROTATE_MAX_VEL,
    ROTATE_MIN_VEL,
    RotateRecovery,
    can_rotate_in_place,
)


def test_rotate_recovery_turns_once_counter_clockwise_then_stops() -> None:
    """Half a turn, then back to the start heading, at sqrt(2 acc dist_left) within
    [min_in_place_rotational_vel, max_rotational_vel]; the robot's own heading, integrated
    at the controller's 5 Hz, tells it when it is done."""
    start = 2.5
    turn, yaw, period, turned, rates = RotateRecovery(start), start, 0.2, 0.0, []
    for _ in range(200):
        rate = turn.command(math.remainder(yaw, 2 * math.pi))
        if rate is None:
            break
        rates.append(rate)
        yaw += rate * period
        turned += rate * period
    else:
        raise AssertionError("the turn never ended")
    assert all(ROTATE_MIN_VEL <= r <= ROTATE_MAX_VEL for r in rates)
    assert 2 * math.pi - 0.1 <= turned <= 2 * math.pi + 0.3


def test_a_turn_is_refused_where_the_footprint_would_touch_an_obstacle() -> None:
    costmap = np.zeros((40, 60), dtype=np.uint8)
    assert can_rotate_in_place(costmap, (20, 20), (1.025, 1.025), None, 0.05, (0.0, 0.0))
    costmap[20, 20] = INSCRIBED_INFLATED_OBSTACLE
    assert not can_rotate_in_place(costmap, (20, 20), (1.025, 1.025), None, 0.05, (0.0, 0.0))
    costmap[20, 20] = 0
    costmap[20, 26] = LETHAL_OBSTACLE  # 0.3 m to the right: a long robot's corner sweeps it
    rectangle = np.array([[0.35, 0.1], [0.35, -0.1], [-0.35, -0.1], [-0.35, 0.1]])
    assert can_rotate_in_place(costmap, (20, 20), (1.025, 1.025), None, 0.05, (0.0, 0.0))
    assert not can_rotate_in_place(costmap, (20, 20), (1.025, 1.025), rectangle, 0.05,
                                   (0.0, 0.0))
