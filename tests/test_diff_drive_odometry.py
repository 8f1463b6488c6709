"""ros2_controllers' diff_drive_controller (ROS 2 Jazzy) odometry and speed limiter, as
servolab.kinematics.diff_drive_odometry and servolab.kinematics.speed_limiter.

Expected values come from closed forms (a circle's arc, a step's travel), from
scipy.integrate.solve_ivp of the unicycle, or by hand from the law the sources state. Each
test names the source that states the behaviour: ros2_controllers branch ``jazzy``
(diff_drive_controller/...), control_toolbox branch ``jazzy`` (control_toolbox/...), rcpputils
branch ``jazzy``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from servolab.kinematics.diff_drive_odometry import (
    DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE,
    EXACT_INTEGRATION_THRESHOLD,
    MIN_UPDATE_INTERVAL,
    DiffDriveOdometry,
    RollingMean,
    WheelGeometry,
    WheelParams,
    integrate_step,
    wheel_velocity_commands,
)
from servolab.kinematics.diffdrive import DiffDrive, WheelMove, moves_pose, wheel_speeds
from servolab.kinematics.errors import KinematicsValueError
from servolab.kinematics.speed_limiter import (
    ResolvedBounds,
    SpeedLimiter,
    SpeedLimits,
    limit_names,
)

# diff_drive_controller/test/config/test_diff_drive_controller.yaml: separation 0.40 m; its
# radius 0.02 m, here 0.05 m so that the wheels turn less per metre.
PARAMS = WheelParams(0.40, 0.05, 0.05)


def odometry(params: WheelParams = PARAMS, window: int = 10) -> DiffDriveOdometry:
    return DiffDriveOdometry(params, window)


# -- defaults and the multipliers ---------------------------------------------------------------

def test_defaults() -> None:
    """odometry.hpp: ``Odometry(size_t velocity_rolling_window_size = 10)``;
    diff_drive_controller_parameter.yaml: ``velocity_rolling_window_size`` default 10;
    odometry.cpp: ``dt < 0.0001`` and ``fabs(angular) < 1e-6``."""
    assert DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE == 10
    assert DiffDriveOdometry(PARAMS).velocity_rolling_window_size == 10
    assert MIN_UPDATE_INTERVAL == 1e-4
    assert EXACT_INTEGRATION_THRESHOLD == 1e-6
    odom = DiffDriveOdometry(PARAMS)
    assert odom.pose == (0.0, 0.0, 0.0)
    assert (odom.linear, odom.angular, odom.timestamp) == (0.0, 0.0, 0.0)


def test_multipliers_scale_the_geometry_and_the_wheel_commands() -> None:
    """diff_drive_controller.cpp, on_configure and update_and_write_commands:
    ``wheel_separation_multiplier * wheel_separation``, ``left_wheel_radius_multiplier *
    wheel_radius``, ``right_wheel_radius_multiplier * wheel_radius``, and
    ``velocity_left = (linear - angular * wheel_separation / 2) / left_wheel_radius`` (right
    with +); multipliers default to 1.0 in diff_drive_controller_parameter.yaml."""
    assert WheelGeometry(0.4, 0.05).wheel_params() == WheelParams(0.4, 0.05, 0.05)
    params = WheelGeometry(0.4, 0.05, wheel_separation_multiplier=1.1,
                           left_wheel_radius_multiplier=0.9,
                           right_wheel_radius_multiplier=1.2).wheel_params()
    assert params.wheel_separation == pytest.approx(0.44, abs=1e-15)
    assert params.left_wheel_radius == pytest.approx(0.045, abs=1e-15)
    assert params.right_wheel_radius == pytest.approx(0.06, abs=1e-15)
    left, right = wheel_velocity_commands(1.0, 0.5, params)
    assert left == pytest.approx((1.0 - 0.5 * 0.44 / 2) / 0.045, rel=1e-14)
    assert right == pytest.approx((1.0 + 0.5 * 0.44 / 2) / 0.06, rel=1e-14)
    # equal radii: diffdrive's wheel_speeds, which the helper reuses
    expected = wheel_speeds(1.0, 0.5, DiffDrive(0.05, 0.4))
    assert wheel_velocity_commands(1.0, 0.5, PARAMS) == pytest.approx(
        (float(expected[0]), float(expected[1])), rel=1e-14)


@pytest.mark.parametrize("bad", [0.0, -1.0, math.nan, math.inf])
def test_geometry_refuses_non_positive_values(bad: float) -> None:
    """diff_drive_controller_parameter.yaml validates ``wheel_separation`` and ``wheel_radius``
    with ``gt<>: [0.0]``; a zero multiplier would divide the wheel commands by zero."""
    with pytest.raises(KinematicsValueError, match="wheel_separation"):
        WheelParams(bad, 0.05, 0.05)
    with pytest.raises(KinematicsValueError, match="right_wheel_radius"):
        WheelParams(0.4, 0.05, bad)
    with pytest.raises(KinematicsValueError, match="left_wheel_radius"):
        WheelGeometry(0.4, 0.05, left_wheel_radius_multiplier=bad)


# -- integration --------------------------------------------------------------------------------

def test_integrate_step_switches_from_runge_kutta_to_the_exact_arc_at_1e_6() -> None:
    """odometry.cpp ``integrateExact``: ``fabs(angular) < 1e-6`` takes
    ``integrateRungeKutta2`` (a chord of length ``ds`` along the mid heading), otherwise the
    exact arc ``r = ds / dheading``. With ds = 1e6 m the two differ by ds * dheading^2 / 24
    (~3e-8 m), far above the rounding of either, so the branch taken shows."""
    ds = 1.0e6
    below = 0.9e-6
    x, y, h = integrate_step(0.0, 0.0, 0.0, ds, below)
    assert abs(x - ds * math.cos(below / 2)) < 1e-9
    assert abs(x - (ds / below) * math.sin(below)) > 1e-8   # not the arc
    assert (y, h) == (pytest.approx(ds * math.sin(below / 2)), below)
    above = 1.1e-6
    x, _, _ = integrate_step(0.0, 0.0, 0.0, ds, above)
    arc_x = (ds / above) * math.sin(above)
    assert abs(x - arc_x) < 1e-9
    assert abs(x - ds * math.cos(above / 2)) > 1e-8         # not Runge-Kutta


def test_integrate_step_half_circle_and_straight_line() -> None:
    """odometry.cpp ``integrateExact``: a left half circle of radius R started facing +y
    (heading pi/2) ends 2R towards -x, facing -y; with no turn the step is straight."""
    r = 0.7
    x, y, h = integrate_step(1.0, 2.0, math.pi / 2, math.pi * r, math.pi)
    assert (x, y, h) == (pytest.approx(1.0 - 2 * r, abs=1e-15), pytest.approx(2.0, abs=1e-15),
                         pytest.approx(1.5 * math.pi))
    assert integrate_step(1.0, 2.0, 0.0, 3.0, 0.0) == (4.0, 2.0, 0.0)


# -- updates from wheel positions ---------------------------------------------------------------

def test_straight_line_from_wheel_positions() -> None:
    """odometry.cpp ``update``: wheel position times radius, difference from the last, then
    ``updateFromVelocity``: linear = mean of the two increments, angular = 0 (Runge-Kutta
    branch); the speed is the increment over dt."""
    odom = odometry()
    dt, step = 0.01, 2.0                      # rad per update on both wheels
    for k in range(1, 51):
        assert odom.update(k * step, k * step, k * dt)
    assert odom.x == pytest.approx(50 * step * 0.05, rel=1e-14)
    assert (odom.y, odom.heading) == (0.0, 0.0)
    assert odom.linear == pytest.approx(step * 0.05 / dt, rel=1e-12)
    assert odom.angular == 0.0


def test_arc_from_wheel_positions_is_a_circles_arc() -> None:
    """odometry.cpp ``update`` + ``integrateExact`` (exact branch): constant wheel speeds
    trace a circle of radius v / omega, x = R sin(omega t), y = R (1 - cos(omega t)), whatever
    the step length. Different left and right radii (multipliers) as on_configure applies
    them in diff_drive_controller.cpp."""
    params = WheelGeometry(0.4, 0.05, left_wheel_radius_multiplier=0.9,
                           right_wheel_radius_multiplier=1.1).wheel_params()
    w_left, w_right = 6.0, 9.0                                 # rad/s
    v_left, v_right = w_left * params.left_wheel_radius, w_right * params.right_wheel_radius
    v = (v_left + v_right) / 2
    omega = (v_right - v_left) / params.wheel_separation
    radius = v / omega
    odom = odometry(params)
    dt = 0.25                                                  # coarse: 0.36 rad per step
    for k in range(1, 41):
        t = k * dt
        assert odom.update(w_left * t, w_right * t, t)
        assert odom.x == pytest.approx(radius * math.sin(omega * t), abs=1e-12)
        assert odom.y == pytest.approx(radius * (1 - math.cos(omega * t)), abs=1e-12)
        assert odom.heading == pytest.approx(omega * t, rel=1e-13)
    assert odom.linear == pytest.approx(v, rel=1e-12)
    assert odom.angular == pytest.approx(omega, rel=1e-12)
    # the same arcs as diffdrive's exact-arc odometry (one radius there: use the mean radius)
    same = WheelParams(0.4, 0.05, 0.05)
    odom2 = odometry(same)
    odom2.update(10.0 * w_left, 10.0 * w_right, 10.0)               # one 3.75 rad arc
    expected = moves_pose((0, 0, 0), [WheelMove(w_left, w_right, 10.0)], DiffDrive(0.05, 0.4))
    assert odom2.pose == pytest.approx(tuple(expected), abs=1e-12)


def _unicycle_command(t: float) -> tuple[float, float]:
    return 0.3 + 0.2 * math.sin(t), 0.8 * math.cos(0.7 * t)


def test_varying_command_matches_solve_ivp() -> None:
    """odometry.cpp ``update`` over 5 s at 1 kHz of wheel positions whose speeds vary
    (v = 0.3 + 0.2 sin t, omega = 0.8 cos 0.7t): the pose follows the unicycle
    x' = v cos(theta), y' = v sin(theta), theta' = omega integrated by scipy's solve_ivp."""
    half = PARAMS.wheel_separation / 2
    r = PARAMS.left_wheel_radius

    def travel(t: float) -> tuple[float, float]:
        # s(t) = int v = 0.3 t + 0.2 (1 - cos t); heading(t) = int omega = (0.8/0.7) sin 0.7t
        return 0.3 * t + 0.2 * (1 - math.cos(t)), (0.8 / 0.7) * math.sin(0.7 * t)

    def wheel_angles(t: float) -> tuple[float, float]:
        s, turned = travel(t)
        return (s - half * turned) / r, (s + half * turned) / r

    def unicycle(t: float, q: np.ndarray) -> list[float]:
        v, omega = _unicycle_command(t)
        return [v * math.cos(q[2]), v * math.sin(q[2]), omega]

    times = np.linspace(0.0, 5.0, 5001)
    truth = solve_ivp(unicycle, (0.0, 5.0), [0.0, 0.0, 0.0], t_eval=times[1000::1000],
                      rtol=1e-11, atol=1e-12).y.T
    odom = odometry()
    poses = []
    for k, t in enumerate(times[1:], start=1):
        assert odom.update(*wheel_angles(float(t)), float(t))
        if k % 1000 == 0:
            poses.append(odom.pose)
    # each step is an arc of constant curvature: O(dt^2) error per second over 5 s
    np.testing.assert_allclose(np.array(poses), truth, atol=2e-6)
    # the rolling mean of the last 10 steps is the mean speed over [4.99, 5]
    (s1, h1), (s0, h0) = travel(5.0), travel(4.99)
    assert odom.linear == pytest.approx((s1 - s0) / 0.01, rel=1e-9)
    assert odom.angular == pytest.approx((h1 - h0) / 0.01, rel=1e-9)
    # which lags the command by half a window (5 ms)
    v, omega = _unicycle_command(5.0 - 5e-3)
    assert (odom.linear, odom.angular) == pytest.approx((v, omega), abs=1e-5)


def test_too_small_an_interval_changes_nothing() -> None:
    """odometry.cpp ``update``: ``if (dt < 0.0001) return false;`` before the old positions
    are stored, so the next accepted update integrates the whole travel since the last."""
    odom = odometry()
    assert odom.update(1.0, 1.0, 1.0)
    before = odom.pose, odom.linear, odom.timestamp
    assert not odom.update(3.0, 3.0, 1.0 + 0.9e-4)
    assert not odom.update(3.0, 3.0, 0.5)                      # time going backwards
    assert (odom.pose, odom.linear, odom.timestamp) == before
    assert odom.update(3.0, 3.0, 1.0 + 1e-3)
    assert odom.x == pytest.approx(3.0 * 0.05, rel=1e-14)
    assert odom.linear == pytest.approx(
        np.mean([1.0 * 0.05 / 1.0, 2.0 * 0.05 / 1e-3]), rel=1e-9)


def test_first_update_counts_from_position_zero_and_reset_keeps_positions() -> None:
    """odometry.cpp: the constructor sets ``left_wheel_old_pos_`` and ``timestamp_`` to 0, so
    the first update's step is the wheels' absolute travel; ``resetOdometry`` zeroes x, y and
    heading only (diff_drive_controller.cpp ``reset`` calls it), so the next step is the
    increment since the last update, not the travel since zero."""
    odom = odometry()
    assert odom.update(100.0, 100.0, 2.0)
    assert odom.x == pytest.approx(5.0, rel=1e-14)             # 100 rad * 0.05 m at once
    assert odom.linear == pytest.approx(5.0 / 2.0, rel=1e-14)  # divided by time since 0.0 s
    odom.reset_odometry()
    assert odom.pose == (0.0, 0.0, 0.0)
    assert odom.update(101.0, 101.0, 2.1)
    assert odom.x == pytest.approx(0.05, rel=1e-12)
    assert odom.linear == pytest.approx((2.5 + 0.5) / 2, rel=1e-12)  # rolling means kept


def test_init_restarts_the_speed_estimate() -> None:
    """odometry.cpp ``init``: resets the accumulators and sets the timestamp."""
    odom = odometry()
    odom.update(100.0, 100.0, 2.0)
    odom.init(10.0)
    assert odom.timestamp == 10.0
    odom.update(102.0, 102.0, 10.5)
    assert odom.linear == pytest.approx(2.0 * 0.05 / 0.5, rel=1e-13)


# -- the rolling mean ---------------------------------------------------------------------------

def test_rolling_mean() -> None:
    """rcpputils include/rcpputils/rolling_mean_accumulator.hpp, values as in rcpputils'
    test/test_accumulator.cpp ``TestAccumulator.test_accumulator``: window 4, the mean is over
    the values held until the window fills, then over the last 4."""
    mean = RollingMean(4)
    expected = [1.0, 1.0, 7 / 3, 12 / 4, 16 / 4, 20 / 4]
    for value, want in zip([1.0, 1.0, 5.0, 5.0, 5.0, 5.0], expected, strict=True):
        mean.accumulate(value)
        assert mean.mean() == pytest.approx(want, abs=1e-12)
    assert (len(mean), mean.window) == (4, 4)
    with pytest.raises(KinematicsValueError, match="no value"):
        RollingMean(3).mean()
    for bad in (0, -1, 2.0, True):
        with pytest.raises(KinematicsValueError, match="window"):
            RollingMean(bad)  # type: ignore[arg-type]


def test_odometry_speed_is_the_rolling_mean_of_the_last_window_steps() -> None:
    """odometry.cpp ``updateFromVelocity``: each update accumulates ``linear / dt`` and
    ``angular / dt``; ``linear_`` and ``angular_`` are the rolling means."""
    odom = odometry(window=3)
    dt = 0.02
    position, samples = 0.0, []
    for k, step in enumerate([1.0, 2.0, 4.0, 8.0, 16.0], start=1):   # rad per update
        position += step
        odom.update(position, position, k * dt)
        samples.append(step * 0.05 / dt)
        assert odom.linear == pytest.approx(np.mean(samples[-3:]), rel=1e-12)
    odom.set_velocity_rolling_window_size(2)                          # empties the means
    odom.update(position + 1.0, position + 1.0, 6 * dt)
    assert odom.linear == pytest.approx(1.0 * 0.05 / dt, rel=1e-12)
    assert odom.velocity_rolling_window_size == 2


# -- updates from wheel velocities and open loop ------------------------------------------------

def test_update_from_velocity_matches_update_from_positions() -> None:
    """diff_drive_controller.cpp, ``position_feedback: false``:
    ``updateFromVelocity(left_feedback_mean * left_wheel_radius * period, ...)``; with
    period = dt this is the same step as ``update`` from the integrated positions."""
    by_velocity, by_position = odometry(), odometry()
    w_left, w_right, dt = 3.0, 5.0, 0.01
    for k in range(1, 101):
        t = k * dt
        assert by_velocity.update_from_velocity(w_left, w_right, t)
        assert by_position.update(w_left * t, w_right * t, t)
    assert by_velocity.pose == pytest.approx(by_position.pose, abs=1e-12)
    assert by_velocity.linear == pytest.approx(by_position.linear, rel=1e-9)
    assert by_velocity.angular == pytest.approx(by_position.angular, rel=1e-9)
    v = (w_left + w_right) * 0.05 / 2
    omega = (w_right - w_left) * 0.05 / 0.4
    assert by_velocity.linear == pytest.approx(v, rel=1e-9)
    assert by_velocity.angular == pytest.approx(omega, rel=1e-9)


def test_update_from_velocity_uses_the_period_for_travel_and_dt_for_speed() -> None:
    """diff_drive_controller.cpp multiplies by the controller's ``period``; odometry.cpp
    divides the step by ``dt = time - timestamp_``: if the two differ, so do travel and
    speed. Too small an interval still refuses the update (``dt < 0.0001``)."""
    odom = odometry()
    assert odom.update_from_velocity(4.0, 4.0, 0.01, period=0.02)
    assert odom.x == pytest.approx(4.0 * 0.05 * 0.02, rel=1e-14)
    assert odom.linear == pytest.approx(4.0 * 0.05 * 0.02 / 0.01, rel=1e-13)
    assert not odom.update_from_velocity(4.0, 4.0, 0.01 + 5e-5, period=0.02)
    assert odom.update_from_increments(0.1, 0.1, 0.03)
    assert odom.x == pytest.approx(4.0 * 0.05 * 0.02 + 0.1, rel=1e-14)


def test_open_loop_integrates_the_command_and_reports_it() -> None:
    """diff_drive_controller/test/test_diff_drive_controller.cpp
    ``test_open_loop_odometry_with_unclamped_input`` (odometry.cpp ``updateOpenLoop``): 5 m/s
    for 0.1 s gives x = 0.5 and linear 5; then 5 rad/s for 0.1 s gives heading 0.5 and
    angular 5, the command itself rather than a rolling mean."""
    odom = odometry()
    odom.update_open_loop(5.0, 0.0, 0.1)
    assert (odom.x, odom.linear) == (pytest.approx(0.5), 5.0)
    odom.update_open_loop(0.0, 5.0, 0.2)
    assert (odom.heading, odom.angular, odom.linear) == (pytest.approx(0.5), 5.0, 0.0)
    assert odom.x == pytest.approx(0.5)
    # no minimum interval in updateOpenLoop: a zero dt integrates nothing but stores the twist
    odom.update_open_loop(1.0, 1.0, 0.2)
    assert (odom.heading, odom.linear) == (pytest.approx(0.5), 1.0)


def test_open_loop_uses_the_limited_command() -> None:
    """diff_drive_controller/test/test_diff_drive_controller.cpp
    ``test_open_loop_odometry_with_clamped_input``: with ``linear.x.max_velocity`` and
    ``angular.z.max_velocity`` 0.5, commands of 5 give x = 0.05 and heading = 0.05 after
    0.1 s each (the limiter runs before ``updateOpenLoop``, CHANGELOG 4.39.0)."""
    linear = SpeedLimiter(SpeedLimits(max_velocity=0.5))
    angular = SpeedLimiter(SpeedLimits(max_velocity=0.5))
    odom = odometry()
    v, _ = linear.limit(5.0, 0.0, 0.0, 0.1)
    w, _ = angular.limit(0.0, 0.0, 0.0, 0.1)
    odom.update_open_loop(v, w, 0.1)
    assert (odom.linear, odom.x) == (0.5, pytest.approx(0.05))
    v, _ = linear.limit(0.0, 0.5, 0.0, 0.1)
    w, _ = angular.limit(5.0, 0.0, 0.0, 0.1)
    odom.update_open_loop(v, w, 0.2)
    assert (odom.angular, odom.heading) == (0.5, pytest.approx(0.05))


def test_non_finite_inputs_are_refused() -> None:
    """Where the C++ would make the pose NaN for good (diff_drive_controller.cpp refuses NaN
    feedback itself, returning ERROR, before it reaches the odometry)."""
    odom = odometry()
    with pytest.raises(KinematicsValueError, match="left_pos"):
        odom.update(math.nan, 0.0, 1.0)
    with pytest.raises(KinematicsValueError, match="time"):
        odom.update(0.0, 0.0, math.inf)
    with pytest.raises(KinematicsValueError, match="angular"):
        odom.update_open_loop(0.0, math.nan, 1.0)
    assert odom.pose == (0.0, 0.0, 0.0)
    assert odom.timestamp == 0.0


# -- the speed limiter --------------------------------------------------------------------------

NAN = math.nan


def test_limits_default_to_nan_and_nan_means_no_limit() -> None:
    """diff_drive_controller_parameter.yaml: every ``linear.x.*`` / ``angular.z.*`` limit
    defaults to ``.NAN``; control_toolbox/test/rate_limiter.cpp ``RateLimiterTest.testNoLimits``
    and the last block of ``testValueNoLimits``: nothing is limited, the factor is 1."""
    limiter = SpeedLimiter()
    assert limiter.bounds == ResolvedBounds(None, None, None, None, None)
    assert limiter.limit(10.0, 0.0, 0.0, 0.5) == (10.0, 1.0)
    assert limiter.limit(-10.0, 0.0, 0.0, 0.5) == (-10.0, 1.0)
    assert limit_names("angular.z") == (
        "angular.z.min_velocity", "angular.z.max_velocity", "angular.z.max_acceleration_reverse",
        "angular.z.max_acceleration", "angular.z.max_deceleration",
        "angular.z.max_deceleration_reverse", "angular.z.min_jerk", "angular.z.max_jerk")


def test_velocity_limits() -> None:
    """control_toolbox/include/control_toolbox/rate_limiter.hpp ``limit_value`` (clamp) and
    ``set_params`` (min NaN: -max); control_toolbox/test/rate_limiter.cpp
    ``RateLimiterTest.testValueLimits``: 10 -> 1.0 (factor 0.1), -10 -> -0.5 (0.05)."""
    limiter = SpeedLimiter(SpeedLimits(min_velocity=-0.5, max_velocity=1.0))
    assert limiter.limit_velocity(10.0) == (1.0, 0.1)
    assert limiter.limit_velocity(-10.0) == (-0.5, 0.05)
    symmetric = SpeedLimiter(SpeedLimits(max_velocity=1.0))
    assert symmetric.limit(-10.0, -5.0, -5.0, 1.0) == (-1.0, 0.1)


def test_acceleration_limits_from_rest() -> None:
    """rate_limiter.hpp ``limit_first_derivative`` at v0 == 0 uses
    [min_first_derivative_neg, max_first_derivative_pos] = [max_acceleration_reverse,
    max_acceleration] (speed_limiter.hpp's argument order); control_toolbox/test/
    rate_limiter.cpp ``RateLimiterTest.testFirstDerivativeLimits``: 10 -> 1.0 * 0.5 = 0.5,
    -10 -> -0.5 * 0.5 = -0.25, the acceleration limiting before the velocity can."""
    limiter = SpeedLimiter(SpeedLimits(-0.5, 1.0, -0.5, 1.0, NAN, NAN, -2.0, 5.0))
    assert limiter.limit_acceleration(10.0, 0.0, 0.5) == (0.5, 0.05)
    assert limiter.limit(10.0, 0.0, 0.0, 0.5) == (0.5, 0.05)
    assert limiter.limit(-10.0, 0.0, 0.0, 0.5) == (-0.25, 0.025)


def test_acceleration_limits_asymmetric() -> None:
    """rate_limiter.hpp: forward (v0 > 0) [max_deceleration, max_acceleration], reverse
    (v0 < 0) [max_acceleration_reverse, max_deceleration_reverse];
    control_toolbox/test/rate_limiter.cpp ``RateLimiterTest.testFirstDerivativeLimitsAsymmetric``
    (the factor keeps its sign; a zero result gives 0)."""
    limiter = SpeedLimiter(SpeedLimits(-0.5, 1.0, -0.5, 1.0, -5.0, 10.0, -0.5, 5.0))
    assert limiter.limit_acceleration(10.0, 5.0, 0.5) == (5.5, 0.55)
    assert limiter.limit_acceleration(-10.0, 5.0, 0.5) == (2.5, -0.25)
    assert limiter.limit_acceleration(10.0, -5.0, 0.5) == (0.0, 0.0)
    assert limiter.limit_acceleration(-10.0, -5.0, 0.5) == (-5.25, 0.525)


def test_unset_reverse_deceleration_falls_back_to_max_acceleration() -> None:
    """rate_limiter.hpp ``set_params``: ``max_first_derivative_neg`` (max_deceleration_reverse)
    NaN becomes ``max_first_derivative_pos`` (max_acceleration), and
    ``min_first_derivative_pos`` (max_deceleration) NaN becomes ``min_first_derivative_neg``.
    diff_drive_controller_parameter.yaml says "-max_deceleration will be used": the code
    wins. By hand: max_acceleration 2, max_deceleration -4, v0 = -1, v = 0, dt = 0.1: the
    step is clamped to [-0.2, 0.2], so -0.8 (not -0.6)."""
    limiter = SpeedLimiter(SpeedLimits(max_acceleration=2.0, max_deceleration=-4.0))
    assert limiter.bounds.forward == (-4.0, 2.0)
    assert limiter.bounds.reverse == (-2.0, 2.0)
    assert limiter.bounds.from_rest == (-2.0, 2.0)
    assert limiter.limit(0.0, -1.0, -1.0, 0.1)[0] == pytest.approx(-0.8, abs=1e-15)
    only = SpeedLimiter(SpeedLimits(max_acceleration=1.0))
    assert only.bounds.forward == only.bounds.reverse == only.bounds.from_rest == (-1.0, 1.0)


def test_a_group_without_its_max_is_off() -> None:
    """rate_limiter.hpp ``set_params``: only a NaN ``max_*`` turns a group off (then its
    other members are ignored); control_toolbox/test/rate_limiter.cpp
    ``RateLimiterTest.testWrongParams`` accepts ``min`` set with ``max`` NaN."""
    limiter = SpeedLimiter(SpeedLimits(min_velocity=-1.0, max_acceleration_reverse=-1.0,
                                       max_deceleration=-1.0, max_deceleration_reverse=1.0,
                                       min_jerk=-1.0))
    assert limiter.bounds == ResolvedBounds(None, None, None, None, None)
    assert limiter.limit(-10.0, 3.0, -3.0, 0.1) == (-10.0, 1.0)


def test_jerk_limits() -> None:
    """rate_limiter.hpp ``limit_second_derivative``: ``v = v0 + dv0 + clamp(dv - dv0,
    min_jerk dt^2, max_jerk dt^2)``; control_toolbox/test/rate_limiter.cpp
    ``RateLimiterTest.testValueNoLimits`` (third block): max_jerk 5, min_jerk -0.5, dt 0.5:
    10 -> 1.25, -10 -> -0.125; and ``testSecondDerivativeLimits``: jerk first, then the
    acceleration (-10 -> -0.25 by jerk, already within -0.5 * 0.5)."""
    jerk_only = SpeedLimiter(SpeedLimits(min_jerk=-0.5, max_jerk=5.0))
    assert jerk_only.limit(10.0, 0.0, 0.0, 0.5) == (1.25, 0.125)
    assert jerk_only.limit(-10.0, 0.0, 0.0, 0.5) == (-0.125, 0.0125)
    both = SpeedLimiter(SpeedLimits(-0.5, 1.0, -0.5, 1.0, NAN, NAN, -1.0, 1.0))
    assert both.limit_jerk(10.0, 0.0, 0.0, 0.5) == (0.25, 0.025)
    assert both.limit(10.0, 0.0, 0.0, 0.5) == (0.25, 0.025)
    assert both.limit(-10.0, 0.0, 0.0, 0.5) == (-0.25, 0.025)


def test_jerk_is_limited_only_while_the_acceleration_grows() -> None:
    """rate_limiter.hpp: ``if ((dv - dv0) * (v - v0) > 0)`` (control_toolbox issue 240). By
    hand, max_jerk 1, dt 0.5 (da in [-0.25, 0.25]), v1 = 0, v0 = 1 (dv0 = 1): v = 1.5 means
    dv = 0.5, a shrinking acceleration, left alone; v = 3 means dv = 2, growing, limited to
    1 + 1 + 0.25 = 2.25; v = 0.5 (dv = -0.5, dv - dv0 = -1.5 < 0, product > 0) is limited
    to 1 + 1 - 0.25 = 1.75."""
    limiter = SpeedLimiter(SpeedLimits(max_jerk=1.0))
    assert limiter.limit(1.5, 1.0, 0.0, 0.5) == (1.5, 1.0)
    assert limiter.limit(3.0, 1.0, 0.0, 0.5) == (2.25, 0.75)
    assert limiter.limit(0.5, 1.0, 0.0, 0.5) == (1.75, 3.5)


def test_factor_of_a_zero_command_is_one() -> None:
    """rate_limiter.hpp: ``tmp != 0 ? v / tmp : 1.0``, even when the zero was changed."""
    limiter = SpeedLimiter(SpeedLimits(max_acceleration=1.0))
    assert limiter.limit(0.0, 1.0, 1.0, 0.1) == (pytest.approx(0.9), 1.0)


def test_controller_step_sequence_reaches_each_target_on_time() -> None:
    """diff_drive_controller/test/test_diff_drive_controller.cpp ``test_speed_limiter``: with
    max_acceleration 2, max_deceleration -4, max_acceleration_reverse -8 and
    max_deceleration_reverse 10, steps 0 -> 1 -> 0 -> -1 -> 0 m/s at dt 1 ms take 1/2, 1/4,
    1/8 and 1/10 s, staying short of the target until the last update. v0 and v1 are the last
    two limited commands, zeros after reset_buffers (diff_drive_controller.cpp)."""
    limiter = SpeedLimiter(SpeedLimits(max_acceleration=2.0, max_deceleration=-4.0,
                                       max_acceleration_reverse=-8.0,
                                       max_deceleration_reverse=10.0))
    last, before = 0.0, 0.0
    dt = 0.001
    for target, seconds in [(1.0, 0.5), (0.0, 0.25), (-1.0, 0.125), (0.0, 0.1)]:
        steps = round(seconds / dt)
        for _ in range(steps - 1):
            v, _ = limiter.limit(target, last, before, dt)
            assert abs(v - target) > 1e-6
            last, before = v, last
        v, _ = limiter.limit(target, last, before, dt)
        assert v == pytest.approx(target, abs=1e-9)
        last, before = v, last
        for _ in range(3):
            v, _ = limiter.limit(target, last, before, 0.01)
            assert v == pytest.approx(target, abs=1e-9)
            last, before = v, last


def test_limits_are_validated_as_the_parameters_are() -> None:
    """diff_drive_controller_parameter.yaml: ``gt_eq_or_nan<>: [0.0]`` on max_velocity,
    max_acceleration, max_deceleration_reverse, max_jerk and ``lt_eq_or_nan<>: [0.0]`` on
    min_velocity, max_deceleration, max_acceleration_reverse, min_jerk; which also rules out
    control_toolbox/test/rate_limiter.cpp ``RateLimiterTest.testWrongParams``' throwing cases
    (min above max)."""
    for name in ("max_velocity", "max_acceleration", "max_deceleration_reverse", "max_jerk"):
        with pytest.raises(KinematicsValueError, match=name):
            SpeedLimits(**{name: -1.0})
    for name in ("min_velocity", "max_deceleration", "max_acceleration_reverse", "min_jerk"):
        with pytest.raises(KinematicsValueError, match=name):
            SpeedLimits(**{name: 1.0})
    limiter = SpeedLimiter(SpeedLimits(max_velocity=1.0))
    with pytest.raises(KinematicsValueError, match="dt"):
        limiter.limit(1.0, 0.0, 0.0, -0.1)
    with pytest.raises(KinematicsValueError, match="v0"):
        limiter.limit(1.0, math.nan, 0.0, 0.1)


def test_limits_from_the_controllers_parameters() -> None:
    """diff_drive_controller.cpp ``on_configure``: ``linear.x.*`` and ``angular.z.*`` build
    the two limiters; a deprecated ``has_*_limits: false`` sets its group to NaN;
    ``min_acceleration`` is declared in diff_drive_controller_parameter.yaml and never read."""
    parameters: dict[str, object] = {
        "wheel_radius": 0.02,
        "linear.x.max_velocity": 0.5, "linear.x.max_acceleration": 1.0,
        "linear.x.min_acceleration": -9.0, "linear.x.max_jerk": NAN,
        "angular.z.max_velocity": 2.0, "angular.z.max_acceleration": 3.0,
        "angular.z.has_acceleration_limits": False,
    }
    linear = SpeedLimiter(SpeedLimits.from_parameters(parameters, "linear.x"))
    assert linear.bounds == ResolvedBounds((-0.5, 0.5), (-1.0, 1.0), (-1.0, 1.0), (-1.0, 1.0),
                                           None)
    angular = SpeedLimiter(SpeedLimits.from_parameters(parameters, "angular.z"))
    assert angular.bounds.velocity == (-2.0, 2.0)
    assert angular.bounds.forward is None
    with pytest.raises(KinematicsValueError, match=r"linear\.x\.max_accel"):
        SpeedLimits.from_parameters({"linear.x.max_accel": 1.0}, "linear.x")
    with pytest.raises(KinematicsValueError, match="axis"):
        SpeedLimits.from_parameters({}, "linear.y")
