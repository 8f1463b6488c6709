"""The emulator, driven byte for byte through the Bus on the virtual clock.

The emulator stands in for real motors in every other test and in `servolab sim`; if it moves
at the wrong speed, answers when a real motor is silent or accepts what a real one refuses, the
driver is tested against a fiction. Expected motions are computed here from the e-Manual scales
(ticks per degree, rpm per unit), never from the emulator's own figures.
"""

from __future__ import annotations

import math

import pytest

from servolab.dynamixel import (
    Bus,
    CorruptResponse,
    Faults,
    MotorError,
    NoResponse,
    VirtualMotor,
    model,
)
from servolab.dynamixel.motorspec import MotorEntry, MotorSpec
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from servolab.sim import emulated_port

RX28_DEG_PER_TICK = 300.0 / 1023        # e-Manual: 0..1023 over 300°
EX106_DEG_PER_TICK = 250.92 / 4095      # e-Manual (EX-106+): 0..4095 over 250.92°
X_TICKS_PER_REV = 4096
# No-load speeds, RX-28 85 rpm and EX-106+ 91 rpm, both at 18.5 V (their e-Manual pages,
# Specifications); the emulated supply is the nominal voltage the model's page gives.
RX28_NO_LOAD_RPM = 85.0
EX106_NO_LOAD_RPM = 91.0


def rpm_to_ticks_per_s(rpm: float, deg_per_tick: float) -> float:
    return rpm * 360.0 / 60.0 / deg_per_tick


def two_samples(bus: Bus, motor_id: int, name: str, wait: float) -> tuple[int, int, float]:
    """Read ``name`` (raw), let ``wait`` seconds of virtual time pass, read it again.

    Returns both values and the virtual time between the two moments the motor sampled them.
    Each read is sampled when its READ packet has fully arrived, from the joint as the last
    physics step left it (the firmware's registers move in fixed steps), so that time is the
    number of physics steps between the two samples times the step.
    """
    clock = bus.port.clock
    motor = bus.emulator.motor(motor_id)
    first = bus.read(motor_id, name, raw=True)
    first_step = motor.sensed_step
    clock.advance(wait)
    second = bus.read(motor_id, name, raw=True)
    return first, second, (motor.sensed_step - first_step) * clock.physics_step


def circular_diff(a: float, b: float, modulus: int) -> float:
    d = (a - b) % modulus
    return min(d, modulus - d)


def spec(model_name: str, positions: dict[int, float], baudrate: int) -> MotorSpec:
    m = model(model_name)
    return MotorSpec(m.protocol, baudrate,
                     tuple(MotorEntry(m, i, p) for i, p in positions.items()))


# -- motion ------------------------------------------------------------------------------------

@pytest.mark.parametrize(("goal", "sign"), [(1000, 1), (100, -1)])
def test_joint_mode_moves_at_moving_speed_and_stops_at_goal(goal: int, sign: int) -> None:
    """RX-28 joint mode: the horn travels toward goal_position at moving_speed (0.111 rpm per
    unit) and stops exactly on it."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "moving_speed", 300, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", goal, raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 0.2)
    speed = rpm_to_ticks_per_s(300 * 0.111, RX28_DEG_PER_TICK)   # about 681 ticks/s
    assert p2 - p1 == pytest.approx(sign * speed * elapsed, abs=2)
    assert bus.read(1, "moving", raw=True) == 1
    present_speed = bus.read(1, "present_speed", raw=True)
    assert present_speed & 0x3FF == pytest.approx(300, abs=1)
    assert bool(present_speed & 0x400) == (sign < 0)
    bus.port.clock.advance(2.0)        # 488 ticks at 681 ticks/s take 0.72 s
    # One READ, so all three are sampled at the same moment, long after the arrival.
    assert bus.read(1, ["present_position", "present_speed", "moving"], raw=True) == {
        "present_position": goal, "present_speed": 0, "moving": 0}


@pytest.mark.parametrize(("spec_text", "rpm", "deg_per_tick", "goal"), [
    ("rx28:1", RX28_NO_LOAD_RPM, RX28_DEG_PER_TICK, 1000),
    ("mx28:1", 55.0, 360.0 / 4096, 4000),       # e-Manual MX-28: 55 rpm at 12 V
])
def test_moving_speed_zero_means_no_load_speed(spec_text: str, rpm: float,
                                               deg_per_tick: float, goal: int) -> None:
    """1.0: moving_speed 0 is 'no speed control', i.e. as fast as the supply allows: the
    model's no-load speed."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=57142)
    bus.write(1, "moving_speed", 0, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", goal, raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 0.1)
    assert p2 - p1 == pytest.approx(rpm_to_ticks_per_s(rpm, deg_per_tick) * elapsed, abs=2)


@pytest.mark.parametrize("clockwise", [True, False])
def test_ex106_wheel_mode_moving_speed_is_output_and_position_counts_to_65535(
        clockwise: bool) -> None:
    """EX-106+ wheel mode: moving_speed 400 is 39 % output, so 400/1023 of 91 rpm unloaded,
    and present_position is the encoder count, 0.06° per count, from 65535 back to 0 (e-Manual,
    EX-106+ Present Position: "If it is decreased when the value is 0, it becomes 65535")."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
    units = 400
    bus.write(1, "torque_enable", 1)
    bus.write(1, "moving_speed", units | (0x400 if clockwise else 0), raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 2.0)
    rpm = units / 1023 * EX106_NO_LOAD_RPM
    travel = rpm_to_ticks_per_s(rpm, EX106_DEG_PER_TICK) * elapsed
    assert circular_diff(p2, p1 + (-travel if clockwise else travel), 65536) <= 2
    speed = bus.read(1, "present_speed", raw=True)
    assert speed & 0x3FF == pytest.approx(units, abs=1)     # the output ratio, 0.1 % units
    assert bool(speed & 0x400) == clockwise
    # Past the wrap: 65 536 counts at full output (91 rpm) take under 7.5 s.
    bus.write(1, "moving_speed", 1023 | (0x400 if clockwise else 0), raw=True)
    q1, q2, elapsed = two_samples(bus, 1, "present_position", 9.0)
    travel = rpm_to_ticks_per_s(EX106_NO_LOAD_RPM, EX106_DEG_PER_TICK) * elapsed
    assert travel > 65536
    assert 0 <= q2 <= 65535
    assert circular_diff(q2, q1 + (-travel if clockwise else travel), 65536) <= 2


def test_rx28_wheel_mode_reads_its_potentiometer_every_360_degrees() -> None:
    """RX-28 wheel mode: the potentiometer reads 0..1023 over 300° of each turn of the horn
    (e-Manual: 0.29° per unit, 300° range; "the value cannot be used to measure the moving
    distance" in wheel mode), so a full 360° turn brings back the same reading."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "moving_speed", 1023, raw=True)           # full output: 85 rpm
    seconds_per_turn = 60.0 / RX28_NO_LOAD_RPM
    samples = []
    for _ in range(12):
        bus.port.clock.advance(seconds_per_turn / 5)
        motor.sync()      # the firmware's reading now, without a packet's wire time
        reading = motor.get_raw("present_position")
        horn_deg = math.degrees(motor.plant.position) + 150.0   # tick 0 is at 0°
        samples.append((horn_deg % 360.0, reading))
    assert max(h for h, _ in samples) - min(h for h, _ in samples) > 200   # went round
    for horn, reading in samples:
        if horn <= 299.0:
            assert reading == pytest.approx(horn / RX28_DEG_PER_TICK, abs=2)
        elif horn >= 301.0:
            assert reading in (0, 1023)                     # the 60° it cannot read
    speed = bus.read(1, "present_speed", raw=True)
    assert speed == 1023                                    # 100 % output, CCW


def test_rx28_wheel_mode_at_full_output_turns_at_no_load_speed() -> None:
    """RX-28 wheel mode at moving_speed 1023 (100 % output) turns at the no-load speed of
    85 rpm at 18.5 V (e-Manual, RX-28 Specifications)."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
    bus.write(1, "moving_speed", 1023, raw=True)
    bus.port.clock.advance(0.01)
    start = motor.plant.position
    bus.port.clock.advance(1.0)
    assert (motor.plant.position - start) / (2 * math.pi) * 60 == pytest.approx(
        RX28_NO_LOAD_RPM, rel=0.01)


def test_x_velocity_mode_counts_turns_and_position_mode_stays_in_one_turn() -> None:
    """X-series velocity mode (operating_mode 1): present_position keeps counting past one
    turn (multi-turn, signed); back in position mode (3) it reads within 0..4095."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 200, raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 3.0)
    expected = 200 * 0.229 / 60 * X_TICKS_PER_REV * elapsed      # about 9 380 ticks
    assert p2 - p1 == pytest.approx(expected, abs=2)
    assert p2 > 4095
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(200, abs=1)

    bus.write(1, "goal_velocity", -200, raw=True)
    q1, q2, elapsed = two_samples(bus, 1, "present_position", 6.0)
    assert q2 - q1 == pytest.approx(-200 * 0.229 / 60 * 4096 * elapsed, abs=2)
    assert q2 < 0                                                 # signed, clockwise of 0
    bus.write(1, "goal_velocity", 0, raw=True)

    bus.write(1, "torque_enable", 0)
    bus.write(1, "operating_mode", 3, raw=True)
    bus.port.clock.advance(0.01)
    in_turn = bus.read(1, "present_position", raw=True)
    assert 0 <= in_turn <= 4095
    total = bus.emulator.motor(1).ticks
    assert in_turn == round(total) % 4096


def test_x_position_mode_moves_to_goal() -> None:
    """Position mode with profile_velocity 0 moves at full speed and stops on the goal."""
    bus = Bus.open("emu://xl430-w250:1", baudrate=1_000_000)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 3000, raw=True)
    bus.port.clock.advance(2.0)
    assert bus.read(1, "present_position", raw=True) == 3000
    assert bus.read(1, "present_position") == pytest.approx((3000 - 2048) * 2 * math.pi / 4096)


def test_speed_is_capped_at_no_load_speed() -> None:
    """A commanded speed above what the motor can do gives the no-load speed, not more:
    XL430-W250 at 11.1 V turns at most 57 rpm (e-Manual), even told its velocity limit of
    265 × 0.229 = 60.7 rpm."""
    bus = Bus.open("emu://xl430-w250:1", baudrate=1_000_000)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 265, raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 1.0)
    assert p2 - p1 == pytest.approx(57.0 / 60 * 4096 * elapsed, abs=2)
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(57.0 / 0.229, abs=1)


def test_goal_velocity_range_follows_velocity_limit() -> None:
    """e-Manual: goal_velocity may be anything within ±velocity_limit, and velocity_limit
    itself may be raised up to 1023. After raising it, a goal of 1000 units is valid (and the
    motor then turns at its no-load speed, 77 rpm for the XM430-W210)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "velocity_limit", 1023, raw=True)
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 1000, raw=True)
    assert bus.read(1, "goal_velocity", raw=True) == 1000
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 1.0)
    assert p2 - p1 == pytest.approx(77.0 / 60 * 4096 * elapsed, abs=2)


def test_rx28_joint_speed_is_capped_at_no_load_speed() -> None:
    """Joint mode too: moving_speed 1023 (113.6 rpm) moves the horn at the no-load speed,
    the same as moving_speed 0."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "moving_speed", 1023, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 1000, raw=True)
    p1, p2, elapsed = two_samples(bus, 1, "present_position", 0.1)
    no_load = rpm_to_ticks_per_s(RX28_NO_LOAD_RPM, RX28_DEG_PER_TICK)
    assert p2 - p1 == pytest.approx(no_load * elapsed, abs=2)


def test_torque_off_means_no_motion() -> None:
    """With torque off the horn is free: goals and speeds are stored but nothing moves."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, {"goal_position": 1000, "moving_speed": 500}, raw=True)
    bus.write(1, "torque_enable", 0)      # the goal write switched it on (1.0); off again
    p1, p2, _ = two_samples(bus, 1, "present_position", 1.0)
    assert abs(p1 - p2) <= 1 and bus.read(1, "moving", raw=True) == 0
    assert bus.read(1, "goal_position", raw=True) == 1000

    xbus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000)
    xbus.write(1, "operating_mode", 1, raw=True)
    xbus.write(1, "goal_velocity", 100, raw=True)   # drive_mode bit 3 is 0 by default
    q1, q2, _ = two_samples(xbus, 1, "present_position", 1.0)
    assert q1 == q2 == 2048
    assert xbus.read(1, "torque_enable", raw=True) == 0


# -- torque rules ------------------------------------------------------------------------------

@pytest.mark.parametrize("register", ["goal_position", "moving_speed"])
@pytest.mark.parametrize("spec_text", ["rx28:1", "ex106+:1", "mx28:1"])
def test_protocol1_goal_or_speed_write_switches_torque_on(spec_text: str,
                                                          register: str) -> None:
    """Protocol 1.0 servos switch torque on when goal_position or moving_speed is written:
    seed 000 drives its EX-106+ wheels with a SYNC_WRITE of moving_speed alone and ROS
    dynamixel_motor (seed 001) writes goal positions without a torque write, and both move
    their robots (the e-Manual does not describe it; the seeds' working programs do)."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=57142)
    assert bus.read(1, "torque_enable", raw=True) == 0        # factory: torque off
    value = 600 if register == "goal_position" else 200
    bus.write(1, register, value, raw=True)
    assert bus.read(1, "torque_enable", raw=True) == 1
    if register == "goal_position":
        bus.port.clock.advance(3.0)
        assert bus.read(1, "present_position", raw=True) == 600


@pytest.mark.parametrize("via", ["write", "sync_write"])
def test_x_series_goal_switches_torque_on_only_with_drive_mode_bit_3(via: str) -> None:
    """X-series (firmware 45 and later): with Drive Mode(10) bit 3 "Torque On by Goal Update" a goal
    written with torque off switches it on; without it the goal waits for a torque write
    (e-Manual, Drive Mode(10), available from firmware V45)."""
    bus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000)
    bus.write(2, "drive_mode", 0x08, raw=True)

    def send(goals: dict[int, int]) -> None:
        if via == "write":
            for motor_id, goal in goals.items():
                bus.write(motor_id, "goal_position", goal, raw=True)
        else:
            bus.sync_write("goal_position", goals, raw=True)

    send({1: 3000, 2: 3000})
    bus.port.clock.advance(2.0)
    assert bus.sync_read("torque_enable", [1, 2], raw=True) == {1: 0, 2: 1}
    assert bus.sync_read("present_position", [1, 2], raw=True) == {1: 2048, 2: 3000}


def test_x_series_drive_mode_reverse_mirrors_position_but_not_homing_offset() -> None:
    """Drive Mode bit 0 (Reverse): "Goal Position, Present Position will have an inverted
    direction", while "the sign of Homing Offset value will not be reversed" (e-Manual,
    Drive Mode(10) and Homing Offset(20)). The same goal turns the two horns opposite ways."""
    bus = Bus.open("emu://xl430-w250:1-2", baudrate=1_000_000)
    bus.write(2, {"drive_mode": 0x01}, raw=True)
    bus.write(2, "homing_offset", 100, raw=True)
    assert bus.read(2, "present_position", raw=True) == 2048 + 100
    for motor_id in (1, 2):
        bus.write(motor_id, "torque_enable", 1)
        bus.write(motor_id, "goal_position", 2548, raw=True)
    bus.port.clock.advance(2.0)
    assert bus.sync_read("present_position", [1, 2], raw=True) == {1: 2548, 2: 2548}
    horn1 = bus.emulator.motor(1).plant.position
    horn2 = bus.emulator.motor(2).plant.position
    assert horn1 == pytest.approx(500 * 2 * math.pi / 4096)
    assert horn2 == pytest.approx(-400 * 2 * math.pi / 4096)   # mirrored, offset unmirrored


def test_torque_limit_zero_holds_the_horn() -> None:
    """1.0 Torque Limit(34) caps the output: "only 50 % of the maximum torque will be used" at
    512, none at 0 (e-Manual, Torque Limit) — with torque limit 0 the motor does not move."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "torque_limit", 0, raw=True)
    bus.write(1, "goal_position", 900, raw=True)
    bus.port.clock.advance(1.0)
    assert bus.read(1, "present_position", raw=True) == 512
    assert bus.read(1, "torque_enable", raw=True) == 1


def test_max_torque_is_the_torque_limit_at_power_up() -> None:
    """"When the power is turned on, Torque Limit(34) is reset to the value of Max
    Torque(14)" (e-Manual, Torque Limit)."""
    m = VirtualMotor(model("RX-28"), 1)
    m.set_raw("max_torque", 400)
    m.execute(PROTOCOL1.reset(1), "RESET")   # defaults again: max torque 1023
    assert m.get_raw("torque_limit") == 1023
    fresh = VirtualMotor(model("EX-106+"), 1)
    assert fresh.get_raw("torque_limit") == fresh.get_raw("max_torque") == 1023


def test_x_series_current_based_position_is_multi_turn_and_limited_by_goal_current() -> None:
    """Current-based Position (mode 5) takes goals over -1 048 575..1 048 575 and counts turns
    (e-Manual, Goal Position(116)); Goal Current(102) "sets a limit to current" there (e-Manual,
    Goal Current(102)): with goal current 0 the horn stays put."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "operating_mode", 5, raw=True)
    bus.write(1, "goal_current", 0, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 2048 + 3 * 4096, raw=True)
    bus.port.clock.advance(1.0)
    assert bus.read(1, "present_position", raw=True) == 2048
    bus.write(1, "goal_current", 600, raw=True)
    bus.port.clock.advance(5.0)
    assert bus.read(1, "present_position", raw=True) == 2048 + 3 * 4096
    bus.write(1, "goal_position", -1_048_575, raw=True)      # the range's end is accepted
    assert bus.read(1, "goal_position", raw=True) == -1_048_575


def test_x_series_extended_position_counts_turns() -> None:
    """Extended Position (mode 4): -256..256 turns, present position counts them (e-Manual,
    Goal Position(116))."""
    bus = Bus.open("emu://xl430-w250:1", baudrate=1_000_000)
    bus.write(1, "operating_mode", 4, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", -2 * 4096 + 100, raw=True)
    bus.port.clock.advance(8.0)
    assert bus.read(1, "present_position", raw=True) == -2 * 4096 + 100


# The supply is the voltage each model's e-Manual page rates its speed at: RX-28 18.5 V,
# MX-28 12 V, XM430 12 V, XL430-W250 11.1 V.
@pytest.mark.parametrize(("spec_text", "baud", "voltage_reg", "load_reg", "volts"), [
    ("rx28:1", 57142, "present_voltage", "present_load", 18.5),
    ("mx28:1", 57142, "present_voltage", "present_load", 12.0),
    ("xm430-w210:1", 1_000_000, "present_input_voltage", "present_current", 12.0),
    ("xl430-w250:1", 1_000_000, "present_input_voltage", "present_load", 11.1),
])
def test_sensors_are_plausible(spec_text: str, baud: int, voltage_reg: str,
                               load_reg: str, volts: float) -> None:
    """Voltage near the supply, temperature between 20 and 80 °C, load within ±100 %,
    whether still or moving."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    for _ in range(2):
        assert bus.read(1, voltage_reg) == pytest.approx(volts, abs=0.5)
        assert 20.0 <= bus.read(1, "present_temperature") <= 80.0
        load = bus.read(1, load_reg)
        assert abs(load) <= (1.0 if load_reg == "present_load" else 1193 * 0.00269)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "goal_position", 0.5)
        bus.port.clock.advance(0.05)


# -- access rights and ranges ----------------------------------------------------------------

def test_protocol1_write_to_read_only_register_is_range_error() -> None:
    """A real 1.0 motor answers a WRITE to a read-only address with the range bit, and the
    register keeps its value."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    with pytest.raises(MotorError) as info:
        bus.transact(PROTOCOL1.write(1, 36, (100).to_bytes(2, "little")), {1: 0})
    assert info.value.errors == ("range",)
    assert (info.value.motor_id, info.value.instruction) == (1, "WRITE")
    assert bus.read(1, "present_position", raw=True) == 512
    with pytest.raises(MotorError, match="range"):
        bus.transact(PROTOCOL1.write(1, 0, (12).to_bytes(2, "little")), {1: 0})
    assert bus.read(1, "model_number", raw=True) == 28


def test_protocol2_write_to_read_only_register_is_access_error() -> None:
    """2.0 reports writes to read-only addresses as 'access' (error 7)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    with pytest.raises(MotorError) as info:
        bus.transact(PROTOCOL2.write(1, 132, (100).to_bytes(4, "little")), {1: 0})
    assert info.value.errors == ("access",)
    assert bus.read(1, "present_position", raw=True) == 2048


@pytest.mark.parametrize(("spec_text", "baud", "inst", "error"), [
    ("rx28:1", 57142, PROTOCOL1.write(1, 30, (2000).to_bytes(2, "little")), "range"),
    ("rx28:1", 57142, PROTOCOL1.write(1, 24, b"\x02"), "range"),
    ("xm430-w210:1", 1_000_000, PROTOCOL2.write(1, 64, b"\x02"), "data range"),
    ("xl430-w250:1", 1_000_000, PROTOCOL2.write(1, 11, b"\x00"), "data range"),  # no current mode
])
def test_out_of_range_raw_value_is_refused(spec_text: str, baud: int, inst,
                                           error: str) -> None:
    """A value outside a register's range (sent raw, past the driver's own checks) gets the
    range / data range error and changes nothing."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    motor = bus.emulator.motor(1)
    table = bytes(motor.table)
    with pytest.raises(MotorError) as info:
        bus.transact(inst, {1: 0})
    assert info.value.errors == (error,)
    assert bytes(motor.table) == table


def _unchecked_write(bus: Bus, motor_id: int, name: str, raw: int) -> None:
    """A WRITE sent as it is, past the Bus's own checks (which refuse before the wire what
    the motor would refuse: tests/dynamixel/test_commissioning.py), so that what the
    emulated firmware does with it shows."""
    reg = bus.model_of(motor_id).register(name)
    bus.transact(bus.proto.write(motor_id, reg.address, reg.encode(raw)), {motor_id: 0})


def test_protocol2_eeprom_is_locked_while_torque_is_on() -> None:
    """X-series: EEPROM writes with torque on are refused with 'access' (e-Manual)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "torque_enable", 1)
    with pytest.raises(MotorError) as info:
        _unchecked_write(bus, 1, "return_delay_time", 0)
    assert info.value.errors == ("access",)
    assert bus.read(1, "return_delay_time", raw=True) == 250
    bus.write(1, "torque_enable", 0)
    bus.write(1, "return_delay_time", 0, raw=True)
    assert bus.read(1, "return_delay_time", raw=True) == 0


def test_protocol2_goal_velocity_above_velocity_limit_is_data_limit() -> None:
    """X-series: a goal velocity beyond velocity_limit is a 'data limit' error (6)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "velocity_limit", 100, raw=True)
    with pytest.raises(MotorError) as info:
        bus.write(1, "goal_velocity", 150, raw=True)
    assert info.value.errors == ("data limit",)


def test_protocol1_goal_outside_angle_limits_is_angle_limit_error() -> None:
    """1.0: a goal outside [cw_angle_limit, ccw_angle_limit] gets the angle limit bit."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, {"cw_angle_limit": 200, "ccw_angle_limit": 800}, raw=True)
    with pytest.raises(MotorError) as info:
        _unchecked_write(bus, 1, "goal_position", 900)
    assert info.value.errors == ("angle limit",)
    with pytest.raises(MotorError, match="angle limit"):
        _unchecked_write(bus, 1, "goal_position", 100)
    bus.write(1, "goal_position", 700, raw=True)
    assert bus.read(1, "goal_position", raw=True) == 700


@pytest.mark.parametrize(("spec_text", "baud"), [("rx28:1-2", 57142),
                                                 ("xm430-w210:1-2", 1_000_000)])
def test_reg_write_applies_only_at_action(spec_text: str, baud: int) -> None:
    """REG_WRITE stores a goal without acting on it; the broadcast ACTION applies it to all
    motors at once (and clears the registered flag)."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    flag = "registered" if bus.proto.version == 1 else "registered_instruction"
    center = 512 if bus.proto.version == 1 else 2048
    goals = {1: center + 200, 2: center - 200}
    for i in (1, 2):
        bus.write(i, "torque_enable", 1)
    for i, goal in goals.items():
        bus.write(i, "goal_position", goal, raw=True, registered=True)
    bus.port.clock.advance(1.0)
    for i in (1, 2):
        assert bus.read(i, "goal_position", raw=True) == center
        assert bus.read(i, "present_position", raw=True) == center
        assert bus.read(i, flag, raw=True) == 1
    bus.action()
    for i, goal in goals.items():
        assert bus.read(i, "goal_position", raw=True) == goal
        assert bus.read(i, flag, raw=True) == 0
    bus.port.clock.advance(2.0)
    for i, goal in goals.items():
        assert bus.read(i, "present_position", raw=True) == goal


# -- timing and who answers --------------------------------------------------------------------

@pytest.mark.parametrize(("spec_text", "baud"), [("rx28:1-2", 57142),
                                                 ("xl430-w250:1-2", 1_000_000)])
def test_return_delay_time_lengthens_round_trip(spec_text: str, baud: int) -> None:
    """Return delay time is in 2 µs units: 250 (the default) answers 0.5 ms later than 0."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    bus.write(1, "return_delay_time", 0, raw=True)
    assert bus.read(2, "return_delay_time", raw=True) == 250
    clock = bus.port.clock

    def round_trip(motor_id: int) -> float:
        start = clock.now()
        bus.read(motor_id, "present_position")
        return clock.now() - start

    assert round_trip(2) - round_trip(1) == pytest.approx(250 * 2e-6, abs=1e-9)


def test_status_return_level_protocol1() -> None:
    """Level 2 answers everything, 1 only READ (and PING), 0 only PING."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.ping(1)
    bus.status_return_level[1] = 1
    bus.write(1, "status_return_level", 1, raw=True)
    assert bus.emulator.motor(1).get_raw("status_return_level") == 1
    assert bus.read(1, "status_return_level", raw=True) == 1      # READ still answered
    bus.ping(1)
    with pytest.raises(NoResponse):                                 # WRITE no longer is
        bus.transact(PROTOCOL1.write(1, 25, b"\x01"), {1: 0}, retries=0)
    assert bus.emulator.motor(1).get_raw("led") == 1                # ... but was applied
    bus.write(1, "led", 0)
    assert bus.read(1, "led", raw=True) == 0

    bus.status_return_level[1] = 0
    bus.write(1, "status_return_level", 0, raw=True)
    assert bus.emulator.motor(1).get_raw("status_return_level") == 0
    with pytest.raises(NoResponse):
        bus.transact(PROTOCOL1.read(1, 36, 2), {1: 2}, retries=0)
    # PING always answers (bus.ping would also READ the model number, which level 0 mutes).
    assert bus.transact(PROTOCOL1.ping(1), {1: 0}, retries=0)[1].error == 0


def test_status_return_level_protocol2() -> None:
    """Same rule on 2.0 (status_return_level lives in RAM at 68 there)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.status_return_level[1] = 1
    bus.write(1, "status_return_level", 1, raw=True)
    assert bus.read(1, "status_return_level", raw=True) == 1
    with pytest.raises(NoResponse):
        bus.transact(PROTOCOL2.write(1, 65, b"\x01"), {1: 0}, retries=0)
    bus.status_return_level[1] = 0
    bus.write(1, "status_return_level", 0, raw=True)
    with pytest.raises(NoResponse):
        bus.transact(PROTOCOL2.read(1, 132, 4), {1: 4}, retries=0)
    assert bus.ping(1).model_number == 1030


@pytest.mark.parametrize(("spec_text", "baud", "proto"), [
    ("rx28:1-3", 57142, PROTOCOL1), ("xm430-w210:1-3", 1_000_000, PROTOCOL2)])
def test_broadcast_write_is_applied_to_all_and_silent(spec_text: str, baud: int,
                                                      proto) -> None:
    """A WRITE to ID 254 reaches every motor and none answers (answers would collide)."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    address = model(spec_text.split(":")[0]).register("led").address
    assert bus.transact(proto.write(254, address, b"\x01")) == {}
    assert bus.port.read(64, 0.01) == b""
    for i in (1, 2, 3):
        assert bus.emulator.motor(i).get_raw("led") == 1


def test_two_motors_with_the_same_id_collide() -> None:
    """Two motors answering at once garble each other's status: the driver must report a
    corrupt answer, not return one motor's value."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.emulator.add(VirtualMotor(model("RX-28"), 1, baudrate=57142, position=0.5))
    bus.declare(1, "rx28")
    with pytest.raises(CorruptResponse) as info:
        bus.read(1, "present_position")
    assert info.value.motor_id == 1
    assert bus.stats.corrupt >= 1


def test_motor_at_another_baud_rate_is_silent_but_found_by_scan() -> None:
    """A motor set to 1 Mbps does not hear a 57 142 bps bus; scanning both rates finds it,
    and the scan leaves the port at its own rate."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.emulator.add(VirtualMotor(model("RX-28"), 2, baudrate=1_000_000))
    with pytest.raises(NoResponse) as info:
        bus.ping(2)
    assert info.value.motor_id == 2
    found = bus.scan([1, 2, 3], [57142, 1_000_000])
    assert [(r.id, r.baudrate, r.model_number) for r in found] == [
        (1, 57142, 28), (2, 1_000_000, 28)]
    assert found[0].model is model("RX-28")
    assert bus.baudrate == 57142


def test_x_series_motor_at_57600_is_heard_by_57142_host() -> None:
    """UARTs within 3 % understand each other: a 57 600 bps X motor answers at 57 142."""
    bus = Bus(emulated_port(spec("xm430-w210", {1: 0.0}, 57_600)))
    bus.port.set_baudrate(57142)
    assert bus.ping(1).model_number == 1030


@pytest.mark.parametrize(("spec_text", "baud"), [("rx28:1", 57142),
                                                 ("xm430-w210:1", 1_000_000)])
def test_unresponsive_motor_raises_no_response_naming_it(spec_text: str, baud: int) -> None:
    """A motor with a cut cable: NoResponse that says which motor and which instruction."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    bus.ping(1)
    bus.emulator.motor(1).responsive = False
    with pytest.raises(NoResponse) as info:
        bus.read(1, "present_position")
    assert (info.value.motor_id, info.value.instruction) == (1, "READ")
    assert "motor 1" in str(info.value) and "READ" in str(info.value)
    with pytest.raises(NoResponse) as info:
        bus.write(1, "led", 1)
    assert (info.value.motor_id, info.value.instruction) == (1, "WRITE")
    assert bus.stats.timeouts >= 2


# -- hardware errors ---------------------------------------------------------------------------

def test_protocol1_overload_sets_bit_in_every_status_and_zeroes_torque_limit() -> None:
    """1.0: a hardware error is a bit of every status error byte until cleared; overload is
    in the default alarm shutdown set (36), so "the motor output becomes 0 % by resetting the
    value of Torque Limit(34) to 0" while torque enable stays; a torque limit other than 0
    lets it run again (e-Manual, Alarm Shutdown and Torque Limit)."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).inject_hardware_error("overload")
    for action in (lambda: bus.read(1, "present_position"),
                   lambda: bus.write(1, "led", 1),
                   lambda: bus.read(1, "goal_position")):
        action()                    # carried out: the data comes with the overload bit
        assert bus.alerts == {1: 0x20}
    assert bus.hardware_errors(1) == ("overload",)
    assert bus.read(1, ["torque_enable", "torque_limit"], raw=True, check=False) == {
        "torque_enable": 1, "torque_limit": 0}
    bus.emulator.motor(1).set_raw("goal_position", 900)
    bus.port.clock.advance(1.0)
    assert bus.read(1, "present_position", raw=True, check=False) == 512   # no output
    bus.emulator.motor(1).clear_hardware_error()
    bus.write(1, "torque_limit", 1023, raw=True)
    bus.port.clock.advance(2.0)
    assert bus.read(1, "present_position", raw=True) == 900


def test_protocol2_hardware_error_sets_alert_and_status_register() -> None:
    """2.0: the alert bit (0x80) is set in every status and hardware_error_status holds the
    cause (bit 5 = overload, e-Manual); torque goes off."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).inject_hardware_error("overload")
    bus.read(1, "present_position")          # the alert is no failed instruction
    assert bus.alerts == {1: 0x80}
    status = bus.transact(PROTOCOL2.ping(1), {1: 3})[1]
    assert PROTOCOL2.error_names(status.error) == ("hardware error alert",)
    values = bus.read(1, ["torque_enable", "hardware_error_status"], raw=True)
    assert values == {"torque_enable": 0, "hardware_error_status": 0x20}


def test_reboot_clears_hardware_error() -> None:
    """REBOOT is how a 2.0 motor leaves a hardware error: afterwards statuses are clean,
    hardware_error_status is 0, and EEPROM settings survive. The REBOOT's own status still
    carries the alert (it is sent before rebooting), which must not make reboot() fail."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "return_delay_time", 10, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).inject_hardware_error("overheating")
    bus.read(1, "present_position")
    assert bus.alerts == {1: 0x80}
    bus.reboot(1)
    assert bus.alerts == {}
    assert bus.read(1, "hardware_error_status", raw=True) == 0
    assert bus.read(1, "return_delay_time", raw=True) == 10
    assert bus.read(1, "torque_enable", raw=True) == 0
    bus.write(1, "torque_enable", 1)
    assert bus.read(1, "torque_enable", raw=True) == 1


def test_x_series_torque_stays_off_after_shutdown_until_reboot() -> None:
    """"REBOOT is the only method to reset Torque Enable(64) to '1' after the shutdown"
    (e-Manual, Shutdown(63)): neither a torque write nor Drive Mode bit 3 brings it back."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "drive_mode", 0x08, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).inject_hardware_error("overload")
    for name, value in (("torque_enable", 1), ("goal_position", 3000)):
        bus.write(1, name, value, raw=True)      # every status carries the alert
        assert bus.alerts == {1: 0x80}
        assert bus.read(1, "torque_enable", raw=True) == 0
    bus.reboot(1)
    bus.write(1, "goal_position", 3000, raw=True)   # bit 3 switches it on again
    assert bus.read(1, "torque_enable", raw=True) == 1


# -- injected faults -------------------------------------------------------------------------

@pytest.mark.parametrize("faults", [Faults(corrupt_rate=0.02, seed=7),
                                    Faults(drop_rate=0.02, seed=3)],
                         ids=["corrupt", "drop"])
def test_retries_recover_from_faults(faults: Faults) -> None:
    """With a few bad bytes on the wire the driver retries and still reads the right
    values."""
    positions = {1: -math.pi / 2, 2: 0.0, 3: math.pi / 4}
    bus = Bus(emulated_port(spec("xm430-w210", positions, 1_000_000)), retries=8)
    for i in positions:
        bus.declare(i, "xm430-w210")
    bus.emulator.faults = faults
    expected = {i: 2048 + round(p / (2 * math.pi) * 4096) for i, p in positions.items()}
    assert expected == {1: 1024, 2: 2048, 3: 2560}
    for _ in range(30):
        for i, ticks in expected.items():
            assert bus.read(i, "present_position", raw=True) == ticks
    assert bus.stats.retries > 0


def test_every_reply_dropped_without_retries_is_no_response() -> None:
    bus = Bus.open("emu://rx28:1", baudrate=57142, retries=0)
    bus.ping(1)
    bus.emulator.faults = Faults(drop_rate=1.0, seed=1)
    with pytest.raises(NoResponse):
        bus.read(1, "present_position")
    assert bus.stats.retries == 0
    assert bus.stats.timeouts == 1


def test_every_reply_corrupted_without_retries_is_corrupt_response() -> None:
    """Garbage is not silence: the driver says it got a corrupt answer."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000, retries=0)
    bus.ping(1)
    bus.emulator.faults = Faults(corrupt_rate=1.0, seed=1)
    with pytest.raises(CorruptResponse):
        bus.read(1, "present_position")
    assert bus.stats.corrupt == 1


def test_delay_beyond_timeout_is_no_response() -> None:
    """An answer later than the timeout counts as none; with a longer timeout it arrives."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.ping(1)
    bus.emulator.faults = Faults(delay=0.05)
    with pytest.raises(NoResponse):
        bus.read(1, "present_position")

    patient = Bus.open("emu://rx28:1", baudrate=57142, timeout=0.1)
    patient.ping(1)
    patient.emulator.faults = Faults(delay=0.05)
    assert patient.read(1, "present_position", raw=True) == 512


# -- instruction sets ---------------------------------------------------------------------------

def test_rx28_does_not_answer_bulk_read() -> None:
    """RX-28 predates BULK_READ: it ignores the instruction (a broadcast gets no status)."""
    bus = Bus.open("emu://rx28:1-2", baudrate=57142)
    with pytest.raises(NoResponse):
        bus.transact(PROTOCOL1.bulk_read([(1, 36, 2), (2, 36, 2)]), {1: 2, 2: 2}, retries=0)


def test_rx28_sync_read_falls_back_to_reads() -> None:
    """bus.sync_read on RX-28s sends one READ per motor and returns each motor's value."""
    positions = {1: -0.5, 2: 0.0, 3: 0.75}
    bus = Bus(emulated_port(spec("rx28", positions, 57142)))
    for i in positions:
        bus.ping(i)
    seen = bus.emulator.instructions_seen
    got = bus.sync_read("present_position", [1, 2, 3], raw=True)
    tick = math.radians(RX28_DEG_PER_TICK)
    assert got == {i: 512 + round(p / tick) for i, p in positions.items()}
    assert bus.emulator.instructions_seen - seen == 3


def test_mx28_answers_bulk_read() -> None:
    """MX-28 has BULK_READ: different registers of different motors in one instruction."""
    positions = {1: -0.5, 2: 0.0, 3: 1.0}
    bus = Bus(emulated_port(spec("mx28", positions, 57142)))
    bus.write(2, "moving_speed", 123, raw=True)
    for i in positions:
        bus.ping(i)
    seen = bus.emulator.instructions_seen
    got = bus.bulk_read({1: "present_position", 2: ["goal_position", "moving_speed"],
                         3: ["present_position", "present_voltage"]}, raw=True)
    tick = 2 * math.pi / 4096
    assert got == {
        1: {"present_position": 2048 + round(-0.5 / tick)},
        2: {"goal_position": 2048, "moving_speed": 123},
        3: {"present_position": 2048 + round(1.0 / tick), "present_voltage": 120},
    }
    assert bus.emulator.instructions_seen - seen == 1
    raw = bus.transact(PROTOCOL1.bulk_read([(1, 36, 2), (3, 36, 2)]), {1: 2, 3: 2})
    assert int.from_bytes(raw[3].params, "little") == 2048 + round(1.0 / tick)


def test_protocol2_sync_read_returns_every_motor() -> None:
    """One SYNC_READ, one value per motor, each its own."""
    positions = {1: -math.pi / 2, 2: -math.pi / 8, 3: math.pi / 8, 4: 3 * math.pi / 4}
    bus = Bus(emulated_port(spec("xm430-w210", positions, 1_000_000)))
    for i in positions:
        bus.declare(i, "xm430-w210")
    seen = bus.emulator.instructions_seen
    got = bus.sync_read(["present_velocity", "present_position"], [1, 2, 3, 4], raw=True)
    assert got == {1: {"present_velocity": 0, "present_position": 1024},
                   2: {"present_velocity": 0, "present_position": 1792},
                   3: {"present_velocity": 0, "present_position": 2304},
                   4: {"present_velocity": 0, "present_position": 3584}}
    assert bus.emulator.instructions_seen - seen == 1


def test_protocol2_bulk_write_applies_different_registers_to_different_motors() -> None:
    """One BULK_WRITE: each motor gets its own register and value, and nothing else."""
    bus = Bus.open("emu://xm430-w210:1-3", baudrate=1_000_000)
    for i in (1, 2, 3):
        bus.declare(i, "xm430-w210")
    seen = bus.emulator.instructions_seen
    bus.bulk_write({1: {"goal_position": 0.5}, 2: {"led": 1},
                    3: {"profile_velocity": 1.0}})
    assert bus.emulator.instructions_seen - seen == 1
    m1, m2, m3 = (bus.emulator.motor(i) for i in (1, 2, 3))
    assert m1.get_raw("goal_position") == 2048 + round(0.5 / (2 * math.pi / 4096))
    assert m2.get_raw("led") == 1
    assert m3.get_raw("profile_velocity") == round(1.0 / (0.229 * 2 * math.pi / 60))
    assert m1.get_raw("led") == 0 and m3.get_raw("led") == 0
    assert m2.get_raw("goal_position") == 2048 and m3.get_raw("goal_position") == 2048
    assert m1.get_raw("profile_velocity") == 0 and m2.get_raw("profile_velocity") == 0


def test_factory_reset_keeping_id_and_baud_restores_defaults() -> None:
    """FACTORY_RESET (0x02) restores the e-Manual defaults but keeps ID and baud rate, so
    the motor is still reachable where it was."""
    bus = Bus.open("emu://xm430-w210:5", baudrate=1_000_000)
    bus.write(5, "return_delay_time", 0, raw=True)
    bus.write(5, "velocity_limit", 100, raw=True)
    bus.write(5, "moving_threshold", 20, raw=True)
    bus.write(5, "led", 1)
    bus.factory_reset(5)
    got = bus.read(5, ["id", "baud_rate", "return_delay_time", "velocity_limit",
                       "moving_threshold", "operating_mode"], raw=True)
    assert got == {"id": 5, "baud_rate": 3, "return_delay_time": 250, "velocity_limit": 330,
                   "moving_threshold": 10, "operating_mode": 3}
    assert bus.read(5, "led", raw=True) == 0


def test_protocol1_reset_restores_id_1() -> None:
    """1.0 RESET restores everything, the ID too (the e-Manual warns of this): the motor
    answers the RESET as ID 7, then only as ID 1."""
    bus = Bus.open("emu://rx28:7", baudrate=57142)
    bus.write(7, "return_delay_time", 0, raw=True)
    bus.factory_reset(7)
    with pytest.raises(NoResponse):
        bus.ping(7, retries=0)
    assert bus.ping(1).model_number == 28
    assert bus.read(1, "return_delay_time", raw=True) == 250


def test_protocol1_joint_mode_after_wheel_mode_reads_within_one_turn() -> None:
    """An RX-28 turned several times in wheel mode, then put back in joint mode, reads its
    potentiometer: the angle within one turn, and a goal inside the range is reached without
    unwinding the turns it made (e-Manual: joint mode is 0..300°)."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)   # wheel mode
    bus.write(1, "torque_enable", 1)
    bus.write(1, "moving_speed", 5.0)                   # wheel mode: 42 % output
    bus.port.clock.advance(8.0)                         # more than three turns
    assert motor.plant.position > 3 * 2 * math.pi
    bus.write(1, "torque_enable", 0)                    # stopped, and limp while it
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 1023}, raw=True)  # goes joint
    horn = math.remainder(motor.plant.position, 2 * math.pi)
    if abs(horn) < 2.6:                                 # outside the pot's dead zone
        assert bus.read(1, "present_position") == pytest.approx(horn, abs=0.006)
    before = motor.plant.position
    bus.write(1, {"goal_position": 0.0, "moving_speed": 0.0})
    bus.port.clock.advance(2.0)
    assert bus.read(1, "present_position") == pytest.approx(0.0, abs=0.006)
    assert abs(motor.plant.position - before) < math.pi  # not three turns back


# The Protocol 2.0 error table (ROBOTIS-GIT/emanual, docs/en/dxl/protocol2.md, "Error"):
# 0x02 Instruction Error — "Action has been used without Reg Write"; 0x05 Data Length Error —
# "Attempt to write Data that is shorter than the data length of the corresponding Address
# (ex: when you attempt to only use 2 bytes of a item that has been defined as 4 bytes)".
def test_protocol2_writing_part_of_an_item_is_a_data_length_error() -> None:
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    motor = bus.emulator.motor(1)
    table = bytes(motor.table)
    for inst in (PROTOCOL2.write(1, 116, (100).to_bytes(2, "little")),    # 2 of 4 bytes
                 PROTOCOL2.write(1, 118, (1).to_bytes(2, "little"))):     # the other half
        with pytest.raises(MotorError) as info:
            bus.transact(inst, {1: 0})
        assert info.value.errors == ("data length",)
    assert bytes(motor.table) == table


def test_protocol2_action_with_nothing_registered_is_an_instruction_error() -> None:
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    with pytest.raises(MotorError) as info:
        bus.transact(PROTOCOL2.action(1), {1: 0})
    assert info.value.errors == ("instruction",)
    bus.write(1, "led", 1, registered=True)
    bus.transact(PROTOCOL2.action(1), {1: 0})          # registered first: no error
    assert bus.read(1, "led", raw=True) == 1


def test_status_return_level_0_keeps_a_sync_read_slot_silent() -> None:
    """Level 0 returns a status for PING only (e-Manual, Status Return Level table), so a
    SYNC_READ gets no answer from that motor; on 2.0 the others still answer in turn."""
    bus = Bus.open("emu://xm430-w210:1-3", baudrate=1_000_000, retries=0)
    bus.emulator.motor(2).set_raw("status_return_level", 0)
    inst = PROTOCOL2.sync_read(132, 4, [1, 2, 3])
    with pytest.raises(NoResponse, match="motor 2"):
        bus.transact(inst, {1: 4, 2: 4, 3: 4})
    got = bus.transact(inst, {1: 4, 3: 4})
    assert sorted(got) == [1, 3]


# e-Manual, X-series Homing Offset(20) (ROBOTIS-GIT/emanual,
# _includes/en/dxl/control_table_homingoffset.md): "Present Position(132) = Actual Position +
# Homing Offset(20)"; in the one-turn position mode values outside -1024..1024 are ignored.
def test_x_homing_offset_shifts_present_position_and_goals() -> None:
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    motor = bus.emulator.motor(1)
    bus.write(1, "homing_offset", 1024, raw=True)
    assert bus.read(1, "present_position", raw=True) == 2048 + 1024   # the horn has not moved
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 2048, raw=True)      # in present-position terms: 90° back
    bus.port.clock.advance(2.0)
    assert bus.read(1, "present_position", raw=True) == 2048
    assert motor.plant.position == pytest.approx(-math.pi / 2, abs=0.002)
    bus.write(1, "torque_enable", 0)
    bus.write(1, "homing_offset", 2000, raw=True)      # outside ±1024 in mode 3: ignored
    assert bus.read(1, "present_position", raw=True) == 1024
    bus.write(1, "operating_mode", 4, raw=True)        # extended position mode: it counts
    assert bus.read(1, "present_position", raw=True) == 1024 + 2000
