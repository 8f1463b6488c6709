"""A base under ros2_control, and the floor its emulated wheels roll on.

Two things a base's plug-in gives from its base file (``base_<name>.yaml``, the one place its
bus and geometry are written):

- :func:`on_floor`: the emulated wheel motors put on the simulated floor
  (:class:`~servolab.sim.floor.DiffDriveFloor`), each side's forward sign from its motor's
  mounting, as :meth:`.mobile_base.MobileBase.emulated` puts them there. Every base is served
  so (``servolab sim --robot NAME``), and ``servolab control run NAME --world robot`` brings a
  base with a controllers file up on it.
- :func:`control_urdf`: the base's URDF with a ``<ros2_control>`` block in the community
  ``dynamixel_hardware``'s words (the hardware's ``usb_port`` and ``baud_rate``, each wheel
  joint's ``id``; a velocity command interface, position and velocity state interfaces), for
  a base that ships a controllers file beside its base file (:func:`controllers_file`:
  ``<name>_controllers.yaml``, a ``diff_drive_controller`` and a
  ``joint_state_broadcaster``).

The URDF's links and joints are turtlebot3_description's (ROBOTIS-GIT/turtlebot3, branch
``jazzy``, ``turtlebot3_description/urdf/turtlebot3_waffle.urdf``: ``base_footprint``,
``base_joint`` 0.010 m up to ``base_link``, the continuous ``wheel_left_joint`` and
``wheel_right_joint`` turned ``rpy="-1.57 0 0"`` with ``axis="0 0 1"``, so that a positive
joint velocity rolls the base forward), with the wheels where the base file puts them: half
``wheel_separation`` to each side (turtlebot3_description has 0.144 m, 1 mm wider than the
firmware's 0.287 m separation the base file keeps), at ``wheel_radius`` above the floor.

Each wheel joint is its motor's horn as the motor reports it: a motor the base file mounts
mirrored (``direction: -1``) gets ``mechanical_reduction`` -1, and each motor of a
Protocol 2.0 base gets its ``Drive_Mode`` (1 where the base file says ``drive_mode: reverse``,
else 0), the byte ROBOTIS's OpenCR ``turtlebot3_setup_motor.ino`` writes at address 10
(``setupMotorRight`` 1, ``setupMotorLeft`` 0). servolab writes it when the hardware is
configured; the community plugin writes only its ``kExtraJointParameters`` and ignores it, as
a TurtleBot3 whose motors that setup configured needs nothing written.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import RobotValueError
from .config import BaseConfig

if TYPE_CHECKING:
    from ...dynamixel.emulator import Emulator
    from ...sim.floor import DiffDriveFloor
    from ...sim.simulation import Simulation

#: the name a base's controllers file takes beside its base file
CONTROLLERS_SUFFIX = "_controllers.yaml"
#: the hardware plugin the block names (servolab runs it as its DynamixelHardware)
PLUGIN = "dynamixel_hardware/DynamixelHardware"
#: the serial port the block names (a TurtleBot3's U2D2 or OpenCR in its USB-to-Dynamixel
#: mode); ``servolab control run`` uses it only with ``--port urdf``
USB_PORT = "/dev/ttyUSB0"
#: each side's wheel joint, as turtlebot3_description names them
WHEEL_JOINTS = {"left": "wheel_left_joint", "right": "wheel_right_joint"}
#: base_joint's height of base_link over base_footprint (turtlebot3_waffle.urdf line 57)
BASE_LINK_HEIGHT = 0.010
#: the wheel joints' roll (turtlebot3_waffle.urdf lines 88 and 120)
WHEEL_ROLL = -1.57


def controllers_file(name: str) -> Path | None:
    """The controllers file shipped beside base ``name``'s base file, if there is one."""
    path = Path(__file__).with_name(f"{name}{CONTROLLERS_SUFFIX}")
    return path if path.is_file() else None


def _one_motor_a_side(config: BaseConfig) -> None:
    for side in ("left", "right"):
        if len(config.side(side)) != 1:
            raise RobotValueError(
                f"{config.path or config.name}: a base under ros2_control has one wheel motor "
                f"a side (a joint each); its {side} side has {len(config.side(side))}")


def control_urdf(config: BaseConfig) -> str:
    """The base's URDF with its ``<ros2_control>`` block (see the module docstring)."""
    _one_motor_a_side(config)
    robot = ET.Element("robot", name=config.name)
    ET.SubElement(robot, "link", name="base_footprint")
    ET.SubElement(robot, "link", name="base_link")
    joint = ET.SubElement(robot, "joint", name="base_joint", type="fixed")
    ET.SubElement(joint, "parent", link="base_footprint")
    ET.SubElement(joint, "child", link="base_link")
    ET.SubElement(joint, "origin", xyz=f"0 0 {BASE_LINK_HEIGHT:g}", rpy="0 0 0")
    height = config.wheel_radius - BASE_LINK_HEIGHT
    for side, sign in (("left", 1), ("right", -1)):
        name = WHEEL_JOINTS[side]
        link = name.replace("_joint", "_link")
        wheel = ET.SubElement(robot, "link", name=link)
        collision = ET.SubElement(wheel, "collision")
        ET.SubElement(ET.SubElement(collision, "geometry"), "cylinder", length="0.018",
                      radius=f"{config.wheel_radius:g}")
        joint = ET.SubElement(robot, "joint", name=name, type="continuous")
        ET.SubElement(joint, "parent", link="base_link")
        ET.SubElement(joint, "child", link=link)
        ET.SubElement(joint, "origin", xyz=f"0 {sign * config.wheel_separation / 2:g} "
                      f"{height:g}", rpy=f"{WHEEL_ROLL:g} 0 0")
        ET.SubElement(joint, "axis", xyz="0 0 1")
    block = ET.SubElement(robot, "ros2_control", name=config.name, type="system")
    hardware = ET.SubElement(block, "hardware")
    ET.SubElement(hardware, "plugin").text = PLUGIN
    ET.SubElement(hardware, "param", name="usb_port").text = USB_PORT
    ET.SubElement(hardware, "param", name="baud_rate").text = str(config.baudrate)
    for side in ("left", "right"):
        (motor,) = config.side(side)
        joint = ET.SubElement(block, "joint", name=WHEEL_JOINTS[side])
        ET.SubElement(joint, "param", name="id").text = str(motor.id)
        ET.SubElement(joint, "param", name="model").text = config.model.name
        if motor.direction < 0:
            ET.SubElement(joint, "param", name="mechanical_reduction").text = "-1"
        if config.protocol == 2:
            ET.SubElement(joint, "param", name="Drive_Mode").text = "1" if motor.reverse \
                else "0"
        ET.SubElement(joint, "command_interface", name="velocity")
        ET.SubElement(joint, "state_interface", name="position")
        ET.SubElement(joint, "state_interface", name="velocity")
    ET.indent(robot)
    return '<?xml version="1.0"?>\n' + ET.tostring(robot, encoding="unicode") + "\n"


def on_floor(config: BaseConfig) -> Callable[[Emulator], tuple[Simulation, Emulator,
                                                               DiffDriveFloor]]:
    """How to put the base's emulated motors on the floor: ``place(emulator)`` gives a
    simulation with the emulator in it and the floor under its wheel motors (the IDs of
    the base file; each side's forward sign its motors' mounting)."""

    def place(emulator: Emulator) -> tuple[Simulation, Emulator, DiffDriveFloor]:
        from ...sim.floor import DiffDriveFloor
        from ...sim.simulation import Simulation

        simulation = Simulation()
        simulation.add_emulator(emulator)
        left, right = config.side("left"), config.side("right")
        try:
            floor = DiffDriveFloor.for_base(
                simulation, emulator, [m.id for m in left], [m.id for m in right],
                wheel_radius=config.wheel_radius, wheel_separation=config.wheel_separation,
                left_forward=tuple(m.mounting for m in left),
                right_forward=tuple(m.mounting for m in right))
        except Exception as exc:  # a motor the base file names that the bus has not
            raise RobotValueError(f"{config.path or config.name}: {exc}") from None
        return simulation, emulator, floor

    return place


def floor_figures(floor: Any, _plot: Path, _now: float) -> dict[str, Any]:
    """What ``servolab sim`` reports of the floor at the end: where the base stands."""
    truth = floor.ground_truth()
    return {"floor": {"x_m": round(truth["x"], 4), "y_m": round(truth["y"], 4),
                      "yaw_deg": round(math.degrees(truth["yaw"]), 2),
                      "distance_m": round(truth["distance"], 4)}}
