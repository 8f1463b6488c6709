"""A MuJoCo world: a robot of Dynamixel joints whose bodies a physics engine moves, each joint
driven through its emulated servo's firmware.

Where the floor and the ball own a few wheels, this world owns a whole robot (an MJCF: any
robot's is written by :func:`servolab.robots.description.mjcf`, the biped of seed 001's by
:mod:`servolab.robots.armstrong.description`) and the state of its joints: hinges and slides,
each driven by one servo through a gear ratio and a direction (:class:`ServoJoint`). A floor
is the model's to have or not: a walking robot stands on one, an arm fixed to a table needs
none. Each emulated motor keeps its firmware (control table, instructions, errors,
alarms) and gets a :class:`JointPlant` in place of its own plant: the firmware's
:class:`~servolab.dynamixel.plant.ServoCommand` goes in, and present position, speed, load
and temperature come out of the physics. Nothing else drives the joints: an MJCF actuator on
a servo's joint is refused, so that no second controller hides inside the model file.

**The firmware's control law** (one step, every joint at once, vectorised). ROBOTIS publish
the AX/RX/EX law only in words (e-Manual, RX-28 Compliance and Punch; Moving Speed), so
this is that law made concrete, and stated so it can be changed:

1. a reference moves from where the horn was when torque came on toward ``goal_position``
   at no more than ``moving_speed`` (0: at once) — the firmware's speed control; on an
   X-series motor it follows the trajectory of the firmware's profile generator instead
   (trapezoid or triangle, velocity- or time-based: :mod:`servolab.dynamixel.profile`, the
   one the default plant follows), and a goal velocity is ramped to;
2. the error (reference - horn) gives the output share ``u``: 0 within the compliance
   margin, then growing linearly across the compliance slope toward full output, capped at
   the torque limit (the e-Manual's Torque Limit caps the output), and never below punch
   while non-zero (the ``cw_*`` values for a negative error); a PID model (MX, X-series)
   adds its integral, derivative and feedforward terms (:mod:`servolab.dynamixel.gains`
   gives them in SI from the registers), the integral held within the torque limit;
3. the motor is a DC motor behind its gears: torque = stall torque x (``u`` - speed /
   no-load speed), the back-EMF line of the datasheet's two figures (RX-28: 3.7 N m, 85 rpm):
   the back-EMF brakes on top of the capped drive (never past the stall torque), also at an
   output of 0; with torque off the motor gives nothing (the H-bridge is open) and the
   gears' viscous friction (:data:`~servolab.dynamixel.plant.FRICTION_VISCOUS`) is all that
   brakes a back-driven horn.

In velocity control ``u`` is, on the X-series, its Velocity PI law on the speed error (to
the goal velocity, or along the profile's ramp to it); on the AX/RX/EX (wheel mode) the goal
speed's share of the no-load speed, the output the e-Manual says wheel mode sets; in PWM
mode the goal PWM. Current Control Mode is a current loop: the torque is the goal current's
(Kt x current) while the supply's voltage allows it, less the gears' viscous friction.
Back in position control the reference starts from the horn again. A PID model's P gain
comes as its compliance equivalent (the MX's table in the e-Manual; an X-series' Position P
Gain, output KPP x error in PWM units), so a stiffer gain sags less under the same load.

**Load and heat.** A 1.0 model's Present Load is the drive ``u``: "an inferred value based on
the internal output value" (e-Manual, RX-28 Present Load), so a joint held against something
reads its torque limit, and a joint back-driven at output 0 reads 0 while it brakes. An
X-series' Present Current is the torque's current, torque / Kt (its Present PWM the drive).
The winding temperature follows the torque (the current that heats the windings goes with it) as the
default plant's does (:mod:`servolab.dynamixel.plant`: a first-order lag toward ambient +
7 °C + 60 °C x (torque / stall torque)²), so a joint pushed against its limit heats, and the
firmware's alarm shutdown and a walk's supervisor act on it as on hardware. The firmware's
overload error needs the joint *stalled*: the drive at its limit while the horn stands still
(sampled every :data:`BOOKKEEPING_S`), for as long as the firmware's
:data:`~servolab.dynamixel.motor_alarms.OVERLOAD_TIME_S` (a joint saturating for a moment while
it accelerates is not overloaded); after the alarm shut the output off it lasts, as the
default plant's does, until a host gives the torque back.

**Time.** The simulation steps the world at its physics step (MuJoCo's timestep is set to
it); the same inputs give the same run, bit for bit: MuJoCo's step is deterministic on one
thread.

**Ground truth.** :meth:`MujocoWorld.ground_truth` gives the base body's pose, the centre of
mass, each foot's normal force and whether the robot has fallen (something other than its
feet touched the floor, or its base tilted past ``max_tilt``). Every ``record_period`` the
world also keeps a :class:`Sample` (:attr:`MujocoWorld.samples`) with the zero-moment point,
the centre of pressure and the support polygon's margin — what a biped's balance is judged
by — and the joints' loads and temperatures, for the run's summary, plot, video and bag.

The zero-moment point is computed from the robot's momentum (the contact wrench that changed
it between two samples, Sardain & Bessonnet 2004's definition): unlike the centre of pressure
it can leave the support polygon, and it does as the robot starts to tip, so its margin says
how near the robot came to falling. The centre of pressure is the contact forces' own: on
the floor it never leaves the polygon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamixel.emulator import VirtualMotor
from ..dynamixel.plant import (
    AMBIENT_C,
    FRICTION_VISCOUS,
    IDLE_RISE_C,
    STALL_HEATING_C,
    THERMAL_TIME_CONSTANT_S,
    ServoCommand,
)
from ..dynamixel.profile import Profile
from .errors import SimulationError
from .simulation import Simulation
from .world import World

#: How often (s) the world updates the windings' temperatures and the joints' stall timers:
#: slow quantities, kept off the per-step path (see MujocoWorld._book).
BOOKKEEPING_S = 0.02
#: Below this share of the no-load speed a joint at its torque limit counts as not moving.
_STILL_SHARE = 0.01
#: A contact carrying less than this (N) is not support: MuJoCo keeps contacts a little
#: before they press, and a corner about to lift would widen the support polygon.
SUPPORT_N = 0.05


@dataclass(frozen=True)
class ServoJoint:
    """An emulated motor and the MJCF joint it drives, a hinge (rad) or a slide (m): horn
    angle (rad from the model's centre tick, what the firmware counts) = ``offset`` +
    ``direction`` x ``gear_ratio`` x joint position. The gear ratio is horn radians a joint
    unit: a belt's or gears' reduction for a hinge, 1 / the pinion's radius for a slide
    driven by rack and pinion (a gripper's fingers). The joint's generalised force is the
    horn's torque x ``direction`` x ``gear_ratio`` (a lossless transmission)."""

    joint: str
    motor: VirtualMotor
    offset: float = 0.0
    direction: int = 1
    gear_ratio: float = 1.0

    @property
    def reduction(self) -> float:
        """Horn angle a joint unit, signed: ``direction`` x ``gear_ratio``."""
        return self.direction * self.gear_ratio


@dataclass(frozen=True)
class Sample:
    """The world every ``record_period``: SI, world frame (z up), ``nan`` where undefined
    (no zero-moment point before the second sample or in the air)."""

    t: float
    base: tuple[float, float, float, float, float, float]   # x y z roll pitch yaw
    com: tuple[float, float, float]
    zmp: tuple[float, float]
    cop: tuple[float, float]
    #: the centre of the support points (nan with no foot on the floor): the middle the
    #: zero-moment point leaves from
    support: tuple[float, float]
    #: signed distance (m) of the zero-moment point from the support polygon's edge: > 0
    #: inside; nan with no foot on the floor
    margin: float
    feet: tuple[float, ...]          # normal force on each foot (N), in the order given
    fallen: bool
    load: tuple[float, ...]          # each joint's present load (fraction of stall torque)
    temperature: tuple[float, ...]   # each joint's winding temperature (°C)
    qpos: tuple[float, ...]          # MuJoCo's qpos: for rendering the run


class JointPlant:
    """One joint of a :class:`MujocoWorld` as its motor's
    :class:`~servolab.dynamixel.plant.ServoPlant`: it forwards the firmware's command to the
    world and reads the joint's state from it. The world steps all its joints at once, so
    :meth:`step` does nothing."""

    #: the world calls the firmware's ``plant_changed`` when temperature or stall change
    #: (MujocoWorld._book), rather than the firmware looking every step
    reports_changes = True

    def __init__(self, world: MujocoWorld, index: int) -> None:
        self._world = world
        self._index = index
        self._command = ServoCommand()
        # the firmware looks at these every step: plain Python values, which the world
        # refreshes whenever it does its bookkeeping (MujocoWorld._book)
        self._temperature = AMBIENT_C + IDLE_RISE_C
        self._stalled = False

    @property
    def command(self) -> ServoCommand:
        return self._command

    @command.setter
    def command(self, command: ServoCommand) -> None:
        if command != self._command:
            self._command = command
            self._world._commanded(self._index, command)

    @property
    def position(self) -> float:
        return self._world._horn(self._index)

    @property
    def velocity(self) -> float:
        return self._world._horn_velocity(self._index)

    @property
    def effort(self) -> float:
        return float(self._world._effort[self._index])

    @property
    def drive(self) -> float:
        """The voltage share the motor runs on (Present PWM): the law's output ``u``; in
        current mode the torque asked plus the back-EMF it must overcome."""
        return float(self._world._drive[self._index])

    @property
    def temperature(self) -> float:
        """Winding temperature, °C; settable (the windings are that warm from now on), as the
        default plant's (:class:`~servolab.dynamixel.plant.KinematicServo`)."""
        return self._temperature

    @temperature.setter
    def temperature(self, celsius: float) -> None:
        if not math.isfinite(celsius):
            raise SimulationError(f"temperature {celsius!r} °C is not a finite number")
        self._world._temperature[self._index] = self._temperature = float(celsius)

    @property
    def thermal_time_constant(self) -> float:
        return float(self._world._thermal_tau[self._index])

    @thermal_time_constant.setter
    def thermal_time_constant(self, seconds: float) -> None:
        if not (math.isfinite(seconds) and seconds > 0):
            raise SimulationError(f"thermal_time_constant {seconds!r} s must be a positive "
                                  "number")
        self._world._thermal_tau[self._index] = float(seconds)

    @property
    def stalled(self) -> bool:
        """At the torque limit and not moving (as last sampled): the condition the firmware
        calls an overload once it has lasted its ``OVERLOAD_TIME_S``."""
        return self._stalled

    def step(self, dt: float) -> None:
        """Nothing: :meth:`MujocoWorld.step` steps every joint together."""


class MujocoWorld(World):
    """A robot in MuJoCo, its joints driven by emulated servos (see the module docstring).

    ``mjcf`` is the model's XML text; ``joints`` name the hinges and slides the motors
    drive. ``base`` is the body whose pose :meth:`ground_truth` reports (default: the first
    body with a free joint, else the first body); ``feet`` the bodies whose floor contacts are
    support (the rest are falls); ``floor`` the floor geom's name (default: the geom named
    ``floor`` if the model has one; a model without a floor — an arm fixed to a table — has no
    contacts with it, no zero-moment point and never falls). ``qpos`` (MuJoCo's) sets the start,
    else the model's own ``qpos0``; ``start`` is the simulation's time when the world joins
    it (the samples' times are the simulation's). ``held_until_torque``: the base hangs in a
    harness, where it stands, until every servo has its torque on (:attr:`released_at`), as a
    lab holds a biped on its gantry while its servos power up: a robot served on a pty waits
    for a client that may come a minute later, and with its torque off (each servo's default
    at power-on) it would creep over its gears and fall before the client's first goal."""

    name = "mujoco"

    def __init__(self, mjcf: str, joints: Sequence[ServoJoint], *, base: str | None = None,
                 feet: Sequence[str] = (), floor: str | None = None,
                 max_tilt: float = math.radians(45.0), record_period: float = 0.02,
                 qpos: Sequence[float] | None = None, start: float = 0.0,
                 max_samples: int = 30_000, held_until_torque: bool = False) -> None:
        import mujoco

        try:
            self.model = mujoco.MjModel.from_xml_string(mjcf)
        except ValueError as error:
            raise SimulationError(f"the MuJoCo model does not load: {error}") from None
        m = self.model
        self.data = mujoco.MjData(m)
        self._mujoco = mujoco
        if not joints:
            raise SimulationError("a MuJoCo world needs at least one servo joint")
        if not (math.isfinite(record_period) and record_period > 0):
            raise SimulationError(f"record_period {record_period!r} s must be a number > 0")
        self.joints = tuple(joints)
        ids = [self._id(mujoco.mjtObj.mjOBJ_JOINT, j.joint, "joint") for j in self.joints]
        if len(set(ids)) != len(ids):
            raise SimulationError("two motors turn the same joint: "
                                  + ", ".join(j.joint for j in self.joints))
        driven = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        for j, jid in zip(self.joints, ids, strict=True):
            if int(m.jnt_type[jid]) not in driven:
                raise SimulationError(f"joint {j.joint!r} is not a hinge or a slide: a servo "
                                      "drives one")
            if j.direction not in (-1, 1):
                raise SimulationError(f"joint {j.joint!r}: direction {j.direction!r} must be "
                                      "+1 or -1")
            ratio = j.gear_ratio
            if isinstance(ratio, bool) or not isinstance(ratio, int | float) \
                    or not (math.isfinite(ratio) and ratio > 0):
                raise SimulationError(f"joint {j.joint!r}: gear_ratio {ratio!r} must be a "
                                      "positive number")
        for a in range(m.nu):
            if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and \
                    int(m.actuator_trnid[a, 0]) in ids:
                name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
                joint = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[a, 0])
                raise SimulationError(
                    f"the model's actuator {name!r} drives joint {joint!r}, which a servo's "
                    "firmware drives: write the model without actuators on servo joints")
        self._qadr = np.array([m.jnt_qposadr[i] for i in ids])
        self._dadr = np.array([m.jnt_dofadr[i] for i in ids])
        # the same places as slices where they run in order (a robot's joints usually do):
        # a slice reads MuJoCo's arrays without gathering them, once a step
        self._qpos_at = _as_slice(self._qadr)
        self._dof_at = _as_slice(self._dadr)
        self._offset = np.array([j.offset for j in self.joints], dtype=np.float64)
        # horn angle a joint unit, signed (direction x gear ratio): what turns a joint's
        # position and speed into the horn's, and the horn's torque into the joint's force
        self._dir = np.array([j.reduction for j in self.joints], dtype=np.float64)
        models = [j.motor.model for j in self.joints]
        self._stall = np.array([mm.stall_torque_nm for mm in models], dtype=np.float64)
        self._w0 = np.array([mm.no_load_speed for mm in models], dtype=np.float64)
        one_tick = np.array([mm.rad_per_tick for mm in models], dtype=np.float64)
        n = len(self.joints)
        # the command, as arrays (refreshed by _commanded)
        self._torque_on = np.zeros(n, dtype=bool)
        self._velocity_mode = np.zeros(n, dtype=bool)
        self._goal = np.zeros(n)
        self._speed = np.zeros(n)
        self._goal_velocity = np.zeros(n)
        self._limit = np.ones(n)
        self._margin = np.zeros((2, n))       # [cw, ccw]
        self._slope = np.vstack([one_tick, one_tick])   # no compliance: full at one tick
        self._punch = np.zeros(n)
        # a PID model's further gains (gains.position_pid, gains.velocity_pi), SI: 0 where none
        self._ki = np.zeros(n)
        self._kd = np.zeros(n)
        self._kff1 = np.zeros(n)
        self._kff2 = np.zeros(n)
        self._kvp = np.zeros(n)
        self._kvi = np.zeros(n)
        self._velocity_pi = np.zeros(n, dtype=bool)
        self._torque_mode = np.zeros(n, dtype=bool)     # current mode: a torque demand
        # the models whose load register is Present Current (the torque's current), not a
        # 1.0 Present Load (the drive)
        self._current_sensing = np.array([mm.has("present_current") for mm in models])
        #: what every joint's load register shows, "load" (the drive) or "current" (the
        #: torque's), or "mixed"
        self._sensing = ("current" if self._current_sensing.all() else "mixed"
                         if self._current_sensing.any() else "load")
        # the X-series profile each joint's reference follows, with the time it began: None
        # where the reference moves at the moving speed (AX/RX/EX, no Profile Acceleration)
        self._profiles: list[tuple[Profile, float] | None] = [None] * n
        self._profiled: list[int] = []
        # the state
        self._reference = np.zeros(n)
        self._effort = np.zeros(n)
        self._drive = np.zeros(n)
        self._integral = np.zeros(n)    # the error's integral (rad s; rad in velocity mode)
        self._last_error = np.zeros(n)  # for the derivative
        self._fresh = np.ones(n, dtype=bool)  # no derivative on a law's first step
        # the trajectory's velocity and acceleration (feedforward; velocity mode's reference)
        self._v_ref = np.zeros(n)
        self._a_ref = np.zeros(n)
        self._temperature = np.array([AMBIENT_C + IDLE_RISE_C] * n)
        self._thermal_tau = np.full(n, THERMAL_TIME_CONSTANT_S)
        self._decay_dt = math.nan                # the step's length
        self._square = np.zeros(n)
        self._heat = np.zeros(n)                 # sum of the squared loads since _book
        self._heat_steps = 0
        self._stalled = np.zeros(n, dtype=bool)
        self._laws_changed = True
        if qpos is not None:
            pose = np.asarray(qpos, dtype=np.float64)
            if pose.shape != (m.nq,) or not np.all(np.isfinite(pose)):
                raise SimulationError(f"qpos: {m.nq} finite numbers wanted, got shape "
                                      f"{pose.shape}")
            self.data.qpos[:] = pose
        mujoco.mj_forward(m, self.data)
        # the robot's bodies and the floor
        self.base = self._base_body(base)
        if floor is None and mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor") >= 0:
            floor = "floor"
        #: the floor geom's id, -1 without a floor
        self.floor = -1 if floor is None else self._id(mujoco.mjtObj.mjOBJ_GEOM, floor, "geom")
        gx, gy, gz = (float(v) for v in m.opt.gravity)
        if self.floor >= 0:
            level = (m.geom_type[self.floor] == mujoco.mjtGeom.mjGEOM_PLANE
                     and abs(float(self.data.geom_xpos[self.floor][2])) < 1e-9
                     and float(self.data.geom_xmat[self.floor][8]) > 1 - 1e-9)
            if not level or gx or gy or not gz < 0:
                raise SimulationError(
                    f"floor {floor!r}: the zero-moment point is computed for a level plane "
                    "at z = 0 under gravity along -z; this model's floor or gravity is not "
                    "that")
        self._gravity = -gz
        self.feet = tuple(feet)
        foot_ids = [self._id(mujoco.mjtObj.mjOBJ_BODY, f, "body") for f in self.feet]
        self._foot_of_geom = {g: k for k, body in enumerate(foot_ids)
                              for g in range(m.ngeom) if m.geom_bodyid[g] == body}
        self.max_tilt = float(max_tilt)
        self._root = int(m.body_rootid[self.base])
        self._mass = float(m.body_subtreemass[self._root])
        self.record_period = float(record_period)
        if isinstance(max_samples, bool) or not isinstance(max_samples, int) \
                or max_samples < 1:
            raise SimulationError(f"max_samples {max_samples!r} must be a whole number >= 1")
        #: the latest samples, at least ``max_samples`` of them (ten minutes at 50 a second by
        #: default, about 100 MB for the biped: a long-running ``servolab sim`` keeps the
        #: last ten minutes, not everything)
        self.samples: list[Sample] = []
        self._max_samples = max_samples
        #: every sample taken since the start, kept or not
        self.samples_taken = 0
        self.fell_at: float | None = None
        self._harness = self._free_joint_of_base() if held_until_torque else None
        #: when the harness let the base go (every servo's torque on), None while it holds
        #: (or when there is none)
        self.released_at: float | None = None
        self._time = float(start)
        self._next_record = float(start)
        self._next_book = float(start) + BOOKKEEPING_S
        self._momentum: tuple[float, ...] | None = None
        self.plants = tuple(JointPlant(self, k) for k in range(len(self.joints)))
        for joint, plant in zip(self.joints, self.plants, strict=True):
            self.attach(joint.motor, plant)
        self._reference[:] = self._horns()

    def _id(self, kind: Any, name: str, what: str) -> int:
        index = int(self._mujoco.mj_name2id(self.model, kind, name))
        if index < 0:
            raise SimulationError(f"the MuJoCo model has no {what} {name!r}")
        return index

    def _free_joint_of_base(self) -> tuple[slice, slice, np.ndarray]:
        """The base's free joint (its place in qpos and qvel) and its pose now, for the
        harness to hold it at."""
        m = self.model
        for j in range(m.njnt):
            if m.jnt_type[j] == self._mujoco.mjtJoint.mjJNT_FREE and \
                    int(m.jnt_bodyid[j]) == self.base:
                qpos = slice(int(m.jnt_qposadr[j]), int(m.jnt_qposadr[j]) + 7)
                qvel = slice(int(m.jnt_dofadr[j]), int(m.jnt_dofadr[j]) + 6)
                return qpos, qvel, self.data.qpos[qpos].copy()
        raise SimulationError("held_until_torque: the base body has no free joint to hold")

    def _base_body(self, name: str | None) -> int:
        m = self.model
        if name is not None:
            return self._id(self._mujoco.mjtObj.mjOBJ_BODY, name, "body")
        for j in range(m.njnt):
            if m.jnt_type[j] == self._mujoco.mjtJoint.mjJNT_FREE:
                return int(m.jnt_bodyid[j])
        return 1 if m.nbody > 1 else 0

    # -- the plants' side ---------------------------------------------------------------------
    def _commanded(self, k: int, command: ServoCommand) -> None:
        was_on = bool(self._torque_on[k])
        if (command.torque_enabled and not was_on) or \
                command.velocity_control != self._velocity_mode[k]:
            self._integral[k] = 0.0     # a new law starts from nothing accumulated
            self._fresh[k] = True
        self._torque_on[k] = command.torque_enabled
        self._velocity_mode[k] = command.velocity_control
        self._torque_mode[k] = command.torque_control
        pid, pi = command.pid, command.velocity_pi
        self._ki[k] = pid.integral if pid is not None else 0.0
        self._kd[k] = pid.derivative if pid is not None else 0.0
        self._kff1[k] = pid.velocity_feedforward if pid is not None else 0.0
        self._kff2[k] = pid.acceleration_feedforward if pid is not None else 0.0
        self._velocity_pi[k] = pi is not None and command.velocity_control \
            and not command.torque_control and not command.voltage_control
        self._kvp[k] = pi.proportional if pi is not None else 0.0
        self._kvi[k] = pi.integral if pi is not None else 0.0
        self._goal[k] = command.goal_position
        self._speed[k] = command.profile_velocity
        self._goal_velocity[k] = command.goal_velocity
        self._limit[k] = max(0.0, min(1.0, command.torque_limit))
        c = command.compliance
        if c is not None:
            self._margin[:, k] = (c.cw_margin, c.ccw_margin)
            tick = self.joints[k].motor.model.rad_per_tick
            # a slope of 0 means full output past the margin: one tick is as steep as the
            # encoder can tell
            self._slope[:, k] = (max(c.cw_slope, tick), max(c.ccw_slope, tick))
            self._punch[k] = c.punch
        if command.torque_enabled and not was_on:
            self._reference[k] = self._horn(k)  # the move starts where the horn is
        self._profiles[k] = self._profile_of(k, command)
        self._profiled = [i for i, p in enumerate(self._profiles) if p is not None]
        self._laws_changed = True

    def _profile_of(self, k: int, command: ServoCommand) -> tuple[Profile, float] | None:
        """The X-series firmware's trajectory joint ``k``'s reference follows, with the time
        it began (its profile generator's: :mod:`servolab.dynamixel.profile`, the law the
        default plant's horn follows too): kept while the command changes only otherwise."""
        trajectory = command.trajectory
        if not command.torque_enabled or trajectory is None:
            return None
        held = self._profiles[k]
        if held is not None and held[0] == trajectory:
            return held
        return trajectory, self._time

    def _horns(self) -> np.ndarray:
        horns: np.ndarray = self._offset + self._dir * self.data.qpos[self._qadr]
        return horns

    def _horn(self, k: int) -> float:
        return float(self._offset[k] + self._dir[k] * self.data.qpos[self._qadr[k]])

    def _horn_velocity(self, k: int) -> float:
        return float(self._dir[k] * self.data.qvel[self._dadr[k]])

    # -- stepping ---------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        m, d = self.model, self.data
        if dt != self._decay_dt:
            m.opt.timestep = dt
            self._decay_dt = dt
            self._laws_changed = True
        if self._laws_changed:
            self._prepare(dt)
        horn = self._offset + self._dir * d.qpos[self._qpos_at]
        # 1. the reference, moving toward the goal at the moving speed (0: at once)
        ref = self._reference
        move = self._goal - ref
        np.minimum(move, self._travel, out=move)
        np.maximum(move, -self._travel, out=move)
        ref += move
        if self._any_off:
            np.copyto(ref, horn, where=self._off)
        if self._any_velocity_mode:     # back in position control, a move starts here too
            np.copyto(ref, horn, where=self._velocity_mode)
        for k in self._profiled:        # the X-series profile: the trajectory's own point
            profile, began = self._profiles[k]  # type: ignore[misc]
            point = profile.at(self._time + dt - began)
            if not self._velocity_mode[k]:
                ref[k] = point[0]
            self._v_ref[k], self._a_ref[k] = point[1], point[2]
        # 2. the output share from the error, by margin, slope and punch
        error = ref - horn
        if self._symmetric:     # the usual case: the same margin and slope either way
            beyond = np.abs(error) - self._margin[1]
            share = beyond * self._gain[1]
        else:
            ccw = error >= 0
            beyond = np.abs(error) - np.where(ccw, self._margin[1], self._margin[0])
            share = beyond * np.where(ccw, self._gain[1], self._gain[0])
        # (a PID model's P term before any limit: the law limits P + I + D + FF once)
        proportional = np.where(beyond > 0, np.copysign(share, error), 0.0) \
            if self._any_pid else None
        np.maximum(share, self._punch, out=share)
        np.minimum(share, self._limit, out=share)
        u = np.where(beyond > 0, np.copysign(share, error), 0.0)
        speed = self._dir * d.qvel[self._dof_at]
        if proportional is not None:  # a PID model's integral, derivative and feedforward
            np.copyto(u, self._pid(error, proportional, dt), where=self._pid_joints)
        if self._any_velocity_mode:
            np.copyto(u, self._velocity_law(speed, dt), where=self._velocity_mode)
        # 3. the DC motor behind its gears: the torque limit caps the drive (u, above); the
        #    back-EMF brakes on top of it, never beyond the stall torque. Present load (1.0)
        #    is the drive ("inferred ... based on the internal output value", e-Manual RX-28
        #    Present Load); Present Current (X-series) the torque's current, torque / Kt;
        #    the torque, and the current that heats the windings, are this:
        if self._any_off:
            u *= self._on
        self._drive = u
        back_emf = speed / self._w0
        torque = u - back_emf
        np.minimum(torque, 1.0, out=torque)
        np.maximum(torque, -1.0, out=torque)
        # (u is not changed from here on; the torque is)
        self._effort = (u if self._sensing == "load" else torque.copy()
                        if self._sensing == "current" else
                        np.where(self._current_sensing, torque, u))
        if self._any_torque_mode:
            # current mode: the current loop gives the torque asked (Kt x current) while the
            # supply's voltage lets it (the torque line at full drive, +-1 - speed share);
            # the gears' viscous friction takes its share of it on the way to the horn (the
            # static part is in the stall figures Kt comes from)
            asked = np.clip(u, -1.0 - back_emf, 1.0 - back_emf)
            current = self._torque_mode & self._torque_on
            np.copyto(torque, asked - FRICTION_VISCOUS * back_emf, where=current)
            self._effort = np.where(current, asked, self._effort)
            self._drive = np.where(current, asked + back_emf, u)
        if self._any_off:
            torque *= self._on
        np.multiply(torque, torque, out=self._square)   # the motor's, for the heat
        if self._any_off:   # torque off: back-driven through the gears' viscous friction
            np.copyto(torque, -FRICTION_VISCOUS * back_emf, where=self._off)
        d.qfrc_applied[self._dof_at] = torque * self._dir_stall
        recording = self._time >= self._next_record - 1e-12   # a sample every period
        before = (self._time, tuple(d.qpos.tolist())) if recording else None
        self._mujoco.mj_step(m, d)   # (its forward pass: contacts and bodies of `before`)
        if self._harness is not None:
            self._hold(dt)
        self._heat += self._square              # for the windings' temperature
        self._heat_steps += 1
        self._time += dt
        if self._time >= self._next_book - 1e-12:
            self._book(self._drive, self._dir * d.qvel[self._dof_at])
            self._next_book += BOOKKEEPING_S
        if before is not None:
            self._record(*before)
            self._next_record += self.record_period

    def _hold(self, dt: float) -> None:
        """The harness: the base back where it hangs, at rest, until every servo's torque is
        on; then it lets go for good."""
        assert self._harness is not None
        if self._torque_on.all():
            self._harness = None
            self.released_at = self._time + dt
            return
        qpos, qvel, pose = self._harness
        self.data.qpos[qpos] = pose
        self.data.qvel[qvel] = 0.0

    def _pid(self, error: np.ndarray, proportional: np.ndarray, dt: float) -> np.ndarray:
        """A PID model's whole position law, P + I + D + feedforward (output shares), limited
        once, as the e-Manual's block diagram limits the controller's sum. The derivative is
        of the error (KPD acts on its change a period), 0 on a law's first step. The
        integral stops while the sum is saturated the way the error pushes (conditional
        integration: the e-Manual's anti-windup gain Ka is not published)."""
        joints = self._pid_joints
        rate = np.where(self._fresh, 0.0, (error - self._last_error) / dt)
        self._last_error = np.where(joints, error, self._last_error)
        self._fresh &= ~joints
        rest = (self._kd * rate + self._kff1 * self._v_ref + self._kff2 * self._a_ref
                + proportional)
        integral = self._integral
        trial = np.where(joints & (self._ki > 0), integral + error * dt, integral)
        total = rest + self._ki * trial
        limit = self._limit
        wound = (np.abs(total) > limit) & (total * error > 0)
        np.copyto(integral, trial, where=~wound)
        law: np.ndarray = np.clip(rest + self._ki * integral, -limit, limit)
        return law

    def _velocity_law(self, speed: np.ndarray, dt: float) -> np.ndarray:
        """Velocity control's output share: the X-series' PI law on the speed error (its
        integral stopped while the sum is saturated, as the position law's), else the goal
        speed's share of the no-load speed, open loop (AX/RX/EX wheel mode, current and PWM
        modes' demands). (The integral shares its array with the position law's: a joint
        uses one law at a time, and a change of law starts it from 0, see _commanded.)"""
        limit = self._limit
        u = np.clip(self._v_ref / self._w0, -limit, limit)
        if self._any_velocity_pi:
            pi = self._velocity_pi
            error = self._v_ref - speed
            integral = self._integral
            trial = np.where(pi & (self._kvi > 0), integral + error * dt, integral)
            total = self._kvp * error + self._kvi * trial
            wound = (np.abs(total) > limit) & (total * error > 0)
            np.copyto(integral, trial, where=pi & ~wound)
            closed = np.clip(self._kvp * error + self._kvi * integral, -limit, limit)
            np.copyto(u, closed, where=pi)
        return u

    def _book(self, effort: np.ndarray, speed: np.ndarray) -> None:
        """Every :data:`BOOKKEEPING_S`: the windings' temperature, by the first-order lag
        over the interval toward the steady temperature of its mean squared load (exact for
        a constant load; the load's changes within 20 ms are nothing to a lag of minutes),
        and whether each joint pushes at its limit without moving (sampled: the firmware's
        overload takes a second of it)."""
        span = self._heat_steps * self._decay_dt
        steady = AMBIENT_C + IDLE_RISE_C + STALL_HEATING_C * (self._heat / self._heat_steps)
        decay = np.exp(-span / self._thermal_tau)
        self._temperature = steady + (self._temperature - steady) * decay
        self._heat[:] = 0.0
        self._heat_steps = 0
        pushing = (np.abs(effort) >= self._saturated) & (np.abs(speed) < self._still)
        # after the overload shut the output off (limit 0), the load it could not hold
        # still cannot be: the condition lasts until a host gives the torque back (as the
        # default plant's, where any load beats a limit of 0)
        shut_off = self._torque_on & (self._limit == 0) & self._stalled
        self._stalled = pushing | shut_off
        stalled = self._stalled.tolist()
        for plant, joint, celsius, stuck in zip(self.plants, self.joints,
                                                self._temperature.tolist(), stalled,
                                                strict=True):
            plant._temperature = celsius
            plant._stalled = stuck
            joint.motor.plant_changed()

    def _prepare(self, dt: float) -> None:
        """The per-step figures of the current commands (recomputed when one changes)."""
        self._laws_changed = False
        self._travel = np.where(self._speed > 0, self._speed * dt, np.inf)
        self._off = ~self._torque_on
        self._on = self._torque_on.astype(np.float64)
        self._gain = 1.0 / self._slope
        self._symmetric = bool(np.array_equal(self._margin[0], self._margin[1])
                               and np.array_equal(self._slope[0], self._slope[1]))
        self._dir_stall = self._dir * self._stall
        self._any_velocity_mode = bool(self._velocity_mode.any())
        self._any_off = bool(self._off.any())
        self._any_torque_mode = bool((self._torque_mode & self._torque_on).any())
        self._pid_joints = self._torque_on & ~self._velocity_mode & (
            (self._ki != 0) | (self._kd != 0) | (self._kff1 != 0) | (self._kff2 != 0))
        self._any_pid = bool(self._pid_joints.any())
        self._any_velocity_pi = bool((self._velocity_pi & self._torque_on).any())
        for k in range(len(self.joints)):
            if self._profiles[k] is None:   # no trajectory: the goal speed, and no ramp
                self._v_ref[k] = self._goal_velocity[k] if self._velocity_mode[k] else 0.0
                self._a_ref[k] = 0.0
        # a joint at its limit (and torque on, with a limit above 0) pushes as hard as it may
        self._saturated = np.where(self._torque_on & (self._limit > 0), self._limit - 1e-9,
                                   np.inf)
        self._still = _STILL_SHARE * self._w0

    # -- what happened ------------------------------------------------------------------------
    def _contacts(self) -> tuple[list[float], list[tuple[float, float, float]], bool]:
        """Each foot's normal force, the support points (x, y, normal force) and whether
        something else touches the floor."""
        m, d = self.model, self.data
        forces = [0.0] * len(self.feet)
        points: list[tuple[float, float, float]] = []
        other = False
        wrench = np.zeros(6)
        for i in range(d.ncon):
            contact = d.contact[i]
            g1, g2 = int(contact.geom1), int(contact.geom2)
            if self.floor not in (g1, g2):
                continue
            geom = g2 if g1 == self.floor else g1
            foot = self._foot_of_geom.get(geom)
            if foot is None:
                if m.geom_bodyid[geom] != 0:
                    other = True
                continue
            self._mujoco.mj_contactForce(m, d, i, wrench)
            normal = float(wrench[0])
            forces[foot] += normal
            if normal > SUPPORT_N:
                points.append((float(contact.pos[0]), float(contact.pos[1]), normal))
        return forces, points, other

    def _tilt(self) -> float:
        """The base's tilt from upright (rad): the angle of its z axis from the world's."""
        zz = float(self.data.xmat[self.base][8])
        return math.acos(max(-1.0, min(1.0, zz)))

    def _zmp(self, t: float) -> tuple[float, float]:
        """The zero-moment point at ``t`` from the momentum's change since the last sample:
        the mean over that interval (the contact impulses of one step would scatter it)."""
        mujoco, m, d = self._mujoco, self.model, self.data
        mujoco.mj_subtreeVel(m, d)
        root, mass = self._root, self._mass
        cx, cy, cz = (float(v) for v in d.subtree_com[root])
        px, py, pz = (mass * float(v) for v in d.subtree_linvel[root])
        lx, ly, _ = (float(v) for v in d.subtree_angmom[root])
        # angular momentum about the origin: com x linear momentum + about the com
        now = (t, cx, cy, pz, cy * pz - cz * py + lx, cz * px - cx * pz + ly)
        before, self._momentum = self._momentum, now
        if before is None:
            return (math.nan, math.nan)
        t0, cx0, cy0, pz0, hx0, hy0 = before
        span = t - t0
        weight = mass * self._gravity
        # the floor's force on the robot: what changed its momentum, less gravity's part
        fz = (pz - pz0) / span + weight
        if fz <= 1e-6 * weight:
            return (math.nan, math.nan)     # in the air: no point on the floor
        # its moment about the origin, less gravity's (at the mean centre of mass)
        mx = (now[4] - hx0) / span + weight * (cy + cy0) / 2
        my = (now[5] - hy0) / span - weight * (cx + cx0) / 2
        return (-my / fz, mx / fz)

    def _record(self, t: float, qpos: tuple[float, ...]) -> None:
        """A :class:`Sample` of the state at ``t`` (the step's start: MuJoCo's forward pass
        of that state is what ``data`` holds, but for ``qpos``, which mj_step moved on)."""
        d = self.data
        forces, points, other = self._contacts()
        zmp = self._zmp(t) if self.floor >= 0 else (math.nan, math.nan)
        total = sum(p[2] for p in points)
        cop = ((sum(p[0] * p[2] for p in points) / total,
                sum(p[1] * p[2] for p in points) / total) if total > 0 else (math.nan, math.nan))
        margin = support_margin(zmp, [(p[0], p[1]) for p in points])
        support = ((sum(p[0] for p in points) / len(points),
                    sum(p[1] for p in points) / len(points)) if points
                   else (math.nan, math.nan))
        # nothing to fall onto without a floor
        fallen = self.floor >= 0 and (other or self._tilt() > self.max_tilt)
        if fallen and self.fell_at is None:
            self.fell_at = t
        pos = d.xpos[self.base]
        self.samples_taken += 1
        if len(self.samples) >= self._max_samples + self._max_samples // 10:
            del self.samples[:len(self.samples) - self._max_samples]   # the oldest, in chunks
        self.samples.append(Sample(
            t=t, base=(*_triple(pos), *_euler(d.xquat[self.base])),
            com=_triple(d.subtree_com[self._root]), zmp=zmp, cop=cop, support=support,
            margin=margin,
            feet=tuple(forces), fallen=fallen,
            load=tuple(self._effort.tolist()), temperature=tuple(self._temperature.tolist()),
            qpos=qpos))

    def ground_truth(self) -> dict[str, float]:
        d = self.data
        x, y, z = (float(v) for v in d.xpos[self.base])
        roll, pitch, yaw = _euler(d.xquat[self.base])
        cx, cy, cz = _triple(d.subtree_com[self._root])
        truth = {"x": x, "y": y, "z": z, "roll": roll, "pitch": pitch, "yaw": yaw,
                 "com_x": cx, "com_y": cy, "com_z": cz,
                 "fallen": 1.0 if self.fell_at is not None else 0.0}
        forces, _, _ = self._contacts()
        for foot, force in zip(self.feet, forces, strict=True):
            truth[f"{foot}_force"] = force
        return truth

    @classmethod
    def example(cls, simulation: Simulation) -> MujocoWorld:
        """An arm of two RX-28 (IDs 1 and 2, 57142 bps) on a post, told to lift."""
        from ..dynamixel.bus import Bus

        bus = Bus.open("emu://rx28:1-2", baudrate=57142, simulation=simulation)
        world = simulation.add(cls(EXAMPLE_ARM, [
            ServoJoint("shoulder", bus.emulator.motor(1)),
            ServoJoint("elbow", bus.emulator.motor(2), direction=-1)], start=simulation.now()))
        for motor_id, goal in ((1, 0.8), (2, -0.6)):
            bus.write(motor_id, "torque_enable", 1)
            bus.write(motor_id, "goal_position", goal)
        return world


def _as_slice(places: np.ndarray) -> slice | np.ndarray:
    """``places`` as a slice when they are consecutive and rising, else as they are."""
    start = int(places[0])
    if np.array_equal(places, np.arange(start, start + len(places))):
        return slice(start, start + len(places))
    return places


def support_margin(point: tuple[float, float], support: Sequence[tuple[float, float]]
                   ) -> float:
    """Signed distance (m) from ``point`` to the edge of the convex hull of the ``support``
    points: positive inside, negative outside, nan without support or point. OpenCV's
    convex hull and point-polygon test do the geometry."""
    import cv2

    if not support or not all(math.isfinite(v) for v in point):
        return math.nan
    if len(set(support)) == 1:
        (x, y), = set(support)
        return -math.hypot(point[0] - x, point[1] - y)
    hull = cv2.convexHull(np.asarray(support, dtype=np.float32))
    return float(cv2.pointPolygonTest(hull, (float(point[0]), float(point[1])), True))


def _triple(values: Any) -> tuple[float, float, float]:
    x, y, z = (float(v) for v in values)
    return x, y, z


def _euler(quat: Any) -> tuple[float, float, float]:
    """Roll, pitch, yaw (rad, z-y-x) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


#: The contract test's scene (:meth:`MujocoWorld.example`): a shoulder and an elbow, each an
#: RX-28's horn, carrying 100 g links.
EXAMPLE_ARM = """
<mujoco model="arm">
  <compiler angle="radian"/>
  <option timestep="0.001" integrator="implicitfast"/>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.05"/>
    <body name="upper" pos="0 0 0.3">
      <joint name="shoulder" type="hinge" axis="0 1 0" armature="0.0037"/>
      <geom type="box" size="0.015 0.015 0.05" pos="0 0 -0.05" mass="0.1"/>
      <body name="lower" pos="0 0 -0.1">
        <joint name="elbow" type="hinge" axis="0 1 0" armature="0.0037"/>
        <geom type="box" size="0.015 0.015 0.05" pos="0 0 -0.05" mass="0.1"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
