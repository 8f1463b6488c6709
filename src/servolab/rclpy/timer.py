"""``rclpy.timer``: :class:`Timer`, a node's timer with rclpy's shape (``rclpy/timer.py``).

Its period is counted on the node's clock, as rclpy's is: the context's clock normally (a
:class:`servolab.middleware.executor.Timer` on the executor), and the ``/clock`` time while
``use_sim_time`` is true, when it is due each time the simulated time has moved a period
on (checked as each ``/clock`` message comes; a jump over several periods calls it once).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.middleware.executor import Timer as _ExecutorTimer

if TYPE_CHECKING:
    from .clock import Clock


class Timer:
    """See the module docstring: ``cancel()``, ``reset()``, ``is_canceled()``."""

    def __init__(self, executor: Any, period_sec: float, callback: Callable[[], Any],
                 clock: Clock, *, autostart: bool = True) -> None:
        self.callback = callback
        self._clock = clock
        self._executor = executor
        self._period_ns = round(period_sec * 1e9)
        self._canceled = not autostart
        self._due_ns: int | None = None  # in simulated time, once it has started there
        self._last_ns = clock.now().nanoseconds
        self._inner = _ExecutorTimer(executor, period_sec, self._on_context_clock,
                                     autostart=autostart)

    # -- rclpy's -----------------------------------------------------------------------------

    @property
    def timer_period_ns(self) -> int:
        return self._period_ns

    @property
    def clock(self) -> Clock:
        return self._clock

    def cancel(self) -> None:
        self._canceled = True
        self._inner.cancel()

    def is_canceled(self) -> bool:
        return self._canceled

    def reset(self) -> None:
        self._canceled = False
        self._inner.reset()
        self._due_ns = (self._clock.now().nanoseconds + self._period_ns
                        if self._simulated() else None)

    def is_ready(self) -> bool:
        if self._canceled:
            return False
        if self._simulated():
            return self._due_ns is not None and self._clock.now().nanoseconds >= self._due_ns
        left = self._inner.time_until_next_call()
        return left is not None and left <= 0

    def time_since_last_call(self) -> int:
        return self._clock.now().nanoseconds - self._last_ns

    def time_until_next_call(self) -> int | None:
        if self._canceled:
            return None
        if self._simulated():
            due = self._due_ns
            return None if due is None else due - self._clock.now().nanoseconds
        left = self._inner.time_until_next_call()
        return None if left is None else round(left * 1e9)

    def destroy(self) -> None:
        self.cancel()

    # -- the two clocks ----------------------------------------------------------------------

    def _simulated(self) -> bool:
        return bool(getattr(self._clock, "ros_time_is_active", False))

    def _call(self) -> None:
        self._last_ns = self._clock.now().nanoseconds
        self.callback()

    def _on_context_clock(self) -> None:
        if not self._simulated():
            self._call()

    def _on_simulated_time(self, now_ns: int) -> None:
        """The node's clock read ``now_ns`` from ``/clock`` (on the executor's thread)."""
        if self._canceled or not self._simulated():
            self._due_ns = None
            return
        if self._due_ns is None or now_ns < self._due_ns - self._period_ns:
            self._due_ns = now_ns + self._period_ns  # first time, or it went back (a loop)
        elif now_ns >= self._due_ns:
            self._due_ns += self._period_ns
            if self._due_ns <= now_ns:  # far behind: one call, then from now on
                self._due_ns = now_ns + self._period_ns
            self._executor.submit(self._call)


__all__ = ["Timer"]
