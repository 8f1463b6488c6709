"""Where a subscription's messages wait for the executor: its inbox.

A transport fills the inbox from its own thread; the executor empties it on the thread that
spins. The two meet edge-triggered, as ``epoll(EPOLLET)`` does: the transport calls ``wake()``
when a message arrives in an inbox that its consumer had found empty, and not again until the
consumer has called :meth:`Inbox.take` until it returned None. So a burst of a thousand
messages costs one wake-up, not a thousand, and a subscription whose messages only the
executor takes never has more than one piece of work queued there, however fast they come.

The in-process transport pushes message objects into a :class:`QueueInbox`; the Zenoh
transport's inbox is Zenoh's own channel (``zenoh_transport.ChannelInbox``), which Zenoh's
thread fills without taking Python's GIL.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable
from typing import Any, Protocol

from .transport import MessageInfo

#: Called by the transport, on its thread, when an inbox its consumer found empty has a message.
Wake = Callable[[], None]
#: What :meth:`Inbox.take` gives: the message (an object, or CDR bytes / a memoryview of them
#: from a transport that carries bytes or for a raw subscription) and where it came from.
Taken = tuple[Any, MessageInfo]
#: The info of a message taken with ``info=False`` where decoding it was skipped.
NO_INFO = MessageInfo(0, 0)


class Inbox(Protocol):
    """One subscription's waiting messages, oldest first."""

    #: messages dropped to keep the QoS depth, where the inbox can count them
    dropped: int
    #: whether ``wake()`` comes from the thread that received the message, one that may take
    #: and run it itself (a subscription's ``run_on_arrival``); not where it is the
    #: publisher's own (in process), whose publish() must not run a subscriber's callback
    wakes_on_receiving_thread: bool

    def take(self, info: bool = True) -> Taken | None:
        """The oldest waiting message, or None (and the next arrival calls ``wake()``).
        With ``info=False`` the caller will not look at the :class:`MessageInfo`, which an
        inbox may then leave undecoded (:data:`NO_INFO`)."""

    @property
    def pending(self) -> int:
        """Messages waiting, where the inbox can count them (else 0)."""

    def last_info(self) -> MessageInfo:
        """The :class:`MessageInfo` of the message :meth:`take` gave last, even when it was
        taken with ``info=False`` (a subscription names the publisher of a message that did
        not deserialize: :mod:`.malformed`)."""

    def close(self) -> None:
        """Stop receiving; what waits may still be taken."""


class QueueInbox:
    """An inbox of at most ``depth`` messages (0: no bound, KEEP_ALL); when full, the oldest
    is dropped and counted, which is KEEP_LAST."""

    #: (see :class:`Inbox`: in process the publisher's thread calls wake())
    wakes_on_receiving_thread = False

    def __init__(self, depth: int, wake: Wake) -> None:
        self.dropped = 0
        self._queue: deque[Taken] = deque(maxlen=depth or None)
        self._lock = threading.Lock()
        self._wake = wake
        self._armed = True  # the consumer found it empty: the next put wakes it
        self._on_close: Callable[[], None] | None = None
        self._last: MessageInfo = NO_INFO

    def put(self, data: Any, info: MessageInfo) -> None:
        """From any thread: keep the message; wake the consumer if it was waiting for one."""
        with self._lock:
            if len(self._queue) == self._queue.maxlen:
                self.dropped += 1
            self._queue.append((data, info))
            wake, self._armed = self._armed, False
        if wake:
            self._wake()

    def take(self, info: bool = True) -> Taken | None:
        with self._lock:
            if self._queue:
                taken = self._queue.popleft()
                self._last = taken[1]
                return taken
            self._armed = True
            return None

    @property
    def pending(self) -> int:
        return len(self._queue)

    def last_info(self) -> MessageInfo:
        return self._last

    def on_close(self, undo: Callable[[], None]) -> None:
        """What :meth:`close` does to stop the transport putting (once)."""
        self._on_close = undo

    def close(self) -> None:
        undo, self._on_close = self._on_close, None
        if undo is not None:
            undo()
