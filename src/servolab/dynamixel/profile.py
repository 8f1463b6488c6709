"""The X-series (and MX 2.0) profile generator: the trajectory a motor's firmware makes from
Goal Position(116) with Profile Velocity(112) and Profile Acceleration(108), in SI units.

A pure law (numbers in, a trajectory out), so that every plant follows the same one: the
default :class:`~.plant.KinematicServo`, and MuJoCo's joints through their reference.

What the e-Manual says (``control_table_profile_velocity.md`` and
``control_table_profile_acceleration.md``, ROBOTIS-GIT/emanual):

- the profile is one of four (Moving Status(123) bits 4-5): not used (Profile Velocity 0, a
  step: the motor goes as fast as it can), rectangular (Profile Acceleration 0: straight to
  the profile velocity), triangular ("when Rectangular velocity profile cannot reach to the
  Profile Velocity") and trapezoidal;
- the acceleration time is t1 = 64 x Profile Velocity / Profile Acceleration ms, the two in
  their units (0.229 rev/min and 214.577 rev/min²): with both in SI it is just V / A. (The
  64 is exact for a velocity unit of 0.22888 rev/min, 60 000 / 2^18, of which 0.229 is the
  rounding: 214.577 / 937.5; with 0.229, t1 comes out 0.05 % longer.)
- "Dynamixel's profile creates desired velocity trajectory based on present velocity":
  a new goal while moving keeps the velocity continuous (Velocity Override), which is what
  planning from the present position *and velocity* gives;
- the time-based profile (Drive Mode(10) bit 2, from firmware V42): Profile Velocity is the
  time span t3 of the move and Profile Acceleration the acceleration time t1, in ms, and
  "Profile Acceleration(108) will not exceed 50% of Profile Velocity(112)";
- in Velocity Control Mode only Profile Acceleration is used: the goal velocity is reached
  along a ramp (step or trapezoidal).

Not modelled: the firmware's jerk control, which the e-Manual says may make a real move
longer than t3 ("t4" in its figure) without saying by how much.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from .errors import ConfigError


class ProfileType(IntEnum):
    """Moving Status(123) bits 4-5 (e-Manual, Moving Status): the kind of velocity profile."""

    NONE = 0x00
    RECTANGULAR = 0x10
    TRIANGULAR = 0x20
    TRAPEZOIDAL = 0x30


@dataclass(frozen=True)
class Phase:
    """A stretch of constant acceleration: ``duration`` s at ``acceleration`` rad/s²; with
    ``jump`` the velocity first jumps to it (the rectangular profile's start)."""

    duration: float
    acceleration: float
    jump: float | None = None


@dataclass(frozen=True)
class Profile:
    """A planned trajectory: from ``start`` rad at ``velocity`` rad/s, the ``phases`` one after
    another; after the last, on at ``after`` rad/s (0: resting on the goal of a move; the goal
    velocity after a velocity ramp)."""

    start: float
    velocity: float
    phases: tuple[Phase, ...]
    kind: ProfileType
    after: float = 0.0

    @property
    def duration(self) -> float:
        """Seconds until the last phase ends (the move's t3)."""
        return sum(p.duration for p in self.phases)

    def at(self, t: float) -> tuple[float, float, float]:
        """(position rad, velocity rad/s, acceleration rad/s²) ``t`` s after the start."""
        p, v = self.start, self.velocity
        for phase in self.phases:
            if phase.jump is not None:
                v = phase.jump
            if t <= phase.duration:
                a = phase.acceleration
                return p + v * t + 0.5 * a * t * t, v + a * t, a
            d, a = phase.duration, phase.acceleration
            p, v = p + v * d + 0.5 * a * d * d, v + a * d
            t -= d
        return p + self.after * t, self.after, 0.0

    @property
    def end(self) -> float:
        """Where the last phase ends (the goal, for a move)."""
        return self.at(self.duration)[0]

    @property
    def peak_speed(self) -> float:
        """The highest speed along the trajectory (rad/s)."""
        speeds = [abs(self.velocity), abs(self.after)]
        v = self.velocity
        for phase in self.phases:
            if phase.jump is not None:
                v = phase.jump
                speeds.append(abs(v))
            v += phase.acceleration * phase.duration
            speeds.append(abs(v))
        return max(speeds)


def move(start: float, velocity: float, goal: float, profile_velocity: float,
         profile_acceleration: float) -> Profile:
    """The velocity-based profile to ``goal`` from ``start`` at ``velocity`` (rad, rad/s),
    with Profile Velocity and Acceleration in SI (rad/s, rad/s²). ``profile_acceleration`` of 0
    or infinity: rectangular (the velocity jumps). ``profile_velocity`` must be > 0 (0 is "no
    profile": the motor's own top speed, which only the plant knows)."""
    v_max = float(profile_velocity)
    if not (v_max > 0):
        raise ConfigError(f"profile velocity {profile_velocity!r} rad/s must be > 0 for a profile")
    a_max = math.inf if profile_acceleration in (0, math.inf) else float(profile_acceleration)
    distance = goal - start
    if math.isinf(a_max):  # rectangular: at the profile velocity at once, stopping on the goal
        return Profile(start, float(velocity), (Phase(
            abs(distance) / v_max, 0.0, jump=math.copysign(v_max, distance)),)
            if distance else (), ProfileType.RECTANGULAR)
    phases: list[Phase] = []
    p, v = float(start), float(velocity)
    direction = math.copysign(1.0, distance) if distance else -math.copysign(1.0, v)
    along = v * direction
    if v and (along < 0 or along * along / (2 * a_max) > abs(distance)):
        # moving away from the goal, or too fast to stop on it: brake to rest first
        brake = abs(v) / a_max
        phases.append(Phase(brake, -math.copysign(a_max, v)))
        p, v = p + v * brake / 2, 0.0
        distance = goal - p
        direction, along = math.copysign(1.0, distance), 0.0
    # the e-Manual's test: triangular when the triangle's peak sqrt(A x distance) (from rest)
    # does not exceed the profile velocity; a move of no distance is the smallest triangle
    kind = ProfileType.TRIANGULAR
    # the peak speed of a triangle from `along` to rest over the distance, capped by V; a
    # distance so small that the peak underflows to 0 (5e-324 rad) is no move at all
    peak = math.sqrt(a_max * abs(distance) + along * along / 2) if distance else 0.0
    if peak > 0:
        if peak > v_max:
            kind, peak = ProfileType.TRAPEZOIDAL, v_max
        to_peak = (peak * peak - along * along) / (2 * a_max if peak >= along else -2 * a_max)
        to_rest = peak * peak / (2 * a_max)
        cruise = max(0.0, abs(distance) - to_peak - to_rest)
        phases += [Phase(abs(peak - along) / a_max,
                         direction * math.copysign(a_max, peak - along)),
                   Phase(cruise / peak, 0.0), Phase(peak / a_max, -direction * a_max)]
    return Profile(float(start), float(velocity), tuple(p for p in phases if p.duration > 0),
                   kind)


def time_based(distance: float, span: float, acceleration_time: float
               ) -> tuple[float, float]:
    """The time-based profile's (Profile Velocity rad/s, Profile Acceleration rad/s²) for a
    move of ``distance`` rad from rest: the trapezoid whose time span is ``span`` s (t3) and
    acceleration time ``acceleration_time`` s (t1, at most half the span: e-Manual). A t1 of
    0 gives a rectangular profile (infinite acceleration)."""
    if not span > 0:
        raise ConfigError(f"time span {span!r} s must be > 0 for a time-based profile")
    t1 = min(max(0.0, acceleration_time), span / 2)
    cruise_speed = abs(distance) / (span - t1)   # area of the trapezoid: v (t3 - t1)
    return cruise_speed, (cruise_speed / t1 if t1 > 0 else math.inf)


def ramp(velocity: float, goal_velocity: float, profile_acceleration: float,
         start: float = 0.0) -> Profile:
    """Velocity Control Mode's profile: from ``velocity`` to ``goal_velocity`` (rad/s) at
    ``profile_acceleration`` (rad/s²; 0 or infinity: a step), then on at the goal velocity."""
    change = goal_velocity - velocity
    if profile_acceleration in (0, math.inf) or not change:
        return Profile(start, float(goal_velocity), (), ProfileType.NONE, after=goal_velocity)
    a = math.copysign(float(profile_acceleration), change)
    return Profile(start, float(velocity), (Phase(change / a, a),), ProfileType.TRAPEZOIDAL,
                   after=goal_velocity)
