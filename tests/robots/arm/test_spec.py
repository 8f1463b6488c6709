"""What ``servolab arm`` finds of an arm in the robot's own files: the OpenMANIPULATOR-X's
controllers file, MoveIt SRDF and joint_limits.yaml; a lab's two-joint arm of a URDF and a
controllers file alone (the rules for what no file says); and the controllers files it
refuses, in one line.

Facts from outside this code: ROBOTIS's MoveIt SRDF of the OpenMANIPULATOR-X
(ROBOTIS-GIT/open_manipulator, open_manipulator_moveit_config/config/open_manipulator_x/
open_manipulator_x.srdf): home (0, -1, 0.7, 0.3), gripper open 0.019 and close -0.01, the
end effector's parent link end_effector_link."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from servolab.robots.arm.spec import (
    DEFAULT_ACCELERATION,
    DEFAULT_JERK,
    GRIPPER_COMMAND,
    arm_spec,
)
from servolab.robots.errors import RobotValueError

from .conftest import DATA, two_joint_folder


def test_the_open_manipulator_x_is_read_from_its_moveit_files() -> None:
    spec = arm_spec("open_manipulator_x")
    assert (spec.controller, spec.joints) == ("arm_controller",
                                              ("joint1", "joint2", "joint3", "joint4"))
    assert spec.spawn == ("joint_state_broadcaster", "arm_controller", "gripper_controller")
    assert (spec.base, spec.tip) == ("link1", "end_effector_link")
    assert spec.home == (0.0, -1.0, 0.7, 0.3)
    assert spec.gripper is not None
    assert (spec.gripper.controller, spec.gripper.action, spec.gripper.joint) == (
        "gripper_controller", GRIPPER_COMMAND, "gripper_left_joint")
    assert (spec.gripper.opened, spec.gripper.closed) == (0.019, -0.01)
    assert spec.velocity == (4.8,) * 4 and spec.acceleration == (5.0,) * 4
    assert spec.jerk == (50.0,) * 4 and spec.velocity_scaling == 0.5
    limits = spec.limits()
    assert limits.velocity == (2.4,) * 4 and spec.limits(1.0).velocity == (4.8,) * 4
    assert "open_manipulator_x.srdf" in spec.origins["tip"]
    assert "open_manipulator_x.srdf" in spec.origins["home"]
    # the chain the IK solves is the controller's joints, base to tool
    chain = spec.chain()
    assert chain.joint_names == spec.joints
    # home as ROBOTIS means it: the tool in front of the arm, level (pitch 0)
    pose = chain.forward(np.array(spec.home))
    assert pose[1, 3] == pytest.approx(0.0, abs=1e-9) and pose[0, 3] > 0.1
    assert chain.pitch(pose) == pytest.approx(0.0, abs=1e-9)


def test_a_lab_arm_of_a_urdf_and_a_controllers_file(two_joint: Path) -> None:
    """No SRDF, no joint_limits file, no gripper: the tip is the link fixed below the last
    joint's child, home every joint at 0, the accelerations and jerks servolab's defaults,
    the speeds the URDF's."""
    spec = arm_spec("two_joint")
    assert (spec.controller, spec.joints) == ("joint_trajectory_controller",
                                              ("joint1", "joint2"))
    assert (spec.base, spec.tip, spec.home) == ("base_link", "tool0", (0.0, 0.0))
    assert spec.velocity == (4.0, 4.0) and spec.lower == (-2.0, -2.0)
    assert spec.acceleration == (DEFAULT_ACCELERATION,) * 2
    assert spec.jerk == (DEFAULT_JERK,) * 2
    assert spec.gripper is None
    assert spec.spawn == ("joint_state_broadcaster", "joint_trajectory_controller")
    assert "no SRDF" in spec.origins["home"] and "servolab's defaults" in spec.origins["limits"]
    # tool0 is 0.1 m out along link2's x, link2 0.1 m above joint1
    assert spec.chain().forward([0.0, 0.0])[:3, 3] == pytest.approx([0.1, 0.0, 0.1])
    assert spec.check_joints([0.5, -0.5], "move") == (0.5, -0.5)
    with pytest.raises(RobotValueError, match=r"^move: joint2 -2.5 rad is outside its limits "
                       r"\[-2, 2\]$"):
        spec.check_joints([0.0, -2.5], "move")
    with pytest.raises(RobotValueError, match=r"2 joint positions \(joint1, joint2\), got 3"):
        spec.check_joints([0.0, 0.0, 0.0], "move")


TWO_TRAJECTORIES = (DATA / "two_joint_controllers.yaml").read_text().replace(
    "    joint_trajectory_controller:\n      type: joint_trajectory_controller/"
    "JointTrajectoryController",
    "    joint_trajectory_controller:\n      type: joint_trajectory_controller/"
    "JointTrajectoryController\n    other_trajectory_controller:\n      type: "
    "joint_trajectory_controller/JointTrajectoryController")
NO_TRAJECTORY = """controller_manager:
  ros__parameters:
    joint_state_broadcaster:
      type: joint_state_broadcaster/JointStateBroadcaster
    forward_position_controller:
      type: position_controllers/JointGroupPositionController

forward_position_controller:
  ros__parameters:
    joints: [joint1, joint2]
"""


@pytest.mark.parametrize(("controllers", "controller", "message"), [
    (TWO_TRAJECTORIES, None, r"^controllers.yaml: 2 trajectory controllers "
     r"\(joint_trajectory_controller, other_trajectory_controller\): name the arm's with "
     r"--controller$"),
    (TWO_TRAJECTORIES, "forward_position_controller", r"no joint_trajectory_controller/"
     r"JointTrajectoryController named 'forward_position_controller'"),
    (NO_TRAJECTORY, None, r"^controllers.yaml: no joint_trajectory_controller/"
     r"JointTrajectoryController: servolab arm moves an arm through one"),
])
def test_a_controllers_file_without_one_arm_controller_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, controllers: str,
        controller: str | None, message: str) -> None:
    two_joint_folder(tmp_path / "robots", controllers)
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    with pytest.raises(RobotValueError, match=message):
        arm_spec("two_joint", controller=controller)


def test_the_one_named_is_taken_among_several(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    two_joint_folder(tmp_path / "robots", TWO_TRAJECTORIES)
    monkeypatch.setenv("SERVOLAB_ROBOT_PATH", str(tmp_path / "robots"))
    spec = arm_spec("two_joint", controller="joint_trajectory_controller")
    assert spec.controller == "joint_trajectory_controller"
    assert spec.action == "/joint_trajectory_controller/follow_joint_trajectory"


def test_a_folder_states_its_arm_in_moveit_files(two_joint: Path) -> None:
    """A robot folder's MoveIt SRDF and joint_limits.yaml, as moveit_setup_assistant writes
    them: the end effector's link is the tool, its home state home; the file's limits and
    scaling factors time the moves (a velocity above the URDF's is held to the URDF's)."""
    (two_joint / "two_joint.srdf").write_text(
        '<robot name="two_joint"><group name="arm"><chain base_link="base_link" '
        'tip_link="tool0"/></group><group_state name="home" group="arm"><joint name="joint1" '
        'value="0.3"/><joint name="joint2" value="-0.4"/></group_state>'
        '<end_effector name="hand" parent_link="link2" group="arm"/></robot>')
    (two_joint / "joint_limits.yaml").write_text(
        "default_velocity_scaling_factor: 0.25\njoint_limits:\n"
        "  joint1: {has_velocity_limits: true, max_velocity: 9.0, has_acceleration_limits: "
        "true, max_acceleration: 3.0, has_jerk_limits: true, max_jerk: 30.0}\n"
        "  joint2: {has_velocity_limits: true, max_velocity: 2.0, has_acceleration_limits: "
        "false, max_acceleration: 1.0}\n")
    spec = arm_spec("two_joint")
    assert (spec.tip, spec.home) == ("link2", (0.3, -0.4))
    assert spec.velocity == (4.0, 2.0) and spec.acceleration == (3.0, DEFAULT_ACCELERATION)
    assert spec.jerk == (30.0, DEFAULT_JERK) and spec.velocity_scaling == 0.25
    assert spec.origins["home"] == "the 'arm' group's home state (two_joint.srdf)"


def test_no_robot_is_the_arm_that_says_it_is_the_default() -> None:
    """``servolab arm`` without --robot: the plug-in whose default_for names ``arm``, found
    here (the library), not in the command."""
    from servolab.robots.registry import default_robot

    assert arm_spec().robot == default_robot("arm") == arm_spec("open_manipulator_x").robot
