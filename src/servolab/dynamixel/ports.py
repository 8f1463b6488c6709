"""Ports: where the bus bytes go.

Three kinds, one interface (:class:`Port`): a USB serial adapter through pyserial
(:class:`SerialPort`), an in-memory wire straight to an :class:`~.emulator.Emulator`
(:class:`MemoryPort`), and a pseudo-terminal that serves an emulator to any other program
(:class:`PtyServer`), so the official SDK or the Dynamixel Wizard can talk to emulated motors.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
from abc import ABC, abstractmethod
from collections import deque
from pathlib import Path

from ..clock import Clock, VirtualClock, WallClock
from .emulator import Emulator, byte_time
from .errors import ConfigError

log = logging.getLogger(__name__)


class Port(ABC):
    """A half-duplex byte pipe to a Dynamixel bus."""

    name: str
    baudrate: int
    clock: Clock
    #: seconds the adapter may hold received bytes before passing them on (FTDI latency timer)
    latency: float = 0.0

    @abstractmethod
    def write(self, data: bytes) -> None: ...

    @abstractmethod
    def read(self, size: int, timeout: float) -> bytes:
        """Up to ``size`` bytes: returns when ``size`` bytes came or ``timeout`` s passed."""

    @abstractmethod
    def reset_input(self) -> None:
        """Throw away whatever was received and not yet read."""

    def set_baudrate(self, baudrate: int) -> None:
        self.baudrate = int(baudrate)

    def close(self) -> None:  # noqa: B027 - optional for ports without resources
        pass

    def __enter__(self) -> Port:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class MemoryPort(Port):
    """A wire from the driver straight into an emulator, in this process.

    On a :class:`~servolab.clock.VirtualClock` it models the wire exactly: every byte takes
    10 bits' time at the baud rate, motors answer after their return delay, and the clock moves
    accordingly, so bus-time figures come out without sleeping. On the wall clock, answers are
    there at once (plus any injected delay).
    """

    def __init__(self, emulator: Emulator, baudrate: int = 1_000_000, *,
                 clock: Clock | None = None, name: str = "memory") -> None:
        if baudrate <= 0:
            raise ConfigError(f"baud rate {baudrate} must be positive")
        self.emulator = emulator
        self.baudrate = int(baudrate)
        self.clock = clock if clock is not None else VirtualClock()
        self.name = name
        self._rx: deque[tuple[float, int]] = deque()  # (time the byte is complete, byte)
        self.bytes_written = 0
        self.bytes_read = 0
        emulator.time = max(emulator.time, self.clock.now())

    def write(self, data: bytes) -> None:
        data = bytes(data)
        now = self.clock.now()
        tick = byte_time(self.baudrate)
        end = now + len(data) * tick if self.clock.virtual else now
        if self.clock.virtual:
            self.clock.advance_to(end)  # type: ignore[attr-defined]
        self.bytes_written += len(data)
        for reply in self.emulator.receive(data, end, self.baudrate):
            start = reply.start if self.clock.virtual else now + self.emulator.faults.delay
            for i, byte in enumerate(reply.data):
                self._rx.append((start + (i + 1) * tick if self.clock.virtual else start, byte))

    def read(self, size: int, timeout: float) -> bytes:
        deadline = self.clock.now() + timeout
        out = bytearray()
        while len(out) < size and self._rx and self._rx[0][0] <= deadline:
            ready, byte = self._rx[0]
            if ready > self.clock.now():
                self.clock.sleep(ready - self.clock.now())
            self._rx.popleft()
            out.append(byte)
        if len(out) < size:
            if self.clock.virtual:
                self.clock.advance_to(deadline)  # type: ignore[attr-defined]
            elif not self._rx:
                pass  # nothing more can come from an in-process emulator: no need to wait
            else:
                self.clock.sleep(deadline - self.clock.now())
        self.bytes_read += len(out)
        self.emulator.advance(self.clock.now())
        return bytes(out)

    def reset_input(self) -> None:
        now = self.clock.now()
        while self._rx and self._rx[0][0] <= now:
            self._rx.popleft()

    def set_baudrate(self, baudrate: int) -> None:
        if baudrate <= 0:
            raise ConfigError(f"baud rate {baudrate} must be positive")
        self.baudrate = int(baudrate)


class SerialPort(Port):
    """A real serial port (USB2Dynamixel, U2D2, OpenCM, ...) through pyserial."""

    def __init__(self, device: str, baudrate: int = 57600, *, latency: float | None = None
                 ) -> None:
        import serial  # pyserial

        if not device.startswith(("COM", "\\\\.\\")) and not os.path.exists(device):
            raise ConfigError(f"serial port {device!r} does not exist; list ports with "
                              "'python -m serial.tools.list_ports' or start an emulated bus "
                              "with 'servolab sim --pty'")
        try:
            self._serial = serial.Serial(device, baudrate=baudrate, timeout=0,
                                         write_timeout=1.0)
        except (serial.SerialException, ValueError, OSError) as exc:
            raise ConfigError(f"cannot open serial port {device!r} at {baudrate} bps: "
                              f"{exc}") from None
        self.name = device
        self.baudrate = int(baudrate)
        self.clock = WallClock()
        timer = usb_latency_timer(device)
        warning = latency_warning(device, timer)
        if warning:
            log.warning(warning)
        self.latency = latency if latency is not None else (
            timer / 1000.0 if timer is not None else 0.016)

    def write(self, data: bytes) -> None:
        self._serial.write(bytes(data))
        self._serial.flush()

    def read(self, size: int, timeout: float) -> bytes:
        self._serial.timeout = max(0.0, timeout)
        return bytes(self._serial.read(size))

    def reset_input(self) -> None:
        self._serial.reset_input_buffer()

    def set_baudrate(self, baudrate: int) -> None:
        self._serial.baudrate = int(baudrate)
        self.baudrate = int(baudrate)

    def close(self) -> None:
        self._serial.close()


USB_SERIAL_SYSFS = Path("/sys/bus/usb-serial/devices")


def latency_timer_path(device: str, sysfs: Path = USB_SERIAL_SYSFS) -> Path:
    """Where Linux exposes the FTDI latency timer of ``device`` (follows symlinks such as
    /dev/serial/by-id/...)."""
    return sysfs / Path(os.path.realpath(device)).name / "latency_timer"


def usb_latency_timer(device: str, sysfs: Path = USB_SERIAL_SYSFS) -> int | None:
    """The FTDI latency timer of ``device`` in ms (Linux), or None where there is none.

    FTDI adapters (USB2Dynamixel, U2D2) hold received bytes up to this long, 16 ms by default:
    every status packet then arrives up to 16 ms late, which caps a bus at about 60
    transactions per second whatever its baud rate."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        return int(latency_timer_path(device, sysfs).read_text().strip())
    except (OSError, ValueError):
        return None


def latency_warning(device: str, timer_ms: int | None) -> str | None:
    """The warning for a latency timer above 1 ms, with the command that lowers it."""
    if timer_ms is None or timer_ms <= 1:
        return None
    return (f"{device}: the USB adapter's latency timer is {timer_ms} ms, which delays every "
            f"reply by up to {timer_ms} ms; lower it with: "
            f"echo 1 | sudo tee {latency_timer_path(device)}")


class PtyServer:
    """Serve an emulator on a pseudo-terminal, so any serial client can talk to it.

    The client opens :attr:`device` as a serial port. Replies are timed on the wall clock
    (return delay and wire time at the emulator's baud are honoured). When the client sets a
    standard line speed that no motor can understand (beyond 3 %), motors stay silent, as
    they would on a real wire; ``line_baud`` overrides what the client set.
    """

    def __init__(self, emulator: Emulator, baudrate: int, *, link: str | Path | None = None,
                 clock: Clock | None = None) -> None:
        import pty
        import termios
        import tty

        self.emulator = emulator
        self.baudrate = int(baudrate)
        self.clock = clock or WallClock()
        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave, termios.TCSANOW)
        self.device = os.ttyname(self._slave)
        self.link = Path(link) if link else None
        if self.link:
            if self.link.is_symlink() or self.link.exists():
                self.link.unlink()
            self.link.symlink_to(self.device)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="pty-emulator", daemon=True)
        self.emulator.time = self.clock.now()

    def start(self) -> PtyServer:
        self._thread.start()
        return self

    def _serve(self) -> None:
        import select

        pending: list[tuple[float, bytes]] = []
        while not self._stop.is_set():
            now = self.clock.now()
            wait = 0.05 if not pending else max(0.0, min(t for t, _ in pending) - now)
            ready, _, _ = select.select([self._master], [], [], wait)
            now = self.clock.now()
            due = [p for p in pending if p[0] <= now]
            for item in due:
                pending.remove(item)
                os.write(self._master, item[1])
            if not ready:
                self.emulator.advance(now)
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                break
            for reply in self.emulator.receive(data, now, self.line_baud()):
                pending.append((reply.start, reply.data))
            pending.sort(key=lambda p: p[0])

    def line_baud(self) -> int:
        """The line speed the client set on its end, or our own rate if it cannot be told."""
        return client_line_speed(self._slave) or self.baudrate

    def close(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)
        for fd in (self._master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        if self.link and self.link.is_symlink():
            self.link.unlink()

    def __enter__(self) -> PtyServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


def client_line_speed(fd: int) -> int | None:
    """Speed set on a terminal (e.g. by pyserial on the pty's client side), in bps."""
    import termios

    try:
        attrs = termios.tcgetattr(fd)
    except termios.error:
        return None
    speed = attrs[5]
    for name in dir(termios):
        if name.startswith("B") and name[1:].isdigit() and getattr(termios, name) == speed:
            return int(name[1:])
    if sys.platform.startswith("linux"):
        # Custom rates (termios2, BOTHER): read c_ospeed with the TCGETS2 ioctl.
        import fcntl
        import struct

        tcgets2 = 0x802C542A
        try:
            buf = fcntl.ioctl(fd, tcgets2, bytes(44))
        except OSError:
            return None
        ospeed = struct.unpack("I", buf[40:44])[0]
        return ospeed or None
    return None


def open_port(device: str, baudrate: int) -> Port:
    """Open a serial port by device path (``/dev/ttyUSB0``, ``COM3``, a pty path)."""
    return SerialPort(device, baudrate)
