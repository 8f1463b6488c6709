"""The stream parser under noise: it never crashes, never invents a packet, and resynchronises.

A half-duplex bus delivers echo, line noise, status packets cut short by a timeout and bytes
flipped by interference. Whatever arrives, the parser may only return packets that are really
on the wire with a valid checksum/CRC, must find every intact packet once the junk before it
can no longer hide it, and must not care how the bytes were split into reads.

Packets are built here from the e-Manual's layout (``ref_packet`` of the protocol tests), and a
slow reference scanner states what "resynchronising" means: scan left to right, take a packet
wherever a valid one starts, otherwise move on by one byte. The parser must agree with it.
"""

from __future__ import annotations

import itertools
import random
from collections.abc import Iterable, Sequence

import pytest
from hypothesis import given
from hypothesis import strategies as st

from servolab.dynamixel.packets import Frame, Protocol, StreamParser
from servolab.dynamixel.protocol1 import PROTOCOL1
from servolab.dynamixel.protocol2 import PROTOCOL2
from tests.dynamixel.test_protocol1 import ref_checksum
from tests.dynamixel.test_protocol1 import ref_packet as ref_packet_v1
from tests.dynamixel.test_protocol2 import ref_crc16, ref_unstuff
from tests.dynamixel.test_protocol2 import ref_packet as ref_packet_v2
from tests.fuzzing import fuzzing

PROTOCOLS: dict[int, Protocol] = {1: PROTOCOL1, 2: PROTOCOL2}
V2_MAX_LENGTH = 1024  # the SDK's RXPACKET_MAX_LEN: a longer LEN is corruption
#: the longest packet a header can announce: until that many bytes have arrived, a corrupt
#: header in noise may still be the start of a packet, so the parser has to wait for them
MAX_FRAME = {1: 0xFF + 4, 2: V2_MAX_LENGTH + 7}

# Generating whole corrupted streams dominates the run time: 150 of them per property and
# protocol keep the whole file within a few seconds.
FUZZ = fuzzing(150)
LIGHT = fuzzing(100)
#: every test here fuzzes the status stream parser (benchmarks/fuzz.py runs them longer)
pytestmark = pytest.mark.fuzz

FRAGMENTS = {
    1: [b"\xff", b"\xff\xff", b"\xff\xff\x01", b"\xff\xff\x01\x04", b"\xff\xff\x01\x02\x01",
        b"\xff\xff\xff", b"\xff\xff\xfe\x20"],
    2: [b"\xff", b"\xff\xff", b"\xff\xff\xfd", b"\xff\xff\xfd\x00", b"\xff\xff\xfd\x00\x01",
        b"\xff\xff\xfd\x00\x01\x07\x00", b"\xff\xff\xfd\xfd", b"\xff\xff\xfd\x00\xfe\x00\x04",
        b"\xff\xff\xfd\x00\x01\x03\x00\x01"],
}


# -- reference scanner -------------------------------------------------------------------------

def ref_scan_v1(stream: bytes) -> list[tuple[int, int, Frame]]:
    """(start, size, frame) of each packet a left-to-right greedy scan takes."""
    found = []
    at = 0
    while at < len(stream):
        if stream[at:at + 2] == b"\xff\xff" and at + 4 <= len(stream):
            motor_id, length = stream[at + 2], stream[at + 3]
            size = length + 4
            end = at + size
            if (motor_id != 0xFF and length >= 2 and end <= len(stream)
                    and ref_checksum(stream[at + 2:end - 1]) == stream[end - 1]):
                found.append((at, size, Frame(motor_id, stream[at + 4], stream[at + 5:end - 1])))
                at = end
                continue
        at += 1
    return found


def ref_scan_v2(stream: bytes) -> list[tuple[int, int, Frame]]:
    found = []
    at = 0
    while at < len(stream):
        if stream[at:at + 4] == b"\xff\xff\xfd\x00" and at + 7 <= len(stream):
            motor_id = stream[at + 4]
            length = int.from_bytes(stream[at + 5:at + 7], "little")
            size = length + 7
            end = at + size
            if (motor_id not in (0xFD, 0xFF) and 3 <= length <= V2_MAX_LENGTH
                    and end <= len(stream)
                    and ref_crc16(stream[at:end - 2]) == int.from_bytes(stream[end - 2:end],
                                                                        "little")):
                body = ref_unstuff(stream[at + 7:end - 2])
                found.append((at, size, Frame(motor_id, body[0], body[1:])))
                at = end
                continue
        at += 1
    return found


REF_SCAN = {1: ref_scan_v1, 2: ref_scan_v2}


# -- feeding -----------------------------------------------------------------------------------

def chunked(data: bytes, sizes: Sequence[int]) -> Iterable[bytes]:
    """``data`` cut into pieces of the given sizes, repeated as needed."""
    at = 0
    for size in itertools.cycle(sizes or [len(data) or 1]):
        if at >= len(data):
            return
        yield data[at:at + size]
        at += size


def feed_all(parser: StreamParser, pieces: Iterable[bytes]) -> list[Frame]:
    frames: list[Frame] = []
    for piece in pieces:
        result = parser.feed(piece)
        assert isinstance(result, list)
        assert all(isinstance(frame, Frame) for frame in result)
        frames += result
    return frames


def check_frames_are_real(version: int, stream: bytes, frames: list[Frame]) -> int:
    """Each frame, encoded again, is the next slice of ``stream`` with a valid checksum/CRC
    (the parser invents nothing and returns packets in order); returns their total size."""
    proto = PROTOCOLS[version]
    at = 0
    total = 0
    for frame in frames:
        assert 0 <= frame.id <= 0xFE and 0 <= frame.code <= 0xFF
        if version == 2:
            assert frame.id != 0xFD
        wire = proto.encode_instruction(proto.as_instruction(frame))
        start = stream.find(wire, at)
        assert start >= 0, f"frame {frame} is not in the stream"
        if version == 1:
            assert wire[-1] == ref_checksum(wire[2:-1])
        else:
            assert int.from_bytes(wire[-2:], "little") == ref_crc16(wire[:-2])
        at = start + len(wire)
        total += len(wire)
    return total


# -- generated traffic -------------------------------------------------------------------------

INJECTIONS = [b"", b"", b"\xff\xff\xfd", b"\xff\xff\xfd\x00", b"\xff\xff", b"\xff", b"\xfd"]


def splice(parts: tuple[bytes, int, bytes]) -> bytes:
    """``parts[2]`` inserted into ``parts[0]`` at ``parts[1]``."""
    base, at, extra = parts
    return base[:at] + extra + base[at:]


def payload() -> st.SearchStrategy[bytes]:
    """Parameters that often hold FF FF FD, FF runs or FD (stuffing, false 1.0 headers)."""
    return st.tuples(st.binary(max_size=24), st.integers(0, 24),
                     st.sampled_from(INJECTIONS)).map(splice)


@st.composite
def packet(draw: st.DrawFn, version: int) -> tuple[bytes, Frame]:
    """A valid instruction or status packet and the frame the parser must make of it."""
    params = draw(payload())
    if version == 1:
        motor_id = draw(st.integers(0, 0xFE))
        code = draw(st.integers(0, 0xFF))
        return ref_packet_v1(motor_id, code, params), Frame(motor_id, code, params)
    motor_id = draw(st.one_of(st.integers(0, 0xFC), st.just(0xFE)))
    if draw(st.booleans()):  # status: instruction 0x55, the error byte leads the parameters
        params = bytes([draw(st.integers(0, 0xFF))]) + params
        code = 0x55
    else:
        code = draw(st.integers(0, 0xFF))
    return ref_packet_v2(motor_id, code, params), Frame(motor_id, code, params)


def noise(version: int) -> st.SearchStrategy[bytes]:
    """Junk with a taste for header fragments, the worst kind for resynchronisation."""
    return st.tuples(st.binary(max_size=12), st.integers(0, 12),
                     st.sampled_from([b"", *FRAGMENTS[version]])).map(splice)


@st.composite
def impostor(draw: st.DrawFn, version: int) -> bytes:
    """A packet with a right checksum/CRC that breaks a header rule (1.0: ID 255 or LENGTH
    below 2; 2.0: reserved byte not 0, ID 253 or 255): junk, whatever its checksum says."""
    params = draw(payload())
    if version == 1:
        if draw(st.booleans()):
            return ref_packet_v1(0xFF, draw(st.integers(0, 0xFF)), params)
        body = bytes([draw(st.integers(0, 0xFE)), draw(st.integers(0, 1))])
        return b"\xff\xff" + body + bytes([ref_checksum(body)])
    reserved, motor_id = draw(st.sampled_from([(0x01, 1), (0xFD, 1), (0x55, 3), (0x00, 0xFD),
                                               (0x00, 0xFF)]))
    real = ref_packet_v2(1, draw(st.integers(0, 0xFF)), params)
    head = real[:3] + bytes([reserved, motor_id]) + real[5:-2]
    return head + ref_crc16(head).to_bytes(2, "little")


@st.composite
def corrupted(draw: st.DrawFn, version: int, wire: bytes) -> bytes:
    """``wire`` after one accident: a bit flip, an insertion, a deletion or a truncation."""
    kind = draw(st.sampled_from(["flip", "insert", "delete", "truncate"]))
    at = draw(st.integers(0, len(wire) - 1))
    if kind == "flip":
        return wire[:at] + bytes([wire[at] ^ (1 << draw(st.integers(0, 7)))]) + wire[at + 1:]
    if kind == "insert":
        extra = draw(noise(version).filter(bool))
        return wire[:at] + extra + wire[at:]
    if kind == "delete":
        return wire[:at] + wire[at + draw(st.integers(1, len(wire) - at)):]
    return wire[:at]


@st.composite
def traffic(draw: st.DrawFn, version: int) -> list[tuple[bytes, Frame | None]]:
    """Segments of a stream: intact packets with their frame, or junk (``None``): noise,
    impostors and packets hit by an accident."""
    segments: list[tuple[bytes, Frame | None]] = []
    for _ in range(draw(st.integers(1, 6))):
        junk = draw(st.sampled_from(["none", "noise", "noise", "impostor"]))
        if junk == "noise":
            segments.append((draw(noise(version)), None))
        elif junk == "impostor":
            segments.append((draw(impostor(version)), None))
        wire, frame = draw(packet(version))
        if draw(st.integers(0, 2)) == 0:
            segments.append((draw(corrupted(version, wire)), None))
        else:
            segments.append((wire, frame))
    if draw(st.booleans()):
        segments.append((draw(noise(version)), None))
    return segments


chunk_sizes = st.lists(st.integers(1, 64), max_size=8)
versions = pytest.mark.parametrize("version", [1, 2])


# -- properties --------------------------------------------------------------------------------

@versions
@LIGHT
@given(data=st.data())
def test_random_bytes_never_crash_the_parser(version: int, data: st.DataObject) -> None:
    stream = data.draw(st.one_of(
        st.binary(max_size=2000),
        st.lists(st.sampled_from([0xFF, 0xFD, 0x00, 0x01, 0x02, 0x03, 0x55, 0xFE]),
                 max_size=2000).map(bytes)))
    sizes = data.draw(chunk_sizes)
    parser = PROTOCOLS[version].parser()
    frames = feed_all(parser, chunked(stream, sizes))
    consumed = check_frames_are_real(version, stream, frames)
    assert consumed + parser.dropped + parser.pending == len(stream)
    assert parser.pending < MAX_FRAME[version]


def run(version: int, pieces: Iterable[bytes]) -> tuple[StreamParser, list[Frame]]:
    parser = PROTOCOLS[version].parser()
    return parser, feed_all(parser, pieces)


@versions
@FUZZ
@given(data=st.data())
@pytest.mark.slow
def test_parser_agrees_with_the_reference_scanner_however_cut(version: int,
                                                               data: st.DataObject) -> None:
    """Corrupted traffic fed whole, in random reads, byte by byte and in two halves: the
    parser is in the same state each time (frames, dropped and pending bytes). Once the line
    has been idle for ``MAX_FRAME`` bytes, so that every header in the stream can be judged,
    it has returned exactly what the greedy reference scan finds, nothing it does not, and
    has accounted for every byte."""
    segments = data.draw(traffic(version))
    stream = b"".join(chunk for chunk, _ in segments)
    cut = data.draw(st.integers(0, len(stream)))
    readings = [[stream], chunked(stream, data.draw(chunk_sizes)), chunked(stream, [1]),
                [stream[:cut], b"", stream[cut:]]]
    idle = bytes(MAX_FRAME[version])
    expected = REF_SCAN[version](stream + idle)
    states = []
    for pieces in readings:
        parser, frames = run(version, pieces)
        states.append((list(frames), parser.dropped, parser.pending))
        frames += parser.feed(idle)
        assert frames == [frame for _, _, frame in expected]
        consumed = check_frames_are_real(version, stream + idle, frames)
        assert consumed == sum(size for _, size, _ in expected)
        assert parser.pending == 0
        assert consumed + parser.dropped == len(stream + idle)
    assert all(state == states[0] for state in states)


@versions
@FUZZ
@given(data=st.data())
@pytest.mark.slow
def test_intact_packet_after_a_quiet_gap_is_always_found(version: int,
                                                         data: st.DataObject) -> None:
    """Resynchronisation: whatever junk came before, an untouched packet preceded by
    ``MAX_FRAME`` bytes that cannot start a header (no FF) is returned, whole, as soon as its
    last byte arrives. Shorter gaps give no such guarantee: a header in the junk may announce
    a packet that spans the good one, and only its checksum/CRC can refute it."""
    segments = data.draw(traffic(version))
    rng = random.Random(data.draw(st.integers(0, 2**32 - 1)))
    sizes = data.draw(chunk_sizes)
    parser = PROTOCOLS[version].parser()
    for chunk, frame in segments:
        if frame is None:
            feed_all(parser, chunked(chunk, sizes))
            continue
        gap = rng.randbytes(MAX_FRAME[version]).replace(b"\xff", b"\x00")
        feed_all(parser, chunked(gap, sizes))
        got = feed_all(parser, chunked(chunk, sizes))
        assert got[-1:] == [frame]
        assert parser.pending == 0


@versions
@LIGHT
@given(data=st.data())
def test_intact_traffic_is_found_whole_in_any_reads(version: int, data: st.DataObject) -> None:
    """No noise at all: every packet comes out, in order, and no byte is dropped."""
    packets = data.draw(st.lists(packet(version), min_size=1, max_size=10))
    stream = b"".join(wire for wire, _ in packets)
    parser = PROTOCOLS[version].parser()
    assert feed_all(parser, chunked(stream, data.draw(chunk_sizes))) == [f for _, f in packets]
    assert parser.dropped == 0
    assert parser.pending == 0


SHORT_STREAMS = {
    1: bytes.fromhex("00 FF FF FF 01 02 01 FB FF FF 01 02"),      # noise, ping, half a packet
    2: bytes.fromhex("FF FF FF FD 00 01 03 00 01 19 4E FF FF FD"),  # noise, ping, a header
}


@versions
def test_every_chunking_of_a_short_stream_gives_the_same_result(version: int) -> None:
    """All 2^(n-1) ways of cutting the stream into reads, exhaustively."""
    stream = SHORT_STREAMS[version]

    def state(pieces: Iterable[bytes]) -> tuple[list[Frame], int, int]:
        parser, frames = run(version, pieces)
        return frames, parser.dropped, parser.pending

    whole = state([stream])
    assert len(whole[0]) == 1
    cuts_between = len(stream) - 1
    for mask in range(1 << cuts_between):
        cuts = [0] + [i + 1 for i in range(cuts_between) if mask >> i & 1] + [len(stream)]
        assert state(stream[a:b] for a, b in itertools.pairwise(cuts)) == whole, cuts


@versions
@LIGHT
@given(data=st.data())
def test_packet_inside_a_packet_is_not_returned(version: int, data: st.DataObject) -> None:
    """A packet carried as data of another (a log, a relayed frame) is part of the outer one."""
    inner, _ = data.draw(packet(version))
    outer_id = data.draw(st.integers(0, 0xFC))
    wire = (ref_packet_v1 if version == 1 else ref_packet_v2)(outer_id, 0x03, inner)
    parser = PROTOCOLS[version].parser()
    assert parser.feed(wire) == [Frame(outer_id, 0x03, inner)]
    assert parser.dropped == 0


@versions
def test_truncated_packet_followed_by_a_good_one(version: int) -> None:
    """The everyday case: a status cut short by a timeout, then the next answer."""
    if version == 1:
        cut, good = bytes.fromhex("FF FF 01 04 02 2B"), bytes.fromhex("FF FF 01 03 00 20 DB")
        expected = Frame(1, 0x00, b"\x20")
    else:
        cut = bytes.fromhex("FF FF FD 00 01 08 00 55 00 A6")
        good = bytes.fromhex("FF FF FD 00 01 08 00 55 00 A6 00 00 00 8C C0")
        expected = Frame(1, 0x55, bytes.fromhex("00 A6 00 00 00"))
    parser = PROTOCOLS[version].parser()
    assert parser.feed(cut + good) == [expected]
    assert parser.dropped == len(cut)
    assert parser.pending == 0


@versions
def test_reset_forgets_a_partial_packet(version: int) -> None:
    """After a timeout the driver resets the parser: the stale half packet must not swallow
    the next answer."""
    good = {1: "FF FF 01 02 01 FB", 2: "FF FF FD 00 01 03 00 01 19 4E"}[version]
    wire = bytes.fromhex(good)
    parser = PROTOCOLS[version].parser()
    assert parser.feed(wire[:5]) == []
    assert parser.pending == 5
    parser.reset()
    assert (parser.pending, parser.dropped) == (0, 5)
    assert parser.feed(wire[5:] + wire) == [Frame(1, 0x01, b"")]
    assert parser.dropped == 5 + len(wire[5:])
    assert parser.pending == 0
