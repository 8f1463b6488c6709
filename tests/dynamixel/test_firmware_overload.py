"""An X-series motor held against more than it can give, and a motor that gives nothing:
the overload takes a persistent load, and a horn with no output is back-driven.

Sources:

- e-Manual, XM430-W350 Shutdown(63) / Hardware Error Status(70): bit 5 "Overload Error
  (default): detects that persistent load that exceeds maximum output"; on a shutdown error
  "Torque Enable(64) is cleared to '0' and the motor output becomes 0 [%]"; the factory
  Shutdown is 52 (0x34: overload, electrical shock, overheating);
- e-Manual, XM430-W350 specifications: no-load speed 46 rpm at 12 V; Present Velocity in
  0.229 rpm units; stall current 2.3 A (4.1 N m) at 12 V, below Current Limit(38)'s
  factory 1 193 x 2.69 mA = 3.2 A: on 12 V the voltage caps the current first;
- servolab's stated assumptions (no ROBOTIS figure): an overload is a load that beats the
  output for servolab.dynamixel.motor_alarms.OVERLOAD_TIME_S; the gears' friction, static and
  viscous, is servolab.dynamixel.plant.FRICTION_STATIC and FRICTION_VISCOUS.
"""

from __future__ import annotations

import pytest

from servolab.dynamixel import Bus
from servolab.dynamixel.motor_alarms import OVERLOAD_TIME_S
from servolab.dynamixel.plant import FRICTION_STATIC, FRICTION_VISCOUS

OVERLOAD = 0x20
NO_LOAD_UNITS = 46 / 0.229          # the no-load speed in Present Velocity's units: 200.9


def _xm430() -> Bus:
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000)
    return bus


def test_an_overload_is_a_load_that_lasts_and_then_the_output_stops() -> None:
    """Held in position mode against 1.2 x stall: for OVERLOAD_TIME_S the motor gives all it
    has (present current at the stall current, 2.3 A / 2.69 mA = 855 units; no error); then
    Hardware Error Status bit 5, torque off — and the load, no longer held, turns the horn
    its way at the no-load speed."""
    bus = _xm430()
    motor = bus.emulator.motor(1)
    bus.write(1, "torque_enable", 1)
    motor.external_load = -1.2
    bus.port.clock.advance(OVERLOAD_TIME_S - 0.05)
    assert bus.read(1, ["hardware_error_status", "torque_enable"], raw=True) == {
        "hardware_error_status": 0, "torque_enable": 1}
    assert bus.read(1, "present_current", raw=True) == round(2.3 / 0.00269)  # pushing back
    assert bus.read(1, "present_velocity", raw=True) == 0      # stalled
    bus.port.clock.advance(0.06)
    assert bus.read(1, ["hardware_error_status", "torque_enable"], raw=True) == {
        "hardware_error_status": OVERLOAD, "torque_enable": 0}
    bus.port.clock.advance(0.1)
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(-NO_LOAD_UNITS, abs=1)
    assert bus.read(1, "present_current", raw=True) == 0


def test_a_load_for_less_than_the_overload_time_is_no_overload() -> None:
    bus = _xm430()
    motor = bus.emulator.motor(1)
    bus.write(1, "torque_enable", 1)
    for _ in range(3):      # three pushes of most of the overload time, each let go
        motor.external_load = 1.5
        bus.port.clock.advance(OVERLOAD_TIME_S * 0.8)
        motor.external_load = 0.0
        bus.port.clock.advance(0.05)
    assert bus.read(1, "hardware_error_status", raw=True) == 0


@pytest.mark.parametrize(("load", "share"), [(0.03, 0.0), (0.07, 0.25), (0.1, 0.5),
                                             (0.5, 1.0), (-0.1, -0.5)])
def test_a_horn_with_torque_off_is_back_driven_through_its_gears(load: float,
                                                                 share: float) -> None:
    """Torque off: the load turns the horn once it beats the gears' static friction (0.04 of
    stall), at the speed their viscous friction (0.12 at the no-load speed) balances it,
    never past the no-load speed: |w| = w0 x min(1, (|load| - 0.04) / 0.12) — 0, 0.25, 0.5,
    1 and 0.5 of w0 here."""
    assert (FRICTION_STATIC, FRICTION_VISCOUS) == (0.04, 0.12)     # the stated assumption
    bus = _xm430()
    bus.emulator.motor(1).external_load = load
    bus.port.clock.advance(0.2)
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(
        share * NO_LOAD_UNITS, abs=1)
    assert bus.read(1, "present_current", raw=True) == 0       # the motor gives nothing


def test_torque_on_at_an_output_of_0_the_back_emf_brakes_the_horn() -> None:
    """PWM Limit 0 with torque on: the driver holds the windings at 0 V, the torque-speed
    line at u = 0, so a load of 0.3 of stall turns the horn at 0.3 of the no-load speed
    (the MuJoCo world's motor at an output of 0 does the same)."""
    bus = _xm430()
    bus.write(1, "pwm_limit", 0, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).external_load = 0.3
    bus.port.clock.advance(0.2)
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(
        0.3 * NO_LOAD_UNITS, abs=1)
