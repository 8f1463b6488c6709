"""Listing 1's control law (seed 002, Appendix A), frame by frame: the error, the 20° camera
rotation, the dead band, omega_i = (J1M[i] . (dxm, dym, dthm SF)) K, and the robot's Twist."""

from __future__ import annotations

import math

import pytest

from servolab.kinematics.aot import THESIS_J1M
from servolab.robots.treadmill.control import FlyControllerConfig, fly_command
from servolab.vision.fly_tracker import FlySighting


def _sighting(cx: float, cy: float, theta: float = 0.0) -> FlySighting:
    return FlySighting(True, cx, cy, theta, 400.0)


def test_wheel_speeds_are_the_listings_formula() -> None:
    cx, cy, theta = 400.0, 150.0, 0.2
    command = fly_command(_sighting(cx, cy, theta), 15_000)
    thm = 20 * 3.141592 / 180  # the listing's pi
    dx, dy, dth = cx - 320.0, cy - 188.0, -(theta - 0.0)
    dxm = math.cos(thm) * dx - math.sin(thm) * dy
    dym = math.sin(thm) * dx + math.cos(thm) * dy
    for i in range(3):
        j = THESIS_J1M[i]
        expected = (j[0] * dxm + j[1] * dym + j[2] * dth * 60.0) * 100.0
        assert command.wheel_speeds[i] == pytest.approx(expected, rel=1e-12)
    assert (command.dxm, command.dym, command.dthm) == pytest.approx((dxm, dym, dth))
    # the robot: distance * 38.4098 * 0.01 / ms forward, dthm / ms * 57 turning
    assert command.linear == pytest.approx(math.hypot(dx, dy) * 38.40983291722681 * 0.01 / 15)
    assert command.angular == pytest.approx(dth / 15 * 57)


def test_inside_the_dead_band_nothing_moves() -> None:
    """Ch. 3: a tolerance of 50 px and 3°."""
    command = fly_command(_sighting(320.0 + 30.0, 188.0 + 40.0, math.radians(2.9)), 15_000)
    assert command.wheel_speeds == (0.0, 0.0, 0.0) and not command.compensating
    assert (command.linear, command.angular) == (0.0, 0.0)
    # one band is enough to move the wheels; the robot only acts on the one that is out
    turned = fly_command(_sighting(330.0, 190.0, math.radians(4.0)), 15_000)
    assert turned.compensating and any(v != 0 for v in turned.wheel_speeds)
    assert turned.linear == 0.0 and turned.angular != 0.0


def test_an_absent_fly_is_no_error() -> None:
    """Listing 1: a fly not found leaves cx, cy, theta at the target: zero error."""
    absent = FlySighting(False, 320.0, 188.0, 0.0, 12.0)
    command = fly_command(absent, 15_000)
    assert command.wheel_speeds == (0.0, 0.0, 0.0) and (command.dx, command.dy) == (0.0, 0.0)


def test_wheel_speeds_are_scaled_within_the_motors_limit() -> None:
    """All three alike, so that the ball turns the way the error asks, only slower."""
    free = fly_command(_sighting(640.0, 376.0, 1.2), 15_000)
    config = FlyControllerConfig(max_wheel_speed=10.0)
    command = fly_command(_sighting(640.0, 376.0, 1.2), 15_000, config)
    assert max(abs(v) for v in command.wheel_speeds) == pytest.approx(10.0)
    scale = command.wheel_speeds[0] / free.wheel_speeds[0]
    assert command.wheel_speeds == pytest.approx(tuple(v * scale for v in free.wheel_speeds))


def test_a_first_frame_has_no_robot_speed_and_bad_config_is_refused() -> None:
    assert fly_command(_sighting(500.0, 300.0, 0.5), 0.0).linear == 0.0
    with pytest.raises(ValueError, match="gain"):
        FlyControllerConfig(gain=math.nan)


# -- the dead band's edges ---------------------------------------------------------------------
# Seed 002, Listing 1: "double limit_r = 50; double limit_th = 3*3.141592/180;" and
# "if ((sqrt(dx*dx + dy*dy) > limit_r) || (fabs(dth) > limit_th))" for the wheels, the same
# "> limit_r" for lin_vel and "(fabs(dth) > limit_th)" for ang_vel: strictly greater, so a fly
# exactly on a limit is inside the band; the listing's truncated pi sets the angle's limit.
# (30, 40) is 50 px exactly: hypot(30, 40) == 50.0 in floating point.
LIMIT_TH = 3 * 3.141592 / 180


def _at(dx: float, dy: float, dth: float = 0.0) -> tuple[float, float, float]:
    """A sighting's (cx, cy, theta) with the error (dx, dy, dth) to Listing 1's target
    (320, 188, 0); dth = -(theta - 0)."""
    return 320.0 + dx, 188.0 + dy, -dth


def test_exactly_50_px_is_inside_the_band_and_just_beyond_is_outside() -> None:
    assert math.hypot(30.0, 40.0) == 50.0
    for dx, dy in ((30.0, 40.0), (-40.0, 30.0), (0.0, -50.0), (50.0, 0.0)):
        on = fly_command(_sighting(*_at(dx, dy)), 15_000)
        assert math.hypot(on.dx, on.dy) == 50.0
        assert not on.compensating and on.wheel_speeds == (0.0, 0.0, 0.0)
        assert on.linear == 0.0 and on.angular == 0.0
    # the next float beyond 228 px: dy = 40.00000000000003, the distance just above 50
    # (with a heading error of half the angle's band: the robot must not turn for it)
    cy = math.nextafter(188.0 + 40.0, math.inf)
    beyond = fly_command(_sighting(320.0 + 30.0, cy, -LIMIT_TH / 2), 15_000)
    assert math.hypot(beyond.dx, beyond.dy) > 50.0
    assert beyond.compensating and all(v != 0.0 for v in beyond.wheel_speeds)
    assert beyond.linear == pytest.approx(50.0 * 38.40983291722681 * 0.01 / 15)
    assert beyond.angular == 0.0  # the angle is within its band: no turn
    # and just inside: the float below 50 px
    inside = fly_command(_sighting(320.0 + 30.0, math.nextafter(228.0, -math.inf)), 15_000)
    assert math.hypot(inside.dx, inside.dy) < 50.0 and not inside.compensating


@pytest.mark.parametrize("turn", [1.0, -1.0], ids=["dth+", "dth-"])
def test_exactly_3_degrees_is_inside_the_band_and_just_beyond_is_outside(turn: float) -> None:
    # the fly 30 px from the target, within the distance's band, throughout
    on = fly_command(_sighting(*_at(30.0, 0.0, turn * LIMIT_TH)), 15_000)
    assert abs(on.dth) == LIMIT_TH
    assert not on.compensating and on.wheel_speeds == (0.0, 0.0, 0.0)
    assert on.angular == 0.0 and on.linear == 0.0
    past = math.nextafter(LIMIT_TH, math.inf)
    beyond = fly_command(_sighting(*_at(30.0, 0.0, turn * past)), 15_000)
    assert abs(beyond.dth) > LIMIT_TH
    assert beyond.compensating and all(v != 0.0 for v in beyond.wheel_speeds)
    assert beyond.angular == pytest.approx(turn * past / 15 * 57)  # dthm / ms * 57
    assert beyond.linear == 0.0  # the distance is within its band: no drive
    inside = fly_command(_sighting(*_at(30.0, 0.0, turn * math.nextafter(LIMIT_TH, 0.0))),
                         15_000)
    assert not inside.compensating and inside.angular == 0.0


def test_the_angle_band_is_the_listings_3_degrees_with_its_pi() -> None:
    """3 * 3.141592 / 180 is 1.1e-8 rad short of 3 degrees: a heading error between the two
    is outside Listing 1's band (math.radians(3) would leave it inside)."""
    between = (LIMIT_TH + math.radians(3.0)) / 2
    assert LIMIT_TH < between < math.radians(3.0)
    command = fly_command(_sighting(*_at(0.0, 0.0, between)), 15_000)
    assert command.compensating and command.angular != 0.0
