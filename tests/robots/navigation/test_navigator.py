"""The navigator node alone, on a hand-made map in virtual time: it drives on a fresh pose,
stops the wheels when the pose gets old (the camera lost the robot), drives on when poses come
back, and gives the goal up after controller_patience without one."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.planning.dwa import DwaConfig
from servolab.robots.navigation.navigator import NavigationStatus, NavigatorNode, Patience
from servolab.robots.navigation.params import load_costmap, load_dwa
from servolab.robots.navigation.run import DEFAULT_COSTMAP, DEFAULT_DWA
from servolab.robots.navigation.tracker_node import LATCHED

POSE = "geometry_msgs/msg/PoseStamped"


class Rig:
    def __init__(self, occupied: tuple[slice, slice] | None = None) -> None:
        self.context = Context.open(clock=VirtualClock())
        dwa = DwaConfig.from_params(load_dwa(DEFAULT_DWA))
        dwa = DwaConfig(**{**dwa.__dict__, "controller_frequency": 5.0})
        self.node = NavigatorNode(self.context, (2.5, 1.0), costmap=load_costmap(
            DEFAULT_COSTMAP), dwa=dwa, patience=Patience(controller=3.0),
            pose_timeout=0.25)
        self.probe = Node(self.context, "probe")
        self.commands: list[Any] = []
        self.probe.create_subscription("geometry_msgs/msg/Twist", "/cmd_vel",
                                       self.commands.append, 0)
        grid = self.probe.create_publisher("nav_msgs/msg/OccupancyGrid", "/map", LATCHED)
        self.pose = self.probe.create_publisher(POSE, "/fused_pose", 10)
        cells = np.zeros((40, 60), dtype=np.int8)
        if occupied is not None:
            cells[occupied] = 100
        grid.publish(self.probe.message("nav_msgs/msg/OccupancyGrid", header={
            "frame_id": "map"}, info={"resolution": 0.05, "width": 60, "height": 40,
                                      "origin": {"orientation": {"w": 1.0}}},
            data=cells.reshape(-1)))

    def send_pose(self, x: float = 0.5, y: float = 1.0) -> None:
        self.pose.publish(self.probe.message(POSE, header={"frame_id": "map"}, pose={
            "position": {"x": x, "y": y}, "orientation": {"w": 1.0}}))

    def drive_for(self, seconds: float, *, poses: bool) -> None:
        end = self.context.clock.now() + seconds
        while self.context.clock.now() < end:
            if poses:
                self.send_pose()
            self.context.spin_for(0.1)


@pytest.fixture
def rig() -> Any:
    r = Rig()
    yield r
    r.context.close()


def test_an_old_pose_stops_the_wheels_until_a_new_one_comes(rig: Rig) -> None:
    rig.drive_for(1.0, poses=True)
    assert rig.node.status is NavigationStatus.ACTIVE
    assert rig.commands[-1].linear.x > 0  # heading for the goal, 2 m ahead
    rig.drive_for(1.0, poses=False)
    assert rig.node.stale_cycles > 0
    last = rig.commands[-1]
    assert (last.linear.x, last.angular.z) == (0.0, 0.0)
    rig.drive_for(1.0, poses=True)
    assert rig.commands[-1].linear.x > 0 and rig.node.status is NavigationStatus.ACTIVE


def test_no_pose_for_controller_patience_gives_the_goal_up(rig: Rig) -> None:
    rig.drive_for(0.6, poses=True)
    rig.drive_for(4.0, poses=False)
    assert rig.node.status is NavigationStatus.ABORTED
    assert "no pose newer than 0.25 s for 3 s" in rig.node.reason
    assert (rig.commands[-1].linear.x, rig.commands[-1].angular.z) == (0.0, 0.0)


def test_a_goal_the_first_map_shows_in_an_obstacle_is_refused_before_moving() -> None:
    rig = Rig(occupied=(slice(17, 23), slice(47, 53)))  # around the goal (2.5, 1.0)
    try:
        rig.drive_for(1.0, poses=True)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED
    assert "goal (2.5, 1) is inside an obstacle" in rig.node.reason
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in rig.commands)
