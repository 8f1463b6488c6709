"""The OpenMANIPULATOR-X as a servolab robot plug-in, found by ``servolab.robots.registry`` as
every robot under ``servolab/robots/`` is (a lab's own package would name :data:`ROBOTS` in a
``servolab.robots`` entry point instead: nothing else changes).

Why a plug-in and not a robot folder: a folder of data (URDF, controllers file, robot.yaml)
would bring the arm up, but its world would be MuJoCo's bare arm; the table and the boxes to
pick are a few lines of code (:mod:`.world`), and so is the layout. Everything the robot *is*
stays data: the URDF and the controllers file beside this module.

ROBOTIS's ``<ros2_control>`` block names no motor model; this plug-in gives :data:`.MODEL` to
everything it opens (its bus, ``servolab.robots.load``, its world). ``servolab control run``
takes the model from ``--model`` only: a plug-in has no field to declare it in.

It is also the default arm of ``servolab arm`` and ``servolab teleop`` (``default_for``: no
command names it), and declares its leader, ``open_manipulator_x_leader`` (the arm with its
torque off, moved by a scripted hand about :data:`.HAND` when served), as any arm's package may
with :func:`servolab.robots.teleop.leader.leader_plugin`.

Nothing here is read or imported until asked, so listing the robots costs nothing.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from servolab.robots import BusSummary, RobotPlugin, ServedRobot
from servolab.robots.plugin import ShownFile
from servolab.robots.teleop.leader import leader_plugin
from servolab.robots.urdf_robot import ON_STOP

from . import CONTROLLERS, HAND, MODEL, NAME, URDF, system, urdf_text

if TYPE_CHECKING:
    from servolab.middleware.view.layout import Layout

#: what ``servolab robots`` says of it
SUMMARY = ("ROBOTIS's OpenMANIPULATOR-X: a 4-joint arm and a gripper of XM430-W350, "
           "ros2_control")
#: what stopping does: the joints hold their last goals, torque on (an arm must not fall)
STOP = "hold"


def _bus() -> BusSummary:
    return system().bus()


def _open(port: str | None) -> Any:
    """The arm on emulated motors (``port`` None) or on a serial port: joints by name, in
    radians (the gripper in metres), within the URDF's limits."""
    from servolab.robots.urdf_robot import UrdfRobot

    return UrdfRobot.open(NAME, urdf_text(), port, source=URDF.name, default_model=MODEL,
                          on_stop=STOP)


def _config() -> Path:
    return URDF


def _files() -> Mapping[str, ShownFile]:
    here = URDF.parent   # MoveIt's two files, which servolab arm reads
    return {f"{NAME}.controllers": CONTROLLERS, f"{NAME}.srdf": here / f"{NAME}.srdf",
            f"{NAME}.joint_limits": here / f"{NAME}_joint_limits.yaml"}


def _served(baudrate: int | None) -> ServedRobot:
    from .world import served

    return served(baudrate)


def _layout() -> Layout:
    from .layout import layout

    return layout()


ROBOTS = (RobotPlugin(NAME, SUMMARY, bus=_bus, open=_open, on_stop=ON_STOP[STOP],
                      config=_config, files=_files, description=urdf_text, served=_served,
                      layout=_layout, default_model=MODEL, commands=("arm", "teleop"),
                      default_for=("arm", "teleop")),
          leader_plugin(NAME, HAND, summary="an OpenMANIPULATOR-X as a leader arm: torque "
                        "off, moved by a scripted hand when emulated (servolab teleop)",
                        default_model=MODEL))
