"""The interface a world implements.

A world is the physics around some emulated motors: a floor under two wheels, a ball under a
fly, a biped in a physics engine. It takes motors over by putting its own
:class:`~servolab.dynamixel.plant.ServoPlant` in place of theirs
(:meth:`World.attach`); from then on the :class:`~.simulation.Simulation` calls
:meth:`World.step` once per physics step, before the emulated buses, and the motors' firmware
commands those plants and reads them back on the bus. What the robot cannot sense but a test,
a plot or an estimator's evaluation wants — where the base really is — comes out of
:meth:`World.ground_truth`.

Every world registered in :data:`servolab.sim.WORLDS` passes one contract test
(tests/sim/test_world_contract.py): it steps in fixed steps without bus traffic, two runs are
bit for bit the same, and it reports finite ground truth with the same keys every time.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

from ..dynamixel.emulator import VirtualMotor
from ..dynamixel.plant import ServoPlant
from .simulation import Simulation


class World(ABC):
    """Physics that owns the plants of some emulated motors."""

    #: the name it is registered under in :data:`servolab.sim.WORLDS`
    name: ClassVar[str]

    @abstractmethod
    def step(self, dt: float) -> None:
        """Move the physics on by one step of ``dt`` seconds: step every plant this world
        owns under its current command, then whatever those plants drive."""

    @abstractmethod
    def ground_truth(self) -> dict[str, float]:
        """The true state, in SI units, under names that stay the same for the whole run
        (e.g. ``x``, ``y``, ``yaw`` of a base)."""

    @classmethod
    @abstractmethod
    def example(cls, simulation: Simulation) -> World:
        """A small scene of this world in ``simulation``, with its motors on an emulated bus
        and already commanded to move: what the contract test and the docs run."""

    @staticmethod
    def attach(motor: VirtualMotor, plant: ServoPlant) -> ServoPlant:
        """Put ``plant`` under ``motor``'s firmware; the world then steps it."""
        motor.attach_plant(plant)
        return plant
