"""The device side in time: what the motors do with bytes that come in pieces and pauses.

The emulator is driven directly with explicit times (no threads), except in the last two
tests, which run the pseudo-terminal server on the wall clock.

Figures and where they come from (see :class:`servolab.dynamixel.emulator.Emulator`):

* Idle timeout, 10 ms: a packet the motors are partway through is dropped after 10 ms of
  silence. ROBOTIS publish no figure for the servos' firmware; the closest ROBOTIS source,
  the device-side parser of Dynamixel2Arduino (src/utility/protocol.cpp, ``rx_timeout =
  500*1000`` µs), uses 500 ms, longer than the SDK's own 34 ms packet timeout. servolab's
  10 ms is under that, so that the SDK's retry after a timeout always starts a fresh packet.
* Broadcast PING (2.0): motor k answers after every lower ID has had its turn: the return
  delay and 14-byte status of an ID that answers, 3 ms of silence for one that does not
  (Dynamixel2Arduino, ``DXL_PROCESS_BROAD_PING``: 3000 µs per ID; the SDK's broadcastPing
  waits 14 bytes x 252 + 3 ms x 252 + 16 ms).
"""

from __future__ import annotations

import os
import time

import pytest
import serial

from servolab.clock import WallClock
from servolab.dynamixel import model
from servolab.dynamixel.emulator import Emulator, Reply, VirtualMotor
from servolab.dynamixel.packets import Protocol
from servolab.dynamixel.ports import PtyServer
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from servolab.dynamixel.wire import byte_time
from tests.waiting import wait_for

BAUD = 57600
TICK = byte_time(BAUD)
IDLE = 0.010                  # Emulator.idle_timeout
RETURN_DELAY = 250 * 2e-6     # factory return_delay_time (250 x 2 µs) of RX-28 and XM430
PING_SLOT = 0.003             # Emulator.ping_slot
T0 = 100.0

#: (protocol, model, a header cut short: a length that swallows what follows)
CASES = {
    1: (PROTOCOL1, "rx28", bytes.fromhex("FF FF 01 40 03")),
    2: (PROTOCOL2, "xm430-w210", bytes.fromhex("FF FF FD 00 01 40 00 03")),
}


def bus(version: int, *ids: int) -> tuple[Emulator, Protocol]:
    proto, name, _ = CASES[version]
    return Emulator(version, [VirtualMotor(model(name), i, baudrate=BAUD) for i in ids]), proto


def send(emulator: Emulator, data: bytes, start: float) -> list[Reply]:
    """The host's bytes, the first starting at ``start``."""
    return emulator.receive(data, start + len(data) * TICK, BAUD)


def ping(proto: Protocol, motor_id: int) -> bytes:
    return proto.encode_instruction(proto.ping(motor_id))


@pytest.mark.parametrize("version", [1, 2])
def test_partial_packet_is_dropped_after_the_idle_timeout(version: int) -> None:
    """Half a packet (a cable plugged in mid-packet), then silence longer than the timeout,
    then a PING: the motor answers the PING once, at its own end plus the return delay."""
    emulator, proto = bus(version, 1)
    cut = CASES[version][2]
    assert send(emulator, cut, T0) == []
    end_of_cut = T0 + len(cut) * TICK
    assert emulator.idle_deadline == pytest.approx(end_of_cut + IDLE)

    start = end_of_cut + IDLE + 1e-4
    replies = send(emulator, ping(proto, 1), start)
    assert len(replies) == 1
    end = start + len(ping(proto, 1)) * TICK
    assert replies[0].start == pytest.approx(end + RETURN_DELAY)
    assert proto.decode_status(replies[0].data).id == 1
    assert emulator.partial_packets_dropped == 1


@pytest.mark.parametrize("version", [1, 2])
def test_within_the_timeout_the_bytes_join_the_partial_packet(version: int) -> None:
    """Less than the timeout apart, the PING is read as the rest of the cut packet (as a real
    motor reads it) and gets no answer; after a silence it is dropped with the junk, and the
    next PING gets exactly one answer: the swallowed one is never answered late."""
    emulator, proto = bus(version, 1)
    cut = CASES[version][2]
    send(emulator, cut, T0)
    start = T0 + len(cut) * TICK + IDLE / 2
    assert send(emulator, ping(proto, 1), start) == []
    emulator.idle(start + IDLE / 2)                 # not yet silent for long enough
    assert emulator.idle_deadline is not None

    later = start + 0.05
    emulator.idle(later)                            # the line stayed silent: dropped
    assert emulator.idle_deadline is None
    replies = send(emulator, ping(proto, 1), later)
    assert [proto.decode_status(r.data).id for r in replies] == [1]


@pytest.mark.parametrize(("version", "short"), [
    (1, bytes.fromhex("FF FF 01 03")),              # ID 1, length 3: 3 more bytes to come
    (2, bytes.fromhex("FF FF FD 00 01 06 00")),     # ID 1, length 6
])
def test_junk_that_ends_inside_the_next_packet_is_resynchronised(version: int,
                                                                  short: bytes) -> None:
    """A short packet whose declared length ends inside the PING that follows, within the
    idle timeout: like a servo's receiver (Dynamixel2Arduino protocol.cpp collects the
    declared length, then checks and goes back to idle), the motor takes the PING's first
    bytes as the rest of the short packet, which fails its checksum/CRC, and looks for a
    header only after it: the PING is lost, as on a real bus, and no stale answer comes
    later. The host's retry, after its own timeout, finds the line idle and is answered."""
    emulator, proto = bus(version, 1)
    replies = send(emulator, short, T0)
    assert replies == []
    start = T0 + len(short) * TICK + IDLE / 2
    assert send(emulator, ping(proto, 1), start) == []
    retry = start + 0.05                       # after the host's timeout: the line was idle
    replies = send(emulator, ping(proto, 1), retry)
    assert len(replies) == 1
    status = proto.decode_status(replies[0].data)
    assert (status.id, status.error) == (1, 0)
    end = retry + len(ping(proto, 1)) * TICK
    assert replies[0].start == pytest.approx(end + RETURN_DELAY)


def test_no_burst_of_answers_to_stale_instructions() -> None:
    """A cut header swallows one PING and half of the next: the motors take all of it as the
    cut packet, whose CRC fails, and lose both PINGs (a servo's receiver looks for a header
    only after a failed packet's end). Nothing is answered late: the next PING, after the
    host's timeout, is answered once, at its own time."""
    emulator, proto = bus(2, 1)
    p = ping(proto, 1)
    header = bytes.fromhex("FF FF FD 00 05 0F 00")   # ID 5 (absent), 15 bytes: ends mid-PING 2
    send(emulator, header, T0)
    t = T0 + len(header) * TICK
    assert send(emulator, p, t + 1e-3) == []
    t += 1e-3 + len(p) * TICK
    assert send(emulator, p, t + 1e-3) == []
    assert emulator.instructions_seen == 0          # neither PING was read
    t += 0.05
    replies = send(emulator, p, t)
    assert len(replies) == 1
    assert replies[0].start == pytest.approx(t + len(p) * TICK + RETURN_DELAY)
    assert emulator.instructions_seen == 1


@pytest.mark.parametrize("version", [1, 2])
def test_of_packets_sent_back_to_back_only_the_last_is_answered(version: int) -> None:
    """A WRITE and a READ in one go: both act, but the WRITE's status would be on the wire
    while the host still sends the READ (half duplex): only the READ is answered."""
    emulator, proto = bus(version, 1)
    address = 30 if version == 1 else 116           # goal_position
    size = 2 if version == 1 else 4
    data = proto.encode_instruction(proto.write(1, address, (700).to_bytes(size, "little")))
    data += proto.encode_instruction(proto.read(1, address, size))
    replies = send(emulator, data, T0)
    assert len(replies) == 1
    status = proto.decode_status(replies[0].data)
    assert int.from_bytes(status.params, "little") == 700
    assert replies[0].start == pytest.approx(T0 + len(data) * TICK + RETURN_DELAY)


def test_partial_packet_at_the_end_of_a_burst_is_dropped_when_the_line_goes_idle() -> None:
    emulator, _ = bus(2, 1)
    send(emulator, CASES[2][2], T0)
    deadline = emulator.idle_deadline
    assert deadline is not None
    emulator.idle(deadline - 1e-6)                  # not quite the timeout
    assert emulator.idle_deadline == deadline
    emulator.idle(deadline + 1e-6)
    assert emulator.idle_deadline is None
    assert emulator.partial_packets_dropped == 1


def expected_ping_starts(ids: set[int], end: float, tick: float) -> dict[int, float]:
    """The broadcast-PING slotting: from the end of the PING, each lower ID in turn costs its
    return delay plus its 14-byte status if present, or PING_SLOT of silence if not."""
    starts = {}
    cursor = end
    for motor_id in range(1, max(ids) + 1):
        if motor_id in ids:
            starts[motor_id] = cursor + RETURN_DELAY
            cursor = starts[motor_id] + 14 * tick
        else:
            cursor += PING_SLOT
    return starts


@pytest.mark.parametrize("baud", [57600, 1_000_000])
@pytest.mark.parametrize("ids", [{1, 2, 3}, {1, 2, 5, 7}, {3, 100, 101}, {252}])
def test_broadcast_ping_replies_are_slotted_by_id(baud: int, ids: set[int]) -> None:
    emulator = Emulator(2, [VirtualMotor(model("xm430-w210"), i, baudrate=baud)
                            for i in sorted(ids, reverse=True)])
    tick = byte_time(baud)
    data = ping(PROTOCOL2, 254)
    end = T0 + len(data) * tick
    replies = emulator.receive(data, end, baud)
    found = {PROTOCOL2.decode_status(r.data).id: r.start for r in replies}
    expected = expected_ping_starts(ids, end, tick)
    assert found == pytest.approx(expected)
    # The replies never overlap, and the last is in before the SDK stops listening.
    ends = [r.start + len(r.data) * tick for r in replies]
    assert all(a <= b for a, b in zip(ends, [r.start for r in replies][1:], strict=False))
    sdk_wait = (14 * 252 * tick + 3e-3 * 252 + 16e-3)
    assert ends[-1] - T0 < sdk_wait


def test_broadcast_ping_for_id_252_alone_waits_251_slots() -> None:
    emulator = Emulator(2, [VirtualMotor(model("xm430-w210"), 252, baudrate=BAUD)])
    data = ping(PROTOCOL2, 254)
    end = T0 + len(data) * TICK
    (reply,) = emulator.receive(data, end, BAUD)
    assert reply.start == pytest.approx(end + 251 * PING_SLOT + RETURN_DELAY)


def test_pty_reply_is_not_readable_before_its_wire_end() -> None:
    """Through the pseudo-terminal on the wall clock: the status's last byte is not there
    before the PING has crossed the wire, the return delay has passed and the status has
    crossed the wire (10 + 14 bytes at 57600 bps, plus 0.5 ms). Measured from before the
    write to after the last byte is read, so a slow machine only makes it longer."""
    emulator = Emulator(2, [VirtualMotor(model("xm430-w210"), 1, baudrate=BAUD)])
    with PtyServer(emulator, BAUD, clock=WallClock()) as server:
        client = serial.Serial(server.device, BAUD, timeout=1.0)
        try:
            data = ping(PROTOCOL2, 1)
            wire = (len(data) + 14) * TICK + RETURN_DELAY
            for _ in range(5):
                client.reset_input_buffer()
                before = time.monotonic()
                client.write(data)
                got = b""
                while len(got) < 14:
                    chunk = client.read(14 - len(got))
                    assert chunk, f"no status; got {got.hex(' ')}"
                    got += chunk
                after = time.monotonic()
                assert PROTOCOL2.decode_status(got).id == 1
                assert after - before >= wire
        finally:
            client.close()


def test_pty_server_drops_a_partial_packet_when_the_line_stays_idle() -> None:
    """A header cut short and then nothing: the server tells the emulator the line went idle,
    and the partial packet is dropped without any further byte arriving."""
    emulator = Emulator(2, [VirtualMotor(model("xm430-w210"), 1, baudrate=BAUD)])
    with PtyServer(emulator, BAUD, clock=WallClock()) as server:
        fd = os.open(server.device, os.O_RDWR | os.O_NOCTTY)
        try:
            os.write(fd, CASES[2][2])
            wait_for(lambda: emulator.partial_packets_dropped == 1,
                     lambda: f"the partial packet dropped; the parser holds "
                             f"{emulator._parser.pending} bytes", timeout=5.0)
        finally:
            os.close(fd)
