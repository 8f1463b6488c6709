"""A subscription's inbox over Zenoh: Zenoh's own channel, emptied by the executor.

A Zenoh subscriber with a Python callback takes the GIL on Zenoh's network thread for every
sample, and each message then crosses from that thread to the executor's: under a flood the
two threads pass the GIL back and forth for every message, which cost more than the rest of
receiving it (docs/middleware.md, "How fast"). Here Zenoh's thread only pushes the sample
into a Rust channel, without the GIL, and the executor pulls samples from it with
``try_recv()`` one after the other: a burst costs one wake-up.

Something must wake a sleeping executor when the channel, found empty, gets a sample: a
*watcher* thread that waits in the channel's ``recv()`` (which releases the GIL) only while
the inbox is armed, that is after the executor found it empty. It hands over the one sample it
received and waits again until the executor has emptied the channel, so it runs once per
burst, not per message.

KEEP_LAST(depth) is Zenoh's ``RingChannel(depth)``, which drops the oldest sample when full,
as the QoS means. KEEP_ALL is a ``FifoChannel`` of :data:`KEEP_ALL_CAPACITY` samples: when an
executor falls that far behind, Zenoh's receiving thread waits until it catches up, and with
it *everything* that session receives from that peer (other topics, service replies, graph
changes), and RELIABLE + KEEP_ALL publishers (which BLOCK) wait too. rmw_zenoh instead queues
a KEEP_ALL subscription's messages in memory without bound; here memory stays bounded (10 000
camera frames are 2.4 GB) and the stall lasts as long as the executor needs to catch up.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from typing import Any

import zenoh

from .inbox import NO_INFO, Taken, Wake
from .qos import QoSProfile
from .rmw_zenoh import ATTACHMENT, GID_SIZE
from .transport import MessageInfo

#: Samples a KEEP_ALL subscription's channel holds before Zenoh's thread waits for the executor.
KEEP_ALL_CAPACITY = 10_000
#: Samples a KEEP_ALL inbox moves from Zenoh's channel to its own queue at once. When the
#: channel is full, Zenoh's thread waits in it and every sample taken wakes it again: taking
#: one sample at a time, a flood cost a thread wake-up per message (a Twist's receiving side
#: 12 us a message instead of 5, benchmarks/middleware.py); taking a batch wakes it once per
#: batch. It adds at most this many samples to what the inbox holds.
KEEP_ALL_BATCH = 256
#: How long :meth:`ChannelInbox.close` waits for the watcher thread to leave (s).
_JOIN_TIMEOUT = 2.0


def channel_for(qos: QoSProfile) -> (zenoh.handlers.RingChannel[zenoh.Sample]
                                    | zenoh.handlers.FifoChannel[zenoh.Sample]):
    """The Zenoh channel that keeps what ``qos`` says a subscription keeps."""
    if qos.keep_all:
        return zenoh.handlers.FifoChannel(KEEP_ALL_CAPACITY)
    return zenoh.handlers.RingChannel(max(1, qos.depth))


def message_info(attachment: zenoh.ZBytes | None, received_ns: int) -> MessageInfo:
    """A received sample's :class:`MessageInfo` from rmw_zenoh's attachment (one struct
    unpack, without :func:`.rmw_zenoh.decode_attachment`'s checks); a sample without it (a
    plain Zenoh put) is still data, stamped on arrival."""
    if attachment is not None:
        data = attachment.to_bytes()
        if len(data) == ATTACHMENT.size and data[16] == GID_SIZE:
            sequence_number, timestamp, _, gid = ATTACHMENT.unpack(data)
            return MessageInfo(timestamp, received_ns, sequence_number, gid)
    return MessageInfo(received_ns, received_ns)


class ChannelInbox:
    """The inbox of one Zenoh subscriber declared with :func:`channel_for`'s channel.

    Messages are handed over as CDR bytes: one copy out of Zenoh per message (Zenoh's
    buffers do not expose Python's buffer protocol), and none after it (the generated codec
    reads an image's pixels with ``numpy.frombuffer`` at their offset in those bytes). A message's
    ``received_timestamp_ns`` is when the executor takes it; its attachment is decoded only
    for a consumer that asks for the :class:`MessageInfo`.

    KEEP_LAST(depth): the sample the watcher received waits outside the ring, so when the
    executor takes it, the newest ``depth`` of it and what the ring kept are kept and the
    older dropped: what a callback gets after a stall is the newest ``depth``, as in rclpy.
    After :meth:`close`, what had arrived can still be taken (a recorder stopping drains it).
    """

    dropped = 0  # Zenoh's ring channel drops without counting
    #: wake() comes from the watcher, a thread that may take and run the message itself
    #: (a subscription's ``run_on_arrival``)
    wakes_on_receiving_thread = True
    pending = 0  # nor does it say how many wait

    def __init__(self, subscriber: Any, wake: Wake, *, name: str, depth: int,
                 token: Any = None) -> None:
        self._subscriber = subscriber
        self._token = token  # the subscription's liveliness token, undeclared first
        self._channel = subscriber.handler
        self._wake = wake
        self._depth = depth  # 0: KEEP_ALL
        self._lock = threading.Lock()
        self._held: zenoh.Sample | None = None  # what the watcher received
        self._last: zenoh.Sample | None = None  # what take() gave last
        self._backlog: deque[zenoh.Sample] = deque(maxlen=depth or None)
        self._armed = threading.Event()  # the executor found it empty: the watcher waits
        self._armed.set()
        self._closed = False
        self._watcher = threading.Thread(target=self._watch, name=f"servolab-inbox {name}",
                                         daemon=True)
        self._watcher.start()

    def _watch(self) -> None:
        channel = self._channel
        while True:
            self._armed.wait()
            if self._closed:
                return
            try:
                sample = channel.recv()  # without the GIL, until a sample comes
            except zenoh.ZError:
                return  # undeclared or session closed: the channel is closed
            with self._lock:
                self._held = sample
                self._armed.clear()
                if self._closed:
                    return  # kept for a drain; no callback after close
            self._wake()

    def take(self, info: bool = True) -> Taken | None:
        try:
            # the backlog is the taker's alone (the watcher holds a sample only after it ran
            # dry): no lock for what waits there, most of a burst
            sample: zenoh.Sample | None = self._backlog.popleft()
        except IndexError:
            with self._lock:
                sample = self._next()
        if sample is None:
            return None
        self._last = sample  # one store; decoded only if the message turns out malformed
        return (sample.payload.to_bytes(),
                message_info(sample.attachment, time.time_ns()) if info else NO_INFO)

    def last_info(self) -> MessageInfo:
        last = self._last
        return NO_INFO if last is None else message_info(last.attachment, time.time_ns())

    def _next(self) -> zenoh.Sample | None:
        """The oldest sample waiting (under the lock), or None and the watcher armed."""
        held, self._held = self._held, None
        if held is not None:
            if not self._depth:
                return held
            # KEEP_LAST: the held sample and what the ring kept may be depth + 1
            self._backlog.append(held)
            self._take_batch(self._depth)
        if self._backlog:
            return self._backlog.popleft()
        if self._armed.is_set() and not self._closed:
            return None  # the watcher has the channel until it wakes us
        if not self._depth:  # KEEP_ALL: a batch, so that a full channel wakes Zenoh once
            self._take_batch(KEEP_ALL_BATCH)
            if self._backlog:
                return self._backlog.popleft()
            if not self._closed:
                self._armed.set()
            return None
        if (sample := self._try_recv()) is None and not self._closed:
            self._armed.set()
        return sample

    def _take_batch(self, limit: int) -> None:
        """Move up to ``limit`` samples from Zenoh's channel to the backlog (:meth:`_try_recv`'s
        work inline: a flood pays this loop per message)."""
        try_recv, append = self._channel.try_recv, self._backlog.append
        try:
            for _ in range(limit):
                sample = try_recv()
                if sample is None:
                    return
                append(sample)
        except zenoh.ZError:
            return  # closed and empty

    def _try_recv(self) -> zenoh.Sample | None:
        try:
            sample: zenoh.Sample | None = self._channel.try_recv()
            return sample
        except zenoh.ZError:
            return None  # closed and empty

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
        if self._token is not None:
            self._token.undeclare()  # leave the graph first, as rmw_zenoh does
        self._subscriber.undeclare()  # a watcher in recv() gets what is left, then an error
        self._armed.set()  # a watcher waiting to be armed leaves
        if self._watcher is not threading.current_thread():
            self._watcher.join(_JOIN_TIMEOUT)
