"""servolab's actions (``servolab.rclpy.action``) against the real thing: ROS 2 Jazzy's rclpy
on Fast DDS, from the package index (``tests/rosoracle.py``).

One Fibonacci server and one client program are written once, for rclpy's API, and run with
their imports pointing at the real rclpy or at servolab's (``from rclpy.action import ...``
or ``from servolab.rclpy.action import ...``): everything else is the same text. The oracle
is the pair real client -> real server; servolab's server must give the real client the same
transcript (feedback, results, a rejected goal, two goals at once, a cancel and a cancel of a
goal that ended), and servolab's client must get from the real server the same transcript
the real client gets. servolab runs on the oracle's ROS 2 through ``--transport ros2``
(a Fast DDS client cannot be answered by servolab's Cyclone DDS transport:
``test_dds_rclpy.py``); its client also runs on servolab's DDS transport.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.processes import started
from tests.rosoracle import free_domain_id, ros_env, ros_python, servolab_on_ros_env
from tests.waiting import wait_for_line

pytestmark = [pytest.mark.slow, pytest.mark.realtime]

REAL = {"rclpy": "rclpy", "msgs": ""}
SERVOLAB = {"rclpy": "servolab.rclpy", "msgs": "servolab.interfaces."}

SERVER = """
import time
import {rclpy} as rclpy
from {rclpy}.action import ActionServer, CancelResponse, GoalResponse
from {rclpy}.callback_groups import ReentrantCallbackGroup
from {rclpy}.executors import MultiThreadedExecutor
from {rclpy}.node import Node
from {msgs}test_msgs.action import Fibonacci


class FibonacciServer(Node):
    def __init__(self):
        super().__init__("fibonacci_server")
        self._server = ActionServer(self, Fibonacci, "fibonacci", self.execute,
                                    callback_group=ReentrantCallbackGroup(),
                                    goal_callback=self.on_goal, cancel_callback=self.on_cancel)

    def on_goal(self, goal):
        # int32 holds Fibonacci numbers up to the 46th
        return GoalResponse.REJECT if goal.order > 46 else GoalResponse.ACCEPT

    def on_cancel(self, goal_handle):
        return CancelResponse.ACCEPT

    def execute(self, goal_handle):
        feedback = Fibonacci.Feedback()
        feedback.sequence = [0, 1]
        for i in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                return Fibonacci.Result(sequence=feedback.sequence)
            feedback.sequence.append(feedback.sequence[i] + feedback.sequence[i - 1])
            goal_handle.publish_feedback(feedback)
            time.sleep(0.1)
        goal_handle.succeed()
        result = Fibonacci.Result()
        result.sequence = feedback.sequence
        return result


rclpy.init()
node = FibonacciServer()
print("ready", flush=True)
rclpy.spin(node, executor=MultiThreadedExecutor(num_threads=4))
"""

CLIENT = """
import {rclpy} as rclpy
from {rclpy}.action import ActionClient
from {msgs}action_msgs.msg import GoalStatus
from {msgs}test_msgs.action import Fibonacci

rclpy.init()
node = rclpy.create_node("fibonacci_client")
client = ActionClient(node, Fibonacci, "fibonacci")
print("server", client.wait_for_server(timeout_sec=30.0), flush=True)
order = []


def ints(values):
    return [int(v) for v in values]


def wait(future):
    rclpy.spin_until_future_complete(node, future, timeout_sec=30.0)
    assert future.done(), "no answer"
    return future.result()


def send(goal_order, tag):
    def feedback(message):
        order.append((tag, ints(message.feedback.sequence)))
    return client.send_goal_async(Fibonacci.Goal(order=goal_order), feedback_callback=feedback)


handle = wait(send(5, "a"))
print("accepted", handle.accepted, flush=True)
answer = wait(handle.get_result_async())
print("result", answer.status == GoalStatus.STATUS_SUCCEEDED, ints(answer.result.sequence))
print("feedback", [seq for tag, seq in order if tag == "a"], flush=True)

print("too long accepted", wait(send(100, "x")).accepted, flush=True)

order.clear()
first, second = wait(send(4, "b")), wait(send(6, "c"))
results = [wait(h.get_result_async()) for h in (first, second)]
print("both", [(r.status, ints(r.result.sequence)) for r in results], flush=True)
tags = [tag for tag, _ in order]
print("at once", tags.index("c") < len(tags) - 1 - tags[::-1].index("b"), flush=True)

order.clear()
long_goal = wait(send(40, "d"))
while not order:
    rclpy.spin_once(node, timeout_sec=0.1)
cancel = wait(long_goal.cancel_goal_async())
print("cancel", cancel.return_code, len(cancel.goals_canceling), flush=True)
ended = wait(long_goal.get_result_async())
print("canceled", ended.status == GoalStatus.STATUS_CANCELED, len(ended.result.sequence) < 41,
      flush=True)
again = wait(long_goal.cancel_goal_async())
print("cancel again", again.return_code, len(again.goals_canceling), flush=True)
"""


@pytest.fixture
def domain() -> int:
    ros_python()  # skips, saying why, where the real rclpy is not installed
    return free_domain_id()


def transcript(server: list[str], server_env: dict[str, str], client: list[str],
               client_env: dict[str, str]) -> list[str]:
    with started(server, env=server_env) as process:
        wait_for_line(process, "ready", timeout=60)
        out = subprocess.run(client, env=client_env, capture_output=True, text=True,
                             timeout=180, check=False)
    assert out.returncode == 0, out.stderr
    return out.stdout.splitlines()


def real(code: str) -> list[str]:
    return [str(ros_python()), "-c", code.format(**REAL)]


def ours(code: str) -> list[str]:
    return [sys.executable, "-c", code.format(**SERVOLAB)]


EXPECTED_START = ["server True", "accepted True", "result True [0, 1, 1, 2, 3, 5]",
                  "feedback [[0, 1, 1], [0, 1, 1, 2], [0, 1, 1, 2, 3], [0, 1, 1, 2, 3, 5]]",
                  "too long accepted False"]


@pytest.fixture(scope="module")
def oracle() -> list[str]:
    """The real client's transcript against the real server, once for the module (in a
    domain of its own)."""
    ros_python()  # skips, saying why, where the real rclpy is not installed
    domain = free_domain_id()
    lines = transcript(real(SERVER), ros_env(domain), real(CLIENT), ros_env(domain))
    assert lines[:5] == EXPECTED_START
    return lines


def test_a_real_action_client_gets_from_servolab_what_a_real_server_gives(
        domain: int, oracle: list[str]) -> None:
    """Feedback, result, a rejected goal, two goals at once, a cancel (ERROR_NONE, one goal
    canceling, the goal CANCELED) and a second cancel of the ended goal: the same lines."""
    ours_ = transcript(ours(SERVER), servolab_on_ros_env(domain), real(CLIENT), ros_env(domain))
    assert ours_ == oracle


@pytest.mark.parametrize("transport", ["ros2", "dds"])
def test_a_servolab_action_client_gets_from_a_real_server_what_a_real_client_gets(
        domain: int, oracle: list[str], transport: str) -> None:
    env = servolab_on_ros_env(domain) if transport == "ros2" else \
        {**ros_env(domain), "SERVOLAB_TRANSPORT": "dds"}
    ours_ = transcript(real(SERVER), ros_env(domain), ours(CLIENT), env)
    assert ours_ == oracle
