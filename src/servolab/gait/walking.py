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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from servolab.gait.errors import GaitValueError
from servolab.gait.motionfile import MotionFile
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

MOTOR_COLUMNS = (
    "m11", "m12", "m13", "m14", "m15", "m16",
    "m21", "m22", "m23", "m24", "m25", "m26",
    "m31", "m32", "m33", "m41", "m42", "m43", "m51", "m61", "m62",
)
PHASES_PER_HALF_CYCLE = 4


def _check_distance(name: str, value: float) -> None:
    if not (np.isfinite(value) and value >= 0):
        raise GaitValueError(f"{name} must be a finite distance >= 0 mm, got {value}")


@dataclass(frozen=True, kw_only=True)
class GaitParameters:
    """Table 5.1 of seed 001 (defaults as printed) and Appendix D/E's fixed values.

    ``c_step`` is the number of half cycles (Appendix D's ``P``; Table 5.1 prints it in mm, a
    slip: it counts). ``y_start`` is Appendix D's ``y_b2 = -y_b1 = 9.5`` mm, ``arm_swing``
    Appendix E's shoulder angle ``P_odd = -P_par`` (degrees, m31 and m41).
    """

    t_step: float = 2000.0   # ms per half cycle (one step)
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


def generate_walk(params: GaitParameters = GaitParameters(),
                  leg: LegGeometry = ARMSTRONG_LEG) -> WalkingSequence:
    """The whole walking sequence: Appendix D's feet, inverse kinematics with flat feet,
    Appendix E's motor angles. Raises ``ValueError`` naming the first unreachable sample."""
    feet = foot_positions(params, leg)
    check_reach(feet, leg)
    left = leg_inverse(feet.left, leg)
    right = leg_inverse(feet.right, leg)
    return WalkingSequence(feet=feet, left_joints=left, right_joints=right,
                           motors=motor_angles(left, right, params.arm_swing))
