"""The fusion node: ``/odom`` and a visual tracker's pose fused into one pose (seed 000, D.4).

Each tracker pose (``geometry_msgs/msg/PoseStamped`` on ``tracker_topic``, ``/tracker/pose`` by
default) is one of the seed's samples: the filter predicts one sample ahead and updates with
the tracker's position and the latest odometry position together, as D.4's loop does, then
publishes the fused position on ``fused_pose`` (``geometry_msgs/msg/PoseStamped``, the
tracker's frame and stamp). The filter is :func:`servolab.estimation.kalman.seed_000_filter`,
with D.4's Q and R unless others are given; it starts at the tracker's first position.
A message holding NaN is refused (logged) and leaves the filter as it was.

Odometry counts from where the base was switched on (the ``odom`` frame), the tracker from the
floor's origin (the ``map`` frame). The seed fuses the two as they are, which is right only
when both start at the same point. With ``align_odometry`` the node first finds ``map -> odom``
from the first tracker pose that arrives after odometry, as a localiser does: the tracker's
position and heading (its orientation) against the odometry pose at that moment. From then on
each odometry pose is moved into the map frame before it is fused, and the fused pose carries
the heading of the aligned odometry. The tracker's heading is coarser than the encoders' but
does not drift: each later sighting turns ``map -> odom`` by ``heading_gain`` (0.05) of the
difference, about the robot, so a wrong first alignment or the encoders' drift fades out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...estimation.kalman import (
    ODOMETRY_AND_TRACKER,
    SEED_000_FUSION,
    TRACKER,
    KalmanFilter,
    Seed000Fusion,
    seed_000_filter,
)
from ...middleware.context import Context
from ...middleware.node import Node
from ..errors import RobotValueError

ODOMETRY = "nav_msgs/msg/Odometry"
POSE = "geometry_msgs/msg/PoseStamped"


class FusionNode(Node):
    """See the module docstring. Parameter: ``tracker_topic``."""

    def __init__(self, context: Context, name: str = "fusion", namespace: str = "/", *,
                 config: Seed000Fusion = SEED_000_FUSION,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        tracker_topic = str(self.declare_parameter("tracker_topic", "/tracker/pose").value)
        self.align = bool(self.declare_parameter(
            "align_odometry", False, description="find map -> odom from the first tracker "
            "pose and fuse odometry in the map frame").value)
        self.heading_gain = float(self.declare_parameter(
            "heading_gain", 0.05, description="with align_odometry: the part of the tracker's "
            "heading error corrected at each later sighting (0: align once)").value)
        if not (math.isfinite(self.heading_gain) and 0.0 <= self.heading_gain <= 1.0):
            raise RobotValueError(f"fusion: heading_gain {self.heading_gain!r} must be in [0, 1]")
        self.config = config
        self.filter: KalmanFilter | None = None
        self.odometry: tuple[float, float] | None = None
        self._odometry_pose: tuple[float, float, float] | None = None
        #: map -> odom as (x, y, yaw), once aligned (``align_odometry``)
        self.map_from_odom: tuple[float, float, float] | None = None
        self.fused = self.create_publisher(POSE, "fused_pose", 10)
        self.create_subscription(ODOMETRY, "odom", self._on_odom, 10)
        self.create_subscription(POSE, tracker_topic, self._on_tracker, 10)

    def _on_odom(self, msg: Any) -> None:
        p = msg.pose.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"odom refused: position ({p.x!r}, {p.y!r}) is not finite")
            return
        q = msg.pose.pose.orientation
        yaw = 2.0 * math.atan2(float(q.z), float(q.w))
        self._odometry_pose = (float(p.x), float(p.y), yaw)
        self.odometry = self._in_map(self._odometry_pose)[:2] if self.align else (
            float(p.x), float(p.y))

    def _in_map(self, pose: tuple[float, float, float]) -> tuple[float, float, float]:
        """An odometry pose in the map frame (as it is until aligned)."""
        if self.map_from_odom is None:
            return pose
        tx, ty, a = self.map_from_odom
        x, y, yaw = pose
        c, s = math.cos(a), math.sin(a)
        return (tx + c * x - s * y, ty + s * x + c * y, yaw + a)

    @staticmethod
    def _heading(msg: Any) -> float | None:
        """The tracker pose's heading, None if its orientation holds none."""
        q = msg.pose.orientation
        if not (math.isfinite(q.z) and math.isfinite(q.w)) or (q.z == 0 and q.w == 0):
            return None
        return 2.0 * math.atan2(float(q.z), float(q.w))

    def _correct_heading(self, msg: Any) -> None:
        """Turn ``map -> odom`` by ``heading_gain`` of the tracker's heading error, about the
        robot (its position in the map stays), as a slow complementary filter: the encoders'
        heading is smooth but drifts, the tracker's is coarse but does not drift."""
        heading = self._heading(msg)
        if heading is None or self.map_from_odom is None or self._odometry_pose is None \
                or self.heading_gain == 0.0:
            return
        here = self._in_map(self._odometry_pose)
        error = math.remainder(heading - here[2], 2 * math.pi)
        a = self.map_from_odom[2] + self.heading_gain * error
        x, y, _ = self._odometry_pose
        c, s = math.cos(a), math.sin(a)
        self.map_from_odom = (here[0] - (c * x - s * y), here[1] - (s * x + c * y), a)

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
        self.map_from_odom = (float(msg.pose.position.x) - (c * x - s * y),
                              float(msg.pose.position.y) - (s * x + c * y), a)
        self.odometry = self._in_map(self._odometry_pose)[:2]

    def _on_tracker(self, msg: Any) -> None:
        p = msg.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"tracker pose refused: ({p.x!r}, {p.y!r}) is not finite")
            return
        tracker = (float(p.x), float(p.y))
        if self.align and self.map_from_odom is None:
            self._align(msg)
            if self.map_from_odom is None:
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
        if self.align and self.map_from_odom is not None and self._odometry_pose is not None:
            yaw = math.remainder(self._in_map(self._odometry_pose)[2], 2 * math.pi)
            orientation = {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}
        self.fused.publish(self.message(POSE, header={"stamp": msg.header.stamp,
                                                      "frame_id": msg.header.frame_id},
                                        pose={"position": {"x": x, "y": y},
                                              "orientation": orientation}))
