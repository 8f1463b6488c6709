"""Safe commissioning and checks before the wire (issue 29): what a lab replacing the Dynamixel
Wizard does on its first day with new motors, on emulated motors.

- IDs: a used ID is refused with nothing written; a free one is taken, the motor is pinged
  there and the bus follows it (its status comes from the new ID).
- Baud rates: from the model's e-Manual table; the WRITE is answered at the old rate, then the
  bus speaks the new one.
- Status return level and return delay: learnt on first contact and honoured, so that a motor
  at level 1 or 0 is written without "is it powered?".
- Before the wire: EEPROM with torque on, values beyond the motor's mode and limits, wrong
  types, unknown names ("did you mean"), raw addresses beyond the protocol.
"""

from __future__ import annotations

import errno
import logging
import math
from collections.abc import Callable
from pathlib import Path

import pytest
import serial

from servolab.dynamixel import Bus, ConfigError, DynamixelError, MotorError, NoResponse, model
from servolab.dynamixel.bus import line_rate, raw_access_limits, register_of, usable_rates
from servolab.dynamixel.errors import did_you_mean
from servolab.dynamixel.packets import Instruction
from tests.clirun import one_line


def sent(bus: Bus) -> list[Instruction]:
    """From now on, every instruction the bus puts on the wire (decoded), in order."""
    packets: list[Instruction] = []
    write = bus.port.write

    def recording(data: bytes) -> None:
        packets.append(bus.proto.decode_instruction(bytes(data)))
        write(data)

    bus.port.write = recording  # type: ignore[method-assign]
    return packets


def names(bus: Bus, packets: list[Instruction]) -> list[str]:
    return [bus.proto.instruction_name(p.instruction) for p in packets]


# -- IDs ------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("url", "baud"), [("emu://xm430-w350:1,12", 57600),
                                           ("emu://rx28:1,12", 57142)])
def test_id_change_to_a_free_id_is_followed(url: str, baud: int) -> None:
    """The motor answers its WRITE from the new ID; the bus takes that status (no timeout,
    no retry), pings the new ID and moves what it knows there."""
    bus = Bus.open(url, baudrate=baud)
    bus.read(1, "present_position")                     # model learnt at ID 1
    packets = sent(bus)
    found = bus.change_id(1, 13)
    assert found.id == 13 and found.model is bus.motors[13]
    assert 13 in bus.motors and 1 not in bus.motors
    assert sorted(m.id for m in bus.emulator.motors) == [12, 13]
    assert names(bus, packets).count("WRITE") == 1       # written once
    write = next(p for p in packets if bus.proto.instruction_name(p.instruction) == "WRITE")
    assert write.id == 1
    assert bus.read(13, "present_position") == pytest.approx(0.0, abs=0.01)


def test_id_change_status_comes_from_the_new_id_and_is_taken() -> None:
    """No timeout is spent on the WRITE: its status, from ID 13, is the one awaited."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    bus.ping(1)
    timeouts = bus.stats.timeouts
    bus.change_id(1, 13)
    # the only timeouts are the PINGs that found ID 13 free, in both protocols (1 + 2
    # retries each: one wire may carry both)
    assert bus.stats.timeouts - timeouts == 6
    assert bus.stats.stale == 0


def test_a_used_id_is_refused_across_protocols() -> None:
    """One wire may carry both protocols (a mixed bus): an RX-28 (1.0) may not take the ID
    an XM430 (2.0) answers at, through a bus that speaks 1.0, nor the other way round."""
    from servolab.dynamixel.emulator import Emulator, VirtualMotor
    from servolab.dynamixel.models import model
    from servolab.dynamixel.ports import MemoryPort
    from servolab.sim import Simulation

    sim = Simulation()
    emulator = sim.add_emulator(Emulator(None))
    emulator.add(VirtualMotor(model("XM430-W210"), 1, baudrate=57600))
    emulator.add(VirtualMotor(model("RX-28"), 11, baudrate=57600))
    for protocol, old, new in ((1, 11, 1), (2, 1, 11)):
        bus = Bus(MemoryPort(emulator, 57600, clock=sim, protocol=protocol, lock=sim.lock),
                  protocol=protocol)
        with pytest.raises(ConfigError, match=f"ID {new} is taken"):
            bus.change_id(old, new)
    assert sorted(m.id for m in emulator.motors) == [1, 11]


def test_a_refused_id_write_is_said_at_once() -> None:
    """An RX-28 whose EEPROM is locked (Lock(47) = 1, e-Manual RX-28) refuses the WRITE of
    its ID from its old ID: the bus sends the WRITE once more, awaiting the status from the
    old ID, and says why, instead of resending it and waiting for the new ID each time."""
    bus = Bus.open("emu://rx28:11", baudrate=57142)
    bus.write(11, "lock", 1)
    packets = sent(bus)
    with pytest.raises(MotorError):
        bus.change_id(11, 12)
    assert names(bus, packets).count("WRITE") == 2
    assert bus.emulator.motor(11).get_raw("id") == 11


def test_id_change_to_a_used_id_is_refused_and_nothing_is_written() -> None:
    """pypot's change_id refuses a used ID too (pypot issue #35): two motors at one ID
    answer together and garble each other."""
    bus = Bus.open("emu://xm430-w350:1,12", baudrate=57600)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        bus.change_id(1, 12)
    one_line(info.value, "ID 12 is taken", "nothing was written")
    assert "WRITE" not in names(bus, packets)             # PINGs only
    assert set(names(bus, packets)) == {"PING"}
    assert sorted(m.id for m in bus.emulator.motors) == [1, 12]
    assert bus.emulator.motor(1).get_raw("id") == 1


def test_id_write_by_name_goes_through_the_same_checks() -> None:
    """``bus.write(1, "id", 12)`` is change_id: refused when used, followed when free."""
    bus = Bus.open("emu://xm430-w350:1,12", baudrate=57600)
    packets = sent(bus)
    with pytest.raises(ConfigError, match="ID 12 is taken"):
        bus.write(1, "id", 12)
    assert "WRITE" not in names(bus, packets)
    bus.write(1, "id", 5)
    assert sorted(bus.motors) == [5, 12] and bus.read(5, "id", raw=True) == 5


def test_id_change_of_a_motor_that_does_not_answer_writes_nothing() -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600, retries=0)
    bus.declare(7, "xm430-w350")
    packets = sent(bus)
    with pytest.raises(NoResponse):
        bus.change_id(7, 8)
    assert names(bus, packets) == ["PING"]


def test_id_change_of_a_level_1_motor_is_followed() -> None:
    """A motor at status return level 1 answers the WRITE of its ID with nothing: the PING
    at the new ID says it worked."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.emulator.motor(1).set_raw("status_return_level", 1)
    assert bus.change_id(1, 4).id == 4
    assert bus.emulator.motor(4).id == 4 and list(bus.motors) == [4]


def test_id_writes_in_groups_are_refused() -> None:
    bus = Bus.open("emu://xm430-w350:1-2", baudrate=57600)
    for do in (lambda: bus.sync_write("id", {1: 5, 2: 6}),
               lambda: bus.bulk_write({1: {"id": 5}}),
               lambda: bus.write(1, {"id": 5, "baud_rate": 3}),
               lambda: bus.write(1, "id", 5, registered=True)):
        with pytest.raises(ConfigError) as info:
            do()
        one_line(info.value, "id")
    assert [m.id for m in bus.emulator.motors] == [1, 2]


# -- baud rates -----------------------------------------------------------------------------------

def test_baud_change_is_followed() -> None:
    """The WRITE is answered at the old rate (the status comes back, no timeout), then the
    bus speaks the new rate: reads go on at 1 Mbps."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    found = bus.change_baud(1, 1_000_000)
    assert found.baudrate == 1_000_000 and bus.baudrate == 1_000_000
    assert bus.emulator.motor(1).baudrate == 1_000_000
    assert bus.emulator.motor(1).get_raw("baud_rate") == 3      # e-Manual: 3 = 1 Mbps
    assert bus.stats.timeouts == 0
    before = bus.port.clock.now()
    assert bus.read(1, "baud_rate", raw=True) == 3
    # a READ of 1 byte at 1 Mbps: 14 + 12 bytes of 10 bits, well under a millisecond
    assert bus.port.clock.now() - before < 0.001


def test_baud_change_of_a_protocol1_motor_by_raw_register_value() -> None:
    """RX-28: baud_rate 1 is 2 000 000 / (1 + 1) = 1 Mbps (e-Manual, Baud Rate); 34 is
    57142 bps, spoken to at 57600 (within UART tolerance)."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "baud_rate", 1, raw=True)
    assert bus.baudrate == 1_000_000 and bus.emulator.motor(1).baudrate == 1_000_000
    bus.write(1, "baud_rate", 57600)                      # SI: bps
    assert bus.emulator.motor(1).get_raw("baud_rate") == 34
    assert bus.baudrate == 57600 and bus.read(1, "id", raw=True) == 1


def test_baud_change_warns_of_motors_left_at_the_old_rate(
        caplog: pytest.LogCaptureFixture) -> None:
    bus = Bus.open("emu://xm430-w350:1-3", baudrate=57600)
    for i in (1, 2, 3):
        bus.ping(i)
    with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.bus"):
        bus.change_baud(2, 1_000_000)
    assert list(bus.motors) == [2]
    assert "1, 3 stay at 57600 bps" in caplog.text


def test_baud_change_without_following_leaves_the_bus_at_its_rate() -> None:
    bus = Bus.open("emu://xm430-w350:1-2", baudrate=57600)
    found = bus.change_baud(2, 115_200, follow=False)
    assert found.baudrate == 115_200 and bus.baudrate == 57600
    assert bus.read(1, "id", raw=True) == 1 and 2 not in bus.motors


def test_a_rate_the_model_cannot_use_is_refused_with_those_it_can() -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        bus.change_baud(1, 250_000)
    one_line(info.value, "250000 bps is not a baud rate it can use", "1000000", "4000000")
    assert "WRITE" not in names(bus, packets)
    assert 57600 in usable_rates(model("rx28")) and 2_000_000 in usable_rates(model("rx28"))
    assert line_rate(57142) == 57600 and line_rate(117647) == 115_200


# -- status return level and return delay ---------------------------------------------------------

@pytest.mark.parametrize(("url", "baud"), [("emu://xm430-w350:1", 57600),
                                           ("emu://rx28:1", 57142)])
@pytest.mark.parametrize("level", [1, 0])
def test_a_motor_at_level_1_or_0_is_written_without_errors(url: str, baud: int,
                                                           level: int) -> None:
    """The bus does not know the level (set by another program, kept in EEPROM): its first
    WRITE gets no status, so the bus reads the level (level 0: READ unanswered, PING
    answered) and from then on awaits no status to writes."""
    bus = Bus.open(url, baudrate=baud)
    bus.ping(1)            # (a 1.0 motor at level 0 answers no READ of its model number)
    bus.emulator.motor(1).set_raw("status_return_level", level)
    bus.write(1, "led", 1)
    assert bus.status_return_level == {1: level}
    assert bus.emulator.motor(1).get_raw("led") == 1
    timeouts = bus.stats.timeouts
    for value in (0, 1, 0):
        bus.write(1, "led", value)                         # no status awaited, none spent
    assert bus.stats.timeouts == timeouts
    assert bus.emulator.motor(1).get_raw("led") == 0
    if level == 1:
        assert bus.read(1, "led", raw=True) == 0           # READ is still answered
    else:
        with pytest.raises(ConfigError, match="status return level 0"):
            bus.read(1, "led")


def test_contact_learns_level_and_return_delay() -> None:
    """Return Delay Time is 2 us a unit (e-Manual): the factory 250 is 500 us."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    contact = bus.contact(1)
    assert (contact.status_return_level, contact.return_delay) == (2, pytest.approx(500e-6))
    assert bus.return_delay == {1: pytest.approx(500e-6)}
    bus.write(1, "status_return_level", 1)
    assert bus.contact(1).status_return_level == 1


def test_the_emulator_answers_by_the_e_manual_levels() -> None:
    """Status Return Level: 0 "PING Instruction only", 1 "PING and READ", 2 "all
    Instructions" (e-Manual, ROBOTIS-GIT/emanual _includes/en/dxl/control_table/
    status_return_level.md)."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600, retries=0)
    reg = bus.model_of(1).register("led")
    write = bus.proto.write(1, reg.address, b"\x01")
    for level, answered in ((0, {"PING"}), (1, {"PING", "READ"}),
                            (2, {"PING", "READ", "WRITE"})):
        bus.emulator.motor(1).set_raw("status_return_level", level)
        got = set()
        for name, inst, n in (("PING", bus.proto.ping(1), 3),
                              ("READ", bus.proto.read(1, reg.address, 1), 1),
                              ("WRITE", write, 0)):
            try:
                bus.transact(inst, {1: n}, check=False)
                got.add(name)
            except NoResponse:
                pass
        assert got == answered, level


# -- checks before the wire -----------------------------------------------------------------------

def test_eeprom_write_with_torque_on_is_refused_in_one_line() -> None:
    """DynamixelSDK issue #306: an X motor refuses EEPROM writes with torque on ("access");
    the bus reads torque_enable first and says what to do, having written nothing."""
    bus = Bus.open("emu://xm430-w350:1-2", baudrate=57600)
    bus.write(1, "torque_enable", 1)
    bus.write(2, "torque_enable", 1)
    packets = sent(bus)
    for do in (lambda: bus.write(1, "operating_mode", 4),
               lambda: bus.sync_write("operating_mode", {1: 4, 2: 4}),
               lambda: bus.bulk_write({1: {"return_delay_time": 0}}),
               lambda: bus.change_id(1, 9)):
        with pytest.raises(ConfigError) as info:
            do()
        one_line(info.value, "switch torque off first (torque_enable 0)")
    assert "WRITE" not in names(bus, packets) and "SYNC_WRITE" not in names(bus, packets)
    bus.write(1, "torque_enable", 0)
    bus.write(1, "operating_mode", 4)
    assert bus.emulator.motor(1).get_raw("operating_mode") == 4


def test_a_locked_protocol1_eeprom_is_named_when_the_motor_refuses() -> None:
    """1.0 motors lock their EEPROM by the Lock register, until powered off and on (e-Manual,
    Lock): the motor's range error says so."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, "lock", 1)
    with pytest.raises(MotorError) as info:
        bus.write(1, "return_delay_time", 0, raw=True)
    one_line(info.value, "range", "lock is 1")


def test_goal_beyond_the_position_limits_is_refused_before_the_wire() -> None:
    """XM430 in position mode: 99 rad is within goal_position's register range (+-1 048 575
    ticks) but beyond the position limits (0..4095): the bus reads mode and limits once and
    refuses; in extended position mode the same goal is taken."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    bus.ping(1)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, "goal_position", 99.0)
    one_line(info.value, "goal_position: 99 rad", "position limits", "operating_mode 3")
    assert names(bus, packets) == ["READ"]                 # mode and limits, once
    with pytest.raises(ConfigError, match="position limits"):
        bus.sync_write("goal_position", {1: 99.0})
    assert names(bus, packets) == ["READ"]
    bus.write(1, "goal_position", 1.0)                     # within: no READ
    assert names(bus, packets) == ["READ", "WRITE"]
    bus.write(1, "operating_mode", 4)
    bus.write(1, "goal_position", 99.0)
    assert bus.emulator.motor(1).get_raw("goal_position") == 2048 + round(99 / (2 * math.pi)
                                                                          * 4096)


def test_sync_write_fast_path_keeps_to_the_known_limits() -> None:
    """After a first SYNC_WRITE (which makes the plan), a goal beyond the limits the bus
    knows is refused all the same: the plan is bounded by them."""
    bus = Bus.open("emu://xm430-w350:1-2", baudrate=57600)
    bus.contact(1)                                         # mode and limits known
    bus.write(1, {"max_position_limit": 3000}, raw=True)   # and followed
    bus.sync_write("goal_position", {1: 0.1, 2: 0.1})
    packets = sent(bus)
    with pytest.raises(ConfigError, match="position limits"):
        bus.sync_write("goal_position", {1: 2.0, 2: 0.1})   # 3352 ticks > 3000
    assert packets == []


def test_moving_speed_minus_one_in_joint_mode_is_refused() -> None:
    """RX-28 in joint mode: moving_speed is 0..1023, no direction (e-Manual, Moving Speed);
    -1 rad/s would set bit 10 and come back as a range error."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.ping(1)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, "moving_speed", -1.0)
    one_line(info.value, "moving_speed", "joint mode", "wheel mode")
    assert packets == []
    bus.write(1, {"cw_angle_limit": 0, "ccw_angle_limit": 0}, raw=True)   # wheel mode
    bus.write(1, "moving_speed", -1.0)
    assert bus.emulator.motor(1).get_raw("moving_speed") & 0x400


def test_goal_outside_the_angle_limits_is_refused() -> None:
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.write(1, {"cw_angle_limit": 200, "ccw_angle_limit": 800}, raw=True)
    with pytest.raises(ConfigError) as info:
        bus.write(1, "goal_position", 900, raw=True)
    one_line(info.value, "angle limits", "raw 200..800")
    bus.write(1, "goal_position", 700, raw=True)


@pytest.mark.parametrize(("name", "value", "needle"), [
    ("goal_position", True, "truth value"),
    ("goal_position", "0.5", "is not a number"),
    ("goal_velocity", 999.0, "outside"),
    ("goal_velocity", 10.0, "velocity_limit"),
    ("operating_mode", 2, "not one of its modes"),
])
def test_types_and_ranges_are_checked_before_the_wire(name: str, value: object,
                                                      needle: str) -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    bus.ping(1)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        bus.write(1, name, value)  # type: ignore[arg-type]
    one_line(info.value, needle)
    assert "WRITE" not in names(bus, packets)


def test_a_switch_takes_true() -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    bus.write(1, "torque_enable", True)
    assert bus.read(1, "torque_enable", raw=True) == 1


def test_unknown_register_gets_did_you_mean_not_the_whole_table() -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    with pytest.raises(ConfigError) as info:
        bus.read(1, "goal_positoin")
    one_line(info.value, "did you mean goal_position")
    assert len(str(info.value)) < 160
    with pytest.raises(ConfigError, match="did you mean"):
        bus.write(1, "presnt_position", 1)
    with pytest.raises(ConfigError, match="did you mean"):
        register_of(bus.motors[1], "torque")
    assert did_you_mean("zzz", ["a", "b"]) == ("no register name is close to it (it has 2; "
                                               "see its e-Manual page)")


# -- raw access ------------------------------------------------------------------------------------

def test_raw_read_and_write_by_address() -> None:
    """Raw bytes, little-endian: goal_position (116, 4 bytes) of an XM430."""
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    assert bus.read_address(1, 132, 4) == (2048).to_bytes(4, "little")
    bus.write_address(1, 116, (3000).to_bytes(4, "little"))
    assert bus.read(1, "goal_position", raw=True) == 3000
    bus.write_address(1, 65, b"\x01")                       # led
    assert bus.read_address(1, 64, 2) == b"\x00\x01"


@pytest.mark.parametrize(("do", "needle"), [
    (lambda bus: bus.write_address(1, 116, b"\x00\x08"), "part of goal_position"),
    (lambda bus: bus.write_address(1, 132, b"\x00\x08\x00\x00"), "read-only"),
    (lambda bus: bus.write_address(1, 116, (99999).to_bytes(4, "little")), "position limits"),
    (lambda bus: bus.read_address(1, 65536, 1), "outside protocol 2.0's 0..65535"),
    (lambda bus: bus.read_address(1, 0, 1021), "1..1020 bytes"),
    (lambda bus: bus.write_address(1, 0, bytes(1020)), "1..1019 bytes"),
    (lambda bus: bus.read_address(1, 65530, 10), "run past 65535"),
    (lambda bus: bus.read_address(1, -1, 1), "outside"),
], ids=["partial", "read-only", "limits", "address", "read-size", "write-size", "past-end",
        "negative"])
def test_raw_access_is_checked_before_the_wire(do: Callable[[Bus], object],
                                               needle: str) -> None:
    bus = Bus.open("emu://xm430-w350:1", baudrate=57600)
    bus.contact(1)
    packets = sent(bus)
    with pytest.raises(ConfigError) as info:
        do(bus)
    one_line(info.value, needle)
    assert packets == []


def test_raw_access_limits_of_protocol_1() -> None:
    """1.0: one-byte addresses and lengths, 253 parameters a packet."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    assert raw_access_limits(bus.proto) == (256, 253, 252)
    with pytest.raises(ConfigError, match=r"1\.\.253 bytes"):
        bus.read_address(1, 0, 254)
    with pytest.raises(ConfigError, match="run past 255"):
        bus.read_address(1, 250, 10)
    assert bus.read_address(1, 0, 3) == bytes((28, 0, 30))  # model 28, firmware 30


def test_raw_write_of_the_id_is_an_id_change() -> None:
    bus = Bus.open("emu://xm430-w350:1,2", baudrate=57600)
    with pytest.raises(ConfigError, match="ID 2 is taken"):
        bus.write_address(1, 7, b"\x02")
    bus.write_address(1, 7, b"\x09")
    assert sorted(bus.motors) == [2, 9]


# -- the port --------------------------------------------------------------------------------------

@pytest.mark.parametrize("error", [
    serial.SerialException(errno.EACCES, "could not open port /dev/ttyUSB0: [Errno 13] "
                           "Permission denied: '/dev/ttyUSB0'"),
    PermissionError(errno.EACCES, "Permission denied"),
], ids=["pyserial", "os"])
def test_permission_denied_says_how_to_join_dialout(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: Path,
                                                   error: Exception) -> None:
    device = tmp_path / "ttyUSB0"
    device.touch()

    def refuse(*args: object, **kwargs: object) -> None:
        raise error

    monkeypatch.setattr(serial, "Serial", refuse)
    with pytest.raises(ConfigError) as info:
        Bus.open(str(device))
    one_line(info.value, str(device), "sudo usermod -aG dialout $USER", "log out and in")


def test_other_open_errors_get_no_dialout_hint(monkeypatch: pytest.MonkeyPatch,
                                               tmp_path: Path) -> None:
    device = tmp_path / "ttyUSB0"
    device.touch()

    def refuse(*args: object, **kwargs: object) -> None:
        raise serial.SerialException(errno.EIO, "could not open port: Input/output error")

    monkeypatch.setattr(serial, "Serial", refuse)
    with pytest.raises(DynamixelError) as info:
        Bus.open(str(device))
    assert "dialout" not in str(info.value)


def test_a_protocol1_motor_at_level_0_is_told_to_be_declared() -> None:
    """A 1.0 PING carries no model number: a motor that answers PING but not READ (level 0)
    cannot be told apart, and the one line says what to do."""
    bus = Bus.open("emu://rx28:1", baudrate=57142)
    bus.emulator.motor(1).set_raw("status_return_level", 0)
    with pytest.raises(ConfigError) as info:
        bus.write(1, "led", 1)
    one_line(info.value, "status return level 0", "declare")
    bus.declare(1, "rx28")
    bus.write(1, "led", 1)
    assert bus.emulator.motor(1).get_raw("led") == 1


@pytest.mark.parametrize(("url", "address"), [("emu://xm430-w350:1-2", 7),
                                              ("emu://xm430-w350:1-2", 8),
                                              ("emu://rx28:1-2", 3), ("emu://rx28:1-2", 4)])
def test_a_raw_broadcast_of_an_id_or_a_rate_is_refused(url: str, address: int) -> None:
    """write_address(254, ...) over the ID (X: 7, 1.0: 3) or the baud rate (X: 8, 1.0: 4)
    would give every motor one ID or one rate: refused, nothing sent."""
    bus = Bus.open(url, baudrate=57600 if "xm" in url else 57142)
    packets = sent(bus)
    with pytest.raises(ConfigError, match="every motor would take it"):
        bus.write_address(254, address, b"\x05")
    assert packets == []
    assert sorted(m.id for m in bus.emulator.motors) == [1, 2]
