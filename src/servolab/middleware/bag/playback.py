"""Playing a bag back: :func:`play` publishes its messages at the bag's own pace (or a
multiple of it) on any :class:`~servolab.clock.Clock`.

It hands CDR bytes to a ``publish`` callable and knows nothing of publishers or transports, so
a test plays a bag into a list, and ``servolab bag play`` into its node's publishers (waiting
there for their subscriptions before the first message).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterable

from ...clock import Clock, WallClock
from ..errors import BagError
from .reader import BagReader

#: While waiting for a message's time, :func:`play` looks at ``should_stop`` this often.
_STOP_POLL_S = 0.05


def play(reader: BagReader, publish: Callable[[str, str, bytes], None], *, rate: float = 1.0,
         clock: Clock | None = None, topics: Iterable[str] | None = None,
         start_offset: float = 0.0, should_stop: Callable[[], bool] | None = None,
         progress: Callable[[int, int], None] | None = None) -> int:
    """Publish the bag's messages (``publish(topic, type, cdr_bytes)``) at the bag's own pace.

    A message logged ``t`` seconds after the bag's start (plus ``start_offset``) is published
    ``t / rate`` seconds after ``play`` begins on ``clock`` (rate 2 is twice as fast; rate 0 or
    infinity, as fast as possible); messages before ``start_offset`` are skipped. With a
    :class:`~servolab.clock.VirtualClock` no real time passes. ``progress(done, total)`` follows
    each message: ``done`` counts messages published or skipped, ``total`` those the chosen
    topics hold. ``should_stop()`` is asked before each message and while waiting. Returns the
    number published.
    """
    if math.isnan(rate) or rate < 0:
        raise BagError(f"playback rate must be zero, positive or infinite, not {rate}")
    if math.isnan(start_offset) or start_offset < 0:
        raise BagError(f"start offset must be zero or positive seconds, not {start_offset}")
    clock = clock or WallClock()
    wanted = None if topics is None else ({topics} if isinstance(topics, str) else set(topics))
    messages = reader.messages(wanted)  # checks the topics before any time passes
    info = reader.info()
    total = sum(t.count for t in info.topics if wanted is None or t.name in wanted)
    origin_ns = info.start_ns + round(start_offset * 1e9)
    timed = 0 < rate < math.inf
    began = clock.now()
    played = 0
    with contextlib.closing(messages):  # stopping early closes the file at once
        for done, msg in enumerate(messages, 1):
            if should_stop is not None and should_stop():
                break
            if msg.log_time_ns >= origin_ns:
                if timed and not _wait_until(
                        clock, began + (msg.log_time_ns - origin_ns) / 1e9 / rate, should_stop):
                    break
                publish(msg.topic, msg.type, msg.data)
                played += 1
            if progress is not None:
                progress(done, total)
    return played


def _wait_until(clock: Clock, target: float, should_stop: Callable[[], bool] | None) -> bool:
    """Sleep until ``clock`` reads ``target``; false if ``should_stop`` said stop meanwhile."""
    while True:
        delay = target - clock.now()
        if delay <= 0:
            return True
        if should_stop is None:
            clock.sleep(delay)
            continue
        if should_stop():
            return False
        clock.sleep(min(delay, _STOP_POLL_S))
