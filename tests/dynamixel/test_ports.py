"""Ports: the serial port's checks and its latency-timer advice, and the pty's line speed."""

from __future__ import annotations

import logging
import os
import pty
from pathlib import Path

import pytest
import serial

from servolab.dynamixel import ports
from servolab.dynamixel.errors import ConfigError


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
