"""The overhead tracker node: a camera frame in, /tracker/pose and a latched /map out (only
when a cell changed); a frame of the wrong encoding or size is refused and changes nothing."""

from __future__ import annotations

import math
from typing import Any

import cv2
import numpy as np
import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.navigation.params import load_nav_scene
from servolab.robots.navigation.tracker_node import LATCHED, OverheadTrackerNode, occupancy_of
from servolab.sim.scene import DEFAULT_SCENE
from servolab.vision.calibration import CameraCalibration, FloorExtrinsics
from servolab.vision.overhead import FloorGrid
from servolab.vision.synthetic import render_floor

IMAGE = "sensor_msgs/msg/Image"


class Rig:
    def __init__(self) -> None:
        self.scene = load_nav_scene(DEFAULT_SCENE)
        camera = self.scene.camera.pinhole()
        rvec, tvec = self.scene.camera.floor_pose()
        # the truth as the calibration: this test is about the node, not the calibration
        self.calib = CameraCalibration(camera.camera_matrix, camera.distortion_coefficients,
                                       camera.image_size)
        self.extrinsics = FloorExtrinsics(np.asarray(cv2.Rodrigues(rvec)[0]), tvec)
        self.camera, self.rvec, self.tvec = camera, rvec, tvec
        self.context = Context.open(clock=VirtualClock())
        self.node = OverheadTrackerNode(self.context, self.calib, self.extrinsics,
                                        FloorGrid(4.0, 3.0, 0.05))
        self.probe = Node(self.context, "probe")
        self.images = self.probe.create_publisher(IMAGE, "/overhead/image_raw")
        self.poses: list[Any] = []
        self.maps: list[Any] = []
        self.probe.create_subscription("geometry_msgs/msg/PoseStamped", "/tracker/pose",
                                       self.poses.append, 0)
        self.probe.create_subscription("nav_msgs/msg/OccupancyGrid", "/map", self.maps.append,
                                       LATCHED)

    def frame(self, t: float, robot: tuple[float, float, float]) -> np.ndarray:
        return render_floor(self.camera, self.rvec, self.tvec, self.scene.floor_scene(t, robot),
                            noise_std=2.0, rng=np.random.default_rng(1))

    def send(self, image: np.ndarray, encoding: str = "mono8") -> None:
        height, width = image.shape[:2]
        step = image.strides[0]
        self.images.publish(self.probe.message(IMAGE, height=height, width=width,
                                               encoding=encoding, step=step,
                                               data=image.reshape(-1)))
        self.context.spin_for(0.05)


@pytest.fixture
def rig() -> Any:
    r = Rig()
    yield r
    r.context.close()


def test_a_frame_gives_the_robots_pose_and_the_map(rig: Rig) -> None:
    rig.send(rig.frame(0.0, (1.0, 0.8, 0.5)))
    (pose,) = rig.poses
    p, q = pose.pose.position, pose.pose.orientation
    assert (p.x, p.y) == pytest.approx((1.0, 0.8), abs=0.01)
    assert 2 * math.atan2(q.z, q.w) == pytest.approx(0.5, abs=math.radians(3))
    (grid,) = rig.maps
    occupied, resolution, origin = occupancy_of(grid)
    assert (resolution, origin, occupied.shape) == (pytest.approx(0.05), (0.0, 0.0), (60, 80))
    assert occupied[28, 40] and not occupied[12, 12]  # circle at (2.0, 1.4); free floor
    # the same floor again: no new map; the obstacle that appears at 6 s: a new one
    rig.send(rig.frame(1.0, (1.1, 0.8, 0.5)))
    assert len(rig.maps) == 1 and len(rig.poses) == 2
    rig.send(rig.frame(6.0, (1.2, 0.8, 0.5)))
    assert len(rig.maps) == 2
    assert occupancy_of(rig.maps[-1])[0][36, 55]  # the late circle at (2.75, 1.8)


@pytest.mark.parametrize("bad", ["encoding", "size"])
def test_a_bad_frame_is_refused_and_changes_nothing(rig: Rig, bad: str,
                                                    caplog: pytest.LogCaptureFixture) -> None:
    image = rig.frame(0.0, (1.0, 0.8, 0.5))
    if bad == "encoding":
        rig.send(np.repeat(image[:, :, None], 3, axis=2), encoding="bgr8")
    else:
        rig.send(np.ascontiguousarray(image[:240, :320]))
    assert rig.poses == [] and rig.maps == [] and rig.node.maps_published == 0
    assert "image refused" in caplog.text


def test_a_map_that_does_not_fill_its_size_is_refused(rig: Rig) -> None:
    grid = rig.probe.message("nav_msgs/msg/OccupancyGrid",
                             info={"resolution": 0.05, "width": 4, "height": 3},
                             data=np.zeros(11, dtype=np.int8))
    with pytest.raises(ValueError, match="11 cells for 4x3"):
        occupancy_of(grid)
