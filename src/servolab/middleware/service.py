"""A service server: one name, one type, one handler (rclpy's ``Service``)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .errors import ServiceError
from .messages import ServiceType

if TYPE_CHECKING:
    from .node import Node


class Service:
    """Answers requests: ``handler(request, response) -> response``, as in rclpy."""

    def __init__(self, node: Node, srv: ServiceType, name: str,
                 handler: Callable[[Any, Any], Any]) -> None:
        self.node = node
        self.srv = srv
        self.name = name
        self._handler = handler
        self._inner = node.context.transport.serve(node.info, name, srv, self._on_request)

    def _on_request(self, request: Any, reply: Callable[[Any], None]) -> None:
        executor = self.node.context.executor
        if executor.in_executor_thread or executor.is_shutdown:
            self._run(request, reply)  # a call from one of our own callbacks: answer now
        else:
            executor.submit(lambda: self._run(request, reply))

    def _run(self, request: Any, reply: Callable[[Any], None]) -> None:
        types = self.node.context.types
        try:
            if isinstance(request, bytes | memoryview):
                request = types.deserialize(request, self.srv.request)
            response = self._handler(request, types.default(self.srv.response))
            if getattr(response, "__msgtype__", None) != self.srv.response:
                raise ServiceError(f"handler of {self.name} returned {response!r}, not a "
                                   f"{self.srv.response}")
        except Exception as exc:  # the caller learns why; the node keeps running
            self.node.get_logger().error("service %s failed: %s", self.name, exc)
            reply(exc)
            return
        reply(response)

    def destroy(self) -> None:
        self._inner.close()

