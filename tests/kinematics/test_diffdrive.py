"""Differential-drive kinematics: seed 002's eq. 5b-5d and Listing 4, wheel-encoder odometry,
and the moves of seed 000's Appendix A (Figures A3, A4) on its EX-106+ robot."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.kinematics.diffdrive import (
    DiffDrive,
    Encoder,
    circle,
    circle_time,
    clamp_wheel_speeds,
    distance_to_ticks,
    figure_eight,
    integrate_odometry,
    limit_wheel_speeds,
    moves_pose,
    rotation,
    tick_delta,
    wheel_speeds,
)
from servolab.kinematics.diffdrive import body_velocity as body

# Seed 000, Figure A3: l = 38 (cm, wheel base), r = 5.2 (cm, wheel radius).
ROBOT = DiffDrive(wheel_radius=0.052, wheel_separation=0.38)
ABS12 = Encoder(ticks_per_rev=4096, modulus=4096)                # 12-bit absolute, 0..4095
MULTI32 = Encoder(ticks_per_rev=4096, modulus=2**32, signed=True)  # XM430 present position

speeds = st.floats(-50.0, 50.0, allow_nan=False)


# -- construction -------------------------------------------------------------------------------

@pytest.mark.parametrize("bad", [0.0, -0.1, math.nan, math.inf])
def test_drive_refuses_non_positive_or_non_finite(bad: float) -> None:
    with pytest.raises(ValueError, match="wheel_radius"):
        DiffDrive(bad, 0.38)
    with pytest.raises(ValueError, match="wheel_separation"):
        DiffDrive(0.052, bad)


def test_encoder_checks_and_ranges() -> None:
    assert ABS12.reading_range == (0, 4095)
    assert MULTI32.reading_range == (-(2**31), 2**31 - 1)
    with pytest.raises(ValueError, match="modulus"):
        Encoder(4096, 1)
    with pytest.raises(ValueError, match="modulus"):
        Encoder(4096, 4096.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="ticks_per_rev"):
        Encoder(0, 4096)


# -- eq. 5b/5c and Listing 4 --------------------------------------------------------------------

def test_wheel_speeds_match_listing_4() -> None:
    # Listing 4: wheel_speed_cmd[LEFT] = v - omega * WHEEL_SEPARATION / 2, RIGHT with +.
    v, omega = 0.3, 0.8
    left, right = wheel_speeds(v, omega, ROBOT)
    assert left * ROBOT.wheel_radius == pytest.approx(v - omega * 0.38 / 2)
    assert right * ROBOT.wheel_radius == pytest.approx(v + omega * 0.38 / 2)


@settings(max_examples=60, deadline=None)
@given(v=st.floats(-2, 2), omega=st.floats(-10, 10))
def test_wheel_speeds_and_body_velocity_round_trip(v: float, omega: float) -> None:
    left, right = wheel_speeds(v, omega, ROBOT)
    v2, omega2 = body(left, right, ROBOT)  # eq. 5b and 5c of seed 002
    assert v2 == pytest.approx(v, abs=1e-12)
    assert omega2 == pytest.approx(omega, abs=1e-12)


def test_twist_functions_broadcast() -> None:
    left, right = wheel_speeds(np.array([0.1, 0.2, 0.3]), 0.5, ROBOT)
    assert left.shape == right.shape == (3,)
    v, omega = body(left, right, ROBOT)
    np.testing.assert_allclose(v, [0.1, 0.2, 0.3])
    np.testing.assert_allclose(omega, 0.5)


def test_twist_refuses_nan() -> None:
    with pytest.raises(ValueError, match=r"omega.*nan"):
        wheel_speeds(0.1, math.nan, ROBOT)
    with pytest.raises(ValueError, match=r"right wheel speed.*inf"):
        body(1.0, [1.0, math.inf], ROBOT)


# -- limiting -----------------------------------------------------------------------------------

@settings(max_examples=80, deadline=None)
@given(left=speeds, right=speeds, limit=st.floats(0.1, 20.0))
def test_limit_keeps_the_ratio(left: float, right: float, limit: float) -> None:
    lim_left, lim_right = limit_wheel_speeds(left, right, limit)
    assert max(abs(lim_left), abs(lim_right)) <= limit * (1 + 1e-12)
    # Same direction (one common non-negative factor) so the curvature is kept ...
    assert lim_left * right == pytest.approx(lim_right * left, abs=1e-9)
    assert lim_left * left >= 0 and lim_right * right >= 0
    # ... and pairs within the limit pass unchanged.
    if max(abs(left), abs(right)) <= limit:
        assert (float(lim_left), float(lim_right)) == (left, right)


def test_limit_versus_listing_4_clamp() -> None:
    # Listing 4 clamps each wheel alone: (4, 10) at 5 -> (4, 5), a different arc. Scaling
    # gives (2, 5), the same ratio 0.4.
    left, right = limit_wheel_speeds([4.0, 0.0], [10.0, 0.0], 5.0)
    np.testing.assert_allclose(left, [2.0, 0.0])
    np.testing.assert_allclose(right, [5.0, 0.0])


def test_limit_leaves_tiny_speeds_alone_without_overflow() -> None:
    """A subnormal wheel speed is within any limit: returned as it is, and limit / speed is
    never computed for it (it overflowed to inf with a RuntimeWarning, seen in CI)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        left, right = limit_wheel_speeds([5e-324, 0.0], [0.0, -5e-324], 1.0)
    assert list(left) == [5e-324, 0.0] and list(right) == [0.0, -5e-324]


def test_limit_refuses_bad_values() -> None:
    with pytest.raises(ValueError, match=r"left wheel speed.*nan"):
        limit_wheel_speeds(math.nan, 1.0, 5.0)
    with pytest.raises(ValueError, match=r"right wheel speed.*-inf"):
        limit_wheel_speeds(1.0, -math.inf, 5.0)
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="max_wheel_speed"):
            limit_wheel_speeds(1.0, 1.0, bad)


# -- encoders -----------------------------------------------------------------------------------

def test_tick_delta_across_the_12_bit_wrap() -> None:
    # A 12-bit count (an MX-28 in wheel mode, 0..4095) wraps at 4096; the EX-106+'s wheel-mode
    # count wraps at 65536 (e-Manual), where seed 000's final.m adds 65535 (test_a2.py).
    assert tick_delta(4090, 5, ABS12) == 11
    assert tick_delta(5, 4090, ABS12) == -11
    assert tick_delta(100, 90, ABS12) == -10  # seed 000 would count +65525 here
    np.testing.assert_array_equal(
        tick_delta([4095, 0, 2000], [0, 4095, 2100], ABS12), [1, -1, 100])


def test_tick_delta_across_the_signed_32_bit_wrap() -> None:
    top, bottom = 2**31 - 1, -(2**31)
    assert tick_delta(top - 2, bottom + 4, MULTI32) == 7
    assert tick_delta(bottom + 4, top - 2, MULTI32) == -7
    assert tick_delta(-5, 7, MULTI32) == 12
    assert tick_delta(0, 10_000_000, MULTI32) == 10_000_000  # multi-turn: no 4096 wrap


@settings(max_examples=80, deadline=None)
@given(start=st.integers(0, 4095), step=st.integers(-2048, 2047))
def test_tick_delta_recovers_any_step_under_half_a_wrap(start: int, step: int) -> None:
    assert tick_delta(start, (start + step) % 4096, ABS12) == step


def test_tick_delta_refuses_readings_outside_the_register() -> None:
    with pytest.raises(ValueError, match="4096 is outside"):
        tick_delta(4096, 0, ABS12)
    with pytest.raises(ValueError, match="-1 is outside"):
        tick_delta(0, -1, ABS12)
    with pytest.raises(ValueError, match="whole ticks"):
        tick_delta(1.5, 0, ABS12)
    with pytest.raises(ValueError, match="nan"):
        tick_delta(math.nan, 0, ABS12)


def test_distance_to_ticks() -> None:
    # One wheel circumference (2 pi 5.2 cm) is one revolution.
    assert distance_to_ticks(2 * math.pi * 0.052, ROBOT, ABS12) == pytest.approx(4096)


# -- odometry -----------------------------------------------------------------------------------

def test_equal_increments_drive_a_straight_line() -> None:
    track = integrate_odometry((1.0, 2.0, math.pi / 2), [100] * 5, [100] * 5, ROBOT, ABS12)
    step = 100 / 4096 * 2 * math.pi * 0.052
    assert track.shape == (5, 3)
    np.testing.assert_allclose(track[:, 0], 1.0, atol=1e-12)
    np.testing.assert_allclose(track[:, 1], 2.0 + step * np.arange(1, 6))
    np.testing.assert_allclose(track[:, 2], math.pi / 2)


def test_opposite_increments_rotate_in_place() -> None:
    # Right forward, left back by a quarter wheel turn each: theta = 2 * (r pi / 2) / L.
    pose = integrate_odometry((0.3, -0.2, 0.1), -1024, 1024, ROBOT, ABS12)
    assert pose.shape == (3,)
    np.testing.assert_allclose(pose[:2], [0.3, -0.2], atol=1e-15)
    assert pose[2] == pytest.approx(0.1 + 2 * 0.052 * (math.pi / 2) / 0.38)


@pytest.mark.parametrize("radius", [0.1, 0.5, 2.0])
def test_constant_ratio_traces_a_circle_of_the_expected_radius(radius: float) -> None:
    # Figure A3: wheel speeds in the ratio (1 - L/2R) : (1 + L/2R) circle with radius R.
    ratio = 0.38 / (2 * radius)
    n = 50
    d_left = np.full(n, 40.0 * (1 - ratio))
    d_right = np.full(n, 40.0 * (1 + ratio))
    track = integrate_odometry((0.0, 0.0, 0.0), d_left, d_right, ROBOT, MULTI32)
    # Counter-clockwise from the origin heading +x: the centre is (0, R).
    np.testing.assert_allclose(np.hypot(track[:, 0], track[:, 1] - radius), radius, rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(d_left=st.floats(-3000, 3000), d_right=st.floats(-3000, 3000))
def test_one_arc_equals_many_small_ones(d_left: float, d_right: float) -> None:
    # Exact arc integration does not depend on how often the encoders were read (eq. 5d).
    once = integrate_odometry((0.0, 0.0, 0.4), d_left, d_right, ROBOT, ABS12)
    many = integrate_odometry((0.0, 0.0, 0.4), np.full(64, d_left / 64),
                              np.full(64, d_right / 64), ROBOT, ABS12)[-1]
    np.testing.assert_allclose(once, many, atol=1e-12)


def test_odometry_from_raw_readings_across_the_wrap() -> None:
    left_reads = np.array([4000, 4090, 84, 178])
    right_reads = np.array([4000, 4090, 84, 178])
    d_left = tick_delta(left_reads[:-1], left_reads[1:], ABS12)
    d_right = tick_delta(right_reads[:-1], right_reads[1:], ABS12)
    pose = integrate_odometry((0.0, 0.0, 0.0), d_left, d_right, ROBOT, ABS12)[-1]
    assert pose[0] == pytest.approx(274 / 4096 * 2 * math.pi * 0.052)


def test_odometry_refuses_bad_input() -> None:
    with pytest.raises(ValueError, match="pose"):
        integrate_odometry((0.0, 0.0), 1, 1, ROBOT, ABS12)
    with pytest.raises(ValueError, match="shapes"):
        integrate_odometry((0.0, 0.0, 0.0), [1, 2], [1], ROBOT, ABS12)
    with pytest.raises(ValueError, match="nan"):
        integrate_odometry((0.0, 0.0, 0.0), math.nan, 1, ROBOT, ABS12)


# -- seed 000's moves ---------------------------------------------------------------------------

def test_circle_ccw_is_figure_a3() -> None:
    # moveCircleCCW(50, 20), seed cm: wl = 20 (1 - 38/100) / 5.2, wr = 20 (1 + 38/100) / 5.2
    move = circle(0.5, 0.2, ROBOT)
    assert move.left == pytest.approx(20 * (1 - 38 / 100) / 5.2)   # 2.3846 rad/s, inner wheel
    assert move.right == pytest.approx(20 * (1 + 38 / 100) / 5.2)  # 5.3077 rad/s
    assert move.duration == pytest.approx(2 * math.pi * 50 / 20)     # t = 2 pi radius n / speed
    # Figure A3 then converts to 0.111-rpm speed units with floor: 205 and 456.
    assert math.floor(move.left * 60 / (2 * math.pi) / 0.111) == 205
    assert math.floor(move.right * 60 / (2 * math.pi) / 0.111) == 456
    left_lin, right_lin = move.linear_speeds(ROBOT)
    assert (left_lin, right_lin) == pytest.approx((0.2 * (0.5 - 0.19) / 0.5, 0.2 * 0.69 / 0.5))


def test_circle_cw_swaps_the_inner_wheel_and_agrees_with_eq_5() -> None:
    ccw, cw = circle(0.5, 0.2, ROBOT), circle(0.5, 0.2, ROBOT, clockwise=True)
    assert (cw.left, cw.right) == (ccw.right, ccw.left)  # right wheel inner when clockwise
    v, omega = body(cw.left, cw.right, ROBOT)
    assert v == pytest.approx(0.2)
    assert omega == pytest.approx(-0.2 / 0.5)


@pytest.mark.parametrize("clockwise", [False, True])
def test_circle_closes_after_its_turns(clockwise: bool) -> None:
    move = circle(0.7, 0.25, ROBOT, clockwise=clockwise, turns=3)
    pose = moves_pose((0.0, 0.0, 0.0), [move], ROBOT)
    np.testing.assert_allclose(pose, [0.0, 0.0, (-1 if clockwise else 1) * 6 * math.pi],
                               atol=1e-12)
    assert circle_time(0.7, 0.25, 3) == move.duration


def test_figure_eight_returns_to_start_through_two_lobes() -> None:
    first, second = figure_eight(0.5, 0.2, ROBOT)
    assert (second.left, second.right) == (first.right, first.left)
    halfway = moves_pose((0.0, 0.0, 0.0), [first], ROBOT)
    end = moves_pose((0.0, 0.0, 0.0), [first, second], ROBOT)
    np.testing.assert_allclose(halfway, [0.0, 0.0, 2 * math.pi], atol=1e-12)
    np.testing.assert_allclose(end, [0.0, 0.0, 0.0], atol=1e-12)
    # The lobes lie on either side of the start: the CCW one to the left (+y).
    quarter = moves_pose((0.0, 0.0, 0.0), [circle(0.5, 0.2, ROBOT, turns=0.5)], ROBOT)
    assert quarter[1] == pytest.approx(1.0)
    # Figure A4 as printed pauses 2t per lobe: two laps each.
    assert figure_eight(0.5, 0.2, ROBOT, turns_per_lobe=2)[0].duration == pytest.approx(
        2 * circle_time(0.5, 0.2))


@pytest.mark.parametrize("angle", [math.pi / 2, -math.pi, 0.3])
def test_rotation_turns_by_the_angle_in_place(angle: float) -> None:
    move = rotation(angle, 3.0, ROBOT)
    assert abs(move.left) == abs(move.right) == 3.0 and move.left == -move.right
    assert move.duration == pytest.approx(abs(angle) * 0.38 / (2 * 0.052 * 3.0))
    np.testing.assert_allclose(moves_pose((0.0, 0.0, 0.0), [move], ROBOT), [0.0, 0.0, angle],
                               atol=1e-12)
    assert rotation(0.0, 3.0, ROBOT).duration == 0.0


def test_moves_refuse_bad_input() -> None:
    for bad in (0.0, -0.5, math.nan, math.inf):
        with pytest.raises(ValueError, match="radius"):
            circle(bad, 0.2, ROBOT)
        with pytest.raises(ValueError, match="speed"):
            circle(0.5, bad, ROBOT)
        with pytest.raises(ValueError, match="wheel_speed"):
            rotation(1.0, bad, ROBOT)
    with pytest.raises(ValueError, match="angle"):
        rotation(math.nan, 1.0, ROBOT)
    with pytest.raises(ValueError, match="turns"):
        circle_time(0.5, 0.2, 0)


def test_clamp_wheel_speeds_clamps_each_wheel_on_its_own() -> None:
    """Seed 002 Listing 4: lin_vel1 and lin_vel2 each clamped at +-LIMIT_X_MAX_VELOCITY, so
    past the limit the ratio (the path's curvature) changes; limit_wheel_speeds keeps it."""
    left, right = clamp_wheel_speeds([9.0, -9.0, 3.0], [12.0, 2.0, -4.0], 8.0)
    assert left.tolist() == [8.0, -8.0, 3.0] and right.tolist() == [8.0, 2.0, -4.0]
    scaled_left, scaled_right = limit_wheel_speeds(9.0, 12.0, 8.0)
    assert float(scaled_right) == 8.0 and float(scaled_left) == pytest.approx(6.0)
    with pytest.raises(ValueError):
        clamp_wheel_speeds(1.0, float("nan"), 8.0)
