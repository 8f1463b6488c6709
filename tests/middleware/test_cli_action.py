"""``servolab action list / info / send_goal``, as a user runs them: separate OS processes over
Zenoh on loopback, against a Fibonacci action server in its own process. The printed forms
are ros2action's (Jazzy: ``verb/list.py``, ``verb/info.py``, ``verb/send_goal.py``):
``Action clients: N`` / ``Action servers: N`` with the nodes indented, and ``Sending goal:``,
``Goal accepted with ID:``, ``Feedback:``, ``Result:``, ``Goal finished with status:``, and
on Ctrl-C ``Canceling goal...`` then ``Goal canceled.``."""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator

import pytest

from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

#: realtime too: a server and a client process beside pytest, in real time
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

SERVER = """
import os, sys, time
os.environ.update(SERVOLAB_TRANSPORT="zenoh", SERVOLAB_LISTEN=sys.argv[1])
from servolab import rclpy
from servolab.rclpy.action import ActionServer, CancelResponse
from servolab.rclpy.callback_groups import ReentrantCallbackGroup
from servolab.rclpy.executors import MultiThreadedExecutor
from servolab.interfaces.test_msgs.action import Fibonacci

rclpy.init()
node = rclpy.create_node("fibonacci_server")

def execute(goal):
    sequence = [0, 1]
    for i in range(1, goal.request.order):
        if goal.is_cancel_requested:
            goal.canceled()
            print("canceled", flush=True)
            return Fibonacci.Result(sequence=sequence)
        sequence.append(sequence[i] + sequence[i - 1])
        goal.publish_feedback(Fibonacci.Feedback(sequence=sequence))
        time.sleep(float(sys.argv[2]))
    goal.succeed()
    return Fibonacci.Result(sequence=sequence)

ActionServer(node, Fibonacci, sys.argv[3], execute, callback_group=ReentrantCallbackGroup(),
             cancel_callback=lambda goal: CancelResponse.ACCEPT)
print("ready", flush=True)
rclpy.spin(node, executor=MultiThreadedExecutor(num_threads=3))
"""


@pytest.fixture(scope="module")
def server() -> Iterator[str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", SERVER, endpoint, "0.05", "/fibonacci"]) as proc:
        wait_for_line(proc, "ready", timeout=30.0)
        yield endpoint


def test_list_and_info_show_the_action_its_type_and_server(server: str) -> None:
    listing = servolab("action", "list", "-t", "--connect", server, timeout=60)
    assert listing.returncode == 0, listing.stderr
    assert listing.stdout.splitlines() == ["/fibonacci [test_msgs/action/Fibonacci]"]
    info = servolab("action", "info", "/fibonacci", "--connect", server, timeout=60)
    assert info.returncode == 0, info.stderr
    assert info.stdout.splitlines() == ["Action: /fibonacci", "Action clients: 0",
                                        "Action servers: 1", "    /fibonacci_server"]
    topics = servolab("topic", "list", "--connect", server, timeout=60)
    assert not any("_action" in line for line in topics.stdout.splitlines()), topics.stdout


def test_send_goal_prints_feedback_result_and_status(server: str) -> None:
    out = servolab("action", "send_goal", "/fibonacci", "test_msgs/action/Fibonacci",
                   "{order: 4}", "--feedback", "--connect", server, timeout=60)
    assert out.returncode == 0, out.stderr
    text = out.stdout
    assert text.startswith("Waiting for an action server to become available...\n"
                           "Sending goal:\n     order: 4\n\nGoal accepted with ID: ")
    # three feedbacks were sent; the first may go before the client's feedback subscription
    # is matched (a client waits for the services only, as rclpy's wait_for_server does)
    assert 1 <= text.count("Feedback:\n    sequence:\n") <= 3
    last = text.rsplit("Feedback:\n    sequence:\n", 1)[1]
    assert last.startswith("- 0\n- 1\n- 1\n- 2\n- 3\n\nResult:")
    assert text.endswith("Result:\n    sequence:\n- 0\n- 1\n- 1\n- 2\n- 3\n\n"
                         "Goal finished with status: SUCCEEDED\n")


def test_bad_goals_are_refused_before_the_graph_is_joined() -> None:
    for args, message in (
            (["/fibonacci", "test_msgs/action/Fibonaci", "{order: 4}"],
             "unknown action type 'test_msgs/action/Fibonaci'"),
            (["/fibonacci", "test_msgs/action/Fibonacci", "{orders: 4}"],
             "goal of test_msgs/action/Fibonacci: orders: the goal has no field 'orders'")):
        out = servolab("action", "send_goal", *args, "--connect",
                       f"tcp/127.0.0.1:{free_port()}", timeout=60)
        assert out.returncode == 2
        assert message in out.stderr and out.stderr.count("\n") == 1, out.stderr


def test_ctrl_c_cancels_the_goal() -> None:
    """(Its own action name: Zenoh peers on loopback find each other through the one they
    connect to, so the module's server, if it runs, would serve "/fibonacci" too. A step a
    second: the goal runs 40 s, so a busy machine's slow client still cancels it before it
    ends, and the cancel ends it within a step.)"""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", SERVER, endpoint, "1.0", "/slow_fibonacci"]) as proc:
        wait_for_line(proc, "ready", timeout=30.0)
        with started([*SERVOLAB, "action", "send_goal", "/slow_fibonacci",
                      "test_msgs/action/Fibonacci", "{order: 40}", "--feedback", "--connect",
                      endpoint]) as client:
            wait_for_line(client, "Feedback:", timeout=60.0)
            client.send_signal(signal.SIGINT)
            out, err = client.communicate(timeout=60)
        try:   # seen once in a clean-clone run on a loaded machine: say what the client said
            wait_for_line(proc, "canceled", timeout=30.0)
        except AssertionError as exc:
            raise AssertionError(f"{exc}; the client exited {client.returncode} saying "
                                 f"{out[-500:]!r} {err[-500:]!r}") from None
    assert client.returncode == 0, err
    assert "Canceling goal...\nGoal canceled.\n" in out
