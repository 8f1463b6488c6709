"""A flat floor under a two-wheel differential-drive base: the smallest world that moves.

Two emulated servos in wheel (velocity) mode turn the wheels; the floor rolls the base along
without slip and integrates its pose exactly along each step's arc. The wheels' plants are
:class:`~servolab.dynamixel.plant.KinematicServo` (they reach the commanded speed at once,
capped by the motor's no-load speed), stepped by this world, so the firmware's
present_position and present_velocity are the wheels' true rotation.

Conventions (REP 103): x forward, y left, yaw counter-clockwise from x, in metres and
radians. A motor's positive rotation is counter-clockwise seen from its horn; mounted on the
left of the base that drives it forward, on the right backward, hence the directions below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..dynamixel.emulator import VirtualMotor
from ..dynamixel.plant import KinematicServo
from .simulation import Simulation, SimulationError
from .world import World


@dataclass(frozen=True)
class DiffDriveGeometry:
    """Where the wheels are and how they are mounted."""

    wheel_radius: float = 0.033    # m
    wheel_separation: float = 0.16  # m, between the wheels' contact points
    #: sign of motor rotation that drives each wheel forward
    left_forward: int = 1
    right_forward: int = -1

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "wheel_separation"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SimulationError(f"{name} {value!r} m must be a positive number")
        for name in ("left_forward", "right_forward"):
            if getattr(self, name) not in (1, -1):
                raise SimulationError(f"{name} must be 1 or -1, not {getattr(self, name)!r}")


class DiffDriveFloor(World):
    """A differential-drive base on a flat floor, rolling without slip."""

    name = "diffdrive_floor"

    def __init__(self, left: VirtualMotor, right: VirtualMotor,
                 geometry: DiffDriveGeometry | None = None, *, x: float = 0.0, y: float = 0.0,
                 yaw: float = 0.0) -> None:
        self.geometry = geometry or DiffDriveGeometry()
        self.left = self.attach(left, KinematicServo(left.model.no_load_speed,
                                                     left.plant.position))
        self.right = self.attach(right, KinematicServo(right.model.no_load_speed,
                                                       right.plant.position))
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.linear_velocity = 0.0
        self.angular_velocity = 0.0
        self.distance = 0.0
        self.steps = 0

    def step(self, dt: float) -> None:
        g = self.geometry
        self.left.step(dt)
        self.right.step(dt)
        v_left = g.left_forward * self.left.velocity * g.wheel_radius
        v_right = g.right_forward * self.right.velocity * g.wheel_radius
        v = 0.5 * (v_left + v_right)
        w = (v_right - v_left) / g.wheel_separation
        turn = w * dt
        if abs(turn) < 1e-9:  # straight: the arc formula's limit
            self.x += v * dt * math.cos(self.yaw + 0.5 * turn)
            self.y += v * dt * math.sin(self.yaw + 0.5 * turn)
        else:
            radius = v / w
            self.x += radius * (math.sin(self.yaw + turn) - math.sin(self.yaw))
            self.y -= radius * (math.cos(self.yaw + turn) - math.cos(self.yaw))
        self.yaw = math.remainder(self.yaw + turn, 2 * math.pi)
        self.linear_velocity, self.angular_velocity = v, w
        self.distance += abs(v) * dt
        self.steps += 1

    def ground_truth(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "yaw": self.yaw,
                "linear_velocity": self.linear_velocity,
                "angular_velocity": self.angular_velocity, "distance": self.distance}

    @classmethod
    def example(cls, simulation: Simulation) -> DiffDriveFloor:
        """Two XM430-W210 (IDs 1 left, 2 right) at 1 Mbps in velocity mode, told to drive a
        left-hand arc."""
        from ..dynamixel.bus import Bus

        bus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000, simulation=simulation)
        world = simulation.add(cls(bus.emulator.motor(1), bus.emulator.motor(2)))
        bus.sync_write("operating_mode", {1: 1, 2: 1}, raw=True)  # velocity mode
        bus.sync_write("torque_enable", {1: 1, 2: 1})
        g = world.geometry
        bus.sync_write("goal_velocity", {1: g.left_forward * 2.0, 2: g.right_forward * 3.0})
        return world
