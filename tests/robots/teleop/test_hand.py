"""The scripted hand: a seeded smooth motion, at rest at home at every episode's ends, and an
emulated leader whose encoders read it."""

from __future__ import annotations

import numpy as np
import pytest

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.emulator import build_emulator
from servolab.dynamixel.models import model
from servolab.robots.dynamixel_system import DynamixelJoint
from servolab.robots.errors import RobotValueError
from servolab.robots.teleop.hand import (
    Episodes,
    HandScript,
    HandWorld,
    Swing,
    hand_on,
    swings,
)
from servolab.robots.teleop.run import Arm
from servolab.sim import Simulation
from servolab.sim.emulated import port_to

SWINGS = (Swing("a", 0.0, 0.5), Swing("b", -0.6, 0.3), Swing("finger", 0.004, 0.009))


def test_episodes_say_which_one_is_in_progress() -> None:
    plan = Episodes(2.0, 3, reset=0.5)
    assert [plan.start(k) for k in range(3)] == [0.0, 2.5, 5.0]
    assert plan.total == 7.0
    assert plan.at(-0.1) is None and plan.at(7.0) is None and plan.at(2.2) is None
    assert plan.at(0.0) == (0, 0.0) and plan.at(3.0) == (1, 0.5)
    assert plan.at(6.9) == (2, pytest.approx(1.9))
    with pytest.raises(RobotValueError, match="a whole number >= 1"):
        Episodes(2.0, 0)


def test_the_motion_starts_and_ends_at_rest_at_home_and_stays_within_its_swings() -> None:
    script = HandScript(SWINGS, Episodes(4.0, 2, reset=1.0), seed=3, begin=10.0)
    home = [s.home for s in SWINGS]
    times = np.arange(9.0, 20.0, 0.001)
    path = np.array([script.at(t) for t in times])
    swing = np.array([s.swing for s in SWINGS])
    assert np.all(np.abs(path - home) <= swing + 1e-12)
    for t in (9.0, 10.0, 14.0, 14.5, 15.0, 19.0, 20.0):   # before, at and between episodes
        assert script.at(t) == pytest.approx(home, abs=1e-12)
    speed = np.abs(np.diff(path, axis=0)) / 0.001
    assert speed[(times[1:] > 9.999) & (times[1:] < 10.01)].max() < 0.01   # from rest
    assert speed.max() < 2.0                                                 # smooth
    moving = np.abs(path - home).max(axis=0)
    assert np.all(moving > 0.3 * swing)                  # every joint moves, within its swing


def test_the_motion_is_the_seeds_and_each_episode_its_own() -> None:
    plan = Episodes(4.0, 2, reset=0.0)
    one, again = (HandScript(SWINGS, plan, seed=7, begin=0.0) for _ in range(2))
    other = HandScript(SWINGS, plan, seed=8, begin=0.0)
    assert np.array_equal(one.at(1.7), again.at(1.7))
    assert not np.allclose(one.at(1.7), other.at(1.7))
    assert not np.allclose(one.at(1.7) - one.at(0.0), one.at(5.7) - one.at(4.0))


def test_a_joint_swings_a_share_of_its_range_unless_told_and_never_past_a_limit() -> None:
    xm = model("XM430-W350")
    found = swings([DynamixelJoint("wide", 1, xm, -3.0, 3.0),
                    DynamixelJoint("narrow", 2, xm, -0.2, 0.2),
                    DynamixelJoint("offset", 3, xm, 0.5, 1.5),
                    DynamixelJoint("told", 4, xm, -1.0, 1.0)], {"told": (0.5, 0.2)})
    assert found == (Swing("wide", 0.0, 0.4), Swing("narrow", 0.0, pytest.approx(0.1)),
                     Swing("offset", 1.0, 0.25), Swing("told", 0.5, 0.2))
    with pytest.raises(RobotValueError, match=r"told, 0.9 ± 0.2, leaves its limits \[-1, 1\]"):
        swings([DynamixelJoint("told", 4, xm, -1.0, 1.0)], {"told": (0.9, 0.2)})


def test_an_emulated_leaders_encoders_read_the_hand_gripper_reversed_included() -> None:
    """The arm's own block: each joint's horn through its transmission, the gripper's metres
    through its pinion and its Drive Mode's reverse bit, as the firmware counts them."""
    system = Arm.named("open_manipulator_x").system
    simulation = Simulation()
    emulator = simulation.add_emulator(build_emulator(system.bus().motor_spec()))
    script = HandScript(swings(system.joints), Episodes(3.0, 1), seed=1, begin=0.5)
    world = hand_on(emulator, simulation, system.joints, script)
    assert isinstance(world, HandWorld)
    bus = Bus(port_to(emulator, simulation, system.baudrate), system.protocol)
    for joint in system.joints:   # the block's items: the gripper counts backwards
        bus.write(joint.id, "torque_enable", 0)
        for register, value in joint.settings:
            bus.write(joint.id, register, value, raw=True)
    ids = [j.id for j in system.joints]
    for t in (0.2, 1.2, 2.0, 2.6):
        simulation.advance_to(t)
        read = bus.sync_read("present_position", ids)
        joints = [j.to_joint(float(read[j.id])) for j in system.joints]
        ticks = [2 * np.pi / 4096 * abs(j.scale) for j in system.joints]
        assert np.all(np.abs(np.array(joints) - world.joints()) <= np.array(ticks))
    assert world.ground_truth()["joint1"] == pytest.approx(world.joints()[0])
