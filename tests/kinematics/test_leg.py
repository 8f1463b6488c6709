"""The Armstrong leg: forward kinematics through seed 001's DH chain (Table 5.2), the
closed-form inverse kinematics with a flat foot, and the motor columns of Table 4.2."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from servolab.kinematics.dh import DHLink, chain_transform, dh_transform
from servolab.kinematics.leg import (
    ARMSTRONG_LEG,
    LegGeometry,
    foot_position,
    leg_inverse,
    leg_motor_angles,
    leg_transform,
    reachable,
)

Z_GAIT = -295.0  # d_leg - d_step = 310 - 15 (Appendix D, Table 5.1 of seed 001)


def printed(value: float, text: str) -> bool:
    """``value`` shows as ``text`` when rounded to as many decimals as ``text`` prints."""
    decimals = len(text.split(".")[1]) if "." in text else 0
    return f"{value + 0.0:.{decimals}f}" == text


def degrees_of(x: float, y: float) -> np.ndarray:
    return np.degrees(leg_inverse([x, y, Z_GAIT]))


@pytest.mark.parametrize(("x", "y", "expected"), [
    # seeds/README.md "Facts worked out": the four angles behind Table 4.2 of seed 001
    (20.0, 2.0, ("0.61939", "27.666", "42.992", "15.326")),
    (-20.0, 17.0, ("5.2503", "14.746", "41.781", "27.035")),
    # seeds/README.md: left foot (20, 22) gives Table 4.3's second row
    (20.0, 22.0, ("6.7817", "26.595", "40.935", "14.34")),
])
def test_readme_angle_sets(x: float, y: float, expected: tuple[str, ...]) -> None:
    yaw, roll, hip, knee, ankle, ankle_roll = degrees_of(x, y)
    assert yaw == 0.0
    assert ankle_roll == pytest.approx(roll)
    for value, text in zip((roll, hip, knee, ankle), expected, strict=True):
        assert f"{value:.5g}" == text


def test_table_4_2_stand_pose_to_every_printed_digit() -> None:
    """Table 4.2 of seed 001 (left foot x = 20, y = 2; right foot x = -20, y = 17, README),
    read per joint function: hip (x, y, z) = (m?2, m?3, m?1), knee m?4, ankle (m?5, m?6)."""
    left = leg_motor_angles(leg_inverse([20.0, 2.0, Z_GAIT]), "left")
    right = leg_motor_angles(leg_inverse([-20.0, 17.0, Z_GAIT]), "right")
    table = {  # motor index (0 = m?1) -> printed cell
        "left": {1: "-27.666", 2: "0.619", 0: "0", 3: "-42.992", 4: "15.326", 5: "-0.619"},
        "right": {1: "-14.746", 2: "5.2503", 0: "0", 3: "41.781", 4: "-27.035", 5: "-5.250"},
    }
    for side, motors in (("left", left), ("right", right)):
        for index, text in table[side].items():
            assert printed(float(motors[index]), text), (side, index, motors[index], text)


def test_zero_angles_give_the_straight_leg() -> None:
    """Table 5.2 at q = 0: the sole d_leg = 310 mm straight below the base (Appendix D)."""
    assert foot_position(np.zeros(6)) == pytest.approx([0.0, 0.0, -310.0], abs=1e-12)
    assert ARMSTRONG_LEG.length == 310.0


def test_joint_senses_match_the_module_conventions() -> None:
    """Positive hip pitch swings the foot forward, positive roll to +y, positive yaw turns
    counter-clockwise (the conventions leg_inverse returns angles in)."""
    pitch = foot_position([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    roll = foot_position([0.0, 0.1, 0.0, 0.0, 0.0, 0.0])
    assert pitch[0] > 0 and roll[1] > 0
    yawed = foot_position([math.pi / 2, 0.0, 0.1, 0.0, 0.0, 0.0])
    assert yawed[:2] == pytest.approx([0.0, pitch[0]], abs=1e-9)


coordinate = st.floats(-200.0, 200.0, allow_nan=False)
height = st.floats(0.001, 200.0, allow_nan=False)
yaw = st.floats(-math.pi, math.pi, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(x=coordinate, y=coordinate, h=height, psi=yaw)
def test_forward_of_inverse_is_identity(x: float, y: float, h: float, psi: float) -> None:
    """FK(IK(p)) = p within 1e-6 mm over the reachable workspace, foot kept flat."""
    target = np.array([x, y, -(h + ARMSTRONG_LEG.l1 + ARMSTRONG_LEG.l4)])
    assume(bool(reachable(target, yaw=psi)[0]))
    joints = leg_inverse(target, yaw=psi)
    transform = leg_transform(joints)
    assert np.max(np.abs(transform[:3, 3] - target)) < 1e-6
    flat = leg_transform(np.array([psi, 0, 0, 0, 0, 0]))[:3, :3]
    assert np.max(np.abs(transform[:3, :3] - flat)) < 1e-9


def test_inverse_is_vectorised() -> None:
    rng = np.random.default_rng(1)
    targets = rng.uniform([-60, -60, -360], [60, 60, -200], size=(5000, 3))
    targets = targets[reachable(targets)]
    joints = leg_inverse(targets)
    assert joints.shape == (len(targets), 6)
    assert np.max(np.abs(foot_position(joints) - targets)) < 1e-6


def test_unreachable_target_is_named_with_its_index() -> None:
    targets = [[0.0, 0.0, Z_GAIT], [20.0, 2.0, Z_GAIT], [300.0, 0.0, Z_GAIT], [0, 0, -900.0]]
    with pytest.raises(ValueError, match=r"foot position 2 \(300, 0, -295\) mm .*exceeds"):
        leg_inverse(targets)
    with pytest.raises(ValueError, match=r"foot position 0 \(0, 0, -50\) mm .*above"):
        leg_inverse([[0.0, 0.0, -50.0]])
    with pytest.raises(ValueError, match="foot position 0"):
        leg_inverse([[math.nan, 0.0, Z_GAIT]])


def test_stretched_leg_is_reachable() -> None:
    assert leg_inverse([0.0, 0.0, -310.0]) == pytest.approx(np.zeros(6), abs=1e-6)


def test_bad_inputs() -> None:
    with pytest.raises(ValueError, match="side"):
        leg_motor_angles(np.zeros(6), "middle")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="shape"):
        leg_inverse(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="l2"):
        LegGeometry(l2=0.0)


def test_dh_helpers() -> None:
    assert dh_transform(np.zeros((3, 2)), 1.0, 2.0, 0.0).shape == (3, 2, 4, 4)
    link = DHLink(0.0, 0.0, 1.0, 0.0)
    assert chain_transform([link, link], [[0.0, math.pi / 2]])[0, :2, 3] == pytest.approx(
        [1.0, 1.0])
    with pytest.raises(ValueError, match="shape"):
        chain_transform([link], np.zeros((2, 2)))
