"""An emulated XM430-W350's current as the motor's own: present current is the torque over the
torque constant, Current Limit caps the torque it allows, Current Control Mode is a torque
demand, and Current-based Position holds an object at Goal Current without shutting down.

Facts from the e-Manual (ROBOTIS-GIT/emanual, ``docs/en/dxl/x/xm430-w350.md``): stall torque
4.1 N m at 2.3 A (12 V), so the torque constant is 4.1 / 2.3 N m/A; Present Current(126) and
Goal Current(102) in 2.69 mA units, Current Limit(38) 0..1 193; "Goal Current(102) sets a
limit to current" in Current-based Position Control Mode (``control_table_goal_current.md``).
A load is applied as the plant's external load, a signed share of the stall torque (negative
pushes clockwise)."""

from __future__ import annotations

import pytest

from servolab.dynamixel import Bus

STALL_NM, STALL_A, UNIT_A = 4.1, 2.3, 0.00269
KT = STALL_NM / STALL_A


def motor_on(mode: int, current_limit: int = 1193) -> Bus:
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    bus.write(1, {"operating_mode": mode}, raw=True)
    bus.write(1, "current_limit", current_limit, raw=True)
    bus.write(1, "torque_enable", 1)
    return bus


def load_nm(bus: Bus, newton_metres: float) -> None:
    """A torque pushing the horn clockwise (against a counter-clockwise hold)."""
    bus.emulator.motor(1).external_load = -newton_metres / STALL_NM  # type: ignore[attr-defined]


@pytest.mark.parametrize("current_limit", [1193, 900, 600])
def test_present_current_is_the_torque_over_the_torque_constant(current_limit: int) -> None:
    """A held 1.64 N m reads 1.64 / Kt = 0.92 A = 342 units whatever Current Limit is set
    (it read 477 / 360 / 240 when the current was scaled by the limit)."""
    bus = motor_on(3, current_limit)
    load_nm(bus, 1.64)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    current = bus.read(1, "present_current", raw=True)
    assert current == pytest.approx(1.64 / KT / UNIT_A, abs=1)
    assert round(1.64 / KT / UNIT_A) == 342


def test_current_limit_caps_the_torque_through_the_torque_constant() -> None:
    """Current Limit 500 is 1.345 A, 2.40 N m: it holds a link needing 2.0 N m (it fell and
    shut down when the limit was taken as a share of 1 193); 400 (1.08 A, 1.92 N m) cannot,
    and the motor overloads."""
    held = motor_on(3, 500)
    goal = held.read(1, "present_position")
    load_nm(held, 2.0)
    held.port.clock.advance(3.0)  # type: ignore[attr-defined]
    assert held.read(1, "present_position") == pytest.approx(goal, abs=0.002)
    assert held.read(1, "hardware_error_status", raw=True) == 0
    assert held.read(1, "present_current", raw=True) == pytest.approx(2.0 / KT / UNIT_A, abs=1)

    dropped = motor_on(3, 400)
    load_nm(dropped, 2.0)
    dropped.port.clock.advance(3.0)  # type: ignore[attr-defined]
    assert dropped.read(1, "hardware_error_status", raw=True) & 0x20    # Overload Error
    assert dropped.read(1, "torque_enable") == 0                        # shut down


def test_current_mode_is_a_torque_demand() -> None:
    """Goal Current 200 is 0.538 A, 1.23 N m (0.30 of stall). Against 2.05 N m the horn is
    held at that torque, present current 200, for as long as asked (no overload: the motor
    gives what it was asked); against 0.41 N m, or none, it turns counter-clockwise."""
    bus = motor_on(0)
    load_nm(bus, 2.05)
    bus.write(1, "goal_current", 200, raw=True)
    bus.port.clock.advance(5.0)  # type: ignore[attr-defined]
    assert bus.read(1, "present_velocity", raw=True) == 0
    assert bus.read(1, "present_current", raw=True) == pytest.approx(200, abs=1)
    assert bus.read(1, "torque_enable") == 1
    assert bus.read(1, "hardware_error_status", raw=True) == 0
    for newton_metres in (0.41, 0.0):
        load_nm(bus, newton_metres)
        bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
        assert bus.read(1, "present_velocity", raw=True) > 0
    bus.write(1, "goal_current", -200, raw=True)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    assert bus.read(1, "present_velocity", raw=True) < 0


def test_current_based_position_holds_an_object_at_goal_current_without_shutdown() -> None:
    """A gripper (mode 5) closing on an object with Goal Current 150 (0.40 A, 0.99 N m): the
    object pushes back harder, the horn stops on it and squeezes at 150 units for 10 s,
    torque on and no hardware error (it shut down as overloaded before)."""
    bus = motor_on(5)
    start = bus.read(1, "present_position")
    bus.write(1, {"goal_current": 150}, raw=True)
    bus.write(1, "goal_position", start + 1.0)
    bus.port.clock.advance(0.1)  # type: ignore[attr-defined]
    load_nm(bus, 2.0)                       # the object, met on the way
    bus.port.clock.advance(10.0)  # type: ignore[attr-defined]
    stopped = bus.read(1, "present_position")
    assert start < stopped < start + 1.0
    assert bus.read(1, "present_current", raw=True) == pytest.approx(150, abs=1)
    assert bus.read(1, "torque_enable") == 1
    assert bus.read(1, "hardware_error_status", raw=True) == 0
    load_nm(bus, 0.0)                       # the object taken away: on to the goal
    bus.port.clock.advance(2.0)  # type: ignore[attr-defined]
    assert bus.read(1, "present_position") == pytest.approx(start + 1.0, abs=0.002)


def test_a_load_pushing_the_way_the_current_turns_does_not_hold_the_horn() -> None:
    """Goal Current -200 asks a clockwise torque; a clockwise load helps it: the horn turns
    clockwise and the motor draws the -200 asked (it was held still, reading +200, when the
    load's direction was ignored)."""
    bus = motor_on(0)
    load_nm(bus, 2.05)                      # clockwise
    bus.write(1, "goal_current", -200, raw=True)
    bus.port.clock.advance(0.5)  # type: ignore[attr-defined]
    assert bus.read(1, "present_velocity", raw=True) < 0
    assert bus.read(1, "present_current", raw=True) == pytest.approx(-200, abs=1)
