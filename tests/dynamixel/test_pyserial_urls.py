"""pyserial's URLs as ports: ``socket://`` to a TCP serial server, ``spy://`` on a serial
device with every byte logged, ``loop://``; through :class:`Bus.open` and ``--port``.

Facts checked, and where they come from:

- pyserial's URL handlers (pyserial 3.5 docs, "URL Handlers"; serial/urlhandler/): ``socket://
  HOST:PORT`` is a raw TCP connection to a serial server; ``rfc2217://HOST:PORT`` a Telnet
  COM-port server (RFC 2217), whose settings the client negotiates (serial/rfc2217.py:
  ``_reconfigure_port`` sends SET-BAUDRATE and the others and waits for the server's
  answers; the server's ``PortManager`` applies them to its serial port; data bytes 0xFF are
  doubled as Telnet IAC); ``spy://PORT?file=LOG`` wraps a serial port and writes a hex dump of
  every TX and RX to LOG; ``loop://`` reads back what was written. Setting a pyserial port's
  ``timeout`` reconfigures the port (serialutil.py, ``SerialBase.timeout``: "if
  self.is_open: self._reconfigure_port()"), which is why the port sets it once
  (docs/layout.md).
- ROBOTIS e-Manual, Protocol 1.0, instruction examples: PING of ID 1 is ``FF FF 01 02 01 FB``
  and its status ``FF FF 01 02 00 FC``; reading the internal temperature of ID 1 (address
  0x2B, 1 byte) is ``FF FF 01 04 02 2B 01 CC`` and the status carries the value in one byte
  with the checksum ``~(ID + LENGTH + ERROR + value)``.
- e-Manual, RX-28: model number 28 (PING's model), Present Temperature at address 43 (0x2B).
"""

from __future__ import annotations

import os
import pty
import re
import select
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from serial import rfc2217
from serial.urlhandler.protocol_loop import Serial as LoopSerial

from servolab.dynamixel.bus import Bus
from servolab.dynamixel.errors import ConfigError, NoResponse, PortError
from servolab.dynamixel.ports import PyserialPort, SerialPort, open_port, pyserial_schemes
from servolab.sim.emulated import emulated_port
from tests.clirun import servolab
from tests.simproc import sim_process
from tests.waiting import wait_for

PING_1 = bytes.fromhex("FF FF 01 02 01 FB")            # e-Manual, Protocol 1.0, PING
PING_1_STATUS = bytes.fromhex("FF FF 01 02 00 FC")
READ_TEMPERATURE_1 = bytes.fromhex("FF FF 01 04 02 2B 01 CC")  # e-Manual, READ example


def _status_1(value: int) -> bytes:
    """Protocol 1.0 status of ID 1, no error, one byte of data (e-Manual checksum)."""
    return bytes([0xFF, 0xFF, 1, 3, 0, value, ~(1 + 3 + 0 + value) & 0xFF])


class BaudSink(LoopSerial):
    """An RFC 2217 server's serial port for its settings only (the data goes to the emulated
    bus): records every baud rate set on it."""

    def __init__(self) -> None:
        self.rates: list[int] = []
        super().__init__("loop://")

    @property
    def baudrate(self) -> int:
        return int(self._baudrate)

    @baudrate.setter
    def baudrate(self, value: int) -> None:
        self.rates.append(int(value))
        LoopSerial.baudrate.fset(self, value)  # type: ignore[attr-defined]


class _Connection:
    """What pyserial's rfc2217.PortManager writes its Telnet answers to."""

    def __init__(self, conn: socket.socket) -> None:
        self.conn = conn

    def write(self, data: bytes) -> None:
        self.conn.sendall(data)


class TcpSerialServer:
    """A raw TCP serial server (what ser2net or an ESP-Link serves) with emulated motors on
    its far side: the bytes of each connection go into an emulated bus, its answers come back.
    The bus is a MemoryPort to an Emulator on its own simulation's clock (see
    servolab.sim.emulated), driven from this server's thread only. ``rfc2217`` serves RFC
    2217 (Telnet COM-port control) with pyserial's own server side, ``PortManager``, whose
    port settings land in :attr:`sink`."""

    def __init__(self, spec: str, baudrate: int, *, rfc2217: bool = False) -> None:
        self.bus_port = emulated_port(spec, baudrate)
        self.listener = socket.create_server(("127.0.0.1", 0))
        self.address = self.listener.getsockname()[:2]
        self.url = (f"{'rfc2217' if rfc2217 else 'socket'}://{self.address[0]}:"
                    f"{self.address[1]}")
        self.rfc2217 = rfc2217
        self.sink = BaudSink()
        self.received = bytearray()   # what clients sent
        self.sent = bytearray()       # what the motors answered
        self.connections = 0
        self._wake_r, self._wake_w = socket.socketpair()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name="tcp-serial", daemon=True)

    def __enter__(self) -> TcpSerialServer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake_w.send(b"x")
        self._thread.join(timeout=10)
        assert not self._thread.is_alive(), "the TCP serial server's thread did not stop"
        for s in (self.listener, self._wake_r, self._wake_w):
            s.close()
        self.sink.close()

    def _serve(self) -> None:
        clients: list[socket.socket] = []
        managers: dict[socket.socket, rfc2217.PortManager] = {}
        try:
            while not self._stop.is_set():
                ready, _, _ = select.select([self.listener, self._wake_r, *clients], [], [])
                if self._wake_r in ready:
                    return
                if self.listener in ready:
                    conn, _ = self.listener.accept()
                    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    clients.append(conn)
                    self.connections += 1
                    if self.rfc2217:  # (it opens the Telnet negotiation at once)
                        managers[conn] = rfc2217.PortManager(self.sink, _Connection(conn))
                for conn in [c for c in clients if c in ready]:
                    data = conn.recv(4096)
                    if not data:  # the client closed the port
                        clients.remove(conn)
                        conn.close()
                        continue
                    manager = managers.get(conn)
                    if manager is not None:  # Telnet: options out, 0xFF 0xFF -> 0xFF
                        data = b"".join(manager.filter(data))
                    if not data:
                        continue
                    self.received += data
                    self.bus_port.write(data)
                    # the answers, on the emulated bus's own (virtual) time: no wall time
                    answer = self.bus_port.read(1 << 16, 0.01)
                    if answer:
                        self.sent += answer
                        conn.sendall(answer if manager is None
                                     else b"".join(manager.escape(answer)))
        finally:
            for conn in clients:
                conn.close()


@pytest.fixture
def tcp_rx28() -> Iterator[TcpSerialServer]:
    with TcpSerialServer("rx28:1-3", 57600) as server:
        yield server


@pytest.fixture(scope="module")
def rx28_pty(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """``servolab sim --pty`` with three RX-28 (IDs 1..3) at 57600 bps, stopped at the end."""
    out = tmp_path_factory.mktemp("sim")
    with sim_process("--motors", "rx28:1-3", "--baud", "57600", out_dir=out) as (device, _):
        # the sim prints its device before it is sure to answer: the first PINGs right after
        # its start can go unanswered (seen with a plain SerialPort too); wait until it does
        wait_for(lambda: _answers(device), f"servolab sim on {device} to answer a PING",
                 timeout=20.0)
        yield device


def _answers(device: str) -> bool:
    with Bus.open(device, protocol=1, baudrate=57600, retries=0) as bus:
        try:
            bus.ping(1)
        except NoResponse:
            return False
    return True


def _spy_log(path: Path) -> dict[str, bytes]:
    """The bytes each way in a spy:// log (pyserial's FormatHexdump: "TIME TX   0000  FF FF
    ..."), each direction's lines joined in order."""
    streams = {"TX": bytearray(), "RX": bytearray()}
    for line in path.read_text().splitlines():
        m = re.match(r"^\S+ (TX|RX)\s+[0-9A-F]{4}  (.{1,49})", line)
        if m:
            streams[m[1]] += bytes.fromhex(m[2])
    return {k: bytes(v) for k, v in streams.items()}


# -- opening -----------------------------------------------------------------------------------


def test_pyserial_schemes_go_to_the_pyserial_port_and_devices_stay_serial_ports() -> None:
    assert {"spy", "socket", "rfc2217", "loop"} <= set(pyserial_schemes())
    with open_port("loop://", 57600) as port:
        assert isinstance(port, PyserialPort) and port.latency == 0.0
        port.write(PING_1)
        assert port.read(len(PING_1), 1.0) == PING_1    # loop:// reads back what it wrote
        port.write(b"stale")
        port.reset_input()
        assert port.read(1, 0.01) == b""
    with pytest.raises(ConfigError, match="does not exist"):  # a device path: SerialPort's
        open_port("/dev/ttyUSB_nothing_here")
    with pytest.raises(ConfigError) as info:
        open_port("nosuch://x")
    assert "socket://" in str(info.value) and "emu://" in str(info.value)
    master, slave = pty.openpty()            # a device path that exists: the fast path
    try:
        with open_port(os.ttyname(slave), 57600, latency=0.001) as port:
            assert type(port) is SerialPort
    finally:
        os.close(master)
        os.close(slave)


def test_socket_url_pings_and_reads_through_a_tcp_serial_server(
        tcp_rx28: TcpSerialServer) -> None:
    with Bus.open(tcp_rx28.url, protocol=1, baudrate=57600) as bus:
        assert isinstance(bus.port, PyserialPort)
        found = bus.ping(1)
        assert (found.model_number, found.model_name) == (28, "RX-28")  # e-Manual, RX-28
        assert PING_1 in tcp_rx28.received                             # e-Manual's PING
        bus.write(2, "goal_position", 600, raw=True)
        assert bus.read(2, "goal_position", raw=True) == 600
        temperature = int(bus.read(1, "present_temperature", raw=True))
        assert READ_TEMPERATURE_1 in tcp_rx28.received
        assert tcp_rx28.sent.endswith(_status_1(temperature))
        assert [r.id for r in bus.scan(range(0, 5))] == [1, 2, 3]


def test_pyserial_timeout_is_set_once_not_per_read(tcp_rx28: TcpSerialServer) -> None:
    """Every transaction reads with its own deadline; pyserial's timeout stays as set at
    open (setting it reconfigures the port: serialutil.py, SerialBase.timeout)."""
    with Bus.open(tcp_rx28.url, protocol=1, baudrate=57600) as bus:
        port = bus.port
        assert isinstance(port, PyserialPort)
        serial_port = port._serial
        reconfigured: list[float] = []
        original = serial_port._reconfigure_port

        def counting() -> None:
            reconfigured.append(serial_port.timeout)
            original()

        serial_port._reconfigure_port = counting
        bus.ping(1)
        for motor_id in (1, 2, 3):
            bus.read(motor_id, ["present_position", "present_speed", "present_load"])
        with pytest.raises(NoResponse):
            bus.ping(9, retries=0)  # silence: the read runs to its deadline
        assert reconfigured == []
        assert serial_port.timeout == PyserialPort.SLICE


def test_reading_a_closed_connection_is_a_port_error() -> None:
    """pyserial's socket:// raises SerialException("socket disconnected") once the server has
    closed the connection: the port says so in one line naming the URL."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        host, number = server.getsockname()[:2]
        with open_port(f"socket://{host}:{number}", 57600) as port:
            conn, _ = server.accept()
            conn.close()
            with pytest.raises(PortError) as info:
                port.read(1, 5.0)
            assert f"socket://{host}:{number}" in str(info.value)
            assert "reading failed" in str(info.value) and "\n" not in str(info.value)


def test_a_closed_connection_is_a_port_error_naming_the_url(tcp_rx28: TcpSerialServer) -> None:
    with Bus.open(tcp_rx28.url, protocol=1, baudrate=57600) as bus:
        bus.ping(1)
        tcp_rx28.close()                     # the server goes away
        with pytest.raises(PortError) as info:
            for _ in range(3):               # (a write may still reach the socket's buffer)
                bus.ping(1, retries=0)
        message = str(info.value)
        assert tcp_rx28.url in message and "\n" not in message


# pyserial 3.5's own rfc2217 client calls Thread.setDaemon and setName
@pytest.mark.filterwarnings(r"ignore:set(Daemon|Name)\(\) is deprecated:DeprecationWarning")
def test_rfc2217_url_negotiates_the_baud_rate_once_and_talks_to_the_motors() -> None:
    """Over RFC 2217 the baud rate reaches the server's port (SET-BAUDRATE) at open and when
    the bus changes it, never per read; the packets' 0xFF bytes cross Telnet's escaping."""
    with TcpSerialServer("rx28:1-3", 57600, rfc2217=True) as server, \
            Bus.open(server.url, protocol=1, baudrate=57600) as bus:
        assert isinstance(bus.port, PyserialPort)
        assert server.connections == 1   # opened at once (no write timeout asked of it)
        assert server.sink.baudrate == 57600
        negotiated = len(server.sink.rates)
        assert bus.ping(1).model_number == 28                      # e-Manual, RX-28
        assert PING_1 in server.received
        for motor_id in (1, 2, 3):
            bus.read(motor_id, ["present_position", "present_voltage"])
        with pytest.raises(NoResponse):
            bus.ping(9, retries=0)
        assert len(server.sink.rates) == negotiated                # no renegotiation per read
        bus.port.set_baudrate(1_000_000)
        assert server.sink.baudrate == 1_000_000                   # the server's port follows


# -- spy:// on servolab sim --pty ------------------------------------------------------------


@pytest.mark.slow
def test_spy_url_reads_a_register_and_logs_the_packets(rx28_pty: str, tmp_path: Path) -> None:
    log = tmp_path / "spy.log"
    with Bus.open(f"spy://{rx28_pty}?file={log}", protocol=1, baudrate=57600) as bus:
        assert isinstance(bus.port, PyserialPort)
        temperature = int(bus.read(1, "present_temperature", raw=True))
    assert bus.port._serial.formatter.output.closed   # the log pyserial opened, closed
    streams = _spy_log(log)
    # the bus learnt the model with a PING, then read address 0x2B: the e-Manual's packets
    assert streams["TX"].startswith(PING_1) and READ_TEMPERATURE_1 in streams["TX"]
    assert PING_1_STATUS in streams["RX"]
    assert streams["RX"].endswith(_status_1(temperature))


# -- the command line --------------------------------------------------------------------------


@pytest.mark.slow
def test_cli_read_with_a_spy_url(rx28_pty: str, tmp_path: Path) -> None:
    log = tmp_path / "cli.log"
    result = servolab("read", "--port", f"spy://{rx28_pty}?file={log}", "--protocol", "1",
                      "--baud", "57600", "--id", "1", "present_temperature", "--raw")
    assert result.returncode == 0, result.stderr
    value = int(result.stdout.strip().removeprefix("present_temperature = "))
    streams = _spy_log(log)
    assert READ_TEMPERATURE_1 in streams["TX"]
    assert streams["RX"].endswith(_status_1(value))


@pytest.mark.slow
def test_cli_scan_with_a_socket_url(tcp_rx28: TcpSerialServer, tmp_path: Path) -> None:
    result = servolab("scan", "--port", tcp_rx28.url, "--protocol", "1", "--baud", "57600",
                      "--ids", "0-4", "--out", str(tmp_path))
    assert result.returncode == 0, result.stderr
    assert result.stdout.splitlines()[-1] == "3 motor(s) found"
    rows = [line.split() for line in result.stdout.splitlines()[1:-1]]
    assert [r[:3] for r in rows] == [["1", "RX-28", "28"], ["2", "RX-28", "28"],
                                     ["3", "RX-28", "28"]]
    assert tcp_rx28.connections == 1
