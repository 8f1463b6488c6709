"""``rclpy.clock``: :class:`Clock`, :class:`ROSClock` and :class:`ClockType`, with rclpy's
shape (``rclpy/clock.py``): ``Clock(clock_type=...)`` (a ``ROSClock`` for ROS_TIME),
``now()`` a :class:`~servolab.rclpy.time.Time` of the clock's type, ``sleep_for``,
``sleep_until``; ``ROSClock.ros_time_is_active`` and ``set_ros_time_override``.

A node's clock (``node.get_clock()``) is a ROSClock that reads its context's ROS time
(:meth:`Context.ros_time <servolab.middleware.context.Context.ros_time>`: the epoch's time on
a wall clock, simulated time on a virtual one), the one source every stamp of the context
goes through; with ``use_sim_time`` true it reads the last ``/clock`` message instead, as
rclpy's ``TimeSource`` makes it (0 until the first one comes).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from .clock_type import ClockType
from .duration import Duration
from .time import Time

#: how long a sleep waits between looks at a clock it cannot wait on (simulated time)
_POLL = 0.01


class Clock:
    """A clock of one type; ``Clock(clock_type=ClockType.ROS_TIME)`` is a :class:`ROSClock`."""

    def __new__(cls, *, clock_type: ClockType = ClockType.SYSTEM_TIME) -> Clock:
        if not isinstance(clock_type, ClockType):
            raise TypeError("Clock type must be a ClockType enum")
        if clock_type is ClockType.UNINITIALIZED:
            raise ValueError("Clock type must not be UNINITIALIZED")
        if clock_type is ClockType.ROS_TIME and cls is Clock:
            cls = ROSClock
        self = super().__new__(cls)
        self._clock_type = clock_type
        return self

    _clock_type: ClockType

    @property
    def clock_type(self) -> ClockType:
        return self._clock_type

    def __repr__(self) -> str:
        return f"Clock(clock_type={self.clock_type.name})"

    def _now_ns(self) -> int:
        if self._clock_type is ClockType.STEADY_TIME:
            return time.monotonic_ns()
        return time.time_ns()

    def now(self) -> Time:
        return Time(nanoseconds=self._now_ns(), clock_type=self._clock_type)

    def sleep_until(self, until: Time, context: Any = None) -> bool:
        """Wait until the clock reads ``until``; True when it does (False if the default
        context was shut down meanwhile)."""
        if until.clock_type != self._clock_type:
            raise ValueError("until's clock type does not match this clock's type")
        from servolab.middleware.default_context import is_initialized, ok_now
        watch = is_initialized()
        while (left := until.nanoseconds - self._now_ns()) > 0:
            if watch and not ok_now():
                return False
            time.sleep(min(left * 1e-9, _POLL) if self._waits_by_polling() else left * 1e-9)
        return True

    def _waits_by_polling(self) -> bool:
        return True

    def sleep_for(self, rel_time: Duration, context: Any = None) -> bool:
        return self.sleep_until(self.now() + rel_time, context)


class ROSClock(Clock):
    """ROS time: the system time, or the last ``/clock`` time while ROS time is active."""

    _source: Callable[[], int] | None
    _override: int | None
    _active: bool

    def __new__(cls, *, clock_type: ClockType = ClockType.ROS_TIME) -> ROSClock:
        self = super().__new__(cls, clock_type=ClockType.ROS_TIME)
        assert isinstance(self, ROSClock)
        self._source = None
        self._override = None
        self._active = False
        return self

    @classmethod
    def of(cls, source: Callable[[], int]) -> ROSClock:
        """A ROS clock that reads ``source()`` (ns) while ROS time is not active: a node's."""
        clock = cls()
        clock._source = source
        return clock

    @property
    def ros_time_is_active(self) -> bool:
        return self._active

    def _set_ros_time_is_active(self, enabled: bool) -> None:
        self._active = bool(enabled)

    def set_ros_time_override(self, time: Time) -> None:
        if not isinstance(time, Time):
            raise TypeError(f"Time must be specified as rclpy.time.Time. Received type: "
                            f"{type(time)}")
        self._override = time.nanoseconds

    def _now_ns(self) -> int:
        if self._active:
            return self._override or 0
        if self._source is not None:
            return self._source()
        return time.time_ns()


__all__ = ["Clock", "ClockType", "ROSClock"]
