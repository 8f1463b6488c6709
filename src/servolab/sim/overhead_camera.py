"""The synthetic overhead camera of seed 000: the scene's floor, obstacles and robot, drawn at
the robot's true pose, as the camera above the arena would see them.

:class:`OverheadCameraNode` publishes ``sensor_msgs/msg/Image`` (``mono8``, frame
``overhead_camera``) on ``/overhead/image_raw`` at the scene camera's rate. It belongs to the
world, not to the robot: it reads the floor's ground truth, which nothing on the robot's side
may, and the obstacles that appear mid-run appear here, at their time after the node started.
In a namespace (a run's, ``/robot1``) its topic is there (``/robot1/overhead/image_raw``); its
frame stays the world's.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..middleware.context import Context
from ..middleware.node import Node
from ..vision.synthetic import Image, render_floor
from .world import World

if TYPE_CHECKING:
    from .scene import Scene

IMAGE = "sensor_msgs/msg/Image"
FRAME = "overhead_camera"


class OverheadCameraNode(Node):
    """See the module docstring. ``seed`` makes the image noise repeatable."""

    def __init__(self, context: Context, scene: Scene, world: World,
                 name: str = "overhead_camera", namespace: str = "/", *, seed: int = 0,
                 parameter_overrides: Mapping[str, Any] | None = None,
                 remappings: Mapping[str, str] | None = None) -> None:
        super().__init__(context, name, namespace, parameter_overrides=parameter_overrides,
                         remappings=remappings)
        self.scene = scene
        self.world = world
        self.camera = scene.camera.pinhole()
        self.rvec, self.tvec = scene.camera.floor_pose()
        self.rng = np.random.default_rng(seed)
        self.start = self.now()
        self.frames = 0
        self.publisher = self.create_publisher(IMAGE, "overhead/image_raw", 2)
        self.create_timer(1.0 / scene.camera.rate, self._publish)

    def render(self) -> Image:
        """The frame the camera sees now."""
        truth = self.world.ground_truth()
        robot = (truth["x"], truth["y"], truth["yaw"])
        return render_floor(self.camera, self.rvec, self.tvec,
                            self.scene.floor_scene(self.now() - self.start, robot),
                            noise_std=self.scene.camera.noise_std, rng=self.rng)

    def _publish(self) -> None:
        image = self.render()
        height, width = image.shape
        self.publisher.publish(self.message(
            IMAGE, header={"stamp": self.stamp(), "frame_id": FRAME},
            height=height, width=width, encoding="mono8", step=width,
            data=np.ascontiguousarray(image).reshape(-1)))
        self.frames += 1
