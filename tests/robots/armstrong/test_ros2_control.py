"""Armstrong's legs under ros2_control (robots/armstrong/ros2_control.py, gait_trajectory.py):
the seed's gait as one FollowJointTrajectory goal to joint_trajectory_controller reaches the
motors as the same goal positions the seed's CSV player writes through its dynamixel_motor
joint controllers (control_node.py, ``servolab walk``), row by row.

The play rate is the seed's: 4.5 rows a second, ``ros::Rate loop_rate(4.5)``, "each movement
... is executed in 222ms" (001 section 4.2.4.4). The CSV player's goals are not computed here:
the emulated robot plays the motion through :class:`~servolab.robots.armstrong.control_node.
Armstrong`, and its motors' Goal Position registers are read.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from servolab.apps.control import robot_files
from servolab.dynamixel.emulator import Emulator
from servolab.dynamixel.models import model
from servolab.gait.motionfile import MotionFile
from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides
from servolab.rclpy.action import ActionClient
from servolab.rclpy.action.server import STATUS_SUCCEEDED
from servolab.robots.armstrong.control_node import PLAY_RATE, Armstrong
from servolab.robots.armstrong.description import describe, horn_maps
from servolab.robots.armstrong.gait_trajectory import (
    GaitTrajectory,
    JointMap,
    duration_fields,
    motion_trajectory,
)
from servolab.robots.armstrong.hardware import MODEL, load_config
from servolab.robots.armstrong.motions import load_motion
from servolab.robots.armstrong.poses import STAND_POSE
from servolab.robots.armstrong.ros2_control import (
    CONTROLLERS,
    LEGS_CONTROLLER,
    control_urdf,
    leg_columns,
    leg_joints,
    legs_trajectory,
    standing,
)
from servolab.robots.control.bringup import BringUpOptions, ControlSystem
from servolab.robots.dynamixel_system import dynamixel_system
from servolab.robots.errors import RobotValueError

from .configs import ping_once_config

ACTION = "control_msgs/action/FollowJointTrajectory"
LEG_IDS = [int(c[1:]) for c in leg_columns()]
RX28 = model(MODEL)


# -- gait_trajectory.motion_trajectory -----------------------------------------------------

def small_motion() -> MotionFile:
    return MotionFile(("a", "b", "c"),
                      np.array([[10.0, -20.0, 1.0], [30.0, 0.0, 2.0], [-5.0, 45.0, 3.0]]))


def test_a_motions_rows_are_points_one_period_apart_from_one_period_in() -> None:
    maps = [JointMap("b", "jb", -1.0), JointMap("a", "ja")]
    t = motion_trajectory(small_motion(), maps, rate=4.0)
    assert t.joint_names == ("jb", "ja")
    assert t.times.tolist() == [0.25, 0.5, 0.75]
    assert t.duration == 0.75
    np.testing.assert_allclose(t.positions, np.radians([[20.0, 10.0], [0.0, 30.0],
                                                        [-45.0, -5.0]]), rtol=0, atol=1e-15)


def test_steps_repeat_the_rows_and_rows_keep_the_first_of_the_whole() -> None:
    maps = [JointMap("c", "jc")]
    t = motion_trajectory(small_motion(), maps, rate=2.0, steps=2, rows=5)
    assert t.times.tolist() == [0.5, 1.0, 1.5, 2.0, 2.5]
    np.testing.assert_allclose(np.degrees(t.positions[:, 0]), [1.0, 2.0, 3.0, 1.0, 2.0])
    default = motion_trajectory(small_motion(), maps)
    assert default.times[0] == pytest.approx(1 / PLAY_RATE)


def test_the_fields_are_a_goals_trajectory_with_positions_only() -> None:
    t = GaitTrajectory(("j",), np.array([0.25, 1.5]), np.array([[0.1], [-0.2]]))
    fields = t.fields(start=3.25)
    assert fields == {
        "header": {"stamp": {"sec": 3, "nanosec": 250_000_000}},
        "joint_names": ["j"],
        "points": [{"positions": [0.1], "time_from_start": {"sec": 0, "nanosec": 250_000_000}},
                   {"positions": [-0.2], "time_from_start": {"sec": 1, "nanosec": 500_000_000}}]}
    assert duration_fields(2 / 9) == {"sec": 0, "nanosec": 222_222_222}


@pytest.mark.parametrize(("kwargs", "maps", "words"), [
    ({"rate": 0.0}, None, "rate must be a number > 0"),
    ({"rate": math.nan}, None, "rate must be a number > 0"),
    ({"rate": -4.5}, None, "rate must be a number > 0"),
    ({"steps": 0}, None, "steps must be >= 1, not 0"),
    ({"rows": 0}, None, "rows must be 1..3"),
    ({"rows": 7, "steps": 2}, None, "rows must be 1..6 (the motion's 3 rows x 2 step(s)), not 7"),
    ({}, [], "at least one joint"),
    ({}, [JointMap("a", "j"), JointMap("b", "j")], "joint 'j' is given twice"),
    ({}, [JointMap("m14", "knee")], "the motion has no column 'm14' (it has a, b, c)"),
])
def test_refusals_are_one_line(kwargs: dict[str, Any], maps: list[JointMap] | None,
                               words: str) -> None:
    with pytest.raises(RobotValueError) as raised:
        motion_trajectory(small_motion(), [JointMap("a", "ja")] if maps is None else maps,
                          **kwargs)
    assert words in str(raised.value) and "\n" not in str(raised.value)


# -- the <ros2_control> block and the files the control CLI takes -------------------------

def test_the_blocks_joints_are_the_urdfs_joint_angles() -> None:
    """Each on-bus motor's joint in the block, read as servolab's DynamixelHardware reads it:
    the horn at ``init`` is joint angle 0, and a joint angle turns the horn by the motor's
    direction x flip, as the description's joint angles turn the seed's motors."""
    text = control_urdf()
    config = load_config()
    horns = horn_maps(describe(None, config), config)
    system = dynamixel_system(text, "armstrong.urdf")
    assert [j.name for j in system.joints] == list(horns)
    assert len(system.joints) == 20 and 62 not in [j.id for j in system.joints]
    assert (system.protocol, system.baudrate) == (1, 57142)
    for joint in system.joints:
        horn = horns[joint.name]
        assert joint.model.name == MODEL and joint.id == horn.id
        assert joint.to_joint(horn.offset) == 0.0
        for angle in (-0.7, 0.3):
            assert joint.to_horn(angle) == pytest.approx(horn.offset + horn.sign * angle,
                                                         abs=1e-15)
    block = ET.fromstring(text).find("ros2_control")
    assert block is not None
    names = {p.get("name") for p in block.iter("param")}
    assert {"mechanical_reduction", "mechanical_offset"} <= names
    assert not names & {"offset", "gear_ratio"}  # not the community plugin's parameters
    # the description's URDF as the generic writer writes it, with the block at the end
    generic = describe().urdf()
    end = generic.rindex("</robot>")
    assert text.startswith(generic[:end]) and text.endswith(generic[end:])


def test_the_control_cli_takes_armstrongs_urdf_and_controllers_file() -> None:
    urdf, source, controllers, plugin = robot_files("armstrong", None)
    assert (urdf, source, controllers) == (control_urdf(), "armstrong.urdf", CONTROLLERS)
    assert plugin.shown_files()["armstrong.controllers"] == CONTROLLERS
    with CONTROLLERS.open() as f:
        params = yaml.safe_load(f)
    legs = params[LEGS_CONTROLLER]["ros__parameters"]
    assert tuple(legs["joints"]) == leg_joints(describe())
    assert set(legs["constraints"]) - {"goal_time"} == set(legs["joints"])
    # twice the play rate: every row's time is an update's
    rate = params["controller_manager"]["ros__parameters"]["update_rate"]
    assert rate / PLAY_RATE == 2


# -- the gait through both paths, on emulated motors in virtual time ----------------------

@dataclass
class Run:
    """Per row of the motion (and once at the end): the leg motors' Goal Position (raw) and
    present angle (rad, from the centre tick), in leg_columns() order."""

    goals: list[list[int]]
    present: list[list[float]]
    end_goals: list[int]
    end_present: list[float]
    result: Any = None


def legs_now(emulator: Emulator) -> tuple[list[int], list[float]]:
    motors = [emulator.motor(i) for i in LEG_IDS]
    return [m.get_raw("goal_position") for m in motors], [m.position for m in motors]


def csv_player(motion: MotionFile, config: Path) -> Run:
    """``servolab walk``'s path: stand (Table 4.2 over 2 s), then play the rows at 4.5 Hz.
    Row k's time is the end of its period, when row k + 1 is sent: the progress callback of
    row k + 2, before that row reaches the bus (and, for the last row, the return of play)."""
    run = Run([], [], [], [])
    with Armstrong(config=config) as robot:
        robot.stand()
        emulator = robot.bus.emulator

        def progress(sent: int, total: int) -> None:
            if sent >= 2:
                goals, present = legs_now(emulator)
                run.goals.append(goals)
                run.present.append(present)

        assert robot.play(motion, progress=progress) == motion.poses
        goals, present = legs_now(emulator)
        run.goals.append(goals)
        run.present.append(present)
        robot.context.spin_for(1.0)
        run.end_goals, run.end_present = legs_now(emulator)
    return run


class Controlled:
    """Armstrong brought up as ``servolab control run armstrong --spawn
    joint_state_broadcaster legs_controller`` brings it up (the plug-in's URDF and controllers
    file), standing at its ``init`` positions as ``servolab walk``'s emulated robot does, in
    virtual time; a FollowJointTrajectory client on ``legs_controller``."""

    def __init__(self) -> None:
        urdf, source, controllers, _plugin = robot_files("armstrong", None)
        assert controllers is not None
        self.system = ControlSystem(
            urdf, source, ParameterOverrides.from_file(controllers),
            BringUpOptions(spawn=("joint_state_broadcaster", LEGS_CONTROLLER),
                           real_time=False, world="robot", place=standing))
        self.context = self.system.context
        self.probe = Node(self.context, "probe")
        self.client = ActionClient(self.probe, ACTION,
                                   f"/{LEGS_CONTROLLER}/follow_joint_trajectory")
        self.started: list[float] = []

    def send(self, trajectory: GaitTrajectory) -> Any:
        """Send the goal; returns the future of its result once the controller has started
        it (``started``: the update it started on, from its first feedback)."""
        self.started.clear()

        def feedback(message: Any) -> None:
            stamp = message.feedback.header.stamp
            self.started.append(int(stamp.sec) + int(stamp.nanosec) * 1e-9)

        goal = self.probe.message(f"{ACTION}_Goal", trajectory=trajectory.fields())
        sent = self.client.send_goal_async(goal, feedback_callback=feedback)
        assert self.context.spin_until(sent.done, timeout=1.0)
        handle = sent.result()
        assert handle.accepted
        ended = handle.get_result_async()
        assert self.context.spin_until(lambda: bool(self.started), timeout=1.0)
        return ended

    def close(self) -> None:
        self.system.close()


#: how long before a row's time the controlled robot is read: before the update that starts
#: then (it writes the goal one update ahead 92 ms later, after reading the 20 motors); the
#: row's goal is on the motors from 19 ms before its time (armstrong_controllers.yaml)
BEFORE_THE_UPDATE = 0.005


def trajectory_controller(motion: MotionFile) -> Run:
    """The same gait as one goal: stand (Table 4.2 over 2 s), then the rows, each read at
    its time from the start of the goal."""
    robot = Controlled()
    try:
        stand = MotionFile(tuple(STAND_POSE), np.array([list(STAND_POSE.values())]))
        ended = robot.send(legs_trajectory(stand, rate=1 / 2.0))
        assert robot.context.spin_until(ended.done, timeout=5.0)
        assert ended.result().status == STATUS_SUCCEEDED
        trajectory = legs_trajectory(motion)
        ended = robot.send(trajectory)
        start, clock, emulator = robot.started[0], robot.context.clock, robot.system.emulator
        assert emulator is not None
        run = Run([], [], [], [])
        for t in trajectory.times:
            robot.context.spin_for(start + float(t) - BEFORE_THE_UPDATE - clock.now())
            goals, present = legs_now(emulator)
            run.goals.append(goals)
            run.present.append(present)
        assert robot.context.spin_until(ended.done, timeout=5.0)
        run.result = ended.result()
        robot.context.spin_for(1.0)
        run.end_goals, run.end_present = legs_now(emulator)
        return run
    finally:
        robot.close()


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[MotionFile, Run, Run]]:
    motion = load_motion(None)  # the seed's gait: one step, 17 rows
    config = ping_once_config(tmp_path_factory.mktemp("armstrong"))
    yield motion, csv_player(motion, config), trajectory_controller(motion)


def test_the_goal_succeeds(both: tuple[MotionFile, Run, Run]) -> None:
    _motion, _csv, controlled = both
    assert controlled.result.status == STATUS_SUCCEEDED
    assert (controlled.result.result.error_code, controlled.result.result.error_string) == (
        0, "Goal successfully reached!")


def test_each_rows_goal_positions_are_the_csv_players(both: tuple[MotionFile, Run, Run]
                                                      ) -> None:
    """Every leg motor's Goal Position at every row's time is the tick the seed's player
    wrote for that row (measured: 0 ticks apart, on all 17 rows of a step), and the rows
    differ, so a row early or late would show."""
    motion, csv, controlled = both
    assert len(csv.goals) == len(controlled.goals) == motion.poses
    assert controlled.goals == csv.goals
    assert all(a != b for a, b in zip(csv.goals, csv.goals[1:], strict=False))


def test_the_motors_end_where_the_csv_players_end(both: tuple[MotionFile, Run, Run]) -> None:
    _motion, csv, controlled = both
    assert controlled.end_goals == csv.end_goals == csv.goals[-1]
    np.testing.assert_allclose(controlled.end_present, csv.end_present, rtol=0,
                               atol=RX28.rad_per_tick)


def test_at_each_rows_time_neither_path_is_a_row_behind(both: tuple[MotionFile, Run, Run]
                                                         ) -> None:
    """Present angles part while moving: the seed's joints go to each row at their
    controller's joint_speed, joint_trajectory_controller's ramp from row to row (measured:
    8.1 degrees apart at most); never by as much as one row's largest step (26.6 degrees)."""
    motion, csv, controlled = both
    apart = np.abs(np.array(controlled.present) - np.array(csv.present))
    legs = np.array([motion.column(c) for c in leg_columns()])
    assert math.degrees(float(apart.max())) < float(np.abs(np.diff(legs, axis=1)).max())


def test_gait_send_refuses_a_bad_motion_in_one_line_before_joining_the_graph(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """``servolab gait send``'s input is checked before any goal is sent: rows beyond the
    motion, a motion file that is not one, each one line and exit 2."""
    from servolab.cli import main

    assert main(["gait", "send", "--rows", "999"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "rows must be 1..17" in err, err
    bad = tmp_path / "bad.csv"
    bad.write_text("m11,m12\n1,x\n")
    assert main(["gait", "send", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.csv" in err, err


def test_gait_send_without_a_controller_says_what_to_start(
        capsys: pytest.CaptureFixture[str]) -> None:
    from servolab.cli import main

    assert main(["gait", "send", "--rows", "2", "--timeout", "0.5", "--transport",
                 "local"]) == 2
    err = capsys.readouterr().err.strip()
    assert "no action server for /legs_controller/follow_joint_trajectory within 0.5 s" \
        in err, err
    assert err.endswith("servolab control run armstrong --spawn joint_state_broadcaster "
                        "legs_controller"), err
