"""The Active Omni-directional Treadmill of seed 002 as a world: a ball on three omni-wheels,
driven by emulated X-series motors, with a fly walking on top, seen from the camera.

Each physics step:

1. the three wheel plants follow their motors' goal velocity, each with the rig's stiction (a
   wheel at rest starts ``stiction_delay`` after it is told to move: the thesis measured about
   110 ms between the end of image processing and the motors' motion, chapter 3) and an
   acceleration limit (the ball's inertia);
2. the wheels' speeds give the ball's surface velocity under the fly, in the motors' frame,
   through ``ball_model``: by default ``"rigid"``, the ball as a rigid body rolling without
   slip along each wheel's rim (or with a stated ``slip``;
   :class:`~servolab.kinematics.ball_rolling.RollingBall`); or ``"eq3b"``, the thesis's
   eq. 3b itself (:class:`~servolab.kinematics.aot.AotKinematics`, from the rig's geometry).
   The controller and the analysis use eq. 3b, as the thesis does; a world that moved by it
   too would agree with them by construction, and hide that eq. 3b is not the rolling
   constraint (at the rig's 40 deg, for the same wheel speeds, the rolling ball translates
   2.51 times and turns 0.87 times as fast as eq. 3b says: eq. 3b's turn against translation
   is 2.9 times the ball's, :mod:`servolab.kinematics.aot`). ``"eq3b"`` is there to show
   the difference;
3. that velocity is turned into the camera's image frame (the camera is turned
   ``camera_to_motor`` from the motors' axes, Listing 1's ``thm``; ``handedness`` says which
   image axes run against the ball's, since the thesis does not: the default is the one under
   which Listing 1's signs compensate, as they did on the rig);
4. the fly moves by its own walk (:class:`~.fly_walk.FlyWalker`) plus the surface under it.

What the camera sees, and what :meth:`ground_truth` reports, is the fly in image pixels
(``fly_x``, ``fly_y``, ``fly_theta``: x right, y down, theta as the tracker measures it), the
ball's rotation integrated as the path of its surface (``ball_x``, ``ball_y`` m, ``ball_yaw``
rad, by the world's ``ball_model``; the thesis's Figure 20 computes that path from the
encoders by eq. 3b), and how far the fly walked.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

from ..dynamixel.emulator import VirtualMotor
from ..dynamixel.plant import ServoPlant
from ..kinematics.aot import CAMERA_HANDEDNESS, AotGeometry, AotKinematics, surface_in_camera
from ..kinematics.ball_rolling import RollingBall, check_slip
from ..kinematics.errors import KinematicsValueError
from ..vision.fly_tracker import PX_PER_MM
from .errors import SimulationError
from .floor import RampedWheel
from .fly_walk import FlyWalker
from .simulation import Simulation
from .world import World

#: the camera's image (Listing 1, Listing 3's format7 ROI)
IMAGE_SIZE = (640, 376)
#: how :class:`BallWorld` turns wheel speeds into the ball's motion (see the module docstring)
BALL_MODELS = ("rigid", "eq3b")


class StictionWheel(RampedWheel):
    """A :class:`~.floor.RampedWheel` (speed changes at most ``max_acceleration`` rad/s²)
    that, at rest, starts only ``delay`` s after it is told to move (see the module
    docstring)."""

    def __init__(self, no_load_speed: float, position: float = 0.0, *, delay: float,
                 max_acceleration: float) -> None:
        if not (math.isfinite(delay) and delay >= 0):
            raise SimulationError(f"delay {delay!r} must be a number of seconds >= 0")
        super().__init__(no_load_speed, position, max_acceleration=max_acceleration)
        self.delay = float(delay)
        self._waiting = 0.0  # s a wheel at rest has been told to move

    def step(self, dt: float) -> None:
        command = self.command
        wants = command.torque_enabled and command.velocity_control \
            and command.goal_velocity != 0.0
        if self._speed == 0.0 and wants and self._waiting < self.delay:
            self._waiting += dt  # stiction: not yet
            self.command = replace(command, goal_velocity=0.0)
            super().step(dt)
            self.command = command
            return
        if not wants or self._speed != 0.0:
            self._waiting = 0.0
        super().step(dt)


def _checked_slip(slip: float) -> float:
    try:
        return check_slip(slip)
    except KinematicsValueError as error:
        raise SimulationError(str(error)) from None


def _ball_kinematics(ball_model: str, geometry: AotGeometry,
                     slip: float) -> RollingBall | AotKinematics:
    """The map from wheel speeds to the ball's surface motion, by name (:data:`BALL_MODELS`);
    both have ``ball_velocity(wheel_speeds) -> (x', y', theta')``."""
    if ball_model == "rigid":
        return RollingBall(geometry, slip)
    if ball_model == "eq3b":
        return AotKinematics.from_geometry(geometry)
    raise SimulationError(f"ball_model {ball_model!r} must be one of {', '.join(BALL_MODELS)}")


class BallWorld(World):
    """The treadmill (see the module docstring). ``motors`` are the three wheels in the order
    of the geometry's ``wheel_angles`` (IDs 100, 101, 102 on the rig). ``ball_model`` is one
    of :data:`BALL_MODELS`; ``slip`` (in [0, 1), default 0) is the fraction of each wheel's
    rim speed the contact does not pass on to the ball, under either model."""

    name = "fly_ball"

    def __init__(self, motors: Sequence[VirtualMotor], geometry: AotGeometry | None = None,
                 *, walker: FlyWalker | None = None, px_per_mm: float = PX_PER_MM,
                 image_size: tuple[int, int] = IMAGE_SIZE,
                 handedness: tuple[int, int, int] = CAMERA_HANDEDNESS,
                 stiction_delay: float = 0.11, max_acceleration: float = 40.0,
                 start: tuple[float, float, float] | None = None,
                 ball_model: str = "rigid", slip: float = 0.0) -> None:
        if len(motors) != 3:
            raise SimulationError(f"the treadmill has three wheel motors, not {len(motors)}")
        if any(h not in (-1, 1) for h in handedness) or len(handedness) != 3:
            raise SimulationError(f"handedness {handedness!r} must be three signs (+-1)")
        self.geometry = geometry = geometry or AotGeometry()
        self.ball_model = ball_model
        self.slip = _checked_slip(slip)
        self.kinematics = _ball_kinematics(ball_model, geometry, self.slip)
        self.walker = walker or FlyWalker()
        self.px_per_m = px_per_mm * 1000.0
        self.image_size = image_size
        self.handedness = handedness
        self.plants: tuple[ServoPlant, ...] = tuple(
            self.attach(m, StictionWheel(m.model.no_load_speed, m.plant.position,
                                         delay=stiction_delay,
                                         max_acceleration=max_acceleration))
            for m in motors)
        w, h = image_size
        x, y, theta = start if start is not None else (w / 2, h / 2, 0.0)
        self.fly_x, self.fly_y, self.fly_theta = float(x), float(y), float(theta)
        self.ball_x = self.ball_y = self.ball_yaw = 0.0
        self.walked = 0.0
        self.surface = (0.0, 0.0, 0.0)  # the last step's surface velocity, image frame

    def wheel_speeds(self) -> tuple[float, float, float]:
        a, b, c = (p.velocity for p in self.plants)
        return (a, b, c)

    def step(self, dt: float) -> None:
        for plant in self.plants:
            plant.step(dt)
        motion = self.kinematics.ball_velocity(self.wheel_speeds())
        if self.ball_model == "eq3b" and self.slip:
            motion = motion * (1.0 - self.slip)  # RollingBall applies its own slip
        vx, vy, wz = (float(v) for v in motion)
        self.ball_x += vx * dt
        self.ball_y += vy * dt
        self.ball_yaw += wz * dt
        sx, sy, sz = (float(v) for v in surface_in_camera(motion, self.geometry,
                                                           self.handedness))
        self.surface = (sx, sy, sz)
        speed, turn = self.walker.step(dt)
        self.walked += speed * dt
        # the ball's spin about its vertical axis (under the image centre) also carries an
        # off-centre fly round it: omega x r
        w, h = self.image_size
        rx, ry = self.fly_x - w / 2, self.fly_y - h / 2
        self.fly_x += ((speed * math.cos(self.fly_theta) + sx) * self.px_per_m - sz * ry) * dt
        self.fly_y += ((speed * math.sin(self.fly_theta) + sy) * self.px_per_m + sz * rx) * dt
        self.fly_theta = math.remainder(self.fly_theta + (turn + sz) * dt, 2 * math.pi)

    def ground_truth(self) -> dict[str, float]:
        return {"fly_x": self.fly_x, "fly_y": self.fly_y, "fly_theta": self.fly_theta,
                "ball_x": self.ball_x, "ball_y": self.ball_y, "ball_yaw": self.ball_yaw,
                "fly_walked": self.walked}

    @classmethod
    def example(cls, simulation: Simulation) -> BallWorld:
        """Three XM430-W210 (IDs 100-102, Protocol 2.0, 1 Mbps) in velocity mode, the ball
        turning under a fly that walks (seed 0)."""
        from ..dynamixel.bus import Bus

        bus = Bus.open("emu://xm430-w210:100-102", baudrate=1_000_000, simulation=simulation)
        ids = (100, 101, 102)
        world = simulation.add(cls([bus.emulator.motor(i) for i in ids],
                                   walker=FlyWalker(seed=0)))
        bus.sync_write("operating_mode", dict.fromkeys(ids, 1), raw=True)  # velocity mode
        bus.sync_write("torque_enable", dict.fromkeys(ids, 1))
        bus.sync_write("goal_velocity", {100: 1.0, 101: -0.5, 102: -0.5})
        return world
