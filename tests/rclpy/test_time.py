"""``servolab.rclpy.time``, ``.duration`` and ``.clock`` have rclpy's shapes (issue 32).

Each fact names the rclpy source it comes from (ROS 2 Jazzy, ``rclpy/time.py``,
``duration.py``, ``clock.py``); the slow test runs one snippet under both and compares."""

from __future__ import annotations

import time as _time

import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.rclpy.clock import Clock, ClockType, ROSClock
from servolab.rclpy.duration import Duration, Infinite
from servolab.rclpy.node import Node
from servolab.rclpy.time import Time
from tests.rclpy.oracle import run_both


def test_time_holds_nanoseconds_and_splits_them() -> None:
    """rclpy/time.py: seconds and nanoseconds add up; seconds_nanoseconds() splits them;
    the default clock type is SYSTEM_TIME; repr names both."""
    t = Time(seconds=1.5, nanoseconds=7)
    assert t.nanoseconds == 1_500_000_007
    assert t.seconds_nanoseconds() == (1, 500_000_007)
    assert t.clock_type is ClockType.SYSTEM_TIME
    assert repr(t) == "Time(nanoseconds=1500000007, clock_type=SYSTEM_TIME)"
    with pytest.raises(ValueError, match="must not be negative"):
        Time(seconds=-1)
    with pytest.raises(TypeError, match="ClockType"):
        Time(clock_type=1)  # type: ignore[arg-type]


def test_time_arithmetic_with_durations() -> None:
    """rclpy/time.py: Time + Duration and Time - Duration are Times of the same clock type;
    Time.__sub__ of two Times is a Duration (negative allowed); times of different clock
    types neither subtract nor compare (TypeError)."""
    a = Time(seconds=2, clock_type=ClockType.ROS_TIME)
    later = a + Duration(seconds=0.5)
    assert isinstance(later, Time) and later.clock_type is ClockType.ROS_TIME
    assert (Duration(seconds=0.5) + a) == later
    assert later - a == Duration(nanoseconds=500_000_000)
    assert a - later == Duration(seconds=-0.5)
    assert later - Duration(seconds=2.5) == Time(clock_type=ClockType.ROS_TIME)
    assert a < later and later >= a and a != later
    with pytest.raises(ValueError, match="negative time"):
        a - Duration(seconds=3)
    with pytest.raises(TypeError, match="different clock types"):
        _ = a < Time(seconds=3)
    with pytest.raises(TypeError, match="different clock types"):
        a - Time(seconds=1)


def test_messages_round_trip() -> None:
    """rclpy/time.py, duration.py: to_msg / from_msg with builtin_interfaces; from_msg's
    clock type defaults to ROS_TIME."""
    t = Time(seconds=3, nanoseconds=4)
    msg = t.to_msg()
    assert (msg.sec, msg.nanosec) == (3, 4)
    assert msg.__msgtype__ == "builtin_interfaces/msg/Time"
    back = Time.from_msg(msg)
    assert back.clock_type is ClockType.ROS_TIME and back.nanoseconds == t.nanoseconds
    d = Duration(seconds=-1.25)
    assert (d.to_msg().sec, d.to_msg().nanosec) == (-2, 750_000_000)
    assert Duration.from_msg(d.to_msg()) == d
    with pytest.raises(TypeError):
        Time.from_msg(d.to_msg())


def test_duration_shape() -> None:
    """rclpy/duration.py: repr, str ("N nanoseconds", "Infinite"), comparisons."""
    assert repr(Duration(seconds=1)) == "Duration(nanoseconds=1000000000)"
    assert str(Duration(nanoseconds=5)) == "5 nanoseconds" and str(Infinite) == "Infinite"
    assert Duration(seconds=1) > Duration(nanoseconds=999_999_999)


def test_clocks_of_each_type() -> None:
    """rclpy/clock.py: Clock(clock_type=ROS_TIME) is a ROSClock; now() is a Time of the
    clock's type; a ROS clock follows its override while ROS time is active."""
    assert isinstance(Clock(clock_type=ClockType.ROS_TIME), ROSClock)
    steady = Clock(clock_type=ClockType.STEADY_TIME)
    assert steady.now().clock_type is ClockType.STEADY_TIME
    assert abs(Clock().now().nanoseconds - _time.time_ns()) < 1e9
    ros = ROSClock()
    assert not ros.ros_time_is_active
    ros._set_ros_time_is_active(True)
    ros.set_ros_time_override(Time(seconds=42, clock_type=ClockType.ROS_TIME))
    assert ros.now() == Time(seconds=42, clock_type=ClockType.ROS_TIME)
    assert repr(ros) == "Clock(clock_type=ROS_TIME)"
    assert steady.sleep_for(Duration(seconds=0.01))


def test_a_nodes_clock_reads_its_contexts_ros_time() -> None:
    """One source of time: a node's ROS clock reads Context.ros_time, simulated seconds on
    a virtual clock (servolab's own Node.now() keeps its float)."""
    clock = VirtualClock()
    with Context.open(clock=clock) as ctx:
        node = Node(ctx, "timed")
        clock.advance_to(12.5)
        assert node.get_clock().now() == Time(seconds=12.5, clock_type=ClockType.ROS_TIME)
        assert node.now() == 12.5


@pytest.mark.slow
def test_the_same_snippet_prints_the_same_under_rclpy() -> None:
    code = """
        from rclpy.clock import Clock, ClockType, ROSClock
        from rclpy.duration import Duration, Infinite
        from rclpy.time import Time
        t = Time(seconds=1, nanoseconds=250, clock_type=ClockType.ROS_TIME)
        print(repr(t), t.seconds_nanoseconds(), t.clock_type.name)
        print(repr(t + Duration(seconds=2)), repr(t - Duration(nanoseconds=250)))
        print(repr(t - Time(seconds=3, clock_type=ClockType.ROS_TIME)))
        print(t.to_msg().sec, t.to_msg().nanosec, Time.from_msg(t.to_msg()) == t)
        d = Duration(seconds=-1.25)
        print(repr(d), str(d), str(Infinite), d.to_msg().sec, d.to_msg().nanosec)
        print(repr(Clock()), repr(Clock(clock_type=ClockType.ROS_TIME)),
              type(Clock(clock_type=ClockType.ROS_TIME)).__name__)
        for bad in (lambda: t < Time(), lambda: t - Duration(seconds=9), lambda: Time(seconds=-1)):
            try:
                bad()
            except Exception as e:
                print(type(e).__name__, e)
        print(int(ClockType.ROS_TIME), int(ClockType.SYSTEM_TIME), int(ClockType.STEADY_TIME))
        """
    ros, ours = run_both(code)
    assert ours == ros
