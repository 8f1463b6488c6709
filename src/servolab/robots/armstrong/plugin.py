"""Armstrong as a servolab robot plug-in (found by :mod:`servolab.robots.registry`): seed 001's
biped, its bus, its files, and the MuJoCo world ``servolab sim --robot armstrong`` serves it in.
Nothing here imports the robot until asked."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..plugin import BusSummary, RobotPlugin, ServedRobot, ShownFile
from . import ON_STOP

if TYPE_CHECKING:
    from collections.abc import Mapping

    from ...middleware.view.layout import Layout


def _config() -> Path:
    from .hardware import CONFIG

    return CONFIG


def _bus() -> BusSummary:
    from . import hardware

    config = hardware.load_config()
    port = config.manager.serial_ports[0]
    ids = tuple(c.motor.id for c in config.controllers if c.motor.id not in hardware.ABSENT)
    return BusSummary.of(hardware.MODEL, ids, 1, port.baud_rate)


def _open(port: str | None) -> Any:
    from .control_node import Armstrong

    return Armstrong(port=port)


def _urdf() -> str:
    """The description's URDF with the ``<ros2_control>`` block of its bus: what ``servolab
    control run armstrong`` brings up (with ``armstrong.controllers``)."""
    from .ros2_control import control_urdf

    return control_urdf()


def _files() -> Mapping[str, ShownFile]:
    from .description import assumptions_table, model_file
    from .ros2_control import CONTROLLERS

    return {"armstrong.mjcf": lambda: model_file("mjcf"),
            "armstrong.assumptions": assumptions_table,
            "armstrong.controllers": CONTROLLERS}


def _served(baudrate: int | None) -> ServedRobot:
    """The biped's 20 RX-28 standing in MuJoCo, each servo's firmware driving its joint."""
    from .hardware import emulated_spec, load_config
    from .physics import in_mujoco
    from .physics_report import served_figures

    return ServedRobot(emulated_spec(load_config(), baudrate=baudrate),
                       place=lambda emulator: in_mujoco(emulator),
                       report=served_figures, what="driving Armstrong in MuJoCo")


def _layout() -> Layout:
    from .layout import LAYOUT

    return LAYOUT


ROBOTS = (RobotPlugin(
    "armstrong", "seed 001's 21-servo biped (20 on its bus), dynamixel_motor controllers "
    "or ros2_control",
    bus=_bus, open=_open, on_stop=ON_STOP, config=_config, files=_files, description=_urdf,
    served=_served, layout=_layout, aliases=("seed001",), commands=("walk", "gait")),)
