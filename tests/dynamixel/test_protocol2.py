"""Protocol 2.0 packets, byte for byte as the ROBOTIS e-Manual gives them.

The vectors are copied from the e-Manual (https://emanual.robotis.com/docs/en/dxl/protocol2/,
source ROBOTIS-GIT/emanual docs/en/dxl/protocol2.md), never from our own output. The CRC is
checked against a bit-by-bit CRC-16 written here from its definition (polynomial 0x8005,
initial value 0, no reflection: the catalogue's CRC-16/BUYPASS), and byte stuffing against a
literal reading of the e-Manual's "Packet Process" rules. A motor drops a packet with a wrong
CRC or length, and one missing stuffing byte lets data look like a header to every motor on
the bus.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servolab.dynamixel.errors import ConfigError, PacketError
from servolab.dynamixel.packets import Frame, Instruction, Status
from servolab.dynamixel.protocol2 import PROTOCOL2, crc16, stuff, unstuff

P2 = PROTOCOL2
BAD_INPUT = (ConfigError, PacketError)
HEADER = b"\xff\xff\xfd\x00"
FFFFFD = b"\xff\xff\xfd"


# -- independent references --------------------------------------------------------------------

def ref_crc16(data: bytes) -> int:
    """CRC-16, polynomial 0x8005, initial 0, MSB first: one bit at a time, from the definition."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def ref_stuff(body: bytes) -> bytes:
    """e-Manual: wherever FF FF FD appears in instruction..parameters, add a FD after it."""
    out = bytearray()
    for i, byte in enumerate(body):
        out.append(byte)
        if i >= 2 and body[i - 2:i + 1] == FFFFFD:
            out.append(0xFD)
    return bytes(out)


def ref_unstuff(body: bytes) -> bytes:
    """e-Manual: FF FF FD FD in a received body is FF FF FD plus one stuffing byte."""
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        stuffed = i >= 2 and body[i - 2:i + 1] == FFFFFD and body[i + 1:i + 2] == b"\xfd"
        i += 2 if stuffed else 1
    return bytes(out)


def ref_packet(motor_id: int, code: int, params: bytes = b"") -> bytes:
    """A 2.0 packet built straight from the e-Manual's layout, independent of servolab."""
    body = ref_stuff(bytes([code]) + params)
    head = HEADER + bytes([motor_id]) + (len(body) + 2).to_bytes(2, "little")
    return head + body + ref_crc16(head + body).to_bytes(2, "little")


def h(text: str) -> bytes:
    return bytes.fromhex(text)


def naming(value: object) -> str:
    """A regex that finds ``value`` as a whole number in an error message."""
    return rf"(?<![\w-]){re.escape(str(value))}(?![\w])"


def with_headers(max_size: int = 40) -> st.SearchStrategy[bytes]:
    """Bytes that often hold FF FF FD, FF runs and FD runs: what byte stuffing is about."""
    piece = st.one_of(st.binary(min_size=1, max_size=6),
                      st.sampled_from([FFFFFD, FFFFFD + b"\xfd", HEADER, b"\xff", b"\xff\xff",
                                       b"\xfd", b"\xfd\xfd", b"\x00"]))
    return st.lists(piece, max_size=12).map(lambda parts: b"".join(parts)[:max_size])


ids = st.one_of(st.integers(0, 252), st.just(254))


# -- e-Manual vectors --------------------------------------------------------------------------

INSTRUCTION_VECTORS: list[tuple[str, Callable[[], Instruction], str]] = [
    ("ping ID 1", lambda: P2.ping(1), "FF FF FD 00 01 03 00 01 19 4E"),
    ("ping broadcast", lambda: P2.ping(0xFE), "FF FF FD 00 FE 03 00 01 31 42"),
    ("read present position", lambda: P2.read(1, 132, 4),
     "FF FF FD 00 01 07 00 02 84 00 04 00 1D 15"),
    ("write goal position 512", lambda: P2.write(1, 116, (512).to_bytes(4, "little")),
     "FF FF FD 00 01 09 00 03 74 00 00 02 00 00 CA 89"),
    ("reg write goal velocity 200",
     lambda: P2.write(1, 104, (200).to_bytes(4, "little"), registered=True),
     "FF FF FD 00 01 09 00 04 68 00 C8 00 00 00 AE 8E"),
    ("action", lambda: P2.action(1), "FF FF FD 00 01 03 00 05 02 CE"),
    ("factory reset except ID", lambda: P2.factory_reset(1, 0x01),
     "FF FF FD 00 01 04 00 06 01 A1 E6"),
    ("reboot", lambda: P2.reboot(1), "FF FF FD 00 01 03 00 08 2F 4E"),
    ("clear multi-turn (no builder: raw instruction)",
     lambda: Instruction(1, P2.instructions["CLEAR"], h("01 44 58 4C 22")),
     "FF FF FD 00 01 08 00 10 01 44 58 4C 22 B1 DC"),
    # The e-Manual prints LEN 0x09 here: 1 instruction + 6 parameters + 2 CRC.
    ("sync read", lambda: P2.sync_read(132, 4, [1, 2]),
     "FF FF FD 00 FE 09 00 82 84 00 04 00 01 02 CE FA"),
    ("sync write", lambda: P2.sync_write(116, 4, [(1, (150).to_bytes(4, "little")),
                                                  (2, (170).to_bytes(4, "little"))]),
     "FF FF FD 00 FE 11 00 83 74 00 04 00 01 96 00 00 00 02 AA 00 00 00 82 87"),
    ("bulk read", lambda: P2.bulk_read([(1, 144, 2), (2, 146, 1)]),
     "FF FF FD 00 FE 0D 00 92 01 90 00 02 00 02 92 00 01 00 1A 05"),
    ("bulk write", lambda: P2.bulk_write([(1, 32, h("A0 00")), (2, 31, h("50"))]),
     "FF FF FD 00 FE 10 00 93 01 20 00 02 00 A0 00 02 1F 00 01 00 50 B7 68"),
]

STATUS_VECTORS: list[tuple[str, Status, str]] = [
    ("ping answer XM430-W210", Status(1, 0, h("06 04 26")),
     "FF FF FD 00 01 07 00 55 00 06 04 26 65 5D"),
    ("ping answer ID 2", Status(2, 0, h("06 04 26")),
     "FF FF FD 00 02 07 00 55 00 06 04 26 6F 6D"),
    ("read answer 166", Status(1, 0, h("A6 00 00 00")),
     "FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0"),
    ("sync read answer 2079", Status(2, 0, h("1F 08 00 00")),
     "FF FF FD 00 02 08 00 55 00 1F 08 00 00 BA BE"),
    ("write answer", Status(1, 0), "FF FF FD 00 01 04 00 55 00 A1 0C"),
    ("bulk read answer voltage", Status(1, 0, h("77 00")),
     "FF FF FD 00 01 06 00 55 00 77 00 C3 69"),
    ("bulk read answer temperature", Status(2, 0, h("24")),
     "FF FF FD 00 02 05 00 55 00 24 8B A9"),
]

ALL_VECTORS = [v for _, _, v in INSTRUCTION_VECTORS] + [v for _, _, v in STATUS_VECTORS]


@pytest.mark.parametrize("vector", ALL_VECTORS)
def test_vectors_are_consistent_with_the_manuals_rules(vector: str) -> None:
    """Guards the vectors themselves: LEN = instruction + parameters + CRC, CRC by definition."""
    packet = h(vector)
    assert packet[:4] == HEADER
    assert int.from_bytes(packet[5:7], "little") == len(packet) - 7
    assert int.from_bytes(packet[-2:], "little") == ref_crc16(packet[:-2])


@pytest.mark.parametrize(("build", "vector"), [(b, v) for _, b, v in INSTRUCTION_VECTORS],
                         ids=[name for name, _, _ in INSTRUCTION_VECTORS])
def test_instruction_encodes_as_in_the_manual(build: Callable[[], Instruction],
                                              vector: str) -> None:
    instruction = build()
    assert P2.encode_instruction(instruction) == h(vector)
    assert P2.decode_instruction(h(vector)) == instruction


@pytest.mark.parametrize(("status", "vector"), [(s, v) for _, s, v in STATUS_VECTORS],
                         ids=[name for name, _, _ in STATUS_VECTORS])
def test_status_encodes_and_decodes_as_in_the_manual(status: Status, vector: str) -> None:
    assert P2.encode_status(status) == h(vector)
    assert P2.decode_status(h(vector)) == status


def test_ping_answer_carries_model_and_firmware() -> None:
    """e-Manual: the XM430-W210 answers model number 1030 (0x0406), firmware 38 (0x26)."""
    status = P2.decode_status(h("FF FF FD 00 01 07 00 55 00 06 04 26 65 5D"))
    assert int.from_bytes(status.params[:2], "little") == 1030
    assert status.params[2] == 38


# -- CRC -------------------------------------------------------------------------------------

def test_crc_check_value() -> None:
    """The CRC catalogue's check value of CRC-16/BUYPASS for "123456789" is 0xFEE8."""
    assert ref_crc16(b"123456789") == 0xFEE8
    assert crc16(b"123456789") == 0xFEE8
    assert crc16(b"") == 0


@pytest.mark.parametrize("vector", ALL_VECTORS)
def test_crc_of_every_manual_packet(vector: str) -> None:
    packet = h(vector)
    assert crc16(packet[:-2]) == int.from_bytes(packet[-2:], "little")


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=400), st.integers(0, 400))
def test_crc_matches_bitwise_definition_and_chains(data: bytes, cut: int) -> None:
    assert crc16(data) == ref_crc16(data)
    assert crc16(data[cut:], crc16(data[:cut])) == crc16(data)


# -- byte stuffing -----------------------------------------------------------------------------

@pytest.mark.parametrize(("body", "stuffed"), [
    ("", ""),
    ("55 00", "55 00"),
    ("FF FF FD", "FF FF FD FD"),                           # at the very end
    ("03 FF FF FD", "03 FF FF FD FD"),
    ("FF FF FD 00 01", "FF FF FD FD 00 01"),               # a whole header
    ("FF FF FD FF FF FD", "FF FF FD FD FF FF FD FD"),      # repeated
    ("FF FF FD FD", "FF FF FD FD FD"),                     # already looks stuffed
    ("FF FF FF FD", "FF FF FF FD FD"),                     # three FF
    ("FF FF FD FD FD", "FF FF FD FD FD FD"),
    ("FF FD FD", "FF FD FD"),                              # one FF is not a header
    ("FF FF FC FD", "FF FF FC FD"),
    ("FF 00 FF FD", "FF 00 FF FD"),
    ("FD FF FF", "FD FF FF"),
])
def test_stuffing_edge_cases(body: str, stuffed: str) -> None:
    assert ref_stuff(h(body)) == h(stuffed)  # the reference reads the manual the same way
    assert stuff(h(body)) == h(stuffed)
    assert unstuff(h(stuffed)) == h(body)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.sampled_from([0xFF, 0xFD, 0x00]), max_size=30).map(bytes))
def test_stuffing_is_the_manuals_rule_and_reversible(body: bytes) -> None:
    """Over the alphabet FF/FD/00 every overlap of headers and stuffing bytes turns up."""
    assert stuff(body) == ref_stuff(body)
    assert unstuff(stuff(body)) == body
    assert ref_unstuff(stuff(body)) == body
    # after stuffing, every FF FF FD is followed by FD: no header can start inside a body
    stuffed = stuff(body)
    for at in range(len(stuffed) - 2):
        if stuffed[at:at + 3] == FFFFFD:
            assert stuffed[at + 3:at + 4] == b"\xfd"


@settings(max_examples=200, deadline=None)
@given(motor_id=ids, code=st.integers(0, 255), params=with_headers(200))
def test_instruction_round_trip_with_stuffing(motor_id: int, code: int, params: bytes) -> None:
    instruction = Instruction(motor_id, code, params)
    wire = P2.encode_instruction(instruction)
    assert wire == ref_packet(motor_id, code, params)
    assert P2.decode_instruction(wire) == instruction


@settings(max_examples=200, deadline=None)
@given(motor_id=st.integers(0, 252), error=st.integers(0, 255), params=with_headers(200))
def test_status_round_trip_with_stuffing(motor_id: int, error: int, params: bytes) -> None:
    """Stuffing covers the error byte too (everything from instruction to parameters)."""
    status = Status(motor_id, error, params)
    wire = P2.encode_status(status)
    assert wire == ref_packet(motor_id, 0x55, bytes([error]) + params)
    assert P2.decode_status(wire) == status
    if FFFFFD not in bytes([0x55, error]) + params:
        assert len(wire) == P2.status_size(len(params))


def test_write_of_a_header_is_stuffed() -> None:
    """WRITE of FF FF FD 00 to address 116: LEN counts the extra FD, the CRC covers it."""
    head = h("FF FF FD 00 01 0A 00 03 74 00 FF FF FD FD 00")
    expected = head + ref_crc16(head).to_bytes(2, "little")
    assert P2.encode_instruction(P2.write(1, 116, h("FF FF FD 00"))) == expected
    assert P2.decode_instruction(expected).params == h("74 00 FF FF FD 00")


def test_stuffing_reaches_across_fields() -> None:
    """Address 0xFFFF followed by data FD makes FF FF FD out of two different fields."""
    head = h("FF FF FD 00 01 07 00 03 FF FF FD FD")
    expected = head + ref_crc16(head).to_bytes(2, "little")
    assert P2.encode_instruction(P2.write(1, 0xFFFF, b"\xfd")) == expected


def test_header_inside_a_stuffed_body_is_not_a_packet() -> None:
    """A status whose data is a whole ping packet must come out as that one status."""
    inner = h("FF FF FD 00 01 03 00 01 19 4E")
    wire = P2.encode_status(Status(3, 0, inner))
    parser = P2.parser()
    assert parser.feed(wire) == [Frame(3, 0x55, b"\x00" + inner)]
    assert parser.dropped == 0
    assert parser.pending == 0


# -- error byte --------------------------------------------------------------------------------

# e-Manual, "Status Packet / Error": bit 7 is Alert, bits 6..0 a number
MANUAL_ERRORS = {
    0x01: "Result Fail", 0x02: "Instruction Error", 0x03: "CRC Error",
    0x04: "Data Range Error", 0x05: "Data Length Error", 0x06: "Data Limit Error",
    0x07: "Access Error",
}


def manual_name(name: str) -> str:
    return name.lower().removesuffix(" error")


@pytest.mark.parametrize("number", sorted(MANUAL_ERRORS))
def test_each_error_number_has_its_manual_name(number: int) -> None:
    """The low 7 bits are a number, not bits: 0x03 is CRC Error, not Result Fail+Instruction."""
    assert P2.error_names(number) == (manual_name(MANUAL_ERRORS[number]),)
    names = P2.error_names(0x80 | number)
    assert names[0] == manual_name(MANUAL_ERRORS[number])
    assert len(names) == 2
    assert "alert" in names[1]


def test_alert_alone_and_no_error() -> None:
    assert P2.error_names(0x00) == ()
    (alert,) = P2.error_names(0x80)
    assert "alert" in alert


def test_unknown_error_number_is_named_by_its_number() -> None:
    (name,) = P2.error_names(0x08)
    assert re.search(naming(8), name)


# -- bad input ---------------------------------------------------------------------------------

ANY_ID_BUILDERS: list[Callable[[int], Instruction]] = [
    lambda i: P2.ping(i), lambda i: P2.action(i), lambda i: P2.reboot(i),
    lambda i: P2.factory_reset(i, 0xFF), lambda i: P2.write(i, 116, b"\x00"),
    lambda i: P2.write(i, 116, b"\x00", registered=True),
]
MOTOR_ID_BUILDERS: list[Callable[[int], Instruction]] = [
    lambda i: P2.read(i, 132, 4),
    lambda i: P2.sync_read(132, 4, [1, i]),
    lambda i: P2.sync_write(116, 1, [(1, b"\x00"), (i, b"\x00")]),
    lambda i: P2.bulk_read([(1, 132, 4), (i, 132, 4)]),
    lambda i: P2.bulk_write([(i, 116, b"\x00")]),
]


@pytest.mark.parametrize("build", ANY_ID_BUILDERS + MOTOR_ID_BUILDERS)
@pytest.mark.parametrize("motor_id", [253, 255, 256, -1])
def test_ids_253_and_255_are_refused(build: Callable[[int], Instruction], motor_id: int) -> None:
    """2.0 does not use 253 (0xFD) or 255 (0xFF): they would look like a header."""
    with pytest.raises(BAD_INPUT, match=naming(motor_id)):
        build(motor_id)


@pytest.mark.parametrize("build", MOTOR_ID_BUILDERS)
def test_broadcast_is_refused_where_one_motor_must_answer(
        build: Callable[[int], Instruction]) -> None:
    with pytest.raises(BAD_INPUT, match=naming(254)):
        build(254)


@pytest.mark.parametrize("build", ANY_ID_BUILDERS)
def test_broadcast_is_allowed_for_commands(build: Callable[[int], Instruction]) -> None:
    assert build(254).id == 254
    assert build(252).id == 252


@pytest.mark.parametrize("address", [0x10000, -1])
def test_addresses_outside_two_bytes_are_refused(address: int) -> None:
    for build in (lambda: P2.read(1, address, 1), lambda: P2.write(1, address, b"\x00"),
                  lambda: P2.sync_read(address, 1, [1]),
                  lambda: P2.sync_write(address, 1, [(1, b"\x00")]),
                  lambda: P2.bulk_read([(1, address, 1)]),
                  lambda: P2.bulk_write([(1, address, b"\x00")])):
        with pytest.raises(BAD_INPUT, match=naming(address)):
            build()


@pytest.mark.parametrize("length", [0, 0x10000, -1])
def test_lengths_outside_1_to_65535_are_refused(length: int) -> None:
    for build in (lambda: P2.read(1, 0, length), lambda: P2.sync_read(0, length, [1]),
                  lambda: P2.sync_write(0, length, []),
                  lambda: P2.bulk_read([(1, 0, length)])):
        with pytest.raises(BAD_INPUT, match=naming(length)):
            build()


@pytest.mark.parametrize("address", [0x0000, 0x00FF, 0xFF00, 0xFFFF])
def test_address_extremes_are_little_endian(address: int) -> None:
    wire = P2.encode_instruction(P2.read(1, address, 0xFFFF))
    assert wire == ref_packet(1, 0x02, address.to_bytes(2, "little") + b"\xff\xff")


@pytest.mark.parametrize("size", [3, 5])
def test_sync_write_block_of_the_wrong_length_is_refused(size: int) -> None:
    with pytest.raises(PacketError, match=naming(9)) as caught:
        P2.sync_write(116, 4, [(1, bytes(4)), (9, bytes(size))])
    assert re.search(naming(size), str(caught.value))


@pytest.mark.parametrize("option", [0x00, 0x03, 0xFE])
def test_factory_reset_option_must_be_one_of_the_manuals(option: int) -> None:
    with pytest.raises(BAD_INPUT, match=f"0x{option:02X}"):
        P2.factory_reset(1, option)


def test_packet_longer_than_1024_is_refused() -> None:
    """LEN above 1024 is what the SDK refuses to receive; we refuse to send it."""
    assert len(P2.encode_instruction(P2.write(1, 0, bytes(1019)))) == 1031  # LEN = 1024
    with pytest.raises(PacketError, match=naming(1025)):
        P2.encode_instruction(P2.write(1, 0, bytes(1020)))


@pytest.mark.parametrize("wire", [
    "FF FF FD 00 01 04 00 55 00 A1 0D",           # CRC off by one
    "FF FF FD 00 01 04 00 55 00 A1",              # truncated
    "FF FF FD 00 01 04 00 55 00 A1 0C 00",        # trailing byte
    "FF FF FD 01 01 04 00 55 00 A1 0C",           # reserved byte is not 0
    "FF FF FD 00 01 02 00 55 A1 0C",              # LEN < 3
    "",
])
def test_decode_refuses_anything_but_one_valid_packet(wire: str) -> None:
    with pytest.raises(PacketError):
        P2.decode_status(h(wire))


@pytest.mark.parametrize(("reserved", "motor_id"), [(0x01, 1), (0xFD, 1), (0x00, 0xFD),
                                                     (0x00, 0xFF)])
def test_packets_breaking_the_header_rules_are_refused_even_with_a_good_crc(
        reserved: int, motor_id: int) -> None:
    """Reserved is always 0x00 and IDs 253/255 are never used: such bytes are line noise or
    the inside of a stuffed body, whatever their CRC says."""
    head = b"\xff\xff\xfd" + bytes([reserved, motor_id]) + h("03 00 01")
    wire = head + ref_crc16(head).to_bytes(2, "little")
    with pytest.raises(PacketError):
        P2.decode_instruction(wire)


def test_an_instruction_is_not_a_status() -> None:
    with pytest.raises(PacketError, match="0x01"):
        P2.decode_status(h("FF FF FD 00 01 03 00 01 19 4E"))


def test_device_side_parser_reports_packets_with_a_bad_crc() -> None:
    """A real motor answers a whole packet with a wrong CRC with the CRC error (0x03)."""
    parser = P2.parser(keep_rejected=True)
    assert parser.feed(h("FF FF FD 00 01 03 00 01 19 4F")) == []
    assert [frame.id for frame in parser.rejected] == [1]
