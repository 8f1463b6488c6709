"""``servolab walk`` end to end on the emulated Armstrong, checked through the recording with
an independent decoder (``mcap`` + ``mcap-ros2-support``), and the five-line API.

Facts: seed 001 section 4.2.4 (a sequence of 17 rows played N times at 4.5 Hz, 3.78 s a step;
the stand pose of Table 4.2 first); Appendix B (the seed's node turned an unreadable cell into
0 degrees: servolab refuses the file before anything moves)."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.gait.motionfile import MotionFileError, write_motion_file
from servolab.gait.walking import generate_walk
from servolab.robots.armstrong.control_node import MOVE_RATE, Armstrong
from servolab.robots.armstrong.motions import load_motion
from servolab.robots.armstrong.poses import MOTORS, STAND_POSE
from servolab.robots.armstrong.run import run_walk
from servolab.robots.armstrong.supervisor import FINISH_DURATION
from servolab.runs import RunFolder
from tests.clirun import servolab

ROOT = Path(__file__).resolve().parents[3]

LEGS = MOTORS[:12]


@pytest.fixture(scope="module")
def walked(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """One walk of 2 steps on the emulated robot, shared by the tests that read it."""
    run = RunFolder.create("walk", tmp_path_factory.mktemp("walk"))
    return run_walk(run, load_motion(None), steps=2, say=lambda s: None, show_progress=False)


def _messages(bag: Path, topic: str) -> list[tuple[float, object]]:
    (mcap,) = bag.glob("*.mcap")
    return [(m.log_time_ns / 1e9, m.ros_msg) for m in read_ros2_messages(str(mcap),
                                                                          topics=[topic])]


@pytest.mark.slow
def test_the_recording_holds_2_x_17_rows_per_motor_at_4_5_hz(
        walked: dict[str, object]) -> None:
    summary = walked
    assert summary["rows_played"] == summary["rows_asked"] == 34
    bag = Path(str(summary["bag"]))
    motion = generate_walk().motion()
    expected = np.radians(np.vstack([motion.angles, motion.angles]))
    for k, motor in enumerate(MOTORS):
        commands = _messages(bag, f"/controller_{motor}/command")
        played = commands[-34:]  # after the stand's interpolated move
        np.testing.assert_allclose([m.data for _, m in played],  # type: ignore[attr-defined]
                                   expected[:, k], atol=1e-12)
        times = np.array([t for t, _ in played])
        # 4.5 rows a second of the robot's (simulated) time; each stamp is when the recorder
        # took the message, up to one manager update (109 ms at 57142 bps) after it was sent
        assert (times[-1] - times[0]) / 33 == pytest.approx(1 / 4.5, rel=0.02)
        assert np.all(np.diff(times) > 0.1) and np.all(np.diff(times) < 0.35)


def test_the_stand_pose_comes_first_and_is_reached_without_a_jump(
        walked: dict[str, object]) -> None:
    summary = walked
    bag = Path(str(summary["bag"]))
    for motor in LEGS:
        commands = [np.degrees(m.data) for _, m in  # type: ignore[attr-defined]
                    _messages(bag, f"/controller_{motor}/command")][:-34]
        assert commands[-1] == pytest.approx(STAND_POSE[motor], abs=1e-9)
        steps = np.abs(np.diff([0.0, *commands]))
        assert steps.max() <= abs(STAND_POSE[motor]) / 10 + 1e-9  # >= 10 interpolated steps


def test_present_positions_follow_their_goals(walked: dict[str, object]) -> None:
    summary = walked
    bag = Path(str(summary["bag"]))
    for motor in LEGS:
        states = _messages(bag, f"/controller_{motor}/state")
        assert len(states) > 50
        last = states[-1][1]
        # the last row held for 0.5 s: within one RX-28 tick (0.29 degrees) of its goal
        assert abs(last.current_pos - last.goal_pos) < np.radians(0.3)  # type: ignore[attr-defined]
        moved = [s.current_pos for _, s in states]  # type: ignore[attr-defined]
        assert max(moved) - min(moved) > np.radians(5) or motor in ("m11", "m21")
    motor_states = _messages(bag, "/motor_states/pan_tilt_port")
    assert len(motor_states) > 50
    assert len(motor_states[-1][1].motor_states) == 20  # type: ignore[attr-defined]


def test_the_run_folder_has_its_plot_and_summary(
        walked: dict[str, object]) -> None:
    summary = walked
    assert Path(str(summary["plot"])).stat().st_size > 10_000
    assert summary["controllers_failed"] == ["controller_m62"]
    assert not summary["stopped"]


@pytest.mark.parametrize(("cell", "says"), [
    ("abc", "column m14: 'abc' is not a number"),
    ("nan", "column m14: 'nan' is not a"),
    ("200", "column m14: 200 degrees is outside the joint's limits"),
])
@pytest.mark.slow
def test_a_bad_motion_file_is_refused_before_anything_moves(tmp_path: Path, cell: str,
                                                           says: str) -> None:
    path = tmp_path / "walk.csv"
    write_motion_file(path, generate_walk().motion())
    lines = path.read_text().splitlines()
    cells = lines[3].split(",")
    cells[MOTORS.index("m14")] = cell
    lines[3] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MotionFileError, match=re.escape(f"walk.csv:4: {says}")):
        load_motion(path)
    out = tmp_path / "run"
    result = servolab("walk", "--file", str(path), "--out", str(out), "--no-progress", timeout=120)
    assert result.returncode != 0
    assert result.stderr.strip().count("\n") == 0, result.stderr  # one line
    assert "walk.csv:4:" in result.stderr and "m14" in result.stderr
    assert not out.exists()  # nothing ran: no bus opened, no run folder


def test_a_missing_column_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "walk.csv"
    write_motion_file(path, generate_walk().motion())
    lines = [",".join(line.split(",")[:-1]) for line in path.read_text().splitlines()]
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MotionFileError, match=r"walk\.csv:1: column m62: missing"):
        load_motion(path)


def test_five_lines_for_a_student() -> None:
    """The module docstring's example, as written there."""
    with Armstrong() as robot:
        assert robot.stand()
        assert robot.move_joint("left_knee", x=-50)
        assert robot.play(generate_walk().motion(), steps=1) == 17
        assert robot.node.commanded["m14"] == pytest.approx(generate_walk().motors[-1, 3])


@pytest.mark.slow
def test_gait_generate_writes_its_files(tmp_path: Path) -> None:
    out = tmp_path / "gait"
    result = servolab("gait", "generate", "--l-step", "30", "--out", str(out), timeout=120)
    assert result.returncode == 0, result.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["l_step"] == 30.0 and summary["rows"] == 17
    assert load_motion(out / "gait.csv").poses == 17
    assert (out / "feet.png").stat().st_size > 0 and (out / "joint_angles.png").stat().st_size


def test_gait_generate_refuses_an_unreachable_gait(tmp_path: Path) -> None:
    result = servolab("gait", "generate", "--s-step", "150", "--out", str(tmp_path / "g"),
                      timeout=120)
    assert result.returncode != 0
    assert "gait sample" in result.stderr and "out of reach" in result.stderr


@pytest.mark.slow
def test_ctrl_c_stops_at_once_and_keeps_what_was_recorded(tmp_path: Path) -> None:
    """A long walk interrupted with Ctrl-C (SIGINT) while it plays: it stops before the end,
    says so (exit status 130), leaves its summary and a bag an independent reader opens, and
    finishes to double support: the last command sent is the stand pose of Table 4.2
    (servolab.robots.armstrong.supervisor)."""
    import signal

    from tests.processes import started
    from tests.waiting import wait_for_line

    out = tmp_path / "run"
    with started([sys.executable, "-m", "servolab", "walk", "--steps", "1000", "--out",
                  str(out), "--no-progress"], stderr_to_stdout=True) as walk:
        wait_for_line(walk, "step 2 of 1000 played", timeout=60.0)
        walk.send_signal(signal.SIGINT)
        assert walk.wait(60) == 130
    summary = json.loads((out / "summary.json").read_text())
    assert summary["stopped"] and 0 < summary["rows_played"] < summary["rows_asked"]
    assert summary["interrupted"] == "SIGINT"
    commands = _messages(out / "walk_bag", "/controller_m14/command")
    assert commands, "nothing recorded"
    assert summary["ending"] == "stand"
    assert commands[-1][1].data == pytest.approx(  # type: ignore[attr-defined]
        math.radians(STAND_POSE["m14"]), abs=1e-12)
    rows = np.radians(generate_walk().motion().angles[:, MOTORS.index("m14")])
    before = [c.data for _, c in commands[:-int(FINISH_DURATION * MOVE_RATE)]]  # type: ignore[attr-defined]
    assert np.min(np.abs(rows - before[-1])) < 1e-12  # the gait played until the stop


def test_goals_reach_the_bus_in_small_steps_while_standing(
        walked: dict[str, object]) -> None:
    """The stand move is sent as 40 interpolated poses; the goals the motors get (MotorState
    goal, as written) change by a few interpolation steps at most between two updates, not
    in one jump (m14 moves 43 degrees: one step is about 1.1 degrees)."""
    bag = Path(str(walked["bag"]))
    goals = [next(s.goal for s in m.motor_states if s.id == 14)  # type: ignore[attr-defined]
             for _, m in _messages(bag, "/motor_states/pan_tilt_port")]
    stand_end = _messages(bag, "/controller_m14/command")[-35][0]
    times = [t for t, _ in _messages(bag, "/motor_states/pan_tilt_port")]
    steps = [abs(b - a) * 300 / 1023 for (a, b, t) in zip(goals, goals[1:], times[1:],
                                                           strict=False) if t <= stand_end]
    assert steps and max(steps) < 6.0, max(steps)


@pytest.mark.slow
def test_the_same_run_folder_twice_replaces_its_bag(tmp_path: Path) -> None:
    for _ in range(2):
        summary = run_walk(RunFolder.create("walk", tmp_path), load_motion(None), steps=1,
                           say=lambda s: None, show_progress=False)
        assert summary["rows_played"] == 17


def test_a_generated_gait_beyond_the_configured_limits_is_refused(tmp_path: Path) -> None:
    from servolab.robots.armstrong import hardware as armstrong

    path = tmp_path / "narrow.yaml"
    path.write_text(armstrong.CONFIG.read_text().replace(
        "motor: {id: 14, init: 512, min: 0, max: 1023}",
        "motor: {id: 14, init: 512, min: 450, max: 1023}"))  # at most ~18 degrees down
    with pytest.raises(ValueError, match=r"row 0 \(t = 0 ms\) turns m14 \(left knee\) to "
                                         r"-42\.63 degrees, beyond"):
        load_motion(None, path)


@pytest.mark.parametrize("rate", ["inf", "nan", "-1"])
def test_a_rate_that_is_not_a_positive_number_is_refused(tmp_path: Path, rate: str) -> None:
    out = tmp_path / "run"
    result = servolab("walk", f"--rate={rate}", "--out", str(out), timeout=120)
    assert result.returncode != 0
    assert "--rate" in result.stderr and result.stderr.strip().count("\n") == 0
    assert not out.exists()


@pytest.mark.slow
def test_appendix_a_as_printed_walks(tmp_path: Path) -> None:
    """Seed 001 Appendix A as printed (tests/data/armstrong_appendix_a.yaml: controllers only,
    m31..m51 all named pan_joint_33): it loads with a warning per repeated joint name, takes
    the manager's settings of Listing 3.3 from the shipped file (as ROS takes them from
    controller_manager.launch), and walks a step."""
    out = tmp_path / "run"
    result = servolab("walk", "--config",
                      str(ROOT / "tests" / "data" / "armstrong_appendix_a.yaml"), "--no-progress",
                      "--out", str(out), timeout=120)
    assert result.returncode == 0, result.stderr
    warnings = [line for line in result.stderr.splitlines() if line.startswith("[WARNING]")]
    assert sum("share joint name 'pan_joint_33'" in w for w in warnings) == 6
    assert any("no dynamixel_manager in it" in w for w in warnings)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["rows_played"] == summary["rows_asked"] == 17
    assert summary["controllers_failed"] == ["controller_m62"]
