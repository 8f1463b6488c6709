"""joint_trajectory_controller on emulated XM430s: FollowJointTrajectory goals end as
ros2_controllers' (Jazzy, src/joint_trajectory_controller.cpp ``update`` and the goal
callbacks) end them; its interpolation (checked alone in tests/test_trajectories.py) is what
reaches the motors."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline

from servolab.middleware.node import Node
from servolab.rclpy.action import ActionClient
from servolab.rclpy.action.server import STATUS_ABORTED, STATUS_CANCELED, STATUS_SUCCEEDED
from servolab.robots.control.bringup import ControlSystem
from servolab.robots.control.manager import STRICT

from .conftest import bring_up

ACTION = "control_msgs/action/FollowJointTrajectory"


class Rig:
    def __init__(self, system: ControlSystem) -> None:
        self.system = system
        self.probe = Node(system.context, "probe")
        self.client = ActionClient(self.probe, ACTION,
                                   "/joint_trajectory_controller/follow_joint_trajectory")
        self.states: list[Any] = []
        self.probe.create_subscription("control_msgs/msg/JointTrajectoryControllerState",
                                       "/joint_trajectory_controller/controller_state",
                                       self.states.append, 100)

    def goal(self, points: list[tuple[float, list[float], list[float] | None]],
             **tolerances: Any) -> Any:
        return self.probe.message(f"{ACTION}_Goal", trajectory={
            "joint_names": ["joint1", "joint2"],
            "points": [{"positions": p, "velocities": v or [],
                        "time_from_start": {"sec": int(t), "nanosec": round(t % 1 * 1e9)}}
                       for t, p, v in points]}, **tolerances)

    def send(self, goal: Any, seconds: float) -> tuple[Any, Any]:
        sent = self.client.send_goal_async(goal)
        self.system.context.spin_for(0.05)
        handle = sent.result()
        ended = handle.get_result_async() if handle.accepted else None
        self.system.context.spin_for(seconds)
        return handle, ended

    def positions(self) -> list[float]:
        bus = self.system.buses[0]
        return [float(bus.read(i, "present_position")) for i in (1, 2)]


@pytest.fixture
def rig() -> Iterator[Rig]:
    system = bring_up(spawn=("joint_state_broadcaster", "joint_trajectory_controller"),
                      inactive=("forward_position_controller",))
    try:
        yield Rig(system)
    finally:
        system.close()


def test_a_goal_is_followed_to_success(rig: Rig) -> None:
    handle, ended = rig.send(rig.goal([(1.0, [0.6, -0.4], None), (2.0, [0.2, 0.3], None)]), 3.0)
    assert handle.accepted
    result = ended.result()
    assert result.status == STATUS_SUCCEEDED
    assert (result.result.error_code, result.result.error_string) == (
        0, "Goal successfully reached!")
    # constraints.goal 0.05 (the controllers file) is met on the motors themselves
    assert rig.positions() == pytest.approx([0.2, 0.3], abs=0.05)


def test_the_reference_is_the_spline_through_the_points(rig: Rig) -> None:
    """trajectory.cpp interpolate_between_points: positions and velocities -> a cubic
    Hermite spline per segment, starting from the state when the goal arrived."""
    points = [(0.5, [0.3, 0.1], [0.4, 0.0]), (1.5, [0.8, -0.2], [0.0, 0.0])]
    _handle, ended = rig.send(rig.goal(points), 2.5)
    assert ended.result().status == STATUS_SUCCEEDED
    times = np.array([0.5, 1.5])
    spline = CubicHermiteSpline(times, np.array([p for _, p, _ in points]),
                                np.array([v for _, _, v in points]))
    start = None
    checked = 0
    for s in rig.states:
        stamp = s.header.stamp.sec + s.header.stamp.nanosec * 1e-9
        if start is None and any(abs(v) > 1e-9 for v in s.reference.velocities):
            start = stamp - 0.01  # the first update of the trajectory samples at its start
        if start is None:
            continue
        t = stamp - start
        if 0.55 < t < 1.45:
            assert list(s.reference.positions) == pytest.approx(list(spline(t)), abs=2e-3)
            checked += 1
    assert checked > 50


def test_a_path_tolerance_violation_aborts_and_holds(rig: Rig) -> None:
    # 1.5 rad in 0.2 s is 7.5 rad/s: an XM430-W350 turns 4.8 rad/s at most (46 rpm)
    goal = rig.goal([(0.2, [1.5, 0.0], None), (1.0, [1.5, 0.0], None)],
                    path_tolerance=[{"name": "joint1", "position": 0.1}])
    _handle, ended = rig.send(goal, 1.0)
    result = ended.result()
    assert result.status == STATUS_ABORTED
    assert (result.result.error_code, result.result.error_string) == (
        -4, "Aborted due to path tolerance violation")  # PATH_TOLERANCE_VIOLATED
    held = rig.positions()
    assert held[0] < 1.4  # stopped short of the goal, where it was when it aborted
    rig.system.context.spin_for(0.5)
    assert rig.positions() == pytest.approx(held, abs=0.02)


def test_a_goal_missing_its_tolerance_after_goal_time_aborts(rig: Rig) -> None:
    # a position servo settles within a tick or two (0.0015 rad), never within 1e-6 rad
    goal = rig.goal([(0.5, [0.3, 0.0], None)],
                    goal_tolerance=[{"name": "joint1", "position": 1e-6}],
                    goal_time_tolerance={"sec": 0, "nanosec": 200_000_000})
    _handle, ended = rig.send(goal, 1.5)
    result = ended.result()
    assert result.status == STATUS_ABORTED and result.result.error_code == -5
    assert result.result.error_string.startswith(
        "Aborted due to goal_time_tolerance exceeding by 0.2")


def test_a_new_goal_preempts_and_a_cancel_holds(rig: Rig) -> None:
    _first, first_end = rig.send(rig.goal([(3.0, [1.0, 1.0], None)]), 0.5)
    second, second_end = rig.send(rig.goal([(3.0, [-1.0, 0.5], None)]), 0.5)
    result = first_end.result()
    assert result.status == STATUS_ABORTED
    assert (result.result.error_code, result.result.error_string) == (
        -1, "Current goal preempted by new incoming action.")
    second.cancel_goal_async()
    rig.system.context.spin_for(0.3)
    assert second_end.result().status == STATUS_CANCELED
    held = rig.positions()
    rig.system.context.spin_for(0.5)
    assert rig.positions() == pytest.approx(held, abs=0.02)


@pytest.mark.slow
def test_deactivation_aborts_the_goal_and_keeps_the_position_commands(rig: Rig) -> None:
    """ros2_controllers jazzy, joint_trajectory_controller.cpp ``on_deactivate`` (lines
    1255-1308): the active goal is aborted with INVALID_GOAL, "Current goal cancelled during
    deactivate transition."; each position command is set to its own value (kept), not to the
    measured position."""
    _handle, ended = rig.send(rig.goal([(3.0, [1.0, 1.0], None)]), 1.0)
    manager = rig.system.manager
    table = manager.interfaces.commands
    ok, message = manager.switch_controller([], ["joint_trajectory_controller"], STRICT)
    assert ok, message
    kept = [table[f"joint{i}/position"] for i in (1, 2)]
    rig.system.context.spin_for(0.2)
    result = ended.result()
    assert result.status == STATUS_ABORTED
    assert (result.result.error_code, result.result.error_string) == (
        -1, "Current goal cancelled during deactivate transition.")
    assert [table[f"joint{i}/position"] for i in (1, 2)] == kept
    assert 0.0 < kept[0] < 1.0, f"the command {kept[0]} is not a point on the way to 1.0"


def test_goals_it_refuses(rig: Rig) -> None:
    bad = rig.probe.message(f"{ACTION}_Goal", trajectory={
        "joint_names": ["joint1", "elbow"], "points": [
            {"positions": [0.1, 0.1], "time_from_start": {"sec": 1}}]})
    handle, _ = rig.send(bad, 0.1)
    assert not handle.accepted
    manager = rig.system.manager
    assert manager.switch_controller(["forward_position_controller"],
                                     ["joint_trajectory_controller"], STRICT)[0]
    handle, _ = rig.send(rig.goal([(1.0, [0.1, 0.1], None)]), 0.1)
    assert not handle.accepted  # "Can't accept new action goals. Controller is not running."


def test_the_trajectory_topic_moves_the_joints(rig: Rig) -> None:
    publisher = rig.probe.create_publisher("trajectory_msgs/msg/JointTrajectory",
                                           "/joint_trajectory_controller/joint_trajectory", 10)
    publisher.publish(rig.probe.message("trajectory_msgs/msg/JointTrajectory",
                                        joint_names=["joint2", "joint1"], points=[
                                            {"positions": [0.4, -0.5],
                                             "time_from_start": {"sec": 1}}]))
    rig.system.context.spin_for(2.0)
    assert rig.positions() == pytest.approx([-0.5, 0.4], abs=0.02)
