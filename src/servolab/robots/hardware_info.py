"""The ``<ros2_control>`` blocks of a URDF, read as ros2_control reads them.

ros2_control's ``hardware_interface::parse_control_resources_from_urdf`` (component_parser.cpp)
turns each ``<ros2_control name type>`` element into a ``HardwareInfo``: the hardware's
``<plugin>`` and ``<param name="...">`` values, and its ``<joint>``, ``<sensor>`` and ``<gpio>``
components, each with its own parameters and its ``<command_interface>`` /
``<state_interface>`` elements (``name``; ``min``, ``max``, ``initial_value`` as ``<param>``
children). :func:`parse_control_resources` does the same, so that the file a ROS 2 lab already
has — ROBOTIS's ``dynamixel_hardware_interface``, the community ``dynamixel_hardware`` — is read
unchanged. Every value stays the text the file holds: what a parameter means is the hardware
plugin's business (:mod:`.urdf_robot` for Dynamixels).

Errors name the file and the element (``arm.urdf: <ros2_control name="arm"> <joint
name="j1">: ...``), in one line.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from .errors import RobotValueError

#: the ``type`` a ``<ros2_control>`` element may have (ros2_control's component types)
HARDWARE_TYPES = ("system", "actuator", "sensor")


class HardwareInfoError(RobotValueError):
    """A ``<ros2_control>`` block that ros2_control would refuse too."""


def _frozen(values: dict[str, str]) -> Mapping[str, str]:
    return MappingProxyType(values)


@dataclass(frozen=True)
class InterfaceInfo:
    """A command or state interface: ``position``, ``velocity``, ``effort``, ... and its
    parameters (``min``, ``max``, ``initial_value``)."""

    name: str
    parameters: Mapping[str, str] = field(default_factory=lambda: _frozen({}))


@dataclass(frozen=True)
class ComponentInfo:
    """A joint, sensor or GPIO of a hardware: its name, parameters and interfaces."""

    kind: str
    name: str
    parameters: Mapping[str, str]
    command_interfaces: tuple[InterfaceInfo, ...]
    state_interfaces: tuple[InterfaceInfo, ...]


@dataclass(frozen=True)
class HardwareInfo:
    """One ``<ros2_control>`` element."""

    name: str
    type: str
    plugin: str
    hardware_parameters: Mapping[str, str]
    joints: tuple[ComponentInfo, ...]
    sensors: tuple[ComponentInfo, ...]
    gpios: tuple[ComponentInfo, ...]

    def where(self, source: str) -> str:
        return f'{source}: <ros2_control name="{self.name}">'


def _text(element: ET.Element, where: str) -> str:
    text = (element.text or "").strip()
    if not text:
        raise HardwareInfoError(f"{where}: <{element.tag}> is empty")
    return text


def _name(element: ET.Element, where: str) -> str:
    name = element.get("name", "").strip()
    if not name:
        raise HardwareInfoError(f"{where}: <{element.tag}> has no name attribute")
    return name


def _parameters(element: ET.Element, where: str) -> Mapping[str, str]:
    values: dict[str, str] = {}
    for param in element.findall("param"):
        name = _name(param, where)
        if name in values:
            raise HardwareInfoError(f'{where}: <param name="{name}"> is given twice')
        values[name] = (param.text or "").strip()
    return _frozen(values)


def _interfaces(element: ET.Element, tag: str, where: str) -> tuple[InterfaceInfo, ...]:
    found = [InterfaceInfo(_name(e, where), _parameters(e, f'{where} <{tag} name='
                                                          f'"{e.get("name", "")}">'))
             for e in element.findall(tag)]
    names = [i.name for i in found]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise HardwareInfoError(f"{where}: <{tag} name=\"{twice[0]}\"> is given twice")
    return tuple(found)


def _components(hardware: ET.Element, kind: str, where: str) -> tuple[ComponentInfo, ...]:
    found: list[ComponentInfo] = []
    for element in hardware.findall(kind):
        name = _name(element, where)
        here = f'{where} <{kind} name="{name}">'
        if any(c.name == name for c in found):
            raise HardwareInfoError(f"{here}: given twice")
        found.append(ComponentInfo(kind, name, _parameters(element, here),
                                   _interfaces(element, "command_interface", here),
                                   _interfaces(element, "state_interface", here)))
    return tuple(found)


def parse_control_resources(urdf: str, source: str = "<urdf>") -> tuple[HardwareInfo, ...]:
    """Every ``<ros2_control>`` block of the URDF text ``urdf`` (``source`` names it in
    errors), in document order. A URDF without one gives ``()``."""
    try:
        root = ET.fromstring(urdf)
    except ET.ParseError as exc:
        raise HardwareInfoError(f"{source}: not XML ({exc})") from None
    if root.tag != "robot":
        raise HardwareInfoError(f"{source}: the root element is <{root.tag}>, not <robot>")
    found: list[HardwareInfo] = []
    for element in root.findall("ros2_control"):
        name = _name(element, source)
        where = f'{source}: <ros2_control name="{name}">'
        kind = element.get("type", "").strip().lower()
        if kind not in HARDWARE_TYPES:
            raise HardwareInfoError(f"{where}: type {element.get('type')!r} is not one of "
                                    f"{', '.join(HARDWARE_TYPES)}")
        hardware = element.find("hardware")
        if hardware is None:
            raise HardwareInfoError(f"{where}: no <hardware> element (ros2_control needs its "
                                    f"<plugin>)")
        plugin = hardware.find("plugin")
        if plugin is None:
            raise HardwareInfoError(f"{where} <hardware>: no <plugin> element")
        if any(h.name == name for h in found):
            raise HardwareInfoError(f"{where}: a second <ros2_control> of that name")
        found.append(HardwareInfo(
            name, kind, _text(plugin, f"{where} <hardware>"),
            _parameters(hardware, f"{where} <hardware>"),
            _components(element, "joint", where), _components(element, "sensor", where),
            _components(element, "gpio", where)))
    return tuple(found)
