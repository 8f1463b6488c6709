"""The ZMP walk (servolab.gait.zmp_walk): footsteps, the ZMP reference, the CoM by preview
control, the swing feet and the legs' inverse kinematics, as a motion file.

Oracles from outside the module: the robot's own facts (Table 4.2 in
``robots.armstrong.poses``, the description's CoM, hip width and feet, the configuration's
joint speed and limits), forward kinematics (``kinematics.leg.foot_position``) for the
feet the rows put down, and the cart-table equation applied here to the planned CoM for the
ZMP it gives.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pytest

from servolab.gait.errors import GaitValueError
from servolab.gait.motionfile import read_motion_file, write_motion_file
from servolab.gait.preview_control import GRAVITY
from servolab.gait.walking import MOTOR_COLUMNS
from servolab.gait.zmp_walk import (
    COM_OFFSET,
    HIP_WIDTH,
    JOINT_SPEED,
    TABLE_4_2_STAND_POSE,
    ZmpWalkParameters,
    ZmpWalkPlan,
    generate_zmp_walk,
    plan_zmp_walk,
    stance_load,
    stand_geometry,
)
from servolab.kinematics.leg import HIP_ROLL, foot_position, leg_inverse, leg_motor_angles
from servolab.robots.armstrong.description import Assumptions, describe, mjcf
from servolab.robots.armstrong.hardware import joint_limits, load_config
from servolab.robots.armstrong.poses import STAND_POSE

LEG_COLUMNS = {"left": list(range(0, 6)), "right": list(range(6, 12))}


@pytest.fixture(scope="module")
def limits() -> dict[str, tuple[float, float]]:
    return joint_limits(load_config())


@pytest.fixture(scope="module")
def walk(limits: dict[str, tuple[float, float]]) -> ZmpWalkPlan:
    return plan_zmp_walk(ZmpWalkParameters(), limits)


def joints_of(motors: np.ndarray, side: str) -> np.ndarray:
    """Motor columns (degrees) back to leg joint angles (radians), through leg.py's signs."""
    signs = leg_motor_angles(np.radians(np.eye(6)), side)  # type: ignore[arg-type]
    return np.asarray(np.radians(motors[:, LEG_COLUMNS[side]] @ signs.T))


def stand_row() -> np.ndarray:
    return np.array([STAND_POSE[c] for c in MOTOR_COLUMNS])


# -- the robot's facts the gait layer holds copies of ------------------------------------------

def test_the_stand_pose_is_table_4_2_of_the_robot() -> None:
    assert dict(TABLE_4_2_STAND_POSE) == STAND_POSE
    assert dict(ZmpWalkParameters().stand_pose) == STAND_POSE


def test_hip_width_and_com_offset_are_the_descriptions() -> None:
    """COM_OFFSET: the description's CoM in the stand pose (MuJoCo's subtree CoM of the
    pelvis at the MJCF's ``stand`` keyframe), relative to the pelvis frame, within 0.1 mm."""
    assert Assumptions().hip_width == HIP_WIDTH
    model = mujoco.MjModel.from_xml_string(mjcf(describe()))
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    mujoco.mj_forward(model, data)
    pelvis = model.body("pelvis").id
    offset = data.subtree_com[pelvis] - data.xpos[pelvis]
    assert pytest.approx(offset[:2], abs=1e-4) == COM_OFFSET


def test_the_joint_speed_is_the_configurations() -> None:
    assert {c.joint_speed for c in load_config().controllers} == {JOINT_SPEED}


def test_stand_geometry_is_the_stand_poses_feet() -> None:
    """Table 4.2 puts the left sole 20 mm ahead of its hip, the right 20 mm behind, both
    295 mm below the hips (the seed's z = -(d_leg - d_step)); the description stands its
    pelvis that high."""
    stand = stand_geometry(STAND_POSE)
    assert stand.left == pytest.approx([20.0, 2.0, -295.0], abs=0.01)
    assert stand.right == pytest.approx([-20.0, 17.0, -295.0], abs=0.01)
    assert stand.hip_height == pytest.approx(describe().standing_height(STAND_POSE), abs=1e-5)


# -- the motion file -------------------------------------------------------------------------

def test_the_walk_is_a_motion_file_of_the_seeds_columns(tmp_path: Path,
                                                        walk: ZmpWalkPlan) -> None:
    params = ZmpWalkParameters()
    motion = generate_zmp_walk(params)
    assert motion.names == MOTOR_COLUMNS
    assert motion == walk.motion()
    assert motion.angles.shape == (params.row_count, 21)
    assert walk.time == pytest.approx(np.arange(params.row_count) / params.rate)
    assert walk.time[-1] >= params.duration - 1e-9
    path = tmp_path / "zmp_walk.csv"
    write_motion_file(path, motion)
    assert read_motion_file(path, limits=joint_limits(load_config())) == motion


def test_first_and_last_rows_are_the_stand_pose(walk: ZmpWalkPlan) -> None:
    """The robot stands in Table 4.2 before it plays and finishes to it: no jump at either
    end (within a hundredth of a degree)."""
    assert walk.motors[0] == pytest.approx(stand_row(), abs=0.01)
    assert walk.motors[-1] == pytest.approx(stand_row(), abs=0.01)


def test_the_upper_body_holds_the_stand_pose(walk: ZmpWalkPlan) -> None:
    upper = [MOTOR_COLUMNS.index(c) for c in MOTOR_COLUMNS[12:]]
    assert np.all(walk.motors[:, upper] == stand_row()[upper])
    assert np.all(walk.motors[:, [0, 6]] == 0.0)    # hip yaw: the feet keep their heading


def test_rows_stay_within_the_joints_limits_and_speed(
        walk: ZmpWalkPlan, limits: dict[str, tuple[float, float]]) -> None:
    low = np.array([limits[c][0] for c in MOTOR_COLUMNS])
    high = np.array([limits[c][1] for c in MOTOR_COLUMNS])
    assert np.all((walk.motors >= low) & (walk.motors <= high))
    speed = np.abs(np.radians(np.diff(walk.motors, axis=0))) * ZmpWalkParameters().rate
    assert speed.max() <= JOINT_SPEED
    assert speed.max() > 0.8 * JOINT_SPEED      # and the default is not needlessly slow


# -- where the feet and the body go ----------------------------------------------------------

def test_the_torso_moves_steps_times_step_length(walk: ZmpWalkPlan) -> None:
    """The last step closes the feet into the stand pose's placement: the pelvis ends
    ``steps x step_length`` ahead (0.4 m), where it started sideways, at rest."""
    params = ZmpWalkParameters()
    travel = walk.pelvis[-1] - walk.pelvis[0]
    assert travel == pytest.approx([params.steps * params.step_length, 0.0, 0.0], abs=1e-4)
    assert walk.pelvis[0] == pytest.approx([0.0, 0.0, 0.295], abs=1e-6)
    assert np.all(np.diff(walk.pelvis[:, 0]) > -1e-3)     # it never walks back


def test_footsteps_alternate_from_the_foot_behind(walk: ZmpWalkPlan) -> None:
    params = ZmpWalkParameters()
    steps = walk.footsteps
    assert steps.shape == (params.steps + 1, 2, 2)
    half = HIP_WIDTH / 2
    assert steps[0] == pytest.approx(np.array([[0.02, half + 0.002], [-0.02, -half + 0.017]]),
                                     abs=1e-5)
    moved = np.abs(np.diff(steps, axis=0)).sum(axis=2) > 0
    swing = np.argmax(moved, axis=1)
    assert np.all(moved.sum(axis=1) == 1)                 # one foot a step
    assert list(swing) == [1, 0] * (params.steps // 2)    # the right (behind) first
    assert np.diff(steps, axis=0)[:, :, 0].max() == pytest.approx(2 * params.step_length)
    assert steps[-1] - steps[0] == pytest.approx(
        np.tile([params.steps * params.step_length, 0.0], (2, 1)))


def test_the_rows_put_the_soles_where_the_plan_says(walk: ZmpWalkPlan) -> None:
    """Inverse kinematics round trip: forward kinematics of the planned joints, and of the
    joints read back from the motor columns (all but the compensated hip roll), give each
    sole's planned position relative to its hip, flat (no rotation about x or y)."""
    hip = np.array([0.0, HIP_WIDTH / 2, 0.0])
    for side, sole, joints, sign in (("left", walk.left, walk.left_joints, 1.0),
                                     ("right", walk.right, walk.right_joints, -1.0)):
        target = (sole - walk.pelvis - sign * hip) * 1e3
        assert foot_position(joints) == pytest.approx(target, abs=1e-6)
        sent = joints_of(walk.motors, side)
        others = [j for j in range(6) if j != HIP_ROLL]
        assert sent[:, others] == pytest.approx(joints[:, others], abs=1e-12)


def test_without_compensation_the_rows_are_the_inverse_kinematics() -> None:
    plan = plan_zmp_walk(ZmpWalkParameters(hip_roll_compensation=0.0))
    hip = np.array([0.0, HIP_WIDTH / 2, 0.0])
    left = foot_position(joints_of(plan.motors, "left"))
    right = foot_position(joints_of(plan.motors, "right"))
    assert left == pytest.approx((plan.left - plan.pelvis - hip) * 1e3, abs=1e-6)
    assert right == pytest.approx((plan.right - plan.pelvis + hip) * 1e3, abs=1e-6)


def test_the_hip_roll_compensation_follows_the_load(walk: ZmpWalkPlan) -> None:
    """Each stance hip roll turns 5 degrees further in single support, the way that lifts
    the pelvis on the swing side (the left's goal up, the right's down), none while both
    feet share the load at the ends."""
    params = ZmpWalkParameters()
    extra = np.degrees(joints_of(walk.motors, "left")[:, HIP_ROLL]
                       - walk.left_joints[:, HIP_ROLL])
    extra_right = np.degrees(joints_of(walk.motors, "right")[:, HIP_ROLL]
                             - walk.right_joints[:, HIP_ROLL])
    load = stance_load(params, walk.time)
    assert extra == pytest.approx(5.0 * load[:, 0], abs=1e-9)
    assert extra_right == pytest.approx(-5.0 * load[:, 1], abs=1e-9)
    lifted = walk.right[:, 2] > 0                         # the right swings: the left carries
    assert np.all(load[lifted, 0] == 1.0) and np.all(load[lifted, 1] == 0.0)
    assert load[0] == pytest.approx([0.0, 0.0]) and load[-1] == pytest.approx([0.0, 0.0])


def test_swing_feet_lift_by_foot_lift_and_touch_down_gently() -> None:
    """One foot in the air at a time, as high as ``foot_lift``; it leaves and meets the floor
    with no speed (sampled finely to see it), and comes straight down at the end."""
    params = ZmpWalkParameters(rate=100.0)
    plan = plan_zmp_walk(params)
    assert not np.any((plan.left[:, 2] > 0) & (plan.right[:, 2] > 0))
    for sole in (plan.left, plan.right):
        assert sole[:, 2].max() == pytest.approx(params.foot_lift, abs=1e-4)
        assert sole[:, 2].min() == 0.0
        velocity = np.diff(sole, axis=0) * params.rate
        down = np.flatnonzero((sole[:-1, 2] > 0) & (sole[1:, 2] == 0))
        up = np.flatnonzero((sole[:-1, 2] == 0) & (sole[1:, 2] > 0))
        assert len(down) == len(up) == params.steps // 2
        assert np.abs(velocity[down]).max() < 0.005       # m/s over the last 10 ms
        assert np.abs(velocity[up]).max() < 0.005
        landing = down[:, None] - np.arange(1, 15)[None, :]   # the last 0.15 s of a swing
        assert np.abs(velocity[landing, :2]).max() < 1e-9


def test_the_planned_com_keeps_the_zmp_on_the_stance_foot(walk: ZmpWalkPlan) -> None:
    """The cart-table equation applied here to the rows' CoM (x'' by central differences at
    10 Hz): its ZMP follows the reference within 5 mm, and in single support lies on the
    stance sole (the description's 120 x 70 mm, centred under the ankle) with 30 mm to spare;
    while standing the CoM is over the stand pose's ZMP."""
    params = ZmpWalkParameters()
    com, dt = walk.com, 1.0 / params.rate
    acc = np.zeros_like(com)
    acc[1:-1] = (com[2:] - 2 * com[1:-1] + com[:-2]) / dt**2
    zmp = com - walk.com_height / GRAVITY * acc
    assert walk.com_height == pytest.approx(0.295, abs=1e-6)
    assert np.abs(zmp - walk.zmp_ref)[1:-1].max() < 5e-3
    assert np.abs(walk.zmp - walk.zmp_ref).max() < 2e-3
    a = Assumptions()
    for lifted, stance in ((walk.right, walk.left), (walk.left, walk.right)):
        single = lifted[:, 2] > 0
        off = np.abs(zmp[single] - stance[single, :2])
        assert np.all(off[:, 0] < a.foot_length / 2 - 0.03)
        assert np.all(off[:, 1] < a.foot_width / 2 - 0.03)
    assert walk.com[0] == pytest.approx(COM_OFFSET, abs=1e-6)


def pose_with_soles(left: list[float], right: list[float]) -> dict[str, float]:
    """The stand pose with its legs solved for other soles (mm from each hip)."""
    pose = dict(STAND_POSE)
    for side, sole, columns in (("left", left, MOTOR_COLUMNS[:6]),
                                ("right", right, MOTOR_COLUMNS[6:12])):
        angles = leg_motor_angles(leg_inverse(np.array([sole])), side)  # type: ignore[arg-type]
        pose.update(zip(columns, (float(v) for v in angles[0]), strict=True))
    return pose


def test_a_stand_pose_with_the_left_foot_behind_steps_off_with_the_left() -> None:
    pose = pose_with_soles([-20.0, 2.0, -295.0], [20.0, 17.0, -295.0])
    plan = plan_zmp_walk(ZmpWalkParameters(stand_pose=pose, steps=2))
    moved = np.abs(np.diff(plan.footsteps, axis=0)).sum(axis=2) > 0
    assert list(np.argmax(moved, axis=1)) == [0, 1]
    assert plan.motors[0] == pytest.approx([pose[c] for c in MOTOR_COLUMNS], abs=0.01)


def test_a_walking_width_of_its_own_returns_to_the_stand_poses() -> None:
    plan = plan_zmp_walk(ZmpWalkParameters(step_width=0.07, steps=4))
    widths = plan.footsteps[:, 0, 1] - plan.footsteps[:, 1, 1]
    assert widths == pytest.approx([0.085, 0.0775, 0.07, 0.0775, 0.085], abs=1e-5)


# -- refusals --------------------------------------------------------------------------------

@pytest.mark.parametrize(("changes", "name"), [
    ({"steps": 9}, "steps 9: odd"),
    ({"steps": 0}, "steps"),
    ({"steps": 2.0}, "steps"),
    ({"step_length": -0.01}, "step_length"),
    ({"step_width": 0.0}, "step_width"),
    ({"step_time": 0.0}, "step_time"),
    ({"double_support": 1.0}, "double_support"),
    ({"double_support": 0.0}, "double_support"),
    ({"foot_lift": float("nan")}, "foot_lift"),
    ({"hip_roll_compensation": float("inf")}, "hip_roll_compensation"),
    ({"com_height": -0.3}, "com_height"),
    ({"com_offset": (0.0,)}, "com_offset"),
    ({"com_offset": (0.0, float("nan"))}, "com_offset"),
    ({"rate": 0.0}, "rate"),
    ({"preview": -1.0}, "preview"),
    ({"control_dt": 0.2}, "control_dt"),
    ({"settle": -1.0}, "settle"),
    ({"hip_width": 0.0}, "hip_width"),
    ({"max_joint_speed": 0.0}, "max_joint_speed"),
    ({"stand_pose": {"m11": 0.0}}, "stand_pose has no angle for motor m12"),
    ({"stand_pose": {**STAND_POSE, "m14": float("nan")}}, "stand_pose\\['m14'\\]"),
])
def test_bad_parameters_are_refused_by_name(changes: dict[str, Any], name: str) -> None:
    with pytest.raises(GaitValueError, match=name) as error:
        ZmpWalkParameters(**changes)
    assert "\n" not in str(error.value)


def test_a_stand_pose_without_flat_feet_or_on_two_levels_is_refused() -> None:
    bent = {**STAND_POSE, "m15": STAND_POSE["m15"] + 5.0}
    with pytest.raises(GaitValueError, match="stand_pose: the left foot is not flat"):
        plan_zmp_walk(ZmpWalkParameters(stand_pose=bent))
    uneven = pose_with_soles([20.0, 2.0, -290.0], [-20.0, 17.0, -295.0])
    with pytest.raises(GaitValueError, match="stand_pose: the soles are not on one level"):
        plan_zmp_walk(ZmpWalkParameters(stand_pose=uneven))


def test_a_step_too_fast_for_the_servos_names_step_time() -> None:
    with pytest.raises(GaitValueError, match=r"^step_time 1\.5 s: row \d+ .* turns m24 "
                       r"\(right knee\) at 1\.\d\d rad/s .* max_joint_speed 1 rad/s") as error:
        plan_zmp_walk(ZmpWalkParameters(step_time=1.5))
    assert "\n" not in str(error.value)


def test_a_lift_too_fast_names_foot_lift_not_the_default_step_time() -> None:
    with pytest.raises(GaitValueError, match=r"^foot_lift 0\.05 m: "):
        plan_zmp_walk(ZmpWalkParameters(foot_lift=0.05))


def test_a_step_out_of_reach_names_step_length() -> None:
    with pytest.raises(GaitValueError, match=r"^step_length 0\.2 m: row \d+ .*the right sole "
                       r"at .* out of reach: the hip-to-ankle distance"):
        plan_zmp_walk(ZmpWalkParameters(step_length=0.2))


def test_a_row_beyond_the_limits_names_the_motor_and_the_limit(
        limits: dict[str, tuple[float, float]]) -> None:
    tight = {**limits, "m24": (-150.0, 50.0)}
    with pytest.raises(GaitValueError, match=r"turns m24 \(right knee\) to 5\d\.\d\d degrees, "
                       r"beyond its limit 50\.00 \(range \[-150\.00, 50\.00\]\)"):
        generate_zmp_walk(limits=tight)
    # a changed parameter whose default would keep it within is the one named
    with pytest.raises(GaitValueError, match=r"^foot_lift 0\.03 m: .* m24"):
        generate_zmp_walk(ZmpWalkParameters(foot_lift=0.03), limits={
            **limits, "m24": (-150.0, float(generate_zmp_walk().angles[:, 9].max()) + 0.1)})


def test_parameters_are_values() -> None:
    params = ZmpWalkParameters(com_offset=[0.01, 0.0])  # type: ignore[arg-type]
    assert params.com_offset == (0.01, 0.0)
    assert params == dataclasses.replace(params)
    assert hash(params) == hash(dataclasses.replace(params))
    assert math.isclose(ZmpWalkParameters().duration, 2 * 1.0 + 10 * 2.5 + 0.5)
