"""The Armstrong biped's walking-pattern generator: a vectorised port of seed 001's Appendix D
(foot positions, four phases per half cycle, the leg swap of equations 5.1–5.2) and
Appendix E (model angles to the 21 motor angles, with the arms' swing), through the leg of
:mod:`servolab.kinematics.leg`.

Row order: the sequence runs forwards in time, sample 0 (t = 0) first, because that is the
order the robot must play it to walk forwards: it is Appendix D's time vector ``t`` and the
order in which Appendix E's ``csvwrite`` writes ``M_winkel``, and only in this order do the
phases mean what section 5.2.1 says (shift the weight, lift the swing foot and carry it
forwards while the stance foot moves back under the hip, put it down, shift back). The
excerpt printed as Table 4.3 runs the other way, from the last sample back to the first
(seeds/README.md); played in that order the robot would walk backwards. Appendix E's leading
row of zeros is not part of the sequence: it stands in the place of the CSV header line, which
the robot's reader skips (section 4.2.4.1), and writing headers is the motion file's job.

What :func:`generate_walk` adds to the seed, each refused with one line naming the parameter
and its value (a :class:`~servolab.gait.errors.GaitValueError`) before any file is written:

* **The loop.** The robot plays a sequence N times in a row (section 4.2.4.4), so the last
  row is followed by the first. An odd ``c_step`` ends with the feet swapped (the left foot
  40 mm behind where the first row has it forward): looped, both planted feet would be
  dragged 40 mm and m12 would jump 12.7 degrees between two rows. It is **refused**, not
  closed: closing it means adding or dropping a half cycle, which is choosing another
  ``c_step`` for the user. Every sequence that is generated is then measured with
  :func:`loop_jumps`: no joint may change more from the last row to the first than it
  changes between two rows inside the sequence. With an even ``c_step`` the wrap is the
  move from the end pose (Table 4.2's stand pose) back to Appendix D's start and changes the
  feet's distance by ``|d_step - 2 y_start|`` (4 mm with Table 5.1's values), exactly as
  much as the first row's own move does (``d_step / 2`` against ``y_start``, the seed's),
  so it adds no slide the sequence does not already have.
* **The joints' limits.** Given ``limits`` (each motor column's range in degrees, from the
  robot's configuration: this layer knows no robot), a row that sends a joint beyond them
  is refused at generation, naming the parameter that takes it there (the one whose Table
  5.1 value would keep the joint inside), the motor, its joint, the angle and the limit.
* **Time.** A motion file holds no time: the robot plays one row per period of its loop,
  4.5 rows a second (``ros::Rate loop_rate(4.5)``, section 4.2.4.4: "each movement ... is
  executed in 222ms", 17 rows in 3.78 s). So ``t_step``, one half cycle of four rows, is
  derived from that rate: ``t_step = 4 rows / rate``, 888.9 ms at :data:`PLAY_RATE`. Table
  5.1's 2000 ms is the time axis of the seed's MATLAB plots (Appendix D's ``t``); the robot
  never played it (at 2000 ms a step it would have to play 2 rows a second).
  :attr:`GaitParameters.play_rate` is the rate a sequence must be played at to take
  ``t_step`` a step, and :meth:`GaitParameters.at_rate` makes parameters for a rate.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any

import numpy as np
import numpy.typing as npt

from servolab.gait.errors import GaitValueError
from servolab.gait.motionfile import SEED_COLUMNS, MotionFile
from servolab.kinematics.dh import FloatArray
from servolab.kinematics.leg import (
    ARMSTRONG_LEG,
    LegGeometry,
    format_position,
    leg_inverse,
    leg_motor_angles,
    reachable,
    unreachable_reason,
)

#: The 21 motor columns in the seed's order (:data:`~servolab.gait.motionfile.SEED_COLUMNS`).
MOTOR_COLUMNS = SEED_COLUMNS

#: Table 4.2 of seed 001, the stand pose (degrees by motor column, as printed): the initial
#: position of the walking algorithm, where the robot stands before it plays a motion
#: (``servolab.robots.armstrong.poses.STAND_POSE`` is this table).
TABLE_4_2_STAND_POSE: Mapping[str, float] = MappingProxyType({
    **dict.fromkeys(MOTOR_COLUMNS, 0.0),
    "m51": 25.0,
    "m12": -27.666, "m13": 0.619, "m11": 0.0, "m14": -42.992, "m15": 15.326, "m16": -0.619,
    "m22": -14.746, "m23": 5.2503, "m21": 0.0, "m24": 41.781, "m25": -27.035, "m26": -5.250,
})

PHASES_PER_HALF_CYCLE = 4
#: Rows a second the seed's control node plays a sequence at (001 section 4.2.4.4).
PLAY_RATE = 4.5
#: The joint each leg motor turns, in the order of a leg's columns m?1..m?6 (Appendix E
#: line 33 and its swaps, lines 54-67; ``kinematics.leg.leg_motor_angles``).
LEG_MOTOR_JOINTS = ("hip yaw", "hip pitch", "hip roll", "knee", "ankle pitch", "ankle roll")
#: Units of the parameters, for messages.
_UNITS = {"t_step": " ms", "d_step": " mm", "l_step": " mm", "c_step": "", "h_step": " mm",
          "s_step": " mm", "y_start": " mm", "arm_swing": " degrees"}


def _check_distance(name: str, value: float) -> None:
    if not (np.isfinite(value) and value >= 0):
        raise GaitValueError(f"{name} must be a finite distance >= 0 mm, got {value}")


@dataclass(frozen=True, kw_only=True)
class GaitParameters:
    """Table 5.1 of seed 001 (defaults as printed, but ``t_step``) and Appendix D/E's fixed
    values.

    ``c_step`` is the number of half cycles (Appendix D's ``P``; Table 5.1 prints it in mm, a
    slip: it counts); :func:`generate_walk` takes only an even number (module docstring).
    ``t_step`` defaults to one half cycle at the seed's playback rate, ``4 / 4.5`` s, not
    Table 5.1's 2000 ms, which the robot never played (module docstring). ``y_start`` is
    Appendix D's ``y_b2 = -y_b1 = 9.5`` mm, ``arm_swing`` Appendix E's shoulder angle
    ``P_odd = -P_par`` (degrees, m31 and m41).
    """

    t_step: float = 1000.0 * PHASES_PER_HALF_CYCLE / PLAY_RATE   # ms per half cycle (step)
    d_step: float = 15.0     # mm the hip is lowered
    l_step: float = 40.0     # mm forward per step
    c_step: int = 4          # half cycles
    h_step: float = 20.0     # mm the swing foot is lifted
    s_step: float = 20.0     # mm the hip moves sideways
    y_start: float = 9.5
    arm_swing: float = 30.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.t_step) and self.t_step > 0):
            raise GaitValueError(f"t_step must be a positive number of ms, got {self.t_step}")
        if isinstance(self.c_step, bool) or not isinstance(self.c_step, int | np.integer) \
                or self.c_step < 1:
            raise GaitValueError(f"c_step counts half cycles: an integer >= 1, got {self.c_step!r}")
        for name in ("d_step", "l_step", "h_step", "s_step"):
            _check_distance(name, getattr(self, name))
        for name in ("y_start", "arm_swing"):
            if not np.isfinite(getattr(self, name)):
                raise GaitValueError(f"{name} must be finite, got {getattr(self, name)}")

    @property
    def play_rate(self) -> float:
        """Rows a second that play one half cycle (four rows) in ``t_step``: the ``--rate``
        of ``servolab walk`` for this gait (4.5 with the default ``t_step``)."""
        return 1000.0 * PHASES_PER_HALF_CYCLE / self.t_step

    @classmethod
    def at_rate(cls, rate: float, **changes: Any) -> GaitParameters:
        """Parameters whose ``t_step`` is what playing at ``rate`` rows a second gives."""
        if not (np.isfinite(rate) and rate > 0):
            raise GaitValueError(f"rate must be a positive number of rows a second, got {rate}")
        if "t_step" in changes:
            raise GaitValueError("give t_step or a rate, not both: t_step = 4 rows / rate")
        return cls(t_step=1000.0 * PHASES_PER_HALF_CYCLE / rate, **changes)


@dataclass(frozen=True)
class FootTrajectory:
    """Foot positions over time: ``time_ms`` ``(N,)``, ``left``/``right`` ``(N, 3)`` in mm."""

    time_ms: FloatArray
    left: FloatArray
    right: FloatArray


@dataclass(frozen=True)
class WalkingSequence:
    """One generated sequence, sample 0 first (see the module docstring for why).

    ``motors`` ``(N, 21)`` in degrees, columns :data:`MOTOR_COLUMNS`; ``left_joints`` and
    ``right_joints`` ``(N, 6)`` in radians, ordered as ``kinematics.leg.JOINT_NAMES``.
    """

    feet: FootTrajectory
    left_joints: FloatArray
    right_joints: FloatArray
    motors: FloatArray
    columns: tuple[str, ...] = field(default=MOTOR_COLUMNS)

    @property
    def time_ms(self) -> FloatArray:
        return self.feet.time_ms

    def motion(self) -> MotionFile:
        """The sequence as a motion file's content (write it with
        :func:`~servolab.gait.motionfile.write_motion_file`, play it on the robot)."""
        return MotionFile(self.columns, self.motors)


def _body_states(params: GaitParameters, leg: LegGeometry) -> FloatArray:
    """Appendix D's ``x_b1, y_b1, z_b1, x_b2, y_b2, z_b2`` after every phase, ``(4P, 6)``.

    The signs ``(-1)^k`` with ``k = 4p - 3 .. 4p`` depend only on the phase, so every half
    cycle adds the same increments. Appendix D's end-of-half-cycle swap (``x_b1 = x_b2``,
    ``x_b2 = x_b1``) returns x to its start values l/2 and -l/2, and y and z come back too, so
    every half cycle starts from the same state and the whole sequence is one cumulative sum
    per half cycle, tiled.
    """
    lowered = leg.length - params.d_step
    if lowered <= 0:
        raise GaitValueError(f"d_step ({params.d_step} mm) must be shorter than the leg "
                             f"({leg.length} mm)")
    k = np.arange(1, PHASES_PER_HALF_CYCLE + 1)   # k of the first half cycle, p = 1
    sign = (-1.0) ** k
    sway = params.s_step * params.h_step / lowered
    side = np.where((k == 1) | (k == 4), params.s_step, sway) * sign
    half_l = params.l_step / 2
    forward = np.array([0.0, half_l, half_l, 0.0])
    lift = np.array([0.0, params.h_step, -params.h_step, 0.0])
    steps = np.stack([-forward, side, np.zeros(4), forward, -side, lift], axis=1)
    start = np.array([half_l, -params.y_start, -lowered, -half_l, params.y_start, -lowered])
    half_cycle = start + np.cumsum(steps, axis=0)
    return np.tile(half_cycle, (params.c_step, 1))


def foot_positions(params: GaitParameters = GaitParameters(),
                   leg: LegGeometry = ARMSTRONG_LEG) -> FootTrajectory:
    """Appendix D: both feet's positions for ``4 * c_step + 1`` samples, ``t_step / 4`` apart.

    Sample 0 is Appendix D's start (``x = ±l_step/2``, ``y = ∓y_start``). Afterwards the body
    variables belong to the left leg in odd half cycles and to the right leg in even ones
    (the swap of equations 5.1–5.2, Appendix D's ``mod(p, 2)``), each foot ``d_step / 2`` to
    its side of the half cycle's reference y.
    """
    states = _body_states(params, leg)
    p = np.arange(states.shape[0]) // PHASES_PER_HALF_CYCLE + 1
    odd = (p % 2 == 1)[:, None]
    b1, b2 = states[:, 0:3], states[:, 3:6]
    half_d = params.d_step / 2
    reference_y = np.where(odd[:, 0], b1[:, 1], b2[:, 1])
    left = np.where(odd, b1, b2)
    right = np.where(odd, b2, b1)
    left[:, 1] = reference_y - half_d
    right[:, 1] = reference_y + half_d
    z0 = -(leg.length - params.d_step)
    first_left = np.array([[params.l_step / 2, -params.y_start, z0]])
    first_right = np.array([[-params.l_step / 2, params.y_start, z0]])
    time_ms = np.arange(states.shape[0] + 1) * (params.t_step / PHASES_PER_HALF_CYCLE)
    return FootTrajectory(time_ms=time_ms, left=np.concatenate([first_left, left]),
                          right=np.concatenate([first_right, right]))


def arm_swing(samples: int, amplitude: float = 30.0) -> FloatArray:
    """Appendix E's upper body, ``(samples, 9)`` columns m31..m62 in degrees: both shoulders
    (m31, m41) at ``+amplitude`` on even samples (MATLAB's odd ``l``, ``P_odd``) and at
    ``-amplitude`` on odd ones (``P_par``); elbows, trunk, neck and camera at 0."""
    upper = np.zeros((samples, 9))
    swing = np.where(np.arange(samples) % 2 == 0, amplitude, -amplitude)
    upper[:, 0] = swing
    upper[:, 3] = swing
    return upper


def motor_angles(left_joints: npt.ArrayLike, right_joints: npt.ArrayLike,
                 arm_amplitude: float = 30.0) -> FloatArray:
    """Appendix E: leg joint angles (radians, ``(N, 6)`` each) to the 21 motor angles in
    degrees, columns :data:`MOTOR_COLUMNS`, sample order kept."""
    left = leg_motor_angles(np.atleast_2d(np.asarray(left_joints, dtype=np.float64)), "left")
    right = leg_motor_angles(np.atleast_2d(np.asarray(right_joints, dtype=np.float64)), "right")
    if left.shape != right.shape:
        raise GaitValueError(f"left and right joint arrays differ in shape: {left.shape}, "
                             f"{right.shape}")
    return np.concatenate([left, right, arm_swing(left.shape[0], arm_amplitude)], axis=1)


def check_reach(feet: FootTrajectory, leg: LegGeometry = ARMSTRONG_LEG) -> None:
    """Refuse a trajectory either foot cannot follow, naming the first such sample (both
    legs are checked before either is solved, so the first sample is the first in time)."""
    bad = ~(reachable(feet.left, leg) & reachable(feet.right, leg))
    if not bad.any():
        return
    index = int(np.argmax(bad))
    for name, positions in (("left", feet.left), ("right", feet.right)):
        if not reachable(positions[index], leg)[0]:
            raise GaitValueError(
                f"gait sample {index} (t = {feet.time_ms[index]:g} ms): the {name} foot at "
                f"{format_position(positions[index])} mm is out of reach: "
                f"{unreachable_reason(positions[index], leg)}")


def motor_joint(column: str) -> str:
    """What ``column`` turns, for messages: ``"m24"`` -> ``"right knee"``, ``"m31"`` ->
    ``"left shoulder"`` (the arm swing's motors); the column itself for the others."""
    if len(column) == 3 and column[1] in "12" and column[2] in "123456":
        side = "left" if column[1] == "1" else "right"
        return f"{side} {LEG_MOTOR_JOINTS[int(column[2]) - 1]}"
    return {"m31": "left shoulder", "m41": "right shoulder"}.get(column, column)


def _motor(column: str) -> str:
    joint = motor_joint(column)
    return column if joint == column else f"{column} ({joint})"


def loop_jumps(angles: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """For a sequence played in a loop (``poses x columns``): per column, the change from the
    last row back to the first, and the largest change between two rows inside the
    sequence (both absolute; zeros for a single row)."""
    a = np.atleast_2d(np.asarray(angles, dtype=np.float64))
    wrap = np.abs(a[0] - a[-1])
    inner = np.abs(np.diff(a, axis=0)).max(axis=0) if a.shape[0] > 1 else np.zeros(a.shape[1])
    return wrap, inner


def check_loop_parameters(params: GaitParameters, walk: WalkingSequence | None = None) -> None:
    """Refuse an odd ``c_step``: the sequence would end with the feet swapped (module
    docstring); ``walk``, the sequence generated with ``params``, gives the jump's size."""
    c = params.c_step
    if c % 2 == 0:
        return
    jump = ""
    if walk is not None:
        wrap, _ = loop_jumps(walk.motors)
        k = int(np.argmax(wrap))
        jump = (f" and turn {MOTOR_COLUMNS[k]} ({motor_joint(MOTOR_COLUMNS[k])}) "
                f"{wrap[k]:.2f} degrees between two rows")
    even = " or ".join(str(n) for n in (c - 1, c + 1) if n > 0)
    raise GaitValueError(
        f"c_step {c}: odd, so the sequence ends with the right foot forward where its first "
        f"row has the left foot forward; played in a loop the wrap would drag both planted "
        f"feet {params.l_step:g} mm{jump}; use an even c_step ({even})")


def _wrap_offence(angles: FloatArray) -> tuple[int, float, float] | None:
    """The column whose wrap most exceeds its largest inner change: ``(column, wrap,
    inner)``, or None."""
    wrap, inner = loop_jumps(angles)
    over = np.flatnonzero(wrap > inner + 1e-9)
    if not over.size:
        return None
    k = int(over[np.argmax(wrap[over] - inner[over])])
    return k, float(wrap[k]), float(inner[k])


def check_loop(angles: npt.ArrayLike, columns: tuple[str, ...] = MOTOR_COLUMNS, *,
               what: str = "the sequence") -> None:
    """Refuse a sequence whose wrap, last row to first, turns a column more than any two
    rows inside it do (:func:`loop_jumps`), naming ``what``, the column and both changes."""
    offence = _wrap_offence(np.atleast_2d(np.asarray(angles, dtype=np.float64)))
    if offence is not None:
        k, wrap, inner = offence
        raise GaitValueError(
            f"{what}: played in a loop, the wrap from the last row back to the first turns "
            f"{_motor(columns[k])} {wrap:.2f} degrees, more than any two rows inside it do "
            f"({inner:.2f})")


def _check_wrap(walk: WalkingSequence, params: GaitParameters, leg: LegGeometry) -> None:
    """:func:`check_loop` for a generated sequence, naming the parameters that cause it."""
    offence = _wrap_offence(walk.motors)
    if offence is None:
        return
    k, wrap, inner = offence
    who, back = _blame(params, leg, lambda w: _wrap_offence(w.motors) is None,
                       among=("d_step", "y_start"))
    first = 2 * params.y_start
    raise GaitValueError(
        f"{who}: played in a loop, the wrap from the last row back to the first turns "
        f"{_motor(MOTOR_COLUMNS[k])} {wrap:.2f} degrees, more than any two rows inside the "
        f"sequence do ({inner:.2f}): the first row has the feet {first:g} mm apart sideways "
        f"(2 y_start), the others {params.d_step:g} mm (d_step), so the wrap drags a planted "
        f"foot {abs(params.d_step - first):g} mm{back}")


def _parameter(params: GaitParameters, name: str) -> str:
    return f"{name} {getattr(params, name):g}{_UNITS.get(name, '')}"


def _limit_offence(motors: FloatArray, limits: Mapping[str, tuple[float, float]]
                   ) -> tuple[int, int, float, float] | None:
    """The first row (in time), and in it the first column, beyond its limits: ``(row,
    column, low, high)``, or None."""
    first: tuple[int, int, float, float] | None = None
    for k, name in enumerate(MOTOR_COLUMNS):
        if name not in limits:
            continue
        low, high = (float(v) for v in limits[name])
        bad = np.flatnonzero((motors[:, k] < low) | (motors[:, k] > high))
        if bad.size and (first is None or int(bad[0]) < first[0]):
            first = (int(bad[0]), k, low, high)
    return first


def _motors(params: GaitParameters, leg: LegGeometry) -> WalkingSequence:
    feet = foot_positions(params, leg)
    check_reach(feet, leg)
    left = leg_inverse(feet.left, leg)
    right = leg_inverse(feet.right, leg)
    return WalkingSequence(feet=feet, left_joints=left, right_joints=right,
                           motors=motor_angles(left, right, params.arm_swing))


def _blame(params: GaitParameters, leg: LegGeometry, passes: Callable[[WalkingSequence], bool],
           among: tuple[str, ...] | None = None) -> tuple[str, str]:
    """Who to name for a sequence that fails ``passes``: the parameters changed from Table 5.1
    (of ``among``, if given) whose seed value alone makes it pass, else every changed one;
    and the sentence that says the seed value fixes it (or ``""``)."""
    seed = GaitParameters()
    changed = [f.name for f in fields(params) if f.name != "t_step"
               and getattr(params, f.name) != getattr(seed, f.name)]
    if among is not None:
        changed = [n for n in changed if n in among] or list(among)

    def fixed(name: str) -> bool:
        if getattr(params, name) == getattr(seed, name):
            return False
        try:
            return passes(_motors(replace(params, **{name: getattr(seed, name)}), leg))
        except GaitValueError:
            return False

    alone = [n for n in changed if fixed(n)]
    names = alone or changed
    if not names:
        return "Table 5.1's parameters", ""
    who = " and ".join(_parameter(params, n) for n in names)
    back = (f"; with Table 5.1's {' or '.join(_parameter(seed, n) for n in alone)} it "
            "stays within" if alone else "")
    return who, back


def check_limits(walk: WalkingSequence, params: GaitParameters,
                 limits: Mapping[str, tuple[float, float]],
                 leg: LegGeometry = ARMSTRONG_LEG) -> None:
    """Refuse a sequence that sends a motor beyond ``limits`` (degrees, inclusive, by motor
    column; columns without limits are not checked), naming the first such row in time, the
    parameter that takes it there, the motor, its joint, the angle and the limit."""
    offence = _limit_offence(walk.motors, limits)
    if offence is None:
        return
    row, k, low, high = offence
    angle = float(walk.motors[row, k])
    limit = high if angle > high else low
    who, back = _blame(params, leg, lambda w: _limit_offence(w.motors, limits) is None)
    raise GaitValueError(
        f"{who}: row {row} (t = {walk.time_ms[row]:g} ms) turns {_motor(MOTOR_COLUMNS[k])} "
        f"to {angle:.2f} degrees, beyond its limit {limit:.2f} (range [{low:.2f}, "
        f"{high:.2f}]){back}")


def generate_walk(params: GaitParameters = GaitParameters(),
                  leg: LegGeometry = ARMSTRONG_LEG,
                  limits: Mapping[str, tuple[float, float]] | None = None) -> WalkingSequence:
    """The whole walking sequence: Appendix D's feet, inverse kinematics with flat feet,
    Appendix E's motor angles.

    Refused with a one-line ``GaitValueError`` (module docstring), in this order: the first
    unreachable sample; an odd ``c_step``; with ``limits`` (degrees by motor column, as
    the robot's configuration gives them), the first row beyond them; a wrap, last row to
    first, that turns a joint more than two rows inside the sequence do.
    """
    walk = _motors(params, leg)
    check_loop_parameters(params, walk)
    if limits is not None:
        check_limits(walk, params, limits, leg)
    _check_wrap(walk, params, leg)
    return walk
