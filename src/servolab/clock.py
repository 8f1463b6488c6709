"""Clocks: wall time for real runs, virtual time for simulation and tests.

The emulator, the in-memory port and (later) the worlds and the middleware all read time from a
clock object rather than from :mod:`time`, so one run can be made fast and deterministic by
handing every part the same :class:`VirtualClock`.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    """What servolab needs of a clock."""

    def now(self) -> float:
        """Seconds since an arbitrary origin, monotonic."""
        ...

    def sleep(self, seconds: float) -> None: ...

    @property
    def virtual(self) -> bool: ...


class WallClock:
    """Real time (``time.monotonic``)."""

    virtual = False

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)


class VirtualClock:
    """Time that moves only when told: ``sleep`` and ``advance`` return at once."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self._t += seconds

    def advance(self, seconds: float) -> None:
        self.sleep(seconds)

    def advance_to(self, t: float) -> None:
        if t > self._t:
            self._t = t
