"""The driver's fast path gives exactly what the slow one gave.

What a repeated read or write works out once (a plan: the packet, the reply layout, one struct
decoding every field, the SI scale) must give the values the control table holds, for every
register of every model, signed ones included; a SYNC_WRITE packet built from its template
must be byte for byte the one the general encoder builds; a reply that is not exactly as
expected (noise, byte stuffing) must still be read, by the stream parser; a plan must not
outlive the model or protocol it was made for. And the serial port must not reconfigure the
line on every read nor drain it on every write.
"""

from __future__ import annotations

import math
import os
import pty
import random
import time

import pytest
import serial

from servolab.dynamixel import MODELS, Bus, ConfigError, ports
from servolab.dynamixel.bus import plans
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from servolab.dynamixel.units import from_si, to_si
from tests.waiting import wait_for

SENSORS = ("present_", "velocity_trajectory", "position_trajectory", "realtime_tick",
           "moving", "registered")


def model_bus(name: str, ids: str = "1") -> Bus:
    m = MODELS[name]
    bus = Bus.open(f"emu://{name}:{ids}", baudrate=1_000_000)
    for motor in bus.emulator.motors:
        bus.declare(motor.id, m)
    return bus


@pytest.mark.parametrize("name", sorted(MODELS))
def test_every_register_reads_back_as_the_table_holds_it(name: str) -> None:
    """Each register alone, and all of them in one READ, raw: the values in the emulated
    control table (signed registers set negative where they can be); the same twice, so that
    the second read goes through the plan the first one made."""
    bus = model_bus(name)
    m, motor = MODELS[name], bus.emulator.motor(1)
    for reg in m.registers:
        if reg.signed and reg.raw_min < 0 and not reg.name.startswith(SENSORS):
            motor.set_raw(reg.name, max(reg.raw_min, -1000))
    names = [r.name for r in m.registers]
    for _ in range(2):
        for reg in m.registers:
            got = bus.read(1, reg.name, raw=True)
            assert got == motor.get_raw(reg.name), reg.name
        together = bus.read(1, names, raw=True)
        assert together == {n: motor.get_raw(n) for n in names}
        assert list(together) == names
    reversed_names = names[::-1][:5]
    assert list(bus.read(1, reversed_names, raw=True)) == reversed_names


@pytest.mark.parametrize("name", sorted(MODELS))
def test_si_conversions_are_those_of_units(name: str) -> None:
    """The plan's converters compute what units.to_si / from_si compute, to the last bit."""
    m = MODELS[name]
    for reg in m.registers:
        decode = plans.si_decoder(m, reg)
        rng = random.Random(reg.address)
        samples = {reg.raw_min, reg.raw_max, (reg.raw_min + reg.raw_max) // 2, 0, 1,
                   *(rng.randint(reg.raw_min, reg.raw_max) for _ in range(50))}
        for raw in samples:
            want = to_si(m, reg, raw)
            assert (raw if decode is None else decode(raw)) == want, (reg.name, raw)
        encode = plans.si_encoder(m, reg)
        if encode is None:
            continue
        lo, hi = sorted((to_si(m, reg, reg.raw_min), to_si(m, reg, reg.raw_max)))
        for value in [lo, hi, 0.0, 0, 1, *(rng.uniform(lo, hi) for _ in range(200))]:
            assert encode(value) == from_si(m, reg, value), (reg.name, value)


@pytest.mark.parametrize("name", ["RX-28", "XM430-W210"])
def test_sync_write_packet_is_the_general_encoders(name: str) -> None:
    """The template-built SYNC_WRITE equals what Protocol.sync_write + encode_instruction
    build, raw and SI, for random goals; values it cannot take go the checked way."""
    m = MODELS[name]
    proto = PROTOCOL1 if m.protocol == 1 else PROTOCOL2
    reg = m.register("goal_position")
    ids = (3, 1, 7, 20)
    plan = plans.SyncWrite(proto, ids, [m] * len(ids), reg, False)
    rng = random.Random(1)
    for _ in range(200):
        values = [rng.randint(reg.raw_min, reg.raw_max) for _ in ids]
        want = proto.encode_instruction(proto.sync_write(
            reg.address, reg.size, [(i, reg.encode(v)) for i, v in zip(ids, values, strict=True)]))
        assert plan.encode(values, True) == want
        radians = [to_si(m, reg, v) for v in values]
        assert plan.encode(radians, False) == want
    assert plan.encode([reg.raw_max + 1, 0, 0, 0], True) is None
    assert plan.encode([1.0, 0, 0, 0], True) is None            # raw takes ints only
    assert plan.encode([math.nan, 0.0, 0.0, 0.0], False) is None
    assert plan.encode(["0.1", 0.0, 0.0, 0.0], False) is None


def test_sync_write_that_needs_byte_stuffing_goes_the_general_way() -> None:
    """2.0: a value whose bytes hold FF FF FD must be stuffed: the template path steps
    aside, and the motor gets the value."""
    bus = model_bus("XM430-W210", "1-2")
    value = -131073  # little-endian FF FF FD FF
    assert value.to_bytes(4, "little", signed=True) == b"\xff\xff\xfd\xff"
    for _ in range(2):
        bus.sync_write("homing_offset", {1: value, 2: 5}, raw=True)
        assert bus.emulator.motor(1).get_raw("homing_offset") == value
        assert bus.emulator.motor(2).get_raw("homing_offset") == 5


def test_reply_with_byte_stuffing_is_read_by_the_parser() -> None:
    """2.0: a status whose data holds FF FF FD is stuffed and longer than expected: the
    parser reads it, for READ and SYNC_READ."""
    bus = model_bus("XM430-W210", "1-2")
    bus.emulator.motor(1).set_raw("homing_offset", -131073)
    for _ in range(2):
        assert bus.read(1, "homing_offset", raw=True) == -131073
        assert bus.sync_read("homing_offset", [1, 2], raw=True) == {1: -131073, 2: 0}
    assert bus.stats.stale == bus.stats.corrupt == bus.stats.timeouts == 0


def test_noise_before_the_reply_is_skipped() -> None:
    """A byte of noise before the status: the fast path's layout does not fit, the parser
    finds the packet after it."""
    bus = model_bus("RX-28")
    port = bus.port
    real = port.device.receive

    def noisy(data: bytes, t: float, baud: float) -> list:
        replies = real(data, t, baud)
        return [type(r)(r.start, b"\x00" + r.data) for r in replies]

    port.device.receive = noisy
    assert bus.read(1, "present_position", raw=True) == 512
    assert bus.read(1, ["present_position", "goal_position"], raw=True) == {
        "present_position": 512, "goal_position": 512}


def test_plan_follows_the_model_and_protocol() -> None:
    """Declaring another model makes the next read use its table and units; a bool is not a
    motor ID even where motor 1 has a plan."""
    bus = model_bus("RX-28")
    assert bus.read(1, "present_position") == 0.0          # RX-28: tick 512 is 0 rad
    bus.declare(1, "mx28")                                  # MX-28: tick 2048 is 0 rad
    assert bus.read(1, "present_position") == pytest.approx((512 - 2048) * 2 * math.pi / 4096)
    bus.declare(1, "rx28")
    assert bus.read(1, "present_position") == 0.0
    with pytest.raises(ConfigError, match="True"):
        bus.read(True, "present_position")  # type: ignore[arg-type]
    bus.sync_read("present_position", [1])
    with pytest.raises(ConfigError, match="True"):
        bus.sync_read("present_position", [True])  # type: ignore[list-item]
    bus.sync_write("goal_position", {1: 600}, raw=True)
    with pytest.raises(ConfigError, match="True"):
        bus.sync_write("goal_position", {True: 600}, raw=True)  # type: ignore[dict-item]
    assert bus.emulator.motor(1).get_raw("goal_position") == 600


def test_unknown_name_in_a_list_is_refused_every_time() -> None:
    bus = model_bus("RX-28", "1-2")
    for _ in range(2):
        with pytest.raises(ConfigError, match="goal_postion"):
            bus.read(1, ["present_position", "goal_postion"])
        with pytest.raises(ConfigError, match="goal_postion"):
            bus.sync_read(["goal_postion"], [1, 2])


def test_sync_write_si_and_raw_share_one_plan_and_check_every_value() -> None:
    """The plan takes ints (raw) and floats (SI); a bad value still goes the checked way
    and writes nothing."""
    bus = model_bus("XM430-W210", "1-3")
    seen = bus.emulator.instructions_seen
    bus.sync_write("goal_position", {1: 0.5, 2: -0.5, 3: 0})
    bus.sync_write("goal_position", {1: 0.25, 2: -0.25, 3: 1})
    assert [bus.emulator.motor(i).get_raw("goal_position") for i in (1, 2, 3)] == [
        2048 + round(0.25 / (2 * math.pi / 4096)), 2048 - round(0.25 / (2 * math.pi / 4096)),
        2048 + round(1 / (2 * math.pi / 4096))]
    with pytest.raises(ConfigError, match="goal_position"):
        bus.sync_write("goal_position", {1: 0.1, 2: 9999.0, 3: 0.0})
    with pytest.raises(ConfigError, match="goal_position"):
        bus.sync_write("goal_position", {1: 1, 2: 2_000_000, 3: 0}, raw=True)
    assert bus.emulator.instructions_seen - seen == 2


def test_sync_write_of_status_return_level_is_remembered_on_the_fast_path() -> None:
    bus = model_bus("XM430-W210", "1-2")
    bus.sync_write("status_return_level", {1: 2, 2: 2}, raw=True)
    bus.sync_write("status_return_level", {1: 1, 2: 0}, raw=True)   # through the plan
    assert bus.status_return_level == {1: 1, 2: 0}
    with pytest.raises(ConfigError, match="status return level 0"):
        bus.read(2, "present_position")


def test_memory_port_counts_what_is_complete() -> None:
    """MemoryPort: bytes of an answer become available one byte time after another."""
    bus = model_bus("RX-28")
    port = bus.port
    port.write(PROTOCOL1.encode_instruction(PROTOCOL1.ping(1)))
    assert port.available() == 0                       # the return delay has not passed
    port.clock.advance(0.0005 + 3 * 10e-6 + 1e-9)
    assert port.available() == 3
    assert port.read(2, 0.0) == b"\xff\xff"
    assert port.available() == 1
    assert port.read(10, 1.0) == bytes((1, 2, 0, 0xFC))
    assert port.available() == 0


# -- the serial port --------------------------------------------------------------------------

@pytest.fixture
def serial_pair(monkeypatch: pytest.MonkeyPatch):
    """A SerialPort on a pty, and the pty's other end; counts how often pyserial reconfigures
    the line, and fails on a drain (flush)."""
    calls = {"reconfigure": 0}
    original = serial.Serial._reconfigure_port

    def counting(self, *args, **kwargs):  # type: ignore[no-untyped-def]
        calls["reconfigure"] += 1
        return original(self, *args, **kwargs)

    def no_drain(self):  # type: ignore[no-untyped-def]
        raise AssertionError("the port drained its output")

    monkeypatch.setattr(serial.Serial, "_reconfigure_port", counting)
    monkeypatch.setattr(serial.Serial, "flush", no_drain)
    master, slave = pty.openpty()
    port = ports.SerialPort(os.ttyname(slave), 57600, latency=0.001)
    try:
        yield port, master, calls
    finally:
        port.close()
        os.close(master)
        os.close(slave)


def test_serial_port_reads_without_reconfiguring_and_writes_without_draining(
        serial_pair) -> None:
    port, master, calls = serial_pair
    after_open = calls["reconfigure"]
    port.write(b"\xff\xff\x01\x02\x01\xfb")
    assert os.read(master, 16) == b"\xff\xff\x01\x02\x01\xfb"
    os.write(master, b"abc")
    assert port.read(3, 0.5) == b"abc"
    t0 = time.monotonic()
    assert port.read(3, 0.05) == b""                  # nothing comes: waits out the timeout
    assert time.monotonic() - t0 >= 0.04
    os.write(master, b"xy")
    assert port.read(5, 0.05) == b"xy"               # part of what was asked, then timeout
    os.write(master, b"123456")
    wait_for(lambda: port._serial.in_waiting == 6, "the 6 bytes to reach the port")
    port.reset_input()
    assert port.read(6, 0.01) == b""
    for timeout in (0.001, 0.002, 0.003):
        port.read(1, timeout)
    assert calls["reconfigure"] == after_open


def test_serial_port_without_descriptor_sets_the_timeout_only_when_it_changes(
        serial_pair) -> None:
    """Where pyserial has no file descriptor (Windows), the timeout goes to pyserial, which
    reconfigures the port when it is set: only when it changes."""
    port, master, calls = serial_pair
    port._fd = None
    after_open = calls["reconfigure"]
    for _ in range(5):
        port.read(1, 0.002)
    assert calls["reconfigure"] == after_open + 1
    os.write(master, b"z")
    assert port.read(1, 0.5) == b"z"
    assert calls["reconfigure"] == after_open + 2
