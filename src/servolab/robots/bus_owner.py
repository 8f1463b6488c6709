"""The one owner of a serial bus's time: goals go out between single reads, never behind a
sweep of them.

A Dynamixel bus is half duplex: one transaction at a time, and at the seed's 57142 bps one
READ of an RX-28's state takes 5.9 ms, twenty of them 119 ms. ROS ``dynamixel_motor`` gives
the bus to a state-reading thread and lets each joint controller's subscriber write its
command between two of those reads (``dynamixel_io``'s serial mutex). servolab's nodes run
on one executor (:mod:`servolab.middleware.executor`), so the owner is *background work* of
that executor instead of a thread: it runs whenever no message waits and no timer is due, one
transaction at a time —

1. the goals given since the last transaction, if any: the newest goal per motor and
   register (a newer goal replaces an older one: there is no queue to overflow), one
   SYNC_WRITE per register;
2. else the next step of the state sweep (one READ of one motor, say).

A command therefore waits for at most one transaction, a sweep takes what the wire leaves,
and :attr:`BusOwner.sweep_rate` says the rate it achieved. A sweep starts at most
``rate`` times a second (the configuration's ``update_rate``); a bus too slow for that
sweeps back to back. On a virtual clock every transaction moves simulated time by its wire
time, so the same scheduling is exercised, bit for bit, in virtual time and over a pty in
real time.

Running on the executor's thread, the owner needs no lock on the bus: the nodes' callbacks
(a service that writes a motor's compliance, say) use it between two of its transactions.
Goals may be given from any thread (:meth:`BusOwner.set_goals`).
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING

from .errors import RobotValueError

if TYPE_CHECKING:
    from ..dynamixel.bus import Bus
    from ..middleware.context import Context

#: Sweeps over which the achieved rate is averaged (dynamixel_serial_proxy averages 50).
RATE_WINDOW = 50

SweepStep = Callable[[], None]
AT_ONCE = float("-inf")


class BusOwner:
    """The background work that owns ``bus``'s time in ``context`` (see the module
    docstring). ``steps`` are the sweep's transactions, each a callable doing one; after the
    last, ``on_sweep()`` is called (to publish what was read)."""

    def __init__(self, context: Context, bus: Bus, *, rate: float,
                 steps: Sequence[SweepStep] = (),
                 on_sweep: Callable[[], None] = lambda: None) -> None:
        if not rate > 0:
            raise RobotValueError(f"a bus owner's sweep rate must be > 0 Hz, not {rate!r}")
        self.bus = bus
        self.period = 1.0 / rate
        self._context = context
        self._clock = context.clock
        self._executor = context.executor
        self._steps = list(steps)
        self._on_sweep = on_sweep
        #: register -> motor ID -> value (SI), in the order the registers were first given;
        #: under ``_lock``, since goals may come from another thread than the executor's
        self._pending: dict[str, dict[int, float]] = {}
        self._lock = threading.Lock()
        self._next = 0
        self._sweep_due = self._clock.now()
        self._sweep_started: float | None = None
        self._durations: deque[float] = deque(maxlen=RATE_WINDOW)
        self._starts: deque[float] = deque(maxlen=RATE_WINDOW + 1)
        #: counts of what the owner did, for the run's summary and the benchmarks
        self.sweeps = 0
        self.writes = 0
        self.goals_written = 0
        self.goals_replaced = 0
        self._closed = False
        self._executor.add_background(self)

    # -- what the nodes give it -----------------------------------------------------------

    def set_goals(self, register: str, values: Mapping[int, float]) -> None:
        """Write ``values`` (motor ID -> SI value) to ``register`` at the next transaction;
        a goal not yet written is replaced by a newer one for the same motor. Any thread may
        call it."""
        with self._lock:
            pending = self._pending.setdefault(register, {})
            self.goals_replaced += len(pending.keys() & values.keys())
            pending.update(values)
        if not self._executor.in_executor_thread:
            self._executor.wake()

    @property
    def pending(self) -> dict[str, dict[int, float]]:
        """The goals not yet written (a copy)."""
        with self._lock:
            return {register: dict(v) for register, v in self._pending.items()}

    def set_sweep(self, steps: Sequence[SweepStep], on_sweep: Callable[[], None]) -> None:
        """Sweep with ``steps`` from the next sweep on."""
        self._steps = list(steps)
        self._on_sweep = on_sweep
        self._next = 0

    # -- background work --------------------------------------------------------------------

    def due(self) -> float | None:
        if self._closed:
            return None
        if self._pending:
            return AT_ONCE
        if not self._steps:
            return None
        if self._next > 0:  # a sweep under way goes on at once
            return AT_ONCE
        return self._sweep_due

    def run(self) -> None:
        """One transaction: the pending goals, else the sweep's next step."""
        if self._pending:
            self.flush()
            return
        steps = self._steps
        if not steps:
            return
        index = self._next % len(steps)
        # moved on before the step runs: a step that raises (a stop signal mid-READ, a port
        # gone) leaves the sweep at the next one, never past its end
        self._next = (index + 1) % len(steps)
        if index == 0:
            self._sweep_started = self._clock.now()
            self._starts.append(self._sweep_started)
        steps[index]()
        if self._next == 0:
            self.sweeps += 1
            end = self._clock.now()
            if self._sweep_started is not None:
                self._durations.append(end - self._sweep_started)
            # the next sweep is due a period after this one was (a fixed schedule, as a
            # timer's: no drift when callbacks made a sweep start late), or at once when the
            # sweep itself took longer than that
            self._sweep_due = max(self._sweep_due + self.period, end)
            self._on_sweep()

    def flush(self) -> None:
        """Write every pending goal now: one SYNC_WRITE per register. A goal is forgotten
        only once written: on an error the goals not written are pending again (a newer one
        given meanwhile still wins)."""
        while True:
            with self._lock:
                if not self._pending:
                    return
                register = next(iter(self._pending))
                values = self._pending.pop(register)
            try:
                self.bus.sync_write(register, values)
            except BaseException:
                with self._lock:
                    self._pending[register] = {**values, **self._pending.get(register, {})}
                raise
            self.writes += 1
            self.goals_written += len(values)

    # -- what it achieved -------------------------------------------------------------------

    @property
    def sweep_rate(self) -> float:
        """Sweeps a second over the last :data:`RATE_WINDOW` sweeps (0 before two)."""
        if len(self._starts) < 2:
            return 0.0
        span = self._starts[-1] - self._starts[0]
        return (len(self._starts) - 1) / span if span > 0 else 0.0

    @property
    def sweep_time(self) -> float:
        """Mean seconds one sweep took, wire and all (0 before the first)."""
        return sum(self._durations) / len(self._durations) if self._durations else 0.0

    def close(self) -> None:
        """Stop using the bus (the pending goals are dropped: call :meth:`flush` first to
        send them)."""
        self._closed = True
        self._executor.remove_background(self)
