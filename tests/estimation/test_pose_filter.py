"""The planar pose filter (issue 30): the EKF of Thrun, Burgard and Fox, *Probabilistic
Robotics* (2005), Table 3.3, with odometry's increments as the control, checked against
hand-derived numbers and against Table 3.3's equations written out independently (numerical
Jacobians of the motion written in the odom frame, an explicit inverse for the gain)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from servolab.estimation.errors import EstimationValueError
from servolab.estimation.pose_filter import (
    PoseFilter,
    PoseFilterConfig,
    between,
    compose,
    correct,
    inverse,
    predict,
    wrap,
)


def test_poses_compose_invert_and_wrap() -> None:
    a = np.array([1.0, 2.0, math.radians(170)])
    b = np.array([0.5, -0.25, math.radians(30)])
    ab = compose(a, b)
    # b's origin moved by a: rotated by 170° and shifted; the yaw wraps past 180°
    c, s = math.cos(a[2]), math.sin(a[2])
    assert ab[:2] == pytest.approx([1.0 + c * 0.5 + s * 0.25, 2.0 + s * 0.5 - c * 0.25])
    assert ab[2] == pytest.approx(math.radians(-160))
    assert compose(a, inverse(a)) == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    assert between(a, ab) == pytest.approx(b)
    assert wrap(3 * math.pi / 2) == pytest.approx(-math.pi / 2)


def test_one_prediction_by_hand() -> None:
    """Heading +y (90°), one metre forward in the robot's frame: the robot moves to +y, and
    the yaw's uncertainty becomes x's (a heading error swings the robot sideways).

    G = [[1, 0, -1], [0, 1, 0], [0, 0, 1]] (-sin(yaw) dx = -1, cos(yaw) dx = 0), so
    G Sigma G^T = [[0.01 + 0.03, 0, -0.03], [0, 0.02, 0], [-0.03, 0, 0.03]], plus M (isotropic
    in x and y, so V M V^T = M)."""
    mean = [1.0, 2.0, math.pi / 2]
    sigma = np.diag([0.01, 0.02, 0.03])
    a, b = 0.001, 0.002
    mu, p = predict(mean, sigma, [1.0, 0.0, 0.0], np.diag([a, a, b]))
    assert mu == pytest.approx([1.0, 3.0, math.pi / 2])
    np.testing.assert_allclose(p, [[0.04 + a, 0.0, -0.03],
                                   [0.0, 0.02 + a, 0.0],
                                   [-0.03, 0.0, 0.03 + b]], atol=1e-15)


def test_one_correction_by_hand() -> None:
    """Diagonal Sigma and Q: each axis is the scalar filter, k = s / (s + q)."""
    sigma = np.diag([0.04, 0.01, 0.03])
    q = np.diag([0.01, 0.01, 0.01])
    result = correct([0.0, 0.0, 0.0], sigma, [1.0, 1.0, 0.4], q)
    assert result.mean == pytest.approx([0.8, 0.5, 0.3])  # 0.04/0.05, 0.01/0.02, 0.03/0.04
    np.testing.assert_allclose(result.covariance, np.diag([0.008, 0.005, 0.0075]), atol=1e-15)
    assert result.mahalanobis2 == pytest.approx(1 / 0.05 + 1 / 0.02 + 0.16 / 0.04)


def _motion_in_odom_frame(mean: np.ndarray, odom_before: np.ndarray, odom_after: np.ndarray
                          ) -> np.ndarray:
    """The prediction written the other way round: the odometry's displacement in the odom
    frame, rotated into the map by map -> odom's yaw (the state's yaw minus the odometry's)."""
    a = mean[2] - odom_before[2]
    c, s = math.cos(a), math.sin(a)
    d = odom_after[:2] - odom_before[:2]
    return np.array([mean[0] + c * d[0] - s * d[1], mean[1] + s * d[0] + c * d[1],
                     mean[2] + (odom_after[2] - odom_before[2])])


def _jacobian(f: Callable[[np.ndarray], np.ndarray], x: np.ndarray, h: float = 1e-6
              ) -> np.ndarray:
    columns = []
    for i in range(x.size):
        step = np.zeros_like(x)
        step[i] = h
        columns.append((f(x + step) - f(x - step)) / (2 * h))
    return np.column_stack(columns)


def _one_step_against_table_3_3(rng: np.random.Generator) -> None:
    mean = np.array([*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi)])
    a = rng.normal(size=(3, 3))
    sigma = a @ a.T * 0.01 + np.eye(3) * 1e-3   # correlated, positive definite
    odom_before = np.array([*rng.uniform(-3, 3, 2), rng.uniform(-math.pi, math.pi)])
    odom_after = odom_before + np.array([*rng.normal(0, 0.3, 2), rng.normal(0, 0.2)])
    m = np.diag([*rng.uniform(1e-4, 1e-2, 2), rng.uniform(1e-4, 1e-2)])
    m[0, 1] = m[1, 0] = 0.3 * math.sqrt(m[0, 0] * m[1, 1])  # along/across correlated

    # the control in the robot's frame at odom_before, as the code takes it
    u = between(odom_before, odom_after)
    mu_bar, p_bar = predict(mean, sigma, u, m)

    def of_state(x: np.ndarray) -> np.ndarray:
        return _motion_in_odom_frame(x, odom_before, odom_after)

    def of_control(du: np.ndarray) -> np.ndarray:
        moved = compose(odom_before, u + du)
        moved[2] = odom_before[2] + u[2] + du[2]  # unwrapped, for the derivative
        return _motion_in_odom_frame(mean, odom_before, moved)

    g = _jacobian(of_state, mean)
    v = _jacobian(of_control, np.zeros(3))
    expected_mu = _motion_in_odom_frame(mean, odom_before, odom_after)
    expected_p = g @ sigma @ g.T + v @ m @ v.T
    assert mu_bar[:2] == pytest.approx(expected_mu[:2], abs=1e-12)
    assert wrap(mu_bar[2] - expected_mu[2]) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(p_bar, expected_p, atol=1e-8)

    for rows in (2, 3):
        z = mu_bar[:rows] + rng.normal(0, 0.1, rows)
        q = np.diag(rng.uniform(1e-3, 1e-2, rows))
        h = np.eye(rows, 3)
        k = p_bar @ h.T @ np.linalg.inv(h @ p_bar @ h.T + q)
        innovation = z - h @ mu_bar
        expected_mu = mu_bar + k @ innovation
        expected_p = (np.eye(3) - k @ h) @ p_bar
        result = correct(mu_bar, p_bar, z, q)
        assert result.mean[:2] == pytest.approx(expected_mu[:2], abs=1e-12)
        assert wrap(result.mean[2] - expected_mu[2]) == pytest.approx(0.0, abs=1e-12)
        np.testing.assert_allclose(result.covariance, expected_p, atol=1e-12)
        np.testing.assert_allclose(result.gain, k, atol=1e-12)


def test_predict_and_correct_are_table_3_3() -> None:
    """Thrun et al., Table 3.3: mu' = g(u, mu); Sigma' = G Sigma G^T + R (R = V M V^T, the
    control's noise carried through V = dg/du); K = Sigma' H^T (H Sigma' H^T + Q)^-1;
    mu = mu' + K (z - h(mu')); Sigma = (I - K H) Sigma'. Here g is the odom-frame
    formulation and G, V its central-difference Jacobians, K an explicit inverse: nothing is
    shared with the code under test but the equations (and compose/between, checked
    above, to write the control)."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        _one_step_against_table_3_3(rng)


def test_a_yaw_across_the_cut_is_a_small_correction() -> None:
    """A heading of 179° and a sighting at -179° are 2° apart, not 358°."""
    result = correct([0.0, 0.0, math.radians(179)], np.eye(3) * 0.01, [0.0, 0.0,
                     math.radians(-179)], np.eye(3) * 0.01)
    assert math.degrees(result.residual[2]) == pytest.approx(2.0)
    assert abs(math.degrees(result.mean[2])) == pytest.approx(180.0)


def test_the_covariance_grows_while_only_odometry_speaks_and_shrinks_on_a_sighting() -> None:
    """Its volume (the determinant) grows at every prediction whatever the motion: det G = 1,
    so G Sigma G^T keeps it, and the noise adds to it. On an arc a single variance may shrink
    (the uncertainty ellipse turns with the robot), so the trace is checked, not each one."""
    f = PoseFilter([0.0, 0.0, 0.0], np.diag([1e-4, 1e-4, 1e-3]))
    volumes = [float(np.linalg.det(f.covariance))]
    traces = [float(np.trace(f.covariance))]
    for _ in range(60):  # a circle's arc: 2 cm and 2° a step
        f.predict([0.02, 0.0, math.radians(2)], dt=1 / 30)
        volumes.append(float(np.linalg.det(f.covariance)))
        traces.append(float(np.trace(f.covariance)))
    assert np.all(np.diff(volumes) > 0)
    assert np.all(np.diff(traces) > 0)
    before = f.covariance
    mean = f.mean
    assert f.correct([mean[0] + 0.05, mean[1], mean[2]])
    assert f.mean[0] == pytest.approx(mean[0] + 0.05 * before[0, 0] / (before[0, 0] + 1e-4),
                                      rel=0.2)  # towards the sighting, by about the gain
    assert mean[0] < f.mean[0] < mean[0] + 0.05
    assert np.all(np.diag(f.covariance) < np.diag(before))


def test_standing_still_the_covariance_still_grows_with_time() -> None:
    f = PoseFilter([0.0, 0.0, 0.0], np.zeros((3, 3)))
    f.predict([0.0, 0.0, 0.0], dt=10.0)
    config = PoseFilterConfig()
    np.testing.assert_allclose(np.diag(f.covariance), [config.translation_per_second * 10] * 2
                               + [config.rotation_per_second * 10])


def test_a_sighting_beyond_the_rejection_threshold_changes_nothing() -> None:
    f = PoseFilter([0.0, 0.0, 0.0], np.eye(3) * 1e-4,
                   PoseFilterConfig(rejection_threshold=3.0))
    mean, sigma = f.mean, f.covariance
    assert not f.correct([1.0, 0.0, 0.0])  # 1 m off, sigma ~ 1.4 cm
    assert f.last_correction is not None and f.last_correction.mahalanobis2 > 9
    assert np.array_equal(f.mean, mean) and np.array_equal(f.covariance, sigma)
    assert f.correct([0.01, 0.0, 0.0])


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused_and_changes_nothing(bad: float) -> None:
    f = PoseFilter([1.0, 2.0, 0.5], np.eye(3) * 1e-3)
    mean, sigma = f.mean, f.covariance
    with pytest.raises(EstimationValueError, match="finite"):
        f.predict([0.1, bad, 0.0])
    with pytest.raises(EstimationValueError, match="finite"):
        f.predict([0.1, 0.0, 0.0], dt=bad)
    with pytest.raises(EstimationValueError, match="finite"):
        f.correct([1.0, bad])
    with pytest.raises(EstimationValueError, match="finite"):
        f.correct([1.0, 2.0, 0.5], np.diag([1e-4, bad, 1e-4]))
    assert np.array_equal(f.mean, mean) and np.array_equal(f.covariance, sigma)
    with pytest.raises(EstimationValueError, match="finite"):
        PoseFilter([bad, 0.0, 0.0], np.eye(3))
    with pytest.raises(EstimationValueError):
        PoseFilterConfig(translation_per_metre=bad)


def test_the_state_handed_out_is_read_only() -> None:
    f = PoseFilter([0.0, 0.0, 0.0], np.eye(3))
    with pytest.raises(ValueError):
        f.mean[0] = 1.0
    with pytest.raises(ValueError):
        f.covariance[0, 0] = 1.0


def test_the_covariance_is_consistent_with_the_errors_it_claims() -> None:
    """Monte Carlo: odometry noisy exactly as the filter's model says, a tracker of the
    configured variance every third step. The normalised estimation error squared
    (e^T Sigma^-1 e) averages 3, the state's size, within its chi-square spread for 150 runs
    (3 ± 0.65, 3.2 standard deviations): the filter is neither over- nor under-confident
    (odometry twice as noisy as the filter is told gives about 6)."""
    rng = np.random.default_rng(7)
    config = PoseFilterConfig()
    runs, steps = 150, 15
    u, dt = np.array([0.03, 0.0, math.radians(3.0)]), 0.1
    start = np.sqrt([config.position_variance] * 2 + [config.yaw_variance])
    odometry = np.sqrt(np.diag(config.odometry_noise(0.03, math.radians(3.0), dt)))
    tracker = np.sqrt(np.diag(config.sensor_covariance()))
    nees = []
    for _ in range(runs):
        truth = np.array([0.0, 0.0, 0.0])
        f = PoseFilter(truth + start * rng.normal(size=3), np.diag(start**2), config)
        for k in range(steps):
            truth = compose(truth, u)
            f.predict(u + odometry * rng.normal(size=3), travelled=0.03,
                      turned=math.radians(3.0), dt=dt)
            if k % 3 == 2:
                f.correct(truth + tracker * rng.normal(size=3))
        error = f.mean - truth
        error[2] = wrap(error[2])
        nees.append(float(error @ np.linalg.solve(f.covariance, error)))
    assert np.mean(nees) == pytest.approx(3.0, abs=0.65)
