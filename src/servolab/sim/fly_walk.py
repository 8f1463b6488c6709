"""A walking fruit fly, as a treadmill sees it: bouts of walking with turns, and pauses.

Why a model and not a recording: the closed loop of seed 002 must run before a rig or a fly
exists, and a test needs the fly's true motion to judge the tracker and the compensation.

The model is the usual coarse description of *Drosophila* walking (e.g. Strauss & Heisenberg
1993, Mendes et al. 2013; ranges, not fits): the fly alternates **bouts** of walking and
**pauses**, each of an exponentially distributed length; while walking, its forward speed is
drawn per bout around ``speed`` (a log-normal spread) and its turning rate wanders as an
Ornstein-Uhlenbeck process (a smooth random turn rate, mean zero, ``turn_std`` rad/s). While
paused it stands still but may still turn in place slowly, as grooming flies do not. All of
it is drawn from one seeded ``numpy`` generator, so a run is repeatable bit for bit.

The fly's own motion is returned in its body frame (forward speed m/s, turning rate rad/s);
the world (:class:`~.ball.BallWorld`) turns that into motion on the ball.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .errors import SimulationError


@dataclass(frozen=True)
class FlyWalkConfig:
    """The walking statistics (SI units). Defaults: a calm fly, walking a little over half the
    time at about 3 mm/s in bouts of about 2 s.

    The speed is set from seed 002, not from free-walking flies (about 10 mm/s): with Listing
    1's gains the treadmill turns the ball at about 1.2 mm/s per mm of error, so a fly much
    faster than 3-4 mm/s would walk out of the 16.7 x 9.9 mm view, and the thesis's fly was
    held (1.8 mm mean error)."""

    speed: float = 0.003          #: m/s, the median forward speed of a bout
    speed_spread: float = 0.35    #: the log-normal sigma of a bout's speed
    bout: float = 2.0             #: s, mean length of a walking bout
    pause: float = 1.5            #: s, mean length of a pause
    turn_std: float = 0.8         #: rad/s, spread of the turning rate while walking
    turn_time: float = 0.3        #: s, how long a turning rate persists (OU time constant)

    def __post_init__(self) -> None:
        for name in ("speed", "speed_spread", "bout", "pause", "turn_std", "turn_time"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise SimulationError(f"FlyWalkConfig: {name} must be a number > 0, not {value!r}")


class FlyWalker:
    """The fly's own motion over time (see the module docstring). ``step(dt)`` advances it and
    returns ``(forward speed m/s, turning rate rad/s)`` for that step."""

    def __init__(self, config: FlyWalkConfig = FlyWalkConfig(), seed: int = 0) -> None:
        self.config = config
        self.rng = np.random.default_rng(seed)
        self.walking = False
        self.left = float(self.rng.exponential(config.pause))  # s until the state changes
        self.speed = 0.0
        self.turn = 0.0

    def _switch(self) -> None:
        c = self.config
        self.walking = not self.walking
        if self.walking:
            self.left = float(self.rng.exponential(c.bout))
            self.speed = float(c.speed * math.exp(c.speed_spread * self.rng.standard_normal()))
        else:
            self.left = float(self.rng.exponential(c.pause))
            self.speed = 0.0

    def step(self, dt: float) -> tuple[float, float]:
        if not (math.isfinite(dt) and dt > 0):
            raise SimulationError(f"dt {dt!r} must be a number of seconds > 0")
        self.left -= dt
        while self.left <= 0:
            carry = self.left
            self._switch()
            self.left += carry
        c = self.config
        # Ornstein-Uhlenbeck turning rate, exact discretisation
        decay = math.exp(-dt / c.turn_time)
        spread = c.turn_std * math.sqrt(1.0 - decay * decay)
        self.turn = self.turn * decay + spread * float(self.rng.standard_normal())
        return (self.speed, self.turn if self.walking else 0.0)
