"""Holding a virtual run to the wall clock while someone watches it.

A simulated robot runs as fast as the computer allows: a minute's walk may take two seconds.
That is what a test or a batch of runs wants, but a person watching the run in Foxglove sees
the robot jump to the end. While a viewer is connected, :class:`Pacer` makes the virtual
clock's owner wait, on its own thread, until the wall clock has caught up with it, so the
robot moves at its own speed (or ``speed`` times it); when the last viewer leaves, the run
goes back to full speed.

It hooks the clock's owner (:meth:`servolab.clock.VirtualClock.call_every`,
``Simulation.call_every``) rather than the executor: the wait then falls between physics
steps, where a real robot's time passes, and the callbacks keep the order they have without a
viewer. A wall clock needs no pacing, and a pacer on one does nothing.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from servolab.errors import ServolabValueError

#: How often (virtual seconds) the pacer looks at the wall clock: often enough that motion
#: looks smooth at a viewer's 60 frames a second, rarely enough to cost nothing.
PACE_PERIOD = 0.01
#: How far (s) the run may fall behind the wall clock before the pacer stops trying to make
#: it up: a run slower than real time is shown as it comes, not in a burst to catch up.
MAX_LAG = 0.25
#: The speeds a watched run may be paced at (times real time), as foxglove-sdk clamps a
#: player's: slower would hold the robot's thread for minutes a step.
MIN_SPEED, MAX_SPEED = 0.01, 100.0
#: The longest one wait lasts before the pacer looks again whether it was released (s).
WAIT_SLICE = 0.05


class TickHandle(Protocol):
    def cancel(self) -> None: ...


class PacedClock(Protocol):
    """What a pacer needs of a clock: whether it is virtual, its reading, and a callback
    as its time passes (only virtual clocks have one)."""

    @property
    def virtual(self) -> bool: ...

    def now(self) -> float: ...


@dataclass(frozen=True)
class PaceConfig:
    """``speed`` is virtual seconds per wall second (1: the robot's own speed)."""

    speed: float = 1.0
    period: float = PACE_PERIOD

    def __post_init__(self) -> None:
        for name in ("speed", "period"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (isinstance(value, int | float)
                                               and 0 < value < float("inf")):
                raise ServolabValueError(f"pace {name} must be a number > 0, got {value!r}")
        if not MIN_SPEED <= self.speed <= MAX_SPEED:
            raise ServolabValueError(f"pace speed must be {MIN_SPEED:g} to {MAX_SPEED:g} times "
                                     f"real time, got {self.speed!r}")


class Pacer:
    """Paces a virtual clock to the wall clock between :meth:`hold` and :meth:`release`;
    holds nest (one per connected viewer), and only the first and last count."""

    def __init__(self, clock: PacedClock, config: PaceConfig | None = None, *,
                 wall: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] | None = None) -> None:
        self.clock = clock
        self.config = config or PaceConfig()
        self._wall = wall
        self._released = threading.Event()  # set when the last viewer leaves: waits end
        self._sleep = sleep if sleep is not None else self._wait
        self._lock = threading.Lock()
        self._holds = 0
        self._tick: TickHandle | None = None
        self._origin = (0.0, 0.0)  # (virtual, wall) when pacing (re)started
        #: wall seconds the pacer has made the run wait, in all
        self.waited = 0.0

    @property
    def pacing(self) -> bool:
        return self._tick is not None

    def hold(self) -> None:
        """Someone watches: from now on the run keeps to the wall clock."""
        with self._lock:
            self._holds += 1
            if self._holds > 1 or not self.clock.virtual:
                return
            call_every: Any = getattr(self.clock, "call_every", None)
            if call_every is None:
                return  # a virtual clock without callbacks cannot be paced
            self._origin = (self.clock.now(), self._wall())
            self._released.clear()
            self._tick = call_every(self.config.period, self._pace)

    def release(self) -> None:
        """One viewer fewer; the last one gone, the run goes back to full speed."""
        with self._lock:
            if self._holds == 0:
                return
            self._holds -= 1
            if self._holds == 0 and self._tick is not None:
                self._tick.cancel()
                self._tick = None
                self._released.set()

    def _wait(self, seconds: float) -> None:
        """Sleep ``seconds`` in short slices, ended at once when the last viewer leaves."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0 and not self._released.is_set():
            self._released.wait(min(left, WAIT_SLICE))

    def _pace(self, virtual_now: float) -> None:
        """Wait until the wall clock has caught up with ``virtual_now`` (on the thread that
        moves the clock)."""
        v0, w0 = self._origin
        ahead = (virtual_now - v0) / self.config.speed - (self._wall() - w0)
        if ahead > 0:
            self._sleep(ahead)
            self.waited += ahead
        elif ahead < -MAX_LAG:
            self._origin = (virtual_now, self._wall())  # too slow: start again from here
