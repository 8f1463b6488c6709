"""Armstrong in MuJoCo: the robot description's bodies, moved by its 20 emulated RX-28.

:func:`armstrong_world` puts a :class:`~servolab.sim.mujoco_world.MujocoWorld` under the
emulated bus of :mod:`.hardware`: the MJCF is the description's (``drive="firmware"``: no
actuators, each joint's torque comes from its motor's firmware), and each motor turns its
joint as the controllers see it — horn angle = the motor's ``init`` angle + the joint's sign
x the joint angle, the sign being the motor's direction (Table 4.2's signs, the
description's :attr:`~.description.Motor.direction`) and the controller's flip. The robot
starts as the emulated motors do: at their ``init`` positions, which is every joint at 0,
legs straight, soles on the floor.

Which world is the default, and why: ``servolab walk`` runs ``--world kinematic`` unless
told otherwise: the joints go where the firmware sends them, nothing can fall, and a walk
costs a fraction of a second — the right first check of a motion file (its limits, its
speeds, the bus's timing). ``--world mujoco`` adds gravity: a student runs it to see
whether the motion stands up, at about a third of the kinematic world's speed (benchmarks/
sim.py: 21 times real time against 56 to 83 with the same bus traffic).
"""

from __future__ import annotations

from dataclasses import dataclass

from ...dynamixel.emulator import Emulator
from ...sim.mujoco_world import MujocoWorld, ServoJoint
from ...sim.simulation import Simulation
from ..controllers.config import RobotConfig
from ..errors import RobotValueError
from .description import Assumptions, Description, describe, horn_maps, mjcf

#: The worlds ``servolab walk`` can put the emulated robot in (the first is the default).
WORLDS = ("kinematic", "mujoco")
#: The bodies whose floor contacts are support, not a fall.
FEET = ("left_foot", "right_foot")


def in_mujoco(emulator: Emulator, config: RobotConfig | None = None
              ) -> tuple[Simulation, Emulator, Physics]:
    """A simulation at the description's step with ``emulator`` (Armstrong's bus) in it,
    driving the biped in MuJoCo: what ``servolab sim --pty --robot armstrong`` serves."""
    from .description import TIMESTEP
    from .hardware import load_config

    simulation = Simulation(TIMESTEP)
    simulation.add_emulator(emulator)
    return simulation, emulator, armstrong_world(simulation, emulator,
                                                 config or load_config(), held=True)


@dataclass(frozen=True)
class Physics:
    """The MuJoCo world an emulated Armstrong stands in, with the description it came from."""

    world: MujocoWorld
    description: Description


def armstrong_world(simulation: Simulation, emulator: Emulator, config: RobotConfig,
                    assumptions: Assumptions | None = None, *, held: bool = False) -> Physics:
    """The MuJoCo world under ``emulator``'s motors (see the module docstring), added to
    ``simulation``; ``held``: in its harness until every servo's torque is on
    (:class:`~servolab.sim.mujoco_world.MujocoWorld`'s ``held_until_torque``), as served to a
    client that comes when it comes."""
    description = describe(assumptions, config)
    joints = []
    for horn in horn_maps(description, config).values():
        try:
            servo = emulator.motor(horn.id)
        except Exception:
            raise RobotValueError(f"motor {horn.id} ({horn.joint}) is not on the emulated "
                                  "bus") from None
        joints.append(ServoJoint(horn.joint, servo, horn.offset, horn.sign))
    world = MujocoWorld(mjcf(description, drive="firmware"), joints, base=description.root,
                        feet=FEET, start=simulation.now(), held_until_torque=held)
    simulation.add(world)
    return Physics(world, description)
