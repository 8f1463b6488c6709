"""The in-process transport: the default, and the fastest.

Publishing hands every subscription of the same topic and type one *copy* of the message
object (:func:`~.messages.copy_message`), with no serialization on the hot path: the publisher
may change and republish its object, as rclpy allows, without changing what subscribers got.
Subscribers share that copy and must not modify it (ROS 2's intra-process rule). Only raw
subscriptions, such as the bag recorder's, get CDR bytes, serialized once per message whatever
their number.

A TRANSIENT_LOCAL publisher keeps its last ``depth`` messages; a TRANSIENT_LOCAL subscription
made later receives them first, oldest first, then what is published after (in that order:
both happen under the transport's lock, so a message is never lost or doubled in between).
"""

from __future__ import annotations

import itertools
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from .errors import ServiceError
from .fast_cdr import CdrError
from .inbox import QueueInbox, Wake
from .messages import MessageTypes, ServiceType, copy_message
from .qos import QoSProfile
from .transport import (
    Closeable,
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
    inbox: QueueInbox
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
                 type_name: str, qos: QoSProfile) -> None:
        self._transport = transport
        self.topic = topic
        self.type_name = type_name
        self._sequence = itertools.count(1)
        self._endpoint = Endpoint("MP", node.fully_qualified_name, topic, type_name, qos)
        #: TRANSIENT_LOCAL's history: (message, info) for late subscriptions
        self.kept: deque[tuple[Any, MessageInfo]] | None = (
            deque(maxlen=qos.history_depth) if qos.transient_local else None)
        transport._add_publisher(self)

    def publish(self, msg: Any) -> None:
        if self.kept is not None:
            with self._transport._lock:  # against a subscription joining (module docstring)
                self._publish(msg)
        else:
            self._publish(msg)

    def _publish(self, msg: Any) -> None:
        subscribers = self._transport._subscribers.get(self.topic, ())
        if not subscribers and self.kept is None:
            return
        now = time.time_ns()
        info = MessageInfo(now, now, next(self._sequence))
        copy: Any = None
        cdr: bytes | None = None
        for sub in subscribers:
            if sub.type_name != self.type_name:
                continue  # a different type on the same name never matches, as in ROS 2
            if sub.raw:
                if cdr is None:
                    cdr = self._transport.types.serialize(msg, self.type_name)
                sub.inbox.put(cdr, info)
            else:
                if copy is None:
                    copy = copy_message(msg)
                sub.inbox.put(copy, info)
        if self.kept is not None:
            self.kept.append((copy_message(msg) if copy is None else copy, info))

    def publish_serialized(self, cdr: bytes) -> None:
        """CDR bytes as they are (``bag play``): each subscription reads them itself, as
        over Zenoh and DDS, so bytes that are not the type (a damaged bag) are dropped and
        counted by each subscription (:mod:`.malformed`), never raised into the player, and a
        raw subscription (a recorder) gets the very bytes. A latched topic keeps messages
        for late subscriptions: there they are read once, and what does not read is not
        kept."""
        if self.kept is not None:
            try:
                message = self._transport.types.deserialize(cdr, self.type_name)
            except CdrError:
                pass  # delivered below as bytes, dropped and counted by each subscription
            else:
                self.publish(message)
                return
        now = time.time_ns()
        info = MessageInfo(now, now, next(self._sequence))
        data = bytes(cdr)
        for sub in self._transport._subscribers.get(self.topic, ()):
            if sub.type_name == self.type_name:
                sub.inbox.put(data, info)

    def wait_for_subscription(self, timeout: float) -> bool:
        def matched() -> bool:
            return any(s.type_name == self.type_name
                       for s in self._transport._subscribers.get(self.topic, ()))
        with self._transport._subscribed:
            return self._transport._subscribed.wait_for(matched, timeout)

    def close(self) -> None:
        self._transport._remove_publisher(self)


class LocalTransport(Transport):
    """Topics and services between the nodes of one process."""

    def __init__(self, types: MessageTypes) -> None:
        super().__init__(types)
        self._lock = threading.RLock()
        self._subscribed = threading.Condition(self._lock)  # notified for each subscription
        # Copy-on-write tuples: publish() reads them without taking the lock.
        self._subscribers: dict[str, tuple[_Subscriber, ...]] = {}
        self._services: dict[str, tuple[ServiceType, Handler]] = {}
        self._publishers: dict[str, tuple[LocalPublisher, ...]] = {}
        self._endpoints: list[Endpoint] = []

    def _add_publisher(self, publisher: LocalPublisher) -> None:
        with self._lock:
            self._publishers[publisher.topic] = (*self._publishers.get(publisher.topic, ()),
                                                 publisher)
            self._endpoints.append(publisher._endpoint)

    def _remove_publisher(self, publisher: LocalPublisher) -> None:
        with self._lock:
            self._publishers[publisher.topic] = tuple(
                p for p in self._publishers.get(publisher.topic, ()) if p is not publisher)
            if publisher._endpoint in self._endpoints:
                self._endpoints.remove(publisher._endpoint)

    def _add_endpoint(self, endpoint: Endpoint) -> None:
        with self._lock:
            self._endpoints.append(endpoint)

    def _remove_endpoint(self, endpoint: Endpoint) -> None:
        with self._lock:
            if endpoint in self._endpoints:
                self._endpoints.remove(endpoint)

    def advertise(self, node: NodeInfo, topic: str, type_name: str,
                  qos: QoSProfile) -> LocalPublisher:
        return LocalPublisher(self, node, topic, type_name, qos)

    def subscribe(self, node: NodeInfo, topic: str, type_name: str, qos: QoSProfile,
                  wake: Wake, *, raw: bool = False) -> QueueInbox:
        inbox = QueueInbox(qos.queue_depth, wake)
        sub = _Subscriber(node, topic, type_name, inbox, raw)
        endpoint = Endpoint("MS", node.fully_qualified_name, topic, type_name, qos)
        with self._lock:
            if qos.transient_local:  # what the publishers kept, before anything new
                for publisher in self._publishers.get(topic, ()):
                    if publisher.kept is None or publisher.type_name != type_name:
                        continue
                    for msg, info in publisher.kept:
                        inbox.put(self.types.serialize(msg, type_name) if raw else msg, info)
            self._subscribers[topic] = (*self._subscribers.get(topic, ()), sub)
            self._endpoints.append(endpoint)
            self._subscribed.notify_all()

        def undo() -> None:
            with self._lock:
                self._subscribers[topic] = tuple(
                    s for s in self._subscribers.get(topic, ()) if s is not sub)
                if endpoint in self._endpoints:
                    self._endpoints.remove(endpoint)
        inbox.on_close(undo)
        return inbox

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
        """Hand the request object to the server's handler. A failed handler (it raised or
        returned a wrong type) answers with the exception: the future then holds a
        :class:`ServiceError` with its reason, as a Zenoh reply marked as failed does."""
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

    def declare_client(self, node: NodeInfo, name: str, srv: ServiceType) -> Closeable:
        endpoint = Endpoint("SC", node.fully_qualified_name, name, srv.name)
        self._add_endpoint(endpoint)
        return _Registration(lambda: self._remove_endpoint(endpoint))

    def announce_node(self, node: NodeInfo) -> Closeable:
        endpoint = Endpoint("NN", node.fully_qualified_name)
        self._add_endpoint(endpoint)
        return _Registration(lambda: self._remove_endpoint(endpoint))

    def graph(self, timeout: float = 0.5) -> list[Endpoint]:
        with self._lock:
            return list(self._endpoints)
