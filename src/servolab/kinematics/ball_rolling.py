"""Seed 002's treadmill ball as a rigid body rolling on its three omni-wheels: the ball's
motion from the wheels' speeds by the no-slip constraint, rather than by eq. (3b).

Why a second model: :mod:`servolab.kinematics.aot` keeps the thesis's eq. (3b)-(3d), which
the controller (Listing 1's ``J1M``) and the analysis use as the thesis does. Eq. (3c) is not
the rolling constraint, though (aot.py's module docstring): it has the form of that map's
transpose, and at the rig's 40 deg its wheel speeds for a turn about the ball's axis are 2.9
times too small against those for a translation (so, read the other way, it has the ball
turn 2.9 times too much for its translation). A simulated ball that moved by (3b) itself
would hide that from every closed-loop run. This module is the physics the simulator uses
instead.

The model. The ball turns about its fixed centre with angular velocity ``omega``; the point
``R_k`` where wheel ``k`` touches it (:func:`~servolab.kinematics.aot.contact_points`) moves
at ``omega x R_k``. An omni-wheel drives that point along its rim's direction ``d_k``
(:func:`drive_directions`, horizontal, tangent to the ball) and its free rollers let it slide
across, so each wheel gives one equation (no slip along ``d_k``; seed 002 section 3.1 assumes
"no slip exists between the omni-directional wheels and the sphere")::

    (omega x R_k) . d_k = (R_k x d_k) . omega = (1 - slip) * rho * w_k,    k = 1, 2, 3

with ``rho`` the wheel's radius and ``w_k`` its angular speed (rad/s): three equations, three
unknowns. ``slip`` is a stated fraction of each rim speed that the contact does not pass on
(0: none). The fly walks on the top of the ball, ``-ball_radius * z``, so the surface under
it moves at ``omega x (-ball_radius z)``.

Frame, as aot.py's: ``x`` horizontal towards wheel 1, ``z`` along the ball's axis from its
centre towards the wheels (down), ``y = z x x``. The surface velocity under the fly is
returned as eq. (3b)'s ``X' = (x', y', theta')`` (m/s, m/s, rad/s), in the motors' frame as
:meth:`~servolab.kinematics.aot.AotKinematics.ball_velocity` returns it::

    x' = -ball_radius * omega_y,   y' = ball_radius * omega_x,   theta' = omega_z

A wheel's positive direction ``d_k`` is the one under which a positive ``w_k`` moves ``X'``
the way eq. (3b)'s ``J`` says it does, for the translations and the rotation alike, so that
Listing 1's signs still bring the fly back (tests/kinematics/test_ball_rolling.py checks the
signs against (3b) wheel by wheel). For three wheels 120 deg apart the two models then
differ only in scale: the rolling ball translates ``1 / (1.5 sin(tilt)^3)`` (2.51 at 40 deg)
and turns ``rho / (3 ball_radius sin(tilt) cos(tilt)^2)`` (0.87) times as fast as (3b) says,
whose ratio is aot.py's 2.886.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from servolab.kinematics.aot import AotGeometry, _checked_condition, contact_points
from servolab.kinematics.dh import FloatArray
from servolab.kinematics.diffdrive import finite_array
from servolab.kinematics.errors import KinematicsValueError


def _readonly(array: FloatArray) -> FloatArray:
    array.setflags(write=False)
    return array


def _check_geometry(geometry: object) -> AotGeometry:
    if not isinstance(geometry, AotGeometry):
        raise KinematicsValueError(f"geometry must be an AotGeometry, got {geometry!r}")
    return geometry


def check_slip(slip: object) -> float:
    """``slip`` as a float in [0, 1): the fraction of each wheel's rim speed that the contact
    loses. 1 would pass nothing on (the ball would not move at all), so it is refused."""
    if isinstance(slip, bool) or not isinstance(slip, (int, float, np.integer, np.floating)) \
            or not (0.0 <= float(slip) < 1.0):
        raise KinematicsValueError(f"slip must be a number in [0, 1), got {slip!r}")
    return float(slip)


def _three_rows(name: str, values: npt.ArrayLike) -> FloatArray:
    """``values`` as a finite float array of shape ``(3,)`` or ``(3, ...)``."""
    try:
        array = finite_array(name, values)
    except (TypeError, ValueError) as error:
        if isinstance(error, KinematicsValueError):
            raise
        raise KinematicsValueError(f"{name} must be numbers, got {values!r}") from None
    if array.ndim == 0 or array.shape[0] != 3:
        raise KinematicsValueError(f"{name} must have 3 rows, got shape {array.shape}")
    return array


def drive_directions(geometry: AotGeometry) -> FloatArray:
    """Row ``k``: ``d_k``, the unit direction in which wheel ``k``'s rim moves at its contact
    point when the wheel turns positively: ``(sin a_k, -cos a_k, 0)`` for the wheel at
    azimuth ``a_k`` (``wheel_angles``).

    Horizontal and tangent to the ball: the wheel's axle lies in the plane through the ball's
    axis and the contact, at ``tilt`` to the axis (seed 002 section 3), so at the contact its
    rim runs round the axis. The sign is eq. (3b)'s (see the module docstring)."""
    a = np.asarray(_check_geometry(geometry).wheel_angles, dtype=np.float64)
    return np.stack([np.sin(a), -np.cos(a), np.zeros(3)], axis=1)


def rolling_matrix(geometry: AotGeometry) -> FloatArray:
    """The no-slip constraint as a matrix ``A`` (m): row ``k`` is ``R_k x d_k``, so that
    ``A @ omega`` is each contact's surface speed along its wheel's rim (m/s), which rolling
    without slip makes equal to the rim's speed ``rho * w_k``.

    Refused (:class:`~servolab.kinematics.aot.AotGeometryError`) when the three rows are
    (nearly) dependent: then some ball motion needs no wheel and the wheels cannot fix
    ``omega``, e.g. contacts at the equator (``tilt`` -> 0, every row vertical) or at the
    pole (``tilt`` -> pi/2, every row horizontal)."""
    normals = np.cross(contact_points(_check_geometry(geometry)), drive_directions(geometry))
    # condition numbers are scale-free: judge the dimensionless matrix (rows over the radius)
    _checked_condition(f"rolling constraint of {geometry!r}", normals / geometry.ball_radius)
    return np.asarray(normals, dtype=np.float64)


def surface_matrix(geometry: AotGeometry) -> FloatArray:
    """``S`` with ``S @ omega = X' = (x', y', theta')``: the surface under the fly (the top of
    the ball, ``-ball_radius z``) moves at ``omega x (-ball_radius z)`` =
    ``ball_radius * (-omega_y, omega_x, 0)``, and ``theta'`` is the spin about the axis."""
    rb = _check_geometry(geometry).ball_radius
    return np.array([[0.0, -rb, 0.0], [rb, 0.0, 0.0], [0.0, 0.0, 1.0]])


def ball_angular_velocity(geometry: AotGeometry, wheel_speeds: npt.ArrayLike,
                          slip: float = 0.0) -> FloatArray:
    """The ball's angular velocity ``omega`` (rad/s, aot.py's frame; shape ``(3,)``, or
    ``(3, ...)`` for ``(3, ...)`` wheel speeds) that the three wheels turning at
    ``wheel_speeds`` (rad/s, in ``wheel_angles`` order) give it when each contact passes on
    ``1 - slip`` of its rim speed: the solution of ``A omega = (1 - slip) rho w``
    (:func:`rolling_matrix`)."""
    return RollingBall.from_geometry(geometry, slip).angular_velocity(wheel_speeds)


def surface_velocity(geometry: AotGeometry, omega: npt.ArrayLike) -> FloatArray:
    """``X' = (x', y', theta')`` (m/s, m/s, rad/s) of the surface under the fly for the
    ball's angular velocity ``omega`` (shape ``(3,)`` or ``(3, ...)``), in the convention of
    :meth:`~servolab.kinematics.aot.AotKinematics.ball_velocity`."""
    return np.asarray(np.tensordot(surface_matrix(geometry), _three_rows("omega", omega),
                                   axes=1), dtype=np.float64)


def rolling_ball_velocity(geometry: AotGeometry, wheel_speeds: npt.ArrayLike,
                          slip: float = 0.0) -> FloatArray:
    """``X'`` of the rolling ball (:func:`surface_velocity` of
    :func:`ball_angular_velocity`): what eq. (3b)'s ``ball_velocity`` claims to give."""
    return RollingBall.from_geometry(geometry, slip).ball_velocity(wheel_speeds)


@dataclass(frozen=True, eq=False)
class RollingBall:
    """The rolling ball's maps from wheel speeds, solved once for a geometry and slip so that
    a simulator stepping at 1 kHz does not solve a 3x3 system every step.

    :meth:`ball_velocity` has :meth:`~servolab.kinematics.aot.AotKinematics.ball_velocity`'s
    signature and meaning, so either model can drive :class:`~servolab.sim.ball.BallWorld`."""

    geometry: AotGeometry
    slip: float = 0.0
    #: wheel speeds (rad/s) to ``omega`` (rad/s)
    to_omega: FloatArray = field(init=False, repr=False)
    #: wheel speeds (rad/s) to ``X'`` (m/s, m/s, rad/s)
    to_surface: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        geometry = _check_geometry(self.geometry)
        slip = check_slip(self.slip)
        object.__setattr__(self, "slip", slip)
        rim = (1.0 - slip) * geometry.wheel_radius * np.eye(3)
        to_omega = np.asarray(np.linalg.solve(rolling_matrix(geometry), rim), dtype=np.float64)
        object.__setattr__(self, "to_omega", _readonly(to_omega))
        object.__setattr__(self, "to_surface",
                           _readonly(np.asarray(surface_matrix(geometry) @ to_omega,
                                                dtype=np.float64)))

    @classmethod
    def from_geometry(cls, geometry: AotGeometry, slip: float = 0.0) -> RollingBall:
        """The same as the constructor; named like ``AotKinematics.from_geometry``."""
        return cls(geometry, slip)

    def angular_velocity(self, wheel_speeds: npt.ArrayLike) -> FloatArray:
        """``omega`` (rad/s) for ``wheel_speeds`` (rad/s), shape ``(3,)`` or ``(3, ...)``."""
        w = _three_rows("wheel_speeds", wheel_speeds)
        return np.asarray(np.tensordot(self.to_omega, w, axes=1), dtype=np.float64)

    def ball_velocity(self, wheel_speeds: npt.ArrayLike) -> FloatArray:
        """``X' = (x', y', theta')`` of the surface under the fly for ``wheel_speeds``."""
        w = _three_rows("wheel_speeds", wheel_speeds)
        return np.asarray(np.tensordot(self.to_surface, w, axes=1), dtype=np.float64)

