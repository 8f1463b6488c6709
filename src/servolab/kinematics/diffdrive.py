"""Differential-drive kinematics: body twist <-> wheel speeds, wheel-encoder odometry, and the
moves of seed 000's two-wheel robot (Appendix A: circles, figure of eight, pure rotation), with
A.2's encoder-counting line (final.m: its counts per mm, its count as meant and as printed).

Conventions (SI throughout): x forward, y to the robot's left, theta counter-clockwise seen
from above, so a positive ``omega`` turns left. Wheel speeds are wheel angular speeds in rad/s,
positive when that wheel drives the robot forward. A servo mounted mirrored (seed 000 sends
``1023 + s`` to one side and ``s`` to the other for a straight line) has its sign flipped by
the caller, not here: this module knows wheels, not servos.

The equations are seed 002's (section 4, eq. 5b-5d), the same as TurtleBot3's ``cmd_vel``
conversion in its Listing 4::

    v     = r (w_l + w_r) / 2          w_l = (v - omega L / 2) / r
    omega = r (w_r - w_l) / L          w_r = (v + omega L / 2) / r

Encoders are described by :class:`Encoder` rather than by a servo model, so that this module
imports nothing of servolab's hardware layer: the caller reads ticks-per-revolution and the
register's wrap-around from the servo's model data.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from servolab.kinematics.dh import FloatArray
from servolab.kinematics.errors import KinematicsValueError

IntArray = npt.NDArray[np.int64]


def _check_positive(name: str, value: float) -> float:
    if not (isinstance(value, (int, float, np.integer, np.floating)) and math.isfinite(value)
            and value > 0):
        raise KinematicsValueError(f"{name} must be a positive finite number, got {value!r}")
    return float(value)


def finite_array(name: str, values: npt.ArrayLike) -> FloatArray:
    """``values`` as a float array; ValueError naming the first NaN or infinity.

    A NaN speed that slipped through would be clamped or scaled into a NaN servo command,
    which the servo layer would then turn into some arbitrary integer: refuse it here.
    """
    array = np.asarray(values, dtype=np.float64)
    bad = ~np.isfinite(array)
    if np.any(bad):
        raise KinematicsValueError(f"{name} must be finite, got {array[bad].flat[0]!r}")
    return array


@dataclass(frozen=True)
class DiffDrive:
    """Wheel radius ``r`` and wheel separation ``L`` (track width, wheel to wheel), metres.

    Seed 000's robot (Appendix A, Figure A3): ``DiffDrive(0.052, 0.38)``.
    """

    wheel_radius: float
    wheel_separation: float

    def __post_init__(self) -> None:
        _check_positive("wheel_radius", self.wheel_radius)
        _check_positive("wheel_separation", self.wheel_separation)


@dataclass(frozen=True)
class Encoder:
    """How a wheel servo's position register counts.

    ``ticks_per_rev``: ticks per wheel revolution (4096 for an X-series servo on the wheel
    axle; fractional if a gear or a partial-turn scale lies between).
    ``modulus``: how many distinct values the register holds before it wraps: 4096 for a
    12-bit absolute encoder reading 0..4095, ``2**32`` for a signed 32-bit multi-turn counter
    (XM430 present position).
    ``signed``: readings lie in ``[-modulus/2, modulus/2)`` rather than ``[0, modulus)``.
    """

    ticks_per_rev: float
    modulus: int
    signed: bool = False

    def __post_init__(self) -> None:
        _check_positive("ticks_per_rev", self.ticks_per_rev)
        if isinstance(self.modulus, bool) or not isinstance(self.modulus, (int, np.integer)) \
                or not 2 <= self.modulus <= 2**62:
            raise KinematicsValueError("modulus must be an integer in 2..2**62, got "
                                       f"{self.modulus!r}")

    @property
    def reading_range(self) -> tuple[int, int]:
        """The smallest and largest value the register can report."""
        low = -(self.modulus // 2) if self.signed else 0
        return low, low + self.modulus - 1


# -- twist <-> wheel speeds ---------------------------------------------------------------------

def wheel_speeds(v: npt.ArrayLike, omega: npt.ArrayLike,
                 drive: DiffDrive) -> tuple[FloatArray, FloatArray]:
    """Left and right wheel angular speeds (rad/s) for body speed ``v`` (m/s) and turn rate
    ``omega`` (rad/s), the inverse of seed 002's eq. 5b/5c (Listing 4's ``wheel_speed_cmd``
    divided by the wheel radius). Broadcasts over arrays."""
    v_arr = finite_array("v", v)
    omega_arr = finite_array("omega", omega)
    half = omega_arr * (drive.wheel_separation / 2.0)
    return (v_arr - half) / drive.wheel_radius, (v_arr + half) / drive.wheel_radius


def body_velocity(left: npt.ArrayLike, right: npt.ArrayLike,
                  drive: DiffDrive) -> tuple[FloatArray, FloatArray]:
    """Body speed ``v`` (m/s) and turn rate ``omega`` (rad/s) from the wheels' angular speeds
    (rad/s): seed 002 eq. 5b ``v = (w_l + w_r) r / 2`` and 5c ``omega = (w_r - w_l) r / L``."""
    left_arr = finite_array("left wheel speed", left)
    right_arr = finite_array("right wheel speed", right)
    r = drive.wheel_radius
    return (left_arr + right_arr) * (r / 2.0), (right_arr - left_arr) * (r / drive.wheel_separation)


def limit_wheel_speeds(left: npt.ArrayLike, right: npt.ArrayLike,
                       max_wheel_speed: float) -> tuple[FloatArray, FloatArray]:
    """Scale each (left, right) pair by one factor so that neither magnitude exceeds
    ``max_wheel_speed``; pairs already within the limit are returned unchanged.

    Seed 002's Listing 4 clamps each wheel on its own, which changes the ratio of the wheel
    speeds and so the path's curvature: a commanded arc becomes a tighter or wider one. Scaling
    both together keeps the path and only slows the robot along it.
    """
    limit = _check_positive("max_wheel_speed", max_wheel_speed)
    left_arr = finite_array("left wheel speed", left)
    right_arr = finite_array("right wheel speed", right)
    largest = np.maximum(np.abs(left_arr), np.abs(right_arr))
    # divided only where over the limit: a subnormal speed must not overflow limit / speed
    scale = np.divide(limit, largest, out=np.ones_like(largest), where=largest > limit)
    return left_arr * scale, right_arr * scale


def clamp_wheel_speeds(left: npt.ArrayLike, right: npt.ArrayLike,
                       max_wheel_speed: float) -> tuple[FloatArray, FloatArray]:
    """Clamp each wheel on its own to ``[-max_wheel_speed, max_wheel_speed]``, as seed 002's
    Listing 4 clamps ``lin_vel1`` and ``lin_vel2`` at ``LIMIT_X_MAX_VELOCITY``: past the
    limit the ratio of the speeds, and so the path's curvature, changes (both wheels at the
    limit drive straight whatever turn was asked). :func:`limit_wheel_speeds` keeps it."""
    limit = _check_positive("max_wheel_speed", max_wheel_speed)
    left_arr = finite_array("left wheel speed", left)
    right_arr = finite_array("right wheel speed", right)
    return np.clip(left_arr, -limit, limit), np.clip(right_arr, -limit, limit)


# -- encoders and odometry ----------------------------------------------------------------------

def _ticks(name: str, values: npt.ArrayLike, encoder: Encoder) -> IntArray:
    array = np.asarray(values)
    if array.dtype.kind not in "iu":
        floats = finite_array(name, array)
        fractional = floats != np.round(floats)
        if np.any(fractional):
            raise KinematicsValueError(f"{name} must be whole ticks, got "
                                       f"{floats[fractional].flat[0]!r}")
        array = floats
    ints = array.astype(np.int64)
    low, high = encoder.reading_range
    outside = (ints < low) | (ints > high)
    if np.any(outside):
        raise KinematicsValueError(f"{name} {ints[outside].flat[0]} is outside the encoder's "
                                   f"range {low}..{high}")
    return ints


def tick_delta(previous: npt.ArrayLike, current: npt.ArrayLike, encoder: Encoder) -> IntArray:
    """Signed tick increment from ``previous`` to ``current`` readings, taking the shorter way
    round the register's wrap: the result lies in ``[-modulus/2, modulus/2)``.

    With a 0..4095 encoder, 4090 -> 5 is +11 and 5 -> 4090 is -11. Seed 000's straight-line
    loop adds 65535 on every negative difference: a wrap adds the modulus (65536 for the
    EX-106+'s 16-bit wheel-mode count), not its maximum, and the loop also counts every
    backward step as nearly a full wrap forward. The caller must sample
    often enough that a wheel turns less than half the modulus between reads.
    """
    prev = _ticks("previous reading", previous, encoder)
    cur = _ticks("current reading", current, encoder)
    m = encoder.modulus
    half = m // 2
    return np.asarray(np.mod(cur - prev + half, m) - half, dtype=np.int64)


def ticks_to_angle(ticks: npt.ArrayLike, encoder: Encoder) -> FloatArray:
    """Wheel rotation (rad) of a tick increment."""
    return finite_array("ticks", ticks) * (2.0 * math.pi / encoder.ticks_per_rev)


def distance_to_ticks(distance: npt.ArrayLike, drive: DiffDrive, encoder: Encoder) -> FloatArray:
    """Ticks a wheel counts while rolling ``distance`` metres: what seed 000's straight-line
    program counts up to (its ``h``) before it stops the motors."""
    return finite_array("distance", distance) * (
        encoder.ticks_per_rev / (2.0 * math.pi * drive.wheel_radius))


def integrate_odometry(pose: npt.ArrayLike, d_left_ticks: npt.ArrayLike,
                       d_right_ticks: npt.ArrayLike, drive: DiffDrive,
                       encoder: Encoder) -> FloatArray:
    """Pose ``(x, y, theta)`` after the wheels turn by the given tick increments.

    Each increment is taken as a circular arc (constant wheel speeds between two reads), which
    integrates seed 002's eq. 5d exactly: the chord of an arc of length ``ds`` turning by
    ``dtheta`` has length ``ds * sinc(dtheta / 2)`` and points along the mean heading. Unlike
    an Euler step this is exact for straight lines, circles and turns in place at any sampling
    rate, and ``sinc`` keeps it exact as ``dtheta -> 0``.

    Scalar increments give the new pose, shape (3,). 1-D increments (one per read) give the
    pose after each of them, shape (N, 3). ``theta`` is not wrapped, so it counts whole turns.
    """
    start = finite_array("pose", pose)
    if start.shape != (3,):
        raise KinematicsValueError(f"pose must be (x, y, theta), got shape {start.shape}")
    d_left = np.asarray(ticks_to_angle(d_left_ticks, encoder) * drive.wheel_radius)
    d_right = np.asarray(ticks_to_angle(d_right_ticks, encoder) * drive.wheel_radius)
    if d_left.shape != d_right.shape or d_left.ndim > 1:
        raise KinematicsValueError("left and right increments must be scalars or 1-D of equal "
                                   f"length, got shapes {d_left.shape} and {d_right.shape}")
    ds = np.atleast_1d((d_left + d_right) / 2.0)
    dtheta = np.atleast_1d((d_right - d_left) / drive.wheel_separation)
    theta_after = start[2] + np.cumsum(dtheta)
    theta_mid = theta_after - dtheta / 2.0
    chord = ds * np.sinc(dtheta / (2.0 * math.pi))      # np.sinc(x) = sin(pi x) / (pi x)
    track = np.empty((ds.size, 3))
    track[:, 0] = start[0] + np.cumsum(chord * np.cos(theta_mid))
    track[:, 1] = start[1] + np.cumsum(chord * np.sin(theta_mid))
    track[:, 2] = theta_after
    return track[0] if d_left.ndim == 0 else track


# -- seed 000's moves ---------------------------------------------------------------------------

@dataclass(frozen=True)
class WheelMove:
    """Constant wheel angular speeds (rad/s) held for ``duration`` seconds."""

    left: float
    right: float
    duration: float

    def linear_speeds(self, drive: DiffDrive) -> tuple[float, float]:
        """The wheels' rim speeds (m/s)."""
        return self.left * drive.wheel_radius, self.right * drive.wheel_radius


def circle_time(radius: float, speed: float, turns: float = 1.0) -> float:
    """Time (s) for ``turns`` laps of a circle of ``radius`` (m) at centre speed ``speed``
    (m/s): Figure A3's ``t = 2*pi*radius*n/speed``."""
    radius = _check_positive("radius", radius)
    speed = _check_positive("speed", speed)
    turns = _check_positive("turns", turns)
    return 2.0 * math.pi * radius * turns / speed


def circle(radius: float, speed: float, drive: DiffDrive, *, clockwise: bool = False,
           turns: float = 1.0) -> WheelMove:
    """Wheel speeds and duration to drive ``turns`` laps of a circle of ``radius`` (m, measured
    to the robot's centre) at centre speed ``speed`` (m/s).

    Figure A3 (``moveCircleCCW``) of seed 000 with ``l`` the wheel base and ``r`` the wheel
    radius::

        wl = speed * (1 - l / (2 * radius)) / r      % left wheel: the inner one
        wr = speed * (1 + l / (2 * radius)) / r      % right wheel: the outer one

    Counter-clockwise turns left, so the left wheel is inner; clockwise (``moveCircleCW``,
    called by Figure A4 but not printed) swaps the two, the right wheel being inner. A radius
    below half the wheel base makes the inner wheel run backwards, as the formula says.
    """
    duration = circle_time(radius, speed, turns)
    ratio = drive.wheel_separation / (2.0 * radius)
    inner = speed * (1.0 - ratio) / drive.wheel_radius
    outer = speed * (1.0 + ratio) / drive.wheel_radius
    if clockwise:
        return WheelMove(outer, inner, duration)
    return WheelMove(inner, outer, duration)


def figure_eight(radius: float, speed: float, drive: DiffDrive, *,
                 turns_per_lobe: float = 1.0) -> tuple[WheelMove, WheelMove]:
    """Figure A4 of seed 000: a counter-clockwise circle, then a clockwise one of the same
    radius from the same point, which together trace an eight.

    Figure A4 waits ``2*t`` per lobe where ``t = 2*pi*radius/speed`` is one lap, i.e. two laps
    of each circle; an eight is one lap each, the default here (``turns_per_lobe=2`` runs the
    figure as printed).
    """
    return (circle(radius, speed, drive, clockwise=False, turns=turns_per_lobe),
            circle(radius, speed, drive, clockwise=True, turns=turns_per_lobe))


def rotation(angle: float, wheel_speed: float, drive: DiffDrive) -> WheelMove:
    """Turn in place by ``angle`` (rad, positive counter-clockwise) with both wheels at
    ``wheel_speed`` (rad/s) in opposite directions ("pure rotation at a single position",
    Appendix A of seed 000).

    By eq. 5c the body turns at ``omega = 2 r w / L``, so the turn takes ``|angle| L / (2 r w)``.
    """
    if not math.isfinite(angle):
        raise KinematicsValueError(f"angle must be finite, got {angle!r}")
    w = _check_positive("wheel_speed", wheel_speed)
    if angle == 0:
        return WheelMove(0.0, 0.0, 0.0)
    sign = 1.0 if angle > 0 else -1.0
    duration = abs(angle) * drive.wheel_separation / (2.0 * drive.wheel_radius * w)
    return WheelMove(-sign * w, sign * w, duration)


def moves_pose(pose: Iterable[float], moves: Iterable[WheelMove], drive: DiffDrive) -> FloatArray:
    """Pose after executing ``moves`` one after another from ``pose`` (exact arcs); a check that
    a circle closes, an eight returns to its start, a rotation turns by its angle."""
    x, y, theta = (float(c) for c in pose)
    for move in moves:
        v, omega = (float(c) for c in body_velocity(move.left, move.right, drive))
        ds, dtheta = v * move.duration, omega * move.duration
        chord = ds * float(np.sinc(dtheta / (2.0 * math.pi)))
        x += chord * math.cos(theta + dtheta / 2.0)
        y += chord * math.sin(theta + dtheta / 2.0)
        theta += dtheta
    return np.array([x, y, theta])


def line_time(distance: float, speed: float) -> float:
    """Time (s) to drive ``distance`` m (either way) at ``speed`` m/s."""
    if not math.isfinite(distance):
        raise KinematicsValueError(f"distance must be finite, got {distance!r}")
    return abs(distance) / _check_positive("speed", speed)


# -- seed 000 A.2: final.m's encoder counting ---------------------------------------------------
#
# final.m drives a straight line by counting one motor's wheel-mode encoder (the EX-106+'s
# present position, 0..65535, 0.06 degree a count: e-Manual, Present Position, Wheel Mode):
#
#     h = abs(round((5265/575)*d));        % d in mm: the counts to go
#     while i < h
#         q = dxl_read_word(m, 36);        % motor m's present position
#         if q-p > 0  i = i+q-p;
#         else        i = i+q-p+65535;     % "crossover maximum limit of motor encoder"
#         end
#         p = q;
#     end
#
# The functions below keep the count pure (numbers in, numbers out) so that the robot's loop,
# the tests and the documentation share one reading of it.

#: final.m's counts per millimetre, ``5265/575`` (seed 000 A.2, its ``h`` line).
A2_COUNTS_PER_MM = 5265 / 575
#: What final.m adds on a difference that is not positive: 65535, the register's largest
#: value, where a wrap of a 0..65535 count is 65536.
A2_WRAP_AS_PRINTED = 65535


def matlab_round(value: float) -> int:
    """MATLAB's ``round``: halves away from zero (Python's ``round`` goes to the even
    integer, so ``round(2.5) == 2`` where MATLAB gives 3)."""
    if not math.isfinite(value):
        raise KinematicsValueError(f"cannot round {value!r}")
    return int(math.copysign(math.floor(abs(value) + 0.5), value))


def a2_target_counts(distance: float, counts_per_mm: float) -> int:
    """final.m's ``h = abs(round((5265/575)*d))`` for ``distance`` in metres (final.m asks for
    millimetres): the encoder counts the loop runs until."""
    cpm = _check_positive("counts_per_mm", counts_per_mm)
    if not math.isfinite(distance):
        raise KinematicsValueError(f"distance must be finite, got {distance!r}")
    return abs(matlab_round(cpm * distance * 1000.0))


def radius_from_counts_per_mm(counts_per_mm: float, encoder: Encoder) -> float:
    """The wheel radius (m) that ``counts_per_mm`` encoder counts a millimetre of travel imply:
    one wheel turn, ``ticks_per_rev`` counts, rolls ``2 pi r``. For final.m's 5265/575 on the
    EX-106+ (250.92 degrees over 4095 counts, 5875.2 counts a turn) that is 0.1021 m."""
    cpm = _check_positive("counts_per_mm", counts_per_mm)
    return encoder.ticks_per_rev / (2.0 * math.pi * cpm * 1000.0)


def a2_increment_as_printed(previous: int, current: int) -> int:
    """One read of final.m's count, as printed: ``q - p`` when positive, else
    ``q - p + 65535``. Two slips follow: a wrap (65530 -> 2) counts one short, since the
    register holds 65536 values; and equal reads (``q == p``, the wheel did not move a count
    between them) take the ``else`` and add 65535, which ends any line under 65535 counts."""
    step = int(current) - int(previous)
    return step if step > 0 else step + A2_WRAP_AS_PRINTED


def a2_increment(previous: int, current: int, encoder: Encoder) -> int:
    """One read of final.m's count as it is meant: the counts since the last read, the shorter
    way round the register (:func:`tick_delta`), so a wrap counts in full and equal reads add
    nothing."""
    return int(tick_delta(previous, current, encoder))


@dataclass(frozen=True)
class A2Count:
    """final.m's loop replayed over a series of reads of one motor's encoder."""

    #: the counter ``i`` after each read
    counts: tuple[int, ...]
    #: the index of the read after which ``i >= h`` ends the loop, or None if it never did
    stop: int | None
    #: reads equal to the one before (``q == p``)
    equal_reads: int
    #: reads lower than the one before (``q < p``): wraps, for a motor counting up
    wraps: int


def replay_a2_count(start: int, reads: Iterable[int], target: int, encoder: Encoder, *,
                    as_printed: bool) -> A2Count:
    """Run final.m's ``while i < h`` over ``reads`` (``p`` starts at ``start``), counting as
    printed or as meant (:func:`a2_increment_as_printed`, :func:`a2_increment`); reads after
    the loop would have ended are ignored."""
    i, p = 0, int(start)
    counts: list[int] = []
    equal = wraps = 0
    for q in (int(r) for r in reads):
        if i >= target:
            break
        equal += q == p
        wraps += q < p
        i += a2_increment_as_printed(p, q) if as_printed else a2_increment(p, q, encoder)
        counts.append(i)
        p = q
    stop = next((k for k, c in enumerate(counts) if c >= target), None)
    return A2Count(tuple(counts), stop, equal, wraps)
