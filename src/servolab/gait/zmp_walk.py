"""A walking pattern for the Armstrong biped (seed 001) that keeps its zero-moment point
(ZMP) on the feet: footsteps, a ZMP reference on them, the centre of mass (CoM) from
Kajita et al.'s preview control (ICRA 2003, :mod:`servolab.gait.preview_control`), swing
feet, and the legs' inverse kinematics, written as the same motion file the seed's generator
writes (:class:`~servolab.gait.motionfile.MotionFile`: columns m11..m62, degrees, one row
every ``1 / rate`` s).

Why a second generator: the seed's gait (:mod:`servolab.gait.walking`, Appendix D/E) moves
the hip sideways by a fixed amount at four rows a step, with no model of the robot's
dynamics; played on a physical robot its ZMP leaves the feet and it falls. Here the CoM is
planned so that the cart-table model's ZMP stays at the stance foot's centre during single
support and moves between the feet during double support.

The pipeline (:func:`plan_zmp_walk`), in metres in the *walk frame*: the pelvis frame of the
stand pose at the start (x forward, y to the robot's left, z up, the floor at z = 0):

1. **Footsteps.** The walk starts and ends in double support in the stand pose (Table 4.2,
   :data:`TABLE_4_2_STAND_POSE`: the left foot 20 mm ahead of the hip, the right 20 mm
   behind). The foot behind (the right) swings first; every swing carries a foot
   ``2 step_length`` forward, so after the even number ``steps`` both feet have moved
   ``steps x step_length`` and the last step, the left's, closes them into the stand pose's
   placement again: the robot ends standing as it started, ``steps x step_length`` further
   on. An odd ``steps`` would end with the right foot ahead, a pose the robot does not
   stand in, and is refused.
2. **ZMP reference.** At the CoM's projection while standing (``settle`` s at each end); in
   each step's double support (``double_support x step_time``) it moves linearly to the
   stance foot's sole centre and stays there through single support.
3. **CoM** by preview control, with the CoM at ``com_height`` above the floor, starting at
   rest over the reference's first point.
4. **Swing foot** over single support: forward and sideways along a cycloid, lifted by
   ``foot_lift`` along ``(1 - cos)/2``: position, velocity (and the lift's height) are 0 at
   lift-off and touch-down.
5. **Pelvis** = CoM - ``com_offset`` (the CoM is taken to sit at a fixed offset from the
   pelvis, horizontally), at the stand pose's height; each foot relative to its hip, flat,
   through :func:`servolab.kinematics.leg.leg_inverse`, and to the motor columns as
   :func:`servolab.gait.walking.motor_angles` does; the upper body stays in the stand pose.

Refused, each with a one-line :class:`~servolab.gait.errors.GaitValueError` naming the
parameter to change: a foot out of reach, a row beyond ``limits`` (degrees by motor column,
the robot's configuration's: this layer knows no robot), a joint turning faster than
``max_joint_speed`` between two rows, a first row more than ``FIRST_ROW_TOLERANCE`` degrees
from the stand pose (a jump when playback starts).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np

from servolab.gait.errors import GaitValueError
from servolab.gait.motionfile import MotionFile
from servolab.gait.preview_control import GRAVITY, PREVIEW_S, com_from_zmp
from servolab.gait.walking import MOTOR_COLUMNS, motor_angles, motor_joint
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

#: Table 4.2 of seed 001, the stand pose (degrees by motor column, as printed): where the
#: robot stands before it plays a motion. The same values as
#: ``servolab.robots.armstrong.poses.STAND_POSE``, which this layer may not import
#: (docs/layout.md: the algorithms know no robot); tests/gait/test_zmp_walk.py checks that
#: the two agree.
TABLE_4_2_STAND_POSE: Mapping[str, float] = MappingProxyType({
    **dict.fromkeys(MOTOR_COLUMNS, 0.0),
    "m51": 25.0,
    "m12": -27.666, "m13": 0.619, "m11": 0.0, "m14": -42.992, "m15": 15.326, "m16": -0.619,
    "m22": -14.746, "m23": 5.2503, "m21": 0.0, "m24": 41.781, "m25": -27.035, "m26": -5.250,
})
#: The hip-yaw axes' distance (m): Armstrong's description's assumption ``hip_width`` (a
#: guess, the seed gives none; ``robots.armstrong.description.Assumptions``).
HIP_WIDTH = 0.100
#: The firmware's moving speed (rad/s): ``joint_speed: 1.0`` of every controller in
#: ``armstrong.yaml`` (Appendix A); a row that asks a joint to go faster is played late.
JOINT_SPEED = 1.0
#: How far (degrees) the first row may be from the stand pose: the robot stands there before
#: playing, so more would be a jump at the start.
FIRST_ROW_TOLERANCE = 1.0
#: The share of a swing, at its end, in which the foot only comes down: its forward and
#: sideways travel ends before. It is set down vertically (no scuff at touch-down), and the
#: swing knee, which straightens as the foot goes both down and ahead, turns slower then.
SET_DOWN = 0.2
#: The leg columns m?1..m?6 of each side, in order.
_LEG_COLUMNS: dict[Side, tuple[str, ...]] = {
    "left": MOTOR_COLUMNS[0:6], "right": MOTOR_COLUMNS[6:12]}
_UPPER_COLUMNS = MOTOR_COLUMNS[12:]
_UNITS = {"steps": "", "step_length": " m", "step_width": " m", "step_time": " s",
          "double_support": "", "foot_lift": " m", "hip_roll_compensation": " degrees",
          "com_height": " m", "rate": " Hz",
          "preview": " s", "settle": " s", "control_dt": " s", "hip_width": " m",
          "max_joint_speed": " rad/s"}
#: What a refusal may blame, most likely first (the others are not what shapes a row).
_BLAMABLE = ("step_time", "step_length", "foot_lift", "hip_roll_compensation", "step_width",
             "double_support",
             "com_height", "com_offset", "settle", "rate")


def _number(name: str, value: object, *, low: float = 0.0, strict: bool = True,
            unit: str = "") -> None:
    ok = isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
    if ok:
        assert isinstance(value, int | float)
        ok = value > low if strict else value >= low
    if not ok:
        relation = ">" if strict else ">="
        raise GaitValueError(f"{name} must be a finite number {relation} {low:g}{unit}, "
                             f"got {value!r}")


@dataclass(frozen=True, kw_only=True)
class ZmpWalkParameters:
    """The walk's parameters, SI units (m, s, Hz, rad/s); the stand pose in degrees.

    Defaults and why (the figures of a simulation of the robot with its servos' firmware are
    in docs, the report of issue "a walking-pattern generator that walks"):

    * ``steps`` 10 and ``step_length`` 0.04 m: Table 5.1's ``l_step`` (40 mm), ten steps.
    * ``step_width``: the lateral distance of the feet's centres while walking; ``None``
      keeps the stand pose's (``hip_width`` + the feet's offsets from their hips, 85 mm).
    * ``step_time`` s a step, ``double_support`` its share with both feet down.
    * ``foot_lift`` 0.02 m: Table 5.1's ``h_step`` (20 mm).
    * ``com_height``: the cart-table's z_c; ``None`` takes the stand pose's hip height above
      the sole (0.295 m: the pelvis frame, on the hip-yaw axes).
    * ``com_offset``: the CoM's horizontal offset from the pelvis (x, y), so that the
      pelvis is placed where the CoM must be minus it.
    * ``rate``: rows a second of the motion file (the rate it must be played at).
    * ``preview`` 1.6 s: Kajita 2003's window; ``control_dt`` 5 ms: its sampling time.
    * ``settle`` s standing still at each end (the CoM starts and ends at rest).
    * ``hip_width`` m: :data:`HIP_WIDTH`; ``stand_pose`` :data:`TABLE_4_2_STAND_POSE`.
    * ``max_joint_speed`` rad/s: :data:`JOINT_SPEED`, what the firmware moves at.
    """

    steps: int = 10
    step_length: float = 0.04
    step_width: float | None = None
    step_time: float = 1.0
    double_support: float = 0.3
    foot_lift: float = 0.02
    hip_roll_compensation: float = 0.0
    com_height: float | None = None
    com_offset: tuple[float, float] = (0.0, 0.0)
    rate: float = 10.0
    preview: float = PREVIEW_S
    control_dt: float = 0.005
    settle: float = 1.0
    hip_width: float = HIP_WIDTH
    max_joint_speed: float = JOINT_SPEED
    stand_pose: Mapping[str, float] = field(default_factory=lambda: TABLE_4_2_STAND_POSE)

    def __post_init__(self) -> None:
        steps = self.steps
        if isinstance(steps, bool) or not isinstance(steps, int | np.integer) or steps < 2:
            raise GaitValueError(f"steps must be an even integer >= 2, got {steps!r}")
        if steps % 2:
            raise GaitValueError(
                f"steps {steps}: odd, so the walk would end with the right foot ahead, not in "
                f"the stand pose it starts from; use {steps - 1} or {steps + 1}")
        _number("step_length", self.step_length, strict=False, unit=" m")
        if self.step_width is not None:
            _number("step_width", self.step_width, unit=" m")
        _number("step_time", self.step_time, unit=" s")
        share = self.double_support
        _number("double_support", share)
        if share >= 1:
            raise GaitValueError(f"double_support is the share of step_time with both feet "
                                 f"down: a number in (0, 1), got {share!r}")
        _number("foot_lift", self.foot_lift, strict=False, unit=" m")
        compensation = self.hip_roll_compensation
        if isinstance(compensation, bool) or not isinstance(compensation, int | float) \
                or not math.isfinite(compensation):
            raise GaitValueError(f"hip_roll_compensation must be a finite number of degrees, "
                                 f"got {compensation!r}")
        if self.com_height is not None:
            _number("com_height", self.com_height, unit=" m")
        offset = self.com_offset
        if not (isinstance(offset, tuple | list) and len(offset) == 2 and all(
                isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                for v in offset)):
            raise GaitValueError(f"com_offset must be two finite numbers (x, y) in m, got "
                                 f"{offset!r}")
        for name, unit in (("rate", " Hz"), ("preview", " s"), ("control_dt", " s"),
                           ("hip_width", " m"), ("max_joint_speed", " rad/s")):
            _number(name, getattr(self, name), unit=unit)
        _number("settle", self.settle, strict=False, unit=" s")
        if self.control_dt > 1.0 / self.rate:
            raise GaitValueError(f"control_dt {self.control_dt:g} s is longer than a row "
                                 f"(1 / rate = {1.0 / self.rate:g} s)")
        missing = [c for c in MOTOR_COLUMNS if c not in self.stand_pose]
        if missing:
            raise GaitValueError(f"stand_pose has no angle for motor {', '.join(missing)}")
        bad = [c for c in MOTOR_COLUMNS if not math.isfinite(self.stand_pose[c])]
        if bad:
            raise GaitValueError(f"stand_pose: motor {bad[0]} has no finite angle "
                                 f"({self.stand_pose[bad[0]]!r})")

    @property
    def row_count(self) -> int:
        """Rows of the motion file: the walk's duration at ``rate``, both ends included."""
        return math.ceil(self.duration * self.rate - 1e-9) + 1

    @property
    def duration(self) -> float:
        """Seconds from the first step's start of ``settle`` to the end of the last: settle,
        the steps, the last double support back to the middle, settle."""
        return (2 * self.settle + self.steps * self.step_time
                + self.double_support * self.step_time)


@dataclass(frozen=True)
class StandGeometry:
    """The stand pose's feet: each sole's centre relative to its hip (mm, leg frame of
    :mod:`servolab.kinematics.leg`) and the hip's height above the floor (m)."""

    left: FloatArray
    right: FloatArray
    hip_height: float


def stand_geometry(pose: Mapping[str, float], leg: LegGeometry = ARMSTRONG_LEG
                   ) -> StandGeometry:
    """Where a stand pose (degrees by motor column) puts the soles, by forward kinematics.

    Refused unless both feet are flat (the inverse kinematics solves for a flat foot with the
    knee bent backwards, so any other pose would not be the walk's first row) and on one
    level (both soles on the floor).
    """
    feet: dict[str, FloatArray] = {}
    sides: tuple[Side, ...] = ("left", "right")
    for side in sides:
        # leg_motor_angles is a signed permutation: joint j at 1 degree is row j
        signs = leg_motor_angles(np.radians(np.eye(6)), side)
        columns = np.array([pose[c] for c in _LEG_COLUMNS[side]])
        joints = np.radians(columns @ signs.T)
        foot = foot_position(joints, leg)
        back = leg_inverse(foot, leg)
        worst = float(np.degrees(np.abs(back - joints)).max())
        if worst > 0.01:
            raise GaitValueError(
                f"stand_pose: the {side} leg's foot is not flat with the knee bent backwards "
                f"({worst:.3f} degrees from what the inverse kinematics gives for its sole at "
                f"{format_position(foot)} mm)")
        feet[side] = foot
    if abs(feet["left"][2] - feet["right"][2]) > 0.5:
        raise GaitValueError(
            f"stand_pose: the soles are not on one level (left z {feet['left'][2]:.2f} mm, "
            f"right {feet['right'][2]:.2f} mm below the hips)")
    height = -float(feet["left"][2] + feet["right"][2]) / 2 * 1e-3
    return StandGeometry(feet["left"], feet["right"], height)


@dataclass(frozen=True)
class ZmpWalkPlan:
    """A planned walk, one entry per row (``time`` s, ``1 / rate`` apart), walk frame (m).

    ``footsteps``: ``(steps + 1, 2, 2)``, the feet's (left, right) sole centres (x, y) before
    the first step and after each; ``zmp_ref``, ``com`` and ``zmp`` (the cart-table model's
    ZMP of ``com``): ``(R, 2)``; ``left``, ``right`` (soles) and ``pelvis``: ``(R, 3)``;
    ``left_joints``, ``right_joints``: ``(R, 6)`` radians (``kinematics.leg.JOINT_NAMES``);
    ``motors``: ``(R, 21)`` degrees, columns :data:`~servolab.gait.walking.MOTOR_COLUMNS`.
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
        """The motion file's content (write it with ``motionfile.write_motion_file``)."""
        return MotionFile(MOTOR_COLUMNS, self.motors)


def footstep_plan(params: ZmpWalkParameters, stand: StandGeometry) -> FloatArray:
    """The feet's sole centres (x, y) in m, ``(steps + 1, 2 feet (left, right), 2)``: the
    stand pose's, then after each step (module docstring: the right foot first, every swing
    ``2 step_length``, the last placement of each foot at the stand pose's width)."""
    half = params.hip_width / 2
    start = np.array([[stand.left[0] * 1e-3, half + stand.left[1] * 1e-3],
                      [stand.right[0] * 1e-3, -half + stand.right[1] * 1e-3]])
    middle = start[:, 1].mean()
    walking_y = start[:, 1].copy()
    if params.step_width is not None:
        walking_y = middle + np.array([1.0, -1.0]) * params.step_width / 2
    plan = np.empty((params.steps + 1, 2, 2))
    plan[0] = start
    for k in range(1, params.steps + 1):
        foot = 1 if k % 2 else 0                      # right on odd steps, left on even
        plan[k] = plan[k - 1]
        plan[k, foot, 0] += 2 * params.step_length
        last = k >= params.steps - 1                  # each foot's last placement
        plan[k, foot, 1] = start[foot, 1] if last else walking_y[foot]
    return plan


def _zmp_reference(params: ZmpWalkParameters, plan: FloatArray, start: FloatArray,
                   times: FloatArray) -> FloatArray:
    """The ZMP reference (m, ``(len(times), 2)``): piecewise linear through its knots."""
    t_ds = params.double_support * params.step_time
    knots_t = [0.0, params.settle]
    knots_p = [start, start]
    for k in range(1, params.steps + 1):
        stance = plan[k - 1, 0 if k % 2 else 1]      # the foot that stays down in step k
        begin = params.settle + (k - 1) * params.step_time
        knots_t += [begin + t_ds, begin + params.step_time]
        knots_p += [stance, stance]
    end = start + (plan[-1].mean(axis=0) - plan[0].mean(axis=0))
    finish = params.settle + params.steps * params.step_time + t_ds
    knots_t += [finish, max(finish, float(times[-1]))]
    knots_p += [end, end]
    kt = np.array(knots_t)
    kp = np.array(knots_p)
    return np.stack([np.interp(times, kt, kp[:, axis]) for axis in range(2)], axis=1)


def stance_load(params: ZmpWalkParameters, times: FloatArray) -> FloatArray:
    """How much of the robot each leg carries, ``(len(times), 2)`` (left, right), from 0 to
    1: rising over the double support in which the ZMP moves onto the leg's foot, 1 through
    its single support, falling over the next double support; 0 while standing at either
    end. Smoothstepped, so what is scaled by it starts and stops without a jerk."""
    t_ds = params.double_support * params.step_time
    load = np.zeros((times.shape[0], 2))
    for k in range(1, params.steps + 1):
        stance = 0 if k % 2 else 1
        begin = params.settle + (k - 1) * params.step_time
        knots = [begin, begin + t_ds, begin + params.step_time, begin + params.step_time + t_ds]
        load[:, stance] += np.interp(times, knots, [0.0, 1.0, 1.0, 0.0], left=0.0, right=0.0)
    ramp = np.clip(load, 0.0, 1.0)
    return ramp * ramp * (3 - 2 * ramp)


def _feet(params: ZmpWalkParameters, plan: FloatArray, times: FloatArray
          ) -> tuple[FloatArray, FloatArray]:
    """Both soles (m, ``(len(times), 3)``): planted at their footsteps; in its step's single
    support the swing foot goes ``(1 - cos)/2`` up and down, and forward and sideways along
    a cycloid that ends :data:`SET_DOWN` of the swing before touch-down."""
    t_ds = params.double_support * params.step_time
    t_ss = params.step_time - t_ds
    feet = np.zeros((2, times.shape[0], 3))
    for foot in (0, 1):
        feet[foot, :, :2] = plan[0, foot]
    for k in range(1, params.steps + 1):
        foot = 1 if k % 2 else 0
        lift_off = params.settle + (k - 1) * params.step_time + t_ds
        tau = np.clip((times - lift_off) / t_ss, 0.0, 1.0)
        after = times >= lift_off
        ahead = np.clip(tau / (1.0 - SET_DOWN), 0.0, 1.0)
        share = ahead - np.sin(2 * np.pi * ahead) / (2 * np.pi)
        a, b = plan[k - 1, foot], plan[k, foot]
        feet[foot, after, :2] = a + (b - a) * share[after, None]
        feet[foot, after, 2] = params.foot_lift * (1 - np.cos(2 * np.pi * tau[after])) / 2
    return feet[0], feet[1]


def _plan(params: ZmpWalkParameters, leg: LegGeometry) -> ZmpWalkPlan:
    stand = stand_geometry(params.stand_pose, leg)
    z_c = stand.hip_height if params.com_height is None else params.com_height
    plan = footstep_plan(params, stand)
    rows = params.row_count
    time = np.arange(rows) / params.rate
    fine_n = math.ceil(time[-1] / params.control_dt) + 1
    fine = np.arange(fine_n) * params.control_dt
    offset = np.array(params.com_offset, dtype=np.float64)
    reference = _zmp_reference(params, plan, offset, fine)
    com_fine, zmp_fine = com_from_zmp(reference, params.control_dt, z_c, params.preview,
                                      initial=offset, gravity=GRAVITY)

    def at_rows(values: FloatArray) -> FloatArray:
        return np.stack([np.interp(time, fine, values[:, a]) for a in range(2)], axis=1)

    com, zmp, zmp_ref = at_rows(com_fine), at_rows(zmp_fine), at_rows(reference)
    left, right = _feet(params, plan, time)
    pelvis = np.column_stack([com - offset, np.full(rows, stand.hip_height)])
    half = params.hip_width / 2
    hips = {"left": pelvis + np.array([0.0, half, 0.0]),
            "right": pelvis + np.array([0.0, -half, 0.0])}
    targets = {"left": (left - hips["left"]) * 1e3, "right": (right - hips["right"]) * 1e3}
    _check_reach(params, leg, targets, time)
    joints = {side: leg_inverse(targets[side], leg) for side in ("left", "right")}
    commanded = _compensated(params, joints, time)
    motors = motor_angles(commanded["left"], commanded["right"], arm_amplitude=0.0)
    for k, column in enumerate(MOTOR_COLUMNS):
        if column in _UPPER_COLUMNS:
            motors[:, k] = params.stand_pose[column]
    return ZmpWalkPlan(time=time, footsteps=plan, zmp_ref=zmp_ref, com=com, zmp=zmp,
                       left=left, right=right, pelvis=pelvis, left_joints=joints["left"],
                       right_joints=joints["right"], motors=motors, com_height=z_c)


def _compensated(params: ZmpWalkParameters, joints: Mapping[str, FloatArray],
                 time: FloatArray) -> dict[str, FloatArray]:
    """The joint angles to command: the stance leg's hip roll turned ``hip_roll_compensation``
    degrees further, in proportion to its load (:func:`stance_load`), towards raising the
    swing leg's side of the pelvis. Why: a servo holds its goal only to within the error at
    which its torque balances the load (the RX-28's compliance slope), and in single
    support the stance hip roll carries the pelvis, the trunk and the swing leg beside it,
    so the pelvis rolls down on the swing side and the swing foot drags; this turns the
    goal by that expected error. Positive hip roll swings the foot to the robot's left
    (``kinematics.leg``), so the left leg's goal rises and the right leg's falls."""
    extra = math.radians(params.hip_roll_compensation) * stance_load(params, time)
    out = {side: joints[side].copy() for side in ("left", "right")}
    out["left"][:, HIP_ROLL] += extra[:, 0]
    out["right"][:, HIP_ROLL] -= extra[:, 1]
    return out


def _check_reach(params: ZmpWalkParameters, leg: LegGeometry,
                 targets: Mapping[str, FloatArray], time: FloatArray) -> None:
    ok = reachable(targets["left"], leg) & reachable(targets["right"], leg)
    if ok.all():
        return
    row = int(np.argmin(ok))
    side = "left" if not reachable(targets["left"][row], leg)[0] else "right"
    position = targets[side][row]
    raise GaitValueError(
        f"{_blame_reach(params, leg)}: row {row} (t = {time[row]:g} s): the {side} foot at "
        f"{format_position(position)} mm from its hip is out of reach: "
        f"{unreachable_reason(position, leg)}")


def _parameter(params: ZmpWalkParameters, name: str) -> str:
    value = getattr(params, name)
    shown = "None" if value is None else (f"{value!r}" if isinstance(value, tuple)
                                          else f"{value:g}")
    return f"{name} {shown}{_UNITS.get(name, '')}"


def _blame(params: ZmpWalkParameters, passes: Callable[[ZmpWalkParameters], bool],
           fallback: str) -> str:
    """Whom a refusal names: the parameters changed from the defaults whose default alone
    makes the walk pass (else every changed one, else ``fallback``)."""
    default = ZmpWalkParameters()
    changed = [n for n in _BLAMABLE if getattr(params, n) != getattr(default, n)]

    def fixed(name: str) -> bool:
        try:
            return passes(replace(params, **{name: getattr(default, name)}))
        except GaitValueError:
            return False

    names = [n for n in changed if fixed(n)] or changed or [fallback]
    return " and ".join(_parameter(params, n) for n in names)


def _blame_reach(params: ZmpWalkParameters, leg: LegGeometry) -> str:
    def passes(candidate: ZmpWalkParameters) -> bool:
        _plan(candidate, leg)
        return True

    return _blame(params, passes, "step_length")


def _limit_offence(motors: FloatArray, limits: Mapping[str, tuple[float, float]]
                   ) -> tuple[int, int, float, float] | None:
    """The first row beyond ``limits`` and in it the first such column: ``(row, column,
    low, high)``, or None."""
    low = np.array([limits[c][0] if c in limits else -np.inf for c in MOTOR_COLUMNS])
    high = np.array([limits[c][1] if c in limits else np.inf for c in MOTOR_COLUMNS])
    bad = (motors < low) | (motors > high)
    if not bad.any():
        return None
    row = int(np.argmax(bad.any(axis=1)))
    column = int(np.argmax(bad[row]))
    return row, column, float(low[column]), float(high[column])


def _speed_offence(motors: FloatArray, rate: float, speed: float
                   ) -> tuple[int, int, float] | None:
    """The first row a joint reaches faster than ``speed`` rad/s from the row before, and
    the column: ``(row, column, rad/s)``, or None."""
    if motors.shape[0] < 2:
        return None
    fast = np.abs(np.radians(np.diff(motors, axis=0))) * rate
    bad = fast > speed + 1e-12
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
    stand = np.array([params.stand_pose[c] for c in MOTOR_COLUMNS])
    first = np.abs(plan.motors[0] - stand)
    if first.max() > FIRST_ROW_TOLERANCE:
        k = int(np.argmax(first))
        raise GaitValueError(
            f"settle {params.settle:g} s: the first row turns {_motor(MOTOR_COLUMNS[k])} "
            f"{first[k]:.2f} degrees from the stand pose, more than {FIRST_ROW_TOLERANCE:g}: "
            "the CoM must start at rest, so stand longer before the first step")
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
            f"max_joint_speed {params.max_joint_speed:g} rad/s (a longer step_time slows "
            "every joint)")


def plan_zmp_walk(params: ZmpWalkParameters | None = None, leg: LegGeometry = ARMSTRONG_LEG,
                  limits: Mapping[str, tuple[float, float]] | None = None) -> ZmpWalkPlan:
    """The whole walk (module docstring), checked: refused with a one-line
    ``GaitValueError`` naming the parameter to change, in this order, for a foot out of
    reach, a first row away from the stand pose, a row beyond ``limits`` (degrees by motor
    column; columns without limits are not checked), a joint faster than
    ``max_joint_speed``."""
    params = params if params is not None else ZmpWalkParameters()
    plan = _plan(params, leg)
    _check(plan, params, leg, limits)
    return plan


def generate_zmp_walk(params: ZmpWalkParameters | None = None,
                      limits: Mapping[str, tuple[float, float]] | None = None,
                      leg: LegGeometry = ARMSTRONG_LEG) -> MotionFile:
    """The walk as a motion file, played at ``params.rate`` rows a second from the stand pose
    (see :func:`plan_zmp_walk`)."""
    return plan_zmp_walk(params, leg, limits).motion()


__all__ = ["FIRST_ROW_TOLERANCE", "HIP_WIDTH", "JOINT_SPEED", "TABLE_4_2_STAND_POSE",
           "StandGeometry", "ZmpWalkParameters", "ZmpWalkPlan", "footstep_plan",
           "generate_zmp_walk", "plan_zmp_walk", "stand_geometry"]
