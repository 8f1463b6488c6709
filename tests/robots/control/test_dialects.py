"""Both ros2_control plugins' ways of naming Dynamixels, read unchanged: the community
dynamixel_hardware (per-joint ``id``, ``Profile_Velocity``-style items, its simple-transmission
branch's ``mechanical_reduction``/``mechanical_offset``) and ROBOTIS's
dynamixel_hardware_interface (``<gpio type="dxl">`` motors with ``ID`` and control-table items,
``transmission_to_joint_matrix``), as OpenMANIPULATOR-X's files write them."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from servolab.robots.dynamixel_system import dynamixel_system
from servolab.robots.hardware_info import HardwareInfoError

from .conftest import TWO_JOINT, TWO_JOINT_ROBOTIS, bring_up
from .test_manager import command


def test_robotis_dialect_writes_its_items_and_turns_through_its_matrix() -> None:
    system = bring_up(TWO_JOINT_ROBOTIS, default_model="XM430-W350",
                      spawn=("joint_state_broadcaster", "forward_position_controller"))
    try:
        bus = system.buses[0]
        # the gpio's parameters, written raw at configure (open_manipulator_x's values)
        assert [bus.read(1, r, raw=True) for r in
                ("position_p_gain", "position_i_gain", "profile_velocity",
                 "profile_acceleration", "drive_mode")] == [800, 100, 20, 10, 4]
        command(system, "forward_position_controller", [0.5, -0.3])
        system.context.spin_for(3.0)
        # transmission_to_joint_matrix 1,0,0,-1: joint2 is minus its horn
        assert [float(bus.read(i, "present_position")) for i in (1, 2)] == pytest.approx(
            [0.5, 0.3], abs=0.01)
        states = system.manager.interfaces.states
        assert states["joint2/position"] == pytest.approx(-0.3, abs=0.01)
        # the gpio's own state interfaces in ROBOTIS's units (rad; current raw)
        assert states["dxl2/Present Position"] == pytest.approx(0.3, abs=0.01)
        assert states["dxl1/Present Current"] == int(states["dxl1/Present Current"])
        # its Goal Position is the joints' to write, not exported
        assert "dxl1/Goal Position" not in system.manager.interfaces.commands
    finally:
        system.close()


def test_community_dialect_reduction_and_offset() -> None:
    text = TWO_JOINT.read_text().replace(
        '<param name="id">2</param>',
        '<param name="id">2</param><param name="mechanical_reduction">2.0</param>'
        '<param name="mechanical_offset">0.1</param><param name="Profile_Velocity">30</param>')
    found = dynamixel_system(text, "two_joint.urdf")
    joint2 = found.joint("joint2")
    # dynamixel_hardware simple-transmission: joint = horn / reduction + offset
    assert joint2.to_joint(0.4) == pytest.approx(0.3)
    assert joint2.to_horn(0.3) == pytest.approx(0.4)
    assert joint2.settings == (("profile_velocity", 30),)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda t: t.replace("1,0,0,-1", "1,1,0,-1", 1),
     '<joint name="joint1">: transmission_to_joint_matrix gives it 2 motors; servolab drives '
     "each joint by one motor (one non-zero entry a row)"),
    (lambda t: t.replace("1,0,0,-1", "1,0,0", 1),
     "<hardware>: transmission_to_joint_matrix has 3 elements, expected 4 (2 joints x 2 "
     "transmissions)"),
    (lambda t: t.replace('<param name="Drive Mode">4</param>',
                         '<param name="Drive Mood">4</param>', 1),
     '<gpio name="dxl1"> <param name="Drive Mood">: the XM430-W350 has no drive_mood register'),
    (lambda t: t.replace('<param name="ID">2</param>', '<param name="ID">1</param>'),
     "ID 1 drives joint1 and joint2"),
])
def test_what_servolab_cannot_drive_is_one_line(edit: object, message: str) -> None:
    text = edit(TWO_JOINT_ROBOTIS.read_text())  # type: ignore[operator]
    with pytest.raises(HardwareInfoError, match=re.escape(message)) as raised:
        dynamixel_system(text, "arm.urdf", default_model="XM430-W350")
    assert "\n" not in str(raised.value)


def test_robotis_dialect_without_a_model_says_what_to_add() -> None:
    with pytest.raises(HardwareInfoError, match=re.escape(
            'arm.urdf: <ros2_control name="TwoJoint"> <gpio name="dxl1">: no Dynamixel model; '
            'add <param name="motor_type">XM430-W350</param>')):
        dynamixel_system(TWO_JOINT_ROBOTIS.read_text(), "arm.urdf")


def test_robotis_revolute_to_prismatic_switch_is_refused_not_guessed() -> None:
    """dynamixel_hardware_interface.cpp (lines 150-157) turns a horn into a prismatic gripper
    inside the plugin when ``use_revolute_to_prismatic_gripper`` is a nonzero integer; servolab
    does not read those switches, and with the identity matrix beside them the gripper would be
    driven at 1 m a radian: refused in one line saying what to write instead."""
    text = TWO_JOINT_ROBOTIS.read_text().replace(
        '<param name="error_timeout_ms">500</param>',
        '<param name="error_timeout_ms">500</param>'
        '<param name="use_revolute_to_prismatic_gripper">1</param>')
    with pytest.raises(HardwareInfoError) as refused:
        dynamixel_system(text, "arm.urdf", default_model="XM430-W350")
    message = str(refused.value)
    assert "\n" not in message
    assert "use_revolute_to_prismatic_gripper is not read by servolab" in message
    assert "transmission_to_joint_matrix" in message


@pytest.mark.parametrize(("param", "said"), [
    ('<param name="mimic">elbow</param>', "mimic 'elbow' is not a joint of the block"),
    ('<param name="mimic">joint1</param><param name="multiplier">abc</param>',
     "multiplier 'abc' is not a number")])
def test_a_mimic_joint_naming_nothing_or_no_number_is_refused(param: str, said: str,
                                                              tmp_path: Path) -> None:
    """A ``mimic`` joint (dynamixel_hardware_interface's) follows a joint of the block by a
    multiplier: one naming no such joint, or a multiplier that is no number, is refused in one
    line naming the joint, not left NaN for ever or raised as a bare ValueError."""
    text = TWO_JOINT_ROBOTIS.read_text()
    text = text.replace('<link name="link2">', '<link name="link3"/><link name="link2">')
    text = text.replace('  <ros2_control name="TwoJoint"',
                        '  <joint name="finger" type="revolute"><parent link="link2"/>'
                        '<child link="link3"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" '
                        'effort="1" velocity="1"/></joint>\n  <ros2_control name="TwoJoint"')
    text = text.replace('    <gpio name="dxl1">',
                        f'    <joint name="finger">{param}'
                        '<state_interface name="position"/></joint>\n    <gpio name="dxl1">')
    robotis = tmp_path / "arm.urdf"
    robotis.write_text(text)
    with pytest.raises(HardwareInfoError) as refused:
        bring_up(robotis, default_model="XM430-W350").close()
    message = str(refused.value)
    assert "\n" not in message and said in message and 'joint name="finger"' in message
