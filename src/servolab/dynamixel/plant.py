"""The servo plant: the physical joint behind an emulated motor's firmware, in SI units.

An emulated Dynamixel is two things. Its *firmware* (:class:`~.virtual_motor.VirtualMotor`) is the
control table, the instructions and the errors: it turns registers into a
:class:`ServoCommand` and reads the joint back into present_* registers. Its *plant* is the
physics: where the horn is, how fast it turns, what load it carries, how warm the motor is.
The two meet only here, in radians, rad/s, fractions of stall torque and degrees Celsius, so a
world can swap the plant — a wheel whose speed a floor integrates, an omni-wheel coupled to a
ball, a joint whose state a physics engine owns — and the firmware answers on the bus from it.

:class:`KinematicServo` is the default plant: the horn moves toward the goal at the commanded
speed, capped by the model's no-load speed less what an external load takes, as the emulator
always did. It can be stepped lazily (:meth:`KinematicServo.advance`): the state after ``n``
fixed steps is computed in closed form from the start of the current motion, by the same
expressions one step at a time uses, so catching up is bit-for-bit the same as stepping and a
bus of twenty idle servos costs nothing while no one talks to it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from .errors import ConfigError
from .profile import Profile, move, ramp

AMBIENT_C = 25.0
#: Winding temperature above ambient with no load (electronics and holding current).
IDLE_RISE_C = 7.0
#: Further steady-state rise at 100 % load. The heat is the windings' copper loss, I²R, and the
#: current goes with the torque, so the rise goes with the square of the load: 60 °C at stall
#: (92 °C, past the RX-28's 80 °C Temperature Limit), 15 °C at half load.
STALL_HEATING_C = 60.0
#: Default lag of the winding temperature (first order); per plant:
#: :attr:`KinematicServo.thermal_time_constant`.
THERMAL_TIME_CONSTANT_S = 300.0
#: Load fraction that friction takes at rest and, additionally, at full speed.
FRICTION_STATIC = 0.04
FRICTION_VISCOUS = 0.12
#: Mechanical time constant of motor and gear train: after the horn's speed changes by ``dv``
#: the motor gives ``dv / no_load_speed`` of its stall torque to accelerate (or brake) them,
#: decaying as exp(-t / this) — a DC motor's torque after a step of its drive. ROBOTIS publish
#: no figure; 20 ms is typical of a small geared DC motor.
MECHANICAL_TIME_CONSTANT_S = 0.020


@dataclass(frozen=True)
class Compliance:
    """The AX/RX/EX firmware's position control law, in SI (e-Manual, RX-28 Compliance
    Margin(26, 27), Compliance Slope(28, 29), Punch(48)): within ``margin`` of the goal the
    motor gives no output; beyond it the output grows across ``slope`` to the torque limit,
    and is never less than ``punch`` while it gives any. The clockwise (``cw_*``) values act
    when the goal lies clockwise of the horn (a negative error), the counter-clockwise ones
    when it lies counter-clockwise. A plant that models only where the horn goes (the
    :class:`KinematicServo`) ignores it; one whose joint a physics engine moves
    (:mod:`servolab.sim.mujoco_world`) turns the error into torque with it."""

    cw_margin: float = 0.0      # rad
    ccw_margin: float = 0.0     # rad
    cw_slope: float = 0.0       # rad (0: full output as soon as the margin is passed)
    ccw_slope: float = 0.0      # rad
    punch: float = 0.0          # fraction of stall torque


@dataclass(frozen=True)
class PositionPid:
    """A PID model's position law beyond its proportional part (which comes as the
    :class:`Compliance` equivalent), in SI: output shares (1.0 = full output) per unit of
    the error's integral, its rate, and the trajectory's velocity and acceleration. The
    firmware's own conversions from its registers are in :mod:`.gains`. Like the
    compliance law, only a plant whose joint a physics engine moves runs it."""

    integral: float = 0.0                   # share per rad s
    derivative: float = 0.0                 # share per rad/s
    velocity_feedforward: float = 0.0       # share per rad/s of the trajectory's velocity
    acceleration_feedforward: float = 0.0   # share per rad/s² of its acceleration

    @property
    def active(self) -> bool:
        return any((self.integral, self.derivative, self.velocity_feedforward,
                    self.acceleration_feedforward))


@dataclass(frozen=True)
class VelocityPi:
    """The X-series Velocity Control Mode law in SI: output share = ``proportional`` x speed
    error + ``integral`` x its integral (rad/s and rad). Without it (AX/RX/EX wheel mode)
    the goal speed's share of the no-load speed is the output, open loop."""

    proportional: float = 0.0   # share per rad/s
    integral: float = 0.0       # share per rad


@dataclass(frozen=True)
class ServoCommand:
    """What the firmware asks of the joint, in SI units.

    ``velocity_control`` selects between holding ``goal_velocity`` (wheel mode, velocity,
    PWM and current modes) and going to ``goal_position`` (joint and position modes) at
    ``profile_velocity`` (0: as fast as the motor can). ``goal_position`` is unbounded: the
    firmware has already placed it in the right turn.
    """

    torque_enabled: bool = False
    velocity_control: bool = False
    goal_position: float = 0.0      # rad
    profile_velocity: float = 0.0   # rad/s, magnitude; 0 = the motor's top speed
    goal_velocity: float = 0.0      # rad/s, signed
    #: the goal is a voltage, not a speed (X-series PWM Control Mode): ``goal_velocity`` is the
    #: unloaded horn's speed at it, and a load moves the horn along the torque-speed line,
    #: forward or backward (nothing stalls: nothing is held)
    voltage_control: bool = False
    #: the goal is a torque (X-series Current Control Mode): the motor gives ``torque_limit``
    #: in ``goal_velocity``'s direction, turning that way unless a load pushes harder against
    #: it (then held there)
    torque_control: bool = False
    #: the X-series firmware's planned trajectory (its profile generator, in the joint's
    #: angle): the horn follows it while the load lets it (else it goes as the limits allow)
    trajectory: Profile | None = None
    torque_limit: float = 1.0       # fraction of stall torque the firmware allows
    #: the position control law: a compliance-controlled model's (AX, RX, EX), or the P gain
    #: of a PID model as its compliance equivalent (MX: the e-Manual's table; X-series:
    #: Position P Gain); None in velocity control
    compliance: Compliance | None = None
    #: the integral, derivative and feedforward gains of a PID model's position law (None:
    #: proportional only)
    pid: PositionPid | None = None
    #: the X-series velocity law (None: the goal velocity's share is the output, open loop)
    velocity_pi: VelocityPi | None = None


class ServoPlant(Protocol):
    """The interface between an emulated motor's firmware and its joint.

    The firmware sets :attr:`command` whenever its registers change and reads the four state
    properties when a register is read. Whoever owns the plant steps it once per physics step
    (:meth:`step`): the emulator for its own default plants, a world for the plants it put in.
    """

    command: ServoCommand

    @property
    def position(self) -> float:
        """Horn angle, rad, unbounded (counts turns), 0 at the model's centre tick."""
        ...

    @property
    def velocity(self) -> float:
        """Horn speed, rad/s, counter-clockwise positive."""
        ...

    @property
    def effort(self) -> float:
        """Load on the motor as a signed fraction of stall torque (present_load's -1..1)."""
        ...

    @property
    def temperature(self) -> float:
        """Motor temperature, °C."""
        ...

    def step(self, dt: float) -> None:
        """Move the physics on by one fixed step of ``dt`` seconds."""
        ...


class KinematicServo:
    """The default plant: an ideal position/velocity servo with a linear torque-speed curve.

    In position control the horn moves straight to the goal at the commanded speed and stops
    on it; in velocity control it turns at the commanded speed. Either speed is capped by
    ``no_load_speed`` × (1 − |external_load|), the DC motor's torque-speed line; when the
    external load exceeds the torque limit the horn stalls (:attr:`stalled`).

    ``external_load`` is the torque the world applies to the horn, as a fraction of stall
    torque (negative pushes clockwise).

    **Effort** (:attr:`effort`, what present_load shows) is the torque the motor gives, as a
    signed fraction of stall torque, counter-clockwise positive — the e-Manual's Present Load
    is "an inferred value based on the internal output value", bit 10 set for a CW load
    (RX-28, Present Load(40)). It is what the motion demands:

    - friction while the horn turns (:data:`FRICTION_STATIC` + :data:`FRICTION_VISCOUS` at full
      speed), in the direction it turns;
    - accelerating or braking the motor and gear train: a change of speed ``dv`` asks
      ``dv / no_load_speed``, decaying with :data:`MECHANICAL_TIME_CONSTANT_S` (the horn's
      motion itself stays ideal: the lag that torque would give is not modelled);
    - holding the external load: ``-external_load`` (a load pushing clockwise is held by a
      counter-clockwise torque);

    and never more than the torque limit allows: held against a load above its limit, the
    motor stalls and gives exactly its limit; with torque off or a limit of 0 it gives none.

    **Back-driven.** A motor with torque off holds nothing: an external load above the
    gears' static friction turns the horn its way, as fast as their viscous friction lets
    it, up to the no-load speed (:meth:`_back_driven`). ROBOTIS publish no back-driving
    figure; the friction is the same that takes :data:`FRICTION_STATIC` and
    :data:`FRICTION_VISCOUS` of the torque driving it. With torque on at an output of 0 (a
    limit of 0) the windings are held at 0 V and the back-EMF brakes it instead: the load
    turns it at no-load speed x load.

    **Temperature** (:attr:`temperature`) is the winding temperature, a first-order lag of
    :attr:`thermal_time_constant` toward ``ambient`` + :data:`IDLE_RISE_C` +
    :data:`STALL_HEATING_C` × effort² (copper loss). The effort that heats is the sustained
    one (friction and the load held); the acceleration transients are left out, as their heat
    (at most STALL_HEATING_C × τ_mech / 2τ per move, under 0.01 °C) is too small to show.

    Two public knobs let a test reach a temperature limit in seconds of virtual time through
    this same model, without faking a reading: ``temperature`` may be *set* (the windings are
    that warm now — say a motor that has worked all morning: ``plant.temperature = 78.0``),
    and ``thermal_time_constant`` (s, default :data:`THERMAL_TIME_CONSTANT_S`) may be set
    shorter (a motor that warms in seconds). Either acts from the present step on.
    """

    def __init__(self, no_load_speed: float, position: float = 0.0, *,
                 ambient: float = AMBIENT_C,
                 thermal_time_constant: float = THERMAL_TIME_CONSTANT_S) -> None:
        if not (math.isfinite(no_load_speed) and no_load_speed > 0):
            raise ConfigError(f"no_load_speed {no_load_speed!r} rad/s must be positive")
        self.no_load_speed = float(no_load_speed)
        self.ambient = float(ambient)
        self._tau = _time_constant(thermal_time_constant)
        self._command = ServoCommand()
        self._external_load = 0.0
        # (dt, exp(-dt / thermal tau), exp(-dt / mechanical tau))
        self._decay: tuple[float, float, float] = (math.nan, 1.0, 1.0)
        # Segment: the motion since the last change of command or load, in closed form.
        self._p0 = float(position)      # position at the segment's start
        self._t0 = self.ambient + IDLE_RISE_C  # temperature at the segment's start
        self._v0 = 0.0                  # velocity and effort at the start: until the first
        self._e0 = 0.0                  # step of a new command, the joint is as it was
        self._i0 = 0.0                  # the acceleration torque still decaying at the start
        self._j = 0                     # steps taken in the segment
        self._elapsed = 0.0             # s into the firmware's trajectory at the segment start
        self._cached_j = -1
        self._cached = (0.0, 0.0, 0.0, 0.0)
        self._plan()

    # -- inputs ---------------------------------------------------------------------------------
    @property
    def command(self) -> ServoCommand:
        return self._command

    @command.setter
    def command(self, command: ServoCommand) -> None:
        if command != self._command:
            self._restart()
            if command.trajectory != self._command.trajectory:
                self._elapsed = 0.0     # a new trajectory starts now
            self._command = command
            self._plan()

    @property
    def external_load(self) -> float:
        return self._external_load

    @external_load.setter
    def external_load(self, load: float) -> None:
        if not math.isfinite(load):
            raise ConfigError(f"external_load {load!r} is not a finite number")
        if load != self._external_load:
            self._restart()
            self._external_load = float(load)
            self._plan()

    @property
    def thermal_time_constant(self) -> float:
        """The winding temperature's first-order lag, s (default
        :data:`THERMAL_TIME_CONSTANT_S`). Setting it acts from the present step: the
        temperature goes on from where it is, at the new pace."""
        return self._tau

    @thermal_time_constant.setter
    def thermal_time_constant(self, seconds: float) -> None:
        tau = _time_constant(seconds)
        if tau != self._tau:
            self._restart()
            self._tau = tau
            self._decay = _decay(self._decay[0], tau)
            self._plan()

    @property
    def stalled(self) -> bool:
        """Torque is on and the external load beats the torque limit: the horn cannot turn
        and the motor gives all the limit allows (the firmware's overload condition)."""
        command = self._command
        if command.torque_control and not self._opposed():
            return False
        # (max() by a comparison here and below: the builtin parses its keywords at every call,
        # and the plant is asked at every read; ties and NaN come out as from the builtin)
        limit = command.torque_limit
        return (command.torque_enabled and not command.voltage_control
                and abs(self._external_load) > (limit if limit > 0.0 else 0.0))

    # -- state ----------------------------------------------------------------------------------
    @property
    def position(self) -> float:
        return self._state()[0]

    @property
    def velocity(self) -> float:
        return self._state()[1]

    @property
    def effort(self) -> float:
        return self._state()[2]

    @property
    def temperature(self) -> float:
        """Winding temperature, °C. Settable: the windings are that warm from the present
        step on, and the model goes on from there (see the class docstring)."""
        return self._state()[3]

    @temperature.setter
    def temperature(self, celsius: float) -> None:
        if not math.isfinite(celsius):
            raise ConfigError(f"temperature {celsius!r} °C is not a finite number")
        self._restart()
        self._t0 = float(celsius)
        self._plan()

    @property
    def drive(self) -> float:
        """The voltage the motor runs on, as a share of the supply (what Present PWM shows):
        on the torque-speed line of the datasheet's figures, drive = output torque share +
        speed / no-load speed, where the output torque is what holds the load and
        accelerates the horn — the gears' friction is already in those figures (the no-load
        speed is measured against it), so it is not counted again. In PWM mode it is the
        goal asked; in current mode the torque asked is the motor's own, friction and all;
        with no output, 0."""
        _, velocity, effort, _ = self._state()
        cmd = self._command
        if not self._limit():
            return 0.0
        if cmd.voltage_control:
            return cmd.goal_velocity / self.no_load_speed
        if cmd.torque_control or not velocity:
            return effort + velocity / self.no_load_speed
        top = self._max_speed()
        friction = FRICTION_STATIC + FRICTION_VISCOUS * (abs(velocity) / top if top else 0.0)
        return effort - math.copysign(friction, velocity) + velocity / self.no_load_speed

    def _state(self) -> tuple[float, float, float, float]:
        """(position, velocity, effort, temperature) now, computed once per step."""
        if self._cached_j != self._j:
            j = self._j
            velocity = self._velocity(j) if j else self._v0
            self._cached = (self._position(j), velocity,
                            self._effort(velocity, j) if j else self._e0, self._temperature(j))
            self._cached_j = j
        return self._cached

    # -- stepping -------------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        self.advance(1, dt)

    def advance(self, steps: int, dt: float, *, temperature_limit: float = math.inf) -> int:
        """Take ``steps`` fixed steps of ``dt`` — bit for bit what as many calls of
        :meth:`step` give — but stop after the first step that leaves the temperature above
        ``temperature_limit`` (the firmware's overheating shutdown must act there). Returns
        the steps taken."""
        if steps <= 0:
            return 0
        if dt != self._decay[0]:
            self._restart()
            self._decay = _decay(dt, self._tau)
            self._plan()        # (a profile is planned again from where the joint is)
        first, last = self._j + 1, self._j + steps
        hot = self._first_above(first, last, temperature_limit)
        self._j = last if hot is None else hot
        return self._j - first + 1

    # -- the closed form ------------------------------------------------------------------------
    def _restart(self) -> None:
        """Start a new segment where the current one stands."""
        self._p0, self._t0 = self.position, self.temperature
        self._v0, self._e0 = self.velocity, self.effort
        self._i0 = self._inertia(self._j)
        if not math.isnan(self._decay[0]):
            self._elapsed += self._j * self._decay[0]
        self._j = 0
        self._cached_j = -1

    def _limit(self) -> float:
        """The most torque the motor may give (fraction of stall torque)."""
        cmd = self._command
        if not cmd.torque_enabled:
            return 0.0
        limit = cmd.torque_limit
        limit = limit if limit < 1.0 else 1.0      # (max(0.0, min(1.0, limit)), by comparisons)
        return limit if limit > 0.0 else 0.0

    def _max_speed(self) -> float:
        load = abs(self._external_load)
        limit = self._command.torque_limit
        if self._command.torque_control and not self._opposed():
            return self.no_load_speed * max(0.0, 1.0 - load) if limit > 0 else 0.0
        if limit <= 0 or load > limit:
            return 0.0  # no torque allowed, or the load beats it: stalled
        left = 1.0 - load
        return self.no_load_speed * (left if left > 0.0 else 0.0)  # (max(0.0, left))

    def _opposed(self) -> bool:
        """Whether the external load pushes against the way a torque demand turns."""
        return self._external_load * self._command.goal_velocity < 0

    def _plan(self) -> None:
        """Decide the segment's motion from the command and the load (dt-independent)."""
        cmd = self._command
        top = self._max_speed()
        self._profile: Profile | None = None
        self._profile_t0 = self._elapsed
        trajectory = cmd.trajectory if cmd.torque_enabled and top > 0 else None
        if trajectory is not None and not _leads_to(trajectory, cmd):
            trajectory = None   # a world changed the goal the firmware planned for (stiction)
        if not cmd.torque_enabled:  # the driver open: back-driven through the gears
            self._speed, self._target = self._back_driven(), math.nan
        elif not self._limit():
            # torque on at an output of 0 (a 1.0 shutdown's Torque Limit 0): the driver holds
            # the windings at 0 V, so the back-EMF brakes the horn along the torque-speed line
            # at u = 0, w = w0 x load, as the MuJoCo world's motor at u = 0
            w0 = self.no_load_speed
            self._speed = w0 * max(-1.0, min(1.0, self._external_load))
            self._target = math.nan
        elif cmd.voltage_control:
            # a DC motor at a voltage share u turns where its torque line u - w / w0 meets the
            # load it holds, -L (L: the external load, + pushing counter-clockwise; friction is
            # in the no-load speed the datasheet gives): w = w0 (u + L), up to the no-load speed
            w0 = self.no_load_speed
            self._speed = w0 * max(-1.0, min(1.0, cmd.goal_velocity / w0 + self._external_load))
            self._target = math.nan
        elif cmd.velocity_control:
            self._speed, self._target = max(-top, min(top, cmd.goal_velocity)), math.nan
            if trajectory is not None:
                # the firmware's ramp while the load lets the horn reach its goal velocity;
                # else one of its own, at the same acceleration, to what it can reach
                self._profile = trajectory if abs(trajectory.after) <= top * (1 + 1e-12) \
                    else self._own(ramp(self._v0, self._speed, _acceleration(trajectory),
                                        start=self._p0))
        else:
            want = abs(cmd.profile_velocity)
            self._speed = top if want == 0 else top if top < want else want  # (min(want, top))
            self._target = cmd.goal_position
            if trajectory is not None:
                self._profile = trajectory if trajectory.peak_speed <= top * (1 + 1e-12) \
                    else self._own(move(self._p0, self._v0, self._target, top,
                                        _acceleration(trajectory)))
        self._plan_steps(self._decay[0])

    def _back_driven(self) -> float:
        """With torque off the motor gives nothing and the external load turns the horn
        through the gears, where it beats their static friction, at the speed their viscous
        friction balances it: |w| = no-load speed x (|load| - FRICTION_STATIC) /
        FRICTION_VISCOUS — never faster than the no-load speed, past which the motor's
        back-EMF exceeds the supply and its driver's diodes brake it."""
        load = self._external_load
        excess = abs(load) - FRICTION_STATIC
        if excess <= 0:
            return 0.0
        return math.copysign(self.no_load_speed * min(1.0, excess / FRICTION_VISCOUS), load)

    def _own(self, profile: Profile) -> Profile:
        """A profile of the plant's own, from where the joint is now (its time starts here)."""
        self._profile_t0 = 0.0
        return profile

    def _plan_steps(self, dt: float) -> None:
        """The segment's per-step figures for this ``dt``: travel per step, the step on which
        a move arrives (the first ``j`` with ``|error| <= travel * j``), the velocity and load
        while moving and at rest, and the temperatures they tend to. Before the first step
        ``dt`` is not known yet (nan) and nothing has moved."""
        self._cached_j = -1
        self._travel = self._speed * dt if not math.isnan(dt) else 0.0
        self._arrive = 0  # 0: no goal (velocity control); -1: stalled short of it
        torque = self._command.torque_enabled
        profile = self._profile
        if profile is not None and not math.isnan(self._target):
            # a profiled move arrives on the first step at or after its end
            self._arrive = max(1, math.ceil((profile.duration - self._profile_t0) / dt - 1e-9)) \
                if not math.isnan(dt) else 1
        elif not math.isnan(self._target):
            error = abs(self._target - self._p0)
            if error == 0:
                self._arrive = 1
            elif self._travel > 0:
                j = math.ceil(error / self._travel)
                j = j if j > 1 else 1   # (max(1, j): a comparison costs less than the builtin)
                while j > 1 and error <= self._travel * (j - 1):
                    j -= 1
                while not error <= self._travel * j:
                    j += 1
                self._arrive = j
            else:
                self._arrive = -1  # pushed to a standstill short of the goal
            self._step_travel = math.copysign(self._travel, self._target - self._p0)
        if math.isnan(self._target):
            self._v_move = self._speed
        elif profile is not None:   # its cruise (or peak) speed, for the heat while it moves
            self._v_move = math.copysign(profile.peak_speed, self._target - self._p0)
        else:
            self._v_move = 0.0 if self._arrive == -1 else math.copysign(
                self._speed, self._target - self._p0)
        self._e_move, self._e_rest = self._sustained(self._v_move), self._sustained(0.0)
        self._steady_move = self._steady(self._e_move)
        self._steady_rest = self._steady(self._e_rest)
        # The first step at rest after moving, when the segment has both parts.
        self._first_rest = (None if math.isnan(self._target) or not torque
                            else (self._arrive if self._arrive > 1 else 1))
        self._t_before_rest = self._t0
        if self._first_rest is not None and self._first_rest > 1:
            self._t_before_rest = self._temperature(self._first_rest - 1)
        # The acceleration torque: the one still decaying from before, plus the speed change
        # of the first step (to the moving speed, or straight to rest), then that of the
        # arrival. Each decays by exp(-dt / MECHANICAL_TIME_CONSTANT_S) a step.
        top = self.no_load_speed
        first_rest = self._first_rest
        if first_rest == 1:
            self._kick_move = self._kick_rest = self._i0 - self._v0 / top
        else:
            self._kick_move = self._i0 + (self._v_move - self._v0) / top
            self._kick_rest = (0.0 if first_rest is None else
                               self._kick_move * self._decay[2] ** (first_rest - 1)
                               - self._v_move / top)

    def _moving(self, j: int) -> bool:
        if j <= 0:
            return False
        if math.isnan(self._target):
            return self._speed != 0 or (self._profile is not None and self._velocity(j) != 0)
        return self._arrive == -1 or j < self._arrive

    def _position(self, j: int) -> float:
        if j <= 0:
            return self._p0
        profile = self._profile
        if profile is not None:
            if not math.isnan(self._target) and j >= self._arrive:
                return self._target
            return profile.at(self._profile_t0 + j * self._decay[0])[0]
        if math.isnan(self._target):
            return self._p0 + self._travel * j
        if self._arrive == -1:
            return self._p0
        if j >= self._arrive:
            return self._target
        return self._p0 + self._step_travel * j

    def _velocity(self, j: int) -> float:
        profile = self._profile
        if profile is not None and j > 0 and self._command.torque_enabled:
            if not math.isnan(self._target) and j >= self._arrive:
                return 0.0
            return profile.at(self._profile_t0 + j * self._decay[0])[1]
        return self._v_move if self._moving(j) else 0.0

    def _inertia(self, j: int) -> float:
        """The torque accelerating or braking motor and gears after step ``j`` (fraction of
        stall torque, before the torque limit); 0 with torque off."""
        if j <= 0:
            return self._i0
        if not self._command.torque_enabled:
            return 0.0
        r = self._decay[2]
        profile = self._profile
        if profile is not None:
            # along a profile the motor and gears ask a x tau / no-load speed (what a step of
            # speed dv gives in all, dv x tau / no-load speed, spread over the ramp): a
            # first-order lag toward it from where the torque stood at the segment's start
            moving = math.isnan(self._target) or j < self._arrive
            k = MECHANICAL_TIME_CONSTANT_S / self.no_load_speed
            a = profile.at(self._profile_t0 + j * self._decay[0])[2] if moving else 0.0
            a0 = profile.at(self._profile_t0)[2]
            return a * k + (self._i0 - a0 * k) * r ** j
        first_rest = self._first_rest
        if first_rest is None or j < first_rest:
            return self._kick_move * r ** j
        return self._kick_rest * r ** (j - first_rest + 1)

    def _sustained(self, velocity: float) -> float:
        """The torque the motor gives turning at ``velocity`` against friction and holding the
        external load, within its torque limit (the effort that heats it)."""
        limit = self._limit()
        if self._command.torque_control and limit:
            return math.copysign(limit, self._command.goal_velocity)
        top = self._max_speed()
        friction = FRICTION_STATIC + FRICTION_VISCOUS * (abs(velocity) / top if top else 0.0)
        load = (math.copysign(friction, velocity) if velocity else 0.0) - self._external_load
        load = load if load < limit else limit     # (max(-limit, min(limit, load)), by comparisons)
        return load if load > -limit else -limit

    def _effort(self, velocity: float, j: int) -> float:
        """The torque the motor gives after step ``j``: sustained plus acceleration, within
        its torque limit."""
        limit = self._limit()
        if not limit:
            return 0.0
        if self._command.torque_control:   # the current loop holds the demanded torque
            return math.copysign(limit, self._command.goal_velocity)
        top = self._max_speed()
        friction = FRICTION_STATIC + FRICTION_VISCOUS * (abs(velocity) / top if top else 0.0)
        load = ((math.copysign(friction, velocity) if velocity else 0.0) - self._external_load
                + self._inertia(j))
        load = load if load < limit else limit     # (max(-limit, min(limit, load)), by comparisons)
        return load if load > -limit else -limit

    def _steady(self, effort: float) -> float:
        return self.ambient + IDLE_RISE_C + STALL_HEATING_C * effort * effort

    def _temperature(self, j: int) -> float:
        """Temperature after step ``j`` of the segment: a first-order lag toward the steady
        temperature of the load, in closed form over each part of constant load (moving,
        then at rest once arrived)."""
        if j <= 0:
            return self._t0
        a = self._decay[1]
        first_rest = self._first_rest
        if first_rest is None or j < first_rest:
            steady = self._steady_move
            return steady + (self._t0 - steady) * a ** j
        steady = self._steady_rest
        return steady + (self._t_before_rest - steady) * a ** (j - first_rest + 1)

    def _first_above(self, first: int, last: int, limit: float) -> int | None:
        """The first step in ``first..last`` whose temperature exceeds ``limit``, or None.
        The temperature is monotonic within each part of the segment, so each part is
        searched by bisection on the exact per-step expression."""
        if math.isinf(limit):
            return None
        # (max(t0, steady_move, steady_rest) by comparisons, as the builtin keeps the first of
        # equals: it parses its keywords at every call, and this is asked at every sync)
        top = self._t0
        if self._steady_move > top:
            top = self._steady_move
        if self._steady_rest > top:
            top = self._steady_rest
        if top <= limit:
            return None  # it cannot get there: each part only approaches its steady value
        rest = self._first_rest
        parts = [(first, last)] if rest is None or rest > last or rest <= first else [
            (first, rest - 1), (rest, last)]
        for lo, hi in parts:
            if self._temperature(lo) > limit:
                return lo
            if not self._temperature(hi) > limit:
                continue
            while hi - lo > 1:  # temperature(lo) <= limit < temperature(hi)
                mid = (lo + hi) // 2
                if self._temperature(mid) > limit:
                    hi = mid
                else:
                    lo = mid
            return hi
        return None


def _time_constant(seconds: float) -> float:
    if not (math.isfinite(seconds) and seconds > 0):
        raise ConfigError(f"thermal_time_constant {seconds!r} s must be a positive number")
    return float(seconds)


def _decay(dt: float, thermal_tau: float) -> tuple[float, float, float]:
    """(dt, the thermal decay per step, the mechanical decay per step); nan before the first
    step, when dt is not known yet."""
    if math.isnan(dt):
        return (dt, 1.0, 1.0)
    return (dt, math.exp(-dt / thermal_tau), math.exp(-dt / MECHANICAL_TIME_CONSTANT_S))


def _acceleration(profile: Profile) -> float:
    """The largest acceleration (rad/s²) of a trajectory's phases; infinity with none (a step
    or a rectangular profile)."""
    return max((abs(p.acceleration) for p in profile.phases), default=0.0) or math.inf


def _leads_to(trajectory: Profile, command: ServoCommand) -> bool:
    """Whether ``trajectory`` ends at ``command``'s goal (velocity, or position)."""
    if command.velocity_control:
        return math.isclose(trajectory.after, command.goal_velocity, abs_tol=1e-12)
    return math.isclose(trajectory.end, command.goal_position, rel_tol=1e-9, abs_tol=1e-9)
