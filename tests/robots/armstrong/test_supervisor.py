"""The biped's safety supervisor on the emulated Armstrong, in virtual time: missing motors,
transient errors, a motor falling silent, overload and overheating mid-walk.

Facts checked, and where they come from:
- dynamixel_serial_proxy.py (arebgun/dynamixel_motor): each ID pinged up to 5 times
  (num_ping_retries); dropped and checksum errors counted and survived; /diagnostics with a
  status per motor, ERROR "OVERHEATING" from error_level_temp (default 75), WARN "VERY HOT"
  from warn_level_temp (70);
- RX-28 e-Manual (Alarm Shutdown, default 0x24: overload and overheating switch the torque
  off; Temperature Limit 80 deg C);
- seed 001 Table 4.2: the stand pose, both feet down (double support);
- issue 27: with the left leg missing (min_motor_id 20) the walk used to stand and play every
  row, exit 0.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.dynamixel.emulator import Emulator, Faults
from servolab.robots.armstrong.control_node import Armstrong
from servolab.robots.armstrong.hardware import CONFIG
from servolab.robots.armstrong.motions import load_motion
from servolab.robots.armstrong.poses import STAND_POSE
from servolab.robots.armstrong.run import run_walk
from servolab.runs import RunFolder
from tests.clirun import servolab

ERROR = 2  # diagnostic_msgs/DiagnosticStatus.ERROR


def _emulator(robot: Armstrong) -> Emulator:
    emulator = robot.bus.port.emulator  # type: ignore[attr-defined]
    assert isinstance(emulator, Emulator)
    return emulator


def _walk(tmp_path: Path, *, faults: Faults | None = None,
          on_row: Callable[[Armstrong, int], None] | None = None,
          finals: dict[str, Any] | None = None) -> dict[str, Any]:
    def remember(robot: Armstrong, row: int) -> None:
        if on_row is not None:
            on_row(robot, row)
        if finals is not None:
            finals["robot"] = robot

    with RunFolder.create("walk", tmp_path / "run") as run:
        summary = run_walk(run, load_motion(None), steps=1, say=lambda _: None,
                           show_progress=False, faults=faults, on_row=remember)
    return summary


def _diagnostics(bag: str, motor: int) -> list[tuple[int, str]]:
    (file,) = Path(bag).glob("*.mcap")
    name = f"Robotis Dynamixel Motor {motor} on port pan_tilt_port"
    return [(s.level, s.message) for m in read_ros2_messages(str(file))
            if m.channel.topic == "/diagnostics" for s in m.ros_msg.status if s.name == name]


def _in_double_support(finals: dict[str, Any]) -> None:
    robot: Armstrong = finals["robot"]
    assert robot.ending == "stand"
    assert robot.node.commanded == pytest.approx(STAND_POSE)


@pytest.mark.slow
def test_a_missing_leg_motor_is_refused_before_anything_moves(tmp_path: Path) -> None:
    """The left leg (motors 11..16) outside the pinged range, as min_motor_id 20 leaves it:
    ``walk`` names the missing motors and exits 2; no bag, nothing sent."""
    config = tmp_path / "armstrong.yaml"
    config.write_text(Path(CONFIG).read_text().replace("min_motor_id: 1", "min_motor_id: 20"))
    out = tmp_path / "run"
    result = servolab("walk", "--config", str(config), "--no-progress", "--out", str(out),
                      timeout=120)
    assert result.returncode == 2, result.stderr
    last = result.stderr.strip().splitlines()[-1]
    assert "m11, m12, m13, m14, m15, m16 did not answer" in last
    assert "nothing was moved" in last
    assert not (out / "walk_bag").exists()


def test_transient_errors_are_counted_and_survived(tmp_path: Path) -> None:
    """drop_rate 0.01 per byte: about one READ in five loses a byte of its 23-byte status and
    is sent again; the few that fail three times are counted against their motor and
    skipped for that sweep. The walk plays every row and no alarm is raised."""
    summary = _walk(tmp_path, faults=Faults(drop_rate=0.01, seed=7))
    assert summary["rows_played"] == summary["rows_asked"] == 17
    assert summary["alarms"] == [] and summary["ending"] == "walked"
    assert summary["bus"]["retries"] > 0.1 * summary["bus"]["transactions"]
    errors = summary["motor_errors"]
    assert len(errors) >= 15, errors  # nearly every motor's reads were sent again
    assert sum(e["retried"] for e in errors.values()) <= summary["bus"]["retries"]
    failed = {m: e for m, e in errors.items() if e["errors"]}
    assert failed, "no read failed three times: drop_rate did not reach the bus?"
    assert all(e["skipped"] == sum(e["errors"].values()) for e in failed.values())


@pytest.mark.slow
def test_a_motor_silent_at_row_5_ends_the_walk_in_double_support(tmp_path: Path) -> None:
    finals: dict[str, Any] = {}

    def unplug(robot: Armstrong, row: int) -> None:
        if row == 5:
            _emulator(robot).unplug(14)

    summary = _walk(tmp_path, on_row=unplug, finals=finals)
    assert 5 <= summary["rows_played"] < 17 and summary["stopped"]
    (alarm,) = summary["alarms"]
    assert (alarm["motor"], alarm["cause"]) == (14, "silent")
    assert summary["motor_errors"]["14"]["errors"]["dropped"] >= 1
    _in_double_support(finals)
    assert any(level == ERROR and message.startswith("NOT RESPONDING")
               for level, message in _diagnostics(summary["bag"], 14))


@pytest.mark.slow
def test_an_overload_at_row_5_ends_the_walk_in_double_support(tmp_path: Path) -> None:
    """A load on the knee beyond its torque limit: the RX-28 reports overload and its
    alarm_shutdown (0x24) switches the torque off."""
    finals: dict[str, Any] = {}

    def load(robot: Armstrong, row: int) -> None:
        if row == 5:
            robot.bus.write(14, "torque_limit", 0.5)
            _emulator(robot).motor(14).external_load = 0.8

    summary = _walk(tmp_path, on_row=load, finals=finals)
    assert 5 <= summary["rows_played"] < 17
    assert [(a["motor"], a["cause"]) for a in summary["alarms"]] == [(14, "overload")]
    _in_double_support(finals)
    assert (ERROR, "OVERLOAD") in _diagnostics(summary["bag"], 14)


@pytest.mark.slow
def test_an_overheat_ends_the_walk_in_double_support(tmp_path: Path) -> None:
    """The knee, warm already (70 deg C) and quick to heat (time constant 2 s), made to hold
    95 % of its torque from row 5: the emulator's thermal model takes it past
    error_level_temp 75 and the supervisor ends the walk."""
    finals: dict[str, Any] = {}

    def heat(robot: Armstrong, row: int) -> None:
        if row == 5:
            motor = _emulator(robot).motor(14)
            motor.temperature = 70.0
            motor.thermal_time_constant = 2.0
            motor.external_load = 0.95

    summary = _walk(tmp_path, on_row=heat, finals=finals)
    assert summary["rows_played"] < 17
    (alarm,) = summary["alarms"]
    assert (alarm["motor"], alarm["cause"]) == (14, "overheating")
    assert "error_level_temp 75" in alarm["detail"]
    _in_double_support(finals)
    assert (ERROR, "OVERHEATING") in _diagnostics(summary["bag"], 14)
    written = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert written["alarms"] == summary["alarms"]
    assert Path(written["alarm_plot"]).stat().st_size > 10_000  # saved beside the bag


@pytest.mark.slow
def test_a_leg_controller_stopped_mid_walk_ends_it_in_double_support(tmp_path: Path) -> None:
    """stop_controller (a service call away, as in ROS) on the knee at row 5: its joint would
    take no more commands, so the supervisor ends the walk."""
    finals: dict[str, Any] = {}

    def stop(robot: Armstrong, row: int) -> None:
        if row == 5:
            robot.manager.stop_controller("controller_m14")

    summary = _walk(tmp_path, on_row=stop, finals=finals)
    assert 5 <= summary["rows_played"] < 17
    assert [(a["motor"], a["cause"]) for a in summary["alarms"]] == [
        (14, "controller stopped")]
    _in_double_support(finals)


FIGURE_3_1 = ("pan_tilt_port: Found 20 motors - 20 RX-28 [11, 12, 13, 14, 15, 16, 21, 22, "
              "23, 24, 25, 26, 31, 32, 33, 41, 42, 43, 51, 61], initialization complete.")


@pytest.mark.parametrize("level", ["info", "warn"])
@pytest.mark.slow
def test_walk_reports_what_it_found_as_figure_3_1(tmp_path: Path, level: str) -> None:
    """Seed 001 Figure 3.1, as rospy prints it ("[INFO] [WallTime: ...] pan_tilt_port: Found
    20 motors - ..."): shown at the default --log-level, not at warn, where the controller
    that could not start (m62) still is."""
    result = servolab("walk", "--steps", "1", "--no-progress", "--log-level", level, "--out",
                      str(tmp_path / "run"), timeout=120)
    assert result.returncode == 0, result.stderr
    lines = result.stderr.splitlines()
    found = [line for line in lines if line.endswith(FIGURE_3_1)]
    assert bool(found) == (level == "info"), lines[:5]
    if found:
        assert found[0].startswith("[INFO] [WallTime: ")
    assert any(line.startswith("[ERROR] ") and "controller_m62" in line for line in lines)
