"""Clocks: wall time for real runs, virtual time for simulation and tests.

Every part of servolab reads time from a clock object rather than from :mod:`time`, so one
run can be made fast and deterministic by handing every part the same virtual clock.

A virtual clock has one owner. Nothing but the owner moves it; everything else (the executor
waiting for its next timer, the in-memory port putting bytes on the wire) *asks* it to move
with :meth:`Clock.advance_to`. The owner of a simulated robot is
:class:`servolab.sim.Simulation`, which steps its worlds on the way; :class:`VirtualClock` is
the owner of a run that has nothing to step (a graph of nodes in a test).
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    """What servolab needs of a clock."""

    @property
    def virtual(self) -> bool:
        """True when time moves only when asked (:meth:`advance_to`), not by itself."""
        ...

    def now(self) -> float:
        """Seconds since an arbitrary origin, monotonic."""
        ...

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass: wait on a wall clock, move a virtual one."""
        ...

    def advance_to(self, t: float) -> None:
        """Let time reach ``t`` (no-op if it already has): a virtual clock's owner moves
        there, stepping whatever it owns on the way; a wall clock waits."""
        ...


class WallClock:
    """Real time (``time.monotonic``)."""

    virtual = False

    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            time.sleep(seconds)

    def advance_to(self, t: float) -> None:
        self.sleep(t - self.now())


class VirtualClock:
    """Time that moves only when told, with nothing to step on the way: ``sleep`` and
    ``advance_to`` return at once."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def sleep(self, seconds: float) -> None:
        self.advance_to(self._t + seconds)

    def advance(self, seconds: float) -> None:
        self.advance_to(self._t + seconds)

    def advance_to(self, t: float) -> None:
        if t > self._t:
            self._t = t
