"""The driver under a misbehaving bus: late answers, stray statuses, hardware errors.

A status that comes after its transaction gave up must never be taken for the answer to the
next request: the next request would return another register's value, or another motor's,
with nothing to show it. The bus therefore takes a status only from a motor it asked, with the
length it asked for, and after a transaction that got no valid answer it lets the time pass in
which that answer could still come before it sends anything else.

A hardware error (overload, overheating, ...) is the motor's state, not a failed instruction:
the e-Manual's Protocol 1.0 error byte mixes both kinds of bits, and Protocol 2.0 keeps the
hardware error to a single Alert bit beside the instruction's error number. The driver returns
the data and names the motor in ``bus.alerts``; only the instruction's own errors raise.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import pytest

from servolab.clock import VirtualClock
from servolab.dynamixel import (
    Bus,
    CorruptResponse,
    Emulator,
    Faults,
    MemoryPort,
    MotorError,
    NoResponse,
)
from servolab.dynamixel.models import model
from servolab.dynamixel.packets import Protocol, Status
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from servolab.dynamixel.wire import byte_time

RX28 = model("RX-28")
GOAL, PRESENT = RX28.register("goal_position"), RX28.register("present_position")


@dataclass(frozen=True)
class Reply:
    start: float
    data: bytes


class ScriptedMotor:
    """A Protocol 1.0 motor, ID 1, that answers READ and WRITE from its own table, each
    answer after the delay its script gives (0 once the script is used up); ``extra`` bytes
    go out before an answer when scripted. Records when each instruction arrived."""

    def __init__(self, proto: Protocol = PROTOCOL1, *, delays: tuple[float, ...] = (),
                 answer_writes: bool = True) -> None:
        self.proto = proto
        self.table = bytearray(64)
        self.delays = list(delays)
        self.answer_writes = answer_writes
        self.heard: list[tuple[float, str]] = []

    def set(self, address: int, value: int, size: int = 2) -> None:
        self.table[address:address + size] = value.to_bytes(size, "little")

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Reply]:
        inst = self.proto.decode_instruction(data)
        name = self.proto.instruction_name(inst.instruction)
        self.heard.append((t, name))
        if name == "READ":
            address, length = inst.params
            status = Status(inst.id, 0, bytes(self.table[address:address + length]))
        elif name == "WRITE":
            address = inst.params[0]
            self.table[address:address + len(inst.params) - 1] = inst.params[1:]
            if not self.answer_writes:
                return []
            status = Status(inst.id, 0)
        else:
            return []
        delay = self.delays.pop(0) if self.delays else 0.0
        return [Reply(t + delay, self.proto.encode_status(status))]


def scripted_bus(motor: ScriptedMotor, **options: object) -> Bus:
    port = MemoryPort(motor, 1_000_000, clock=VirtualClock(), protocol=1)
    bus = Bus(port, **options)  # type: ignore[arg-type]
    bus.declare(1, RX28)
    return bus


# -- late answers --------------------------------------------------------------------------------

def test_late_answer_to_a_read_is_not_the_answer_to_the_next() -> None:
    """READ goal_position (700) times out, its answer comes 1.5 ms late; the READ of
    present_position (300) that follows must return 300, not the late 700. The bus sends the
    second READ only once the first one's answer can no longer come (its wire time, the
    longest return delay and 2 ms after it was sent), and throws away what came meanwhile."""
    motor = ScriptedMotor(delays=(0.0015,))
    motor.set(GOAL.address, 700)
    motor.set(PRESENT.address, 300)
    bus = scripted_bus(motor, retries=0, timeout=0.001)
    with pytest.raises(NoResponse):
        bus.read(1, "goal_position", raw=True)
    assert bus.read(1, "present_position", raw=True) == 300
    (t_a, _), (t_b, _) = motor.heard
    tick = byte_time(1_000_000)
    assert t_b - t_a >= (8 + 8) * tick + 254 * 2e-6 + 0.002 - 1e-9
    # the next transaction, after one that went well, goes out at once
    assert bus.read(1, "goal_position", raw=True) == 700
    assert motor.heard[2][0] - t_b < 0.0002


def test_late_answer_on_an_emulated_bus_with_injected_delay() -> None:
    """The same with the emulator: a 1.5 ms injected delay against a 1 ms timeout; once the
    delay is gone, the next READ returns its own register."""
    bus = Bus.open("emu://rx28:1", baudrate=1_000_000, retries=0, timeout=0.001)
    bus.declare(1, "rx28")
    motor = bus.emulator.motor(1)
    motor.set_raw("goal_position", 700)
    assert motor.get_raw("present_position") == 512
    bus.emulator.faults = Faults(delay=0.0015)
    with pytest.raises(NoResponse):
        bus.read(1, "goal_position", raw=True)
    bus.emulator.faults = Faults()
    assert bus.read(1, "present_position", raw=True) == 512
    assert bus.read(1, "goal_position", raw=True) == 700


def test_late_answer_to_a_retried_read_is_not_taken_for_the_retry() -> None:
    """Retries obey the same rule: the retry of a timed-out READ goes out once the first
    attempt's answer can no longer come, and takes its own."""
    motor = ScriptedMotor(delays=(0.0015,))
    motor.set(GOAL.address, 700)
    bus = scripted_bus(motor, retries=1, timeout=0.001)
    assert bus.read(1, "goal_position", raw=True) == 700
    assert (bus.stats.retries, bus.stats.timeouts) == (1, 1)
    (t_first, _), (t_retry, _) = motor.heard
    assert t_retry - t_first >= 16 * byte_time(1_000_000) + 254 * 2e-6 + 0.002 - 1e-9


def test_status_of_another_length_is_a_stale_answer_and_ignored() -> None:
    """A motor the bus believes silent to WRITE (status return level 1) does answer it, and
    that 0-byte status arrives while the next READ waits. The READ takes its own 2-byte answer
    and counts the other as stale (the e-Manual's status packet carries exactly the data
    asked for: a READ of N bytes is answered with N parameters)."""
    motor = ScriptedMotor(delays=(0.0003, 0.0))
    motor.set(PRESENT.address, 345)
    bus = scripted_bus(motor, retries=0)
    bus.status_return_level[1] = 1
    bus.write(1, "led", 1)
    assert bus.read(1, "present_position", raw=True) == 345
    assert bus.stats.stale == 1
    assert (bus.stats.timeouts, bus.stats.corrupt) == (0, 0)


def test_a_status_of_the_wrong_length_and_nothing_else_is_corrupt() -> None:
    """If the only status that comes has the wrong length, the transaction fails as a corrupt
    answer, saying so (and is not returned as data)."""
    motor = ScriptedMotor(delays=(0.0003,))
    bus = scripted_bus(motor, retries=0)
    bus.status_return_level[1] = 1
    bus.write(1, "led", 1)
    motor.receive = lambda data, t, baud: []  # type: ignore[method-assign]
    with pytest.raises(CorruptResponse, match="0 data bytes from motor 1, expected 2"):
        bus.read(1, "present_position", raw=True)


def test_status_from_a_motor_not_asked_is_ignored() -> None:
    """A status from ID 2 in the middle of motor 1's answer is dropped; motor 1's is read."""
    motor = ScriptedMotor()
    motor.set(PRESENT.address, 222)
    stray = PROTOCOL1.encode_status(Status(2, 0, b"\x11\x11"))
    real = motor.receive

    def with_stray(data: bytes, t: float, baud: float) -> list[Reply]:
        return [Reply(t, stray), *real(data, t, baud)]

    motor.receive = with_stray  # type: ignore[method-assign]
    bus = scripted_bus(motor, retries=0)
    assert bus.read(1, "present_position", raw=True) == 222
    assert bus.stats.stale == 1


# -- hardware errors: data with the alert ---------------------------------------------------
# e-Manual, Protocol 1.0, "Status Packet", Error (ROBOTIS-GIT/emanual docs/en/dxl/protocol1.md):
# bit 6 Instruction, bit 4 Checksum, bit 3 Range, bit 1 Angle Limit ("When Goal Position is
# written out of the range") concern the instruction; bit 5 Overload, bit 2 Overheating, bit 0
# Input Voltage the motor's state.
# e-Manual, Protocol 2.0, "Status Packet", Error (docs/en/dxl/protocol2.md): "Bit 7 Alert,
# Bit 6 ~ Bit 0 Error Number"; "Alert: When there has been a problem in the Device ...
# Checking the Hardware error status value of the Control Table can indicate the cause";
# "Error Number: When there has been an Error in the processing of the Instruction Packet."

def test_protocol1_error_bits_split_into_instruction_and_hardware() -> None:
    assert PROTOCOL1.failed(0x40) and PROTOCOL1.failed(0x10) and PROTOCOL1.failed(0x08)
    assert PROTOCOL1.failed(0x02)
    for bit in (0x20, 0x04, 0x01):
        assert not PROTOCOL1.failed(bit) and PROTOCOL1.alert(bit) == bit
    assert PROTOCOL1.alert(0x24 | 0x08) == 0x24  # the manual's example: overload+overheating


def test_protocol2_alert_bit_is_not_an_instruction_error() -> None:
    assert not PROTOCOL2.failed(0x80) and PROTOCOL2.alert(0x80) == 0x80
    for number in range(1, 8):
        assert PROTOCOL2.failed(0x80 | number) == number and not PROTOCOL2.alert(number)


def test_protocol1_hardware_error_comes_with_the_data(caplog: pytest.LogCaptureFixture) -> None:
    """An overloaded RX-28 (e-Manual bit 5) still answers READ and WRITE: the data comes
    back, the motor is in bus.alerts, and a warning is logged once, not per transaction."""
    bus = Bus.open("emu://rx28:1-2", baudrate=57142)
    bus.write(2, "torque_enable", 1)
    bus.emulator.motor(2).inject_hardware_error("overload")
    with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.bus"):
        got = bus.sync_read(["present_position", "torque_limit"], [1, 2], raw=True)
        assert got == {1: {"present_position": 512, "torque_limit": 1023},
                       2: {"present_position": 512, "torque_limit": 0}}  # shut down
        bus.write(2, "led", 1)                      # carried out, no error raised
        assert bus.read(2, "led", raw=True) == 1
    assert bus.alerts == {2: 0x20}
    warnings = [r.message for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1 and "motor 2" in warnings[0] and "overload" in warnings[0]
    assert bus.hardware_errors(2) == ("overload",)
    assert bus.hardware_errors(1) == ()
    # an instruction error still fails, naming every bit of the error byte
    with pytest.raises(MotorError) as info:
        bus.transact(PROTOCOL1.write(2, 36, b"\x00\x00"), {2: 0})  # present_position: range
    assert info.value.errors == ("range", "overload")
    bus.emulator.motor(2).clear_hardware_error()
    bus.read(2, "led")
    assert bus.alerts == {}


def test_protocol2_hardware_error_status_can_be_read() -> None:
    """An X-series motor in overload sets the alert bit in every status; the driver returns
    the data, so hardware_error_status (address 70) tells the cause (bit 5, overload); a
    SYNC_READ returns every motor's data and names the alerting one; REBOOT clears it."""
    bus = Bus.open("emu://xm430-w210:1-3", baudrate=1_000_000)
    bus.write(2, "torque_enable", 1)
    bus.emulator.motor(2).inject_hardware_error("overload")
    assert bus.read(2, "hardware_error_status", raw=True) == 0x20
    assert bus.alerts == {2: 0x80}
    got = bus.sync_read(["present_position", "torque_enable"], [1, 2, 3], raw=True)
    assert got == {i: {"present_position": 2048, "torque_enable": 0} for i in (1, 2, 3)}
    assert bus.alerts == {2: 0x80}
    assert bus.hardware_errors(2) == ("overload",)
    assert bus.hardware_errors(3) == ()
    bus.reboot(2)
    assert bus.alerts == {}
    assert bus.read(2, "hardware_error_status", raw=True) == 0
    assert bus.hardware_errors(2) == ()


def test_instruction_error_with_alert_still_raises() -> None:
    """Alert and an error number together: the instruction failed (access error: writing a
    read-only address), and the error names both."""
    bus = Bus.open("emu://xm430-w210:1", baudrate=1_000_000)
    bus.emulator.motor(1).inject_hardware_error("overheating")
    with pytest.raises(MotorError) as info:
        bus.transact(PROTOCOL2.write(1, 132, bytes(4)), {1: 0})
    assert info.value.errors == ("access", "hardware error alert")
    # check=False returns the status as it came
    status = bus.transact(PROTOCOL2.write(1, 132, bytes(4)), {1: 0}, check=False)[1]
    assert status.error == 0x87


# -- broadcast ping ----------------------------------------------------------------------------

@pytest.mark.parametrize("baud", [57600, 1_000_000])
@pytest.mark.parametrize("timeout", [None, 0.01])
def test_broadcast_ping_finds_id_252(baud: int, timeout: float | None) -> None:
    """"When the Packet ID field is 0xFE (Broadcast ID): All devices send their Status Packet
    according to their arranged order" (e-Manual, Protocol 2.0, Ping): ID 252 answers last,
    after the turn of every ID before it, and must be found; a short per-transaction timeout
    set on the bus (10 ms) does not cut the broadcast ping short."""
    bus = Bus.open("emu://xm430-w210:0,1,252", baudrate=baud, timeout=timeout)
    found = bus.broadcast_ping()
    assert [(r.id, r.model_name) for r in found] == [(0, "XM430-W210"), (1, "XM430-W210"),
                                                    (252, "XM430-W210")]
    # The motors wait Emulator.ping_slot (3 ms, ROBOTIS's device code) for each absent ID,
    # and an answer's time for a present one: the bus listens for the longer of the two for
    # each of the IDs 0..251, and then ID 252's answer.
    tick = byte_time(baud)
    answer = 14 * tick + 254 * 2e-6
    assert Emulator.ping_slot == 0.003
    assert bus.broadcast_ping_wait() >= 252 * max(Emulator.ping_slot, answer) + answer
    assert bus.broadcast_ping_wait() < 252 * max(Emulator.ping_slot, answer) + answer + 0.01
