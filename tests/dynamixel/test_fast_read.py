"""Fast Sync Read (0x8A) and Fast Bulk Read (0x9A), host and device side, against the SDK.

Sources. The official ``dynamixel_sdk`` 4.1.0: ``Protocol2PacketHandler.syncReadTx`` /
``bulkReadTx`` with ``fast_option`` (the instruction packets are SYNC_READ's and BULK_READ's
with 0x8A / 0x9A), ``rxPacket(port, fast_option=True)`` (one status packet from the broadcast
ID, not unstuffed, its last CRC over all of it) and ``fastSyncReadRx`` / ``fastBulkReadRx``
with ``GroupSyncRead.fastSyncRead*`` / ``GroupBulkRead.fastBulkRead*`` (blocks ERR, ID, DATA,
CRC, found by counting 4 + L bytes). The e-Manual's Fast Sync Read example (3 motors x 4
bytes: LEN 25) as quoted by a third-party implementation; the e-Manual copy at hand
(ROBOTIS-GIT/emanual docs/en/dxl/protocol2.md) predates the Fast sections. Which models: the
ROBOTIS forum ("DYNAMIXEL X Series only", not MX 2.0, forum.robotis.com/t/820) and
pollen-robotics/rustypot PR #122 (XL330 firmware v46+; "return delays do not compound").
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable, Sequence
from pathlib import Path

import dynamixel_sdk as sdk
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.dynamixel import (
    Bus,
    ConfigError,
    CorruptResponse,
    Emulator,
    MotorError,
    NoResponse,
    VirtualMotor,
    model,
)
from servolab.dynamixel.emulator import Reply
from servolab.dynamixel.models import FAST_READ_FIRMWARE, XM430_W210, Model, supports
from servolab.dynamixel.protocol2 import (
    ACCESS,
    FAST_BULK_READ,
    FAST_HEAD,
    FAST_SYNC_READ,
    PROTOCOL2,
    crc16,
    encode_fast_status,
    fast_status_length,
    match_fast_status,
    read_fast_status,
)
from servolab.dynamixel.wire import byte_time
from tests.dynamixel.test_sdk_packets import RecordingPort, StuffingSdk2
from tests.simproc import sim_process
from tests.waiting import wait_until

BAUD = 1_000_000
TICK = byte_time(BAUD)
PRESENT_POSITION, PRESENT_VELOCITY, GOAL_POSITION, INDIRECT_DATA_1 = 132, 128, 116, 224
SDK2 = StuffingSdk2()   # the SDK's handler; its stuffing fix is a no-op for these packets
OLD_X = dataclasses.replace(XM430_W210, firmware=FAST_READ_FIRMWARE - 1)
ids_v2 = st.integers(0, 252)
address_v2 = st.one_of(st.integers(0, 0xFFFF), st.sampled_from([0xFFFF, 0xFDFF, 0xFFFD]))
length_v2 = st.one_of(st.integers(1, 0xFFFF), st.sampled_from([0xFD, 0xFFFF, 0xFDFF]))


def fast_tx(make: Callable[[RecordingPort], sdk.GroupSyncRead | sdk.GroupBulkRead]) -> bytes:
    """The one packet an SDK group object writes from its fast*TxPacket."""
    port = RecordingPort()
    group = make(port)
    send = (group.fastSyncReadTxPacket if isinstance(group, sdk.GroupSyncRead)
            else group.fastBulkReadTxPacket)
    assert send() == sdk.COMM_SUCCESS
    assert len(port.written) == 1
    return port.written[0]


class EmulatorPort(RecordingPort):
    """An SDK PortHandler stand-in wired to an :class:`Emulator`: what the SDK writes goes to
    the motors, and their reply bytes are what it reads."""

    def __init__(self, emulator: Emulator) -> None:
        super().__init__()
        self.emulator = emulator
        self.replies: list[Reply] = []
        self.t = 0.0

    def writePort(self, packet: Sequence[int]) -> int:
        n = super().writePort(packet)
        self.t += 1.0  # each request well after the last reply
        self.replies = self.emulator.receive(self.written[-1], self.t, BAUD)
        self.incoming += b"".join(r.data for r in self.replies)
        return n


def x_emulator(*ids: int, m: Model = XM430_W210) -> Emulator:
    """XM430s each at its own angle, so that each reports its own present position."""
    return Emulator(2, [VirtualMotor(m, i, baudrate=BAUD, position=0.3 * i) for i in ids])


def check_running_crcs(packet: bytes, lengths: Sequence[int]) -> None:
    """Every block's CRC is the SDK's CRC (its own updateCRC) of the packet up to it."""
    end = FAST_HEAD
    for n in lengths:
        end += 2 + n
        assert SDK2.updateCRC(0, list(packet), end) == packet[end] | packet[end + 1] << 8
        end += 2
    assert end == len(packet)


# -- 1. the instruction packets are the SDK's ---------------------------------------------------
@settings(max_examples=100, deadline=None)
@given(address=address_v2, length=length_v2,
       motors=st.lists(ids_v2, min_size=1, max_size=253, unique=True))
def test_fast_sync_read_packet_is_the_sdks(address: int, length: int, motors: list[int]) -> None:
    """GroupSyncRead.fastSyncReadTxPacket: SYNC_READ's parameters, instruction 0x8A."""
    ours = PROTOCOL2.encode_instruction(PROTOCOL2.fast_sync_read(address, length, motors))
    assert ours[7] == FAST_SYNC_READ == sdk.INST_FAST_SYNC_READ

    def group(port: RecordingPort) -> sdk.GroupSyncRead:
        g = sdk.GroupSyncRead(port, SDK2, address, length)
        for motor_id in motors:
            assert g.addParam(motor_id)
        return g

    assert ours == fast_tx(group)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(ids_v2, address_v2, length_v2), min_size=1, max_size=60,
                unique_by=lambda r: r[0]))
def test_fast_bulk_read_packet_is_the_sdks(requests: list[tuple[int, int, int]]) -> None:
    """GroupBulkRead.fastBulkReadTxPacket: BULK_READ's parameters, instruction 0x9A."""
    ours = PROTOCOL2.encode_instruction(PROTOCOL2.fast_bulk_read(requests))
    assert ours[7] == FAST_BULK_READ == sdk.INST_FAST_BULK_READ

    def group(port: RecordingPort) -> sdk.GroupBulkRead:
        g = sdk.GroupBulkRead(port, SDK2)
        for motor_id, address, length in requests:
            assert g.addParam(motor_id, address, length)
        return g

    assert ours == fast_tx(group)


def test_the_bus_sends_the_sdks_packets() -> None:
    """What Bus.fast_sync_read / fast_bulk_read put on the wire, byte for byte the SDK's."""
    bus = Bus.open("emu://xm430-w210:1-5", baudrate=BAUD)
    for i in range(1, 6):
        bus.declare(i, "xm430-w210")
    sent: list[bytes] = []
    write = bus.port.write
    bus.port.write = lambda data: (sent.append(bytes(data)), write(data))[1]  # type: ignore[method-assign]
    bus.fast_sync_read("present_position", [1, 2, 3, 4, 5])
    bus.fast_bulk_read({1: "present_position", 2: ["present_velocity", "present_position"],
                        5: "goal_position"})

    def sync(port: RecordingPort) -> sdk.GroupSyncRead:
        g = sdk.GroupSyncRead(port, SDK2, PRESENT_POSITION, 4)
        for motor_id in range(1, 6):
            g.addParam(motor_id)
        return g

    def bulk(port: RecordingPort) -> sdk.GroupBulkRead:
        g = sdk.GroupBulkRead(port, SDK2)
        g.addParam(1, PRESENT_POSITION, 4)
        g.addParam(2, PRESENT_VELOCITY, 8)
        g.addParam(5, GOAL_POSITION, 4)
        return g

    assert sent == [fast_tx(sync), fast_tx(bulk)]


def test_status_length_is_the_e_manuals() -> None:
    """The e-Manual's Fast Sync Read example: 3 motors x 4 bytes, LEN 25 (INST + 3 x (ERR, ID,
    4 data, CRC 2)); and a packet of that LEN is what the SDK waits for."""
    assert fast_status_length([4, 4, 4]) == 25
    packet = encode_fast_status([(1, 0, b"\xa6\0\0\0"), (2, 0, b"\x1f\x08\0\0"),
                                 (3, 0, b"\xff\xff\xfd\0")])
    assert packet[:8] == bytes.fromhex("FF FF FD 00 FE 19 00 55")
    assert len(packet) == 7 + 25
    check_running_crcs(packet, [4, 4, 4])


# -- 2. the SDK reads the emulator's status ------------------------------------------------------
def test_sdk_fast_sync_read_reads_the_emulators_status() -> None:
    """GroupSyncRead.fastSyncRead on the emulator: the SDK's own receiver (rxPacket with
    fast_option, fastSyncReadRx) takes our packet and gets each motor's value; data holding
    FF FF FD goes unstuffed, as the SDK reads it."""
    emulator = x_emulator(1, 2, 3)
    indirect = {1: b"\xff\xff\xfd", 2: b"\xff\xff\xfd", 3: b"\xfd\xfd\xfd"}
    for motor_id, data in indirect.items():   # Indirect Data 1-3 (addresses 224-226)
        for k, value in enumerate(data):
            emulator.motor(motor_id).set_raw(f"indirect_data_{k + 1}", value)
    port = EmulatorPort(emulator)
    group = sdk.GroupSyncRead(port, SDK2, PRESENT_POSITION, 4)
    for motor_id in (1, 2, 3):
        group.addParam(motor_id)
    assert group.fastSyncRead() == sdk.COMM_SUCCESS
    for motor_id in (1, 2, 3):
        want = emulator.motor(motor_id).get_raw("present_position")
        assert group.getData(motor_id, PRESENT_POSITION, 4) == want & 0xFFFFFFFF
    assert port.written[-1][7] == FAST_SYNC_READ
    reply = b"".join(r.data for r in port.replies)
    assert reply[:8] == bytes.fromhex("FF FF FD 00 FE 19 00 55")
    check_running_crcs(reply, [4, 4, 4])

    group = sdk.GroupSyncRead(port, SDK2, INDIRECT_DATA_1, 3)
    for motor_id in (1, 2, 3):
        group.addParam(motor_id)
    assert group.fastSyncRead() == sdk.COMM_SUCCESS
    reply = b"".join(r.data for r in port.replies)
    assert len(reply) == FAST_HEAD + 3 * (4 + 3)   # no stuffing byte inserted
    check_running_crcs(reply, [3, 3, 3])
    assert {i: bytes(group.data_dict[i]) for i in (1, 2, 3)} == indirect


def test_sdk_fast_bulk_read_reads_the_emulators_status() -> None:
    """GroupBulkRead.fastBulkRead: blocks of different lengths. (IDs and lengths are chosen
    so that no ID equals an earlier address or length byte: fastBulkReadRx finds a block's
    length with ``param.index(dxl_id)`` in the flat parameter list.)"""
    emulator = x_emulator(1, 2, 3)
    port = EmulatorPort(emulator)
    group = sdk.GroupBulkRead(port, SDK2)
    for motor_id, address, length in ((1, PRESENT_POSITION, 4), (2, INDIRECT_DATA_1, 2),
                                      (3, PRESENT_VELOCITY, 8)):
        assert group.addParam(motor_id, address, length)
    emulator.motor(2).set_raw("indirect_data_1", 0x5A)
    emulator.motor(2).set_raw("indirect_data_2", 0xA5)
    assert group.fastBulkRead() == sdk.COMM_SUCCESS
    assert port.written[-1][7] == FAST_BULK_READ
    m1, m3 = emulator.motor(1), emulator.motor(3)
    assert group.getData(1, PRESENT_POSITION, 4) == m1.get_raw("present_position")
    assert group.getData(2, INDIRECT_DATA_1, 2) == 0xA55A
    assert group.getData(3, PRESENT_POSITION, 4) == m3.get_raw("present_position")
    reply = b"".join(r.data for r in port.replies)
    assert reply[5] | reply[6] << 8 == fast_status_length([4, 2, 8]) == 27
    check_running_crcs(reply, [4, 2, 8])


def test_emulated_chain_timing() -> None:
    """The first motor of the request sends the head and its block after its return delay;
    each next motor's block starts where the one before it ended (no return delay of its
    own), and the motors answer in the order of the request, not of their IDs."""
    emulator = x_emulator(1, 2, 3)
    request = PROTOCOL2.encode_instruction(PROTOCOL2.fast_sync_read(PRESENT_POSITION, 4,
                                                                    [3, 1, 2]))
    end = 0.5
    replies = emulator.receive(request, end, BAUD)
    delay = emulator.motor(3).return_delay
    assert delay == pytest.approx(500e-6)  # the factory 250 x 2 us
    assert [len(r.data) for r in replies] == [FAST_HEAD + 8, 8, 8]
    assert replies[0].start == pytest.approx(end + delay)
    for before, after in itertools.pairwise(replies):
        assert after.start == pytest.approx(before.start + len(before.data) * TICK)
    packet = b"".join(r.data for r in replies)
    assert [packet[8 + 1 + 8 * k] for k in range(3)] == [3, 1, 2]
    assert match_fast_status(packet, packet[:8], crc16(packet[:8]), [3, 1, 2],
                             [14, 22, 30]) == ()


def test_emulated_chain_stops_at_a_silent_motor() -> None:
    """A motor that sends no block (absent, status return level 0, or firmware without the
    instruction) stops the chain: the host gets the packet cut after the last block sent."""
    emulator = x_emulator(1, 2, 4)
    emulator.add(VirtualMotor(OLD_X, 5, baudrate=BAUD))
    request = PROTOCOL2.encode_instruction(PROTOCOL2.fast_sync_read(PRESENT_POSITION, 4,
                                                                    [1, 2, 3, 4]))
    packet = b"".join(r.data for r in emulator.receive(request, 1.0, BAUD))
    assert len(packet) == FAST_HEAD + 2 * 8        # motors 1 and 2; 3 absent, 4 waits
    blocks, cut = read_fast_status(packet, 0, [1, 2, 3, 4], [4, 4, 4, 4])
    assert [b.id for b in blocks] == [1, 2] and not cut
    emulator.motor(1).set_raw("status_return_level", 0)
    assert emulator.receive(request, 2.0, BAUD) == []
    old = PROTOCOL2.encode_instruction(PROTOCOL2.fast_sync_read(PRESENT_POSITION, 4, [5]))
    assert emulator.receive(old, 3.0, BAUD) == []     # firmware 45 knows no 0x8A
    assert not supports(OLD_X, "FAST_SYNC_READ") and supports(XM430_W210, "FAST_BULK_READ")
    assert not supports(model("mx28"), "FAST_SYNC_READ")


def test_a_failed_read_keeps_its_block_length() -> None:
    """A motor whose read fails (here past the end of its control table: an access error)
    still sends a block of the length asked, zeros for data, so the motors after it find
    where it ends; the error byte says what happened."""
    emulator = x_emulator(1, 2)
    request = PROTOCOL2.encode_instruction(PROTOCOL2.fast_bulk_read([(1, 660, 4),
                                                                     (2, PRESENT_POSITION, 4)]))
    packet = b"".join(r.data for r in emulator.receive(request, 1.0, BAUD))
    blocks, cut = read_fast_status(packet, 0, [1, 2], [4, 4])
    assert not cut and [(b.id, b.error) for b in blocks] == [(1, ACCESS), (2, 0)]
    assert blocks[0].params == bytes(4)


# -- 3. the unmodified SDK as a client of `servolab sim --pty` ------------------------------------
@pytest.mark.slow
@pytest.mark.realtime  # the SDK's packet timeout: a wall-clock deadline
def test_sdk_fast_reads_through_the_pty(tmp_path: Path) -> None:
    """GroupSyncRead.fastSyncRead and GroupBulkRead.fastBulkRead of the SDK, through its own
    PortHandler on the pseudo-terminal: the motors go to the positions written, and the fast
    reads say so."""
    goals = {1: 1000, 2: 2600, 3: 3100}
    with sim_process("--motors", "xm430-w210:1-3", "--baud", "57600",
                     out_dir=tmp_path) as (device, _):
        port = sdk.PortHandler(device)
        assert port.openPort() and port.setBaudRate(57600)
        ph = sdk.PacketHandler(2.0)
        try:
            writer = sdk.GroupSyncWrite(port, ph, 64, 1)          # torque_enable
            for motor_id in goals:
                writer.addParam(motor_id, [1])
            assert writer.txPacket() == sdk.COMM_SUCCESS
            writer = sdk.GroupSyncWrite(port, ph, GOAL_POSITION, 4)
            for motor_id, goal in goals.items():
                writer.addParam(motor_id, list(goal.to_bytes(4, "little")))
            assert writer.txPacket() == sdk.COMM_SUCCESS

            reader = sdk.GroupSyncRead(port, ph, PRESENT_POSITION, 4)
            for motor_id in goals:
                assert reader.addParam(motor_id)
            seen: list[dict[int, int]] = []

            def arrived() -> bool:
                assert reader.fastSyncRead() == sdk.COMM_SUCCESS
                seen.append({i: reader.getData(i, PRESENT_POSITION, 4) for i in goals})
                return seen[-1] == goals

            assert wait_until(arrived, timeout=10.0), seen[-3:]

            bulk = sdk.GroupBulkRead(port, ph)
            assert bulk.addParam(1, GOAL_POSITION, 4)
            assert bulk.addParam(2, PRESENT_VELOCITY, 8)
            assert bulk.addParam(3, PRESENT_POSITION, 4)
            assert bulk.fastBulkRead() == sdk.COMM_SUCCESS
            assert bulk.getData(1, GOAL_POSITION, 4) == goals[1]
            assert bulk.getData(2, PRESENT_POSITION, 4) == goals[2]
            assert bulk.getData(2, PRESENT_VELOCITY, 4) == 0
            assert bulk.getData(3, PRESENT_POSITION, 4) == goals[3]
        finally:
            port.closePort()


# -- 4. the driver ----------------------------------------------------------------------------
def x_bus(ids: str = "1-5") -> Bus:
    """XM430s on an emulated bus (a virtual clock), declared, each at its own angle."""
    bus = Bus.open(f"emu://xm430-w210:{ids}", baudrate=BAUD)
    for motor in bus.emulator.motors:
        bus.declare(motor.id, "xm430-w210")
        motor.set_raw("homing_offset", 100 * motor.id)   # present = actual + homing offset
    return bus


def present(bus: Bus, *ids: int) -> dict[int, int]:
    """The raw present positions the emulated motors hold now."""
    return {i: int.from_bytes(bus.emulator.motor(i).read(PRESENT_POSITION, 4).params, "little",
                              signed=True) for i in ids}


def sent_instructions(bus: Bus) -> list[int]:
    """Record the instruction byte of every packet the bus sends from now on."""
    codes: list[int] = []
    write = bus.port.write
    bus.port.write = lambda data: (codes.append(data[7]), write(data))[1]  # type: ignore[method-assign]
    return codes


def test_bus_fast_reads_give_the_control_tables_values() -> None:
    bus = x_bus()
    ids = [1, 2, 3, 4, 5]
    codes = sent_instructions(bus)
    raw = present(bus, *ids)
    assert len(set(raw.values())) == 5
    assert bus.fast_sync_read("present_position", ids, raw=True) == raw
    assert bus.fast_sync_read("present_position", ids) == bus.sync_read("present_position", ids)
    both = bus.fast_sync_read(["present_velocity", "present_position"], ids, raw=True)
    assert both == {i: {"present_velocity": 0, "present_position": raw[i]} for i in ids}
    bulk = bus.fast_bulk_read({2: "goal_position", 4: ["present_position", "moving"]},
                              raw=True)
    goal = bus.emulator.motor(2).get_raw("goal_position")
    assert bulk == {2: {"goal_position": goal}, 4: {"present_position": raw[4], "moving": 0}}
    assert bus.bulk_read({2: "goal_position"}, raw=True, fast=True) == {
        2: {"goal_position": goal}}
    assert codes == [0x8A, 0x8A, 0x82, 0x8A, 0x9A, 0x9A]
    # fast=None: the fast instruction, as every motor has it
    assert bus.sync_read("present_position", ids, raw=True, fast=None) == raw
    assert codes[-1] == 0x8A
    assert bus.stats.retries == bus.stats.corrupt == bus.stats.timeouts == 0


@pytest.mark.parametrize("delay_raw", [250, 0])
def test_fast_sync_read_saves_headers_and_return_delays(delay_raw: int) -> None:
    """The virtual wire time of a fast sync read of 5 motors against a SYNC_READ's: the
    same instruction packet, then one status packet of 8 + 5 x (4 + 4) bytes after one
    return delay instead of five of 11 + 4 bytes, each after its own return delay."""
    bus = x_bus()
    ids, n, length = [1, 2, 3, 4, 5], 5, 4
    bus.sync_write("return_delay_time", dict.fromkeys(ids, delay_raw), raw=True)
    delay = delay_raw * 2e-6
    clock = bus.port.clock

    def wire(fast: bool) -> float:
        bus.sync_read("present_position", ids, fast=fast)   # the plan; models known
        t0 = clock.now()
        bus.sync_read("present_position", ids, fast=fast)
        return clock.now() - t0

    request = 14 + n
    plain = (request + n * (11 + length)) * TICK + n * delay
    fast = (request + FAST_HEAD + n * (4 + length)) * TICK + delay
    assert wire(False) == pytest.approx(plain)
    assert wire(True) == pytest.approx(fast)
    saved = (n * 7 - FAST_HEAD) * TICK + (n - 1) * delay   # 27 bytes, 4 return delays
    assert wire(False) - wire(True) == pytest.approx(saved)
    if delay_raw == 250:
        assert plain == pytest.approx(3.44e-3) and fast == pytest.approx(1.17e-3)


def test_an_absent_motor_is_named_with_the_ones_behind_it() -> None:
    """Motor 3 does not answer: motors 1 and 2 have sent their blocks, 4 and 5 wait for 3's.
    NoResponse names 3 (motor_id), and 4 and 5 as after it; the next read works again."""
    bus = x_bus()
    bus.emulator.motor(3).responsive = False
    with pytest.raises(NoResponse) as err:
        bus.fast_sync_read("present_position", [1, 2, 3, 4, 5])
    assert err.value.motor_id == 3 and err.value.instruction == "FAST_SYNC_READ"
    assert str(err.value).startswith("motor 3, 4, 5: ")
    assert "motors 4, 5 after it in the chain" in str(err.value)
    assert bus.stats.timeouts == 3 and bus.stats.retries == 2   # as a plain read counts
    with pytest.raises(NoResponse) as err:
        bus.fast_bulk_read({3: "present_position"})
    assert err.value.motor_id == 3
    assert bus.fast_sync_read("present_position", [1, 2, 4, 5], raw=True) == present(
        bus, 1, 2, 4, 5)


def test_a_corrupt_block_is_named_and_noise_before_the_packet_is_skipped() -> None:
    """The slow path: noise ahead of the packet is skipped (the in-place check fails, the
    packet is found after it); a block whose CRC fails names its motor in CorruptResponse."""
    bus = x_bus("1-3")
    emulator = bus.emulator
    receive = emulator.receive
    mode = {"noise": True}

    def tampered(data: bytes, t: float, baudrate: float) -> list[Reply]:
        replies = receive(data, t, baudrate)
        if mode["noise"]:
            return [Reply(replies[0].start - 3 * TICK, b"\x00\x13\xff"), *replies]
        second = bytearray(replies[1].data)
        second[3] ^= 0x40                            # a data bit of motor 2
        return [replies[0], Reply(replies[1].start, bytes(second)), *replies[2:]]

    emulator.receive = tampered
    want = present(bus, 1, 2, 3)
    assert bus.fast_sync_read("present_position", [1, 2, 3], raw=True) == want
    assert bus.stats.retries == 0
    mode["noise"] = False
    with pytest.raises(CorruptResponse) as err:
        bus.fast_sync_read("present_position", [1, 2, 3])
    assert err.value.motor_id == 2 and str(err.value).startswith("motor 2, 3: ")


def test_hardware_alerts_come_with_the_data_and_instruction_errors_raise() -> None:
    """A motor in an overload state answers all the same: its data comes, and it is named in
    Bus.alerts (the error byte's alert bit, e-Manual Protocol 2.0 Status Packet Error). An
    instruction error in a block raises MotorError for that motor."""
    bus = x_bus("1-3")
    bus.emulator.motor(2).inject_hardware_error("overload")
    got = bus.fast_sync_read("present_position", [1, 2, 3], raw=True)
    assert got == present(bus, 1, 2, 3)
    assert bus.alerts == {2: 0x80}
    bus.reboot(2)
    bus.fast_sync_read("present_position", [1, 2, 3])
    assert bus.alerts == {}

    emulator = bus.emulator
    receive = emulator.receive

    def access_error(data: bytes, t: float, baudrate: float) -> list[Reply]:
        replies = receive(data, t, baudrate)
        packet = b"".join(r.data for r in replies)
        blocks, _ = read_fast_status(packet, 0, [1, 2, 3], [4, 4, 4])
        bad = encode_fast_status([(b.id, ACCESS if b.id == 3 else b.error, b.params)
                                  for b in blocks])
        return [Reply(replies[0].start, bad)]

    emulator.receive = access_error
    with pytest.raises(MotorError) as err:
        bus.fast_sync_read("present_position", [1, 2, 3])
    assert err.value.motor_id == 3 and err.value.errors == ("access",)
    assert bus.fast_sync_read("present_position", [1, 2, 3], check=False)


def test_models_without_fast_reads_are_refused_before_anything_is_sent() -> None:
    """Protocol 1.0 (MX-28 has BULK_READ, no fast one) and an X motor at firmware 45: fast
    reads raise ConfigError with nothing on the wire; fast=None falls back to the plain
    instruction."""
    mx = Bus.open("emu://mx28:1-2", baudrate=BAUD)
    for i in (1, 2):
        mx.declare(i, "mx28")
    with pytest.raises(ConfigError, match=r"protocol 2\.0"):
        mx.fast_sync_read("present_position", [1, 2])
    with pytest.raises(ConfigError, match=r"protocol 2\.0"):
        mx.bulk_read({1: "present_position"}, fast=True)
    assert mx.port.bytes_written == 0 and mx.stats.transactions == 0
    assert mx.sync_read("present_position", [1, 2], raw=True, fast=None) == {
        i: mx.emulator.motor(i).get_raw("present_position") for i in (1, 2)}

    bus = x_bus("1-3")
    bus.declare(2, OLD_X)   # the bus is told motor 2 runs firmware 45
    with pytest.raises(ConfigError, match=r"motor 2 .*firmware 45"):
        bus.fast_sync_read("present_position", [1, 2, 3])
    with pytest.raises(ConfigError, match="motor 2"):
        bus.fast_bulk_read({1: "present_position", 2: "present_position"})
    assert bus.port.bytes_written == 0
    codes = sent_instructions(bus)
    bus.sync_read("present_position", [1, 2, 3], fast=None)
    bus.bulk_read({1: "present_position", 2: "goal_position"}, fast=None)
    bus.sync_read("present_position", [1, 3], fast=None)
    assert codes == [0x82, 0x92, 0x8A]


def test_the_bus_learns_the_firmware_a_motor_reports() -> None:
    """A real XM430 may still run firmware 45, without the fast reads: what the bus sends
    follows the firmware the motor's PING reports (Protocol 2.0 PING: model number and
    firmware version), not the version servolab's table describes."""
    emulator = Emulator(2)
    emulator.add(VirtualMotor(XM430_W210, 1, baudrate=BAUD))
    emulator.add(VirtualMotor(OLD_X, 2, baudrate=BAUD))
    bus = Bus.open("emu://xm430-w210:9", baudrate=BAUD)
    bus.port.device = emulator
    found = {r.id: r for r in bus.broadcast_ping()}
    assert found[2].firmware == FAST_READ_FIRMWARE - 1
    assert bus.motors[2].firmware == FAST_READ_FIRMWARE - 1
    assert bus.motors[1].firmware == FAST_READ_FIRMWARE
    codes = sent_instructions(bus)
    assert bus.sync_read("present_position", [1, 2], raw=True, fast=None) == {1: 2048, 2: 2048}
    assert bus.sync_read("present_position", [1], raw=True, fast=None) == {1: 2048}
    assert codes == [0x82, 0x8A]
