"""Seed 000's moves on the emulated bases, measured against the simulated floor's truth.

Facts: seed 000 Appendix A (Figure A3's circle: wl = v (1 - l/2R) / r, wr = v (1 + l/2R) / r;
Figure A4's eight: a circle each way; A.2's straight line by encoder counting), the issue's
bounds (a circle's truth radius within 2 %, an eight closing within 2 % of its size, a 1 m line
within 1 %)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from servolab.robots.base.config import SHIPPED_DIR, load
from servolab.robots.base.mobile_base import MobileBase

CONFIGS = SHIPPED_DIR  # the shipped bases: package data of servolab.robots.base
BASES = ["base_seed000.yaml", "base_turtlebot3_waffle.yaml"]


def _base(name: str) -> MobileBase:
    return MobileBase.emulated(load(CONFIGS / name))


def _truth(base: MobileBase) -> np.ndarray:
    return np.array([(t[4], t[5]) for t in base.track])


@pytest.mark.parametrize("name", BASES)
def test_a_1_m_line_stops_within_1_percent(name: str) -> None:
    base = _base(name)
    base.line(1.0, 0.1)
    truth = base.truth()
    assert math.hypot(truth["x"], truth["y"]) == pytest.approx(1.0, rel=0.01)
    assert base.commands[-1][1:] == (0.0, 0.0)  # ends stopped


@pytest.mark.parametrize("name", BASES)
@pytest.mark.parametrize("clockwise", [False, True])
@pytest.mark.slow
def test_a_circle_has_its_radius_within_2_percent(name: str, clockwise: bool) -> None:
    base = _base(name)
    base.circle(0.5, 0.1, clockwise=clockwise)
    points = _truth(base)
    centre = points.mean(axis=0)
    radii = np.hypot(*(points - centre).T)
    assert np.mean(radii) == pytest.approx(0.5, rel=0.02)
    assert np.sign(centre[1]) == (-1 if clockwise else 1)  # CCW turns left (REP 103)
    assert base.commands[-1][1:] == (0.0, 0.0)


@pytest.mark.parametrize("name", BASES)
@pytest.mark.slow
def test_a_figure_of_eight_closes_within_2_percent_of_its_size(name: str) -> None:
    base = _base(name)
    base.eight(0.3, 0.1)
    truth = base.truth()
    size = 4 * 0.3  # two circles side by side
    assert math.hypot(truth["x"], truth["y"]) < 0.02 * size
    points = _truth(base)
    assert points[:, 1].max() == pytest.approx(0.6, rel=0.03)   # the left lobe
    assert points[:, 1].min() == pytest.approx(-0.6, rel=0.03)  # the right lobe


def test_a_rotation_turns_in_place() -> None:
    base = _base("base_seed000.yaml")
    base.rotate(math.pi / 2)
    truth = base.truth()
    assert truth["yaw"] == pytest.approx(math.pi / 2, abs=0.02)
    assert math.hypot(truth["x"], truth["y"]) < 1e-3


@pytest.mark.parametrize(("move", "says"), [
    (lambda b: b.circle(0.0, 0.1), "radius must be a number > 0"),
    (lambda b: b.circle(-0.5, 0.1), "radius must be a number > 0"),
    (lambda b: b.line(1.0, math.nan), "speed must be a number > 0"),
    (lambda b: b.set_wheel_speeds(math.nan, 1.0), "must be finite"),
    (lambda b: b.line(1.0, 2.0), "over the EX-106\\+'s 9.529 rad/s"),
    (lambda b: b.circle(0.3, 0.45), "needs the right wheel at"),
])
def test_bad_moves_are_refused_and_nothing_moves(move: object, says: str) -> None:
    base = _base("base_seed000.yaml")
    sent = len(base.commands)
    with pytest.raises(ValueError, match=says):
        move(base)  # type: ignore[operator]
    assert len(base.commands) == sent
    assert base.truth()["distance"] == 0.0


def test_speeds_over_the_motors_limit_are_scaled_keeping_the_curvature() -> None:
    base = _base("base_seed000.yaml")
    top = base.max_wheel_speed
    left, right = base.set_wheel_speeds(2 * top, 4 * top)
    assert right == pytest.approx(top) and left / right == pytest.approx(0.5)
    base.stop()


def test_rpm_reads_each_wheel() -> None:
    base = _base("base_turtlebot3_waffle.yaml")
    base.set_wheel_speeds(2.0, 2.0)
    base.clock.sleep(0.5)
    rpm = base.rpm()
    assert rpm[1] == pytest.approx(2.0 * 60 / (2 * math.pi), rel=0.02)
    # the right motor is mounted mirrored but in reverse Drive Mode (ROBOTIS's
    # turtlebot3_setup_motor.ino writes Drive Mode 1 on it): it reads forward as positive
    assert rpm[2] == pytest.approx(rpm[1], rel=0.02)
    base.stop()


def test_the_waffles_encoders_both_count_up_driving_forward() -> None:
    """Seed 002 Listing 4 sends one signed speed to both wheels and logs both encoders as
    they count: on a Waffle set up by ROBOTIS (right motor Drive Mode 1, OpenCR's
    turtlebot3_setup_motor.ino) both count up when it drives forward, and the emulated motor
    honours the Drive Mode bit (its register reads 1 after setup)."""
    base = _base("base_turtlebot3_waffle.yaml")
    assert int(base.bus.read(2, "drive_mode", raw=True)) & 1 == 1
    assert int(base.bus.read(1, "drive_mode", raw=True)) & 1 == 0
    before = {i: int(base.bus.read(i, "present_position", raw=True)) for i in (1, 2)}
    base.set_wheel_speeds(2.0, 2.0)
    base.clock.sleep(1.0)
    base.stop()
    after = {i: int(base.bus.read(i, "present_position", raw=True)) for i in (1, 2)}
    assert after[1] - before[1] > 500 and after[2] - before[2] > 500
    pose = base.update_odometry()
    assert pose.x > 0.05 and abs(pose.theta) < 0.01  # straight ahead


def test_the_velocity_limit_register_bounds_a_2_0_wheel() -> None:
    """An XM430's goal_velocity above its velocity_limit is refused by the motor (e-Manual):
    the base never asks for more, so both wheels turn."""
    base = _base("base_turtlebot3_waffle.yaml")
    limit = float(base.bus.read(1, "velocity_limit"))
    assert base.max_wheel_speed == pytest.approx(min(limit, base.config.max_wheel_speed))
    base.set_wheel_speeds(3.8, 100.0)
    base.clock.sleep(0.2)
    assert abs(float(base.bus.read(2, "present_velocity"))) == pytest.approx(
        base.max_wheel_speed, rel=0.01)
    base.stop()


def test_the_seeds_own_sync_write_moves_the_4_motor_base() -> None:
    """Seed 000 A.2 (final.m, tx.m): for a forward move at 30 % (s = round(0.3 x 1023)),
    motors 1 and 2 get a = 1023 + s and motors 3 and 4 get b = s, in one SYNC_WRITE to the
    broadcast ID of address 32 (moving speed), 2 bytes each, with no torque-enable write:
    sent as the seed builds it (with m34 where tx.m's slip wrote the literal 34), the emulated
    4-motor base, torque off before, rolls forwards and nearly straight."""
    from servolab.dynamixel.protocol1 import checksum

    base = _base("base_seed000_4motor.yaml")
    base.bus.sync_write("torque_enable", dict.fromkeys([1, 2, 3, 4], 0))
    s = round(0.3 * 1023)
    a, b = 1023 + s, s
    params = [32, 2]
    for motor_id, value in ((1, a), (2, a), (3, b), (4, b)):
        params += [motor_id, value & 0xFF, value >> 8]
    body = bytes([0xFE, 16, 0x83, *params])  # length 16 = (2 + 1) x 4 + 4, as tx.m says
    base.bus.port.write(b"\xff\xff" + body + bytes([checksum(body)]))
    base.clock.sleep(2.0)
    truth = base.truth()
    # forwards: 30 % of the EX-106+'s 91 rpm no-load speed on A.2's 0.1021 m wheel (final.m's
    # 5265/575 counts a mm, test_a2.py), 2 s: 0.58 m
    assert truth["x"] == pytest.approx(0.3 * 91 * 2 * math.pi / 60 * 0.1021 * 2.0, rel=0.02)
    assert abs(truth["yaw"]) < 0.05 and abs(truth["y"]) < 0.02
    assert all(base.bus.read(i, "torque_enable") == 1 for i in (1, 2, 3, 4))


def test_encoder_wrap_around_on_a_long_line() -> None:
    """The EX-106+ in wheel mode counts 0..65535 (e-Manual, servolab.dynamixel.models): a 5 m
    line on 5.2 cm wheels turns them 15 times, past the wrap; odometry stays right."""
    base = _base("base_seed000.yaml")
    base.line(5.0, 0.4)
    truth = base.truth()
    assert math.hypot(truth["x"], truth["y"]) == pytest.approx(5.0, rel=0.01)
    assert base.pose.x == pytest.approx(truth["x"], rel=0.01)
    turned = base.wheel_angles()[0] / (2 * math.pi)
    assert turned > 65536 / base.encoder.ticks_per_rev  # more than one wrap of the register


def test_a_line_backwards_and_zero_length_moves() -> None:
    base = _base("base_seed000.yaml")
    base.line(-0.5, 0.1)
    assert base.truth()["x"] == pytest.approx(-0.5, rel=0.01)
    sent = len(base.commands)
    assert base.line(0.0, 0.1) == 0.0
    base.rotate(0.0)
    assert len(base.commands) == sent  # the wheels were not started


def test_an_mx28_base_counts_its_turns_and_an_rx28_base_is_refused(tmp_path: Path) -> None:
    """MX-28 wheel mode: present_position the ticks of each turn (0..4095); RX-28: a
    potentiometer, which cannot count a wheel's turns (servolab.dynamixel.models)."""
    from servolab.robots.base.config import BaseConfigError

    text = (CONFIGS / "base_seed000.yaml").read_text()
    mx = tmp_path / "mx.yaml"
    mx.write_text(text.replace("model: EX-106+", "model: MX-28"))
    base = MobileBase.emulated(load(mx))
    base.line(1.0, 0.1)
    assert math.hypot(base.truth()["x"], base.truth()["y"]) == pytest.approx(1.0, rel=0.01)
    rx = tmp_path / "rx.yaml"
    rx.write_text(text.replace("model: EX-106+", "model: RX-28"))
    with pytest.raises(BaseConfigError, match="potentiometer"):
        load(rx)
