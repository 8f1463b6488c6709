"""The camera PC's node of seed 002 (Listing 1's ``image_converter``): each frame is tracked,
the treadmill's three wheels are told how to turn, the robot is told how to drive, and the
frame's record is logged.

Per frame, in the listing's order:

1. the tracker finds the fly (:func:`~servolab.vision.fly_tracker.track_fly`);
2. the controller (:func:`~.control.fly_command`) gives the wheel speeds and the robot's
   Twist;
3. one SYNC_WRITE of ``goal_velocity`` to the three X-series motors (IDs 100-102), truncated to
   whole units as the listing's ``(int)`` does, and one SYNC_READ of ``present_position``;
4. the 17-value record of Listing 1 is written to ``fly_data.bin`` (the thesis's layout,
   :mod:`.fly_logs`) and published, with ``/cmd_vel`` (``geometry_msgs/msg/Twist``) for the
   robot and ``/fly/pose`` (``geometry_msgs/msg/Pose2D``: cx, cy px, theta rad, in the image).

The frames come from a ``camera`` callable (the simulated camera, recorded frames, ...), so
the node is the same on every source. Stopping the node does what ``motor_deinit`` does: the
wheels are stopped and their torque switched off, also after an error.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ...dynamixel.bus import Bus
from ...middleware.context import Context
from ...middleware.messages import time_of
from ...middleware.node import Node
from ...vision.fly_tracker import FlySighting, FlyTrackerConfig, track_fly
from ..bus_owner import BusOwner
from ..errors import RobotValueError
from .control import FlyCommand, FlyControllerConfig, fly_command
from .logs import FlyLogWriter

#: Listing 1: DXL1_ID..DXL3_ID, Protocol 2.0 at 1 Mbps
TREADMILL_IDS = (100, 101, 102)
TREADMILL_BAUDRATE = 1_000_000
#: the thesis's wheel motors (XM430-W210, seed 002 section 2)
TREADMILL_MODEL = "XM430-W210"
#: Listing 3: the camera's frame_rate
FRAME_RATE = 66.0
TWIST = "geometry_msgs/msg/Twist"
POSE2D = "geometry_msgs/msg/Pose2D"
JOINT_STATE = "sensor_msgs/msg/JointState"
Camera = Callable[[], "npt.NDArray[np.uint8] | None"]


def emulated_treadmill_bus(simulation: Any) -> Bus:
    """The treadmill's three wheels emulated in ``simulation``: XM430-W210, IDs 100-102,
    Protocol 2.0 at 1 Mbps, as Listing 1 addresses them."""
    return Bus.open(f"emu://{TREADMILL_MODEL.lower()}:{TREADMILL_IDS[0]}-{TREADMILL_IDS[-1]}",
                    baudrate=TREADMILL_BAUDRATE, simulation=simulation)


@dataclass
class Treadmill:
    """The treadmill as :func:`servolab.robots.load` gives it: its wheels' bus and, when
    emulated, the simulated ball (with a walking fly) they turn and the simulation both live
    in. Stopping means zero speed and torque off: a ball left turning would carry the fly."""

    bus: Bus
    world: Any = None
    simulation: Any = None

    @classmethod
    def open(cls, port: str | None = None) -> Treadmill:
        if port is not None:
            return cls(Bus.open(port, protocol=2, baudrate=TREADMILL_BAUDRATE))
        from ...sim import Simulation
        from ...sim.fly_walk import FlyWalker

        simulation = Simulation()
        bus, world = simulated_treadmill(simulation, FlyWalker())
        return cls(bus, world, simulation)

    def stop(self) -> None:
        stop_wheels(self.bus)

    def close(self) -> None:
        self.bus.close()


def stop_wheels(bus: Bus, ids: tuple[int, ...] = TREADMILL_IDS) -> None:
    """Zero goal velocity, then torque off (also when the first write fails), on every wheel:
    Listing 1's motor_deinit."""
    try:
        bus.sync_write("goal_velocity", dict.fromkeys(ids, 0), raw=True)
    finally:
        bus.sync_write("torque_enable", dict.fromkeys(ids, 0))


class TreadmillNode(Node):
    """See the module docstring. ``camera()`` returns the next frame, or None when there is
    none (a recording that ended: the node then stops the wheels and sets :attr:`finished`)."""

    def __init__(self, context: Context, bus: Bus, camera: Camera, *,
                 log: FlyLogWriter | None = None,
                 tracker: FlyTrackerConfig | None = None,
                 controller: FlyControllerConfig | None = None,
                 frame_rate: float = FRAME_RATE, ids: tuple[int, int, int] = TREADMILL_IDS,
                 name: str = "image_converter", namespace: str = "/",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        if not (math.isfinite(frame_rate) and frame_rate > 0):
            raise RobotValueError(f"frame_rate {frame_rate!r} must be a number > 0 of frames/s")
        self.bus, self.camera, self.log, self.ids = bus, camera, log, ids
        self.tracker = tracker or FlyTrackerConfig()
        self.controller = controller or FlyControllerConfig(
            max_wheel_speed=min(float(v) for v in bus.sync_read(
                "velocity_limit", ids, raw=True).values()))
        self.frames = 0
        self.finished = False
        self.last: tuple[FlySighting, FlyCommand] | None = None
        self._previous: float | None = None
        self._motor_init()
        self.cmd_vel = self.create_publisher(TWIST, "/cmd_vel", 10)
        self.pose = self.create_publisher(POSE2D, "/fly/pose", 10)
        self.wheels = self.create_publisher(JOINT_STATE, "/treadmill/joint_states", 10)
        # each frame's bus work (the wheels' goal velocities, then their positions) is the
        # one step of the sweep of the bus's one owner, at the camera's frame rate
        self.owner = BusOwner(context, bus, rate=frame_rate, steps=[self._frame])

    def _motor_init(self) -> None:
        """``motor_init``: torque off, velocity mode (address 11 <- 1), torque on."""
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 0))
        self.bus.sync_write("operating_mode", dict.fromkeys(self.ids, 1), raw=True)
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 1))

    def motor_deinit(self) -> None:
        """The wheels stopped and their torque off, as the listing's ``motor_deinit``."""
        stop_wheels(self.bus, tuple(self.ids))

    def _frame(self) -> None:
        if self.finished:
            return
        image = self.camera()
        if image is None:
            self.finished = True
            self.motor_deinit()
            return
        started = time.perf_counter()  # Listing 1's `begin`: once the frame is in hand
        now = self.now()
        sampling_us = 0.0 if self._previous is None else (now - self._previous) * 1e6
        self._previous = now
        target = self.controller.target
        sighting = track_fly(image, self.tracker, target=(target[0], target[1]))
        command = fly_command(sighting, sampling_us, self.controller)
        raw = {i: int(v) for i, v in zip(self.ids, command.wheel_speeds, strict=True)}
        self.bus.sync_write("goal_velocity", raw, raw=True)
        present = self.bus.sync_read("present_position", self.ids, raw=True)
        positions = [float(present[i]) for i in self.ids]
        loop_us = (time.perf_counter() - started) * 1e6
        self.last = (sighting, command)
        # the listing's `secs` is taken when the record is written, after the bus
        record = [float(self.frames), loop_us, sampling_us, sighting.cx, sighting.cy,
                  sighting.theta, command.dxm, command.dym, command.dthm,
                  *command.wheel_speeds, sighting.area, *positions, self.now()]
        if self.log is not None:
            self.log.write(record)
        stamp = time_of(now)
        self.cmd_vel.publish(self.message(TWIST, linear={"x": command.linear},
                                          angular={"z": command.angular}))
        self.pose.publish(self.message(POSE2D, x=sighting.cx, y=sighting.cy,
                                       theta=sighting.theta))
        self.wheels.publish(self.message(
            JOINT_STATE, header={"stamp": stamp},
            name=[f"aot_wheel_{i}" for i in self.ids],
            position=[self.bus.to_si(i, "present_position", int(present[i]))
                      for i in self.ids],
            velocity=[self.bus.to_si(i, "goal_velocity", raw[i]) for i in self.ids]))
        self.frames += 1

    def destroy(self) -> None:
        self.owner.close()
        try:
            self.motor_deinit()
        finally:
            super().destroy()


def simulated_treadmill(simulation: Any, walker: Any) -> tuple[Any, Any]:
    """The emulated wheels (:func:`emulated_treadmill_bus`) under a
    :class:`~servolab.sim.ball.BallWorld` with ``walker`` on the ball, in ``simulation``."""
    from ...sim import BallWorld

    bus = emulated_treadmill_bus(simulation)
    world = simulation.add(BallWorld([bus.emulator.motor(i) for i in TREADMILL_IDS], walker=walker))
    return bus, world
