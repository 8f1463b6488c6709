"""``servolab drive``: seed 000's moves end to end on the emulated bases, checked through the
recording with an independent reader (mcap + mcap-ros2-support) and the summary.

Facts: seed 000 Appendix A (Figure A3's circle, Figure A4's eight, A.2's line); the issue's
demands of the summary (raw wheel commands sent, a circle's truth radius, a line's truth
length, odometry's final error) and of bad input (one line, the wheels do not move)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.robots.base.config import SHIPPED_DIR
from servolab.robots.base.run import run_drive
from servolab.runs import RunFolder
from tests.clirun import servolab

CONFIGS = SHIPPED_DIR  # the shipped bases: package data of servolab.robots.base


def _drive(tmp_path: Path, move: str, **kwargs: object) -> dict[str, object]:
    return run_drive(RunFolder.create("drive", tmp_path), move, say=lambda s: None,
                     show_progress=False, **kwargs)  # type: ignore[arg-type]


def test_a_circle_is_recorded_plotted_and_measured(tmp_path: Path) -> None:
    summary = _drive(tmp_path, "circle", radius=0.5, speed=0.2)
    measured = summary["measured"]
    assert measured["truth_radius_m"] == pytest.approx(0.5, rel=0.02)  # type: ignore[index]
    assert measured["odometry_error_m"] < 0.01  # type: ignore[index]
    first = summary["wheel_commands"][0]  # type: ignore[index]
    assert first["register"] == "moving_speed"
    assert set(first["raw"]) == {"0", "1"}
    assert summary["wheel_commands"][-1]["raw"] == {"0": 0, "1": 0}  # type: ignore[index]
    (mcap,) = Path(str(summary["bag"])).glob("*.mcap")
    topics = {m.channel.topic for m in read_ros2_messages(str(mcap))}
    assert topics == {"/odom", "/ground_truth", "/wheel_commands"}
    assert Path(str(summary["plot"])).stat().st_size > 10_000


def test_a_line_measures_its_truth_length(tmp_path: Path) -> None:
    summary = _drive(tmp_path, "line", distance=1.0, speed=0.1,
                     base=CONFIGS / "base_turtlebot3_waffle.yaml")
    assert summary["measured"]["truth_length_m"] == pytest.approx(1.0, rel=0.01)  # type: ignore[index]
    assert summary["wheel_commands"][0]["register"] == "goal_velocity"  # type: ignore[index]


@pytest.mark.slow
def test_the_cli_writes_its_run_folder(tmp_path: Path) -> None:
    out = tmp_path / "eight"
    result = servolab("drive", "eight", "--radius", "0.3", "--out", str(out), "--no-progress",
                      timeout=120)
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["measured"]["closure_m"] < 0.02 * 4 * 0.3
    assert (out / "drive.png").exists() and (out / "drive_bag").is_dir()


@pytest.mark.parametrize(("args", "says"), [
    (["circle", "--radius", "0"], "--radius: 0 must be a number > 0"),
    (["circle", "--radius", "-0.5"], "--radius: -0.5 must be a number > 0"),
    (["line", "--distance", "nan"], "--distance: nan must be a finite number"),
    (["line", "--distance", "1", "--speed", "inf"], "--speed: inf must be a number > 0"),
])
def test_bad_arguments_are_one_line_and_nothing_moves(tmp_path: Path, args: list[str],
                                                      says: str) -> None:
    out = tmp_path / "run"
    result = servolab("drive", *args, "--out", str(out), timeout=120)
    assert result.returncode == 2
    assert says in result.stderr.strip().splitlines()[-1]
    assert not out.exists()


def test_a_base_without_a_wheel_radius_is_refused_before_anything_moves(tmp_path: Path) -> None:
    bad = tmp_path / "base.yaml"
    bad.write_text((CONFIGS / "base_seed000.yaml").read_text().replace(
        "  wheel_radius: 0.052\n", ""))
    out = tmp_path / "run"
    result = servolab("drive", "line", "--distance", "1", "--base", str(bad), "--out", str(out),
                      timeout=120)
    assert result.returncode == 2  # bad input (servolab.harness)
    assert f"{bad}:" in result.stderr and "wheel_radius" in result.stderr
    assert result.stderr.strip().count("\n") == 0
    assert not out.exists()  # refused before a run folder was made


def test_a_speed_over_the_motors_limit_is_refused_in_one_line(tmp_path: Path) -> None:
    """The EX-106+'s no-load 91 rpm on a 5.2 cm wheel is 0.50 m/s: 2 m/s is refused before the
    wheels move."""
    result = servolab("drive", "line", "--distance", "1", "--speed", "2", "--out",
                      str(tmp_path / "run"), timeout=120)
    assert result.returncode != 0
    assert result.stderr.strip().count("\n") == 0, result.stderr
    assert "over the EX-106+'s" in result.stderr and "rad/s" in result.stderr


def test_with_slip_odometry_drifts_from_the_truth_as_much_as_the_slip(tmp_path: Path) -> None:
    """10 % slip on both wheels: odometry believes the circle closed, the truth turned 90 %
    of it, so it ends a chord of 36 degrees from the start: 2 R sin(18 deg)."""
    summary = _drive(tmp_path, "circle", radius=0.5, speed=0.2, slip=0.1)
    chord = 2 * 0.5 * math.sin(math.radians(18))
    measured = summary["measured"]
    assert measured["closure_m"] == pytest.approx(chord, rel=0.02)  # type: ignore[index]
    assert measured["odometry_error_m"] == pytest.approx(chord, rel=0.02)  # type: ignore[index]


def test_slip_out_of_range_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="slip must be a fraction"):
        _drive(tmp_path, "line", slip=1.5)


def test_encoder_noise_shakes_odometry_but_not_the_truth(tmp_path: Path) -> None:
    """Noise on each position read (0.01 rad) leaves the truth's 1 m line as it is; odometry
    differs from it by the noise of its last reads, about a wheel radius times 0.01 rad."""
    summary = _drive(tmp_path, "line", distance=1.0, speed=0.1, encoder_noise=0.01)
    measured = summary["measured"]
    assert measured["truth_length_m"] == pytest.approx(1.0, rel=0.01)  # type: ignore[index]
    assert 0.0 < measured["odometry_error_m"] < 0.01  # type: ignore[index]
