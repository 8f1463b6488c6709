"""The teleoperation loop: read the leader, command the follower, as fast as the wires allow.

One cycle (:meth:`TeleopLoop.cycle`) is one SYNC_READ of the leader's present positions, the
goals mapped by joint name within the follower's limits (:class:`~.mapping.JointMap`), and one
SYNC_WRITE of the follower's goal positions; every ``state_rate`` the follower's state too
(one SYNC_READ, Goal Position to Present Position), which checks that the last goals written
are the ones the motors hold (a goal that is not counts as a command lost) and gives the
tracking error (|present - goal| of each joint). Each sample goes to the bag, if any.

**Engaging.** The follower is not thrown at the leader's pose: for its first seconds
(:meth:`TeleopLoop.engage`) each goal is a smooth blend from where the follower was to where
the leader is now, over the time the largest horn move takes at ``engage_speed``.

**The watchdog.** A leader read that fails (no answer, a corrupt one) is counted and the
cycle skipped: the follower keeps its last goal. A leader that gives no reading for
``watchdog`` seconds raises :class:`LeaderLost`, and the run's way out holds the follower.
A follower that fails is an error at once: nothing else can hold it.

**Wire time.** :func:`cycle_wire_s` is what one cycle occupies the two wires, from the
Protocol 2.0 packet sizes (e-Manual, "Protocol 2.0", Instruction and Status Packet), as
``benchmarks/control.py`` computes an update's: the loop cannot run faster than its inverse
(the *wire limit*) whatever the computer.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ...dynamixel.errors import DynamixelError
from ...dynamixel.wire import BITS_PER_BYTE
from ..errors import RobotError, RobotValueError

if TYPE_CHECKING:
    from ...clock import Clock
    from .arms import TeleopArm
    from .hand import Episodes
    from .mapping import JointMap
    from .recording import EpisodeBag, FollowerCamera

#: Protocol 2.0: header 4 + ID 1 + length 2 + instruction 1 + CRC 2 around the parameters
FRAME = 10
#: bytes a motor's position takes (Present Position, Goal Position)
POSITION_BYTES = 4


class LeaderLost(RobotError):
    """The leader gave no reading for longer than the watchdog allows."""


@dataclass(frozen=True)
class LoopOptions:
    """How the loop runs. ``rate``: cycles a second (0: as fast as the wires allow);
    ``state_rate``: the follower's state reads a second; ``camera_rate``: images a second
    (0: none); ``watchdog``: s without a leader reading that end the run; ``engage_speed``:
    rad/s of horn, on average, at which the follower is brought to the leader at the start."""

    def __post_init__(self) -> None:
        for name, zero in (("rate", "as fast as the wires allow"), ("camera_rate", "none")):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise RobotValueError(f"{name} must be Hz >= 0 (0: {zero}), not {value!r}")
        for name in ("state_rate", "watchdog", "engage_speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise RobotValueError(f"{name} must be a number > 0, not {value!r}")
        if self.rate and 1.0 / self.rate >= self.watchdog:
            # one lost read would already be a silence longer than the watchdog
            raise RobotValueError(f"rate {self.rate:g} Hz reads the leader every "
                                  f"{1 / self.rate:g} s, not within the {self.watchdog:g} s "
                                  f"watchdog: give more than {1 / self.watchdog:g} Hz (or 0)")

    rate: float = 0.0
    state_rate: float = 50.0
    camera_rate: float = 10.0
    watchdog: float = 0.1
    engage_speed: float = 1.0


def cycle_wire_s(leader_motors: int, follower_motors: int, baudrate: float,
                 return_delay_s: float = 0.0) -> float:
    """Seconds one cycle occupies the wires: a SYNC_READ of the leader's positions (address
    2 + length 2 + an ID a motor) answered by one status a motor (error 1 + 4 bytes, after
    its return delay), and a SYNC_WRITE of the follower's goals (address 2 + length 2 + ID 1
    + 4 bytes a motor)."""
    sync_read = FRAME + 4 + leader_motors
    statuses = leader_motors * (FRAME + 1 + POSITION_BYTES)
    sync_write = FRAME + 4 + follower_motors * (1 + POSITION_BYTES)
    return ((sync_read + statuses + sync_write) * BITS_PER_BYTE / baudrate
            + leader_motors * return_delay_s)


def state_wire_s(motors: int, span: int, baudrate: float, return_delay_s: float = 0.0) -> float:
    """Seconds one SYNC_READ of ``span`` bytes from ``motors`` occupies the wire."""
    return ((FRAME + 4 + motors + motors * (FRAME + 1 + span)) * BITS_PER_BYTE / baudrate
            + motors * return_delay_s)


@dataclass
class Episode:
    """One episode as it ran: its index, start and end (the loop clock's s), cycles."""

    index: int
    start: float
    end: float = math.nan
    cycles: int = 0
    complete: bool = False


@dataclass
class LoopRecord:
    """What the loop counted and measured."""

    cycles: int = 0
    #: leader reads that failed (the cycle skipped), and the last failure
    leader_failures: int = 0
    last_failure: str = ""
    commands_sent: int = 0
    #: state reads that compared the goals the motors hold with the last ones sent
    commands_checked: int = 0
    commands_lost: int = 0
    #: the loop's clock when the cycles began and when the last one ended
    started: float = math.nan
    ended: float = math.nan
    engage_s: float = 0.0
    #: the loop's clock when the follower had reached the leader (the tracking error counts
    #: from here)
    engaged_at: float = math.nan
    episodes: list[Episode] = field(default_factory=list)
    #: at each state read: the time, the goals in force and the follower's positions
    times: list[float] = field(default_factory=list)
    goals: list[list[float]] = field(default_factory=list)
    positions: list[list[float]] = field(default_factory=list)


class TeleopLoop:
    """See the module docstring. ``clock`` is the one both buses wait on (a simulation's in
    virtual time); ``ros_time`` turns its readings into the bag's stamps. ``bag`` and
    ``camera`` are optional; ``on_cycle`` (a test's hook) is called after each cycle."""

    def __init__(self, leader: TeleopArm, follower: TeleopArm, mapping: JointMap,
                 clock: Clock, options: LoopOptions | None = None, *,
                 bag: EpisodeBag | None = None, camera: FollowerCamera | None = None,
                 on_cycle: Callable[[TeleopLoop], None] | None = None) -> None:
        self.leader = leader
        self.follower = follower
        self.mapping = mapping
        self.clock = clock
        self.options = options or LoopOptions()
        self.bag = bag
        self.camera = camera
        self.on_cycle = on_cycle
        self.record = LoopRecord()
        #: the episode in progress (-1: none)
        self.episode = -1
        self._sent: dict[int, float] | None = None
        self._goals: list[float] = []
        self._last_reading = math.nan
        self._next_state = -math.inf
        self._next_frame = -math.inf
        self._next_cycle = -math.inf
        self._blend: tuple[float, float, list[float]] | None = None

    # -- one cycle ----------------------------------------------------------------------------

    def cycle(self) -> None:
        """Read the leader, command the follower; the state and an image when due."""
        clock, record, options = self.clock, self.record, self.options
        if options.rate > 0:
            now = clock.now()
            if now < self._next_cycle:
                clock.sleep(self._next_cycle - now)
            self._next_cycle = max(self._next_cycle + 1.0 / options.rate, clock.now())
        try:
            leader = self.leader.positions()
        except DynamixelError as exc:
            record.leader_failures += 1
            record.last_failure = " ".join(str(exc).split())
            silent = clock.now() - self._last_reading
            if not silent <= options.watchdog:  # (also when it never answered: nan)
                raise LeaderLost(f"the leader stopped answering: no reading for "
                                 f"{min(silent, 1e9):.3f} s (watchdog {options.watchdog:g} s;"
                                 f" {record.last_failure}); the follower holds where it is"
                                 ) from None
            return
        t = self._last_reading = clock.now()
        goals = self.mapping(leader)
        if self._blend is not None:
            goals = self._blended(t, goals)
        horns = self.follower.horns(goals)
        self.follower.send(horns)
        self._sent, self._goals = horns, goals
        record.commands_sent += 1
        record.cycles += 1
        if self.episode >= 0:
            record.episodes[-1].cycles += 1
        bag = self.bag
        if bag is not None:
            stamp = clock.ros_time(t)
            bag.leader(stamp, leader)
            bag.command(stamp, goals)
        if t >= self._next_state:
            self._next_state = max(self._next_state + 1.0 / options.state_rate, t)
            self._state()
        if self.camera is not None and options.camera_rate > 0 and t >= self._next_frame:
            self._next_frame = max(self._next_frame + 1.0 / options.camera_rate, t)
            image = self.camera.grab()
            if bag is not None:
                bag.image(clock.ros_time(t), image)
        record.ended = clock.now()
        if self.on_cycle is not None:
            self.on_cycle(self)

    def _state(self) -> None:
        """The follower's state: its samples, the tracking error, the goals' check."""
        clock, record = self.clock, self.record
        state = self.follower.state()
        t = clock.now()
        sent = self._sent
        if sent is not None and state.goals[0] >= 0:
            record.commands_checked += 1
            if state.goals != self.follower.goal_ticks(sent):
                record.commands_lost += 1
        record.times.append(t)
        record.goals.append(list(self._goals))
        record.positions.append(list(state.position))
        if self.bag is not None:
            self.bag.follower(clock.ros_time(t), state)

    # -- phases -------------------------------------------------------------------------------

    def engage(self) -> float:
        """Bring the follower to the leader smoothly (see the module docstring); returns the
        seconds it took (0 when the follower was already there)."""
        record, clock = self.record, self.clock
        record.started = clock.now()
        if self.bag is not None:
            self.bag.episode(clock.ros_time(record.started), -1)
        start = self.follower.positions()
        try:
            target = self.mapping(self.leader.positions())
        except DynamixelError as exc:
            raise LeaderLost(f"the leader does not answer: {' '.join(str(exc).split())}"
                             ) from None
        self._last_reading = clock.now()
        horn = max((abs(j.to_horn(a) - j.to_horn(b)) for j, a, b in
                    zip(self.follower.joints, start, target, strict=True)), default=0.0)
        seconds = horn / self.options.engage_speed
        if seconds > 0:
            t0 = clock.now()
            self._blend = (t0, seconds, start)
            while clock.now() < t0 + seconds:
                self.cycle()
            self._blend = None
        record.engage_s = seconds
        record.engaged_at = clock.now()
        return seconds

    def _blended(self, t: float, goals: list[float]) -> list[float]:
        assert self._blend is not None
        t0, seconds, start = self._blend
        x = min(1.0, max(0.0, (t - t0) / seconds))
        s = x * x * (3.0 - 2.0 * x)
        return [a + s * (b - a) for a, b in zip(start, goals, strict=True)]

    def run(self, episodes: Episodes, on_begin: Callable[[float], None] | None = None,
            progress: Callable[[int, float], None] | None = None) -> None:
        """The episodes, from now: each one's start and end marked in the bag, the loop
        going on between them. ``on_begin(t)`` is told when the first one starts (the
        scripted hand's cue); ``progress(k, s)`` after each cycle of episode ``k``, ``s``
        seconds into it (a bar, a line a second)."""
        clock = self.clock
        begin = clock.now()
        if on_begin is not None:
            on_begin(begin)
        for k in range(episodes.count):
            start = begin + episodes.start(k)
            while clock.now() < start:
                self.cycle()
            self._mark(k)
            end = start + episodes.seconds
            while clock.now() < end:
                self.cycle()
                if progress is not None:
                    progress(k, clock.now() - start)
            self.record.episodes[-1].complete = True
            self._mark(-1)

    def _mark(self, k: int) -> None:
        """Episode ``k`` starts now (-1: the one in progress ends)."""
        t = self.clock.now()
        if k >= 0:
            self.record.episodes.append(Episode(k, t))
        elif self.episode >= 0:
            self.record.episodes[-1].end = t
        self.episode = k
        if self.bag is not None:
            self.bag.episode(self.clock.ros_time(t), k)

    def interrupted(self) -> None:
        """The run ended early: the episode in progress ends now, incomplete."""
        if self.episode >= 0:
            self._mark(-1)

    # -- figures ------------------------------------------------------------------------------

    def figures(self, linear: Collection[str] = ()) -> dict[str, Any]:
        """The loop's figures for the summary. ``linear``: the follower's prismatic joints,
        whose errors (m) are kept apart from the revolute ones' (rad)."""
        record = self.record
        elapsed = record.ended - record.started
        figures: dict[str, Any] = {
            "cycles": record.cycles,
            "achieved_hz": record.cycles / elapsed if elapsed > 0 else math.nan,
            "engage_s": record.engage_s,
            "leader_failures": record.leader_failures,
            "commands_sent": record.commands_sent,
            "commands_checked": record.commands_checked,
            "commands_lost": record.commands_lost,
            "state_reads": len(record.times),
        }
        engaged = [i for i, t in enumerate(record.times) if t >= record.engaged_at]
        if engaged:
            errors = np.abs(np.array(record.positions)[engaged] - np.array(record.goals)[engaged])
            names = self.follower.names
            for label, chosen, unit in (("arm", [n not in linear for n in names], "rad"),
                                        ("linear", [n in linear for n in names], "m")):
                if any(chosen):
                    picked = errors[:, np.array(chosen)]
                    figures[f"tracking_error_{label}_{unit}"] = {
                        "p50": float(np.percentile(picked, 50)),
                        "p99": float(np.percentile(picked, 99)),
                        "max": float(picked.max())}
            figures["tracking_error_max_by_joint"] = dict(zip(names, errors.max(axis=0).tolist(),
                                                              strict=True))
        return figures
