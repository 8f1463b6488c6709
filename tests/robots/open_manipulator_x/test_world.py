"""The pieces of the OpenMANIPULATOR-X's MuJoCo world that need no servo: the table and boxes
added to the arm's MJCF, and how a block's joint becomes the physical horn's transmission."""

from __future__ import annotations

import pytest

from servolab.dynamixel.models import model
from servolab.robots.description import Description, mjcf
from servolab.robots.dynamixel_system import DynamixelJoint
from servolab.robots.open_manipulator_x import MODEL, URDF, urdf_text
from servolab.robots.open_manipulator_x.world import BOXES, TABLE_SIZE, table_mjcf
from servolab.robots.urdf_world import Transmission

from .conftest import GRIPPER_SCALE

mujoco = pytest.importorskip("mujoco")


def test_the_boxes_rest_on_the_table_beside_the_arm() -> None:
    """The arm's own MJCF (no motors: it hangs limp, which does not matter here) with the
    table and the boxes: a second of MuJoCo later each box lies where it was put."""
    arm = mjcf(Description.from_urdf(urdf_text(), URDF.name), "firmware")
    m = mujoco.MjModel.from_xml_string(table_mjcf(arm))
    d = mujoco.MjData(m)
    assert m.geom("table").size[:2] == pytest.approx([s / 2 for s in TABLE_SIZE])
    for _ in range(int(1.0 / m.opt.timestep)):
        mujoco.mj_step(m, d)
    for box in BOXES:
        body = m.body(box.name)
        assert m.body_mass[body.id] == pytest.approx(box.mass)
        assert d.xpos[body.id] == pytest.approx([box.x, box.y, box.edge / 2], abs=3e-4)
        assert d.xmat[body.id][8] == pytest.approx(1.0, abs=1e-6)    # flat on a face


def _joint(scale: float, drive_mode: int, offset: float = 0.0) -> DynamixelJoint:
    return DynamixelJoint("gripper_left_joint", 15, model(MODEL), -0.011, 0.02, scale, offset,
                          (("operating_mode", 5), ("drive_mode", drive_mode)))


def test_the_gripper_horn_turns_backwards_to_open() -> None:
    """The block reads the finger as +0.01149 m a radian of the firmware's count, and writes
    Drive Mode 5: that count is the physical horn's backwards, so the horn turns -87 rad a
    metre of opening; without the reverse bit it would turn +87."""
    reversed_ = Transmission.of(_joint(GRIPPER_SCALE, 5))
    assert (reversed_.direction, reversed_.offset) == (-1, 0.0)
    assert reversed_.gear_ratio == pytest.approx(1 / GRIPPER_SCALE)
    assert Transmission.of(_joint(GRIPPER_SCALE, 4)).direction == 1
    assert Transmission.of(_joint(-GRIPPER_SCALE, 5)).direction == 1
    # an offset: joint = scale x count + offset, so at joint 0 the count is -offset / scale
    shifted = Transmission.of(_joint(0.5, 0, offset=0.1))
    assert (shifted.offset, shifted.direction, shifted.gear_ratio) == (-0.2, 1, 2.0)
