"""A flat floor under a differential-drive base: the smallest world that moves.

Emulated servos in wheel (velocity) mode turn the wheels — one motor a side, or several that
share a side's ground contact (seed 000's 4-motor base: motors 1-2 one side, 3-4 the other);
the floor rolls the base along and integrates its pose exactly along each step's arc. The
wheels' plants are stepped by this world, so the firmware's present_position and
present_velocity are the wheels' true rotation:

- by default :class:`~servolab.dynamixel.plant.KinematicServo` (the wheel reaches the commanded
  speed at once, capped by the motor's no-load speed);
- with ``max_acceleration`` a :class:`RampedWheel`, which reaches it at most that fast.

Optional wheel ``slip`` is a fraction of each wheel's rotation that does not move the base
(the encoders still count it), constant or with seeded, deterministic jitter. Optional
``encoder_noise`` (:class:`NoisyEncoder`) is white noise on the position each motor reports
(present_position), seeded; the floor itself rolls on the true rotation, so its ground truth
is what the wheels really did.

Conventions (REP 103): x forward, y left, yaw counter-clockwise from x, in metres and
radians. A motor's positive rotation is counter-clockwise seen from its horn; mounted on the
left of the base that drives it forward, on the right backward, hence the directions below.
"""

from __future__ import annotations

import math
import random
from collections.abc import Sequence
from dataclasses import dataclass, replace

from ..dynamixel.emulator import Emulator, VirtualMotor
from ..dynamixel.errors import ConfigError
from ..dynamixel.plant import KinematicServo, ServoCommand, ServoPlant
from .errors import SimulationError
from .simulation import Simulation
from .world import World

#: a side's forward sign: one for all its motors, or one per motor
Forward = int | tuple[int, ...]


@dataclass(frozen=True)
class DiffDriveGeometry:
    """Where the wheels are and how they are mounted.

    ``left_forward`` / ``right_forward``: the sign of motor rotation that drives that side's
    wheel forward — one int for all the side's motors, or a tuple with one sign per motor (in
    the order the motors are given to :class:`DiffDriveFloor`)."""

    wheel_radius: float = 0.033    # m
    wheel_separation: float = 0.16  # m, between the wheels' contact points
    #: sign of motor rotation that drives each wheel forward
    left_forward: Forward = 1
    right_forward: Forward = -1

    def __post_init__(self) -> None:
        for name in ("wheel_radius", "wheel_separation"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise SimulationError(f"{name} {value!r} m must be a positive number")
        for name in ("left_forward", "right_forward"):
            value = getattr(self, name)
            if isinstance(value, list):
                value = tuple(value)
                object.__setattr__(self, name, value)
            signs = value if isinstance(value, tuple) else (value,)
            if not signs or any(isinstance(s, bool) or s not in (1, -1) for s in signs):
                raise SimulationError(f"{name} must be 1 or -1 (or a non-empty tuple of "
                                      f"them, one per motor), not {value!r}")

    def signs(self, side: str, motors: int) -> tuple[int, ...]:
        """The forward sign of each of ``motors`` motors on ``side`` ("left" or "right")."""
        value = self.left_forward if side == "left" else self.right_forward
        if isinstance(value, tuple):
            if len(value) != motors:
                raise SimulationError(f"{side}_forward {value!r} gives {len(value)} sign(s) "
                                      f"for {motors} {side} motor(s)")
            return value
        return (value,) * motors


class NoisyEncoder:
    """A wheel plant whose reported position carries white noise of ``noise`` rad (standard
    deviation; seeded ``rng``): what the firmware reads as present_position, so odometry sees
    it, while the base rolls on the true rotation (the world reads :attr:`inner`'s speed)."""

    def __init__(self, inner: ServoPlant, noise: float, rng: random.Random) -> None:
        if not (math.isfinite(noise) and noise >= 0):
            raise SimulationError(f"encoder_noise {noise!r} rad must be 0 or more")
        self.inner = inner
        self.noise = float(noise)
        self._rng = rng

    @property
    def command(self) -> ServoCommand:
        return self.inner.command

    @command.setter
    def command(self, command: ServoCommand) -> None:
        self.inner.command = command

    @property
    def position(self) -> float:
        return self.inner.position + self._rng.gauss(0.0, self.noise)

    @property
    def velocity(self) -> float:
        return self.inner.velocity

    @property
    def effort(self) -> float:
        return self.inner.effort

    @property
    def temperature(self) -> float:
        return self.inner.temperature

    def step(self, dt: float) -> None:
        self.inner.step(dt)


class RampedWheel:
    """A wheel plant whose speed changes at most ``max_acceleration`` rad/s² (the base's
    inertia behind the motor), capped by the motor's no-load speed.

    In velocity control the speed moves toward the commanded one by at most
    ``max_acceleration × dt`` a step; with torque off it runs down to a stop at the same rate
    (reporting no load). Position control (joint mode) is passed to the inner
    :class:`KinematicServo` unramped. The horn's motion is the inner plant's, fed the ramped
    speed, so position, load and temperature stay its closed form's.
    """

    def __init__(self, no_load_speed: float, position: float = 0.0, *,
                 max_acceleration: float) -> None:
        if not (math.isfinite(max_acceleration) and max_acceleration > 0):
            raise SimulationError(f"max_acceleration {max_acceleration!r} rad/s^2 must be a "
                                  "positive number")
        self.max_acceleration = float(max_acceleration)
        self.inner = KinematicServo(no_load_speed, position)
        self._command = ServoCommand()
        self._speed = 0.0  # the ramped speed the inner plant is told to turn at

    @property
    def command(self) -> ServoCommand:
        return self._command

    @command.setter
    def command(self, command: ServoCommand) -> None:
        self._command = command  # acts from the next step, ramped

    @property
    def position(self) -> float:
        return self.inner.position

    @property
    def velocity(self) -> float:
        return self.inner.velocity

    @property
    def effort(self) -> float:
        return self.inner.effort if self._command.torque_enabled else 0.0

    @property
    def temperature(self) -> float:
        return self.inner.temperature

    def step(self, dt: float) -> None:
        cmd = self._command
        if cmd.torque_enabled and not cmd.velocity_control:
            self.inner.command = cmd
            self.inner.step(dt)
            self._speed = self.inner.velocity
            return
        top = self.inner.no_load_speed if cmd.torque_limit > 0 else 0.0
        target = max(-top, min(top, cmd.goal_velocity)) if cmd.torque_enabled else 0.0
        dv = self.max_acceleration * dt
        self._speed = max(self._speed - dv, min(self._speed + dv, target))
        if cmd.torque_enabled or self._speed != 0.0:
            self.inner.command = replace(cmd, torque_enabled=True, velocity_control=True,
                                         goal_velocity=self._speed,
                                         torque_limit=max(cmd.torque_limit, 1e-9))
        else:
            self.inner.command = cmd
        self.inner.step(dt)


def _motors(value: VirtualMotor | Sequence[VirtualMotor], side: str
            ) -> tuple[VirtualMotor, ...]:
    motors = (value,) if isinstance(value, VirtualMotor) else tuple(value)
    if not motors or not all(isinstance(m, VirtualMotor) for m in motors):
        raise SimulationError(f"{side}: give a VirtualMotor or a non-empty sequence of them")
    return motors


class DiffDriveFloor(World):
    """A differential-drive base on a flat floor.

    ``left`` and ``right`` are each a motor or a sequence of motors; a side's wheel speed is
    the mean of its motors' speeds, each times its forward sign (they share the wheel's ground
    contact). ``max_acceleration`` (rad/s² of the wheel, None: reached at once) ramps the
    wheels' speed; ``slip`` (0..1) is the fraction of each wheel's rotation that does not move
    the base, plus, if ``slip_jitter`` > 0, a normal per-step, per-wheel deviation of that
    standard deviation (clipped to 0..1) drawn from ``random.Random(seed)``.

    ``self.left`` / ``self.right`` are the first plant of each side (as with one motor a side);
    ``self.left_plants`` / ``self.right_plants`` all of them.
    """

    name = "diffdrive_floor"

    def __init__(self, left: VirtualMotor | Sequence[VirtualMotor],
                 right: VirtualMotor | Sequence[VirtualMotor],
                 geometry: DiffDriveGeometry | None = None, *, x: float = 0.0, y: float = 0.0,
                 yaw: float = 0.0, max_acceleration: float | None = None, slip: float = 0.0,
                 slip_jitter: float = 0.0, seed: int = 0, encoder_noise: float = 0.0) -> None:
        self.geometry = g = geometry or DiffDriveGeometry()
        left_motors, right_motors = _motors(left, "left"), _motors(right, "right")
        everyone = left_motors + right_motors
        if len({id(m) for m in everyone}) != len(everyone):
            raise SimulationError("a motor is given twice (each drives one side once)")
        self._left_signs = g.signs("left", len(left_motors))
        self._right_signs = g.signs("right", len(right_motors))
        for name, value in (("x", x), ("y", y), ("yaw", yaw)):
            if not math.isfinite(value):
                raise SimulationError(f"{name} {value!r} must be a finite number")
        if not (math.isfinite(slip) and 0.0 <= slip <= 1.0):
            raise SimulationError(f"slip {slip!r} must be a fraction from 0 to 1")
        if not (math.isfinite(slip_jitter) and slip_jitter >= 0.0):
            raise SimulationError(f"slip_jitter {slip_jitter!r} must be 0 or more")
        self.max_acceleration = max_acceleration
        self.slip, self.slip_jitter, self.seed = float(slip), float(slip_jitter), seed
        self._rng = random.Random(seed)
        if not (math.isfinite(encoder_noise) and encoder_noise >= 0.0):
            raise SimulationError(f"encoder_noise {encoder_noise!r} rad must be 0 or more")
        self.encoder_noise = float(encoder_noise)
        self._noise_rng = random.Random(seed + 1)
        self.left_motors, self.right_motors = left_motors, right_motors
        self.left_plants = tuple(self._wheel(m) for m in left_motors)
        self.right_plants = tuple(self._wheel(m) for m in right_motors)
        self.left, self.right = self.left_plants[0], self.right_plants[0]
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.linear_velocity = 0.0
        self.angular_velocity = 0.0
        self.distance = 0.0
        self.steps = 0

    def _wheel(self, motor: VirtualMotor) -> ServoPlant:
        position = motor.plant.position
        if self.max_acceleration is None:
            plant: ServoPlant = KinematicServo(motor.model.no_load_speed, position)
        else:
            plant = RampedWheel(motor.model.no_load_speed, position,
                                max_acceleration=self.max_acceleration)
        if self.encoder_noise > 0:
            attached = self.attach(motor, NoisyEncoder(plant, self.encoder_noise,
                                                       self._noise_rng))
            return attached.inner  # type: ignore[attr-defined, no-any-return]
        return self.attach(motor, plant)

    @staticmethod
    def _side_speed(plants: tuple[ServoPlant, ...], signs: tuple[int, ...]) -> float:
        """The side's wheel speed, rad/s forward: the mean of its motors'."""
        if len(plants) == 1:
            return signs[0] * plants[0].velocity
        return math.fsum(s * p.velocity for p, s in zip(plants, signs, strict=True)) \
            / len(plants)

    def _grip(self) -> float:
        """The fraction of a wheel's rotation that moves the base, this step."""
        slip = self.slip
        if self.slip_jitter > 0:
            slip = min(1.0, max(0.0, slip + self._rng.gauss(0.0, self.slip_jitter)))
        return 1.0 - slip

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """(left, right) wheel angular speeds, rad/s, positive forward."""
        return (self._side_speed(self.left_plants, self._left_signs),
                self._side_speed(self.right_plants, self._right_signs))

    def step(self, dt: float) -> None:
        g = self.geometry
        for plant in self.left_plants:
            plant.step(dt)
        for plant in self.right_plants:
            plant.step(dt)
        w_left, w_right = self.wheel_speeds
        v_left = w_left * g.wheel_radius
        v_right = w_right * g.wheel_radius
        if self.slip or self.slip_jitter:
            v_left *= self._grip()
            v_right *= self._grip()
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
    def for_base(cls, simulation: Simulation, emulator: Emulator,
                 left_ids: int | Sequence[int], right_ids: int | Sequence[int], *,
                 wheel_radius: float, wheel_separation: float,
                 left_forward: int | Sequence[int] = 1, right_forward: int | Sequence[int] = -1,
                 max_acceleration: float | None = None, slip: float = 0.0,
                 slip_jitter: float = 0.0, seed: int = 0, encoder_noise: float = 0.0,
                 x: float = 0.0, y: float = 0.0,
                 yaw: float = 0.0) -> DiffDriveFloor:
        """Put the base whose wheel motors are ``left_ids`` / ``right_ids`` on ``emulator``
        (an emulated bus already in ``simulation``: ``bus.emulator``, ``port.emulator``) on a
        floor, added to ``simulation``. A forward sign is one int for the side or one per ID.
        """
        if emulator not in simulation.emulators:
            raise SimulationError("for_base: this emulated bus is not in the simulation given "
                                  "(open it with simulation=..., or simulation.add_emulator)")

        def motors(ids: int | Sequence[int], side: str) -> list[VirtualMotor]:
            ids = [ids] if isinstance(ids, int) else list(ids)
            if not ids:
                raise SimulationError(f"for_base: no {side} motor IDs")
            try:
                return [emulator.motor(i) for i in ids]
            except ConfigError as e:  # no such motor
                raise SimulationError(f"for_base: {side} motor: {e.args[0]}") from None

        def forward(value: int | Sequence[int]) -> Forward:
            return value if isinstance(value, int) else tuple(value)

        geometry = DiffDriveGeometry(wheel_radius, wheel_separation, forward(left_forward),
                                     forward(right_forward))
        return simulation.add(cls(motors(left_ids, "left"), motors(right_ids, "right"),
                                  geometry, x=x, y=y, yaw=yaw,
                                  max_acceleration=max_acceleration, slip=slip,
                                  slip_jitter=slip_jitter, seed=seed,
                                  encoder_noise=encoder_noise))

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
        left, right = g.signs("left", 1)[0], g.signs("right", 1)[0]
        bus.sync_write("goal_velocity", {1: left * 2.0, 2: right * 3.0})
        return world
