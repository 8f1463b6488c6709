"""A planar pose filter: ``(x, y, yaw)`` predicted from wheel odometry, corrected by an absolute
pose sensor (an overhead camera's tracker), as robot_localization's ``ekf_node`` estimates a
ground robot's pose in ``two_d_mode``.

It is the extended Kalman filter of Thrun, Burgard and Fox, *Probabilistic Robotics* (2005),
Table 3.3, with the odometry as the control ``u`` (their EKF localisation's arrangement, ch. 7):

**Prediction.** ``u = (dx, dy, dyaw)`` is the odometry's increment between two of its poses,
in the robot's frame at the first of them (:func:`between`). Applied to the state
``mu = (x, y, yaw)`` in the map frame::

    g(u, mu) = mu (+) u = (x + cos(yaw) dx - sin(yaw) dy,  y + sin(yaw) dx + cos(yaw) dy,
                           yaw + dyaw)
    G = dg/dmu = [[1, 0, -sin(yaw) dx - cos(yaw) dy],     V = dg/du = [[cos, -sin, 0],
                  [0, 1,  cos(yaw) dx - sin(yaw) dy],                  [sin,  cos, 0],
                  [0, 0,  1]]                                          [0,    0,   1]]
    mu' = g(u, mu)      Sigma' = G Sigma G^T + V M V^T

This is the same as taking the odometry's displacement in the ``odom`` frame and rotating it
into the map by ``map -> odom``'s yaw (``yaw - yaw_odom``): ``R(yaw - yaw_odom) R(yaw_odom)
(dx, dy) = R(yaw) (dx, dy)``. ``M`` is the odometry's noise in the robot's frame, grown by how
far the robot went, how far it turned, and how long it took (:class:`PoseFilterConfig`):
wheel odometry's error grows with distance and rotation (slip, a wheel's radius, the wheel
separation), and the per-second terms are robot_localization's ``process_noise_covariance``
(scaled by the step's duration there too), which keeps the covariance growing while the robot
stands still with no absolute sensor: nothing vouches for the pose then either.

**Correction.** ``z = (x, y)`` or ``(x, y, yaw)`` with covariance ``Q`` (Thrun's ``Q_t``; the
measurement is linear, ``H`` is rows of the identity)::

    y = z - H mu'  (yaw wrapped)     S = H Sigma' H^T + Q     K = Sigma' H^T S^-1
    mu = mu' + K y (yaw wrapped)     Sigma = (I - K H) Sigma'

computed with a linear solve (no explicit inverse) and the Joseph form
``(I - K H) Sigma' (I - K H)^T + K Q K^T``, equal to Table 3.3's for the optimal gain and
positive semi-definite under rounding. ``y^T S^-1 y`` (the squared Mahalanobis distance) is
kept: robot_localization rejects a measurement when it reaches ``rejection_threshold²``
(its ``pose0_rejection_threshold``, infinite by default), and so does :class:`PoseFilter`.

Yaw is wrapped to ``[-pi, pi]`` after every step, and so is every yaw residual, so a heading
of 179° and a sighting at -179° differ by 2°, not 358°.

Everything here is arrays in, arrays out; :class:`PoseFilter` keeps the state between calls and
leaves it unchanged when it refuses an input (non-finite, wrong shape), as the filters of
:mod:`.kalman` do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .errors import EstimationValueError
from .kalman import _check_covariance

FloatArray = npt.NDArray[np.float64]

X, Y, YAW = 0, 1, 2


def wrap(angle: float) -> float:
    """``angle`` in ``[-pi, pi]`` (IEEE remainder, so exact for angles already in range)."""
    return math.remainder(float(angle), 2.0 * math.pi)


def _pose(name: str, value: npt.ArrayLike) -> FloatArray:
    pose = np.array(value, dtype=np.float64).reshape(-1)
    if pose.shape != (3,):
        raise EstimationValueError(f"{name} must be (x, y, yaw), got shape {np.shape(value)}")
    if not np.all(np.isfinite(pose)):
        raise EstimationValueError(f"{name} must be finite, got {pose.tolist()}")
    return pose


def compose(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """``a (+) b``: the pose ``b``, given in ``a``'s frame, in the frame ``a`` is given in
    (for transforms: ``T_map_odom (+) T_odom_base = T_map_base``)."""
    ax, ay, ayaw = _pose("a", a)
    bx, by, byaw = _pose("b", b)
    c, s = math.cos(ayaw), math.sin(ayaw)
    return np.array([ax + c * bx - s * by, ay + s * bx + c * by, wrap(ayaw + byaw)])


def inverse(a: npt.ArrayLike) -> FloatArray:
    """``a⁻¹``: ``compose(a, inverse(a))`` is the identity ``(0, 0, 0)``."""
    x, y, yaw = _pose("a", a)
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([-c * x - s * y, s * x - c * y, wrap(-yaw)])


def between(a: npt.ArrayLike, b: npt.ArrayLike) -> FloatArray:
    """``a⁻¹ (+) b``: where ``b`` is seen from ``a`` (odometry's increment from pose ``a`` to
    ``b``, in the robot's frame at ``a``)."""
    return compose(inverse(a), b)


@dataclass(frozen=True)
class PoseFilterConfig:
    """The filter's noise values, SI.

    Odometry (the prediction's ``M``, variances added in the robot's frame):

    - ``translation_per_metre`` (m²/m): to x and y, per metre travelled;
    - ``rotation_per_radian`` (rad²/rad): to yaw, per radian turned;
    - ``rotation_per_metre`` (rad²/m): to yaw, per metre travelled (unequal wheels turn a
      robot that drives straight);
    - ``translation_per_second`` (m²/s), ``rotation_per_second`` (rad²/s): per second,
      moving or not, as robot_localization's ``process_noise_covariance``.

    The absolute sensor (the correction's ``Q``): ``position_variance`` (m², each of x and y)
    and ``yaw_variance`` (rad²); ``rejection_threshold`` (Mahalanobis distance, in standard
    deviations; infinite: never reject, robot_localization's default).

    The defaults suit seed 000's base under its overhead camera (``docs/navigation.md``):
    odometry within about 2 cm and 1° per metre, the camera's marker within about a
    centimetre (6 mm pixels) and 3° (``tests/vision/test_overhead.py``).
    """

    translation_per_metre: float = 0.02**2
    rotation_per_radian: float = 0.05**2
    rotation_per_metre: float = 0.02**2
    translation_per_second: float = 1e-5
    rotation_per_second: float = 1e-5
    position_variance: float = 0.01**2
    yaw_variance: float = 0.05**2
    rejection_threshold: float = math.inf

    def __post_init__(self) -> None:
        for name in ("translation_per_metre", "rotation_per_radian", "rotation_per_metre",
                     "translation_per_second", "rotation_per_second"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise EstimationValueError(f"{name} must be a finite number >= 0, got {value!r}")
        for name in ("position_variance", "yaw_variance"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise EstimationValueError(f"{name} must be a finite number > 0, got {value!r}")
        if math.isnan(self.rejection_threshold) or self.rejection_threshold <= 0:
            raise EstimationValueError("rejection_threshold must be > 0 (inf: never reject), "
                                       f"got {self.rejection_threshold!r}")

    def odometry_noise(self, travelled: float, turned: float, dt: float) -> FloatArray:
        """``M``: the noise of an increment that went ``travelled`` m and turned ``turned``
        rad (path lengths, not net) in ``dt`` s, in the robot's frame (diagonal)."""
        for name, value in (("travelled", travelled), ("turned", turned), ("dt", dt)):
            if not (math.isfinite(value) and value >= 0):
                raise EstimationValueError(f"{name} must be a finite number >= 0, got {value!r}")
        translation = self.translation_per_metre * travelled + self.translation_per_second * dt
        rotation = (self.rotation_per_radian * turned + self.rotation_per_metre * travelled
                    + self.rotation_per_second * dt)
        if not (math.isfinite(translation) and math.isfinite(rotation)):
            raise EstimationValueError(f"odometry noise overflows for {travelled!r} m, "
                                       f"{turned!r} rad, {dt!r} s")
        return np.diag([translation, translation, rotation])

    def sensor_covariance(self, with_yaw: bool = True) -> FloatArray:
        """``Q`` of one sighting: ``(x, y, yaw)``, or ``(x, y)`` without ``with_yaw``."""
        variances = [self.position_variance, self.position_variance]
        return np.diag([*variances, self.yaw_variance] if with_yaw else variances)


def predict(mean: npt.ArrayLike, covariance: npt.ArrayLike, increment: npt.ArrayLike,
            noise: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """One prediction (see the module docstring): the state ``mean`` ``(x, y, yaw)`` and its
    ``covariance`` (3x3) moved by the odometry ``increment`` ``(dx, dy, dyaw)`` (robot frame),
    whose ``noise`` ``M`` (3x3, robot frame) is added through ``V``. Returns new arrays."""
    mu = _pose("mean", mean)
    sigma = np.array(covariance, dtype=np.float64)
    _check_covariance("covariance", sigma, 3, definite=False)
    u = _pose("increment", increment)
    m = np.array(noise, dtype=np.float64)
    _check_covariance("odometry noise", m, 3, definite=False)
    return _predict(mu, sigma, u, m)


def _predict(mu: FloatArray, sigma: FloatArray, u: FloatArray, m: FloatArray
             ) -> tuple[FloatArray, FloatArray]:
    """:func:`predict` on inputs already checked."""
    c, s = math.cos(mu[YAW]), math.sin(mu[YAW])
    dx, dy = u[X], u[Y]
    g = np.array([[1.0, 0.0, -s * dx - c * dy],
                  [0.0, 1.0, c * dx - s * dy],
                  [0.0, 0.0, 1.0]])
    v = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    predicted = np.array([mu[X] + c * dx - s * dy, mu[Y] + s * dx + c * dy,
                          wrap(mu[YAW] + u[YAW])])
    return predicted, _symmetric(g @ sigma @ g.T + v @ m @ v.T)


@dataclass(frozen=True, eq=False)
class Correction:
    """One correction's result: the corrected ``mean`` and ``covariance``, and what the
    sighting said beyond the prediction: ``residual`` ``y`` (yaw wrapped), its covariance
    ``S``, the ``gain`` ``K`` and ``mahalanobis²`` ``y^T S^-1 y`` (chi-square with ``len(z)``
    degrees of freedom when the noise values are right)."""

    mean: FloatArray
    covariance: FloatArray
    residual: FloatArray
    innovation_covariance: FloatArray
    gain: FloatArray
    mahalanobis2: float


def correct(mean: npt.ArrayLike, covariance: npt.ArrayLike, measurement: npt.ArrayLike,
            measurement_covariance: npt.ArrayLike) -> Correction:
    """One correction (see the module docstring) with ``measurement`` ``(x, y)`` or
    ``(x, y, yaw)`` in the map frame, of covariance ``measurement_covariance`` (2x2 or 3x3,
    positive definite)."""
    mu = _pose("mean", mean)
    sigma = np.array(covariance, dtype=np.float64)
    _check_covariance("covariance", sigma, 3, definite=False)
    return _correct(mu, sigma, measurement, measurement_covariance)


def _correct(mu: FloatArray, sigma: FloatArray, measurement: npt.ArrayLike,
             measurement_covariance: npt.ArrayLike) -> Correction:
    """:func:`correct` with the state already checked (the sighting is checked here)."""
    z = np.array(measurement, dtype=np.float64).reshape(-1)
    if z.shape not in ((2,), (3,)):
        raise EstimationValueError(f"a sighting is (x, y) or (x, y, yaw), got shape "
                                   f"{np.shape(measurement)}")
    if not np.all(np.isfinite(z)):
        raise EstimationValueError(f"a sighting must be finite, got {z.tolist()}")
    q = np.array(measurement_covariance, dtype=np.float64)
    _check_covariance("sighting covariance", q, z.size, definite=True)
    h = np.eye(z.size, 3)
    residual = z - h @ mu
    if z.size == 3:
        residual[YAW] = wrap(residual[YAW])
    s = _symmetric(h @ sigma @ h.T + q)
    try:
        # K = Sigma H^T S^-1, as the solve S K^T = H Sigma (S and Sigma symmetric)
        gain = np.asarray(np.linalg.solve(s, h @ sigma).T, dtype=np.float64)
        mahalanobis2 = float(residual @ np.linalg.solve(s, residual))
    except np.linalg.LinAlgError as error:
        raise EstimationValueError(f"innovation covariance is singular: {s.tolist()}") \
            from error
    a = np.eye(3) - gain @ h
    corrected = mu + gain @ residual
    corrected[YAW] = wrap(corrected[YAW])
    return Correction(corrected, _symmetric(a @ sigma @ a.T + gain @ q @ gain.T), residual, s,
                      gain, mahalanobis2)


def _symmetric(matrix: FloatArray) -> FloatArray:
    return np.asarray(0.5 * (matrix + matrix.T))


class PoseFilter:
    """The filter's state between calls: :attr:`mean` ``(x, y, yaw)`` in the map frame and its
    :attr:`covariance`, both handed out as read-only copies. A call that refuses its input
    raises :class:`~.errors.EstimationValueError` and leaves the state as it was."""

    def __init__(self, mean: npt.ArrayLike, covariance: npt.ArrayLike,
                 config: PoseFilterConfig | None = None) -> None:
        mu = _pose("initial pose", mean)
        mu[YAW] = wrap(mu[YAW])
        sigma = np.array(covariance, dtype=np.float64)
        _check_covariance("initial covariance", sigma, 3, definite=False)
        self.config = config or PoseFilterConfig()
        self._mean = mu
        self._covariance = _symmetric(sigma)
        #: the last correction, accepted or rejected (None before the first)
        self.last_correction: Correction | None = None

    @property
    def mean(self) -> FloatArray:
        return _read_only(self._mean)

    @property
    def covariance(self) -> FloatArray:
        return _read_only(self._covariance)

    def predict(self, increment: npt.ArrayLike, *, travelled: float | None = None,
                turned: float | None = None, dt: float = 0.0) -> None:
        """Apply the odometry ``increment`` ``(dx, dy, dyaw)`` (robot frame) that took ``dt``
        s; ``travelled`` and ``turned`` are the path lengths it covered (default: the
        increment's own, right when it is one short step)."""
        u = _pose("increment", increment)
        distance = math.hypot(u[X], u[Y]) if travelled is None else travelled
        rotation = abs(u[YAW]) if turned is None else turned
        noise = self.config.odometry_noise(distance, rotation, dt)  # diagonal, >= 0: checked
        # the state was checked when it was made: only the new inputs are
        self._mean, self._covariance = _predict(self._mean, self._covariance, u, noise)

    def correct(self, measurement: npt.ArrayLike,
                measurement_covariance: npt.ArrayLike | None = None) -> bool:
        """Correct with a sighting ``(x, y)`` or ``(x, y, yaw)``, of the configuration's
        covariance unless one is given. Returns False, the state unchanged, when the sighting
        is ``rejection_threshold`` or more standard deviations (Mahalanobis) from the
        prediction."""
        size = np.size(measurement)
        q = (self.config.sensor_covariance(with_yaw=size == 3)
             if measurement_covariance is None else measurement_covariance)
        result = _correct(self._mean, self._covariance, measurement, q)
        self.last_correction = result
        if result.mahalanobis2 >= self.config.rejection_threshold**2:
            return False
        self._mean, self._covariance = result.mean, result.covariance
        return True


def _read_only(array: FloatArray) -> FloatArray:
    out = np.array(array, dtype=np.float64)
    out.setflags(write=False)
    return out
