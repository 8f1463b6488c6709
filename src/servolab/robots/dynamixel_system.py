"""Which Dynamixel drives which joint: a URDF's ``<ros2_control>`` block, read with the parameter
names the two ros2_control plugins for Dynamixels use.

- ROBOTIS's ``dynamixel_hardware_interface`` and the community ``dynamixel_hardware``
  (dynamixel-community/dynamixel_hardware, README "Configure Dynamixel motor parameters"):
  the hardware's ``port_name`` or ``usb_port`` and ``baud_rate`` or ``baudrate``; each joint's
  ``id`` (``ID``) and, where the file names it, ``motor_type`` (servolab also takes ``model``).

A Dynamixel block is one whose ``<plugin>`` names a Dynamixel plugin (its text contains
"dynamixel", as ``dynamixel_hardware/DynamixelHardware`` and
``dynamixel_hardware_interface/DynamixelHardware`` do). Its joints' models are looked up in
servolab's model tables: an emulated motor must be a model servolab knows, and a real bus is
checked against it (servolab pings each motor before it moves). The protocol follows the
models (Protocol 2.0 for X-series, 1.0 for AX/RX/EX/MX 1.0); the baud rate is the block's, or
the first model's factory rate.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..dynamixel.errors import ConfigError
from ..dynamixel.models import Model, model
from .description import Description, Joint
from .hardware_info import ComponentInfo, HardwareInfo, HardwareInfoError, parse_control_resources
from .plugin import BusSummary

#: the hardware parameter naming the serial port, as each plugin spells it
PORT_PARAMETERS = ("port_name", "usb_port")
#: the hardware parameter giving the baud rate
BAUD_PARAMETERS = ("baud_rate", "baudrate")
#: a joint's Dynamixel ID
ID_PARAMETERS = ("id", "ID")
#: a joint's Dynamixel model
MODEL_PARAMETERS = ("motor_type", "model")
#: the URDF joint types a Dynamixel drives here: its horn is the joint (a prismatic joint needs
#: a transmission, which the <ros2_control> blocks of both plugins state in their own ways)
DRIVEN_TYPES = ("revolute", "continuous")


@dataclass(frozen=True)
class DynamixelJoint:
    """A URDF joint and the Dynamixel that drives it; its limits are the URDF's (rad or m;
    None where the joint has none, as a continuous joint)."""

    name: str
    id: int
    model: Model
    lower: float | None
    upper: float | None


@dataclass(frozen=True)
class DynamixelSystem:
    """The Dynamixel bus of a robot: its ``<ros2_control>`` block's name, the port it names
    (None when it names none), baud rate, protocol and joints in the block's order."""

    name: str
    port_name: str | None
    baudrate: int
    protocol: int
    joints: tuple[DynamixelJoint, ...]

    def bus(self) -> BusSummary:
        return BusSummary(tuple((j.id, j.model.name) for j in self.joints), self.protocol,
                          self.baudrate)

    def joint(self, name: str) -> DynamixelJoint:
        for joint in self.joints:
            if joint.name == name:
                return joint
        raise HardwareInfoError(f"no Dynamixel joint {name!r}; there are "
                                f"{', '.join(j.name for j in self.joints)}")


def _one(parameters: dict[str, str], names: tuple[str, ...], where: str) -> str | None:
    given = [n for n in names if n in parameters]
    if len(given) > 1:
        raise HardwareInfoError(f"{where}: give one of the parameters {' or '.join(given)}")
    return parameters[given[0]] if given else None


def _integer(text: str, what: str, where: str, low: int, high: int) -> int:
    try:
        value = int(text, 0)
    except ValueError:
        raise HardwareInfoError(f"{where}: {what} {text!r} is not an integer") from None
    if not low <= value <= high:
        raise HardwareInfoError(f"{where}: {what} {value} is outside {low}..{high}")
    return value


def _joint(component: ComponentInfo, urdf_joint: Joint | None, where: str,
           default_model: str | None) -> DynamixelJoint:
    here = f'{where} <joint name="{component.name}">'
    if urdf_joint is None:
        raise HardwareInfoError(f"{here}: the URDF has no <joint> of that name")
    if urdf_joint.kind not in DRIVEN_TYPES:
        raise HardwareInfoError(f"{here}: a {urdf_joint.kind} joint cannot be driven (one of "
                                f"{', '.join(DRIVEN_TYPES)})")
    parameters = dict(component.parameters)
    id_text = _one(parameters, ID_PARAMETERS, here)
    if id_text is None:
        raise HardwareInfoError(f'{here}: no Dynamixel ID; add <param name="id">1</param>')
    model_name = _one(parameters, MODEL_PARAMETERS, here) or default_model
    if model_name is None:
        raise HardwareInfoError(f'{here}: no Dynamixel model; add <param name="motor_type">'
                                f"XM430-W350</param> (or a default model in robot.yaml)")
    try:
        found = model(model_name)
    except ConfigError as exc:
        raise HardwareInfoError(f"{here}: {exc}") from None
    return DynamixelJoint(component.name, _integer(id_text, "ID", here, 0, 252), found,
                          urdf_joint.lower, urdf_joint.upper)


def dynamixel_system(urdf: str, source: str = "<urdf>", *,
                     default_model: str | None = None) -> DynamixelSystem:
    """The Dynamixel bus the URDF text ``urdf`` describes (``source`` names it in errors):
    its one Dynamixel ``<ros2_control>`` block, checked (IDs, models, protocols, joints)."""
    blocks = parse_control_resources(urdf, source)
    ours = [b for b in blocks if "dynamixel" in b.plugin.lower()]
    if not ours:
        plugins = ", ".join(b.plugin for b in blocks) or "none"
        raise HardwareInfoError(f"{source}: no <ros2_control> block with a Dynamixel hardware "
                                f"plugin (plugins: {plugins}); e.g. <plugin>dynamixel_hardware/"
                                f"DynamixelHardware</plugin>")
    if len(ours) > 1:
        raise HardwareInfoError(f"{source}: {len(ours)} Dynamixel <ros2_control> blocks "
                                f"({', '.join(b.name for b in ours)}); servolab opens one bus "
                                "a robot")
    joints = {j.name: j for j in Description.from_urdf(urdf, source).joints}
    return _system(ours[0], joints, source, default_model)


def block_system(urdf: str, block: HardwareInfo, source: str = "<urdf>", *,
                 default_model: str | None = None) -> DynamixelSystem:
    """The Dynamixel bus of one ``<ros2_control>`` block of the URDF text ``urdf``."""
    joints = {j.name: j for j in Description.from_urdf(urdf, source).joints}
    return _system(block, joints, source, default_model)


def _system(block: HardwareInfo, urdf_joints: dict[str, Joint], source: str,
            default_model: str | None) -> DynamixelSystem:
    where = block.where(source)
    if not block.joints:
        raise HardwareInfoError(f"{where}: no <joint> elements")
    joints = tuple(_joint(c, urdf_joints.get(c.name), where, default_model)
                   for c in block.joints)
    ids = [j.id for j in joints]
    twice = sorted({i for i in ids if ids.count(i) > 1})
    if twice:
        names = [j.name for j in joints if j.id == twice[0]]
        raise HardwareInfoError(f"{where}: ID {twice[0]} drives {' and '.join(names)}")
    protocols = sorted({j.model.protocol for j in joints})
    if len(protocols) > 1:
        raise HardwareInfoError(f"{where}: its models speak Protocol 1.0 and 2.0 "
                                f"({', '.join(sorted({j.model.name for j in joints}))}); "
                                "servolab opens one protocol a bus")
    hardware = dict(block.hardware_parameters)
    baud_text = _one(hardware, BAUD_PARAMETERS, f"{where} <hardware>")
    first = joints[0].model
    baudrate = (_integer(baud_text, "baud rate", f"{where} <hardware>", 1, 10_500_000)
                if baud_text is not None
                else first.baud_from_register(first.register("baud_rate").default or 0))
    return DynamixelSystem(block.name, _one(hardware, PORT_PARAMETERS, f"{where} <hardware>"),
                           baudrate, protocols[0], joints)
