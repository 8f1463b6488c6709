"""The OpenMANIPULATOR-X in MuJoCo under gravity: on its table with the boxes (``--world robot``,
the plug-in's world) and bare (``--world mujoco``, any URDF with masses). Its five emulated
servos' firmware drives the joints; the physics loads them, and their Present Current says so.

Facts from sources other than this code: an XM430-W350's torque constant is its stall torque
over its stall current, 4.1 N m / 2.3 A at 12.0 V (e-Manual, "Specifications"), its Present
Current 2.69 mA a unit (e-Manual, Present Current(126)); MuJoCo's ``qfrc_bias`` is the
generalised force that holds the model still against gravity (and Coriolis, 0 at rest)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from servolab.rclpy.action.server import STATUS_SUCCEEDED
from servolab.robots.open_manipulator_x.world import BOXES, box_positions

from .conftest import ARM, Arm, bring_up

pytest.importorskip("mujoco")

#: a pose whose shoulder, elbow and wrist gravity loads (rad)
POSE = (0.5, -0.6, 0.4, 0.6)
XM430_TICK = 0.0015339807878856412   # 2 pi / 4096 rad (e-Manual, 0.088 degree)
#: N m a unit of Present Current: 2.69 mA x 4.1 N m / 2.3 A
EFFORT_UNIT = 0.00269 * 4.1 / 2.3


@pytest.fixture(scope="module")
def table() -> Iterator[Arm]:
    system = bring_up("robot")
    try:
        yield Arm(system)
    finally:
        system.close()


def test_the_boxes_lie_on_the_table_and_the_arm_holds_itself_up(table: Arm) -> None:
    table.system.context.spin_for(0.5)
    held = [table.horn(j) for j in ARM]
    table.system.context.spin_for(0.5)
    found = box_positions(table.system.world)
    for box in BOXES:
        x, y, z = found[box.name]
        assert (x, y) == pytest.approx((box.x, box.y), abs=1e-4), box.name
        # resting on the table's top (z = 0), sunk no more than MuJoCo's soft contact lets it
        assert z == pytest.approx(box.edge / 2, abs=3e-4), box.name
    # upright at the start (it leans a little before the controllers turn the torque on),
    # then held still, to a tick or two, against gravity
    assert held == pytest.approx([0.0] * 4, abs=0.05)
    assert [table.horn(j) for j in ARM] == pytest.approx(held, abs=2 * XM430_TICK)


def _loads_follow_gravity(arm: Arm) -> None:
    """Each arm joint's effort (the hardware's: Present Current x the torque constant) is the
    torque MuJoCo needs to hold it still, and the shoulder's and elbow's is well off zero."""
    world = arm.system.world
    for joint in ARM:
        gravity = float(world.data.qfrc_bias[world.model.joint(joint).dofadr[0]])
        effort = arm.state(joint, "effort")
        assert effort == pytest.approx(arm.current(joint) * EFFORT_UNIT)
        assert effort == pytest.approx(gravity, rel=0.1, abs=2 * EFFORT_UNIT), joint
    for joint in ("joint2", "joint3"):
        assert abs(arm.current(joint)) >= 10, f"{joint}: gravity loads it"


def test_a_trajectory_goal_succeeds_under_gravity(table: Arm) -> None:
    result = table.follow([(1.0, (0.2, -0.3, 0.2, 0.3)), (2.0, POSE)], 3.0)
    assert result.status == STATUS_SUCCEEDED
    assert result.result.error_string == "Goal successfully reached!"
    assert [table.horn(j) for j in ARM] == pytest.approx(POSE, abs=0.02)
    _loads_follow_gravity(table)


@pytest.mark.slow
def test_a_gripper_goal_opens_and_closes_both_fingers(table: Arm) -> None:
    world = table.system.world
    for position in (0.015, -0.008):
        result = table.grip(position, 2.0)
        assert result.status == STATUS_SUCCEEDED and result.result.reached_goal
        fingers = [float(world.data.qpos[world.model.joint(name).qposadr[0]])
                   for name in ("gripper_left_joint", "gripper_right_joint")]
        # the left finger is the servo's (through its pinion), the right its <mimic>
        assert fingers == pytest.approx([position, position], abs=2e-4)
        assert table.state("gripper_left_joint") == pytest.approx(position, abs=2e-4)


@pytest.mark.slow
def test_the_bare_urdf_in_mujoco_moves_too() -> None:
    """``--world mujoco``: servolab's own MuJoCo world of any URDF with masses."""
    system = bring_up("mujoco")
    try:
        arm = Arm(system)
        result = arm.follow([(1.5, POSE)], 2.5)
        assert result.status == STATUS_SUCCEEDED
        _loads_follow_gravity(arm)
        assert arm.grip(0.01, 1.5).result.reached_goal
        assert arm.state("gripper_left_joint") == pytest.approx(0.01, abs=2e-4)
    finally:
        system.close()
