"""The in-process transport: the default, and the fastest.

Publishing hands the message *object* to every subscription of the same topic and type, with no
serialization on the hot path (a subscriber must therefore not modify what it receives, the
same rule as ROS 2's intra-process communication). Only raw subscriptions, such as the bag
recorder's, get CDR bytes, serialized once per message whatever their number.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from .errors import ServiceError
from .messages import MessageTypes, ServiceType
from .transport import (
    Closeable,
    Deliver,
    Endpoint,
    Handler,
    MessageInfo,
    NodeInfo,
    Transport,
    TransportPublisher,
)


@dataclass
class _Subscriber:
    node: NodeInfo
    topic: str
    type_name: str
    deliver: Deliver
    raw: bool


class _Registration:
    def __init__(self, undo: Callable[[], None]) -> None:
        self._undo: Callable[[], None] | None = undo

    def close(self) -> None:
        if self._undo is not None:
            self._undo()
            self._undo = None


class LocalPublisher(TransportPublisher):
    def __init__(self, transport: LocalTransport, node: NodeInfo, topic: str,
                 type_name: str) -> None:
        self._transport = transport
        self.topic = topic
        self.type_name = type_name
        self._sequence = itertools.count(1)
        self._endpoint = Endpoint("MP", node.fully_qualified_name, topic, type_name)
        transport._add_endpoint(self._endpoint)

    def publish(self, msg: Any) -> None:
        subscribers = self._transport._subscribers.get(self.topic, ())
        if not subscribers:
            return
        now = time.time_ns()
        info = MessageInfo(now, now, next(self._sequence))
        cdr: bytes | None = None
        for sub in subscribers:
            if sub.type_name != self.type_name:
                continue  # a different type on the same name never matches, as in ROS 2
            if sub.raw:
                if cdr is None:
                    cdr = self._transport.types.serialize(msg, self.type_name)
                sub.deliver(cdr, info)
            else:
                sub.deliver(msg, info)

    def publish_serialized(self, cdr: bytes) -> None:
        self.publish(self._transport.types.deserialize(cdr, self.type_name))

    def close(self) -> None:
        self._transport._remove_endpoint(self._endpoint)


class LocalTransport(Transport):
    """Topics and services between the nodes of one process."""

    def __init__(self, types: MessageTypes) -> None:
        super().__init__(types)
        self._lock = threading.Lock()
        # Copy-on-write tuples: publish() reads them without taking the lock.
        self._subscribers: dict[str, tuple[_Subscriber, ...]] = {}
        self._services: dict[str, tuple[ServiceType, Handler]] = {}
        self._endpoints: list[Endpoint] = []

    def _add_endpoint(self, endpoint: Endpoint) -> None:
        with self._lock:
            self._endpoints.append(endpoint)

    def _remove_endpoint(self, endpoint: Endpoint) -> None:
        with self._lock:
            if endpoint in self._endpoints:
                self._endpoints.remove(endpoint)

    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  depth: int, *, reliable: bool = True) -> LocalPublisher:
        return LocalPublisher(self, node, topic, type_name)

    def subscribe(self, node: NodeInfo, topic: str, type_name: str, depth: int,
                  deliver: Deliver, *, raw: bool = False) -> Closeable:
        sub = _Subscriber(node, topic, type_name, deliver, raw)
        endpoint = Endpoint("MS", node.fully_qualified_name, topic, type_name)
        with self._lock:
            self._subscribers[topic] = (*self._subscribers.get(topic, ()), sub)
            self._endpoints.append(endpoint)

        def undo() -> None:
            with self._lock:
                self._subscribers[topic] = tuple(
                    s for s in self._subscribers.get(topic, ()) if s is not sub)
                if endpoint in self._endpoints:
                    self._endpoints.remove(endpoint)
        return _Registration(undo)

    def serve(self, node: NodeInfo, name: str, srv: ServiceType, handler: Handler) -> Closeable:
        endpoint = Endpoint("SS", node.fully_qualified_name, name, srv.name)
        with self._lock:
            if name in self._services:
                raise ServiceError(f"service {name} is already offered in this process")
            self._services[name] = (srv, handler)
            self._endpoints.append(endpoint)

        def undo() -> None:
            with self._lock:
                self._services.pop(name, None)
                if endpoint in self._endpoints:
                    self._endpoints.remove(endpoint)
        return _Registration(undo)

    def call(self, name: str, srv: ServiceType, request: Any, timeout: float) -> Future[Any]:
        entry = self._services.get(name)
        if entry is None:
            raise ServiceError(f"no service {name} (is its node running?)")
        if entry[0].name != srv.name:
            raise ServiceError(f"service {name} is a {entry[0].name}, not a {srv.name}")
        future: Future[Any] = Future()

        def reply(response: Any) -> None:
            if isinstance(response, Exception):
                future.set_exception(ServiceError(f"service {name} failed: {response}"))
            else:
                future.set_result(response)

        entry[1](request, reply)
        return future

    def announce_node(self, node: NodeInfo) -> Closeable:
        endpoint = Endpoint("NN", node.fully_qualified_name)
        self._add_endpoint(endpoint)
        return _Registration(lambda: self._remove_endpoint(endpoint))

    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        with self._lock:
            return list(self._endpoints)
