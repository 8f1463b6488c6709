"""Subscriptions' inboxes (``inbox.py``, ``zenoh_inbox.py``): KEEP_LAST over Zenoh's ring
channel, one piece of executor work per subscription, a raising callback that does not stop
its subscription, and watcher threads that leave with their subscription or context."""

from __future__ import annotations

import threading
from typing import Any

import pytest
import zenoh

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.rmw_zenoh import topic_keyexpr
from servolab.middleware.subscription import Subscription
from tests.waiting import wait_for, wait_for_subscriber

FLOAT = "std_msgs/msg/Float64"


class _Arrivals:
    """A bare Zenoh subscriber on a topic's key in ``context``'s session: counts what
    arrives there without the executor."""

    def __init__(self, context: Context, topic: str, type_name: str = FLOAT) -> None:
        self.count = 0
        key = topic_keyexpr(0, topic, type_name, context.types.rihs01(type_name))
        session: zenoh.Session = context.transport.session  # type: ignore[attr-defined]
        self._subscriber = session.declare_subscriber(key, self._arrived)

    def _arrived(self, sample: zenoh.Sample) -> None:
        self.count += 1

    def close(self) -> None:
        self._subscriber.undeclare()


def _watchers() -> list[threading.Thread]:
    return [t for t in threading.enumerate() if t.name.startswith("servolab-inbox")]


def test_keep_last_over_zenoh_keeps_the_newest_depth(zenoh_pair: tuple[Context, Context, int]
                                                     ) -> None:
    """100 messages arrive while the callback is blocked: Zenoh's ring channel of depth 5
    keeps the newest 5 (plus the one the watcher already handed over), oldest dropped."""
    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    got: list[float] = []
    entered, release = threading.Event(), threading.Event()

    def callback(m: Any) -> None:
        if m.data < 0:
            entered.set()
            assert release.wait(10.0)
        got.append(m.data)

    listener.create_subscription(FLOAT, "/x", callback, qos_profile=5)
    arrived = _Arrivals(b, "/x")
    try:
        pub = talker.create_publisher(FLOAT, "/x", 0)  # KEEP_ALL: BLOCKs, never drops
        wait_for_subscriber(a, "/x", FLOAT, "/listener")
        b.executor.spin_in_thread()
        pub.publish(talker.message(FLOAT, data=-1.0))
        assert entered.wait(10.0)
        for k in range(100):
            pub.publish(talker.message(FLOAT, data=float(k)))
        wait_for(lambda: arrived.count == 101, lambda: f"101 arrivals, {arrived.count}")
        release.set()
        wait_for(lambda: got and got[-1] == 99.0, lambda: f"the last message, got {got}")
        assert got == [-1.0, 95.0, 96.0, 97.0, 98.0, 99.0]
    finally:
        release.set()
        arrived.close()


def _flood_while_idle(zenoh_pair: tuple[Context, Context, int], topic: str, n: int,
                      depth: int) -> tuple[Subscription, list[float]]:
    """A subscription of ``depth`` in the second session, and ``n`` messages from the first
    that have all arrived there (counted by a bare Zenoh subscriber) while its executor did
    not spin; the subscription and the list its callback appends to."""
    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    got: list[float] = []
    sub = listener.create_subscription(FLOAT, topic, lambda m: got.append(m.data),
                                       qos_profile=depth)
    pub = talker.create_publisher(FLOAT, topic, 0)  # KEEP_ALL: BLOCKs, never drops
    wait_for_subscriber(a, topic, FLOAT, "/listener")
    arrived = _Arrivals(b, topic)
    try:
        for k in range(n):
            pub.publish(talker.message(FLOAT, data=float(k)))
        wait_for(lambda: arrived.count == n, lambda: f"{n} arrivals, {arrived.count}")
    finally:
        arrived.close()
    return sub, got


@pytest.mark.parametrize("depth", [1, 3])
def test_keep_last_over_zenoh_after_an_idle_executor_gets_the_newest(
        zenoh_pair: tuple[Context, Context, int], depth: int) -> None:
    """The executor sleeps while 100 messages arrive: the watcher holds the first, the ring
    the newest ``depth``; the callbacks then get the newest ``depth`` only, never the stale
    first one (the newest ``depth`` of what waits, as rclpy's KEEP_LAST)."""
    _, got = _flood_while_idle(zenoh_pair, "/idle", 100, depth)
    b = zenoh_pair[1]
    b.spin_until(lambda: bool(got) and got[-1] == 99.0, timeout=5.0)
    assert got == [float(k) for k in range(100 - depth, 100)]


def test_a_flood_over_zenoh_arrives_whole_and_in_order(zenoh_pair: tuple[Context, Context, int]
                                                       ) -> None:
    """KEEP_ALL (depth 0) through Zenoh's FIFO channel: all 5000, in order, with info."""
    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    got: list[tuple[float, int]] = []
    listener.create_subscription(FLOAT, "/flood", lambda m, info: got.append(
        (m.data, info.sequence_number)), qos_profile=0, with_info=True)
    pub = talker.create_publisher(FLOAT, "/flood", 0)
    wait_for_subscriber(a, "/flood", FLOAT, "/listener")
    for k in range(5000):
        pub.publish(talker.message(FLOAT, data=float(k)))
    assert b.spin_until(lambda: len(got) == 5000, timeout=30.0), len(got)
    assert got == [(float(k), k + 1) for k in range(5000)]


def test_without_info_the_attachment_is_not_decoded(zenoh_pair: tuple[Context, Context, int]
                                                    ) -> None:
    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    sub = listener.create_subscription(FLOAT, "/y", lambda m: None)
    pub = talker.create_publisher(FLOAT, "/y")
    wait_for_subscriber(a, "/y", FLOAT, "/listener")
    pub.publish(talker.message(FLOAT, data=1.0))
    inbox = sub._inbox
    wait_for(lambda: inbox._held is not None, "the watcher's sample")  # type: ignore[attr-defined]
    data, info = inbox.take(info=False)  # type: ignore[misc]
    assert b.types.deserialize(data, FLOAT).data == 1.0
    assert (info.sequence_number, info.source_timestamp_ns) == (0, 0)  # NO_INFO


def test_one_piece_of_executor_work_per_subscription_over_zenoh(
        zenoh_pair: tuple[Context, Context, int]) -> None:
    _, got = _flood_while_idle(zenoh_pair, "/z", 200, 0)
    b = zenoh_pair[1]
    wait_for(lambda: b.executor.pending == 1, "the watcher's wake-up")
    assert b.executor.pending == 1  # not 200: the rest wait in Zenoh's channel
    assert b.spin_until(lambda: len(got) == 200, timeout=10.0)
    assert got == [float(k) for k in range(200)]


def test_what_arrived_is_drained_after_destroy_and_no_callback_runs_after(
        zenoh_pair: tuple[Context, Context, int]) -> None:
    """As a recorder stops: the subscription is destroyed with 1000 messages waiting in
    Zenoh's channel; ``drain()`` still runs their callbacks, in order, and the executor
    runs none after ``destroy()``."""
    sub, got = _flood_while_idle(zenoh_pair, "/drain", 1000, 0)
    b = zenoh_pair[1]
    sub.destroy()
    b.spin_until(lambda: b.executor.pending == 0, timeout=5.0)  # the queued take: no callback
    assert got == []
    assert sub.drain() == 1000
    assert got == [float(k) for k in range(1000)]


def test_a_message_during_subscription_start_up_is_not_lost(
        types: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """The transport may wake a subscription from inside ``subscribe()`` (here the replay of
    a latched message) and the executor, spinning on another thread, may run before
    ``subscribe()`` returns: made certain here by spinning inside it. The wake-up waits
    until the subscription has its inbox, and the message arrives."""
    from servolab.middleware.qos import qos_profile_latched

    with Context.open(types=types) as ctx:
        node = Node(ctx, "n")
        pub = node.create_publisher(FLOAT, "/latched", qos_profile_latched)
        pub.publish(node.message(FLOAT, data=7.0))
        subscribe = ctx.transport.subscribe

        def subscribe_then_spin(*args: Any, **kwargs: Any) -> Any:
            inbox = subscribe(*args, **kwargs)
            ctx.executor.spin_once(0)  # the executor's thread, before subscribe() returns
            return inbox

        monkeypatch.setattr(ctx.transport, "subscribe", subscribe_then_spin)
        got: list[float] = []
        node.create_subscription(FLOAT, "/latched", lambda m: got.append(m.data),
                                 qos_profile_latched)
        assert ctx.spin_until(lambda: got == [7.0], timeout=5.0), got


def test_a_raising_callback_does_not_stop_its_subscription(types: Any) -> None:
    """With ``on_error="log"`` the spin thread keeps going, and so does the subscription
    whose callback raised: it still queues its next take."""
    with Context.open(types=types) as ctx:
        _raise_then_keep_going(ctx)


def _raise_then_keep_going(ctx: Context) -> None:
    node = Node(ctx, "n")
    got: list[float] = []

    def callback(m: Any) -> None:
        if m.data == 0.0:
            raise RuntimeError("first message")
        got.append(m.data)

    node.create_subscription(FLOAT, "/r", callback, qos_profile=0)
    pub = node.create_publisher(FLOAT, "/r", 0)
    for k in range(3):
        pub.publish(node.message(FLOAT, data=float(k)))
    ctx.executor.spin_in_thread(on_error="log")
    wait_for(lambda: got == [1.0, 2.0], lambda: f"the two others, got {got}")


def test_watcher_threads_leave_with_their_subscription_and_context(types: Any) -> None:
    from servolab.middleware.transport import TransportOptions
    from tests.middleware.conftest import free_port

    before = set(_watchers())
    with Context.open(TransportOptions(
            "zenoh", listen=[f"tcp/127.0.0.1:{free_port()}"]), types=types) as ctx:
        node = Node(ctx, "n")
        first = node.create_subscription(FLOAT, "/a", lambda m: None)
        node.create_subscription(FLOAT, "/b", lambda m: None)
        assert len(set(_watchers()) - before) == 2
        first.destroy()
        wait_for(lambda: len(set(_watchers()) - before) == 1, "one watcher left")
    wait_for(lambda: not set(_watchers()) - before, "no watcher left")


def test_a_plain_zenoh_put_is_still_data(zenoh_pair: tuple[Context, Context, int]) -> None:
    """A sample without rmw_zenoh's attachment (a bare ``zenoh`` put) is delivered, stamped
    on arrival."""
    a, b, _ = zenoh_pair
    got: list[tuple[float, int]] = []
    Node(b, "listener").create_subscription(FLOAT, "/plain", lambda m, info: got.append(
        (m.data, info.sequence_number)), with_info=True)
    wait_for_subscriber(a, "/plain", FLOAT, "/listener")
    session: zenoh.Session = a.transport.session  # type: ignore[attr-defined]
    session.put(topic_keyexpr(0, "/plain", FLOAT, a.types.rihs01(FLOAT)),
                a.types.serialize(a.types.from_value(FLOAT, {"data": 2.5})))
    assert b.spin_until(lambda: got == [(2.5, 0)], timeout=5.0), got
