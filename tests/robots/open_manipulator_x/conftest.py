"""The OpenMANIPULATOR-X under ros2_control in this process: its shipped URDF and controllers file
brought up on emulated motors (or in MuJoCo) whose time the tests step, and an action client.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides
from servolab.rclpy.action import ActionClient
from servolab.robots.control.bringup import BringUpOptions, ControlSystem
from servolab.robots.open_manipulator_x import CONTROLLERS, MODEL, URDF, urdf_text

ARM = ("joint1", "joint2", "joint3", "joint4")
IDS = {"joint1": 11, "joint2": 12, "joint3": 13, "joint4": 14, "gripper_left_joint": 15}
TRAJECTORY = "control_msgs/action/FollowJointTrajectory"
GRIPPER = "control_msgs/action/GripperCommand"
#: the gripper's metres a radian of horn (the block's transmission matrix)
GRIPPER_SCALE = 1.7626621790e-5 * 4096 / (2 * math.pi)


def bring_up(world: str = "emulated") -> ControlSystem:
    """The arm with its three controllers active, in ``world`` (emulated, mujoco, or robot:
    its own table)."""
    from servolab.robots.open_manipulator_x.world import on_table

    return ControlSystem(urdf_text(), URDF.name, ParameterOverrides.from_file(CONTROLLERS),
                         BringUpOptions(spawn=("joint_state_broadcaster", "arm_controller",
                                               "gripper_controller"),
                                        real_time=False, world=world, default_model=MODEL,
                                        place=on_table if world == "robot" else None))


class Arm:
    """An action client for each controller, and the motors' registers, of a brought-up arm."""

    def __init__(self, system: ControlSystem) -> None:
        self.system = system
        self.node = Node(system.context, "probe")
        self.trajectory = ActionClient(self.node, TRAJECTORY,
                                       "/arm_controller/follow_joint_trajectory")
        self.gripper = ActionClient(self.node, GRIPPER, "/gripper_controller/gripper_cmd")

    def send(self, client: ActionClient, goal: Any, seconds: float) -> Any:
        """The goal's result after ``seconds`` of the robot's time (it must have ended)."""
        sent = client.send_goal_async(goal)
        self.system.context.spin_for(0.05)
        handle = sent.result()
        assert handle.accepted
        ended = handle.get_result_async()
        self.system.context.spin_for(seconds)
        assert ended.done(), f"the goal has not ended after {seconds} s"
        return ended.result()

    def follow(self, points: Sequence[tuple[float, Sequence[float]]], seconds: float) -> Any:
        """A FollowJointTrajectory goal through ``points`` (time from start s, joint1..joint4
        rad), as MoveIt sends one."""
        goal = self.node.message(f"{TRAJECTORY}_Goal", trajectory={
            "joint_names": list(ARM),
            "points": [{"positions": list(p), "time_from_start": {
                "sec": int(t), "nanosec": round(t % 1 * 1e9)}} for t, p in points]})
        return self.send(self.trajectory, goal, seconds)

    def grip(self, position: float, seconds: float) -> Any:
        """A GripperCommand goal: the left finger to ``position`` (m, positive opens)."""
        goal = self.node.message(f"{GRIPPER}_Goal",
                                 command={"position": position, "max_effort": 0.0})
        return self.send(self.gripper, goal, seconds)

    def horn(self, joint: str) -> float:
        """The joint's motor's Present Position (rad, as its firmware counts it)."""
        return float(self.system.buses[0].read(IDS[joint], "present_position"))

    def current(self, joint: str) -> int:
        """The joint's motor's Present Current, raw (2.69 mA a unit)."""
        return int(self.system.buses[0].read(IDS[joint], "present_current", raw=True))

    def state(self, joint: str, interface: str = "position") -> float:
        """What the hardware gives the controllers (rad or m; N m or N)."""
        return float(self.system.manager.interfaces.states[f"{joint}/{interface}"])
