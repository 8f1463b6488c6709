"""The simulation: the one owner of simulated time.

Everything in a simulated robot reads the same clock — the executor's timers, the bytes on an
emulated bus, the worlds' physics — and only the :class:`Simulation` moves it. Others ask it
to (:meth:`Simulation.advance_to`: the executor waiting for its next timer, the in-memory port
putting bytes on the wire); on the way it steps every world and every emulated bus in fixed
physics steps, 1 ms unless told otherwise, whether or not anyone talks on the bus. The same
inputs therefore give the same run, bit for bit.

Time itself is continuous: a byte on a 57142 bps wire takes 175 µs and the clock shows that;
the physics moves at the step boundaries ``start + k * physics_step`` that time passes, and a
command written between two boundaries acts from the next one, as a servo's control loop
samples its registers.

The same simulation runs in real time too (:meth:`Simulation.start_real_time`): a thread of
its own steps the worlds as wall time passes, and a pseudo-terminal server answers from the
same motors, holding :attr:`Simulation.lock` while it does.

**ROS time** (:meth:`Simulation.ros_time`, what messages are stamped with; see
:mod:`servolab.clock`) follows the mode. In virtual time it is the simulated seconds, as
Gazebo stamps with ``use_sim_time``, and the run publishes them on ``/clock``
(:mod:`servolab.middleware.clock_node`, driven by :meth:`Simulation.call_every`). In real time
the simulation is a real-time run: it shares the wall with a live camera, a serial port,
other processes on the wall clock, so it stamps as they do, in the epoch's seconds (the
reading plus an offset fixed when real time starts), and publishes no ``/clock``. A
simulation switched from one mode to the other jumps from one time base to the other, as a
ROS node's time does when ``use_sim_time`` changes.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, TypeVar

from ..clock import Tick, Ticks, epoch_offset
from .errors import SimulationError

if TYPE_CHECKING:
    from ..dynamixel.emulator import Emulator
    from .world import World

DEFAULT_PHYSICS_STEP = 0.001
#: How far past a step boundary (in steps) a time may fall and still count as on it, so that
#: 0.1 + 0.2 s reaches step 300 of 1 ms.
_BOUNDARY_SLACK = 1e-9

W = TypeVar("W", bound="World")


class Simulation:
    """Simulated time and the worlds and emulated buses that live in it.

    It is a clock (:class:`servolab.clock.Clock`): hand it to a
    :class:`~servolab.middleware.context.Context` and to an emulated bus
    (``Bus.open("emu://...", simulation=sim)``), and nodes, wire and physics share one time.
    """

    def __init__(self, physics_step: float = DEFAULT_PHYSICS_STEP, *, start: float = 0.0
                 ) -> None:
        if not (math.isfinite(physics_step) and physics_step > 0):
            raise SimulationError(f"physics_step {physics_step!r} s must be a positive number")
        self.physics_step = float(physics_step)
        self.start = float(start)
        self.worlds: list[World] = []
        self.emulators: list[Emulator] = []
        #: held while the simulation steps; whoever else touches the motors from another
        #: thread (the pty server in real time) holds it too
        self.lock = threading.RLock()
        #: notified after each advance while a thread waits on it (:attr:`_waiting`: notifying
        #: no one costs a Python call, and every byte on an emulated wire advances time)
        self._stepped = threading.Condition(self.lock)
        self._waiting = 0
        self._time = self.start
        self._steps = 0
        self._real_time: threading.Thread | None = None
        self._stop_real_time = threading.Event()
        self._wall_origin = 0.0
        self._ticks = Ticks()

    # -- what it owns -----------------------------------------------------------------------
    def add(self, world: W) -> W:
        """Step ``world`` from now on, before the emulated buses (their firmware then reads
        the state the world's plants reached)."""
        if world in self.worlds:
            raise SimulationError(f"world {world!r} is in this simulation already")
        with self.lock:
            self.worlds.append(world)
        return world

    def add_emulator(self, emulator: Emulator) -> Emulator:
        """Step the motors of an emulated bus from now on."""
        if emulator in self.emulators:
            raise SimulationError("this emulated bus is in the simulation already")
        with self.lock:
            self.emulators.append(emulator)
        return emulator

    @property
    def steps(self) -> int:
        """Physics steps taken since the start."""
        return self._steps

    # -- the clock ------------------------------------------------------------------------------
    @property
    def virtual(self) -> bool:
        """True while time moves only when asked; False while it runs in real time."""
        return self._real_time is None

    def now(self) -> float:
        if self._real_time is not None:
            return time.monotonic() - self._wall_origin
        return self._time

    def ros_time(self, t: float | None = None) -> float:
        """ROS time of the reading ``t`` (default now): simulated seconds in virtual time,
        the epoch's in real time (see the module docstring)."""
        if t is None:
            t = self.now()
        if self._real_time is None:
            return t
        return t + self._wall_origin + epoch_offset()

    def call_every(self, period: float, callback: Callable[[float], None]) -> Tick:
        """Call ``callback(t)`` as virtual time passes each ``period`` from now, with the time
        reached (once per move, however many periods it passed:
        :class:`~servolab.clock.Ticks`), after the move and outside :attr:`lock`. Not in real
        time: a real-time run keeps the wall's time and needs no ``/clock``. No executor
        timer is involved, so what the robots do is the same with or without it."""
        return self._ticks.add(period, self.now(), callback)

    def _fire_ticks(self) -> None:
        if self._real_time is None and self._time >= self._ticks.next_due:
            self._ticks.fire(self._time)

    def sleep(self, seconds: float) -> None:
        self.advance_to(self.now() + seconds)

    def advance(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass (steps every world on the way)."""
        self.advance_to(self.now() + seconds)

    def advance_to(self, t: float) -> None:
        """Move time to ``t``, taking every physics step whose boundary it passes. In real
        time this waits instead until the simulation's own thread has taken those steps
        (which, with worlds slower than real time, is later than the wall clock says)."""
        if self._real_time is None:
            self._advance(t)
            self._fire_ticks()
            return
        boundary = self._boundary(t)
        with self._stepped:
            self._waiting += 1
            try:
                while self._real_time is not None and (self._steps < boundary
                                                       or self.now() < t):
                    self._stepped.wait(self.physics_step)
            finally:
                self._waiting -= 1

    def step(self, count: int = 1) -> None:
        """Take ``count`` physics steps from the current step boundary (virtual time only)."""
        if self._real_time is not None:
            raise SimulationError("step(): the simulation runs in real time; its own thread "
                                  "takes the steps (stop_real_time() first)")
        with self.lock:
            self._advance(self.start + (self._steps + count) * self.physics_step)
        self._fire_ticks()

    def _boundary(self, t: float) -> int:
        """The number of the last step boundary at or before ``t``."""
        return math.floor((t - self.start) / self.physics_step + _BOUNDARY_SLACK)

    def _advance(self, t: float) -> None:
        with self.lock:
            boundary = self._boundary(t)
            steps = self._steps
            if steps < boundary:
                dt, start = self.physics_step, self.start
                worlds, emulators = self.worlds, self.emulators
                # (the count in a local, stored after each step as before; max() as a comparison)
                while steps < boundary:
                    for world in worlds:
                        world.step(dt)
                    for emulator in emulators:
                        emulator.step(dt)
                    steps += 1
                    self._steps = steps
                    end = start + steps * dt
                    if end > self._time:
                        self._time = end
            if t > self._time:
                self._time = t
            if self._waiting:
                self._stepped.notify_all()

    # -- real time ------------------------------------------------------------------------------
    def start_real_time(self) -> None:
        """Step on a thread of its own as wall time passes, from the current time on."""
        if self._real_time is not None:
            return
        stop = self._stop_real_time = threading.Event()  # each thread its own: an old one
        self._wall_origin = time.monotonic() - self._time  # that outlived its join stays off
        self._real_time = threading.Thread(target=self._run_real_time, args=(stop,),
                                           name="simulation", daemon=True)
        self._real_time.start()

    def stop_real_time(self) -> None:
        """Stop the real-time thread; time stands still (and is virtual) again, with every
        step up to the moment it stopped taken."""
        thread = self._real_time
        if thread is None:
            return
        self._stop_real_time.set()
        thread.join(timeout=2.0)
        with self.lock:
            stopped_at = time.monotonic() - self._wall_origin
            self._real_time = None
            self._advance(stopped_at)

    @contextmanager
    def real_time(self) -> Iterator[Simulation]:
        """``with sim.real_time(): ...`` runs in real time inside, and stops it after."""
        self.start_real_time()
        try:
            yield self
        finally:
            self.stop_real_time()

    def _run_real_time(self, stop: threading.Event) -> None:
        while not stop.is_set():
            with self.lock:
                if stop.is_set():
                    return
                self._advance(time.monotonic() - self._wall_origin)
            next_step = self.start + (self._steps + 1) * self.physics_step
            stop.wait(max(0.0, next_step - (time.monotonic() - self._wall_origin)))

    def __repr__(self) -> str:
        return (f"Simulation(physics_step={self.physics_step}, t={self.now():.6f}, "
                f"steps={self._steps}, worlds={len(self.worlds)}, "
                f"buses={len(self.emulators)})")
