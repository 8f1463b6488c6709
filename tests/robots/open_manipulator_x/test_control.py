"""The OpenMANIPULATOR-X under ros2_control on emulated motors, as ROBOTIS's bringup runs it: the
three controllers of its file active, a FollowJointTrajectory goal moving joint1 to joint4 and a
GripperCommand goal opening and closing the gripper (in metres, through the gripper's
transmission: 0.01149077 m a radian of horn)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from servolab.rclpy.action.server import STATUS_SUCCEEDED

from .conftest import ARM, GRIPPER_SCALE, Arm, bring_up

XM430_TICK = 0.0015339807878856412   # 2 pi / 4096 rad (XM430 e-Manual, 0.088 degree)


@pytest.fixture(scope="module")
def arm() -> Iterator[Arm]:
    system = bring_up()
    try:
        yield Arm(system)
    finally:
        system.close()


def test_its_three_controllers_are_active(arm: Arm) -> None:
    controllers = arm.system.manager.controllers
    assert {name: c.label for name, c in controllers.items()} == {
        "joint_state_broadcaster": "active", "arm_controller": "active",
        "gripper_controller": "active"}
    # the block's settings are in the motors: the arm's position gains, the gripper in
    # current-based position mode, its current capped at Goal Current 200
    bus = arm.system.buses[0]
    assert [int(bus.read(i, "position_p_gain", raw=True)) for i in range(11, 15)] == [800] * 4
    assert (int(bus.read(15, "operating_mode")), int(bus.read(15, "goal_current", raw=True)),
            int(bus.read(15, "drive_mode"))) == (5, 200, 5)


@pytest.mark.slow
def test_a_trajectory_goal_moves_the_arm(arm: Arm) -> None:
    goal = (0.5, -0.6, 0.4, 0.6)
    result = arm.follow([(1.0, (0.2, -0.3, 0.2, 0.3)), (2.0, goal)], 3.0)
    assert result.status == STATUS_SUCCEEDED
    assert (result.result.error_code, result.result.error_string) == (
        0, "Goal successfully reached!")
    # within the file's goal tolerance (0.02 rad) on the motors themselves
    assert [arm.horn(j) for j in ARM] == pytest.approx(goal, abs=0.02)
    assert [arm.state(j) for j in ARM] == pytest.approx(goal, abs=0.02)


@pytest.mark.slow
def test_a_gripper_goal_opens_and_closes_it(arm: Arm) -> None:
    for position in (0.015, -0.008):    # open, then nearly shut (m)
        result = arm.grip(position, 2.0)
        assert result.status == STATUS_SUCCEEDED and result.result.reached_goal
        assert not result.result.stalled
        # ended within goal_tolerance (the controller's default, 0.01 m); the motor then
        # goes on to the goal itself, to the tick
        assert arm.state("gripper_left_joint") == pytest.approx(position, abs=1e-4)
        assert arm.horn("gripper_left_joint") == pytest.approx(position / GRIPPER_SCALE,
                                                               abs=2 * XM430_TICK)
