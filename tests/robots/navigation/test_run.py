"""Seed 000's navigation loop end to end on the simulated floor (issue 18): the synthetic
overhead camera, calibrated first, gives the map and the robot's position; D* Lite plans and
repairs; DWA drives the emulated base through /cmd_vel; the robot reaches the goal without
touching an obstacle, also when one appears on its path mid-run. Bad input is refused before
anything moves. The recording is read back with an independent reader (mcap-ros2-support)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap_ros2.reader import read_ros2_messages

from servolab.robots.base.config import SHIPPED_DIR as BASES
from servolab.robots.navigation.params import load_nav_scene
from servolab.robots.navigation.run import (
    BOARD_AT,
    GoalNotReached,
    NavigationError,
    calibrate_synthetic,
    prepare,
    run_navigate,
)
from servolab.runs import RunFolder
from servolab.sim.scene import DEFAULT_SCENE, CircleObstacle
from tests.clirun import refusal

pytestmark = pytest.mark.slow
SCENE = DEFAULT_SCENE
#: beyond the goal tolerances, what the estimate may be off the truth: the tracker's heading
#: (within 3° on these images, tests/vision/test_overhead.py) aligns the odometry, and the
#: position is fused from a camera of ~6 mm per pixel and the encoders
ESTIMATE_XY, ESTIMATE_YAW = 0.03, math.radians(5.0)


@pytest.fixture(scope="module")
def calibration() -> Any:
    """The synthetic session once for the module (each run would repeat it identically)."""
    return calibrate_synthetic(load_nav_scene(SCENE), np.random.default_rng(0))


def _run(tmp: Path, calibration: Any, goal: tuple[float, float], **kwargs: Any
         ) -> dict[str, Any]:
    navigation = dataclasses.replace(prepare(goal, **kwargs), calibration=calibration,
                                     board_at=BOARD_AT)
    return run_navigate(RunFolder.create("navigate", tmp), navigation, say=lambda _: None,
                        show_progress=False)


def _messages(summary: dict[str, Any], topic: str) -> list[Any]:
    (mcap,) = Path(summary["bag"]).glob("*.mcap")
    return [m for m in read_ros2_messages(str(mcap), topics=[topic])]


def _reached(summary: dict[str, Any]) -> None:
    assert summary["status"] == "SUCCEEDED", summary["reason"]
    estimate, truth = summary["final_estimate"], summary["final_truth"]
    gx, gy, gyaw = summary["goal"]
    # the controller stops on its estimate within D.3's tolerances ...
    assert math.hypot(estimate["x"] - gx, estimate["y"] - gy) <= summary["xy_goal_tolerance_m"]
    assert abs(math.remainder(estimate["yaw"] - gyaw, 2 * math.pi)) \
        <= summary["yaw_goal_tolerance_rad"] + 1e-9
    # ... and the estimate is the truth, within what the sensors allow
    assert math.hypot(estimate["x"] - truth["x"], estimate["y"] - truth["y"]) <= ESTIMATE_XY
    assert abs(math.remainder(estimate["yaw"] - truth["yaw"], 2 * math.pi)) <= ESTIMATE_YAW
    assert summary["goal_distance_m"] <= summary["xy_goal_tolerance_m"] + ESTIMATE_XY
    # never touched an obstacle or a wall (truth against the scene's shapes, robot's radius)
    assert summary["min_clearance_m"] > 0.0


@pytest.fixture(scope="module")
def appearing(tmp_path_factory: pytest.TempPathFactory, calibration: Any) -> dict[str, Any]:
    """The shipped scene: an obstacle appears at 6 s on the way to (3.3, 2.3), where the robot
    ends facing -90° (issue 30's second headline goal: without base_local_planner's latched
    final turn it was given up as oscillating at 112°)."""
    return _run(tmp_path_factory.mktemp("nav"), calibration, (3.3, 2.3),
                goal_yaw=-math.pi / 2)


def test_the_robot_reaches_the_goal_around_an_obstacle_that_appears(
        appearing: dict[str, Any]) -> None:
    _reached(appearing)
    world = load_nav_scene(SCENE)
    (late,) = [o for o in world.obstacles if o.appear_at is not None]
    assert isinstance(late, CircleObstacle)
    plans = [(m.log_time_ns * 1e-9, np.array([(p.pose.position.x, p.pose.position.y)
                                              for p in m.ros_msg.poses]))
             for m in _messages(appearing, "/plan")]
    start = appearing["start_time_s"]

    def nearest(plan: np.ndarray) -> float:
        return float(np.min(np.hypot(plan[:, 0] - late.x, plan[:, 1] - late.y))) - late.radius

    # the plan held before the obstacle appeared ran through it: a repair was needed ...
    before = [p for t, p in plans if t - start < late.appear_at]
    assert nearest(before[-1]) < 0.0
    # ... and was made: after it appeared the map changed and the plan went around it
    repairs = appearing["repairs"]
    assert any(r["t"] - start >= late.appear_at and r["cells"] > 0 for r in repairs)
    after = [p for t, p in plans if t - start >= late.appear_at + 0.5]
    assert after and all(nearest(p) > 0.2 for p in after)  # outside the inscribed radius


def test_the_run_is_recorded_and_plotted(appearing: dict[str, Any]) -> None:
    (mcap,) = Path(appearing["bag"]).glob("*.mcap")
    topics = {m.channel.topic for m in read_ros2_messages(str(mcap))}
    assert topics == {"/odom", "/ground_truth", "/cmd_vel", "/tracker/pose", "/fused_pose",
                      "/plan", "/map", "/odometry/filtered", "/tf", "/clock",
                      "/navigate_to_pose/_action/status", "/global_costmap/costmap",
                      "/local_plan", "/path", "/goal_pose"}
    # simulated time, as under Gazebo with use_sim_time: /clock and the stamps agree
    clock = _messages(appearing, "/clock")
    assert clock and all(m.ros_msg.clock.sec < 1000 for m in clock)
    odom = _messages(appearing, "/odom")[-1]
    assert abs(odom.ros_msg.header.stamp.sec + odom.ros_msg.header.stamp.nanosec * 1e-9
               - odom.log_time_ns * 1e-9) < 0.5
    status = _messages(appearing, "/navigate_to_pose/_action/status")[-1].ros_msg
    assert [s.status for s in status.status_list] == [4]  # action_msgs SUCCEEDED
    # the camera's last map, as map_server's map_saver writes it, read back
    from servolab.vision.map_file import load_map

    saved = load_map(appearing["map"])
    assert saved.resolution == pytest.approx(0.05)
    assert saved.origin[:2] == pytest.approx((-0.2, -0.2))
    assert (saved.occupancy == 100).any() and (saved.occupancy == 0).any()
    commands = _messages(appearing, "/cmd_vel")
    assert max(m.ros_msg.linear.x for m in commands) == pytest.approx(0.15)  # D.3's max_vel_x
    assert commands[-1].ros_msg.linear.x == 0.0 and commands[-1].ros_msg.angular.z == 0.0
    grid = _messages(appearing, "/map")[-1].ros_msg
    assert (grid.info.resolution, grid.header.frame_id) == (pytest.approx(0.05), "map")
    assert Path(appearing["plot"]).stat().st_size > 10_000
    # the calibration found the scene's camera (fx 420, cx 321 px) within 1 %
    found = appearing["calibration"]
    assert found["fx"] == pytest.approx(420.0, rel=0.01)
    assert found["cx"] == pytest.approx(321.0, rel=0.01)
    assert appearing["controller_frequency_hz"] == 5.0  # turtlebot's move_base


def test_a_half_turn_at_the_goal(tmp_path: Path, calibration: Any) -> None:
    """Issue 30's first headline goal, (3.0, 0.6, 180°) on the shipped scene: the robot arrives
    facing away from the goal's heading, stops, then turns half a turn on the spot until within
    yaw_goal_tolerance (D.3's 0.3 rad). Without the latch of base_local_planner's
    LatchedStopRotateController (latched_stop_rotate_controller.cpp) every turn at
    min_rot_vel read as "not stopped" and was braked, and the goal was given up at 112°."""
    summary = _run(tmp_path / "run", calibration, (3.0, 0.6), goal_yaw=math.pi)
    _reached(summary)
    assert summary["goal"][2] == pytest.approx(math.pi)
    assert summary["goal_yaw_error_rad"] <= summary["yaw_goal_tolerance_rad"] + ESTIMATE_YAW
    commands = _messages(summary, "/cmd_vel")
    turning = [m.ros_msg for m in commands if m.ros_msg.linear.x == 0.0
               and abs(m.ros_msg.angular.z) >= 0.4 - 1e-9]  # rotateToGoal: >= min_rot_vel
    assert turning, "the robot never turned on the spot to the goal's heading"


def test_a_way_closed_later_is_given_up_after_the_recovery_behaviours(
        tmp_path: Path, calibration: Any) -> None:
    """A wall across the floor with a gap, and a box that closes the gap at 1 s: the goal
    beyond it stays free, but there is no path. After move_base's planner_patience (1 s in
    this move_base file) the file's recovery_behaviors run in their order, each logged (a
    clearing, which restarts the search on the camera's map; a turn on the spot); the planner
    still failing, the goal is given up with the wheels stopped, and the summary is still
    there for the caller to write (move_base.cpp executeCycle's CLEARING state)."""
    text = SCENE.read_text()
    head = text[:text.rindex("\nobstacles:") + 1]
    scene = tmp_path / "scene.yaml"
    scene.write_text(head + "obstacles:\n"
                     "  - {box: {x: 1.8, y: 0.0, width: 0.2, depth: 2.2}}\n"
                     "  - {box: {x: 1.8, y: 2.2, width: 0.2, depth: 0.8}, appear_at: 1.0}\n")
    (tmp_path / "base_seed000.yaml").write_text((BASES / "base_seed000.yaml").read_text())
    move_base = tmp_path / "move_base.yaml"
    move_base.write_text(
        "controller_frequency: 5.0\nplanner_frequency: 1.0\nplanner_patience: 1.0\n"
        "recovery_behaviors:\n"
        "  - {name: reset, type: clear_costmap_recovery/ClearCostmapRecovery}\n"
        "  - {name: turn, type: rotate_recovery/RotateRecovery}\n"
        "reset: {reset_distance: 1.0}\n")
    with pytest.raises(GoalNotReached, match="no plan to the goal: no path to the goal for 1 s"
                       ", even after 2 recovery behaviour") as error:
        _run(tmp_path / "run", calibration, (3.0, 0.6), scene=scene, move_base=move_base)
    summary = error.value.summary
    assert summary is not None and summary["status"] == "ABORTED"
    assert not summary["refused_before_driving"]
    recoveries = summary["recoveries"]
    assert [(r["name"], r["trigger"]) for r in recoveries] == [("reset", "planning"),
                                                               ("turn", "planning")]
    assert recoveries[0]["t"] == pytest.approx(1.0 + 1.0 + summary["start_time_s"], abs=0.5)
    commands = _messages(summary, "/cmd_vel")
    # rotate_recovery turns once on the spot, counter-clockwise, at 0.4..1.0 rad/s
    turn_at = recoveries[1]["t"] * 1e9
    turning = [m.ros_msg for m in commands if m.log_time_ns >= turn_at]
    turned = [m.angular.z for m in turning if m.linear.x == 0.0 and m.angular.z > 0.39]
    assert len(turned) >= 10 and max(turned) <= 1.0
    # one full turn at the controller's 5 Hz
    assert sum(turned) * 0.2 == pytest.approx(2 * math.pi, abs=0.6)
    assert (commands[-1].ros_msg.linear.x, commands[-1].ros_msg.angular.z) == (0.0, 0.0)


@pytest.mark.parametrize("goal", [(0.3, 1.5, 180.0), (3.7, 1.5, 0.0), (2.0, 0.3, -90.0),
                                  (2.0, 2.7, 90.0)])
def test_a_goal_near_a_wall_is_reached_or_refused_before_driving(
        tmp_path: Path, calibration: Any, goal: tuple[float, float, float]) -> None:
    """0.3 m from the middle of each wall of the shipped scene, facing it: issue 30 found all
    such goals given up as "oscillating" with D.3's occdist_scale 0.8 and no word why. Each is
    now reached, or refused before the wheels move with the reason: its cost in the inflated
    band and DWA's dry run stopping short."""
    try:
        summary = _run(tmp_path, calibration, goal[:2], goal_yaw=math.radians(goal[2]))
    except GoalNotReached as error:
        summary = error.summary or {}
        assert summary["refused_before_driving"], summary["reason"]
        assert "lies in the inflated band" in summary["reason"]
        assert "a dry run of DWA" in summary["reason"]
        commands = _messages(summary, "/cmd_vel")
        assert all(m.ros_msg.linear.x == 0.0 and m.ros_msg.angular.z == 0.0
                   for m in commands)
        assert summary["path_length_m"] < 0.01
    else:
        _reached(summary)


@pytest.mark.parametrize(("args", "message"), [
    (["--goal", "5", "1"], "goal (5, 1) is outside the floor of"),
    (["--goal", "1"], "--goal takes X Y or X Y YAW, not 1 number(s)"),
    (["--goal", "1", "1", "--board-at", "0", "0"], "it needs a calibration file (--calib)"),
    (["--goal", "1", "1", "--dwa", "MISSING"], "MISSING"),
    (["--goal", "2", "1.4"], "goal (2, 1.4) is inside an obstacle of"),
    (["--goal", "3.9", "1"], "within the robot's inscribed radius 0.206 m"),  # the wall
    (["--goal", "1", "1", "--dwa", str(SCENE)], "none of dwa_local_planner's parameters"),
    (["--goal", "1", "1", "--seed", "-1"], "argument --seed: -1 must be 0 or more"),
])
def test_bad_input_is_refused_in_one_line_before_a_run_folder(
        tmp_path: Path, args: list[str], message: str,
        capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run"
    status, line = refusal(["navigate", *args, "--out", str(out)], capsys)
    assert status == 2 and message in line
    assert line.startswith(("servolab navigate: error: ", "servolab navigate: error: argument"))
    assert not out.exists()


def test_a_calibration_without_its_floor_is_refused(tmp_path: Path, calibration: Any) -> None:
    from servolab.vision.calibration import save

    calib, _ = calibration
    path = tmp_path / "no_floor.yaml"
    save(calib, None, path)
    with pytest.raises(NavigationError, match="has no floor extrinsics"):
        prepare((1.0, 1.0), calib=path)


def test_an_unwritable_run_folder_is_one_line(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    status, line = refusal(["navigate", "--goal", "3.3", "2.3", "--out", str(blocker / "run")],
                           capsys)
    assert status == 2 and line.startswith("servolab navigate: error: cannot make the run folder")


def test_a_runs_calibration_file_gives_the_same_map_frame(appearing: dict[str, Any]) -> None:
    """--calib with the calibration.yaml a run wrote: the board's place is in the file, so the
    map frame it gives is the scene's: the camera is found where the scene puts it (1 %)."""
    from servolab.vision.calibration import in_map

    navigation = prepare((3.3, 2.3), calib=appearing["calibration_file"])
    assert navigation.board_at == pytest.approx(BOARD_AT)
    assert navigation.calibration is not None
    _, board = navigation.calibration
    found = in_map(board, (BOARD_AT[0] * 1000, BOARD_AT[1] * 1000, BOARD_AT[2]))
    truth = np.array(load_nav_scene(SCENE).camera.position) * 1000
    assert found.camera_position == pytest.approx(truth, abs=0.01 * truth[2])
    # a board placed elsewhere on the command line wins over the file's
    moved = prepare((3.3, 2.3), calib=appearing["calibration_file"], board_at=(0.0, 0.0, 0.0))
    assert moved.board_at == (0.0, 0.0, 0.0)
