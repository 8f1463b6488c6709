"""JointStateNode: a robot's joints on ``/joint_states`` (sensor_msgs/JointState), read from its
bus at a fixed rate — the job ros2_control's ``joint_state_broadcaster`` does for a ROS 2 robot,
and what a robot_state_publisher turns into ``/tf``."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

from ..middleware.node import Node
from .errors import RobotValueError

if TYPE_CHECKING:
    from ..middleware.context import Context

JOINT_STATE = "sensor_msgs/msg/JointState"


class JointStateNode(Node):
    """Publishes ``read()`` (positions in rad or m, by joint name) for ``joints``, in that
    order, ``rate`` times a second of the context's clock."""

    def __init__(self, context: Context, joints: Sequence[str],
                 read: Callable[[], Mapping[str, float]], *, rate: float = 50.0,
                 name: str = "joint_state_broadcaster", namespace: str = "/") -> None:
        super().__init__(context, name, namespace)
        if not (math.isfinite(rate) and rate > 0):
            raise RobotValueError(f"{name}: rate {rate:g} Hz must be a number > 0")
        self.joints = list(joints)
        self.read = read
        self.publisher = self.create_publisher(JOINT_STATE, "joint_states", 10)
        self.create_timer(1.0 / rate, self.publish)

    def publish(self) -> None:
        positions = self.read()
        self.publisher.publish(self.message(
            JOINT_STATE, header={"stamp": self.stamp()}, name=self.joints,
            position=[float(positions[j]) for j in self.joints]))
