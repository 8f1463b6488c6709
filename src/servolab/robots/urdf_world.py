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
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from .description import TIMESTEP, Description, Motor, mjcf
from .dynamixel_system import DynamixelJoint, DynamixelSystem

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


#: Drive Mode(10)'s reverse bit (bit 0, e-Manual): the firmware counts the horn backwards
REVERSE_BIT = 0x01


@dataclass(frozen=True)
class Transmission:
    """How a motor's horn, as it physically turns, moves its joint: horn (rad) = ``offset`` +
    ``direction`` x ``gear_ratio`` x joint (rad, or m for a rack), what a MuJoCo servo joint
    takes. The block states the joint against the horn *as the firmware counts it* (joint =
    scale x count + offset), and the firmware counts backwards when the block writes Drive
    Mode's reverse bit (OpenMANIPULATOR-X's gripper, Drive Mode 5): the physical horn is that
    count times -1."""

    offset: float
    direction: int
    gear_ratio: float

    @classmethod
    def of(cls, joint: DynamixelJoint) -> Transmission:
        reverse = any(name == "drive_mode" and value & REVERSE_BIT
                      for name, value in joint.settings)
        sign = (-1 if reverse else 1) * (1 if joint.scale > 0 else -1)
        return cls(-sign * joint.offset / abs(joint.scale), sign, 1.0 / abs(joint.scale))


def described(urdf: str, system: DynamixelSystem, source: str) -> Description:
    """The URDF's description with the block's Dynamixels on their joints through their
    :class:`Transmission`, each with :data:`ARMATURE` seen through its gear ratio (a horn
    radian's times the ratio squared: a rack's is the pinion's over its radius squared)
    unless the description states one."""
    motors = {}
    for joint in system.joints:
        transmission = Transmission.of(joint)
        motors[joint.name] = Motor(joint.id, joint.model.name, transmission.direction,
                                   transmission.gear_ratio)
    description = Description.from_urdf(urdf, source).with_motors(motors)
    return replace(description, joints=tuple(
        replace(j, armature=ARMATURE * motors[j.name].gear_ratio ** 2)
        if j.name in motors and j.armature is None else j for j in description.joints))


def has_masses(description: Description) -> bool:
    """Whether every link a joint moves has a mass MuJoCo can move."""
    moved = {j.child for j in description.joints if j.movable}
    return all(description.link(name).mass > 0 for name in moved)


def mujoco_placement(urdf: str, system: DynamixelSystem, source: str, *,
                     scene: Callable[[str], str] | None = None,
                     base: str | None = None) -> Placement | None:
    """How to put the robot's emulated motors in MuJoCo, or None when its URDF has no masses.
    ``scene`` edits the robot's MJCF before it is compiled (a plug-in's table and objects);
    ``base`` is the link whose pose is the world's ground truth (MujocoWorld's ``base``)."""
    description = described(urdf, system, source)
    if not has_masses(description):
        return None
    model = mjcf(description, "firmware")
    if scene is not None:
        model = scene(model)
    transmissions = {j.name: Transmission.of(j) for j in system.joints}

    def place(emulator: Emulator) -> tuple[Simulation, Emulator, MujocoWorld]:
        from ..sim import MujocoWorld, ServoJoint, Simulation

        simulation = Simulation(TIMESTEP)
        simulation.add_emulator(emulator)
        joints = [ServoJoint(j.name, emulator.motor(m.id), transmissions[j.name].offset,
                             m.direction, m.gear_ratio) for j, m in description.motors]
        world = simulation.add(MujocoWorld(model, joints, base=base, start=simulation.now()))
        return simulation, emulator, world

    return place
