"""Raw register values <-> SI units, checked against the e-Manual's scales.

`units` is the only place where ticks become radians; a scale or sign error here sends every
joint of a robot to the wrong angle or spins a wheel the wrong way. Expected values are computed
here from the e-Manual figures (300° over 0..1023 on the RX-28, 4096 ticks per turn on the
X-series and MX-28, 0.111 / 0.114 / 0.229 rpm per speed unit, bit 10 = clockwise on 1.0).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from servolab.dynamixel import ConfigError, model
from servolab.dynamixel.units import from_si, to_si

RPM = 2 * math.pi / 60  # rad/s per rpm

RX28 = model("RX-28")
EX106 = model("EX-106+")
MX28 = model("MX-28")
XM210 = model("XM430-W210")
XL250 = model("XL430-W250")

RX28_TICK = math.radians(300.0) / 1023   # e-Manual: 0..1023 covers 0..300°
X_TICK = 2 * math.pi / 4096              # e-Manual: 4096 pulses per revolution


def si(m, name: str, raw: int) -> float:
    return to_si(m, m.register(name), raw)


def raw_of(m, name: str, value) -> int:
    return from_si(m, m.register(name), value)


# -- position ----------------------------------------------------------------------------------

def test_rx28_centre_is_zero() -> None:
    """512 is the horn's middle (150° on the e-Manual dial), which servolab calls 0 rad."""
    assert si(RX28, "goal_position", 512) == 0.0
    assert si(RX28, "present_position", 512) == 0.0
    assert raw_of(RX28, "goal_position", 0.0) == 512


def test_rx28_ends_are_plus_minus_150_degrees() -> None:
    """0 and 1023 are the dial's ends, 300° apart: 1023 is +150°, 0 is -150° (within the
    half-tick the odd tick count forces), and counter-clockwise is positive."""
    top = si(RX28, "present_position", 1023)
    bottom = si(RX28, "present_position", 0)
    assert top - bottom == pytest.approx(math.radians(300.0), abs=1e-12)
    assert top == pytest.approx(math.radians(150.0), abs=RX28_TICK)
    assert bottom == pytest.approx(math.radians(-150.0), abs=RX28_TICK)
    assert top > 0 > bottom


def test_rx28_one_tick_is_0_29_degrees() -> None:
    """e-Manual: resolution 0.29° (300° / 1023)."""
    step = si(RX28, "goal_position", 513) - si(RX28, "goal_position", 512)
    assert step == pytest.approx(RX28_TICK, rel=1e-12)
    assert math.degrees(step) == pytest.approx(0.29, abs=0.005)


@pytest.mark.parametrize("m", [XM210, XL250, MX28], ids=lambda m: m.name)
def test_4096_ticks_per_turn(m) -> None:
    """X-series and MX-28: 4096 ticks a turn, 2048 (180° on the dial) is 0 rad, 3072 is a
    quarter turn counter-clockwise, 0 is half a turn clockwise."""
    assert si(m, "present_position", 2048) == 0.0
    assert si(m, "present_position", 3072) == pytest.approx(math.pi / 2, abs=1e-12)
    assert si(m, "present_position", 1024) == pytest.approx(-math.pi / 2, abs=1e-12)
    assert si(m, "present_position", 0) == pytest.approx(-math.pi, abs=1e-12)
    assert raw_of(m, "goal_position", math.pi / 2) == 3072


def test_x_series_multi_turn_positions() -> None:
    """X-series positions are signed 32-bit and count turns: one turn past the centre is 2π,
    and negative ticks are further clockwise."""
    assert si(XM210, "present_position", 2048 + 4096) == pytest.approx(2 * math.pi)
    assert si(XM210, "present_position", -2048) == pytest.approx(-2 * math.pi)
    assert raw_of(XM210, "goal_position", 4 * math.pi) == 2048 + 2 * 4096


def test_ex106_position_scale() -> None:
    """EX-106+: 0..4095 covers about 251° (e-Manual: 0.06° resolution), centre 2048."""
    assert si(EX106, "present_position", 2048) == 0.0
    span = si(EX106, "present_position", 4095) - si(EX106, "present_position", 0)
    assert math.degrees(span) == pytest.approx(251.0, abs=0.2)
    step = si(EX106, "present_position", 2049) - si(EX106, "present_position", 2048)
    assert math.degrees(step) == pytest.approx(0.06, abs=0.002)


# -- speed ---------------------------------------------------------------------------------------

@pytest.mark.parametrize(("m", "per_unit"), [(RX28, 0.111), (EX106, 0.111), (MX28, 0.114)],
                         ids=lambda v: getattr(v, "name", str(v)))
def test_protocol1_speed_units_and_direction_bit(m, per_unit: float) -> None:
    """1.0 speed: bits 0..9 are the magnitude in `per_unit` rpm, bit 10 (1024) means
    clockwise, which servolab makes negative."""
    assert si(m, "moving_speed", 100) == pytest.approx(100 * per_unit * RPM, rel=1e-12)
    assert si(m, "moving_speed", 1024 + 100) == pytest.approx(-100 * per_unit * RPM, rel=1e-12)
    assert si(m, "present_speed", 1023) == pytest.approx(1023 * per_unit * RPM, rel=1e-12)
    assert si(m, "present_speed", 2047) == pytest.approx(-1023 * per_unit * RPM, rel=1e-12)
    assert si(m, "moving_speed", 1024) == 0.0
    assert raw_of(m, "moving_speed", 100 * per_unit * RPM) == 100
    assert raw_of(m, "moving_speed", -100 * per_unit * RPM) == 1024 + 100


def test_protocol1_negative_speed_sets_bit_10() -> None:
    """-1 rad/s on an RX-28 is round(1 / (0.111 rpm)) units with the clockwise bit."""
    expected = round(1.0 / (0.111 * RPM))
    assert raw_of(RX28, "moving_speed", -1.0) == expected | 1024
    assert raw_of(RX28, "moving_speed", 1.0) == expected


@pytest.mark.parametrize("m", [XM210, XL250], ids=lambda m: m.name)
def test_x_series_velocity_unit(m) -> None:
    """2.0 velocity: signed, 0.229 rpm a unit, negative is clockwise."""
    assert si(m, "goal_velocity", 100) == pytest.approx(100 * 0.229 * RPM, rel=1e-12)
    assert si(m, "goal_velocity", -100) == pytest.approx(-100 * 0.229 * RPM, rel=1e-12)
    assert si(m, "present_velocity", -7) == pytest.approx(-7 * 0.229 * RPM, rel=1e-12)
    assert raw_of(m, "goal_velocity", -100 * 0.229 * RPM) == -100


# -- other kinds -------------------------------------------------------------------------------

def test_other_units() -> None:
    """Voltage 0.1 V, temperature 1 °C, return delay 2 µs, current 2.69 mA (XM430), load
    0.1 % with bit 10 = clockwise on 1.0 and signed on 2.0, baud register -> bps."""
    assert si(RX28, "present_voltage", 120) == pytest.approx(12.0)
    assert si(XM210, "present_input_voltage", 121) == pytest.approx(12.1)
    assert si(RX28, "present_temperature", 37) == 37.0
    assert si(RX28, "return_delay_time", 250) == pytest.approx(500e-6)
    assert si(XM210, "present_current", 100) == pytest.approx(0.269)
    assert si(XM210, "present_current", -100) == pytest.approx(-0.269)
    assert si(RX28, "present_load", 500) == pytest.approx(0.5)
    assert si(RX28, "present_load", 1024 + 500) == pytest.approx(-0.5)
    assert si(XL250, "present_load", -500) == pytest.approx(-0.5)
    assert si(RX28, "baud_rate", 34) == 57_142
    assert si(XM210, "baud_rate", 3) == 1_000_000
    assert raw_of(RX28, "baud_rate", 1_000_000) == 1
    assert raw_of(RX28, "return_delay_time", 0.0001) == 50
    assert raw_of(RX28, "torque_limit", 0.5) == round(0.5 * 1023)


# -- bad values ------------------------------------------------------------------------------

@pytest.mark.parametrize(("m", "name", "value"), [
    (RX28, "goal_position", 3.0),                   # beyond +150°
    (RX28, "goal_position", -2.7),                  # beyond -150°
    (RX28, "moving_speed", 20.0),                   # > 1023 × 0.111 rpm = 11.9 rad/s
    (RX28, "moving_speed", -20.0),
    (MX28, "moving_speed", 13.0),                   # > 1023 × 0.114 rpm = 12.2 rad/s
    (XM210, "goal_velocity", 30.0),                 # > 1023 × 0.229 rpm = 24.5 rad/s
    (XM210, "goal_velocity", -30.0),
    (XM210, "goal_position", 2000.0),               # beyond ±1 048 575 ticks
    (RX28, "torque_enable", 2),
    (RX28, "torque_enable", 0.5),
    (RX28, "return_delay_time", 0.001),             # 500 units > 254
    (XM210, "profile_velocity", -1.0),
])
def test_out_of_range_is_config_error_naming_register(m, name: str, value: float) -> None:
    """A value the register cannot hold is refused before it is encoded, naming the
    register, in one line. Never wrapped, truncated, or folded into the direction bit."""
    with pytest.raises(ConfigError) as info:
        raw_of(m, name, value)
    assert name in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("value", ["abc", math.nan, math.inf, -math.inf, None, "", [1.0]])
@pytest.mark.parametrize("name", ["goal_position", "moving_speed", "torque_enable"])
def test_non_numeric_is_config_error_naming_register(name: str, value) -> None:
    """Strings, None and non-finite floats are user mistakes, not numbers to round."""
    with pytest.raises(ConfigError) as info:
        raw_of(RX28, name, value)
    assert name in str(info.value)


def test_numeric_strings_are_accepted() -> None:
    """Values from the command line arrive as text; "0" is a number."""
    assert raw_of(RX28, "goal_position", "0") == 512


# -- round trips -------------------------------------------------------------------------------

@given(st.integers(0, 1023))
def test_rx28_position_raw_round_trip(raw: int) -> None:
    """Every tick converts to an angle that converts back to the same tick."""
    assert raw_of(RX28, "goal_position", si(RX28, "goal_position", raw)) == raw


@given(st.integers(0, 4095))
def test_ex106_and_mx28_position_raw_round_trip(raw: int) -> None:
    for m in (EX106, MX28):
        assert raw_of(m, "goal_position", si(m, "goal_position", raw)) == raw


@given(st.integers(-1_048_575, 1_048_575))
def test_x_position_raw_round_trip(raw: int) -> None:
    assert raw_of(XM210, "goal_position", si(XM210, "goal_position", raw)) == raw


@given(st.integers(0, 2047).filter(lambda r: r != 1024))
def test_protocol1_speed_raw_round_trip(raw: int) -> None:
    """Both directions survive; 1024 (clockwise zero) is the one value that means 0."""
    assert raw_of(RX28, "moving_speed", si(RX28, "moving_speed", raw)) == raw


@given(st.integers(-330, 330))
def test_x_velocity_raw_round_trip(raw: int) -> None:
    assert raw_of(XM210, "goal_velocity", si(XM210, "goal_velocity", raw)) == raw


@given(st.floats(math.radians(-150.0), math.radians(149.8), allow_nan=False))
def test_rx28_angle_round_trip_within_half_a_tick(angle: float) -> None:
    """An angle in range lands on the nearest tick: at most half a tick (0.15°) away."""
    back = si(RX28, "goal_position", raw_of(RX28, "goal_position", angle))
    assert abs(back - angle) <= RX28_TICK / 2 + 1e-12


@given(st.floats(-50.0, 50.0, allow_nan=False))
def test_x_angle_round_trip_within_half_a_tick(angle: float) -> None:
    back = si(XM210, "goal_position", raw_of(XM210, "goal_position", angle))
    assert abs(back - angle) <= X_TICK / 2 + 1e-12


@given(st.floats(-11.8, 11.8, allow_nan=False))
def test_rx28_speed_round_trip_keeps_sign(speed: float) -> None:
    """A speed in range comes back within half a unit and never with the wrong sign."""
    unit = 0.111 * RPM
    back = si(RX28, "moving_speed", raw_of(RX28, "moving_speed", speed))
    assert abs(back - speed) <= unit / 2 + 1e-12
    assert back * speed >= 0
