"""The generic robot description (robots/description.py): a URDF read into it, written back
out as URDF and MJCF.

Facts and oracles, none of them servolab's:

- the URDF as ROS's own reader, ``urdf-parser-py``, reads it (joint types, limits, axes,
  origins, ``<mimic joint multiplier offset>``; wiki.ros.org/urdf/XML/joint: a continuous
  joint has no position limits, a revolute and a prismatic one need ``<limit>``);
- the MJCF as MuJoCo compiles it (its bodies' poses at given joint positions against the
  URDF's forward kinematics from urdf-parser-py, tests/robots/urdf_oracle.py; a mimic joint
  as a joint equality whose ``polycoef`` is offset, multiplier: MuJoCo's XML reference,
  equality/joint);
- ros_control's SimpleTransmission: actuator position = mechanicalReduction x joint
  position, so a rack and pinion of radius r reduces by 1 / r radians a metre.
"""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from urdf_parser_py.urdf import URDF

from servolab.robots.description import SPECK_KG, Description, Mimic, Motor, mjcf, urdf
from servolab.robots.errors import RobotValueError
from tests.robots.urdf_oracle import urdf_fk

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <material name="blue"><color rgba="0 0 0.8 1"/></material>
  <link name="base_link">
    <inertial><origin xyz="0 0 0.02"/><mass value="0.5"/>
      <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0 0 0.02"/><geometry><box size="0.06 0.06 0.04"/></geometry>
      <material name="blue"/></visual>
  </link>
  <link name="carriage">
    <inertial><origin xyz="0.05 0 0" rpy="0 0 0.4"/><mass value="0.2"/>
      <inertia ixx="0.0001" iyy="0.0004" izz="0.0004" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><origin xyz="0.05 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.015" length="0.1"/></geometry></visual>
    <collision><origin xyz="0.05 0 0" rpy="0 1.5707963 0"/>
      <geometry><cylinder radius="0.015" length="0.1"/></geometry></collision>
  </link>
  <link name="wrist">
    <inertial><mass value="0.05"/>
      <inertia ixx="0.00001" iyy="0.00001" izz="0.00001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><sphere radius="0.02"/></geometry></visual>
  </link>
  <link name="left_finger">
    <inertial><mass value="0.01"/>
      <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://arm/meshes/finger.stl"/></geometry></visual>
  </link>
  <link name="right_finger">
    <inertial><mass value="0.01"/>
      <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <link name="camera"/>
  <joint name="lift" type="prismatic">
    <parent link="base_link"/><child link="carriage"/>
    <origin xyz="0.05 0 0.1" rpy="0 0 0.3"/>
    <axis xyz="0 0 1"/>
    <limit lower="0" upper="0.2" effort="50" velocity="0.1"/>
    <dynamics damping="0.5" friction="0.1"/>
  </joint>
  <joint name="wrist_roll" type="continuous">
    <parent link="carriage"/><child link="wrist"/>
    <origin xyz="0.1 0 0" rpy="0.2 -0.4 0"/>
    <axis xyz="1 0 1"/>
  </joint>
  <joint name="left_finger_joint" type="revolute">
    <parent link="wrist"/><child link="left_finger"/>
    <origin xyz="0.03 0.02 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-0.5" upper="0.8" effort="2" velocity="3"/>
  </joint>
  <joint name="right_finger_joint" type="revolute">
    <parent link="wrist"/><child link="right_finger"/>
    <origin xyz="0.03 -0.02 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-0.8" upper="0.5" effort="2" velocity="3"/>
    <mimic joint="left_finger_joint" multiplier="-1.5" offset="0.1"/>
  </joint>
  <joint name="camera_mount" type="fixed">
    <parent link="carriage"/><child link="camera"/>
    <origin xyz="0 0 0.04" rpy="0 0.5 0"/>
  </joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type>
    <joint name="lift"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="m1"><mechanicalReduction>1</mechanicalReduction></actuator>
  </transmission>
  <gazebo reference="carriage"><material>Gazebo/Blue</material></gazebo>
  <ros2_control name="arm" type="system">
    <hardware><plugin>dynamixel_hardware/DynamixelHardware</plugin></hardware>
    <joint name="lift"><param name="id">1</param></joint>
  </ros2_control>
</robot>
"""
MOVABLE = ("lift", "wrist_roll", "left_finger_joint", "right_finger_joint")


@pytest.fixture(scope="module")
def described() -> Description:
    return Description.from_urdf(ARM, source="arm.urdf")


def test_a_urdf_is_read_with_every_joint_kind_its_limits_and_its_mimic(
        described: Description) -> None:
    d = described
    assert (d.name, d.root) == ("arm", "base_link")
    kinds = {j.name: j.kind for j in d.joints}
    assert kinds == {"lift": "prismatic", "wrist_roll": "continuous",
                     "left_finger_joint": "revolute", "right_finger_joint": "revolute",
                     "camera_mount": "fixed"}
    lift = d.joint("lift")
    assert (lift.parent, lift.child, lift.lower, lift.upper) == ("base_link", "carriage",
                                                                 0.0, 0.2)
    assert (lift.effort, lift.velocity, lift.damping, lift.friction) == (50, 0.1, 0.5, 0.1)
    wrist = d.joint("wrist_roll")
    assert wrist.lower is None and wrist.upper is None      # continuous: unbounded
    assert d.joint("right_finger_joint").mimic == Mimic("left_finger_joint", -1.5, 0.1)
    assert d.joint("left_finger_joint").mimic is None
    # the inertial as given, its rotated frame turned into the link's axes
    carriage = d.link("carriage").inertial
    assert carriage.mass == 0.2
    expected = Rotation.from_euler("xyz", [0, 0, 0.4]).as_matrix() @ np.diag(
        [0.0001, 0.0004, 0.0004]) @ Rotation.from_euler("xyz", [0, 0, 0.4]).as_matrix().T
    np.testing.assert_allclose(np.array(carriage.inertia), expected, atol=1e-15)
    assert d.link("camera").inertial.mass == 0.0
    assert d.materials == {"blue": (0.0, 0.0, 0.8, 1.0)}
    # a collision that repeats a visual makes that visual solid, not a second shape
    (cylinder,) = d.link("carriage").shapes
    assert cylinder.contact == "all" and cylinder.visual
    assert not any(j.motor for j in d.joints)   # <transmission>/<ros2_control>: not read here


def test_the_written_urdf_reads_the_same_in_urdf_parser_py_and_here(
        described: Description) -> None:
    text = urdf(described)
    robot = URDF.from_xml_string(text)
    original = URDF.from_xml_string(ARM)
    for joint in original.joints:
        written = robot.joint_map[joint.name]
        assert written.type == joint.type
        assert (written.parent, written.child) == (joint.parent, joint.child)
        np.testing.assert_allclose(written.origin.xyz, joint.origin.xyz)
        np.testing.assert_allclose(written.origin.rpy,
                                   joint.origin.rpy if joint.origin.rpy else [0, 0, 0])
        if joint.type != "fixed":
            np.testing.assert_allclose(written.axis, joint.axis)
        if joint.limit is not None and joint.type != "continuous":
            assert (written.limit.lower, written.limit.upper) == (joint.limit.lower,
                                                                   joint.limit.upper)
        if joint.mimic is not None:
            assert (written.mimic.joint, written.mimic.multiplier, written.mimic.offset) == (
                joint.mimic.joint, joint.mimic.multiplier, joint.mimic.offset)
    for link in original.links:
        if link.inertial is not None:
            assert robot.link_map[link.name].inertial.mass == link.inertial.mass
    assert Description.from_urdf(text).joints == described.joints
    assert described.urdf() == text


def test_motors_write_transmissions_whose_reduction_is_direction_times_gear_ratio(
        described: Description) -> None:
    pinion = 0.012     # m: 1 / r radians of horn a metre of lift
    d = described.with_motors({"lift": Motor(1, "XM430-W350", direction=-1,
                                             gear_ratio=1 / pinion),
                               "left_finger_joint": Motor(2, "XM430-W350", name="finger")})
    robot = URDF.from_xml_string(urdf(d))
    reductions = {t.joints[0].name: (t.actuators[0].name,
                                     float(t.actuators[0].mechanicalReduction))
                  for t in robot.transmissions}
    assert reductions == {"lift": ("m1", pytest.approx(-1 / pinion)),
                          "left_finger_joint": ("finger", 1.0)}
    model = mujoco.MjModel.from_xml_string(mjcf(d))
    assert model.actuator("m1").gear[0] == pytest.approx(-1 / pinion)
    # the control is the horn's angle: the lift's range through the pinion
    np.testing.assert_allclose(model.actuator("m1").ctrlrange, [-0.2 / pinion, 0.0])
    with pytest.raises(RobotValueError, match="camera_mount' is fixed"):
        described.with_motors({"camera_mount": Motor(3)})
    with pytest.raises(RobotValueError, match="a mimic"):
        described.with_motors({"right_finger_joint": Motor(3)})


def test_the_mjcf_has_no_floor_and_a_fixed_base_unless_asked(described: Description) -> None:
    model = mujoco.MjModel.from_xml_string(mjcf(described))
    assert model.njnt == 4 and model.nq == 4                     # no free joint
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor") == -1
    types = {model.joint(n).name: int(model.joint(n).type[0]) for n in MOVABLE}
    assert types["lift"] == mujoco.mjtJoint.mjJNT_SLIDE
    assert types["wrist_roll"] == mujoco.mjtJoint.mjJNT_HINGE
    assert not model.joint("wrist_roll").limited[0]              # continuous
    np.testing.assert_allclose(model.joint("lift").range, [0.0, 0.2])
    assert model.neq == 1                                        # the mimic
    assert model.eq_obj1id[0] == model.joint("right_finger_joint").id
    assert model.eq_obj2id[0] == model.joint("left_finger_joint").id
    np.testing.assert_allclose(model.eq_data[0][:5], [0.1, -1.5, 0, 0, 0])

    free = mujoco.MjModel.from_xml_string(described.mjcf(floor=True, free_base=True,
                                                         base_height=0.5))
    assert free.nq == 7 + 4 and free.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    floor = free.geom("floor")
    assert floor.type[0] == mujoco.mjtGeom.mjGEOM_PLANE
    data = mujoco.MjData(free)
    mujoco.mj_forward(free, data)
    assert data.xpos[free.body("base_link").id][2] == pytest.approx(0.5)


def test_a_urdf_without_inertials_still_makes_a_model_mujoco_takes() -> None:
    bare = re.sub(r"<inertial>.*?</inertial>", "", ARM, flags=re.S)
    d = Description.from_urdf(bare)
    assert d.total_mass == 0.0
    model = mujoco.MjModel.from_xml_string(mjcf(d))
    mass = {name: float(model.body(name).mass[0]) for name in
            ("carriage", "wrist", "left_finger", "right_finger")}
    # shapes at MuJoCo's default density (1000 kg/m³), a bare or mesh-only moving link a speck
    assert mass["carriage"] == pytest.approx(1000 * math.pi * 0.015 ** 2 * 0.1)
    assert mass["wrist"] == pytest.approx(1000 * 4 / 3 * math.pi * 0.02 ** 3)
    assert mass["left_finger"] == mass["right_finger"] == SPECK_KG


@pytest.mark.parametrize("trial", range(3))
def test_mujoco_places_the_bodies_where_the_urdfs_kinematics_do(described: Description,
                                                                trial: int) -> None:
    robot = URDF.from_xml_string(ARM)
    model = mujoco.MjModel.from_xml_string(mjcf(described))
    data = mujoco.MjData(model)
    rng = np.random.default_rng(7 + trial)
    q = {"lift": rng.uniform(0, 0.2), "wrist_roll": rng.uniform(-6, 6),
         "left_finger_joint": rng.uniform(-0.5, 0.8)}
    q["right_finger_joint"] = -1.5 * q["left_finger_joint"] + 0.1     # the URDF's mimic
    for name, value in q.items():
        data.qpos[model.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(model, data)
    for link in ("carriage", "wrist", "left_finger", "right_finger"):
        expected = urdf_fk(robot, link, q)
        body = model.body(link).id
        np.testing.assert_allclose(data.xpos[body], expected[:3, 3], atol=1e-9)
        np.testing.assert_allclose(data.xmat[body].reshape(3, 3), expected[:3, :3],
                                   atol=1e-7)
    camera = urdf_fk(robot, "camera", q)        # a frame-only link: a site
    np.testing.assert_allclose(data.site("camera").xpos, camera[:3, 3], atol=1e-9)
    np.testing.assert_allclose(data.site("camera").xmat.reshape(3, 3), camera[:3, :3],
                               atol=1e-7)


def test_a_world_link_is_the_world_and_a_joint_can_be_welded() -> None:
    text = ARM.replace('<link name="camera"/>', '<link name="camera"/><link name="world"/>'
                       ).replace("<joint name=\"lift\"", """<joint name="to_world" type="fixed">
    <parent link="world"/><child link="base_link"/><origin xyz="0 0 0.7"/></joint>
  <joint name="lift\"""")
    d = Description.from_urdf(text)
    assert d.root == "world"
    model = mujoco.MjModel.from_xml_string(mjcf(d, welded={"wrist_roll"}))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "base_link") == 1
    assert model.body("base_link").parentid[0] == 0          # MuJoCo's world body
    assert model.nq == 3                                      # the wrist welded
    with pytest.raises(RobotValueError, match="root link is 'world'"):
        mjcf(d, free_base=True)


@pytest.mark.parametrize(("change", "words"), [
    (("<limit lower=\"0\" upper=\"0.2\"", "<limit lower=\"zero\" upper=\"0.2\""),
     "joint 'lift' <limit>: lower='zero' is not 1 finite number"),
    (('<parent link="wrist"/><child link="left_finger"/>',
      '<parent link="wirst"/><child link="left_finger"/>'),
     "joint 'left_finger_joint' <parent>: link='wirst' is not a <link> of the robot "
     "(did you mean 'wrist'?)"),
    (('type="continuous"', 'type="floating"'),
     "joint 'wrist_roll': type='floating' is not one servolab's worlds can drive"),
    (('<limit lower="-0.5" upper="0.8" effort="2" velocity="3"/>', ""),
     "joint 'left_finger_joint': a revolute joint needs <limit"),
    (('<mimic joint="left_finger_joint"', '<mimic joint="thumb"'),
     "joint 'right_finger_joint' <mimic>: joint='thumb' is not a movable joint"),
    (('<axis xyz="1 0 1"/>', '<axis xyz="0 0 0"/>'),
     "joint 'wrist_roll' <axis>: xyz='0 0 0' is not a direction"),
    (('<box size="0.06 0.06 0.04"/>', '<box size="0.06 0.06"/>'),
     "link 'base_link' <visual> <box>: size='0.06 0.06' is not 3 finite numbers"),
    (('<parent link="carriage"/><child link="camera"/>',
      '<parent link="carriage"/><child link="wrist"/>'),
     "joint 'camera_mount' <child>: link 'wrist' already hangs from joint 'wrist_roll'"),
    (("robot", "robt"), "<robt>: the root element must be <robot>"),
    (("</robot>", ""), "arm.urdf: not XML"),
])
def test_bad_input_is_refused_in_one_line_naming_the_file_and_element(
        change: tuple[str, str], words: str) -> None:
    text = ARM.replace(*change)
    assert text != ARM
    with pytest.raises(RobotValueError) as caught:
        Description.from_urdf(text, source="arm.urdf")
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith("arm.urdf: ")
    assert words in message


def test_armstrongs_description_is_the_generic_one() -> None:
    from servolab.robots.armstrong.description import describe, model_file

    armstrong = describe()
    assert isinstance(armstrong, Description)
    assert armstrong.urdf() == model_file("urdf") and armstrong.mjcf() == model_file("mjcf")
    read = Description.from_urdf(model_file("urdf"), "armstrong.urdf")
    assert [(j.name, j.kind, j.parent, j.child, j.origin, j.axis) for j in read.joints] == [
        (j.name, j.kind, j.parent, j.child, j.origin, j.axis) for j in armstrong.joints]
    for mine, theirs in zip(read.joints, armstrong.joints, strict=True):
        if mine.kind != "fixed":     # the URDF keeps 12 significant digits
            assert (mine.lower, mine.upper) == pytest.approx((theirs.lower, theirs.upper),
                                                             rel=1e-11)
    assert all(math.isclose(read.link(k.name).mass, k.mass) for k in armstrong.links)
