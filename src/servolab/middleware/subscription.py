"""A subscription: one topic, one type, one QoS profile, one callback (rclpy's
``Subscription``)."""

from __future__ import annotations

import inspect
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .fast_cdr import CdrError
from .inbox import NO_INFO, Taken
from .malformed import publisher_name
from .qos import QoSProfile

if TYPE_CHECKING:
    from .node import Node

#: what a transport that carries bytes hands over (the in-process one hands over objects)
_CDR = (bytes, memoryview)


class Subscription:
    """Calls ``callback(msg)``, or ``callback(msg, info)`` when created with
    ``with_info=True``, for each message on a topic.

    Messages wait in the transport's :mod:`.inbox`: up to ``qos.depth`` of them (KEEP_LAST;
    when more arrive, the oldest are dropped), or all (KEEP_ALL, what a recorder needs).
    ``raw=True`` hands the callback the CDR bytes.

    However fast messages arrive, a subscription has at most one piece of work queued in the
    executor: it takes one message, runs the callback, and queues itself again while messages
    wait. So due timers still come first, and subscriptions with messages waiting take turns,
    one callback each, as in rclpy's executor.

    Bytes that are not the topic's type are dropped, not a crash: counted against their
    publisher in the context's :class:`~.malformed.MalformedMessages` and said once per
    publisher on the node's logger (:mod:`.malformed`), and the next good message is
    delivered. :attr:`malformed` counts them for this subscription.

    ``run_on_arrival=True`` (servolab's own; rclpy has no such option) is for a callback
    whose latency matters more than the thread it runs on: over Zenoh, a message that finds
    the executor idle is taken and its callback run at once on the thread that received it
    (:meth:`Executor.run_if_idle <.executor.Executor.run_if_idle>`), still one callback at a
    time, rather than after that thread has woken the spinning one. A busy executor gets the
    message as any other. The callback then may run on either thread, so it must not need
    the spinning thread's own (a GUI's, ``signal.signal``'s main thread).

    The callback's signature is said, not guessed: a callback that needs two arguments
    without ``with_info=True`` is refused when the subscription is made, not when the first
    message comes.
    """

    def __init__(self, node: Node, type_name: str, topic: str, callback: Callable[..., Any],
                 qos: QoSProfile, *, raw: bool = False, with_info: bool = False,
                 run_on_arrival: bool = False) -> None:
        _check_signature(callback, 2 if with_info else 1, topic)
        self.node = node
        self.type_name = type_name
        self.topic = topic
        self.qos = qos
        self.raw = raw
        #: messages whose callback has run
        self.received = 0
        #: messages dropped because they did not deserialize (:mod:`.malformed`)
        self.malformed = 0
        self._callback = callback
        self._with_info = with_info
        self._submit = node.context.executor.submit
        self._deserialize = node.context.types.reader(type_name)
        self._take_turn = self._take  # bound once: queued again after every message
        self._destroyed = False
        # The transport may wake us before subscribe() returns (a TRANSIENT_LOCAL replay, a
        # publisher on another thread, Zenoh's watcher): such a wake-up is kept until the
        # inbox is ours, or the executor would take from an inbox we do not have yet.
        self._started = False
        self._early_wake = False
        self._start_lock = threading.Lock()
        self._inbox = node.context.transport.subscribe(node.info, topic, type_name, qos,
                                                       self._wake, raw=raw)
        # only where the inbox wakes us from the thread that received the message (Zenoh's
        # watcher): in process, that thread is the publisher's, whose publish() must not run
        # the subscriber's callback
        self._on_arrival = (run_on_arrival and self._inbox is not None
                            and self._inbox.wakes_on_receiving_thread)
        self._run_if_idle = node.context.executor.run_if_idle
        with self._start_lock:
            self._started = True
            early = self._early_wake
        if early:
            self._submit(self._take)

    @property
    def topic_name(self) -> str:
        """rclpy's name for :attr:`topic`."""
        return self.topic

    @property
    def pending(self) -> int:
        """Messages waiting for the callback (at most ``depth`` unless KEEP_ALL), where the
        transport can count them: in-process it can; over Zenoh they wait in Zenoh's channel,
        which does not say (0)."""
        return self._inbox.pending

    @property
    def dropped(self) -> int:
        """Messages dropped to keep ``depth`` (KEEP_LAST), where the transport can count them
        (in-process; Zenoh's ring channel drops without counting: 0)."""
        return self._inbox.dropped

    def _wake(self) -> None:
        if not self._started:
            with self._start_lock:
                if not self._started:
                    self._early_wake = True
                    return
        # one message, then the spinner's turn as after any callback: a stream never keeps
        # the spinner from a due timer or a stop
        if self._on_arrival and self._run_if_idle(self._take):
            return
        self._submit(self._take)

    def _take(self) -> None:
        if self._destroyed:
            return  # no callback after destroy(); what waits is for drain()
        taken = self._inbox.take(self._with_info)
        if taken is None:
            return  # the inbox wakes us when the next message comes
        try:
            self._run(taken)
        finally:  # more may wait (also after a callback that raised): look again after
            self._submit(self._take_turn)  # the others' turn

    def _run(self, taken: Taken) -> None:
        data, info = taken
        if not self.raw and isinstance(data, _CDR):
            try:
                data = self._deserialize(data)
            except CdrError as error:
                self._drop(info, error)
                return
        self.received += 1
        if self._with_info:
            self._callback(data, info)
        else:
            self._callback(data)

    def _drop(self, info: Any, error: CdrError) -> None:
        """A message from outside that is not the topic's type: counted, said once per
        publisher, never raised into the executor (any peer could stop the node)."""
        self.malformed += 1
        if info is NO_INFO:  # taken without its info: the inbox still knows who sent it
            info = self._inbox.last_info()
        n, counted_as = self.node.context.malformed.count(self.topic, info.publisher_gid)
        if n == 1:
            self.node.get_logger().error(
                "dropped a malformed message on %s from publisher %s: %s (the next from "
                "this publisher are dropped and counted, not said again)",
                self.topic, publisher_name(counted_as), error)

    def drain(self) -> int:
        """Run the callback for every message still waiting (a recorder stopping keeps what
        had already arrived); returns how many. Called after :meth:`destroy`, as the
        recorder does, it is the only one taking: the executor no longer does."""
        n = 0
        while (taken := self._inbox.take(self._with_info)) is not None:
            self._run(taken)
            n += 1
        return n

    def destroy(self) -> None:
        """Stop receiving (the transport forgets the subscription); no callback runs after
        this except through :meth:`drain`."""
        self._destroyed = True
        self._inbox.close()


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
