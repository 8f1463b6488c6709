"""Seed 000 A.2's straight line (final.m) run as written: its counts per mm, its speed
percentage, its counting loop as meant and as printed, and the 4-motor base's wheel radius
that its constant implies (issue 30).

Facts and where they come from:

- final.m (seed 000, Appendix A.2, the listing after "Flexible code in Matlab for close loop
  control of Dynamixel EX106+ actuator"): ``h=abs(round((5265/575)*d))`` with ``d`` "Distance to
  move in mm" (its comment: 1000); ``s=abs(round((s/100)*1023))`` from "Speed Percentage" (its
  comment: 30); ``m=4`` read forwards ("motor 1&2 clockwise, motor 3&4 counter clockwise"),
  ``m=1`` backwards; ``if q-p>0 i=i+q-p; else i=i+q-p+65535;``; ``pause(0.0001)`` between reads.
- ROBOTIS e-Manual, EX-106+ (docs/en/dxl/ex/ex-106+.md): Present Position in Wheel Mode is
  "0~65535 (0XFFFF), and the unit is 0.06 degree", "if it is increased when it is 65535, the
  value becomes 0"; Moving Speed in Wheel Mode "0~2047 ... the unit is about 0.1%", "only the
  output control is possible, not speed". servolab's EX-106+ table: 250.92 degrees over 4095
  counts (0.06127 degree a count, 5875.2 counts a turn), no-load speed 91 rpm.
- Figure A3 (seed 000, Appendix A.1): the two-wheel robot's ``r = 5.2`` cm.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from servolab.dynamixel.models import model
from servolab.dynamixel.units import wheel_speed_raw
from servolab.kinematics.diffdrive import (
    A2_COUNTS_PER_MM,
    a2_increment_as_printed,
    a2_target_counts,
    matlab_round,
    radius_from_counts_per_mm,
    replay_a2_count,
)
from servolab.robots.base.config import BaseConfig, load, shipped_base
from servolab.robots.base.mobile_base import (
    MAX_MOVE_SECONDS,
    MobileBase,
    counting_motor,
    encoder_of,
    percent_speed,
)

FOUR = load(shipped_base("seed000_4motor"))
EX106 = encoder_of(model("EX-106+"))


def test_final_m_s_counts_per_mm_imply_a_0_102_m_wheel_not_figure_a3s() -> None:
    """The issue's finding, checked: 5265/575 counts a mm on the EX-106+'s 5875.2 counts a
    turn is a 641.6 mm wheel turn, radius 0.1021 m; the 4-motor base now has it. On Figure
    A3's 0.052 m wheel final.m's h for 1000 mm rolls 509.2 mm (the issue says 508.8: the same
    ratio with the radius rounded to 0.1022 m). With 4096 counts a turn (the 12-bit joint
    range) it would be 0.0712 m, and with the e-Manual's rounded 0.06 degree 0.1043 m: the
    table's 0.06127 degree is the one the emulated encoder counts with."""
    assert round(A2_COUNTS_PER_MM, 5) == 9.15652
    assert EX106.ticks_per_rev == pytest.approx(4095 * 360 / 250.92, rel=1e-12)
    assert EX106.modulus == 65536
    implied = radius_from_counts_per_mm(A2_COUNTS_PER_MM, EX106)
    assert implied == pytest.approx(0.10212, abs=1e-5)
    assert FOUR.wheel_radius == pytest.approx(implied, rel=1e-3)
    h = a2_target_counts(1.0, A2_COUNTS_PER_MM)          # final.m's d = 1000 (mm)
    assert h == 9157
    rolled_on_5_2_cm = h / EX106.ticks_per_rev * 2 * math.pi * 0.052
    assert rolled_on_5_2_cm == pytest.approx(0.5092, abs=1e-4)
    # the same counts a millimetre on the EX-106+ read at other scales
    twelve_bit = dataclasses.replace(EX106, ticks_per_rev=4096)  # the 12-bit joint range
    assert radius_from_counts_per_mm(A2_COUNTS_PER_MM, twelve_bit) == \
        pytest.approx(0.0712, abs=1e-4)
    rounded = dataclasses.replace(EX106, ticks_per_rev=360 / 0.06)  # e-Manual: 0.06 degree
    assert radius_from_counts_per_mm(A2_COUNTS_PER_MM, rounded) == \
        pytest.approx(0.1043, abs=1e-4)


def test_matlab_round_goes_half_away_from_zero() -> None:
    """final.m's round is MATLAB's (halves away from zero), not Python's (halves to even)."""
    assert (matlab_round(2.5), matlab_round(-2.5), round(2.5)) == (3, -3, 2)
    assert a2_target_counts(-0.5, 2.0) == 1000


def test_the_speed_percentage_is_final_ms_moving_speed_on_the_wire() -> None:
    """30 % -> s = round(0.3 x 1023) = 307, a share of full output (e-Manual, Moving Speed,
    Wheel Mode), taken as 30 % of the 91 rpm no-load speed; the m/s it becomes encodes back
    to 307, and the mirrored motors get 1024 + 307 (final.m writes 1023 + s: 306 clockwise)."""
    speed = percent_speed(FOUR, 30)
    assert speed == pytest.approx(307 / 1023 * 91 * 2 * math.pi / 60 * FOUR.wheel_radius,
                                  rel=1e-3)
    wheel = speed / FOUR.wheel_radius
    assert wheel_speed_raw(FOUR.model, wheel) == 307
    assert wheel_speed_raw(FOUR.model, -wheel) == 1024 + 307
    waffle = load(shipped_base("turtlebot3_waffle"))
    for config, pct, says in ((waffle, 30.0, "XM430-W210 is given a velocity"),
                              (FOUR, 150.0, r"in \(0, 100\], not 150"),
                              (FOUR, 0.01, "rounds to a moving speed of 0")):
        with pytest.raises(ValueError, match=says):
            percent_speed(config, pct)


def test_final_m_reads_motor_4_forwards_and_motor_1_backwards() -> None:
    """final.m: m=4 for d > 0, m=1 for d < 0: the motors whose count rises on that move."""
    assert (counting_motor(FOUR, True)[0].id, counting_motor(FOUR, False)[0].id) == (4, 1)


def test_the_count_as_printed_slips_at_the_wrap_and_on_equal_reads() -> None:
    """``q-p+65535`` on a wrap counts one short (65534 -> 2 is 4 counts); on equal reads it
    adds 65535, which ends any line under 65535 counts at once."""
    assert a2_increment_as_printed(65534, 2) == 3
    wrap = [65534, 2, 6]  # from 65530: 4 + 4 + 4 counts
    assert replay_a2_count(65530, wrap, 100, EX106, as_printed=False).counts == (4, 8, 12)
    printed = replay_a2_count(65530, wrap, 100, EX106, as_printed=True)
    assert printed.counts == (4, 7, 11) and printed.wraps == 1
    still = [103, 103, 106, 109]   # the wheel did not move a count between two reads
    meant = replay_a2_count(100, still, 9157, EX106, as_printed=False)
    assert meant.counts == (3, 3, 6, 9) and meant.stop is None and meant.equal_reads == 1
    slipped = replay_a2_count(100, still, 9157, EX106, as_printed=True)
    assert slipped.counts == (3, 65538) and slipped.stop == 1


def _four_motor(radius: float | None = None) -> MobileBase:
    config: BaseConfig = FOUR if radius is None else dataclasses.replace(
        FOUR, wheel_radius=radius)
    return MobileBase.emulated(config)


@pytest.mark.parametrize(("radius", "rolled"), [(None, 0.200), (0.052, 0.200 * 0.052 / 0.10212)])
def test_final_m_s_line_rolls_its_distance_only_on_the_wheel_it_implies(
        radius: float | None, rolled: float) -> None:
    """The loop as meant, on the emulated 4-motor base at 30 %: 200 mm asked, h = 1831
    counts; the truth is 200 mm on the 0.1021 m wheel, 102 mm on Figure A3's 0.052 m one."""
    base = _four_motor(radius)
    counted = base.count_line(0.2, percent_speed(base.config, 30), A2_COUNTS_PER_MM)
    assert (counted.motor, counted.target) == (4, 1831)
    assert counted.target <= counted.counted <= counted.target + 3
    truth = base.truth()
    assert math.hypot(truth["x"], truth["y"]) == pytest.approx(rolled, rel=0.01)
    assert base.commands[-1][1:] == (0.0, 0.0)
    assert counted.final_read - counted.counted == pytest.approx(2048, abs=5)  # started at 2048


def test_final_m_s_line_as_printed_stops_at_its_first_equal_read() -> None:
    """As printed, on the emulated base (its wheels move each 1 ms physics step, final.m reads
    every ~0.8 ms), the second read equals the first: i jumps past h and the line ends after
    less than a millimetre."""
    base = _four_motor()
    counted = base.count_line(1.0, percent_speed(base.config, 30), A2_COUNTS_PER_MM,
                              as_printed=True)
    assert counted.equal_reads == 1 and counted.reads <= 3
    assert counted.counted > 65535 > counted.target == 9157
    assert base.truth()["distance"] < 0.001


@pytest.mark.parametrize(("move", "says"), [
    (lambda b: b.line(1e6, 0.1), "a line of 1e\\+06 m at 0.1 m/s would take 1e\\+07 s"),
    (lambda b: b.line(1.0, 1e-6), "would take 1e\\+06 s"),
    (lambda b: b.circle(0.5, 0.1, turns=1e4), "10000 turn\\(s\\) of a circle"),
    (lambda b: b.eight(100.0, 0.1), "an eight of 100 m"),
    (lambda b: b.rotate(math.radians(1e9)), "a rotation of 1e\\+09 deg .* 3.25e\\+07 s"),
    (lambda b: b.count_line(1e4, 0.29, A2_COUNTS_PER_MM), "a line of 91565217 counts"),
])
def test_an_absurd_move_is_refused_before_a_wheel_turns(move: object, says: str) -> None:
    """Issue 30: rotate --angle 1e9 planned 63.8 million seconds (on 0.052 m wheels; 32.5
    million on the 4-motor base's 0.1021 m). Every move kind is refused over
    MAX_MOVE_SECONDS (600 s), naming its value and the limit, and nothing is sent."""
    base = _four_motor()
    sent = len(base.commands)
    with pytest.raises(ValueError, match=says) as info:
        move(base)  # type: ignore[operator]
    assert f"over the {MAX_MOVE_SECONDS:g} s" in str(info.value)
    assert "\n" not in str(info.value)
    assert len(base.commands) == sent and base.truth()["distance"] == 0.0
