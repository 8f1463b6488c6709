"""Time as ROS has it (issue 30): one source of stamps per context, the epoch's time in real
time, simulated time beside ``/clock`` in virtual time, and bags on the same time base.

Facts checked, and where they come from:
- rclpy's ROS time is the system clock unless ``use_sim_time`` is true, then the last
  ``rosgraph_msgs/msg/Clock`` on ``/clock`` (rclpy/time_source.py; design.ros2.org
  "Clock and Time"): a real-time run's stamps are within a second of ``time.time()``, a
  virtual run's stamps are in the time its ``/clock`` says;
- rosbag2's recorder writes ``node->now()`` under ``use_sim_time`` and the middleware's
  receive time otherwise (rosbag2_transport/recorder.cpp): a bag's log times are the run's
  time base;
- ``/clock`` is published best effort, depth 1 (rclcpp ``ClockQoS``, as rosbag2's player),
  and decodes with rosbags' own type store, not servolab's.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from servolab.clock import VirtualClock
from servolab.middleware.clock_node import (
    CLOCK_QOS,
    CLOCK_TOPIC,
    CLOCK_TYPE,
    DEFAULT_RATE,
    ClockPublisher,
    start_clock,
)
from servolab.middleware.context import Context
from servolab.middleware.errors import MiddlewareValueError
from servolab.middleware.messages import MessageTypes, seconds_of
from servolab.middleware.node import Node
from servolab.middleware.recorder import Recorder
from servolab.sim import Simulation
from servolab.sim.truth_node import GroundTruthNode
from tests.stamps import TODAY_S

STAMPED = "std_msgs/msg/Header"


class _Still:
    """A world that stays where it is: enough for the ground-truth node."""

    name = "still"

    def step(self, dt: float) -> None:
        pass

    def ground_truth(self) -> dict[str, float]:
        return {"x": 1.0, "y": 2.0, "yaw": 0.5}


def _bag_messages(bag: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time ns, CDR) of every message, read with ``mcap``'s own reader."""
    (file,) = sorted(bag.glob("*.mcap"))
    with file.open("rb") as stream:
        return [(channel.topic, message.log_time, bytes(message.data))
                for _, channel, message in make_reader(stream).iter_messages()]


def test_a_real_time_context_stamps_the_epochs_time_from_one_source(
        types: MessageTypes) -> None:
    """Two nodes of one context stamp alike: the same clock reading gives the same stamp,
    and a message's stamp is within a second of the wall, as rclpy's would be."""
    with Context.open(types=types) as ctx:
        talker, listener = Node(ctx, "talker"), Node(ctx, "listener")
        heard: list[Any] = []
        listener.create_subscription(STAMPED, "/stamped", heard.append, 10)
        pub = talker.create_publisher(STAMPED, "/stamped", 10)
        t = ctx.clock.now()
        assert talker.stamp(t) == listener.stamp(t)
        pub.publish(talker.message(STAMPED, stamp=talker.stamp(), frame_id="talker"))
        assert ctx.spin_until(lambda: heard, timeout=5.0)
        assert abs(seconds_of(heard[0].stamp) - time.time()) < TODAY_S
        assert start_clock(ctx) is None  # the wall needs no /clock
        with pytest.raises(MiddlewareValueError, match="wall clock"):
            ClockPublisher(ctx)


def test_a_real_time_bag_is_on_the_stamps_time_base(tmp_path: Path,
                                                   types: MessageTypes) -> None:
    with Context.open(types=types) as ctx:
        node = Node(ctx, "talker")
        pub = node.create_publisher(STAMPED, "/stamped", 10)
        recorder = Recorder(ctx, str(tmp_path / "bag"), ["/stamped"], quiet=True)
        stamps = []
        for _ in range(3):
            stamps.append(node.stamp())
            pub.publish(node.message(STAMPED, stamp=stamps[-1]))
        assert ctx.spin_until(lambda: recorder.counts["/stamped"] == 3, timeout=5.0)
        recorder.destroy()
    logged = [t for _, t, _ in _bag_messages(tmp_path / "bag")]
    for stamp, log_time in zip(stamps, logged, strict=True):
        sent = stamp["sec"] * 1_000_000_000 + stamp["nanosec"]
        assert 0 <= log_time - sent + 1_000_000 < 1_000_000_000  # received after, within 1 s
    assert abs(logged[-1] * 1e-9 - time.time()) < TODAY_S


def test_a_virtual_run_publishes_clock_and_stamps_in_that_time(tmp_path: Path,
                                                              types: MessageTypes) -> None:
    """/clock carries the simulated time as it is reached (never behind the run's messages),
    at most once in each 1/40 s of it (time moves at the ground truth's 30 Hz here, so about
    30 times a second); the ground truth's stamps lie in that time; a recorded /clock decodes
    with rosbags' own type store, and the bag's log times are the simulated time too."""
    sim = Simulation()
    sim.add(_Still())  # type: ignore[arg-type]
    with Context.open(clock=sim, types=types) as ctx:
        clock = start_clock(ctx)
        assert clock is not None and clock.rate == DEFAULT_RATE == 40.0
        GroundTruthNode(ctx, _Still())  # type: ignore[arg-type]
        watcher = Node(ctx, "watcher")
        clocks: list[tuple[float, float]] = []  # (/clock value, time it was taken)
        truths: list[float] = []
        watcher.create_subscription(CLOCK_TYPE, CLOCK_TOPIC, lambda m: clocks.append(
            (seconds_of(m.clock), sim.now())), CLOCK_QOS)
        watcher.create_subscription("nav_msgs/msg/Odometry", "/ground_truth",
                                    lambda m: truths.append(seconds_of(m.header.stamp)), 10)
        recorder = Recorder(ctx, str(tmp_path / "bag"), [CLOCK_TOPIC, "/ground_truth"],
                            types={CLOCK_TOPIC: CLOCK_TYPE}, quiet=True)
        ctx.spin_for(2.0)
        recorder.destroy()
        end = sim.now()
    values = [value for value, _ in clocks]
    assert 2.0 * 30 - 2 <= len(values) <= 2.0 * 40 + 1
    assert values[0] == pytest.approx(1 / 30) and values[-1] <= end  # 0.0 came before
    assert all(abs(value - taken) < 1e-9 for value, taken in clocks)  # as soon as reached
    periods = [int(value * 40 + 1e-6) for value in values]  # at most one a period
    assert periods == sorted(set(periods))
    assert len(truths) >= 55  # 30 Hz for 2 s, the first after 1/30 s
    assert values[0] <= truths[0] and truths[-1] <= end  # stamped in the simulated time
    assert all(t == pytest.approx(round(t * 30) / 30, abs=1e-6) for t in truths)

    store = get_typestore(Stores.ROS2_JAZZY)
    recorded = _bag_messages(tmp_path / "bag")
    clock_records = [(t, data) for topic, t, data in recorded if topic == CLOCK_TOPIC]
    assert len(values) <= len(clock_records) <= len(values) + 1  # destroy() drains the last
    for log_time, data in clock_records:
        msg = store.deserialize_cdr(data, CLOCK_TYPE)
        assert msg.clock.sec * 1_000_000_000 + msg.clock.nanosec == log_time  # sim time
    assert max(t for _, t, _ in recorded) <= round(end * 1e9)


def _trace(clock: str, types: MessageTypes) -> list[tuple[str, float]]:
    """What a small graph does on a simulation, in the order it runs: a 100 Hz timer
    publishing three messages, whose callback each takes 3.1 ms of bus time (it moves the
    clock, as a transaction on the wire does), and a timer every 21 ms. ``clock``: no
    ``/clock`` (""), ``/clock`` from the clock's owner ("owner") or, as an executor timer
    would publish it, from a timer ("timer")."""
    sim = Simulation()
    if clock == "timer":
        vars(sim)["call_every"] = None  # as a clock that cannot call back: a timer
    out: list[tuple[str, float]] = []
    with Context.open(clock=sim, types=types) as ctx:
        if clock:
            start_clock(ctx)
        node = Node(ctx, "graph")
        pub = node.create_publisher(STAMPED, "/x", 10)

        def busy(msg: Any) -> None:
            sim.advance(0.0031)  # a transaction on the wire
            out.append(("message", sim.now()))

        def fast() -> None:
            out.append(("fast", sim.now()))
            for _ in range(3):
                pub.publish(node.message(STAMPED))

        node.create_subscription(STAMPED, "/x", busy, 10)
        node.create_timer(0.01, fast)
        node.create_timer(0.021, lambda: out.append(("slow", sim.now())))
        ctx.spin_for(0.2)
    return out


def test_clock_changes_nothing_the_robots_do(types: MessageTypes) -> None:
    """/clock comes from the clock's owner, not from an executor timer: the order and times
    of every callback are the same with and without it. (A timer would have changed them: a
    timer's turn lets a waiting message go before the next due timer.)"""
    without = _trace("", types)
    assert _trace("owner", types) == without
    assert _trace("timer", types) != without


def test_a_virtual_clock_with_no_simulation_publishes_clock_too(types: MessageTypes) -> None:
    """The time at start, then each tick as a 20 Hz timer moves time past it; the idle
    stretch after the timer is cancelled is one move, and one message."""
    with Context.open(clock=VirtualClock(start=3.0), types=types) as ctx:
        heard: list[float] = []
        watcher = Node(ctx, "watcher")
        watcher.create_subscription(
            CLOCK_TYPE, CLOCK_TOPIC, lambda m: heard.append(seconds_of(m.clock)), CLOCK_QOS)
        publisher = start_clock(ctx, rate=10.0)
        timer = watcher.create_timer(0.05, lambda: None)
        ctx.spin_for(0.36)
        timer.cancel()
        ctx.spin_for(1.0)
        assert publisher is not None and publisher.published == len(heard) == 5
    assert heard == pytest.approx([3.0, 3.1, 3.2, 3.3, 4.36])
