"""Protocol 1.0 packets, byte for byte as the ROBOTIS e-Manual gives them.

A motor only obeys the bytes its manual specifies, so the vectors below are copied from the
e-Manual (https://emanual.robotis.com/docs/en/dxl/protocol1/, source ROBOTIS-GIT/emanual
docs/en/dxl/protocol1.md) and from the RX-28/RX-64 user's manuals it replaced, never from our
own output. Each vector's LENGTH and checksum are also re-derived here from the manual's
formula, so a typo in a vector cannot pass silently.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.dynamixel.errors import ConfigError, PacketError
from servolab.dynamixel.packets import Instruction, Status
from servolab.dynamixel.protocol1 import PROTOCOL1, checksum

P1 = PROTOCOL1
BAD_INPUT = (ConfigError, PacketError)


def ref_checksum(body: bytes) -> int:
    """The e-Manual's formula: ~(ID + Length + Instruction/Error + Parameters), low byte."""
    return (0xFF - (sum(body) & 0xFF)) & 0xFF


def ref_packet(motor_id: int, code: int, params: bytes = b"") -> bytes:
    """A 1.0 packet built straight from the e-Manual's layout, independent of servolab."""
    body = bytes([motor_id, len(params) + 2, code]) + params
    return b"\xff\xff" + body + bytes([ref_checksum(body)])


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def naming(value: object) -> str:
    """A regex that finds ``value`` as a whole number in an error message."""
    return rf"(?<![\w-]){re.escape(str(value))}(?![\w])"


# -- e-Manual vectors --------------------------------------------------------------------------

INSTRUCTION_VECTORS: list[tuple[str, Callable[[], Instruction], str]] = [
    # e-Manual, Protocol 1.0
    ("ping ID 1", lambda: P1.ping(1), "FF FF 01 02 01 FB"),
    ("read present temperature", lambda: P1.read(1, 0x2B, 1), "FF FF 01 04 02 2B 01 CC"),
    ("checksum example", lambda: P1.write(1, 0x0C, h("64 AA")), "FF FF 01 05 03 0C 64 AA DC"),
    ("broadcast write ID", lambda: P1.write(0xFE, 3, b"\x01"), "FF FF FE 04 03 03 01 F6"),
    ("reg write goal 500",
     lambda: P1.write(1, 0x1E, h("F4 01"), registered=True), "FF FF 01 05 04 1E F4 01 E2"),
    ("action broadcast", lambda: P1.action(0xFE), "FF FF FE 02 05 FA"),
    ("action default is broadcast", lambda: P1.action(), "FF FF FE 02 05 FA"),
    ("factory reset ID 0", lambda: P1.reset(0), "FF FF 00 02 06 F7"),
    ("sync write, 2 motors",
     lambda: P1.sync_write(0x1E, 4, [(0, h("10 00 50 01")), (1, h("20 02 60 03"))]),
     "FF FF FE 0E 83 1E 04 00 10 00 50 01 01 20 02 60 03 67"),
    ("bulk read", lambda: P1.bulk_read([(1, 0x1E, 2), (2, 0x24, 2)]),
     "FF FF FE 09 92 00 02 01 1E 02 02 24 1D"),
    # RX-28 user's manual: SYNC WRITE example 5 (4 motors) and the "Example" chapter
    ("sync write, 4 motors",
     lambda: P1.sync_write(0x1E, 4, [(0, h("10 00 50 01")), (1, h("20 02 60 03")),
                                     (2, h("30 00 70 01")), (3, h("20 02 80 03"))]),
     "FF FF FE 18 83 1E 04 00 10 00 50 01 01 20 02 60 03 02 30 00 70 01 03 20 02 80 03 12"),
    ("read model number", lambda: P1.read(1, 0x00, 3), "FF FF 01 04 02 00 03 F5"),
    ("write ID 0", lambda: P1.write(1, 0x03, b"\x00"), "FF FF 01 04 03 03 00 F4"),
    ("write angle limit, data holds FF",
     lambda: P1.write(0, 0x08, h("FF 01")), "FF FF 00 05 03 08 FF 01 EF"),
    ("write voltage limits", lambda: P1.write(0, 0x0C, h("64 AA")), "FF FF 00 05 03 0C 64 AA DD"),
    # RX-64 user's manual: REG_WRITE then ACTION
    ("reg write ID 0", lambda: P1.write(0, 0x1E, h("00 00"), registered=True),
     "FF FF 00 05 04 1E 00 00 D8"),
    ("reg write ID 1", lambda: P1.write(1, 0x1E, h("FF 03"), registered=True),
     "FF FF 01 05 04 1E FF 03 D5"),
]

STATUS_VECTORS: list[tuple[str, Status, str]] = [
    ("ping answer", Status(1, 0x00), "FF FF 01 02 00 FC"),
    ("read answer", Status(1, 0x00, b"\x20"), "FF FF 01 03 00 20 DB"),
    ("overload and overheating", Status(1, 0x24), "FF FF 01 02 24 D8"),
    ("factory reset answer", Status(0, 0x00), "FF FF 00 02 00 FD"),
    ("bulk read answer ID 1", Status(1, 0x00, h("00 80")), "FF FF 01 04 00 00 80 7A"),
    ("bulk read answer ID 2", Status(2, 0x00, h("00 80")), "FF FF 02 04 00 00 80 79"),
    ("RX-28 model and firmware", Status(1, 0x00, h("1C 00 08")), "FF FF 01 05 00 1C 00 08 D5"),
]

ALL_VECTORS = [v for _, _, v in INSTRUCTION_VECTORS] + [v for _, _, v in STATUS_VECTORS]


@pytest.mark.parametrize("vector", ALL_VECTORS)
def test_vectors_are_consistent_with_the_manuals_formulas(vector: str) -> None:
    """Guards the vectors themselves: LENGTH = parameters + 2, checksum by the formula."""
    packet = h(vector)
    assert packet[:2] == b"\xff\xff"
    assert packet[3] == len(packet) - 4
    assert packet[-1] == ref_checksum(packet[2:-1])


@pytest.mark.parametrize(("build", "vector"), [(b, v) for _, b, v in INSTRUCTION_VECTORS],
                         ids=[name for name, _, _ in INSTRUCTION_VECTORS])
def test_instruction_encodes_as_in_the_manual(build: Callable[[], Instruction],
                                              vector: str) -> None:
    instruction = build()
    assert P1.encode_instruction(instruction) == h(vector)
    assert P1.decode_instruction(h(vector)) == instruction


@pytest.mark.parametrize(("status", "vector"), [(s, v) for _, s, v in STATUS_VECTORS],
                         ids=[name for name, _, _ in STATUS_VECTORS])
def test_status_encodes_and_decodes_as_in_the_manual(status: Status, vector: str) -> None:
    assert P1.encode_status(status) == h(vector)
    assert P1.decode_status(h(vector)) == status


def test_checksum_of_the_manuals_worked_example() -> None:
    """e-Manual: ~(0x01 + 0x05 + 0x03 + 0x0C + 0x64 + 0xAA) = ~0x123 -> 0xDC."""
    assert checksum(h("01 05 03 0C 64 AA")) == 0xDC


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=300))
def test_checksum_matches_the_formula(body: bytes) -> None:
    assert checksum(body) == ref_checksum(body)
    assert (sum(body) + checksum(body)) & 0xFF == 0xFF


# -- round trips -----------------------------------------------------------------------------

@settings(max_examples=200, deadline=None)
@given(motor_id=st.integers(0, 254), code=st.integers(0, 255),
       params=st.binary(max_size=253))
def test_instruction_round_trip(motor_id: int, code: int, params: bytes) -> None:
    instruction = Instruction(motor_id, code, params)
    wire = P1.encode_instruction(instruction)
    assert wire == ref_packet(motor_id, code, params)
    assert P1.decode_instruction(wire) == instruction


@settings(max_examples=200, deadline=None)
@given(motor_id=st.integers(0, 253), error=st.integers(0, 255),
       params=st.binary(max_size=253))
def test_status_round_trip(motor_id: int, error: int, params: bytes) -> None:
    status = Status(motor_id, error, params)
    wire = P1.encode_status(status)
    assert wire == ref_packet(motor_id, error, params)
    assert P1.decode_status(wire) == status
    assert len(wire) == P1.status_size(len(params))


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 253), st.integers(0, 255), st.binary(max_size=20)),
                min_size=1, max_size=6))
def test_back_to_back_statuses_parse_in_order(answers: list[tuple[int, int, bytes]]) -> None:
    """A BULK_READ answer is several status packets with no gap: each must come out whole."""
    statuses = [Status(*a) for a in answers]
    parser = P1.parser()
    frames = parser.feed(b"".join(P1.encode_status(s) for s in statuses))
    assert [P1.as_status(f) for f in frames] == statuses
    assert parser.pending == 0
    assert parser.dropped == 0


# -- builders ----------------------------------------------------------------------------------

@settings(max_examples=100, deadline=None)
@given(address=st.integers(0, 255), length=st.integers(1, 16),
       blocks=st.lists(st.tuples(st.integers(0, 253), st.binary(min_size=16, max_size=16)),
                       max_size=10))
def test_sync_write_layout(address: int, length: int,
                           blocks: list[tuple[int, bytes]]) -> None:
    """e-Manual: address, L, then (ID, L bytes) per motor; LENGTH = (L + 1) * N + 4."""
    data = [(motor_id, block[:length]) for motor_id, block in blocks]
    wire = P1.encode_instruction(P1.sync_write(address, length, data))
    expected = bytes([address, length]) + b"".join(bytes([i]) + d for i, d in data)
    assert wire == ref_packet(0xFE, 0x83, expected)
    assert wire[3] == (length + 1) * len(data) + 4


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 253), st.integers(0, 255), st.integers(1, 255)),
                max_size=20))
def test_bulk_read_layout(requests: list[tuple[int, int, int]]) -> None:
    """e-Manual: 0x00, then (length, ID, address) per motor; LENGTH = 3N + 3."""
    wire = P1.encode_instruction(P1.bulk_read(requests))
    expected = b"\x00" + b"".join(bytes([n, i, a]) for i, a, n in requests)
    assert wire == ref_packet(0xFE, 0x92, expected)
    assert wire[3] == 3 * len(requests) + 3


def test_id_253_is_a_normal_motor_on_1_0() -> None:
    """1.0 IDs run 0..253 (0xFD); only 254 is broadcast and 255 is unused."""
    assert P1.encode_instruction(P1.read(253, 0x2B, 1)) == ref_packet(0xFD, 0x02, h("2B 01"))
    assert P1.encode_instruction(P1.ping(253)) == ref_packet(0xFD, 0x01)


# -- error byte --------------------------------------------------------------------------------

# e-Manual, "Status Packet / Error": bit -> error name
MANUAL_ERROR_BITS = {
    0: "Input Voltage Error", 1: "Angle Limit Error", 2: "Overheating Error",
    3: "Range Error", 4: "Checksum Error", 5: "Overload Error", 6: "Instruction Error",
}


def manual_name(name: str) -> str:
    return name.lower().removesuffix(" error")


@pytest.mark.parametrize("bit", sorted(MANUAL_ERROR_BITS))
def test_each_error_bit_has_its_manual_name(bit: int) -> None:
    assert P1.error_names(1 << bit) == (manual_name(MANUAL_ERROR_BITS[bit]),)


def test_error_bits_combine() -> None:
    """e-Manual: 0x24 from ID 1 means Overload and Overheating."""
    status = P1.decode_status(h("FF FF 01 02 24 D8"))
    assert set(P1.error_names(status.error)) == {"overload", "overheating"}
    assert set(P1.error_names(0x7F)) == {manual_name(n) for n in MANUAL_ERROR_BITS.values()}


def test_no_error_and_unused_bit_7_have_no_names() -> None:
    assert P1.error_names(0x00) == ()
    assert P1.error_names(0x80) == ()


# -- bad input ---------------------------------------------------------------------------------

@pytest.mark.parametrize("motor_id", [254, 255, 256, -1])
def test_read_refuses_ids_that_cannot_answer(motor_id: int) -> None:
    """READ needs one answering motor: broadcast (254) and IDs outside 0..253 are refused."""
    with pytest.raises(BAD_INPUT, match=naming(motor_id)):
        P1.read(motor_id, 0x2B, 1)


@pytest.mark.parametrize("build", [
    lambda i: P1.ping(i), lambda i: P1.write(i, 0, b"\x00"), lambda i: P1.action(i),
    lambda i: P1.reset(i), lambda i: P1.write(i, 0, b"\x00", registered=True),
])
@pytest.mark.parametrize("motor_id", [255, 300, -1])
def test_builders_refuse_ids_outside_the_protocol(build: Callable[[int], Instruction],
                                                  motor_id: int) -> None:
    with pytest.raises(BAD_INPUT, match=naming(motor_id)):
        build(motor_id)


@pytest.mark.parametrize("motor_id", [254, 255])
def test_group_instructions_refuse_non_motor_ids(motor_id: int) -> None:
    with pytest.raises(BAD_INPUT, match=naming(motor_id)):
        P1.sync_write(0x1E, 2, [(1, b"\x00\x00"), (motor_id, b"\x00\x00")])
    with pytest.raises(BAD_INPUT, match=naming(motor_id)):
        P1.bulk_read([(motor_id, 0x1E, 2)])


@pytest.mark.parametrize("motor_id", ["1", 1.0, True, None])
def test_non_integer_ids_are_refused(motor_id: object) -> None:
    with pytest.raises(ConfigError):
        P1.ping(motor_id)  # type: ignore[arg-type]


@pytest.mark.parametrize("address", [256, 1000, -1])
def test_addresses_outside_one_byte_are_refused(address: int) -> None:
    for build in (lambda: P1.read(1, address, 1), lambda: P1.write(1, address, b"\x00"),
                  lambda: P1.sync_write(address, 1, [(1, b"\x00")]),
                  lambda: P1.bulk_read([(1, address, 1)])):
        with pytest.raises(BAD_INPUT, match=naming(address)):
            build()


@pytest.mark.parametrize("length", [0, 256, -1])
def test_lengths_outside_1_to_255_are_refused(length: int) -> None:
    for build in (lambda: P1.read(1, 0, length), lambda: P1.sync_write(0, length, []),
                  lambda: P1.bulk_read([(1, 0, length)])):
        with pytest.raises(BAD_INPUT, match=naming(length)):
            build()
    with pytest.raises(BAD_INPUT, match=naming(0)):
        P1.write(1, 0, b"")


@pytest.mark.parametrize("size", [1, 3, 5])
def test_sync_write_block_of_the_wrong_length_is_refused(size: int) -> None:
    """A short block would shift every later motor's data: refuse it, naming the motor."""
    with pytest.raises(PacketError, match=naming(7)) as caught:
        P1.sync_write(0x1E, 4, [(1, bytes(4)), (7, bytes(size))])
    assert re.search(naming(size), str(caught.value))
    assert re.search(naming(4), str(caught.value))


def test_too_many_parameters_for_one_packet() -> None:
    """LENGTH is one byte: at most 253 parameters fit."""
    assert P1.encode_instruction(Instruction(1, 0x03, bytes(253)))[3] == 255
    with pytest.raises(PacketError, match=naming(254)):
        P1.encode_instruction(Instruction(1, 0x03, bytes(254)))


@pytest.mark.parametrize("wire", [
    "FF FF 01 03 00 20 DA",           # checksum off by one
    "FF FF 01 03 00 20",              # truncated
    "FF FF 01 03 00 20 DB 00",        # trailing byte
    "00 FF FF 01 03 00 20 DB",        # leading byte
    "FF FF 01 03 00 20 DB FF FF 01 02 00 FC",  # two packets
    "FF FF FF 02 01 FD",              # ID 255, although its checksum is right
    "FF FF 01 01 00 FD",              # LENGTH < 2
    "",
])
def test_decode_refuses_anything_but_one_valid_packet(wire: str) -> None:
    with pytest.raises(PacketError):
        P1.decode_status(h(wire))


def test_device_side_parser_reports_packets_with_a_bad_checksum() -> None:
    """A real motor answers a whole packet with a wrong checksum with the checksum error."""
    parser = P1.parser(keep_rejected=True)
    assert parser.feed(h("FF FF 01 04 02 2B 01 CD")) == []
    assert [frame.id for frame in parser.rejected] == [1]
