"""Kinematics of any URDF chain (servolab.kinematics.chain) on the OpenMANIPULATOR-X's geometry
(tests/kinematics/data/open_manipulator_x_geometry.urdf, from ROBOTIS's published URDF): FK
against the URDF's joint origins composed here with scipy's rotations, the Jacobian against
finite differences, FK(IK(p)) over 1000 reachable targets, the closed-form IK
(servolab.kinematics.yaw_pitch_arm) against the numeric one, and refusals in one line."""

from __future__ import annotations

import functools
import math
import time
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import mujoco
import numpy as np
import pytest
from scipy.optimize import lsq_linear  # type: ignore[import-untyped]
from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

from servolab.kinematics.chain import Chain, UnreachableError
from servolab.kinematics.errors import KinematicsValueError
from servolab.kinematics.least_squares import bounded_step
from servolab.kinematics.yaw_pitch_arm import YawPitchArm
from servolab.robots.description import Description

URDF = Path(__file__).parent / "data" / "open_manipulator_x_geometry.urdf"
BASE, TIP = "link1", "end_effector_link"


@pytest.fixture(scope="module")
def description() -> Description:
    return Description.from_urdf(URDF.read_text(), str(URDF))


@pytest.fixture(scope="module")
def mjcf(description: Description) -> str:
    return description.mjcf("firmware")


@pytest.fixture(scope="module")
def chain(mjcf: str) -> Chain:
    return Chain(mjcf, BASE, TIP)


# -- an independent forward kinematics: the URDF's joints composed with scipy -----------------

def numbers(joint: ET.Element, tag: str, attribute: str, default: str) -> np.ndarray:
    """The numbers of ``<tag attribute=...>`` in ``joint`` (the URDF's default if absent)."""
    node = joint.find(tag)
    text = default if node is None else node.get(attribute, default)
    return np.array([float(v) for v in text.split()])


def link_of(joint: ET.Element, tag: str) -> str:
    node = joint.find(tag)
    assert node is not None
    return node.get("link", "")


def urdf_joints(base: str, tip: str) -> list[ET.Element]:
    """The URDF's <joint> elements from ``base`` down to ``tip``, read here with ElementTree."""
    by_child = {link_of(j, "child"): j for j in ET.parse(URDF).getroot().findall("joint")}
    path = []
    link = tip
    while link != base:
        path.append(by_child[link])
        link = link_of(by_child[link], "parent")
    return path[::-1]


def transform(rotation: Rotation, translation: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[:3, :3] = rotation.as_matrix()
    out[:3, 3] = translation
    return out


def urdf_forward(base: str, tip: str, q: np.ndarray) -> np.ndarray:
    """origin (xyz, then rpy about the fixed axes) x motion about the joint's axis, joint by
    joint, as the URDF specification composes them."""
    pose = np.eye(4)
    movable = iter(q)
    for joint in urdf_joints(base, tip):
        rpy = numbers(joint, "origin", "rpy", "0 0 0")
        pose = pose @ transform(Rotation.from_euler("xyz", rpy),
                                numbers(joint, "origin", "xyz", "0 0 0"))
        kind = joint.get("type")
        if kind == "fixed":
            continue
        axis = numbers(joint, "axis", "xyz", "1 0 0")
        value = next(movable)
        if kind == "prismatic":
            pose = pose @ transform(Rotation.identity(), axis * value)
        else:
            pose = pose @ transform(Rotation.from_rotvec(axis * value), np.zeros(3))
    return pose


@functools.cache
def yaw_axis_xy() -> np.ndarray:
    """joint1's origin in link1: where the pitch plane turns."""
    return numbers(urdf_joints(BASE, "link2")[0], "origin", "xyz", "0 0 0")[:2]


def pitch_of(pose: np.ndarray) -> float:
    """The tool x axis's angle below the horizontal direction from the yaw axis to the tool."""
    dx, dy = pose[:2, 3] - yaw_axis_xy()
    azimuth = math.atan2(dy, dx)
    x_axis = pose[:3, 0]
    return math.atan2(-x_axis[2], x_axis[0] * math.cos(azimuth) + x_axis[1] * math.sin(azimuth))


def random_q(chain: Chain, count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(chain.lower, chain.upper, size=(count, chain.n))


def one_line(error: pytest.ExceptionInfo[BaseException]) -> str:
    text = str(error.value)
    assert "\n" not in text and text
    return text


# -- the chain ----------------------------------------------------------------------------------

def test_the_chain_has_the_urdf_joints_and_limits(chain: Chain) -> None:
    assert chain.joint_names == ("joint1", "joint2", "joint3", "joint4")
    assert chain.kinds == ("hinge",) * 4
    np.testing.assert_allclose(chain.lower, [-math.pi, -1.5, -1.5, -1.7], atol=1e-10)
    np.testing.assert_allclose(chain.upper, [math.pi, 1.5, 1.4, 1.97], atol=1e-10)


def test_forward_kinematics_matches_the_urdf_composed_with_scipy(chain: Chain) -> None:
    qs = random_q(chain, 200, seed=1)
    poses = chain.forward(qs)
    assert poses.shape == (200, 4, 4)
    for q, pose in zip(qs, poses, strict=True):
        np.testing.assert_allclose(pose, urdf_forward(BASE, TIP, q), atol=1e-12)
    # at zero: straight out along x, 0.012 + 0.024 + 0.124 + 0.126 m, 0.0595 + 0.128 m up
    np.testing.assert_allclose(chain.forward(np.zeros(4))[:3, 3], [0.286, 0.0, 0.1875],
                               atol=1e-12)


def test_any_base_and_any_tip_of_the_tree(mjcf: str, description: Description) -> None:
    q = random_q(Chain(mjcf, BASE, TIP), 1, seed=2)[0]
    from_world = Chain(mjcf, "world", TIP)
    np.testing.assert_allclose(from_world.forward(q), urdf_forward("world", TIP, q), atol=1e-12)
    upper = Chain(mjcf, "link2", TIP)              # a chain that starts above the root's joint
    assert upper.joint_names == ("joint2", "joint3", "joint4")
    np.testing.assert_allclose(upper.forward(q[1:]), urdf_forward("link2", TIP, q[1:]),
                               atol=1e-12)
    finger = Chain(mjcf, BASE, "gripper_left_link")     # a slide at the end
    assert finger.kinds == ("hinge",) * 4 + ("slide",)
    qf = np.append(q, 0.015)
    np.testing.assert_allclose(finger.forward(qf), urdf_forward(BASE, "gripper_left_link", qf),
                               atol=1e-12)
    # a tool frame as an offset from a link, and a frame-only link (an MJCF site)
    offset = Chain(mjcf, BASE, "link5", tip_offset=[0.126, 0.0, 0.0])
    np.testing.assert_allclose(offset.forward(q), urdf_forward(BASE, TIP, q), atol=1e-12)
    bare = replace(description, links=tuple(replace(k, shapes=()) if k.name == TIP else k
                                            for k in description.links))
    as_site = bare.mjcf("firmware")
    assert f'<site name="{TIP}"' in as_site
    np.testing.assert_allclose(Chain(as_site, BASE, TIP).forward(q),
                               urdf_forward(BASE, TIP, q), atol=1e-12)
    compiled = mujoco.MjModel.from_xml_string(mjcf)
    np.testing.assert_allclose(Chain(compiled, BASE, TIP).forward(q),
                               urdf_forward(BASE, TIP, q), atol=1e-12)


def test_the_jacobian_matches_finite_differences(chain: Chain) -> None:
    step = 1e-6
    for q in random_q(chain, 50, seed=3):
        jac = chain.jacobian(q)
        assert jac.shape == (6, 4)
        numeric = np.zeros((6, 4))
        for i in range(4):
            dq = np.zeros(4)
            dq[i] = step
            ahead, behind = chain.forward(q + dq), chain.forward(q - dq)
            numeric[:3, i] = (ahead[:3, 3] - behind[:3, 3]) / (2 * step)
            # the angular velocity in the base frame: log(R(q + h) R(q - h)ᵀ) / 2h
            turn = Rotation.from_matrix(ahead[:3, :3] @ behind[:3, :3].T)
            numeric[3:, i] = turn.as_rotvec() / (2 * step)
        np.testing.assert_allclose(jac, numeric, atol=1e-8)


def test_the_axes_are_the_urdf_joints(chain: Chain) -> None:
    anchors, axes = chain.axes(np.zeros(4))
    np.testing.assert_allclose(anchors, [[0.012, 0, 0], [0.012, 0, 0.0595],
                                         [0.036, 0, 0.1875], [0.16, 0, 0.1875]], atol=1e-12)
    np.testing.assert_allclose(axes, [[0, 0, 1], [0, 1, 0], [0, 1, 0], [0, 1, 0]], atol=1e-12)


# -- inverse kinematics -------------------------------------------------------------------------

@pytest.mark.slow
def test_fk_of_ik_is_within_1_mm_and_1_degree_over_1000_reachable_targets(chain: Chain) -> None:
    """Targets are FK of 1000 seeded random in-limit joint positions (position + pitch: 4
    constraints for 4 joints); each solved from the middle of the limits, then seeded
    restarts. Measured: every target met within the solver's own tolerance (worst 0.010 mm,
    0.006°), 1.6 starts a target on average; 3.5-5.6 s for the 1000 on a two-core machine
    busy with other work (3.5-5.6 ms a target; printed with ``pytest -s``)."""
    qs = random_q(chain, 1000, seed=47)
    poses = chain.forward(qs)
    pitches = [pitch_of(pose) for pose in poses]
    began = time.perf_counter()
    solutions = [chain.solve_position(pose[:3, 3], pitch=pitch)
                 for pose, pitch in zip(poses, pitches, strict=True)]
    elapsed = time.perf_counter() - began
    reached = chain.forward(np.array([s.q for s in solutions]))
    position = np.linalg.norm(reached[:, :3, 3] - poses[:, :3, 3], axis=1)
    pitch = np.array([abs(math.remainder(pitch_of(r) - p, 2 * math.pi))
                      for r, p in zip(reached, pitches, strict=True)])
    print(f"1000 targets in {elapsed:.2f} s: worst {position.max() * 1000:.4f} mm, "
          f"{math.degrees(pitch.max()):.4f}°, {np.mean([s.starts for s in solutions]):.2f} "
          "starts a target")
    assert position.max() < 1e-3
    assert math.degrees(pitch.max()) < 1.0
    assert all(chain.within_limits(s.q) for s in solutions)
    assert max(s.position_error for s in solutions) <= 1e-5
    assert elapsed < 60.0


def test_position_only_and_whole_poses(chain: Chain) -> None:
    qs = random_q(chain, 100, seed=5)
    for q, pose in zip(qs, chain.forward(qs), strict=True):
        found = chain.solve_position(pose[:3, 3])
        assert np.linalg.norm(chain.forward(found.q)[:3, 3] - pose[:3, 3]) < 1e-5
        assert found.angle_error == 0.0
        whole = chain.solve(pose, np.ones(6), q0=q + 0.2)
        reached = chain.forward(whole.q)
        np.testing.assert_allclose(reached, pose, atol=2e-4)


def test_a_tilted_base_and_weights_on_some_components(chain: Chain) -> None:
    """Errors and weights are in the base's frame: the arm mounted tilted on a world link,
    solved from the world; and a weight of 0 frees its component."""
    text = URDF.read_text().replace('<origin xyz="0 0 0" rpy="0 0 0"/>\n    <parent link="world"/>',
                                    '<origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.5"/>\n'
                                    '    <parent link="world"/>')
    assert text != URDF.read_text()
    mounted = Chain(Description.from_urdf(text).mjcf("firmware"), "world", TIP)
    mount = transform(Rotation.from_euler("xyz", [0.3, -0.2, 0.5]), np.array([0.1, 0.2, 0.3]))
    for q in random_q(chain, 20, seed=10):
        pose = mounted.forward(q)
        np.testing.assert_allclose(pose, mount @ chain.forward(q), atol=1e-12)
        found = mounted.solve(pose, np.ones(6), q0=q + 0.1)
        np.testing.assert_allclose(mounted.forward(found.q), pose, atol=1e-4)
        above = pose.copy()
        above[2, 3] += 5.0                       # out of reach in z, which is left free
        found = mounted.solve(above, [1, 1, 0, 0, 0, 0])
        reached = mounted.forward(found.q)
        assert np.linalg.norm(reached[:2, 3] - pose[:2, 3]) < 1e-5
        assert found.angle_error == 0.0


def test_a_seed_near_the_answer_finds_it_in_a_few_steps(chain: Chain) -> None:
    q = np.array([0.3, 0.4, -0.2, 0.6])
    pose = chain.forward(q)
    found = chain.solve_position(pose[:3, 3], q + 0.05, pitch=pitch_of(pose))
    np.testing.assert_allclose(found.q, q, atol=1e-3)
    assert found.starts == 1 and found.iterations <= 6


# -- the closed form ----------------------------------------------------------------------------

def test_the_closed_form_takes_its_links_from_the_chain(chain: Chain) -> None:
    arm = YawPitchArm.from_chain(chain)
    assert arm.yaw_axis == pytest.approx((0.012, 0.0))
    assert arm.shoulder == pytest.approx((0.0, 0.0595))
    assert arm.upper_arm == pytest.approx((0.024, 0.128))
    assert arm.forearm == pytest.approx((0.124, 0.0))
    assert arm.hand == pytest.approx((0.126, 0.0))
    assert arm.signs == (1.0, 1.0, 1.0, 1.0)


def wrapped_distance(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(np.remainder(a - b + math.pi, 2 * math.pi) - math.pi).max())


def test_closed_form_and_numeric_solutions_agree(chain: Chain) -> None:
    """Every closed-form solution reaches the target through MuJoCo's FK; the arm's own joint
    positions are among them; and the numeric solution is one of them: its joint angles are
    those of the closed-form solution of its branch (yaw side and elbow). Solved here to 1e-9 m
    and 1e-8 rad: at the default 1e-5 m an elbow near straight is only known to some 0.006 rad
    (the position moves with the square of the bend there), though its FK is met all the
    same."""
    arm = YawPitchArm.from_chain(chain)
    qs = random_q(chain, 300, seed=6)
    worst = 0.0
    for q, pose in zip(qs, chain.forward(qs), strict=True):
        pitch = pitch_of(pose)
        exact = arm.solve(pose[:3, 3], pitch)
        assert 1 <= len(exact) <= 4
        assert min(wrapped_distance(s, q) for s in exact) < 1e-9
        for s in exact:
            reached = chain.forward(s)
            assert np.linalg.norm(reached[:3, 3] - pose[:3, 3]) < 1e-12
            assert abs(math.remainder(pitch_of(reached) - pitch, 2 * math.pi)) < 1e-12
        xyz, arm_pitch = arm.forward(q)
        np.testing.assert_allclose(xyz, pose[:3, 3], atol=1e-12)
        assert math.remainder(arm_pitch - pitch, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
        numeric = chain.solve_position(pose[:3, 3], pitch=pitch, position_tolerance=1e-9,
                                       angle_tolerance=1e-8).q
        worst = max(worst, min(wrapped_distance(s, numeric) for s in exact))
    print(f"numeric within {worst:.2e} rad of a closed-form solution")
    assert worst < 1e-4


def test_the_closed_form_refuses_an_arm_of_another_layout(mjcf: str) -> None:
    with pytest.raises(KinematicsValueError) as error:
        YawPitchArm.from_chain(Chain(mjcf, "link2", TIP))
    assert "not four revolute joints" in one_line(error)


# -- refusals -----------------------------------------------------------------------------------

def test_a_target_outside_the_workspace_is_refused_in_one_line(chain: Chain) -> None:
    with pytest.raises(UnreachableError) as error:
        chain.solve_position([0.5, 0.1, 0.2])
    text = one_line(error)
    assert text.startswith("position (0.500, 0.100, 0.200) m is out of reach of link1 -> "
                           "end_effector_link within its joint limits: the nearest of 16 "
                           "starts is ")
    assert text.endswith(" mm off")
    # the nearest is the arm stretched straight at it: the shoulder-to-target distance less
    # the reach (upper arm 0.024 x 0.128, forearm 0.124, hand 0.126)
    shoulder_to_target = math.hypot(math.hypot(0.5 - 0.012, 0.1), 0.2 - 0.0595)
    reach = math.hypot(0.024, 0.128) + 0.124 + 0.126
    nearest = error.value.nearest
    assert nearest.position_error == pytest.approx(shoulder_to_target - reach, abs=1e-4)
    assert chain.within_limits(nearest.q)
    assert f"starts is {(shoulder_to_target - reach) * 1000:.1f} mm off" in text
    with pytest.raises(UnreachableError) as error:
        chain.solve_position([0.2, 0.0, 0.1], pitch=math.radians(-150))
    assert "pitch -150.0° is out of reach" in one_line(error)


def test_a_target_only_beyond_the_limits_is_refused(chain: Chain) -> None:
    """Targets the arm reaches only with a joint past its limit (the closed form finds
    solutions without the limits and none within them) are refused, in one line."""
    arm = YawPitchArm.from_chain(chain)
    rng = np.random.default_rng(8)
    refused = 0
    while refused < 5:
        q = rng.uniform(chain.lower - 1.0, chain.upper + 1.0)
        if chain.within_limits(q):
            continue
        pose = chain.forward(q)
        pitch = pitch_of(pose)
        if len(arm.solve(pose[:3, 3], pitch, within_limits=False)) == 0 \
                or len(arm.solve(pose[:3, 3], pitch)) > 0:
            continue
        with pytest.raises(UnreachableError) as error:
            chain.solve_position(pose[:3, 3], pitch=pitch)
        assert "within its joint limits" in one_line(error)
        refused += 1


@pytest.mark.parametrize(("call", "message"), [
    (lambda c: c.solve_position([0.2, math.nan, 0.1]), "target_xyz must be finite"),
    (lambda c: c.solve_position([0.2, 0.1]), "target_xyz must have shape (3,), got (2,)"),
    (lambda c: c.solve_position("near"), "target_xyz must be numbers"),
    (lambda c: c.solve_position([0.2, 0.0, 0.1], pitch=math.inf), "pitch must be finite"),
    (lambda c: c.solve_position([0.2, 0.0, 0.1], [0, 0, 0]), "q0 must have shape (4,)"),
    (lambda c: c.solve_position([0.2, 0.0, 0.1], starts=0), "starts must be a whole number"),
    (lambda c: c.solve_position([0.2, 0.0, 0.1], position_tolerance=-1),
     "position_tolerance must be a number > 0"),
    (lambda c: c.solve(np.eye(3)), "target_pose must have shape (4, 4), got (3, 3)"),
    (lambda c: c.solve(np.diag([2.0, 1, 1, 1])), "target_pose's upper-left 3x3 is not a rotation"),
    (lambda c: c.solve(np.eye(4), [1, 1, 1, -1, 0, 0]), "weights must be >= 0 and not all 0"),
    (lambda c: c.solve(np.eye(4), np.zeros(6)), "weights must be >= 0 and not all 0"),
    (lambda c: c.forward([0.0, 0.1]), "q must have shape (4,) or (N, 4), got (2,)"),
    (lambda c: c.forward([0.0, 0.1, math.nan, 0.0]), "q must be finite"),
    (lambda c: c.jacobian(np.zeros((2, 4))), "q must have shape (4,), got (2, 4)"),
])
def test_bad_input_is_refused_in_one_line(chain: Chain, call: object, message: str) -> None:
    with pytest.raises(KinematicsValueError) as error:
        call(chain)  # type: ignore[operator]
    assert message in one_line(error)
    assert not isinstance(error.value, UnreachableError)


@pytest.mark.parametrize(("base", "tip", "message"), [
    (BASE, "end_efector_link", "the tip link 'end_efector_link' is not a link of the model "
                               "(did you mean 'end_effector_link'?)"),
    ("lnk1", TIP, "the base link 'lnk1' is not a link of the model (did you mean 'link1'?)"),
    ("link5", "link2", "the base link 'link5' is not above the tip link 'link2'"),
    ("link5", "gripper_right_link", "joint 'gripper_right_joint' between 'link5' and "
                                    "'gripper_right_link' follows another joint (a mimic)"),
    (TIP, TIP, "no joint moves 'end_effector_link' relative to 'end_effector_link'"),
])
def test_bad_links_are_refused_in_one_line(mjcf: str, base: str, tip: str, message: str) -> None:
    with pytest.raises(KinematicsValueError) as error:
        Chain(mjcf, base, tip)
    assert message in one_line(error)


def test_bad_models_and_offsets_are_refused_in_one_line(mjcf: str) -> None:
    with pytest.raises(KinematicsValueError) as error:
        Chain(URDF.read_text(), BASE, TIP)
    assert "this is a URDF: convert it with" in one_line(error)
    with pytest.raises(KinematicsValueError) as error:
        Chain("<mujoco><worldbody><body name='a'></worldbody></mujoco>", "world", "a")
    assert one_line(error).startswith("the MJCF does not compile: ")
    with pytest.raises(KinematicsValueError) as error:
        Chain(None, BASE, TIP)
    assert "a Chain takes an MJCF's text or a mujoco.MjModel, got NoneType" in one_line(error)
    with pytest.raises(KinematicsValueError) as error:
        Chain(mjcf, BASE, TIP, tip_offset=[0.1, 0.0])
    assert "tip_offset must have shape (4, 4), got (2,)" in one_line(error)


# -- the bounded damped step ------------------------------------------------------------------

def test_the_bounded_step_is_the_bounded_least_squares_optimum() -> None:
    """Against scipy's lsq_linear on the damped problem [J; sqrt(mu) I] step = [e; 0]."""
    rng = np.random.default_rng(9)
    for _ in range(150):
        n = int(rng.integers(2, 8))
        jac = rng.normal(size=(int(rng.integers(1, 7)), n))
        error = rng.normal(size=jac.shape[0])
        damping = float(10 ** rng.uniform(-4, 0))
        low = -rng.uniform(0, 0.5, size=n) * (rng.random(n) < 0.8)
        high = rng.uniform(0, 0.5, size=n) * (rng.random(n) < 0.8)
        low[rng.random(n) < 0.15] = -np.inf
        ours = np.array(bounded_step((jac.T @ jac).tolist(), (jac.T @ error).tolist(), damping,
                                     low.tolist(), high.tolist()))
        stacked = np.vstack((jac, math.sqrt(damping) * np.eye(n)))
        target = np.concatenate((error, np.zeros(n)))
        theirs = lsq_linear(stacked, target, bounds=(low - 1e-15, high + 1e-15),
                            tol=1e-14).x

        def cost(step: np.ndarray, a: np.ndarray = stacked, b: np.ndarray = target) -> float:
            return float(np.sum((a @ step - b) ** 2))

        assert np.all(ours >= low) and np.all(ours <= high)
        assert cost(ours) <= cost(theirs) + 1e-9
