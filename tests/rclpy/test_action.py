"""Actions in one process, on the in-process transport (the default): rcl_action's cancel
policy and return codes (``rcl_action_process_cancel_request``, checked against the real
rcl_action in review; action_msgs/srv/CancelGoal's constants), results kept
``result_timeout`` s, a server destroyed while a goal runs, an execute callback that raises,
goals run outside the callback group as rclpy's ``create_task`` runs them, and feedback
published from one list that grows (each message its own copy, as rclpy's value semantics
give it). The real rclpy's behaviour over the wire is ``tests/middleware/test_actions_rclpy.py``."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest

from servolab.middleware.context import Context
from servolab.rclpy.action import ActionClient, ActionServer, CancelResponse
from servolab.rclpy.action.server import (
    ERROR_GOAL_TERMINATED,
    ERROR_NONE,
    ERROR_UNKNOWN_GOAL_ID,
    STATUS_ABORTED,
    STATUS_CANCELED,
    STATUS_SUCCEEDED,
    STATUS_UNKNOWN,
)
from servolab.rclpy.executors import MultiThreadedExecutor
from servolab.rclpy.node import Node

FIBONACCI = "test_msgs/action/Fibonacci"


class Rig:
    """A Fibonacci server whose goals wait for ``release`` (so they can be canceled while
    they run), and a client, spun by a multi-threaded executor on the nodes' default
    (mutually exclusive) callback groups."""

    def __init__(self, context: Context, *, result_timeout: float = 900.0) -> None:
        self.context = context
        self.release = threading.Event()
        self.finished = threading.Event()  # an execute callback has returned
        self.canceled_asked: list[bytes] = []
        self.server_node = Node(context, "fibonacci_server")
        self.server = ActionServer(self.server_node, FIBONACCI, "fibonacci", self.execute,
                                   cancel_callback=self.on_cancel,
                                   result_timeout=result_timeout)
        self.client = ActionClient(Node(context, "fibonacci_client"), FIBONACCI, "fibonacci")
        self.executor = MultiThreadedExecutor(num_threads=4, context=context)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def execute(self, goal: Any) -> Any:
        try:
            return self._execute(goal)
        finally:
            self.finished.set()

    def _execute(self, goal: Any) -> Any:
        feedback = self.server_node.message(f"{FIBONACCI}_Feedback")
        feedback.sequence = [0, 1]
        for _ in range(goal.request.order - 1):
            feedback.sequence.append(feedback.sequence[-1] + feedback.sequence[-2])
            goal.publish_feedback(feedback)
        while not self.release.wait(0.01):
            if goal.is_cancel_requested:
                goal.canceled()
                return self.server_node.message(f"{FIBONACCI}_Result")
        goal.succeed()
        return self.server_node.message(f"{FIBONACCI}_Result", sequence=feedback.sequence)

    def on_cancel(self, goal: Any) -> CancelResponse:
        self.canceled_asked.append(bytes(bytearray(goal.goal_id.uuid)))
        return CancelResponse.ACCEPT

    @staticmethod
    def wait(future: Any, timeout: float = 10.0) -> Any:
        end = time.monotonic() + timeout
        while not future.done():
            assert time.monotonic() < end, "no answer"
            time.sleep(0.005)
        return future.result()

    def send(self, order: int, feedback: list[Any] | None = None) -> Any:
        callback = None if feedback is None else feedback.append
        return self.wait(self.client.send_goal_async(
            self.server_node.message(f"{FIBONACCI}_Goal", order=order),
            feedback_callback=callback))

    def cancel(self, **goal_info: Any) -> Any:
        return self.wait(self.client._send_cancel(self.server_node.message(
            "action_msgs/srv/CancelGoal_Request", goal_info=goal_info)))


@pytest.fixture
def rig() -> Iterator[Rig]:
    with Context.open() as context:
        r = Rig(context)
        assert r.client.wait_for_server(timeout_sec=5.0)
        yield r
        r.release.set()
        r.executor.shutdown()
        r.thread.join(5.0)


def test_feedback_from_one_growing_list_arrives_as_it_was(rig: Rig) -> None:
    feedback: list[Any] = []
    handle = rig.send(4, feedback)
    rig.release.set()
    result = rig.wait(handle.get_result_async())
    assert result.status == STATUS_SUCCEEDED
    end = time.monotonic() + 10.0
    while len(feedback) < 3:  # each is work for the client's executor, maybe not done yet
        assert time.monotonic() < end, feedback
        time.sleep(0.005)
    assert [list(m.feedback.sequence) for m in feedback] == [[0, 1, 1], [0, 1, 1, 2],
                                                             [0, 1, 1, 2, 3]]


def test_a_goal_is_canceled_while_it_runs_under_the_default_groups(rig: Rig) -> None:
    """The execute callback runs outside the node's mutually exclusive group (rclpy's
    create_task), so the cancel request is served while the goal runs."""
    handle = rig.send(3)
    answer = rig.wait(handle.cancel_goal_async())
    assert (answer.return_code, len(answer.goals_canceling)) == (ERROR_NONE, 1)
    assert rig.wait(handle.get_result_async()).status == STATUS_CANCELED


def test_the_cancel_policy_and_return_codes(rig: Rig) -> None:
    nothing = rig.cancel()  # cancel all, with no goal: nothing to do, no error
    assert (nothing.return_code, len(nothing.goals_canceling)) == (ERROR_NONE, 0)
    unknown = rig.cancel(goal_id={"uuid": list(range(1, 17))})
    assert (unknown.return_code, len(unknown.goals_canceling)) == (ERROR_UNKNOWN_GOAL_ID, 0)
    first, second = rig.send(3), rig.send(3)
    again = rig.wait(first.cancel_goal_async())
    assert (again.return_code, len(again.goals_canceling)) == (ERROR_NONE, 1)
    asked = len(rig.canceled_asked)
    twice = rig.wait(first.cancel_goal_async())  # CANCELING already: not cancelable again
    assert (twice.return_code, len(twice.goals_canceling)) == (ERROR_GOAL_TERMINATED, 0)
    assert len(rig.canceled_asked) == asked  # the cancel callback was not asked again
    # by stamp: every goal accepted at or before it (the second, still executing)
    by_stamp = rig.cancel(stamp=second.stamp)
    assert (by_stamp.return_code, len(by_stamp.goals_canceling)) == (ERROR_NONE, 1)
    assert bytes(bytearray(by_stamp.goals_canceling[0].goal_id.uuid)) == \
        bytes(bytearray(second.goal_id.uuid))
    for handle in (first, second):
        assert rig.wait(handle.get_result_async()).status == STATUS_CANCELED
    ended = rig.wait(first.cancel_goal_async())
    assert (ended.return_code, len(ended.goals_canceling)) == (ERROR_GOAL_TERMINATED, 0)


def test_an_execute_callback_that_raises_aborts_its_goal(rig: Rig) -> None:
    def broken(goal: Any) -> Any:
        raise RuntimeError("the arm hit its limit")

    rig.server._execute_callback = broken
    handle = rig.send(3)
    assert rig.wait(handle.get_result_async()).status == STATUS_ABORTED


def test_results_are_kept_result_timeout_seconds() -> None:
    with Context.open() as context:
        r = Rig(context, result_timeout=0.3)
        try:
            assert r.client.wait_for_server(timeout_sec=5.0)
            r.release.set()
            handle = r.send(2)
            assert r.wait(handle.get_result_async()).status == STATUS_SUCCEEDED
            again = r.wait(r.client._get_result_async(handle))  # still kept
            assert again.status == STATUS_SUCCEEDED
            end = time.monotonic() + 10.0
            while r.wait(r.client._get_result_async(handle)).status != STATUS_UNKNOWN:
                assert time.monotonic() < end, "the result was never forgotten"
                time.sleep(0.05)
        finally:
            r.release.set()
            r.executor.shutdown()
            r.thread.join(5.0)


def test_a_server_destroyed_while_its_goal_runs_stops_the_goal_quietly(rig: Rig) -> None:
    rig.send(3)
    rig.server.destroy()
    rig.release.set()  # the goal ends now: its succeed() must change nothing, raise nothing
    assert rig.finished.wait(10.0)
    rig.executor.shutdown()
    rig.thread.join(5.0)  # the executor ran the goal's end to its last step, and stopped
    assert not rig.thread.is_alive() and rig.executor._errors == []


def test_async_execute_callbacks_await_without_holding_the_executor() -> None:
    """An ``async def`` execute callback that awaits a future is resumed when the future is
    done, as executor work: under one thread, two goals wait at once, and a cancel is served
    meanwhile (a callback that held the thread would serve them one after the other)."""
    from servolab.rclpy.executors import SingleThreadedExecutor
    from servolab.rclpy.task import Future

    with Context.open() as context:
        node = Node(context, "waiting_server")
        waits: list[Future] = []

        async def execute(goal: Any) -> Any:
            waiting = Future(executor=context.executor)
            waits.append(waiting)
            await waiting
            if goal.is_cancel_requested:
                goal.canceled()
            else:
                goal.succeed()
            return node.message(f"{FIBONACCI}_Result", sequence=[goal.request.order])

        ActionServer(node, FIBONACCI, "fibonacci", execute,
                     cancel_callback=lambda _goal: CancelResponse.ACCEPT)
        client = ActionClient(Node(context, "client"), FIBONACCI, "fibonacci")
        executor = SingleThreadedExecutor(context=context)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            handles = []
            for order in (1, 2, 3):
                sent = client.send_goal_async(node.message(f"{FIBONACCI}_Goal", order=order))
                handles.append(Rig.wait(sent))
            end = time.monotonic() + 10.0
            while len(waits) < 3:  # all three wait at once, on one thread
                assert time.monotonic() < end, waits
                time.sleep(0.005)
            canceled = Rig.wait(handles[2].cancel_goal_async())
            assert len(canceled.goals_canceling) == 1
            for waiting in waits:
                threading.Timer(0.05, waiting.set_result, args=(None,)).start()
            results = [Rig.wait(h.get_result_async()) for h in handles]
        finally:
            executor.shutdown()
            thread.join(5.0)
    assert [(r.status, list(r.result.sequence)) for r in results] == [
        (STATUS_SUCCEEDED, [1]), (STATUS_SUCCEEDED, [2]), (STATUS_CANCELED, [3])]
