"""Kinematics of seed 002's Active Omni-directional Treadmill (AOT): a 4-inch acrylic ball on
three omni-wheels, turned so that a walking fly stays under the camera.

Section 3.1 of seed 002 (after Robinson et al. 2005, the Atlas spherical orienting device)
writes the model as eq. (3b)-(3d)::

    [w_y, w_x, w_z] = M [x', y', theta'] = J [w_1, w_2, w_3]
    J^-1 M X' = [w_1, w_2, w_3]                          (3d)
    M = [[0, 1/r, 0], [1/r, 0, 0], [0, 0, 1]]
    J = R_1z / |R|^2 [[ R_1z, R_1z cos a_2, R_1z cos a_3],
                      [ 0,   -R_1z sin a_2, -R_1z sin a_3],
                      [-R_1x, -R_1x,        -R_1x       ]]  (3c)

``X' = (x', y', theta')`` is the velocity of the ball's surface under the fly (m/s, m/s,
rad/s) and ``w_k`` the wheels' angular speeds (rad/s). All three contact points are rotations
of ``R_1`` about the ball's axis, which is why (3c) needs only ``R_1``'s radial and axial
components; ``jacobian`` writes column 1 with ``a_1`` too, which is (3c) when ``a_1 = 0``.

Geometry (section 3, "oriented at a 40 deg angle to the axis of the ball"): ``tilt`` is read
as the angle between each wheel's axle and the ball's axis, so the ball's radius to the
contact point (perpendicular to the axle, in the plane through the axis and the wheel) makes
``tilt`` with the ball's equatorial plane::

    R_1 = ball_radius * (cos tilt, 0, sin tilt)

with ``z`` along the ball's axis pointing from the centre towards the wheels. This is the
reading, and the sign of ``z``, that the thesis's own numbers pin down: Listing 1's ``J1M`` is,
to all six printed digits, ``J^-1 M`` of (3c) evaluated in millimetres with
``R_1 = 50.8 (cos 40, 0, sin 40)``, ``r = 50`` (the wheel's radius, as (3a) says) and the
prefactor ``R_1z / |R|^2`` left out. The other reading (contact point 40 deg from the axis)
gives a rotation-to-translation ratio tan(50)/tan(40) = 1.42 times the listing's.

What (3c) is not: the rigid-body rolling constraint. A wheel's rim speed equals the ball's
surface speed along the wheel's rolling direction ``s_k``: ``rho w_k = (R_k x s_k) . omega``.
(3c) has instead the form of that map's transpose (up to a constant factor and the axes'
signs: each wheel's contribution taken as if the others were absent), which inverts it
only when the three contact normals ``R_k x s_k`` are mutually orthogonal, i.e.
``tan(tilt) = sqrt(2)`` (54.7 deg). At 40 deg the rolling constraint needs the rotation
column ``2 / tan(tilt)**2 * ball_radius / r`` = 2.9 times larger relative to the translation
columns than (3c) gives; the listing's ``SF = 60`` on the rotation input (against 38.4 pixels
per millimetre on the translation inputs) makes up a factor 1.56 of that. This module keeps
the paper's model; ``ball_velocity`` inherits its error in ``theta'`` when used to
reconstruct the ball's path from the encoders.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from servolab.kinematics.dh import FloatArray
from servolab.kinematics.diffdrive import finite_array
from servolab.kinematics.errors import KinematicsValueError

#: Largest condition number of ``J`` (dimensionless, so unit-independent) accepted: beyond it
#: the solve keeps fewer than half of float64's digits and some command needs wheel speeds
#: larger than the motion asked for by that factor, which no servo can deliver.
MAX_CONDITION = 1e8


def _readonly(array: FloatArray) -> FloatArray:
    array.setflags(write=False)
    return array


#: Listing 1's ``J1M[9]`` ("J inverse * M"), row-major: row ``k`` gives wheel ``k + 1``.
#: Units as the listing uses it: columns 0-1 take pixel errors after the 20 deg camera rotation,
#: column 2 takes a heading error in rad multiplied by ``SF = 60``, and the sum times
#: ``K = 100`` is written, truncated to int, as the XM motors' raw ``Goal Velocity``
#: (0.229 rev/min per unit). As a geometric matrix it is (3c)'s ``J^-1 M`` in millimetres
#: times ``|R|^2 / R_1z`` = 79.0 mm (see the module docstring), not an SI matrix.
THESIS_J1M: FloatArray = _readonly(np.array([
    [0.0, 0.000408326, -0.00856566],
    [-0.000353621, -0.000204163, -0.00856566],
    [0.000353621, -0.000204163, -0.00856566],
]))


class AotGeometryError(KinematicsValueError):
    """The wheels cannot produce every ball motion: ``J`` (or a given ``J^-1 M``) is singular
    or so ill-conditioned that the wheel speeds would be rounding noise."""


def _check_positive(name: str, value: float) -> float:
    if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
            and value > 0):
        raise KinematicsValueError(f"{name} must be a positive finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class AotGeometry:
    """The rig's dimensions, SI: metres and radians.

    Defaults are seed 002's rig (section 3): a 4-inch ball (radius 0.0508 m), 100 mm wheels
    (radius 0.05 m), wheel axles at 40 deg to the ball's axis (``tilt``, see the module
    docstring for why this reading), wheels at 0, 120, 240 deg about the axis, and the camera
    rotated 20 deg from the motors' frame (Listing 1's ``thm``).

    ``tilt`` must lie strictly between 0 and pi/2: outside it the contact point is not on the
    lower half of the ball facing the wheel. Angles equal modulo 2 pi are refused here; nearly
    equal ones pass and are refused as ill-conditioned by :func:`inverse_jacobian_m`.
    """

    ball_radius: float = 0.0508
    wheel_radius: float = 0.05
    tilt: float = math.radians(40.0)
    wheel_angles: tuple[float, float, float] = (0.0, 2.0 * math.pi / 3.0, 4.0 * math.pi / 3.0)
    camera_to_motor: float = math.radians(20.0)

    def __post_init__(self) -> None:
        _check_positive("ball_radius", self.ball_radius)
        _check_positive("wheel_radius", self.wheel_radius)
        _check_positive("tilt", self.tilt)
        if not self.tilt < math.pi / 2.0:
            raise KinematicsValueError(f"tilt must be below pi/2 rad, got {self.tilt!r}")
        if not math.isfinite(self.camera_to_motor):
            raise KinematicsValueError("camera_to_motor must be finite, got "
                                       f"{self.camera_to_motor!r}")
        angles = tuple(self.wheel_angles)
        if len(angles) != 3 or not all(
                isinstance(a, (int, float, np.integer, np.floating)) and math.isfinite(a)
                for a in angles):
            raise KinematicsValueError(f"wheel_angles must be three finite numbers, got {angles!r}")
        wrapped = [math.remainder(float(a), 2.0 * math.pi) for a in angles]
        for i in range(3):
            for j in range(i + 1, 3):
                if math.remainder(wrapped[i] - wrapped[j], 2.0 * math.pi) == 0.0:
                    raise KinematicsValueError("wheel_angles must be three distinct angles, got "
                                               f"{angles!r}")


def contact_points(geometry: AotGeometry) -> FloatArray:
    """Row ``k``: ``R_k``, ball centre to wheel ``k``'s contact point (m), ``R_1`` rotated by
    ``wheel_angles[k]`` about the ball's axis; (3c) and any slip check start from these."""
    rb, t = geometry.ball_radius, geometry.tilt
    a = np.asarray(geometry.wheel_angles, dtype=np.float64)
    return np.stack([rb * math.cos(t) * np.cos(a), rb * math.cos(t) * np.sin(a),
                     np.full(3, rb * math.sin(t))], axis=1)


def jacobian(geometry: AotGeometry) -> FloatArray:
    """Eq. (3c)'s ``J`` (dimensionless): wheel speeds to ``[w_y, w_x, w_z]`` of the ball.

    Built from ``R_1``'s components only, as the paper writes it; column ``k`` uses
    ``wheel_angles[k]``, so column 1 is (3c)'s ``[R_1z, 0, -R_1x]`` when ``a_1 = 0``.
    """
    r1 = contact_points(geometry)[0]
    r1x, r1z = math.hypot(r1[0], r1[1]), float(r1[2])
    a = np.asarray(geometry.wheel_angles, dtype=np.float64)
    body = np.stack([r1z * np.cos(a), -r1z * np.sin(a), np.full(3, -r1x)])
    return np.asarray(r1z / geometry.ball_radius**2 * body, dtype=np.float64)


def m_matrix(r: float) -> FloatArray:
    """Eq. (3b)'s ``M``: ``[x', y', theta']`` to ``[w_y, w_x, w_z]``, with (3b)'s row order."""
    inv = 1.0 / _check_positive("r", r)
    return np.array([[0.0, inv, 0.0], [inv, 0.0, 0.0], [0.0, 0.0, 1.0]])


def _checked_condition(name: str, matrix: FloatArray) -> None:
    cond = float(np.linalg.cond(matrix))
    if not cond <= MAX_CONDITION:
        shown = f"{cond:.3g}" if math.isfinite(cond) else "infinite"
        raise AotGeometryError(f"{name} is singular: condition number {shown} exceeds "
                               f"{MAX_CONDITION:.0e}")


def inverse_jacobian_m(geometry: AotGeometry) -> FloatArray:
    """Eq. (3d)'s ``J^-1 M``: ``[x', y', theta']`` (m/s, m/s, rad/s) to wheel speeds (rad/s).

    ``M`` takes ``r = wheel_radius`` as (3a) defines it and as the listing's constants were
    computed; solved rather than inverted so that a near-singular ``J`` is caught by its
    condition number before it turns into enormous wheel speeds.
    """
    j = jacobian(geometry)
    _checked_condition(f"J of {geometry!r}", j)
    return np.asarray(np.linalg.solve(j, m_matrix(geometry.wheel_radius)), dtype=np.float64)


def listing_matrix(geometry: AotGeometry) -> FloatArray:
    """``J^-1 M`` as Listing 1's ``J1M`` was made (module docstring): (3d) for ``geometry``
    in millimetres with (3c)'s prefactor ``R_1z / |R|^2`` left out. For section 3's rig this is
    :data:`THESIS_J1M` to its six printed digits, so a rig of other dimensions gets the gains
    the thesis's controller had (``K``, ``SF`` and pixel errors as inputs)."""
    mm = AotGeometry(ball_radius=geometry.ball_radius * 1000.0,
                     wheel_radius=geometry.wheel_radius * 1000.0, tilt=geometry.tilt,
                     wheel_angles=geometry.wheel_angles,
                     camera_to_motor=geometry.camera_to_motor)
    r1z = float(contact_points(mm)[0, 2])
    return np.asarray(inverse_jacobian_m(mm) * (r1z / mm.ball_radius**2), dtype=np.float64)


@dataclass(frozen=True, eq=False)
class AotKinematics:
    """A ``J^-1 M`` matrix and its inverse: ball-surface velocity <-> wheel speeds.

    From :meth:`from_geometry` it is SI: ``[x', y', theta']`` in m/s, m/s, rad/s to wheel
    rad/s. From :meth:`from_matrix` it is in whatever units the matrix was made in; given
    :data:`THESIS_J1M`, inputs are camera pixels (after :func:`camera_to_motor`) and rad, and
    the listing scales the rotation input by ``SF = 60`` and the output by ``K = 100`` into raw
    XM ``Goal Velocity`` units, neither of which is applied here. The listing's constants are
    not a calibration: they are (3c) in millimetres without its prefactor (module docstring),
    so they match :meth:`from_geometry` column by column only up to one scale per column.
    """

    matrix: FloatArray
    inverse: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        matrix = finite_array("matrix", self.matrix)
        if matrix.shape != (3, 3):
            raise KinematicsValueError(f"matrix must be 3x3, got shape {matrix.shape}")
        _checked_condition("J^-1 M matrix", matrix)
        object.__setattr__(self, "matrix", _readonly(matrix.copy()))
        object.__setattr__(self, "inverse",
                           _readonly(np.asarray(np.linalg.inv(matrix), dtype=np.float64)))

    @classmethod
    def from_geometry(cls, geometry: AotGeometry) -> AotKinematics:
        """The paper's model (3d) for ``geometry``, SI units."""
        return cls(inverse_jacobian_m(geometry))

    @classmethod
    def from_matrix(cls, matrix: npt.ArrayLike) -> AotKinematics:
        """A ``J^-1 M`` given directly, e.g. :data:`THESIS_J1M`, in its own units."""
        return cls(np.asarray(matrix, dtype=np.float64))

    def wheel_speeds(self, dx: npt.ArrayLike, dy: npt.ArrayLike,
                     dtheta: npt.ArrayLike) -> FloatArray:
        """Eq. (3d): wheel speeds, shape ``(3,)`` for scalars, ``(3, ...)`` when broadcasting.

        To hold the fly still the ball's surface must move opposite to the fly's walk: the
        caller passes the counter-motion, as Listing 1 does with its position errors.
        """
        x, y, th = np.broadcast_arrays(finite_array("dx", dx), finite_array("dy", dy),
                                       finite_array("dtheta", dtheta))
        return np.asarray(np.tensordot(self.matrix, np.stack([x, y, th]), axes=1),
                          dtype=np.float64)

    def ball_velocity(self, wheel_speeds: npt.ArrayLike) -> FloatArray:
        """Inverse of :meth:`wheel_speeds`: ``[x', y', theta']`` of the ball's surface under
        the fly from the three wheels' speeds (shape ``(3,)`` or ``(3, ...)``), to rebuild
        the ball's path, and so the fly's walk, from the servos' encoders."""
        w = finite_array("wheel_speeds", wheel_speeds)
        if w.ndim == 0 or w.shape[0] != 3:
            raise KinematicsValueError(f"wheel_speeds must have 3 rows, got shape {w.shape}")
        return np.asarray(np.tensordot(self.inverse, w, axes=1), dtype=np.float64)


def camera_to_motor(dx: npt.ArrayLike, dy: npt.ArrayLike,
                    angle: float) -> tuple[FloatArray, FloatArray]:
    """Rotate a camera-frame vector by ``angle`` (rad) into the motors' frame, as Listing 1
    does with ``thm`` = 20 deg before applying ``J1M``::

        dxm = cos(thm) dx - sin(thm) dy
        dym = sin(thm) dx + cos(thm) dy

    The heading error needs no rotation (the listing's ``dthm = dth``): a rotation about the
    ball's axis is the same in both frames.
    """
    if not math.isfinite(angle):
        raise KinematicsValueError(f"angle must be finite, got {angle!r}")
    x, y = finite_array("dx", dx), finite_array("dy", dy)
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y, s * x + c * y



#: Which of the camera's image axes (x, y, and the sense of rotation) run against the ball's
#: surface motion in the motors' frame. The thesis does not say; this is the one under which
#: Listing 1's signs bring the fly back, as they did on the rig (tests/sim/test_ball.py shows
#: another drives the fly away). The treadmill world and the analysis both take it from here.
CAMERA_HANDEDNESS = (-1, -1, 1)


def surface_in_camera(velocity: npt.ArrayLike, geometry: AotGeometry,
                      handedness: tuple[int, int, int] = CAMERA_HANDEDNESS) -> FloatArray:
    """The ball's surface motion under the fly, ``(x, y, theta)`` in the motors' frame (as
    :meth:`AotKinematics.ball_velocity` gives it; shape ``(3,)`` or ``(3, ...)``), in the
    camera's image frame: turned back by ``camera_to_motor`` and signed by ``handedness``."""
    v = finite_array("velocity", velocity)
    if v.ndim == 0 or v.shape[0] != 3:
        raise KinematicsValueError(f"velocity must have 3 rows, got shape {v.shape}")
    a = -geometry.camera_to_motor
    c, s = math.cos(a), math.sin(a)
    hx, hy, hz = handedness
    return np.stack([hx * (c * v[0] - s * v[1]), hy * (s * v[0] + c * v[1]), hz * v[2]])
