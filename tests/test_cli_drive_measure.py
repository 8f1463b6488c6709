"""``servolab drive`` and ``servolab measure`` on the command line, in process (issue 30):
final.m's line by its own options, absurd moves and off-image pixels refused in one line
before anything is made or moved.

Facts: seed 000 A.2 (final.m: "Speed Percentage" 30, ``h=abs(round((5265/575)*d))``, the
SYNC_WRITE of moving speed to motors 1-4 in tx.m); the EX-106+ e-Manual (Moving Speed in wheel
mode, 0.1 % of full output a unit, bit 10 the direction); the issue's "``drive rotate --angle
1e9`` plans 63.8 million seconds" on seed 000's two-wheel robot (Figure A3: r = 5.2 cm,
l = 38 cm; 1e9 degrees x 0.38 / (2 x 0.052 x 1 rad/s))."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from servolab.apps.drive import counts_per_mm
from servolab.cli import main
from tests.clirun import stderr_line


@pytest.mark.parametrize(("args", "value"), [
    (["rotate", "--angle", "1e9"], "drive rotate --angle 1e+09 (degrees; the wheels at 1 "
                                   "rad/s) would take 6.38e+07 s"),
    (["line", "--distance", "1e6"], "drive line --distance 1e+06 --speed 0.1 would take 1e+07 s"),
    (["circle", "--radius", "0.5", "--turns", "1e4"], "--turns 10000 --speed 0.1 would take"),
    (["eight", "--radius", "100"], "drive eight --radius 100 --speed 0.1 would take"),
    (["line", "--distance", "1e4", "--percent", "30", "--counts-per-mm", "5265/575"],
     "--percent 30 (0.149 m/s) --counts-per-mm 9.15652 would take"),
])
def test_an_absurd_move_is_one_line_and_no_run_folder(
        args: list[str], value: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["drive", *args, "--out", str(out), "--no-progress"]) == 2
    line = stderr_line(capsys)
    assert value in line and "over the 600 s (10 min) a move may take" in line
    assert not out.exists()


@pytest.mark.parametrize(("args", "says"), [
    (["--as-printed"], "--as-printed counts as final.m does: give its --counts-per-mm"),
    (["--percent", "30", "--base", "turtlebot3_waffle"], "the XM430-W210 is given a velocity"),
    (["--percent", "101"], "a speed percentage must be in (0, 100], not 101"),
])
def test_final_m_options_refused_in_one_line(args: list[str], says: str, tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    assert main(["drive", "line", "--distance", "1", *args, "--out", str(out)]) == 2
    assert says in stderr_line(capsys)
    assert not out.exists()


def test_counts_per_mm_is_written_as_final_m_writes_it() -> None:
    assert counts_per_mm("5265/575") == 5265 / 575
    assert counts_per_mm("9.5") == 9.5
    for bad in ("5265/0", "a/b", "-3", "inf"):
        with pytest.raises(argparse.ArgumentTypeError):
            counts_per_mm(bad)


def test_final_m_s_line_from_the_command_line(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """final.m at 30 %, 50 mm (h = round(9.1565 x 50) = 458 counts) on the 4-motor base:
    motors 3-4 get s = 307, 1-2 the direction bit with it (1331), and the truth is 50 mm."""
    out = tmp_path / "run"
    assert main(["drive", "line", "--distance", "0.05", "--percent", "30", "--counts-per-mm",
                 "5265/575", "--base", "seed000_4motor", "--out", str(out),
                 "--no-progress"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["wheel_commands"][0]["raw"] == {"1": 1331, "2": 1331, "3": 307, "4": 307}
    assert summary["counted"]["target"] == 458 and summary["counted"]["motor"] == 4
    # within a millimetre: the loop stops a few counts past h (a read, the stop's SYNC_WRITE)
    assert summary["measured"]["truth_length_m"] == pytest.approx(0.05, abs=0.001)
    assert "final.m's count on motor 4: i = " in capsys.readouterr().out


def test_measure_refuses_a_pixel_off_the_calibrated_image(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Issue 30: measure took pixels far outside the image; the lens model was never fitted
    there. 5000 on a 640-wide image is refused in one line naming the pixel and the size."""
    from servolab.vision import calibration as cal

    path = tmp_path / "camera.yaml"
    k = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    cal.save(cal.CameraCalibration(k, np.zeros(5), (640, 480)),
             cal.FloorExtrinsics(np.eye(3), np.array([0.0, 0.0, 1000.0])), path)
    assert main(["measure", "--calib", str(path), "100", "100", "200", "100"]) == 0
    assert capsys.readouterr().out == "125.00 mm\n"  # 100 px at f = 800 px, 1000 mm away
    assert main(["measure", "--calib", str(path), "5000", "340", "100", "100"]) == 2
    assert stderr_line(capsys) == ("servolab measure: error: image point (5000, 340) is outside "
                                 "the calibrated 640x480 image (u -0.5..639.5, v -0.5..479.5 "
                                 "px)")
