"""An X-series motor's profile generator as its firmware runs it: when a goal comes, it plans
the trajectory (:mod:`.profile`) from where the horn is, keeps it, and reports on it —
Velocity Trajectory(136), Position Trajectory(140) and Moving Status(123).

It is the firmware's, not the plant's: the plant moves the horn (along the same law, from the
limits :meth:`ProfileGenerator.plan` returns), and Moving Status compares the two. Kept apart
from :class:`~.virtual_motor.VirtualMotor` so that the law and its registers are read in one place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .profile import Profile, ProfileType, move, ramp, time_based

#: Drive Mode(10) bit 2: Time-based Profile, "available from firmware V42" (e-Manual).
TIME_BASED_BIT = 0x04
TIME_BASED_FIRMWARE = 42
#: Moving Status(123) bits (e-Manual, Moving Status).
IN_POSITION = 0x01
PROFILE_ONGOING = 0x02
FOLLOWING_ERROR = 0x08
#: Ticks between goal and present position within which the In-Position bit is set. ROBOTIS
#: publish no window for the X-series (the Y-series has a register for it, In-Position
#: Threshold, in pulses); servolab takes 20 ticks (1.76° on a 4096-tick motor), wider than a
#: held joint's sag under its gains, so that a loop waiting for the bit ends.
IN_POSITION_TICKS = 20
#: Ticks between the desired position trajectory and the present position beyond which the
#: Following Error bit is set ("fails to reach desired position trajectory"; no figure is
#: published): an eighth of a turn on a 4096-tick motor.
FOLLOWING_ERROR_TICKS = 512

POSITION_MODES = (3, 4, 5)
VELOCITY_MODE = 1


@dataclass(frozen=True)
class Registers:
    """What the generator reads of the control table, raw, and the horn, in SI (rad, rad/s;
    the joint's own direction). A new plan is made when :attr:`key` changes."""

    mode: int
    torque: bool
    drive_mode: int
    goal_position: int          # raw, for telling a new goal
    goal_angle: float           # rad, the joint's
    goal_velocity: float        # rad/s, the joint's
    profile_velocity_raw: int
    profile_acceleration_raw: int
    profile_velocity: float     # rad/s (velocity-based)
    profile_acceleration: float  # rad/s² (velocity-based)

    @property
    def key(self) -> tuple[int, bool, int]:
        """What a new profile is made on: "when Goal Position(116) is updated" in the
        position modes, Goal Velocity(104) in Velocity Control Mode (e-Manual, Profile
        Velocity(112)); the operating mode and torque (switching either starts afresh). The
        profile registers and Drive Mode take effect from the next goal."""
        goal = (self.goal_position if self.mode in POSITION_MODES
                else round(self.goal_velocity * 1e6) if self.mode == VELOCITY_MODE else 0)
        return self.mode, self.torque, goal


class ProfileGenerator:
    """The firmware's profile: planned again only when what decides it changes (a new goal,
    profile, drive mode, operating mode or torque), as the e-Manual says a profile is created
    "when Goal Position(116) is updated"."""

    def __init__(self, firmware: int) -> None:
        self.time_based_allowed = firmware >= TIME_BASED_FIRMWARE
        self._key: tuple[int, bool, int] | None = None
        self._mode = -1
        self._limits = (0.0, math.inf)
        self.trajectory: Profile | None = None
        self.kind = ProfileType.NONE
        self._start_time = 0.0

    def plan(self, registers: Registers, position: float, velocity: float, now: float
             ) -> float:
        """Plan :attr:`trajectory` from the horn at ``position`` and ``velocity`` at ``now``
        (s) if a new goal came; return the profile velocity (rad/s) it moves at, 0 where no
        profile applies (a step: the motor's top speed)."""
        if registers.key == self._key:
            return self._limits[0]
        self._plan(registers, position, velocity, now)
        return self._limits[0]

    def _plan(self, registers: Registers, position: float, velocity: float, now: float
              ) -> tuple[float, float]:
        """Plan afresh; (profile velocity rad/s, profile acceleration rad/s²)."""
        self._key, self._mode = registers.key, registers.mode
        self._start_time = now
        self.trajectory, self.kind = None, ProfileType.NONE
        self._limits = (0.0, math.inf)
        if not registers.torque or registers.mode not in (*POSITION_MODES, VELOCITY_MODE):
            return self._limits
        by_time = self.time_based_allowed and bool(registers.drive_mode & TIME_BASED_BIT)
        if registers.mode == VELOCITY_MODE:
            acceleration = registers.profile_acceleration or math.inf
            if by_time:
                t1 = registers.profile_acceleration_raw / 1000.0
                change = abs(registers.goal_velocity - velocity)
                acceleration = change / t1 if t1 > 0 and change else math.inf
            self.trajectory = ramp(velocity, registers.goal_velocity, acceleration, position)
            self.kind = self.trajectory.kind
            self._limits = (0.0, acceleration)
            return self._limits
        if by_time:
            span = registers.profile_velocity_raw / 1000.0
            if span <= 0:
                return self._limits
            limits = time_based(registers.goal_angle - position, span,
                                registers.profile_acceleration_raw / 1000.0)
            velocity = 0.0  # the span is the move's from rest (e-Manual, time-based profile)
        else:
            limits = (registers.profile_velocity, registers.profile_acceleration or math.inf)
        if not limits[0] > 0:
            return self._limits
        self._limits = limits
        self.trajectory = move(position, velocity, registers.goal_angle, *limits)
        self.kind = self.trajectory.kind
        return self._limits

    def reset(self) -> None:
        """No profile until the next goal (the bus watchdog stopped the motor)."""
        self._key, self._mode = None, -1
        self.trajectory, self.kind = None, ProfileType.NONE
        self._limits = (0.0, math.inf)

    def desired(self, now: float) -> tuple[float, float] | None:
        """The desired (position rad, velocity rad/s) at ``now``, or None with no profile."""
        if self.trajectory is None:
            return None
        position, velocity, _ = self.trajectory.at(now - self._start_time)
        return position, velocity

    def ongoing(self, now: float) -> bool:
        """Whether a move's profile is still in progress at ``now``."""
        return (self.trajectory is not None and self._mode in POSITION_MODES
                and now - self._start_time < self.trajectory.duration)

    def moving_status(self, now: float, goal_ticks: float, present_ticks: float,
                      desired_ticks: float | None) -> int:
        """Moving Status(123): the profile type, and in the position modes the in-position,
        profile-ongoing and following-error bits."""
        status = int(self.kind)
        key = self._key
        if key is None or self._mode not in POSITION_MODES:
            return status
        ongoing = self.ongoing(now)
        if ongoing:
            status |= PROFILE_ONGOING
        elif key[1] and abs(goal_ticks - present_ticks) <= IN_POSITION_TICKS:
            status |= IN_POSITION
        if desired_ticks is not None and abs(desired_ticks - present_ticks) > \
                FOLLOWING_ERROR_TICKS:
            status |= FOLLOWING_ERROR
        return status
