"""The fusion node: wheel odometry and an overhead tracker's pose fused into the robot's pose in
the map, as robot_localization's ``ekf_node`` does it (default), or as seed 000's D.4 did.

**What it does (``filter: ekf``, the default).** A ROS user puts robot_localization between
odometry and an absolute sensor and expects what it gives; this node gives the same for a
planar robot (its ``two_d_mode``):

- a cycle at a fixed rate, ``frequency`` (30 Hz, robot_localization's default), that predicts
  the pose from the odometry that came in since the last cycle and publishes it, whether or
  not the tracker said anything: through a camera dropout the pose keeps following the
  odometry and its covariance keeps growing;
- each tracker pose corrects the pose when it arrives (the odometry up to that moment
  predicted first), pulling it towards the sighting and shrinking the covariance;
- out: ``/odometry/filtered`` (``nav_msgs/msg/Odometry``, ``map`` -> ``base_link_frame``, the
  6x6 pose covariance row-major over ``x y z roll pitch yaw`` as robot_localization fills it;
  the twist is the odometry's own, in the robot's frame), ``/fused_pose``
  (``geometry_msgs/msg/PoseStamped`` in the map frame: what the navigator takes) and ``/tf``
  (``map -> odom``, the transform that makes ``map -> odom -> base`` the fused pose given the
  base's ``odom -> base`` at the odometry pose last used: robot_localization's
  ``world_frame: map``).

Nothing is published before the first tracker pose: until the camera has seen the robot, the
node does not know where in the map it is (robot_localization would start at the origin; a
navigator must not drive on that). The first sighting sets the pose and its covariance (the
tracker's); one without a heading (a zero quaternion) takes the odometry's heading, as if
``map`` and ``odom`` were parallel (seed 000's assumption), with a variance of (45°)².

The filter is :class:`servolab.estimation.pose_filter.PoseFilter`, the EKF of *Probabilistic
Robotics* Table 3.3 with odometry's increments as the control: see that module for the
equations. robot_localization instead runs a constant-velocity model and fuses the odometry's
twist as a measurement; with odometry the only source of motion its velocity states follow the
odometry's, which is what taking the increments directly does, without the velocity states and
their tuning and without time-aligning two sensors' stamps.

**Parameters.** ``tracker_topic`` (``tracker/pose``); ``filter`` (``ekf`` or ``seed_000``);
``frequency`` (Hz); ``sensor_timeout`` (s, 0.5): a sensor silent this long has timed out. Here
every cycle predicts anyway (robot_localization predicts without correcting when its sensors
time out; its default, ``1 / frequency``, would call a 10 Hz camera timed out between every
two frames), so the timeout says so: a warning when the tracker has been silent that long
(:attr:`FusionNode.dropouts` counts them, :attr:`FusionNode.tracker_silent` says whether one
is on) and when the odometry has (the pose is then held where it was, its covariance still
growing by the per-second terms); an info line when each comes back. ``max_dead_reckoning``
(s, 10; 0: no limit): with the tracker silent that long the node stops publishing, so that a
controller's pose timeout stops the robot rather than let it drive on odometry alone for
ever (robot_localization has no such limit; servolab's choice, :attr:`FusionNode.blind`).
``tracker_position_variance``
(m²), ``tracker_yaw_variance`` (rad²), ``tracker_rejection_threshold`` (Mahalanobis distance,
robot_localization's ``pose0_rejection_threshold``; infinite by default, as there), and
``process_noise.translation_per_metre``, ``.rotation_per_radian``, ``.rotation_per_metre``,
``.translation_per_second``, ``.rotation_per_second``: the defaults of each are those of the
``pose_filter`` the node is built with (:class:`~servolab.estimation.pose_filter.PoseFilterConfig`).
``map_frame`` (``map``), ``odom_frame`` (``odom``), ``base_link_frame`` (``base_footprint``:
the frame BaseNode's odometry and ``/tf`` give the pose of, TurtleBot3's; robot_localization's
default, ``base_link``, names a frame this base does not publish), ``publish_tf`` (true). In a
namespace (``/robot1``) the topics are the robot's (``/robot1/odom``, ``/robot1/fused_pose``;
``/tf`` is every robot's) and the two frames of the robot take its prefix (``robot1/odom``,
``robot1/base_footprint``: :func:`~servolab.middleware.names.frame_prefix`), the map's not.

**Seed 000's D.4 (``filter: seed_000``).** The seed's algorithm, kept as the seed ran it: each
tracker pose is one sample; the filter predicts one sample ahead and updates with the
tracker's position and the latest odometry position together, then publishes ``/fused_pose``
(the tracker's frame and stamp) and nothing else; the filter is
:func:`~servolab.estimation.kalman.seed_000_filter`, with D.4's Q and R (``config``) unless
others are given. Odometry counts from where the base was
switched on (the ``odom`` frame), the tracker from the floor's origin (the ``map`` frame), and
the seed fuses the two as they are, which is right only when both start at the same point.
With ``align_odometry`` the node first finds ``map -> odom`` from the first tracker pose that
arrives after odometry (its position and heading against the odometry pose at that moment)
and fuses odometry moved into the map frame, the fused pose carrying the aligned odometry's
heading; each later sighting turns ``map -> odom`` by ``heading_gain`` (0.05) of the tracker's
heading error, about the robot, so a wrong first alignment or the encoders' drift fades out.
Both parameters are D.4's only: the EKF estimates ``map -> odom`` by itself (it is its
output), and its Kalman gain, worked out from the variances at each sighting, is what
``heading_gain`` fixed by hand.

Why the EKF is the default, not D.4 nor D.4's position update with the new prediction: D.4
takes odometry's *position* as a measurement of fixed variance, right only while odometry's
error stays bounded, which wheel odometry's does not (it grows with the distance driven); it
estimates no heading, and steps only when the tracker speaks, so a dropout stops it. D.4's
update after a prediction from the same odometry would count the odometry twice. The EKF takes
odometry for what it is, a good increment and a poor absolute pose.

A message holding NaN or infinity (odometry or tracker) is refused with one logged line and
changes nothing; so is a tracker pose in a frame other than ``map_frame`` (or empty).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...estimation.errors import EstimationValueError
from ...estimation.kalman import (
    ODOMETRY_AND_TRACKER,
    SEED_000_FUSION,
    TRACKER,
    KalmanFilter,
    Seed000Fusion,
    seed_000_filter,
)
from ...estimation.pose_filter import (
    PoseFilter,
    PoseFilterConfig,
    between,
    compose,
    inverse,
    wrap,
)
from ...middleware.context import Context
from ...middleware.names import BASE_FRAME, ODOM_FRAME, frame_prefix
from ...middleware.node import Node
from ..errors import RobotValueError

ODOMETRY = "nav_msgs/msg/Odometry"
POSE = "geometry_msgs/msg/PoseStamped"
TF = "tf2_msgs/msg/TFMessage"
FILTERS = ("ekf", "seed_000")
#: the variance of z, roll and pitch in the published covariance: that of the pseudo-measurement
#: robot_localization's two_d_mode fuses for them at every update (``forceTwoD``)
TWO_D_VARIANCE = 1e-6
#: the variance of a first heading taken from odometry (a sighting without one): (45°)²
UNKNOWN_YAW_VARIANCE = (math.pi / 4) ** 2
#: the process-noise parameters, ``process_noise.<name>``, each a PoseFilterConfig field
PROCESS_NOISE = ("translation_per_metre", "rotation_per_radian", "rotation_per_metre",
                 "translation_per_second", "rotation_per_second")

Pose = tuple[float, float, float]


def _yaw(q: Any) -> float:
    """The heading of a planar quaternion (z and w; atan2(0, 0) = 0 for a zero one)."""
    return 2.0 * math.atan2(float(q.z), float(q.w))


def _quaternion(yaw: float) -> dict[str, float]:
    return {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


class FusionNode(Node):
    """See the module docstring. ``config`` is D.4's noise (``filter: seed_000``),
    ``pose_filter`` the EKF's defaults (its parameters override them)."""

    def __init__(self, context: Context, name: str = "fusion", namespace: str = "/", *,
                 config: Seed000Fusion = SEED_000_FUSION,
                 pose_filter: PoseFilterConfig | None = None,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        tracker_topic = str(self.declare_parameter("tracker_topic", "tracker/pose").value)
        self.filter_kind = str(self.declare_parameter(
            "filter", "ekf", description="ekf (robot_localization's way) or seed_000 (D.4)"
        ).value)
        if self.filter_kind not in FILTERS:
            raise RobotValueError(f"fusion: filter {self.filter_kind!r} must be one of "
                                  f"{', '.join(FILTERS)}")
        self.align = bool(self.declare_parameter(
            "align_odometry", False, description="seed_000: find map -> odom from the first "
            "tracker pose and fuse odometry in the map frame (the EKF always does)").value)
        self.heading_gain = float(self.declare_parameter(
            "heading_gain", 0.05, description="seed_000 with align_odometry: the part of the "
            "tracker's heading error corrected at each later sighting (0: align once)").value)
        if not (math.isfinite(self.heading_gain) and 0.0 <= self.heading_gain <= 1.0):
            raise RobotValueError(f"fusion: heading_gain {self.heading_gain!r} must be in [0, 1]")
        if self.align and self.filter_kind != "seed_000":
            self.get_logger().warning("align_odometry is seed_000's: the EKF estimates "
                                      "map -> odom itself, so it is not used")
        self.config = config
        # seed 000's D.4
        self.filter: KalmanFilter | None = None
        self.odometry: tuple[float, float] | None = None
        self._odometry_pose: Pose | None = None
        self._seed_map_from_odom: Pose | None = None
        #: the EKF, from the first tracker pose on (None with seed_000)
        self.pose_filter: PoseFilter | None = None
        #: the odometry pose the EKF's state last took in (the odom frame)
        self._absorbed: Pose | None = None
        self.fused = self.create_publisher(POSE, "fused_pose", 10)
        if self.filter_kind == "seed_000":
            self.create_subscription(ODOMETRY, "odom", self._on_odom_d4, 10)
            self.create_subscription(POSE, tracker_topic, self._on_tracker_d4, 10)
            return
        self._declare_ekf(pose_filter or PoseFilterConfig())
        self.create_subscription(ODOMETRY, "odom", self._on_odom, 10)
        self.create_subscription(POSE, tracker_topic, self._on_tracker, 10)

    # -- the EKF (robot_localization's way) --------------------------------------------------

    def _declare_ekf(self, defaults: PoseFilterConfig) -> None:
        self.frequency = float(self.declare_parameter(
            "frequency", 30.0, description="Hz: predict and publish this often").value)
        self.sensor_timeout = float(self.declare_parameter(
            "sensor_timeout", 0.5, description="s: a sensor silent this long has timed out "
            "(logged; the pose is predicted from odometry alone)").value)
        if not (math.isfinite(self.frequency) and self.frequency > 0
                and math.isfinite(self.sensor_timeout) and self.sensor_timeout > 0):
            raise RobotValueError(f"fusion: frequency {self.frequency!r} Hz and sensor_timeout "
                                  f"{self.sensor_timeout!r} s must be numbers > 0")
        self.max_dead_reckoning = float(self.declare_parameter(
            "max_dead_reckoning", 10.0, description="s: with the tracker silent this long the "
            "pose is no longer published (0: no limit)").value)
        if not (math.isfinite(self.max_dead_reckoning) and self.max_dead_reckoning >= 0):
            raise RobotValueError(f"fusion: max_dead_reckoning {self.max_dead_reckoning!r} s "
                                  "must be a number >= 0")
        #: the tracker has been silent longer than max_dead_reckoning: nothing is published
        self.blind = False
        noise = {name: float(self.declare_parameter(
            f"process_noise.{name}", float(getattr(defaults, name)),
            description="odometry's noise (see PoseFilterConfig)").value)
            for name in PROCESS_NOISE}
        position = float(self.declare_parameter(
            "tracker_position_variance", defaults.position_variance, description="m², each of "
            "x and y").value)
        yaw = float(self.declare_parameter(
            "tracker_yaw_variance", defaults.yaw_variance, description="rad²").value)
        threshold = float(self.declare_parameter(
            "tracker_rejection_threshold", defaults.rejection_threshold,
            description="Mahalanobis distance beyond which a sighting is rejected").value)
        try:
            self.pose_config = PoseFilterConfig(**noise, position_variance=position,
                                                yaw_variance=yaw, rejection_threshold=threshold)
        except EstimationValueError as error:
            raise RobotValueError(f"fusion: {error}") from error
        # the robot's frames take its namespace's prefix, as the base node's do; the map is
        # every robot's
        prefix = frame_prefix(self.get_namespace())
        self.map_frame = str(self.declare_parameter("map_frame", "map").value)
        self.odom_frame = str(self.declare_parameter("odom_frame", prefix + ODOM_FRAME).value)
        self.base_frame = str(self.declare_parameter("base_link_frame",
                                                     prefix + BASE_FRAME).value)
        self.publish_tf = bool(self.declare_parameter("publish_tf", True).value)
        #: path length and rotation the odometry covered since then
        self._travelled = 0.0
        self._turned = 0.0
        self._twist = (0.0, 0.0)
        self._odom_at: float | None = None
        self._predicted_at = self.now()
        self._tracker_at: float | None = None
        self._odometry_silent = False
        #: whether the tracker has been silent for sensor_timeout (a dropout is on)
        self.tracker_silent = False
        #: dropouts begun, sightings taken in, sightings rejected (Mahalanobis)
        self.dropouts = 0
        self.corrections = 0
        self.rejected = 0
        self.odometry_filtered = self.create_publisher(ODOMETRY, "odometry/filtered", 10)
        self.tf = self.create_publisher(TF, "/tf", 10)
        self.timer = self.create_timer(1.0 / self.frequency, self._cycle)

    def _on_odom(self, msg: Any) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        values = (p.x, p.y, q.z, q.w)
        if not all(math.isfinite(float(v)) for v in values):
            self.get_logger().error(f"odom refused: position ({p.x!r}, {p.y!r}), orientation "
                                    f"z {q.z!r} w {q.w!r} is not finite; the pose keeps what "
                                    "it had")
            return
        pose = (float(p.x), float(p.y), _yaw(q))
        if self._odometry_pose is not None:
            px, py, pyaw = self._odometry_pose
            self._travelled += math.hypot(pose[0] - px, pose[1] - py)
            self._turned += abs(wrap(pose[2] - pyaw))
        self._odometry_pose = pose
        v, w = float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z)
        self._twist = (v, w) if math.isfinite(v) and math.isfinite(w) else (0.0, 0.0)
        self._odom_at = self.now()
        if self._odometry_silent:
            self._odometry_silent = False
            self.get_logger().info("odometry is back")

    def _absorb(self, now: float) -> None:
        """Predict up to ``now`` from the odometry that came since the last prediction (none:
        the pose is held, its covariance grows by the per-second noise)."""
        assert self.pose_filter is not None
        latest = self._odometry_pose
        if latest is not None and self._absorbed is None:
            self._absorbed, self._travelled, self._turned = latest, 0.0, 0.0
        increment = np.zeros(3)
        if latest is not None and self._absorbed is not None and latest != self._absorbed:
            increment = between(self._absorbed, latest)
        dt = max(0.0, now - self._predicted_at)
        try:
            self.pose_filter.predict(increment, travelled=self._travelled, turned=self._turned,
                                     dt=dt)
        except EstimationValueError as error:  # not reachable with checked inputs
            self.get_logger().error(f"prediction refused: {error}")
            return
        self._absorbed, self._travelled, self._turned = latest, 0.0, 0.0
        self._predicted_at = now

    def _on_tracker(self, msg: Any) -> None:
        p, q = msg.pose.position, msg.pose.orientation
        values = (p.x, p.y, q.z, q.w)
        if not all(math.isfinite(float(v)) for v in values):
            self.get_logger().error(f"tracker pose refused: position ({p.x!r}, {p.y!r}), "
                                    f"orientation z {q.z!r} w {q.w!r} is not finite")
            return
        frame = str(msg.header.frame_id)
        if frame not in ("", self.map_frame):
            self.get_logger().error(f"tracker pose refused: frame {frame!r}, expected "
                                    f"{self.map_frame!r}")
            return
        has_heading = not (float(q.z) == 0.0 and float(q.w) == 0.0)
        now = self.now()
        config = self.pose_config
        if self.pose_filter is None:
            if has_heading:
                yaw, yaw_variance = _yaw(q), config.yaw_variance
            else:  # map and odom taken as parallel until a heading comes
                yaw = self._odometry_pose[2] if self._odometry_pose is not None else 0.0
                yaw_variance = UNKNOWN_YAW_VARIANCE
            self.pose_filter = PoseFilter(
                (float(p.x), float(p.y), yaw),
                np.diag([config.position_variance, config.position_variance, yaw_variance]),
                config)
            self._absorbed, self._travelled, self._turned = self._odometry_pose, 0.0, 0.0
            self._predicted_at = now
            self._tracker_seen(now)
            return
        self._absorb(now)
        z = (float(p.x), float(p.y), _yaw(q)) if has_heading else (float(p.x), float(p.y))
        try:
            accepted = self.pose_filter.correct(z)
        except EstimationValueError as error:  # not reachable with checked inputs
            self.get_logger().error(f"tracker pose refused: {error}")
            return
        if not accepted:
            self.rejected += 1
            last = self.pose_filter.last_correction
            distance = math.sqrt(last.mahalanobis2) if last is not None else math.nan
            self.get_logger().warning(
                f"tracker pose ({float(p.x):.3f}, {float(p.y):.3f}) rejected: {distance:.1f} "
                f"standard deviations from the prediction (tracker_rejection_threshold "
                f"{config.rejection_threshold:g})", throttle_duration_sec=1.0)
            return
        self.corrections += 1
        self._tracker_seen(now)

    def _tracker_seen(self, now: float) -> None:
        if self.tracker_silent and self._tracker_at is not None:
            self.get_logger().info(f"tracker back after {now - self._tracker_at:.2f} s")
        self.tracker_silent = False
        self._tracker_at = now

    def _cycle(self) -> None:
        """One cycle at ``frequency``: predict to now, note timeouts, publish."""
        if self.pose_filter is None:
            return
        now = self.now()
        self._absorb(now)
        timeout = self.sensor_timeout
        if (not self.tracker_silent and self._tracker_at is not None
                and now - self._tracker_at > timeout):
            self.tracker_silent = True
            self.dropouts += 1
            self.get_logger().warning(
                f"no tracker pose for {now - self._tracker_at:.2f} s (sensor_timeout "
                f"{timeout:g} s): the pose is predicted from odometry alone")
        if not self._odometry_silent and (self._odom_at is None or now - self._odom_at > timeout):
            self._odometry_silent = True
            self.get_logger().warning(f"no odometry for {timeout:g} s or more: the pose is held "
                                      "where it was")
        limit = self.max_dead_reckoning
        if limit > 0 and self._tracker_at is not None and now - self._tracker_at > limit:
            if not self.blind:
                self.get_logger().error(
                    f"no tracker pose for {limit:g} s (max_dead_reckoning): the pose is no "
                    "longer published until the tracker sees the robot again")
            self.blind = True
            return
        self.blind = False
        self._publish()

    @property
    def pose(self) -> Pose | None:
        """The fused pose ``(x, y, yaw)`` in the map frame (EKF; None before the first
        sighting)."""
        if self.pose_filter is None:
            return None
        x, y, yaw = (float(v) for v in self.pose_filter.mean)
        return (x, y, yaw)

    @property
    def map_from_odom(self) -> Pose | None:
        """``map -> odom`` as ``(x, y, yaw)``: D.4's alignment, or the EKF's pose composed with
        the inverse of the odometry pose it last took in."""
        if self.filter_kind == "seed_000":
            return self._seed_map_from_odom
        pose = self.pose
        if pose is None or self._absorbed is None:
            return None
        x, y, yaw = (float(v) for v in compose(pose, inverse(self._absorbed)))
        return (x, y, yaw)

    def _publish(self) -> None:
        assert self.pose_filter is not None
        x, y, yaw = (float(v) for v in self.pose_filter.mean)
        sigma = self.pose_filter.covariance
        stamp = self.stamp()  # ROS time, as every node of the context stamps
        header = {"stamp": stamp, "frame_id": self.map_frame}
        pose = {"position": {"x": x, "y": y}, "orientation": _quaternion(yaw)}
        covariance = np.zeros((6, 6))
        index = [0, 1, 5]  # x, y, yaw among x y z roll pitch yaw
        covariance[np.ix_(index, index)] = sigma
        covariance[2, 2] = covariance[3, 3] = covariance[4, 4] = TWO_D_VARIANCE
        v, w = self._twist
        self.odometry_filtered.publish(self.message(
            ODOMETRY, header=header, child_frame_id=self.base_frame,
            pose={"pose": pose, "covariance": covariance.reshape(-1)},
            twist={"twist": {"linear": {"x": v}, "angular": {"z": w}}}))
        self.fused.publish(self.message(POSE, header=header, pose=pose))
        transform = self.map_from_odom
        if self.publish_tf and transform is not None:
            tx, ty, tyaw = transform
            self.tf.publish(self.message(TF, transforms=[{
                "header": header, "child_frame_id": self.odom_frame,
                "transform": {"translation": {"x": tx, "y": ty},
                              "rotation": _quaternion(tyaw)}}]))

    # -- seed 000's D.4 ----------------------------------------------------------------------

    def _on_odom_d4(self, msg: Any) -> None:
        p = msg.pose.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"odom refused: position ({p.x!r}, {p.y!r}) is not finite")
            return
        q = msg.pose.pose.orientation
        self._odometry_pose = (float(p.x), float(p.y), _yaw(q))
        self.odometry = self._in_map(self._odometry_pose)[:2] if self.align else (
            float(p.x), float(p.y))

    def _in_map(self, pose: Pose) -> Pose:
        """An odometry pose in the map frame (as it is until aligned)."""
        if self._seed_map_from_odom is None:
            return pose
        tx, ty, a = self._seed_map_from_odom
        x, y, yaw = pose
        c, s = math.cos(a), math.sin(a)
        return (tx + c * x - s * y, ty + s * x + c * y, yaw + a)

    @staticmethod
    def _heading(msg: Any) -> float | None:
        """The tracker pose's heading, None if its orientation holds none."""
        q = msg.pose.orientation
        if not (math.isfinite(q.z) and math.isfinite(q.w)) or (q.z == 0 and q.w == 0):
            return None
        return _yaw(q)

    def _correct_heading(self, msg: Any) -> None:
        """Turn ``map -> odom`` by ``heading_gain`` of the tracker's heading error, about the
        robot (its position in the map stays), as a slow complementary filter: the encoders'
        heading is smooth but drifts, the tracker's is coarse but does not drift."""
        heading = self._heading(msg)
        if heading is None or self._seed_map_from_odom is None or self._odometry_pose is None \
                or self.heading_gain == 0.0:
            return
        here = self._in_map(self._odometry_pose)
        error = math.remainder(heading - here[2], 2 * math.pi)
        a = self._seed_map_from_odom[2] + self.heading_gain * error
        x, y, _ = self._odometry_pose
        c, s = math.cos(a), math.sin(a)
        self._seed_map_from_odom = (here[0] - (c * x - s * y), here[1] - (s * x + c * y), a)

    def _align(self, msg: Any) -> None:
        """``map -> odom`` from this tracker pose and the odometry pose at hand."""
        if self._odometry_pose is None:
            return
        yaw_map = self._heading(msg)
        if yaw_map is None:
            return  # no heading in this sighting: wait for one that has it
        x, y, yaw = self._odometry_pose
        a = yaw_map - yaw
        c, s = math.cos(a), math.sin(a)
        self._seed_map_from_odom = (float(msg.pose.position.x) - (c * x - s * y),
                                    float(msg.pose.position.y) - (s * x + c * y), a)
        self.odometry = self._in_map(self._odometry_pose)[:2]

    def _on_tracker_d4(self, msg: Any) -> None:
        p = msg.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"tracker pose refused: ({p.x!r}, {p.y!r}) is not finite")
            return
        tracker = (float(p.x), float(p.y))
        if self.align and self._seed_map_from_odom is None:
            self._align(msg)
            if self._seed_map_from_odom is None:
                self.odometry = None  # odometry in another frame is not fused
        elif self.align:
            self._correct_heading(msg)
        if self.filter is None:
            self.filter = seed_000_filter(np.array(tracker), self.config)
        elif self.odometry is not None:
            self.filter.predict(self.config.sample_period)
            self.filter.update(ODOMETRY_AND_TRACKER, np.array([*self.odometry, *tracker]))
        else:  # no odometry yet: the tracker alone
            self.filter.predict(self.config.sample_period)
            self.filter.update(TRACKER, np.array(tracker))
        x, y = (float(v) for v in self.filter.state[:2])
        orientation = {"w": 1.0}
        if self.align and self._seed_map_from_odom is not None \
                and self._odometry_pose is not None:
            yaw = math.remainder(self._in_map(self._odometry_pose)[2], 2 * math.pi)
            orientation = _quaternion(yaw)
        self.fused.publish(self.message(POSE, header={"stamp": msg.header.stamp,
                                                      "frame_id": msg.header.frame_id},
                                        pose={"position": {"x": x, "y": y},
                                              "orientation": orientation}))
