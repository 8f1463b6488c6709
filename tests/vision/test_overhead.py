"""The overhead camera's occupancy grid and robot pose against a synthetic camera whose truth is
known: a 640x480 camera with barrel distortion 2.5 m above a 3 m x 2 m floor, slightly tilted."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from servolab.vision.calibration import CameraCalibration, FloorExtrinsics, floor_to_image
from servolab.vision.overhead import FloorGrid, FloorSampler, find_robot
from servolab.vision.synthetic import Circle, FloorScene, PinholeCamera, RobotMarker, render_floor

CAMERA = PinholeCamera(420.0, 420.0, 322.0, 238.0, 640, 480, (-0.1, 0.03, 0.0, 0.0, 0.0))
# Looking straight down, floor -> camera is diag(1, -1, -1); a few degrees of tilt on top.
ROTATION = np.asarray(np.asarray(cv2.Rodrigues(np.deg2rad([3.0, -2.0, 1.5]))[0])
                      @ np.diag([1.0, -1.0, -1.0]), dtype=np.float64)
CENTRE_MM = np.array([1500.0, 1000.0, 2500.0])  # the camera above the floor's middle
TVEC = -ROTATION @ CENTRE_MM
RVEC = np.asarray(cv2.Rodrigues(ROTATION)[0], dtype=np.float64).ravel()
CALIB = CameraCalibration(CAMERA.camera_matrix, CAMERA.distortion_coefficients,
                          CAMERA.image_size)
EXTRINSICS = FloorExtrinsics(ROTATION, TVEC)

BOX = np.array([[300.0, 250.0], [900.0, 250.0], [900.0, 700.0], [300.0, 700.0]])
CIRCLES = (Circle(2300.0, 1400.0, 250.0), Circle(1900.0, 400.0, 150.0))
ROBOT = RobotMarker(1200.0, 1300.0, 0.7)
# Beyond the camera's view on the left: the floor from -1.5 m.
GRID = FloorGrid(width=4.5, depth=2.0, resolution=0.05, origin=(-1.5, 0.0))


def _image(scene: FloorScene, seed: int = 0) -> np.ndarray:
    return render_floor(CAMERA, RVEC, TVEC, scene, noise_std=2.0,
                        rng=np.random.default_rng(seed))


def _angle_diff(a: float, b: float) -> float:
    return abs((a - b + math.pi) % (2 * math.pi) - math.pi)


@pytest.mark.parametrize(("x", "y", "theta_deg"), [
    (1500.0, 1000.0, 0.0), (400.0, 300.0, 179.0), (2700.0, 1750.0, -179.0),
    (2600.0, 250.0, 180.0), (300.0, 1700.0, -90.0), (1000.0, 1200.0, 37.0),
    (2100.0, 900.0, -135.0), (1800.0, 1600.0, 100.0),
])
def test_robot_found_within_10_mm_and_3_degrees(x: float, y: float, theta_deg: float) -> None:
    theta = math.radians(theta_deg)
    scene = FloorScene(polygons=(BOX,), circles=CIRCLES[:1], robot=RobotMarker(x, y, theta))
    seen = find_robot(_image(scene, seed=int(x)), CALIB, EXTRINSICS)
    assert seen is not None
    assert math.hypot(seen.x * 1000.0 - x, seen.y * 1000.0 - y) < 10.0, seen
    assert math.degrees(_angle_diff(seen.yaw, theta)) < 3.0, seen
    u, v = floor_to_image(CALIB, EXTRINSICS, (x, y))
    assert math.hypot(seen.u - u, seen.v - v) < 2.0


def test_no_robot_is_none() -> None:
    assert find_robot(_image(FloorScene(polygons=(BOX,), circles=CIRCLES)),
                      CALIB, EXTRINSICS) is None


def _cell_points(grid: FloorGrid, samples: int = 3) -> np.ndarray:
    """Sub-points (mm) of every cell, [row, col, k, 2]."""
    rows, cols = grid.shape
    step = grid.resolution / samples
    offs = (np.arange(samples) + 0.5) * step
    ox, oy = np.meshgrid(offs, offs)
    col_x = grid.origin[0] + np.arange(cols) * grid.resolution
    row_y = grid.origin[1] + np.arange(rows) * grid.resolution
    x = col_x[None, :, None] + ox.ravel()[None, None, :]
    y = row_y[:, None, None] + oy.ravel()[None, None, :]
    x, y = np.broadcast_arrays(x, y)
    return np.asarray(np.stack([x, y], axis=-1) * 1000.0, dtype=np.float64)


def _in_obstacle(p: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """Whether floor points (mm) lie within ``margin`` of an obstacle (inside: margin 0)."""
    x, y = p[..., 0], p[..., 1]
    box = ((x >= BOX[0, 0] - margin) & (x <= BOX[1, 0] + margin)
           & (y >= BOX[0, 1] - margin) & (y <= BOX[2, 1] + margin))
    for c in CIRCLES:
        box |= np.hypot(x - c.x, y - c.y) <= c.radius + margin
    return np.asarray(box, dtype=np.bool_)


def test_occupancy_marks_obstacles_and_the_unseen_but_not_the_robot() -> None:
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    grid = sampler.occupancy(_image(FloorScene(polygons=(BOX,), circles=CIRCLES, robot=ROBOT)))
    assert grid.shape == GRID.shape == (40, 90) and grid.dtype == np.bool_
    pts = _cell_points(GRID)
    inside = _in_obstacle(pts).all(axis=2)
    assert inside.sum() > 100
    assert grid[inside].all()
    # On the floor (0..3 m x 0..2 m, all in view), more than a cell from any obstacle.
    on_floor = ((pts[..., 0] >= 0) & (pts[..., 0] <= 3000)).all(axis=2)
    clear = on_floor & ~_in_obstacle(pts, margin=GRID.resolution * 1000.0).any(axis=2)
    assert clear.sum() > 1000
    assert not grid[clear].any()
    # The robot's disc is not an obstacle.
    robot_cells = (np.hypot(pts[..., 0] - ROBOT.x, pts[..., 1] - ROBOT.y)
                   <= ROBOT.radius).any(axis=2)
    assert robot_cells.sum() >= 4 and not grid[robot_cells].any()
    # Out of view (x < -1.2 m is beyond the image's left edge): occupied, unknown is not free.
    col = int((-1.4 - GRID.origin[0]) / GRID.resolution)
    assert grid[:, col].all()


def test_occupancy_follows_the_frame() -> None:
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    empty = sampler.occupancy(_image(FloorScene()))
    full = sampler.occupancy(_image(FloorScene(polygons=(BOX,))))
    assert not empty[:, 30:90].any()
    assert (full & ~empty).sum() > 100


def test_bad_images_refused_by_name() -> None:
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    good = _image(FloorScene())
    with pytest.raises(ValueError, match=r"^image is 320x240 pixels, .* 640x480$"):
        sampler.occupancy(good[:240, :320])
    with pytest.raises(ValueError, match=r"2-D uint8 .*float64"):
        sampler.occupancy(good.astype(np.float64))
    with pytest.raises(ValueError, match=r"2-D uint8 .*\(480, 640, 3\)"):
        find_robot(np.dstack([good] * 3), CALIB, EXTRINSICS)


@pytest.mark.parametrize("field", ["width", "depth", "resolution"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.nan, math.inf])
def test_grid_refuses_bad_fields_by_name(field: str, value: float) -> None:
    sizes = {"width": 3.0, "depth": 2.0, "resolution": 0.05, field: value}
    with pytest.raises(ValueError, match=rf"^FloorGrid {field} "):
        FloorGrid(sizes["width"], sizes["depth"], sizes["resolution"])


def _aligned_box(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]) * 1000.0


def test_image_noise_20_flips_no_cell_but_a_real_obstacle_marks_its_cells() -> None:
    """Noise 20 (grey levels) darkens single samples at random, on the robot's mid-grey disc
    (120, 2.3 sigma above the threshold 75) most: with the old rule (any dark sample) cells
    flip from frame to frame, with map_server's thresholds on the cell's dark share
    (occupied_thresh 0.65, free_thresh 0.196; map_saver.cpp writes them, image_loader.cpp
    applies them) none does, while every cell of a box still is occupied."""
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    # a box on cell borders (GRID's cells are 5 cm from x = -1.5 m): cells 40..45 x 10..15
    scene = FloorScene(polygons=(_aligned_box(0.5, 0.5, 0.8, 0.8),),
                       robot=RobotMarker(1500.0, 1000.0, 0.4, 180.0))
    frames = [render_floor(CAMERA, RVEC, TVEC, scene, noise_std=20.0,
                           rng=np.random.default_rng(seed)) for seed in range(12)]
    grids = [sampler.occupancy(frame) for frame in frames]
    assert all(np.array_equal(grid, grids[0]) for grid in grids)
    assert grids[0][10:16, 40:46].all()  # the box's 36 cells
    assert grids[0][9:17, 39:47].sum() == 36  # and not the cells round it
    pts = _cell_points(GRID)
    robot = (np.hypot(pts[..., 0] - 1500.0, pts[..., 1] - 1000.0) <= 180.0).any(axis=2)
    assert robot.sum() > 30 and not grids[0][robot].any()
    old = [sampler.dark_fraction(frame) > 0 for frame in frames]
    assert sum(int((grid != old[0]).sum()) for grid in old) > 0, "the old rule flickered"


def test_a_cell_between_the_thresholds_is_unknown_and_keeps_its_previous_state() -> None:
    """A cell a third dark (3 of 9 samples: between free_thresh 0.196 and occupied_thresh
    0.65) is unknown: occupied on its own (unknown is not free), as it was with ``previous``,
    so an edge splitting a cell cannot flicker; clear evidence changes it either way."""
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    cell = (20, 50)  # x 1.0..1.05 m, y 1.0..1.05 m
    full = _image(FloorScene(polygons=(_aligned_box(1.0, 1.0, 1.05, 1.05),)))
    third = _image(FloorScene(polygons=(_aligned_box(1.0, 1.0, 1.0 + 0.05 / 3, 1.05),)))
    empty = _image(FloorScene())
    assert sampler.dark_fraction(third)[cell] == pytest.approx(3 / 9)
    assert sampler.occupancy(full)[cell] and sampler.occupancy(third)[cell]
    free = sampler.occupancy(empty)
    assert not free[cell]
    assert not sampler.occupancy(third, previous=free)[cell]
    assert sampler.occupancy(third, previous=sampler.occupancy(full))[cell]
    assert sampler.occupancy(full, previous=free)[cell]
    assert not sampler.occupancy(empty, previous=sampler.occupancy(full))[cell]
    with pytest.raises(ValueError, match=r"previous occupancy has shape \(2, 2\)"):
        sampler.occupancy(empty, previous=np.zeros((2, 2), bool))


def test_with_its_previous_map_no_obstacle_edge_flickers_at_noise_20() -> None:
    """Round obstacles' edges split cells at every share: chained through ``previous`` (as the
    tracker can pass its last map), twelve frames at noise 20 give one map, where the old
    rule (any dark sample) changed cells between frames."""
    sampler = FloorSampler(CALIB, EXTRINSICS, GRID)
    scene = FloorScene(polygons=(BOX,), circles=CIRCLES, robot=ROBOT)
    previous = None
    changes = old_changes = 0
    old_previous = None
    for seed in range(12):
        frame = render_floor(CAMERA, RVEC, TVEC, scene, noise_std=20.0,
                             rng=np.random.default_rng(100 + seed))
        grid = sampler.occupancy(frame, previous=previous)
        old = sampler.dark_fraction(frame) > 0
        if previous is not None and old_previous is not None:
            changes += int((grid != previous).sum())
            old_changes += int((old != old_previous).sum())
        previous, old_previous = grid, old
    assert changes == 0 and old_changes > 0
