"""A two-joint XM430 robot under ros2_control, brought up in this process on emulated motors
whose time the test steps (the tests that run it in real time, across processes and over a
pty, are test_control_cli.py's)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from servolab.middleware.parameters import ParameterOverrides
from servolab.robots.control.bringup import BringUpOptions, ControlSystem

DATA = Path(__file__).parent / "data"
#: the robot in the community dynamixel_hardware's words (usb_port, per-joint id)
TWO_JOINT = DATA / "two_joint.urdf"
#: the same robot in ROBOTIS's dynamixel_hardware_interface's words (gpio motors, matrices)
TWO_JOINT_ROBOTIS = DATA / "two_joint_robotis.urdf"
CONTROLLERS = DATA / "two_joint_controllers.yaml"


def bring_up(urdf: Path = TWO_JOINT, *, spawn: tuple[str, ...] = (),
             inactive: tuple[str, ...] = (), params: str | None = None,
             world: str = "emulated", default_model: str | None = None) -> ControlSystem:
    overrides = ParameterOverrides.from_file(CONTROLLERS)
    if params:
        overrides.merge(ParameterOverrides.from_text(params))
    return ControlSystem(urdf.read_text(), urdf.name, overrides,
                         BringUpOptions(spawn=spawn, inactive=inactive, real_time=False,
                                        world=world, default_model=default_model))


@pytest.fixture
def two_joint() -> Iterator[ControlSystem]:
    """Broadcaster and position group active, the velocity group and the trajectory
    controller loaded and configured."""
    system = bring_up(spawn=("joint_state_broadcaster", "forward_position_controller"),
                      inactive=("forward_velocity_controller",))
    try:
        yield system
    finally:
        system.close()
