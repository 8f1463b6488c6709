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


CONTEXT_PROGRAM = """
import threading
from servolab.middleware.context import Context
from servolab.middleware.default_context import options_from_environment
from servolab.middleware.node import Node
ctx = Context.open(options_from_environment())
node = Node(ctx, "never_closed")
node.create_subscription("std_msgs/msg/String", "chatter", lambda m: None)
worker = threading.Thread(target=lambda: (ctx.spin_once(0.3), print("worker ends", flush=True)))
worker.start()
print("main ends", flush=True)
"""


@pytest.mark.parametrize("program", [PROGRAM, CONTEXT_PROGRAM], ids=["rclpy", "context"])
@pytest.mark.parametrize("transport", ["local", "zenoh", "dds"])
def test_a_program_that_never_shuts_down_ends(transport: str, program: str) -> None:
    """With rclpy's default context, and with a Context of its own (whose node a
    non-daemon thread of the program still spins when the main thread ends: it finishes
    first)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SERVOLAB_", "ROS_"))}
    env.update({"SERVOLAB_TRANSPORT": transport, "SERVOLAB_ZENOH_ROUTER": "",
                "ROS_DOMAIN_ID": str(free_domain_id()),
                "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    done = run_to_end([sys.executable, "-c", program], timeout=60, env=env)
    assert done.returncode == 0, done.stderr
    wanted = ["main ends"] if program is PROGRAM else ["main ends", "worker ends"]
    assert done.stdout.splitlines() == wanted
