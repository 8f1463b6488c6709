"""``rclpy.action.server``: :class:`ActionServer`, :class:`ServerGoalHandle`,
:class:`GoalResponse` and :class:`CancelResponse`, with rclpy's API and goal states.

On the wire an action is what rcl_action makes of it (``rcl_action/names.c``, and the ROS 2
design article "Actions"): under ``<name>/_action/`` the services ``send_goal``
(``<Action>_SendGoal``), ``cancel_goal`` (``action_msgs/srv/CancelGoal``) and ``get_result``
(``<Action>_GetResult``), and the topics ``feedback`` (``<Action>_FeedbackMessage``) and
``status`` (``action_msgs/msg/GoalStatusArray``, transient-local, keep-last 1: a late client
learns the states). So a stock ROS 2 action client reaches a servolab server over every
transport that answers it, and servolab's client a stock server.

What the server does is rclpy's (``rclpy/action/server.py``, Jazzy): a goal goes to
``goal_callback`` (default: accept), an accepted one to ``handle_accepted_callback``
(default: execute it now), whose ``execute_callback`` runs as executor work outside any
callback group (rclpy's ``create_task``), so under a
:class:`~servolab.rclpy.executors.MultiThreadedExecutor` goals run at once, and an ``async
def`` one is resumed as executor work when the future it awaits is done. ``get_result`` is
answered when the goal ends, for as long as ``result_timeout`` s after; a cancel request
goes to ``cancel_callback`` (default: reject) for each goal it names, by rcl_action's policy.
A goal whose execute callback returns without a terminal state is aborted, with rclpy's
warning. The states and their legal changes are
rcl_action's (``goal_state_machine.c``); an illegal change raises.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import threading
from collections.abc import Callable
from enum import Enum
from typing import Any

import numpy as np

from servolab.middleware.errors import MiddlewareError
from servolab.middleware.qos import DurabilityPolicy, QoSProfile
from servolab.middleware.service import Service

from ..task import Future

#: action_msgs/msg/GoalStatus' states
STATUS_UNKNOWN, STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING = 0, 1, 2, 3
STATUS_SUCCEEDED, STATUS_CANCELED, STATUS_ABORTED = 4, 5, 6
#: action_msgs/srv/CancelGoal's return codes
ERROR_NONE, ERROR_REJECTED, ERROR_UNKNOWN_GOAL_ID, ERROR_GOAL_TERMINATED = 0, 1, 2, 3
#: rcl_action's default status QoS (``rcl_action_qos_profile_status_default``)
STATUS_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: rclpy's default feedback QoS (``QoSProfile(depth=10)``)
FEEDBACK_QOS = QoSProfile(depth=10)


class GoalResponse(Enum):
    """What a goal callback answers."""

    REJECT = 1
    ACCEPT = 2


class CancelResponse(Enum):
    """What a cancel callback answers."""

    REJECT = 1
    ACCEPT = 2


class GoalEvent(Enum):
    """The events of rcl_action's goal state machine."""

    EXECUTE = 1
    CANCEL_GOAL = 2
    SUCCEED = 3
    ABORT = 4
    CANCELED = 5


#: rcl_action's goal state machine: (state, event) -> next state
_TRANSITIONS = {
    (STATUS_ACCEPTED, GoalEvent.EXECUTE): STATUS_EXECUTING,
    (STATUS_ACCEPTED, GoalEvent.CANCEL_GOAL): STATUS_CANCELING,
    (STATUS_EXECUTING, GoalEvent.CANCEL_GOAL): STATUS_CANCELING,
    (STATUS_EXECUTING, GoalEvent.SUCCEED): STATUS_SUCCEEDED,
    (STATUS_EXECUTING, GoalEvent.ABORT): STATUS_ABORTED,
    (STATUS_CANCELING, GoalEvent.SUCCEED): STATUS_SUCCEEDED,
    (STATUS_CANCELING, GoalEvent.ABORT): STATUS_ABORTED,
    (STATUS_CANCELING, GoalEvent.CANCELED): STATUS_CANCELED,
}
_ACTIVE = (STATUS_ACCEPTED, STATUS_EXECUTING, STATUS_CANCELING)
#: the states a cancel request can move to CANCELING (rcl_action_goal_handle_is_cancelable)
_CANCELABLE = (STATUS_ACCEPTED, STATUS_EXECUTING)


class ActionError(MiddlewareError):
    """An illegal goal state change (rclpy raises RCLError for it)."""


def action_type_name(action_type: Any) -> str:
    """``pkg/action/Name`` of an action class (:mod:`servolab.interfaces`) or of its name."""
    name = action_type if isinstance(action_type, str) else \
        getattr(action_type, "__actiontype__", None)
    if not isinstance(name, str) or name.count("/") != 2 or "/action/" not in name:
        raise TypeError(f"{action_type!r} is not an action type (pkg/action/Name, or a class "
                        "from servolab.interfaces.<pkg>.action)")
    return name


def action_names(resolved: str) -> dict[str, str]:
    """The services' and topics' names of the action ``resolved`` (rcl_action's names.c)."""
    return {part: f"{resolved.rstrip('/')}/_action/{part}"
            for part in ("send_goal", "cancel_goal", "get_result", "feedback", "status")}


def run_callback(node: Any, callback: Callable[..., Any], *args: Any) -> Any:
    """Call ``callback(*args)`` as rclpy's ``await_or_execute`` does, for the callbacks whose
    answer is wanted at once (goal, cancel, handle-accepted): a coroutine function's coroutine
    is run to its end, running executor work while it awaits a future."""
    result = callback(*args)
    if not inspect.iscoroutine(result):
        return result
    executor = node.context.executor
    while True:
        try:
            result.send(None)
        except StopIteration as stop:
            return stop.value
        # it awaits a future that other work completes: let that work run meanwhile
        if executor.in_executor_thread:
            executor.spin_once(0.001)
        else:
            executor.clock.sleep(0.001)


def _uuid(goal_id: Any) -> bytes:
    return bytes(bytearray(goal_id.uuid))


def _is_zero(stamp: Any) -> bool:
    return int(stamp.sec) == 0 and int(stamp.nanosec) == 0


def _nanoseconds(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


class ServerGoalHandle:
    """One goal on the server: its request, id, state, feedback and end."""

    def __init__(self, server: ActionServer, goal_info: Any, goal_request: Any) -> None:
        self._server = server
        self._goal_info = goal_info
        self._goal_request = goal_request
        self._status = STATUS_ACCEPTED
        self._lock = threading.Lock()
        self.ended_at: float | None = None

    @property
    def request(self) -> Any:
        return self._goal_request

    @property
    def goal_id(self) -> Any:
        return self._goal_info.goal_id

    @property
    def goal_info(self) -> Any:
        return self._goal_info

    @property
    def status(self) -> int:
        return self._status

    @property
    def is_active(self) -> bool:
        return self._status in _ACTIVE

    @property
    def is_cancel_requested(self) -> bool:
        return self._status == STATUS_CANCELING

    def _update_state(self, event: GoalEvent) -> None:
        if self._server.destroyed:
            return  # the server is gone: nothing left to tell (rclpy ignores it too)
        with self._lock:
            state = _TRANSITIONS.get((self._status, event))
            if state is None:
                raise ActionError(f"goal {_uuid(self.goal_id).hex()} cannot take {event.name} "
                                  f"in state {self._status} (rcl_action's goal state machine)")
            self._status = state
            if state not in _ACTIVE:
                self.ended_at = self._server.node.now()
        self._server.publish_status()

    def execute(self, execute_callback: Callable[[ServerGoalHandle], Any] | None = None) -> None:
        """Start executing (a goal canceled before it ran still reaches its callback, which
        ends it: rclpy's rule)."""
        if not self.is_cancel_requested:
            self._update_state(GoalEvent.EXECUTE)
        self._server.notify_execute(self, execute_callback)

    def publish_feedback(self, feedback: Any) -> None:
        expected = f"{self._server.type_name}_Feedback"
        if getattr(feedback, "__msgtype__", None) != expected:
            raise TypeError(f"feedback of {self._server.name} is a {expected}, not "
                            f"{getattr(feedback, '__msgtype__', type(feedback).__name__)}")
        if not self.is_active or self._server.destroyed:
            return
        self._server.feedback_publisher.publish(self._server.node.message(
            f"{self._server.type_name}_FeedbackMessage", goal_id=self.goal_id,
            feedback=feedback))

    def succeed(self) -> None:
        self._update_state(GoalEvent.SUCCEED)

    def abort(self) -> None:
        self._update_state(GoalEvent.ABORT)

    def canceled(self) -> None:
        self._update_state(GoalEvent.CANCELED)

    def destroy(self) -> None:
        pass


def default_goal_callback(goal_request: Any) -> GoalResponse:
    return GoalResponse.ACCEPT


def default_handle_accepted_callback(goal_handle: ServerGoalHandle) -> None:
    goal_handle.execute()


def default_cancel_callback(cancel_request: Any) -> CancelResponse:
    return CancelResponse.REJECT


class ActionServer:
    """See the module docstring. ``node`` is a servolab node (rclpy-shaped or servolab's own);
    ``action_type`` a class from ``servolab.interfaces.<pkg>.action`` or ``pkg/action/Name``."""

    def __init__(self, node: Any, action_type: Any, action_name: str,
                 execute_callback: Callable[[ServerGoalHandle], Any], *,
                 callback_group: Any = None,
                 goal_callback: Callable[[Any], Any] = default_goal_callback,
                 handle_accepted_callback: Callable[[ServerGoalHandle], Any] =
                 default_handle_accepted_callback,
                 cancel_callback: Callable[[ServerGoalHandle], Any] = default_cancel_callback,
                 goal_service_qos_profile: Any = None, result_service_qos_profile: Any = None,
                 cancel_service_qos_profile: Any = None, feedback_pub_qos_profile: Any = None,
                 status_pub_qos_profile: Any = None, result_timeout: float = 900) -> None:
        self.node = node
        self.type_name = action_type_name(action_type)
        self._action_type = action_type
        types = node.context.types
        if not types.is_action(self.type_name):
            raise TypeError(f"unknown action type {self.type_name!r}")
        self.name = node.resolve(action_name)
        self._execute_callback = execute_callback
        self._goal_callback = goal_callback
        self._handle_accepted_callback = handle_accepted_callback
        self._cancel_callback = cancel_callback
        self._group = callback_group or getattr(node, "default_callback_group", None)
        self.result_timeout = float(result_timeout)
        self._lock = threading.RLock()
        #: set by :meth:`destroy`: goal handles still held change nothing after it
        self.destroyed = False
        self._goal_handles: dict[bytes, ServerGoalHandle] = {}
        self._result_futures: dict[bytes, Future] = {}
        names = action_names(self.name)
        self._entities = [
            node.own(Service(node, types.service(f"{self.type_name}_SendGoal"),
                             names["send_goal"], self._on_send_goal, answers_later=True)),
            node.own(Service(node, types.service("action_msgs/srv/CancelGoal"),
                             names["cancel_goal"], self._on_cancel_goal, answers_later=True)),
            node.own(Service(node, types.service(f"{self.type_name}_GetResult"),
                             names["get_result"], self._on_get_result, answers_later=True)),
        ]
        self.feedback_publisher = node.create_publisher(
            f"{self.type_name}_FeedbackMessage", names["feedback"], FEEDBACK_QOS)
        self.status_publisher = node.create_publisher(
            "action_msgs/msg/GoalStatusArray", names["status"], STATUS_QOS)
        self._entities += [self.feedback_publisher, self.status_publisher]
        self._expiry = node.create_timer(min(1.0, max(self.result_timeout, 0.01)),
                                         self._expire_goals)
        self._entities.append(self._expiry)

    @property
    def action_type(self) -> Any:
        return self._action_type

    # -- the three services ----------------------------------------------------------------

    def _in_group(self, callback: Callable[..., Any], *args: Any) -> Any:
        if self._group is None:
            return run_callback(self.node, callback, *args)
        return self._group.run(run_callback, self.node, callback, *args)

    def _on_send_goal(self, request: Any, respond: Callable[[Any], None]) -> None:
        node = self.node
        goal_uuid = _uuid(request.goal_id)
        response_type = f"{self.type_name}_SendGoal_Response"
        with self._lock:
            in_use = goal_uuid in self._goal_handles
        if in_use:
            node.get_logger().error(f"Received goal request for goal ID {goal_uuid.hex()} "
                                    "already in use")
            respond(node.message(response_type, accepted=False))
            return
        response = self._in_group(self._goal_callback, request.goal)
        if not isinstance(response, GoalResponse):
            node.get_logger().warning(f"Unexpected type for GoalResponse. Expected "
                                      f"GoalResponse, got {type(response)}. Rejecting goal.")
            response = GoalResponse.REJECT
        accepted = response == GoalResponse.ACCEPT
        stamp = node.stamp()
        if not accepted:
            respond(node.message(response_type, accepted=False, stamp=stamp))
            return
        goal_info = node.message("action_msgs/msg/GoalInfo", goal_id=request.goal_id,
                                 stamp=stamp)
        goal_handle = ServerGoalHandle(self, goal_info, request.goal)
        with self._lock:
            self._goal_handles[goal_uuid] = goal_handle
            self._result_futures[goal_uuid] = Future(executor=node.context.executor)
        respond(node.message(response_type, accepted=True, stamp=stamp))
        self.publish_status()
        try:
            self._in_group(self._handle_accepted_callback, goal_handle)
        except Exception as exc:  # accepted already: end it, or its get_result waits for ever
            node.get_logger().error(f"Error raised in handle_accepted_callback: {exc!r}")
            with contextlib.suppress(ActionError):
                if goal_handle.status == STATUS_ACCEPTED:
                    goal_handle._update_state(GoalEvent.EXECUTE)
            self._end_goal(goal_handle, None)

    def notify_execute(self, goal_handle: ServerGoalHandle,
                       execute_callback: Callable[[ServerGoalHandle], Any] | None) -> None:
        callback = execute_callback or self._execute_callback

        # a task of the executor outside any callback group, as rclpy's create_task: under a
        # multi-threaded executor goals run at once and a cancel is served while one runs
        self.node.context.executor.submit(lambda: self._execute_goal(callback, goal_handle))

    def _execute_goal(self, execute_callback: Callable[[ServerGoalHandle], Any],
                      goal_handle: ServerGoalHandle) -> None:
        """Run the execute callback and end the goal with what it returns. A coroutine (an
        ``async def`` callback) is stepped as executor work, each step when the future it
        awaits is done, so that it holds no thread while it waits (rclpy's tasks); a future
        returned (a servolab node that ends its goals from its own loop) ends the goal when
        it is done."""
        try:
            result = execute_callback(goal_handle)
        except Exception as exc:
            self._goal_failed(exc, goal_handle)
            return
        if inspect.iscoroutine(result):
            self._step(result, goal_handle)
        elif isinstance(result, Future):
            result.add_done_callback(lambda done: self._ended(goal_handle, done))
        else:
            self._end_goal(goal_handle, result)

    def _step(self, coroutine: Any, goal_handle: ServerGoalHandle) -> None:
        try:
            awaited = coroutine.send(None)
        except StopIteration as stop:
            self._end_goal(goal_handle, stop.value)
            return
        except Exception as exc:
            self._goal_failed(exc, goal_handle)
            return
        executor = self.node.context.executor

        def resume() -> None:
            executor.submit(lambda: self._step(coroutine, goal_handle))

        if isinstance(awaited, Future):  # resumed, as executor work, when it is done
            awaited.add_done_callback(lambda _done: resume())
        elif awaited is None:  # a bare yield: resumed on the executor's next turn
            resume()
        else:
            coroutine.close()
            self._goal_failed(TypeError(
                f"an execute callback awaited {awaited!r}: servolab's executor runs rclpy "
                "futures (servolab.rclpy.task.Future), not asyncio's"), goal_handle)

    def _ended(self, goal_handle: ServerGoalHandle, done: Future) -> None:
        try:
            result = done.result()
        except Exception as exc:
            self._goal_failed(exc, goal_handle)
            return
        self._end_goal(goal_handle, result)

    def _goal_failed(self, exc: Exception, goal_handle: ServerGoalHandle) -> None:
        self.node.get_logger().error(f"Error raised in execute callback: {exc!r}")
        self._end_goal(goal_handle, None)

    def _end_goal(self, goal_handle: ServerGoalHandle, result: Any) -> None:
        if self.destroyed:
            return  # no one left to answer
        node = self.node
        goal_uuid = _uuid(goal_handle.goal_id)
        if result is None or getattr(result, "__msgtype__", None) != \
                f"{self.type_name}_Result":
            result = node.message(f"{self.type_name}_Result")
        if goal_handle.is_active:
            node.get_logger().warning(f"Goal state not set, assuming aborted. Goal ID: "
                                      f"{goal_uuid.hex()}")
            goal_handle.abort()
        with self._lock:
            future = self._result_futures.get(goal_uuid)
        if future is not None:
            future.set_result(node.message(f"{self.type_name}_GetResult_Response",
                                           status=goal_handle.status, result=result))

    def accept_goal(self, goal: Any) -> ServerGoalHandle:
        """Accept ``goal`` (a ``<Action>_Goal``) that the server's own node received another
        way (a pose on ``/goal_pose``, a goal set in code), as nav2's bt_navigator sends one to
        itself: it gets an id and a status, and is ended by its handle as any other. The
        caller executes it (``handle.execute(...)``)."""
        node = self.node
        goal_id = node.message("unique_identifier_msgs/msg/UUID",
                               uuid=np.frombuffer(os.urandom(16), dtype=np.uint8).copy())
        goal_info = node.message("action_msgs/msg/GoalInfo", goal_id=goal_id,
                                 stamp=node.stamp())
        goal_handle = ServerGoalHandle(self, goal_info, goal)
        with self._lock:
            self._goal_handles[_uuid(goal_id)] = goal_handle
            self._result_futures[_uuid(goal_id)] = Future(executor=node.context.executor)
        self.publish_status()
        return goal_handle

    def _on_get_result(self, request: Any, respond: Callable[[Any], None]) -> None:
        goal_uuid = _uuid(request.goal_id)
        with self._lock:
            future = self._result_futures.get(goal_uuid)
        if future is None:
            respond(self.node.message(f"{self.type_name}_GetResult_Response",
                                      status=STATUS_UNKNOWN))
            return

        def send(done: Future) -> None:
            respond(done.result())

        future.add_done_callback(send)  # when the goal ends, or now if it has

    def _on_cancel_goal(self, request: Any, respond: Callable[[Any], None]) -> None:
        """rcl_action's cancel policy (``rcl_action_process_cancel_request``): a zero id and
        zero stamp cancel every goal; a zero id and a stamp, those accepted at or before it;
        an id, that goal, and with a stamp also those accepted at or before it. Only a goal
        ACCEPTED or EXECUTING can be canceled (one already CANCELING cannot be again); each
        goes to the cancel callback. The return code is ERROR_NONE but where an id alone
        (zero stamp) names no goal the server knows (ERROR_UNKNOWN_GOAL_ID) or one that can
        no longer be canceled (ERROR_GOAL_TERMINATED)."""
        info = request.goal_info
        wanted = _uuid(info.goal_id)
        any_id = not any(wanted)
        no_stamp = _is_zero(info.stamp)
        with self._lock:
            handles = list(self._goal_handles.items())
        known = dict(handles)
        return_code = ERROR_NONE
        if not any_id and no_stamp:
            handle = known.get(wanted)
            if handle is None:
                return_code = ERROR_UNKNOWN_GOAL_ID
            elif handle.status not in _CANCELABLE:
                return_code = ERROR_GOAL_TERMINATED
        candidates = [
            handle for goal_uuid, handle in handles
            if handle.status in _CANCELABLE and (
                (any_id and no_stamp)
                or (not any_id and goal_uuid == wanted)
                or (not no_stamp
                    and _nanoseconds(handle.goal_info.stamp) <= _nanoseconds(info.stamp)))]
        canceling = []
        for handle in candidates:
            answer = self._in_group(self._cancel_callback, handle)
            if answer == CancelResponse.ACCEPT:
                try:
                    handle._update_state(GoalEvent.CANCEL_GOAL)
                except ActionError:
                    continue  # it ended meanwhile
                canceling.append(handle.goal_info)
        respond(self.node.message("action_msgs/srv/CancelGoal_Response",
                                  return_code=return_code, goals_canceling=canceling))

    # -- status ----------------------------------------------------------------------------

    def publish_status(self) -> None:
        """Every goal the server keeps, with its state (rcl_action's status array), published
        under the lock so that arrays leave in the order the states changed."""
        node = self.node
        with self._lock:
            if self.destroyed:
                return
            statuses = [node.message("action_msgs/msg/GoalStatus", goal_info=handle.goal_info,
                                     status=handle.status)
                        for handle in self._goal_handles.values()]
            self.status_publisher.publish(node.message("action_msgs/msg/GoalStatusArray",
                                                       status_list=statuses))

    def _expire_goals(self) -> None:
        """Forget goals that ended more than ``result_timeout`` s ago (their results too)."""
        now = self.node.now()
        with self._lock:
            expired = [goal_uuid for goal_uuid, handle in self._goal_handles.items()
                       if handle.ended_at is not None
                       and now - handle.ended_at >= self.result_timeout
                       and self._result_futures[goal_uuid].done()]
            for goal_uuid in expired:
                del self._goal_handles[goal_uuid]
                del self._result_futures[goal_uuid]
        if expired:
            self.publish_status()

    def destroy(self) -> None:
        """Leave the graph; goals still running end with nothing more published."""
        with self._lock:
            self.destroyed = True
            self._goal_handles.clear()
            self._result_futures.clear()
        for entity in self._entities:
            self.node.destroy_entity(entity)
        self._entities.clear()


__all__ = ["ActionServer", "CancelResponse", "GoalEvent", "GoalResponse", "ServerGoalHandle"]
