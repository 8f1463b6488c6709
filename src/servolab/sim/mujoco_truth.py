"""A MuJoCo world's ground truth as topics: what a biped really did, into the bag beside
what its motors reported.

:class:`SampledTruthNode` publishes every :class:`~.mujoco_world.Sample` the world keeps
(50 a second by default), each stamped with its own time, so nothing between two timer
ticks is lost:

- ``/ground_truth`` (``nav_msgs/msg/Odometry``, frame ``world``): the base body's pose;
- ``/ground_truth/com``, ``/ground_truth/zmp``, ``/ground_truth/cop``
  (``geometry_msgs/msg/PointStamped``): the centre of mass, the zero-moment point and the
  centre of pressure on the floor (a point that is undefined, in the air, is not published);
- ``/ground_truth/support_margin`` (``std_msgs/msg/Float64``): the zero-moment point's
  distance inside the support polygon (m, negative outside); ROS has no stamped float, so
  the bag dates it when it is published, within a timer period (50 ms) of its sample;
- ``/ground_truth/<foot>/wrench`` (``geometry_msgs/msg/WrenchStamped``): the floor's normal
  force on each foot.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from ..middleware.context import Context
from ..middleware.node import Node
from .errors import SimulationError
from .mujoco_world import MujocoWorld, Sample

ODOMETRY = "nav_msgs/msg/Odometry"
POINT = "geometry_msgs/msg/PointStamped"
WRENCH = "geometry_msgs/msg/WrenchStamped"
FLOAT64 = "std_msgs/msg/Float64"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
#: the fixed frame the truth is given in (the MuJoCo world's), parent of the base's /tf
WORLD_FRAME = "world"


def truth_topics(world: MujocoWorld) -> dict[str, str]:
    """Topic -> type of everything :class:`SampledTruthNode` publishes for ``world``."""
    topics = {"/ground_truth": ODOMETRY, "/tf": TF_MESSAGE, "/ground_truth/com": POINT,
              "/ground_truth/zmp": POINT, "/ground_truth/cop": POINT,
              "/ground_truth/support_margin": FLOAT64}
    for foot in world.feet:
        topics[f"/ground_truth/{foot}/wrench"] = WRENCH
    return topics


class SampledTruthNode(Node):
    """See the module docstring. Parameter: ``rate`` (Hz, 20): how often the samples kept
    since the last time are published."""

    def __init__(self, context: Context, world: MujocoWorld, name: str = "ground_truth",
                 namespace: str = "/", *, parameter_overrides: Mapping[str, Any] | None = None
                 ) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides)
        self.world = world
        rate = float(self.declare_parameter("rate", 20.0, description="Hz").value)
        if not (math.isfinite(rate) and rate > 0):
            raise SimulationError(f"ground truth: rate {rate!r} must be a number > 0 Hz")
        self._publishers = {topic: self.create_publisher(kind, topic, 100)
                            for topic, kind in truth_topics(world).items()}
        self._sent = 0
        self.create_timer(1.0 / rate, self.publish_new)

    def publish_new(self) -> None:
        """Publish the samples taken since the last call (those the world still keeps)."""
        world = self.world
        new = min(world.samples_taken - self._sent, len(world.samples))
        for sample in world.samples[len(world.samples) - new:]:
            self._publish(sample)
        self._sent = world.samples_taken

    def _publish(self, s: Sample) -> None:
        header = {"stamp": self.stamp(s.t), "frame_id": WORLD_FRAME}
        x, y, z, roll, pitch, yaw = s.base
        base = self.world.model.body(self.world.base).name
        rotation = _quaternion(roll, pitch, yaw)
        self._publishers["/ground_truth"].publish(self.message(
            ODOMETRY, header=header, child_frame_id=base,
            pose={"pose": {"position": {"x": x, "y": y, "z": z}, "orientation": rotation}}))
        # the base placed in the world on /tf, as Gazebo's ground-truth plugins do: a 3D
        # viewer then shows the robot walking over the floor, not pinned at its base
        self._publishers["/tf"].publish(self.message(TF_MESSAGE, transforms=[{
            "header": header, "child_frame_id": base,
            "transform": {"translation": {"x": x, "y": y, "z": z}, "rotation": rotation}}]))
        points = {"/ground_truth/com": s.com, "/ground_truth/zmp": (*s.zmp, 0.0),
                  "/ground_truth/cop": (*s.cop, 0.0)}
        for topic, (px, py, pz) in points.items():
            if math.isfinite(px):
                self._publishers[topic].publish(self.message(
                    POINT, header=header, point={"x": px, "y": py, "z": pz}))
        if math.isfinite(s.margin):
            self._publishers["/ground_truth/support_margin"].publish(
                self.message(FLOAT64, data=s.margin))
        for foot, force in zip(self.world.feet, s.feet, strict=True):
            self._publishers[f"/ground_truth/{foot}/wrench"].publish(self.message(
                WRENCH, header=header, wrench={"force": {"z": force}}))


def _quaternion(roll: float, pitch: float, yaw: float) -> dict[str, float]:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return {"w": cr * cp * cy + sr * sp * sy, "x": sr * cp * cy - cr * sp * sy,
            "y": cr * sp * cy + sr * cp * sy, "z": cr * cp * sy - sr * sp * cy}
