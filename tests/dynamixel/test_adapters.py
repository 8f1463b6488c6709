"""Adapters as they really behave: a port another program holds, an adapter that echoes what
it sends, the low-latency mode, and an adapter unplugged and plugged in again.

Facts used, and where they come from:

- pyserial 3.5, ``serial.Serial(..., exclusive=True)``: on POSIX the port is locked with
  ``fcntl.flock(fd, LOCK_EX | LOCK_NB)``, and a second such open fails with EWOULDBLOCK
  ("Could not exclusively lock port", serial/serialposix.py ``open``).
- pyserial 3.5, ``Serial.set_low_latency_mode(True)`` (Linux): sets ASYNC_LOW_LATENCY with
  TIOCGSERIAL/TIOCSSERIAL and raises ValueError where the driver has no such setting (a pty);
  elsewhere NotImplementedError.
- ROBOTIS e-Manual, Protocol 1.0: the instruction and the status packet have the same layout
  (FF FF ID LENGTH INSTRUCTION/ERROR PARAMETERS CHECKSUM), so an echoed READ (instruction 2)
  reads as a status with error bit 1, "Angle Limit Error", and an echoed PING (instruction 1)
  as one with bit 0, "Input Voltage Error"; PING of ID 1 is ``FF FF 01 02 01 FB``. Protocol
  2.0: a status has instruction 0x55, which no instruction packet has.
"""

from __future__ import annotations

import errno
import logging
import os
import pty
import select
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial

from servolab.clock import WallClock
from servolab.dynamixel import Bus, model, motorspec, ports
from servolab.dynamixel.emulator import Emulator, VirtualMotor, build_emulator
from servolab.dynamixel.errors import MotorError, NoResponse, PortError
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.sim import Simulation

BAUD = 57600
PING_1 = bytes.fromhex("FF FF 01 02 01 FB")     # e-Manual, Protocol 1.0


@pytest.fixture
def slave_path() -> Iterator[str]:
    """A pty's slave device path (its master end held open, unread)."""
    master, slave = pty.openpty()
    try:
        yield os.ttyname(slave)
    finally:
        os.close(master)
        os.close(slave)


# -- exclusive open ------------------------------------------------------------------------------


def test_a_second_opener_is_refused_in_one_line(slave_path: str) -> None:
    first = ports.SerialPort(slave_path, BAUD, latency=0.001, echo=False)
    try:
        for opener in (lambda: ports.SerialPort(slave_path, BAUD, latency=0.001),
                       lambda: Bus.open(slave_path, baudrate=BAUD)):
            with pytest.raises(PortError) as info:
                opener()
            assert str(info.value) == (f"{slave_path} is in use by another program "
                                       f"(close it: lsof {slave_path})")
    finally:
        first.close()
    ports.SerialPort(slave_path, BAUD, latency=0.001).close()   # free again once closed


# -- low latency --------------------------------------------------------------------------------


def test_low_latency_is_asked_for_and_then_no_warning(
        slave_path: str, monkeypatch: pytest.MonkeyPatch,
        caplog: pytest.LogCaptureFixture) -> None:
    """Where the driver takes it (an FTDI adapter then reports a 1 ms timer), no advice."""
    asked: list[bool] = []
    monkeypatch.setattr(serial.Serial, "set_low_latency_mode",
                        lambda self, on: asked.append(on), raising=False)
    monkeypatch.setattr(ports.sys, "platform", "linux")
    monkeypatch.setattr(ports, "usb_latency_timer", lambda device: 1)
    with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.ports"):
        port = ports.SerialPort(slave_path, BAUD)
    port.close()
    assert asked == [True] and port.low_latency
    assert port.latency == pytest.approx(0.001)
    assert not caplog.records


@pytest.mark.parametrize("refusal", [ValueError("Failed to update ASYNC_LOW_LATENCY flag"),
                                     NotImplementedError("Low latency not supported"),
                                     OSError(errno.ENOTTY, "Inappropriate ioctl")])
def test_a_refused_low_latency_is_tolerated_and_the_timer_advice_stays(
        slave_path: str, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture,
        refusal: Exception) -> None:
    def refuse(self: serial.Serial, on: bool) -> None:
        raise refusal

    monkeypatch.setattr(serial.Serial, "set_low_latency_mode", refuse, raising=False)
    monkeypatch.setattr(ports.sys, "platform", "linux")
    monkeypatch.setattr(ports, "usb_latency_timer", lambda device: 16)
    with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.ports"):
        port = ports.SerialPort(slave_path, BAUD)
    port.close()
    assert not port.low_latency
    assert [r.message for r in caplog.records if "latency timer is 16 ms" in r.message]


def test_a_pty_has_no_low_latency_mode_and_opens_all_the_same(slave_path: str) -> None:
    port = ports.SerialPort(slave_path, BAUD, latency=0.001)
    port.close()
    assert port.low_latency is False


# -- echo -----------------------------------------------------------------------------------------

#: (protocol, motors, a register to write and read back, a value)
BUSES = {1: ("rx28:1-3", "goal_position", 700), 2: ("xm430-w210:1-3", "goal_position", 2500)}


def echoing_bus(version: int, *, echo: bool | None = None) -> tuple[Bus, Emulator]:
    """A bus through an adapter that echoes, on a virtual wire (every byte 10 bits' time)."""
    spec = motorspec.load(BUSES[version][0], baudrate=BAUD)
    simulation = Simulation()
    emulator = simulation.add_emulator(build_emulator(spec))
    port = ports.MemoryPort(ports.EchoingDevice(emulator), BAUD, clock=simulation,
                            protocol=version, lock=simulation.lock, echo=echo)
    return Bus(port), emulator


@pytest.mark.parametrize("version", [1, 2])
@pytest.mark.parametrize("echo", [None, True])
def test_an_echoing_adapter_reads_and_writes_right(version: int, echo: bool | None) -> None:
    """Learnt from the first instruction (None) or given (True): the echo is dropped and
    every operation sees the motors' own answers."""
    bus, emulator = echoing_bus(version, echo=echo)
    _, name, value = BUSES[version]
    assert [found.id for found in bus.scan(range(5))] == [1, 2, 3]
    assert bus.port.echo is True
    bus.write(2, name, value, raw=True)
    assert bus.read(2, name, raw=True) == value
    assert emulator.motor(2).get_raw(name) == value
    bus.sync_write(name, {1: value - 10, 3: value + 10}, raw=True)
    assert bus.sync_read(name, [1, 2, 3], raw=True) == {1: value - 10, 2: value,
                                                        3: value + 10}
    assert bus.read(1, "model_number", raw=True) == model(
        "RX-28" if version == 1 else "XM430-W210").number
    # silence only where the scan found no motor (IDs 0 and 4), nothing corrupt or stale
    assert (bus.stats.timeouts, bus.stats.corrupt, bus.stats.stale) == (2, 0, 0)
    assert bus.port.echoes_missing == 0


def test_an_echo_not_dropped_is_the_false_angle_limit_error() -> None:
    """What the issue saw: on Protocol 1.0 the echo of a READ is a status with the angle
    limit bit, taken for the motor's answer."""
    bus, _ = echoing_bus(1, echo=False)
    bus.declare(1, "rx28")
    with pytest.raises(MotorError, match="angle limit"):
        bus.read(1, "present_position", raw=True)


def test_an_absent_motor_on_an_echoing_adapter_is_silent_not_an_error() -> None:
    """The echo of a 1.0 PING to an absent ID is the very bytes a present motor at input
    voltage error answers: told apart by bytes nothing answers, then dropped."""
    bus, emulator = echoing_bus(1)
    with pytest.raises(NoResponse):
        bus.ping(9, retries=0)
    assert bus.port.echo is True
    seen = emulator.instructions_seen
    assert bus.ping(1).model_name == "RX-28"
    assert emulator.instructions_seen == seen + 2    # PING, then the READ of its model


def test_a_status_that_looks_like_its_instruction_is_not_an_echo() -> None:
    """Without an echo, a 1.0 motor at input voltage error answers a PING with the PING's own
    bytes: the port learns there is no echo and the bus takes the status (and the alert)."""
    simulation = Simulation()
    emulator = simulation.add_emulator(Emulator(1, [VirtualMotor(model("rx28"), 1,
                                                                 baudrate=BAUD)]))
    emulator.motor(1).supply_voltage = 30.0           # above Max Voltage Limit (16 V)
    port = ports.MemoryPort(emulator, BAUD, clock=simulation, protocol=1,
                            lock=simulation.lock, echo=None)
    bus = Bus(port)
    assert bus.ping(1).model_name == "RX-28"
    assert port.echo is False
    assert PROTOCOL1.error_names(bus.alerts[1]) == ("input voltage",)


def test_an_echo_that_comes_late_after_a_broadcast_is_dropped_with_it() -> None:
    """A broadcast is not read after; its echo may come after the next instruction went out
    (an adapter's latency timer): what comes before the next echo is dropped with it."""
    bus, _ = echoing_bus(2, echo=True)
    bus.declare(1, "xm430-w210")
    port = bus.port
    port.write(action := bus.proto.encode_instruction(bus.proto.action()))
    assert port._echo_of == action
    request = bus.proto.encode_instruction(bus.proto.ping(1))
    port.write(request)                               # no reset_input between them
    status = port.read(14, 0.1)
    assert bus.proto.decode_status(status).id == 1


@pytest.mark.parametrize("version", [1, 2])
def test_an_echoing_pty_is_learnt_and_stripped(version: int) -> None:
    """The same through a pseudo-terminal (``servolab sim --echo``) and a serial port."""
    spec = motorspec.load(BUSES[version][0], baudrate=BAUD)
    emulator = build_emulator(spec)
    _, name, value = BUSES[version]
    with ports.PtyServer(ports.EchoingDevice(emulator), BAUD, clock=WallClock()) as server, \
            Bus.open(server.device, protocol=version, baudrate=BAUD, latency=0.001) as bus:
        assert bus.ping(2).id == 2
        assert bus.port.echo is True
        bus.write(2, name, value, raw=True)
        assert bus.read(2, name, raw=True) == value
        assert bus.sync_read(name, [1, 3], raw=True) == {
            i: emulator.motor(i).get_raw(name) for i in (1, 3)}


def test_loop_url_still_reads_back_what_it_wrote() -> None:
    """loop:// is pyserial's loopback: reading back is its point, not an echo to drop."""
    with ports.open_port("loop://", BAUD) as port:
        assert port.echo is False
        port.write(PING_1)
        assert port.read(len(PING_1), 1.0) == PING_1


# -- replug ---------------------------------------------------------------------------------------


def xm430_bus() -> Emulator:
    return Emulator(2, [VirtualMotor(model("xm430-w210"), 1, baudrate=BAUD)])


def test_an_adapter_that_comes_back_is_reopened_once_with_one_line(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """The device path goes away (the pty closes, its link with it) and comes back (a new
    pty at the same link): the next call reopens it and says so once; while it is gone,
    the error says that, and the call after it tries again."""
    link = tmp_path / "ttyDXL"
    server = ports.PtyServer(xm430_bus(), BAUD, link=link).start()
    bus = Bus.open(str(link), protocol=2, baudrate=BAUD, latency=0.001, echo=False)
    try:
        assert bus.ping(1).id == 1
        server.close()                                # unplugged
        server = ports.PtyServer(xm430_bus(), BAUD, link=link).start()   # plugged in again
        with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.ports"):
            assert bus.read(1, "model_number", raw=True) == 1030
            assert bus.read(1, "model_number", raw=True) == 1030
        said = [r.message for r in caplog.records]
        assert len(said) == 1 and said[0].startswith(f"serial port {link} went away (")
        assert said[0].endswith("and is back: reopened")

        server.close()                                # unplugged, and not back
        with pytest.raises(PortError) as info:
            bus.ping(1)
        message = str(info.value)
        assert message.startswith(f"serial port {link}: ")
        assert f"gone (unplugged?) and not back: {link} does not exist" in message
        assert "\n" not in message
        with pytest.raises(PortError, match="not back"):
            bus.ping(1)                               # each call tries once more

        server = ports.PtyServer(xm430_bus(), BAUD, link=link).start()
        assert bus.ping(1).id == 1                    # and finds it back
    finally:
        bus.close()
        server.close()


def test_a_write_timeout_is_not_taken_for_an_unplugged_adapter(
        slave_path: str, monkeypatch: pytest.MonkeyPatch) -> None:
    port = ports.SerialPort(slave_path, BAUD, latency=0.001, echo=False)
    reopened: list[bool] = []
    monkeypatch.setattr(port, "_reopen", lambda: reopened.append(True))

    def slow(data: bytes) -> None:
        raise serial.SerialTimeoutException("Write timeout")

    monkeypatch.setattr(port, "_write", slow)
    try:
        with pytest.raises(PortError, match="Write timeout"):
            port.write(PING_1)
        assert reopened == []
    finally:
        port.close()


# -- the pty server's own timing ----------------------------------------------------------------


def test_the_server_says_how_late_it_handed_replies_over() -> None:
    emulator = xm430_bus()
    request = bytes.fromhex("FF FF FD 00 01 03 00 01 19 4E")   # PING ID 1 (e-Manual, 2.0)
    with ports.PtyServer(emulator, BAUD) as server:
        assert server.reply_lateness()["replies"] == 0
        client = serial.Serial(server.device, BAUD, timeout=2.0)
        try:
            for _ in range(3):
                client.write(request)
                assert len(client.read(14)) == 14
        finally:
            client.close()
        figures = server.reply_lateness()
    assert figures["replies"] == 3
    assert 0 <= figures["p50_ms"] <= figures["p99_ms"] <= figures["max_ms"]  # type: ignore[operator]


def test_a_realtime_server_where_the_os_refuses_serves_all_the_same(
        monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[tuple[int, int]] = []

    def refuse(pid: int, policy: int, param: object) -> None:
        asked.append((pid, policy))
        raise PermissionError(errno.EPERM, "Operation not permitted")

    monkeypatch.setattr(ports.os, "sched_setscheduler", refuse)
    with ports.PtyServer(xm430_bus(), BAUD, realtime=True) as server:
        assert asked == [(server._thread.native_id, os.SCHED_FIFO)]
        assert server.realtime is False
        with Bus.open(server.device, protocol=2, baudrate=BAUD, latency=0.001) as bus:
            assert bus.ping(1).id == 1


def test_the_waiter_above_fd_setsize_waits_and_wakes() -> None:
    """select() cannot take descriptors from 1024 on: the server then waits with poll() for
    whole milliseconds and sleeps the rest."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard != resource.RLIM_INFINITY and hard < 1100:
        pytest.skip(f"cannot open descriptor 1050 (hard limit {hard})")
    if soft < 1100:
        resource.setrlimit(resource.RLIMIT_NOFILE, (1100, hard))
    r, w = os.pipe()
    high = os.dup2(r, 1050)
    try:
        wait = ports._readable_waiter(high, w)
        assert wait(0.0015) is False                 # nothing to read: the timeout passes
        os.write(w, b"x")
        assert wait(None) is True
        assert select.select([r], [], [], 0)[0] == [r]
    finally:
        for fd in (r, w, high):
            os.close(fd)
        if soft < 1100:
            resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


def test_servolab_sim_echo_serves_an_echoing_adapter(tmp_path: Path) -> None:
    """``servolab sim --pty --echo``: a client through an echoing adapter, end to end; the
    summary says so and how late the replies were handed over."""
    import json

    from tests.simproc import sim_process

    with sim_process("--motors", "rx28:1-2", "--echo", out_dir=tmp_path) as (device, _), \
            Bus.open(device, protocol=1, baudrate=BAUD, latency=0.001) as bus:
        assert [found.id for found in bus.scan(range(4))] == [1, 2]
        assert bus.port.echo is True
        bus.write(2, "goal_position", 650, raw=True)
        assert bus.read(2, "goal_position", raw=True) == 650
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["echo"] is True
    assert summary["reply_lateness"]["replies"] >= 4
