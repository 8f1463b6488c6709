"""``rclpy.action.client``: :class:`ActionClient` and :class:`ClientGoalHandle`, with rclpy's
API (``rclpy/action/client.py``, Jazzy).

A client calls the action's three services and listens to its two topics
(:mod:`.server` says where they are). ``send_goal_async`` gives a future of the goal's
handle, whose ``get_result_async`` gives a future of the ``GetResult`` response (``status``
and ``result``) and ``cancel_goal_async`` one of the ``CancelGoal`` response. Feedback goes
to the callback given with the goal, as the whole ``FeedbackMessage`` (``goal_id`` and
``feedback``); the status topic keeps each handle's ``status`` current. Futures complete on
the executor that spins the node, as rclpy's do.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from ..client import Client
from ..task import Future
from .server import (
    FEEDBACK_QOS,
    STATUS_ACCEPTED,
    STATUS_QOS,
    STATUS_UNKNOWN,
    action_names,
    action_type_name,
)


def _uuid(goal_id: Any) -> bytes:
    return bytes(bytearray(goal_id.uuid))


class ClientGoalHandle:
    """A goal the client sent: whether it was accepted, its id, stamp and latest status."""

    def __init__(self, action_client: ActionClient, goal_id: Any, goal_response: Any) -> None:
        self._action_client = action_client
        self._goal_id = goal_id
        self._goal_response = goal_response
        self._status = STATUS_ACCEPTED if goal_response.accepted else STATUS_UNKNOWN

    def __repr__(self) -> str:
        return (f"ClientGoalHandle <id={list(bytearray(self._goal_id.uuid))}, "
                f"accepted={self.accepted}, status={self.status}>")

    @property
    def goal_id(self) -> Any:
        return self._goal_id

    @property
    def stamp(self) -> Any:
        return self._goal_response.stamp

    @property
    def accepted(self) -> bool:
        return bool(self._goal_response.accepted)

    @property
    def status(self) -> int:
        return self._status

    def cancel_goal(self) -> Any:
        """The ``CancelGoal`` response, waiting for it (not from a callback)."""
        return self._action_client._wait(self.cancel_goal_async())

    def cancel_goal_async(self) -> Future:
        return self._action_client._cancel_goal_async(self)

    def get_result(self) -> Any:
        """The ``GetResult`` response, waiting for the goal's end (not from a callback)."""
        return self._action_client._wait(self.get_result_async())

    def get_result_async(self) -> Future:
        if not self.accepted:
            raise RuntimeError("Cannot get result. Goal was not accepted.")
        return self._action_client._get_result_async(self)


class ActionClient:
    """See the module docstring. ``node`` is a servolab node; ``action_type`` a class from
    ``servolab.interfaces.<pkg>.action`` or ``pkg/action/Name``."""

    def __init__(self, node: Any, action_type: Any, action_name: str, *,
                 callback_group: Any = None, goal_service_qos_profile: Any = None,
                 result_service_qos_profile: Any = None,
                 cancel_service_qos_profile: Any = None, feedback_sub_qos_profile: Any = None,
                 status_sub_qos_profile: Any = None) -> None:
        self._node = node
        self.type_name = action_type_name(action_type)
        self._action_type = action_type
        types = node.context.types
        if not types.is_action(self.type_name):
            raise TypeError(f"unknown action type {self.type_name!r}")
        self.name = node.resolve(action_name)
        names = action_names(self.name)
        self._send_goal = node.own(Client(node, types.service(f"{self.type_name}_SendGoal"),
                                          names["send_goal"]))
        self._cancel_goal = node.own(Client(node, types.service("action_msgs/srv/CancelGoal"),
                                            names["cancel_goal"]))
        self._get_result = node.own(Client(node, types.service(f"{self.type_name}_GetResult"),
                                           names["get_result"]))
        self._lock = threading.Lock()
        self._feedback_callbacks: dict[bytes, Callable[[Any], None]] = {}
        self._goal_handles: dict[bytes, ClientGoalHandle] = {}
        self._feedback = node.create_subscription(
            f"{self.type_name}_FeedbackMessage", names["feedback"], self._on_feedback,
            FEEDBACK_QOS)
        self._status = node.create_subscription(
            "action_msgs/msg/GoalStatusArray", names["status"], self._on_status, STATUS_QOS)
        self._entities = [self._send_goal, self._cancel_goal, self._get_result,
                          self._feedback, self._status]

    @property
    def action_type(self) -> Any:
        return self._action_type

    # -- goals -------------------------------------------------------------------------------

    def send_goal_async(self, goal: Any, feedback_callback: Callable[[Any], None] | None = None,
                        goal_uuid: Any = None) -> Future:
        """Send ``goal``; the future holds its :class:`ClientGoalHandle` once the server
        answers (``accepted`` or not)."""
        expected = f"{self.type_name}_Goal"
        if getattr(goal, "__msgtype__", None) != expected:
            raise TypeError(f"a goal of {self.name} is a {expected}, not "
                            f"{getattr(goal, '__msgtype__', type(goal).__name__)}")
        node = self._node
        raw = os.urandom(16) if goal_uuid is None else bytes(bytearray(goal_uuid.uuid))
        goal_id = node.message("unique_identifier_msgs/msg/UUID",
                               uuid=np.frombuffer(raw, dtype=np.uint8).copy())
        if feedback_callback is not None:
            with self._lock:
                self._feedback_callbacks[raw] = feedback_callback
        request = node.message(f"{self.type_name}_SendGoal_Request", goal_id=goal_id, goal=goal)

        def handle_of(response: Any) -> ClientGoalHandle:
            handle = ClientGoalHandle(self, goal_id, response)
            with self._lock:
                if handle.accepted:
                    self._goal_handles[raw] = handle
                else:
                    self._feedback_callbacks.pop(raw, None)
            return handle

        return self._then(self._send_goal.call_async(request), handle_of)

    def _then(self, sent: Future, convert: Callable[[Any], Any]) -> Future:
        """A future of ``convert(response)`` once ``sent`` holds the response (its
        exception, if it fails)."""
        future = Future(executor=self._node.context.executor)

        def answered(done: Future) -> None:
            try:
                future.set_result(convert(done.result()))
            except Exception as exc:
                future.set_exception(exc)

        sent.add_done_callback(answered)
        return future

    def send_goal(self, goal: Any, **kwargs: Any) -> Any:
        """Send ``goal`` and wait for its end: the ``GetResult`` response (``status``,
        ``result``), or None if the goal was rejected. Not from a callback."""
        handle = self._wait(self.send_goal_async(goal, **kwargs))
        if not handle.accepted:
            return None
        return self._wait(handle.get_result_async())

    def _get_result_async(self, handle: ClientGoalHandle) -> Future:
        raw = _uuid(handle.goal_id)
        node = self._node
        sent = self._get_result.call_async(node.message(
            f"{self.type_name}_GetResult_Request", goal_id=handle.goal_id))

        def ended(response: Any) -> Any:
            handle._status = int(response.status)
            with self._lock:
                self._feedback_callbacks.pop(raw, None)
                self._goal_handles.pop(raw, None)
            return response

        return self._then(sent, ended)

    def _cancel_goal_async(self, handle: ClientGoalHandle) -> Future:
        node = self._node
        request = node.message("action_msgs/srv/CancelGoal_Request",
                               goal_info={"goal_id": handle.goal_id})
        return self._send_cancel(request)

    def _cancel_all_goals_async(self, before: Any = None) -> Future:
        """Cancel every goal (accepted at or before ``before``, a Time, if given)."""
        goal_info: dict[str, Any] = {} if before is None else {"stamp": before}
        return self._send_cancel(self._node.message("action_msgs/srv/CancelGoal_Request",
                                                    goal_info=goal_info))

    def _send_cancel(self, request: Any) -> Future:
        sent: Future = self._cancel_goal.call_async(request)
        return sent

    def _on_feedback(self, message: Any) -> None:
        with self._lock:
            callback = self._feedback_callbacks.get(_uuid(message.goal_id))
        if callback is not None:
            callback(message)

    def _on_status(self, message: Any) -> None:
        with self._lock:
            for status in message.status_list:
                handle = self._goal_handles.get(_uuid(status.goal_info.goal_id))
                if handle is not None:
                    handle._status = int(status.status)

    # -- the server --------------------------------------------------------------------------

    def server_is_ready(self) -> bool:
        """Whether the three services have a server (rcl_action_server_is_available)."""
        return all(client.service_is_ready()
                   for client in (self._send_goal, self._cancel_goal, self._get_result))

    def wait_for_server(self, timeout_sec: float | None = None) -> bool:
        """True once a server is ready; False after ``timeout_sec`` s (None: for ever)."""
        clock = self._node.context.clock
        end = None if timeout_sec is None else clock.now() + timeout_sec
        while not self.server_is_ready():
            if end is not None and clock.now() >= end:
                return False
            clock.sleep(0.05)
        return True

    def _wait(self, future: Future) -> Any:
        """The future's result, spinning the executor meanwhile if no other thread does."""
        executor = self._node.context.executor
        if executor.spinning_elsewhere:
            done = threading.Event()
            future.add_done_callback(lambda _f: done.set())
            done.wait()
        else:
            executor.spin_until(future.done)
        return future.result()

    def destroy(self) -> None:
        for entity in self._entities:
            self._node.destroy_entity(entity)
        self._entities.clear()


__all__ = ["ActionClient", "ClientGoalHandle"]
