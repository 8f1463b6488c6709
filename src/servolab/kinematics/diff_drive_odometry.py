"""The odometry of ros2_controllers' ``diff_drive_controller`` (ROS 2 Jazzy), as servolab's
pure algorithm: what a differential-drive controller written in servolab needs to report the
same pose and twist as the ROS controller would from the same wheel readings.

Why a second odometry next to :func:`servolab.kinematics.diffdrive.integrate_odometry`: that
one integrates encoder ticks as exact arcs with one wheel radius. The ROS controller differs in
ways a comparison with a ROS robot would show, so this module reproduces them:

* each wheel has its own radius (``wheel_radius`` times ``left_wheel_radius_multiplier`` or
  ``right_wheel_radius_multiplier``; :class:`WheelGeometry`);
* a step turning by less than :data:`EXACT_INTEGRATION_THRESHOLD` (1e-6 rad) is taken as a
  second-order Runge-Kutta step along the mid heading, a larger one as the exact arc
  (:func:`integrate_step`);
* an update less than :data:`MIN_UPDATE_INTERVAL` (0.1 ms) after the last one is refused and
  changes nothing;
* the reported twist is the rolling mean of the last ``velocity_rolling_window_size`` (default
  10) per-update speeds (:class:`RollingMean`), while open-loop odometry reports the command
  itself.

Sources (read for their behaviour; no code is copied), ros2_controllers branch ``jazzy``
(diff_drive_controller 4.42.1, commit ed360c97):

* ``diff_drive_controller/src/odometry.cpp`` and
  ``include/diff_drive_controller/odometry.hpp``: ``update``, ``updateFromVelocity``,
  ``updateOpenLoop``, ``integrateRungeKutta2``, ``integrateExact`` (the ``fabs(angular) <
  1e-6`` switch), the ``dt < 0.0001`` refusal, ``resetOdometry``, ``setWheelParams``, the
  constructor's window of 10;
* ``diff_drive_controller/src/diff_drive_controller.cpp``: ``on_configure`` and
  ``update_and_write_commands`` apply the multipliers, feed ``update`` with the mean wheel
  position (``position_feedback: true``) or ``updateFromVelocity`` with ``velocity * radius *
  period`` (``position_feedback: false``), and compute the wheel velocity commands;
* ``diff_drive_controller/src/diff_drive_controller_parameter.yaml``: defaults
  ``velocity_rolling_window_size: 10``, the three multipliers 1.0, ``position_feedback:
  true``, ``open_loop: false``;
* rcpputils (branch ``jazzy``, 2.11.0) ``include/rcpputils/rolling_mean_accumulator.hpp``: the
  rolling mean (mean of the values held, fewer than the window until it fills).

Conventions are :mod:`servolab.kinematics.diffdrive`'s (x forward, y left, heading
counter-clockwise; wheel positions and speeds in rad and rad/s, positive forward); times are
seconds as floats, what ``rclcpp::Time::seconds()`` gives the C++. Unlike the C++, a NaN or
infinite input raises :class:`~servolab.kinematics.errors.KinematicsValueError` rather than
making the pose NaN for good (the ROS controller itself refuses NaN feedback before it reaches
the odometry).

The ROS 2 Kilted/Rolling odometry (``master``) has moved on (``update_from_pos`` with a
``1e-6`` s threshold, a rolling mean of velocities rather than of increments over ``dt``, a
different small-turn step): this module is Jazzy's.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from servolab.kinematics.diffdrive import DiffDrive, body_velocity, wheel_speeds
from servolab.kinematics.errors import KinematicsValueError
from servolab.kinematics.errors import finite_number as _finite

#: Updates closer than this to the last accepted one (s) are refused: ``odometry.cpp`` returns
#: false on ``dt < 0.0001`` ("Interval too small to integrate with"), so the speed estimate
#: never divides by a near-zero interval. A time going backwards is refused the same way.
MIN_UPDATE_INTERVAL = 0.0001

#: A step turning by less than this (rad) is integrated with the second-order Runge-Kutta step
#: (``integrateExact``'s ``fabs(angular) < 1e-6`` in ``odometry.cpp``): the exact arc's radius
#: ``ds / dheading`` would be huge and lose precision there.
EXACT_INTEGRATION_THRESHOLD = 1e-6

#: ``velocity_rolling_window_size``'s default, the same in ``odometry.hpp`` (the constructor's
#: argument) and ``diff_drive_controller_parameter.yaml``.
DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE = 10


def _positive(name: str, value: float) -> float:
    number = _finite(name, value)
    if number <= 0:
        raise KinematicsValueError(f"{name} must be positive, got {value!r}")
    return number


# -- geometry and the multipliers ---------------------------------------------------------------

@dataclass(frozen=True)
class WheelParams:
    """The wheel geometry the odometry and the wheel commands use (m): the separation and each
    side's radius after the multipliers, what ``Odometry::setWheelParams`` receives.

    Each side has its own radius because a calibration that finds one wheel slightly larger
    (worn tyre, different load) corrects only that side.
    """

    wheel_separation: float
    left_wheel_radius: float
    right_wheel_radius: float
    #: This separation with a wheel radius of 1: the drive whose "wheel angles" are the
    #: wheels' travel in metres, so that :mod:`~servolab.kinematics.diffdrive`'s twist
    #: formulas apply to per-side radii once each side has been scaled by its own.
    unit_drive: DiffDrive = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        _positive("wheel_separation", self.wheel_separation)
        _positive("left_wheel_radius", self.left_wheel_radius)
        _positive("right_wheel_radius", self.right_wheel_radius)
        object.__setattr__(self, "unit_drive", DiffDrive(1.0, self.wheel_separation))


@dataclass(frozen=True)
class WheelGeometry:
    """The controller's geometry parameters, named and defaulted as in
    ``diff_drive_controller_parameter.yaml``: ``wheel_separation`` and ``wheel_radius``
    (required, > 0) and the correction factors ``wheel_separation_multiplier``,
    ``left_wheel_radius_multiplier`` and ``right_wheel_radius_multiplier`` (default 1.0).

    Kept apart from :class:`WheelParams` so that a configuration file holds the nominal values
    and the calibration factors as the ROS parameters do, and :meth:`wheel_params` is the one
    place that combines them.
    """

    wheel_separation: float
    wheel_radius: float
    wheel_separation_multiplier: float = 1.0
    left_wheel_radius_multiplier: float = 1.0
    right_wheel_radius_multiplier: float = 1.0

    def __post_init__(self) -> None:
        _positive("wheel_separation", self.wheel_separation)
        _positive("wheel_radius", self.wheel_radius)
        self.wheel_params()  # a zero or negative multiplier is refused here, not at first use

    def wheel_params(self) -> WheelParams:
        """The effective geometry, as ``on_configure`` and ``update_and_write_commands`` in
        ``diff_drive_controller.cpp`` compute it: each multiplier times its nominal value
        (``wheel_separation_multiplier * wheel_separation``,
        ``left_wheel_radius_multiplier * wheel_radius``,
        ``right_wheel_radius_multiplier * wheel_radius``)."""
        return WheelParams(self.wheel_separation_multiplier * self.wheel_separation,
                           self.left_wheel_radius_multiplier * self.wheel_radius,
                           self.right_wheel_radius_multiplier * self.wheel_radius)


def wheel_velocity_commands(linear: float, angular: float,
                            params: WheelParams) -> tuple[float, float]:
    """Left and right wheel velocity commands (rad/s) for a body twist (m/s, rad/s), as
    ``update_and_write_commands`` computes them after the speed limiter: each side's rim speed
    ``linear -/+ angular * separation / 2`` (:func:`~servolab.kinematics.diffdrive.wheel_speeds`
    on a unit-radius drive) divided by that side's own radius."""
    left_rim, right_rim = wheel_speeds(linear, angular, params.unit_drive)
    return float(left_rim) / params.left_wheel_radius, float(right_rim) / params.right_wheel_radius


# -- integration --------------------------------------------------------------------------------

def integrate_step(x: float, y: float, heading: float, ds: float,
                   dheading: float) -> tuple[float, float, float]:
    """Pose after moving ``ds`` metres along the path while turning by ``dheading`` rad:
    ``Odometry::integrateExact``.

    Below :data:`EXACT_INTEGRATION_THRESHOLD` the step is ``integrateRungeKutta2``: a straight
    chord of length ``ds`` along the mid heading ``heading + dheading / 2``. Otherwise it is the
    exact arc of radius ``ds / dheading``: ``x += r (sin(h1) - sin(h0))``,
    ``y -= r (cos(h1) - cos(h0))``. The two agree to ``O(dheading^2)`` relative error at the
    switch, and the arc is the same curve as diffdrive's ``sinc`` chord; the switch is kept
    because it decides the last bits of every pose the ROS controller publishes.
    """
    if abs(dheading) < EXACT_INTEGRATION_THRESHOLD:
        direction = heading + dheading * 0.5
        return x + ds * math.cos(direction), y + ds * math.sin(direction), heading + dheading
    radius = ds / dheading
    new_heading = heading + dheading
    return (x + radius * (math.sin(new_heading) - math.sin(heading)),
            y - radius * (math.cos(new_heading) - math.cos(heading)),
            new_heading)


class RollingMean:
    """Mean of the last ``window`` values: rcpputils' ``RollingMeanAccumulator``.

    Before the window has filled, the mean is over the values accumulated so far (not over a
    window padded with zeros), so the first speed estimate is the first step's speed.
    Why a rolling mean: a wheel encoder's increment over one control period is a few ticks, and
    its quantisation makes the per-update speed jump; the mean smooths the published twist at
    the cost of a lag of about half a window.
    """

    def __init__(self, window: int) -> None:
        if isinstance(window, bool) or not isinstance(window, int) or window < 1:
            raise KinematicsValueError(f"rolling window size must be an integer >= 1, "
                                       f"got {window!r}")
        self._window = window
        self._values: deque[float] = deque(maxlen=window)

    @property
    def window(self) -> int:
        """How many of the latest values the mean covers."""
        return self._window

    def __len__(self) -> int:
        return len(self._values)

    def accumulate(self, value: float) -> None:
        """Add ``value``, dropping the oldest once the window is full."""
        self._values.append(_finite("rolling mean value", value))

    def mean(self) -> float:
        """The mean of the values held; refused while empty (the C++ asserts there)."""
        if not self._values:
            raise KinematicsValueError("the rolling mean has no value yet")
        return math.fsum(self._values) / len(self._values)


# -- the odometry -------------------------------------------------------------------------------

class DiffDriveOdometry:
    """``diff_drive_controller::Odometry`` of ROS 2 Jazzy: a pose and a twist updated from
    wheel positions, wheel velocities or the commanded twist.

    State starts as the C++ does: pose and twist zero, last time 0.0 s, last wheel positions
    0 m. Note what follows from the last two, as in ROS: the first :meth:`update` integrates the
    wheels' whole travel from position 0 (encoders that do not start at zero make the pose jump
    once), and its speed sample is divided by the time since 0.0 s unless :meth:`init` set a
    start time (the Jazzy controller never calls ``init``).

    Unlike the C++, the wheel geometry is required at construction, so there is no state in
    which a zero separation would make the heading infinite.
    """

    def __init__(self, wheel_params: WheelParams,
                 velocity_rolling_window_size: int = DEFAULT_VELOCITY_ROLLING_WINDOW_SIZE
                 ) -> None:
        self._params = wheel_params
        self._window = velocity_rolling_window_size
        self._linear_mean = RollingMean(velocity_rolling_window_size)
        self._angular_mean = RollingMean(velocity_rolling_window_size)
        self._timestamp = 0.0
        self._x = self._y = self._heading = 0.0
        self._linear = self._angular = 0.0
        self._left_old = self._right_old = 0.0

    # -- read-outs --

    @property
    def x(self) -> float:
        """Position along the odometry frame's x (m)."""
        return self._x

    @property
    def y(self) -> float:
        """Position along the odometry frame's y (m)."""
        return self._y

    @property
    def heading(self) -> float:
        """Heading (rad), not wrapped: it counts whole turns, as the C++ ``heading_`` does."""
        return self._heading

    @property
    def pose(self) -> tuple[float, float, float]:
        """``(x, y, heading)``."""
        return self._x, self._y, self._heading

    @property
    def linear(self) -> float:
        """Estimated body speed (m/s): the rolling mean, or the last open-loop command."""
        return self._linear

    @property
    def angular(self) -> float:
        """Estimated turn rate (rad/s): the rolling mean, or the last open-loop command."""
        return self._angular

    @property
    def timestamp(self) -> float:
        """Time (s) of the last accepted update (or of :meth:`init`)."""
        return self._timestamp

    @property
    def wheel_params(self) -> WheelParams:
        """The geometry in use."""
        return self._params

    @property
    def velocity_rolling_window_size(self) -> int:
        """How many updates the speed estimate averages."""
        return self._window

    # -- configuration --

    def init(self, time: float) -> None:
        """Start the speed estimate afresh at ``time`` (``Odometry::init``): empties the
        rolling means and sets the last time, leaving the pose and the last wheel positions."""
        self._timestamp = _finite("time", time)
        self._reset_accumulators()

    def set_wheel_params(self, wheel_separation: float, left_wheel_radius: float,
                         right_wheel_radius: float) -> None:
        """Use a new geometry from the next update on (``Odometry::setWheelParams``). As in
        the C++, the stored last wheel positions keep the metres of the old radii."""
        self._params = WheelParams(wheel_separation, left_wheel_radius, right_wheel_radius)

    def set_velocity_rolling_window_size(self, velocity_rolling_window_size: int) -> None:
        """Change the window, emptying both rolling means
        (``Odometry::setVelocityRollingWindowSize``)."""
        RollingMean(velocity_rolling_window_size)  # refuse a bad size before changing anything
        self._window = velocity_rolling_window_size
        self._reset_accumulators()

    def reset_odometry(self) -> None:
        """Pose back to zero (``Odometry::resetOdometry``); the twist, the rolling means, the
        last time and the last wheel positions are kept, as the controller's ``reset`` does
        (wheel positions are absolute, so keeping them keeps the next increment right)."""
        self._x = self._y = self._heading = 0.0

    def _reset_accumulators(self) -> None:
        self._linear_mean = RollingMean(self._window)
        self._angular_mean = RollingMean(self._window)

    # -- updates --

    def update(self, left_pos: float, right_pos: float, time: float) -> bool:
        """Update from the wheels' absolute positions (rad) at ``time`` (s):
        ``Odometry::update``, what the controller calls with ``position_feedback: true`` (the
        mean position of each side's wheels).

        Each position times its side's radius is the wheel's travel (m); the difference from
        the last accepted update is the step. Returns False, changing nothing (not even the
        stored positions), when ``time`` is less than :data:`MIN_UPDATE_INTERVAL` after the
        last accepted update.
        """
        left_m = _finite("left_pos", left_pos) * self._params.left_wheel_radius
        right_m = _finite("right_pos", right_pos) * self._params.right_wheel_radius
        if not self._interval_ok(time):
            return False
        d_left, d_right = left_m - self._left_old, right_m - self._right_old
        self._left_old, self._right_old = left_m, right_m
        return self.update_from_increments(d_left, d_right, time)

    def update_from_velocity(self, left_vel: float, right_vel: float, time: float,
                             period: float | None = None) -> bool:
        """Update from the wheels' angular velocities (rad/s): what the controller does with
        ``position_feedback: false``, passing ``velocity * radius * period`` of each side to
        ``Odometry::updateFromVelocity``.

        ``period`` (s) is the controller's update period; None takes the time since the last
        accepted update, which is what the period is when the controller runs on time. Returns
        False, changing nothing, when ``time`` is too close to the last update.
        """
        left = _finite("left_vel", left_vel)
        right = _finite("right_vel", right_vel)
        if not self._interval_ok(time):
            return False
        step = time - self._timestamp if period is None else _finite("period", period)
        return self.update_from_increments(left * self._params.left_wheel_radius * step,
                                           right * self._params.right_wheel_radius * step, time)

    def update_from_increments(self, left_travel: float, right_travel: float,
                               time: float) -> bool:
        """Update from each wheel's travel (m) since the last update: the C++
        ``Odometry::updateFromVelocity`` itself, whose "velocities" are in fact these
        increments (:meth:`update` and :meth:`update_from_velocity` both end here).

        The step ``(left + right) / 2`` along the path and ``(right - left) / separation`` of
        turn is integrated by :func:`integrate_step`; each divided by the time since the last
        update is one sample of the rolling means that :attr:`linear` and :attr:`angular`
        report. Returns False, changing nothing, when the interval is under
        :data:`MIN_UPDATE_INTERVAL`.
        """
        d_left = _finite("left_travel", left_travel)
        d_right = _finite("right_travel", right_travel)
        if not self._interval_ok(time):
            return False
        dt = time - self._timestamp
        ds, dheading = (float(c) for c in body_velocity(d_left, d_right,
                                                         self._params.unit_drive))
        self._x, self._y, self._heading = integrate_step(self._x, self._y, self._heading,
                                                         ds, dheading)
        self._timestamp = time
        self._linear_mean.accumulate(ds / dt)
        self._angular_mean.accumulate(dheading / dt)
        self._linear = self._linear_mean.mean()
        self._angular = self._angular_mean.mean()
        return True

    def update_open_loop(self, linear: float, angular: float, time: float) -> None:
        """Dead-reckon the commanded twist (m/s, rad/s) from the last update to ``time``:
        ``Odometry::updateOpenLoop``, used with ``open_loop: true`` on the command *after* the
        speed limiter (Jazzy 4.39.0 moved the limiter first).

        The twist is reported as given, not averaged, and the rolling means are left alone.
        There is no minimum interval here: as in the C++ every call integrates
        ``linear * dt`` and ``angular * dt``, even for a zero or negative ``dt``.
        """
        v = _finite("linear", linear)
        w = _finite("angular", angular)
        now = _finite("time", time)
        self._linear, self._angular = v, w
        dt = now - self._timestamp
        self._timestamp = now
        self._x, self._y, self._heading = integrate_step(self._x, self._y, self._heading,
                                                         v * dt, w * dt)

    def _interval_ok(self, time: float) -> bool:
        return _finite("time", time) - self._timestamp >= MIN_UPDATE_INTERVAL
