"""Armstrong's robot description (robots/armstrong/description.py): its URDF read by a reader
that is not servolab's, its MJCF's kinematics against the URDF's, the model's legs against
kinematics.leg, Table 4.2's stand pose, the masses, and the seed's facts each joint carries.

Seed 001's tables are cited where a test checks them; the RX-28's figures are the ROBOTIS
e-Manual's (docs/en/dxl/rx/rx-28.md, "Specifications": 72 g, 3.7 N m stall torque)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import mujoco
import numpy as np
import pytest

from servolab.gait.walking import foot_positions
from servolab.kinematics.leg import JOINT_NAMES, foot_position, leg_inverse, leg_transform
from servolab.robots.armstrong.description import (
    RX28_MASS,
    Assumptions,
    Description,
    describe,
    mjcf,
    model_file,
    urdf,
)
from servolab.robots.armstrong.hardware import joint_limits, load_config
from servolab.robots.armstrong.poses import MOTORS, STAND_POSE
from servolab.robots.errors import RobotValueError

SIDES = ("left", "right")
#: Table 2.2 of seed 001: the 21 motor IDs, in its order.
TABLE_2_2_IDS = (11, 12, 13, 14, 15, 16, 21, 22, 23, 24, 25, 26, 31, 32, 33, 41, 42, 43, 51,
                 61, 62)
RNG_SEED = 31


@pytest.fixture(scope="module")
def description() -> Description:
    return describe()


@pytest.fixture(scope="module")
def urdf_text(description: Description) -> str:
    return urdf(description)


@pytest.fixture(scope="module")
def mj_model(description: Description) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(mjcf(description))


@pytest.fixture(scope="module")
def mj_urdf(urdf_text: str) -> mujoco.MjModel:
    """MuJoCo's own URDF import. It fuses links on fixed joints into their parents by
    default, which would take the soles' names away: asked not to (MuJoCo's documented
    ``<mujoco><compiler/></mujoco>`` extension, added here, not written by servolab)."""
    text = urdf_text.replace('<robot name="armstrong">', '<robot name="armstrong"><mujoco>'
                             '<compiler fusestatic="false"/></mujoco>', 1)
    return mujoco.MjModel.from_xml_string(text)


def set_joints(model: mujoco.MjModel, data: mujoco.MjData, positions: Mapping[str, float]
               ) -> None:
    for name, value in positions.items():
        data.qpos[model.joint(name).qposadr[0]] = value
    mujoco.mj_kinematics(model, data)


def in_pelvis(model: mujoco.MjModel, data: mujoco.MjData, position: np.ndarray,
              rotation: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """A world position (and rotation) in the pelvis frame: the MJCF's pelvis floats, the
    imported URDF's is fixed at the origin, so the two are compared there."""
    pelvis = model.body("pelvis").id
    r = data.xmat[pelvis].reshape(3, 3)
    local = r.T @ (position - data.xpos[pelvis])
    return local, (r.T @ rotation if rotation is not None else None)


def random_positions(description: Description, rng: np.random.Generator,
                     names: tuple[str, ...] | None = None) -> dict[str, float]:
    """Joint angles drawn uniformly within each joint's range."""
    joints = [j for j, _ in description.motors if names is None or j.name in names]
    return {j.name: float(rng.uniform(j.lower, j.upper)) for j in joints}


# -- (a) the URDF, read by others ------------------------------------------------------------

@pytest.fixture(scope="module")
def parsed_urdf(urdf_text: str) -> Any:
    """The URDF as ROS's own Python reader, urdf_parser_py (the test extra), reads it."""
    from urdf_parser_py.urdf import URDF

    return URDF.from_xml_string(urdf_text)


def test_urdf_read_by_urdf_parser_py_has_the_descriptions_joints_limits_and_motors(
        description: Description, parsed_urdf: Any) -> None:
    robot = parsed_urdf
    assert robot.get_root() == "pelvis"
    read = {j.name: j for j in robot.joints}
    assert set(read) == {j.name for j in description.joints}
    for joint in description.joints:
        got = read[joint.name]
        assert (got.type, got.parent, got.child) == (joint.kind, joint.parent, joint.child)
        np.testing.assert_allclose(got.origin.xyz, joint.origin, atol=1e-12)
        np.testing.assert_allclose(got.origin.rpy, (0.0, 0.0, 0.0), atol=1e-12)
        if joint.kind == "revolute":
            np.testing.assert_allclose(got.axis, joint.axis)
            assert got.limit.lower == pytest.approx(joint.lower, abs=1e-9)
            assert got.limit.upper == pytest.approx(joint.upper, abs=1e-9)
            # RX-28: 3.7 N m stall torque, 85 rpm no load (e-Manual)
            assert got.limit.effort == pytest.approx(3.7)
            assert got.limit.velocity == pytest.approx(85 * 2 * math.pi / 60, rel=1e-9)
    # one transmission a motor joint: its actuator is the motor column (the 21 IDs of Table
    # 2.2), its reduction the motor's direction
    motors = {t.joints[0].name: (t.actuators[0].name, int(t.actuators[0].mechanicalReduction))
              for t in robot.transmissions}
    assert sorted(int(str(column)[1:]) for column, _ in motors.values()) == sorted(TABLE_2_2_IDS)
    assert motors == {j.name: (m.column, m.direction) for j, m in description.motors}


def test_urdf_loads_in_mujoco_with_the_same_ranges_and_masses(
        description: Description, mj_urdf: mujoco.MjModel) -> None:
    assert mj_urdf.njnt == 21
    for joint, _ in description.motors:
        np.testing.assert_allclose(mj_urdf.jnt_range[mj_urdf.joint(joint.name).id],
                                   (joint.lower, joint.upper), atol=1e-9)
    for link in description.links:
        assert mj_urdf.body_mass[mj_urdf.body(link.name).id] == pytest.approx(link.mass)
    assert mj_urdf.body_subtreemass[0] == pytest.approx(description.total_mass)


# -- (b) the MJCF moves as the URDF does ------------------------------------------------------

def test_mjcf_kinematics_equal_the_urdfs(description: Description, mj_model: mujoco.MjModel,
                                          mj_urdf: mujoco.MjModel) -> None:
    """Random angles of all 21 joints: every link and both soles where MuJoCo's import of the
    URDF puts them. In the MJCF a sole is a site (a frame without mass), in the URDF a link on
    a fixed joint."""
    rng = np.random.default_rng(RNG_SEED)
    a, b = mujoco.MjData(mj_model), mujoco.MjData(mj_urdf)
    links = [link.name for link in description.links if link.boxes]
    for _ in range(50):
        positions = random_positions(description, rng)
        set_joints(mj_model, a, positions)
        set_joints(mj_urdf, b, positions)
        for name in links:
            i, k = mj_model.body(name).id, mj_urdf.body(name).id
            pa, ra = in_pelvis(mj_model, a, a.xpos[i], a.xmat[i].reshape(3, 3))
            pb, rb = in_pelvis(mj_urdf, b, b.xpos[k], b.xmat[k].reshape(3, 3))
            np.testing.assert_allclose(pa, pb, atol=1e-12, err_msg=name)
            np.testing.assert_allclose(ra, rb, atol=1e-12, err_msg=name)
        for side in SIDES:
            sole_a, _ = in_pelvis(mj_model, a, a.site_xpos[mj_model.site(f"{side}_sole").id])
            sole_b, _ = in_pelvis(mj_urdf, b, b.xpos[mj_urdf.body(f"{side}_sole").id])
            np.testing.assert_allclose(sole_a, sole_b, atol=1e-12)


def _chain_sole(robot: Any, side: str, positions: dict[str, float]) -> np.ndarray:
    """The sole in the pelvis frame by composing urdf_parser_py's joint origins and axes
    (every origin unrotated, checked above; a revolute joint turns about its axis by
    Rodrigues' formula): a forward kinematics owing nothing to MuJoCo or to the writer."""
    parents = {j.child: j for j in robot.joints}
    chain, link = [], f"{side}_sole"
    while link in parents:
        chain.append(parents[link])
        link = parents[link].parent
    rotation, position = np.eye(3), np.zeros(3)
    for joint in reversed(chain):
        position = position + rotation @ np.asarray(joint.origin.xyz)
        if joint.type == "revolute":
            k = np.asarray(joint.axis, dtype=float)
            cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
            q = positions.get(joint.name, 0.0)
            rotation = rotation @ (np.eye(3) + math.sin(q) * cross
                                   + (1 - math.cos(q)) * cross @ cross)
    return position


def test_soles_where_the_urdfs_own_chain_puts_them(description: Description, parsed_urdf: Any,
                                                   mj_model: mujoco.MjModel) -> None:
    """A third forward kinematics, the URDF's joint chain composed as read by urdf_parser_py,
    agrees with MuJoCo's."""
    rng = np.random.default_rng(RNG_SEED + 1)
    data = mujoco.MjData(mj_model)
    for _ in range(10):
        positions = random_positions(description, rng)
        set_joints(mj_model, data, positions)
        for side in SIDES:
            sole, _ = in_pelvis(mj_model, data, data.site_xpos[mj_model.site(f"{side}_sole").id])
            np.testing.assert_allclose(_chain_sole(parsed_urdf, side, positions), sole,
                                       atol=1e-12)


# -- (c) the model's legs are kinematics.leg's ------------------------------------------------

def test_model_forward_kinematics_is_kinematics_leg(description: Description,
                                                    mj_model: mujoco.MjModel) -> None:
    """For random angles of both legs within their ranges, the sole from MuJoCo equals
    ``kinematics.leg.foot_position`` (Table 5.2's DH chain).

    The transform between the two frames: leg.py's origin is the DH base frame, on the
    hip-yaw axis (description: the origin of joint ``<side>_hip_yaw`` in the pelvis frame,
    (0, ±hip_width/2, 0)); its axes are the pelvis's (x forward, y left, z up); it counts in
    mm. So ``p_leg = 1000 · (Rᵀ(p_sole − p_pelvis) − o_hip)``. The joint angles are the same
    numbers in both (a leg joint's angle is leg.py's; the motor's sign is in the actuator).
    The foot's frame is leg.py's last DH frame turned so it is the pelvis's at zero angles:
    ``R_foot(q) = R_6(q) · R_6(0)ᵀ``.
    """
    rng = np.random.default_rng(RNG_SEED + 2)
    data = mujoco.MjData(mj_model)
    leg_names = tuple(f"{s}_{n}" for s in SIDES for n in JOINT_NAMES)
    r6_zero = leg_transform(np.zeros(6))[:3, :3]
    for _ in range(100):
        positions = random_positions(description, rng, leg_names)
        set_joints(mj_model, data, positions)
        for side in SIDES:
            q = description.leg_joints(positions, side)
            origin = np.array(description.joint(f"{side}_hip_yaw").origin)
            sole, _ = in_pelvis(mj_model, data, data.site_xpos[mj_model.site(f"{side}_sole").id])
            np.testing.assert_allclose(1000.0 * (sole - origin), foot_position(q), atol=1e-9)
            foot = mj_model.body(f"{side}_foot").id
            _, rotation = in_pelvis(mj_model, data, data.xpos[foot],
                                    data.xmat[foot].reshape(3, 3))
            np.testing.assert_allclose(rotation, leg_transform(q)[:3, :3] @ r6_zero.T,
                                       atol=1e-12)


def test_soles_reach_the_seeds_gait_targets_with_the_feet_flat(
        description: Description, mj_model: mujoco.MjModel) -> None:
    """Appendix D's foot positions (Table 5.1's parameters) through leg.py's IK: the model's
    soles land on them, each foot parallel to the floor (section 5.2.4: alpha = beta =
    gamma = 0)."""
    feet = foot_positions()
    data = mujoco.MjData(mj_model)
    for i in range(len(feet.time_ms)):
        targets = {"left": feet.left[i], "right": feet.right[i]}
        positions = {f"{side}_{n}": float(v) for side in SIDES
                     for n, v in zip(JOINT_NAMES, leg_inverse(targets[side]), strict=True)}
        set_joints(mj_model, data, positions)
        for side in SIDES:
            origin = np.array(description.joint(f"{side}_hip_yaw").origin)
            sole, _ = in_pelvis(mj_model, data, data.site_xpos[mj_model.site(f"{side}_sole").id])
            np.testing.assert_allclose(1000.0 * (sole - origin), targets[side], atol=1e-9)
            foot = mj_model.body(f"{side}_foot").id
            _, rotation = in_pelvis(mj_model, data, data.xpos[foot],
                                    data.xmat[foot].reshape(3, 3))
            np.testing.assert_allclose(rotation, np.eye(3), atol=1e-12)


# -- (d) Table 4.2's stand pose -----------------------------------------------------------------

def test_stand_keyframe_is_table_4_2_with_both_soles_flat_on_the_floor(
        description: Description, mj_model: mujoco.MjModel) -> None:
    """The MJCF's ``stand`` key is Table 4.2 (motor columns in degrees, through each
    motor's direction), and it puts both soles flat (the foot's z axis vertical) at the same
    height, on the floor; the feet where seeds/README.md's facts put them: left (20, 2, -295)
    and right (-20, 17, -295) mm from their hips. Table 4.2 prints 4 to 5 digits, so flat and
    level hold to its rounding (1e-5 rad, a few micrometres)."""
    data = mujoco.MjData(mj_model)
    key = mj_model.key("stand").id
    mujoco.mj_resetDataKeyframe(mj_model, data, key)
    mujoco.mj_forward(mj_model, data)
    expected = description.joint_positions(STAND_POSE)
    for name, value in expected.items():
        assert data.qpos[mj_model.joint(name).qposadr[0]] == pytest.approx(value, abs=1e-9)
    # an actuator's length (and control) is its motor's angle: Table 4.2's degrees
    for i, column in enumerate(MOTORS):
        assert mj_model.actuator(i).name == column
        assert data.actuator_length[i] == pytest.approx(math.radians(STAND_POSE[column]))
        assert data.ctrl[i] == pytest.approx(math.radians(STAND_POSE[column]))
    heights = []
    for side, target in (("left", (20.0, 2.0, -295.0)), ("right", (-20.0, 17.0, -295.0))):
        foot = mj_model.body(f"{side}_foot").id
        z_axis = data.xmat[foot].reshape(3, 3)[:, 2]
        assert math.acos(min(1.0, z_axis[2])) < 1e-5
        sole = data.site_xpos[mj_model.site(f"{side}_sole").id]
        heights.append(sole[2])
        origin = np.array(description.joint(f"{side}_hip_yaw").origin)
        local, _ = in_pelvis(mj_model, data, sole)
        np.testing.assert_allclose(1000.0 * (local - origin), target, atol=0.01)
    assert heights[0] == pytest.approx(heights[1], abs=5e-6)
    assert min(heights) == pytest.approx(0.0, abs=1e-9)


def test_stand_pose_holds_under_gravity(mj_model: mujoco.MjModel) -> None:
    """Two simulated seconds in Table 4.2's pose on the RX-28's position actuators (3.7 N m
    at most): the robot stays up, the pelvis within 2 mm of its height and 3 degrees of
    upright (it settles about 1 degree forward, the actuators' compliance under its weight).
    A motor's sign (gear) the wrong way round would fold the leg at once."""
    data = mujoco.MjData(mj_model)
    mujoco.mj_resetDataKeyframe(mj_model, data, mj_model.key("stand").id)
    height = data.qpos[2]
    mujoco.mj_step(mj_model, data, nstep=2000)
    assert abs(data.qpos[2] - height) < 0.002
    tilt = 2 * math.acos(min(1.0, abs(data.qpos[3])))
    assert tilt < math.radians(3)
    # standing, no joint is near its motor's stall torque (MuJoCo would clip at 3.7 N m
    # silently): the pose holds with torque to spare
    assert np.all(np.abs(data.actuator_force) < 0.5 * 3.7)


# -- (e) masses and assumptions ---------------------------------------------------------------

def test_every_servo_weighs_72_g_and_the_total_is_stated(description: Description,
                                                         mj_model: mujoco.MjModel) -> None:
    """21 RX-28 (001 section 2.1: "conformed by 21 motors") at 72 g each (e-Manual), plus
    the stated masses of the frames: 2.242 kg."""
    servos = [box for link in description.links for box in link.boxes
              if box.material == "servo"]
    assert sorted(int(box.name[1:3]) for box in servos) == sorted(TABLE_2_2_IDS)
    assert all(box.mass == 0.072 == RX28_MASS for box in servos)
    a = Assumptions()
    frames = (a.pelvis_mass + a.chest_mass + a.head_mass
              + 2 * (a.thigh_mass + a.shank_mass + a.foot_mass + a.upper_arm_mass
                     + a.forearm_mass))
    assert description.total_mass == pytest.approx(21 * 0.072 + frames)
    assert description.total_mass == pytest.approx(2.242)
    assert mj_model.body_subtreemass[mj_model.body("pelvis").id] == pytest.approx(2.242)


def test_every_assumption_says_its_unit_and_source() -> None:
    for name, value, unit, source in Assumptions().table():
        assert unit in ("m", "kg", "kg m²", "N m"), name
        assert source.startswith("guess: "), name
        assert math.isfinite(value)


@pytest.mark.parametrize(("change", "words"), [
    ({"foot_mass": -0.06}, "assumption foot_mass = -0.06 kg must be a positive, finite number"),
    ({"chest_mass": 0.0}, "assumption chest_mass = 0.0 kg must be a positive"),
    ({"hip_width": math.nan}, "assumption hip_width = nan m must be a positive"),
    ({"foot_forward": math.inf}, "assumption foot_forward = inf m must be a finite number"),
    ({"foot_width": 0.12}, "foot_width 0.12 m is not less than hip_width 0.1 m"),
    ({"foot_thickness": 0.05}, "does not fit under the ankle axis, L4 = 0.04 m"),
])
def test_a_bad_assumption_is_refused_in_one_line(change: dict[str, float], words: str) -> None:
    with pytest.raises(RobotValueError) as caught:
        replace(Assumptions(), **change)
    assert words in str(caught.value)
    assert "\n" not in str(caught.value)


def test_an_assumption_changes_the_model() -> None:
    wide = describe(replace(Assumptions(), hip_width=0.12, foot_mass=0.09))
    assert wide.joint("left_hip_yaw").origin == (0.0, 0.06, 0.0)
    assert wide.total_mass == pytest.approx(2.242 + 2 * 0.03)


# -- the seed's facts on every joint ----------------------------------------------------------

def test_joints_carry_table_2_2_ids_appendix_a_ranges_and_table_4_2_signs(
        description: Description) -> None:
    """Motor IDs of Table 2.2 in the motion files' order; each range the controller's
    (Appendix A: 0..1023 around Table 2.2's init) through the motor's direction; the leg
    motors' directions the signs Table 4.2 is printed with (seeds/README.md); motor 62 off
    the bus (Figure 3.4)."""
    assert tuple(m.id for _, m in description.motors) == TABLE_2_2_IDS
    limits = joint_limits(load_config())
    for joint, motor in description.motors:
        lo, hi = sorted(motor.direction * math.radians(v) for v in limits[motor.column])
        assert (joint.lower, joint.upper) == pytest.approx((lo, hi))
        assert motor.on_bus == (motor.id != 62)
    signs = {"m12": -1, "m13": 1, "m14": -1, "m15": 1, "m16": -1,
             "m22": -1, "m23": 1, "m24": 1, "m25": -1, "m26": -1}
    assert {m.column: m.direction for _, m in description.motors if m.column in signs} == signs
    assert [j.name for j, m in description.motors if m.id < 30] == [
        f"{side}_{n}" for side in SIDES for n in
        ("hip_yaw", "hip_pitch", "hip_roll", "knee", "ankle_pitch", "ankle_roll")]
    assert description.joint("left_hip_pitch").motor.function == "left_hip x"  # Table 4.1


def _motion(mj_model: mujoco.MjModel, description: Description, column: str,
            measure: Callable[[mujoco.MjData], float]) -> float:
    """How ``measure`` changes when motor ``column`` turns 0.05 rad up from 0 (its init)."""
    data = mujoco.MjData(mj_model)
    mujoco.mj_kinematics(mj_model, data)
    before = measure(data)
    joint, motor = next((j, m) for j, m in description.motors if m.column == column)
    set_joints(mj_model, data, {joint.name: motor.direction * 0.05})
    return measure(data) - before


def _site(name: str, axis: int) -> Callable[[mujoco.MjModel], Callable[[mujoco.MjData], float]]:
    return lambda model: lambda data: float(data.site_xpos[model.site(name).id][axis])


def _geom(name: str, axis: int) -> Callable[[mujoco.MjModel], Callable[[mujoco.MjData], float]]:
    return lambda model: lambda data: float(data.geom_xpos[model.geom(name).id][axis])


def _facing(body: str, row: int) -> Callable[[mujoco.MjModel], Callable[[mujoco.MjData], float]]:
    """Component ``row`` (world) of the body's x axis: where its toe or lens points."""
    return lambda model: lambda data: float(data.xmat[model.body(body).id].reshape(3, 3)[row, 0])


X, Y, Z = range(3)


@pytest.mark.parametrize(("column", "word", "measure", "sign"), [
    # Table 2.2: which way each motor turns as its position increases
    ("m12", "backwards", _site("left_sole", X), -1),
    ("m22", "backwards", _site("right_sole", X), -1),
    ("m13", "out", _site("left_sole", Y), 1),
    ("m23", "inwards", _site("right_sole", Y), 1),
    ("m14", "forwards", _site("left_sole", X), 1),
    ("m24", "backwards", _site("right_sole", X), -1),
    ("m15", "up", _facing("left_foot", Z), 1),
    ("m25", "down", _facing("right_foot", Z), -1),
    ("m51", "Down (the chest leans forwards)", _geom("head_camera", X), 1),
    ("m31", "Backwards", _geom("left_forearm_frame", X), -1),
    ("m41", "Forwards", _geom("right_forearm_frame", X), 1),
    ("m32", "Down (the hanging arm comes in)", _geom("left_forearm_frame", Y), -1),
    ("m42", "Up (the hanging arm goes out)", _geom("right_forearm_frame", Y), -1),
    ("m33", "Down (the forearm back)", _geom("left_forearm_frame", X), -1),
    ("m43", "Up (the forearm forwards)", _geom("right_forearm_frame", X), 1),
    ("m61", "Left", _facing("head", Y), 1),
    ("m62", "Up", _facing("head", Z), 1),
])
def test_motors_turn_the_way_table_2_2_says(
        description: Description, mj_model: mujoco.MjModel, column: str, word: str,
        measure: Callable[[mujoco.MjModel], Callable[[mujoco.MjData], float]],
        sign: int) -> None:
    moved = _motion(mj_model, description, column, measure(mj_model))
    assert np.sign(moved) == sign, f"{column} increasing should move {word}"


@pytest.mark.parametrize(("column", "side"), [("m11", "left"), ("m21", "right")])
def test_hip_yaw_motors_turn_as_appendix_e_has_them(
        description: Description, mj_model: mujoco.MjModel, column: str, side: str) -> None:
    """Seed 001 contradicts itself here: Table 2.2 turns m11 "inwards" and m21 "out" (both
    clockwise seen from above, the toe to -y), Appendix E (lines 7-8 and 36, ``mm11 =
    Theta(:,1) - 90``) both counter-clockwise. The seed's gait never turns the yaw, so nothing
    tells which the real robot does; kinematics.leg follows Appendix E and so does the
    description: a positive motor angle turns either foot's toe to +y."""
    moved = _motion(mj_model, description, column, _facing(f"{side}_foot", Y)(mj_model))
    assert np.sign(moved) == 1


# -- the MJCF's physics settings ----------------------------------------------------------------

def test_mjcf_in_radians_with_a_floor_foot_contacts_and_rx28_actuators(
        description: Description, mj_model: mujoco.MjModel) -> None:
    """Ranges as the description's radians (MJCF reads degrees unless told: a missing
    ``angle="radian"`` would shrink them 57-fold); a floor plane; only the soles meet each
    other, everything meets the floor; one position actuator a motor with the RX-28's stall
    torque as its force limit (3.7 N m, e-Manual) and the motor's range as its control's."""
    limits = joint_limits(load_config())
    for joint, motor in description.motors:
        np.testing.assert_allclose(mj_model.jnt_range[mj_model.joint(joint.name).id],
                                   (joint.lower, joint.upper))
        actuator = mj_model.actuator(motor.column)
        assert actuator.gear[0] == motor.direction
        np.testing.assert_allclose(actuator.forcerange, (-3.7, 3.7))
        np.testing.assert_allclose(actuator.ctrlrange,
                                   [math.radians(v) for v in limits[motor.column]])
    floor = mj_model.geom("floor")
    assert floor.type[0] == mujoco.mjtGeom.mjGEOM_PLANE

    def meet(a: int, b: int) -> bool:
        return bool(mj_model.geom_contype[a] & mj_model.geom_conaffinity[b]
                    or mj_model.geom_contype[b] & mj_model.geom_conaffinity[a])

    soles = [mj_model.geom(f"{side}_foot_sole").id for side in SIDES]
    assert meet(*soles) and all(meet(s, floor.id) for s in soles)
    solid = [i for i in range(mj_model.ngeom) if i != floor.id and
             (mj_model.geom_contype[i] or mj_model.geom_conaffinity[i])]
    assert len(solid) > 2 and all(meet(i, floor.id) for i in solid)
    assert [(a, b) for a in solid for b in solid if a < b and meet(a, b)] == [tuple(soles)]
    for side in SIDES:
        sole = mj_model.geom(f"{side}_foot_sole")
        assert sole.type[0] == mujoco.mjtGeom.mjGEOM_BOX


def test_model_file_writes_either_format_and_refuses_others() -> None:
    assert "<robot name=\"armstrong\">" in model_file("urdf")
    assert '<compiler angle="radian"' in model_file("mjcf")
    with pytest.raises(RobotValueError, match=r"no model format 'mjfc'.*did you mean 'mjcf'"):
        model_file("mjfc")


def test_robots_show_lists_every_assumption_walk_assume_takes() -> None:
    import dataclasses

    from servolab.robots.armstrong.description import Assumptions, assumptions_table
    from servolab.robots.registry import shipped_files

    shown = shipped_files()["armstrong.assumptions"]
    assert callable(shown)
    text = shown()
    assert text == assumptions_table()
    for f in dataclasses.fields(Assumptions):
        assert f"\n{f.name} = " in text
    changed = Assumptions.with_values({"hip_width": 0.12})
    assert "hip_width = 0.12 m" in assumptions_table(changed)
