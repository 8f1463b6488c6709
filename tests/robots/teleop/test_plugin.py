"""The default rig's leader is a robot plug-in: listed, opened on emulated motors, and served by
``servolab sim --robot open_manipulator_x_leader`` with its horns in the scripted hand."""

from __future__ import annotations

import pytest

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.emulator import build_emulator
from servolab.robots.registry import discover
from servolab.robots.teleop import DEFAULT_ARM, DEFAULT_LEADER
from servolab.robots.teleop.hand import HandWorld
from servolab.robots.teleop.plugin import HAND, SERVED_BEGIN_S
from servolab.sim.emulated import port_to


def test_it_is_found_and_is_the_arm_with_its_torque_off() -> None:
    found = discover({})
    leader, arm = found.entry(DEFAULT_LEADER), found.entry(DEFAULT_ARM)
    assert leader.origin == "servolab" and leader.commands == ("teleop",)
    assert leader.bus() == arm.bus()
    assert leader.description is not None and arm.description is not None
    assert leader.description() == arm.description()
    assert leader.on_stop.startswith("the motors' torque goes off")


def test_served_its_motors_follow_the_hand() -> None:
    served = discover({}).entry(DEFAULT_LEADER).serve()
    assert served.place is not None and served.spec.baudrate == 1_000_000
    simulation, emulator, world = served.place(build_emulator(served.spec))
    assert isinstance(world, HandWorld)
    bus = Bus(port_to(emulator, simulation, 1_000_000), 2)
    ids = [11, 12, 13, 14]
    homes = [HAND[f"joint{i}"][0] for i in range(1, 5)]
    simulation.advance_to(SERVED_BEGIN_S - 0.1)   # held at home until the hand begins
    assert list(bus.sync_read("present_position", ids).values()) == pytest.approx(homes,
                                                                                  abs=2e-3)
    simulation.advance_to(SERVED_BEGIN_S + 3.0)
    moved = bus.sync_read("present_position", ids)
    assert max(abs(moved[i] - h) for i, h in zip(ids, homes, strict=True)) > 0.05
    assert [moved[i] for i in ids] == pytest.approx(list(world.joints()[:4]), abs=2e-3)
