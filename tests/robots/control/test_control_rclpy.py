"""A servolab controller manager seen by the real ROS 2 Jazzy rclpy on Fast DDS (the oracle of
tests/rosoracle.py), as a stock ROS 2 on the lab's network sees it: ``servolab control run``
on DDS in its own process; a real rclpy program commands the position group with
``std_msgs/Float64MultiArray`` and reads the joints back from ``/joint_states``
(``sensor_msgs/JointState``), and finds the controller manager's node and its
``controller_manager_msgs`` services in the ROS graph under ros2_control's names. (The service
types themselves are not in the package index's ROS wheels, so the oracle lists them rather
than calling them; servolab's own verbs call them in test_control_cli.py.)"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.clirun import SERVOLAB
from tests.processes import started
from tests.rosoracle import free_domain_id, ros_env, ros_python
from tests.waiting import wait_for_line

from .conftest import CONTROLLERS, TWO_JOINT

pytestmark = [pytest.mark.slow, pytest.mark.realtime]

ROS_PROGRAM = """
import json, time
import rclpy
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
rclpy.init()
node = rclpy.create_node("ros_user")
states = []
node.create_subscription(JointState, "/joint_states", states.append, 10)
commands = node.create_publisher(Float64MultiArray, "/forward_position_controller/commands", 10)
end = time.monotonic() + 60
while commands.get_subscription_count() == 0 and time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
goal = [0.5, -0.3]
while time.monotonic() < end:
    commands.publish(Float64MultiArray(data=goal))
    rclpy.spin_once(node, timeout_sec=0.1)
    if states and all(abs(p - g) < 0.01 for p, g in zip(states[-1].position, goal)):
        break
last = states[-1] if states else None
print(json.dumps({
    "names": list(last.name) if last else [],
    "positions": list(last.position) if last else [],
    "nodes": [list(n) for n in node.get_node_names_and_namespaces()],
    "services": {n: t for n, t in node.get_service_names_and_types()
                 if n.startswith("/controller_manager/")},
}), flush=True)
"""


def test_a_real_rclpy_program_moves_the_joints_and_sees_the_controller_manager(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ros_python()  # skips, saying why, where the real rclpy is not installed
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    domain = free_domain_id()
    run = [*SERVOLAB, "control", "run", str(TWO_JOINT), "--params", str(CONTROLLERS),
           "--transport", "dds", "--domain-id", str(domain),
           "--spawn", "joint_state_broadcaster", "forward_position_controller"]
    with started(run, stderr_to_stdout=True) as manager:
        wait_for_line(manager, "running; Ctrl-C stops it", timeout=60)
        with started([str(ros_python()), "-c", ROS_PROGRAM], env=ros_env(domain)) as ros:
            out, _ = ros.communicate(timeout=120)
    seen = json.loads(out.strip().splitlines()[-1])
    assert seen["names"] == ["joint1", "joint2"], seen
    assert seen["positions"] == pytest.approx([0.5, -0.3], abs=0.01), seen["positions"]
    assert ["controller_manager", "/"] in seen["nodes"], seen["nodes"]
    # controller_manager.cpp's services, with controller_manager_msgs' types
    for service, kind in (("list_controllers", "ListControllers"),
                          ("switch_controller", "SwitchController"),
                          ("load_controller", "LoadController"),
                          ("list_hardware_interfaces", "ListHardwareInterfaces"),
                          ("set_hardware_component_state", "SetHardwareComponentState")):
        assert seen["services"].get(f"/controller_manager/{service}") == [
            f"controller_manager_msgs/srv/{kind}"], sorted(seen["services"])
