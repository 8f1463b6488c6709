"""``rclpy.task``: :class:`Future`, rclpy's (``rclpy/task.py``): ``result()`` never blocks
(None until done), and done-callbacks run on the executor's thread, as rclpy schedules them
as tasks, not on the thread that completed the future (a transport's)."""

from __future__ import annotations

import threading
from collections.abc import Callable, Generator
from typing import Any


class Future:
    """Represents the outcome of a task in the future."""

    def __init__(self, *, executor: Any = None) -> None:
        self._lock = threading.Lock()
        self._state = "PENDING"
        self._result: Any = None
        self._exception: BaseException | None = None
        self._exception_fetched = False
        self._callbacks: list[Callable[[Future], None]] = []
        self._executor = executor

    def __del__(self) -> None:
        if self._exception is not None and not self._exception_fetched:
            import logging
            logging.getLogger("servolab.rclpy").error(
                "The following exception was never retrieved: %s", self._exception)

    def __await__(self) -> Generator[Future, None, Any]:
        # it yields itself, so that whoever steps the coroutine can resume it when done
        while not self.done():
            yield self
        return self.result()

    def cancel(self) -> None:
        with self._lock:
            if self._state != "PENDING":
                return
            self._state = "CANCELLED"
        self._schedule_or_invoke_done_callbacks()

    def cancelled(self) -> bool:
        return self._state == "CANCELLED"

    def done(self) -> bool:
        return self._state in ("FINISHED", "CANCELLED")

    def result(self) -> Any:
        """The result, None if not done; raises the exception if one was set."""
        if self._exception is not None:
            self._exception_fetched = True
            raise self._exception
        return self._result

    def exception(self) -> BaseException | None:
        self._exception_fetched = True
        return self._exception

    def set_result(self, result: Any) -> None:
        with self._lock:
            if self._state != "PENDING":
                return
            self._result = result
            self._state = "FINISHED"
        self._schedule_or_invoke_done_callbacks()

    def set_exception(self, exception: BaseException) -> None:
        with self._lock:
            if self._state != "PENDING":
                return
            self._exception = exception
            self._exception_fetched = False
            self._state = "FINISHED"
        self._schedule_or_invoke_done_callbacks()

    def _schedule_or_invoke_done_callbacks(self) -> None:
        with self._lock:
            callbacks, self._callbacks = self._callbacks, []
        for callback in callbacks:
            self._run(callback)

    def _run(self, callback: Callable[[Future], None]) -> None:
        executor = self._executor
        if executor is not None and not executor.is_shutdown:
            executor.submit(lambda: callback(self))
        else:
            callback(self)

    def _set_executor(self, executor: Any) -> None:
        self._executor = executor

    def add_done_callback(self, callback: Callable[[Future], None]) -> None:
        """``callback(future)`` once done: on the executor's thread if the future has one."""
        with self._lock:
            if not self.done():
                self._callbacks.append(callback)
                return
        self._run(callback)


__all__ = ["Future"]
