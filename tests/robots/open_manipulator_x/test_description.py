"""The OpenMANIPULATOR-X's URDF and controllers file hold the figures they cite.

Sources, as the URDF names them (ROBOTIS-GIT/open_manipulator, branch jazzy, 2025-12-15):
ARM = open_manipulator_description/urdf/open_manipulator_x/open_manipulator_x_arm.urdf.xacro;
R2C = open_manipulator_description/ros2_control/open_manipulator_x_position.ros2_control.xacro
(R2C@6a61bcc^: the same before commit 6a61bcc); XM430 = the XM430-W350 e-Manual
(emanual.robotis.com/docs/en/dxl/x/xm430-w350/, "Specifications"); SPEC = the
OpenMANIPULATOR-X e-Manual, "Hardware Specification".
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import pytest

from servolab.dynamixel.models import model
from servolab.middleware.parameters import ParameterOverrides
from servolab.robots.description import Box, Description
from servolab.robots.hardware_info import parse_control_resources
from servolab.robots.open_manipulator_x import CONTROLLERS, MODEL, URDF, system, urdf_text
from servolab.robots.robot_folder import check_controllers

from .conftest import ARM, GRIPPER_SCALE, IDS

#: (joint, type, parent, child, origin xyz, axis, lower, upper) from ARM, lines 38-45,
#: 74-81, 110-117, 146-153, 182-189 and 218-226
JOINTS = [
    ("joint1", "revolute", "link1", "link2", (0.012, 0, 0), (0, 0, 1), -math.pi, math.pi),
    ("joint2", "revolute", "link2", "link3", (0, 0, 0.0595), (0, 1, 0), -1.5, 1.5),
    ("joint3", "revolute", "link3", "link4", (0.024, 0, 0.128), (0, 1, 0), -1.5, 1.4),
    ("joint4", "revolute", "link4", "link5", (0.124, 0, 0), (0, 1, 0), -1.7, 1.97),
    ("gripper_left_joint", "prismatic", "link5", "gripper_left_link", (0.0817, 0.021, 0),
     (0, 1, 0), -0.011, 0.02),
    ("gripper_right_joint", "prismatic", "link5", "gripper_right_link", (0.0817, -0.021, 0),
     (0, -1, 0), -0.011, 0.02),
]
#: (link, mass kg, centre of mass) from ARM's <inertial>s (lines 29-35, 65-71, 101-107,
#: 137-143, 173-179, 209-215, 246-252; link2's z is ARM's 0.018 + 2.9433464e-02)
LINKS = [
    ("link1", 7.9119962e-02, (3.0876154e-04, 0.0, -1.2176461e-04)),
    ("link2", 9.8406837e-02, (-3.0184870e-04, 5.4043684e-04, 0.018 + 2.9433464e-02)),
    ("link3", 1.3850917e-01, (1.0308393e-02, 3.7743363e-04, 1.0170197e-01)),
    ("link4", 1.3274562e-01, (9.0909590e-02, 3.8929816e-04, 2.2413279e-04)),
    ("link5", 1.4327573e-01, (4.4206755e-02, 3.6839985e-07, 8.9142216e-03)),
    ("gripper_left_link", 1.0e-03, (0.0, 0.0, 0.0)),
    ("gripper_right_link", 1.0e-03, (0.0, 0.0, 0.0)),
]
#: the control-table items R2C writes to each motor at start: the arm's four (lines 75-138)
ARM_SETTINGS = {"type": "dxl", "Operating Mode": "3", "Position P Gain": "800",
                "Position I Gain": "100", "Position D Gain": "100", "Profile Velocity": "20",
                "Profile Acceleration": "10", "Drive Mode": "4", "Return Delay Time": "0"}
#: and the gripper's (lines 139-151; Drive Mode 5 since commit 661e0da)
GRIPPER_SETTINGS = {"type": "dxl", "Operating Mode": "5", "Profile Velocity": "20",
                    "Profile Acceleration": "10", "Drive Mode": "5", "Return Delay Time": "0",
                    "Goal Current": "200"}


@pytest.fixture(scope="module")
def description() -> Description:
    return Description.from_urdf(urdf_text(), URDF.name)


def test_the_joints_are_robotis_own(description: Description) -> None:
    for name, kind, parent, child, origin, axis, lower, upper in JOINTS:
        joint = description.joint(name)
        assert (joint.kind, joint.parent, joint.child) == (kind, parent, child), name
        assert joint.origin == pytest.approx(origin) and joint.axis == pytest.approx(axis), name
        assert (joint.lower, joint.upper) == pytest.approx((lower, upper)), name
    mimic = description.joint("gripper_right_joint").mimic
    assert mimic is not None and (mimic.joint, mimic.multiplier, mimic.offset) == (
        "gripper_left_joint", 1.0, 0.0)                        # ARM line 225
    assert description.joint("end_effector_joint").origin == pytest.approx((0.126, 0, 0))
    assert description.root == "world"                          # TOP lines 16-22


def test_the_masses_are_robotis_own_and_hold_five_servos(description: Description) -> None:
    for name, mass, com in LINKS:
        inertial = description.link(name).inertial
        assert inertial.mass == pytest.approx(mass, rel=1e-7), name
        assert inertial.com == pytest.approx(com, abs=1e-9), name
    total = sum(description.link(name).inertial.mass for name, _, _ in LINKS)
    # five XM430-W350 of 82 g each (XM430, "Weight") are inside; the whole arm weighs 0.70 kg
    # (SPEC, "Weight"), its base plate and cables included, which ARM leaves out
    assert 5 * 0.082 < total < 0.70


def test_the_limits_are_the_servos(description: Description) -> None:
    """A joint's effort is the XM430-W350's stall torque at 12.0 V (XM430: 4.1 N m), which
    servolab's model table holds too; its speed ARM's 4.8 rad/s, the XM430's 46 rpm no-load
    speed at 12.0 V. The gripper's are the same through its 0.01149 m/rad transmission."""
    xm430 = model(MODEL)
    assert xm430.stall_torque_nm == 4.1
    assert 46 * 2 * math.pi / 60 == pytest.approx(4.8, abs=0.02)
    for name in ARM:
        joint = description.joint(name)
        assert (joint.effort, joint.velocity) == (4.1, 4.8), name
    for name in ("gripper_left_joint", "gripper_right_joint"):
        joint = description.joint(name)
        assert joint.effort == pytest.approx(4.1 / GRIPPER_SCALE, abs=0.05)
        assert joint.velocity == pytest.approx(4.8 * GRIPPER_SCALE, abs=5e-5)


def test_the_fingers_open_about_as_far_as_robotis_says(description: Description) -> None:
    """The fingers' boxes are a guess (the STL meshes are not shipped); over the joint's limits
    open 16 to 78 mm, SPEC's gripper stroke being 20 to 75 mm (ARM's limits give each finger
    31 mm of travel, 62 mm between them; the stroke is 55 mm)."""
    left = description.link("gripper_left_link")
    (finger,) = [s for s in left.shapes if s.contact == "all"]
    assert isinstance(finger, Box)
    thickness = finger.size[1]
    joint = description.joint("gripper_left_joint")
    assert joint.lower is not None and joint.upper is not None

    def opening(q: float) -> float:
        return 2 * (joint.origin[1] + q - thickness / 2)

    assert opening(joint.lower) == pytest.approx(0.016, abs=1e-9)
    assert opening(joint.upper) == pytest.approx(0.078, abs=1e-9)


def test_the_block_is_robotis_real_arm() -> None:
    (block,) = parse_control_resources(urdf_text(), URDF.name)
    assert (block.name, block.type, block.plugin) == (
        "OpenManipulatorXSystem", "system", "dynamixel_hardware_interface/DynamixelHardware")
    hardware = block.hardware_parameters
    assert (hardware["port_name"], hardware["baud_rate"]) == ("/dev/ttyUSB0", "1000000")
    assert (hardware["number_of_joints"], hardware["number_of_transmissions"]) == ("5", "5")
    assert [j.name for j in block.joints] == list(IDS)            # R2C lines 35-64
    for joint in block.joints:
        assert [i.name for i in joint.command_interfaces] == ["position"]
        assert [i.name for i in joint.state_interfaces] == ["position", "velocity", "effort"]
    assert [(g.name, g.parameters["ID"]) for g in block.gpios] == [
        (f"dxl{k}", str(motor_id)) for k, motor_id in enumerate(IDS.values(), start=1)]
    for gpio in block.gpios:
        settings = dict(gpio.parameters)
        del settings["ID"]
        assert settings == (GRIPPER_SETTINGS if gpio.name == "dxl5" else ARM_SETTINGS)
        assert [i.name for i in gpio.command_interfaces] == ["Goal Position"]
        assert [i.name for i in gpio.state_interfaces] == [
            "Present Position", "Present Velocity", "Present Current"]


def test_the_gripper_transmission_is_robotis_unit() -> None:
    """Identity on the arm (R2C@6a61bcc^ lines 26-39); the gripper's entry is R2C's "[unit
    info]" (0.000017626621790 m a tick, lines 152-157) over the XM430's 4096 ticks a turn, and
    the two matrices are each other's inverse."""
    (block,) = parse_control_resources(urdf_text(), URDF.name)

    def matrix(name: str) -> list[list[float]]:
        values = [float(v) for v in block.hardware_parameters[name].split(",")]
        return [values[row * 5:row * 5 + 5] for row in range(5)]

    to_joint = matrix("transmission_to_joint_matrix")
    to_motor = matrix("joint_to_transmission_matrix")
    for row in range(5):
        for column in range(5):
            expected = (GRIPPER_SCALE if row == 4 else 1.0) if row == column else 0.0
            assert to_joint[row][column] == pytest.approx(expected, abs=1e-8)
            assert to_motor[row][column] == pytest.approx(
                1.0 / expected if expected else 0.0, rel=1e-6)
    assert model(MODEL).rad_per_tick == pytest.approx(2 * math.pi / 4096)
    # the offset [unit info] gives, -0.036099321 m at tick 0, is 0 at the centre tick 2048
    centre = 2048 * 1.7626621790e-5
    assert centre == pytest.approx(0.036099321, abs=1e-9)


def test_the_urdf_is_the_file_a_ros_machine_takes() -> None:
    """One file, one robot: the <ros2_control> block, no servolab-only parameter in it (a
    "model" parameter on a gpio would stop ROBOTIS's plugin: it writes every gpio parameter
    it does not know as a control-table item)."""
    root = ET.fromstring(urdf_text())
    assert root.get("name") == "open_manipulator_x"
    names = {p.get("name") for p in root.iter("param")}
    assert not names & {"model", "motor_type"}


def test_servolab_reads_the_block_as_robotis_plugin_does() -> None:
    found = system()
    assert (found.protocol, found.baudrate, found.port_name) == (2, 1_000_000, "/dev/ttyUSB0")
    assert [(j.name, j.id, j.model.name) for j in found.joints] == [
        (name, motor_id, MODEL) for name, motor_id in IDS.items()]
    gripper = found.joint("gripper_left_joint")
    assert gripper.scale == pytest.approx(GRIPPER_SCALE, abs=1e-8) and gripper.offset == 0.0
    assert (gripper.lower, gripper.upper) == (-0.011, 0.02)
    assert dict(gripper.settings) == {
        "operating_mode": 5, "profile_velocity": 20, "profile_acceleration": 10,
        "drive_mode": 5, "return_delay_time": 0, "goal_current": 200}
    assert all(found.joint(name).scale == 1.0 for name in ARM)


def test_the_controllers_are_robotis() -> None:
    """ROBOTIS's hardware_controller_manager.yaml (jazzy, lines 1-38) with the humble file's
    constraints (lines 38-40) and a 0.02 rad goal tolerance (a guess, said in the file)."""
    overrides = ParameterOverrides.from_file(CONTROLLERS)
    manager = overrides.for_node("/controller_manager")
    assert manager["update_rate"] == 100
    assert {k: v for k, v in manager.items() if k.endswith(".type")} == {
        "joint_state_broadcaster.type": "joint_state_broadcaster/JointStateBroadcaster",
        "arm_controller.type": "joint_trajectory_controller/JointTrajectoryController",
        "gripper_controller.type": "position_controllers/GripperActionController"}
    arm = overrides.for_node("/arm_controller")
    assert arm["joints"] == list(ARM)
    assert (arm["command_interfaces"], arm["state_interfaces"]) == (["position"],
                                                                    ["position", "velocity"])
    assert arm["allow_partial_joints_goal"] is True
    assert (arm["constraints.stopped_velocity_tolerance"], arm["constraints.goal_time"]) == (
        0.01, 0.0)
    assert [arm[f"constraints.{j}.goal"] for j in ARM] == [0.02] * 4
    assert overrides.for_node("/gripper_controller") == {"joint": "gripper_left_joint"}
    check_controllers(CONTROLLERS, {j.get("name", "") for j in
                                    ET.fromstring(urdf_text()).findall("joint")})
