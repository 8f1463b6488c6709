"""The minimal action server and client of ros2/examples (``rclpy/actions/
minimal_action_server`` and ``minimal_action_client``), restated here with their structure and
every rclpy call they make, run as two processes with only their imports changed: servolab
against servolab over Zenoh and over DDS, and the same text under the real rclpy (Fast DDS)
as its oracle.

What the examples do: the server accepts every goal and every cancel, and runs an ``async``
execute callback under a multi-threaded executor that publishes the growing sequence as
feedback and succeeds; the client waits for the server, sends ``order=10`` with a feedback
callback, asks for the result from the goal-response callback, logs it and shuts rclpy down
from the result callback. The originals sleep a second per step; here a tenth.
"""

from __future__ import annotations

import os
import re
import sys

import pytest

from tests.middleware.conftest import free_port
from tests.processes import started
from tests.rosoracle import free_domain_id, ros_env, ros_python
from tests.waiting import wait_for_line

pytestmark = [pytest.mark.slow, pytest.mark.realtime]

SERVER = """
import time

from {msgs}{package}.action import Fibonacci

import {rclpy} as rclpy
from {rclpy}.action import ActionServer, CancelResponse, GoalResponse
from {rclpy}.callback_groups import ReentrantCallbackGroup
from {rclpy}.executors import MultiThreadedExecutor
from {rclpy}.node import Node


class MinimalActionServer(Node):

    def __init__(self):
        super().__init__('minimal_action_server')
        self._action_server = ActionServer(
            self, Fibonacci, 'fibonacci',
            execute_callback=self.execute_callback,
            callback_group=ReentrantCallbackGroup(),
            goal_callback=self.goal_callback,
            cancel_callback=self.cancel_callback)

    def destroy(self):
        self._action_server.destroy()
        super().destroy_node()

    def goal_callback(self, goal_request):
        self.get_logger().info('Received goal request')
        return GoalResponse.ACCEPT

    def cancel_callback(self, goal_handle):
        self.get_logger().info('Received cancel request')
        return CancelResponse.ACCEPT

    async def execute_callback(self, goal_handle):
        self.get_logger().info('Executing goal...')
        feedback_msg = Fibonacci.Feedback()
        feedback_msg.sequence = [0, 1]
        for i in range(1, goal_handle.request.order):
            if goal_handle.is_cancel_requested:
                goal_handle.canceled()
                self.get_logger().info('Goal canceled')
                return Fibonacci.Result()
            feedback_msg.sequence.append(feedback_msg.sequence[i] + feedback_msg.sequence[i-1])
            self.get_logger().info('Publishing feedback: {{0}}'.format(feedback_msg.sequence))
            goal_handle.publish_feedback(feedback_msg)
            time.sleep(0.1)
        goal_handle.succeed()
        result = Fibonacci.Result()
        result.sequence = feedback_msg.sequence
        self.get_logger().info('Returning result: {{0}}'.format(result.sequence))
        return result


def main(args=None):
    rclpy.init(args=args)
    minimal_action_server = MinimalActionServer()
    executor = MultiThreadedExecutor()
    print('ready', flush=True)
    rclpy.spin(minimal_action_server, executor=executor)
    minimal_action_server.destroy()
    rclpy.shutdown()


main()
"""

CLIENT = """
from action_msgs.msg import GoalStatus
from {msgs}{package}.action import Fibonacci

import {rclpy} as rclpy
from {rclpy}.action import ActionClient
from {rclpy}.node import Node


class MinimalActionClient(Node):

    def __init__(self):
        super().__init__('minimal_action_client')
        self._action_client = ActionClient(self, Fibonacci, 'fibonacci')

    def goal_response_callback(self, future):
        goal_handle = future.result()
        if not goal_handle.accepted:
            self.get_logger().info('Goal rejected :(')
            return
        self.get_logger().info('Goal accepted :)')
        self._get_result_future = goal_handle.get_result_async()
        self._get_result_future.add_done_callback(self.get_result_callback)

    def feedback_callback(self, feedback):
        print('feedback', [int(v) for v in feedback.feedback.sequence], flush=True)

    def get_result_callback(self, future):
        result = future.result().result
        status = future.result().status
        if status == GoalStatus.STATUS_SUCCEEDED:
            print('succeeded', [int(v) for v in result.sequence], flush=True)
        else:
            print('failed with status', status, flush=True)
        rclpy.shutdown()

    def send_goal(self):
        self.get_logger().info('Waiting for action server...')
        self._action_client.wait_for_server()
        goal_msg = Fibonacci.Goal()
        goal_msg.order = 10
        self.get_logger().info('Sending goal request...')
        self._send_goal_future = self._action_client.send_goal_async(
            goal_msg, feedback_callback=self.feedback_callback)
        self._send_goal_future.add_done_callback(self.goal_response_callback)


def main(args=None):
    rclpy.init(args=args)
    action_client = MinimalActionClient()
    action_client.send_goal()
    rclpy.spin(action_client)


main()
"""

FIBONACCI_10 = [0, 1, 1, 2, 3, 5, 8, 13, 21, 34, 55]


def run_pair(python: str, names: dict[str, str], server_env: dict[str, str],
             client_env: dict[str, str]) -> list[str]:
    client_code = CLIENT.format(**names)
    if names["msgs"]:  # servolab's action_msgs too
        client_code = client_code.replace("from action_msgs", f"from {names['msgs']}action_msgs")
    with started([python, "-c", SERVER.format(**names)], env=server_env) as server:
        wait_for_line(server, "ready", timeout=60)
        with started([python, "-c", client_code], env=client_env) as client:
            out, _ = client.communicate(timeout=120)
            assert client.returncode == 0, out
    return out.splitlines()


def check(lines: list[str]) -> None:
    assert lines[-1] == f"succeeded {FIBONACCI_10}", lines
    feedback = [line for line in lines if line.startswith("feedback")]
    # each step's sequence, in order (feedback is reliable, depth 10, and none is late)
    assert feedback == [f"feedback {FIBONACCI_10[:n]}" for n in range(3, 12)], lines


SERVOLAB = {"rclpy": "servolab.rclpy", "msgs": "servolab.interfaces.",
            "package": "example_interfaces"}


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("SERVOLAB_", "ROS_"))}
    return {**env, "PYTHONUNBUFFERED": "1", **extra}


def test_the_minimal_examples_over_zenoh() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    check(run_pair(sys.executable, SERVOLAB,
                   _env(SERVOLAB_TRANSPORT="zenoh", SERVOLAB_LISTEN=endpoint),
                   _env(SERVOLAB_TRANSPORT="zenoh", SERVOLAB_CONNECT=endpoint)))


def test_the_minimal_examples_over_dds() -> None:
    ros_python()  # the domain is chosen as the oracle's are (tests/rosoracle.py)
    domain = str(free_domain_id())
    env = _env(SERVOLAB_TRANSPORT="dds", ROS_DOMAIN_ID=domain,
               ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    check(run_pair(sys.executable, SERVOLAB, env, env))


def test_the_same_text_under_the_real_rclpy() -> None:
    """The oracle: the restated examples, as rclpy runs them (test_msgs' Fibonacci, the same
    fields as example_interfaces', which is not on the package index)."""
    env = ros_env(free_domain_id())
    lines = run_pair(str(ros_python()), {"rclpy": "rclpy", "msgs": "", "package": "test_msgs"},
                     env, env)
    check(lines)
    assert not any(re.search(r"Traceback|Error", line) for line in lines)
