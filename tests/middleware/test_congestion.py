"""Never block a control loop: a stopped (SIGSTOP) remote subscriber does not stall a KEEP_LAST
publisher's ``publish()`` (rmw_zenoh's congestion control: DROP unless RELIABLE + KEEP_ALL),
and the publishing node's timers keep their rate meanwhile."""

from __future__ import annotations

import os
import signal
import sys
import time
from dataclasses import replace

import pytest
import zenoh

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import QoSProfile, ReliabilityPolicy, as_profile
from servolab.middleware.transport import TransportOptions
from servolab.middleware.zenoh_transport import congestion_control
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line, wait_for_subscriber

#: holds the wall clock to deadlines: never beside another such test (tests/conftest.py)
pytestmark = pytest.mark.realtime

IMAGE = "sensor_msgs/msg/Image"
MESSAGES = 2000
PAYLOAD = 64 * 1024
#: The documented bound on one publish() of a KEEP_LAST publisher while a subscriber is stalled
#: (generous: Zenoh drops after ~1 ms, 50 ms for a fragmented message).
PUBLISH_BOUND_S = 0.05
RELIABLE, BEST_EFFORT = ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT

SINK = """
import sys
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
ctx = Context.open(TransportOptions("zenoh", connect=[sys.argv[1]]))
Node(ctx, "sink").create_subscription("sensor_msgs/msg/Image", "/flood", lambda m: None)
print("ready", flush=True)
with ctx.stop_on_signals():
    ctx.spin()
ctx.close()
"""


def test_congestion_control_is_rmw_zenohs() -> None:
    assert congestion_control(reliable=True, depth=0) == zenoh.CongestionControl.BLOCK
    assert congestion_control(reliable=True, depth=10) == zenoh.CongestionControl.DROP
    assert congestion_control(reliable=False, depth=10) == zenoh.CongestionControl.DROP
    assert congestion_control(reliable=False, depth=0) == zenoh.CongestionControl.DROP


@pytest.mark.slow
@pytest.mark.parametrize("reliable", [True, False], ids=["reliable", "best_effort"])
def test_stopped_subscriber_does_not_block_publish_or_timers(types, reliable: bool) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    ctx = Context.open(TransportOptions("zenoh", listen=[endpoint]), types=types)
    try:
        with started([sys.executable, "-c", SINK, endpoint]) as sink:
            wait_for_line(sink, "ready")
            node = Node(ctx, "camera")
            pub = node.create_publisher(IMAGE, "/flood", QoSProfile(
                depth=10, reliability=RELIABLE if reliable else BEST_EFFORT))
            wait_for_subscriber(ctx, "/flood", IMAGE, "/sink")
            msg = node.message(IMAGE, height=1, width=PAYLOAD, encoding="mono8", step=PAYLOAD,
                               data=bytes(PAYLOAD))
            durations: list[float] = []
            ticks: list[float] = []

            def publish_one() -> None:
                if len(durations) < MESSAGES:
                    start = time.perf_counter()
                    pub.publish(msg)
                    durations.append(time.perf_counter() - start)

            os.kill(sink.pid, signal.SIGSTOP)
            try:
                node.create_timer(0.1, lambda: ticks.append(time.monotonic()))
                node.create_timer(0.001, publish_one)
                assert ctx.spin_until(lambda: len(durations) >= MESSAGES, timeout=60.0), \
                    f"only {len(durations)} of {MESSAGES} published"
            finally:
                os.kill(sink.pid, signal.SIGCONT)
            pub.destroy()
        worst = max(durations)
        assert worst <= PUBLISH_BOUND_S, (
            f"publish() took up to {worst * 1000:.1f} ms with the subscriber stopped "
            f"(bound {PUBLISH_BOUND_S * 1000:.0f} ms)")
        assert len(ticks) >= 3, ticks
        rate = (len(ticks) - 1) / (ticks[-1] - ticks[0])
        assert rate >= 9.0, f"the 10 Hz timer ran at {rate:.1f} Hz while publishing"
    finally:
        ctx.close()


@pytest.mark.parametrize(("reliable", "depth", "reliability", "control"), [
    (True, 10, "RELIABLE", "DROP"), (True, 0, "RELIABLE", "BLOCK"),
    (False, 10, "BEST_EFFORT", "DROP"), (False, 0, "BEST_EFFORT", "DROP")])
def test_a_nodes_publisher_takes_its_qos_to_the_wire(types, reliable: bool, depth: int,
                                                     reliability: str, control: str) -> None:
    """``create_publisher(..., QoSProfile(reliability=...))`` reaches the Zenoh publisher: its
    reliability, and congestion control as rmw_zenoh's rmw_publisher_data.cpp sets it."""
    ctx = Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{free_port()}"]),
                       types=types)
    try:
        qos = replace(as_profile(depth),  # a depth, 0 meaning KEEP_ALL
                      reliability=RELIABLE if reliable else BEST_EFFORT)
        pub = Node(ctx, "talker").create_publisher(IMAGE, "/qos", qos)
        declared = pub._inner._publisher      # the zenoh publisher behind it
        assert declared.reliability == getattr(zenoh.Reliability, reliability)
        assert declared.congestion_control == getattr(zenoh.CongestionControl, control)
    finally:
        ctx.close()
