"""Ports: the serial port's checks and its latency-timer advice, the pty's line speed, and the
pty server's loop (clients that come and go, an idle line, half duplex)."""

from __future__ import annotations

import errno
import logging
import os
import pty
import threading
import time
from pathlib import Path

import pytest
import serial

from servolab.dynamixel import model, ports
from servolab.dynamixel.emulator import Emulator, Faults, VirtualMotor
from servolab.dynamixel.errors import ConfigError, PortError
from servolab.dynamixel.protocol2 import PROTOCOL2
from tests.clirun import one_line
from tests.waiting import wait_for


def test_missing_serial_port_is_named_with_what_to_do() -> None:
    with pytest.raises(ConfigError) as info:
        ports.SerialPort("/dev/ttyUSB_nothing_here", 57600)
    message = str(info.value)
    assert "/dev/ttyUSB_nothing_here" in message and "servolab sim --pty" in message
    assert "\n" not in message


def test_latency_timer_read_from_sysfs(tmp_path: Path) -> None:
    """The timer is found under the device's real name, also through a symlink."""
    (tmp_path / "ttyUSB7").mkdir()
    (tmp_path / "ttyUSB7" / "latency_timer").write_text("16\n")
    dev = tmp_path / "dev"
    dev.mkdir()
    (dev / "ttyUSB7").touch()
    link = dev / "by-id-u2d2"
    link.symlink_to(dev / "ttyUSB7")
    assert ports.usb_latency_timer(str(link), sysfs=tmp_path) == 16
    assert ports.usb_latency_timer(str(dev / "ttyS0"), sysfs=tmp_path) is None


def test_latency_warning_says_how_to_lower_it() -> None:
    warning = ports.latency_warning("/dev/ttyUSB0", 16)
    assert warning is not None
    assert "16 ms" in warning
    assert "echo 1 | sudo tee /sys/bus/usb-serial/devices/ttyUSB0/latency_timer" in warning
    assert ports.latency_warning("/dev/ttyUSB0", 1) is None
    assert ports.latency_warning("/dev/ttyUSB0", None) is None


def test_serial_port_warns_when_timer_is_high(monkeypatch: pytest.MonkeyPatch,
                                             caplog: pytest.LogCaptureFixture) -> None:
    master, slave = pty.openpty()
    try:
        device = os.ttyname(slave)
        monkeypatch.setattr(ports, "usb_latency_timer", lambda dev: 16)
        with caplog.at_level(logging.WARNING, logger="servolab.dynamixel.ports"):
            port = ports.SerialPort(device, 57600)
        port.close()
        assert any("latency timer is 16 ms" in r.message for r in caplog.records)
        assert port.latency == pytest.approx(0.016)
    finally:
        os.close(master)
        os.close(slave)


@pytest.mark.parametrize("baud", [57600, 1_000_000, 57142])
def test_pty_reports_the_line_speed_the_client_set(baud: int) -> None:
    """The emulator stays silent on a baud mismatch, so it must see what the client set,
    including non-standard rates such as the RX-28's 57142."""
    master, slave = pty.openpty()
    try:
        client = serial.Serial(os.ttyname(slave), baudrate=baud, timeout=0)
        try:
            assert ports.client_line_speed(slave) == baud
        finally:
            client.close()
    finally:
        os.close(master)
        os.close(slave)


def test_the_driver_loads_no_emulator() -> None:
    """The driver and its ports import nothing of the emulator, the plant or the simulation:
    an emulated bus is reached only through the emu:// URL, whose handler is imported when
    such a URL is opened."""
    import subprocess
    import sys

    code = ("import sys\nfrom servolab.dynamixel import Bus\nfrom servolab.dynamixel.bus "
            "import Bus as B\nBus.open\n"
            "print(sorted(m for m in sys.modules if m.endswith(('.emulator', '.plant')) "
            "or m.startswith('servolab.sim')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True).stdout
    assert out.strip() == "[]"


# -- the pseudo-terminal server ---------------------------------------------------------------


def _pty_bus() -> tuple[Emulator, bytes]:
    emulator = Emulator(2, [VirtualMotor(model("xm430-w210"), 1, baudrate=57600)])
    return emulator, PROTOCOL2.encode_instruction(PROTOCOL2.ping(1))


def _read_status(client: serial.Serial) -> bytes:
    """One 2.0 PING status (14 bytes), or whatever came within the client's timeout."""
    got = b""
    while len(got) < 14:
        chunk = client.read(14 - len(got))
        if not chunk:
            break
        got += chunk
    return got


def _thread_cpu_seconds(native_id: int) -> float:
    fields = Path(f"/proc/self/task/{native_id}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def test_pty_server_serves_a_client_that_closes_and_opens_again() -> None:
    """A client may go away at any time, even with a reply on its way, and come back: the
    server neither stops nor blocks, and answers the new client."""
    emulator, ping = _pty_bus()
    with ports.PtyServer(emulator, 57600) as server:
        for _ in range(3):
            client = serial.Serial(server.device, 57600, timeout=1.0)
            client.write(ping)
            assert PROTOCOL2.decode_status(_read_status(client)).id == 1
            client.write(ping)          # and leave without reading the answer
            client.close()
        client = serial.Serial(server.device, 57600, timeout=1.0)
        try:
            client.reset_input_buffer()
            client.write(ping)
            got = _read_status(client)
            assert PROTOCOL2.decode_status(got[-14:]).id == 1
        finally:
            client.close()


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs /proc")
def test_pty_server_sleeps_while_the_line_is_idle() -> None:
    """No busy loop: with nothing to send and nothing received (after a partial packet the
    emulator drops when the line stays idle), the server thread uses next to no CPU."""
    emulator, _ = _pty_bus()
    with ports.PtyServer(emulator, 57600) as server:
        client = serial.Serial(server.device, 57600, timeout=1.0)
        try:
            client.write(bytes.fromhex("FF FF FD 00 01 40 00"))   # a header cut short
            wait_for(lambda: emulator.partial_packets_dropped == 1,
                     "the emulator to drop the partial packet")
            tid = server._thread.native_id
            assert tid is not None
            before = _thread_cpu_seconds(tid)
            time.sleep(0.5)                               # the window measured
            assert _thread_cpu_seconds(tid) - before < 0.05
            assert server._thread.is_alive()
        finally:
            client.close()


def test_pty_reply_on_its_way_is_lost_when_the_client_sends_again() -> None:
    """Half duplex: a status still to come when the client sends again would meet the
    client's bytes on the wire; it is lost, and only the second PING is answered. (Answers
    are held back 0.5 s here, so that the second PING surely comes before the first status.)"""
    emulator, ping = _pty_bus()
    emulator.faults = Faults(delay=0.5)
    with ports.PtyServer(emulator, 57600) as server:
        client = serial.Serial(server.device, 57600, timeout=5.0)
        try:
            client.write(ping)
            wait_for(lambda: emulator.instructions_seen == 1, "the server to read the PING")
            client.write(ping)
            assert PROTOCOL2.decode_status(_read_status(client)).id == 1
            assert server.replies_lost == 1
            client.timeout = 0.2
            assert client.read(64) == b""       # and nothing else comes
        finally:
            client.close()


# -- the serial port when the device goes away -------------------------------------------------


@pytest.fixture
def pty_port():
    """A SerialPort on a pty's slave, and the master (None once a test closed it)."""
    master, slave = pty.openpty()
    port = ports.SerialPort(os.ttyname(slave), 57600, latency=0.001)
    ends = {"master": master}
    try:
        yield port, ends
    finally:
        port.close()
        if ends["master"] is not None:
            os.close(ends["master"])
        os.close(slave)


def test_serial_port_gone_is_one_line_naming_it(pty_port) -> None:
    """Reading a pty whose other end is closed fails with EIO, as a USB adapter does once it
    is unplugged: a PortError (which the CLI prints on one line), not an OSError's
    traceback."""
    port, ends = pty_port
    os.close(ends["master"])
    ends["master"] = None
    with pytest.raises(PortError) as info:
        port.read(4, 0.2)
    one_line(info.value, port.name, "unplugged")
    assert isinstance(info.value.__cause__, OSError)


def test_serial_port_write_error_is_one_line_naming_it(pty_port,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    port, _ = pty_port

    def eio(fd: int, data: bytes) -> int:
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(ports.os, "write", eio)
    with pytest.raises(PortError) as info:
        port.write(b"\xff\xff\x01\x02\x01\xfb")
    one_line(info.value, port.name, "unplugged")
    assert "Input/output error" in str(info.value)


def test_cli_reports_a_port_error_as_a_failure_at_run_time() -> None:
    """``servolab read`` and the others print it as "servolab read: PortError: ..." and exit
    with status 1 (not 2, which says the user typed something wrong)."""
    from servolab.cli import _label
    from servolab.harness import exit_status

    error = PortError("serial port /dev/ttyUSB0: reading failed")
    assert (exit_status(error), _label(error)) == (1, "PortError")


def test_serial_port_waits_on_a_descriptor_above_1023() -> None:
    """select() cannot wait on a descriptor from 1024 on (FD_SETSIZE), which a process with
    many files open gets: the port must still wait for its bytes."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    want = 1200
    if soft < want:
        if hard != resource.RLIM_INFINITY and hard < want:
            pytest.skip(f"cannot open {want} files (hard limit {hard})")
        resource.setrlimit(resource.RLIMIT_NOFILE, (want, hard))
    master, slave = pty.openpty()
    filler: list[int] = []
    port = None
    try:
        while not filler or filler[-1] < 1100:       # the lowest free descriptors taken
            filler.append(os.dup(slave))
        port = ports.SerialPort(os.ttyname(slave), 57600, latency=0.001)
        assert port._fd is not None and port._fd > 1100
        for fd in filler:
            os.close(fd)
        filler.clear()
        threading.Timer(0.05, os.write, (master, b"late")).start()
        assert port.read(4, 2.0) == b"late"          # came while the port waited
    finally:
        if port is not None:
            port.close()
        for fd in filler:
            os.close(fd)
        os.close(master)
        os.close(slave)
        if soft < want:
            resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))


@pytest.mark.slow
def test_pty_server_close_leaves_the_descriptors_to_a_thread_still_serving() -> None:
    """close() waits 1 s for the serving thread; a thread still inside the device then must
    not find its descriptors closed under it (their numbers may belong to other files by
    then): it closes them itself when it stops."""
    emulator, ping = _pty_bus()
    inside, release = threading.Event(), threading.Event()
    receive = emulator.receive

    def slow(data: bytes, t: float, baudrate: float):  # type: ignore[no-untyped-def]
        inside.set()
        release.wait(10)
        return receive(data, t, baudrate)

    emulator.receive = slow  # type: ignore[method-assign]
    server = ports.PtyServer(emulator, 57600).start()
    client = serial.Serial(server.device, 57600, timeout=1.0)
    try:
        client.write(ping)
        wait_for(inside.is_set, "the server to be inside the device")
        server.close()                              # gives up after 1 s
        assert server._thread.is_alive()
        os.fstat(server._master)                    # still open: not closed under the thread
        release.set()
        server._thread.join(5)
        assert not server._thread.is_alive()
        with pytest.raises(OSError):
            os.fstat(server._master)                # closed by the thread as it stopped
    finally:
        release.set()
        client.close()
