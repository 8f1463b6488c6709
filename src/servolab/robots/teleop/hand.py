"""The scripted hand: what moves an emulated leader arm, as a person's hand moves a real one.

A person teleoperating holds the leader and moves it; its motors, torque off, only measure.
Emulated, the hand is a :class:`~servolab.sim.World` whose plants are the leader's horns:
each joint follows :class:`HandScript`, a seeded smooth motion, and the firmware reads its
present position from it (through the joint's transmission and the Drive Mode's direction,
as the real motor's encoder would). The hand is stronger than the motors: torque on or off,
the horn goes where the hand puts it, and the motor reports no load.

The motion (pure: :meth:`HandScript.at`): during episode ``k`` each joint is its home plus
a sum of three sines of random frequency (0.08 to 0.35 Hz), phase and weight (seed ``seed +
k``), scaled to the joint's swing and faded in and out over :data:`RAMP_S` at the episode's
ends, so every episode starts and ends at rest at home (an episode shorter than two ramps
moves less, never faster). Before, between and after episodes
the hand holds the leader at home. At 0.35 Hz a swing of 0.4 rad peaks near 0.9 rad/s, a
brisk human pace.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ...dynamixel.plant import AMBIENT_C, IDLE_RISE_C, ServoCommand
from ...sim.world import World
from ..errors import RobotValueError

if TYPE_CHECKING:
    from ...dynamixel.emulator import Emulator, VirtualMotor
    from ...sim.simulation import Simulation
    from ..dynamixel_system import DynamixelJoint

#: s over which an episode's motion fades in at its start and out at its end
RAMP_S = 1.0
#: the sines' frequencies are drawn from this range (Hz)
FREQUENCIES_HZ = (0.08, 0.35)
#: sines a joint's motion sums
SINES = 3
#: a revolute joint's swing without a home of its own: this share of its range, at most
#: :data:`MAX_SWING_RAD`
SWING_SHARE = 0.25
MAX_SWING_RAD = 0.4
#: a joint without limits (continuous) is taken as this range (rad)
OPEN_RANGE = (-math.pi, math.pi)


@dataclass(frozen=True)
class Episodes:
    """When the episodes are, from the moment they begin: ``count`` episodes of ``seconds``
    each, ``reset`` seconds apart (the time to put the scene back)."""

    seconds: float
    count: int
    reset: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise RobotValueError(f"an episode must last a number of seconds > 0, not "
                                  f"{self.seconds!r}")
        if isinstance(self.count, bool) or not isinstance(self.count, int) or self.count < 1:
            raise RobotValueError(f"episodes: a whole number >= 1, not {self.count!r}")
        if not (math.isfinite(self.reset) and self.reset >= 0):
            raise RobotValueError(f"the reset between episodes must be seconds >= 0, not "
                                  f"{self.reset!r}")

    def start(self, k: int) -> float:
        """Episode ``k``'s start, s from the first's."""
        return k * (self.seconds + self.reset)

    @property
    def total(self) -> float:
        """From the first episode's start to the last one's end (s)."""
        return self.start(self.count - 1) + self.seconds

    def at(self, t: float) -> tuple[int, float] | None:
        """(episode, seconds into it) at ``t`` s from the first's start, or None between,
        before and after them."""
        if t < 0:
            return None
        k = min(int(t // (self.seconds + self.reset)), self.count - 1)
        into = t - self.start(k)
        return (k, into) if 0 <= into < self.seconds else None


@dataclass(frozen=True)
class Swing:
    """One joint's part of the hand's motion: its home and how far either side of it the
    hand moves it (the joint's units: rad, or m for a prismatic joint)."""

    joint: str
    home: float
    swing: float


def swings(joints: Sequence[DynamixelJoint],
           homes: Mapping[str, tuple[float, float]] | None = None) -> tuple[Swing, ...]:
    """Each joint's :class:`Swing`: ``homes`` gives (home, swing) by joint name; any other
    joint swings :data:`SWING_SHARE` of its range (at most :data:`MAX_SWING_RAD` radians of
    horn) about 0, or about its range's middle when 0 is not within a swing of its limits.
    Either is refused when it would leave the joint's limits."""
    found = []
    for joint in joints:
        lower, upper = (joint.lower if joint.lower is not None else OPEN_RANGE[0],
                        joint.upper if joint.upper is not None else OPEN_RANGE[1])
        if homes is not None and joint.name in homes:
            home, swing = homes[joint.name]
        else:
            swing = min(SWING_SHARE * (upper - lower), MAX_SWING_RAD * abs(joint.scale))
            home = 0.0 if lower + swing <= 0.0 <= upper - swing else (lower + upper) / 2
        if not (swing >= 0 and lower <= home - swing and home + swing <= upper):
            raise RobotValueError(f"the hand's motion of {joint.name}, {home:g} ± {swing:g}, "
                                  f"leaves its limits [{lower:g}, {upper:g}]")
        found.append(Swing(joint.name, float(home), float(swing)))
    return tuple(found)


def _smoothstep(x: float) -> float:
    x = min(1.0, max(0.0, x))
    return x * x * (3.0 - 2.0 * x)


class HandScript:
    """The hand's motion of each joint (:data:`swings`' order) over time; see the module
    docstring. ``begin`` is when the first episode starts (s, on the clock the caller
    gives :meth:`at`): None holds every joint at home until :meth:`begin_at` sets it."""

    def __init__(self, swings: Sequence[Swing], episodes: Episodes, seed: int, *,
                 begin: float | None = None) -> None:
        self.swings = tuple(swings)
        self.episodes = episodes
        self.seed = int(seed)
        self.begin = begin
        self._home = np.array([s.home for s in self.swings])
        self._swing = np.array([s.swing for s in self.swings])
        self._sines: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}

    def begin_at(self, t: float) -> None:
        """The first episode starts at ``t``."""
        self.begin = float(t)

    def _episode(self, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Episode ``k``'s sines: angular frequencies, phases and weights (joints x sines),
        each joint's weights summing to 1 in absolute value."""
        found = self._sines.get(k)
        if found is None:
            rng = np.random.default_rng([self.seed, k])
            n = len(self.swings)
            omega = 2 * math.pi * rng.uniform(*FREQUENCIES_HZ, size=(n, SINES))
            phase = rng.uniform(0.0, 2 * math.pi, size=(n, SINES))
            weight = rng.uniform(0.3, 1.0, size=(n, SINES)) * rng.choice((-1.0, 1.0),
                                                                         size=(n, SINES))
            weight /= np.abs(weight).sum(axis=1, keepdims=True)
            found = self._sines[k] = (omega, phase, weight)
        return found

    def at(self, t: float) -> np.ndarray:
        """Each joint's position at ``t``."""
        if self.begin is None:
            return self._home.copy()
        now = self.episodes.at(t - self.begin)
        if now is None:
            return self._home.copy()
        k, into = now
        omega, phase, weight = self._episode(k)
        fade = _smoothstep(into / RAMP_S) * _smoothstep((self.episodes.seconds - into) / RAMP_S)
        motion = (weight * np.sin(omega * into + phase)).sum(axis=1)
        found: np.ndarray = self._home + fade * self._swing * motion
        return found


class HandPlant:
    """A leader's horn in the hand (a :class:`~servolab.dynamixel.plant.ServoPlant`): where
    the hand holds it, whatever its firmware commands. The world sets it each step."""

    reports_changes = True  # its temperature and stall never change

    def __init__(self, position: float) -> None:
        self.command = ServoCommand()
        self.position = float(position)
        self.velocity = 0.0
        self.effort = 0.0
        self.temperature = AMBIENT_C + IDLE_RISE_C
        self.stalled = False

    def step(self, dt: float) -> None:
        """Nothing: :class:`HandWorld` moves every horn together."""


@dataclass(frozen=True)
class Horn:
    """A leader joint's horn as its motor counts it: horn (rad) = ``offset`` + ``ratio`` x
    joint. ``ratio`` holds the gear ratio, the direction and the Drive Mode's reverse bit
    (:class:`~servolab.robots.urdf_world.Transmission`)."""

    motor: VirtualMotor
    offset: float
    ratio: float


class HandWorld(World):
    """The scripted hand holding a leader's horns (see the module docstring)."""

    name = "hand"

    def __init__(self, script: HandScript, horns: Sequence[Horn], *, start: float = 0.0
                 ) -> None:
        if len(horns) != len(script.swings):
            raise RobotValueError(f"the hand holds {len(script.swings)} joints, given "
                                  f"{len(horns)} horns")
        self.script = script
        self.horns = tuple(horns)
        self.t = float(start)
        self._offset = np.array([h.offset for h in self.horns])
        self._ratio = np.array([h.ratio for h in self.horns])
        self.plants = [HandPlant(p) for p in self._positions(self.t)]
        for horn, plant in zip(self.horns, self.plants, strict=True):
            self.attach(horn.motor, plant)

    def _positions(self, t: float) -> np.ndarray:
        found: np.ndarray = self._offset + self._ratio * self.script.at(t)
        return found

    def step(self, dt: float) -> None:
        before = np.array([p.position for p in self.plants])
        self.t += dt
        after = self._positions(self.t)
        for plant, position, speed in zip(self.plants, after, (after - before) / dt,
                                          strict=True):
            plant.position = float(position)
            plant.velocity = float(speed)

    def joints(self) -> np.ndarray:
        """Where the hand holds each joint now (the script's, in joint units)."""
        return self.script.at(self.t)

    def ground_truth(self) -> dict[str, float]:
        return {s.joint: float(v) for s, v in zip(self.script.swings, self.joints(),
                                                  strict=True)}

    @classmethod
    def example(cls, simulation: Simulation) -> HandWorld:
        """A hand turning one XM430-W350 (ID 1, 1 Mbps) by ± 0.3 rad in a 4 s episode."""
        from ...dynamixel.bus import Bus

        bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, simulation=simulation)
        script = HandScript((Swing("joint", 0.0, 0.3),), Episodes(4.0, 1), seed=0,
                            begin=simulation.now())
        return simulation.add(cls(script, [Horn(bus.emulator.motor(1), 0.0, 1.0)],
                                  start=simulation.now()))


def hand_on(emulator: Emulator, simulation: Simulation, joints: Sequence[DynamixelJoint],
            script: HandScript) -> HandWorld:
    """The scripted hand on the leader's emulated motors (``joints``, the hand's order),
    stepped by ``simulation`` from now on."""
    from ..urdf_world import Transmission

    horns = []
    for joint in joints:
        transmission = Transmission.of(joint)
        horns.append(Horn(emulator.motor(joint.id), transmission.offset,
                          transmission.direction * transmission.gear_ratio))
    return simulation.add(HandWorld(script, horns, start=simulation.now()))
