"""The rig file (servolab's treadmill.yaml, ``--rig``, ``--set``): the shipped one is the
thesis's rig, value for value (seed 002, Listing 1's constants and Listing 3's camera), and a
wrong value is refused in one line naming where it was written, before anything runs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from servolab.kinematics.aot import THESIS_J1M, AotGeometry
from servolab.robots.treadmill.config import SHIPPED_RIG, RigConfig, RigConfigError, load_rig
from servolab.robots.treadmill.control import FlyControllerConfig
from servolab.vision.fly_tracker import FlyTrackerConfig
from tests.clirun import refusal


def test_the_shipped_rig_is_the_thesis_rig() -> None:
    """Listing 1: threshold 50, min area 100, target (320, 188, 0), limit_r 50,
    limit_th 3*3.141592/180, K 100, SF 60, thm 20*3.141592/180, J1M; Listing 3: 640x376 at
    66 frames/s; section 3: the 4-inch ball, 100 mm wheels, 40 deg."""
    rig = load_rig()
    default = RigConfig()  # the file and the code's defaults agree
    assert (rig.camera, rig.lost_fly_share, rig.late_after) == (
        default.camera, default.lost_fly_share, default.late_after)
    assert rig.tracker == FlyTrackerConfig()
    assert rig.geometry == AotGeometry()
    listing = FlyControllerConfig()
    c = rig.controller
    assert c.dead_band_rad == 3 * 3.141592 / 180 == listing.dead_band_rad  # exact, not ~
    assert c.camera_to_motor == 20 * 3.141592 / 180
    assert np.array_equal(c.matrix, np.array(THESIS_J1M))
    assert (c.target, c.dead_band_px, c.gain, c.rotation_scale) == ((320.0, 188.0, 0.0), 50.0,
                                                                     100.0, 60.0)
    assert rig.camera.size == (640, 376) and rig.camera.frame_rate == 66.0
    assert rig.geometry.tilt == pytest.approx(math.radians(40.0))


def test_set_changes_one_value_and_keeps_the_rest() -> None:
    rig = load_rig(overrides=["tracker.polarity=dark", "tracker.threshold=200",
                              "tracker.roi=[10, 20, 300, 200]", "ball.radius=0.06",
                              "controller.matrix=[[1, 0, 0], [0, 2, 0], [0, 0, 3]]"])
    assert rig.tracker.polarity == "dark" and rig.tracker.threshold == 200.0
    assert rig.tracker.roi == (10, 20, 300, 200)
    assert rig.geometry.ball_radius == 0.06 and rig.geometry.wheel_radius == 0.05
    assert np.array_equal(rig.controller.matrix, np.diag([1.0, 2.0, 3.0]))
    assert rig.source.endswith("--set controller.matrix=[[1, 0, 0], [0, 2, 0], [0, 0, 3]]")


def test_another_ball_gets_its_own_matrix_made_as_listing_1s_was() -> None:
    """``matrix: geometry`` is J1M made for the ball section's rig (kinematics.aot.
    listing_matrix): for the thesis's ball, Listing 1's own numbers (six printed digits);
    for a 6-inch ball, other ones."""
    thesis = load_rig(overrides=["controller.matrix=geometry"])
    np.testing.assert_allclose(thesis.controller.matrix, THESIS_J1M, rtol=2e-6, atol=1e-12)
    bigger = load_rig(overrides=["ball.radius=0.0762", "controller.matrix=geometry"])
    assert not np.allclose(bigger.controller.matrix, THESIS_J1M, rtol=1e-3)
    assert load_rig(overrides=["fictrac.cam_to_lab=[0, 0, 3.14]"]).cam_to_lab == (0, 0, 3.14)


def test_a_copied_rig_file_is_read(tmp_path: Path) -> None:
    mine = tmp_path / "my_rig.yaml"
    mine.write_text(SHIPPED_RIG.read_text().replace("frame_rate: 66.0", "frame_rate: 120.0"))
    rig = load_rig(mine)
    assert rig.camera.frame_rate == 120.0 and rig.late_after_s == pytest.approx(1 / 120)


@pytest.mark.parametrize(("overrides", "where", "says"), [
    (["tracker.thresold=60"], "--set tracker.thresold=60:1: ", "did you mean 'threshold'"),
    (["tracker.polarity=grey"], "--set tracker.polarity=grey:1: ", "bright, dark"),
    (["tracker.threshold=255"], "--set tracker.threshold=255:1: ", "grey level"),
    (["tracker.max_area=50"], "--set tracker.max_area=50:1: ", "above min_area 100"),
    (["tracker.roi=[600, 0, 100, 10]"], "--set tracker.roi=", "within the 640x376"),
    (["ball.tilt=90"], "--set ball.tilt=90:1: ", "between 0 and 90"),
    (["ball.radius=0"], "--set ball.radius=0:1: ", "must be > 0"),
    (["ball.wheel_angles=[0, 0, 120]"], "--set ball.wheel_angles=", "distinct"),
    (["controller.gain=-1"], "--set controller.gain=-1:1: ", "must be >= 0"),
    (["controller.matrix=[[1, 2, 3], [2, 4, 6], [0, 0, 1]]"], "--set controller.matrix=",
     "singular"),
    (["controller.target=[700, 0, 0]"], "--set controller.target=", "outside"),
    (["run.lost_fly_share=2"], "--set run.lost_fly_share=2:1: ", "[0, 1]"),
    (["camera.frame_rate=true"], "--set camera.frame_rate=true:1: ", "finite number"),
    (["threshold"], "--set threshold", "KEY.PATH=VALUE"),
    (["tracker.threshold=60, polarity: dark"], "--set tracker.threshold=60, polarity",
     "must set one value"),
    (["camera.angle_to_motors=720"], "--set camera.angle_to_motors=720:1: ", "-180..180"),
    (["ball.radius=0.0762"], str(SHIPPED_RIG), "listing1 is the thesis rig's J1M"),
    (["fictrac.cam_to_lab=[0, 0]"], "--set fictrac.cam_to_lab=", "must be 3 numbers"),
])
def test_a_wrong_value_names_where_it_was_written(overrides: list[str], where: str,
                                                    says: str) -> None:
    with pytest.raises(RigConfigError) as caught:
        load_rig(overrides=overrides)
    text = str(caught.value)
    assert text.startswith(where) and says in text and "\n" not in text


def test_a_wrong_line_in_a_file_is_named(tmp_path: Path) -> None:
    mine = tmp_path / "rig.yaml"
    lines = SHIPPED_RIG.read_text().splitlines()
    number = next(i for i, line in enumerate(lines, 1) if "min_area" in line)
    lines[number - 1] = "  min_area: lots"
    mine.write_text("\n".join(lines) + "\n")
    with pytest.raises(RigConfigError, match=rf"^{mine}:{number}: key 'tracker.min_area'"):
        load_rig(mine)


def test_the_command_refuses_a_bad_rig_before_a_run_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    status, line = refusal(["flyball", "--set", "tracker.polarity=grey", "--out",
                                  str(out), "--no-progress"], capsys)
    assert status == 2 and "tracker.polarity" in line and "bright, dark" in line
    assert not out.exists()
