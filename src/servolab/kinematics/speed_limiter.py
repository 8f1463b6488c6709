"""The speed limiter of ros2_controllers' ``diff_drive_controller`` (ROS 2 Jazzy): velocity,
acceleration (four asymmetric bounds) and jerk limits on one axis of the commanded twist.

Why here: a servolab differential-drive controller that limits its commands the way the ROS
controller does drives a robot the same way from the same ``cmd_vel``, so a navigation stack
tuned against one behaves the same against the other.

Where it lives in Jazzy: ``diff_drive_controller/include/diff_drive_controller/speed_limiter.hpp``
(ros2_controllers branch ``jazzy``, diff_drive_controller 4.42.1) is a thin header-only wrapper
whose non-deprecated constructor hands its eight arguments, in order, to
``control_toolbox::RateLimiter<double>`` (control_toolbox branch ``jazzy``, 4.11.0,
``control_toolbox/include/control_toolbox/rate_limiter.hpp``), and whose ``limit`` is
``RateLimiter::limit``. The ``speed_limiter.cpp`` of older distributions is gone. The law below
is read from those two headers (no code copied):

``limit(v, v0, v1, dt)`` limits, in this order, the jerk, then the acceleration, then the
velocity, and returns the limited ``v`` and the factor ``limited / v`` (1.0 when ``v`` is 0):

* jerk, only when ``(dv - dv0) * dv > 0`` with ``dv = v - v0`` and ``dv0 = v0 - v1`` (the
  acceleration grows in the direction the velocity moves; control_toolbox issue 240: limiting
  the jerk while the acceleration shrinks made closed loops oscillate):
  ``v = v0 + dv0 + clamp(dv - dv0, min_jerk dt^2, max_jerk dt^2)``. So an acceleration that
  falls towards zero, or stops at once (``dv == 0``), is never jerk-limited, while a command
  that reverses the velocity change is (the velocity keeps moving the old way for a few
  steps);
* acceleration: ``v = v0 + clamp(v - v0, lo dt, hi dt)`` where ``(lo, hi)`` is
  ``(max_deceleration, max_acceleration)`` moving forward (``v0 > 0``),
  ``(max_acceleration_reverse, max_deceleration_reverse)`` moving backward (``v0 < 0``) and
  ``(max_acceleration_reverse, max_acceleration)`` at rest (``v0 == 0``);
* velocity: ``clamp(v, min_velocity, max_velocity)``.

The controller's parameters, one set per axis, ``linear.x.<name>`` (m/s, m/s^2, m/s^3) and
``angular.z.<name>`` (rad/s, ...), all ``double`` with default ``.NAN`` in
``diff_drive_controller/src/diff_drive_controller_parameter.yaml``. NaN means "not set":

============================  ==========  ====================================================
name                          validation  when NaN
============================  ==========  ====================================================
``max_velocity``              >= 0        no velocity limit (``min_velocity`` is ignored)
``min_velocity``              <= 0        ``-max_velocity``
``max_acceleration``          >= 0        no acceleration limit at all: the three below are
                                          then ignored
``max_acceleration_reverse``  <= 0        ``-max_acceleration``
``max_deceleration``          <= 0        ``max_acceleration_reverse`` (as resolved)
``max_deceleration_reverse``  >= 0        ``max_acceleration`` (the YAML's description says
                                          ``-max_deceleration``; the code does not)
``max_jerk``                  >= 0        no jerk limit (``min_jerk`` is ignored)
``min_jerk``                  <= 0        ``-max_jerk``
============================  ==========  ====================================================

Deprecated and still read: ``has_velocity_limits``, ``has_acceleration_limits`` and
``has_jerk_limits`` (bool, default true): false sets that group to NaN. ``min_acceleration``
(deprecated, "use max_deceleration") is declared but read by nothing in Jazzy's controller.

How the controller feeds the limiter (``diff_drive_controller.cpp``,
``update_and_write_commands``): ``v0`` and ``v1`` are the last and second-to-last *limited*
commands of that axis, both 0.0 after ``reset_buffers`` (configure, deactivate, cleanup,
error), so the first command is limited as an acceleration from rest; ``dt`` is the
controller's update period. The odometry's open-loop update and the wheel commands use the
limited command (:mod:`servolab.kinematics.diff_drive_odometry`).

Ours refuses what the C++ would turn into NaN or undefined behaviour: a non-finite ``v``,
``v0``, ``v1`` or ``dt``, a negative ``dt``, and limits outside the YAML's validation (which
also makes every clamp's bounds ordered, the checks ``RateLimiter::set_params`` makes).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields

from servolab.kinematics.errors import KinematicsValueError
from servolab.kinematics.errors import finite_number as _finite

#: The two axes the controller limits, as its parameters' prefixes.
AXES = ("linear.x", "angular.z")

#: ``(name, sign)``: the parameters a :class:`SpeedLimits` holds, with the YAML's
#: ``gt_eq_or_nan<>: [0.0]`` (+1) or ``lt_eq_or_nan<>: [0.0]`` (-1) validation.
LIMIT_PARAMETERS: tuple[tuple[str, int], ...] = (
    ("min_velocity", -1), ("max_velocity", 1),
    ("max_acceleration_reverse", -1), ("max_acceleration", 1),
    ("max_deceleration", -1), ("max_deceleration_reverse", 1),
    ("min_jerk", -1), ("max_jerk", 1),
)

#: The deprecated switches, each with the limits it turns off when false.
DEPRECATED_SWITCHES: dict[str, tuple[str, ...]] = {
    "has_velocity_limits": ("min_velocity", "max_velocity"),
    "has_acceleration_limits": ("max_acceleration_reverse", "max_acceleration",
                                "max_deceleration", "max_deceleration_reverse"),
    "has_jerk_limits": ("min_jerk", "max_jerk"),
}

#: Declared in the YAML, read by nothing in Jazzy's controller.
IGNORED_PARAMETERS = ("min_acceleration",)

Bounds = tuple[float, float]


def _clamp(value: float, low: float, high: float) -> float:
    # std::clamp's comparisons, so that NaN bounds (inf * 0 at dt = 0) leave the value alone
    if value < low:
        return low
    if high < value:
        return high
    return value


def _factor(limited: float, original: float) -> float:
    return limited / original if original != 0.0 else 1.0


@dataclass(frozen=True)
class SpeedLimits:
    """One axis's limits, named and defaulted (NaN: not set) as the controller's parameters
    ``linear.x.<field>`` / ``angular.z.<field>``; the module docstring says what each bounds
    and what a NaN falls back to. Refused unless each is NaN or of its sign, as the parameters'
    validation refuses them."""

    min_velocity: float = math.nan
    max_velocity: float = math.nan
    max_acceleration_reverse: float = math.nan
    max_acceleration: float = math.nan
    max_deceleration: float = math.nan
    max_deceleration_reverse: float = math.nan
    min_jerk: float = math.nan
    max_jerk: float = math.nan

    def __post_init__(self) -> None:
        for name, sign in LIMIT_PARAMETERS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise KinematicsValueError(f"{name} must be a number or NaN, got {value!r}")
            if not math.isnan(value) and value * sign < 0:
                raise KinematicsValueError(
                    f"{name} must be {'>=' if sign > 0 else '<='} 0 or NaN, got {value!r}")

    @classmethod
    def from_parameters(cls, parameters: Mapping[str, object], axis: str) -> SpeedLimits:
        """The limits of ``axis`` (``"linear.x"`` or ``"angular.z"``) from a flat mapping of
        the controller's parameter names (``{"linear.x.max_velocity": 0.5, ...}``, as in a
        ``ros__parameters`` block); names of other prefixes are skipped, a missing limit is
        NaN, and a deprecated ``has_*_limits: false`` sets its group to NaN as
        ``on_configure`` does. An unknown name under ``axis`` is refused, where ROS would
        silently ignore the typo."""
        if axis not in AXES:
            raise KinematicsValueError(f"axis must be one of {AXES}, got {axis!r}")
        prefix = axis + "."
        known = {name for name, _ in LIMIT_PARAMETERS} | set(DEPRECATED_SWITCHES) \
            | set(IGNORED_PARAMETERS)
        values: dict[str, float] = {}
        off: set[str] = set()
        for key, value in parameters.items():
            if not key.startswith(prefix):
                continue
            name = key[len(prefix):]
            if name not in known:
                raise KinematicsValueError(f"unknown speed limit parameter {key!r}; known: "
                                           f"{', '.join(sorted(known))}")
            if name in DEPRECATED_SWITCHES:
                if not isinstance(value, bool):
                    raise KinematicsValueError(f"{key} must be true or false, got {value!r}")
                if not value:
                    off.update(DEPRECATED_SWITCHES[name])
            elif name not in IGNORED_PARAMETERS:
                if isinstance(value, bool) or not isinstance(value, (int, float)):
                    raise KinematicsValueError(f"{key} must be a number or NaN, got {value!r}")
                values[name] = float(value)
        for name in off:
            values[name] = math.nan
        return cls(**values)


@dataclass(frozen=True)
class ResolvedBounds:
    """The bounds the limiter applies, NaNs resolved as ``RateLimiter::set_params`` does;
    None where a group is off. Each pair is ``(lowest, highest)``: of the velocity, of the
    acceleration when moving forward, backward or at rest, and of the jerk."""

    velocity: Bounds | None
    forward: Bounds | None
    reverse: Bounds | None
    from_rest: Bounds | None
    jerk: Bounds | None

    @classmethod
    def of(cls, limits: SpeedLimits) -> ResolvedBounds:
        """Resolve ``limits``: a group is on only when its ``max_*`` is set (for the
        acceleration, ``max_acceleration``), and each unset member falls back as the module
        docstring's table says."""
        velocity = jerk = forward = reverse = from_rest = None
        if not math.isnan(limits.max_velocity):
            low = limits.min_velocity
            velocity = (-limits.max_velocity if math.isnan(low) else low, limits.max_velocity)
        if not math.isnan(limits.max_acceleration):
            acc = limits.max_acceleration
            acc_rev = -acc if math.isnan(limits.max_acceleration_reverse) \
                else limits.max_acceleration_reverse
            dec = acc_rev if math.isnan(limits.max_deceleration) else limits.max_deceleration
            dec_rev = acc if math.isnan(limits.max_deceleration_reverse) \
                else limits.max_deceleration_reverse
            forward, reverse, from_rest = (dec, acc), (acc_rev, dec_rev), (acc_rev, acc)
        if not math.isnan(limits.max_jerk):
            low = limits.min_jerk
            jerk = (-limits.max_jerk if math.isnan(low) else low, limits.max_jerk)
        return cls(velocity, forward, reverse, from_rest, jerk)


@dataclass(frozen=True)
class SpeedLimiter:
    """``diff_drive_controller::SpeedLimiter`` (``control_toolbox::RateLimiter``) of one axis.

    Stateless: the caller keeps the last two limited commands, as the controller does, so the
    same limiter serves any number of independent command streams. Every method returns
    ``(limited value, factor)``, the factor being ``limited / value`` (1.0 for a zero value),
    as the C++'s in/out argument and return value.
    """

    limits: SpeedLimits = field(default_factory=SpeedLimits)
    bounds: ResolvedBounds = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "bounds", ResolvedBounds.of(self.limits))

    def limit(self, v: float, v0: float, v1: float, dt: float) -> tuple[float, float]:
        """Limit command ``v`` given the previous limited commands ``v0`` (last) and ``v1``
        (before it) and the period ``dt`` (s): jerk, then acceleration, then velocity."""
        original = _finite("v", v)
        limited, _ = self.limit_jerk(original, v0, v1, dt)
        limited, _ = self.limit_acceleration(limited, v0, dt)
        limited, _ = self.limit_velocity(limited)
        return limited, _factor(limited, original)

    def limit_velocity(self, v: float) -> tuple[float, float]:
        """Clamp ``v`` to ``[min_velocity, max_velocity]`` (``limit_velocity``)."""
        original = _finite("v", v)
        bounds = self.bounds.velocity
        limited = original if bounds is None else _clamp(original, *bounds)
        return limited, _factor(limited, original)

    def limit_acceleration(self, v: float, v0: float, dt: float) -> tuple[float, float]:
        """Limit the change from ``v0`` over ``dt`` (``limit_acceleration``); which bounds
        apply depends on the sign of ``v0`` alone (forward, backward, at rest)."""
        original = _finite("v", v)
        previous = _finite("v0", v0)
        step = self._period(dt)
        b = self.bounds
        if b.forward is None or b.reverse is None or b.from_rest is None:
            return original, 1.0
        low, high = b.forward if previous > 0 else b.reverse if previous < 0 else b.from_rest
        limited = previous + _clamp(original - previous, low * step, high * step)
        return limited, _factor(limited, original)

    def limit_jerk(self, v: float, v0: float, v1: float, dt: float) -> tuple[float, float]:
        """Limit the change of acceleration (``limit_jerk``), only while the acceleration
        grows in the direction of the velocity change: ``(dv - dv0) * dv > 0``."""
        original = _finite("v", v)
        previous = _finite("v0", v0)
        before = _finite("v1", v1)
        step = self._period(dt)
        bounds = self.bounds.jerk
        dv, dv0 = original - previous, previous - before
        if bounds is None or not (dv - dv0) * dv > 0:
            return original, 1.0
        step2 = step * step
        limited = previous + dv0 + _clamp(dv - dv0, bounds[0] * step2, bounds[1] * step2)
        return limited, _factor(limited, original)

    @staticmethod
    def _period(dt: float) -> float:
        step = _finite("dt", dt)
        if step < 0:
            raise KinematicsValueError(f"dt must be >= 0, got {dt!r}")
        return step


def limit_names(axis: str) -> tuple[str, ...]:
    """The controller's full parameter names of ``axis``'s limits, in :class:`SpeedLimits`'
    field order (``linear.x.min_velocity``, ...): for a configuration file's keys and error
    messages."""
    if axis not in AXES:
        raise KinematicsValueError(f"axis must be one of {AXES}, got {axis!r}")
    return tuple(f"{axis}.{f.name}" for f in fields(SpeedLimits))
