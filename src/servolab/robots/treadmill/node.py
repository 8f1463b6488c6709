"""The camera PC's node of seed 002 (Listing 1's ``image_converter``): each frame is tracked,
the treadmill's three wheels are told how to turn, the robot is told how to drive, and the
frame's record is logged.

Frames come as ``sensor_msgs/msg/Image`` on ``/image_raw``, as Listing 1 subscribes (a queue
of one: a frame that comes while one is being handled replaces the one waiting), from
:class:`~.camera_node.CameraNode` or any ROS camera driver. Per frame, in the listing's order:

1. the tracker finds the fly (:func:`~servolab.vision.fly_tracker.track_fly`);
2. the controller (:func:`~.control.fly_command`) gives the wheel speeds and the robot's
   Twist, dividing by the time between the frames' capture stamps;
3. one SYNC_WRITE of ``goal_velocity`` to the three X-series motors (IDs 100-102), truncated to
   whole units as the listing's ``(int)`` does, and one SYNC_READ of ``present_position``;
4. the 17-value record of Listing 1 is written to ``fly_data.bin`` (the thesis's layout,
   :mod:`.logs`; its first value the camera's frame number, :mod:`.timing`) and published,
   with ``/cmd_vel`` (``geometry_msgs/msg/Twist``) for the robot, ``/fly/pose``
   (``geometry_msgs/msg/Pose2D``: cx, cy px, theta rad, in the image) and, when someone
   subscribes, Listing 1's drawing (the fly's outline, its centre, the dead band round the
   target) on ``/image_converter/output_video``, the listing's ``image_pub_`` topic;
5. FicTrac's 25 columns for the frame (:mod:`.fictrac`: the ball's rotation from the wheels
   through eq. 3b, integrated) on ``/fictrac/data`` and, given a writer, to FicTrac's
   ``.dat``, so that a FicTrac user's scripts read the run.

A frame that cannot be used (an encoding or size the rig's camera does not have, a stamp that
goes back) is refused and counted, with an error logged. Stopping the node does what
``motor_deinit`` does: the wheels are stopped and their torque switched off, also after an
error.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from ...dynamixel.bus import Bus
from ...dynamixel.errors import CommError
from ...middleware.context import Context
from ...middleware.images import IMAGE, ImageMessageError, image_fields, mono8_of
from ...middleware.messages import seconds_of
from ...middleware.node import Node
from ...vision.fly_tracker import FlySighting, draw_overlay, track_fly
from ..errors import RobotError
from .config import FRAME_RATE, RigConfig
from .control import FlyCommand, fly_command
from .fictrac import FicTracIntegrator, FicTracWriter, multiarray_value
from .logs import FlyLogWriter
from .timing import frame_timing, sequence_of

#: Listing 1: DXL1_ID..DXL3_ID, Protocol 2.0 at 1 Mbps
TREADMILL_IDS = (100, 101, 102)
TREADMILL_BAUDRATE = 1_000_000
#: the thesis's wheel motors (XM430-W210, seed 002 section 2)
TREADMILL_MODEL = "XM430-W210"
#: frames in a row that may keep the last wheel positions before the run ends (a third of a
#: second at 66 frames/s)
MAX_MISSED_READS = 22
#: Listing 1's image_pub_: what the tracker saw, drawn on the frame
OVERLAY_TOPIC = "/image_converter/output_video"
__all__ = ["FRAME_RATE", "OVERLAY_TOPIC", "TREADMILL_BAUDRATE", "TREADMILL_IDS", "Treadmill",
           "TreadmillNode", "emulated_treadmill_bus", "simulated_treadmill", "stop_wheels"]
TWIST = "geometry_msgs/msg/Twist"
POSE2D = "geometry_msgs/msg/Pose2D"
JOINT_STATE = "sensor_msgs/msg/JointState"
MULTIARRAY = "std_msgs/msg/Float64MultiArray"


class SequenceSource(Protocol):
    """A camera that says each frame's number by its stamp (:class:`~.camera_node.CameraNode`)."""

    def sequence_at(self, stamp_ns: int) -> int | None: ...


#: each frame's FicTrac columns (:mod:`.fictrac`), for FicTrac users' live tools
FICTRAC_TOPIC = "/fictrac/data"


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
    """See the module docstring. ``rig`` is the rig's configuration (default the thesis's,
    :mod:`.config`); frames come on ``image_topic``."""

    def __init__(self, context: Context, bus: Bus, *, rig: RigConfig | None = None,
                 log: FlyLogWriter | None = None, fictrac_log: FicTracWriter | None = None,
                 ids: tuple[int, int, int] = TREADMILL_IDS, image_topic: str = "/image_raw",
                 camera: SequenceSource | None = None,
                 name: str = "image_converter", namespace: str = "/",
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.rig = rig = rig or RigConfig()
        self.bus, self.log, self.fictrac_log, self.ids = bus, log, fictrac_log, ids
        self.fictrac = FicTracIntegrator(rig.geometry, cam_to_lab=rig.cam_to_lab)
        self.tracker = rig.tracker
        self.frame_rate = rig.camera.frame_rate
        self.controller = replace(rig.controller, max_wheel_speed=min(
            float(v) for v in bus.sync_read("velocity_limit", ids, raw=True).values()))
        self.frames = 0
        self.frames_with_fly = 0
        self.refused = 0
        self.last: tuple[FlySighting, FlyCommand] | None = None
        #: each handled frame's capture stamp, its number in the camera's sequence and the
        #: time it was taken up (s, both ROS time: the camera may be another process)
        self.stamps: list[float] = []
        self.sequences: list[int] = []
        self.handled: list[float] = []
        #: the in-process camera that numbers its frames (None: numbers from the stamps)
        self.camera = camera
        self._first_stamp: float | None = None
        self._sequence = -1  # the last frame's camera frame number
        self.missed_reads = 0
        self._missed_in_a_row = 0
        self._last_present: dict[int, float] | None = None
        self._motor_init()
        self.cmd_vel = self.create_publisher(TWIST, "/cmd_vel", 10)
        self.pose = self.create_publisher(POSE2D, "/fly/pose", 10)
        self.wheels = self.create_publisher(JOINT_STATE, "/treadmill/joint_states", 10)
        self.overlay = self.create_publisher(IMAGE, OVERLAY_TOPIC, 1)
        self.fictrac_data = self.create_publisher(MULTIARRAY, FICTRAC_TOPIC, 10)
        # Listing 1: it_.subscribe("/image_raw", 1, ...): a queue of one, the newest frame
        self.create_subscription(IMAGE, image_topic, self._on_image, 1)

    def _motor_init(self) -> None:
        """``motor_init``: torque off, velocity mode (address 11 <- 1), torque on."""
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 0))
        self.bus.sync_write("operating_mode", dict.fromkeys(self.ids, 1), raw=True)
        self.bus.sync_write("torque_enable", dict.fromkeys(self.ids, 1))

    def motor_deinit(self) -> None:
        """The wheels stopped and their torque off, as the listing's ``motor_deinit``."""
        stop_wheels(self.bus, tuple(self.ids))

    def _refuse(self, why: str) -> None:
        self.refused += 1
        if self.refused == 1 or self.refused % 100 == 0:  # a wrong camera: said, not flooded
            self.get_logger().error(f"frame refused ({self.refused} so far): {why}")

    def _on_image(self, msg: Any) -> None:
        # on the stamps' time base (ROS time), which a camera in another process shares
        handled = self.context.ros_time()
        try:
            image = mono8_of(msg)
        except ImageMessageError as error:
            self._refuse(str(error))
            return
        if (image.shape[1], image.shape[0]) != self.rig.camera.size:
            self._refuse(f"{image.shape[1]}x{image.shape[0]}, but the rig's camera is "
                         f"{self.rig.camera.width}x{self.rig.camera.height} (camera.width, "
                         "camera.height)")
            return
        stamp = seconds_of(msg.header.stamp)
        previous = self.stamps[-1] if self.stamps else None
        if previous is not None and stamp <= previous:
            self._refuse(f"stamp {stamp:.6f} s is not after the previous frame's "
                         f"{previous:.6f} s")
            return
        if self._first_stamp is None:
            self._first_stamp = stamp
        told = None if self.camera is None else self.camera.sequence_at(
            int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec))
        sequence = (told if told is not None
                    else sequence_of(stamp, self._first_stamp, self.frame_rate, self._sequence))
        self._sequence = sequence
        self._frame(image, stamp, sequence, previous, handled, msg.header.stamp)

    def _frame(self, image: npt.NDArray[np.uint8], stamp: float, sequence: int,
               previous: float | None, handled: float, ros_stamp: Any) -> None:
        started = time.perf_counter()  # Listing 1's `begin`: once the frame is in hand
        # the time between the frames' captures (Listing 1 reads its clock as each arrives)
        sampling_us = 0.0 if previous is None else (stamp - previous) * 1e6
        target = self.controller.target
        sighting = track_fly(image, self.tracker, target=(target[0], target[1]))
        command = fly_command(sighting, sampling_us, self.controller)
        raw = {i: int(v) for i, v in zip(self.ids, command.wheel_speeds, strict=True)}
        self.bus.sync_write("goal_velocity", raw, raw=True)
        present = self._present_positions()
        positions = [float(present[i]) for i in self.ids]
        loop_us = (time.perf_counter() - started) * 1e6
        self.last = (sighting, command)
        self.stamps.append(stamp)
        self.sequences.append(sequence)
        self.handled.append(handled)
        self.frames_with_fly += sighting.present
        # the listing's `seq_init` is the camera's sequence; its `secs` is taken when the
        # record is written, after the bus
        record = [float(sequence), loop_us, sampling_us, sighting.cx, sighting.cy,
                  sighting.theta, command.dxm, command.dym, command.dthm,
                  *command.wheel_speeds, sighting.area, *positions,
                  self.context.ros_time()]  # ros::Time::now().toSec()
        if self.log is not None:
            self.log.write(record)
        # FicTrac's timestamp: the frame's capture time, the epoch's in real time
        fictrac = self.fictrac.update(positions, stamp, sequence)
        if self.fictrac_log is not None:
            self.fictrac_log.write(fictrac)
        self.cmd_vel.publish(self.message(TWIST, linear={"x": command.linear},
                                          angular={"z": command.angular}))
        self.pose.publish(self.message(POSE2D, x=sighting.cx, y=sighting.cy,
                                       theta=sighting.theta))
        self.wheels.publish(self.message(
            JOINT_STATE, header={"stamp": ros_stamp},
            name=[f"aot_wheel_{i}" for i in self.ids],
            position=[self.bus.to_si(i, "present_position", int(present[i]))
                      for i in self.ids],
            velocity=[self.bus.to_si(i, "goal_velocity", raw[i]) for i in self.ids]))
        self.fictrac_data.publish(self.message(MULTIARRAY, **multiarray_value(fictrac)))
        if self.overlay.get_subscription_count():  # drawn only for someone watching
            self.overlay.publish(self.message(IMAGE, **image_fields(
                draw_overlay(image, sighting, target=(target[0], target[1]),
                             dead_band_px=self.controller.dead_band_px),
                ros_stamp, "camera")))
        self.frames += 1

    def _present_positions(self) -> dict[int, float]:
        """The wheels' positions: one SYNC_READ, and once more if it went unanswered. A frame
        whose reads both fail keeps the last positions read, as Listing 1 goes on after its
        ``groupSyncRead getdata failed`` (logged, counted in :meth:`timing`); more than
        :data:`MAX_MISSED_READS` such frames in a row end the run, since the ball is then
        turned blind."""
        for attempt in (1, 2):
            try:
                present = self.bus.sync_read("present_position", self.ids, raw=True)
            except CommError as error:
                if attempt == 1:
                    continue
                if self._last_present is None or self._missed_in_a_row >= MAX_MISSED_READS:
                    raise RobotError(f"treadmill: no positions from the wheels for "
                                     f"{self._missed_in_a_row + 1} frame(s) in a row: "
                                     f"{error}") from error
                self.missed_reads += 1
                self._missed_in_a_row += 1
                if self._missed_in_a_row == 1:
                    self.get_logger().error(f"SYNC_READ of the wheels failed twice ({error}); "
                                            "this frame keeps the last positions")
                return self._last_present
            self._missed_in_a_row = 0
            self._last_present = present
            return present
        raise AssertionError("unreachable")

    def timing(self) -> dict[str, Any]:
        """The run's frame timing (:func:`.timing.frame_timing`) and the share of frames
        with the fly found."""
        out = frame_timing(self.stamps, self.handled, self.sequences,
                           frame_rate=self.frame_rate, late_after=self.rig.late_after_s)
        out["frames_refused"] = self.refused
        out["wheel_reads_missed"] = self.missed_reads
        out["fly_found_share"] = (self.frames_with_fly / self.frames if self.frames
                                  else math.nan)
        return out

    def destroy(self) -> None:
        try:
            self.motor_deinit()
        finally:
            super().destroy()


def simulated_treadmill(simulation: Any, walker: Any, *, rig: RigConfig | None = None
                        ) -> tuple[Any, Any]:
    """The emulated wheels (:func:`emulated_treadmill_bus`) under a
    :class:`~servolab.sim.ball.BallWorld` of ``rig``'s geometry and camera (default the
    thesis's) with ``walker`` on the ball, in ``simulation``."""
    from ...sim import BallWorld

    rig = rig or RigConfig()
    bus = emulated_treadmill_bus(simulation)
    world = simulation.add(BallWorld([bus.emulator.motor(i) for i in TREADMILL_IDS],
                                     rig.geometry, walker=walker,
                                     px_per_mm=rig.camera.px_per_mm,
                                     image_size=rig.camera.size))
    return bus, world
