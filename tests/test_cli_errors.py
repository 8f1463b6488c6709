"""``servolab`` tells bugs from bad input: an error raised on purpose (a ServolabError) is one
line on stderr, exit status 2 for bad input and 1 for a failure at run time; anything else
is a bug and keeps its traceback, also when it is a ValueError (numpy's, a shape that does
not fit), which the commands used to print as if the user had typed something wrong."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from servolab.cli import main
from servolab.robots.errors import RobotError, RobotValueError
from tests.clirun import stderr_line


def _raising(error: BaseException) -> Callable[..., None]:
    """A stand-in for a command's run function that raises ``error``."""

    def run(*args: object, **kwargs: object) -> None:
        raise error
    return run


DRIVE = ["drive", "line", "--distance", "0.5", "--no-progress"]


@pytest.mark.parametrize("bug", [IndexError("index 3 is out of bounds for axis 0 with size 3"),
                                 ValueError("operands could not be broadcast together with "
                                            "shapes (3,) (2,)")])
def test_a_bug_in_a_command_keeps_its_traceback(bug: Exception, tmp_path: Path,
                                                monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr("servolab.robots.base.run.run_drive", _raising(bug))
    with pytest.raises(type(bug)) as raised:
        main([*DRIVE, "--out", str(tmp_path / "run")])
    assert raised.value is bug
    assert "servolab drive:" not in capsys.readouterr().err  # not made into a user error


def test_a_numpy_shape_error_is_a_bug_too(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def run_drive(*args: object, **kwargs: object) -> None:
        np.zeros(3) + np.zeros(2)  # a real shape error, from numpy

    monkeypatch.setattr("servolab.robots.base.run.run_drive", run_drive)
    with pytest.raises(ValueError, match="broadcast"):
        main([*DRIVE, "--out", str(tmp_path / "run")])


def test_bad_input_is_one_line_exit_2(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr("servolab.robots.base.run.run_drive",
                        _raising(RobotValueError("distance must be a finite number of metres")))
    assert main([*DRIVE, "--out", str(tmp_path / "run")]) == 2
    assert stderr_line(capsys) == "servolab drive: error: distance must be a finite number of " \
        "metres"


def test_a_failure_at_run_time_is_one_line_exit_1(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr("servolab.robots.base.run.run_drive",
                        _raising(RobotError("the goal was not reached in 10 s")))
    assert main([*DRIVE, "--out", str(tmp_path / "run")]) == 1
    assert stderr_line(capsys) == "servolab drive: RobotError: the goal was not reached in 10 s"


def test_walk_with_no_steps_is_bad_input(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["walk", "--steps", "0", "--out", str(tmp_path / "run")]) == 2
    assert stderr_line(capsys) == "servolab walk: error: --steps 0: must be 1 or more"
    assert not (tmp_path / "run").exists()


# -- the commands that used to print ValueErrors themselves ------------------------------------

def test_gait_out_of_reach_is_bad_input(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["gait", "generate", "--s-step", "150", "--out", str(tmp_path / "g")]) == 2
    line = stderr_line(capsys)
    assert line.startswith("servolab gait generate: error: gait sample ")
    assert "out of reach" in line
    assert not (tmp_path / "g").exists()


def test_a_bug_in_gait_generate_keeps_its_traceback(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("servolab.gait.walking.generate_walk",
                        _raising(ValueError("math domain error")))
    with pytest.raises(ValueError, match="math domain error"):
        main(["gait", "generate", "--out", str(tmp_path / "g")])


def test_calibrate_a_missing_image_is_bad_input(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "nope.png"
    assert main(["calibrate", str(missing), "--board", "10x7", "--square", "25",
                 "--out", str(tmp_path / "c.yaml")]) == 2
    assert stderr_line(capsys) == f"servolab calibrate: error: no image file {str(missing)!r}"
    folder = tmp_path / "folder"
    folder.mkdir()
    assert main(["calibrate", str(missing), "--board", "10x7", "--square", "25",
                 "--out", str(folder)]) == 2
    assert stderr_line(capsys) == (f"servolab calibrate: error: cannot write --out "
                                 f"{str(folder)!r}: it is a folder")


def test_measure_without_a_floor_plane_is_bad_input(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    from servolab.vision import calibration as cal

    path = tmp_path / "camera.yaml"
    k = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    cal.save(cal.CameraCalibration(k, np.zeros(5), (640, 480)), None, path)
    assert main(["measure", "--calib", str(path), "1", "2", "3", "4"]) == 2
    assert stderr_line(capsys) == (f"servolab measure: error: --calib {path} has no floor plane; "
                                 "calibrate with --floor IMAGE")


def test_gait_stopped_while_it_plots_leaves_its_summary(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    """SIGTERM while `servolab gait generate` draws its figures: exit 143, and the run folder
    still gets summary.json saying what ended it (the run folder's own guard)."""
    import json
    import signal

    import servolab.gait.plots as plots
    from servolab.harness import StopSignal

    def stopped(*args: object, **kwargs: object) -> Path:
        raise StopSignal(signal.SIGTERM)

    monkeypatch.setattr(plots, "plot_joint_angles", stopped)
    out = tmp_path / "run"
    assert main(["gait", "generate", "--out", str(out)]) == 143
    assert capsys.readouterr().err == "servolab gait generate: stopped by SIGTERM\n"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["interrupted"] == "SIGTERM"
    assert (out / "gait.csv").exists()  # what was made before the stop is kept
