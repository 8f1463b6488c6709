"""Clocks: wall time for real runs, virtual time for simulation and tests.

Every part of servolab reads time from a clock object rather than from :mod:`time`, so one
run can be made fast and deterministic by handing every part the same virtual clock.

A virtual clock has one owner. Nothing but the owner moves it; everything else (the executor
waiting for its next timer, the in-memory port putting bytes on the wire) *asks* it to move
with :meth:`Clock.advance_to`. The owner of a simulated robot is
:class:`servolab.sim.Simulation`, which steps its worlds on the way; :class:`VirtualClock` is
the owner of a run that has nothing to step (a graph of nodes in a test).

**Two readings of one clock.** :meth:`Clock.now` is the clock's own reading: monotonic, for
durations, timers and rates. :meth:`Clock.ros_time` turns a reading into *ROS time*, the
seconds a message's ``header.stamp`` carries, as ROS 2 defines it (design article "Clock and
Time", design.ros2.org/articles/clock_and_time.html; rclpy's ``ROSClock`` and
``TimeSource``):

- a wall clock gives seconds since the UNIX epoch, what rclpy's ROS time is with
  ``use_sim_time`` false (the system clock), so rviz2, tf2 and ``ros2 bag`` date the data
  today, not in 1970. It is the monotonic reading plus an offset taken once per process
  (:func:`epoch_offset`), not ``time.time()`` read anew: stamps never go back when the
  system clock is set, and a reading taken earlier (a frame's capture time) maps exactly;
- a virtual clock gives its own seconds, simulated time, what a ROS node with
  ``use_sim_time`` true reads from ``/clock`` (as Gazebo publishes it): a virtual run
  publishes ``/clock`` (:mod:`servolab.middleware.clock_node`) so that ROS tools agree.

Owners of virtual time also call back as time passes (:meth:`VirtualClock.call_every`), which
is how ``/clock`` is published without a timer in the executor: a timer would change the
order in which the robot's own callbacks run.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Protocol

from .errors import ServolabValueError


class Clock(Protocol):
    """What servolab needs of a clock."""

    @property
    def virtual(self) -> bool:
        """True when time moves only when asked (:meth:`advance_to`), not by itself."""
        ...

    def now(self) -> float:
        """Seconds since an arbitrary origin, monotonic."""
        ...

    def ros_time(self, t: float | None = None) -> float:
        """ROS time in seconds (see the module docstring) of the reading ``t`` of
        :meth:`now` (default: now): the epoch's seconds on a wall clock, simulated seconds
        on a virtual one."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass: wait on a wall clock, move a virtual one."""
        ...

    def advance_to(self, t: float) -> None:
        """Let time reach ``t`` (no-op if it already has): a virtual clock's owner moves
        there, stepping whatever it owns on the way; a wall clock waits."""
        ...


def _measure_epoch_offset_ns() -> int:
    """``time.time_ns() - time.monotonic_ns()``, read so that the two readings are as close as
    the machine allows: the wall read between two monotonic reads, of five tries the
    tightest."""
    best: tuple[int, int] | None = None
    for _ in range(5):
        before = time.monotonic_ns()
        wall = time.time_ns()
        after = time.monotonic_ns()
        if best is None or after - before < best[0]:
            best = (after - before, wall - (before + after) // 2)
    assert best is not None
    return best[1]


_EPOCH_OFFSET_NS = _measure_epoch_offset_ns()
_EPOCH_OFFSET = _EPOCH_OFFSET_NS * 1e-9


def epoch_offset() -> float:
    """Seconds from ``time.monotonic()`` to the UNIX epoch's time, taken once when servolab
    was imported, so that every wall clock of the process stamps alike (one source) and a
    stamp is a monotonic function of the reading it came from. Whatever the clock, ROS time
    in real time is ``time.monotonic() + epoch_offset()``."""
    return _EPOCH_OFFSET


def epoch_offset_ns() -> int:
    """:func:`epoch_offset` in whole nanoseconds, for times kept as ints (a bag's)."""
    return _EPOCH_OFFSET_NS


class WallClock:
    """Real time (``time.monotonic``); its ROS time is the epoch's (:func:`epoch_offset`)."""

    virtual = False

    def now(self) -> float:
        return time.monotonic()

    def ros_time(self, t: float | None = None) -> float:
        return (time.monotonic() if t is None else t) + _EPOCH_OFFSET

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)

    def advance_to(self, t: float) -> None:
        self.sleep(t - self.now())


#: How far before a tick (in periods) a time may fall and still count as on it, so that
#: 75 steps of 1 ms reach the third tick of 25 ms (``3 * 0.025`` is ``0.07500000000000001``).
_TICK_SLACK = 1e-9


class Tick:
    """One :meth:`Ticks.add` registration; :meth:`cancel` ends it."""

    def __init__(self, ticks: Ticks, period: float, start: float,
                 callback: Callable[[float], None]) -> None:
        self.period = period
        self.start = start
        self.callback = callback
        self.due = self._when(1)
        self._ticks = ticks

    def _when(self, k: int) -> float:
        """The time from which the ``k``-th tick counts as reached."""
        return self.start + (k - _TICK_SLACK) * self.period

    def _after(self, now: float) -> None:
        """Due next at the first tick after ``now``."""
        self.due = self._when(math.floor((now - self.start) / self.period + _TICK_SLACK) + 1)

    def cancel(self) -> None:
        self._ticks.remove(self)


class Ticks:
    """Callbacks of a virtual clock's owner, called as its time passes ``start + k * period``:
    once per call that passes one or more of those (a jump over three ticks calls once, as a
    timer that fell behind skips), with the time reached. The owner calls :meth:`fire` after
    each move, and only when :attr:`next_due` has been reached, so a clock with no callbacks
    pays one comparison a move."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._ticks: list[Tick] = []
        #: the earliest time a callback is due (infinity: none)
        self.next_due = math.inf

    def add(self, period: float, now: float, callback: Callable[[float], None]) -> Tick:
        if not (math.isfinite(period) and period > 0):
            raise ServolabValueError(f"tick period must be a number > 0 s, got {period!r}")
        tick = Tick(self, float(period), now, callback)
        with self._lock:
            self._ticks.append(tick)
            self.next_due = min(self.next_due, tick.due)
        return tick

    def remove(self, tick: Tick) -> None:
        with self._lock:
            if tick in self._ticks:
                self._ticks.remove(tick)
            self.next_due = min((t.due for t in self._ticks), default=math.inf)

    def fire(self, now: float) -> None:
        """Call every callback due at ``now``, outside the lock (a callback publishes, which
        may take other locks)."""
        due: list[Tick] = []
        with self._lock:
            for tick in self._ticks:
                if tick.due <= now:
                    due.append(tick)
                    tick._after(now)
            self.next_due = min((t.due for t in self._ticks), default=math.inf)
        for tick in due:
            tick.callback(now)


class VirtualClock:
    """Time that moves only when told, with nothing to step on the way: ``sleep`` and
    ``advance_to`` return at once. Its ROS time is its own seconds."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)
        self._ticks = Ticks()

    def now(self) -> float:
        return self._t

    def ros_time(self, t: float | None = None) -> float:
        return self._t if t is None else t

    def sleep(self, seconds: float) -> None:
        self.advance_to(self._t + seconds)

    def advance(self, seconds: float) -> None:
        self.advance_to(self._t + seconds)

    def advance_to(self, t: float) -> None:
        if t > self._t:
            self._t = t
            if t >= self._ticks.next_due:
                self._ticks.fire(t)

    def call_every(self, period: float, callback: Callable[[float], None]) -> Tick:
        """Call ``callback(t)`` as time passes each ``period`` from now (see :class:`Ticks`):
        a virtual clock's own way to do something at a rate without a timer in anyone's
        executor (``/clock``, :mod:`servolab.middleware.clock_node`)."""
        return self._ticks.add(period, self._t, callback)
