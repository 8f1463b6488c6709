"""An emulated XM430-W350 in PWM Control Mode (16) is driven by a voltage: its speed lies on
the DC motor's torque-speed line, so a load slows it, stops it or turns it back; Present PWM
is the voltage it gets, never above PWM Limit.

Facts: the e-Manual (ROBOTIS-GIT/emanual, ``control_table_position_pid_gain.md``): "In case
of PWM Control Mode, both PID controller and Feedforward controller are deactivated while
Goal PWM(100) value is directly controlling the motor through an inverter ... users can
directly control the supplying voltage"; Goal PWM and PWM Limit 885 = 100 %; XM430-W350 no-load
speed 46 rev/min and stall torque 4.1 N m at 12 V (specifications); a DC motor's speed at a
voltage share u under a load torque share L is w0 (u - L) (its linear torque-speed line);
Present Velocity in 0.229 rev/min units."""

from __future__ import annotations

import pytest

from servolab.dynamixel import Bus

NO_LOAD_UNITS = 46 / 0.229          # the no-load speed in Present Velocity's units


def pwm_motor() -> Bus:
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    bus.write(1, "operating_mode", 16, raw=True)
    bus.write(1, "torque_enable", 1)
    return bus


@pytest.mark.parametrize(("against", "share"), [(0.0, 0.5), (0.3, 0.2), (0.6, -0.1)])
def test_half_pwm_turns_at_the_torque_speed_lines_speed(against: float, share: float) -> None:
    """Goal PWM 442 (half) against a load of 0, 0.3 and 0.6 of stall: w0 x (0.5 - load), so
    half the no-load speed, a fifth of it, and backwards at a tenth (it turned forward at 80
    units under 0.6 before)."""
    bus = pwm_motor()
    bus.emulator.motor(1).external_load = -against   # type: ignore[attr-defined]
    bus.write(1, "goal_pwm", 442, raw=True)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    velocity = bus.read(1, "present_velocity", raw=True)
    assert velocity == pytest.approx(442 / 885 * NO_LOAD_UNITS - against * NO_LOAD_UNITS,
                                     abs=1.5)
    assert velocity == pytest.approx(share * NO_LOAD_UNITS, abs=1.5)
    assert bus.read(1, "hardware_error_status", raw=True) == 0     # nothing stalls
    assert bus.read(1, "present_pwm", raw=True) == pytest.approx(442, abs=2)


def test_present_pwm_never_exceeds_pwm_limit() -> None:
    """PWM Limit 442 caps Goal PWM (a larger goal is refused) and what the motor reads back
    (it read 885 above a limit of 442 before)."""
    bus = pwm_motor()
    bus.write(1, "torque_enable", 0)
    bus.write(1, "pwm_limit", 442, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_pwm", 442, raw=True)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    assert abs(bus.read(1, "present_pwm", raw=True)) <= 442
    bus.emulator.motor(1).external_load = 0.5       # type: ignore[attr-defined]
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    assert abs(bus.read(1, "present_pwm", raw=True)) <= 442


@pytest.mark.parametrize(("against", "expected_share"), [(0.0, 100 / NO_LOAD_UNITS),
                                                         (0.3, 0.3 + 100 / NO_LOAD_UNITS)])
def test_present_pwm_in_velocity_mode_is_the_voltage_the_speed_and_load_take(
        against: float, expected_share: float) -> None:
    """Velocity mode at Goal Velocity 100 (22.9 rev/min, half the no-load speed): the motor
    runs on the voltage its torque-speed line asks, PWM share = held torque share + speed /
    no-load speed — 0.498 with no load (the gears' friction is inside the datasheet's no-load
    speed, not counted again), 0.798 holding 0.3 of stall against it."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).external_load = -against   # type: ignore[attr-defined]
    bus.write(1, "goal_velocity", 100, raw=True)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    assert bus.read(1, "present_velocity", raw=True) == 100
    assert bus.read(1, "present_pwm", raw=True) == pytest.approx(885 * expected_share, abs=2)
