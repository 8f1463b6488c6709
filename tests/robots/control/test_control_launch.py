"""configs/waffle_control.launch.yaml: ros2_control as a launch runs it, the controller
manager and the spawners each a process over Zenoh (turtlebot3_bringup's robot.launch.py
shape): the spawners activate the controllers, ``cmd_vel`` from another process drives the
base on its floor, and Ctrl-C on the launch stops every process it started."""

from __future__ import annotations

import signal
from pathlib import Path
from typing import Any

import pytest

from tests.clirun import launched, servolab
from tests.waiting import wait_for

ROOT = Path(__file__).resolve().parents[3]

pytestmark = pytest.mark.slow


def test_the_waffle_launch_spawns_its_controllers_and_drives() -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    with launched(ROOT / "configs" / "waffle_control.launch.yaml") as (launch, endpoint):
        connect = ["--connect", endpoint]

        def listed() -> dict[str, str]:
            out = servolab("control", "list_controllers", *connect, timeout=60).stdout
            return {line.split()[0]: line.split()[-1] for line in out.splitlines() if line}

        wait_for(lambda: listed() == {"joint_state_broadcaster": "active",
                                      "diff_drive_controller": "active"},
                 lambda: f"both controllers active; listed {listed()}", timeout=60, step=0.5)
        with Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
            odom: list[Any] = []
            Node(ctx, "probe").create_subscription(
                "nav_msgs/msg/Odometry", "/diff_drive_controller/odom", odom.append, 10)
            pub = servolab("topic", "pub", "/diff_drive_controller/cmd_vel",
                           "geometry_msgs/msg/TwistStamped", "{twist: {linear: {x: 0.1}}}",
                           "--rate", "10", "--count", "20", *connect, timeout=60)
            assert pub.returncode == 0, pub.stderr
            assert ctx.spin_until(lambda: bool(odom) and
                                  odom[-1].pose.pose.position.x > 0.05, timeout=30.0), \
                odom[-1:] or "no odometry"
        launch.send_signal(signal.SIGINT)
        said, _ = launch.communicate(timeout=60)
        assert launch.returncode == 128 + signal.SIGINT, said
