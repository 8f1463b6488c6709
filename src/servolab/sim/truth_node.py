"""A world's ground truth as a topic: what the simulated robot really did, beside what it
believes (its odometry), so that a recording holds both and the error can be measured.

:class:`GroundTruthNode` publishes a :class:`~.world.World`'s pose (``x``, ``y``, ``yaw`` of
:meth:`~.world.World.ground_truth`) as ``nav_msgs/msg/Odometry`` in the frame ``world`` on
``/ground_truth`` at ``rate`` Hz, with its linear and angular velocity where the world gives
them. In a robot's namespace (``/robot1``) the topic is the robot's (``/robot1/ground_truth``)
and so is the child frame (``robot1/base_footprint``); ``world`` is the floor's, every
robot's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..middleware.context import Context
from ..middleware.names import BASE_FRAME, frame_prefix
from ..middleware.node import Node
from .errors import SimulationError
from .world import World

ODOMETRY = "nav_msgs/msg/Odometry"


class GroundTruthNode(Node):
    """See the module docstring. Parameter: ``rate`` (Hz, 30)."""

    def __init__(self, context: Context, world: World, name: str = "ground_truth",
                 namespace: str = "/", *, parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.world = world
        rate = float(self.declare_parameter("rate", 30.0, description="Hz").value)
        if not (math.isfinite(rate) and rate > 0):
            raise SimulationError(f"ground truth: rate {rate!r} must be a number > 0 Hz")
        self.child_frame = frame_prefix(self.get_namespace()) + BASE_FRAME
        self.publisher = self.create_publisher(ODOMETRY, "ground_truth", 10)
        self.create_timer(1.0 / rate, self._publish)

    def _publish(self) -> None:
        truth = self.world.ground_truth()
        yaw = truth.get("yaw", 0.0)
        self.publisher.publish(self.message(
            ODOMETRY,
            header={"stamp": self.stamp(), "frame_id": "world"},
            child_frame_id=self.child_frame,
            pose={"pose": {"position": {"x": truth.get("x", 0.0), "y": truth.get("y", 0.0)},
                           "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}},
            twist={"twist": {"linear": {"x": truth.get("linear_velocity", 0.0)},
                             "angular": {"z": truth.get("angular_velocity", 0.0)}}}))
