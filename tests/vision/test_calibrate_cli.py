"""``servolab calibrate`` and ``servolab measure`` on synthetic images written to files: the
calibration file is ROS camera_info YAML, a 100 mm distance on the floor is measured within
1 mm (issue 18), and bad input is one line (seed 000 Appendix C: the even/odd board)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from servolab.vision import calibration as cal
from servolab.vision.synthetic import (
    PinholeCamera,
    pose_from,
    random_board_poses,
    render_checkerboard,
)
from tests.clirun import servolab

CAMERA = PinholeCamera(fx=820.0, fy=805.0, cx=326.0, cy=236.0, width=640, height=480,
                       distortion=(-0.28, 0.11, 0.0012, -0.0008, -0.02))


@pytest.fixture(scope="module")
def images(tmp_path_factory: pytest.TempPathFactory) -> tuple[list[str], str, Path]:
    folder = tmp_path_factory.mktemp("boards")
    rng = np.random.default_rng(3)
    paths = []
    for k, (r, t) in enumerate(random_board_poses(CAMERA, (10, 7), 25.0, 14, rng)):
        path = folder / f"board_{k:02d}.png"
        cv2.imwrite(str(path), render_checkerboard(CAMERA, (10, 7), 25.0, r, t, noise_std=1.0,
                                                   rng=rng))
        paths.append(str(path))
    floor_r, floor_t = pose_from((12.0, -8.0, 25.0), (30.0, -20.0, 1000.0), (12, 9), 40.0)
    floor = folder / "floor.png"
    cv2.imwrite(str(floor), render_checkerboard(CAMERA, (12, 9), 40.0, floor_r, floor_t))
    return paths, str(floor), folder


@pytest.mark.slow
def test_calibrate_then_measure_100_mm_on_the_floor(images: tuple[list[str], str, Path],
                                                    tmp_path: Path) -> None:
    paths, floor, _ = images
    out = tmp_path / "camera.yaml"
    result = servolab("calibrate", *paths, "--board", "10x7", "--square", "25", "--floor", floor,
                      "--floor-board", "12x9", "--floor-square", "40", "--out", str(out),
                      timeout=180)
    assert result.returncode == 0, result.stderr
    info = yaml.safe_load(out.read_text())
    assert (info["image_width"], info["image_height"]) == (640, 480)
    assert info["camera_matrix"]["rows"] == 3 and len(info["camera_matrix"]["data"]) == 9
    assert info["distortion_model"] == "plumb_bob"
    assert "floor_extrinsics" in info
    assert info["camera_matrix"]["data"][0] == pytest.approx(CAMERA.fx, rel=0.01)
    # two floor points 100 mm apart, seen through the true camera at the floor's true pose
    _, extrinsics = cal.load(out)
    assert extrinsics is not None
    floor_r, floor_t = pose_from((12.0, -8.0, 25.0), (30.0, -20.0, 1000.0), (12, 9), 40.0)
    truth = cal.FloorExtrinsics(np.asarray(cv2.Rodrigues(floor_r)[0], dtype=np.float64),
                                np.asarray(floor_t, dtype=np.float64).reshape(3))
    true_calib = cal.CameraCalibration(CAMERA.camera_matrix, CAMERA.distortion_coefficients,
                                       CAMERA.image_size)
    uv = cal.floor_to_image(true_calib, truth, np.array([[60.0, 80.0], [160.0, 80.0]]))
    measured = servolab("measure", "--calib", str(out), *(f"{v:.4f}" for v in uv.ravel()),
                        timeout=180)
    assert measured.returncode == 0, measured.stderr
    assert float(measured.stdout.split()[0]) == pytest.approx(100.0, abs=1.0)


@pytest.mark.parametrize(("args", "says"), [
    (["--board", "10x8"], "asymmetric: one side should be even, and the other should be odd"),
    (["--board", "ten"], "not COLSxROWS"),
])
def test_bad_boards_are_one_line(images: tuple[list[str], str, Path], tmp_path: Path,
                                 args: list[str], says: str) -> None:
    paths, _, _ = images
    result = servolab("calibrate", *paths[:3], *args, "--square", "25", "--out",
                      str(tmp_path / "c.yaml"), timeout=180)
    assert result.returncode != 0
    assert says in result.stderr.strip().splitlines()[-1]  # one line (after argparse's usage)


def test_a_missing_image_and_too_few_boards_are_named(images: tuple[list[str], str, Path],
                                                      tmp_path: Path) -> None:
    paths, _, folder = images
    missing = servolab("calibrate", str(folder / "nope.png"), "--board", "10x7", "--square", "25",
                       "--out", str(tmp_path / "c.yaml"), timeout=180)
    assert missing.returncode != 0 and "nope.png" in missing.stderr
    blank = folder / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 128, np.uint8))
    few = servolab("calibrate", paths[0], str(blank), "--board", "10x7", "--square", "25", "--out",
                   str(tmp_path / "c.yaml"), timeout=180)
    assert few.returncode != 0
    assert few.stderr.strip().count("\n") == 0, few.stderr
    assert "blank.png" in few.stderr


def test_measure_needs_a_floor_plane(tmp_path: Path) -> None:
    calib = cal.CameraCalibration(CAMERA.camera_matrix, CAMERA.distortion_coefficients,
                                  CAMERA.image_size)
    path = tmp_path / "camera.yaml"
    cal.save(calib, None, path)
    result = servolab("measure", "--calib", str(path), "1", "2", "3", "4", timeout=180)
    assert result.returncode != 0 and "no floor plane" in result.stderr
