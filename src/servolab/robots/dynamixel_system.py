"""Which Dynamixel drives which joint: a URDF's ``<ros2_control>`` block, read with the parameter
names the two ros2_control plugins for Dynamixels use — both dialects, unchanged.

- the community ``dynamixel_hardware`` (dynamixel-community/dynamixel_hardware, README
  "Configure Dynamixel motor parameters"): the hardware's ``usb_port`` and ``baud_rate``; each
  ``<joint>``'s ``id``, and optionally the control-table items it writes at start
  (``Profile_Velocity``, ``Profile_Acceleration``, ``Position_P_Gain``, ``Position_I_Gain``,
  ``Position_D_Gain``, ``Velocity_P_Gain``, ``Velocity_I_Gain``: its ``kExtraJointParameters``)
  and, as its simple-transmission branch reads them, ``mechanical_reduction`` and
  ``mechanical_offset`` (joint = horn / reduction + offset);
- ROBOTIS's ``dynamixel_hardware_interface`` (as OpenMANIPULATOR-X's
  ``open_manipulator_x_position.ros2_control.xacro`` writes it): the hardware's ``port_name``
  and ``baud_rate``; the motors are ``<gpio>`` elements with ``type`` ``dxl`` and ``ID`` and
  the control-table items they write at start as parameters (``Operating Mode``, ``Position P
  Gain``, ``Profile Velocity``, ``Drive Mode``, ``Return Delay Time``, ...); the ``<joint>``
  elements take their values through ``transmission_to_joint_matrix`` (identity when not
  given, its ``SetMatrix``). servolab maps each joint to one motor, so a matrix must have one
  non-zero entry a row (a sign or a ratio); one that mixes motors is refused in one line.

Either dialect may name a joint's model as ``model`` or ``motor_type`` (servolab's addition:
neither plugin needs one, both read the model number off the motor), or take a default
(robot.yaml's ``default_model``); emulated motors need one. Models are looked up in servolab's
model tables, and a real bus is checked against them (each motor is pinged before anything
moves). The protocol follows the models (Protocol 2.0 for X-series, 1.0 for AX/RX/EX/MX 1.0);
the baud rate is the block's, or the first model's factory rate.

A Dynamixel block is one whose ``<plugin>`` names a Dynamixel plugin (its text contains
"dynamixel", as ``dynamixel_hardware/DynamixelHardware`` and
``dynamixel_hardware_interface/DynamixelHardware`` do).
"""

from __future__ import annotations

import math
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
#: a component's parameters that are no control-table item (dynamixel_hardware_interface's
#: gpio keys, dynamixel_hardware's transmission): everything else names a register it writes
NOT_SETTINGS = ("id", "ID", "motor_type", "model", "type", "comm_id", "model_num", "Reboot",
                "mechanical_reduction", "mechanical_offset")
#: a <gpio>'s ``type`` that is a motor, in dynamixel_hardware_interface
MOTOR_GPIO = "dxl"
#: the URDF joint types a Dynamixel drives here: its horn is the joint (a prismatic joint needs
#: a transmission, which the <ros2_control> blocks of both plugins state in their own ways)
DRIVEN_TYPES = ("revolute", "continuous")
#: dynamixel_hardware_interface's switches that convert a revolute horn to a prismatic joint
#: inside the plugin (its older OpenMANIPULATOR-X files), which servolab does not read
#: (read with std::stoi: any integer but 0 turns it on, dynamixel_hardware_interface.cpp)
REVOLUTE_TO_PRISMATIC = ("use_revolute_to_prismatic_gripper",)
#: a joint a Dynamixel drives through a transmission that states its ratio (m a radian of
#: horn: a rack and pinion), given as mechanical_reduction or in the transmission matrix
SCALED_TYPES = ("prismatic",)


@dataclass(frozen=True)
class DynamixelJoint:
    """A URDF joint and the Dynamixel that drives it; its limits are the URDF's (rad or m;
    None where the joint has none, as a continuous joint)."""

    name: str
    id: int
    model: Model
    lower: float | None
    upper: float | None
    #: joint = scale x horn + offset (rad): a reduction, a sign, a zero elsewhere
    scale: float = 1.0
    offset: float = 0.0
    #: control-table items written before the motor moves: (register, raw value), as the
    #: block gives them
    settings: tuple[tuple[str, int], ...] = ()
    #: the block's element that names the motor (``<joint name="j1">``, ``<gpio name="dxl1">``)
    element: str = ""

    def to_joint(self, horn: float) -> float:
        return self.scale * horn + self.offset

    def to_horn(self, joint: float) -> float:
        return (joint - self.offset) / self.scale


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


def register_name(text: str) -> str:
    """A control-table item as the plugins spell it (``Profile_Velocity``, ``Position P
    Gain``) in servolab's words (``profile_velocity``, ``position_p_gain``)."""
    return "_".join(text.replace("_", " ").split()).lower()


def _settings(component: ComponentInfo, model_: Model, here: str) -> tuple[tuple[str, int], ...]:
    found: list[tuple[str, int]] = []
    for key, text in component.parameters.items():
        if key in NOT_SETTINGS:
            continue
        name = register_name(key)
        if not model_.has(name):
            raise HardwareInfoError(f'{here} <param name="{key}">: the {model_.name} has no '
                                    f"{name} register (a control-table item is written at "
                                    "start; see its e-Manual)")
        found.append((name, _integer(text, key, here, -(2 ** 31), 2 ** 32 - 1)))
    return tuple(found)


def _model(parameters: dict[str, str], here: str, default_model: str | None) -> Model:
    model_name = _one(parameters, MODEL_PARAMETERS, here) or default_model
    if model_name is None:
        raise HardwareInfoError(f'{here}: no Dynamixel model; add <param name="motor_type">'
                                f"XM430-W350</param> (or a default model in robot.yaml)")
    try:
        return model(model_name)
    except ConfigError as exc:
        raise HardwareInfoError(f"{here}: {exc}") from None


def _number(text: str | None, what: str, here: str, default: float) -> float:
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        raise HardwareInfoError(f"{here}: {what} {text!r} is not a number") from None
    if not math.isfinite(value):
        raise HardwareInfoError(f"{here}: {what} {text!r} is not a finite number")
    return value


def _urdf_joint(component: ComponentInfo, urdf_joint: Joint | None, here: str,
                scaled: bool = False) -> Joint:
    if urdf_joint is None:
        raise HardwareInfoError(f"{here}: the URDF has no <joint> of that name")
    if urdf_joint.kind in SCALED_TYPES and not scaled:
        raise HardwareInfoError(f"{here}: a {urdf_joint.kind} joint needs its transmission's "
                                "ratio (metres a radian of horn: mechanical_reduction, or "
                                "transmission_to_joint_matrix)")
    if urdf_joint.kind not in DRIVEN_TYPES + SCALED_TYPES:
        raise HardwareInfoError(f"{here}: a {urdf_joint.kind} joint cannot be driven (one of "
                                f"{', '.join(DRIVEN_TYPES)})")
    return urdf_joint


def _joint(component: ComponentInfo, urdf_joint: Joint | None, where: str,
           default_model: str | None) -> DynamixelJoint:
    """A joint that names its motor itself (dynamixel_hardware)."""
    here = f'{where} <joint name="{component.name}">'
    parameters = dict(component.parameters)
    found = _urdf_joint(component, urdf_joint, here, "mechanical_reduction" in parameters)
    id_text = _one(parameters, ID_PARAMETERS, here)
    if id_text is None:
        raise HardwareInfoError(f'{here}: no Dynamixel ID; add <param name="id">1</param> '
                                '(or give the motors as <gpio> elements with type dxl and ID, '
                                "as dynamixel_hardware_interface does)")
    model_ = _model(parameters, here, default_model)
    reduction = _number(parameters.get("mechanical_reduction"), "mechanical_reduction", here,
                        1.0)
    if reduction == 0:
        raise HardwareInfoError(f"{here}: mechanical_reduction 0 drives nothing")
    return DynamixelJoint(component.name, _integer(id_text, "ID", here, 0, 252), model_,
                          found.lower, found.upper, 1.0 / reduction,
                          _number(parameters.get("mechanical_offset"), "mechanical_offset",
                                  here, 0.0),
                          _settings(component, model_, here), f'<joint name="{component.name}">')


def _matrix(block: HardwareInfo, where: str, rows: int, columns: int) -> list[list[float]]:
    """``transmission_to_joint_matrix`` (rows: joints, columns: motors), identity when the
    block gives none, as dynamixel_hardware_interface's SetMatrix reads it."""
    text = block.hardware_parameters.get("transmission_to_joint_matrix")
    if text is None:
        return [[1.0 if i == j else 0.0 for j in range(columns)] for i in range(rows)]
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise HardwareInfoError(f"{where} <hardware>: transmission_to_joint_matrix "
                                f"{text[:40]!r} is not comma-separated numbers") from None
    if len(values) != rows * columns:
        raise HardwareInfoError(f"{where} <hardware>: transmission_to_joint_matrix has "
                                f"{len(values)} elements, expected {rows * columns} ({rows} "
                                f"joints x {columns} transmissions)")
    return [values[i * columns:(i + 1) * columns] for i in range(rows)]


def _gpio_joints(block: HardwareInfo, urdf_joints: dict[str, Joint], where: str,
                 default_model: str | None) -> tuple[DynamixelJoint, ...]:
    """The joints of a block whose motors are <gpio type="dxl"> (dynamixel_hardware_interface)."""
    motors = [g for g in block.gpios if g.parameters.get("type", "").strip() == MOTOR_GPIO]
    joints = [j for j in block.joints if "mimic" not in j.parameters]
    for key in REVOLUTE_TO_PRISMATIC:
        if block.hardware_parameters.get(key, "0").strip() not in ("0", "false", ""):
            # read alone, its identity matrix would drive the gripper at 1 m a radian
            raise HardwareInfoError(
                f"{where} <hardware>: {key} is not read by servolab; give the gripper's ratio "
                "(metres of finger a radian of horn) in transmission_to_joint_matrix instead, "
                "as OpenMANIPULATOR-X's file does since ROBOTIS's commit 6a61bcc")
    matrix = _matrix(block, where, len(joints), len(motors))
    found: list[DynamixelJoint] = []
    for row, component in zip(matrix, joints, strict=True):
        here = f'{where} <joint name="{component.name}">'
        urdf_joint = _urdf_joint(component, urdf_joints.get(component.name), here,
                                 "transmission_to_joint_matrix" in block.hardware_parameters)
        driving = [(k, v) for k, v in enumerate(row) if v != 0.0]
        if len(driving) != 1:
            raise HardwareInfoError(
                f"{here}: transmission_to_joint_matrix gives it {len(driving)} motors; "
                "servolab drives each joint by one motor (one non-zero entry a row)")
        column, scale = driving[0]
        gpio = motors[column]
        there = f'{where} <gpio name="{gpio.name}">'
        parameters = dict(gpio.parameters)
        id_text = _one(parameters, ID_PARAMETERS, there)
        if id_text is None:
            raise HardwareInfoError(f'{there}: no ID; add <param name="ID">11</param>')
        model_ = _model(parameters, there, default_model)
        found.append(DynamixelJoint(component.name, _integer(id_text, "ID", there, 0, 252),
                                    model_, urdf_joint.lower, urdf_joint.upper, scale, 0.0,
                                    _settings(gpio, model_, there),
                                    f'<gpio name="{gpio.name}">'))
    return tuple(found)


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
    if any(g.parameters.get("type", "").strip() == MOTOR_GPIO for g in block.gpios):
        joints = _gpio_joints(block, urdf_joints, where, default_model)
    else:
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
