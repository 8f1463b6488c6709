"""TRANSIENT_LOCAL: a publisher keeps its last ``depth`` messages for subscriptions that come
later (a latched ``/robot_description``), in-process and over Zenoh.

Over Zenoh servolab does what rmw_zenoh does (``rmw_publisher_data.cpp`` /
``rmw_subscription_data.cpp``, Jazzy): a TRANSIENT_LOCAL publisher is a zenoh-ext
AdvancedPublisher with a cache of ``depth`` samples, a TRANSIENT_LOCAL subscription an
AdvancedSubscriber that queries the caches of publishers, late ones included. A VOLATILE
subscription gets only what is published after it exists, as in ROS 2.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator

import pytest

from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.qos import (
    KEEP_ALL_HISTORY,
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
)
from servolab.middleware.transport import TransportOptions
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

STRING = "std_msgs/msg/String"
LATCHED = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _late_joiner(publisher_ctx: Context, subscriber_ctx: Context) -> None:
    talker = Node(publisher_ctx, "robot_state_publisher")
    pub = talker.create_publisher(STRING, "/robot_description", LATCHED)
    for k in range(3):
        pub.publish(talker.message(STRING, data=f"urdf {k}"))
    listener = Node(subscriber_ctx, "late")
    latched: list[tuple[str, int]] = []
    volatile: list[str] = []
    listener.create_subscription(
        STRING, "/robot_description",
        lambda m, info: latched.append((m.data, info.sequence_number)), LATCHED,
        with_info=True)
    listener.create_subscription(STRING, "/robot_description",
                                 lambda m: volatile.append(m.data), 10)
    assert subscriber_ctx.spin_until(lambda: len(latched) >= 2, timeout=10.0)
    # the last depth (2) of the three, oldest first, with their original sequence numbers
    assert latched == [("urdf 1", 2), ("urdf 2", 3)]
    assert volatile == []
    pub.publish(talker.message(STRING, data="urdf 3"))
    assert subscriber_ctx.spin_until(lambda: len(latched) == 3 and volatile, timeout=10.0)
    assert latched[-1] == ("urdf 3", 4) and volatile == ["urdf 3"]


def test_late_joiner_in_process(types: MessageTypes) -> None:
    with Context.open(types=types) as ctx:
        _late_joiner(ctx, ctx)


@pytest.fixture
def two_sessions(types: MessageTypes) -> Iterator[tuple[Context, Context]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    a = Context.open(TransportOptions("zenoh", listen=[endpoint]), types=types)
    b = Context.open(TransportOptions("zenoh", connect=[endpoint]), types=types)
    try:
        yield a, b
    finally:
        b.close()
        a.close()


def test_late_joiner_over_zenoh(two_sessions: tuple[Context, Context]) -> None:
    _late_joiner(*two_sessions)


KEEP_ALL_LATCHED = QoSProfile(history=HistoryPolicy.KEEP_ALL, depth=0,
                              durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.mark.parametrize("transport", ["local", "zenoh"])
def test_keep_all_keeps_a_bounded_history(types: MessageTypes, transport: str) -> None:
    """TRANSIENT_LOCAL + KEEP_ALL keeps every message up to servolab's bound
    (KEEP_ALL_HISTORY) for a late subscription, in-process and over Zenoh."""
    assert KEEP_ALL_LATCHED.history_depth == KEEP_ALL_HISTORY
    options = TransportOptions(transport, listen=[f"tcp/127.0.0.1:{free_port()}"]
                               if transport == "zenoh" else [])
    with Context.open(options, types=types) as ctx:
        node = Node(ctx, "n")
        pub = node.create_publisher(STRING, "/log", KEEP_ALL_LATCHED)
        for k in range(5):
            pub.publish(node.message(STRING, data=str(k)))
        got: list[str] = []
        node.create_subscription(STRING, "/log", lambda m: got.append(m.data),
                                 KEEP_ALL_LATCHED)
        assert ctx.spin_until(lambda: len(got) == 5, timeout=10.0)
        assert got == ["0", "1", "2", "3", "4"]


LATE_PROCESS = """
import sys
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import (
    KEEP_ALL_HISTORY,
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
)
from servolab.middleware.transport import TransportOptions
ctx = Context.open(TransportOptions("zenoh", connect=[sys.argv[1]]))
latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
Node(ctx, "late").create_subscription("std_msgs/msg/String", "/robot_description",
                                      lambda m: print("got", m.data, flush=True), latched)
print("subscribed", flush=True)
with ctx.stop_on_signals():
    ctx.spin()
ctx.close()
"""


@pytest.mark.slow
def test_a_process_started_after_the_publish_gets_the_latched_message(
        types: MessageTypes) -> None:
    """The /robot_description case: published once, then a subscriber process starts."""
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with Context.open(TransportOptions("zenoh", listen=[endpoint]), types=types) as ctx:
        node = Node(ctx, "robot_state_publisher")
        node.create_publisher(STRING, "/robot_description", QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)).publish(
            node.message(STRING, data="<robot name='biped'/>"))
        with started([sys.executable, "-c", LATE_PROCESS, endpoint]) as late:
            wait_for_line(late, "subscribed")
            wait_for_line(late, "got <robot name='biped'/>", timeout=15.0)
