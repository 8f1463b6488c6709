"""Ctrl-C in ``servolab action send_goal`` cancels an accepted goal wherever it lands, as
ros2action's ``send_goal`` (Jazzy, ``verb/send_goal.py``) cancels on KeyboardInterrupt. A
clean-clone run once had the interrupt land while a feedback held back until the acceptance was
printed, outside the cancel's ``try``: the client stopped and the goal ran on. In one process on
the in-process transport, with the interrupt raised by the printing itself, so the test is
deterministic."""

from __future__ import annotations

import threading
from typing import Any

import pytest

from servolab.apps.action import send_goal_message
from servolab.middleware.context import Context
from servolab.rclpy.action import ActionClient, ActionServer, CancelResponse
from servolab.rclpy.action.server import STATUS_CANCELED
from servolab.rclpy.node import Node
from servolab.rclpy.task import Future

FIBONACCI = "test_msgs/action/Fibonacci"


class Server:
    """Publishes feedback from a thread of its own until the goal is canceled (or 30 s pass:
    then the test fails). Its execute callback returns a future, so the one executor the
    client spins is not held while the goal runs."""

    def __init__(self, context: Context) -> None:
        self.node = Node(context, "fibonacci_server")
        self.canceled = threading.Event()
        self.threads: list[threading.Thread] = []
        self.server = ActionServer(self.node, FIBONACCI, "fibonacci", self.execute,
                                   cancel_callback=lambda _goal: CancelResponse.ACCEPT)

    def execute(self, goal: Any) -> Future:
        done = Future()
        thread = threading.Thread(target=self.run, args=(goal, done), daemon=True)
        self.threads.append(thread)
        thread.start()
        return done

    def run(self, goal: Any, done: Future) -> None:
        feedback = self.node.message(f"{FIBONACCI}_Feedback", sequence=[0, 1])
        for _ in range(3000):
            if goal.is_cancel_requested:
                goal.canceled()
                self.canceled.set()
                break
            goal.publish_feedback(feedback)
            self.canceled.wait(0.01)
        else:
            goal.abort()
        done.set_result(self.node.message(f"{FIBONACCI}_Result"))


@pytest.mark.parametrize("interrupted_at", ["Goal accepted", "Feedback:"])
def test_ctrl_c_at_any_line_after_acceptance_cancels_the_goal(
        interrupted_at: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The feedback is made to come before the acceptance is printed, every time: the goal's
    answer is handed back only once two feedbacks have reached the client, so they are held
    back and printed after the acceptance line, where the CI run's interrupt landed."""
    printed: list[str] = []
    delivered: list[Any] = []

    def say(line: str) -> None:
        printed.append(line)
        if line.startswith(interrupted_at) and not any(
                p.startswith(interrupted_at) for p in printed[:-1]):
            raise KeyboardInterrupt

    send_goal_async, wait = ActionClient.send_goal_async, ActionClient._wait

    def counted_send_goal_async(self: ActionClient, goal: Any,
                                feedback_callback: Any = None) -> Future:
        def counted(message: Any) -> None:
            delivered.append(message)
            feedback_callback(message)
        return send_goal_async(self, goal, counted if feedback_callback else None)

    def held_wait(self: ActionClient, future: Future) -> Any:
        printed.append("<waiting>")
        result = wait(self, future)
        if printed.count("<waiting>") == 1:  # the goal's answer: feedback first
            assert self._node.context.executor.spin_until(lambda: len(delivered) >= 2, 30)
        return result

    monkeypatch.setattr(ActionClient, "send_goal_async", counted_send_goal_async)
    monkeypatch.setattr(ActionClient, "_wait", held_wait)
    with Context.open() as ctx:
        server = Server(ctx)
        goal = server.node.message(f"{FIBONACCI}_Goal", order=40)
        try:
            status = send_goal_message(ctx, "/fibonacci", FIBONACCI, goal, say,
                                       feedback=True, timeout=30.0)
        except KeyboardInterrupt:  # not let out: it would stop the whole suite
            server.canceled.set()
            pytest.fail(f"the interrupt at {interrupted_at!r} stopped the client without "
                        f"canceling the goal; printed {printed}")
        for thread in server.threads:
            thread.join(timeout=30)
    assert server.canceled.is_set(), printed
    assert printed[-2:] == ["Canceling goal...", "Goal canceled."], printed
    assert status == STATUS_CANCELED
    # the held-back feedback printed straight after the acceptance, before the result's wait
    accepted = next(i for i, line in enumerate(printed) if line.startswith("Goal accepted"))
    if interrupted_at == "Feedback:":
        assert printed[accepted + 1].startswith("Feedback:"), printed
    assert printed.count("<waiting>") == 1, printed  # interrupted before the result's wait


def test_ctrl_c_after_the_goal_ended_cancels_nothing() -> None:
    """ros2action's send_goal cancels only a goal still ACCEPTED or EXECUTING (ros2cli,
    ros2action/verb/send_goal.py): the interrupt after the end keeps the end."""
    from servolab.apps.action import _cancel

    class Ended:
        status = 4  # SUCCEEDED

        def cancel_goal_async(self) -> Future:
            raise AssertionError("a cancel was sent for a goal that had ended")

    printed: list[str] = []
    assert _cancel(None, Ended(), printed.append) == 4
    assert printed == []
