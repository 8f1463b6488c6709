"""``rclpy.callback_groups``: which callbacks may run at once under a multi-threaded
executor (``rclpy/callback_groups.py``).

A :class:`MutuallyExclusiveCallbackGroup` runs one of its callbacks at a time; a
:class:`ReentrantCallbackGroup` any number. Every node has a mutually exclusive default
group (``node.default_callback_group``) for the callbacks given none. Under one thread
(``rclpy.spin``, :class:`~servolab.rclpy.executors.SingleThreadedExecutor`) groups change
nothing, as in rclpy. servolab applies a group around the callback itself (see
:class:`MutuallyExclusiveCallbackGroup` for what waits where).
"""

from __future__ import annotations

import threading
import weakref
from collections import deque
from collections.abc import Callable
from typing import Any


class CallbackGroup:
    """The base class: :meth:`can_execute`, :meth:`beginning_execution` and
    :meth:`ending_execution` are rclpy's; :meth:`run` is how servolab applies them."""

    def __init__(self) -> None:
        self.entities: set[Any] = set()

    def add_entity(self, entity: Any) -> None:
        self.entities.add(weakref.ref(entity))

    def has_entity(self, entity: Any) -> bool:
        return weakref.ref(entity) in self.entities

    def can_execute(self, entity: Any) -> bool:
        raise NotImplementedError

    def beginning_execution(self, entity: Any) -> bool:
        raise NotImplementedError

    def ending_execution(self, entity: Any) -> None:
        raise NotImplementedError

    def run(self, callback: Callable[..., Any], *args: Any) -> Any:
        """Call ``callback(*args)`` as the group allows (waiting for it if it is busy) and
        return its result: for a service callback, whose response is wanted now."""
        raise NotImplementedError

    def dispatch(self, callback: Callable[..., Any], *args: Any) -> None:
        """Call ``callback(*args)`` as the group allows, later if it is busy (a message or
        timer callback, whose result nobody waits for)."""
        self.run(callback, *args)


class ReentrantCallbackGroup(CallbackGroup):
    """Its callbacks may run at once, each of them in several threads too."""

    def can_execute(self, entity: Any) -> bool:
        return True

    def beginning_execution(self, entity: Any) -> bool:
        return True

    def ending_execution(self, entity: Any) -> None:
        pass

    def run(self, callback: Callable[..., Any], *args: Any) -> Any:
        return callback(*args)


class MutuallyExclusiveCallbackGroup(CallbackGroup):
    """One of its callbacks at a time.

    A message or timer callback that comes while another of the group runs waits in the
    group's queue, in order, and the thread that holds the group runs it next: no thread of a
    multi-threaded executor is kept waiting, as rclpy's executor takes other work meanwhile.
    A service callback, whose response is wanted at once, waits for the group. The thread
    that holds the group may run more of its callbacks (a callback that spins, with no other
    thread to spin: a synchronous call)."""

    def __init__(self) -> None:
        super().__init__()
        self._active_entity: Any = None
        self._cond = threading.Condition()
        self._owner: int | None = None
        self._depth = 0
        self._queue: deque[tuple[Callable[..., Any], tuple[Any, ...]]] = deque()
        self._submit: Callable[[Callable[[], None]], None] | None = None

    def can_execute(self, entity: Any) -> bool:
        with self._cond:
            return self._owner is None

    def beginning_execution(self, entity: Any) -> bool:
        with self._cond:
            if self._owner is None:
                self._owner, self._depth = threading.get_ident(), 1
                self._active_entity = entity
                return True
        return False

    def ending_execution(self, entity: Any) -> None:
        self._release()

    def _take(self, wait: bool) -> bool:
        me = threading.get_ident()
        with self._cond:
            while self._owner not in (None, me):
                if not wait:
                    return False
                self._cond.wait()
            self._owner = me
            self._depth += 1
            return True

    def _release(self) -> None:
        with self._cond:
            self._depth -= 1
            if self._depth > 0:
                return
            self._owner = None
            self._active_entity = None
            self._cond.notify_all()
            waiting = bool(self._queue) and self._submit is not None
        if waiting and self._submit is not None:
            self._submit(self._drain)  # queued while a service callback held the group

    def run(self, callback: Callable[..., Any], *args: Any) -> Any:
        """Call ``callback(*args)`` once the group is free, and return what it returns."""
        self._take(wait=True)
        try:
            return callback(*args)
        finally:
            self._release()

    def dispatch(self, callback: Callable[..., Any], *args: Any) -> None:
        """Call ``callback(*args)`` now if the group is free (or held by this thread), else
        queue it for the thread that holds the group."""
        me = threading.get_ident()
        with self._cond:
            if self._owner != me and (self._queue or self._owner is not None):
                self._queue.append((callback, args))
                return
            self._owner = me
            self._depth += 1
        self._hold_and_run(callback, args)

    def _drain(self) -> None:
        with self._cond:
            if self._owner is not None or not self._queue:
                return  # a holder drains it
            callback, args = self._queue.popleft()
            self._owner, self._depth = threading.get_ident(), 1
        self._hold_and_run(callback, args)

    def _hold_and_run(self, callback: Callable[..., Any], args: tuple[Any, ...]) -> None:
        """Run ``callback`` holding the group, then what queued meanwhile, then let go."""
        while True:
            try:
                callback(*args)
            except BaseException:
                self._release()  # what is queued runs on (a drain is submitted)
                raise
            with self._cond:
                following = self._queue.popleft() if self._queue and self._depth == 1 else None
            if following is None:
                self._release()
                return
            callback, args = following


__all__ = ["CallbackGroup", "MutuallyExclusiveCallbackGroup", "ReentrantCallbackGroup"]
