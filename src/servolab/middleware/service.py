"""A service server: one name, one type, one handler (rclpy's ``Service``).

A request is answered, as a ROS 2 client expects (over DDS and an installed ROS 2's rmw a
failed handler sends nothing: they have no error reply, and the client's wait ends at its
timeout). A handler that raises, or returns
something that is not the service's response, is logged; in-process the caller's future then
holds a :class:`~.errors.ServiceError` with the reason. Over Zenoh the reply is still what an
rmw_zenoh client can take: an OK reply whose payload is the CDR of a default response (every
field zero or empty) with rmw_zenoh's attachment, because rmw_zenoh's client drops an error
reply and would wait for ever (``rmw_client_data.cpp``, ``ClientData::send_request``: ``if
(!reply.is_ok()) { log; return; }``). The failure rides in the reply's Zenoh *encoding*,
:data:`~.rmw_zenoh.ERROR_ENCODING` with the reason as its schema
(:func:`~.rmw_zenoh.error_encoding`), which rmw_zenoh never reads
(``ClientData::take_response`` reads payload and attachment only); servolab's client sees it
(:func:`~.rmw_zenoh.error_reason`) and raises ServiceError with the reason.

A request whose bytes are not the service's request type comes from outside: it is answered
with the error too, counted in the context's :class:`~.malformed.MalformedMessages`, and
said once per service, not once per request (a peer cannot fill the log).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .errors import ServiceError
from .fast_cdr import CdrError
from .messages import ServiceType

if TYPE_CHECKING:
    from .node import Node


class Service:
    """Answers requests: ``handler(request, response) -> response``, as in rclpy.

    With ``answers_later`` the handler is ``handler(request, respond)`` instead, and the
    request is answered when ``respond(response)`` is called, from any thread, maybe after the
    handler returned (an action's ``get_result``, answered when its goal ends): every
    transport keeps what it needs to answer until then."""

    def __init__(self, node: Node, srv: ServiceType, name: str,
                 handler: Callable[[Any, Any], Any], *, answers_later: bool = False) -> None:
        self.node = node
        self.srv = srv
        self.name = name
        self._handler = handler
        self._answers_later = answers_later
        self._inner = node.context.transport.serve(node.info, name, srv, self._on_request)

    def _on_request(self, request: Any, reply: Callable[[Any], None]) -> None:
        executor = self.node.context.executor
        if executor.in_executor_thread or executor.is_shutdown:
            self._run(request, reply)  # a call from one of our own callbacks: answer now
        else:
            executor.submit(lambda: self._run(request, reply))

    def _run(self, request: Any, reply: Callable[[Any], None]) -> None:
        types = self.node.context.types
        if isinstance(request, bytes | memoryview):
            try:
                request = types.deserialize(request, self.srv.request)
            except CdrError as exc:  # from outside: answered, counted, said once
                if self.node.context.malformed.count(self.name)[0] == 1:
                    self.node.get_logger().error(
                        "service %s: a request that is not a %s: %s (answered with the "
                        "error; the next are counted, not said again)", self.name,
                        self.srv.request, exc)
                reply(exc)
                return
        try:
            if self._answers_later:
                respond = self._checked(reply)
                try:
                    self._handler(request, respond)
                except Exception as exc:  # reported once: an answer given stands
                    self.node.get_logger().error("service %s failed: %s", self.name, exc)
                    respond(exc, quiet=True)
                return
            response = self._handler(request, types.default(self.srv.response))
            if getattr(response, "__msgtype__", None) != self.srv.response:
                raise ServiceError(f"handler of {self.name} returned {response!r}, not a "
                                   f"{self.srv.response}")
        except Exception as exc:  # the caller learns why; the node keeps running
            self.node.get_logger().error("service %s failed: %s", self.name, exc)
            reply(exc)
            return
        reply(response)

    def _checked(self, reply: Callable[[Any], None]) -> Callable[..., None]:
        """``reply`` for a later answer: once, and a response of the service's type only (an
        exception is the failure it reports). ``quiet``: a failure after the answer was given
        is dropped, not raised (the handler raised after answering)."""
        answered = False
        lock = threading.Lock()

        def respond(response: Any, *, quiet: bool = False) -> None:
            nonlocal answered
            with lock:
                again, answered = answered, True
            if again:
                if quiet:
                    return
                raise ServiceError(f"service {self.name}: a request is answered once")
            if not isinstance(response, Exception) \
                    and getattr(response, "__msgtype__", None) != self.srv.response:
                error = ServiceError(f"handler of {self.name} answered {response!r}, not a "
                                     f"{self.srv.response}")
                self.node.get_logger().error("service %s failed: %s", self.name, error)
                response = error
            reply(response)
        return respond

    def destroy(self) -> None:
        self._inner.close()

