"""A ``FollowJointTrajectory`` goal sent from another process moves the OpenMANIPULATOR-X in
MuJoCo under gravity, in real time, as a lab sends one from MoveIt or
``ros2 action send_goal``: ``servolab control run open_manipulator_x --world robot`` in one
process, ``servolab action send_goal`` in a second, and this test, a third, reading
``/joint_states`` and ``/dynamic_joint_states`` over Zenoh.

The oracles are not servolab's: the goal's end is joint_trajectory_controller's own words
("Goal successfully reached!", ros2_controllers jazzy, joint_trajectory_controller.cpp) within
the tolerances of the arm's controllers file (0.02 rad a joint, ROBOTIS's
hardware_controller_manager.yaml); the gravity torque at the reached pose is computed by
MuJoCo's own URDF compiler from the arm's URDF, in this process (``qfrc_bias`` at rest: the
generalised force that holds the model still); an XM430-W350's torque constant is its stall
torque over its stall current, 4.1 N m / 2.3 A at 12.0 V, and Present Current is 2.69 mA a unit
(e-Manual, XM430-W350 "Specifications" and Present Current(126)). The emulated motors turn
torque into current with those same two figures, so what this checks is the physics (the
load MuJoCo puts on each joint reaches its motor's Present Current, sign and size) and
the wire (ROBOTIS's gpio interface on /dynamic_joint_states), not the e-Manual's constant;
the joint's effort on /joint_states is the hardware's conversion of that current back."""

from __future__ import annotations

import signal
from typing import Any

import pytest

from servolab.robots.open_manipulator_x import NAME, urdf_text
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

mujoco = pytest.importorskip("mujoco")

pytestmark = pytest.mark.slow

ARM = ("joint1", "joint2", "joint3", "joint4")
#: the goal: a pose whose shoulder, elbow and wrist gravity loads (rad)
POSE = (0.5, -0.6, 0.4, 0.6)
#: rad: the controllers file's goal tolerance of each arm joint
GOAL_TOLERANCE = 0.02
#: N m a unit of Present Current: 2.69 mA x 4.1 N m / 2.3 A
EFFORT_UNIT = 0.00269 * 4.1 / 2.3
#: the gpio state interface ROBOTIS's block names for a motor's current, and the motors'
#: gpio of each arm joint (the URDF's <gpio name="dxlN">, IDs 11-14)
PRESENT_CURRENT = "Present Current"
GPIO = {"joint1": "dxl1", "joint2": "dxl2", "joint3": "dxl3", "joint4": "dxl4"}


def gravity_torques(positions: dict[str, float]) -> dict[str, float]:
    """N m each arm joint needs to hold the arm still at ``positions``, by MuJoCo alone."""
    model = mujoco.MjModel.from_xml_string(urdf_text())
    data = mujoco.MjData(model)
    for joint, value in positions.items():
        data.qpos[model.joint(joint).qposadr[0]] = value
    mujoco.mj_forward(model, data)
    return {j: float(data.qfrc_bias[model.joint(j).dofadr[0]]) for j in ARM}


def test_a_goal_from_another_process_moves_the_arm_and_its_current_holds_gravity() -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    run = [*SERVOLAB, "control", "run", NAME, "--world", "robot", "--listen", endpoint,
           "--spawn", "joint_state_broadcaster", "arm_controller", "gripper_controller"]
    with started(run, stderr_to_stdout=True) as manager:
        wait_for_line(manager, "running; Ctrl-C stops it", timeout=60)
        goal = servolab(
            "action", "send_goal", "/arm_controller/follow_joint_trajectory",
            "control_msgs/action/FollowJointTrajectory",
            "{trajectory: {joint_names: [joint1, joint2, joint3, joint4], points: ["
            "{positions: [0.2, -0.3, 0.2, 0.3], time_from_start: {sec: 1}}, "
            f"{{positions: {list(POSE)}, time_from_start: {{sec: 2}}}}]}}}}",
            "--connect", endpoint, timeout=90)
        assert "Goal finished with status: SUCCEEDED" in goal.stdout, goal.stdout + goal.stderr
        assert "error_string: Goal successfully reached!" in goal.stdout
        with Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
            states: list[Any] = []
            dynamic: list[Any] = []
            probe = Node(ctx, "probe")
            probe.create_subscription("sensor_msgs/msg/JointState", "/joint_states",
                                      states.append, 10)
            probe.create_subscription("control_msgs/msg/DynamicJointState",
                                      "/dynamic_joint_states", dynamic.append, 10)
            assert ctx.spin_until(lambda: len(states) >= 5 and len(dynamic) >= 5,
                                  timeout=30.0), "no joint states from the arm"
        last = states[-1]
        at = dict(zip(last.name, last.position, strict=True))
        effort = dict(zip(last.name, last.effort, strict=True))
        for joint, wanted in zip(ARM, POSE, strict=True):
            assert at[joint] == pytest.approx(wanted, abs=GOAL_TOLERANCE), joint
        gravity = gravity_torques({j: at[j] for j in ARM})
        interfaces = dynamic[-1].interface_values
        gpio = dict(zip(dynamic[-1].joint_names, interfaces, strict=True))
        for joint in ARM:
            held = gpio[GPIO[joint]]
            current = dict(zip(held.interface_names, held.values, strict=True))[
                PRESENT_CURRENT]
            # what the motor says it pulls, as torque, is what holds the arm up
            assert current * EFFORT_UNIT == pytest.approx(gravity[joint], rel=0.1,
                                                          abs=2 * EFFORT_UNIT), joint
            assert effort[joint] == pytest.approx(gravity[joint], rel=0.1,
                                                  abs=2 * EFFORT_UNIT), joint
        for joint in ("joint2", "joint3"):
            assert abs(gravity[joint]) > 20 * EFFORT_UNIT, f"{joint}: gravity loads it"
        manager.send_signal(signal.SIGINT)
        said, _ = manager.communicate(timeout=60)
        assert manager.returncode == 128 + signal.SIGINT, said
