"""A walking pattern for the Armstrong biped (seed 001) that keeps its zero-moment point
(ZMP) on its feet: footsteps, a ZMP reference on them, the centre of mass (CoM) from
Kajita et al.'s preview control ("Biped walking pattern generation by using preview control
of zero-moment point", ICRA 2003; :mod:`servolab.gait.preview_control`), swing feet, and the
legs' inverse kinematics, written as the motion file the seed's generator writes
(:class:`~servolab.gait.motionfile.MotionFile`: columns m11..m62, degrees, one row every
``1 / rate`` s).

Why a second generator: the seed's gait (:mod:`servolab.gait.walking`, Appendix D/E) moves
the hip sideways by a fixed amount in four rows a step, without a model of the robot's
dynamics; played in a physics simulation of the robot with its servos emulated, it falls
within two seconds. Here the CoM is planned so that the cart-table model's ZMP stays on the
stance foot's centre in single support and moves from foot to foot in double support.

The pipeline (:func:`plan_zmp_walk`), in metres in the *walk frame*: the pelvis frame of the
stand pose at the start (x forward, y to the robot's left, z up, the floor at z = 0):

1. **Footsteps.** The walk starts and ends in double support in the stand pose (Table 4.2,
   :data:`TABLE_4_2_STAND_POSE`: the left foot 20 mm ahead of its hip, the right 20 mm
   behind). The foot behind swings first; every swing carries a foot ``2 step_length``
   forward, so after the even number ``steps`` both feet have moved ``steps x
   step_length`` and the last step closes them into the stand pose's placement again: the
   robot ends standing as it started, ``steps x step_length`` further on (with Table 5.1's
   40 mm the feet are always 40 mm apart lengthwise, as in the stand pose). An odd
   ``steps`` would end with the feet the other way round, a pose the robot does not stand
   in, and is refused.
2. **ZMP reference.** Under the CoM while standing (``settle`` s at each end); in each
   step's double support (``double_support x step_time``) it moves linearly to the stance
   foot's sole centre and stays there through the single support.
3. **CoM** by preview control, the CoM at ``com_height`` above the floor, starting at rest.
4. **Swing foot** in single support: up and down along ``(1 - cos)/2`` by ``foot_lift``,
   forward (and sideways) along a cycloid that ends :data:`SET_DOWN` of the swing early:
   position and velocity are continuous and 0 at lift-off and touch-down.
5. **Legs.** The pelvis is the CoM minus ``com_offset`` (the CoM is taken to sit at a
   fixed horizontal offset from the pelvis), at the stand pose's height; each sole relative
   to its hip, flat, through :func:`servolab.kinematics.leg.leg_inverse`; the stance leg's
   hip roll turned by ``hip_roll_compensation`` against the servo's sag under load
   (:func:`stance_load`); the motor columns as :func:`servolab.gait.walking.motor_angles`
   maps them; the upper body stays in the stand pose.

The first and the last row are the stand pose (the CoM starts and ends at rest over the
stand pose's ZMP), so playback starts and ends without a jump. Refused, each with a one-line
:class:`~servolab.gait.errors.GaitValueError` naming the parameter to change: a foot out of
reach; a row beyond ``limits`` (degrees by motor column, the robot's configuration's: this
layer knows no robot); a joint turning faster than ``max_joint_speed`` between two rows (the
servo could not follow).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace

import numpy as np

from servolab.gait.errors import GaitValueError
from servolab.gait.motionfile import MotionFile
from servolab.gait.preview_control import PREVIEW_S, com_from_zmp
from servolab.gait.walking import (
    MOTOR_COLUMNS,
    TABLE_4_2_STAND_POSE,
    motor_angles,
    motor_joint,
)
from servolab.kinematics.dh import FloatArray
from servolab.kinematics.leg import (
    ARMSTRONG_LEG,
    HIP_ROLL,
    LegGeometry,
    Side,
    foot_position,
    format_position,
    leg_inverse,
    leg_motor_angles,
    reachable,
    unreachable_reason,
)

__all__ = ["COM_OFFSET", "HIP_ROLL_COMPENSATION", "HIP_WIDTH", "JOINT_SPEED", "SET_DOWN",
           "TABLE_4_2_STAND_POSE", "StandGeometry", "ZmpWalkParameters", "ZmpWalkPlan",
           "footstep_plan", "generate_zmp_walk", "joint_speeds", "plan_zmp_walk",
           "stance_load", "stand_geometry"]

#: The hip-yaw axes' distance (m): Armstrong's description's assumption ``hip_width`` (a
#: guess; the seed gives none).
HIP_WIDTH = 0.100
#: Where the CoM sits relative to the pelvis frame (m, x forward, y left): Armstrong's
#: description (its stated masses) in the stand pose, whose trunk leans 25 degrees forward
#: (m51); tests/gait/test_zmp_walk.py checks it against ``describe()``. With 0 the pelvis
#: would be put where the CoM must be, and the real ZMP would run 18 mm ahead of the plan.
COM_OFFSET = (0.0185, 0.0024)
#: Degrees the stance hip roll is turned against the servo's sag (:func:`stance_load`).
#: The RX-28 holds a goal only to within the error at which its torque (3.7 N m at the
#: compliance slope's 32 ticks, 9.4 degrees) balances the load; in single support the stance
#: hip roll carries the rest of the robot beside it (about 1 N m: some 3 degrees) and the
#: ankle roll sags too. Tuned on a simulation of the robot with its firmware emulated
#: (:class:`ZmpWalkParameters`): from 3 to 7 degrees it walks, 5 furthest and most
#: evenly with the masses +-20 %; without it the pelvis rolls 6 degrees towards the swing
#: foot, which then rises 8 mm instead of 20 and drags.
HIP_ROLL_COMPENSATION = 5.0
#: The firmware's moving speed (rad/s): ``joint_speed: 1.0`` of every controller in
#: ``armstrong.yaml`` (Appendix A); a row that asks a joint to go faster is reached late.
JOINT_SPEED = 1.0
#: The share of a swing, at its end, in which the foot only comes down: its forward and
#: sideways travel ends before. It is set down vertically (no scuff at touch-down), and the
#: swing knee, which straightens as the foot goes both down and ahead, turns slower (0.87
#: rad/s at most instead of 1.09 with the defaults).
SET_DOWN = 0.2

_SIDES: tuple[Side, Side] = ("left", "right")
#: The leg columns m?1..m?6 of each side, in order.
_LEG_COLUMNS: dict[Side, tuple[str, ...]] = {
    "left": MOTOR_COLUMNS[0:6], "right": MOTOR_COLUMNS[6:12]}
_UPPER_COLUMNS = MOTOR_COLUMNS[12:]
_UNITS = {"step_length": " m", "step_width": " m", "step_time": " s", "foot_lift": " m",
          "hip_roll_compensation": " degrees", "com_height": " m", "com_offset": " m",
          "rate": " Hz", "preview": " s", "settle": " s", "control_dt": " s",
          "hip_width": " m", "max_joint_speed": " rad/s"}
#: What a refusal may blame (the parameters that shape the rows), most likely first.
_BLAMABLE = ("step_time", "step_length", "foot_lift", "hip_roll_compensation", "step_width",
             "double_support", "com_height", "com_offset", "hip_width", "settle", "rate")


def _number(name: str, value: object, *, low: float = 0.0, strict: bool = True,
            unit: str = "") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not math.isfinite(value) or not (value > low if strict else value >= low):
        bound = (f" of{unit}" if unit else "") if low == -math.inf else \
            f" {'>' if strict else '>='} {low:g}{unit}"
        raise GaitValueError(f"{name} must be a finite number{bound}, got {value!r}")
    return float(value)


@dataclass(frozen=True, kw_only=True)
class ZmpWalkParameters:
    """The walk's parameters in SI units (m, s, Hz, rad/s; the stand pose and the
    compensation in degrees). Each value that cannot be is refused on construction, in one
    line naming it.

    Defaults, and why:

    * ``steps`` 10, ``step_length`` 0.04 m: Table 5.1's ``l_step`` (40 mm).
    * ``step_width`` (m): the lateral distance of the feet's centres while walking; ``None``
      keeps the stand pose's (``hip_width`` + the soles' offsets from their hips, 85 mm).
    * ``step_time`` 2.5 s a step, ``double_support`` 0.2 of it with both feet down: the
      RX-28 moves at 1 rad/s (``max_joint_speed``), and the swing knee needs 0.87 rad/s at
      2.5 s (1.0 at 2.1 s), which leaves room to change the other parameters a little.
    * ``foot_lift`` 0.02 m: Table 5.1's ``h_step`` (20 mm).
    * ``hip_roll_compensation`` :data:`HIP_ROLL_COMPENSATION` degrees.
    * ``com_height`` (m): the cart-table's z_c; ``None`` takes the stand pose's hip height
      above the soles (0.295 m, the pelvis frame on the hip-yaw axes).
    * ``com_offset`` :data:`COM_OFFSET`.
    * ``rate`` 10 rows a second: the rate the file must be played at.
    * ``preview`` 1.6 s and ``control_dt`` 5 ms: Kajita 2003's window and sampling time.
    * ``settle`` 1 s standing still at each end, so that the CoM starts and ends at rest.
    * ``hip_width`` :data:`HIP_WIDTH`; ``stand_pose`` :data:`TABLE_4_2_STAND_POSE`.
    * ``max_joint_speed`` :data:`JOINT_SPEED`.

    With these, Armstrong walks the ten steps in the MuJoCo world without falling
    (``servolab walk --world mujoco --gait zmp``; docs/biped.md gives the distance and the
    sweep over the description's unknowns; the plan's is 0.40 m).
    """

    steps: int = 10
    step_length: float = 0.04
    step_width: float | None = None
    step_time: float = 2.5
    double_support: float = 0.2
    foot_lift: float = 0.02
    hip_roll_compensation: float = HIP_ROLL_COMPENSATION
    com_height: float | None = None
    com_offset: tuple[float, float] = COM_OFFSET
    rate: float = 10.0
    preview: float = PREVIEW_S
    control_dt: float = 0.005
    settle: float = 1.0
    hip_width: float = HIP_WIDTH
    max_joint_speed: float = JOINT_SPEED
    stand_pose: Mapping[str, float] = field(default_factory=lambda: TABLE_4_2_STAND_POSE,
                                            hash=False)

    def __post_init__(self) -> None:
        steps = self.steps
        if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 2:
            raise GaitValueError(f"steps must be an even integer >= 2, got {steps!r}")
        if steps % 2:
            raise GaitValueError(
                f"steps {steps}: odd, so the walk would end with the feet the other way round "
                f"than in the stand pose it starts from; use {steps - 1} or {steps + 1}")
        _number("step_length", self.step_length, strict=False, unit=" m")
        if self.step_width is not None:
            _number("step_width", self.step_width, unit=" m")
        _number("step_time", self.step_time, unit=" s")
        if _number("double_support", self.double_support) >= 1:
            raise GaitValueError(f"double_support is the share of step_time with both feet "
                                 f"down, a number in (0, 1), got {self.double_support!r}")
        _number("foot_lift", self.foot_lift, strict=False, unit=" m")
        _number("hip_roll_compensation", self.hip_roll_compensation, low=-math.inf,
                unit=" degrees")
        if self.com_height is not None:
            _number("com_height", self.com_height, unit=" m")
        offset = self.com_offset
        try:
            pair = tuple(_number("com_offset", v, low=-math.inf) for v in offset)
        except (GaitValueError, TypeError):
            pair = ()
        if len(pair) != 2:
            raise GaitValueError(f"com_offset must be two finite numbers (x, y) in m, got "
                                 f"{offset!r}")
        object.__setattr__(self, "com_offset", pair)
        for name, unit in (("rate", " Hz"), ("preview", " s"), ("control_dt", " s"),
                           ("hip_width", " m"), ("max_joint_speed", " rad/s")):
            _number(name, getattr(self, name), unit=unit)
        _number("settle", self.settle, unit=" s")   # > 0: the walk starts at rest
        if self.control_dt > 1.0 / self.rate:
            raise GaitValueError(f"control_dt {self.control_dt:g} s is longer than a row "
                                 f"(1 / rate = {1.0 / self.rate:g} s)")
        pose = self.stand_pose
        missing = [c for c in MOTOR_COLUMNS if c not in pose]
        if missing:
            raise GaitValueError(f"stand_pose has no angle for motor {', '.join(missing)}")
        for column in MOTOR_COLUMNS:
            _number(f"stand_pose[{column!r}]", pose[column], low=-math.inf, unit=" degrees")
        # a copy of its own (a plain dict, so the parameters copy and pickle)
        object.__setattr__(self, "stand_pose", {c: float(pose[c]) for c in MOTOR_COLUMNS})

    @property
    def double_support_time(self) -> float:
        """Seconds of a step with both feet down."""
        return self.double_support * self.step_time

    @property
    def duration(self) -> float:
        """Seconds the walk takes: ``settle``, the steps, the last double support (back to
        the stand pose's ZMP), ``settle``."""
        return 2 * self.settle + self.steps * self.step_time + self.double_support_time

    @property
    def row_count(self) -> int:
        """Rows of the motion file: ``duration`` at ``rate``, both ends included."""
        return math.ceil(self.duration * self.rate - 1e-9) + 1

    def step_start(self, k: int) -> float:
        """When step ``k`` (from 1) begins: its double support, then its single support."""
        return self.settle + (k - 1) * self.step_time


@dataclass(frozen=True, eq=False)
class StandGeometry:
    """The stand pose's feet: each sole's centre relative to its hip (mm, the leg frame of
    :mod:`servolab.kinematics.leg`) and the hips' height above the floor (m)."""

    left: FloatArray
    right: FloatArray
    hip_height: float


def stand_geometry(pose: Mapping[str, float], leg: LegGeometry = ARMSTRONG_LEG
                   ) -> StandGeometry:
    """Where a stand pose (degrees by motor column) puts the soles, by forward kinematics.

    Refused unless both feet are flat with the knees bent backwards (what the inverse
    kinematics solves for: any other pose could not be the walk's first row) and on one
    level (both soles on the floor).
    """
    feet: dict[str, FloatArray] = {}
    for side in _SIDES:
        # leg_motor_angles is a signed permutation: row j is joint j at 1 degree
        signs = leg_motor_angles(np.radians(np.eye(6)), side)
        joints = np.radians(np.array([pose[c] for c in _LEG_COLUMNS[side]]) @ signs.T)
        foot = foot_position(joints, leg)
        worst = float(np.degrees(np.abs(leg_inverse(foot, leg) - joints)).max())
        if worst > 0.01:
            raise GaitValueError(
                f"stand_pose: the {side} foot is not flat with the knee bent backwards "
                f"({worst:.3f} degrees from the inverse kinematics of its sole at "
                f"{format_position(foot)} mm)")
        feet[side] = foot
    if abs(feet["left"][2] - feet["right"][2]) > 0.5:
        raise GaitValueError(
            f"stand_pose: the soles are not on one level ({-feet['left'][2]:.2f} mm below the "
            f"left hip, {-feet['right'][2]:.2f} mm below the right)")
    height = -float(feet["left"][2] + feet["right"][2]) / 2 * 1e-3
    return StandGeometry(feet["left"], feet["right"], height)


@dataclass(frozen=True, eq=False)
class ZmpWalkPlan:
    """A planned walk, one entry per row (``time`` s, ``1 / rate`` apart), walk frame (m).

    ``footsteps`` ``(steps + 1, 2, 2)``: the (left, right) soles' (x, y) before the first
    step and after each; ``zmp_ref``, ``com`` and ``zmp`` (the cart-table model's ZMP of
    ``com``) ``(R, 2)``; the soles ``left``, ``right`` and the ``pelvis`` ``(R, 3)``;
    ``left_joints``, ``right_joints`` ``(R, 6)``, radians (``kinematics.leg.JOINT_NAMES``),
    what puts the soles there (before the hip roll's compensation); ``motors`` ``(R, 21)``,
    degrees, columns :data:`~servolab.gait.walking.MOTOR_COLUMNS`: what the robot is sent.
    """

    time: FloatArray
    footsteps: FloatArray
    zmp_ref: FloatArray
    com: FloatArray
    zmp: FloatArray
    left: FloatArray
    right: FloatArray
    pelvis: FloatArray
    left_joints: FloatArray
    right_joints: FloatArray
    motors: FloatArray
    com_height: float

    def motion(self) -> MotionFile:
        """The rows as a motion file (write it with ``motionfile.write_motion_file``)."""
        return MotionFile(MOTOR_COLUMNS, self.motors)


def _first_swing(stand: StandGeometry) -> int:
    """0 (left) or 1 (right): the foot behind swings first (the right on a tie)."""
    return 0 if stand.left[0] < stand.right[0] else 1


def _swing(k: int, first: int) -> int:
    """The foot that swings in step ``k`` (from 1)."""
    return first if k % 2 else 1 - first


def footstep_plan(params: ZmpWalkParameters, stand: StandGeometry) -> FloatArray:
    """The soles' centres (x, y) in m, ``(steps + 1, 2 (left, right), 2)``: the stand pose's,
    then after each step (module docstring: the foot behind first, every swing ``2
    step_length``, each foot's last placement at the stand pose's width)."""
    half = params.hip_width / 2
    start = np.array([[stand.left[0] * 1e-3, half + stand.left[1] * 1e-3],
                      [stand.right[0] * 1e-3, -half + stand.right[1] * 1e-3]])
    walking_y = start[:, 1].copy()
    if params.step_width is not None:
        walking_y = start[:, 1].mean() + np.array([0.5, -0.5]) * params.step_width
    first = _first_swing(stand)
    plan = np.empty((params.steps + 1, 2, 2))
    plan[0] = start
    for k in range(1, params.steps + 1):
        foot = _swing(k, first)
        plan[k] = plan[k - 1]
        plan[k, foot, 0] += 2 * params.step_length
        plan[k, foot, 1] = start[foot, 1] if k >= params.steps - 1 else walking_y[foot]
    return plan


def _zmp_reference(params: ZmpWalkParameters, plan: FloatArray, first: int,
                   start: FloatArray, times: FloatArray) -> FloatArray:
    """The ZMP reference (m, ``(len(times), 2)``), piecewise linear through its knots."""
    knots_t = [0.0, params.settle]
    knots_p = [start, start]
    for k in range(1, params.steps + 1):
        stance = plan[k - 1, 1 - _swing(k, first)]
        begin = params.step_start(k)
        knots_t += [begin + params.double_support_time, begin + params.step_time]
        knots_p += [stance, stance]
    end = start + (plan[-1].mean(axis=0) - plan[0].mean(axis=0))
    finish = params.step_start(params.steps + 1) + params.double_support_time
    knots_t += [finish, max(finish, float(times[-1]))]
    knots_p += [end, end]
    points = np.array(knots_p)
    return np.stack([np.interp(times, knots_t, points[:, a]) for a in range(2)], axis=1)


def stance_load(params: ZmpWalkParameters, times: FloatArray, first: int = 1) -> FloatArray:
    """How much of the robot each leg is taken to carry beyond standing, ``(len(times), 2)``
    (left, right), from 0 to 1: rising over the double support in which the ZMP moves onto
    its foot, 1 through that step's single support, falling over the next double support;
    0 while standing at either end. Smoothstepped, so what it scales starts and stops
    without a jump in speed. ``first``: the foot that swings first (0 left, 1 right)."""
    load = np.zeros((times.shape[0], 2))
    for k in range(1, params.steps + 1):
        begin = params.step_start(k)
        knots = [begin, begin + params.double_support_time, begin + params.step_time,
                 begin + params.step_time + params.double_support_time]
        load[:, 1 - _swing(k, first)] += np.interp(times, knots, [0.0, 1.0, 1.0, 0.0],
                                                   left=0.0, right=0.0)
    ramp = np.clip(load, 0.0, 1.0)
    return ramp * ramp * (3 - 2 * ramp)


def _feet(params: ZmpWalkParameters, plan: FloatArray, first: int, times: FloatArray
          ) -> tuple[FloatArray, FloatArray]:
    """Both soles (m, ``(len(times), 3)``): planted on their footsteps, and the swing foot in
    its step's single support as the module docstring says."""
    single = params.step_time - params.double_support_time
    feet = np.zeros((2, times.shape[0], 3))
    feet[:, :, :2] = plan[0][:, None, :]
    for k in range(1, params.steps + 1):
        foot = _swing(k, first)
        lift_off = params.step_start(k) + params.double_support_time
        after = times >= lift_off
        tau = np.clip((times[after] - lift_off) / single, 0.0, 1.0)
        ahead = np.clip(tau / (1.0 - SET_DOWN), 0.0, 1.0)
        share = ahead - np.sin(2 * np.pi * ahead) / (2 * np.pi)
        a, b = plan[k - 1, foot], plan[k, foot]
        feet[foot, after, :2] = a + (b - a) * share[:, None]
        feet[foot, after, 2] = params.foot_lift * (1 - np.cos(2 * np.pi * tau)) / 2
    return feet[0], feet[1]


def _compensated(params: ZmpWalkParameters, joints: Mapping[Side, FloatArray], first: int,
                 time: FloatArray) -> dict[Side, FloatArray]:
    """The joint angles to command: each stance leg's hip roll turned
    ``hip_roll_compensation`` degrees further as it takes the load (:func:`stance_load`),
    the way that raises the swing leg's side of the pelvis. Why: the servo sags by the error
    at which its torque holds the load (:data:`HIP_ROLL_COMPENSATION`), so the pelvis would
    roll down on the swing side and the swing foot drag. Positive hip roll swings the foot
    to the robot's left (``kinematics.leg``): the left leg's goal rises, the right's falls."""
    extra = math.radians(params.hip_roll_compensation) * stance_load(params, time, first)
    out = {side: joints[side].copy() for side in _SIDES}
    out["left"][:, HIP_ROLL] += extra[:, 0]
    out["right"][:, HIP_ROLL] -= extra[:, 1]
    return out


def _plan(params: ZmpWalkParameters, leg: LegGeometry) -> ZmpWalkPlan:
    """The walk, unchecked but for reach (the inverse kinematics needs it)."""
    stand = stand_geometry(params.stand_pose, leg)
    z_c = stand.hip_height if params.com_height is None else params.com_height
    first = _first_swing(stand)
    plan = footstep_plan(params, stand)
    time = np.arange(params.row_count) / params.rate
    fine = np.arange(math.ceil(time[-1] / params.control_dt - 1e-9) + 1) * params.control_dt
    offset = np.array(params.com_offset)
    reference = _zmp_reference(params, plan, first, offset, fine)
    com_fine, zmp_fine = com_from_zmp(reference, params.control_dt, z_c, params.preview,
                                      initial=offset)

    def at_rows(values: FloatArray) -> FloatArray:
        return np.stack([np.interp(time, fine, values[:, a]) for a in range(2)], axis=1)

    com = at_rows(com_fine)
    left, right = _feet(params, plan, first, time)
    pelvis = np.column_stack([com - offset, np.full(time.shape, stand.hip_height)])
    hip = np.array([0.0, params.hip_width / 2, 0.0])
    targets = {"left": (left - pelvis - hip) * 1e3, "right": (right - pelvis + hip) * 1e3}
    _check_reach(params, leg, targets, time)
    joints = {side: leg_inverse(targets[side], leg) for side in _SIDES}
    commanded = _compensated(params, joints, first, time)
    motors = motor_angles(commanded["left"], commanded["right"], arm_amplitude=0.0)
    upper = [MOTOR_COLUMNS.index(c) for c in _UPPER_COLUMNS]
    motors[:, upper] = [params.stand_pose[c] for c in _UPPER_COLUMNS]
    return ZmpWalkPlan(time=time, footsteps=plan, zmp_ref=at_rows(reference), com=com,
                       zmp=at_rows(zmp_fine), left=left, right=right, pelvis=pelvis,
                       left_joints=joints["left"], right_joints=joints["right"],
                       motors=motors, com_height=z_c)


def _shown(params: ZmpWalkParameters, name: str) -> str:
    value = getattr(params, name)
    text = "None" if value is None else (
        "(" + ", ".join(f"{v:g}" for v in value) + ")" if isinstance(value, tuple)
        else f"{value:g}")
    return f"{name} {text}{_UNITS.get(name, '')}"


def _blame(params: ZmpWalkParameters, passes: Callable[[ZmpWalkParameters], bool],
           fallback: str) -> str:
    """Whom a refusal names: the parameters changed from the defaults whose default alone
    makes the walk pass, else every changed one, else ``fallback`` (with its value)."""
    default = ZmpWalkParameters()
    changed = [n for n in _BLAMABLE if getattr(params, n) != getattr(default, n)]

    def fixes(name: str) -> bool:
        try:
            return passes(replace(params, **{name: getattr(default, name)}))
        except GaitValueError:
            return False

    names = [n for n in changed if fixes(n)] or changed or [fallback]
    return " and ".join(_shown(params, n) for n in names)


def _check_reach(params: ZmpWalkParameters, leg: LegGeometry,
                 targets: Mapping[str, FloatArray], time: FloatArray) -> None:
    ok = reachable(targets["left"], leg) & reachable(targets["right"], leg)
    if ok.all():
        return
    row = int(np.argmin(ok))
    side = "left" if not reachable(targets["left"][row], leg)[0] else "right"
    position = targets[side][row]

    def reaches(candidate: ZmpWalkParameters) -> bool:
        _plan(candidate, leg)
        return True

    raise GaitValueError(
        f"{_blame(params, reaches, 'step_length')}: row {row} (t = {time[row]:g} s): the "
        f"{side} sole at {format_position(position)} mm from its hip is out of reach: "
        f"{unreachable_reason(position, leg)}")


def _limit_offence(motors: FloatArray, limits: Mapping[str, tuple[float, float]]
                   ) -> tuple[int, int, float, float] | None:
    """The first row beyond ``limits`` and in it the first such column: ``(row, column,
    low, high)``, or None. Columns without limits are not checked."""
    low = np.array([limits[c][0] if c in limits else -np.inf for c in MOTOR_COLUMNS])
    high = np.array([limits[c][1] if c in limits else np.inf for c in MOTOR_COLUMNS])
    bad = (motors < low) | (motors > high)
    if not bad.any():
        return None
    row = int(np.argmax(bad.any(axis=1)))
    column = int(np.argmax(bad[row]))
    return row, column, float(low[column]), float(high[column])


def joint_speeds(motors: FloatArray, rate: float) -> FloatArray:
    """Each column's speed from the row before (rad/s), ``(R - 1, columns)``: what the servo
    must turn at to reach each row when it is due."""
    return np.abs(np.radians(np.diff(motors, axis=0))) * rate


def _speed_offence(motors: FloatArray, rate: float, speed: float
                   ) -> tuple[int, int, float] | None:
    """The first row a joint must reach faster than ``speed`` rad/s, and that column: ``(row,
    column, rad/s)``, or None."""
    fast = joint_speeds(motors, rate)
    bad = fast > speed * (1 + 1e-9)
    if not bad.any():
        return None
    row = int(np.argmax(bad.any(axis=1)))
    column = int(np.argmax(fast[row]))
    return row + 1, column, float(fast[row, column])


def _motor(column: str) -> str:
    joint = motor_joint(column)
    return column if joint == column else f"{column} ({joint})"


def _check(plan: ZmpWalkPlan, params: ZmpWalkParameters, leg: LegGeometry,
           limits: Mapping[str, tuple[float, float]] | None) -> None:
    if limits is not None:
        offence = _limit_offence(plan.motors, limits)
        if offence is not None:
            row, k, low, high = offence
            angle = float(plan.motors[row, k])

            def within(candidate: ZmpWalkParameters) -> bool:
                return _limit_offence(_plan(candidate, leg).motors, limits) is None

            raise GaitValueError(
                f"{_blame(params, within, 'step_length')}: row {row} (t = {plan.time[row]:g} "
                f"s) turns {_motor(MOTOR_COLUMNS[k])} to {angle:.2f} degrees, beyond its "
                f"limit {high if angle > high else low:.2f} (range [{low:.2f}, {high:.2f}])")
    speed = _speed_offence(plan.motors, params.rate, params.max_joint_speed)
    if speed is not None:
        row, k, fast = speed

        def slow(candidate: ZmpWalkParameters) -> bool:
            return _speed_offence(_plan(candidate, leg).motors, candidate.rate,
                                  candidate.max_joint_speed) is None

        raise GaitValueError(
            f"{_blame(params, slow, 'step_time')}: row {row} (t = {plan.time[row]:g} s) turns "
            f"{_motor(MOTOR_COLUMNS[k])} at {fast:.2f} rad/s from the row before, faster than "
            f"max_joint_speed {params.max_joint_speed:g} rad/s; a longer step_time slows "
            "every joint")


def plan_zmp_walk(params: ZmpWalkParameters | None = None,
                  limits: Mapping[str, tuple[float, float]] | None = None, *,
                  leg: LegGeometry = ARMSTRONG_LEG) -> ZmpWalkPlan:
    """The whole walk (module docstring), checked. Refused with a one-line
    ``GaitValueError`` naming the parameter to change, in this order: a sole out of reach, a
    row beyond ``limits`` (degrees by motor column, inclusive; columns without limits are
    not checked), a joint faster than ``max_joint_speed``."""
    params = params if params is not None else ZmpWalkParameters()
    plan = _plan(params, leg)
    _check(plan, params, leg, limits)
    return plan


def generate_zmp_walk(params: ZmpWalkParameters | None = None,
                      limits: Mapping[str, tuple[float, float]] | None = None, *,
                      leg: LegGeometry = ARMSTRONG_LEG) -> MotionFile:
    """The walk as a motion file, to be played at ``params.rate`` rows a second from the
    stand pose (:func:`plan_zmp_walk` says what is refused)."""
    return plan_zmp_walk(params, limits, leg=leg).motion()
