"""Control-table registers that do something on the emulated motors, as on the real ones.

Each test names the e-Manual entry it checks (ROBOTIS-GIT/emanual, the model pages under
docs/en/dxl/ and the control-table descriptions under _includes/en/dxl/). The motors are driven
through the Bus on a virtual clock, so the seconds below cost nothing.
"""

from __future__ import annotations

import dataclasses
import math

import pytest

from servolab.dynamixel import Bus, ConfigError, MotorError, VirtualMotor, model
from servolab.dynamixel.packets import BROADCAST_ID, Instruction
from servolab.dynamixel.plant import ServoCommand
from servolab.dynamixel.protocol2 import ACTION, CLEAR, FACTORY_RESET, FACTORY_RESET_ALL
from servolab.sim import Simulation

# -- Input voltage -----------------------------------------------------------------------------

@pytest.mark.parametrize(("spec_text", "baud", "low_volts"), [
    ("rx28:1", 57142, 5.0), ("xm430-w210:1", 1_000_000, 9.0)])
def test_supply_outside_the_voltage_limits_sets_the_input_voltage_error(
        spec_text: str, baud: int, low_volts: float) -> None:
    """Min/Max Voltage Limit: "If Present Voltage(42) is out of the range, Voltage Range Error
    Bit (Bit0) of Status Packet is returned as '1'" (e-Manual, EX-106+ Min/Max Voltage Limit;
    the RX-28's default limits are 6.0..19.0 V, the XM430's 9.5..16.0 V). The X-series keep
    it in Hardware Error Status (bit 0) until a REBOOT; a 1.0 servo reports the condition as
    it stands."""
    bus = Bus.open(f"emu://{spec_text}", baudrate=baud)
    motor = bus.emulator.motor(1)
    motor.supply_voltage = low_volts
    bus.read(1, "present_position")         # a hardware error: the data comes all the same
    if motor.model.protocol == 1:
        assert bus.alerts == {1: 0x01}
        motor.supply_voltage = 12.0
        bus.read(1, "present_position")
        assert bus.alerts == {}                             # clean again
    else:
        assert bus.alerts == {1: 0x80}
        assert bus.read(1, "hardware_error_status", raw=True) == 0x01
        motor.supply_voltage = 12.0
        bus.read(1, "present_position")
        assert bus.alerts == {1: 0x80}                      # latched until a reboot
        bus.reboot(1)
        assert bus.read(1, "hardware_error_status", raw=True) == 0
        assert bus.alerts == {}


def test_lowering_the_max_voltage_limit_below_the_supply_is_an_error() -> None:
    """The limits are checked against the supply whenever either changes: the WRITE's own
    status already carries the error bit, and the limit is stored."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "max_voltage_limit", 150, raw=True)   # 15.0 V < the 18.5 V supply
    assert bus.alerts == {1: 0x01}                     # its own status carries the bit
    assert bus.hardware_errors(1) == ("input voltage",)
    assert bus.read(1, "max_voltage_limit", raw=True) == 150


# -- Lock (1.0) --------------------------------------------------------------------------------

def test_lock_makes_the_eeprom_read_only_until_power_off() -> None:
    """Lock(47): "1: EEPROM area cannot be modified ... If Lock is set to 1, the power must be
    turned off and then turned on again to change into 0" (e-Manual, Lock). The refused write
    answers a range error, as in the AX-12 user's manual's example 20 (whose older text locks
    all but addresses 24-35; servolab follows the e-Manual's EEPROM). RAM stays writable."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "lock", 1, raw=True)
    for name, value in (("return_delay_time", 10), ("lock", 0)):
        with pytest.raises(MotorError) as info:
            bus.write(1, name, value, raw=True)
        assert "range" in info.value.errors
    assert bus.read(1, ["return_delay_time", "lock"], raw=True) == {
        "return_delay_time": 250, "lock": 1}
    bus.write(1, "led", 1, raw=True)
    assert bus.read(1, "led", raw=True) == 1


# -- Realtime tick (X) -------------------------------------------------------------------------

def test_realtime_tick_counts_milliseconds_and_wraps_at_32767() -> None:
    """Realtime Tick(120): milliseconds, 0..32767, then from 0 again (e-Manual, XM430)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    clock = bus.port.clock
    motor = bus.emulator.motor(1)
    first = bus.read(1, "realtime_tick", raw=True)
    first_step = motor.sensed_step
    clock.advance(1.5)
    second = bus.read(1, "realtime_tick", raw=True)
    elapsed_ms = (motor.sensed_step - first_step) * clock.physics_step * 1000
    assert (second - first) % 32768 == pytest.approx(elapsed_ms, abs=1)
    clock.advance(32.0)
    third = bus.read(1, "realtime_tick", raw=True)
    assert 0 <= third <= 32767
    elapsed_ms = (motor.sensed_step - first_step) * clock.physics_step * 1000
    assert third == pytest.approx((first + elapsed_ms) % 32768, abs=1)


# -- Bus watchdog (X) --------------------------------------------------------------------------

def test_bus_watchdog_stops_a_motor_whose_host_fell_silent() -> None:
    """Bus Watchdog(98), the e-Manual's own example: velocity mode, torque on, goal velocity
    50, watchdog 100 (2 000 ms). With no instruction for 2 s the motor stops and the register
    reads -1; a goal written then is a Data Range Error; writing 0 clears the error and the
    next goal runs (e-Manual, Bus Watchdog(98), steps 1-8)."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    clock = bus.port.clock
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 50, raw=True)
    bus.write(1, "bus_watchdog", 100, raw=True)
    for _ in range(4):                     # the host keeps talking: 1.9 s gaps are fine
        clock.advance(1.9)
        assert bus.read(1, "present_velocity", raw=True) == pytest.approx(50, abs=1)
    motor = bus.emulator.motor(1)
    motor.sync()
    before = motor.plant.position
    clock.advance(2.5)                     # silence past 2 s: the motor stops at 2 s
    moved = motor.plant.position - before
    assert moved == pytest.approx(50 * 0.229 / 60 * 2 * 3.141592653589793 * 2.0, rel=0.02)
    assert bus.read(1, ["bus_watchdog", "present_velocity"], raw=True) == {
        "bus_watchdog": -1, "present_velocity": 0}
    with pytest.raises(MotorError) as info:
        bus.write(1, "goal_velocity", 150, raw=True)
    assert "data range" in " ".join(info.value.errors)
    with pytest.raises(MotorError):        # only 0 clears the error
        bus.write(1, "bus_watchdog", 100, raw=True)
    bus.write(1, "bus_watchdog", 0, raw=True)
    clock.advance(0.5)                     # cleared, but no new goal yet: still stopped
    assert bus.read(1, "present_velocity", raw=True) == 0
    bus.write(1, "goal_velocity", 150, raw=True)
    clock.advance(0.5)
    assert bus.read(1, "present_velocity", raw=True) == pytest.approx(150, abs=1)


def test_bus_watchdog_sleeps_while_torque_is_off() -> None:
    """It "monitors the communication interval ... when Torque Enable(64) is '1'"."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "bus_watchdog", 1, raw=True)   # 20 ms
    bus.port.clock.advance(1.0)
    assert bus.read(1, "bus_watchdog", raw=True) == 1


# -- Secondary ID (X) --------------------------------------------------------------------------

def test_secondary_id_groups_motors_for_ram_writes_without_answers() -> None:
    """Secondary ID(12): devices with the same Secondary ID form a group; a packet to it is
    acted on but "a Status Packet will not be returned"; "the EEPROM area of the Control Table
    cannot be modified with Secondary ID(12)"; "ID(7) has a greater priority" (e-Manual,
    XM430 Secondary(Shadow) ID(12))."""
    bus = Bus.open("emu://xl430-w250:1-3", baudrate=1_000_000)
    for motor_id in (1, 2):
        bus.write(motor_id, "secondary_id", 3, raw=True)   # 3 is also motor 3's own ID
    bus.write(1, "secondary_id", 10, raw=True)
    bus.write(2, "secondary_id", 10, raw=True)
    proto = bus.proto
    # RAM through the secondary ID: both act, nobody answers.
    bus.transact(proto.write(10, 65, b"\x01"))              # LED on
    assert bus.sync_read("led", [1, 2, 3], raw=True) == {1: 1, 2: 1, 3: 0}
    # EEPROM through it: refused.
    bus.transact(proto.write(10, 9, b"\x05"))               # return delay time
    assert bus.sync_read("return_delay_time", [1, 2], raw=True) == {1: 250, 2: 250}
    # An ID that is some motor's own ID reaches that motor alone.
    bus.write(2, "secondary_id", 3, raw=True)
    bus.write(3, "led", 1, raw=True)                        # answered by motor 3
    assert bus.sync_read("led", [2, 3], raw=True) == {2: 1, 3: 1}
    bus.write(2, "led", 0, raw=True)
    bus.transact(proto.write(3, 65, b"\x00"), {3: 0})
    assert bus.sync_read("led", [2, 3], raw=True) == {2: 0, 3: 0}


# -- Factory reset (X) -------------------------------------------------------------------------

def test_broadcast_factory_reset_all_is_ignored() -> None:
    """"In case of when Packet ID is a Broadcast ID 0xFE and Option is Reset All 0xFF,
    Factory Reset Instruction(0x06) will NOT be activated" (e-Manual, Protocol 2.0, Factory
    Reset); the other options are."""
    bus = Bus.open("emu://xm430-w350:1-2", baudrate=1_000_000)
    bus.sync_write("return_delay_time", {1: 10, 2: 10}, raw=True)
    bus.transact(Instruction(BROADCAST_ID, FACTORY_RESET, bytes((FACTORY_RESET_ALL,))))
    assert bus.sync_read("return_delay_time", [1, 2], raw=True) == {1: 10, 2: 10}
    bus.transact(Instruction(BROADCAST_ID, FACTORY_RESET, b"\x02"))   # keep ID and baud
    assert bus.sync_read("return_delay_time", [1, 2], raw=True) == {1: 250, 2: 250}


# -- MX-28 multi-turn (1.0) --------------------------------------------------------------------

def test_mx28_multi_turn_mode_goes_several_turns_and_reads_them() -> None:
    """MX-28: both angle limits 4095 is multi-turn mode, "joint mode control over multiple
    rotations (Position range : -28,672 ~ 28,672)"; "Present position = (Real Position /
    Resolution Divider) + Multi-turn Offset", applied in multi-turn mode only (e-Manual,
    MX-28 CW/CCW Angle Limit, Multi-turn Offset(20), Resolution Divider(22))."""
    bus = Bus.open("emu://mx28:1", baudrate=57142)
    bus.write(1, {"cw_angle_limit": 4095, "ccw_angle_limit": 4095}, raw=True)
    bus.write(1, "goal_position", 2048 + 3 * 4096, raw=True)   # three turns CCW
    bus.port.clock.advance(5.0)                                 # 55 rpm: 3.3 s
    assert bus.read(1, "present_position", raw=True) == 2048 + 3 * 4096
    bus.write(1, "goal_position", -20000, raw=True)
    bus.port.clock.advance(12.0)
    assert bus.read(1, "present_position", raw=True) == -20000
    with pytest.raises(ConfigError):                 # the driver refuses it first
        bus.write(1, "goal_position", 28673, raw=True)
    with pytest.raises(MotorError) as info:          # and so does the motor, sent raw
        bus.transact(bus.proto.write(1, 30, (28673).to_bytes(2, "little")), {1: 0})
    assert info.value.errors == ("range",)   # beyond the register's range of usage
    # Offset and divider change the reading, not the horn.
    bus.write(1, "torque_enable", 0)
    bus.write(1, {"multi_turn_offset": 1024, "resolution_divider": 4}, raw=True)
    assert bus.read(1, "present_position", raw=True) == -20000 // 4 + 1024
    # Back in joint mode the magnetic encoder reads the horn within one turn again, offset
    # and divider ignored: -20000 counts is 480 of its turn.
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 4095}, raw=True)
    assert bus.read(1, "present_position", raw=True) == -20000 % 4096 == 480


# -- Indirect address / data (X) ---------------------------------------------------------------

def test_indirect_data_stand_for_the_addresses_they_point_at() -> None:
    """Indirect Address n (168 + 2(n-1)) names the address Indirect Data n (224 + (n-1))
    stands for; a 4-byte item needs four consecutive indirect slots; the e-Manual's two
    examples: LED(65) through Indirect Data 1, Goal Position(116) through Indirect Data 2-5
    (e-Manual, XM430 Indirect Address and Indirect Data). Clients such as dynamixel-workbench
    use them to read scattered registers in one SYNC_READ."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "indirect_address_1", 65, raw=True)
    for n, address in zip((2, 3, 4, 5), (116, 117, 118, 119), strict=True):
        bus.write(1, f"indirect_address_{n}", address, raw=True)
    bus.write(1, "indirect_data_1", 1, raw=True)
    assert bus.read(1, "led", raw=True) == 1
    bus.write(1, "torque_enable", 1)
    bus.transact(bus.proto.write(1, 225, (1024).to_bytes(4, "little")), {1: 0})
    assert bus.read(1, "goal_position", raw=True) == 1024
    block = bus.read(1, ["indirect_data_1", "indirect_data_2", "indirect_data_3",
                         "indirect_data_4", "indirect_data_5"], raw=True)
    assert list(block.values()) == [1, *(1024).to_bytes(4, "little")]
    bus.port.clock.advance(2.0)
    assert bus.read(1, "present_position", raw=True) == 1024
    # Two of the four bytes of goal_position through indirect data: a Data Length Error.
    with pytest.raises(MotorError) as info:
        bus.transact(bus.proto.write(1, 225, b"\x00\x08"), {1: 0})
    assert "data length" in " ".join(info.value.errors)


# -- Sensed current (EX-106+) ------------------------------------------------------------------

def test_ex106_sensed_current_is_512_at_rest_and_moves_with_the_load() -> None:
    """Sensed Current(56): "512 is equal to 0mA"; 10 mA per unit; below 512 the motor torques
    CCW, above it CW (e-Manual, EX-106+ Sensed Current); under a load it follows present_load,
    7 A at stall (EX-106+ Specifications: 10.9 N*m at 18.5 V, 7 A)."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142)
    assert bus.read(1, "sensed_current", raw=True) == 512
    bus.write(1, "torque_enable", 1)
    bus.emulator.motor(1).external_load = -0.3        # 30 % of stall torque, clockwise
    bus.port.clock.advance(0.1)
    load = bus.read(1, "present_load")
    current = bus.read(1, "sensed_current", raw=True)
    assert (current < 512) == (load > 0)
    assert abs(current - 512) * 0.010 == pytest.approx(abs(load) * 7.0, abs=0.02)  # 7 A stall


def test_protocol1_overheating_lasts_as_long_as_the_heat() -> None:
    """1.0: the status error byte reports overheating while "the internal temperature is out
    of the range of operating temperature set in the Control Table" (e-Manual, Alarm
    Shutdown bit 2); its shutdown zeroes the torque limit, and once cool the bit goes."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, "temperature_limit", 40, raw=True)
    bus.write(1, "torque_enable", 1)
    motor.external_load = 0.9                       # heats past 40 °C
    bus.port.clock.advance(300.0)
    bus.read(1, "present_temperature")
    assert bus.alerts == {1: 0x04}
    assert bus.read(1, "torque_limit", raw=True) == 0   # shutdown: output 0 %
    motor.external_load = 0.0
    bus.write(1, "torque_enable", 0)
    bus.port.clock.advance(1500.0)                  # five time constants to cool
    assert bus.read(1, "present_temperature") < 40
    assert bus.alerts == {}


# -- Present Position's turns (X) --------------------------------------------------------------

def test_x_present_position_counts_turns_until_position_mode_resets_it() -> None:
    """"Present Position(132) represents a 4 byte continuous range ... when Torque is turned
    off regardless of Operating Mode(11)", and is "reset to an absolute position value within
    one full rotation" 1. when the mode is changed to Position Control Mode, 2. when torque is
    turned on in Position Control Mode, 3. at power-up or REBOOT (e-Manual, Present Position
    note, control_table_opmode_note.md)."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=1_000_000)
    turn = 4096
    bus.write(1, "operating_mode", 4, raw=True)             # extended position
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_position", 2048 + 2 * turn + 100, raw=True)
    bus.port.clock.advance(10.0)
    assert bus.read(1, "present_position", raw=True) == 2048 + 2 * turn + 100
    bus.reboot(1)                                            # 3: within one turn again
    assert bus.read(1, "present_position", raw=True) == 2148
    bus.write(1, "operating_mode", 1, raw=True)              # velocity: counts turns
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 100, raw=True)
    bus.port.clock.advance(5.0)
    bus.write(1, "goal_velocity", 0, raw=True)
    bus.write(1, "torque_enable", 0)
    counted = bus.read(1, "present_position", raw=True)
    assert counted > 2 * turn
    bus.write(1, "operating_mode", 3, raw=True)              # 1: mode changed to position
    assert bus.read(1, "present_position", raw=True) == counted % turn
    # Out of position mode again, turns are counted once more (with torque off too) ...
    bus.write(1, "operating_mode", 1, raw=True)
    bus.write(1, "torque_enable", 1)
    bus.write(1, "goal_velocity", 100, raw=True)
    bus.port.clock.advance(4.0)
    bus.write(1, "torque_enable", 0)                         # torque off: keep counting
    over = bus.read(1, "present_position", raw=True)
    assert over > turn
    bus.write(1, {"operating_mode": 3}, raw=True)            # ... until position mode
    assert bus.read(1, "present_position", raw=True) == over % turn


class HandTurned:
    """A joint a hand turns while the torque is off: a plant whose angle the test sets."""

    def __init__(self) -> None:
        self.command = ServoCommand()
        self.position = 0.0
        self.velocity = self.effort = 0.0
        self.temperature = 30.0

    def step(self, dt: float) -> None:
        pass


def test_x_torque_on_in_position_mode_resets_the_count() -> None:
    """Case 2 of the e-Manual's note: torque turned on in Position Control Mode. With torque
    off the count follows the horn past a turn; torque on brings it within one."""
    sim = Simulation()
    bus = Bus.open("emu://xl430-w250:1", baudrate=1_000_000, simulation=sim)
    hand = HandTurned()
    bus.emulator.motor(1).attach_plant(hand)
    hand.position = 3 * math.pi                              # one and a half turns by hand
    bus.port.clock.advance(0.01)
    assert bus.read(1, "present_position", raw=True) == 2048 + 3 * 2048
    bus.write(1, "torque_enable", 1)
    assert bus.read(1, "present_position", raw=True) == (2048 + 3 * 2048) % 4096


# -- Firmware-dependent behaviour ---------------------------------------------------------------

def test_drive_mode_bit_3_needs_firmware_45() -> None:
    """"Torque On by Goal Update is available from firmware V45" (e-Manual, Drive Mode(10)):
    an X-series on firmware 44 keeps torque off when a goal is written."""
    old = VirtualMotor(dataclasses.replace(model("XM430-W210"), firmware=44), 1)
    new = VirtualMotor(model("XM430-W210"), 2)
    for motor in (old, new):
        motor.set_raw("drive_mode", 0x08)
        assert motor.write(116, (3000).to_bytes(4, "little")) == 0
    assert (old.get_raw("torque_enable"), new.get_raw("torque_enable")) == (0, 1)


def test_broadcast_factory_reset_all_is_carried_out_by_firmware_before_42() -> None:
    """The broadcast FACTORY_RESET 0xFF guard is a firmware-42 feature (e-Manual, Protocol
    2.0, Factory Reset); an older motor resets."""
    old = VirtualMotor(dataclasses.replace(model("XM430-W210"), firmware=41), 1)
    old.set_raw("return_delay_time", 10)
    old.execute(Instruction(BROADCAST_ID, FACTORY_RESET, bytes((FACTORY_RESET_ALL,))),
                "FACTORY_RESET")
    assert old.get_raw("return_delay_time") == 250


# -- Reverse mode --------------------------------------------------------------------------------

def test_ex106_ignores_reverse_in_wheel_mode_and_x_reverses_velocity() -> None:
    """"When MX-106 and EX-106+ are set to Wheel Mode(endless), Normal/Reverse Mode is not
    available" (e-Manual, Drive Mode(10)); an X-series in reverse turns the other way for the
    same goal velocity, and reports its velocity in its own (reversed) sense."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
    bus.write(1, "drive_mode", 0x01, raw=True)
    bus.write(1, "moving_speed", 500, raw=True)              # CCW at 49 % output
    bus.port.clock.advance(0.5)
    assert bus.emulator.motor(1).plant.velocity > 0
    xbus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000)
    xbus.write(2, "drive_mode", 0x01, raw=True)
    for motor_id in (1, 2):
        xbus.write(motor_id, "operating_mode", 1, raw=True)
        xbus.write(motor_id, "torque_enable", 1)
        xbus.write(motor_id, "goal_velocity", 100, raw=True)
    xbus.port.clock.advance(0.5)
    horns = [xbus.emulator.motor(i).plant.velocity for i in (1, 2)]
    assert horns[0] == pytest.approx(-horns[1]) and horns[0] > 0
    assert xbus.sync_read("present_velocity", [1, 2], raw=True) == {1: 100, 2: 100}


# -- Realtime tick (MX-28) -------------------------------------------------------------------------

def test_mx28_realtime_tick_counts_milliseconds() -> None:
    """MX-28 (1.0, firmware 40 and later): Realtime Tick(50), 1 ms, 0..32767 (e-Manual,
    MX-28)."""
    bus = Bus.open("emu://mx28:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    first = bus.read(1, "realtime_tick", raw=True)
    step = motor.sensed_step
    bus.port.clock.advance(2.0)
    second = bus.read(1, "realtime_tick", raw=True)
    elapsed_ms = (motor.sensed_step - step) * bus.port.clock.physics_step * 1000
    assert (second - first) % 32768 == pytest.approx(elapsed_ms, abs=1)


# -- Wheel-mode present speed (1.0) ----------------------------------------------------------------

def test_wheel_mode_present_speed_is_the_output_not_the_speed() -> None:
    """EX-106+ wheel mode: present speed is the output ratio ("if it is set to 512, it means
    that the torque is controlled by 50 % of the maximum torque", e-Manual EX-106+ Present
    Speed): a load that slows the horn leaves it where moving_speed put it."""
    bus = Bus.open("emu://ex106+:1", baudrate=57142)
    motor = bus.emulator.motor(1)
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)
    bus.write(1, "moving_speed", 512, raw=True)
    bus.port.clock.advance(0.5)
    free = motor.plant.velocity
    assert bus.read(1, "present_speed", raw=True) == 512
    motor.external_load = -0.6                   # caps the horn at 40 % of no-load speed
    bus.port.clock.advance(0.5)
    assert motor.plant.velocity < free
    assert bus.read(1, "present_speed", raw=True) == 512
    bus.write(1, "torque_enable", 0)
    assert bus.read(1, "present_speed", raw=True) == 0


# -- Resets --------------------------------------------------------------------------------------

def test_a_registered_write_does_not_survive_a_reboot() -> None:
    """REBOOT restarts the firmware: a REG_WRITE waiting for its ACTION is gone, so an ACTION
    then has nothing registered, the Protocol 2.0 error table's Instruction Error ("Action
    has been used without Reg Write")."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.write(1, "led", 1, raw=True, registered=True)
    assert bus.read(1, "registered_instruction", raw=True) == 1
    bus.reboot(1)
    assert bus.read(1, "registered_instruction", raw=True) == 0
    with pytest.raises(MotorError) as info:
        bus.transact(Instruction(1, ACTION), {1: 0})
    assert "instruction" in " ".join(info.value.errors)
    assert bus.read(1, "led", raw=True) == 0


def test_clear_keeps_the_homing_offset_as_reboot_does() -> None:
    """CLEAR and REBOOT both bring the count within one turn, which "will still be affected
    by the configured Homing Offset(20)" (e-Manual, Present Position note)."""
    present = {}
    for how in ("clear", "reboot"):
        bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
        bus.write(1, {"operating_mode": 4}, raw=True)
        bus.write(1, "homing_offset", 1000, raw=True)
        bus.write(1, "torque_enable", 1)
        bus.write(1, "goal_position", 2048 + 1000 + 4096 + 500, raw=True)
        bus.port.clock.advance(6.0)
        bus.write(1, "torque_enable", 0)
        if how == "clear":
            # CLEAR of the multi-turn count: option 0x01 and the key "DXL\"" (e-Manual,
            # Protocol 2.0, Clear)
            bus.transact(Instruction(1, CLEAR, bytes.fromhex("01 44 58 4C 22")), {1: 0})
        else:
            bus.reboot(1)
        present[how] = bus.read(1, "present_position", raw=True)
    assert present == {"clear": 2048 + 500 + 1000, "reboot": 2048 + 500 + 1000}


def test_the_bus_refuses_a_broadcast_factory_reset_of_everything() -> None:
    """The motors ignore it (e-Manual, Protocol 2.0, Factory Reset): the bus says so before
    sending anything, instead of forgetting what it knows of every motor."""
    bus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000)
    sent = bus.port.bytes_written
    with pytest.raises(ConfigError, match="broadcast"):
        bus.factory_reset(BROADCAST_ID, keep_id=False)
    assert bus.port.bytes_written == sent


def test_motors_of_one_model_and_firmware_share_one_model_object() -> None:
    """The bus keeps one Model per (model, firmware) a PING reports, so that motors of the
    same kind share the plans it precomputes."""
    emulator_model = dataclasses.replace(model("XM430-W210"), firmware=44)
    bus = Bus.open("emu://xm430-w210:1-2", baudrate=1_000_000)
    for motor in bus.emulator.motors:
        motor.set_raw("firmware_version", emulator_model.firmware)
    bus.ping(1)
    bus.ping(2)
    assert bus.motors[1].firmware == 44 and bus.motors[1] is bus.motors[2]
