"""``rclpy.client``: :class:`Client` with rclpy's shape (``rclpy/client.py``):
``call_async(request)`` gives an :class:`~servolab.rclpy.task.Future` with no timeout of its
own, ``call(request, timeout_sec=None)``, ``wait_for_service``, ``service_is_ready``,
``remove_pending_request``. It is servolab's client (:mod:`servolab.middleware.client`)."""

from __future__ import annotations

from concurrent.futures import Future as _Done
from typing import Any

from servolab.middleware.client import Client as _Client

from .task import Future


class Client(_Client):
    """See the module docstring."""

    def call_async(self, request: Any | None = None,  # type: ignore[override]
                   timeout: float | None = None) -> Future:
        sent = super().call_async(request, timeout)
        future = Future(executor=self.node.context.executor)

        def cancelled(mine: Future) -> None:
            if mine.cancelled():
                sent.cancel()

        future.add_done_callback(cancelled)

        def done(answer: _Done[Any]) -> None:
            if answer.cancelled():
                future.cancel()
            elif (error := answer.exception()) is not None:
                future.set_exception(error)
            else:
                future.set_result(answer.result())

        sent.add_done_callback(done)
        return future

    def call(self, request: Any | None = None,
             timeout_sec: float | None = None) -> Any:
        """The response, waiting up to ``timeout_sec`` (None: as long as it takes). rclpy's
        needs another thread to spin; servolab's spins while it waits if none does."""
        return super().call(request, timeout_sec)

    def remove_pending_request(self, future: Future) -> None:
        future.cancel()


__all__ = ["Client"]
