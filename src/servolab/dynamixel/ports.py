"""Ports: where the bus bytes go.

Three kinds, one interface (:class:`Port`): a USB serial adapter through pyserial
(:class:`SerialPort`), an in-memory wire straight to a :class:`Device` such as an emulated bus
(:class:`MemoryPort`), and a pseudo-terminal that serves a device to any other program
(:class:`PtyServer`), so the official SDK or the Dynamixel Wizard can talk to emulated motors.

:func:`open_port` opens a port by name, as pyserial's ``serial_for_url`` does: a device path
(``/dev/ttyUSB0``, ``COM3``) is a serial port; ``scheme://...`` goes to the handler that
:data:`URL_SCHEMES` names for the scheme, imported only when such a URL is opened. That is how
``emu://rx28:11-16`` reaches the emulator without the driver importing it.
"""

from __future__ import annotations

import contextlib
import importlib
import logging
import math
import os
import sys
import threading
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from pathlib import Path
from typing import Any, Protocol

from ..clock import Clock, WallClock
from .errors import ConfigError
from .wire import byte_time

log = logging.getLogger(__name__)


class Reply(Protocol):
    """Bytes a device puts on the wire, starting at ``start`` (seconds)."""

    @property
    def start(self) -> float: ...

    @property
    def data(self) -> bytes: ...


class Device(Protocol):
    """The far end of an in-memory wire: takes the host's bytes, finished at ``t`` at the
    host's ``baudrate``, and returns what it answers, each reply with the time it starts."""

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Any]: ...


class Port(ABC):
    """A half-duplex byte pipe to a Dynamixel bus."""

    name: str
    baudrate: int
    clock: Clock
    #: seconds the adapter may hold received bytes before passing them on (FTDI latency timer)
    latency: float = 0.0
    #: the protocol the port knows its bus speaks (an emulated bus does), else None
    protocol: int | None = None

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
    """A wire from the driver straight into a :class:`Device` (an emulated bus), in this
    process.

    On a virtual clock it models the wire exactly: every byte takes 10 bits' time at the baud
    rate, motors answer after their return delay, and the port asks the clock's owner to move
    time on accordingly (so worlds step while bytes travel), which gives bus-time figures
    without sleeping. On the wall clock, answers are there at once (plus any injected delay).
    """

    def __init__(self, device: Device, baudrate: int = 1_000_000, *, clock: Clock,
                 name: str = "memory", protocol: int | None = None,
                 lock: AbstractContextManager[Any] | None = None) -> None:
        if baudrate <= 0:
            raise ConfigError(f"baud rate {baudrate} must be positive")
        self.device = device
        self.baudrate = int(baudrate)
        self.clock = clock
        self.name = name
        self.protocol = protocol
        self._lock = lock if lock is not None else nullcontext()
        self._rx: deque[tuple[float, int]] = deque()  # (time the byte is complete, byte)
        self.bytes_written = 0
        self.bytes_read = 0

    @property
    def emulator(self) -> Device:
        """The device on the wire (an :class:`~.emulator.Emulator` when emulated)."""
        return self.device

    def write(self, data: bytes) -> None:
        data = bytes(data)
        virtual = self.clock.virtual
        now = self.clock.now()
        tick = byte_time(self.baudrate)
        end = now + len(data) * tick if virtual else now
        if virtual:
            self.clock.advance_to(end)
        self.bytes_written += len(data)
        with self._lock:
            replies = self.device.receive(data, end, self.baudrate)
        # On the wall clock only an injected delay (a device's ``faults.delay``) holds answers.
        delay = getattr(getattr(self.device, "faults", None), "delay", 0.0)
        for reply in replies:
            start = reply.start if virtual else now + delay
            for i, byte in enumerate(reply.data):
                self._rx.append((start + (i + 1) * tick if virtual else start, byte))

    def read(self, size: int, timeout: float) -> bytes:
        deadline = self.clock.now() + timeout
        out = bytearray()
        rx = self._rx
        last = -math.inf
        while len(out) < size and rx and rx[0][0] <= deadline:
            ready, byte = rx.popleft()
            last = ready
            out.append(byte)
        if last > self.clock.now():
            self.clock.advance_to(last)  # the bytes come one after another: wait for the last
        if len(out) < size:
            if self.clock.virtual:
                self.clock.advance_to(deadline)
            elif self._rx:  # an answer is still on its way (injected delay): wait for it
                self.clock.sleep(deadline - self.clock.now())
            # else nothing more can come from an in-process device: no need to wait
        self.bytes_read += len(out)
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
    """Serve a device (an emulated bus) on a pseudo-terminal, so any serial client can talk to
    it.

    The client opens :attr:`device` as a serial port. Replies are timed on ``clock``, which
    must run at wall speed (a :class:`servolab.sim.Simulation` in real time, whose thread steps
    the motors; ``lock`` is held while the device answers, so the two never meet halfway);
    return delay and wire time at the bus's baud are honoured. When the client sets a
    standard line speed that no motor can understand (beyond 3 %), motors stay silent, as
    they would on a real wire; ``line_baud`` overrides what the client set.
    """

    def __init__(self, emulator: Device, baudrate: int, *, link: str | Path | None = None,
                 clock: Clock | None = None,
                 lock: AbstractContextManager[Any] | None = None) -> None:
        import pty
        import termios
        import tty

        self.emulator = emulator
        self.baudrate = int(baudrate)
        self.clock: Clock = clock or WallClock()
        self._lock = lock if lock is not None else nullcontext()
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
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                break
            with self._lock:
                replies = self.emulator.receive(data, now, self.line_baud())
            for reply in replies:
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


#: URL schemes and the function that opens each, as ``"module:function"``; the module is
#: imported only when such a URL is opened. The function takes (the URL after ``scheme://``,
#: baudrate or None, **options) and returns a :class:`Port`.
URL_SCHEMES: dict[str, str] = {
    "emu": "servolab.sim.emulated:open_emulated_url",
}


#: The baud rate of a serial port opened without one: the X-series' factory rate, within 1 %
#: of the RX-28's 57142.
DEFAULT_BAUDRATE = 57600


def open_port(url: str, baudrate: int | None = None, **options: Any) -> Port:
    """Open a port by name: a serial device (``/dev/ttyUSB0``, ``COM3``, a pty path) or a URL
    (``emu://rx28:11-16`` for emulated motors). ``baudrate`` None: 57600 on a serial port, the
    motors' own rate on an emulated bus. ``options`` go to the URL's handler (for ``emu://``:
    ``simulation``, ``faults``) or, for a serial device, to :class:`SerialPort`."""
    scheme, sep, rest = url.partition("://")
    if not sep:
        return SerialPort(url, baudrate or DEFAULT_BAUDRATE, **options)
    target = URL_SCHEMES.get(scheme)
    if target is None:
        known = ", ".join(f"{s}://" for s in URL_SCHEMES)
        raise ConfigError(f"port {url!r}: unknown scheme {scheme!r}; use a serial device "
                          f"such as /dev/ttyUSB0 or {known}")
    module_name, _, function = target.partition(":")
    opener: Callable[..., Port] = getattr(importlib.import_module(module_name), function)
    return opener(rest, baudrate, **options)
