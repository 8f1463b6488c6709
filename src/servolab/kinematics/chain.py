"""Kinematics of any serial chain of a robot, numeric, on MuJoCo's own kinematics.

A :class:`Chain` is the joints between a base link and a tip link (or a tool frame fixed to a
link, ``tip_offset``) of a fixed-base MuJoCo model, compiled once from its MJCF. A URDF
becomes that MJCF through the robot description, which reads URDFs (the algorithms import
nothing above them, so the caller converts)::

    from servolab.robots.description import Description
    chain = Chain(Description.from_urdf(text).mjcf("firmware"), "link1", "end_effector_link")

It gives the chain's joints (names, limits), :meth:`~Chain.forward` (the tip's 4x4 pose in the
base link's frame, from MuJoCo's ``mj_kinematics``), :meth:`~Chain.jacobian` (6 x n: the tool
point's linear velocity, then the angular velocity, both in the base frame, from ``mj_jac``)
and inverse kinematics: :meth:`~Chain.solve` for a pose with a weight on each of its six
components, and :meth:`~Chain.solve_position` for a position alone or a position and the
tool's pitch (what a yaw-and-three-pitch-joints arm such as the OpenMANIPULATOR-X can meet:
four constraints for four joints).

The inverse kinematics is damped least squares (Levenberg-Marquardt: a step is kept only if
it lowers the weighted error; the damping falls after a kept step and grows after a refused
one) within the joint limits: each step is the best damped step inside the limits
(:func:`~servolab.kinematics.least_squares.bounded_step`, not the free step clipped), and a
hinge with a full turn of range wraps instead of stopping at its ends. It starts from ``q0``
(or the middle of the limits), then from seeded random positions within the limits (a start
that stops making progress is abandoned after a few steps), and returns the first that meets
the tolerances. A target none of them meets is refused with one line
(:class:`UnreachableError`) naming the target and the nearest residual found; this module
moves nothing, so a caller that solves before it commands refuses before anything moves.

A pitch constraint aims the tool's x axis and leaves its roll free. Its error is the turn
that brings the axis onto the target's (:func:`aim_error`), not two components of the full
rotation's log, which stop saying where the axis points when the roll is near half a turn (the
arm reaching back over its yaw axis has its tool rolled by exactly that).

On the OpenMANIPULATOR-X (tests/kinematics/test_chain.py), position and pitch: every one of
1000 random reachable targets met within 0.01 mm and 0.006°, 1.6 starts and 3.5-5.6 ms a
target (a two-core machine busy with other work).

Why MuJoCo rather than ``mink`` or ``pin`` (pinocchio): MuJoCo is already servolab's physics,
so its kinematics is the very model the simulated arm moves in (one source of truth, no second
model to drift), it reads the MJCF the description already writes, and it is one dependency
fewer. ``mink`` is a differential-IK layer over the same MuJoCo (a QP per step, with a QP
solver as a further dependency) and would add little for chains of four to seven joints;
pinocchio is a second rigid-body library with its own URDF parser. Both remain good choices for
whole-body or constrained tasks this module does not attempt.

Units: metres, radians. Poses are 4x4 homogeneous matrices. Not thread-safe: a chain holds one
MuJoCo ``MjData`` (one chain a thread).
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from servolab.kinematics.dh import FloatArray
from servolab.kinematics.diffdrive import finite_array
from servolab.kinematics.errors import KinematicsValueError
from servolab.kinematics.least_squares import bounded_step

#: Position error (m) and rotation error (rad) an IK solution meets by default.
POSITION_TOLERANCE = 1e-5
ANGLE_TOLERANCE = 1e-4
#: Default IK weights: metres count 1, radians 0.1 (an angle of 1 rad weighs what 10 cm does,
#: about what it moves the tip of a 0.3 m arm); they matter only for the nearest residual of a
#: target that cannot be met exactly.
POSE_WEIGHTS = (1.0, 1.0, 1.0, 0.1, 0.1, 0.1)
_MAX_ITERATIONS = 100
#: Levenberg-Marquardt's damping, relative to the mean of the normal matrix's diagonal: where
#: it starts, and where a start that finds no better step gives up
_DAMPING = 1e-3
_MAX_DAMPING = 1e4
#: A start that lowered its cost by less than half over this many iterations is abandoned
_STALL_WINDOW = 6
_ZERO3 = np.zeros(3)
_HINGE, _SLIDE = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)


class UnreachableError(KinematicsValueError):
    """No joint position within the limits reaches the target; ``nearest`` is the best found."""

    def __init__(self, message: str, nearest: Solution) -> None:
        super().__init__(message)
        self.nearest = nearest


@dataclass(frozen=True)
class Solution:
    """An inverse kinematics result: joint positions ``q`` (within the limits), the remaining
    ``position_error`` (m) and ``angle_error`` (rad) of the weighted components, the
    ``iterations`` of its start and how many ``starts`` were tried."""

    q: FloatArray
    position_error: float
    angle_error: float
    iterations: int
    starts: int


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _floats(name: str, values: npt.ArrayLike) -> FloatArray:
    """``values`` as a finite float array, or one line naming ``name``."""
    try:
        array = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError):
        raise KinematicsValueError(f"{name} must be numbers, got "
                                   f"{_one_line(repr(values))[:80]}") from None
    return finite_array(name, array)


def _array(name: str, values: npt.ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    """``values`` as a finite float array of ``shape``, or one line naming ``name``."""
    array = _floats(name, values)
    if array.shape != shape:
        raise KinematicsValueError(f"{name} must have shape {shape}, got {array.shape}")
    return array


def _rotation(name: str, matrix: FloatArray) -> FloatArray:
    if not np.allclose(matrix @ matrix.T, np.eye(3), atol=1e-6) or np.linalg.det(matrix) < 0:
        raise KinematicsValueError(f"{name}'s upper-left 3x3 is not a rotation")
    return matrix


def pose_matrix(name: str, values: npt.ArrayLike) -> FloatArray:
    """``values`` as a 4x4 homogeneous pose (a rotation, a translation, a last row 0 0 0 1),
    or a :class:`KinematicsValueError` naming ``name``."""
    pose = _array(name, values, (4, 4))
    if not np.allclose(pose[3], (0.0, 0.0, 0.0, 1.0)):
        raise KinematicsValueError(f"{name}'s last row must be 0 0 0 1, got {pose[3].tolist()}")
    _rotation(name, pose[:3, :3])
    return pose


def rotation_log(matrix: FloatArray) -> FloatArray:
    """The rotation vector (axis x angle, rad) of a rotation matrix, also near half a turn."""
    cos = min(1.0, max(-1.0, (float(np.trace(matrix)) - 1.0) / 2.0))
    skew = np.array([matrix[2, 1] - matrix[1, 2], matrix[0, 2] - matrix[2, 0],
                     matrix[1, 0] - matrix[0, 1]])
    sin = float(np.linalg.norm(skew)) / 2.0
    angle = math.atan2(sin, cos)
    if sin > 1e-6 or cos > 0:
        return skew * (0.5 if sin < 1e-12 else angle / (2.0 * sin))
    # about half a turn: the axis is the largest column of R + I
    sym = matrix + np.eye(3)
    column = sym[:, int(np.argmax(np.linalg.norm(sym, axis=0)))]
    axis = column / np.linalg.norm(column)
    if np.dot(axis, skew) < 0:
        axis = -axis
    return axis * angle


def aim_error(target_axis: Sequence[float], axis: int) -> FloatArray:
    """The rotation vector (tool frame, rad) that turns the tool's ``axis`` (0, 1, 2: x, y, z)
    onto ``target_axis`` (the target's, in the tool's frame) with no turn about it: an aim
    whose roll is free. (The log of the full turn is no such measure: at a roll near half a
    turn its other two components no longer say where the axis points.)"""
    i, j, k = axis, (axis + 1) % 3, (axis + 2) % 3
    out = [0.0, 0.0, 0.0]
    out[j], out[k] = -target_axis[k], target_axis[j]          # e_axis x target_axis
    sin = math.hypot(out[j], out[k])
    angle = math.atan2(sin, target_axis[i])
    if sin > 1e-12:
        return np.array(out) * (angle / sin)
    out[j], out[k] = (angle, 0.0) if angle > 1.0 else (0.0, 0.0)   # opposite: any way round
    return np.array(out)


def _yaw_pitch(yaw: float, pitch: float) -> FloatArray:
    """``Rz(yaw) @ Ry(pitch)``: a tool whose x axis points along ``yaw``, ``pitch`` below the
    horizontal."""
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    return np.array([[cy * cp, -sy, cy * sp], [sy * cp, cy, sy * sp], [-sp, 0.0, cp]])


class Chain:
    """The joints from ``base`` to ``tip`` (links of the model: MJCF bodies or sites) of a
    fixed-base MuJoCo model (its MJCF text or a compiled ``mujoco.MjModel``); ``tip_offset``
    (a 4x4 pose or an xyz translation, in the tip's frame) places a tool frame on the tip.

    Joints off the chain, and those above ``base``, stay at the model's reference position
    and do not change the chain's poses. A joint of the chain tied to another by a joint
    equality (a URDF ``<mimic>``) is refused: its position is not the chain's to choose."""

    def __init__(self, model: str | mujoco.MjModel, base: str, tip: str, *,
                 tip_offset: npt.ArrayLike | None = None) -> None:
        if isinstance(model, str):
            if re.search(r"<\s*robot[\s>]", model) and "<mujoco" not in model:
                raise KinematicsValueError(
                    "a Chain takes an MJCF and this is a URDF: convert it with servolab.robots"
                    ".description's Description.from_urdf(text).mjcf()")
            try:
                model = mujoco.MjModel.from_xml_string(model)
            except ValueError as error:
                raise KinematicsValueError(
                    f"the MJCF does not compile: {_one_line(str(error))[:200]}") from None
        if not isinstance(model, mujoco.MjModel):
            raise KinematicsValueError(f"a Chain takes an MJCF's text or a mujoco.MjModel, "
                                       f"got {type(model).__name__}")
        self.model = model
        self.data = mujoco.MjData(model)
        self.base, self.tip = base, tip
        base_body, base_local = self._frame("base", base)
        tip_body, tip_local = self._frame("tip", tip)
        self.tip_offset = self._offset(tip_offset)
        self._tip_local = tip_local @ self.tip_offset
        self._tip_moved = not np.array_equal(self._tip_local, np.eye(4))
        self._tip_body = tip_body
        joints = self._path(base_body, tip_body)
        self.joint_names: tuple[str, ...] = tuple(model.joint(j).name for j in joints)
        #: each joint's kind: "hinge" (revolute or continuous: radians) or "slide" (metres)
        self.kinds: tuple[str, ...] = tuple(
            "hinge" if int(model.jnt_type[j]) == _HINGE else "slide" for j in joints)
        self.n = len(joints)
        self._joint_ids = np.array(joints, dtype=np.intp)
        limited = np.array([bool(model.jnt_limited[j]) for j in joints], dtype=bool)
        ranges = np.array([model.jnt_range[j] for j in joints]).reshape(self.n, 2)
        self.lower: FloatArray = np.where(limited, ranges[:, 0], -np.inf)
        self.upper: FloatArray = np.where(limited, ranges[:, 1], np.inf)
        #: the hinges with a full turn of range, which the IK wraps rather than clamps
        self._wrapping = [i for i, j in enumerate(joints) if int(model.jnt_type[j]) == _HINGE
                          and self.upper[i] - self.lower[i] >= 2.0 * math.pi - 1e-9]
        self._qpos = np.array([model.jnt_qposadr[j] for j in joints], dtype=np.intp)
        self._dofs = np.array([model.jnt_dofadr[j] for j in joints], dtype=np.intp)
        self._jacp = np.zeros((3, model.nv))
        self._jacr = np.zeros((3, model.nv))
        mujoco.mj_kinematics(model, self.data)
        # the base moves with no joint of the chain: its world pose is fixed once
        self._world_base = self._body_pose(base_body) @ base_local
        self._base_world: FloatArray = np.linalg.inv(self._world_base).astype(np.float64)
        self._yaw_axis = self._find_yaw_axis(joints)

    # -- the model --------------------------------------------------------------------------

    def _names(self, kind: mujoco.mjtObj, count: int) -> list[str]:
        return [mujoco.mj_id2name(self.model, kind, i) or "" for i in range(count)]

    def _frame(self, role: str, name: str) -> tuple[int, FloatArray]:
        """The body a link is (or carries it, for a site) and the link's pose in that body."""
        m = self.model
        if not isinstance(name, str):
            raise KinematicsValueError(f"the {role} link must be a name, got {name!r}")
        body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        if body >= 0:
            return body, np.eye(4)
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)
        if site >= 0:
            local = np.eye(4)
            rotation = np.zeros(9)
            mujoco.mju_quat2Mat(rotation, m.site_quat[site])
            local[:3, :3] = rotation.reshape(3, 3)
            local[:3, 3] = m.site_pos[site]
            return int(m.site_bodyid[site]), local
        known = self._names(mujoco.mjtObj.mjOBJ_BODY, m.nbody) + \
            self._names(mujoco.mjtObj.mjOBJ_SITE, m.nsite)
        close = difflib.get_close_matches(name, known, n=1)
        raise KinematicsValueError(f"the {role} link {name!r} is not a link of the model"
                                   + (f" (did you mean {close[0]!r}?)" if close else ""))

    def _offset(self, offset: npt.ArrayLike | None) -> FloatArray:
        if offset is None:
            return np.eye(4)
        array = np.asarray(offset, dtype=object)
        if array.shape == (3,):
            pose = np.eye(4)
            pose[:3, 3] = _array("tip_offset", offset, (3,))
            return pose
        return pose_matrix("tip_offset", offset)

    def _path(self, base_body: int, tip_body: int) -> list[int]:
        """The joints from the base body down to the tip body, base first."""
        m = self.model
        bodies = []
        body = tip_body
        while body != base_body:
            if body == 0:
                raise KinematicsValueError(f"the base link {self.base!r} is not above the tip "
                                           f"link {self.tip!r}: no chain joins them")
            bodies.append(body)
            body = int(m.body_parentid[body])
        joints = [j for b in reversed(bodies)
                  for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])]
        for j in joints:
            if int(m.jnt_type[j]) not in (_HINGE, _SLIDE):
                raise KinematicsValueError(f"joint {m.joint(j).name!r} between {self.base!r} "
                                           f"and {self.tip!r} is a free or ball joint: a chain "
                                           "takes hinges and slides")
        tied = {int(m.eq_obj1id[e]) for e in range(m.neq)
                if int(m.eq_type[e]) == int(mujoco.mjtEq.mjEQ_JOINT)}
        for j in joints:
            if j in tied:
                raise KinematicsValueError(f"joint {m.joint(j).name!r} between {self.base!r} "
                                           f"and {self.tip!r} follows another joint (a mimic): "
                                           "choose a tip whose chain has none")
        if not joints:
            raise KinematicsValueError(f"no joint moves {self.tip!r} relative to {self.base!r}")
        return joints

    def _find_yaw_axis(self, joints: list[int]) -> FloatArray:
        """Where the pitch plane turns: the first joint's axis (x, y) if it is vertical in the
        base frame at the reference position, else the base's origin."""
        axis = self._base_world[:3, :3] @ self.data.xaxis[joints[0]]
        if int(self.model.jnt_type[joints[0]]) == _HINGE \
                and abs(abs(axis[2]) - 1.0) < 1e-9:
            anchor = self._base_world[:3, :3] @ self.data.xanchor[joints[0]] \
                + self._base_world[:3, 3]
            return np.array(anchor[:2])
        return np.zeros(2)

    def _body_pose(self, body: int) -> FloatArray:
        pose = np.eye(4)
        pose[:3, :3] = self.data.xmat[body].reshape(3, 3)
        pose[:3, 3] = self.data.xpos[body]
        return pose

    def _set(self, q: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Runs MuJoCo's kinematics at ``q``; the tool's world position and rotation."""
        self.data.qpos[self._qpos] = q
        mujoco.mj_kinematics(self.model, self.data)
        rotation = self.data.xmat[self._tip_body].reshape(3, 3)
        position = self.data.xpos[self._tip_body]
        if self._tip_moved:
            return position + rotation @ self._tip_local[:3, 3], \
                rotation @ self._tip_local[:3, :3]
        return position.copy(), rotation.copy()

    def _world_jacobian(self, world_position: FloatArray) -> FloatArray:
        """The tool point's 6 x n Jacobian in the world frame, after :meth:`_set`."""
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_jac(self.model, self.data, self._jacp, self._jacr, world_position,
                      self._tip_body)
        return np.vstack((self._jacp[:, self._dofs], self._jacr[:, self._dofs]))

    def _base_pose(self, q: FloatArray) -> FloatArray:
        position, rotation = self._set(q)
        pose = np.eye(4)
        pose[:3, :3] = rotation
        pose[:3, 3] = position
        return self._base_world @ pose

    def _joints(self, q: npt.ArrayLike, name: str = "q") -> FloatArray:
        """``q`` checked: n finite joint positions, or one line naming what is wrong."""
        return _array(name, q, (self.n,))

    # -- the public API ---------------------------------------------------------------------

    def within_limits(self, q: npt.ArrayLike) -> bool:
        """Whether every joint position of ``q`` is within its limits."""
        positions = self._joints(q)
        return bool(np.all(positions >= self.lower) and np.all(positions <= self.upper))

    def clamp(self, q: npt.ArrayLike) -> FloatArray:
        """``q`` clamped into the joint limits."""
        return np.clip(self._joints(q), self.lower, self.upper)

    def forward(self, q: npt.ArrayLike) -> FloatArray:
        """The tool's 4x4 pose in the base frame at joint positions ``q`` (shape ``(n,)``),
        or at each row of ``q`` (shape ``(N, n)``: poses ``(N, 4, 4)``). Positions outside the
        limits are computed too (see :meth:`within_limits`)."""
        array = _floats("q", q)
        if array.shape == (self.n,):
            return self._base_pose(array)
        if array.ndim == 2 and array.shape[1] == self.n:
            return np.array([self._base_pose(row) for row in array]).reshape(-1, 4, 4)
        raise KinematicsValueError(f"q must have shape ({self.n},) or (N, {self.n}), "
                                   f"got {array.shape}")

    def jacobian(self, q: npt.ArrayLike) -> FloatArray:
        """The 6 x n geometric Jacobian at ``q``: rows 0-2 the tool point's linear velocity,
        rows 3-5 the tool's angular velocity, both in the base frame, per unit joint speed."""
        position, _ = self._set(self._joints(q))
        rotation = self._base_world[:3, :3]
        jac = self._world_jacobian(position)
        return np.vstack((rotation @ jac[:3], rotation @ jac[3:]))

    def axes(self, q: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Where each joint's axis is at ``q``, in the base frame: its anchor (a point on it)
        and its unit direction, each n x 3 (from MuJoCo's ``xanchor`` and ``xaxis``)."""
        self._set(self._joints(q))
        rotation, origin = self._base_world[:3, :3], self._base_world[:3, 3]
        anchors = self.data.xanchor[self._joint_ids] @ rotation.T + origin
        return anchors, self.data.xaxis[self._joint_ids] @ rotation.T

    def pitch(self, pose: npt.ArrayLike) -> float:
        """The tool's pitch (rad) as :meth:`solve_position` constrains it: the angle of the
        tool's x axis below the horizontal direction from the yaw axis to the tool's position
        (the first joint's axis when it is vertical, else the base's z axis), in the vertical
        plane through both; above the horizontal is negative, past the vertical beyond 90°."""
        p = pose_matrix("pose", pose)
        yaw = self._azimuth(p[:3, 3])
        x_axis = p[:3, 0]
        return math.atan2(-x_axis[2], x_axis[0] * math.cos(yaw) + x_axis[1] * math.sin(yaw))

    def _azimuth(self, xyz: FloatArray) -> float:
        """The direction (rad about the base's z) from the yaw axis to ``xyz`` (0 on the axis)."""
        return math.atan2(xyz[1] - self._yaw_axis[1], xyz[0] - self._yaw_axis[0])

    def solve_position(self, target_xyz: npt.ArrayLike, q0: npt.ArrayLike | None = None, *,
                       pitch: float | None = None, starts: int = 16, seed: int = 0,
                       position_tolerance: float = POSITION_TOLERANCE,
                       angle_tolerance: float = ANGLE_TOLERANCE) -> Solution:
        """Joint positions that put the tool at ``target_xyz`` (base frame, m), and, given
        ``pitch`` (rad), with the tool's x axis pointing toward the target's side of the yaw
        axis at that pitch below the horizontal (:meth:`pitch`; the roll about that axis is
        free). See :meth:`solve` for the rest."""
        xyz = _array("target_xyz", target_xyz, (3,))
        target = np.eye(4)
        target[:3, 3] = xyz
        if pitch is None:
            return self._solve(target, np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]), q0,
                               (starts, seed, position_tolerance, angle_tolerance),
                               f"position {_xyz(xyz)} m")
        pitch_rad = _array("pitch", pitch, ())
        target[:3, :3] = _yaw_pitch(self._azimuth(xyz), float(pitch_rad))
        weights = np.array([1.0, 1.0, 1.0, 0.0, POSE_WEIGHTS[4], POSE_WEIGHTS[5]])
        return self._solve(target, weights, q0,
                           (starts, seed, position_tolerance, angle_tolerance),
                           f"position {_xyz(xyz)} m, pitch {math.degrees(pitch_rad):.1f}°")

    def solve(self, target_pose: npt.ArrayLike, weights: npt.ArrayLike = POSE_WEIGHTS,
              q0: npt.ArrayLike | None = None, *, starts: int = 16, seed: int = 0,
              position_tolerance: float = POSITION_TOLERANCE,
              angle_tolerance: float = ANGLE_TOLERANCE) -> Solution:
        """Joint positions within the limits that put the tool at ``target_pose`` (4x4, base
        frame). ``weights`` (six numbers >= 0) scale the position error along the base's x, y,
        z (m) and the rotation error about the tool's own x, y, z (rad); a 0 frees that
        component (``(1, 1, 1, 0, 0, 0)``: position only; ``(.., 0, 1, 1)``: the tool's x axis
        aimed, its roll free). The components with a weight must come within
        ``position_tolerance`` (m) and ``angle_tolerance`` (rad).

        Tries ``q0`` (clamped into the limits; default the middle of the limits) and then up
        to ``starts - 1`` seeded random positions within the limits (``seed``: the same call
        gives the same answer). Raises :class:`UnreachableError` (one line: the target and the
        nearest residual) when no start meets the tolerances."""
        pose = pose_matrix("target_pose", target_pose)
        w = _array("weights", weights, (6,))
        if np.any(w < 0) or not np.any(w > 0):
            raise KinematicsValueError(f"weights must be >= 0 and not all 0, got {w.tolist()}")
        rpy = np.degrees(_euler_xyz(pose[:3, :3]))
        return self._solve(pose, w, q0, (starts, seed, position_tolerance, angle_tolerance),
                           f"pose {_xyz(pose[:3, 3])} m, rpy "
                           f"({rpy[0]:.1f}°, {rpy[1]:.1f}°, {rpy[2]:.1f}°)")

    # -- inverse kinematics -----------------------------------------------------------------

    def _solve(self, target: FloatArray, weights: FloatArray, q0: npt.ArrayLike | None,
               options: tuple[int, int, float, float], label: str) -> Solution:
        starts, seed, tol_p, tol_r = options
        if isinstance(starts, bool) or not isinstance(starts, int) or starts < 1:
            raise KinematicsValueError(f"starts must be a whole number >= 1, got {starts!r}")
        for name, tol in (("position_tolerance", tol_p), ("angle_tolerance", tol_r)):
            if isinstance(tol, bool) or not isinstance(tol, (int, float)) \
                    or not math.isfinite(tol) or tol <= 0:
                raise KinematicsValueError(f"{name} must be a number > 0, got {tol!r}")
        goal = _Goal(self._world_base @ target, weights, self._base_world[:3, :3], (tol_p, tol_r))
        first = self._middle() if q0 is None else self.clamp(self._joints(q0, "q0"))
        rng = np.random.default_rng(seed)
        low = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        high = np.where(np.isfinite(self.upper), self.upper, math.pi)
        best: Solution | None = None
        best_cost = math.inf
        for k in range(starts):
            start = first if k == 0 else rng.uniform(low, high)
            q, cost, errors, iterations = self._descend(start, goal)
            found = Solution(q, errors[0], errors[1], iterations, k + 1)
            if goal.met(errors):
                return found
            if cost < best_cost:
                best, best_cost = found, cost
        assert best is not None
        angle = f" and {math.degrees(best.angle_error):.1f}°" if goal.turns else ""
        raise UnreachableError(
            f"{label} is out of reach of {self.base} -> {self.tip} within its joint limits: "
            f"the nearest of {starts} starts is {best.position_error * 1000:.1f} mm{angle} off",
            best)

    def _middle(self) -> FloatArray:
        low = np.where(np.isfinite(self.lower), self.lower, 0.0)
        high = np.where(np.isfinite(self.upper), self.upper, 0.0)
        return np.clip((low + high) / 2.0, self.lower, self.upper)

    def _error(self, q: FloatArray, goal: _Goal
               ) -> tuple[FloatArray, FloatArray, FloatArray, tuple[float, float]]:
        """At ``q``: the weighted error (6), the tool's world position and rotation, and the
        raw errors (m, rad) of the weighted components."""
        position, rotation = self._set(q)
        moved = goal.position - position
        if goal.base_rotation is not None:
            moved = goal.base_rotation @ moved
        if goal.aim is not None:
            turned = aim_error((rotation.T @ goal.rotation[:, goal.aim]).tolist(), goal.aim)
        elif goal.turns:
            turned = rotation_log(rotation.T @ goal.rotation)
        else:
            turned = _ZERO3
        error = np.concatenate((moved, turned))
        raw = (math.sqrt(float(moved @ moved)) if goal.all_position
               else float(np.linalg.norm(moved[goal.used[:3]])),
               math.sqrt(float(turned @ turned)) if goal.aim is not None or goal.all_rotation
               else float(np.linalg.norm(turned[goal.used[3:]])))
        return goal.weights * error, position, rotation, raw

    def _descend(self, q: FloatArray, goal: _Goal
                 ) -> tuple[FloatArray, float, tuple[float, float], int]:
        """Bounded Levenberg-Marquardt from ``q``: (q, weighted cost, raw errors, iterations).
        Gives up when no step lowers the cost, or when the cost fell by less than half over
        the last :data:`_STALL_WINDOW` iterations (a local minimum: another start is cheaper)."""
        error, position, rotation, raw = self._error(q, goal)
        cost = float(error @ error)
        costs = [cost]
        damping = _DAMPING
        for iteration in range(_MAX_ITERATIONS):
            if goal.met(raw) or (len(costs) > _STALL_WINDOW
                                 and cost > 0.5 * costs[-1 - _STALL_WINDOW]):
                return q, cost, raw, iteration
            jac = self._world_jacobian(position)
            if goal.base_rotation is not None:
                jac[:3] = goal.base_rotation @ jac[:3]
            jac[3:] = rotation.T @ jac[3:]       # the rotation error is in the tool's frame
            jac *= goal.weights[:, None]
            normal = jac.T @ jac
            gradient = (jac.T @ error).tolist()
            scale = float(np.trace(normal)) / self.n + 1e-12
            rows = normal.tolist()
            low, high = self._room(q)
            while True:
                step = bounded_step(rows, gradient, damping * scale, low, high)
                trial = self._within(q + np.array(step))
                trial_error, trial_position, trial_rotation, trial_raw = \
                    self._error(trial, goal)
                trial_cost = float(trial_error @ trial_error)
                if trial_cost < cost:
                    q, error, position, rotation, raw, cost = \
                        trial, trial_error, trial_position, trial_rotation, trial_raw, trial_cost
                    costs.append(cost)
                    damping = max(damping / 3.0, _DAMPING * 1e-6)
                    break
                damping *= 4.0
                if damping > _MAX_DAMPING:
                    return q, cost, raw, iteration
        return q, cost, raw, _MAX_ITERATIONS

    def _room(self, q: FloatArray) -> tuple[list[float], list[float]]:
        """How far each joint may step down and up from ``q`` (a wrapping joint: any way)."""
        low, high = (self.lower - q).tolist(), (self.upper - q).tolist()
        for i in self._wrapping:
            low[i], high[i] = -math.inf, math.inf
        return low, high

    def _within(self, q: FloatArray) -> FloatArray:
        """``q`` clamped into the limits, a joint with a full turn of range wrapped instead."""
        for i in self._wrapping:
            q[i] = self.lower[i] + math.fmod(q[i] - self.lower[i], 2.0 * math.pi) % (2 * math.pi)
        return np.clip(q, self.lower, self.upper)


class _Goal:
    """An IK target in the world frame, with its weights and tolerances, and what the solver
    asks of it every iteration worked out once."""

    def __init__(self, pose: FloatArray, weights: FloatArray, base_rotation: FloatArray,
                 tolerances: tuple[float, float]) -> None:
        self.position = pose[:3, 3].copy()
        self.rotation = pose[:3, :3].copy()
        self.weights = weights
        #: world -> base, None where they are the same
        self.base_rotation = None if np.array_equal(base_rotation, np.eye(3)) else base_rotation
        self.tolerances = tolerances
        self.used = weights > 0
        self.all_position = bool(self.used[:3].all())
        self.all_rotation = bool(self.used[3:].all())
        self.turns = bool(self.used[3:].any())
        free = np.flatnonzero(~self.used[3:])
        #: the tool axis that is aimed, its roll free: the one rotation weight that is 0
        self.aim = int(free[0]) if len(free) == 1 else None

    def met(self, raw: tuple[float, float]) -> bool:
        return raw[0] <= self.tolerances[0] and raw[1] <= self.tolerances[1]


def _xyz(values: FloatArray) -> str:
    return "(" + ", ".join(f"{v:.3f}" for v in values) + ")"


def _euler_xyz(rotation: FloatArray) -> FloatArray:
    """The URDF's roll, pitch, yaw (about the fixed x, y, z) of a rotation matrix (rad)."""
    pitch = math.asin(max(-1.0, min(1.0, -float(rotation[2, 0]))))
    roll = math.atan2(rotation[2, 1], rotation[2, 2])
    yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    return np.array([roll, pitch, yaw])
