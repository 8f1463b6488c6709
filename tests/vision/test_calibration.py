"""Calibration against a synthetic camera whose truth is known (issue 18, "What must be shown"):
intrinsics within 1 %, a 100 mm floor distance within 1 mm, and bad input refused by name."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from servolab.errors import ConfigFileError
from servolab.vision.calibration import (
    SPOIL_FLOOR_PX,
    SYMMETRIC_BOARD_REASON,
    CalibrationError,
    CameraCalibration,
    FloorExtrinsics,
    calibrate,
    check_board,
    check_in_image,
    find_board,
    floor_extrinsics,
    floor_to_image,
    image_to_floor,
    in_map,
    load,
    measure,
    save,
    spoiling_views,
)
from servolab.vision.errors import VisionValueError
from servolab.vision.synthetic import (
    Circle,
    FloorScene,
    PinholeCamera,
    RobotMarker,
    board_corners,
    pose_from,
    random_board_poses,
    render_checkerboard,
    render_floor,
)

BOARD = (10, 7)
SQUARE = 25.0
TRUTH = PinholeCamera(fx=820.0, fy=805.0, cx=326.0, cy=236.0, width=640, height=480,
                      distortion=(-0.28, 0.11, 0.0012, -0.0008, -0.02))


def _views(count: int, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    poses = random_board_poses(TRUTH, BOARD, SQUARE, count, rng)
    return [render_checkerboard(TRUTH, BOARD, SQUARE, r, t, noise_std=2.0, rng=rng)
            for r, t in poses]


@pytest.fixture(scope="module")
def calibration() -> CameraCalibration:
    return calibrate(_views(16, seed=7), BOARD, SQUARE)


def _floor_pose() -> tuple[np.ndarray, np.ndarray]:
    """The overhead camera about 1 m above the floor, looking down at a slight slant; the
    floor frame is the board's (z into the floor, away from the camera)."""
    return pose_from((12.0, -8.0, 25.0), (30.0, -20.0, 1000.0), (12, 9), 40.0)


def _rotation(rvec: np.ndarray) -> np.ndarray:
    return np.asarray(cv2.Rodrigues(rvec)[0], dtype=np.float64)


def _truth_calib() -> CameraCalibration:
    return CameraCalibration(TRUTH.camera_matrix, TRUTH.distortion_coefficients,
                             TRUTH.image_size)


@pytest.mark.slow
def test_intrinsics_within_one_percent(calibration: CameraCalibration) -> None:
    for got, want in ((calibration.fx, TRUTH.fx), (calibration.fy, TRUTH.fy),
                      (calibration.cx, TRUTH.cx), (calibration.cy, TRUTH.cy)):
        assert abs(got - want) / want < 0.01, (got, want)
    assert calibration.rms < 0.5
    assert len(calibration.per_image_errors) == 16
    assert calibration.image_size == (640, 480)
    # k2 and k3 trade off against each other; what must match is the lens's effect, the
    # distortion of rays across the image.
    rays = np.stack(np.meshgrid(np.linspace(-0.35, 0.35, 9), np.linspace(-0.27, 0.27, 7)),
                    axis=-1).reshape(-1, 2)
    points = np.column_stack([rays, np.ones(len(rays))])
    zero = np.zeros(3)
    estimated = cv2.projectPoints(points, zero, zero, calibration.camera_matrix,
                                  calibration.distortion_coefficients)[0].reshape(-1, 2)
    true = TRUTH.project(points, zero, zero)
    assert np.max(np.linalg.norm(estimated - true, axis=1)) < 1.0


def test_hundred_mm_on_the_floor_within_one_mm(calibration: CameraCalibration) -> None:
    rvec, tvec = _floor_pose()
    floor_board, floor_square = (12, 9), 40.0
    image = render_checkerboard(TRUTH, floor_board, floor_square, rvec, tvec, noise_std=2.0,
                                rng=np.random.default_rng(3))
    ext = floor_extrinsics(calibration, image, floor_board, floor_square)
    truth = _truth_calib()
    rotation = _rotation(rvec)
    true_ext = FloorExtrinsics(rotation, tvec)
    rng = np.random.default_rng(11)
    worst = 0.0
    seen = 0
    width, height = TRUTH.image_size
    while seen < 10:
        a = rng.uniform((-100.0, -100.0), (500.0, 350.0))
        angle = rng.uniform(0.0, 2 * np.pi)
        b = a + 100.0 * np.array([np.cos(angle), np.sin(angle)])
        uv = floor_to_image(truth, true_ext, np.stack([a, b]))  # what the camera sees
        if np.any(uv < -0.5) or np.any(uv > (width - 0.5, height - 0.5)):
            continue  # off the image: the camera does not see it (measure refuses it)
        seen += 1
        worst = max(worst, abs(measure(calibration, ext, uv[0], uv[1]) - 100.0))
    assert worst < 1.0, worst


def test_image_to_floor_inverts_floor_to_image() -> None:
    rvec, tvec = _floor_pose()
    calib = _truth_calib()
    ext = FloorExtrinsics(_rotation(rvec), tvec)
    xy = np.random.default_rng(2).uniform((-200.0, -200.0), (600.0, 500.0), (200, 2))
    back = image_to_floor(calib, ext, floor_to_image(calib, ext, xy))
    assert back.shape == (200, 2)
    assert np.max(np.abs(back - xy)) < 1e-6
    one = image_to_floor(calib, ext, floor_to_image(calib, ext, xy[0]))
    assert one.shape == (2,) and np.allclose(one, xy[0], atol=1e-6)


@pytest.mark.parametrize("board", [(10, 8), (9, 7)])
def test_symmetric_board_refused_with_the_seeds_reason(board: tuple[int, int]) -> None:
    with pytest.raises(CalibrationError) as info:
        check_board(board, SQUARE)
    assert SYMMETRIC_BOARD_REASON in str(info.value)
    assert "one side should be even, and the other should be odd" in str(info.value)
    with pytest.raises(CalibrationError, match="asymmetric"):
        calibrate([], board, SQUARE)


def test_blank_image_named_as_not_found() -> None:
    views = _views(4, seed=5)
    blank = np.full((480, 640), 200, dtype=np.uint8)
    names = ["a.png", "b.png", "blank.png", "c.png", "d.png"]
    calib = calibrate([*views[:2], blank, *views[2:]], BOARD, SQUARE, names=names)
    assert calib.image_names == ("a.png", "b.png", "c.png", "d.png")
    not_found = [w for w in calib.warnings if "not found" in w]
    assert len(not_found) == 1 and not_found[0].startswith("blank.png:")
    assert "10x7 squares (9x6 inner corners)" in not_found[0]
    with pytest.raises(CalibrationError, match=r"^floor: checkerboard .* not found$"):
        floor_extrinsics(calib, blank, BOARD, SQUARE, name="floor")


def test_too_few_usable_images_refused() -> None:
    views = _views(2, seed=9)
    blank = np.zeros((480, 640), dtype=np.uint8)
    with pytest.raises(CalibrationError) as info:
        calibrate([views[0], blank, views[1]], BOARD, SQUARE)
    message = str(info.value)
    assert "only 2 usable image(s) of 3" in message
    assert "image 1" in message and "at least 3" in message
    assert "\n" not in message


def test_image_that_spoils_the_fit_is_warned_about() -> None:
    views = _views(10, seed=21)
    # A view drawn by a different lens: its corners cannot fit the others' intrinsics.
    other = PinholeCamera(600.0, 600.0, 300.0, 250.0, 640, 480, (0.3, 0.0, 0.0, 0.0, 0.0))
    rng = np.random.default_rng(4)
    (r, t), = random_board_poses(other, BOARD, SQUARE, 1, rng)
    views.append(render_checkerboard(other, BOARD, SQUARE, r, t))
    calib = calibrate(views, BOARD, SQUARE)
    spoiled = [w for w in calib.warnings if "spoils the fit" in w]
    assert any(w.startswith("image 10:") for w in spoiled), calib.warnings
    # still flagged with the absolute floor: the other lens misses by pixels, not tenths
    assert calib.per_image_errors[10] > 2 * SPOIL_FLOOR_PX


def test_a_view_well_under_a_pixel_is_never_an_outlier() -> None:
    """Issue 30: 0.123 px against a median of 0.054 px is "twice the median" but fits to an
    eighth of a pixel: not flagged. A view at 1.5 px among 0.05 px ones still is, and so is
    0.6 px: over both the ratio and the SPOIL_FLOOR_PX (0.5 px) floor."""
    good = [0.054, 0.050, 0.061, 0.047, 0.058, 0.123]
    assert spoiling_views(good) == []
    assert spoiling_views([0.05, 0.06, 0.05, 1.5, 0.04]) == [3]
    assert spoiling_views([0.05, 0.06, 0.05, 0.6, 0.04]) == [3]
    assert spoiling_views([1.0, 1.1, 0.9, 1.05, 1.6]) == []   # under 2x the median of 1.05
    assert spoiling_views([]) == []


def test_measure_refuses_a_pixel_off_the_calibrated_image() -> None:
    """Issue 30: the lens model is fitted only on the image; 640x480 covers -0.5..639.5 and
    -0.5..479.5 (pixel centres at whole numbers, OpenCV)."""
    calib = _truth_calib()
    r, t = _floor_pose()
    ext = FloorExtrinsics(_rotation(r), t)
    assert measure(calib, ext, (-0.5, -0.5), (639.5, 479.5)) > 0
    for bad in ((5000.0, 340.0), (100.0, -0.6), (639.6, 10.0), (10.0, 480.0)):
        with pytest.raises(VisionValueError, match=rf"^image point \({bad[0]:g}, {bad[1]:g}\) "
                           r"is outside the calibrated 640x480 image"):
            measure(calib, ext, (100.0, 100.0), bad)
    with pytest.raises(VisionValueError, match="640x480"):
        check_in_image(calib, [[10.0, 10.0], [700.0, 10.0]])


def test_save_load_round_trip(tmp_path: Path) -> None:
    rvec, tvec = _floor_pose()
    calib = CameraCalibration(TRUTH.camera_matrix, TRUTH.distortion_coefficients,
                              TRUTH.image_size, camera_name="overhead")
    ext = FloorExtrinsics(_rotation(rvec), tvec)
    path = tmp_path / "camera.yaml"
    save(calib, ext, path)
    text = path.read_text()
    for key in ("image_width: 640", "camera_matrix:", "distortion_model: plumb_bob",
                "rectification_matrix:", "projection_matrix:", "floor_extrinsics:"):
        assert key in text
    back, back_ext = load(path)
    assert back_ext is not None
    assert np.array_equal(back.camera_matrix, calib.camera_matrix)
    assert np.array_equal(back.distortion_coefficients, calib.distortion_coefficients)
    assert back.image_size == (640, 480) and back.camera_name == "overhead"
    assert np.array_equal(back_ext.rotation, ext.rotation)
    assert np.array_equal(back_ext.translation, ext.translation)
    save(calib, None, path)
    assert load(path)[1] is None


def test_load_names_the_bad_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    calib = _truth_calib()
    save(calib, None, path)
    text = path.read_text().replace("image_height: 480", "image_height: tall")
    path.write_text(text)
    line = 1 + text.splitlines().index("image_height: tall")
    with pytest.raises(ConfigFileError, match=rf"bad.yaml:{line}: key 'image_height'"):
        load(path)


def test_floor_scene_renders_obstacles_dark() -> None:
    rvec, tvec = _floor_pose()
    calib, ext = _truth_calib(), FloorExtrinsics(
        _rotation(rvec), tvec)
    scene = FloorScene(polygons=(np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 80.0],
                                           [0.0, 80.0]]),),
                       circles=(Circle(300.0, 200.0, 40.0),),
                       robot=RobotMarker(150.0, 300.0, 0.5, 60.0))
    image = render_floor(TRUTH, rvec, tvec, scene)
    assert image.shape == (480, 640)

    def grey(x: float, y: float) -> int:
        u, v = np.round(floor_to_image(calib, ext, (x, y))).astype(int)
        return int(image[v, u])

    assert grey(50.0, 40.0) < 60 and grey(300.0, 200.0) < 60
    assert grey(200.0, 100.0) > 180
    assert 80 < grey(150.0 - 40.0, 300.0) < 160


def _turned_pose(z_deg: float, board: tuple[int, int], square: float,
                 distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The board facing the camera with a slight tilt, turned ``z_deg`` about the optical axis."""
    tilt = _rotation(np.deg2rad([10.0, -6.0, 0.0]))
    turn = _rotation(np.array([0.0, 0.0, np.deg2rad(z_deg)]))
    rvec = np.asarray(cv2.Rodrigues(tilt @ turn)[0], dtype=np.float64).ravel()
    return pose_from(np.rad2deg(rvec), (10.0, -5.0, distance), board, square)


@pytest.mark.parametrize("z_deg", [0.0, 90.0, 170.0, 180.0, 270.0])
def test_find_board_keeps_the_boards_own_origin_when_turned(z_deg: float) -> None:
    rvec, tvec = _turned_pose(z_deg, BOARD, SQUARE, 700.0)
    image = render_checkerboard(TRUTH, BOARD, SQUARE, rvec, tvec, noise_std=2.0,
                                rng=np.random.default_rng(int(z_deg)))
    truth = TRUTH.project(board_corners(BOARD, SQUARE), rvec, tvec)
    got = find_board(image, BOARD)
    assert got.shape == truth.shape
    assert np.max(np.linalg.norm(got - truth, axis=1)) < 0.5


def test_find_board_corrects_a_detector_that_reads_the_board_upside_down(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # OpenCV 5.0 happens to return the corners of these boards in order; the orientation must
    # come from the image, not from the detector's habits.
    rvec, tvec = _turned_pose(180.0, BOARD, SQUARE, 700.0)
    image = render_checkerboard(TRUTH, BOARD, SQUARE, rvec, tvec, noise_std=2.0,
                                rng=np.random.default_rng(1))
    truth = TRUTH.project(board_corners(BOARD, SQUARE), rvec, tvec)
    detect = cv2.findChessboardCorners

    def upside_down(gray: np.ndarray, pattern: tuple[int, int], corners: None,
                    flags: int) -> tuple[bool, np.ndarray]:
        found, got = detect(gray, pattern, corners, flags)
        return found, np.asarray(got)[::-1].copy()

    monkeypatch.setattr(cv2, "findChessboardCorners", upside_down)
    got = find_board(image, BOARD)
    assert np.max(np.linalg.norm(got - truth, axis=1)) < 0.5


@pytest.mark.parametrize("z_deg", [0.0, 180.0])
def test_floor_extrinsics_of_a_board_turned_round_keep_its_frame(z_deg: float) -> None:
    floor_board, floor_square = (12, 9), 40.0
    rvec, tvec = _turned_pose(z_deg, floor_board, floor_square, 1000.0)
    image = render_checkerboard(TRUTH, floor_board, floor_square, rvec, tvec, noise_std=2.0,
                                rng=np.random.default_rng(5))
    calib = _truth_calib()
    ext = floor_extrinsics(calib, image, floor_board, floor_square)
    true_ext = FloorExtrinsics(_rotation(rvec), tvec)
    xy = np.array([[0.0, 0.0], [400.0, 0.0], [0.0, 280.0], [-100.0, 350.0], [250.0, 120.0]])
    seen = floor_to_image(calib, true_ext, xy)  # where the camera sees the floor points
    assert np.max(np.linalg.norm(image_to_floor(calib, ext, seen) - xy, axis=1)) < 2.0


@pytest.mark.parametrize("yaw_deg", [0.0, 30.0, -120.0])
def test_in_map_gives_a_z_up_map_frame_where_the_board_lay(yaw_deg: float) -> None:
    """A camera looking straight down on a map frame (z up: its rotation is 180° about x);
    the floor board lies face up with its first inner corner at (250, 150) mm and its first
    row at yaw_deg. in_map of the board's extrinsics is the map's own pose in the camera, so
    map points seen in the image come back as map points, and the camera is above the floor."""
    map_rotation = np.diag([1.0, -1.0, -1.0]) @ _rotation(np.deg2rad([3.0, -2.0, 0.0]))
    map_translation = -map_rotation @ np.array([250.0, 150.0, 1300.0])
    yaw = np.deg2rad(yaw_deg)
    corner = np.array([250.0, 150.0, 0.0])
    # the board's axes in the map: x at yaw, y at yaw - 90° (face up: its z into the floor)
    axes = np.array([[np.cos(yaw), np.sin(yaw), 0.0], [np.sin(yaw), -np.cos(yaw), 0.0],
                     [0.0, 0.0, -1.0]])
    board_rotation = map_rotation @ axes
    board_rvec = cv2.Rodrigues(board_rotation)[0].reshape(3)
    board_tvec = map_rotation @ corner + map_translation
    floor_board, floor_square = (12, 9), 30.0
    image = render_checkerboard(TRUTH, floor_board, floor_square, board_rvec, board_tvec,
                                noise_std=2.0, rng=np.random.default_rng(3))
    calib = _truth_calib()
    board = floor_extrinsics(calib, image, floor_board, floor_square)
    assert board.camera_position[2] < 0  # the board's z points into the floor
    found = in_map(board, (250.0, 150.0, yaw))
    assert found.camera_position == pytest.approx([250.0, 150.0, 1300.0], abs=13.0)  # 1 %
    assert np.allclose(found.rotation, map_rotation, atol=0.01)  # within about 0.6°
    xy = np.array([[0.0, 0.0], [500.0, 100.0], [100.0, 400.0], [350.0, 250.0]])
    seen = floor_to_image(calib, FloorExtrinsics(map_rotation, map_translation), xy)
    assert np.max(np.linalg.norm(image_to_floor(calib, found, seen) - xy, axis=1)) < 2.0


def test_in_map_refuses_a_placement_that_is_not_a_number() -> None:
    ext = FloorExtrinsics(np.eye(3), np.array([0.0, 0.0, 1000.0]))
    with pytest.raises(ValueError, match="board_at must be finite"):
        in_map(ext, (0.0, float("nan"), 0.0))
