"""A pick's plan and its judgement, without servos: the OpenMANIPULATOR-X's inverse kinematics
for the four poses of a pick, and the box on its MuJoCo table (the arm's MJCF with the table
and boxes, stepped with no motor: it hangs limp, away from the boxes) put, parked and judged.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from servolab.kinematics.chain import UnreachableError
from servolab.robots.arm.pick import (
    APPROACH_HEIGHT,
    DROP,
    HAND_OFFSET,
    HAND_YAW_DEG,
    OffTableError,
    PickJudge,
    by_hand,
    check_support,
    free_bodies,
    plan_pick,
    set_the_table,
    support_height,
)
from servolab.robots.arm.spec import ArmSpec, arm_spec

mujoco = pytest.importorskip("mujoco")

HALF = 0.0125   # the table's boxes: 25 mm cubes


@pytest.fixture(scope="module")
def spec() -> ArmSpec:
    return arm_spec("open_manipulator_x")


def test_a_pick_plans_four_poses_at_one_pitch(spec: ArmSpec) -> None:
    chain = spec.chain()
    plan = plan_pick(chain, (0.2, 0.0), (0.15, 0.12), HALF, spec.home)
    assert plan.pitch_deg == 90.0
    assert set(plan.poses) == {"above_pick", "grasp", "above_place", "release"}
    assert plan.points["grasp"] == (0.2, 0.0, HALF)
    assert plan.points["above_pick"] == (0.2, 0.0, HALF + APPROACH_HEIGHT)
    assert plan.points["release"] == (0.15, 0.12, HALF + DROP)
    for name, q in plan.poses.items():
        pose = chain.forward(np.array(q))
        assert pose[:3, 3] == pytest.approx(plan.points[name], abs=1e-4), name
        assert chain.pitch(pose) == pytest.approx(math.pi / 2, abs=1e-3), name
        assert chain.within_limits(q)
    # a place farther out than a vertical tool reaches: the whole pick at a shallower pitch
    far = plan_pick(chain, (0.15, 0.0), (0.0, -0.235), HALF, spec.home)
    assert far.pitch_deg < 90.0
    assert all(chain.pitch(chain.forward(np.array(q))) == pytest.approx(
        math.radians(far.pitch_deg), abs=1e-3) for q in far.poses.values())


def test_a_place_out_of_reach_refuses_the_pick(spec: ArmSpec) -> None:
    with pytest.raises(UnreachableError, match=r"^the place point \(0\.000, 0\.450\) m: "
                       r"position \(0\.000, 0\.450, 0\.0[0-9]+\) m, pitch 45\.0° is out of "
                       "reach of link1 -> end_effector_link"):
        plan_pick(spec.chain(), (0.2, 0.0), (0.0, 0.45), HALF, spec.home)


def _table() -> SimpleNamespace:
    from servolab.robots.description import Description, mjcf
    from servolab.robots.open_manipulator_x import URDF, urdf_text
    from servolab.robots.open_manipulator_x.world import table_mjcf

    model = mujoco.MjModel.from_xml_string(table_mjcf(mjcf(
        Description.from_urdf(urdf_text(), URDF.name), "firmware")))
    return SimpleNamespace(model=model, data=mujoco.MjData(model))


def _run(world: SimpleNamespace, seconds: float) -> None:
    for _ in range(round(seconds / world.model.opt.timestep)):
        mujoco.mj_step(world.model, world.data)


def test_the_box_is_put_by_hand_and_the_others_parked() -> None:
    world = _table()
    assert free_bodies(world) == ["box_front", "box_left", "box_right"]
    x, y, yaw = by_hand((0.15, -0.1), seed=3)
    assert math.dist((x, y), (0.15, -0.1)) <= HAND_OFFSET
    assert abs(yaw - math.atan2(-0.1, 0.15)) <= math.radians(HAND_YAW_DEG)
    assert by_hand((0.15, -0.1), seed=3) == (x, y, yaw) != by_hand((0.15, -0.1), seed=4)
    target = set_the_table(world, (x, y), yaw)
    assert (target.name, target.half_height) == ("box_front", HALF)
    _run(world, 1.0)
    assert target.position() == pytest.approx((x, y, HALF), abs=3e-4)
    assert target.upright() == pytest.approx(1.0, abs=1e-6)
    for name in ("box_left", "box_right"):   # held a metre below the table, touching nothing
        assert world.data.xpos[world.model.body(name).id][2] == pytest.approx(-1.0, abs=1e-6)


def test_the_table_is_found_under_a_point_and_nowhere_else() -> None:
    """The OpenMANIPULATOR-X's table: 0.6 x 0.8 m, its top at the base's z = 0, centred
    0.15 m in front of it (plug-in's world.py)."""
    world = _table()
    assert support_height(world, 0.2, 0.0) == pytest.approx(0.0, abs=1e-9)
    assert support_height(world, 0.44, -0.39) == pytest.approx(0.0, abs=1e-9)
    assert support_height(world, -0.16, 0.0) is None
    check_support(world, (0.2, 0.1), "pick")
    with pytest.raises(OffTableError, match=r"^the place point \(0\.200, 0\.500\) m is off "
                       "the table: nothing under it"):
        check_support(world, (0.2, 0.5), "place")


def test_the_judge_reads_the_world_not_the_commands(spec: ArmSpec) -> None:
    world = _table()
    plan = plan_pick(spec.chain(), (0.2, 0.0), (0.15, 0.12), HALF, spec.home)
    target = set_the_table(world, plan.pick, 0.0)
    # closed on nothing: missed, and the verdict says where it lies
    judge = PickJudge(target, plan)
    judge.after_close(settled=-0.0099, closed=-0.01)
    verdict = judge.verdict()
    assert (verdict["placed"], verdict["failure"]) == (False, "missed")
    assert verdict["placement_error_m"] == pytest.approx(math.dist(plan.pick, plan.place),
                                                         abs=1e-6)
    # held, lifted: then not between the fingers above the place point: slipped
    judge = PickJudge(target, plan)
    judge.after_close(settled=-0.0072, closed=-0.01)
    target.put(0.2, 0.0, HALF + APPROACH_HEIGHT)
    judge.after_lift()
    assert judge.failure is None
    target.put(0.2, 0.0, HALF)
    judge.after_carry(plan.points["above_place"])
    assert judge.failure == "slipped"
    # put down 6 mm from the place point: placed (within 1 cm), whatever the commands said
    target.put(plan.place[0] + 0.006, plan.place[1], HALF)
    verdict = PickJudge(target, plan).verdict()
    assert (verdict["placed"], verdict["failure"]) == (True, None)
    assert verdict["placement_error_m"] == pytest.approx(0.006, abs=1e-6)
    # 15 mm off: misplaced
    target.put(plan.place[0], plan.place[1] - 0.015, HALF)
    verdict = PickJudge(target, plan).verdict()
    assert (verdict["placed"], verdict["failure"]) == (False, "misplaced")
    assert "15.0 mm from the place point" in verdict["failure_reason"]
