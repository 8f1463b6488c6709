"""Simulated worlds and the one owner of simulated time.

- :mod:`.simulation` — :class:`Simulation`: virtual time, fixed physics steps, real time
- :mod:`.world` — :class:`World`: the interface a world implements
- :mod:`.floor` — :class:`DiffDriveFloor`: two wheels on a flat floor
- :mod:`.ball` — :class:`BallWorld`: seed 002's treadmill, a fly walking on a ball
- :mod:`.mujoco_world` — :class:`MujocoWorld`: a robot in MuJoCo, each joint driven by its
  emulated servo's firmware (seed 001's biped)
- :mod:`.emulated` — emulated buses in a simulation (what ``emu://`` opens)

``docs/sim.md`` explains time, plants and worlds for someone who will write a world.
"""

from .ball import BallWorld
from .emulated import emulated_port, port_to
from .errors import SimError, SimulationError
from .floor import DiffDriveFloor, DiffDriveGeometry
from .mujoco_world import MujocoWorld, ServoJoint
from .simulation import DEFAULT_PHYSICS_STEP, Simulation
from .world import World

#: Every world servolab ships, by name. Each passes the contract test of
#: tests/sim/test_world_contract.py; add a new world here to have it checked.
WORLDS: dict[str, type[World]] = {
    DiffDriveFloor.name: DiffDriveFloor,
    BallWorld.name: BallWorld,
    MujocoWorld.name: MujocoWorld,
}

__all__ = ["DEFAULT_PHYSICS_STEP", "WORLDS", "BallWorld", "DiffDriveFloor", "DiffDriveGeometry",
           "MujocoWorld", "ServoJoint", "SimError", "Simulation", "SimulationError", "World",
           "emulated_port", "port_to"]
