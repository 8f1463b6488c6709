"""FicTrac-compatible output for seed 002's treadmill: the ball's rotation, from the wheels'
encoders, in the 25 columns that fly-VR software reads from FicTrac.

FicTrac (github.com/rjdmoore/fictrac) tracks a patterned ball with a camera and writes one
line per frame; labs build closed loops and analyses on that line. The treadmill knows its
ball's rotation without any image matching: the three wheel encoders give it through eq. 3b,
exactly as the run's analysis computes it (:func:`~.analysis.sphere_motion`,
:class:`~servolab.kinematics.aot.AotKinematics`,
:func:`~servolab.kinematics.aot.surface_in_camera`), so this module only turns that motion
into FicTrac's quantities and FicTrac's file.

What FicTrac writes, and where it says so (rjdmoore/fictrac at commit ``1a528715527d`` of
2023-11-13, CMake version 2.1.2):

- the columns: ``doc/data_header.txt``, 25 of them. Columns 24 (delta timestamp) and 25
  (ms since midnight) came with commit ``7894ebb`` of 2019-12-06 ("add additional timestamp
  output data", first in tag 2.03); files of FicTrac 2.02 and earlier have 23;
- how each is computed: ``src/Trackball.cpp``, ``Trackball::updatePath`` (lines 877-997:
  lab rotation, ``velx = dr_lab[1]``, ``vely = -dr_lab[0]``, heading, 4-step position
  integration) and ``Trackball::process`` (lines 627-753: ``cnt`` and ``seq`` counting);
- the line: ``Trackball::logData`` (lines 999-1026): a ``std::stringstream`` with
  ``precision(14)`` (C's ``%.14g``), the values joined by ``", "``, ``std::endl`` at the end;
  the socket and serial outputs send the same line after ``"FT, "``;
- the file: ``<output_fn>-<YYYYMMDD_HHMMSS>.dat`` (line 399, ``execTime()`` in
  ``include/timing.h``).

:data:`COLUMNS` lists the 25 columns as implemented here, with units.
"""

from __future__ import annotations

import math
import operator
import re
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from types import TracebackType
from typing import IO, Any, NamedTuple, Self

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation  # type: ignore[import-untyped]

from ...kinematics.aot import AotGeometry, AotKinematics, surface_in_camera
from ..errors import RobotValueError
from .analysis import _unwrapped_turns, sphere_motion

FloatArray = npt.NDArray[np.float64]

#: FicTrac's ``doc/data_header.txt`` (rjdmoore/fictrac 1a528715527d, lines 2-43): the column
#: names used here, in FicTrac's order, with the units written to the file. "rad" of a
#: position or speed is radians of ball rotation: FicTrac says "scale by sphere radius for
#: true position" (lines 19-21, 30-32).
COLUMNS: tuple[tuple[str, str], ...] = (
    ("frame_counter", "the camera frame's sequence number (col 1, 'corresponding video frame')"),
    ("delta_rotation_cam_x", "rad, this frame's rotation vector, camera frame (cols 2-4)"),
    ("delta_rotation_cam_y", "rad"),
    ("delta_rotation_cam_z", "rad"),
    ("delta_rotation_error", "always 0: no template matching is done (col 5)"),
    ("delta_rotation_lab_x", "rad, this frame's rotation vector, lab frame (cols 6-8)"),
    ("delta_rotation_lab_y", "rad"),
    ("delta_rotation_lab_z", "rad"),
    ("absolute_rotation_cam_x", "rad, the ball's orientation, camera frame (cols 9-11)"),
    ("absolute_rotation_cam_y", "rad"),
    ("absolute_rotation_cam_z", "rad"),
    ("absolute_rotation_lab_x", "rad, the ball's orientation, lab frame (cols 12-14)"),
    ("absolute_rotation_lab_y", "rad"),
    ("absolute_rotation_lab_z", "rad"),
    ("position_x", "rad, integrated fictive position, world frame (cols 15-16)"),
    ("position_y", "rad"),
    ("heading", "rad in [0, 2 pi), integrated heading, lab frame (col 17)"),
    ("direction", "rad in [0, 2 pi), this frame's running direction, animal frame (col 18)"),
    ("speed", "rad per frame, this frame's running speed (col 19)"),
    ("forward_motion", "rad, integrated forward motion, heading ignored (col 20)"),
    ("side_motion", "rad, integrated side motion, heading ignored (col 21)"),
    ("timestamp_ms", "ms, the frame's stamp: ms since the epoch for ROS time (col 22)"),
    ("sequence_counter", "frames since the integrator started or was reset, from 0 (col 23)"),
    ("delta_timestamp_ms", "ms since the previous frame, 0 for the first (col 24)"),
    ("ms_since_midnight", "ms from the local midnight of the first frame's day (col 25)"),
)
#: 25: FicTrac since 2.03 (commit 7894ebb, 2019-12-06); 23 before.
COLUMN_COUNT = len(COLUMNS)
#: the two columns FicTrac writes as ``unsigned int`` (``Trackball.h``, ``DATA::cnt, seq``)
INTEGER_COLUMNS = (0, 22)
#: FicTrac's separator and number format (``Trackball::logData``: ``ss.precision(14)``)
SEPARATOR = ", "
NUMBER_FORMAT = "%.14g"
#: what FicTrac's socket and serial outputs put before the line (``"FT, " + ss.str()``)
SOCKET_PREFIX = "FT, "
#: ``Trackball::updatePath``'s ``steps``: sub-steps of the position integration per frame
PATH_SUBSTEPS = 4

#: The default camera-to-lab rotation (FicTrac's ``c2a_r``, here as a matrix whose rows are
#: the lab's axes in camera coordinates): the identity.
#:
#: FicTrac's camera frame is the image's x (right), y (down) and their right-handed z
#: (``doc/coordinate_frames.md``). In this repository's frames the image axes are the motors'
#: turned about the ball's axis (:func:`~servolab.kinematics.aot.surface_in_camera`: 20 deg
#: and the half turn of ``CAMERA_HANDEDNESS = (-1, -1, 1)``, a proper rotation that keeps the
#: sense of theta), so the image's z is the motors' z: down, from the ball's centre towards
#: the wheels (:func:`~servolab.kinematics.aot.contact_points`). The image is a view from
#: above, and the fly on top of the ball is at ``(0, 0, -R)``. FicTrac's lab frame is the
#: animal's (x forward, y right, z down): forward is image +x (the simulated fly walks along
#: ``(cos theta, sin theta)`` of the image, so at the tracker's target heading 0 it faces
#: +x), down is the camera's z, and right, ``z x x``, is image +y -- the camera's own axes.
#: The tracker's theta is an axis, not a heading (``vision/fly_tracker.py``): for a fly that
#: faces image -x at theta 0, pass ``diag(-1, -1, 1)``. (The thesis's text puts the camera
#: below the ball; a direct view from below would be a mirror of the motors' frame, which
#: ``CAMERA_HANDEDNESS`` is not: the rig's image must be flipped once on its way.)
DEFAULT_CAM_TO_LAB: FloatArray = np.eye(3)
DEFAULT_CAM_TO_LAB.setflags(write=False)

_UINT32 = 2**32


class FicTracError(RobotValueError):
    """A FicTrac row, file or setting that cannot be used; ``str(error)`` is one line.

    For a file it reads ``"<path>: line <n>: <what is wrong>"``; ``path`` and ``line``
    (1-based, ``None`` when the fault is not on one line) are kept for callers.
    """

    def __init__(self, message: str, path: str | Path | None = None,
                 line: int | None = None) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        where = "" if path is None else f"{path}: "
        where += "" if line is None else f"line {line}: "
        super().__init__(where + message)


class FicTracRow(NamedTuple):
    """One frame of FicTrac's output, its 25 columns in FicTrac's order (see :data:`COLUMNS`
    for the units). ``np.asarray(row)`` is the float row that :func:`fictrac_rows` returns."""

    frame_counter: int
    delta_rotation_cam_x: float
    delta_rotation_cam_y: float
    delta_rotation_cam_z: float
    delta_rotation_error: float
    delta_rotation_lab_x: float
    delta_rotation_lab_y: float
    delta_rotation_lab_z: float
    absolute_rotation_cam_x: float
    absolute_rotation_cam_y: float
    absolute_rotation_cam_z: float
    absolute_rotation_lab_x: float
    absolute_rotation_lab_y: float
    absolute_rotation_lab_z: float
    position_x: float
    position_y: float
    heading: float
    direction: float
    speed: float
    forward_motion: float
    side_motion: float
    timestamp_ms: float
    sequence_counter: int
    delta_timestamp_ms: float
    ms_since_midnight: float


assert FicTracRow._fields == tuple(name for name, _ in COLUMNS)


# -- rotations -------------------------------------------------------------------------------

Quaternion = tuple[float, float, float, float]  # (w, x, y, z), unit


def _quaternion(x: float, y: float, z: float) -> Quaternion:
    """The unit quaternion of an angle-axis vector (rad): FicTrac's ``omegaToMatrix``
    (right-handed, angle = the vector's length), kept as a quaternion because it composes in
    a few float operations, which a run of 80 000 frames needs in pure Python."""
    angle = math.sqrt(x * x + y * y + z * z)
    half = 0.5 - angle * angle / 48.0 if angle < 1e-4 else math.sin(angle / 2.0) / angle
    return (math.cos(angle / 2.0), x * half, y * half, z * half)


def _multiply(a: Quaternion, b: Quaternion) -> Quaternion:
    """``a * b``: the rotation ``b`` then ``a`` (matrices: ``A @ B``)."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


def _rotation_vector(q: Quaternion) -> tuple[float, float, float]:
    """The angle-axis vector (rad, angle in [0, pi]) of a unit quaternion.

    FicTrac's ``CmPoint::matrixToOmega`` (``src/CmPoint.cpp`` lines 270-287) divides by
    ``sin(angle)`` of a matrix and so returns 0 for a half turn and loses digits near one;
    ``2 atan2(|v|, w)`` is the same map without that, so a ball turned by nearly pi is
    reported, not zeroed.
    """
    w, x, y, z = q if q[0] >= 0 else (-q[0], -q[1], -q[2], -q[3])
    n = math.sqrt(x * x + y * y + z * z)
    scale = 2.0 / w if n < 1e-12 else 2.0 * math.atan2(n, w) / n
    return (x * scale + 0.0, y * scale + 0.0, z * scale + 0.0)


def _cam_to_lab_matrix(value: npt.ArrayLike) -> FloatArray:
    m = np.asarray(value, dtype=np.float64)
    if m.shape == (3,):
        if not np.all(np.isfinite(m)):
            raise FicTracError(f"cam_to_lab rotation vector {m.tolist()} is not finite")
        m = Rotation.from_rotvec(m).as_matrix()
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise FicTracError(f"cam_to_lab must be a rotation vector (3,) or matrix (3, 3), "
                           f"got shape {m.shape}" + ("" if m.shape != (3, 3) else " not finite"))
    if not (np.allclose(m @ m.T, np.eye(3), atol=1e-9) and np.linalg.det(m) > 0):
        raise FicTracError(f"cam_to_lab {m.tolist()} is not a rotation (orthonormal, det +1)")
    out = m.copy()
    out.setflags(write=False)
    return out


def surface_to_rotation(x: float, y: float, theta: float,
                        radius: float) -> tuple[float, float, float]:
    """The ball's rotation vector (rad, camera frame) for its surface's motion under the fly,
    ``(x, y, theta)`` in the image frame (m, m, rad: a row of :func:`~.analysis.sphere_motion`).

    The fly stands on top of the ball. In a frame with z up that point is ``(0, 0, R)`` and a
    rotation ``w`` moves it by ``v = w x (0, 0, R)``; the camera's z points down (see
    :data:`DEFAULT_CAM_TO_LAB`), so there the point is ``p = (0, 0, -R)`` and ``v = w x p =
    (-R w_y, R w_x, 0)``: ``w_x = v_y / R``, ``w_y = -v_x / R``. The top point does not see
    ``w_z``, which is eq. 3b's own third row (``w_z = theta'``, the surface turning about the
    ball's axis, which is the camera's z).

    The surface motion is the one fact shared with the analysis and the simulator (the fly
    is carried by it). Eq. 3b's ``M`` pairs each surface velocity with ``r`` times a rotation
    component (``w_y = y'/r``, ``w_x = x'/r``; eq. 3a writes the pairing the other way round)
    rather than by the cross product; the cross product gives the rotation's physical axis,
    and ``R`` = that ``r`` (the wheel radius, :func:`~servolab.kinematics.aot.m_matrix`)
    gives it exactly the size of eq. 3b's ``J w``: ``|(w_x, w_y)| = |(x', y')| / r`` is kept
    by the camera's rotation and sign flips, and ``w_z`` is ``theta'`` unchanged.
    """
    # + 0.0: a ball at rest is (0, 0, 0), not -0 (which the file would show as "-0")
    return (y / radius + 0.0, -x / radius + 0.0, theta + 0.0)


# -- the integrator --------------------------------------------------------------------------

def _local_midnight(stamp: float) -> float:
    """The epoch second of the local midnight that starts ``stamp``'s day, as FicTrac's
    ``ms_since_midnight`` takes it once (``include/timing.h``: ``localtime``, zero the
    hour, minute and second, ``mktime``)."""
    try:
        day = datetime.fromtimestamp(stamp).replace(hour=0, minute=0, second=0, microsecond=0)
    except (OverflowError, OSError, ValueError) as error:
        raise FicTracError(f"stamp {stamp!r} s has no local date ({error}); pass midnight_s"
                           ) from None
    return day.timestamp()


def _wrap_heading(heading: float) -> float:
    """FicTrac's two loops (``Trackball::updatePath``): into ``[0, 2 pi)``."""
    if abs(heading) > 1e6:
        heading = math.fmod(heading, math.tau)
    while heading < 0:
        heading += math.tau
    while heading >= math.tau:
        heading -= math.tau
    return heading


def _wrap_pi(angle: float) -> float:
    while angle >= math.pi:
        angle -= math.tau
    while angle < -math.pi:
        angle += math.tau
    return angle


def _frame_number(value: Any, what: str) -> int:
    """A counter as FicTrac writes it, an ``unsigned int``: a whole number 0..2**32-1 (an int,
    or a float such as the fly log's ``frame``) or a one-line :class:`FicTracError`."""
    try:
        number = operator.index(value) if not isinstance(value, float | np.floating) else None
    except TypeError:
        number = None
    if number is None:
        f = float(value) if isinstance(value, float | np.floating) else math.nan
        if not (math.isfinite(f) and f.is_integer()):
            raise FicTracError(f"{what} {value!r} is not a whole number")
        number = int(f)
    if not 0 <= number < _UINT32:
        raise FicTracError(f"{what} {number} is outside FicTrac's unsigned int (0..2**32-1)")
    return number


class FicTracIntegrator:
    """FicTrac's per-frame state, fed by the treadmill's wheel encoders: one
    :class:`FicTracRow` per frame, the same numbers FicTrac's ``updatePath`` would compute
    from the same ball rotation.

    Per frame (:meth:`update`): the three wheels' ``present_position`` (ticks, 4096 a turn),
    the frame's stamp (s) and its sequence number. The change of the wheel angles since the
    previous frame goes through eq. 3b and into the camera's frame exactly as
    :func:`~.analysis.sphere_motion` does it (the same functions), then
    :func:`surface_to_rotation` makes it the frame's rotation vector ``dr_cam``. The first
    frame has no previous one: its rotation is 0, as FicTrac's first (globally searched)
    frame has no relative rotation either.

    From ``dr_cam``, as FicTrac (``Trackball::updatePath``):

    - ``dr_lab = C dr_cam`` (``C`` = ``cam_to_lab``); orientation ``R_cam <- exp(dr_cam)
      R_cam`` from the identity, ``R_lab = C R_cam``; columns 9-14 are their rotation vectors
      (angle in [0, pi], see :func:`_rotation_vector` for FicTrac's half-turn fault);
    - the animal's step: ``velx = dr_lab[1]`` (forward), ``vely = -dr_lab[0]`` (right),
      ``speed = hypot(velx, vely)``, ``direction = atan2(vely, velx)`` in ``[0, 2 pi)``;
      ``forward_motion``/``side_motion`` sum ``velx``/``vely`` ("two optic mice");
    - ``heading -= dr_lab[2]``, wrapped into ``[0, 2 pi)``;
    - the position: the step split into 4 sub-steps, each along the step's direction turned
      by the heading at its middle (the heading change of the frame spread evenly).

    Counters: FicTrac writes the frame counter ``cnt`` and the sequence counter ``seq``,
    both 0 on the first frame its code logs (``Trackball::process``; its doc says the
    frame counter "starts at #1"). Here column 1 is the camera's own sequence number (the
    image ``header.seq`` of the fly log's ``frame``): it *is* the "corresponding video
    frame" and lets a row be joined with its image; column 23 counts frames from 0 since the
    start or the last :meth:`reset`, as FicTrac's ``seq``.

    Times: column 22 is the stamp in ms (FicTrac: "frame capture time (ms since epoch)"),
    24 the difference to the previous frame's (0 on the first, as FicTrac's
    ``static prev_ts``), 25 ms since ``midnight_s`` -- by default the local midnight of the
    first frame's day, which FicTrac also fixes once per run.

    ``rotation_radius`` (m) turns surface motion into rotation; by default eq. 3b's ``r``,
    the wheel radius the rig's ``M`` uses (:func:`~servolab.kinematics.aot.m_matrix`), so that
    the rotation has the size of eq. 3b's ``J w`` (see :func:`surface_to_rotation`).
    FicTrac's positions are then radians of *that* rotation: times ``rotation_radius`` they
    are the metres of :func:`~.analysis.fictive_path` (eq. 3b's surface motion); times the
    ball's radius, as FicTrac's doc says to scale, 1.6 % more on the thesis's rig (50.8 mm
    ball, 50 mm wheels).
    """

    def __init__(self, geometry: AotGeometry | None = None, *,
                 cam_to_lab: npt.ArrayLike = DEFAULT_CAM_TO_LAB,
                 rotation_radius: float | None = None,
                 midnight_s: float | None = None) -> None:
        self.geometry = geometry or AotGeometry()
        self.kinematics = AotKinematics.from_geometry(self.geometry)
        self.cam_to_lab = _cam_to_lab_matrix(cam_to_lab)
        self._c = tuple(tuple(float(v) for v in row) for row in self.cam_to_lab)
        qx, qy, qz, qw = Rotation.from_matrix(self.cam_to_lab).as_quat().tolist()
        self._q_lab: Quaternion = (qw, qx, qy, qz)
        radius = self.geometry.wheel_radius if rotation_radius is None else rotation_radius
        if not (isinstance(radius, int | float) and math.isfinite(radius) and radius > 0):
            raise FicTracError(f"rotation_radius {radius!r} m must be a positive number")
        self.rotation_radius = float(radius)
        if midnight_s is not None and not math.isfinite(midnight_s):
            raise FicTracError(f"midnight_s {midnight_s!r} must be finite")
        self.midnight_s = midnight_s
        self._wheels: FloatArray | None = None
        self._prev_ts: float | None = None
        self.forward_motion = 0.0
        self.side_motion = 0.0
        self.reset()

    def reset(self) -> None:
        """Start a new tracking sequence, as FicTrac's ``Trackball::resetData``: orientation,
        heading and position back to 0, the sequence counter to 0; the integrated
        forward/side motion, the previous frame's stamp and wheel positions are kept (FicTrac
        keeps ``intx``/``inty``: they do not depend on the heading)."""
        self._q_cam: Quaternion = (1.0, 0.0, 0.0, 0.0)
        self.heading = 0.0
        self._prev_heading = 0.0
        self.position = (0.0, 0.0)
        self.sequence = 0

    def update(self, positions: npt.ArrayLike, stamp: float, frame: int) -> FicTracRow:
        """The row of a frame: ``positions`` the three wheels' ``present_position`` (ticks),
        ``stamp`` its capture time (s), ``frame`` its sequence number (see the class)."""
        ticks = np.asarray(positions, dtype=np.float64)
        if ticks.shape != (3,) or not np.all(np.isfinite(ticks)):
            raise FicTracError(f"positions must be 3 finite tick counts, got {ticks.tolist()}")
        if self._wheels is None:
            motion = np.zeros(3)
        else:
            # sphere_motion's steps on two frames: unwrapped wheel angles, their change
            # through eq. 3b, into the camera's frame
            turns = _unwrapped_turns(np.stack([self._wheels, ticks], axis=1))  # (3, 2)
            motion = surface_in_camera(self.kinematics.ball_velocity(turns[:, 1] - turns[:, 0]),
                                       self.geometry)
        self._wheels = ticks
        return self.advance(motion, stamp, frame)

    def advance(self, motion: npt.ArrayLike, stamp: float, frame: int) -> FicTracRow:
        """The row of a frame given the ball's surface motion since the previous frame
        (``(x, y, theta)``, image frame, m, m, rad: a row of :func:`~.analysis.sphere_motion`);
        :meth:`update` ends here, and :func:`fictrac_rows` in the same step."""
        m = np.asarray(motion, dtype=np.float64)
        if m.shape != (3,) or not np.all(np.isfinite(m)):
            raise FicTracError(f"motion must be 3 finite numbers, got {m.tolist()}")
        stamp = float(stamp)
        if not math.isfinite(stamp):
            raise FicTracError(f"stamp {stamp!r} s is not finite")
        mx, my, mt = m.tolist()
        return self._step(mx, my, mt, stamp, _frame_number(frame, "frame"))

    def _step(self, mx: float, my: float, mt: float, stamp: float, cnt: int) -> FicTracRow:
        """``Trackball::updatePath`` and ``logData``'s values on checked floats."""
        if self.midnight_s is None:
            self.midnight_s = _local_midnight(stamp)
        c0, c1, c2 = surface_to_rotation(mx, my, mt, self.rotation_radius)
        (a, b, c), (d, e, f), (g, h, i) = self._c
        l0, l1, l2 = (a * c0 + b * c1 + c * c2 + 0.0, d * c0 + e * c1 + f * c2 + 0.0,
                      g * c0 + h * c1 + i * c2 + 0.0)
        q = _multiply(_quaternion(c0, c1, c2), self._q_cam)  # pre-multiplied, as FicTrac
        norm = math.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
        self._q_cam = (q[0] / norm, q[1] / norm, q[2] / norm, q[3] / norm)
        r_cam = _rotation_vector(self._q_cam)
        r_lab = _rotation_vector(_multiply(self._q_lab, self._q_cam))  # R_lab = C R_cam

        velx, vely = l1, -l0 + 0.0
        speed = math.hypot(velx, vely)
        direction = math.atan2(vely, velx)
        if direction < 0:
            direction += math.tau
        self.forward_motion += velx
        self.side_motion += vely
        self.heading = _wrap_heading(self.heading - l2)
        self.position = self._integrate_position(velx, vely, speed)

        ts = stamp * 1000.0
        delta_ts = 0.0 if self._prev_ts is None else ts - self._prev_ts
        self._prev_ts = ts
        row = FicTracRow(
            cnt, c0, c1, c2, 0.0, l0, l1, l2, *r_cam, *r_lab, self.position[0],
            self.position[1], self.heading, direction, speed, self.forward_motion,
            self.side_motion, ts, self.sequence, delta_ts, (stamp - self.midnight_s) * 1000.0)
        self.sequence += 1
        return row

    def _integrate_position(self, velx: float, vely: float, speed: float) -> tuple[float, float]:
        """``Trackball::updatePath``'s "super-res integration": 4 sub-steps of ``speed / 4``
        along the step's direction, turned by the heading at each sub-step's middle."""
        step = speed / PATH_SUBSTEPS
        heading_step = _wrap_pi(self.heading - self._prev_heading) / PATH_SUBSTEPS
        dx, dy = (velx / speed, vely / speed) if speed != 0 else (0.0, 0.0)
        angle = self._prev_heading + heading_step / 2.0
        x, y = self.position
        for i in range(PATH_SUBSTEPS):
            c, s = math.cos(angle + i * heading_step), math.sin(angle + i * heading_step)
            x += step * (c * dx - s * dy)
            y += step * (s * dx + c * dy)
        self._prev_heading = self.heading
        return x, y


def fictrac_rows(fly: npt.NDArray[np.void], geometry: AotGeometry | None = None, *,
                 cam_to_lab: npt.ArrayLike = DEFAULT_CAM_TO_LAB,
                 rotation_radius: float | None = None,
                 midnight_s: float | None = None) -> FloatArray:
    """``(N, 25)`` FicTrac rows of a whole run's fly log (records of
    :data:`~.logs.FLY_RECORD`: ``position1..3``, ``time``, ``frame``), so that a run can
    write its ``.dat`` after the fact: the surface motion from
    :func:`~.analysis.sphere_motion`, then the integrator's step frame by frame (what
    :meth:`FicTracIntegrator.update` does on the same frames, to rounding: numpy sums the
    eq. 3b products of a whole run in another order than of one frame)."""
    integrator = FicTracIntegrator(geometry, cam_to_lab=cam_to_lab,
                                   rotation_radius=rotation_radius, midnight_s=midnight_s)
    if len(fly) == 0:
        return np.zeros((0, COLUMN_COUNT))
    _, _, motion = sphere_motion(fly, integrator.geometry)  # checks the positions
    times = np.asarray(fly["time"], dtype=np.float64)
    frames = np.asarray(fly["frame"], dtype=np.float64)
    if not np.all(np.isfinite(times)):
        raise FicTracError(f"record {int(np.argmax(~np.isfinite(times)))}: time is not finite")
    bad = ~(np.isfinite(frames) & (np.floor(frames) == frames) & (frames >= 0)
            & (frames < _UINT32))
    if bad.any():
        index = int(np.argmax(bad))
        raise FicTracError(f"record {index}: frame {frames[index]!r} is not an image seq")
    step = integrator._step
    rows = [step(0.0, 0.0, 0.0, times[0].item(), int(frames[0]))]
    rows += [step(mx, my, mt, t, int(f)) for (mx, my, mt), t, f
             in zip(motion.tolist(), times[1:].tolist(), frames[1:].tolist(), strict=True)]
    return np.array(rows, dtype=np.float64)


# -- the .dat file ---------------------------------------------------------------------------

def _row_values(row: FicTracRow | npt.ArrayLike) -> list[float | int]:
    values = list(row) if isinstance(row, tuple) else np.asarray(row, dtype=np.float64).tolist()
    if len(values) != COLUMN_COUNT:
        raise FicTracError(f"a FicTrac row has {COLUMN_COUNT} values, got {len(values)}")
    out: list[float | int] = []
    for i, value in enumerate(values):
        if i in INTEGER_COLUMNS:
            out.append(_frame_number(value, f"column {i + 1} ({COLUMNS[i][0]})"))
        else:
            out.append(float(value))
    return out


def format_line(row: FicTracRow | npt.ArrayLike) -> str:
    """The line FicTrac's ``logData`` writes for a row, newline included: ``%.14g`` numbers
    (``std::stringstream`` with ``precision(14)``), the two counters as integers, joined
    by ``", "``."""
    return SEPARATOR.join(str(v) if isinstance(v, int) else NUMBER_FORMAT % v
                          for v in _row_values(row)) + "\n"


def socket_message(row: FicTracRow | npt.ArrayLike) -> str:
    """What FicTrac sends per frame over its UDP socket (``sock_port``) or serial port:
    ``"FT, "`` and the file's line (``Trackball::logData``; ``scripts/socket_client.py``
    splits it on ``", "`` and checks the ``"FT"``)."""
    return SOCKET_PREFIX + format_line(row)


#: FicTrac's output in a run folder: FicTrac names its own ``<base>-<date>_<time>.dat``
#: (:func:`fictrac_filename`); a run folder is named by its time already
FICTRAC_FILE = "fictrac.dat"


def fictrac_filename(base: str, when: datetime) -> str:
    """FicTrac's data file name: ``<base>-YYYYMMDD_HHMMSS.dat``, ``when`` the start of the
    run (``Trackball.cpp`` line 399; ``execTime()`` formats the local start time)."""
    return f"{base}-{when:%Y%m%d_%H%M%S}.dat"


class FicTracWriter:
    """Writes FicTrac's ``.dat`` (:func:`format_line` per row), flushed after every row as
    FicTrac's ``FileRecorder`` does, so a killed run keeps what it wrote. Refuses to
    overwrite an existing file unless ``overwrite=True``."""

    def __init__(self, path: str | Path, *, overwrite: bool = False) -> None:
        self.path = Path(path)
        self.rows = 0
        try:
            self._file: IO[str] | None = open(  # noqa: SIM115 - closed by close()/__exit__
                self.path, "w" if overwrite else "x", encoding="ascii", newline="\n")
        except FileExistsError:
            raise FicTracError("exists; pass overwrite=True to replace it", self.path) from None
        except OSError as error:
            raise FicTracError(f"cannot write: {error.strerror}", self.path) from None

    def write(self, row: FicTracRow | npt.ArrayLike) -> None:
        if self._file is None:
            raise FicTracError("is closed", self.path)
        self._file.write(format_line(row))
        self._file.flush()
        self.rows += 1

    def write_rows(self, rows: Sequence[FicTracRow] | npt.ArrayLike) -> None:
        for row in (rows if isinstance(rows, Sequence) else np.asarray(rows)):
            self.write(row)

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(nan|inf)", re.IGNORECASE)


def read_fictrac_dat(path: str | Path) -> FloatArray:
    """A FicTrac ``.dat`` as an ``(N, 25)`` float array, FicTrac's column order.

    Every line must hold 25 numbers separated by commas (FicTrac writes ``", "``), the frame
    and sequence counters whole numbers: a file of FicTrac 2.02 or earlier (23 columns), a
    socket capture (``"FT, "`` first) or anything else is refused with one line naming the
    file and line, rather than read as shifted columns.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="ascii")
    except FileNotFoundError:
        raise FicTracError("no such file", path) from None
    except UnicodeDecodeError as error:
        where = path.read_bytes()[:error.start].count(b"\n") + 1
        raise FicTracError("not text (a byte outside ASCII): not a FicTrac .dat", path,
                           where) from None
    except OSError as error:
        raise FicTracError(f"cannot read: {error.strerror}", path) from None
    lines = text.splitlines()
    rows = np.empty((len(lines), COLUMN_COUNT))
    for n, line in enumerate(lines):
        fields = line.split(",")
        if len(fields) != COLUMN_COUNT:
            old = " (23 is FicTrac 2.02 or older)" if len(fields) == 23 else ""
            raise FicTracError(f"{len(fields)} columns, a FicTrac .dat has {COLUMN_COUNT}{old}",
                               path, n + 1)
        for i, field in enumerate(fields):
            token = field.strip()
            if not _NUMBER.fullmatch(token):
                raise FicTracError(f"column {i + 1} ({COLUMNS[i][0]}) is {token!r}, not a number",
                                   path, n + 1)
            rows[n, i] = float(token)
        for i in INTEGER_COLUMNS:
            value = rows[n, i]
            if not (value.is_integer() and 0 <= value < _UINT32):
                raise FicTracError(f"column {i + 1} ({COLUMNS[i][0]}) is {fields[i].strip()}, "
                                   "not a counter (a whole number 0..2**32-1)", path, n + 1)
    return rows


# -- ROS -------------------------------------------------------------------------------------

#: the label of the one dimension of the ``std_msgs/msg/Float64MultiArray`` a row is sent in
MULTIARRAY_LABEL = "fictrac_data_header_columns"


def multiarray_value(row: FicTracRow | npt.ArrayLike) -> dict[str, Any]:
    """A row as the value of a ``std_msgs/msg/Float64MultiArray`` (for
    :meth:`~servolab.middleware.messages.MessageTypes.from_value`): one dimension of 25,
    labelled :data:`MULTIARRAY_LABEL`, ``data`` in FicTrac's column order (the counters as
    exact floats). No ROS package has a FicTrac message this repository can copy field for
    field; a multi-array keeps FicTrac's own layout, which its users already index."""
    data = np.asarray(_row_values(row), dtype=np.float64)
    return {"layout": {"dim": [{"label": MULTIARRAY_LABEL, "size": COLUMN_COUNT,
                                "stride": COLUMN_COUNT}], "data_offset": 0},
            "data": data}


def row_from_multiarray(message: Any) -> FicTracRow:
    """The row in a ``Float64MultiArray`` made by :func:`multiarray_value`; its layout is
    checked so that another publisher's array is not read as FicTrac's columns."""
    dims = list(message.layout.dim)
    if (len(dims) != 1 or dims[0].label != MULTIARRAY_LABEL or dims[0].size != COLUMN_COUNT
            or message.layout.data_offset != 0 or len(message.data) != COLUMN_COUNT):
        shape = [(d.label, d.size) for d in dims]
        raise FicTracError(f"a Float64MultiArray of layout {shape} and {len(message.data)} "
                           f"values is not a FicTrac row ([({MULTIARRAY_LABEL!r}, 25)])")
    values = _row_values(message.data)
    return FicTracRow(*values)  # type: ignore[arg-type]
