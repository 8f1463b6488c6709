"""The shipped robots under ros2_control in real time, as a lab runs them: each robot's bus
served by ``servolab sim --robot NAME --pty`` at its own baud rate (Armstrong: 20 RX-28 at
57 142 bps, seed 001; the Waffle: two XM430-W210 at 1 Mbps, on the simulated floor), every core
kept busy, ``servolab control run NAME --port PTY`` in its own process, and the commands a
student types from another: ``servolab gait send`` (the seed's gait as one
FollowJointTrajectory goal) and ``servolab topic pub`` of ``cmd_vel``. After Ctrl-C the motors
are read on the pty itself: the legs hold the goal's last point, the wheels have stopped."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest
import yaml

from servolab.dynamixel.bus import Bus
from servolab.robots.armstrong.motions import load_motion
from servolab.robots.armstrong.ros2_control import control_urdf, legs_trajectory
from servolab.robots.dynamixel_system import dynamixel_system
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.simproc import sim_process
from tests.waiting import wait_for, wait_for_line

pytestmark = [pytest.mark.slow, pytest.mark.realtime]

#: rows of the seed's gait sent: the first half step (both feet's first moves)
ROWS = 8


def test_armstrongs_legs_follow_the_gait_as_one_goal_on_a_real_time_bus(
        tmp_path: Path, busy_cpu: None) -> None:
    port = free_port()
    connect = ["--connect", f"tcp/127.0.0.1:{port}"]
    with sim_process("--robot", "armstrong", out_dir=tmp_path / "sim") as (device, _sim):
        run = [*SERVOLAB, "control", "run", "armstrong", "--port", device,
               "--listen", f"tcp/127.0.0.1:{port}",
               "--spawn", "joint_state_broadcaster", "legs_controller"]
        with started(run, stderr_to_stdout=True) as manager:
            wait_for_line(manager, "running; Ctrl-C stops it", timeout=60)
            sent = servolab("gait", "send", "--rows", str(ROWS), *connect, timeout=120)
            assert sent.returncode == 0, sent.stdout + sent.stderr
            assert f"{ROWS} points of 12 joints" in sent.stdout
            # joint_trajectory_controller's result within its goal tolerances
            # (armstrong_controllers.yaml: 0.05 rad per leg joint by goal_time)
            assert "Goal finished with status: SUCCEEDED" in sent.stdout, sent.stdout
            manager.send_signal(signal.SIGINT)
            said, _ = manager.communicate(timeout=60)
            assert manager.returncode == 128 + signal.SIGINT, said
            assert "Traceback" not in said, said
        # the legs hold the goal's last point: each motor's Goal Position is the horn the
        # block's transmission makes of that joint angle (to one RX-28 tick, 0.29 deg: the
        # controller keeps its last command when it is deactivated, and so does the
        # hardware), torque on; Present Position near it, how near being the world's say
        # (the biped stands in MuJoCo, and an RX-28's compliance gives way under its weight)
        trajectory = legs_trajectory(load_motion(None), rows=ROWS)
        last = dict(zip(trajectory.joint_names, trajectory.positions[-1], strict=True))
        joints = {j.name: j for j in dynamixel_system(control_urdf(), "armstrong.urdf").joints}
        tick = joints["left_knee"].model.rad_per_tick
        with Bus.open(device, protocol=1, baudrate=57142) as bus:
            for name, angle in last.items():
                joint = joints[name]
                horn = joint.to_horn(angle)
                goal = float(bus.read(joint.id, "goal_position"))
                present = float(bus.read(joint.id, "present_position"))
                assert goal == pytest.approx(horn, abs=tick), \
                    f"{name} (ID {joint.id}) holds goal {goal} rad, the last point is {horn}"
                assert present == pytest.approx(horn, abs=0.15), \
                    f"{name} (ID {joint.id}) is at {present} rad, its goal {horn}"
                assert bus.read(joint.id, "torque_enable") == 1, f"{name} went limp"


def test_the_waffle_drives_by_cmd_vel_and_ctrl_c_stops_its_wheels_on_a_real_time_bus(
        tmp_path: Path, busy_cpu: None) -> None:
    port = free_port()
    connect = ["--connect", f"tcp/127.0.0.1:{port}"]
    with sim_process("--robot", "turtlebot3_waffle", out_dir=tmp_path / "sim") as (device,
                                                                                   _sim):
        run = [*SERVOLAB, "control", "run", "turtlebot3_waffle", "--port", device,
               "--listen", f"tcp/127.0.0.1:{port}",
               "--spawn", "joint_state_broadcaster", "diff_drive_controller"]
        with started(run, stderr_to_stdout=True) as manager:
            wait_for_line(manager, "running; Ctrl-C stops it", timeout=60)
            # a teleop's stream of commands, still coming when the manager is stopped
            teleop = [*SERVOLAB, "topic", "pub", "/diff_drive_controller/cmd_vel",
                      "geometry_msgs/msg/TwistStamped", "{twist: {linear: {x: 0.1}}}",
                      "--rate", "10", *connect]
            with started(teleop) as _teleop:

                def odom_x() -> float:
                    echo = servolab("topic", "echo", "/diff_drive_controller/odom", "--count",
                                    "1", *connect, timeout=60)
                    odom = yaml.safe_load(echo.stdout.split("---")[0])
                    return float(odom["pose"]["pose"]["position"]["x"]) if odom else 0.0

                wait_for(lambda: odom_x() > 0.05, "the Waffle's odometry past 5 cm",
                         timeout=60, step=0.5)
                manager.send_signal(signal.SIGINT)
                said, _ = manager.communicate(timeout=60)
            assert manager.returncode == 128 + signal.SIGINT, said
            assert "Traceback" not in said, said
        # the wheels: goal velocity 0 and the motors at rest, read on the pty itself
        with Bus.open(device, protocol=2, baudrate=1_000_000) as bus:
            assert [int(bus.read(i, "goal_velocity", raw=True)) for i in (1, 2)] == [0, 0]
            wait_for(lambda: all(abs(float(bus.read(i, "present_velocity"))) < 0.05
                                 for i in (1, 2)), "both wheels at rest", timeout=10)
