"""The executor: runs subscription, timer and service callbacks on one thread.

Transports deliver from their own threads (Zenoh's, a publisher's); the executor queues the
work and runs it on the thread that spins, one callback at a time, as rclpy's
``SingleThreadedExecutor`` does, so a node's callbacks never race each other. (A
subscription made with ``run_on_arrival`` may have a message that finds the executor idle run
on the thread that received it, :meth:`Executor.run_if_idle`; the spinner waits meanwhile, so
still one callback at a time.)

On a virtual clock, an executor with nothing to do asks the clock's owner to move time to the
next timer instead of waiting (on a :class:`servolab.sim.Simulation` that steps every world on
the way): a simulated robot runs as fast as the CPU allows and the same way every time.

Due timers come before queued message callbacks, as in rclpy's executor, so a flood of
messages cannot starve a control loop's timer: a due timer waits for at most the one callback
already running. (Should timers alone keep the executor busy, a waiting message callback runs
between two timer callbacks, so messages are never starved either.)

*Background work* (:meth:`Executor.add_background`) is what a node does with the time no
callback wants: a serial bus's owner reading the next motor's state, say. It runs only when
no message waits and no timer is due, one short piece at a time, so a command or a timer
waits for at most one piece (one bus transaction), never for a whole sweep of them. It says
when it next wants to run (:meth:`BackgroundWork.due`), and on a virtual clock the executor
moves time to that moment as it would to a timer's.

:meth:`Executor.spin_in_thread` never dies silently: a callback that raises stops the thread
and is raised again to the owner by the next ``spin_*``/``Rate.sleep`` call, by
:meth:`Executor.shutdown` or by the thread's ``join()``; with ``on_error="log"`` it is logged
and the thread keeps spinning.
"""

from __future__ import annotations

import contextlib
import heapq
import itertools
import logging
import threading
from collections import deque
from collections.abc import Callable, Iterator
from typing import Any, Literal, Protocol

from servolab.clock import Clock

from .errors import MiddlewareValueError

#: What :meth:`Executor.spin_in_thread` does with a callback that raises.
OnError = Literal["raise", "log"]

_log = logging.getLogger("servolab.executor")


class BackgroundWork(Protocol):
    """Work that fills the executor's idle time in short pieces (see the module docstring)."""

    def due(self) -> float | None:
        """The clock time at which the next piece wants to run (``-inf``, or any time not
        later than now: at once), or None while there is nothing to do (a callback that gives
        it some makes it due)."""
        ...

    def run(self) -> None:
        """Do one piece: short, since timers and messages wait for it."""
        ...


class Timer:
    """Calls ``callback()`` every ``period`` seconds of the executor's clock.

    As rclpy's ``Timer`` (``rclpy/timer.py``): :meth:`cancel` stops it, :meth:`reset`
    starts it again a whole period from now (cancelled or not), :meth:`is_canceled` says
    which; ``autostart=False`` makes it cancelled until its first :meth:`reset`."""

    def __init__(self, executor: Executor, period: float, callback: Callable[[], Any], *,
                 autostart: bool = True) -> None:
        if not period > 0:
            raise MiddlewareValueError(f"timer period must be > 0 s, got {period!r}")
        self.period = float(period)
        self.callback = callback
        self.next_due = executor.clock.now() + self.period
        self.cancelled = not autostart
        self._entry = -1  # the executor's heap entry that is this timer's current one
        self._executor = executor
        if autostart:
            executor._add_timer(self)

    def cancel(self) -> None:
        self.cancelled = True

    def is_canceled(self) -> bool:
        return self.cancelled

    def reset(self) -> None:
        """Due again a whole period from now, and running if it was cancelled."""
        self.next_due = self._executor.clock.now() + self.period
        self.cancelled = False
        self._executor._add_timer(self)  # the entry it had, if any, is stale from now on

    @property
    def timer_period_ns(self) -> int:
        return round(self.period * 1e9)

    def time_until_next_call(self) -> float | None:
        """Seconds until the next call (None when cancelled), as rclpy's (in ns there)."""
        if self.cancelled:
            return None
        return self.next_due - self._executor.clock.now()


class SpinThread(threading.Thread):
    """The thread of :meth:`Executor.spin_in_thread`. :attr:`exception` is the callback
    error that stopped it (``on_error="raise"``); :meth:`join` raises it to the owner unless
    the owner has already been given it."""

    def __init__(self, executor: Executor, on_error: OnError) -> None:
        super().__init__(name="servolab-executor", daemon=True)
        self.executor = executor
        self.on_error: OnError = on_error
        self.exception: BaseException | None = None

    def run(self) -> None:
        executor = self.executor
        executor._enter()
        try:
            while not executor.is_shutdown:
                try:
                    if not executor._run_ready():
                        executor.spin_once(0.1)
                except Exception as exc:
                    if self.on_error == "log":
                        _log.exception("callback failed; executor keeps spinning")
                        continue
                    self.exception = exc
                    executor._failed(exc)
                    return
        finally:
            executor._leave()

    def join(self, timeout: float | None = None) -> None:
        super().join(timeout)
        if not self.is_alive():
            self.executor.raise_if_failed()


class Executor:
    """Runs queued work and due timers; see the module docstring."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._lock = threading.RLock()  # re-entrant: a virtual clock's advance may submit
        self._cond = threading.Condition(self._lock)
        self._ready: deque[Callable[[], None]] = deque()
        self._sleepers = 0  # spinning threads waiting on _cond for work
        self._asleep: set[int] = set()  # which threads those are
        #: the thread running a callback that arrived while the executor was idle
        #: (:meth:`run_if_idle`); the spinner waits for it
        self._idle_runner: int | None = None
        self._idle_runs = 0  # how many such runs ended: a sleeping spinner then looks again
        self._idle_error: BaseException | None = None  # what one raised, for the spinner
        self._idle_waiter: int | None = None  # that spinner: the one asleep when it began
        self._timers: list[tuple[float, int, Timer]] = []
        self._order = itertools.count()
        self._thread: SpinThread | None = None
        #: threads spinning now (several with rclpy's MultiThreadedExecutor): ident -> depth
        self._spinning: dict[int, int] = {}
        self._shutdown = False
        self._last_was_timer = False
        self._error: BaseException | None = None  # from the spin thread, not yet raised
        self._background: list[BackgroundWork] = []

    # -- queueing (any thread) --------------------------------------------------------------

    def submit(self, work: Callable[[], None]) -> None:
        """Queue ``work``. Only a spinner that sleeps is woken: while it is busy, a burst of
        messages (Zenoh's thread handing over sample after sample) is queued without taking
        the lock, and the spinner drains it with one wake-up, not one per message."""
        self._ready.append(work)  # deque.append is atomic
        if self._sleepers:
            with self._cond:
                if self._idle_runner is None:
                    self._cond.notify()
                else:  # the spinner waits out the idle run on _cond too: wake the runner
                    self._cond.notify_all()

    @property
    def pending(self) -> int:
        """Pieces of work queued and waiting (not counting timers)."""
        return len(self._ready)

    def add_background(self, work: BackgroundWork) -> None:
        """Run ``work`` in the executor's idle time from now on (see the module docstring)."""
        with self._cond:
            if work not in self._background:
                self._background.append(work)
            self._cond.notify_all()  # the sleeper, also past a spinner waiting out an idle run

    def remove_background(self, work: BackgroundWork) -> None:
        with self._cond:
            if work in self._background:
                self._background.remove(work)

    def wake(self) -> None:
        """Look again at what is due: for background work given something to do from
        another thread (a callback on the executor's own thread needs no wake-up). Always
        under the lock: the spinner looks at background work and goes to sleep within one
        hold of it, so a wake-up lands either before the look or in the sleep."""
        with self._cond:
            self._cond.notify_all()

    def _background_due(self) -> tuple[float | None, BackgroundWork | None]:
        """The background work that wants to run first, and when."""
        first: tuple[float | None, BackgroundWork | None] = (None, None)
        for work in self._background:
            due = work.due()
            if due is not None and (first[0] is None or due < first[0]):
                first = (due, work)
        return first

    def _add_timer(self, timer: Timer) -> None:
        with self._cond:
            timer._entry = next(self._order)
            heapq.heappush(self._timers, (timer.next_due, timer._entry, timer))
            self._cond.notify_all()

    # -- spinning ---------------------------------------------------------------------------

    @contextlib.contextmanager
    def spinning(self) -> Iterator[None]:
        """Count the calling thread as spinning this executor while inside, for a loop that
        spins it (rclpy's executors on their threads): from another thread, a ``Client.call``
        or a ``Rate`` then waits for this one rather than spinning too."""
        self._enter()
        try:
            yield
        finally:
            self._leave()

    def _enter(self) -> None:
        ident = threading.get_ident()
        with self._lock:
            self._spinning[ident] = self._spinning.get(ident, 0) + 1

    def _leave(self) -> None:
        ident = threading.get_ident()
        with self._lock:
            depth = self._spinning.get(ident, 0) - 1
            if depth > 0:
                self._spinning[ident] = depth
            else:
                self._spinning.pop(ident, None)

    @property
    def in_executor_thread(self) -> bool:
        return threading.get_ident() in self._spinning

    @property
    def spinning_elsewhere(self) -> bool:
        """True when another thread spins this executor (so a ``Rate`` may just sleep)."""
        ident = threading.get_ident()
        if self._idle_runner == ident:
            return False  # the spinner waits for this thread (run_if_idle): it spins itself
        return any(other != ident for other in list(self._spinning))

    @property
    def exception(self) -> BaseException | None:
        """The callback error that stopped :meth:`spin_in_thread`'s thread and that the owner
        has not been given yet."""
        return self._error

    def raise_if_failed(self) -> None:
        """Raise (once) the error that stopped the spin thread, if any."""
        with self._cond:
            error, self._error = self._error, None
        if error is not None:
            raise error

    def _failed(self, error: BaseException) -> None:
        with self._cond:
            if self._error is None:
                self._error = error
            self._cond.notify_all()

    def spin_once(self, timeout: float | None = None) -> bool:
        """Run one piece of ready work or one due timer, waiting up to ``timeout`` seconds
        (None: until there is some). Returns whether anything ran. Due timers go first."""
        if self._error is not None and not self.in_executor_thread:
            self.raise_if_failed()
        ready = self._ready
        if ready and not self._timers and not self._shutdown and self._idle_runner is None:
            # no timer to put first: work waiting needs neither the lock nor the clock
            # (a flood's cost per message); a timer added meanwhile is seen next time
            try:
                work: Callable[[], None] | None = ready.popleft()
            except IndexError:  # another spinner took it
                work = self._next_work(timeout)
        else:
            work = self._next_work(timeout)
        if work is None:
            return False
        if threading.get_ident() in self._spinning:
            work()  # inside spin()/spin_until()/spinning(): counted once for the whole loop
            return True
        self._enter()
        try:
            work()
        finally:
            self._leave()
        return True

    def _next_work(self, timeout: float | None) -> Callable[[], None] | None:
        clock = self.clock
        deadline = None if timeout is None else clock.now() + timeout
        me = threading.get_ident()
        with self._lock:
            idle_runs = self._idle_runs
            while True:
                if self._idle_runs != idle_runs:
                    # a callback ran on the thread its message came on while this one slept:
                    # back to the caller, whose condition it may have met (spin_until), with
                    # what it raised, as if it had run here
                    if me == self._idle_waiter:  # not another thread's to raise
                        error, self._idle_error = self._idle_error, None
                        self._idle_waiter = None
                        if error is not None:
                            raise error
                    return None
                if self._idle_runner is not None and self._idle_runner != me:
                    # a callback runs on the thread it arrived on: one at a time, so this
                    # thread neither runs work nor returns until it is done (run_if_idle)
                    self._cond.wait(0.05)
                    continue
                if self._shutdown:
                    return None
                while self._timers and (self._timers[0][2].cancelled
                                        or self._timers[0][1] != self._timers[0][2]._entry):
                    heapq.heappop(self._timers)  # cancelled, or reset since: stale
                now = clock.now()
                due = self._timers[0][0] if self._timers else None
                if self._ready and (self._last_was_timer or due is None or due > now):
                    self._last_was_timer = False
                    return self._ready.popleft()
                if due is not None and due <= now:
                    self._last_was_timer = True
                    _, _, timer = heapq.heappop(self._timers)
                    timer.next_due = due + timer.period
                    if timer.next_due <= now:  # far behind: skip ticks rather than burst
                        timer.next_due = now + timer.period
                    timer._entry = next(self._order)
                    heapq.heappush(self._timers, (timer.next_due, timer._entry, timer))
                    return timer.callback
                background_due, background = self._background_due()
                if background is not None and background_due is not None:
                    if background_due <= now or background_due <= clock.now():
                        return background.run
                    due = background_due if due is None else min(due, background_due)
                wake = due if deadline is None else (deadline if due is None
                                                     else min(due, deadline))
                if deadline is not None and now >= deadline:
                    return None
                if clock.virtual and wake is not None:
                    clock.advance_to(wake)
                    continue
                # say we sleep, then look again: a submit() that came after the look above
                # and before this either is seen now or sees _sleepers and notifies
                self._sleepers += 1
                self._asleep.add(me)
                try:
                    if not self._ready and not self._shutdown:
                        # on a virtual clock with no timer only another thread can bring work
                        self._cond.wait(0.05 if clock.virtual else
                                        None if wake is None else max(0.0, wake - now))
                finally:
                    self._sleepers -= 1
                    self._asleep.discard(me)

    def run_if_idle(self, work: Callable[[], None]) -> bool:
        """Run ``work`` on the calling thread now if the executor has nothing else to do: one
        thread spins it and sleeps, no work waits and no timer is due. Whether it ran.

        What a subscription that asked for it (``run_on_arrival``) does on the thread its
        transport received the message on (Zenoh's inbox watcher), so the message does not
        wait for that thread to wake the spinning one: the one thread wake-up between
        servolab's callback and bare Zenoh's (``benchmarks/wakeups.py``). Callbacks still
        run one at a time: the spinner, asleep, neither runs work nor returns until ``work``
        is done. ``work`` counts as spinning (a ``Client.call`` in it spins here); what it
        raises is raised in the spinner, as if the spinner had run it (a ``SpinThread``'s
        ``on_error`` applies). A stop signal comes to the spinner: it waits for the one
        callback running here, not for more."""
        me = threading.get_ident()
        with self._lock:
            spinning = self._spinning
            if (self._shutdown or self._idle_runner is not None or self.clock.virtual
                    or self._ready or self._sleepers != 1 or len(spinning) != 1
                    or me in spinning or self._asleep != spinning.keys()
                    or (self._timers and self._timers[0][0] <= self.clock.now())):
                return False
            background_due, _ = self._background_due()
            if background_due is not None and background_due <= self.clock.now():
                return False
            self._idle_runner = me
            self._idle_waiter = next(iter(spinning))
            self._idle_error = None  # one left by a spinner that left by a stop signal
            spinning[me] = 1
        raised: BaseException | None = None
        try:
            work()
        except BaseException as error:  # the spinner's to raise, not this thread's to die of
            raised = error
        finally:
            with self._cond:
                spinning.pop(me, None)
                self._idle_runner = None
                self._idle_runs += 1
                self._idle_error = raised
                self._cond.notify_all()  # the spinner looks again (spin_until's condition)
        return True

    def spin_until(self, done: Callable[[], bool], timeout: float | None = None) -> bool:
        """Spin until ``done()`` is true (checked after each callback) or ``timeout`` passes;
        returns ``done()``."""
        now, spin_once = self.clock.now, self.spin_once  # looked up once: a flood's loop
        end = None if timeout is None else now() + timeout
        # on a wall clock a bounded wait: done() may turn true on another thread with no work
        # for this one (another spinner took the wake-up), and is looked at again then; a
        # virtual clock must not be moved by a wait with nothing due
        idle = None if self.clock.virtual else 0.1
        outer = not self.in_executor_thread  # the owner: given a spin thread's error
        with self.spinning():
            while not done() and not self._shutdown:
                if outer and self._error is not None:
                    self.raise_if_failed()
                if end is None:
                    spin_once(idle)
                    continue
                left = end - now()
                if left <= 0:
                    break
                spin_once(left if left < 0.1 else 0.1)
        return done()

    def spin_for(self, seconds: float) -> None:
        """Run callbacks for ``seconds`` of the executor's clock."""
        end = self.clock.now() + seconds
        outer = not self.in_executor_thread  # the owner: given a spin thread's error
        with self.spinning():
            while not self._shutdown and (left := end - self.clock.now()) > 0:
                if outer and self._error is not None:
                    self.raise_if_failed()
                self.spin_once(left)

    def spin(self) -> None:
        """Run callbacks until :meth:`shutdown` (from a callback, a signal or another thread)."""
        outer = not self.in_executor_thread  # the owner: given a spin thread's error
        with self.spinning():
            while not self._shutdown:
                if outer and self._error is not None:
                    self.raise_if_failed()
                if not self._run_ready():
                    self.spin_once(0.1)

    def _run_ready(self) -> int:
        """Run queued work back to back while no timer is due; how many pieces ran.

        What :meth:`spin` and a spin thread do between waits: the same pieces in the same
        order as :meth:`spin_once` one after the other, without a call, a lock or a clock
        deadline per piece (under a flood that bookkeeping cost about as much as
        deserializing a ``Twist``). A timer that falls due stops the run, so timers still
        come first, and so does a spin thread's error, so its owner gets it; loops that look
        at a condition after each callback (:meth:`spin_until`) use :meth:`spin_once`. Only
        from a thread counted as spinning (:meth:`spinning`)."""
        ready, timers, now = self._ready, self._timers, self.clock.now
        popleft = ready.popleft
        ran = 0
        try:
            while (ready and not self._shutdown and self._error is None
                   and self._idle_runner is None and (not timers or timers[0][0] > now())):
                try:
                    work = popleft()
                except IndexError:  # another spinner took it
                    break
                ran += 1
                work()
        finally:
            if ran:
                self._last_was_timer = False  # a message has had its turn since the timer
        return ran

    def spin_in_thread(self, *, on_error: OnError = "raise") -> SpinThread:
        """Spin on a daemon thread, for scripts whose main thread runs a ``Rate`` loop.

        A callback that raises stops the thread (``on_error="raise"``): the owner gets the
        error from its next ``spin_*`` or ``Rate.sleep`` call, from :meth:`shutdown` or from
        the thread's ``join()``. ``on_error="log"`` logs it and keeps spinning."""
        if on_error not in ("raise", "log"):
            raise MiddlewareValueError(f"on_error must be 'raise' or 'log', got {on_error!r}")
        self.raise_if_failed()
        if self._thread is None or not self._thread.is_alive():
            self._thread = SpinThread(self, on_error)
            self._thread.start()
        else:
            self._thread.on_error = on_error
        return self._thread

    def shutdown(self) -> None:
        """Stop spinning; from the owner, raise an error that stopped the spin thread and
        that it was not given yet."""
        with self._cond:
            self._shutdown = True
            self._cond.notify_all()
        if (self._thread is not None and self._thread is not threading.current_thread()
                and self._idle_runner != threading.get_ident()):  # it waits for this thread
            threading.Thread.join(self._thread, timeout=2.0)
            self.raise_if_failed()

    @property
    def is_shutdown(self) -> bool:
        return self._shutdown
