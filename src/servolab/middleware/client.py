"""A service client: calls one service by name (rclpy's ``Client``)."""

from __future__ import annotations

import contextlib
from concurrent.futures import Future, InvalidStateError
from concurrent.futures import TimeoutError as FutureTimeout
from typing import TYPE_CHECKING, Any

from .errors import MessageError, ServiceError
from .messages import ServiceType

if TYPE_CHECKING:
    from .node import Node
    from .transport import Closeable

#: What :meth:`Client.call_async` asks the transport for as a timeout: none in effect (a
#: year), since a transport's call takes a number (Zenoh's query does).
_NO_TIMEOUT = 365 * 24 * 3600.0


class Client:
    """Calls a service: ``call(request)`` blocks; ``call_async`` returns a Future.

    From its creation to :meth:`destroy` the client is in the graph (kind SC: over Zenoh,
    rmw_zenoh's client liveliness token), so ``ros2 service info`` and servolab's graph views
    count it. A server whose handler fails still answers (see :mod:`.service`); the call then
    raises :class:`ServiceError` with the handler's reason."""

    def __init__(self, node: Node, srv: ServiceType, name: str) -> None:
        self.node = node
        self.srv = srv
        self.name = name
        self._declared: Closeable | None = node.context.transport.declare_client(
            node.info, name, srv)
        self._pending: set[Future[Any]] = set()

    def request(self, **fields: Any) -> Any:
        return self.node.context.types.from_value(self.srv.request, fields)

    def call(self, request: Any | None = None, timeout: float | None = 5.0) -> Any:
        """The response, waiting up to ``timeout`` s (None: as long as it takes). When no
        other thread spins the executor, this one does while it waits, so a server in this
        process can answer."""
        future = self._send(request, timeout)
        executor = self.node.context.executor
        if not executor.spinning_elsewhere:
            executor.spin_until(future.done, timeout)
        try:
            return future.result(timeout=0 if future.done() else timeout)
        except FutureTimeout:
            future.cancel()
            raise ServiceError(f"service {self.name} did not answer within "
                               f"{timeout:g} s") from None

    def call_async(self, request: Any | None = None,
                   timeout: float | None = None) -> Future[Any]:
        """Send ``request``; the future holds the response when it comes. As in rclpy
        (``rclpy/client.py``), it has no timeout unless given one (issue 32, D4): it stays
        pending until the server answers, or is cancelled when the client is destroyed.
        Where no server exists at all (Zenoh finds no queryable), it holds a
        :class:`ServiceError` at once, where rclpy's would stay pending. ``timeout`` (s)
        bounds the transport's wait (servolab's ``service call`` command gives one)."""
        return self._send(request, timeout)

    def _send(self, request: Any | None, timeout: float | None) -> Future[Any]:
        request = self.request() if request is None else request
        if getattr(request, "__msgtype__", None) != self.srv.request:
            raise MessageError(f"{self.name} takes a {self.srv.request}, not "
                               f"{getattr(request, '__msgtype__', type(request).__name__)}")
        sent = self.node.context.transport.call(
            self.name, self.srv, request, _NO_TIMEOUT if timeout is None else timeout)
        # The caller's future is its own: cancelling it (destroy(), a call() that gave up)
        # never races the transport completing the one it holds
        future: Future[Any] = Future()
        self._pending.add(future)
        executor = self.node.context.executor

        def done(answer: Future[Any]) -> None:
            self._pending.discard(future)
            if not future.done():
                with contextlib.suppress(InvalidStateError):  # cancelled meanwhile
                    error = answer.exception()
                    if error is None:
                        future.set_result(answer.result())
                    else:
                        future.set_exception(error)
            # The answer completes the future on the transport's thread (Zenoh's): it is
            # also work for the executor, as a response is in rclpy, so a spin_once or a
            # spin_until_future_complete waiting on it returns then (issue 32, D1), not at
            # its timeout, or never
            _wake(executor)

        sent.add_done_callback(done)
        return future

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        """True once a server of this service is in the graph; False after ``timeout_sec``
        s (None: wait as long as it takes, as rclpy does)."""
        clock = self.node.context.clock
        end = None if timeout_sec is None else clock.now() + timeout_sec
        while True:
            if self.service_is_ready():
                return True
            if end is not None and clock.now() >= end:
                return False
            clock.sleep(0.05)

    def service_is_ready(self) -> bool:
        return any(e.kind == "SS" and e.name == self.name
                   for e in self.node.context.transport.graph(0.2))

    def destroy(self) -> None:
        """Leave the graph (the SC token is undeclared) and cancel the calls still waiting
        for an answer; a second call does nothing."""
        for future in list(self._pending):
            future.cancel()
        self._pending.clear()
        declared, self._declared = self._declared, None
        if declared is not None:
            declared.close()


def _wake(executor: Any) -> None:
    """Wake the spinning caller (from the transport's thread); nothing if it has stopped."""
    if not executor.is_shutdown:
        with contextlib.suppress(RuntimeError):
            executor.submit(lambda: None)
