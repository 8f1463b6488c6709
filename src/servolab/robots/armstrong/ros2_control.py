"""Armstrong's legs under ros2_control: its URDF with a ``<ros2_control>`` block for its bus
(:func:`control_urdf`, the plug-in's description), the controllers file shipped beside this
module (``armstrong_controllers.yaml``: a joint_state_broadcaster and ``legs_controller``, a
joint_trajectory_controller over the twelve leg joints), and a motion's rows as that
controller's trajectory (:func:`legs_trajectory`). The seed's own path, ``dynamixel_motor``'s
joint controllers (:mod:`.control_node`, ``servolab walk``), stays as it is; both write the
same goal positions for the same rows (tests/robots/armstrong/test_ros2_control.py).

::

    servolab control run armstrong --spawn joint_state_broadcaster legs_controller

The block's joints are the URDF's joint angles. Armstrong's joint angle 0 is each motor at
its ``init`` (444 on m12 and m42, 338 on m16, 408 on m23, 505 on m26, else the centre tick,
512), and a joint turns its horn by its motor's direction times its controller's flip
(``horn = init + sign x joint``: :class:`.description.HornMap`). The block says so in the
community ``dynamixel_hardware``'s simple-transmission parameters, which servolab's
DynamixelHardware reads (:mod:`servolab.robots.dynamixel_system`: ``joint = horn /
mechanical_reduction + mechanical_offset``): ``mechanical_reduction`` = sign (+1 or -1, its
own inverse) and ``mechanical_offset`` = -sign x init (:func:`transmission`).

The bus is the robot's: 20 RX-28 on Protocol 1.0 at 57142 bps (motor 62, the camera, is not
on it: 001 Figure 3.4). Every motor on the bus is in the block, so the update reads them all
(``armstrong_controllers.yaml`` says what that costs on the wire); only the legs have a
controller that moves them, the others hold where they are.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ...configfile import shipped
from ...gait.motionfile import MotionFile
from ...gait.walking import PLAY_RATE
from ..controllers.config import RobotConfig
from ..description import Description as GenericDescription
from ..errors import RobotValueError
from .description import Assumptions, Description, HornMap, describe, horn_maps, urdf
from .gait_trajectory import GaitTrajectory, JointMap, motion_trajectory
from .hardware import MODEL, load_config
from .poses import JOINTS, MOTORS

if TYPE_CHECKING:
    from ...dynamixel.emulator import Emulator
    from ...sim.simulation import Simulation

#: the controllers file shipped beside this module
CONTROLLERS = shipped(__package__ or "servolab.robots.armstrong", "armstrong_controllers.yaml")
#: the hardware plugin the block names: the community plugin's (servolab reads it as
#: :class:`~servolab.robots.control.dynamixel_hardware.DynamixelHardware`)
PLUGIN = "dynamixel_hardware/DynamixelHardware"
#: Table 4.1's joint functions that are a leg's (:data:`.poses.JOINTS`)
LEG_GROUPS = ("left_hip", "left_knee", "left_ankle", "right_hip", "right_knee", "right_ankle")
#: the controller that moves the legs (``armstrong_controllers.yaml``)
LEGS_CONTROLLER = "legs_controller"


@dataclass(frozen=True)
class ControlBlock:
    """What :func:`control_urdf` writes in the ``<ros2_control>`` block: its name, the
    plugin, the port (None: the configuration's, ``/dev/ttyUSB0``), and the command and
    state interfaces of every joint."""

    name: str = "armstrong"
    plugin: str = PLUGIN
    port_name: str | None = None
    command_interfaces: tuple[str, ...] = ("position",)
    state_interfaces: tuple[str, ...] = ("position",)


def leg_columns() -> tuple[str, ...]:
    """The motor columns of Table 4.1's leg joints, in the motion files' order (m11..m16,
    m21..m26)."""
    legs = {c for group in LEG_GROUPS for c in JOINTS[group].values()}
    return tuple(c for c in MOTORS if c in legs)


def leg_joints(description: Description) -> tuple[str, ...]:
    """The URDF joints of Table 4.1's leg groups, in the motion files' column order: the
    joints ``legs_controller`` moves."""
    by_column = {m.actuator: j.name for j, m in description.motors}
    return tuple(by_column[c] for c in leg_columns())


def transmission(horn: HornMap) -> tuple[float, float]:
    """``(mechanical_reduction, mechanical_offset)`` that make a joint's position its URDF
    angle: ``horn / reduction + offset = sign x (horn - init)``, the inverse of ``horn =
    init + sign x joint`` (``sign`` is +1 or -1)."""
    return float(horn.sign), 0.0 - horn.sign * horn.offset  # 0.0, never -0.0


def joint_maps(description: GenericDescription, columns: tuple[str, ...]) -> list[JointMap]:
    """Motion columns to the URDF's joint angles (``direction x`` the motor's angle, as
    :meth:`.description.Description.joint_positions`): what the block's joints are
    commanded in."""
    by_column = {m.actuator: (j.name, m.direction) for j, m in description.motors}
    missing = [c for c in columns if c not in by_column]
    if missing:
        raise RobotValueError(f"no joint has motor column {missing[0]!r}")
    return [JointMap(c, by_column[c][0], float(by_column[c][1])) for c in columns]


def legs_trajectory(motion: MotionFile, *, rate: float = PLAY_RATE, steps: int = 1,
                    rows: int | None = None, assumptions: Assumptions | None = None,
                    config: str | Path | None = None) -> GaitTrajectory:
    """``motion``'s leg columns as ``legs_controller``'s trajectory in the URDF's joint
    angles (:func:`.gait_trajectory.motion_trajectory`: ``rows`` at ``rate`` a second, the
    seed's 4.5 by default)."""
    description = describe(assumptions, load_config(config))
    return motion_trajectory(motion, joint_maps(description, leg_columns()), rate=rate,
                             steps=steps, rows=rows)


def control_block(description: Description, config: RobotConfig,
                  block: ControlBlock | None = None) -> ET.Element:
    """The ``<ros2_control>`` element of Armstrong's bus: the plugin, ``port_name`` and
    ``baud_rate``; each joint whose motor is on the bus with its ``id``, ``model``,
    ``mechanical_reduction`` and ``mechanical_offset`` (:func:`transmission`) and its
    interfaces."""
    b = block if block is not None else ControlBlock()
    port = config.manager.serial_ports[0]
    element = ET.Element("ros2_control", name=b.name, type="system")
    hardware = ET.SubElement(element, "hardware")
    ET.SubElement(hardware, "plugin").text = b.plugin
    ET.SubElement(hardware, "param", name="port_name").text = b.port_name or port.port_name
    # an integer, as both plugins read it (57142.0 in armstrong.yaml is ROS 1's float)
    ET.SubElement(hardware, "param", name="baud_rate").text = str(round(port.baud_rate))
    for name, horn in horn_maps(description, config).items():
        reduction, offset = transmission(horn)
        joint = ET.SubElement(element, "joint", name=name)
        ET.SubElement(joint, "param", name="id").text = str(horn.id)
        ET.SubElement(joint, "param", name="model").text = MODEL
        ET.SubElement(joint, "param", name="mechanical_reduction").text = repr(reduction)
        ET.SubElement(joint, "param", name="mechanical_offset").text = repr(offset)
        for interface in b.command_interfaces:
            ET.SubElement(joint, "command_interface", name=interface)
        for interface in b.state_interfaces:
            ET.SubElement(joint, "state_interface", name=interface)
    return element


def control_urdf(assumptions: Assumptions | None = None, config: str | Path | None = None,
                 block: ControlBlock | None = None) -> str:
    """Armstrong's URDF (:func:`.description.urdf`, under ``assumptions``, with the
    configuration ``config``) with the ``<ros2_control>`` block of its bus at the end."""
    robot_config = load_config(config)
    description = describe(assumptions, robot_config)
    text = urdf(description)
    element = control_block(description, robot_config, block)
    ET.indent(element, space="  ", level=1)
    # appended as text: the generated file's declaration and comment stay as they are
    end = text.rindex("</robot>")
    return f"{text[:end]}  {ET.tostring(element, encoding='unicode')}\n{text[end:]}"


def standing(emulator: Emulator) -> tuple[Simulation, Emulator, None]:
    """Armstrong's emulated bus as ``servolab walk`` has it (:func:`.hardware.emulated_spec`:
    every motor at its ``init``, every joint at 0) in place of ``emulator`` (the block's
    motors at their centre ticks), at its baud rate, in a simulation of its own and no world
    but the motors' (``servolab walk --world kinematic``): a ``place`` for
    :class:`~servolab.robots.control.bringup.BringUpOptions` with ``world="robot"``."""
    from ...dynamixel.emulator import build_emulator
    from ...sim.simulation import Simulation
    from .hardware import emulated_spec

    spec = emulated_spec(load_config(), baudrate=emulator.motors[0].baudrate)
    ours, theirs = sorted(m.id for m in spec.motors), sorted(m.id for m in emulator.motors)
    if ours != theirs:
        raise RobotValueError(f"the block's motors {theirs} are not Armstrong's bus {ours}")
    simulation = Simulation()
    return simulation, simulation.add_emulator(build_emulator(spec)), None
