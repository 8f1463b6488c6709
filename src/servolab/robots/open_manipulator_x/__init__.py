"""ROBOTIS's OpenMANIPULATOR-X as a servolab robot: four XM430-W350-T joints and a one-servo
gripper on Protocol 2.0 at 1 Mbps (IDs 11 to 15), under ros2_control.

It is written as a lab would write its own robot, against servolab's public API only (no
``servolab.*._*`` name is imported: ``tests/robots/open_manipulator_x`` checks), and it is data
first: ``open_manipulator_x.urdf`` (the description from ROBOTIS's published figures, with its
``<ros2_control>`` block in ROBOTIS's ``dynamixel_hardware_interface`` words) and
``open_manipulator_x_controllers.yaml`` (ROBOTIS's controllers). The Python around them says
what the data cannot: the motors' model (ROBOTIS's block names none), the table and the boxes
of its MuJoCo world (:mod:`.world`) and its view layout (:mod:`.layout`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from servolab.robots.dynamixel_system import DynamixelSystem

#: the robot's name, as ``servolab robots`` lists it
NAME = "open_manipulator_x"
#: every joint's motor (OpenMANIPULATOR-X e-Manual, Specification: "Actuator DYNAMIXEL
#: XM430-W350-T"); the ``<ros2_control>`` block names none, as ROBOTIS writes it
MODEL = "XM430-W350"
#: the scripted hand's (home, swing) of each joint when the arm leads (``servolab teleop``; rad,
#: m for the gripper's finger): joint2 leaning back, joint4 pitched down, as ROBOTIS's "home"
#: pose of the arm (joint2 -1.05, joint3 0.35, joint4 0.7) is, nearer the table's boxes; a
#: choice, checked in MuJoCo to keep the fingers at least 5 cm above the table (and its boxes'
#: tops) whichever way the sines add up, and within each joint's limits
HAND = {"joint1": (0.0, 0.8), "joint2": (-0.6, 0.4), "joint3": (-0.2, 0.4),
        "joint4": (1.0, 0.4), "gripper_left_joint": (0.0045, 0.009)}
#: the description, with its ``<ros2_control>`` block
URDF = Path(__file__).with_name(f"{NAME}.urdf")
#: the controllers file (OpenMANIPULATOR-X's ``hardware_controller_manager.yaml``)
CONTROLLERS = Path(__file__).with_name(f"{NAME}_controllers.yaml")


def urdf_text() -> str:
    """The description's text."""
    return URDF.read_text(encoding="utf-8")


def system() -> DynamixelSystem:
    """The arm's bus, as its ``<ros2_control>`` block says, every motor an XM430-W350."""
    from servolab.robots.dynamixel_system import dynamixel_system

    return dynamixel_system(urdf_text(), URDF.name, default_model=MODEL)
