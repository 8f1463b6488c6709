"""A URDF robot's emulated motors moving its description in MuJoCo: what ``servolab sim --robot
NAME`` serves for a robot folder whose links have their masses (a URDF's ``<inertial>``).

The description is read from the URDF (:mod:`.description`), each driven joint gets the
Dynamixel its ``<ros2_control>`` block names, and :func:`~.description.mjcf` writes it with the
root fixed to the world and no floor (an arm on its table, a head on its mount); each servo's
firmware drives its joint in :class:`~servolab.sim.MujocoWorld`. A URDF without masses is a
drawing, not a body: MuJoCo cannot move it, and its motors are served alone.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

from .description import TIMESTEP, Description, Motor, mjcf
from .dynamixel_system import DynamixelSystem

if TYPE_CHECKING:
    from ..dynamixel.emulator import Emulator
    from ..sim.mujoco_world import MujocoWorld
    from ..sim.simulation import Simulation

Placement = Callable[["Emulator"], tuple["Simulation", "Emulator", "MujocoWorld"]]


#: kg m², each driven joint's armature (its servo's rotor inertia seen through the gears)
#: where the URDF gives none: a guess, Armstrong's rotor inertia (1e-7 kg m², the order of a
#: small coreless motor's; the e-Manual gives none) times an XM430-W350's gear ratio squared
#: (353.5:1, e-Manual) ≈ 0.0125. Without it a light link under a servo's full torque is
#: stiffer than MuJoCo's 2 ms step can integrate; the servos' own motor models will replace it.
ARMATURE = 0.0125


def described(urdf: str, system: DynamixelSystem, source: str) -> Description:
    """The URDF's description with the block's Dynamixels on their joints, each with
    :data:`ARMATURE` unless the description states one."""
    description = Description.from_urdf(urdf, source).with_motors(
        {j.name: Motor(j.id, j.model.name) for j in system.joints})
    driven = {j.name for j in system.joints}
    return replace(description, joints=tuple(
        replace(j, armature=ARMATURE) if j.name in driven and j.armature is None else j
        for j in description.joints))


def has_masses(description: Description) -> bool:
    """Whether every link a joint moves has a mass MuJoCo can move."""
    moved = {j.child for j in description.joints if j.movable}
    return all(description.link(name).mass > 0 for name in moved)


def mujoco_placement(urdf: str, system: DynamixelSystem, source: str) -> Placement | None:
    """How to put the robot's emulated motors in MuJoCo, or None when its URDF has no masses."""
    description = described(urdf, system, source)
    if not has_masses(description):
        return None
    model = mjcf(description, "firmware")

    def place(emulator: Emulator) -> tuple[Simulation, Emulator, MujocoWorld]:
        from ..sim import MujocoWorld, ServoJoint, Simulation

        simulation = Simulation(TIMESTEP)
        simulation.add_emulator(emulator)
        joints = [ServoJoint(j.name, emulator.motor(m.id), direction=m.direction,
                             gear_ratio=m.gear_ratio) for j, m in description.motors]
        world = simulation.add(MujocoWorld(model, joints, start=simulation.now()))
        return simulation, emulator, world

    return place
