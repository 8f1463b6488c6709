"""What the bus knows of a motor's state: its mode (1.0 wheel mode, which changes the units
of moving and present speed on AX/RX/EX) and its status return level, through every way the
bus changes them (WRITE, SYNC_WRITE, REG_WRITE + ACTION, REBOOT, RESET, FACTORY_RESET).

A bus that gets a motor's state wrong turns a wheel at the wrong speed, or waits for a status
that never comes (a timeout on every instruction), or takes a status for the answer to the
wrong request.
"""

from __future__ import annotations

import logging
import math

import pytest

from servolab.dynamixel import Bus, ConfigError, model
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.units import from_si, to_si

RPM = 2 * math.pi / 60
EX106 = model("EX-106+")
RX28 = model("RX-28")
MX28 = model("MX-28")


def v1_bus(name: str, ids: str = "1") -> Bus:
    bus = Bus.open(f"emu://{name}:{ids}", baudrate=57142, retries=0)
    for motor in bus.emulator.motors:
        bus.ping(motor.id)
    return bus


def wheel(bus: Bus, motor_id: int) -> None:
    """Wheel mode through the bus: both angle limits 0 (e-Manual, CW/CCW Angle Limit)."""
    bus.write(motor_id, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)


def seen(bus: Bus) -> int:
    return int(bus.emulator.instructions_seen)


# -- wheel mode: moving/present speed are an output ratio on AX/RX/EX ---------------------------
# e-Manual, Moving Speed (_includes/en/dxl/control_table_moving_speed.md, and the EX-106+ page
# docs/en/dxl/ex/ex-106+.md): "Wheel Mode: 0~2047 can be used, the unit is about 0.1%. ...
# the 10th bit becomes the direction bit ... In Wheel Mode, only the output control is
# possible, not speed"; EX-106+ Present Speed: "Wheel Mode: The unit is about 0.1%". Unloaded,
# an output of x % turns the horn at x % of the no-load speed (EX-106+: 91 rpm at 18.5 V).

@pytest.mark.parametrize("m", [EX106, RX28], ids=lambda m: m.name)
@pytest.mark.parametrize("speed", [3.0, -3.0])
def test_wheel_speed_in_si_is_the_unloaded_horn_speed(m, speed: float) -> None:
    bus = v1_bus(m.name.lower())
    wheel(bus, 1)
    before = seen(bus)
    bus.write(1, "moving_speed", speed)
    assert seen(bus) - before == 1              # the bus wrote the limits: no READ of them
    motor = bus.emulator.motor(1)
    share = round(abs(speed) / m.no_load_speed * 1023)
    assert motor.get_raw("moving_speed") == (share | 0x400 if speed < 0 else share)
    bus.port.clock.advance(1.0)
    assert motor.velocity == pytest.approx(speed, abs=m.no_load_speed / 1023)
    assert bus.read(1, "present_speed") == pytest.approx(speed, abs=m.no_load_speed / 1023)
    # raw is the register as it is
    assert bus.read(1, "moving_speed", raw=True) == motor.get_raw("moving_speed")


def test_speed_beyond_full_output_is_refused_in_both_modes() -> None:
    """Full output (1023) unloaded is the no-load speed: a faster wheel speed cannot be asked
    for, and is refused before anything is sent, as a joint speed beyond 1023 x 0.111 rpm."""
    bus = v1_bus("ex106+", "1-2")
    wheel(bus, 1)
    bus.write(1, "moving_speed", -EX106.no_load_speed)   # exactly full output, clockwise
    assert bus.emulator.motor(1).get_raw("moving_speed") == 0x400 | 1023
    before = seen(bus)
    with pytest.raises(ConfigError, match="full output"):
        bus.write(1, "moving_speed", -100.0)
    with pytest.raises(ConfigError, match="moving_speed"):
        bus.write(2, "moving_speed", 100.0)          # joint mode: 1023 x 0.111 rpm at most
    assert seen(bus) == before


def test_mode_unknown_is_read_once_then_kept() -> None:
    """A motor put in wheel mode behind the bus's back (here a raw instruction the bus does
    not look into): the first SI speed reads both angle limits, once."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142, retries=0)
    bus.declare(1, "ex106+")                                 # no PING: mode unknown
    bus.transact(PROTOCOL1.write(1, 6, bytes(4)), {1: 0})   # CW, CCW angle limit = 0
    bus.write(1, "moving_speed", 2.0)
    before = seen(bus)
    bus.port.clock.advance(1.0)
    assert bus.read(1, "present_speed") == pytest.approx(2.0, abs=EX106.no_load_speed / 1023)
    assert bus.read(1, ["present_position", "present_speed"])["present_speed"] \
        == pytest.approx(2.0, abs=EX106.no_load_speed / 1023)
    assert seen(bus) - before == 2                   # the two reads, no more limits
    assert bus.wheel_mode(1)


def test_plans_follow_the_mode() -> None:
    """A read or write repeated after a change of mode converts by the new one: what the bus
    keeps of a repeated transaction holds no conversion of a mode."""
    bus = v1_bus("ex106+", "1-2")
    for motor_id in (1, 2):
        bus.write(motor_id, "moving_speed", 1.0)     # joint mode: 0.111 rpm a unit
    assert bus.emulator.motor(1).get_raw("moving_speed") == round(1.0 / (0.111 * RPM))
    assert bus.read(1, "moving_speed") == pytest.approx(1.0, abs=0.111 * RPM)
    wheel(bus, 1)
    bus.write(1, "moving_speed", 1.0)
    assert bus.emulator.motor(1).get_raw("moving_speed") == round(1.0 / EX106.no_load_speed
                                                                  * 1023)
    assert bus.read(1, "moving_speed") == pytest.approx(1.0, abs=EX106.no_load_speed / 1023)
    # many motors, one in each mode
    bus.sync_write("moving_speed", {1: 2.0, 2: 2.0})
    assert [bus.emulator.motor(i).get_raw("moving_speed") for i in (1, 2)] == [
        round(2.0 / EX106.no_load_speed * 1023), round(2.0 / (0.111 * RPM))]
    got = bus.sync_read("moving_speed", [1, 2])
    assert got[1] == pytest.approx(2.0, abs=EX106.no_load_speed / 1023)
    assert got[2] == pytest.approx(2.0, abs=0.111 * RPM)
    # back to joint mode (one limit written: the other is known)
    bus.write(1, "ccw_angle_limit", 4095, raw=True)
    assert not bus.wheel_mode(1)
    assert bus.read(1, "moving_speed") == pytest.approx(
        bus.emulator.motor(1).get_raw("moving_speed") * 0.111 * RPM)


def test_registered_mode_change_applies_at_action() -> None:
    bus = v1_bus("ex106+")
    assert not bus.wheel_mode(1)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True, registered=True)
    assert not bus.wheel_mode(1)                     # not before ACTION
    bus.action()
    before = seen(bus)
    assert bus.wheel_mode(1)
    bus.write(1, "moving_speed", 3.0)
    assert seen(bus) - before == 1
    assert bus.emulator.motor(1).get_raw("moving_speed") == round(3.0 / EX106.no_load_speed
                                                                  * 1023)


def test_mx28_wheel_mode_speed_stays_a_speed() -> None:
    """MX-28 wheel mode sets a speed, 0.114 rpm a unit (Model.wheel_output_ratio False):
    no conversion by mode, and so no READ of the limits."""
    bus = v1_bus("mx28")
    bus.transact(PROTOCOL1.write(1, 6, bytes(4)), {1: 0})
    before = seen(bus)
    bus.write(1, "moving_speed", 3.0)
    assert seen(bus) - before == 1
    assert bus.emulator.motor(1).get_raw("moving_speed") == round(3.0 / (0.114 * RPM))


def test_units_convert_wheel_speed_by_model() -> None:
    reg = EX106.register("present_speed")
    assert to_si(EX106, reg, 1023, wheel=True) == pytest.approx(EX106.no_load_speed)
    assert to_si(EX106, reg, 0x400 | 512, wheel=True) == pytest.approx(
        -512 / 1023 * EX106.no_load_speed)
    assert to_si(EX106, reg, 300) == pytest.approx(300 * 0.111 * RPM)   # joint mode
    speed = MX28.register("moving_speed")
    assert to_si(MX28, speed, 300, wheel=True) == to_si(MX28, speed, 300)
    assert from_si(MX28, speed, 3.0, wheel=True) == from_si(MX28, speed, 3.0)
    moving = EX106.register("moving_speed")
    assert from_si(EX106, moving, -EX106.no_load_speed / 2, wheel=True) == 0x400 | 512
    with pytest.raises(ConfigError, match="full output"):
        from_si(EX106, moving, 50.0, wheel=True)


# -- status return level ------------------------------------------------------------------------
# e-Manual, Status Return Level (_includes/en/dxl/control_table_status_return_lv.md): 0 answers
# PING only, 1 PING and READ, 2 every instruction. X-series: address 68, RAM (factory 2 after
# a REBOOT); 1.0: address 16, EEPROM.

def x_bus(ids: str = "1-2", baud: int = 1_000_000) -> Bus:
    bus = Bus.open(f"emu://xm430-w210:{ids}", baudrate=baud, retries=0)
    for motor in bus.emulator.motors:
        bus.ping(motor.id)
    return bus


def quiet(bus: Bus) -> None:
    """No timeout and no status out of place: the bus waited exactly for what came."""
    bus.port.clock.advance(0.05)
    bus.read(bus.emulator.motors[0].id, "led", raw=True)
    assert (bus.stats.timeouts, bus.stats.stale, bus.stats.corrupt) == (0, 0, 0)


@pytest.mark.parametrize("level", [0, 1, 2])
def test_reboot_brings_an_x_series_level_back_to_2(level: int) -> None:
    """The REBOOT's status goes out before the reboot, by the level before it (only at 2);
    then the motor is at its factory level 2 (RAM), and the bus knows."""
    bus = x_bus()
    bus.write(1, "status_return_level", level)
    assert bus.status_return_level == {1: level}
    bus.reboot(1)
    assert bus.status_return_level.get(1, 2) == 2
    assert bus.emulator.motor(1).get_raw("status_return_level") == 2
    bus.write(1, "led", 1)                           # answered again: awaited
    assert bus.read(1, "led", raw=True) == 1
    quiet(bus)


@pytest.mark.parametrize("spec", ["xm430-w210:1-2", "rx28:1-2"])
def test_registered_level_applies_at_action(spec: str) -> None:
    bus = Bus.open(f"emu://{spec}", baudrate=57142 if spec.startswith("rx") else 1_000_000,
                   retries=0)
    bus.write(1, "status_return_level", 1, registered=True)
    assert bus.status_return_level.get(1, 2) == 2    # nothing changes before ACTION
    bus.write(1, "led", 1)                           # still level 2: answered
    bus.action()
    assert bus.status_return_level == {1: 1}
    bus.write(1, "led", 0)                           # level 1: no status, none awaited
    assert bus.read(1, "led", raw=True) == 0
    # the motor keeps one REG_WRITE, the last: a later one replaces a level's
    bus.write(1, "status_return_level", 2)
    bus.write(1, "status_return_level", 0, registered=True)
    bus.write(1, "led", 1, registered=True)
    bus.action()
    assert bus.status_return_level.get(1, 2) == 2
    assert bus.emulator.motor(1).get_raw("status_return_level") == 2
    quiet(bus)


@pytest.mark.parametrize("level", [1, 2])
def test_protocol1_reset_moves_the_motor_to_id_1_at_level_2(level: int) -> None:
    """e-Manual, Protocol 1.0, Factory Reset: "reset the Control Table of Dynamixel to the
    factory default values"; the factory ID is 1 (ibid., ID), the level 2."""
    bus = v1_bus("rx28", "5")
    bus.write(5, "status_return_level", level)
    bus.write(5, "led", 1)
    bus.factory_reset(5)
    assert 5 not in bus.motors and 5 not in bus.status_return_level
    assert bus.status_return_level == {}
    assert [m.id for m in bus.emulator.motors] == [1]
    assert bus.read(1, "status_return_level", raw=True) == 2   # learns the model by PING
    assert bus.motors[1] == RX28
    quiet(bus)


@pytest.mark.parametrize(("keep_id", "level"), [(True, 1), (False, 1), (False, 2)])
def test_protocol2_factory_reset_follows_the_id_and_level(keep_id: bool, level: int) -> None:
    """FACTORY_RESET keeping the ID (and baud rate) or not (e-Manual, Protocol 2.0, Factory
    Reset: 0xFF reset all, 0x01 all but the ID); the motor is at level 2 after it. At 57600
    bps, the factory rate, so that the motor stays on the bus when its baud rate resets."""
    bus = x_bus("3", baud=57600)
    bus.write(3, "status_return_level", level)
    bus.factory_reset(3, keep_id=keep_id)
    assert bus.status_return_level == {}
    motor_id = 3 if keep_id else 1
    assert (3 in bus.motors) == keep_id
    assert [m.id for m in bus.emulator.motors] == [motor_id]
    bus.write(motor_id, "led", 1)                    # level 2: answered, awaited
    assert bus.read(motor_id, "led", raw=True) == 1
    quiet(bus)


def test_reboot_does_not_log_the_alert_it_clears(caplog: pytest.LogCaptureFixture) -> None:
    """The REBOOT's status still carries the hardware-error alert the reboot clears: it is
    not the motor's state, and not worth a warning."""
    bus = x_bus()
    bus.write(2, "torque_enable", 1)
    bus.emulator.motor(2).inject_hardware_error("overload")
    with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.bus"):
        bus.reboot(2)
        assert bus.read(2, "hardware_error_status", raw=True) == 0
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert bus.alerts == {}


def test_alerts_is_a_read_only_view() -> None:
    bus = x_bus()
    bus.emulator.motor(1).inject_hardware_error("overheating")
    bus.read(1, "led")
    alerts = bus.alerts
    assert alerts == {1: 0x80}
    with pytest.raises(TypeError):
        alerts[1] = 0  # type: ignore[index]
    bus.emulator.motor(1).clear_hardware_error()
    bus.read(1, "led")
    assert alerts == {}                              # a view: up to date


def test_ping_learns_the_mode_with_the_model_number() -> None:
    """On 1.0 the READ after a PING takes addresses 0-9 (model number to CCW angle limit, the
    same on every 1.0 model, e-Manual control tables): no extra READ for the mode later, and
    nothing is sent before a ConfigError for an out-of-range SI speed."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142, retries=0)
    motor = bus.emulator.motor(1)
    motor.set_raw("cw_angle_limit", 0)
    motor.set_raw("ccw_angle_limit", 0)
    bus.ping(1)
    assert bus.wheel_mode(1)
    before = seen(bus)
    with pytest.raises(ConfigError):
        bus.write(1, "moving_speed", 10 * EX106.no_load_speed)
    assert seen(bus) == before


def test_a_mode_that_cannot_be_read_is_an_error_before_the_wire() -> None:
    """At status return level 0 a motor answers no READ (e-Manual, Status Return Level): the
    bus says to declare the mode instead of sending a READ that cannot be answered."""
    bus = Bus.open("emu://rx28:1", baudrate=57142, retries=0)
    bus.declare(1, "rx28")
    bus.status_return_level[1] = 0
    with pytest.raises(ConfigError, match="wheel_mode"):
        bus.sync_write("moving_speed", {1: 1.0})
    bus.declare(1, "rx28", wheel_mode=True)
    bus.sync_write("moving_speed", {1: 1.0})
    assert bus.emulator.motor(1).get_raw("moving_speed") == round(
        1.0 / RX28.no_load_speed * 1023)


@pytest.mark.parametrize(("values", "message"), [
    ({"goal_position": 9.0}, r"goal_position"),          # beyond the XM430's position limits
    ({"goal_position": 1.0, "id": 5}, r"\bid\b"),        # commissioning beside a register
    ({"id": 5}, r"change_id\(\) and change_baud\(\)"),
    ({}, r"names no register"),
    ({"goal_positon": 1.0}, r"did you mean goal_position"),
])
def test_check_write_refuses_what_write_refuses_and_sends_no_write(
        values: dict[str, float], message: str) -> None:
    """A robot checks every joint's goal with check_write before it moves any: each refusal
    is one line, and no WRITE reaches the motor (its goal stays where it was)."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    motor = bus.port.emulator.motor(1)  # type: ignore[attr-defined]
    before = motor.get_raw("goal_position")
    with pytest.raises(ConfigError, match=message) as info:
        bus.check_write(1, values)
    assert "\n" not in str(info.value)
    if values and "id" not in values:  # write() refuses each the same way
        with pytest.raises(ConfigError):
            bus.write(1, values)
    assert motor.get_raw("goal_position") == before
    bus.check_write(1, {"goal_position": 1.0})   # a goal the motor takes passes
    assert motor.get_raw("goal_position") == before
    with pytest.raises(ConfigError, match="motor ID 254 is the broadcast ID"):
        bus.check_write(254, {"led": 1})


def test_a_write_of_id_alone_in_a_mapping_is_followed_as_change_id() -> None:
    """``write(1, {"id": 5})`` is the same as ``write(1, "id", 5)``: the bus follows the motor
    to its new ID rather than losing it."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000, retries=0)
    bus.write(1, {"id": 5})
    assert bus.ping(5).model is not None and bus.read(5, "id") == 5
