"""The linear Kalman filter, its process models and seed 000's odometry + TLD fusion (D.4)."""

from __future__ import annotations

import numpy as np
import pytest

from servolab.estimation.kalman import (
    ODOMETRY,
    ODOMETRY_AND_TRACKER,
    SEED_000_FUSION,
    TRACKER,
    ConstantVelocity,
    KalmanFilter,
    MeasurementModel,
    RandomWalk,
    Seed000Fusion,
    fuse_seed_000,
    position_sensor,
    seed_000_filter,
)


def rmse(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Root mean square of the 2-D position error."""
    return float(np.sqrt(np.mean(np.sum((estimate - truth) ** 2, axis=1))))


def circle_run(seed: int = 0, samples: int = 1471) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A robot driving one circle of radius 50 in the seed's 1471 samples (exp1's length):
    the truth, odometry that drifts (a random-walk bias, 0.05 per sample, plus white noise of
    standard deviation 1) and a tracker with white noise of D.4's tracker variances."""
    rng = np.random.default_rng(seed)
    angle = 2 * np.pi * np.arange(samples) / (samples - 1)
    truth = np.column_stack([50 * np.cos(angle), 50 * np.sin(angle)])
    drift = np.cumsum(rng.normal(0.0, 0.05, (samples, 2)), axis=0)
    odometry = truth + drift + rng.normal(0.0, 1.0, (samples, 2))
    tracker_sd = np.sqrt(SEED_000_FUSION.tracker_variance)
    tracker = truth + rng.normal(0.0, 1.0, (samples, 2)) * tracker_sd
    return truth, odometry, tracker


def test_seed_000_fusion_beats_either_sensor() -> None:
    """On the simulated circle (rng seed 0) the fused track of D.4 has an RMSE of 1.63 against
    2.39 for the drifting odometry and 4.06 for the noisy tracker alone."""
    truth, odometry, tracker = circle_run()
    fused = fuse_seed_000(odometry, tracker)
    numbers = rmse(odometry, truth), rmse(tracker, truth), rmse(fused, truth)
    message = "RMSE odometry {:.3f}, tracker {:.3f}, fused {:.3f}".format(*numbers)
    assert numbers[2] < 0.75 * min(numbers[:2]), message
    assert numbers == pytest.approx((2.394, 4.065, 1.627), abs=5e-3), message


def matlab_d4(odo: np.ndarray, tld: np.ndarray, q: float, r: tuple[float, float]) -> np.ndarray:
    """Seed 000's D.4 loop for one axis, transcribed literally, 2x2 matrices and all."""
    Q = np.diag([q, q])
    R = np.diag(r)
    A = np.eye(2)
    Pk = np.ones((2, 2))
    C = np.array([[1.0, 0.0], [1.0, 0.0]])
    out = np.empty(len(odo))
    out[0] = tld[0]
    for i in range(1, len(odo)):
        pred = out[i - 1]
        Pk = A @ Pk @ A.T + Q
        G = Pk @ C.T @ np.linalg.inv(C @ Pk @ C.T + R)
        Z = np.array([[odo[i], 0.0], [tld[i], 0.0]])
        out[i] = (pred + G @ (Z - C * pred))[0, 0]
        Pk = (np.eye(2) - G @ C) @ Pk
    return out


def test_seed_000_filter_is_the_seed_loop() -> None:
    """The position-only filter reproduces D.4's 2x2 MATLAB loop sample for sample, on both
    axes with their own R (the dummy second state of the seed changes nothing)."""
    _, odometry, tracker = circle_run(seed=3, samples=200)
    fused = fuse_seed_000(odometry, tracker)
    x = matlab_d4(odometry[:, 0], tracker[:, 0], 1.25, (3.782, 7.491))
    y = matlab_d4(odometry[:, 1], tracker[:, 1], 1.25, (3.395, 8.591))
    np.testing.assert_allclose(fused, np.column_stack([x, y]), rtol=0, atol=1e-10)


def test_sequential_updates_equal_the_stacked_update() -> None:
    """Independent sensors: odometry then tracker is the same as D.4's stacked update."""
    a = seed_000_filter([1.0, 2.0])
    b = seed_000_filter([1.0, 2.0])
    for kf in (a, b):
        kf.predict(1.0)
    a.update(ODOMETRY, [1.5, 2.5])
    a.update(TRACKER, [0.5, 3.0])
    b.update(ODOMETRY_AND_TRACKER, [1.5, 2.5, 0.5, 3.0])
    np.testing.assert_allclose(a.state, b.state, atol=1e-12)
    np.testing.assert_allclose(a.covariance, b.covariance, atol=1e-12)


def test_seed_000_defaults_are_d4() -> None:
    kf = seed_000_filter([0.0, 0.0])
    np.testing.assert_allclose(kf.covariance, np.eye(2))
    np.testing.assert_allclose(kf.sensors[ODOMETRY].R, np.diag([3.782, 3.395]))
    np.testing.assert_allclose(kf.sensors[TRACKER].R, np.diag([7.491, 8.591]))
    kf.predict(SEED_000_FUSION.sample_period)
    np.testing.assert_allclose(kf.covariance, np.diag([2.25, 2.25]))
    slow = seed_000_filter([0.0, 0.0], Seed000Fusion(sample_period=0.1))
    slow.predict(0.1)
    np.testing.assert_allclose(slow.covariance, np.diag([2.25, 2.25]))


def test_static_state_converges_to_the_mean_with_variance_r_over_n() -> None:
    """A constant with a nearly uninformative prior: after n measurements the estimate is their
    mean and its variance r / n, the sample mean's."""
    rng = np.random.default_rng(1)
    r = 4.0
    kf = KalmanFilter([0.0], 1e12, RandomWalk(1, 0.0), {"s": position_sensor(r, 1)})
    values = 7.0 + rng.normal(0.0, 2.0, 400)
    for n, z in enumerate(values, start=1):
        kf.predict(1.0)
        kf.update("s", [z])
        if n in (1, 10, 100, 400):
            assert kf.state[0] == pytest.approx(values[:n].mean(), rel=1e-9, abs=1e-9)
            assert kf.covariance[0, 0] == pytest.approx(r / n, rel=1e-9)
    assert kf.state[0] == pytest.approx(7.0, abs=3 * np.sqrt(r / 400))


def test_constant_velocity_matrices() -> None:
    f, q = ConstantVelocity(2, (3.0, 5.0))(0.5)
    np.testing.assert_allclose(f[:2, 2:], 0.5 * np.eye(2))
    np.testing.assert_allclose(np.diag(f), 1.0)
    np.testing.assert_allclose(q[0, 0], 3.0 * 0.5**3 / 3)
    np.testing.assert_allclose(q[1, 3], 5.0 * 0.5**2 / 2)
    np.testing.assert_allclose(q[3, 3], 5.0 * 0.5)
    np.testing.assert_allclose(q, q.T)


def test_constant_velocity_recovers_the_velocity_from_positions() -> None:
    """Position sensors only; the velocity is inferred, and P stays symmetric and positive."""
    rng = np.random.default_rng(2)
    velocity = np.array([0.3, -0.2])
    kf = KalmanFilter(np.zeros(4), 100.0, ConstantVelocity(2, 1e-4),
                      {"pos": position_sensor(0.25, 4, axes=2)})
    for step in range(1, 301):
        kf.predict(0.1)
        kf.update("pos", velocity * 0.1 * step + rng.normal(0.0, 0.5, 2))
    np.testing.assert_allclose(kf.state[2:], velocity, atol=0.05)
    p = kf.covariance
    np.testing.assert_array_equal(p, p.T)
    assert np.min(np.linalg.eigvalsh(p)) > 0


def test_innovation_is_reported() -> None:
    kf = KalmanFilter([1.0], 2.0, RandomWalk(1, 0.0), {"s": position_sensor(3.0, 1)})
    peek = kf.innovation("s", [4.0])
    np.testing.assert_allclose(kf.state, [1.0])  # innovation() does not update
    result = kf.update("s", [4.0])
    assert kf.last_innovation is result
    np.testing.assert_allclose(peek.residual, [3.0])
    np.testing.assert_allclose(result.covariance, [[5.0]])
    np.testing.assert_allclose(result.gain, [[0.4]])
    assert result.nis == pytest.approx(9.0 / 5.0)
    np.testing.assert_allclose(kf.state, [2.2])
    np.testing.assert_allclose(kf.covariance, [[1.2]])


def test_state_and_covariance_are_read_only_copies() -> None:
    kf = seed_000_filter([1.0, 2.0])
    with pytest.raises(ValueError):
        kf.state[0] = 5.0
    assert kf.state is not kf.state


@pytest.mark.parametrize("z", [[np.nan, 0.0], [0.0, np.inf], [-np.inf, 1.0]])
def test_non_finite_measurements_are_refused(z: list[float]) -> None:
    kf = seed_000_filter([1.0, 2.0])
    kf.predict(1.0)
    before = kf.state, kf.covariance
    with pytest.raises(ValueError, match="non-finite"):
        kf.update(TRACKER, z)
    np.testing.assert_array_equal(kf.state, before[0])
    np.testing.assert_array_equal(kf.covariance, before[1])


@pytest.mark.parametrize("z", [[1.0], [1.0, 2.0, 3.0], [[1.0, 2.0]], 1.0])
def test_wrong_measurement_size_is_refused(z: object) -> None:
    kf = seed_000_filter([1.0, 2.0])
    with pytest.raises(ValueError, match="measures 2 values"):
        kf.update(ODOMETRY, z)  # type: ignore[arg-type]


def test_dimension_mismatches_are_refused() -> None:
    with pytest.raises(ValueError, match="H of shape"):
        KalmanFilter([0.0, 0.0], 1.0, RandomWalk(2, 1.0), {"s": position_sensor(1.0, 3)})
    with pytest.raises(ValueError, match="P0 must have shape"):
        KalmanFilter([0.0, 0.0], np.eye(3), RandomWalk(2, 1.0), {})
    with pytest.raises(ValueError, match="R must have shape"):
        MeasurementModel(np.eye(2), np.eye(3))
    with pytest.raises(ValueError, match="positive definite"):
        MeasurementModel(np.eye(2), np.diag([1.0, 0.0]))
    with pytest.raises(ValueError, match="symmetric"):
        MeasurementModel(np.eye(2), np.array([[1.0, 0.5], [0.0, 1.0]]))
    kf = KalmanFilter([0.0, 0.0], 1.0, RandomWalk(3, 1.0), {})
    with pytest.raises(ValueError, match="F of shape"):
        kf.predict(1.0)
    with pytest.raises(ValueError, match="unknown sensor 'gps'"):
        seed_000_filter([0.0, 0.0]).update("gps", [0.0, 0.0])


@pytest.mark.parametrize("dt", [-0.1, np.nan, np.inf])
def test_bad_time_steps_are_refused(dt: float) -> None:
    with pytest.raises(ValueError, match="dt must be"):
        seed_000_filter([0.0, 0.0]).predict(dt)


def test_bad_configuration_is_refused() -> None:
    with pytest.raises(ValueError, match="tracker_variance"):
        Seed000Fusion(tracker_variance=(7.491, 0.0))
    with pytest.raises(ValueError, match="non-negative"):
        RandomWalk(2, -1.0)
    with pytest.raises(ValueError, match="one per axis"):
        ConstantVelocity(2, (1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match=r"shape \(N, 2\)"):
        fuse_seed_000(np.zeros((5, 2)), np.zeros((4, 2)))
