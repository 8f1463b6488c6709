"""Every packet our host side sends is the packet the official ROBOTIS ``dynamixel_sdk`` sends.

The SDK's packet handlers are driven through a stand-in port that records what ``writePort``
receives and answers with whatever bytes a test queues, so no hardware is involved. For each
instruction both implement, in both protocols, hypothesis draws IDs, addresses, lengths and
data (often holding FF FF FD, so 2.0 byte stuffing is exercised) within the SDK's own packet
limits, and the two byte strings must be identical. The other direction: the SDK's receiver
must read our status packets back into the same ID, error and parameters.

One correction to the SDK is needed and kept as small as possible: ``dynamixel_sdk`` 4.1.0's
``Protocol2PacketHandler.txPacket`` calls ``self.addStuffing(txpacket)`` and ignores its result.
When stuffing lengthens a packet, ``addStuffing`` builds a new list, so the SDK sends the
*unstuffed* bytes with the unstuffed LEN, contrary to the e-Manual's "Packet Process" (and to the
SDK's own C++ version). ``StuffingSdk2`` keeps the SDK's algorithm and only writes its result
back into the caller's list; ``test_stuffing_fix_changes_nothing_without_ff_ff_fd`` shows it is
a no-op for every packet that needs no stuffing. The same issue was reported against the Python
SDK in strands-labs/robots#2750 and #2802 (its ``removeStuffing`` also loses a byte in rare
payloads; the receive test below accounts for that).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import dynamixel_sdk as sdk
import pytest
from dynamixel_sdk import protocol1_packet_handler as sdk_p1
from dynamixel_sdk import protocol2_packet_handler as sdk_p2
from hypothesis import event, example, given, settings
from hypothesis import strategies as st

from servolab.dynamixel.packets import Instruction, Protocol, Status
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2

FFFFFD = b"\xff\xff\xfd"
V1_TX_MAX = sdk_p1.TXPACKET_MAX_LEN   # 250: the SDK refuses longer 1.0 packets
V1_RX_MAX = sdk_p1.RXPACKET_MAX_LEN   # 250: largest LENGTH byte the SDK accepts
V2_TX_MAX = sdk_p2.TXPACKET_MAX_LEN   # 1024 bytes on the wire, after stuffing

SDK = settings(max_examples=100, deadline=None)


class RecordingPort:
    """Stands in for ``dynamixel_sdk.PortHandler`` (same camelCase methods): keeps what is
    written, replays ``incoming``.

    Every packet timeout has already expired, so a handler waiting for an answer gives up as
    soon as the queued bytes are used up.
    """

    def __init__(self, incoming: bytes = b"") -> None:
        self.written: list[bytes] = []
        self.incoming = bytearray(incoming)
        self.is_using = False
        self.is_open = True
        self.baudrate = 1_000_000
        self.tx_time_per_byte = 0.01
        self.packet_timeout = 0.0

    def clearPort(self) -> None:
        pass

    def writePort(self, packet: Sequence[int]) -> int:
        self.written.append(bytes(packet))  # raises if the SDK built a value outside 0..255
        return len(packet)

    def readPort(self, length: int) -> bytes:
        data = bytes(self.incoming[:length])
        del self.incoming[:length]
        return data

    def getBytesAvailable(self) -> int:
        return len(self.incoming)

    def getBaudRate(self) -> int:
        return self.baudrate

    def setPacketTimeout(self, packet_length: float) -> None:
        self.packet_timeout = packet_length

    def setPacketTimeoutMillis(self, msec: float) -> None:
        self.packet_timeout = msec

    def isPacketTimeout(self) -> bool:
        return True


class StuffingSdk2(sdk.Protocol2PacketHandler):
    """The SDK's 2.0 handler with the result of its own ``addStuffing`` actually sent."""

    def addStuffing(self, packet: list[int]) -> list[int]:
        packet[:] = super().addStuffing(list(packet))
        return packet


SDK1 = sdk.PacketHandler(1.0)
SDK2 = StuffingSdk2()
STOCK_SDK2 = sdk.PacketHandler(2.0)


def sdk_sends(handler: object, call: Callable[[object, RecordingPort], object]) -> bytes:
    """The one packet the SDK writes for ``call(handler, port)``."""
    port = RecordingPort()
    call(handler, port)
    assert len(port.written) == 1, f"the SDK wrote {len(port.written)} packets"
    return port.written[0]


def group_sends(make: Callable[[RecordingPort], object]) -> bytes:
    """The one packet a ``Group*`` object of the SDK writes from its ``txPacket``."""
    port = RecordingPort()
    group = make(port)
    result = group.txPacket()  # type: ignore[attr-defined]
    assert result in (sdk.COMM_SUCCESS, sdk.COMM_RX_TIMEOUT), result
    assert len(port.written) == 1
    return port.written[0]


def v1(instruction: Instruction) -> bytes:
    return PROTOCOL1.encode_instruction(instruction)


def v2(instruction: Instruction) -> bytes:
    return PROTOCOL2.encode_instruction(instruction)


def data(min_size: int = 1, max_size: int = 64) -> st.SearchStrategy[bytes]:
    """Register data, often holding FF FF FD (and FF, FD runs) so stuffing is exercised."""
    piece = st.one_of(st.binary(min_size=1, max_size=8),
                      st.sampled_from([FFFFFD, FFFFFD + b"\xfd", FFFFFD + b"\x00", b"\xff",
                                       b"\xff\xff", b"\xfd"]))
    return (st.lists(piece, min_size=min(1, min_size), max_size=max(1, max_size // 3))
            .map(lambda parts: b"".join(parts)[:max_size])
            .filter(lambda b: len(b) >= min_size))


def block(length: int) -> st.SearchStrategy[bytes]:
    return data(1, length).map(lambda b: (b * length)[:length])


ids_v1 = st.integers(0, 253)
targets_v1 = st.integers(0, 254)               # with broadcast
ids_v2 = st.integers(0, 252)
targets_v2 = st.one_of(ids_v2, st.just(254))
address_v1 = st.integers(0, 0xFF)
address_v2 = st.one_of(st.integers(0, 0xFFFF), st.sampled_from([0xFFFF, 0xFDFF, 0xFFFD]))
length_v1 = st.integers(1, 0xFF)
length_v2 = st.one_of(st.integers(1, 0xFFFF), st.sampled_from([0xFD, 0xFFFF, 0xFDFF]))


# -- Protocol 1.0 ------------------------------------------------------------------------------

@SDK
@given(motor_id=ids_v1)
def test_v1_ping(motor_id: int) -> None:
    sent = sdk_sends(SDK1, lambda ph, port: ph.ping(port, motor_id))
    assert v1(PROTOCOL1.ping(motor_id)) == sent


@SDK
@given(motor_id=ids_v1, address=address_v1, length=length_v1)
def test_v1_read(motor_id: int, address: int, length: int) -> None:
    sent = sdk_sends(SDK1, lambda ph, port: ph.readTx(port, motor_id, address, length))
    assert v1(PROTOCOL1.read(motor_id, address, length)) == sent


@SDK
@given(motor_id=targets_v1, address=address_v1, payload=data(1, V1_TX_MAX - 7),
       registered=st.booleans())
def test_v1_write_and_reg_write(motor_id: int, address: int, payload: bytes,
                                registered: bool) -> None:
    def call(ph: sdk.Protocol1PacketHandler, port: RecordingPort) -> int:
        tx = ph.regWriteTxOnly if registered else ph.writeTxOnly
        return tx(port, motor_id, address, len(payload), list(payload))

    sent = sdk_sends(SDK1, call)
    assert v1(PROTOCOL1.write(motor_id, address, payload, registered=registered)) == sent


def test_v1_write_at_the_sdks_length_limit() -> None:
    payload = bytes(range(V1_TX_MAX - 7))
    sent = sdk_sends(SDK1, lambda ph, port: ph.writeTxOnly(port, 1, 0, len(payload),
                                                          list(payload)))
    assert len(sent) == V1_TX_MAX
    assert v1(PROTOCOL1.write(1, 0, payload)) == sent


@SDK
@given(motor_id=targets_v1)
def test_v1_action_and_reset(motor_id: int) -> None:
    assert v1(PROTOCOL1.action(motor_id)) == sdk_sends(
        SDK1, lambda ph, port: ph.action(port, motor_id))
    assert v1(PROTOCOL1.reset(motor_id)) == sdk_sends(
        SDK1, lambda ph, port: ph.factoryReset(port, motor_id))


@st.composite
def sync_write_args(draw: st.DrawFn, ids: st.SearchStrategy[int], address: st.SearchStrategy[int],
                    max_length: int, max_motors: int) -> tuple[int, int, list[tuple[int, bytes]]]:
    length = draw(st.integers(1, max_length))
    motors = draw(st.lists(ids, min_size=1, max_size=max_motors, unique=True))
    return draw(address), length, [(i, draw(block(length))) for i in motors]


@SDK
@given(sync_write_args(ids_v1, address_v1, max_length=20, max_motors=11))
def test_v1_sync_write(args: tuple[int, int, list[tuple[int, bytes]]]) -> None:
    check_sync_write(PROTOCOL1, SDK1, V1_TX_MAX, *args)


def check_sync_write(protocol: Protocol, handler: object, tx_max: int, address: int,
                     length: int, blocks: list[tuple[int, bytes]]) -> None:
    """Our SYNC_WRITE equals both the SDK's ``syncWriteTxOnly`` and its ``GroupSyncWrite``."""
    param = [b for motor_id, chunk in blocks for b in (motor_id, *chunk)]
    ours = protocol.encode_instruction(protocol.sync_write(address, length, blocks))
    assert len(ours) <= tx_max
    assert ours == sdk_sends(handler, lambda ph, port: ph.syncWriteTxOnly(
        port, address, length, param, len(param)))

    def group(port: RecordingPort) -> sdk.GroupSyncWrite:
        g = sdk.GroupSyncWrite(port, handler, address, length)
        for motor_id, chunk in blocks:
            assert g.addParam(motor_id, list(chunk))
        return g

    assert ours == group_sends(group)


@SDK
@given(st.lists(st.tuples(ids_v1, address_v1, length_v1), min_size=1, max_size=81))
def test_v1_bulk_read(requests: list[tuple[int, int, int]]) -> None:
    """Only bulkReadTx: GroupBulkRead.txPacket of SDK 4.1.0 crashes on 1.0 (it passes an extra
    ``fast_option`` argument that Protocol1PacketHandler.bulkReadTx does not take)."""
    param = [b for motor_id, address, length in requests for b in (length, motor_id, address)]
    ours = v1(PROTOCOL1.bulk_read(requests))
    assert len(ours) <= V1_TX_MAX
    assert ours == sdk_sends(SDK1, lambda ph, port: ph.bulkReadTx(port, param, len(param)))


# -- Protocol 2.0 ------------------------------------------------------------------------------

@SDK
@given(motor_id=ids_v2)
def test_v2_ping(motor_id: int) -> None:
    assert v2(PROTOCOL2.ping(motor_id)) == sdk_sends(SDK2, lambda ph, port: ph.ping(port,
                                                                                     motor_id))


def test_v2_broadcast_ping() -> None:
    assert v2(PROTOCOL2.ping(254)) == sdk_sends(SDK2, lambda ph, port: ph.broadcastPing(port))


@SDK
@given(motor_id=ids_v2, address=address_v2, length=length_v2)
def test_v2_read(motor_id: int, address: int, length: int) -> None:
    sent = sdk_sends(SDK2, lambda ph, port: ph.readTx(port, motor_id, address, length))
    assert v2(PROTOCOL2.read(motor_id, address, length)) == sent


@SDK
@given(motor_id=targets_v2, address=address_v2, payload=data(1, 600), registered=st.booleans())
def test_v2_write_and_reg_write(motor_id: int, address: int, payload: bytes,
                                registered: bool) -> None:
    def call(ph: sdk.Protocol2PacketHandler, port: RecordingPort) -> int:
        tx = ph.regWriteTxOnly if registered else ph.writeTxOnly
        return tx(port, motor_id, address, len(payload), list(payload))

    event("stuffed" if FFFFFD in address.to_bytes(2, "little") + payload else "not stuffed")
    sent = sdk_sends(SDK2, call)
    assert v2(PROTOCOL2.write(motor_id, address, payload, registered=registered)) == sent


def test_v2_write_at_the_sdks_length_limit_with_stuffing() -> None:
    """100 stuffing bytes bring the packet to exactly the SDK's 1024 bytes."""
    payload = FFFFFD * 100 + bytes(V2_TX_MAX - 12 - 100 - 300)
    sent = sdk_sends(SDK2, lambda ph, port: ph.writeTxOnly(port, 1, 116, len(payload),
                                                          list(payload)))
    assert len(sent) == V2_TX_MAX
    assert v2(PROTOCOL2.write(1, 116, payload)) == sent


@SDK
@given(motor_id=targets_v2)
def test_v2_action_and_reboot(motor_id: int) -> None:
    assert v2(PROTOCOL2.action(motor_id)) == sdk_sends(
        SDK2, lambda ph, port: ph.action(port, motor_id))
    assert v2(PROTOCOL2.reboot(motor_id)) == sdk_sends(
        SDK2, lambda ph, port: ph.reboot(port, motor_id))


@pytest.mark.parametrize("option", [0xFF, 0x01, 0x02])
@pytest.mark.parametrize("motor_id", [0, 1, 252, 254])
def test_v2_factory_reset(motor_id: int, option: int) -> None:
    sent = sdk_sends(SDK2, lambda ph, port: ph.factoryReset(port, motor_id, option))
    assert v2(PROTOCOL2.factory_reset(motor_id, option)) == sent


@SDK
@given(address=address_v2, length=length_v2,
       motors=st.lists(ids_v2, min_size=1, max_size=253, unique=True))
def test_v2_sync_read(address: int, length: int, motors: list[int]) -> None:
    ours = v2(PROTOCOL2.sync_read(address, length, motors))
    assert ours == sdk_sends(SDK2, lambda ph, port: ph.syncReadTx(
        port, address, length, motors, len(motors), False))

    def group(port: RecordingPort) -> sdk.GroupSyncRead:
        g = sdk.GroupSyncRead(port, SDK2, address, length)
        for motor_id in motors:
            assert g.addParam(motor_id)
        return g

    assert ours == group_sends(group)


@SDK
@given(sync_write_args(ids_v2, address_v2, max_length=32, max_motors=16))
def test_v2_sync_write(args: tuple[int, int, list[tuple[int, bytes]]]) -> None:
    check_sync_write(PROTOCOL2, SDK2, V2_TX_MAX, *args)


@SDK
@given(st.lists(st.tuples(ids_v2, address_v2, length_v2), min_size=1, max_size=60,
                unique_by=lambda r: r[0]))
def test_v2_bulk_read(requests: list[tuple[int, int, int]]) -> None:
    param = [b for motor_id, address, length in requests
             for b in (motor_id, *address.to_bytes(2, "little"), *length.to_bytes(2, "little"))]
    ours = v2(PROTOCOL2.bulk_read(requests))
    assert ours == sdk_sends(SDK2, lambda ph, port: ph.bulkReadTx(port, param, len(param), False))

    def group(port: RecordingPort) -> sdk.GroupBulkRead:
        g = sdk.GroupBulkRead(port, SDK2)
        for motor_id, address, length in requests:
            assert g.addParam(motor_id, address, length)
        return g

    assert ours == group_sends(group)


@SDK
@given(st.lists(st.tuples(ids_v2, address_v2, data(1, 40)), min_size=1, max_size=12,
                unique_by=lambda b: b[0]))
def test_v2_bulk_write(blocks: list[tuple[int, int, bytes]]) -> None:
    param = [b for motor_id, address, chunk in blocks
             for b in (motor_id, *address.to_bytes(2, "little"),
                       *len(chunk).to_bytes(2, "little"), *chunk)]
    ours = v2(PROTOCOL2.bulk_write(blocks))
    assert len(ours) <= V2_TX_MAX
    assert ours == sdk_sends(SDK2, lambda ph, port: ph.bulkWriteTxOnly(port, param, len(param)))

    def group(port: RecordingPort) -> sdk.GroupBulkWrite:
        g = sdk.GroupBulkWrite(port, SDK2)
        for motor_id, address, chunk in blocks:
            assert g.addParam(motor_id, address, len(chunk), list(chunk))
        return g

    assert ours == group_sends(group)


@SDK
@given(motor_id=targets_v2, address=address_v2, payload=data(1, 200))
def test_stuffing_fix_changes_nothing_without_ff_ff_fd(motor_id: int, address: int,
                                                       payload: bytes) -> None:
    """Where there is nothing to stuff, the unmodified SDK and ``StuffingSdk2`` agree (and
    therefore so do we and the unmodified SDK)."""
    body = bytes([0x03]) + address.to_bytes(2, "little") + payload
    if FFFFFD in body:
        return

    def call(ph: sdk.Protocol2PacketHandler, port: RecordingPort) -> int:
        return ph.writeTxOnly(port, motor_id, address, len(payload), list(payload))

    stock = sdk_sends(STOCK_SDK2, call)
    assert stock == sdk_sends(SDK2, call)
    assert stock == v2(PROTOCOL2.write(motor_id, address, payload))


# -- our status packets through the SDK's receiver ---------------------------------------------

@SDK
@given(motor_id=ids_v1, error=st.integers(0, 0x7F), params=data(0, V1_RX_MAX - 2))
def test_sdk_receives_our_v1_status(motor_id: int, error: int, params: bytes) -> None:
    """The SDK takes error bytes 0..0x7F (bit 7 is unused in 1.0) and LENGTH up to 250."""
    wire = PROTOCOL1.encode_status(Status(motor_id, error, params))
    rx, result = SDK1.rxPacket(RecordingPort(wire))
    assert result == sdk.COMM_SUCCESS
    assert (rx[2], rx[4], bytes(rx[5:-1])) == (motor_id, error, params)

    got, result, got_error = SDK1.readRx(RecordingPort(wire), motor_id, len(params))
    assert result == sdk.COMM_SUCCESS
    assert (bytes(got), got_error) == (params, error)


def sdk_unstuffing_is_lossless(wire: bytes, status_body: bytes) -> bool:
    """Whether the SDK's own removeStuffing gives back the whole unstuffed packet (its LEN,
    body and CRC) from the packet on the wire: it unstuffs the CRC too, and after a stuffing
    byte it can drop a data or CRC FD and shorten LEN (found with the CRC FD 8F after a body
    ending in FF FD), which a packet built with another CRC would not show."""
    length = len(status_body) + 2
    unstuffed = wire[:5] + bytes([length & 0xFF, length >> 8]) + status_body + wire[-2:]
    return bytes(SDK2.removeStuffing(list(wire))) == unstuffed


@settings(max_examples=200, deadline=None)
@given(motor_id=ids_v2, error=st.integers(0, 0xFF), params=data(0, 400))
@example(motor_id=31, error=93,
         params=b"\xfd\xfd}Z\x19\x10\xff\xff\xfd\xfd\x00Z\x19\x10\xff\xfd")
def test_sdk_receives_our_v2_status(motor_id: int, error: int, params: bytes) -> None:
    """CRC, LEN and stuffing of our status are what the SDK checks and removes.

    The SDK's removeStuffing looks back at bytes it has already shifted, so after one stuffing
    byte it can drop a FD that was data (e.g. ``FF FF FD FF FD FD``); for those rare bodies only
    the framing is compared, since the SDK's unstuffer would also garble its own packets.
    """
    wire = PROTOCOL2.encode_status(Status(motor_id, error, params))
    rx, result = SDK2.rxPacket(RecordingPort(wire), False)
    assert result == sdk.COMM_SUCCESS
    assert (rx[4], rx[7], rx[8]) == (motor_id, 0x55, error)
    if sdk_unstuffing_is_lossless(wire, bytes([0x55, error]) + params):
        length = rx[5] | rx[6] << 8
        assert bytes(rx[9:7 + length - 2]) == params
        got, result, got_error = SDK2.readRx(RecordingPort(wire), motor_id, len(params))
        assert result == sdk.COMM_SUCCESS
        assert (bytes(got), got_error) == (params, error)
    else:
        event("the SDK's removeStuffing loses a byte")


@SDK
@given(motor_id=ids_v2, model=st.integers(0, 0xFFFF), firmware=st.integers(0, 0xFF))
def test_sdk_ping_reads_our_v2_answer(motor_id: int, model: int, firmware: int) -> None:
    answer = PROTOCOL2.encode_status(Status(motor_id, 0, model.to_bytes(2, "little")
                                            + bytes([firmware])))
    port = RecordingPort(answer)
    assert SDK2.ping(port, motor_id) == (model, sdk.COMM_SUCCESS, 0)
    assert port.written == [v2(PROTOCOL2.ping(motor_id))]


@SDK
@given(motor_id=ids_v1, model=st.integers(0, 0xFFFF))
def test_sdk_ping_reads_our_v1_answers(motor_id: int, model: int) -> None:
    """The 1.0 SDK pings, then READs the model number at address 0: it gets both answers."""
    answers = (PROTOCOL1.encode_status(Status(motor_id, 0))
               + PROTOCOL1.encode_status(Status(motor_id, 0, model.to_bytes(2, "little"))))
    port = RecordingPort(answers)
    assert SDK1.ping(port, motor_id) == (model, sdk.COMM_SUCCESS, 0)
    assert port.written == [v1(PROTOCOL1.ping(motor_id)), v1(PROTOCOL1.read(motor_id, 0, 2))]
