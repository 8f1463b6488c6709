"""``rclpy.executors``: :class:`SingleThreadedExecutor`, :class:`MultiThreadedExecutor` and
:class:`ExternalShutdownException`, with rclpy's shape (``rclpy/executors.py``).

servolab keeps one queue of work (timers, messages, requests, responses) per context
(:class:`servolab.middleware.executor.Executor`); an executor here runs that queue for the
context of the nodes added to it. :class:`MultiThreadedExecutor` runs it on several threads
at once, each callback within its callback group's rule
(:mod:`servolab.rclpy.callback_groups`): callbacks of one mutually exclusive group (every
node's default) one at a time, those of a reentrant group or of different groups together.

rclpy's ``spin()`` raises :class:`ExternalShutdownException` when the context is shut down
while it spins; servolab's returns (so ``except (KeyboardInterrupt,
ExternalShutdownException)`` around it changes nothing), and returns on Ctrl-C instead of
raising KeyboardInterrupt.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .task import Future

if TYPE_CHECKING:
    from servolab.middleware.context import Context

    from .node import Node


class ExternalShutdownException(Exception):
    """Context has been shutdown (rclpy's; see the module docstring)."""


class ShutdownException(Exception):
    """Signal that executor was shut down."""


class Executor:
    """Runs the callbacks of the nodes added to it (see the module docstring)."""

    def __init__(self, *, context: Any = None) -> None:
        self._nodes: list[Node] = []
        self._context: Context | None = context
        self._is_shutdown = False
        self._lock = threading.Lock()

    @property
    def context(self) -> Context:
        if self._context is None:
            from servolab.middleware.default_context import default_context
            self._context = default_context()
        return self._context

    def add_node(self, node: Node) -> bool:
        with self._lock:
            if node in self._nodes:
                return False
            self._nodes.append(node)
            if self._context is None:
                self._context = node.context
            return True

    def remove_node(self, node: Node) -> None:
        with self._lock:
            if node in self._nodes:
                self._nodes.remove(node)

    def get_nodes(self) -> list[Node]:
        with self._lock:
            return list(self._nodes)

    def wake(self) -> None:
        self.context.executor.wake()

    def create_task(self, callback: Callable[..., Any], *args: Any, **kwargs: Any) -> Future:
        """Run ``callback(*args, **kwargs)`` on the executor; its future holds the result."""
        future = Future(executor=self.context.executor)

        def run() -> None:
            try:
                future.set_result(callback(*args, **kwargs))
            except Exception as exc:
                future.set_exception(exc)

        self.context.executor.submit(run)
        return future

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        """Stop this executor's spinning (the context and its nodes stay as they are)."""
        self._is_shutdown = True
        self.context.executor.wake()
        return True

    def _running(self) -> bool:
        context = self.context
        return not self._is_shutdown and context.ok()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        if self._running():
            self.context.spin_once(timeout_sec)

    def spin_until_future_complete(self, future: Any, timeout_sec: float | None = None) -> None:
        context = self.context
        if timeout_sec is None or timeout_sec < 0:
            while self._running() and not future.done():
                context.spin_once(0.1)
            return
        context.executor.spin_until(lambda: future.done() or not self._running(), timeout_sec)

    def spin_once_until_future_complete(self, future: Any,
                                        timeout_sec: float | None = None) -> None:
        self.spin_once(timeout_sec)

    def spin(self) -> None:
        """Execute callbacks until shutdown (this executor's or the context's) or Ctrl-C."""
        context = self.context
        with context.stop_on_signals(), context.executor.spinning():
            while self._running():
                context.spin_once(0.1)

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()


class SingleThreadedExecutor(Executor):
    """Runs callbacks in the thread that calls :meth:`spin`, one at a time."""


class MultiThreadedExecutor(Executor):
    """Runs callbacks on ``num_threads`` threads (default: the CPU count, at least 2), as
    their callback groups allow."""

    def __init__(self, num_threads: int | None = None, *, context: Any = None) -> None:
        super().__init__(context=context)
        if num_threads is None:
            num_threads = max(2, os.cpu_count() or 2)
        if num_threads < 1:
            raise ValueError("num_threads must be a positive integer")
        self._num_threads = num_threads
        self._errors: list[BaseException] = []

    @property
    def num_threads(self) -> int:
        return self._num_threads

    def _work(self, more: Callable[[], bool]) -> None:
        context = self.context
        try:
            with context.executor.spinning():
                while self._running() and more():
                    context.spin_once(0.05)
        except BaseException as exc:  # handed to spin()'s caller
            self._errors.append(exc)
            self._is_shutdown = True

    def _spin_while(self, more: Callable[[], bool]) -> None:
        """Run callbacks on the threads while ``more()`` and neither this executor nor the
        context is shut down."""
        context = self.context
        workers = [threading.Thread(target=self._work, args=(more,), daemon=True,
                                    name=f"rclpy-executor-{i}")
                   for i in range(self._num_threads - 1)]
        for worker in workers:
            worker.start()
        try:
            with context.stop_on_signals():
                self._work(more)
        finally:
            for worker in workers:
                worker.join(5.0)
        if self._errors:
            raise self._errors.pop(0)

    def spin(self) -> None:
        self._spin_while(lambda: True)

    def spin_until_future_complete(self, future: Any, timeout_sec: float | None = None) -> None:
        if timeout_sec is None or timeout_sec < 0:
            self._spin_while(lambda: not future.done())
            return
        end = time.monotonic() + timeout_sec
        self._spin_while(lambda: not future.done() and time.monotonic() < end)


class _Global:
    executor: Executor | None = None


def _global_executor() -> Executor:
    if _Global.executor is None or _Global.executor._is_shutdown:
        _Global.executor = SingleThreadedExecutor()
    return _Global.executor


__all__ = ["Executor", "ExternalShutdownException", "MultiThreadedExecutor",
           "ShutdownException", "SingleThreadedExecutor"]
