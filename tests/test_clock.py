"""The clocks' two readings (servolab/clock.py): ``now()``, monotonic, for durations, and
``ros_time()``, what stamps carry: the epoch's seconds on a wall clock (rclpy's ROS time with
``use_sim_time`` false is the system time), a virtual clock's own seconds (``use_sim_time``
true, fed by ``/clock``). And the virtual clock's ``call_every``, which ``/clock`` rides on.
"""

from __future__ import annotations

import time

import pytest

from servolab.clock import VirtualClock, WallClock, epoch_offset, epoch_offset_ns
from tests.stamps import TODAY_S


def test_a_wall_clock_stamps_the_epochs_time_from_its_monotonic_reading() -> None:
    clock = WallClock()
    assert abs(clock.ros_time() - time.time()) < TODAY_S  # today, not 1970 + uptime
    t = clock.now()
    # a reading taken earlier (a frame's capture) maps exactly, by one fixed offset
    assert clock.ros_time(t) == t + epoch_offset()
    assert clock.ros_time(t + 0.5) - clock.ros_time(t) == pytest.approx(0.5, abs=1e-6)
    # one source: every wall clock of the process stamps alike
    assert WallClock().ros_time(t) == clock.ros_time(t)
    assert epoch_offset_ns() == pytest.approx(epoch_offset() * 1e9, abs=1e3)


def test_a_virtual_clock_stamps_its_own_seconds() -> None:
    clock = VirtualClock(start=5.0)
    assert clock.ros_time() == 5.0 and clock.ros_time(2.5) == 2.5
    clock.advance(1.25)
    assert clock.ros_time() == clock.now() == 6.25


def test_call_every_fires_as_time_passes_each_period_with_the_time_reached() -> None:
    clock = VirtualClock()
    seen: list[float] = []
    tick = clock.call_every(0.1, seen.append)
    clock.advance_to(0.05)
    assert seen == []
    clock.advance_to(0.1)  # the tick itself
    clock.advance_to(0.12)
    clock.advance_to(0.55)  # over 0.2 .. 0.5 in one move: once, with the time reached
    clock.advance_to(0.55)  # no move, no call
    clock.advance_to(0.61)
    assert seen == [0.1, 0.55, 0.61]
    tick.cancel()
    clock.advance_to(2.0)
    assert seen == [0.1, 0.55, 0.61]


def test_call_every_refuses_a_period_that_is_not_a_positive_number() -> None:
    with pytest.raises(ValueError, match="period"):
        VirtualClock().call_every(0.0, print)
