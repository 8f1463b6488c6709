"""Chapter 3's analysis (seed 002) on hand-made logs with known answers: encoder wrap, the
fictive path's sense of turning, the robot's odometry, the shape measure, the delay."""

from __future__ import annotations

import math

import numpy as np
import pytest

from servolab.kinematics.aot import AotGeometry, AotKinematics, surface_in_camera
from servolab.kinematics.diffdrive import DiffDrive
from servolab.robots.treadmill.analysis import (
    TICKS_PER_REV,
    analyze,
    fictive_path,
    path_disparity,
    response_delay,
    robot_path,
    sphere_motion,
)
from servolab.robots.treadmill.logs import ENCODER_RECORD, FLY_RECORD


def _fly_log(n: int, dt: float = 1 / 66) -> np.ndarray:
    log = np.zeros(n, dtype=FLY_RECORD)
    log["frame"] = np.arange(n)
    log["time"] = np.arange(n) * dt
    log["cx"], log["cy"], log["contour_area"] = 320.0, 188.0, 500.0
    return log


def _signed_area(path: np.ndarray) -> float:
    x, y = path[:, 0], path[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def test_encoder_wraps_are_unwrapped() -> None:
    """The XM's present_position is a 32-bit count; a wrap is not a turn of the wheel."""
    geometry = AotGeometry()
    log = _fly_log(3)
    for i, ticks in ((1, (4095, 4099, 4103)), (2, (2**31 - 1, -(2**31) + 3, -(2**31) + 7)),
                     (3, (0, 4, 8))):
        log[f"position{i}"] = ticks
    _, _, motion = sphere_motion(log, geometry)
    expected = AotKinematics.from_geometry(geometry).ball_velocity(
        np.full(3, 4 * 2 * math.pi / TICKS_PER_REV))
    camera = surface_in_camera(expected, geometry)
    np.testing.assert_allclose(motion, np.tile(camera, (2, 1)), atol=1e-9)


def test_the_fictive_path_turns_the_way_the_fly_turns() -> None:
    """The fly walks along +x of the image and turns clockwise on the screen (+theta, y
    down); the ball moves against it. Seen from above with y up, its path turns clockwise:
    negative area, as a robot turning right has."""
    step, turn = 0.001, 0.02  # m and rad per frame
    motion = np.tile([-step, 0.0, -turn], (300, 1))  # the surface, in the image frame
    path = fictive_path(motion)
    assert path[1, 0] == pytest.approx(step, rel=1e-3) and path[1, 1] < 0
    assert _signed_area(path) < 0
    # a regular polygon of chords `step` turning `turn` each: its circumradius
    radius = step / (2 * math.sin(turn / 2))
    centre = np.array([0.0, -radius])
    np.testing.assert_allclose(np.hypot(*(path - centre).T), radius, rtol=1e-6)


def test_robot_odometry_of_the_encoder_log() -> None:
    """Listing 2's log: one wheel turn of both wheels is 2 pi r forward; left only turns
    right (clockwise)."""
    drive = DiffDrive(0.033, 0.287)
    log = np.zeros(3, dtype=ENCODER_RECORD)
    log["left"] = (0, 4096, 8192)
    log["right"] = (0, 4096, 8192)
    assert robot_path(log, drive)[-1] == pytest.approx((2 * 2 * math.pi * 0.033, 0.0))
    log["right"] = 0
    assert _signed_area(robot_path(log, drive)) <= 0 and robot_path(log, drive)[-1, 1] < 0


def test_the_shape_measure_is_blind_to_pose_and_size_but_not_to_a_mirror() -> None:
    t = np.linspace(0, 3 * math.pi, 400)
    path = np.column_stack([t * np.cos(t), t * np.sin(t)])  # a spiral turning left
    turned = 2.5 * path @ np.array([[0.6, -0.8], [0.8, 0.6]]) + [3.0, -1.0]
    assert path_disparity(path, turned) == pytest.approx(0.0, abs=1e-9)
    mirrored = path * [1.0, -1.0]  # the same spiral turning right
    assert path_disparity(path, mirrored) > 0.3
    assert math.isnan(path_disparity(path, np.zeros((5, 2))))


def test_the_delay_from_command_to_motion() -> None:
    """Wheels told to move at frame 10 first show motion at frame 18: 8 frames."""
    log = _fly_log(40)
    log["omega1"][10:] = 5.0
    log["position1"][18:] = np.arange(22) + 1
    delay, events = response_delay(log)
    assert events == 1 and delay == pytest.approx(8 / 66)


def test_analyze_a_log_where_the_fly_stands_still() -> None:
    log = _fly_log(50)
    result, series = analyze(log, np.zeros(0, dtype=ENCODER_RECORD))
    assert result.frames == result.frames_with_fly == 50
    assert result.mean_distance_error_mm == 0.0 and result.sphere_path_length_m == 0.0
    assert math.isnan(result.path_disparity)  # no paths to compare
    assert series["sphere_path"].shape == (50, 2)
