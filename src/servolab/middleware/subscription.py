"""A subscription: one topic, one type, one QoS profile, one callback (rclpy's
``Subscription``)."""

from __future__ import annotations

import inspect
import threading
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .qos import QoSProfile
from .transport import MessageInfo

if TYPE_CHECKING:
    from .node import Node


class Subscription:
    """Calls ``callback(msg)``, or ``callback(msg, info)`` when created with
    ``with_info=True``, for each message on a topic.

    Up to ``qos.depth`` messages wait for the executor (KEEP_LAST); when more arrive, the
    oldest are dropped and counted in :attr:`dropped`. KEEP_ALL keeps all, which is what a
    recorder needs. ``raw=True`` hands the callback the CDR bytes.

    The executor holds one piece of work per message waiting, not per message received: a
    KEEP_LAST(depth) subscription never has more than ``depth`` callbacks pending, however
    fast messages arrive, and callbacks keep the order in which messages arrived.

    The callback's signature is said, not guessed: a callback that needs two arguments
    without ``with_info=True`` is refused when the subscription is made, not when the first
    message comes.
    """

    def __init__(self, node: Node, type_name: str, topic: str, callback: Callable[..., Any],
                 qos: QoSProfile, *, raw: bool = False, with_info: bool = False) -> None:
        _check_signature(callback, 2 if with_info else 1, topic)
        self.node = node
        self.type_name = type_name
        self.topic = topic
        self.qos = qos
        self.raw = raw
        self.dropped = 0
        self.received = 0
        self._callback = callback
        self._with_info = with_info
        self._queue: deque[tuple[Any, MessageInfo]] = deque(maxlen=qos.queue_depth or None)
        self._lock = threading.Lock()
        self._takes = 0  # _take calls queued in the executor
        self._executor = node.context.executor
        self._deserialize = node.context.types.deserialize
        self._inner = node.context.transport.subscribe(node.info, topic, type_name, qos,
                                                       self._deliver, raw=raw)

    @property
    def topic_name(self) -> str:
        """rclpy's name for :attr:`topic`."""
        return self.topic

    def _deliver(self, data: Any, info: MessageInfo) -> None:
        with self._lock:
            if self._queue.maxlen is not None and len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append((data, info))
            self.received += 1
            if self._takes >= len(self._queue):
                return  # a message was dropped: its queued _take will take this one
            self._takes += 1
        self._executor.submit(self._take)

    @property
    def pending(self) -> int:
        """Messages waiting for the callback (at most ``depth`` unless KEEP_ALL)."""
        return len(self._queue)

    def drain(self) -> int:
        """Run the callback for every message still queued (a recorder stopping keeps what
        had already arrived); returns how many."""
        n = 0
        while self._queue:
            self._take(from_executor=False)
            n += 1
        return n

    def _take(self, from_executor: bool = True) -> None:
        with self._lock:
            if from_executor:
                self._takes -= 1
            if not self._queue:
                return  # drained while waiting
            data, info = self._queue.popleft()
        if not self.raw and isinstance(data, bytes | memoryview):
            data = self._deserialize(data, self.type_name)
        if self._with_info:
            self._callback(data, info)
        else:
            self._callback(data)

    def destroy(self) -> None:
        self._inner.close()


def _check_signature(callback: Callable[..., Any], given: int, topic: str) -> None:
    """Refuse a callback that cannot be called with ``given`` positional arguments."""
    if not callable(callback):
        raise TypeError(f"subscription callback for {topic} is {callback!r}, not callable")
    try:
        signature = inspect.signature(callback)
    except (TypeError, ValueError):
        return  # a builtin without a signature: trust the caller
    try:
        signature.bind(*range(given))
    except TypeError:
        hint = ("; a callback(msg, info) needs with_info=True" if given == 1
                else "; with_info=True calls it as callback(msg, info)")
        raise TypeError(f"subscription callback {getattr(callback, '__name__', callback)!r} "
                        f"for {topic} cannot be called with {given} argument(s){hint}") from None
