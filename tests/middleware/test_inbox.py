"""Subscriptions' inboxes (``inbox.py``, ``zenoh_inbox.py``): KEEP_LAST over Zenoh's ring
channel, one piece of executor work per subscription, a raising callback that does not stop
its subscription, and watcher threads that leave with their subscription or context."""

from __future__ import annotations

import threading
from typing import Any

import zenoh

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.rmw_zenoh import topic_keyexpr
from tests.waiting import wait_for, wait_for_subscriber

FLOAT = "std_msgs/msg/Float64"


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
    # a bare Zenoh subscriber on the same key counts arrivals without the executor
    arrived = [0]
    key = topic_keyexpr(0, "/x", FLOAT, b.types.rihs01(FLOAT))
    counter = b.transport.session.declare_subscriber(  # type: ignore[attr-defined]
        key, lambda s: arrived.__setitem__(0, arrived[0] + 1))
    try:
        pub = talker.create_publisher(FLOAT, "/x", 0)  # KEEP_ALL: BLOCKs, never drops
        wait_for_subscriber(a, "/x", FLOAT, "/listener")
        b.executor.spin_in_thread()
        pub.publish(talker.message(FLOAT, data=-1.0))
        assert entered.wait(10.0)
        for k in range(100):
            pub.publish(talker.message(FLOAT, data=float(k)))
        wait_for(lambda: arrived[0] == 101, lambda: f"101 arrivals, {arrived[0]}")
        release.set()
        wait_for(lambda: got and got[-1] == 99.0, lambda: f"the last message, got {got}")
        assert got == [-1.0, 95.0, 96.0, 97.0, 98.0, 99.0]
    finally:
        release.set()
        counter.undeclare()


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
    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    got: list[float] = []
    listener.create_subscription(FLOAT, "/z", lambda m: got.append(m.data), qos_profile=0)
    pub = talker.create_publisher(FLOAT, "/z", 0)
    wait_for_subscriber(a, "/z", FLOAT, "/listener")
    for k in range(200):
        pub.publish(talker.message(FLOAT, data=float(k)))
    wait_for(lambda: b.executor.pending == 1, "the watcher's wake-up")
    assert b.executor.pending == 1  # not 200: the rest wait in Zenoh's channel
    assert b.spin_until(lambda: len(got) == 200, timeout=10.0)


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
