"""The base node: ``/cmd_vel`` in, wheels turned, odometry out, as a TurtleBot3 user expects.

- ``/cmd_vel`` (``geometry_msgs/msg/Twist``): linear.x and angular.z, clamped to the base's
  limits; a Twist holding NaN or infinity is refused (logged) and changes nothing;
- a watchdog: no command for ``watchdog`` s (0.5 by default) stops the wheels;
- ``/odom`` (``nav_msgs/msg/Odometry``) and ``/tf`` (``odom`` -> ``base_footprint``, TurtleBot3's
  frame names), ``/joint_states`` (``wheel_left_joint``, ``wheel_right_joint``) at ``rate`` Hz
  (30 by default), from the wheel encoders;
- ``/sensor_state`` (``turtlebot3_msgs/msg/SensorState``): the time and the raw encoder counts
  of the left and right wheels, what seed 002's Listing 4 logs, and the torque state.

Each cycle is one SYNC_WRITE of the wheels' speeds and the encoders' reads, together,
``rate`` times a second: the one step of the sweep of the bus's
:class:`~servolab.robots.bus_owner.BusOwner`, the one owner of the bus's time (as the biped's
controller manager has it). The two stay one step, as the cycle always was: the wheels'
command and the odometry read right after it belong together (split, other callbacks ran
between them, and the navigation's timing moved). Stopping the node (or its context) stops
the wheels.

In a namespace (``/robot1``) every topic but ``/tf`` is the robot's own (``/robot1/cmd_vel``,
``/robot1/odom``: the names above are relative), ``/tf`` is every robot's, and the frames take
the namespace as their prefix (``robot1/odom`` -> ``robot1/base_footprint``:
:func:`~servolab.middleware.names.frame_prefix`), as TurtleBot3's multi-robot launch runs its
robots; at the root nothing changes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ...kinematics.diffdrive import wheel_speeds
from ...middleware.context import Context
from ...middleware.names import BASE_FRAME, ODOM_FRAME, frame_prefix
from ...middleware.node import Node
from ..bus_owner import BusOwner
from ..errors import RobotValueError
from .mobile_base import MobileBase

TWIST = "geometry_msgs/msg/Twist"
ODOMETRY = "nav_msgs/msg/Odometry"
TF = "tf2_msgs/msg/TFMessage"
JOINT_STATE = "sensor_msgs/msg/JointState"
SENSOR_STATE = "turtlebot3_msgs/msg/SensorState"
#: TurtleBot3's joint names (turtlebot3_node); its frames are REP-105's (ODOM_FRAME, BASE_FRAME)
WHEEL_JOINTS = ("wheel_left_joint", "wheel_right_joint")


class BaseNode(Node):
    """See the module docstring. Parameters: ``rate`` (Hz), ``watchdog`` (s)."""

    def __init__(self, context: Context, base: MobileBase, name: str = "base",
                 namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.base = base
        rate = float(self.declare_parameter("rate", 30.0, description="Hz").value)
        self.watchdog = float(self.declare_parameter(
            "watchdog", 0.5, description="s without /cmd_vel before the wheels stop").value)
        if not (math.isfinite(rate) and rate > 0 and math.isfinite(self.watchdog)
                and self.watchdog > 0):
            raise RobotValueError(f"base node: rate {rate:g} Hz and watchdog {self.watchdog:g} s "
                                  "must be numbers > 0")
        self.command = (0.0, 0.0)   # (v, omega) asked, within the limits
        self.last_command: float | None = None
        self.stopped_by_watchdog = 0
        self._sent: tuple[float, float] | None = None
        self._cycle_started = self.now()
        self._previous = (base.pose.x, base.pose.y, base.pose.theta, self.now())
        prefix = frame_prefix(self.get_namespace())
        #: the odometry's frame and the base's, prefixed in a namespace
        self.odom_frame, self.base_frame = prefix + ODOM_FRAME, prefix + BASE_FRAME
        self.odom = self.create_publisher(ODOMETRY, "odom", 10)
        self.tf = self.create_publisher(TF, "/tf", 10)
        self.joint_states = self.create_publisher(JOINT_STATE, "joint_states", 10)
        self.sensor_state = self.create_publisher(SENSOR_STATE, "sensor_state", 10)
        self.create_subscription(TWIST, "cmd_vel", self._on_cmd_vel, 10)
        self.owner = BusOwner(context, base.bus, rate=rate,
                              steps=[self._cycle])

    def _on_cmd_vel(self, msg: Any) -> None:
        v, omega = float(msg.linear.x), float(msg.angular.z)
        if not (math.isfinite(v) and math.isfinite(omega)):
            self.get_logger().error(f"cmd_vel refused: linear.x {v!r}, angular.z {omega!r} "
                                    "is not a finite number; the wheels keep what they had")
            return
        base = self.base
        if base.config.wheel_clamp == "per-wheel":
            # Listing 4 takes cmd_vel as it comes; each wheel is clamped on its own after
            self.command, self.last_command = (v, omega), self.now()
            return
        # within the base's limits, and always within what its wheels can do (a huge but
        # finite value would otherwise become an infinite wheel speed)
        top_v = base.max_wheel_speed * base.drive.wheel_radius
        top_w = 2 * top_v / base.drive.wheel_separation
        config = base.config
        limit_v = min(top_v, config.max_linear_velocity or top_v)
        limit_w = min(top_w, config.max_angular_velocity or top_w)
        v = max(-limit_v, min(limit_v, v))
        omega = max(-limit_w, min(limit_w, omega))
        self.command = (v, omega)
        self.last_command = self.now()

    def _cycle(self) -> None:
        """One cycle: the wheels' speeds, then the encoders."""
        self._drive()
        self._odometry()

    def _drive(self) -> None:
        """The cycle's first transaction: the wheels' speeds (stopped by the watchdog)."""
        now = self.now()
        if self.last_command is not None and now - self.last_command > self.watchdog:
            self.command, self.last_command = (0.0, 0.0), None
            self.stopped_by_watchdog += 1
            self.get_logger().warning(f"no cmd_vel for {self.watchdog:g} s: wheels stopped")
        v, omega = self.command
        left, right = wheel_speeds(v, omega, self.base.drive)
        self._cycle_started = now
        try:
            self.base.set_wheel_speeds(float(left), float(right))
        except BaseException:
            self.base.stop()  # whatever went wrong, the wheels do not keep turning
            raise

    def _odometry(self) -> None:
        """The cycle's second: the encoders, integrated and published."""
        try:
            pose = self.base.update_odometry()
        except BaseException:
            self.base.stop()
            raise
        self._publish(pose.x, pose.y, pose.theta, self._cycle_started)

    def _publish(self, x: float, y: float, theta: float, now: float) -> None:
        px, py, ptheta, pt = self._previous
        dt = now - pt
        v = math.hypot(x - px, y - py) / dt if dt > 0 else 0.0
        if dt > 0 and (x - px) * math.cos(theta) + (y - py) * math.sin(theta) < 0:
            v = -v
        omega = (theta - ptheta) / dt if dt > 0 else 0.0
        self._previous = (x, y, theta, now)
        stamp = self.stamp(now)  # the cycle's start, in ROS time
        quaternion = {"z": math.sin(theta / 2), "w": math.cos(theta / 2)}
        self.odom.publish(self.message(
            ODOMETRY, header={"stamp": stamp, "frame_id": self.odom_frame},
            child_frame_id=self.base_frame,
            pose={"pose": {"position": {"x": x, "y": y}, "orientation": quaternion}},
            twist={"twist": {"linear": {"x": v}, "angular": {"z": omega}}}))
        self.tf.publish(self.message(TF, transforms=[{
            "header": {"stamp": stamp, "frame_id": self.odom_frame},
            "child_frame_id": self.base_frame,
            "transform": {"translation": {"x": x, "y": y}, "rotation": quaternion}}]))
        left, right = self.base.wheel_angles()
        self.joint_states.publish(self.message(
            JOINT_STATE, header={"stamp": stamp}, name=list(WHEEL_JOINTS),
            position=[left, right]))
        ticks = self.base.encoder_counts()
        self.sensor_state.publish(self.message(
            SENSOR_STATE, header={"stamp": stamp}, torque=True,
            left_encoder=ticks["left"], right_encoder=ticks["right"]))

    def destroy(self) -> None:
        self.owner.close()
        try:
            self.base.stop()
        finally:
            super().destroy()


class BaseRobot(Node):
    """A base for launch files: opens the base of parameter ``base`` (a configuration file;
    default seed 000's robot), emulated on a simulated floor in real time unless ``port``
    names a serial device, and runs a :class:`BaseNode` on it (and, emulated, a
    :class:`~servolab.sim.truth_node.GroundTruthNode` publishing ``/ground_truth``)."""

    def __init__(self, context: Context, name: str = "base_robot", namespace: str = "/", *,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        from ...sim.truth_node import GroundTruthNode
        from .config import load, resolve
        from .mobile_base import open_base

        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        path = str(self.declare_parameter("base", "", description="base YAML").value)
        port = str(self.declare_parameter("port", "", description="serial device; empty: "
                                          "emulated").value)
        self.base = open_base(load(resolve(path)), port or None)
        self.simulation = None if port else self.base.clock
        if self.simulation is not None:
            self.simulation.start_real_time()  # type: ignore[attr-defined]
        try:
            overrides = dict(parameter_overrides or {})
            node_overrides: dict[str, Any] = {k: overrides[k] for k in ("rate", "watchdog")
                                              if k in overrides}
            # in the launch entry's namespace, as a launch's namespace puts every node the
            # entry starts (a PushRosNamespace group)
            self.node = BaseNode(context, self.base, namespace=self.get_namespace(),
                                 parameter_overrides=node_overrides)
            self.truth = (GroundTruthNode(context, self.base.floor,
                                          namespace=self.get_namespace())
                          if self.base.floor is not None else None)
        except BaseException:
            self._release()
            raise

    def _release(self) -> None:
        if self.simulation is not None:
            self.simulation.stop_real_time()  # type: ignore[attr-defined]
        self.base.bus.close()

    def destroy(self) -> None:
        super().destroy()
        self._release()
