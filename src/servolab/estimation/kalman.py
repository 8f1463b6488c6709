"""A linear Kalman filter, the process models it is usually run with, and the configuration of
seed 000's Appendix D.4, which fuses wheel odometry with a visual tracker (TLD) per axis.

The filter is n-dimensional: a state ``x`` with covariance ``P``, a process model that gives the
transition ``F(dt)`` and process noise ``Q(dt)`` for the time step the caller passes (so one
filter serves sensors that arrive at irregular times), and any number of named linear
measurement models ``z = H x + v``, ``v ~ N(0, R)``. Each sensor is applied by name as its
measurement arrives; for sensors with independent noise, updating them one after the other is
exactly the same as one update with the stacked model.

Numerics: the gain comes from a linear solve with the innovation covariance ``S`` (never an
explicit inverse), the covariance update uses the Joseph form
``P = (I - K H) P (I - K H)^T + K R K^T``, which stays positive semi-definite even when ``K`` is
not the exact optimal gain (rounding, a poorly conditioned ``S``), and ``P`` is re-symmetrised
after every step so that rounding cannot make it drift asymmetric over thousands of steps.

Seed 000, Appendix D.4 (MATLAB), for each of the two floor axes separately::

    Q = [1.25 0; 0 1.25]    R = [3.782 0; 0 7.491]   (x: odometry, tracker)
                            R = [3.395 0; 0 8.591]   (y: odometry, tracker)
    A = I, C = [1 0; 1 0], Pk = [1 1; 1 1], kal(1) = tld(1)

The model there is **position only**: the estimate ``pred_x`` is a scalar, ``A`` is the identity
(the position is a random walk, no velocity) and both sensors measure the position directly
(``C``'s first column); the second state of its 2x2 matrices is never observed (``C``'s second
column is zero) and never feeds back into the first, so the loop is exactly the scalar filter
with ``Q = 1.25`` per sample, ``P0 = Pk(1,1) = 1`` and the two sensors stacked with
``R = diag(R_odometry, R_tracker)``. :func:`seed_000_filter` builds that filter for both axes at
once (the axes are independent, as the seed has them); the constant-velocity model below is
the usual next step when the motion, not only the sensors, is worth modelling. The seed does
not state units or the sample period: the values are in its (overhead-camera floor)
coordinates, per sample.

D.4 stays here as the seed's algorithm (its tests and ``docs/mobile.md`` check it, and the
fusion node runs it with ``filter: seed_000``). The node's default since issue 30 is the
planar EKF of :mod:`.pose_filter`, which predicts from odometry's increments instead of
taking odometry's position as a measurement: see that module, and the node's docstring for
why.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import numpy.typing as npt

from .errors import EstimationValueError

FloatArray = npt.NDArray[np.float64]

ProcessModel = Callable[[float], tuple[npt.ArrayLike, npt.ArrayLike]]
"""``dt -> (F, Q)``: the transition and the process noise accumulated over ``dt``."""


def _frozen(array: npt.ArrayLike) -> FloatArray:
    out = np.array(array, dtype=np.float64)  # a copy: callers may keep mutating theirs
    out.setflags(write=False)
    return out


def _check_covariance(name: str, matrix: FloatArray, size: int, *, definite: bool) -> None:
    """Square, finite, symmetric, and positive (semi-)definite, or a ValueError saying which."""
    if matrix.shape != (size, size):
        raise EstimationValueError(f"{name} must have shape ({size}, {size}), got {matrix.shape}")
    if not np.all(np.isfinite(matrix)):
        raise EstimationValueError(f"{name} must be finite, got {matrix.tolist()}")
    scale = max(1.0, float(np.max(np.abs(matrix)))) if size else 1.0
    if not np.allclose(matrix, matrix.T, rtol=1e-9, atol=1e-12 * scale):
        raise EstimationValueError(f"{name} must be symmetric, got {matrix.tolist()}")
    if size == 0:
        return
    smallest = float(np.min(np.linalg.eigvalsh(matrix)))
    if definite and smallest <= 0:
        raise EstimationValueError(f"{name} must be positive definite, smallest eigenvalue "
                                   f"{smallest:.6g}")
    if smallest < -1e-12 * scale:
        raise EstimationValueError(
            f"{name} must be positive semi-definite, smallest eigenvalue {smallest:.6g}"
        )


def _per_axis(name: str, values: float | Sequence[float], axes: int) -> FloatArray:
    """One value for every axis, or one per axis; each finite and non-negative."""
    array = np.asarray(values, dtype=np.float64)
    if array.ndim == 0:
        array = np.full(axes, float(array))
    if array.shape != (axes,):
        raise EstimationValueError(f"{name} needs one value or one per axis ({axes}), got "
                                   f"{values!r}")
    if not (np.all(np.isfinite(array)) and np.all(array >= 0)):
        raise EstimationValueError(f"{name} must be finite and non-negative, got {values!r}")
    return array


@dataclass(frozen=True, eq=False)
class MeasurementModel:
    """``z = H x + v`` with ``v ~ N(0, R)``: ``H`` of shape ``(m, n)``, ``R`` of ``(m, m)``.

    ``R`` must be positive definite: a sensor claiming zero noise would make the innovation
    covariance singular as soon as the state is known along that direction.
    """

    H: FloatArray
    R: FloatArray

    def __post_init__(self) -> None:
        h = _frozen(self.H)
        r = _frozen(self.R)
        if h.ndim == 1:
            h = _frozen(h[np.newaxis, :])
        if h.ndim != 2:
            raise EstimationValueError(f"H must be a matrix (m, n), got shape {h.shape}")
        if not np.all(np.isfinite(h)):
            raise EstimationValueError(f"H must be finite, got {h.tolist()}")
        if r.ndim == 0:
            r = _frozen(r.reshape(1, 1))
        _check_covariance("R", r, h.shape[0], definite=True)
        object.__setattr__(self, "H", h)
        object.__setattr__(self, "R", r)

    @property
    def size(self) -> int:
        """``m``, the length of one measurement."""
        return int(self.H.shape[0])


def position_sensor(variances: float | Sequence[float], state_size: int,
                    axes: int | None = None) -> MeasurementModel:
    """A sensor that reads the first ``axes`` states directly (the positions, in the layouts of
    :class:`RandomWalk` and :class:`ConstantVelocity`), with independent noise of the given
    variance per axis. ``axes`` defaults to the number of variances given."""
    k = axes if axes is not None else int(np.size(variances))
    if not 0 < k <= state_size:
        raise EstimationValueError(f"a position sensor needs 1..{state_size} axes, got {k}")
    r = _per_axis("sensor variance", variances, k)
    if np.any(r <= 0):
        raise EstimationValueError(f"sensor variances must be positive, got {variances!r}")
    return MeasurementModel(np.eye(k, state_size), np.diag(r))


@dataclass(frozen=True)
class RandomWalk:
    """Position only: ``x_{k+1} = x_k + w``, ``F = I``, ``Q = rate * dt`` per axis.

    The model of seed 000's D.4. The variance grows linearly with time, as a Wiener process does,
    so ``rate`` is the process variance per unit of ``dt`` (per sample when ``dt`` counts
    samples, as the seed's ``Q = 1.25`` does).
    """

    axes: int
    rate: float | tuple[float, ...]

    def __post_init__(self) -> None:
        if self.axes < 1:
            raise EstimationValueError(f"a random walk needs at least one axis, got {self.axes}")
        _per_axis("random-walk rate", self.rate, self.axes)

    @property
    def state_size(self) -> int:
        return self.axes

    def __call__(self, dt: float) -> tuple[FloatArray, FloatArray]:
        rate = _per_axis("random-walk rate", self.rate, self.axes)
        return np.eye(self.axes), np.diag(rate * dt)


@dataclass(frozen=True)
class ConstantVelocity:
    """Position and velocity for ``axes`` axes, state ``[p_1..p_k, v_1..v_k]``.

    Between updates each axis moves at constant velocity and is pushed by white acceleration
    noise of power spectral density ``acceleration_psd`` (units²/s³ when ``dt`` is in seconds).
    Integrating that noise over ``dt`` gives the exact discrete ``Q`` per axis::

        F = [[1, dt], [0, 1]]      Q = q * [[dt³/3, dt²/2], [dt²/2, dt]]

    which, unlike the piecewise-constant ``G G^T`` form, stays consistent whatever the step.
    """

    axes: int
    acceleration_psd: float | tuple[float, ...]

    def __post_init__(self) -> None:
        if self.axes < 1:
            raise EstimationValueError("a constant-velocity model needs at least one axis, got "
                                       f"{self.axes}")
        _per_axis("acceleration PSD", self.acceleration_psd, self.axes)

    @property
    def state_size(self) -> int:
        return 2 * self.axes

    def __call__(self, dt: float) -> tuple[FloatArray, FloatArray]:
        k = self.axes
        q = np.diag(_per_axis("acceleration PSD", self.acceleration_psd, k))
        eye = np.eye(k)
        f = np.block([[eye, dt * eye], [np.zeros((k, k)), eye]])
        noise = np.block([[q * dt**3 / 3, q * dt**2 / 2], [q * dt**2 / 2, q * dt]])
        return f, noise


@dataclass(frozen=True, eq=False)
class Innovation:
    """What one measurement said beyond the prediction, kept for gating and diagnostics.

    ``residual`` is ``y = z - H x⁻``, ``covariance`` is ``S = H P⁻ H^T + R``, ``gain`` is
    ``K = P⁻ H^T S⁻¹`` and ``nis`` the normalised innovation squared ``y^T S⁻¹ y``, which is
    chi-square with ``m`` degrees of freedom when the filter's noise values are right.
    """

    sensor: str
    residual: FloatArray
    covariance: FloatArray
    gain: FloatArray
    nis: float


class KalmanFilter:
    """A linear Kalman filter over a state of size ``n``.

    ``process`` gives ``(F, Q)`` for a time step; ``sensors`` maps names to measurement models.
    The filter owns copies of ``x0`` and ``P0``; :attr:`state` and :attr:`covariance` hand out
    read-only copies so a caller cannot corrupt it between steps.
    """

    def __init__(self, x0: npt.ArrayLike, P0: npt.ArrayLike, process: ProcessModel,
                 sensors: Mapping[str, MeasurementModel]) -> None:
        x = np.array(x0, dtype=np.float64).reshape(-1)
        if not np.all(np.isfinite(x)):
            raise EstimationValueError(f"initial state must be finite, got {x.tolist()}")
        p = np.array(P0, dtype=np.float64)
        if p.ndim == 0:
            p = p * np.eye(x.size)
        _check_covariance("P0", p, x.size, definite=False)
        for name, model in sensors.items():
            if not isinstance(model, MeasurementModel):
                raise EstimationValueError(f"sensor {name!r} must be a MeasurementModel, got "
                                           f"{model!r}")
            if model.H.shape[1] != x.size:
                raise EstimationValueError(
                    f"sensor {name!r} has H of shape {model.H.shape}, "
                    f"the state has {x.size} entries"
                )
        self._x = x
        self._P = p
        self._process = process
        self._sensors: Mapping[str, MeasurementModel] = MappingProxyType(dict(sensors))
        self.last_innovation: Innovation | None = None

    @property
    def state(self) -> FloatArray:
        """The current estimate ``x`` (a read-only copy)."""
        return _frozen(self._x)

    @property
    def covariance(self) -> FloatArray:
        """The current covariance ``P`` (a read-only copy, symmetric)."""
        return _frozen(self._P)

    @property
    def sensors(self) -> Mapping[str, MeasurementModel]:
        return self._sensors

    @property
    def size(self) -> int:
        return int(self._x.size)

    def predict(self, dt: float) -> None:
        """Advance ``dt`` (finite, not negative): ``x = F x``, ``P = F P F^T + Q``."""
        if not (np.isfinite(dt) and dt >= 0):
            raise EstimationValueError(f"dt must be a finite, non-negative time step, got {dt}")
        f_raw, q_raw = self._process(float(dt))
        f = np.asarray(f_raw, dtype=np.float64)
        q = np.asarray(q_raw, dtype=np.float64)
        n = self.size
        if f.shape != (n, n) or not np.all(np.isfinite(f)):
            raise EstimationValueError(f"process model gave F of shape {f.shape} "
                                       f"(finite ({n}, {n}) needed)")
        _check_covariance("Q", q, n, definite=False)
        self._x = f @ self._x
        self._P = _symmetric(f @ self._P @ f.T + q)

    def innovation(self, name: str, z: npt.ArrayLike) -> Innovation:
        """The innovation of measurement ``z`` from sensor ``name``, without updating."""
        model = self._sensor(name)
        measurement = np.asarray(z, dtype=np.float64).reshape(-1) if np.ndim(z) <= 1 else None
        if measurement is None or measurement.shape != (model.size,):
            raise EstimationValueError(
                f"sensor {name!r} measures {model.size} values, got shape {np.shape(z)}"
            )
        if not np.all(np.isfinite(measurement)):
            raise EstimationValueError(
                f"sensor {name!r} gave a non-finite measurement {measurement.tolist()}"
            )
        h = model.H
        residual = measurement - h @ self._x
        s = _symmetric(h @ self._P @ h.T + model.R)
        try:
            # K = P H^T S^-1, as the solve S K^T = H P (S and P symmetric)
            gain = np.linalg.solve(s, h @ self._P).T
            nis = float(residual @ np.linalg.solve(s, residual))
        except np.linalg.LinAlgError as error:
            raise EstimationValueError(
                f"innovation covariance of {name!r} is singular: {s.tolist()}"
            ) from error
        return Innovation(name, _frozen(residual), _frozen(s), _frozen(gain), nis)

    def update(self, name: str, z: npt.ArrayLike) -> Innovation:
        """Correct the estimate with measurement ``z`` from sensor ``name`` (Joseph form).

        Returns the :class:`Innovation` (also kept as :attr:`last_innovation`). Raises
        ValueError for an unknown sensor, a measurement of the wrong length or a NaN/inf
        measurement, leaving the filter unchanged.
        """
        innovation = self.innovation(name, z)
        model = self._sensors[name]
        k = innovation.gain
        a = np.eye(self.size) - k @ model.H
        self._x = self._x + k @ innovation.residual
        self._P = _symmetric(a @ self._P @ a.T + k @ model.R @ k.T)
        self.last_innovation = innovation
        return innovation

    def _sensor(self, name: str) -> MeasurementModel:
        try:
            return self._sensors[name]
        except KeyError:
            known = ", ".join(repr(key) for key in self._sensors) or "none"
            raise EstimationValueError(f"unknown sensor {name!r} (known: {known})") from None


def _symmetric(matrix: FloatArray) -> FloatArray:
    return np.asarray(0.5 * (matrix + matrix.T))


# --- seed 000, Appendix D.4 ---------------------------------------------------------------------

ODOMETRY = "odometry"
TRACKER = "tracker"
ODOMETRY_AND_TRACKER = "odometry+tracker"
"""The seed's own stacked update, ``C = [1; 1]`` per axis: ``z = [odometry, tracker]``."""


@dataclass(frozen=True)
class Seed000Fusion:
    """The noise values of seed 000's D.4, per axis ``(x, y)``, in the seed's units per sample.

    ``process_variance`` is ``Q = 1.25`` (both axes), ``odometry_variance`` and
    ``tracker_variance`` the diagonal of ``R``: x ``[3.782, 7.491]``, y ``[3.395, 8.591]``;
    ``initial_variance`` is ``Pk(1,1) = 1``. ``sample_period`` is the ``dt`` that stands for one
    of the seed's samples (the seed states no rate), so ``predict(sample_period)`` adds exactly
    ``Q``.
    """

    process_variance: tuple[float, float] = (1.25, 1.25)
    odometry_variance: tuple[float, float] = (3.782, 3.395)
    tracker_variance: tuple[float, float] = (7.491, 8.591)
    initial_variance: float = 1.0
    sample_period: float = 1.0

    def __post_init__(self) -> None:
        _per_axis("process variance", self.process_variance, 2)
        for name in ("odometry_variance", "tracker_variance"):
            values = _per_axis(name, getattr(self, name), 2)
            if np.any(values <= 0):
                raise EstimationValueError(f"{name} must be positive, got {getattr(self, name)!r}")
        if not (np.isfinite(self.initial_variance) and self.initial_variance >= 0):
            raise EstimationValueError("initial_variance must be >= 0, got "
                                       f"{self.initial_variance}")
        if not (np.isfinite(self.sample_period) and self.sample_period > 0):
            raise EstimationValueError(f"sample_period must be positive, got {self.sample_period}")


SEED_000_FUSION = Seed000Fusion()


def seed_000_filter(initial_position: npt.ArrayLike,
                    config: Seed000Fusion = SEED_000_FUSION) -> KalmanFilter:
    """The filter of seed 000's D.4 for both floor axes: state ``[x, y]``, a random walk with
    ``Q = diag(1.25, 1.25)`` per sample, and sensors ``"odometry"`` (``R = diag(3.782, 3.395)``),
    ``"tracker"`` (``R = diag(7.491, 8.591)``) and ``"odometry+tracker"`` (the seed's stacked
    update, ``z = [odo_x, odo_y, tld_x, tld_y]``). The seed starts from the tracker's first
    sample with ``P = 1``.

    Position only, as the seed has it: see the module docstring for why its 2x2 matrices reduce
    to this.
    """
    rate = tuple(np.asarray(config.process_variance, dtype=np.float64) / config.sample_period)
    process = RandomWalk(2, tuple(float(r) for r in rate))
    odometry = position_sensor(config.odometry_variance, 2)
    tracker = position_sensor(config.tracker_variance, 2)
    stacked = MeasurementModel(
        np.vstack([odometry.H, tracker.H]),
        np.diag(np.concatenate([np.diag(odometry.R), np.diag(tracker.R)])),
    )
    sensors = {ODOMETRY: odometry, TRACKER: tracker, ODOMETRY_AND_TRACKER: stacked}
    return KalmanFilter(initial_position, config.initial_variance, process, sensors)


def fuse_seed_000(odometry: npt.ArrayLike, tracker: npt.ArrayLike,
                  config: Seed000Fusion = SEED_000_FUSION) -> FloatArray:
    """D.4's loop over whole recordings: ``odometry`` and ``tracker`` of shape ``(N, 2)``
    (x, y per sample) give the fused track ``(N, 2)``; its first row is the tracker's first
    sample, as ``kal_x(1,1) = tld_x_exp1(1,1)`` has it, and every later sample is one predict
    and one stacked update with both sensors."""
    odo = np.asarray(odometry, dtype=np.float64)
    tld = np.asarray(tracker, dtype=np.float64)
    if odo.ndim != 2 or odo.shape[1] != 2 or tld.shape != odo.shape:
        raise EstimationValueError(
            f"odometry and tracker must both have shape (N, 2), got {odo.shape} and {tld.shape}"
        )
    out = np.empty_like(odo)
    if len(odo) == 0:
        return out
    kf = seed_000_filter(tld[0], config)
    out[0] = kf.state
    for i in range(1, len(odo)):
        kf.predict(config.sample_period)
        kf.update(ODOMETRY_AND_TRACKER, np.concatenate([odo[i], tld[i]]))
        out[i] = kf.state
    return out
