"""Leader joints to follower goals: by name, in the follower's order, within its limits."""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel.models import model
from servolab.robots.dynamixel_system import DynamixelJoint
from servolab.robots.errors import RobotValueError
from servolab.robots.teleop.mapping import JointMap

XM = model("XM430-W350")


def joint(name: str, lower: float | None = -1.0, upper: float | None = 1.0) -> DynamixelJoint:
    return DynamixelJoint(name, 1, XM, lower, upper)


def test_joints_are_copied_by_name_in_the_followers_order() -> None:
    leader = [joint("wrist"), joint("shoulder"), joint("elbow")]
    follower = [joint("shoulder"), joint("elbow"), joint("wrist")]
    mapping = JointMap(leader, follower)
    assert mapping.follower == ("shoulder", "elbow", "wrist")
    assert mapping([0.3, 0.1, 0.2]) == [0.1, 0.2, 0.3]
    assert mapping.unused == ()


def test_goals_stay_within_the_followers_limits() -> None:
    mapping = JointMap([joint("a", -3.0, 3.0), joint("b", None, None)],
                       [joint("a", -0.5, 1.5), joint("b", None, None)])
    assert mapping([2.0, -2.9]) == [1.5, -2.9]     # a continuous joint has none
    assert mapping([-1.0, 7.0]) == [-0.5, 7.0]
    assert mapping([0.25, math.pi]) == [0.25, math.pi]


def test_a_leader_joint_no_follower_joint_copies_is_left_out() -> None:
    mapping = JointMap([joint("a"), joint("spare"), joint("b")], [joint("b"), joint("a")])
    assert mapping.unused == ("spare",)
    assert mapping([0.1, 0.9, 0.2]) == [0.2, 0.1]


def test_a_follower_joint_without_a_leader_joint_is_refused() -> None:
    with pytest.raises(RobotValueError, match=(
            r"^the follower's joints gripper, wrist have no leader joint of that name \(the "
            r"leader has shoulder\): teleoperation copies joints by name$")):
        JointMap([joint("shoulder")], [joint("shoulder"), joint("gripper"), joint("wrist")])
