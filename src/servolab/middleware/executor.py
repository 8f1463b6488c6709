"""The executor: runs subscription, timer and service callbacks on one thread.

Transports deliver from their own threads (Zenoh's, a publisher's); the executor queues the
work and runs it on the thread that spins, one callback at a time, as rclpy's
``SingleThreadedExecutor`` does, so a node's callbacks never race each other.

On a virtual clock, an executor with nothing to do asks the clock's owner to move time to the
next timer instead of waiting (on a :class:`servolab.sim.Simulation` that steps every world on
the way): a simulated robot runs as fast as the CPU allows and the same way every time.
"""

from __future__ import annotations

import heapq
import itertools
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

from servolab.clock import Clock


class Timer:
    """Calls ``callback()`` every ``period`` seconds of the executor's clock."""

    def __init__(self, executor: Executor, period: float, callback: Callable[[], Any]) -> None:
        if not period > 0:
            raise ValueError(f"timer period must be > 0 s, got {period!r}")
        self.period = float(period)
        self.callback = callback
        self.next_due = executor.clock.now() + self.period
        self.cancelled = False
        self._executor = executor
        executor._add_timer(self)

    def cancel(self) -> None:
        self.cancelled = True


class Executor:
    """Runs queued work and due timers; see the module docstring."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._cond = threading.Condition()
        self._ready: deque[Callable[[], None]] = deque()
        self._timers: list[tuple[float, int, Timer]] = []
        self._order = itertools.count()
        self._thread: threading.Thread | None = None
        self._spinning: int | None = None
        self._shutdown = False

    # -- queueing (any thread) --------------------------------------------------------------

    def submit(self, work: Callable[[], None]) -> None:
        with self._cond:
            self._ready.append(work)
            self._cond.notify()

    def _add_timer(self, timer: Timer) -> None:
        with self._cond:
            heapq.heappush(self._timers, (timer.next_due, next(self._order), timer))
            self._cond.notify()

    # -- spinning ---------------------------------------------------------------------------

    @property
    def in_executor_thread(self) -> bool:
        return self._spinning == threading.get_ident()

    @property
    def spinning_elsewhere(self) -> bool:
        """True when another thread spins this executor (so a ``Rate`` may just sleep)."""
        return self._spinning is not None and not self.in_executor_thread

    def spin_once(self, timeout: float | None = None) -> bool:
        """Run one piece of ready work or one due timer, waiting up to ``timeout`` seconds
        (None: until there is some). Returns whether anything ran."""
        work = self._next_work(timeout)
        if work is None:
            return False
        previous, self._spinning = self._spinning, threading.get_ident()
        try:
            work()
        finally:
            self._spinning = previous
        return True

    def _next_work(self, timeout: float | None) -> Callable[[], None] | None:
        clock = self.clock
        deadline = None if timeout is None else clock.now() + timeout
        with self._cond:
            while True:
                if self._shutdown:
                    return None
                if self._ready:
                    return self._ready.popleft()
                while self._timers and self._timers[0][2].cancelled:
                    heapq.heappop(self._timers)
                now = clock.now()
                due = self._timers[0][0] if self._timers else None
                if due is not None and due <= now:
                    _, _, timer = heapq.heappop(self._timers)
                    timer.next_due = due + timer.period
                    if timer.next_due <= now:  # far behind: skip ticks rather than burst
                        timer.next_due = now + timer.period
                    heapq.heappush(self._timers, (timer.next_due, next(self._order), timer))
                    return timer.callback
                wake = due if deadline is None else (deadline if due is None
                                                     else min(due, deadline))
                if deadline is not None and now >= deadline:
                    return None
                if clock.virtual:
                    if wake is None:
                        self._cond.wait(0.05)  # only another thread can bring work
                    else:
                        clock.advance_to(wake)
                    continue
                self._cond.wait(None if wake is None else max(0.0, wake - now))

    def spin_until(self, done: Callable[[], bool], timeout: float | None = None) -> bool:
        """Spin until ``done()`` is true (checked after each callback) or ``timeout`` passes;
        returns ``done()``."""
        end = None if timeout is None else self.clock.now() + timeout
        while not done() and not self._shutdown:
            left = None if end is None else end - self.clock.now()
            if left is not None and left <= 0:
                break
            self.spin_once(left if left is None else min(left, 0.1))
        return done()

    def spin_for(self, seconds: float) -> None:
        """Run callbacks for ``seconds`` of the executor's clock."""
        end = self.clock.now() + seconds
        while not self._shutdown and (left := end - self.clock.now()) > 0:
            self.spin_once(left)

    def spin(self) -> None:
        """Run callbacks until :meth:`shutdown` (from a callback, a signal or another thread)."""
        while not self._shutdown:
            self.spin_once(0.1)

    def spin_in_thread(self) -> threading.Thread:
        """Spin on a daemon thread, for scripts whose main thread runs a ``Rate`` loop."""
        if self._thread is None or not self._thread.is_alive():
            def run() -> None:
                self._spinning = threading.get_ident()
                self.spin()
            self._thread = threading.Thread(target=run, name="servolab-executor", daemon=True)
            self._thread.start()
        return self._thread

    def shutdown(self) -> None:
        with self._cond:
            self._shutdown = True
            self._cond.notify_all()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)

    @property
    def is_shutdown(self) -> bool:
        return self._shutdown
