"""What a navigation session sets up, shared by ``servolab navigate`` (:mod:`.run`) and the
launch files' nodes (:mod:`.launch_nodes`): the synthetic calibration session, the map's cells,
the pose timeout, the error a navigation that cannot start raises and the one a goal not
reached ends with."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from ...estimation.pose_filter import PoseFilterConfig
from ...sim.scene import Scene
from ...vision.calibration import CameraCalibration, FloorExtrinsics, calibrate, floor_extrinsics
from ...vision.overhead import FloorGrid
from ...vision.synthetic import random_board_poses, render_checkerboard
from ..errors import RobotError, RobotValueError

#: the calibration board of the synthetic session: 10 x 7 squares of 80 mm (even x odd, as
#: the seed requires), 15 views
BOARD, SQUARE_MM, VIEWS = (10, 7), 80.0, 15
#: the board laid on the floor for its plane: 10 x 7 squares of 150 mm, large enough for the
#: corner detector from a camera 3 m up
FLOOR_BOARD, FLOOR_SQUARE_MM = (10, 7), 150.0
#: where the synthetic session's floor board lies (x m, y m, yaw rad): its first inner corner,
#: its first row along x; face up, so its squares run towards -y, all on the floor
BOARD_AT = (0.3, 1.4, 0.0)
#: how far the map reaches beyond the floor on each side (m): the arena's walls are in it
MAP_MARGIN = 0.2
#: the navigator stops the wheels when the pose is older than this many camera frames
POSE_TIMEOUT_FRAMES = 2.5



class NavigationError(RobotValueError):
    """A navigation that cannot start (a goal in an obstacle, a file that does not fit); the
    message says why. Raised before anything moves."""


class GoalNotReached(RobotError):
    """The robot did not reach its goal; the message says why (move_base gave up, time ran
    out) and where the run folder is. ``summary`` holds the run's figures, written already."""

    def __init__(self, message: str, summary: dict[str, Any] | None = None) -> None:
        super().__init__(message)
        self.summary = summary


def fusion_for(scene: Scene) -> PoseFilterConfig:
    """The localiser's noise for this scene: the tracker sees the robot's marker within about
    a pixel's footprint on the floor below the camera; odometry's noise is the filter's
    default for seed 000's base."""
    pixel = scene.camera.position[2] / max(scene.camera.fx, scene.camera.fy)  # m per pixel
    return PoseFilterConfig(position_variance=pixel**2)


def calibrate_synthetic(scene: Scene, rng: np.random.Generator
                        ) -> tuple[CameraCalibration, FloorExtrinsics]:
    """Calibrate the scene's camera from synthetic board images, and find the floor plane
    from one image of the board lying at the floor's origin (see the module docstring)."""
    camera = scene.camera.pinhole()
    poses = random_board_poses(camera, BOARD, SQUARE_MM, VIEWS, rng)
    images = [render_checkerboard(camera, BOARD, SQUARE_MM, r, t, noise_std=1.0, rng=rng)
              for r, t in poses]
    calib = calibrate(images, BOARD, SQUARE_MM, camera_name="overhead_camera")
    # the board's pose in the camera: the floor's (map frame, z up) composed with the board's
    # place on it (x along the map's x, y along its -y, z into the floor)
    rvec, tvec = scene.camera.floor_pose()
    floor_rotation, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))
    axes = np.diag([1.0, -1.0, -1.0])
    corner = np.array([BOARD_AT[0] * 1000.0, BOARD_AT[1] * 1000.0, 0.0])

    board_rvec, _ = cv2.Rodrigues(np.asarray(floor_rotation) @ axes)
    board_tvec = np.asarray(floor_rotation) @ corner + np.asarray(tvec, dtype=np.float64)
    floor = render_checkerboard(camera, FLOOR_BOARD, FLOOR_SQUARE_MM, board_rvec, board_tvec,
                                noise_std=1.0, rng=rng, background=200)
    return calib, floor_extrinsics(calib, floor, FLOOR_BOARD, FLOOR_SQUARE_MM,
                                   name="floor board image")


def map_grid(scene: Scene, resolution: float) -> FloorGrid:
    """The map's cells: the floor and :data:`MAP_MARGIN` around it."""
    return FloorGrid(scene.width + 2 * MAP_MARGIN, scene.depth + 2 * MAP_MARGIN, resolution,
                     origin=(-MAP_MARGIN, -MAP_MARGIN))
