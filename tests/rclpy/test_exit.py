"""A program that never shuts rclpy down still ends (issue 32, D2).

rclpy's own programs often end without ``rclpy.shutdown()`` (the context is closed at exit).
Over Zenoh, servolab's default context used to keep such a program alive for ever: ``atexit``
handlers run only after Python has waited for the other threads, and the open context's
threads never end. Each case fails by timing out (the process is then killed), not by a
measured duration.
"""

from __future__ import annotations

import os
import sys

import pytest

from tests.processes import run_to_end
from tests.rosoracle import free_domain_id

PROGRAM = """
from servolab import rclpy
from servolab.interfaces.std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("never_shut_down")
node.create_publisher(String, "chatter", 10).publish(String(data="hi"))
node.create_subscription(String, "chatter", lambda m: None, 10)
node.create_timer(0.1, lambda: None)
rclpy.spin_once(node, timeout_sec=0.2)
print("main ends", flush=True)
"""


@pytest.mark.parametrize("transport", ["local", "zenoh", "dds"])
def test_a_program_that_never_shuts_down_ends(transport: str) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SERVOLAB_", "ROS_"))}
    env.update({"SERVOLAB_TRANSPORT": transport, "SERVOLAB_ZENOH_ROUTER": "",
                "ROS_DOMAIN_ID": str(free_domain_id()),
                "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    done = run_to_end([sys.executable, "-c", PROGRAM], timeout=60, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["main ends"]
