"""DWA's dry run (servolab.planning.approach): the real controller on a fixed map with ideal
wheels, used to refuse, before driving, goals DWA would not settle on (issue 30)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from servolab.planning.approach import dry_run, start_on_plan
from servolab.planning.costmap import inflate, traversal_costs
from servolab.planning.dstar_lite import DStarLite
from servolab.planning.errors import PlanningValueError
from tests.planning.test_dwa import D3 as D3_AT_20_HZ

RES = 0.05
#: seed 000's D.3 at turtlebot's 5 Hz controller (move_base_params.yaml)
D3 = dataclasses.replace(D3_AT_20_HZ, controller_frequency=5.0)


def wall_scene(goal_x: float) -> tuple[np.ndarray, np.ndarray]:
    """A 3 x 2 m room with a wall from x = 2.85 m; D.2's inflation (0.4 m, 12.0, 0.21 m)."""
    occupied = np.zeros((40, 60), dtype=bool)
    occupied[:, 57:] = True
    costmap = inflate(occupied, RES, 0.40, 12.0, 0.21)
    cells = DStarLite(traversal_costs(costmap), (20, 10), (20, math.floor(goal_x / RES))).path()
    return costmap, (cells[:, ::-1] + 0.5) * RES


def test_a_goal_deep_in_the_inflated_band_stalls_and_a_lighter_occdist_reaches_it() -> None:
    """0.275 m from the wall (cost 81): with D.3's occdist_scale 0.8 the obstacle term
    outweighs goal_distance_bias and DWA stops beyond xy_goal_tolerance; with turtlebot3's
    occdist_scale 0.02 (turtlebot3_navigation dwa_local_planner_params) it arrives."""
    costmap, plan = wall_scene(2.575)
    stalled = dry_run(costmap, plan, D3, resolution=RES, start=(0.5, 1.0, 0.0))
    assert stalled.status == "stalled" and not stalled.reached
    assert D3.xy_goal_tolerance < stalled.distance < 0.3
    light = dataclasses.replace(D3, occdist_scale=0.02)
    arrived = dry_run(costmap, plan, light, resolution=RES, start=(0.5, 1.0, 0.0))
    assert arrived.reached and arrived.distance <= D3.xy_goal_tolerance


def test_a_goal_outside_the_band_is_reached_with_its_heading() -> None:
    costmap, plan = wall_scene(2.0)
    result = dry_run(costmap, plan, D3, resolution=RES, start=(0.5, 1.0, 0.0),
                     goal_yaw=math.pi / 2)
    assert result.reached and result.distance <= D3.xy_goal_tolerance
    assert abs(math.remainder(result.pose[2] - math.pi / 2, 2 * math.pi)) \
        <= D3.yaw_goal_tolerance
    # about 1.5 m at up to 0.15 m/s, then a quarter turn
    assert 10.0 < result.seconds < 25.0


def test_the_start_on_the_plan_and_bad_arguments() -> None:
    plan = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0]])
    x, y, yaw = start_on_plan(plan, 1.0)
    assert (x, y) == (2.0, 0.0) and yaw == pytest.approx(math.pi / 2)
    assert start_on_plan(plan, 10.0)[:2] == (0.0, 0.0)
    costmap, line = wall_scene(2.0)
    with pytest.raises(PlanningValueError, match="stall_time must be > 0"):
        dry_run(costmap, line, D3, resolution=RES, stall_time=0.0)
    with pytest.raises(PlanningValueError, match="plan must be"):
        dry_run(costmap, np.zeros((0, 2)), D3, resolution=RES)
