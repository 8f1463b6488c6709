"""``servolab control`` as a lab runs it: the robot brought up from its URDF on emulated motors
served by ``servolab sim --pty`` at 1 Mbps, in real time (ROBOTIS's dialect with every core
busy); the ``ros2
control`` verbs, ``topic pub`` and ``action send_goal`` from other processes over Zenoh; the
motors read back over the pty once the manager has stopped (the joints hold). Both
Dynamixel dialects (tests/robots/control/data). The messages checked are ros2_control's own
(controller_manager.cpp, ros2controlcli's verbs, Jazzy branch)."""

from __future__ import annotations

import re
import signal
from pathlib import Path

import pytest

from servolab.dynamixel.bus import Bus
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.simproc import sim_process
from tests.waiting import wait_for, wait_for_line

from .conftest import CONTROLLERS, TWO_JOINT, TWO_JOINT_ROBOTIS

pytestmark = pytest.mark.slow


def positions(say: str) -> list[float]:
    """The positions of the first JointState ``servolab topic echo`` printed."""
    block = say.split("position:", 1)[1].split("velocity:", 1)[0]
    return [float(v) for v in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", block)]


# the community dialect on a quiet CPU; ROBOTIS's with every core busy (busy_cpu: one such
# test at a time, so marked realtime): the dialects differ in what is read from the URDF, not
# in the real-time path, which the busy run checks once
@pytest.mark.parametrize("urdf", [
    pytest.param(TWO_JOINT, id="dynamixel_hardware"),
    pytest.param(TWO_JOINT_ROBOTIS, id="robotis", marks=pytest.mark.realtime)])
def test_a_urdf_robot_under_ros2_control_on_a_real_time_pty(
        urdf: Path, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    if request.node.get_closest_marker("realtime") is not None:
        request.getfixturevalue("busy_cpu")
    port = free_port()
    connect = ["--connect", f"tcp/127.0.0.1:{port}"]
    with sim_process("--motors", "xm430-w350:1-2", "--baud", "1000000",
                     out_dir=tmp_path / "sim") as (device, _sim):
        run = [*SERVOLAB, "control", "run", str(urdf), "--params", str(CONTROLLERS),
               "--model", "XM430-W350", "--port", device, "--listen", f"tcp/127.0.0.1:{port}",
               "--spawn", "joint_state_broadcaster", "forward_position_controller",
               "--inactive", "joint_trajectory_controller"]
        with started(run, stderr_to_stdout=True) as manager:
            wait_for_line(manager, "running; Ctrl-C stops it", timeout=30)
            listed = servolab("control", "list_controllers", *connect, timeout=60)
            assert listed.returncode == 0, listed.stderr
            rows = {line.split()[0]: line.split()[-1] for line in listed.stdout.splitlines()}
            assert rows == {"joint_state_broadcaster": "active",
                            "forward_position_controller": "active",
                            "joint_trajectory_controller": "inactive"}
            published = servolab("topic", "pub", "--once", "/forward_position_controller/"
                                 "commands", "std_msgs/msg/Float64MultiArray",
                                 "{data: [0.5, -0.3]}", *connect, timeout=60)
            assert published.returncode == 0, published.stderr

            def at(goal: list[float]) -> bool:
                echo = servolab("topic", "echo", "/joint_states", "--count", "1", *connect,
                                timeout=60)
                return positions(echo.stdout) == pytest.approx(goal, abs=0.01)

            wait_for(lambda: at([0.5, -0.3]), "the joints at [0.5, -0.3] on /joint_states",
                     timeout=20)
            switched = servolab("control", "switch_controllers", "--activate",
                                "joint_trajectory_controller", "--deactivate",
                                "forward_position_controller", *connect, timeout=60)
            assert (switched.returncode, switched.stdout.strip()) == (
                0, "Successfully switched controllers!")
            goal = servolab("action", "send_goal",
                            "/joint_trajectory_controller/follow_joint_trajectory",
                            "control_msgs/action/FollowJointTrajectory",
                            "{trajectory: {joint_names: [joint1, joint2], points: [{positions: "
                            "[-0.4, 0.6], time_from_start: {sec: 1}}]}}", *connect, timeout=60)
            assert "Goal finished with status: SUCCEEDED" in goal.stdout, goal.stdout
            assert "error_string: Goal successfully reached!" in goal.stdout
            conflict = servolab("control", "switch_controllers", "--activate",
                                "forward_position_controller", "--strict", *connect,
                                timeout=60)
            assert (conflict.returncode, conflict.stdout.strip()) == (
                1, "Unable to activate controller 'forward_position_controller' since the "
                   "command interface 'joint1/position' is currently claimed by another "
                   "controller.")
            manager.send_signal(signal.SIGINT)
            said, _ = manager.communicate(timeout=30)
            assert manager.returncode == 128 + signal.SIGINT
            assert "Caught exception" not in said and "Traceback" not in said, said
        # the manager has gone and the joints hold: read them on the pty itself
        # (the ROBOTIS file's transmission_to_joint_matrix turns joint2 against its horn)
        horn2 = -0.6 if urdf == TWO_JOINT_ROBOTIS else 0.6
        with Bus.open(device, protocol=2, baudrate=1_000_000) as bus:
            assert [float(bus.read(i, "present_position")) for i in (1, 2)] == pytest.approx(
                [-0.4, horn2], abs=0.02)
            assert [bus.read(i, "torque_enable") for i in (1, 2)] == [1, 1]


def test_the_spawner_and_the_verbs(tmp_path: Path) -> None:
    port = free_port()
    connect = ["--connect", f"tcp/127.0.0.1:{port}"]
    run = [*SERVOLAB, "control", "run", str(TWO_JOINT), "--params", str(CONTROLLERS),
           "--listen", f"tcp/127.0.0.1:{port}"]
    with started(run, stderr_to_stdout=True) as manager:
        wait_for_line(manager, "running; Ctrl-C stops it", timeout=30)
        empty = servolab("control", "list_controllers", *connect, timeout=60)
        assert empty.stdout.strip() == "No controllers are currently loaded!"
        spawned = servolab("control", "spawner", "joint_state_broadcaster",
                           "forward_velocity_controller", *connect, timeout=60)
        assert spawned.returncode == 0, spawned.stdout + spawned.stderr
        assert spawned.stdout.splitlines() == [
            "Loaded joint_state_broadcaster", "Configured and activated joint_state_broadcaster",
            "Loaded forward_velocity_controller",
            "Configured and activated forward_velocity_controller"]
        loaded = servolab("control", "load_controller", "joint_trajectory_controller",
                          "--set-state", "inactive", *connect, timeout=60)
        assert loaded.stdout.splitlines() == [
            "Successfully loaded controller joint_trajectory_controller",
            "Successfully loaded controller joint_trajectory_controller into state inactive"]
        interfaces = servolab("control", "list_hardware_interfaces", *connect, timeout=60)
        assert interfaces.stdout.splitlines()[:5] == [
            "command interfaces", "\tjoint1/position [available] [unclaimed]",
            "\tjoint1/velocity [available] [claimed]",
            "\tjoint2/position [available] [unclaimed]",
            "\tjoint2/velocity [available] [claimed]"]
        components = servolab("control", "list_hardware_components", *connect, timeout=60)
        assert "\tplugin name: dynamixel_hardware/DynamixelHardware" in components.stdout
        assert "\tstate: id=3 label=active" in components.stdout
        types = servolab("control", "list_controller_types", *connect, timeout=60)
        assert "joint_trajectory_controller/JointTrajectoryController" in types.stdout
        unload = servolab("control", "unload_controller", "joint_trajectory_controller",
                          *connect, timeout=60)
        assert unload.stdout.strip() == "Successfully unloaded controller " \
                                        "joint_trajectory_controller"
        manager.send_signal(signal.SIGINT)
        manager.communicate(timeout=30)
    nobody = servolab("control", "list_controllers", *connect, "--service-call-timeout", "1",
                      timeout=60)
    assert nobody.returncode == 2
    assert "no controller manager /controller_manager answered within 1 s" in nobody.stderr
