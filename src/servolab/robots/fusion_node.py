"""The fusion node: ``/odom`` and a visual tracker's pose fused into one pose (seed 000, D.4).

Each tracker pose (``geometry_msgs/msg/PoseStamped`` on ``tracker_topic``, ``/tracker/pose`` by
default) is one of the seed's samples: the filter predicts one sample ahead and updates with
the tracker's position and the latest odometry position together, as D.4's loop does, then
publishes the fused position on ``fused_pose`` (``geometry_msgs/msg/PoseStamped``, the
tracker's frame and stamp). The filter is :func:`servolab.estimation.kalman.seed_000_filter`,
with D.4's Q and R unless others are given; it starts at the tracker's first position.
A message holding NaN is refused (logged) and leaves the filter as it was.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..estimation.kalman import (
    ODOMETRY_AND_TRACKER,
    SEED_000_FUSION,
    TRACKER,
    KalmanFilter,
    Seed000Fusion,
    seed_000_filter,
)
from ..middleware.context import Context
from ..middleware.node import Node

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
        self.config = config
        self.filter: KalmanFilter | None = None
        self.odometry: tuple[float, float] | None = None
        self.fused = self.create_publisher(POSE, "fused_pose", 10)
        self.create_subscription(ODOMETRY, "odom", self._on_odom, 10)
        self.create_subscription(POSE, tracker_topic, self._on_tracker, 10)

    def _on_odom(self, msg: Any) -> None:
        p = msg.pose.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"odom refused: position ({p.x!r}, {p.y!r}) is not finite")
            return
        self.odometry = (float(p.x), float(p.y))

    def _on_tracker(self, msg: Any) -> None:
        p = msg.pose.position
        if not (math.isfinite(p.x) and math.isfinite(p.y)):
            self.get_logger().error(f"tracker pose refused: ({p.x!r}, {p.y!r}) is not finite")
            return
        tracker = (float(p.x), float(p.y))
        if self.filter is None:
            self.filter = seed_000_filter(np.array(tracker), self.config)
        elif self.odometry is not None:
            self.filter.predict(self.config.sample_period)
            self.filter.update(ODOMETRY_AND_TRACKER, np.array([*self.odometry, *tracker]))
        else:  # no odometry yet: the tracker alone
            self.filter.predict(self.config.sample_period)
            self.filter.update(TRACKER, np.array(tracker))
        x, y = (float(v) for v in self.filter.state[:2])
        self.fused.publish(self.message(POSE, header={"stamp": msg.header.stamp,
                                                      "frame_id": msg.header.frame_id},
                                        pose={"position": {"x": x, "y": y},
                                              "orientation": {"w": 1.0}}))
