"""``diff_drive_controller/DiffDriveController``, as ros2_controllers' (Jazzy) behaves.

Read for its behaviour, no code copied: ros2_controllers branch ``jazzy`` (diff_drive_controller
4.42.1, commit ed360c97), ``diff_drive_controller/src/diff_drive_controller.cpp`` (cited below
as ``.cpp:LINE``), ``src/diff_drive_controller_parameter.yaml`` (the parameters' names and
defaults) and ``doc/userdoc.rst``. The odometry and the rate limiter are servolab's pure ports
of the same controller's (:mod:`servolab.kinematics.diff_drive_odometry`,
:mod:`servolab.kinematics.speed_limiter`).

- Claims ``<wheel>/velocity`` of every ``left_wheel_names`` and ``right_wheel_names`` joint,
  and reads ``<wheel>/position`` (``<wheel>/velocity`` with ``position_feedback: false``;
  nothing with ``open_loop: true``) (``.cpp:74-105``).
- Subscribes ``~/cmd_vel`` (geometry_msgs/TwistStamped: Jazzy has no ``use_stamped_vel``, the
  Twist of older distributions is gone). A message is taken only while the controller is
  active; a zero stamp is read as now; one older than ``cmd_vel_timeout`` is ignored with the
  original's warning (``.cpp:460-495``).
- Each update (``.cpp:107-316``): the newest command becomes the reference; a command older
  than ``cmd_vel_timeout`` (0 disables it) brakes, the reference set to zero ("Velocity command
  timed out. Braking."); a command holding NaN leaves the reference as it was. Until there
  is a reference (after configure and deactivate: NaN) nothing is written and the odometry
  waits. The reference goes through ``linear.x.*`` / ``angular.z.*`` jerk, acceleration and
  velocity limits against the last two limited commands (both zero after a reset), so a brake
  is rate-limited too; the wheels are told ``(v -/+ w * separation / 2) / radius`` of their
  side, with ``wheel_separation_multiplier`` and ``left/right_wheel_radius_multiplier``
  applied.
- Odometry from the mean wheel position of each side (or velocity x radius x period, or the
  limited command with ``open_loop``), published on ``~/odom`` (nav_msgs/Odometry, the
  covariance diagonals given) and, with ``enable_odom_tf``, on ``/tf`` (``odom_frame_id`` to
  ``base_frame_id``, each prefixed by ``tf_frame_prefix`` or the namespace when
  ``tf_frame_prefix_enable``), at most ``publish_rate`` times a second; with
  ``publish_limited_velocity`` the limited command on ``~/cmd_vel_out`` every update.
- Deactivating sets every wheel's velocity to 0 and resets the reference and the limiter's
  history (``.cpp:596-605``, ``halt`` ``.cpp:669-685``).

Where servolab refuses what the original would take: a multiplier that is not positive (the
pure odometry's :class:`~servolab.kinematics.diff_drive_odometry.WheelParams`), a covariance
diagonal that is not six numbers (the original indexes past its end), and a limit of the wrong
sign (the parameter file's validation, which servolab applies at configure): each one line
naming the parameter and its value.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

from ...kinematics.diff_drive_odometry import (
    DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE,
    DiffDriveOdometry,
    WheelGeometry,
    WheelParams,
    wheel_velocity_commands,
)
from ...kinematics.errors import KinematicsValueError
from ...kinematics.speed_limiter import (
    AXES,
    DEPRECATED_SWITCHES,
    IGNORED_PARAMETERS,
    LIMIT_PARAMETERS,
    SpeedLimiter,
    SpeedLimits,
)
from ...middleware.messages import seconds_of
from ...middleware.names import frame_prefix
from ...middleware.parameters import DOUBLE_ARRAY
from .controller import (
    INDIVIDUAL,
    NONE,
    ControllerError,
    ControllerInterface,
    InterfaceConfiguration,
)
from .hardware import POSITION, VELOCITY
from .resources import Handle

TWIST_STAMPED = "geometry_msgs/msg/TwistStamped"
#: the topics, as ``.cpp:35-38`` names them
COMMAND_TOPIC, COMMAND_OUT_TOPIC, ODOMETRY_TOPIC, TRANSFORM_TOPIC = (
    "~/cmd_vel", "~/cmd_vel_out", "~/odom", "/tf")
#: SystemDefaultsQoS: KEEP_LAST 10, reliable, volatile
QOS_DEPTH = 10
#: the parameters of ``diff_drive_controller_parameter.yaml`` other than the wheel names and
#: the limits, with their defaults
PARAMETERS: dict[str, Any] = {
    "wheel_separation": 0.0,
    "wheel_radius": 0.0,
    "wheel_separation_multiplier": 1.0,
    "left_wheel_radius_multiplier": 1.0,
    "right_wheel_radius_multiplier": 1.0,
    "tf_frame_prefix_enable": True,
    "tf_frame_prefix": "",
    "odom_frame_id": "odom",
    "base_frame_id": "base_link",
    "pose_covariance_diagonal": [0.0] * 6,
    "twist_covariance_diagonal": [0.0] * 6,
    "open_loop": False,
    "position_feedback": True,
    "enable_odom_tf": True,
    "cmd_vel_timeout": 0.5,
    "publish_limited_velocity": False,
    "velocity_rolling_window_size": DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE,
    "publish_rate": 50.0,
}
#: how often a repeated warning may be logged (``warning_throttle_ms`` = 1000, ``.cpp:118``)
WARNING_THROTTLE = 1.0


@dataclass(frozen=True)
class WheelHandles:
    """One wheel's loaned interfaces: its velocity command, its feedback (None open loop)."""

    name: str
    velocity: Handle
    feedback: Handle | None


@dataclass(frozen=True)
class Command:
    """A ``cmd_vel`` as the controller keeps it: its stamp (ROS time, s) and the two
    components it uses (``linear.x``, ``angular.z``; the others are ignored)."""

    stamp: float
    linear: float
    angular: float


def tf_prefix(enabled: bool, prefix: str, namespace: str) -> str:
    """The prefix of both frames (``.cpp:504-526``): none when disabled, else
    ``tf_frame_prefix`` or the node's namespace, without a leading ``/`` and with a
    trailing one (the root namespace gives none): the rule every servolab robot's frames
    follow, :func:`~servolab.middleware.names.frame_prefix`."""
    return frame_prefix(prefix or namespace) if enabled else ""


def yaw_quaternion(yaw: float) -> dict[str, float]:
    """The rotation about z by ``yaw`` (tf2's ``setRPY(0, 0, yaw)``)."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * yaw), "w": math.cos(0.5 * yaw)}


def diagonal(values: list[float]) -> list[float]:
    """A 6 x 6 row-major covariance with ``values`` on its diagonal (indices 0, 7, .., 35)."""
    matrix = [0.0] * 36
    for i, value in enumerate(values):
        matrix[7 * i] = float(value)
    return matrix


class DiffDriveController(ControllerInterface):
    TYPE = "diff_drive_controller/DiffDriveController"

    # -- parameters -------------------------------------------------------------------------

    def on_init(self) -> None:
        self.strings("left_wheel_names", required=False)
        self.strings("right_wheel_names", required=False)
        for name, default in PARAMETERS.items():
            self.parameter(name, default, DOUBLE_ARRAY if isinstance(default, list) else None)
        for axis in AXES:
            for name, _sign in LIMIT_PARAMETERS:
                self.parameter(f"{axis}.{name}", math.nan)
            for switch in DEPRECATED_SWITCHES:
                self.parameter(f"{axis}.{switch}", True)
            for name in IGNORED_PARAMETERS:
                self.parameter(f"{axis}.{name}", math.nan)
        self.odometry: DiffDriveOdometry | None = None
        self.wheel_params: WheelParams | None = None
        self.limiters: dict[str, SpeedLimiter] = {}
        #: the reference (linear m/s, angular rad/s); NaN until a command is taken
        self.reference = [math.nan, math.nan]
        #: the last two limited commands, oldest first (``previous_two_commands_``)
        self.previous: deque[tuple[float, float]] = deque(maxlen=2)
        self.left: list[WheelHandles] = []
        self.right: list[WheelHandles] = []
        self._received: Command | None = None
        self._command = Command(0.0, math.nan, math.nan)
        self._subscriber_active = False
        self._entities: list[Any] = []
        self._subscription: Any = None
        #: ``previous_publish_timestamp_``: None until the first publication (never reset,
        #: as the original never resets it)
        self._published: float | None = None
        self._reading = 0.0

    def _wheel_names(self) -> tuple[tuple[str, ...], tuple[str, ...]]:
        return (self.strings("left_wheel_names", required=False),
                self.strings("right_wheel_names", required=False))

    def _flag(self, name: str) -> bool:
        return bool(self.parameter(name, PARAMETERS[name]))

    def _number(self, name: str) -> float:
        value = self.parameter(name, PARAMETERS[name])
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ControllerError(f"{self.name}: parameter '{name}' is a number, not {value!r}")
        return float(value)

    @property
    def feedback_type(self) -> str:
        """The state interface read from each wheel (``.cpp:52-55``)."""
        return POSITION if self._flag("position_feedback") else VELOCITY

    def command_interface_configuration(self) -> InterfaceConfiguration:
        left, right = self._wheel_names()
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{j}/{VELOCITY}" for j in left + right))

    def state_interface_configuration(self) -> InterfaceConfiguration:
        if self._flag("open_loop"):
            return InterfaceConfiguration(NONE)
        left, right = self._wheel_names()
        feedback = self.feedback_type
        return InterfaceConfiguration(INDIVIDUAL, tuple(f"{j}/{feedback}" for j in left + right))

    # -- lifecycle --------------------------------------------------------------------------

    def on_configure(self) -> None:
        log = self.node.get_logger()
        left, right = self._wheel_names()
        for side, names in (("left", left), ("right", right)):
            if not names:  # the parameter file's not_empty<> validation
                raise ControllerError(f"{self.name}: parameter '{side}_wheel_names' is empty "
                                      f"(the controllers file gives {self.name}: "
                                      f"ros__parameters: {side}_wheel_names: [...])")
        if len(left) != len(right):
            raise ControllerError(f"{self.name}: The number of left wheels [{len(left)}] and "
                                  f"the number of right wheels [{len(right)}] are different")
        for name in ("wheel_separation", "wheel_radius"):  # validation gt<>: [0.0]
            value = self._number(name)
            if not (math.isfinite(value) and value > 0):
                raise ControllerError(f"{self.name}: parameter '{name}' is {value!r}: it must "
                                      "be a length > 0 (m)")
        try:
            params = WheelGeometry(
                self._number("wheel_separation"), self._number("wheel_radius"),
                self._number("wheel_separation_multiplier"),
                self._number("left_wheel_radius_multiplier"),
                self._number("right_wheel_radius_multiplier")).wheel_params()
        except KinematicsValueError as exc:
            raise ControllerError(f"{self.name}: {exc} (wheel_separation x "
                                  "wheel_separation_multiplier, wheel_radius x "
                                  "left/right_wheel_radius_multiplier)") from None
        window = self.parameter("velocity_rolling_window_size",
                                PARAMETERS["velocity_rolling_window_size"])
        if isinstance(window, bool) or not isinstance(window, int) or window < 1:
            raise ControllerError(f"{self.name}: parameter 'velocity_rolling_window_size' is "
                                  f"{window!r}: it must be an integer >= 1")
        if self.odometry is None:
            self.odometry = DiffDriveOdometry(params, window)
        else:  # the odometry object lives as long as the controller (.cpp:342-343)
            self.odometry.set_wheel_params(params.wheel_separation, params.left_wheel_radius,
                                           params.right_wheel_radius)
            self.odometry.set_velocity_rolling_window_size(window)
        self.wheel_params = params
        timeout = self._number("cmd_vel_timeout")
        if not (math.isfinite(timeout) and timeout >= 0):
            raise ControllerError(f"{self.name}: parameter 'cmd_vel_timeout' is {timeout!r}: "
                                  "it must be 0 (no timeout) or more (s)")
        self.cmd_vel_timeout = timeout
        self.limiters = {axis: self._limiter(axis, log) for axis in AXES}
        covariances = {}
        for name in ("pose_covariance_diagonal", "twist_covariance_diagonal"):
            values = self.parameter(name, PARAMETERS[name], DOUBLE_ARRAY)
            if not isinstance(values, list) or len(values) != 6:
                raise ControllerError(f"{self.name}: parameter '{name}' is {values!r}: it "
                                      "must be six numbers (x, y, z, roll, pitch, yaw)")
            covariances[name] = diagonal(values)
        rate = self._number("publish_rate")
        if not (math.isfinite(rate) and rate > 0):
            raise ControllerError(f"{self.name}: parameter 'publish_rate' is {rate!r}: it must "
                                  "be > 0 (Hz)")
        self.publish_period = 1.0 / rate
        self._reset()
        node = self.node
        self.limited_publisher = (node.create_publisher(TWIST_STAMPED, COMMAND_OUT_TOPIC,
                                                        QOS_DEPTH)
                                  if self._flag("publish_limited_velocity") else None)
        self._subscription = node.create_subscription(TWIST_STAMPED, COMMAND_TOPIC,
                                                      self._on_cmd_vel, QOS_DEPTH)
        self.odometry_publisher = node.create_publisher("nav_msgs/msg/Odometry",
                                                        ODOMETRY_TOPIC, QOS_DEPTH)
        self.transform_publisher = node.create_publisher("tf2_msgs/msg/TFMessage",
                                                         TRANSFORM_TOPIC, QOS_DEPTH)
        self._entities = [e for e in (self.limited_publisher, self.odometry_publisher,
                                      self.transform_publisher) if e is not None]
        prefix = tf_prefix(self._flag("tf_frame_prefix_enable"),
                           str(self.parameter("tf_frame_prefix", "")), node.get_namespace())
        self.odom_frame_id = prefix + str(self.parameter("odom_frame_id", "odom"))
        self.base_frame_id = prefix + str(self.parameter("base_frame_id", "base_link"))
        self.open_loop = self._flag("open_loop")
        self.position_feedback = self._flag("position_feedback")
        self.enable_odom_tf = self._flag("enable_odom_tf")
        self._pose_covariance = covariances["pose_covariance_diagonal"]
        self._twist_covariance = covariances["twist_covariance_diagonal"]

    def _limiter(self, axis: str, log: Any) -> SpeedLimiter:
        """One axis's limiter from its parameters (``.cpp:347-440``), a deprecated
        ``has_*_limits: false`` warned about as the original warns."""
        values = {}
        for name, _sign in LIMIT_PARAMETERS:
            values[f"{axis}.{name}"] = self._number_or_nan(f"{axis}.{name}")
        for switch in DEPRECATED_SWITCHES:
            on = self.parameter(f"{axis}.{switch}", True)
            if not isinstance(on, bool):
                raise ControllerError(f"{self.name}: parameter '{axis}.{switch}' is true or "
                                      f"false, not {on!r}")
            if not on:
                log.warning(f"[deprecated] {switch} parameter is deprecated, instead set the "
                            "respective limits to NAN")
            values[f"{axis}.{switch}"] = on
        try:
            return SpeedLimiter(SpeedLimits.from_parameters(values, axis))
        except KinematicsValueError as exc:
            what = "linear" if axis == "linear.x" else "angular"
            raise ControllerError(f"{self.name}: Failed to configure {what} speed limiter: "
                                  f"{axis}.{exc}") from None

    def _number_or_nan(self, name: str) -> float:
        value = self.parameter(name, math.nan)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ControllerError(f"{self.name}: parameter '{name}' is a number or .NAN, not "
                                  f"{value!r}")
        return float(value)

    def on_activate(self) -> None:
        """Find each wheel's interfaces (``configure_side``, ``.cpp:687-744``); then commands
        are taken."""
        left, right = self._wheel_names()
        self.left = self._side("left", left)
        self.right = self._side("right", right)
        self._subscriber_active = True

    def _side(self, side: str, names: tuple[str, ...]) -> list[WheelHandles]:
        if not names:
            raise ControllerError(f"No '{side}' wheel names specified")
        commands = {(h.prefix, h.interface): h for h in self.command_interfaces}
        states = {(h.prefix, h.interface): h for h in self.state_interfaces}
        found = []
        for name in names:
            velocity = commands.get((name, VELOCITY))
            if velocity is None:
                raise ControllerError(f"Unable to obtain joint command handle for {name}")
            feedback = None
            if not self.open_loop:
                feedback = states.get((name, self.feedback_type))
                if feedback is None:
                    raise ControllerError(f"Unable to obtain joint state handle for {name}")
            found.append(WheelHandles(name, velocity, feedback))
        return found

    def on_deactivate(self) -> None:
        self._subscriber_active = False
        self.halt()
        self._reset_buffers()
        self.left, self.right = [], []

    def on_cleanup(self) -> None:
        self._reset()
        for entity in self._entities:
            self.node.destroy_entity(entity)
        self._entities = []

    def halt(self) -> None:
        """Every wheel's velocity command to 0 (``.cpp:669-685``)."""
        for wheel in (*self.left, *self.right):
            wheel.velocity.set_value(0.0)

    def _reset(self) -> None:
        """``reset`` (``.cpp:627-640``): the pose to zero, the buffers emptied, no handles,
        no subscription."""
        if self.odometry is not None:
            self.odometry.reset_odometry()
        self._reset_buffers()
        self.left, self.right = [], []
        self._subscriber_active = False
        if self._subscription is not None:
            self.node.destroy_entity(self._subscription)
            self._subscription = None

    def _reset_buffers(self) -> None:
        """``reset_buffers`` (``.cpp:642-667``): the reference NaN, the last two limited
        commands zero, and the kept command NaN stamped now (so that it times out
        ``cmd_vel_timeout`` from now and brakes)."""
        self.reference = [math.nan, math.nan]
        self.previous = deque([(0.0, 0.0), (0.0, 0.0)], maxlen=2)
        self._command = Command(self.node.context.ros_time(), math.nan, math.nan)
        self._received = self._command

    # -- commands in ------------------------------------------------------------------------

    def _on_cmd_vel(self, msg: Any) -> None:
        log = self.node.get_logger()
        if not self._subscriber_active:
            log.warning("Can't accept new commands. subscriber is inactive")
            return
        now = self.node.context.ros_time()
        stamp = seconds_of(msg.header.stamp)
        if msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 0:
            log.warning("Received TwistStamped with zero timestamp, setting it to current "
                        "time, this message will only be shown once", once=True)
            stamp = now
        age = now - stamp
        if self.cmd_vel_timeout == 0.0 or age < self.cmd_vel_timeout:
            self._received = Command(stamp, float(msg.twist.linear.x), float(msg.twist.angular.z))
        else:
            log.warning(f"Ignoring the received message (timestamp {stamp:.10f}) because it is "
                        f"older than the current time by {age:.10f} seconds, which exceeds the "
                        f"allowed timeout ({self.cmd_vel_timeout:.4f})")

    # -- the update -------------------------------------------------------------------------

    def update(self, time: float, period: float) -> bool:
        """One step on ROS time (what the stamps of ``cmd_vel`` are in); the messages out
        are stamped with this update's time, as the original stamps them."""
        self._reading = time
        now = self.node.context.ros_time(time)
        self._update_reference(now)
        return self._update_and_write(now, period)

    def _update_reference(self, now: float) -> None:
        """``update_reference_from_subscribers`` (``.cpp:107-148``)."""
        if self._received is not None:
            self._command = self._received
        command = self._command
        if self.cmd_vel_timeout != 0.0 and now - command.stamp > self.cmd_vel_timeout:
            self.reference = [0.0, 0.0]
            self.node.get_logger().warning("Velocity command timed out. Braking.",
                                           throttle_duration_sec=WARNING_THROTTLE)
        elif math.isfinite(command.linear) and math.isfinite(command.angular):
            self.reference = [command.linear, command.angular]
        else:
            self.node.get_logger().warning(
                "Command message contains NaNs. Not updating reference interfaces.",
                throttle_duration_sec=WARNING_THROTTLE, skip_first=True)

    def _update_and_write(self, now: float, period: float) -> bool:
        """``update_and_write_commands`` (``.cpp:150-316``)."""
        linear, angular = self.reference
        if not (math.isfinite(linear) and math.isfinite(angular)):
            return True  # no reference yet: nothing to do
        odometry, params = self.odometry, self.wheel_params
        assert odometry is not None and params is not None
        (second_linear, second_angular), (last_linear, last_angular) = self.previous
        dt = max(0.0, period)
        linear, _ = self.limiters["linear.x"].limit(linear, last_linear, second_linear, dt)
        angular, _ = self.limiters["angular.z"].limit(angular, last_angular, second_angular,
                                                      dt)
        self.previous.append((linear, angular))
        if self.open_loop:
            odometry.update_open_loop(linear, angular, now)
        else:
            left = self._feedback(self.left)
            right = self._feedback(self.right)
            if left is None or right is None:
                self.node.get_logger().error(
                    f"Either the left or right wheel {self.feedback_type} is invalid for index "
                    f"[{self._invalid_index()}]")
                return False
            try:
                if self.position_feedback:
                    odometry.update(left, right, now)
                else:
                    odometry.update_from_velocity(left, right, now, dt)
            except KinematicsValueError as exc:  # an infinite reading: as NaN above
                self.node.get_logger().error(str(exc), throttle_duration_sec=WARNING_THROTTLE)
                return False
        if self._published is None:
            self._published = now
            publish = True
        elif self._published + self.publish_period < now:
            self._published += self.publish_period
            publish = True
        else:
            publish = False
        if publish:
            self._publish_odometry(now)
        if self.limited_publisher is not None:
            node = self.node
            self.limited_publisher.publish(node.message(
                TWIST_STAMPED, header={"stamp": node.stamp(self._reading)},
                twist={"linear": {"x": linear}, "angular": {"z": angular}}))
        left_velocity, right_velocity = wheel_velocity_commands(linear, angular, params)
        for wheel in self.left:
            wheel.velocity.set_value(left_velocity)
        for wheel in self.right:
            wheel.velocity.set_value(right_velocity)
        return True

    @staticmethod
    def _feedback(wheels: list[WheelHandles]) -> float | None:
        """The mean feedback of a side's wheels; None if one reads NaN."""
        total = 0.0
        for wheel in wheels:
            assert wheel.feedback is not None
            value = wheel.feedback.get_value()
            if math.isnan(value):
                return None
            total += value
        return total / len(wheels)

    def _invalid_index(self) -> int:
        for index, (left, right) in enumerate(zip(self.left, self.right, strict=True)):
            for wheel in (left, right):
                if wheel.feedback is not None and math.isnan(wheel.feedback.get_value()):
                    return index
        return 0

    def _publish_odometry(self, now: float) -> None:
        odometry = self.odometry
        assert odometry is not None
        node = self.node
        stamp = node.stamp(self._reading)
        rotation = yaw_quaternion(odometry.heading)
        self.odometry_publisher.publish(node.message(
            "nav_msgs/msg/Odometry",
            header={"stamp": stamp, "frame_id": self.odom_frame_id},
            child_frame_id=self.base_frame_id,
            pose={"pose": {"position": {"x": odometry.x, "y": odometry.y},
                           "orientation": rotation},
                  "covariance": self._pose_covariance},
            twist={"twist": {"linear": {"x": odometry.linear},
                             "angular": {"z": odometry.angular}},
                   "covariance": self._twist_covariance}))
        if self.enable_odom_tf:
            self.transform_publisher.publish(node.message(
                "tf2_msgs/msg/TFMessage", transforms=[{
                    "header": {"stamp": stamp, "frame_id": self.odom_frame_id},
                    "child_frame_id": self.base_frame_id,
                    "transform": {"translation": {"x": odometry.x, "y": odometry.y},
                                  "rotation": rotation}}]))

