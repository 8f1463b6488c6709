"""The OpenMANIPULATOR-X on a table in MuJoCo, under gravity, with small boxes to pick: the world
``servolab control run open_manipulator_x --world robot`` and ``servolab sim --robot
open_manipulator_x`` put its emulated motors in.

The arm is its URDF (:func:`servolab.robots.description.mjcf` writes it, fixed at its base, each
servo's firmware driving its joint through the block's transmission: the gripper's rack through
its pinion, 0.01149 m a radian of horn), and the rest is added to that MJCF here: a table whose
top is the arm's base plane (z = 0) and :data:`BOXES` lying on it, each free to be pushed,
lifted and dropped. The sizes below are GUESSES, stated once: the e-Manual gives the arm's reach
(380 mm) and payload (500 g), not a table or the things a lab puts on it.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import TYPE_CHECKING

from servolab.robots import ServedRobot
from servolab.robots.errors import RobotError

from . import URDF, system, urdf_text

if TYPE_CHECKING:
    from servolab.dynamixel.emulator import Emulator
    from servolab.sim import MujocoWorld, Simulation

#: the table's top, x by y (m), centred this far in front of the arm's base (m), and its
#: thickness: a GUESS, a lab bench's corner with the arm 0.15 m from its back edge
TABLE_SIZE = (0.60, 0.80)
TABLE_CENTRE_X = 0.15
TABLE_THICKNESS = 0.02


@dataclass(frozen=True)
class Box:
    """A cube on the table: its name, edge (m), mass (kg) and where its centre starts (x, y
    on the table, m)."""

    name: str
    edge: float
    mass: float
    x: float
    y: float


#: three 25 mm cubes of 20 g within reach, in front and to each side: GUESSES (a cube the
#: gripper's 20-75 mm stroke closes on, far below its 500 g payload)
BOXES = (Box("box_front", 0.025, 0.020, 0.20, 0.0),
         Box("box_left", 0.025, 0.020, 0.18, 0.12),
         Box("box_right", 0.025, 0.020, 0.18, -0.12))


#: a box's contacts are its own (priority) and hard: MuJoCo's default soft contact (solref
#: 0.02 s, solimp 0.9-0.95) lets the gripper's 84 N squeeze (Goal Current 200 through the
#: rack) sink a finger millimetres into a 20 g box; these let it sink a fraction of one. And
#: the fingers' <mimic> tie as hard, so the right finger does not give way to the left.
#: Both GUESSES of a rigid plastic box and a rigid rack, tuned in MuJoCo (servolab arm pick)
HARD = {"priority": "1", "solimp": "0.99 0.999 0.001", "solref": "0.004 1"}
HARD_TIE = {"solimp": "0.99 0.999 0.001", "solref": "0.004 1"}


def _add(parent: ET.Element, tag: str, **attributes: str) -> ET.Element:
    return ET.SubElement(parent, tag, attributes)


def _numbers(*values: float) -> str:
    return " ".join(f"{v:.6g}" for v in values)


def table_mjcf(arm: str, boxes: tuple[Box, ...] = BOXES) -> str:
    """The arm's MJCF with the table and ``boxes`` added to its world body. Their geoms keep
    MuJoCo's default contact bits, so they touch each other and the fingers (the URDF's
    collision shapes), not the arm's drawn links."""
    root = ET.fromstring(arm)
    world = root.find("worldbody")
    if world is None:
        raise RobotError("the arm's MJCF has no <worldbody> to put the table in")
    length, width = TABLE_SIZE
    _add(world, "geom", name="table", type="box",
         size=_numbers(length / 2, width / 2, TABLE_THICKNESS / 2),
         pos=_numbers(TABLE_CENTRE_X, 0.0, -TABLE_THICKNESS / 2), rgba="0.55 0.42 0.3 1")
    for box in boxes:
        body = _add(world, "body", name=box.name, pos=_numbers(box.x, box.y, box.edge / 2))
        _add(body, "freejoint", name=box.name)
        _add(body, "geom", name=box.name, type="box", size=_numbers(*(box.edge / 2,) * 3),
             mass=_numbers(box.mass), rgba="0.85 0.2 0.15 1", **HARD)
    for tie in root.iter("equality"):   # the rack's two fingers on one pinion: rigid
        for joint in tie.findall("joint"):
            joint.attrib.update(HARD_TIE)
    return ET.tostring(root, encoding="unicode")


def on_table(emulator: Emulator) -> tuple[Simulation, Emulator, MujocoWorld]:
    """The arm's emulated motors (``emulator``, IDs 11 to 15) moving it on the table."""
    from servolab.robots.urdf_world import mujoco_placement

    place = mujoco_placement(urdf_text(), system(), URDF.name, scene=table_mjcf, base="link1")
    if place is None:
        raise RobotError(f"{URDF.name}: a link a joint moves has no mass")
    return place(emulator)


def served(baudrate: int | None) -> ServedRobot:
    """What ``servolab sim --robot open_manipulator_x`` serves: its five motors on the table."""
    found = system()
    spec = found.bus().motor_spec().at_baudrate(baudrate or found.baudrate)
    return ServedRobot(spec, place=on_table, what="moving the arm on its table in MuJoCo")


def box_positions(world: MujocoWorld) -> dict[str, tuple[float, float, float]]:
    """Where each box's centre is now (m, the arm's base frame: z up from the table's top)."""
    found: dict[str, tuple[float, float, float]] = {}
    for box in BOXES:
        x, y, z = (float(v) for v in world.data.xpos[world.model.body(box.name).id])
        found[box.name] = (x, y, z)
    return found

