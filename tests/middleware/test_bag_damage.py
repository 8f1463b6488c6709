"""Damaged bags: whatever was cut or flipped in a bag's file, reading it raises nothing but a
one-line BagError and gives no message that is not the recorded one.

The corpus is made here from a small bag servolab's own BagWriter writes (zstd chunks, about
fifteen of them, two topics): truncations at many offsets, and flipped bits in message data,
in record headers (opcode and length), in chunks' CRC fields and headers, in compressed chunk
bytes, in the magic, the Header record, the summary and the footer. For each, BagReader's
messages (each decoded) and check, and the ``bag info --check`` / ``bag play`` paths of the
command line, give no traceback, and every message given equals the undamaged bag's message
at the same (topic, log time) (servolab's writer writes sequence 0 everywhere, so these name
one message) or is reported lost.

Facts relied on, and where they are from:

- the MCAP spec (https://mcap.dev/spec): a Chunk's ``uncompressed_crc`` is the CRC32 of its
  uncompressed records, "a value of zero indicates that CRC validation should not be
  performed"; the Footer's ``summary_crc`` covers the summary section up through the footer's
  ``summary_offset_start``; a chunk's records field is the record's last field, so its
  compressed bytes end the record; a file starts with the magic and the Header record;
- the ``mcap`` Python library: ``make_reader(f, validate_crcs=True)`` raises
  ``CRCValidationError`` for a chunk whose CRC does not match, and without ``validate_crcs``
  (its default) gives the damaged message as it is (both shown below on the same files);
- rosbag2's ``ros2 bag reindex`` rebuilds a bag's metadata "in the event of loss or
  corruption" (rosbag2_cpp's ``Reindexer``,
  https://docs.ros.org/en/humble/p/rosbag2_cpp/generated/classrosbag2__cpp_1_1Reindexer.html);
  ``servolab bag reindex`` rewrites the MCAP file itself, whose index is inside it.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
import zstandard
from hypothesis import given
from hypothesis import strategies as st
from mcap.reader import make_reader
from mcap.records import ChunkIndex
from mcap.stream_reader import CRCValidationError

from servolab.apps.bag import check_bag, play_bag, reindex_bag
from servolab.cli import main
from servolab.middleware.bag import BagDamage, BagMessage, BagReader, BagWriter, reindex
from servolab.middleware.context import Context
from servolab.middleware.errors import BagError
from servolab.middleware.messages import MessageTypes
from tests.clirun import one_line
from tests.fuzzing import fuzzing

T0 = 1_700_000_000_000_000_000
MAGIC = b"\x89MCAP0\r\n"
PREFIX = 9                      # a record's opcode (uint8) and length (uint64)
CHUNK_CRC_AT = PREFIX + 8 + 8 + 8  # uncompressed_crc, after start, end and uncompressed size


@dataclass
class Original:
    """The undamaged bag, and where its records are."""

    path: Path
    data: bytes
    messages: list[BagMessage]
    chunks: list[ChunkIndex]                 # from mcap's own reading of the summary
    records: list[tuple[int, int, int]]      # (offset, opcode, length), in file order
    summary_start: int

    def by_key(self) -> dict[tuple[str, int], BagMessage]:
        return {(m.topic, m.log_time_ns): m for m in self.messages}

    def in_chunk(self, chunk: ChunkIndex) -> set[tuple[str, int]]:
        """The messages of one chunk: those its index's times hold (they do not overlap)."""
        return {(m.topic, m.log_time_ns) for m in self.messages
                if chunk.message_start_time <= m.log_time_ns <= chunk.message_end_time}


def write_bag(path: Path, types: MessageTypes, compression: str) -> Original:
    """120 /cmd_vel Twists and 40 /tf transforms over 1.2 s, about 11 messages a chunk."""
    with BagWriter(path, types, chunk_size=1024, compression=compression) as writer:
        for i in range(120):
            t = T0 + i * 10_000_000
            writer.write("/cmd_vel", types.from_value("geometry_msgs/msg/Twist", {
                "linear": {"x": i * 0.5}, "angular": {"z": -i / 7}}), t, t - 5)
            if i % 3 == 0:
                writer.write("/tf", types.from_value("tf2_msgs/msg/TFMessage", {"transforms": [{
                    "header": {"stamp": {"sec": i}, "frame_id": "odom"},
                    "child_frame_id": "base_link",
                    "transform": {"translation": {"x": i / 10}, "rotation": {"w": 1.0}}}]}),
                    t + 1)
    file = path / f"{path.name}_0.mcap"
    data = file.read_bytes()
    with file.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    records = []
    pos = len(MAGIC)
    while pos < len(data) - len(MAGIC):
        opcode, length = struct.unpack_from("<BQ", data, pos)
        records.append((pos, opcode, length))
        pos += PREFIX + length
    (footer_at, footer_op, _), = records[-1:]
    assert footer_op == 0x02
    summary_start = struct.unpack_from("<Q", data, footer_at + PREFIX)[0]
    messages = list(BagReader(file, types).messages())
    return Original(file, data, messages, sorted(summary.chunk_indexes,
                                                 key=lambda c: c.chunk_start_offset),
                    records, summary_start)


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory, types: MessageTypes) -> Original:
    original = write_bag(tmp_path_factory.mktemp("damage") / "run", types, "zstd")
    assert len(original.chunks) >= 10 and len(original.messages) == 160
    assert all(c.compression == "zstd" and c.chunk_length > 100 for c in original.chunks)
    return original


@pytest.fixture(scope="module")
def plain_bag(tmp_path_factory: pytest.TempPathFactory, types: MessageTypes) -> Original:
    """The same bag with uncompressed chunks, so a flipped bit lands in a message's bytes."""
    return write_bag(tmp_path_factory.mktemp("damage") / "plain", types, "none")


def flipped(data: bytes, *flips: tuple[int, int]) -> bytes:
    out = bytearray(data)
    for offset, bit in flips:
        out[offset] ^= 1 << bit
    return bytes(out)


@dataclass
class Outcome:
    messages: list[BagMessage]
    reported: list[BagDamage]    # what on_damage was given
    problems: tuple[BagDamage, ...]  # what check() found
    error: BagError | None

    def keys(self) -> set[tuple[str, int]]:
        return {(m.topic, m.log_time_ns) for m in self.messages}

    def texts(self) -> list[str]:
        return [str(d) for d in self.problems]


def read(path: Path, original: Original, types: MessageTypes) -> Outcome:
    """Read a damaged file every way a program does and hold the reader to the rules: only a
    one-line BagError, no message that is not the original's, none given twice, log-time
    order, and a message missing only if damage or a cut was reported."""
    reported: list[BagDamage] = []
    try:
        reader = BagReader(path, types, on_damage=reported.append)
        got = []
        for message in reader.messages():
            reader.decode(message)  # raises nothing: the bytes are the recorded ones
            got.append(message)
        checked = reader.check()
    except BagError as exc:
        one_line(exc, str(path))
        return Outcome([], reported, (), exc)
    want = original.by_key()
    for message in got:
        assert want.get((message.topic, message.log_time_ns)) == message, \
            f"{path}: a message that is not the recorded one: {message}"
    assert len({(m.topic, m.log_time_ns) for m in got}) == len(got), "a message given twice"
    assert [m.log_time_ns for m in got] == sorted(m.log_time_ns for m in got)
    for damage in (*reported, *checked.problems):
        one_line(damage, str(path), f"at byte {damage.offset}:")
        assert 0 <= damage.offset <= path.stat().st_size
    assert set(reported) <= set(checked.problems)  # check() lists what reading reported
    if len(got) < len(original.messages):
        assert checked.problems, f"{path}: {len(got)} messages and no damage said"
    return Outcome(got, reported, checked.problems, None)


def through_the_cli(path: Path, ctx: Context, types: MessageTypes) -> list[str]:
    """``bag info --check`` and ``bag play`` (their functions, on shared types and context):
    what they said on stderr, the check's one-line error first if it found damage, then each
    of play's warnings, one line each."""
    said: list[str] = []
    errors: list[str] = []
    warned: list[str] = []
    for run in (lambda: check_bag(str(path), said.append, types),
                lambda: play_bag(ctx, str(path), said.append, rate=0, wait_matching=0,
                                 warn=warned.append)):
        try:
            run()
        except BagError as exc:
            errors.append(one_line(exc, str(path)))
    for line in warned:
        assert line.startswith(f"servolab bag play: warning: {path} at byte ")
        assert "\n" not in line
    assert said[-1].startswith("played ")
    return errors + warned


def mcap_reads(path: Path, *, validate_crcs: bool) -> list[tuple[int, bytes]]:
    """What the ``mcap`` library's own reader gives: (log time, data) of every message."""
    with path.open("rb") as f:
        return [(m.log_time, bytes(m.data))
                for _, _, m in make_reader(f, validate_crcs=validate_crcs).iter_messages()]


# -- truncations ----------------------------------------------------------------------------


def test_a_file_cut_anywhere_gives_a_prefix_and_says_it_was_cut(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    counts = []
    for size in [*range(0, 10), *range(10, len(bag.data), len(bag.data) // 30)]:
        path = tmp_path / f"cut{size}.mcap"
        path.write_bytes(bag.data[:size])
        out = read(path, bag, types)
        if size < len(MAGIC):
            assert out.error is not None and "not an MCAP file" in str(out.error)
            continue
        assert out.error is None
        assert out.messages == bag.messages[:len(out.messages)]  # the chunks in time order
        if size < bag.summary_start:  # a cut in the data: the cut is the one problem
            assert out.reported == [], out.texts()
            assert "a recording cut short" in out.texts()[-1]
        counts.append(len(out.messages))
    assert counts == sorted(counts) and counts[0] == 0 and counts[-1] == 160


# -- flipped bits -----------------------------------------------------------------------------


def chunk_damage(bag: Original, chunk: ChunkIndex, out: Outcome) -> BagDamage:
    """The one damage said of a chunk: its messages, and only those, are missing."""
    lost = {(m.topic, m.log_time_ns) for m in bag.messages} - out.keys()
    assert lost == bag.in_chunk(chunk), out.texts()
    (damage,) = out.problems
    assert damage.offset == chunk.chunk_start_offset and damage.lost
    number = bag.chunks.index(chunk) + 1
    assert f"chunk {number} is damaged" in damage.text
    return damage


def test_a_flipped_bit_in_a_chunk_loses_that_chunk_only_and_says_which(
        bag: Original, types: MessageTypes, ctx: Context, tmp_path: Path) -> None:
    """Compressed bytes (zstd refuses them, or the CRC does), the CRC field, the header's
    uncompressed size and compression name: the chunk is skipped with its byte offset; the
    ``mcap`` library, checking CRCs, refuses the same file."""
    for n, chunk in enumerate(bag.chunks):  # each chunk one way, the ways taken in turn
        end = chunk.chunk_start_offset + chunk.chunk_length
        at = chunk.chunk_start_offset
        what, flip = [("compressed bytes", (end - chunk.compressed_size // 2, n % 8)),
                      ("its CRC", (at + CHUNK_CRC_AT + n % 4, 5)),
                      ("compressed bytes", (end - 3, 0)),
                      ("uncompressed size", (at + PREFIX + 16, 1)),
                      ("compression name", (at + PREFIX + 32 + 1, 2))][n % 5]
        path = tmp_path / f"chunk{n}.mcap"
        path.write_bytes(flipped(bag.data, flip))
        out = read(path, bag, types)
        damage = chunk_damage(bag, chunk, out)
        if what == "its CRC":
            assert "CRC" in damage.text
            with pytest.raises(CRCValidationError):
                mcap_reads(path, validate_crcs=True)
        elif what == "compressed bytes":
            with pytest.raises((CRCValidationError, zstandard.ZstdError)):
                mcap_reads(path, validate_crcs=True)
        if n == 3:  # the command line's way: one warning naming the chunk, the rest played
            warned = through_the_cli(path, ctx, types)
            assert f"{path} is damaged: 1 problem(s)" in warned[0]
            assert warned[1:] == [f"servolab bag play: warning: {damage}"]


def test_a_flipped_bit_in_message_data_is_caught_by_the_chunk_crc(
        plain_bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    """Uncompressed chunks: the bit lands in a /tf message's bytes. mcap's reader without CRC
    checks gives that message wrong; servolab's reader skips its chunk and says so."""
    bag = plain_bag
    wrong = 0
    for n, chunk in enumerate(bag.chunks[1:13:3]):
        # the records field of an uncompressed chunk is its last field: find a /tf message in
        # it by its bytes, and flip a bit in the middle of them
        tf = next(m for m in bag.messages if m.topic == "/tf"
                  and chunk.message_start_time <= m.log_time_ns <= chunk.message_end_time)
        at = bag.data.index(tf.data, chunk.chunk_start_offset) + len(tf.data) // 2
        assert at < chunk.chunk_start_offset + chunk.chunk_length
        path = tmp_path / f"data{n}.mcap"
        path.write_bytes(flipped(bag.data, (at, n % 8)))
        out = read(path, bag, types)
        damage = chunk_damage(bag, chunk, out)
        assert "CRC" in damage.text
        unchecked = dict(mcap_reads(path, validate_crcs=False))
        wrong += unchecked[tf.log_time_ns] != tf.data
        with pytest.raises(CRCValidationError):
            mcap_reads(path, validate_crcs=True)
    assert wrong == 4  # what a reader that skips the CRC would have played


def test_a_flipped_bit_in_a_record_header_loses_no_other_record(
        bag: Original, types: MessageTypes, ctx: Context, tmp_path: Path) -> None:
    """The opcode or length of records of every kind: a chunk's loses that chunk at most, any
    other record's nothing. In the whole file the summary indexes the chunks; in the file cut
    after its Data End record (no summary: read record by record) the damaged record is
    passed over, and said. Among the flips: a Message Index's opcode turned into a Message's
    (0x07 ^ 0x02), whose fields would parse as a message of a real channel at a real log
    time, and a chunk's turned into an application's own record (0x06 ^ 0x80)."""
    (data_end,) = [offset for offset, opcode, _ in bag.records if opcode == 0x0F]
    unindexed = bag.data[:data_end + PREFIX + 4]
    starts = {c.chunk_start_offset: c for c in bag.chunks}
    kinds: set[int] = set()
    for n, (offset, opcode, _) in enumerate(bag.records):
        if n % 4 and opcode in kinds:
            continue  # every kind of record, and every fourth record of the file
        kinds.add(opcode)
        flips = [(offset, 1), (offset, 7), (offset + 1 + n % 8, (n // 4) % 8)]
        for k, flip in enumerate(flips):
            for name, data in (("whole", bag.data), ("unindexed", unindexed)):
                if offset >= len(data) or (name == "whole" and k != n % 3):
                    continue
                path = tmp_path / f"{name}{offset}_{k}.mcap"
                path.write_bytes(flipped(data, flip))
                out = read(path, bag, types)
                assert out.error is None
                lost = {(m.topic, m.log_time_ns) for m in bag.messages} - out.keys()
                if offset in starts and offset > bag.chunks[1].chunk_start_offset:
                    assert lost <= bag.in_chunk(starts[offset]), (name, flip, out.texts())
                elif offset not in starts:
                    assert not lost, (name, opcode, flip, out.texts())
        if n in (0, 8):  # the Header's opcode; a chunk's
            through_the_cli(path, ctx, types)
    assert kinds >= {0x01, 0x02, 0x03, 0x04, 0x06, 0x07, 0x08, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F}


def test_a_flipped_bit_in_the_magic_header_summary_or_footer_loses_nothing(
        bag: Original, types: MessageTypes, ctx: Context, tmp_path: Path) -> None:
    """A damaged magic is said and read past; a damaged summary or footer is passed over and
    the records read one by one: every message still comes back. (A bit of the Header's
    profile or library string changes nothing servolab reads, and no CRC covers it: that one
    may pass unsaid.)"""
    footer_at = len(bag.data) - len(MAGIC) - PREFIX - 20
    places = [*((i, i % 8) for i in range(0, len(MAGIC), 3)),          # the magic
              *((i, (3 * i) % 8) for i in range(8, 8 + PREFIX + 26, 4)),   # the Header
              *((i, i % 8) for i in range(bag.summary_start, footer_at, 331)),  # the summary
              *((i, 6) for i in range(footer_at, len(bag.data), 5))]       # footer, magic
    for n, place in enumerate(places):
        path = tmp_path / f"place{place[0]}.mcap"
        path.write_bytes(flipped(bag.data, place))
        out = read(path, bag, types)
        assert out.messages == bag.messages, (place, out.texts())
        assert out.problems or 8 + PREFIX + 4 <= place[0] < 8 + PREFIX + 26, place
        if n in (0, len(places) - 1):  # the magic, the closing magic
            assert through_the_cli(path, ctx, types)[0].endswith("keeps what is sound")


def test_a_cut_file_with_a_damaged_magic_or_header_still_gives_its_chunks(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    """The issue's files "cut short, 0 messages": without a summary the reader reads the
    records one by one, and a damaged Header (or magic) no longer ends that at the start:
    reading resumes at the next sound chunk and says what it passed over."""
    cut = bag.data[:bag.chunks[-2].chunk_start_offset + 20]  # killed inside the 14th chunk
    (tmp_path / "cut.mcap").write_bytes(cut)
    whole = read(tmp_path / "cut.mcap", bag, types)
    assert len(whole.messages) > 100
    for at in [0, 3, *range(8, 8 + PREFIX + 26, 3)]:
        path = tmp_path / f"cut_header{at}.mcap"
        path.write_bytes(flipped(cut, (at, at % 8)))
        out = read(path, bag, types)
        assert out.messages == whole.messages, (at, out.texts())
        assert len(out.problems) >= 2 or at >= 8 + PREFIX + 4  # the damage, and the cut


def test_a_cut_file_whose_defining_chunk_is_damaged_says_what_it_lost(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    """Schemas and channels are written once, in the chunk where a topic first appears (the
    second chunk defines /tf); without a summary to define them again, the messages on a
    channel whose definition was in a damaged chunk are reported lost, never guessed at."""
    cut = bag.data[:bag.summary_start - 100]
    second = bag.chunks[1]
    path = tmp_path / "orphans.mcap"
    path.write_bytes(flipped(cut, (second.chunk_start_offset + 60, 1)))
    out = read(path, bag, types)
    assert {m.topic for m in out.messages} == {"/cmd_vel"} and len(out.messages) > 100
    texts = out.texts()
    assert "chunk 2 is damaged" in texts[0]
    assert any("message(s) on channel 2, which no sound record defines" in t for t in texts)
    # the first chunk holds both schemas: all is lost, and said
    path.write_bytes(flipped(cut, (bag.chunks[0].chunk_start_offset + 60, 1)))
    out = read(path, bag, types)
    assert out.messages == [] and "chunk 1 is damaged" in out.texts()[0]
    assert sum("which no sound record defines" in t for t in out.texts()) > 10


# -- the command line and reindex -----------------------------------------------------------


def test_the_command_line_says_damage_in_one_line_and_plays_the_rest(
        bag: Original, types: MessageTypes, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """``servolab`` itself, in this process: the issue's file (one bit flipped in a zstd
    chunk, which ended ``bag play`` with zstandard's traceback) is checked, played and
    reindexed, each saying the damage in one line."""
    chunk = bag.chunks[5]
    path = tmp_path / "damaged.mcap"
    path.write_bytes(flipped(bag.data, (chunk.chunk_start_offset + chunk.chunk_length - 20, 3)))
    assert main(["bag", "info", "--check", str(path)]) == 2
    out, err = capsys.readouterr()
    assert f"byte {chunk.chunk_start_offset}: chunk 6 is damaged" in out
    assert err.count("\n") == 1 and err.startswith(f"servolab bag info: error: {path} is "
                                                   "damaged: 1 problem(s)")

    # what is sound is played; the exit status (2: bad input) tells a script it was damaged
    assert main(["bag", "play", str(path), "--transport", "local", "--rate", "0",
                 "--wait-matching", "0"]) == 2
    out, err = capsys.readouterr()
    assert err.startswith(f"servolab bag play: warning: {path} at byte "
                          f"{chunk.chunk_start_offset}: chunk 6 is damaged (")
    assert err.count("\n") == 2 and "Traceback" not in err
    assert err.splitlines()[1] == (f"servolab bag play: error: {path}: 1 damaged part(s) "
                                   "skipped (servolab bag reindex keeps what is sound)")
    played = 160 - len(bag.in_chunk(chunk))
    assert f"played {played} message(s); the file has 1 damaged part(s)" in out

    said: list[str] = []
    warned: list[str] = []
    reindex_bag(str(path), said.append, warned.append, types)
    assert f"{played} message(s) kept" in said[0] and f"kept as {path.name}.damaged" in said[0]
    assert warned == ["servolab bag reindex: warning: "
                      + err.splitlines()[0].split("warning: ", 1)[1]]
    assert (tmp_path / "damaged.mcap.damaged").read_bytes() != path.read_bytes()
    # what is left is a sound file of every sound message, mcap's checking reader agrees
    assert mcap_reads(path, validate_crcs=True) == [
        (m.log_time_ns, m.data) for m in bag.messages
        if (m.topic, m.log_time_ns) not in bag.in_chunk(chunk)]
    check_bag(str(path), said.append, types)
    assert "every chunk's CRC matches" in said[-1]


def test_reindex_recovers_a_cut_bag_as_the_prefix_of_the_original(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    for n, size in enumerate((bag.chunks[4].chunk_start_offset + 50, bag.summary_start - 3,
                              len(bag.data) - 1)):
        folder = tmp_path / f"cut{n}"
        folder.mkdir()
        (folder / "cut_0.mcap").write_bytes(bag.data[:size])
        found = reindex(folder, types)
        assert found is not None and found.recovered
        again = list(BagReader(folder, types).messages())
        assert again == bag.messages[:len(again)] and len(again) == found.message_count
        assert [(t, d) for t, d in mcap_reads(folder / "cut_0.mcap", validate_crcs=True)] == [
            (m.log_time_ns, m.data) for m in again]
        assert sorted(p.name for p in folder.iterdir()) == ["cut_0.mcap", "metadata.yaml"]
        assert reindex(folder, types) is None  # sound now
    assert len(again) == 160


# -- fuzz -----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("fuzz")


@pytest.mark.fuzz
@fuzzing(50)
@given(flips=st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(0, 7)),
                      min_size=1, max_size=3),
       cut=st.one_of(st.none(), st.floats(0.05, 1.0)))
def test_random_flipped_bits_never_give_a_wrong_message(
        bag: Original, types: MessageTypes, fuzz_dir: Path,
        flips: list[tuple[float, int]], cut: float | None) -> None:
    data = flipped(bag.data, *((int(where * len(bag.data)), bit) for where, bit in flips))
    if cut is not None:
        data = data[:int(cut * len(data))]
    path = fuzz_dir / "fuzzed.mcap"
    path.write_bytes(data)
    out = read(path, bag, types)
    if out.error is None and data != bag.data:
        assert out.problems or len(out.messages) == 160


def test_a_summary_that_disagrees_with_its_chunks_is_found_by_the_check(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    """A summary whose CRC is right but whose statistics are not (as a buggy writer leaves
    it): reading takes the messages from the chunks, and the check says what is wrong."""
    (stats_at,) = [offset for offset, opcode, _ in bag.records if opcode == 0x0B]
    data = bytearray(bag.data)
    struct.pack_into("<Q", data, stats_at + PREFIX, 161)  # message_count, its first field
    footer_at = len(data) - len(MAGIC) - PREFIX - 20
    (start,) = struct.unpack_from("<Q", data, footer_at + PREFIX)
    crc = zlib.crc32(bytes(data[footer_at:footer_at + PREFIX + 16]),
                     zlib.crc32(bytes(data[start:footer_at])))  # the spec's summary_crc
    struct.pack_into("<I", data, footer_at + PREFIX + 16, crc)
    path = tmp_path / "stats.mcap"
    path.write_bytes(bytes(data))
    out = read(path, bag, types)
    assert out.messages == bag.messages
    (problem,) = out.problems
    assert problem.offset == start and not problem.lost
    assert "it counts 161 messages, the chunks hold 160" in problem.text


def test_every_damage_is_a_bag_error_of_one_line_that_may_refuse_the_bag(
        bag: Original, types: MessageTypes, tmp_path: Path) -> None:
    damage: Any = BagDamage(bag.path, 12, "chunk 1 is damaged (why); its messages are skipped")
    assert isinstance(damage, BagError) and str(damage) == (
        f"{bag.path} at byte 12: chunk 1 is damaged (why); its messages are skipped")

    def refuse(damage: BagDamage) -> None:
        raise damage

    chunk = bag.chunks[2]
    path = tmp_path / "refused.mcap"
    path.write_bytes(flipped(bag.data, (chunk.chunk_start_offset + chunk.chunk_length - 5, 0)))
    reader = BagReader(path, types, on_damage=refuse)
    with pytest.raises(BagError) as refused:
        list(reader.messages())
    one_line(refused, str(path), f"at byte {chunk.chunk_start_offset}: chunk 3 is damaged")
