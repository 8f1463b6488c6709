"""No start-up race: a publisher that has seen a subscription's liveliness token loses nothing
it publishes right then (the subscriber is declared before its token, as in rmw_zenoh)."""

from __future__ import annotations

import sys
import threading
import time

import pytest

from servolab.middleware.qos import QoSProfile
from servolab.middleware.rmw_zenoh import parse_token
from servolab.middleware.transport import MessageInfo, NodeInfo
from tests.middleware.conftest import free_port
from tests.middleware.inboxes import subscribe_with
from tests.processes import started
from tests.waiting import wait_for, wait_for_line

STRING = "std_msgs/msg/String"
REPETITIONS = 200


@pytest.mark.slow
def test_publish_right_after_the_token_loses_nothing(zenoh_pair) -> None:
    """200 times: a subscription appears in one session; the other sees its token (as a
    publisher's graph cache would) and publishes one message at once, from the token's
    callback. Every one of the 200 messages arrives."""
    a, b, _ = zenoh_pair
    seen: dict[str, threading.Event] = {}
    lock = threading.Lock()

    def on_token(sample) -> None:
        if str(sample.kind) != "SampleKind.PUT":
            return
        entity = parse_token(str(sample.key_expr))
        if entity.kind == "MS" and entity.topic:
            with lock:
                event = seen.get(entity.topic)
            if event is not None:
                event.set()

    topics = [f"/race_{k}" for k in range(REPETITIONS)]
    talker, listener = NodeInfo("talker", node_id=1), NodeInfo("listener", node_id=2)
    publishers = {t: a.transport.advertise(talker, t, STRING, QoSProfile()) for t in topics}
    cdr = a.types.serialize(a.types.from_value(STRING, {"data": "first"}))
    watcher = a.transport.session.liveliness().declare_subscriber("@ros2_lv/0/**", on_token)
    got: dict[str, list[bytes]] = {t: [] for t in topics}
    subscriptions = []
    lost = []
    try:
        for topic in topics:
            matched = threading.Event()
            with lock:
                seen[topic] = matched

            def deliver(data: bytes, info: MessageInfo, topic: str = topic) -> None:
                got[topic].append(data)

            subscriptions.append(subscribe_with(b.transport, listener, topic, STRING, deliver))
            # Generous bounds: a loaded 2-core machine can be slow; a lost message never comes.
            assert matched.wait(20.0), f"the token of {topic}'s subscription never arrived"
            publishers[topic].publish_serialized(cdr)  # right away, as a waiting talker does
            try:
                wait_for(lambda topic=topic: got[topic], f"the message on {topic}",
                         timeout=10.0)
            except AssertionError:
                lost.append(topic)
        assert not lost, f"{len(lost)} of {REPETITIONS} first messages lost: {lost[:5]}"
        assert all(v == [cdr] for v in got.values())
    finally:
        watcher.undeclare()
        for s in subscriptions:
            s.close()
        for p in publishers.values():
            p.close()


LISTENER = """
import sys
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
ctx = Context.open(TransportOptions("zenoh", listen=[sys.argv[1]]))
node = Node(ctx, "listener")
def show(msg):
    print("got", msg.data, flush=True)
node.create_subscription("std_msgs/msg/String", "/chatter", show)
print("ready", flush=True)
with ctx.stop_on_signals():
    ctx.spin()
ctx.close()
"""


@pytest.mark.slow
def test_topic_pub_once_reaches_a_subscriber_process(types) -> None:
    """``topic pub --once`` waits for the subscription (not a fixed time) and its one
    message arrives, a few times over, each time with a fresh subscriber process."""
    from servolab.apps.topic import topic_pub
    from servolab.middleware.context import Context
    from servolab.middleware.transport import TransportOptions

    for k in range(3):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        with started([sys.executable, "-c", LISTENER, endpoint]) as listener:
            wait_for_line(listener, "ready")
            ctx = Context.open(TransportOptions("zenoh", connect=[endpoint]), types=types)
            try:
                said: list[str] = []
                sent = topic_pub(ctx, "/chatter", STRING, f"{{data: hello {k}}}",
                                 said.append, count=1, wait_matching=10.0)
                assert sent == 1
                assert not any("no subscription" in s for s in said), said
            finally:
                ctx.close()
            wait_for_line(listener, f"got hello {k}", timeout=5.0)


@pytest.mark.slow
def test_topic_pub_says_when_nobody_subscribes(types) -> None:
    from servolab.apps.topic import topic_pub
    from servolab.middleware.context import Context

    ctx = Context.open(types=types)
    try:
        said: list[str] = []
        assert topic_pub(ctx, "/nobody", STRING, "{data: x}", said.append, count=1,
                         wait_matching=0.3) == 1
        assert any("no subscription on /nobody" in s for s in said), said
    finally:
        ctx.close()


def test_wait_for_subscription_in_one_process(types) -> None:
    """False when nobody subscribes (or only with another type); True as soon as a
    subscription of the type appears, from another thread, without waiting the timeout."""
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node

    with Context.open(types=types) as ctx:
        talker, listener = Node(ctx, "talker"), Node(ctx, "listener")
        pub = talker.create_publisher(STRING, "/chatter")
        assert not pub.wait_for_subscription(0.05)
        listener.create_subscription("std_msgs/msg/Float64", "/chatter", lambda m: None)
        assert not pub.wait_for_subscription(0.05)
        later = threading.Timer(0.1, lambda: listener.create_subscription(
            STRING, "/chatter", lambda m: None))
        later.start()
        start = time.monotonic()
        try:
            assert pub.wait_for_subscription(30.0)
            # woken by the subscription, not by the end of the 30 s (generous for a slow CI)
            assert time.monotonic() - start < 20.0
        finally:
            later.join()


def test_wait_for_subscription_over_zenoh_then_nothing_is_lost(zenoh_pair) -> None:
    """A plain and a TRANSIENT_LOCAL publisher (an AdvancedPublisher, which has no matching
    status of its own) wait for a subscription in another session; what they publish right
    after arrives."""
    from servolab.middleware.node import Node
    from servolab.middleware.qos import qos_profile_latched

    a, b, _ = zenoh_pair
    talker, listener = Node(a, "talker"), Node(b, "listener")
    for topic, qos in (("/plain", QoSProfile()), ("/latched", qos_profile_latched)):
        pub = talker.create_publisher(STRING, topic, qos)
        assert not pub.wait_for_subscription(0.05)
        got: list[str] = []
        listener.create_subscription(STRING, topic, lambda m, got=got: got.append(m.data), qos)
        assert pub.wait_for_subscription(20.0), topic
        pub.publish(talker.message(STRING, data="first"))
        assert b.spin_until(lambda got=got: got == ["first"], timeout=10.0), (topic, got)
