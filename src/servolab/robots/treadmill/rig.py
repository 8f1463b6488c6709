"""The treadmill's camera PC as launch files run it (seed 002 Figure 2), and Listing 2's
encoder logger, which runs on that PC in the thesis and is a node of its own here.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from typing import Any

from ...harness import StopSignal
from ...middleware.context import Context
from ...middleware.node import Node
from ..errors import RobotError, RobotValueError
from . import ON_STOP
from .analysis import analysed_run
from .camera_node import CameraNode
from .config import load_rig
from .fictrac import FICTRAC_FILE, FicTracWriter
from .logs import EncoderLogWriter
from .node import TreadmillNode, simulated_treadmill
from .timing import lost_fly_warning

SENSOR_STATE = "turtlebot3_msgs/msg/SensorState"
#: what a run of the closed loop records in its bag
RECORDED = ("/cmd_vel", "/fly/pose", "/treadmill/joint_states", "/sensor_state", "/odom")


class MobrobDataTracker(Node):
    """Listing 2: every ``sensor_state`` message's time (µs) and the left and right encoder
    counts, as three int64, to ``log``."""

    def __init__(self, context: Context, log: EncoderLogWriter, name: str = "mobrob_data_tracker",
                 namespace: str = "/", *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.log = log
        self.records = 0
        self.create_subscription(SENSOR_STATE, "sensor_state", self._on_state, 1000)

    def _on_state(self, msg: Any) -> None:
        self.log.write(round(self.now() * 1e6), int(msg.left_encoder), int(msg.right_encoder))
        self.records += 1


class TreadmillRig(Node):
    """The camera PC of seed 002 for launch files (Figure 2): the simulated fly, ball and
    camera in real time (or the real treadmill on ``port`` -- then frames must come from
    elsewhere, which this node does not do yet, so ``port`` is refused), Listing 1's
    ``image_converter`` and Listing 2's ``mobrob_data_tracker``, writing the run folder
    ``out``. ``duration`` seconds after it first hears the robot (its ``sensor_state``: the
    robot's process may take a while to start) it stops the wheels (torque off), analyses the logs
    into ``out``/summary.json and ``out``/flyball.png, and shuts its process down, so that as
    a ``required`` node it ends the launch. The robot is another node, anywhere on the
    network: it hears ``/cmd_vel`` and answers on ``sensor_state``.

    A robot never heard within ``robot_timeout`` seconds of wall time (default 30) ends the
    run as a failure: the wheels are stopped, the summary is written with an ``error`` that
    says so, and the node raises :class:`~servolab.robots.errors.RobotError` from its timer,
    which ends its process with status 1 and, the node being required, the launch with it."""

    def __init__(self, context: Context, name: str = "treadmill", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:

        from ...runs import RunFolder
        from ...sim import Simulation
        from ...sim.fly_camera import SimulatedFlyCamera
        from ...sim.fly_walk import FlyWalker
        from .logs import FlyLogWriter

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.duration = float(self.declare_parameter(
            "duration", 100.0, description="s to run before stopping").value)
        seed = int(self.declare_parameter("seed", 0, description="the fly's walk").value)
        out = str(self.declare_parameter("out", "", description="run folder; empty: "
                                         "runs/flyball-<time>").value)
        port = str(self.declare_parameter("port", "", description="must stay empty: the "
                                          "simulated fly needs the simulated ball").value)
        rig_file = str(self.declare_parameter("rig", "", description="rig file; empty: the "
                                              "thesis's (servolab's treadmill.yaml)").value)
        self.rig = load_rig(rig_file or None)
        self.robot_timeout = float(self.declare_parameter(
            "robot_timeout", 30.0, description="s of wall time to wait for the robot's first "
            "sensor_state before giving up").value)
        if port:
            raise RobotValueError("treadmill: a real treadmill needs a real camera; run "
                             "'servolab flyball --frames ... --port ...' instead")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise RobotValueError(f"treadmill: duration {self.duration!r} must be > 0 s")
        if not (math.isfinite(self.robot_timeout) and self.robot_timeout > 0):
            raise RobotValueError(f"treadmill: robot_timeout {self.robot_timeout!r} must be > 0 s")
        self.run = RunFolder.create("flyball", out or None)
        self.simulation = Simulation()
        self.bus, self.world = simulated_treadmill(self.simulation, FlyWalker(seed=seed),
                                                   rig=self.rig)
        try:
            self.fly_log = FlyLogWriter(self.run.file("fly_data.bin"))
            self.encoder_log = EncoderLogWriter(self.run.file("robot_encoders.bin"))
            self.fictrac_log = FicTracWriter(self.run.file(FICTRAC_FILE), overwrite=True)
            self.simulation.start_real_time()
            self.camera = CameraNode(context, SimulatedFlyCamera(
                self.world, seed=seed, simulation=self.simulation),
                frame_rate=self.rig.camera.frame_rate)
            self.node = TreadmillNode(context, self.bus, rig=self.rig, log=self.fly_log,
                                      fictrac_log=self.fictrac_log, camera=self.camera)
            self.tracker = MobrobDataTracker(context, self.encoder_log)
        except BaseException:
            self.simulation.stop_real_time()
            for name in ("fly_log", "encoder_log", "fictrac_log"):
                if hasattr(self, name):
                    getattr(self, name).close()
            self.bus.close()
            raise
        self.start: float | None = None  # the robot's first sensor_state: the run starts
        self.summary: dict[str, Any] | None = None
        self._waiting_since = time.monotonic()  # wall time: whatever clock the nodes keep
        self.create_timer(0.1, self._check_done)
        self._built = True

    def _check_done(self) -> None:
        if self.start is None:
            if self.tracker.records:  # the robot is up and heard: count from here
                self.start = self.now()
            elif time.monotonic() - self._waiting_since >= self.robot_timeout:
                self._robot_never_heard()
            return
        if self.summary is None and self.now() - self.start >= self.duration:
            self.finish()
            self.context.shutdown()  # a required node ends the launch

    def _robot_never_heard(self) -> None:
        """The robot did not come up: stop, say so in the summary, and fail."""
        message = (f"treadmill: the robot was never heard: no sensor_state within "
                   f"{self.robot_timeout:g} s; is the robot's node running and on this "
                   "node's network? (its process's output says why it stopped)")
        self.get_logger().error(message)
        try:
            self.finish(error=message)
        finally:
            self.context.shutdown()
        raise RobotError(message)

    def finish(self, error: str | None = None) -> dict[str, Any]:
        """Stop the wheels, close the logs, analyse them (once); ``error`` says why the run
        failed, in the summary, whose ``interrupted`` is that error, or the stop signal that
        ended the launch, or null when it ran its duration."""
        if self.summary is not None:
            return self.summary
        wheels: dict[str, Any] = {}
        try:
            self.node.motor_deinit()
            wheels = {str(i): self.bus.read(i, ["goal_velocity", "torque_enable"], raw=True)
                      for i in self.node.ids}  # read back: the stop reached the motors
        finally:
            self.simulation.stop_real_time()
            self.fly_log.close()
            self.encoder_log.close()
            self.fictrac_log.close()
        summary = analysed_run(self.run, self.run.file("fly_data.bin"),
                               self.run.file("robot_encoders.bin"), None, self.rig)
        summary.update({"duration_asked_s": self.duration, "frames": self.node.frames,
                        "encoder_records": self.tracker.records, "motors_on_stop": ON_STOP,
                        "wheels_after_stop": wheels, "timing": self.node.timing(),
                        "rig": self.rig.source,
                        "fictrac": str(self.run.file(FICTRAC_FILE))})
        warning = lost_fly_warning(summary["timing"]["fly_found_share"],
                                   self.rig.lost_fly_share)
        if warning is not None:
            summary["warnings"] = [warning]
            self.get_logger().warning(warning)
        ended: BaseException | None = None
        if error is not None:
            summary["error"] = error
            ended = RobotError(error)
        elif self.context.stopped_by is not None:
            ended = StopSignal(self.context.stopped_by)
        self.summary = summary
        self.run.write_summary(summary, interrupted=ended)
        analysis = summary["analysis"] or {}
        timing = summary["timing"]
        self.get_logger().info(
            f"{self.node.frames} frames ({timing['achieved_fps']:.1f} frames/s, interval p99 "
            f"{timing['interval_ms']['p99']:.1f} ms, {timing['late_frames']} late, "
            f"{timing['dropped_frames']} dropped), {self.tracker.records} robot encoder "
            f"records: mean distance error "
            f"{analysis.get('mean_distance_error_mm', math.nan):.3f} mm, run folder "
            f"{self.run.path}")
        return summary

    def destroy(self) -> None:
        if not getattr(self, "_built", False):
            # its constructor failed (a parameter refused): it has nothing to finish, and
            # what it had opened is closed already
            super().destroy()
            return
        try:
            if self.summary is None:
                self.finish()
        finally:
            super().destroy()
            self.bus.close()
