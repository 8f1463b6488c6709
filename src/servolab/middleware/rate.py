"""``Rate``: a loop at a fixed frequency that runs callbacks while it waits (``ros::Rate``)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .errors import MiddlewareValueError

if TYPE_CHECKING:
    from .node import Node


class Rate:
    """Keeps a loop at ``hz``, like ``ros::Rate``: :meth:`sleep` waits until the next tick.

    While it waits it runs the node's callbacks (unless another thread spins the executor),
    so a ROS 1-style loop needs no ``spinOnce``. Ticks are on a fixed schedule; a loop that
    falls a whole period behind starts a new schedule instead of bursting to catch up.
    """

    def __init__(self, node: Node, hz: float) -> None:
        if not (math.isfinite(hz) and hz > 0):
            raise MiddlewareValueError(f"rate must be a finite number > 0 Hz, got {hz!r}")
        self.period = 1.0 / hz
        self._executor = node.context.executor
        self._clock = node.context.clock
        self._next = self._clock.now() + self.period

    def sleep(self) -> None:
        if self._executor.exception is not None:
            self._executor.raise_if_failed()  # the spin thread stopped on a callback's error
        now = self._clock.now()
        if now < self._next:
            if self._executor.spinning_elsewhere:
                self._clock.sleep(self._next - now)
            else:
                self._executor.spin_for(self._next - now)
            self._next += self.period
        else:
            missed = (now - self._next) // self.period + 1
            self._next += missed * self.period
            if self._next - now > self.period:
                self._next = now + self.period

