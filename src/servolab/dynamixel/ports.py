"""Ports: where the bus bytes go.

Four kinds, one interface (:class:`Port`): a USB serial adapter through pyserial
(:class:`SerialPort`), whatever else pyserial opens from a URL (:class:`PyserialPort`:
``spy://``, ``socket://``, ``rfc2217://``, ``loop://``, ...), an in-memory wire straight to a
:class:`Device` such as an emulated bus (:class:`MemoryPort`), and a pseudo-terminal that
serves a device to any other program (:class:`PtyServer`), so the official SDK or the
Dynamixel Wizard can talk to emulated motors.

:func:`open_port` opens a port by name, as pyserial's ``serial_for_url`` does: a device path
(``/dev/ttyUSB0``, ``COM3``) is a serial port; ``scheme://...`` goes to the handler that
:data:`URL_SCHEMES` names for the scheme, imported only when such a URL is opened (that is how
``emu://rx28:11-16`` reaches the emulator without the driver importing it), and any other
scheme pyserial has a handler for (:func:`pyserial_schemes`) to :class:`PyserialPort`.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import importlib
import logging
import math
import os
import pkgutil
import sys
import threading
import time
from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ..clock import Clock, WallClock
from .errors import ConfigError, PortError
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


#: What the echo of an adapter is learnt from when an instruction's own bytes cannot tell
#: (see :meth:`Port._learn_echo`): no 0xFF, so no Dynamixel receiver takes any of it for the
#: start of a packet (headers FF FF and FF FF FD 00), and nothing answers it.
ECHO_PROBE = b"\x00\x5a\xa5\x00"
#: The longest a motor waits before it answers: return delay 254 x 2 us (e-Manual).
MAX_REPLY_DELAY = 254 * 2e-6


def _may_be_a_status(data: bytes) -> bool:
    """Whether ``data``, an instruction packet, could also be a motor's status packet byte
    for byte: Protocol 1.0 to one ID (the status carries the error byte where the
    instruction has its code). Not Protocol 2.0 (a status has instruction 0x55, which no
    instruction has) nor a broadcast (no status answers one with those bytes)."""
    if data[:4] == b"\xff\xff\xfd\x00":
        return len(data) > 7 and data[7] == 0x55
    return data[:2] == b"\xff\xff" and len(data) > 2 and data[2] != 0xFE


def _overlap(buf: bytes, echo: bytes) -> int:
    """The length of the longest end of ``buf`` that ``echo`` starts with (shorter than
    ``echo``)."""
    for k in range(min(len(buf), len(echo) - 1), 0, -1):
        if echo.startswith(buf[-k:]):
            return k
    return 0


@dataclass(frozen=True)
class _Bytes:
    """Bytes on the wire from ``start`` (a :class:`Reply`)."""

    start: float
    data: bytes


class EchoingDevice:
    """``device`` behind an adapter that echoes: what the host sends comes back to it first,
    each byte as it goes out, then the device's own replies. For testing a driver against
    such an adapter: ``MemoryPort(EchoingDevice(emulator), echo=None)``, or
    ``PtyServer(EchoingDevice(emulator), ...)``. Everything else is the device's (its
    motors, faults, idle timeout)."""

    def __init__(self, device: Device) -> None:
        self.device = device

    def receive(self, data: bytes, t: float, baudrate: float) -> list[Any]:
        echo = _Bytes(t - len(data) * byte_time(baudrate), bytes(data))
        return [echo, *self.device.receive(data, t, baudrate)]

    def __getattr__(self, name: str) -> Any:
        return getattr(self.device, name)


class Port(ABC):
    """A half-duplex byte pipe to a Dynamixel bus."""

    name: str
    baudrate: int
    clock: Clock
    #: seconds the adapter may hold received bytes before passing them on (FTDI latency timer)
    latency: float = 0.0
    #: the protocol the port knows its bus speaks (an emulated bus does), else None
    protocol: int | None = None
    #: Whether the adapter sends back every byte the host sends (an RS-485 adapter without
    #: echo suppression, TX and RX tied for TTL): True drops the echo of each instruction
    #: from what is read after it, None learns it from the first instruction sent
    #: (:meth:`_learn_echo`), False (no echo) reads as it comes.
    echo: bool | None = False
    #: bytes read from the device and not yet returned (read ahead while learning the echo)
    _held: bytes = b""
    #: (echo True) the instruction whose echo is still to come in what is read next
    _echo_of: bytes = b""
    #: (echo True) instructions whose echo never came whole (a collision, a broken line)
    echoes_missing: int = 0

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

    # -- the echo of a half-duplex adapter ---------------------------------------------------
    # Ports that can meet one implement the raw byte I/O below, read() through
    # _read_echoed() while _held or _echo_of is set, and call _after_write() after a write.
    def _read(self, size: int, timeout: float) -> bytes:
        """Read as :meth:`read` does, without regard to any echo."""
        raise NotImplementedError

    def _write(self, data: bytes) -> None:
        """Write as :meth:`write` does, without regard to any echo."""
        raise NotImplementedError

    def _after_write(self, data: bytes) -> None:
        """``data`` went out: expect its echo (echo True), or learn whether one comes."""
        if self.echo:
            self._echo_of = bytes(data)
        elif self.echo is None:
            self._learn_echo(bytes(data))

    def _echo_wait(self, size: int) -> float:
        """How long the echo of ``size`` bytes may take to come back (s): their wire time,
        twice the adapter's latency and 2 ms, as a reply's timeout counts."""
        return size * byte_time(self.baudrate) + 2 * self.latency + 0.002

    def _learn_echo(self, data: bytes) -> None:
        """The first instruction sent tells whether the adapter echoes: its bytes come back
        at once, byte for byte, or they do not.

        Where those bytes could also be a motor's status (Protocol 1.0 to one ID: a PING
        answered with the input voltage error is the very bytes of the PING), the echo is
        told by what follows: a status right after it, else (a motor absent) bytes that no
        motor answers or acts on (:data:`ECHO_PROBE`) sent once the line is quiet. Bytes read
        on the way are kept for the next read. A partial echo decides nothing."""
        got = self._read(len(data), self._echo_wait(len(data)))
        if got != data:
            if not (got and data.startswith(got)):  # a partial echo decides nothing
                self._set_echo(False)
            self._held += got
            return
        if not _may_be_a_status(data):
            self._set_echo(True)
            return
        window = MAX_REPLY_DELAY + 2 * self.latency + 0.002 + 8 * byte_time(self.baudrate)
        more = self._read(1, window)
        if more:          # a status came after the echo
            self._set_echo(True)
            self._held += more
        elif self._probe_echo():
            self._set_echo(True)      # the bytes were the echo; no motor answered
        else:
            self._set_echo(False)     # they were a motor's status
            self._held += got

    def _probe_echo(self) -> bool:
        """Send :data:`ECHO_PROBE` and say whether it came back (what else came is
        dropped: nothing answers those bytes)."""
        self._write(ECHO_PROBE)
        clock = self.clock
        deadline = clock.now() + self._echo_wait(len(ECHO_PROBE))
        got = b""
        while ECHO_PROBE not in got:
            remaining = deadline - clock.now()
            chunk = self._read(len(ECHO_PROBE), remaining) if remaining > 0 else b""
            if not chunk:
                return False
            got += chunk
        return True

    def _set_echo(self, echo: bool) -> None:
        self.echo = echo
        if echo:
            log.warning("%s: the adapter sends back every byte sent (an RS-485 adapter "
                        "without echo suppression, or TX and RX tied): its echo is dropped "
                        "from every reply", self.name)

    def _read_echoed(self, size: int, timeout: float) -> bytes:
        """:meth:`read` when bytes are held or an echo is to come: the held bytes first;
        then, if an echo is to come, everything up to and including it is dropped (bytes
        before the echo were on the line before the instruction went out), and the
        ``size`` bytes after it are read."""
        clock = self.clock
        deadline = clock.now() + timeout
        buf, self._held = self._held, b""
        echo = self._echo_of
        if echo:
            while True:
                at = buf.find(echo)
                if at >= 0:
                    buf = buf[at + len(echo):]
                    self._echo_of = b""
                    break
                # Read no further than the earliest end the echo and size bytes can have.
                want = len(echo) - _overlap(buf, echo) + size
                chunk = self._read(want, max(0.0, deadline - clock.now()))
                if not chunk:   # the echo never came whole
                    self._echo_of = b""
                    self.echoes_missing += 1
                    break
                buf += chunk
        if len(buf) >= size:
            self._held = buf[size:]
            return buf[:size]
        return buf + self._read(size - len(buf), max(0.0, deadline - clock.now()))

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

    ``echo``: False (an in-memory wire has no adapter), or, on a device that echoes (an
    :class:`EchoingDevice`), True or None to strip the echo as a serial port does.
    """

    def __init__(self, device: Device, baudrate: int = 1_000_000, *, clock: Clock,
                 name: str = "memory", protocol: int | None = None,
                 lock: AbstractContextManager[Any] | None = None,
                 echo: bool | None = False) -> None:
        if baudrate <= 0:
            raise ConfigError(f"baud rate {baudrate} must be positive")
        self.device = device
        self.baudrate = int(baudrate)
        self.clock = clock
        self.name = name
        self.protocol = protocol
        self._lock = lock if lock is not None else nullcontext()
        #: replies on their way, oldest first: [start, byte time, data, bytes already read];
        #: byte i of a reply is complete at start + (i + 1) * byte time (all at start when
        #: the byte time is 0, on the wall clock)
        self._rx: deque[list[Any]] = deque()
        self.bytes_written = 0
        self.bytes_read = 0
        self.echo = echo

    @property
    def emulator(self) -> Device:
        """The device on the wire (an :class:`~.emulator.Emulator` when emulated)."""
        return self.device

    def write(self, data: bytes) -> None:
        self._write(data)
        if self.echo is not False:
            self._after_write(data)

    def _write(self, data: bytes) -> None:
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
        if not replies:
            return
        # On the wall clock only an injected delay (a device's ``faults.delay``) holds answers
        # (on a virtual clock the replies' start times have it).
        delay = 0.0 if virtual else getattr(getattr(self.device, "faults", None), "delay", 0.0)
        for reply in replies:
            if reply.data:
                self._rx.append([reply.start, tick, bytes(reply.data), 0] if virtual
                                else [now + delay, 0.0, bytes(reply.data), 0])

    @staticmethod
    def _ready(chunk: list[Any], t: float) -> int:
        """How many bytes of ``chunk`` (counted from its start) are complete at ``t``."""
        start, tick, data, _ = chunk
        if not tick:
            return len(data) if start <= t else 0
        # the largest i with start + i * tick <= t, computed as the byte times are
        # (min(size, max(0, i)) by comparisons: the builtins parse their keywords at every call)
        i, size = int((t - start) / tick), len(data)
        i = i if i > 0 else 0
        i = i if i < size else size
        while i < size and start + (i + 1) * tick <= t:
            i += 1
        while i > 0 and start + i * tick > t:
            i -= 1
        return i

    def available(self) -> int:
        """Bytes received and not yet read (complete by now)."""
        now = self.clock.now()
        total = len(self._held)
        for chunk in self._rx:
            ready = self._ready(chunk, now) - chunk[3]
            if ready <= 0:
                break
            total += ready
            if chunk[3] + ready < len(chunk[2]):
                break
        return total

    def read(self, size: int, timeout: float) -> bytes:
        if self._held or self._echo_of:
            return self._read_echoed(size, timeout)
        return self._read(size, timeout)

    def _read(self, size: int, timeout: float) -> bytes:
        clock = self.clock
        deadline = clock.now() + timeout
        rx = self._rx
        parts: list[bytes] = []
        got = 0
        last = -math.inf
        while got < size and rx:
            chunk = rx[0]
            start, tick, data, pos = chunk
            ready = self._ready(chunk, deadline)
            take, left = size - got, ready - pos
            take = left if left < take else take  # (min(take, left), by a comparison)
            if take <= 0:
                break
            parts.append(data[pos:pos + take])
            got += take
            pos += take
            last = start + pos * tick if tick else start
            if pos == len(data):
                rx.popleft()
            else:
                chunk[3] = pos
                break
        if last > clock.now():
            clock.advance_to(last)  # the bytes come one after another: wait for the last
        if got < size:
            if clock.virtual:
                clock.advance_to(deadline)
            elif rx:  # an answer is still on its way (injected delay): wait for it
                clock.sleep(deadline - clock.now())
            # else nothing more can come from an in-process device: no need to wait
        self.bytes_read += got
        return parts[0] if len(parts) == 1 else b"".join(parts)

    def reset_input(self) -> None:
        self._held = self._echo_of = b""
        rx = self._rx
        if not rx:
            return
        now = self.clock.now()
        while rx:
            chunk = rx[0]
            ready = self._ready(chunk, now)
            if ready < len(chunk[2]):
                chunk[3] = max(chunk[3], ready)
                return
            rx.popleft()

    def set_baudrate(self, baudrate: int) -> None:
        if baudrate <= 0:
            raise ConfigError(f"baud rate {baudrate} must be positive")
        self.baudrate = int(baudrate)


@functools.cache
def _io_errors() -> tuple[type[Exception], ...]:
    """What an I/O error of a serial port can raise: OSError (pyserial's SerialException is
    one) and, where there is termios, its error (tcflush, tcsetattr on a device gone)."""
    try:
        import termios
    except ImportError:  # Windows
        return (OSError,)
    return (OSError, termios.error)


def _reason(exc: BaseException) -> str:
    """The system's reason for an I/O error, as strerror says it."""
    return (exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            or type(exc).__name__)


def port_failed(port: str, what: str, exc: BaseException, advice: str) -> PortError:
    """One line for an I/O error of ``port``: what failed, the system's reason, what to do."""
    return PortError(f"{port}: {what} failed ({_reason(exc)}); {advice}")


def in_use(port: str) -> PortError:
    """The error for a port another program holds (pyserial's exclusive lock refused)."""
    return PortError(f"{port} is in use by another program (close it: lsof {port})")


def _is_in_use(exc: BaseException) -> bool:
    """Whether opening failed because another program holds the port locked (pyserial's
    ``exclusive``: flock fails with EWOULDBLOCK) or busy (EBUSY)."""
    return getattr(exc, "errno", None) in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EBUSY)


def _is_timeout(exc: BaseException) -> bool:
    """pyserial's write timeout: the port is there, only slow to take the bytes."""
    return type(exc).__name__ == "SerialTimeoutException"


class DevicePort(Port):
    """A port whose I/O can fail under it (an adapter unplugged, a server gone): every read
    and write error becomes one :class:`PortError` line that names the port and what to do
    (``_failed``), so the driver above sees one kind of error from any port.

    **Replug.** A port whose I/O fails (the adapter unplugged: EIO) is reopened by the same
    name at once, once, and if that works the port says so in one line (a warning) and goes
    on: a write is sent again (nothing went out on the old descriptor), a read returns what
    it has (what was on its way went with the old descriptor: the bus's retry asks again).
    If the port is not back, the error says so, and the next call tries to reopen it again,
    once.

    **Echo** (:attr:`Port.echo`): learnt from the first instruction unless given, and
    learnt again after a reopen (another adapter may have been plugged in).
    """

    #: the I/O error the port was lost with, while it is not back; the next call reopens it
    _lost: BaseException | None = None
    #: the echo as given at open (None: learnt), which a reopened port starts from again
    _echo_given: bool | None = None
    #: whether a port lost under it is reopened (see above); a URL's is not: a server that
    #: closed the connection may take another, which is not this one coming back
    reopens: bool = True

    @abstractmethod
    def _failed(self, what: str, exc: BaseException) -> PortError: ...

    @abstractmethod
    def _write(self, data: bytes) -> None: ...

    @abstractmethod
    def _read(self, size: int, timeout: float) -> bytes: ...

    @abstractmethod
    def _reopen(self) -> None:
        """Close the port and open it again by its name, set up as it was; raises an I/O
        error or :class:`ConfigError` where it cannot."""

    @property
    def label(self) -> str:
        """How messages name the port."""
        return f"port {self.name}"

    def _gone_detail(self, again: BaseException) -> str:
        """Why the port is not back (``again``: what reopening it raised)."""
        return f"reopening it failed ({_reason(again)})"

    def write(self, data: bytes) -> None:
        if self._lost is not None:
            self._come_back("writing")
        try:
            self._write(data)
        except _io_errors() as exc:
            self._recover("writing", exc)
            try:
                self._write(data)   # nothing went out on the old descriptor
            except _io_errors() as again:
                raise self._failed("writing", again) from again
        if self.echo is not False:
            try:
                self._after_write(data)
            except _io_errors() as exc:
                raise self._failed("reading the echo", exc) from exc

    def read(self, size: int, timeout: float) -> bytes:
        if self._lost is not None:
            self._come_back("reading")
        try:
            if self._held or self._echo_of:
                return self._read_echoed(size, timeout)
            return self._read(size, timeout)
        except _io_errors() as exc:
            self._recover("reading", exc)
            return b""  # what was on its way went with the old descriptor

    def _redo(self, what: str, action: Callable[[], object]) -> None:
        """``action`` (resetting input, setting the baud rate), once more on the reopened
        port if the port was lost under it."""
        if self._lost is not None:
            self._come_back(what)
        try:
            action()
        except _io_errors() as exc:
            self._recover(what, exc)
            try:
                action()
            except _io_errors() as again:
                raise self._failed(what, again) from again

    def _recover(self, what: str, exc: BaseException) -> None:
        """``what`` failed with ``exc``: reopen the port (once) and return, or raise."""
        if _is_timeout(exc) or not self.reopens:
            raise self._failed(what, exc) from exc
        self._lost = exc
        self._come_back(what)

    def _come_back(self, what: str) -> None:
        """Reopen the port lost with :attr:`_lost`, saying so in one line; a
        :class:`PortError` that says it is not back where it cannot."""
        lost = self._lost
        assert lost is not None
        failures: tuple[type[Exception], ...] = (ConfigError, *_io_errors())
        try:
            self._reopen()
        except failures as again:
            raise PortError(f"{self.label}: {what} failed ({_reason(lost)}); the adapter is "
                            f"gone (unplugged?) and not back: {self._gone_detail(again)}; "
                            "plug it in again, the next call reopens it") from lost
        self._lost = None
        self.echo = self._echo_given
        self._held = self._echo_of = b""
        log.warning("%s went away (%s) and is back: reopened", self.label, _reason(lost))


class SerialPort(DevicePort):
    """A real serial port (USB2Dynamixel, U2D2, OpenCM, ...) through pyserial.

    Reads and writes go straight to the port's file descriptor where there is one (POSIX):
    pyserial applies its whole port configuration again (tcsetattr) each time its ``timeout``
    is set, which a read with a per-call deadline would otherwise do on every transaction.
    An I/O error of the device (EIO once the adapter is unplugged) raises :class:`PortError`,
    one line naming the port and what to do, unless the port is back (see
    :class:`DevicePort`).

    The port is opened exclusively (pyserial's ``exclusive``, an advisory lock): a second
    program that asks the same (servolab, pyserial with ``exclusive``) is refused with "PORT
    is in use by another program" instead of both reading each other's replies. Where the OS
    allows (Linux serial drivers), it asks for low latency (:attr:`low_latency`), which FTDI
    adapters honour by lowering their latency timer to 1 ms; where it cannot and the timer is
    higher, a warning says how to lower it.
    """

    def __init__(self, device: str, baudrate: int = 57600, *, latency: float | None = None,
                 echo: bool | None = None) -> None:
        import serial  # pyserial

        if not device.startswith(("COM", "\\\\.\\")) and not os.path.exists(device):
            raise ConfigError(f"serial port {device!r} does not exist; list ports with "
                              "'python -m serial.tools.list_ports' or start an emulated bus "
                              "with 'servolab sim --pty'")
        try:
            self._serial = serial.Serial(device, baudrate=baudrate, timeout=0,
                                         write_timeout=1.0, exclusive=True)
        except (serial.SerialException, ValueError, OSError) as exc:
            if _is_in_use(exc):
                raise in_use(device) from None
            raise ConfigError(f"cannot open serial port {device!r} at {baudrate} bps: "
                              f"{exc}") from None
        self._timeout: float | None = 0.0  # what pyserial's timeout is set to
        #: the (non-blocking) descriptor pyserial opened, on POSIX; None elsewhere
        self._fd: int | None = None
        #: waits for it to be readable: poll, not select, which fails for descriptors from
        #: 1024 on (FD_SETSIZE), as a process with many files open has
        self._poll: Any = None
        self._watch()
        self.name = device
        self.baudrate = int(baudrate)
        self.clock = WallClock()
        self.echo = self._echo_given = echo
        #: whether the driver took the request for low latency (:meth:`_ask_low_latency`)
        self.low_latency = self._ask_low_latency()
        timer = usb_latency_timer(device)
        warning = latency_warning(device, timer)
        if warning:
            log.warning(warning)
        self.latency = latency if latency is not None else (
            timer / 1000.0 if timer is not None else 0.016)

    @property
    def label(self) -> str:
        return f"serial port {self.name}"

    def _watch(self) -> None:
        """Wait on the descriptor pyserial opened (POSIX)."""
        self._fd = getattr(self._serial, "fd", None)
        if self._fd is not None:
            import select

            self._poll = select.poll()
            self._poll.register(self._fd, select.POLLIN)

    def _unwatch(self) -> None:
        if self._poll is not None and self._fd is not None:
            with contextlib.suppress(KeyError, ValueError, OSError):
                self._poll.unregister(self._fd)
        self._poll = self._fd = None

    def _ask_low_latency(self) -> bool:
        """Ask the serial driver for low latency (pyserial's ``set_low_latency_mode``, the
        ASYNC_LOW_LATENCY flag, Linux only), which FTDI adapters (U2D2, USB2Dynamixel) honour
        by setting their latency timer to 1 ms. True where it took; a port that has no such
        setting (a pty, another OS) refuses it, which changes nothing."""
        return _ask_low_latency(self._serial, self.name)

    def _reopen(self) -> None:
        self._unwatch()
        with contextlib.suppress(*_io_errors()):
            self._serial.close()
        try:
            self._serial.open()   # by the same name, with the same settings and lock
        except OSError as exc:
            if _is_in_use(exc):
                raise in_use(self.name) from None
            raise
        self._watch()
        self.low_latency = self._ask_low_latency()

    def _gone_detail(self, again: BaseException) -> str:
        if not self.name.startswith(("COM", "\\\\.\\")) and not os.path.exists(self.name):
            return f"{self.name} does not exist"
        return super()._gone_detail(again)

    def _failed(self, what: str, exc: BaseException) -> PortError:
        """The error for an I/O error of the port (EIO once a USB adapter is unplugged): one
        line naming the port and what to do."""
        return port_failed(f"serial port {self.name}", what, exc,
                           "was the adapter unplugged or the device closed? Check the cable "
                           "and the port, then open it again")

    def _write(self, data: bytes) -> None:
        # No flush() (tcdrain) after the write: it would block until the last byte has left
        # the UART, which only matters to a controller that switches the half-duplex line's
        # direction itself ("When changing the direction, the TXD_SHIFT_REGISTER_EMPTY_BIT
        # must be checked", e-Manual, Protocol 1.0, Tx/Rx Direction). The USB adapters do that
        # in hardware (the U2D2's and USB2Dynamixel's FTDI chip drives the direction pin from
        # its own transmitter), the reply cannot come before the request has left anyway, and
        # the read timeout counts the request's wire time. The ROBOTIS SDK does not drain
        # either (PortHandler.writePort is ser.write alone); on a USB adapter tcdrain costs a
        # round trip to the chip, up to a USB frame (1 ms), per transaction.
        fd = self._fd
        if fd is not None:
            try:
                sent = os.write(fd, data)
            except BlockingIOError:
                sent = 0
            if sent == len(data):
                return
            data = data[sent:]  # the kernel's buffer is full: let pyserial wait for room
        self._serial.write(bytes(data))

    def _read(self, size: int, timeout: float) -> bytes:
        fd = self._fd
        if fd is None:
            timeout = max(0.0, timeout)
            if timeout != self._timeout:  # setting it reconfigures the port: only on change
                self._serial.timeout = self._timeout = timeout
            return bytes(self._serial.read(size))
        try:
            data = os.read(fd, size)
        except (BlockingIOError, InterruptedError):
            data = b""
        if len(data) >= size or timeout <= 0:
            return data
        buf = bytearray(data)
        deadline = time.monotonic() + timeout
        while len(buf) < size:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            if not self._poll.poll(left * 1000.0):
                break
            try:
                chunk = os.read(fd, size - len(buf))
            except (BlockingIOError, InterruptedError):
                continue
            if not chunk:
                # as pyserial: a descriptor that is ready but reads nothing is gone
                raise OSError(errno.EIO, "the device reports data to read but gives none")
            buf += chunk
        return bytes(buf)

    def reset_input(self) -> None:
        self._held = self._echo_of = b""
        self._redo("discarding its input", self._serial.reset_input_buffer)

    def set_baudrate(self, baudrate: int) -> None:
        def set_rate() -> None:
            self._serial.baudrate = int(baudrate)

        self._redo(f"setting {int(baudrate)} bps", set_rate)
        self.baudrate = int(baudrate)

    def close(self) -> None:
        self._unwatch()
        self._serial.close()


class PyserialPort(DevicePort):
    """A port pyserial opens from one of its URLs, read and written through pyserial itself:
    ``spy://DEVICE?file=LOG`` (a serial device, every byte each way logged as a hex dump),
    ``socket://HOST:PORT`` (a raw TCP serial server such as ser2net), ``rfc2217://HOST:PORT``
    (a Telnet COM-port server), ``loop://``, ``hwgrep://``, ``alt://`` and any handler added to
    ``serial.protocol_handler_packages``. These have no descriptor to poll, or one that must
    not be bypassed (a spy would log nothing), so unlike :class:`SerialPort` they use
    pyserial's ``read`` and ``write``.

    pyserial's read timeout is set once, at open, to :attr:`SLICE`, and never per read:
    pyserial applies a port's whole configuration whenever its timeout changes, which is a
    tcsetattr on a spy's device and a round of RFC 2217 negotiation over the network (50 ms or
    more) on ``rfc2217://``. A read that may wait longer is several pyserial reads; it
    returns as soon as its bytes are there, and at most one slice after its deadline.
    ``latency`` (s) defaults to the device's FTDI latency timer behind ``spy://`` or
    ``hwgrep://`` (as :class:`SerialPort`), 0 on ``loop://``, and 16 ms (an FTDI adapter's
    default) behind a network server, whose adapter this end cannot see.

    As :class:`SerialPort`, it asks pyserial for an exclusive lock where the handler has one
    (a serial device behind ``spy://`` or ``hwgrep://``) and for low latency on a serial
    device, learns an echo from the first instruction (``echo``; not on ``loop://``, whose
    reading back what is written is its point), and reopens a port lost under it.
    """

    #: pyserial's read timeout (s): the longest one pyserial read waits
    SLICE = 0.001
    reopens = False
    #: a port's latency where it cannot be known (s)
    UNKNOWN_LATENCY = 0.016

    def __init__(self, url: str, baudrate: int = 57600, *, latency: float | None = None,
                 echo: bool | None = None) -> None:
        import serial  # pyserial

        self.name = url
        self.baudrate = int(baudrate)
        self.clock = WallClock()
        loop = url.lower().startswith("loop://")
        self.echo = self._echo_given = False if loop and echo is None else echo
        ser: Any = None
        try:
            ser = serial.serial_for_url(url, do_not_open=True)
            ser.baudrate = self.baudrate
            ser.timeout = self.SLICE
            ser.exclusive = True
            # rfc2217:// refuses a write timeout (NotImplementedError) after connecting
            ser.write_timeout = None if url.lower().startswith("rfc2217://") else 1.0
            try:
                ser.open()
            except NotImplementedError:  # another handler without a write timeout
                ser.write_timeout = None
                ser.open()
        except (serial.SerialException, ValueError, OSError) as exc:
            if ser is not None:
                _close_spy_log(ser)
            if _is_in_use(exc):
                raise in_use(url) from None
            raise ConfigError(f"cannot open port {url!r} at {baudrate} bps: {exc}") from None
        self._serial: Any = ser
        #: the serial device behind the URL (spy://, hwgrep://), else None
        self._device = ser.port if getattr(ser, "fd", None) is not None else None
        #: whether the serial driver took the request for low latency (see SerialPort)
        self.low_latency = (_ask_low_latency(ser, url) if self._device is not None
                            else False)
        if latency is None:
            if self._device is not None:  # a serial device after all (spy://, hwgrep://)
                timer = usb_latency_timer(self._device)
                warning = latency_warning(self._device, timer)
                if warning:
                    log.warning(warning)
                latency = timer / 1000.0 if timer is not None else self.UNKNOWN_LATENCY
            else:
                latency = 0.0 if loop else self.UNKNOWN_LATENCY
        self.latency = latency

    def _reopen(self) -> None:
        ser = self._serial
        with contextlib.suppress(*_io_errors()):
            ser.close()
        try:
            ser.open()
        except OSError as exc:
            if _is_in_use(exc):
                raise in_use(self.name) from None
            raise
        if self._device is not None:
            self.low_latency = _ask_low_latency(ser, self.name)

    def _failed(self, what: str, exc: BaseException) -> PortError:
        return port_failed(f"port {self.name}", what, exc,
                           "was the connection closed, the server stopped or the adapter "
                           "unplugged? Check it, then open the port again")

    def _write(self, data: bytes) -> None:
        self._serial.write(bytes(data))

    def _read(self, size: int, timeout: float) -> bytes:
        ser = self._serial
        if timeout <= 0:
            return self._drain(size)
        deadline = time.monotonic() + timeout
        buf = bytearray()
        while True:
            # returns when the bytes asked for are there, or after one slice
            buf += ser.read(size - len(buf))
            if len(buf) >= size or time.monotonic() >= deadline:
                return bytes(buf)

    def _drain(self, size: int) -> bytes:
        """What has been received, up to ``size`` bytes, without waiting."""
        ser = self._serial
        buf = bytearray()
        while len(buf) < size:
            waiting = ser.in_waiting  # (a socket:// port says 1 while there is any)
            if not waiting:
                break
            chunk = ser.read(min(waiting, size - len(buf)))
            if not chunk:
                break
            buf += chunk
        return bytes(buf)

    def reset_input(self) -> None:
        # What has come so far is read and dropped here, not by pyserial's
        # reset_input_buffer: on rfc2217:// that asks the server to purge, a network round
        # trip before every transaction, and a spy would log each call.
        self._held = self._echo_of = b""
        self._redo("discarding its input", lambda: self._drain(1 << 16))

    def set_baudrate(self, baudrate: int) -> None:
        def set_rate() -> None:
            self._serial.baudrate = int(baudrate)

        try:
            self._redo(f"setting {int(baudrate)} bps", set_rate)
        except ValueError as exc:
            raise ConfigError(f"port {self.name}: {exc}") from None
        self.baudrate = int(baudrate)

    def close(self) -> None:
        try:
            self._serial.close()
        finally:
            _close_spy_log(self._serial)


def _ask_low_latency(ser: Any, name: str) -> bool:
    """Ask the serial driver of pyserial port ``ser`` for low latency
    (``set_low_latency_mode``: the ASYNC_LOW_LATENCY flag, Linux only; FTDI adapters honour it
    by setting their latency timer to 1 ms). True where it took; a port without that setting
    (a pty, a USB CDC device, another OS) refuses it, which changes nothing."""
    if not sys.platform.startswith("linux"):
        return False
    refusals: tuple[type[Exception], ...] = (ValueError, NotImplementedError, AttributeError,
                                             *_io_errors())
    try:
        ser.set_low_latency_mode(True)
    except refusals as exc:
        log.debug("%s: no low-latency mode (%s)", name, exc)
        return False
    return True


def _close_spy_log(ser: Any) -> None:
    """Close the log file pyserial's ``spy://...?file=LOG`` opened: its port's close leaves it
    open."""
    output = getattr(getattr(ser, "formatter", None), "output", None)
    if output is not None and output not in (sys.stdout, sys.stderr, sys.__stdout__,
                                             sys.__stderr__):
        with contextlib.suppress(OSError, ValueError):
            output.close()


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


#: replies whose lateness a :class:`PtyServer` keeps (the latest)
LATENESS_KEPT = 100_000
#: The SCHED_FIFO priority a :class:`PtyServer` asks for with ``realtime``: above every
#: ordinary process, below the kernel's own real-time threads (50) and audio servers (20+).
REALTIME_PRIORITY = 10


def quantile(ordered: list[float], q: float) -> float:
    """The ``q`` quantile of the sorted ``ordered`` (nearest rank, as a percentile is read
    off a sorted list)."""
    return ordered[min(len(ordered) - 1, max(0, math.ceil(q * len(ordered)) - 1))]


def realtime_thread(native_id: int, priority: int = REALTIME_PRIORITY) -> bool:
    """Put thread ``native_id`` (its ``threading.Thread.native_id``) at real-time priority
    (SCHED_FIFO), where the OS allows; True where it did. Linux schedules each thread on its
    own; elsewhere, or without the right, nothing changes."""
    try:
        os.sched_setscheduler(native_id, os.SCHED_FIFO, os.sched_param(priority))
    except (OSError, AttributeError):
        return False
    return True


def _readable_waiter(*fds: int) -> Callable[[float | None], bool]:
    """A function that waits up to ``timeout`` s (None: for ever) for one of ``fds`` to be
    readable and says whether the first one is.

    Timed to the microsecond: select() where every descriptor is below FD_SETSIZE (1024),
    not poll() or epoll(), whose millisecond timeouts Python rounds up (a reply due in
    0.3 ms would wait 1 ms). Above it (select fails there, as a process with many files open
    has), poll() for the whole milliseconds and a sleep for the rest, during which bytes
    that come are seen at its end."""
    import select

    first = fds[0]
    if max(fds) < 1024:
        watched = list(fds)

        def wait_select(timeout: float | None) -> bool:
            return first in select.select(watched, [], [], timeout)[0]

        return wait_select
    poller = select.poll()
    for fd in fds:
        poller.register(fd, select.POLLIN)

    def wait_poll(timeout: float | None) -> bool:
        if timeout is None:
            return any(fd == first for fd, _ in poller.poll())
        whole = math.floor(timeout * 1000.0)
        ready = poller.poll(whole)
        if not ready and timeout * 1000.0 > whole:
            time.sleep(timeout - whole / 1000.0)
            ready = poller.poll(0)
        return any(fd == first for fd, _ in ready)

    return wait_poll


class PtyServer:
    """Serve a device (an emulated bus) on a pseudo-terminal, so any serial client can talk to
    it.

    The client opens :attr:`device` as a serial port. Replies are timed on ``clock``, which
    must run at wall speed (a :class:`servolab.sim.Simulation` in real time, whose thread steps
    the motors; ``lock`` is held while the device answers, so the two never meet halfway).
    When the client sets a standard line speed that no motor can understand (beyond 3 %),
    motors stay silent, as they would on a real wire; ``line_baud`` overrides what the client
    set.

    The wire is modelled at the client's line speed: the client's bytes go onto it when they
    arrive (or when the bytes before them have left it) and take 10 bits each, and each reply
    is written to the pty whole when its last byte has crossed the wire (``reply.start`` plus
    its wire time), never earlier. Whole, not byte by byte: a USB adapter hands received bytes
    to the host in packets anyway, and a thread woken once per byte would add as much jitter
    (about 0.1 ms) as a byte lasts at 57600 bps. The bus is half duplex: a reply not yet
    finished when the client starts sending again collides with the client's bytes and is
    lost (:attr:`replies_lost`). Bytes the client leaves unread beyond the pty's buffer are
    dropped (:attr:`bytes_overflowed`), as by a UART whose FIFO is full; the server never
    blocks on the client, which may close the port and open it again at any time.

    **On time.** One thread reads the client's bytes, answers as soon as they arrive (the
    device's reply is computed then, under ``lock``) and hands each reply over when it is
    due, waiting for that moment to the microsecond (:func:`_readable_waiter`).
    :attr:`lateness` records how late each was handed over, :meth:`reply_lateness` sums it
    up. What is left on a busy machine is the OS waking the thread late: ``realtime`` asks
    for a real-time thread (SCHED_FIFO at :data:`REALTIME_PRIORITY`, granted to root, to
    CAP_SYS_NICE and within RLIMIT_RTPRIO; :attr:`realtime` says whether it was), which no
    ordinary process delays.
    """

    def __init__(self, emulator: Device, baudrate: int, *, link: str | Path | None = None,
                 clock: Clock | None = None,
                 lock: AbstractContextManager[Any] | None = None,
                 realtime: bool = False) -> None:
        import pty
        import termios
        import tty

        self.emulator = emulator
        self.baudrate = int(baudrate)
        self.clock: Clock = clock or WallClock()
        self._lock = lock if lock is not None else nullcontext()
        self._master, self._slave = pty.openpty()
        tty.setraw(self._slave, termios.TCSANOW)
        os.set_blocking(self._master, False)
        # Our own end of the slave stays open, so the master never sees the client hang up.
        self.device = os.ttyname(self._slave)
        self.link = Path(link) if link else None
        if self.link:
            if self.link.is_symlink() or self.link.exists():
                self.link.unlink()
            self.link.symlink_to(self.device)
        #: replies lost because the client was sending when they were on the wire
        self.replies_lost = 0
        #: reply bytes dropped because the client did not read them
        self.bytes_overflowed = 0
        #: how late each reply was handed to the pty (s after its last byte crossed the
        #: modelled wire), the latest :data:`LATENESS_KEPT`: what :meth:`reply_lateness`
        #: sums up
        self.lateness: deque[float] = deque(maxlen=LATENESS_KEPT)
        self._stop = threading.Event()
        self._wake_r, self._wake_w = os.pipe()  # close() wakes the server through it
        self._thread = threading.Thread(target=self._run, name="pty-emulator", daemon=True)
        self._fds_lock = threading.Lock()
        self._fds_closed = False
        self._realtime_wanted = realtime
        #: whether the serving thread runs at real-time priority (asked with ``realtime``)
        self.realtime = False

    def start(self) -> PtyServer:
        # What the first answer computes once and keeps, computed now rather than while a
        # client waits for it (Protocol 2.0's CRC table: some 10 ms).
        proto = getattr(self.emulator, "protocol", None)
        if proto is not None and hasattr(proto, "encode_instruction"):
            proto.encode_instruction(proto.ping(1))
        self._thread.start()
        if self._realtime_wanted and self._thread.native_id is not None:
            self.realtime = realtime_thread(self._thread.native_id)
        return self

    def reply_lateness(self) -> dict[str, float | int | None]:
        """How late the replies were handed to the pty, of the latest
        :data:`LATENESS_KEPT`: their number, median, 99th percentile and maximum, in ms
        (None before the first)."""
        late = sorted(self.lateness.copy())
        if not late:
            return {"replies": 0, "p50_ms": None, "p99_ms": None, "max_ms": None}
        return {"replies": len(late), "p50_ms": round(quantile(late, 0.5) * 1e3, 3),
                "p99_ms": round(quantile(late, 0.99) * 1e3, 3),
                "max_ms": round(late[-1] * 1e3, 3)}

    #: how long after a device's idle deadline the server tells it the line stayed silent
    _IDLE_MARGIN = 1e-3

    def _run(self) -> None:
        try:
            self._serve()
        finally:
            if self._stop.is_set():  # close() may have given up waiting for this thread
                self._close_fds()

    def _serve(self) -> None:
        import heapq
        import itertools

        master = self._master
        wait = _readable_waiter(master, self._wake_r)
        # (time the reply's last byte has crossed the wire, order, bytes)
        pending: list[tuple[float, int, bytes]] = []
        order = itertools.count()
        wire_end = -math.inf   # when the client's bytes so far have left the wire
        idle = getattr(self.emulator, "idle", None)
        clock, late = self.clock, self.lateness
        while not self._stop.is_set():
            now = clock.now()
            wake = pending[0][0] if pending else math.inf
            idle_at = getattr(self.emulator, "idle_deadline", None)
            if idle is not None and idle_at is not None:
                if idle_at + self._IDLE_MARGIN <= now:
                    with self._lock:
                        idle(now)   # the line stayed silent: drop a partial packet
                    idle_at = getattr(self.emulator, "idle_deadline", None)
                if idle_at is not None and idle_at + self._IDLE_MARGIN > now:
                    wake = min(wake, idle_at + self._IDLE_MARGIN)
            try:
                readable = wait(None if wake == math.inf else max(0.0, wake - now))
            except (OSError, ValueError):
                return
            if self._stop.is_set():
                return
            arrival = clock.now()      # the best time the client's bytes are known by
            while pending and pending[0][0] <= arrival:
                due, _, payload = heapq.heappop(pending)
                late.append(clock.now() - due)     # (counted before the client can read it)
                self._write(payload)
            if not readable:
                continue
            try:
                data = os.read(master, 4096)
            except BlockingIOError:
                continue
            except OSError:  # EIO: no one has the slave open (not while we hold it)
                self._stop.wait(0.05)
                continue
            if not data:
                self._stop.wait(0.05)
                continue
            baud = self.line_baud()
            tick = byte_time(baud)
            sent = max(arrival, wire_end)
            wire_end = sent + len(data) * tick
            if any(p[0] > sent for p in pending):
                kept = [p for p in pending if p[0] <= sent]
                self.replies_lost += len(pending) - len(kept)
                pending[:] = kept
                heapq.heapify(pending)
            with self._lock:
                replies = self.emulator.receive(data, wire_end, baud)
            for reply in replies:
                payload = bytes(reply.data)
                heapq.heappush(pending, (reply.start + len(payload) * tick, next(order),
                                         payload))

    def _write(self, data: bytes) -> None:
        try:
            written = os.write(self._master, data)
        except OSError:     # full (the client reads nothing) or gone
            written = 0
        self.bytes_overflowed += len(data) - written

    def line_baud(self) -> int:
        """The line speed the client set on its end, or our own rate if it cannot be told."""
        return client_line_speed(self._slave) or self.baudrate

    def close(self) -> None:
        if self._stop.is_set():
            return          # closed already: its descriptors may belong to others by now
        self._stop.set()
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"x")
        if self._thread.is_alive():
            self._thread.join(timeout=1.0)
        if self._thread.is_alive():
            # Still in the device (e.g. a slow emulator step): its descriptors stay open until
            # it sees the stop and closes them itself (_run), never under it, where their
            # numbers may already belong to files opened since.
            log.warning("pty server %s: the serving thread did not stop within 1 s; it "
                        "closes the pty when it does", self.device)
        else:
            self._close_fds()
        if self.link and self.link.is_symlink():
            self.link.unlink()

    def _close_fds(self) -> None:
        with self._fds_lock:
            if self._fds_closed:
                return
            self._fds_closed = True
            for fd in (self._master, self._slave, self._wake_r, self._wake_w):
                with contextlib.suppress(OSError):
                    os.close(fd)

    def __enter__(self) -> PtyServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()


@functools.cache
def _standard_speeds() -> dict[int, int]:
    """termios speed code (``termios.B57600``, ...) -> bps, built once."""
    import termios

    speeds: dict[int, int] = {}
    for name in dir(termios):
        if name.startswith("B") and name[1:].isdigit():
            speeds.setdefault(getattr(termios, name), int(name[1:]))
    return speeds


def client_line_speed(fd: int) -> int | None:
    """Speed set on a terminal (e.g. by pyserial on the pty's client side), in bps."""
    import termios

    try:
        attrs = termios.tcgetattr(fd)
    except termios.error:
        return None
    bps = _standard_speeds().get(attrs[5])
    if bps is not None:
        return bps
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


def pyserial_schemes() -> list[str]:
    """The URL schemes pyserial's ``serial_for_url`` has a handler for (``spy``, ``socket``,
    ``rfc2217``, ``loop``, ...), found as pyserial finds them: a ``protocol_<scheme>`` module
    in a package of ``serial.protocol_handler_packages``. Empty without pyserial."""
    try:
        import serial
    except ImportError:
        return []
    found: set[str] = set()
    for package in serial.protocol_handler_packages:
        try:
            paths = importlib.import_module(package).__path__
        except (ImportError, AttributeError):
            continue
        found.update(info.name.removeprefix("protocol_") for info in pkgutil.iter_modules(paths)
                     if info.name.startswith("protocol_"))
    return sorted(found)


def open_port(url: str, baudrate: int | None = None, **options: Any) -> Port:
    """Open a port by name: a serial device (``/dev/ttyUSB0``, ``COM3``, a pty path) or a URL:
    ``emu://rx28:11-16`` for emulated motors, or any URL pyserial opens (``spy://DEVICE``,
    ``socket://HOST:PORT``, ``rfc2217://HOST:PORT``, ``loop://``; :class:`PyserialPort`).
    ``baudrate`` None: 57600 on a serial port or a pyserial URL, the motors' own rate on an
    emulated bus. ``options`` go to the URL's handler (for ``emu://``: ``simulation``,
    ``faults``) or to the port class (``latency``)."""
    scheme, sep, rest = url.partition("://")
    if not sep:
        return SerialPort(url, baudrate or DEFAULT_BAUDRATE, **options)
    target = URL_SCHEMES.get(scheme)
    if target is None:
        theirs = pyserial_schemes()
        if scheme.lower() in theirs:
            return PyserialPort(url, baudrate or DEFAULT_BAUDRATE, **options)
        known = ", ".join(f"{s}://" for s in [*URL_SCHEMES, *theirs])
        raise ConfigError(f"port {url!r}: unknown scheme {scheme!r}; use a serial device "
                          f"such as /dev/ttyUSB0 or {known}")
    module_name, _, function = target.partition(":")
    opener: Callable[..., Port] = getattr(importlib.import_module(module_name), function)
    return opener(rest, baudrate, **options)
