"""configs/flyball.launch.yaml: the camera PC and the robot as two processes over Zenoh
(seed 002, Figure 2). The treadmill is required: it stops after its duration, analyses the
logs, and the launch ends; the robot's encoder log was heard across the processes. A robot
that never comes up ends the launch too, as a failure, after the camera PC's
``robot_timeout`` (servolab's own: the seed's camera PC simply waits)."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.errors import RobotError
from servolab.robots.treadmill.logs import read_encoder_log, read_fly_log
from servolab.robots.treadmill.node import TREADMILL_IDS
from servolab.robots.treadmill.rig import SENSOR_STATE, TreadmillRig
from tests.clirun import servolab

ROOT = Path(__file__).resolve().parents[3]
LAUNCH = ROOT / "configs" / "flyball.launch.yaml"


@pytest.mark.slow
def test_camera_pc_and_robot_in_two_processes(tmp_path: Path) -> None:
    out = tmp_path / "run"
    text = LAUNCH.read_text()
    shipped = 'parameters: {duration: 30.0, seed: 0, out: "runs/flyball-launch"}'
    assert shipped in text and "base: turtlebot3_waffle" in text  # a shipped base, by name
    path = tmp_path / "flyball.launch.yaml"
    path.write_text(text.replace(shipped, f'parameters: {{duration: 4.0, seed: 0, '
                                          f'out: "{out}"}}'))
    # to its end; on a timeout the launcher gets SIGTERM and whatever is left of its
    # children's process groups is killed (tests/clirun.py servolab), so no camera PC or
    # robot outlives it
    result = servolab("launch", str(path), timeout=180)
    said = result.stdout + result.stderr
    assert result.returncode == 0, said[-3000:]
    pids = set(re.findall(r"started (?:treadmill|robot) \(pid (\d+)\)", said))
    assert len(pids) == 2, said[-2000:]
    # the same outputs as the one-process run: both logs, the analysis, the figure
    summary = json.loads((out / "summary.json").read_text())
    fly = read_fly_log(out / "fly_data.bin")
    encoders = read_encoder_log(out / "robot_encoders.bin")
    # 4 s counted from the robot's first message: real time at 66 frames/s, about 264 frames
    assert len(fly) == summary["frames"] > 100
    assert len(encoders) == summary["encoder_records"] > 20  # the robot, over Zenoh
    analysis = summary["analysis"]
    for key in ("mean_distance_error_mm", "mean_angle_error_deg", "sphere_path_length_m"):
        assert analysis[key] >= 0.0, key  # a number, not NaN
    assert analysis["robot_path_length_m"] > 0.0  # the robot drove, on /cmd_vel over Zenoh
    assert (out / "flyball.png").stat().st_size > 20_000
    # a live launch says how well it kept up with the camera (real time, a busy machine:
    # the numbers vary, their presence and consistency do not)
    timing = summary["timing"]
    assert timing["frames"] == len(fly)
    assert 0 < timing["achieved_fps"] <= 66.0 * 1.1
    assert timing["interval_ms"]["p50"] <= timing["interval_ms"]["p99"] <= \
        timing["interval_ms"]["max"]
    assert timing["latency_ms"]["p50"] >= 0.0  # stamps are capture times, on the same clock
    # the log's first value is the camera's frame number (its node's own count): it only
    # goes up, and its span is what the camera took, handled or dropped
    assert np.all(np.diff(fly["frame"]) >= 1)
    assert fly["frame"][-1] - fly["frame"][0] + 1 == timing["camera_frames"]
    assert "frames/s, interval p99" in said and "late" in said


# -- a robot that never comes up ---------------------------------------------------------------


@pytest.fixture
def context() -> Iterator[Context]:
    """An in-process graph on the wall clock, as the camera PC's process has."""
    ctx = Context.open()
    try:
        yield ctx
    finally:
        ctx.close()


@pytest.mark.slow
def test_the_camera_pc_gives_up_on_a_robot_never_heard(context: Context,
                                                       tmp_path: Path) -> None:
    out = tmp_path / "run"
    rig = TreadmillRig(context, parameter_overrides={
        "robot_timeout": 0.5, "duration": 5.0, "out": str(out)})
    made = time.monotonic()
    gave_up: list[float] = []
    give_up = rig._robot_never_heard

    def noted() -> None:
        gave_up.append(time.monotonic())
        give_up()

    rig._robot_never_heard = noted  # type: ignore[method-assign]
    with pytest.raises(RobotError, match="robot was never heard"):
        context.spin_until(lambda: False, timeout=60.0)  # until the rig fails
    # not before robot_timeout has passed since the rig was made (its wall-time count starts
    # at the end of its constructor: 0.1 s of margin for what follows it there)
    assert len(gave_up) == 1 and gave_up[0] - made >= 0.4
    assert not context.ok()                             # it shut its process's graph down
    summary = json.loads((out / "summary.json").read_text())
    assert "robot was never heard" in summary["error"] and "0.5 s" in summary["error"]
    assert summary["encoder_records"] == 0
    # the wheels stopped, torque off (Listing 1's motor_deinit)
    for motor_id in TREADMILL_IDS:
        assert rig.bus.read(motor_id, "torque_enable") == 0
        assert rig.bus.read(motor_id, "goal_velocity", raw=True) == 0


@pytest.mark.slow
def test_a_robot_heard_in_time_runs_its_duration_without_error(context: Context,
                                                               tmp_path: Path) -> None:
    out = tmp_path / "run"
    TreadmillRig(context, parameter_overrides={
        "robot_timeout": 0.5, "duration": 1.0, "out": str(out)})
    robot = Node(context, "robot")
    state = robot.create_publisher(SENSOR_STATE, "sensor_state", 10)
    state.publish(robot.message(SENSOR_STATE, left_encoder=0, right_encoder=0))
    started = time.monotonic()
    context.spin_until(lambda: not context.ok(), timeout=60.0)  # the rig ends the run
    assert not context.ok()
    assert time.monotonic() - started >= 1.0            # its duration, past robot_timeout
    summary = json.loads((out / "summary.json").read_text())
    assert "error" not in summary and summary["encoder_records"] == 1


def test_a_bad_robot_timeout_is_refused(context: Context, tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="robot_timeout"):
        TreadmillRig(context, parameter_overrides={"robot_timeout": 0.0,
                                                   "out": str(tmp_path / "run")})


@pytest.mark.slow
def test_a_launch_whose_robot_never_comes_up_ends_by_itself(tmp_path: Path) -> None:
    """The flyball launch without its robot: the camera PC gives up after robot_timeout,
    writes its summary with the error, and the launch ends with a failure."""
    out = tmp_path / "run"
    path = tmp_path / "no_robot.launch.yaml"
    path.write_text(f"""\
transport: zenoh
nodes:
  - name: treadmill
    node: servolab.robots.treadmill.rig:TreadmillRig
    parameters: {{duration: 30.0, seed: 0, out: "{out}", robot_timeout: 2.0}}
    process: camera_pc
    required: true
""")
    result = servolab("launch", str(path), timeout=120)
    said = result.stdout + result.stderr
    assert result.returncode == 1, said[-3000:]
    assert "robot was never heard" in said
    assert "treadmill exited with 1; stopping the others (required)" in said
    summary = json.loads((out / "summary.json").read_text())
    assert "robot was never heard" in summary["error"]
