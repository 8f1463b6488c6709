"""An MCAP file read record by record, as far as its records are sound and on past those that
are not: how the reader opens a file whose summary it cannot use (a recording cut short, a
damaged footer or summary) and how ``servolab bag info --check`` goes through every record.

The ``mcap`` library does what it can: its record classes parse every record, and
``get_chunk_data_stream`` decompresses a chunk and checks the chunk's CRC (the MCAP spec's
``uncompressed_crc``, "a value of zero indicates that CRC validation should not be
performed", https://mcap.dev/spec#chunk-op0x06). Written here is only what it does not do:

- a field must lie inside its record (:class:`_Exact`): mcap's ``ReadDataStream`` takes a
  short read as the whole field, so a damaged length would give a string or a chunk's data
  cut short without a word;
- a chunk's records are split here, not by mcap's ``breakup_chunk``, for the same reason: a
  record cut short inside a chunk without a CRC would pass as a shorter one;
- the summary's CRC (the footer's ``summary_crc``), which mcap's ``SeekingReader`` never
  checks, and a summary read without the leading magic, which ``SeekingReader`` insists on;
- going on past damage: mcap's ``StreamReader`` raises at the first record that does not
  parse, and the rest of the file is lost. Here a record whose framing (opcode and length)
  cannot be trusted is skipped by looking for the next chunk whose own fields frame it
  consistently (:func:`find_chunk`), as a resynchronising reader does; what lay between is
  reported;
- suspicion where a flipped bit would otherwise pass unsaid: outside a chunk nothing has a
  CRC, so a record longer than its fields, an application's own opcode (0x80-0xFF), or a
  schema, channel or message outside the chunks of a file that keeps them in chunks (a
  Message Index's opcode is one bit away from a Message's, and its fields parse as a message
  of a real channel at a real log time) is said as damage and not taken.

Nothing here raises for damage: what is found goes into :attr:`Index.damage`, each a
one-line :class:`~.layout.BagDamage` naming the file and the offset.
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import get_chunk_data_stream
from mcap.summary import Summary

from .layout import MCAP_MAGIC, BagDamage

_PREFIX = 9  # a record's opcode (uint8) and content length (uint64)
_FOOTER_LENGTH = 8 + 8 + 4  # summary_start, summary_offset_start, summary_crc
FOOTER_TAIL = _PREFIX + _FOOTER_LENGTH + len(MCAP_MAGIC)
#: A chunk's fixed fields: message start and end time, uncompressed size, CRC, the compression's
#: length; then the compression's name and the records' uint64 length.
_CHUNK_FIXED = 8 + 8 + 8 + 4 + 4
_COMPRESSIONS = ("", "zstd", "lz4")  # the spec's well-known ones, and what mcap decompresses
_MESSAGE_FIXED = 2 + 4 + 8 + 8  # channel id, sequence, log time, publish time
_SEARCH_BLOCK = 1 << 20
_CHUNK_OPCODE = bytes([Opcode.CHUNK])

_READERS: dict[int, Callable[[ReadDataStream], Any]] = {
    Opcode.HEADER: Header.read, Opcode.FOOTER: Footer.read, Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read, Opcode.CHUNK: Chunk.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read, Opcode.CHUNK_INDEX: ChunkIndex.read,
    Opcode.ATTACHMENT: Attachment.read, Opcode.ATTACHMENT_INDEX: AttachmentIndex.read,
    Opcode.STATISTICS: Statistics.read, Opcode.METADATA: Metadata.read,
    Opcode.METADATA_INDEX: MetadataIndex.read, Opcode.SUMMARY_OFFSET: SummaryOffset.read,
    Opcode.DATA_END: DataEnd.read,
}
#: What the spec allows in the data section, besides the Header that opens it and the Data End
#: that closes it (https://mcap.dev/spec#data-section). Opcodes 0x80-0xFF are applications' own
#: records and are skipped; any other opcode there is damage.
_DATA_RECORDS = (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.ATTACHMENT,
                 Opcode.MESSAGE_INDEX, Opcode.METADATA)
_PRIVATE_OPCODES = 0x80


class Damaged(Exception):
    """A record that cannot be used; its text (one line) says why."""


def reason(exc: BaseException) -> str:
    """Any exception as one line: what a damaged record made a parser or decompressor say."""
    if isinstance(exc, Damaged):
        return str(exc)
    text = (str(exc).splitlines() or [""])[0]
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


class _Exact(io.BytesIO):
    """A record's content that refuses a read past its end (see the module docstring)."""

    def read(self, size: int | None = -1, /) -> bytes:
        data = super().read(size)
        if size is not None and size > 0 and len(data) < size:
            raise Damaged("a field runs past the end of its record")
        return data


def parse(opcode: int, body: bytes) -> tuple[Any, bool]:
    """One record from its content by mcap's record class, and whether it filled its content
    exactly (the spec lets a newer writer add fields at a record's end, so more is allowed).
    :class:`Damaged` if it does not parse."""
    stream = ReadDataStream(_Exact(body))
    try:
        if opcode == Opcode.MESSAGE:
            if len(body) < _MESSAGE_FIXED:
                raise Damaged(f"a message record of {len(body)} bytes is shorter than its fields")
            record = Message.read(stream, len(body))
        else:
            record = _READERS[opcode](stream)
    except Exception as exc:  # struct.error, UnicodeDecodeError, mcap's EndOfFile, ...
        raise Damaged(reason(exc)) from None
    return record, stream.count == len(body)


def chunk_records(body: bytes) -> tuple[Any, list[Any]]:
    """A chunk (from its record's content) and the schemas, channels and messages in it:
    decompressed and CRC-checked by mcap, every record inside whole. :class:`Damaged` if any
    of it is not sound."""
    chunk, _ = parse(Opcode.CHUNK, body)
    if chunk.compression not in _COMPRESSIONS:
        raise Damaged(f"unknown compression {chunk.compression!r}")
    try:
        stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    except Exception as exc:  # zstandard.ZstdError, lz4's RuntimeError, CRCValidationError, ...
        raise Damaged(reason(exc)) from None
    if size != chunk.uncompressed_size:
        raise Damaged(f"its records are {size} bytes, not the {chunk.uncompressed_size} its "
                      f"header says")
    data = stream.read(size)
    records: list[Any] = []
    pos = 0
    while pos < size:
        if pos + _PREFIX > size:
            raise Damaged("its last record is cut short")
        opcode, length = struct.unpack_from("<BQ", data, pos)
        end = pos + _PREFIX + length
        if end > size:
            raise Damaged("a record inside it runs past its end")
        if opcode in (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE):
            records.append(parse(opcode, data[pos + _PREFIX:end])[0])
        pos = end  # anything else in a chunk is skipped, as mcap's breakup_chunk does
    return chunk, records


def lengths_agree(body: bytes, length: int) -> bool:
    """Whether a chunk's content (``body``, or its first bytes) of ``length`` bytes is exactly
    as long as its own fields say: the compression name's length and the records' length. A
    flipped bit cannot keep the three in agreement, so a chunk whose lengths agree can be
    stepped over even when its data is damaged, and one whose lengths do not is not trusted
    to say where the next record starts. (The spec lets a record gain fields at its end; no
    writer adds any to a chunk, and a chunk that had some would be read as damaged.)"""
    if len(body) < _CHUNK_FIXED:
        return False
    name_length: int = struct.unpack_from("<I", body, _CHUNK_FIXED - 4)[0]
    records_at = _CHUNK_FIXED + name_length
    if len(body) < records_at + 8:
        return False
    records: int = struct.unpack_from("<Q", body, records_at)[0]
    return records_at + 8 + records == length


def chunk_framed(head: bytes, offset: int, size: int) -> bool:
    """Whether ``head`` (the first bytes of a record at ``offset`` in a file of ``size``
    bytes) starts a chunk that holds together: its lengths agree (:func:`lengths_agree`), its
    compression is a known one, its start time is no later than its end, and it ends inside
    the file."""
    if len(head) < _PREFIX + _CHUNK_FIXED or head[0] != Opcode.CHUNK:
        return False
    length: int = struct.unpack_from("<Q", head, 1)[0]
    start, end = struct.unpack_from("<QQ", head, _PREFIX)
    name_length: int = struct.unpack_from("<I", head, _PREFIX + _CHUNK_FIXED - 4)[0]
    name_at = _PREFIX + _CHUNK_FIXED
    name = head[name_at:name_at + name_length] if name_length <= 4 else b"?"
    return (name in (b"", b"zstd", b"lz4") and start <= end
            and lengths_agree(head[_PREFIX:], length) and offset + _PREFIX + length <= size)


def find_chunk(f: IO[bytes], start: int, size: int) -> int | None:
    """The offset of the first chunk at or after ``start`` whose framing is consistent
    (:func:`chunk_framed`), or ``None``: where reading resumes after damage. Chunks are what
    is looked for because their fields check each other; servolab's writer, mcap's and
    rosbag2's put every message in one."""
    pos = start
    while pos + _PREFIX + _CHUNK_FIXED <= size:
        f.seek(pos)
        data = f.read(_SEARCH_BLOCK + 64)  # 64: a chunk's framing, read past the block's end
        i = data.find(_CHUNK_OPCODE)
        while 0 <= i < _SEARCH_BLOCK:
            if chunk_framed(data[i:i + 64], pos + i, size):
                return pos + i
            i = data.find(_CHUNK_OPCODE, i + 1)
        pos += _SEARCH_BLOCK
    return None


def _near_magic(data: bytes) -> bool:
    """The MCAP magic with at most one byte changed (a flipped bit): the file is still taken
    as MCAP, and the damage reported."""
    return len(data) == len(MCAP_MAGIC) and sum(a != b for a, b in zip(
        data, MCAP_MAGIC, strict=True)) <= 1


def is_mcap_start(head: bytes) -> bool:
    """Whether a file starting with ``head`` (its first 8 bytes) is taken as MCAP."""
    return _near_magic(head)


# -- what a reader learns when it opens a file ---------------------------------------------


@dataclass
class Segment:
    """A chunk (or a message outside chunks) the reader loads messages from."""

    first_ns: int          # the earliest log time in it: the merge's order
    offset: int            # of its record in the file
    length: int            # of its record, opcode and length included
    opcode: int
    number: int = 0        # a chunk's place among the file's chunks (1, 2, ...)
    channels: frozenset[int] | None = None  # the channels of its messages, when known
    last_ns: int = 0       # the latest log time in it


@dataclass
class Index:
    """What a reader learns once when it opens a file (from its summary, or a scan)."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    start_ns: int = 0
    end_ns: int = 0
    segments: list[Segment] = field(default_factory=list)
    scanned: bool = False
    recovered: bool = False
    cut: bool = False  # the file has no end (no closing magic): a recording cut short
    lost_bytes: int = 0
    damage: list[BagDamage] = field(default_factory=list)
    #: the summary it was made from, and the footer's summary start (0 if none)
    summary: Summary | None = None
    summary_start: int = 0
    #: a scan's: the chunks it found sound, where the Data End record is and its data CRC
    chunks: int = 0
    data_end: int | None = None
    data_crc: int = 0


def read_ending(f: IO[bytes], path: Path, size: int,
                damage: list[BagDamage]) -> tuple[Footer | None, bool]:
    """The footer, if the file has a sound one, and whether the file has an end at all (its
    closing magic, or nearly: else it was cut short)."""
    if size < 2 * len(MCAP_MAGIC) + FOOTER_TAIL:
        return None, False
    footer_at = size - FOOTER_TAIL
    f.seek(footer_at)
    tail = f.read(FOOTER_TAIL)
    magic = tail[-len(MCAP_MAGIC):]
    if not _near_magic(magic):
        return None, False  # no end: a recording cut short
    if magic != MCAP_MAGIC:
        damage.append(BagDamage(path, size - len(MCAP_MAGIC), f"the closing magic is "
                                f"{magic!r}, not {MCAP_MAGIC!r}; nothing is lost", lost=False))
    if tail[:_PREFIX] != struct.pack("<BQ", Opcode.FOOTER, _FOOTER_LENGTH):
        damage.append(BagDamage(path, footer_at, "the footer's opcode or length is damaged; "
                                "its summary is not used, the records are read one by one",
                                lost=False))
        return None, True
    footer, _ = parse(Opcode.FOOTER, tail[_PREFIX:_PREFIX + _FOOTER_LENGTH])
    return footer, True


def read_summary(f: IO[bytes], path: Path, size: int, footer: Footer,
                 damage: list[BagDamage]) -> Summary | None:
    """The summary the footer points at, if its CRC matches and it parses and holds together;
    else ``None``, with the damage said."""
    start = footer.summary_start
    footer_at = size - FOOTER_TAIL

    def refused(what: str) -> None:
        damage.append(BagDamage(path, start if 0 < start < size else footer_at,
                                f"the summary {what}; it is not used, the records are read "
                                "one by one", lost=False))

    if not len(MCAP_MAGIC) < start <= footer_at:
        refused(f"start the footer gives, byte {start}, is outside the file's records")
        return None
    f.seek(start)
    body = f.read(footer_at - start)
    if footer.summary_crc:
        # The spec's summary_crc: "a CRC32 of all bytes from the start of the Summary section
        # up through the end of the previous field in the footer record".
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, _FOOTER_LENGTH, start,
                                     footer.summary_offset_start), zlib.crc32(body))
        if crc != footer.summary_crc:
            refused(f"is damaged (its CRC is {crc:#010x}, the footer says "
                    f"{footer.summary_crc:#010x})")
            return None
    summary = Summary()
    pos = 0
    try:
        while pos < len(body):
            if pos + _PREFIX > len(body):
                raise Damaged("a record is cut short")
            opcode, length = struct.unpack_from("<BQ", body, pos)
            end = pos + _PREFIX + length
            if end > len(body) or opcode not in _READERS:
                raise Damaged(f"the record at byte {start + pos} is not one")
            record, _ = parse(opcode, body[pos + _PREFIX:end])
            if isinstance(record, Statistics):
                summary.statistics = record
            elif isinstance(record, Schema):
                summary.schemas[record.id] = record
            elif isinstance(record, Channel):
                summary.channels[record.id] = record
            elif isinstance(record, ChunkIndex):
                summary.chunk_indexes.append(record)
            elif isinstance(record, AttachmentIndex):
                summary.attachment_indexes.append(record)
            elif isinstance(record, MetadataIndex):
                summary.metadata_indexes.append(record)
            pos = end
    except Damaged as exc:
        refused(f"does not parse ({exc})")
        return None
    for ci in summary.chunk_indexes:
        if not (len(MCAP_MAGIC) <= ci.chunk_start_offset
                and ci.chunk_start_offset + ci.chunk_length <= start
                and ci.chunk_length > _PREFIX):
            refused(f"indexes a chunk at byte {ci.chunk_start_offset} outside the data")
            return None
    for channel in summary.channels.values():
        if channel.schema_id and channel.schema_id not in summary.schemas:
            refused(f"names schema {channel.schema_id} for {channel.topic}, and holds none")
            return None
    return summary


def index_from_summary(summary: Summary, start: int) -> Index:
    stats = summary.statistics
    assert stats is not None
    counts = {cid: stats.channel_message_counts.get(cid, 0) for cid in summary.channels}
    ordered = sorted(summary.chunk_indexes, key=lambda ci: ci.chunk_start_offset)
    segments = [Segment(ci.message_start_time, ci.chunk_start_offset, ci.chunk_length,
                        Opcode.CHUNK, number, frozenset(ci.message_index_offsets) or None,
                        ci.message_end_time)
                for number, ci in enumerate(ordered, 1)]
    return Index(dict(summary.schemas), dict(summary.channels), counts,
                 stats.message_start_time, stats.message_end_time, segments,
                 summary=summary, summary_start=start)


def _stamp(ns: int) -> str:
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"


def lost_messages(start_ns: int, end_ns: int) -> str:
    """What a damaged chunk costs, from the times its header (or index) gives."""
    if not start_ns and not end_ns:
        return "its messages are skipped"
    return f"its messages, logged {_stamp(start_ns)} to {_stamp(end_ns)} s, are skipped"


class _Framing(Exception):
    """A record whose opcode or length cannot be trusted: where the next one starts is not
    known. ``cut``: it runs past the end of the file (a recording cut short, if no sound
    chunk follows)."""

    def __init__(self, text: str, *, cut: bool = False) -> None:
        super().__init__(text)
        self.cut = cut


class Scan:
    """One pass over a file's data section (:meth:`run`), into an :class:`Index`.

    ``known`` (a sound summary's schemas and channels) defines channels whose own records
    are in a damaged chunk, so ``--check`` counts as lost only what a reader loses.
    """

    def __init__(self, f: IO[bytes], path: Path, size: int, *,
                 known: Summary | None = None, data_end_at: int = 0) -> None:
        self.f = f
        self.path = path
        self.size = size
        self.index = Index(start_ns=1 << 64, scanned=True)
        if known is not None:
            self.index.schemas.update(known.schemas)
            self.index.channels.update(known.channels)
            self.index.counts.update(dict.fromkeys(known.channels, 0))
        #: where the data section ends, by the footer: a Data End record there is the end
        self._data_ends = {size - FOOTER_TAIL}
        if data_end_at:
            self._data_ends.add(data_end_at)
        self._chunk_number = 0
        self._chunked = False  # a chunk was met: the file keeps its records in chunks

    def damaged(self, offset: int, text: str, *, lost: bool = True) -> None:
        self.index.damage.append(BagDamage(self.path, offset, text, lost=lost))

    def run(self) -> Index:
        index = self.index
        pos = sound = len(MCAP_MAGIC)  # sound: the end of the last record known whole
        first = True
        while pos < self.size:
            try:
                end, exact = self._record(pos, first)
            except _Framing as exc:
                found = find_chunk(self.f, sound + 1, self.size)
                if found is None:
                    if exc.cut:  # the unfinished record of a recording cut short
                        index.lost_bytes = self.size - pos
                    else:
                        index.lost_bytes = self.size - sound
                        self.damaged(sound, f"the rest of the file, {self.size - sound} "
                                     f"bytes, cannot be read ({exc} at byte {pos}); whatever "
                                     "it held is lost")
                    break
                self.damaged(sound, f"{found - sound} bytes cannot be read ({exc} at byte "
                             f"{pos}); reading resumes at the chunk at byte {found}")
                pos = sound = found
                first = False
                continue
            first = False
            if end is None:
                break
            if exact:
                sound = end
            pos = end
        if not index.counts or not any(index.counts.values()):
            index.start_ns = index.end_ns = 0
        return index

    def _record(self, pos: int, first: bool) -> tuple[int | None, bool]:
        """Take the record at ``pos``: its end and whether its length is known to be right,
        or ``None`` for the end of the data section."""
        f, size = self.f, self.size
        f.seek(pos)
        prefix = f.read(_PREFIX)
        if len(prefix) < _PREFIX:
            raise _Framing("the file ends inside a record's opcode and length", cut=True)
        opcode, length = struct.unpack("<BQ", prefix)
        end = pos + _PREFIX + length
        if end > size:
            raise _Framing(f"a record's length, {length} bytes, runs past the end of the file",
                           cut=True)
        if first != (opcode == Opcode.HEADER):
            raise _Framing(f"opcode {opcode:#04x} where the Header record must be" if first
                           else "a second Header record")
        if opcode == Opcode.CHUNK:
            self._chunked = True
            return self._chunk(pos, length), True
        if opcode == Opcode.DATA_END and (length == 4 or end in self._data_ends):
            data_end, _ = self._parse(opcode, f.read(length))
            self.index.data_end = pos
            self.index.data_crc = data_end.data_section_crc
            return None, True
        if opcode == Opcode.FOOTER and end == size - len(MCAP_MAGIC):
            return None, True  # no Data End record (allowed before it was in the spec)
        if opcode >= _PRIVATE_OPCODES:  # said: a damaged opcode may land here too
            self.damaged(pos, f"a record of opcode {opcode:#04x} (an application's own, or "
                         "a damaged opcode) is skipped; whatever it held is not read")
            return end, False
        if opcode in (Opcode.DATA_END, Opcode.FOOTER):
            raise _Framing(f"a {Opcode(opcode).name.lower()} record where the data section "
                           "goes on")
        if opcode not in (Opcode.HEADER, *_DATA_RECORDS):
            raise _Framing(f"opcode {opcode:#04x} has no place in the data section")
        kind = Opcode(opcode).name.lower().replace("_", " ")
        record, exact = self._parse(opcode, f.read(length))
        if not exact:
            # The spec lets a record gain fields at its end, but no writer adds any: a record
            # longer than its fields is far likelier a damaged opcode or length, which would
            # otherwise swallow the records after it unsaid.
            raise _Framing(f"a {kind} record is longer than its fields")
        if self._chunked and isinstance(record, Schema | Channel | Message):
            # Every writer that chunks (mcap's, rosbag2's, rosbags', servolab's) puts these in
            # chunks, where a CRC guards them; one outside is likelier another record (a
            # Message Index is a bit away from a Message) than what it seems.
            self.damaged(pos, f"a {kind} record outside the chunks of a file that keeps them "
                         "in chunks (likely a damaged opcode) is skipped")
            return end, False
        if isinstance(record, Schema | Channel):
            self._define(pos, record)
        elif isinstance(record, Message):
            stamps = self._messages(pos, 0, [record])
            if stamps:
                self.index.segments.append(Segment(stamps[0], pos, end - pos, opcode,
                                                   last_ns=stamps[0]))
        return end, True

    @staticmethod
    def _parse(opcode: int, body: bytes) -> tuple[Any, bool]:
        try:
            return parse(opcode, body)
        except Damaged as exc:
            raise _Framing(f"a {Opcode(opcode).name.lower()} record does not parse ({exc})"
                           ) from None

    def _chunk(self, pos: int, length: int) -> int:
        self._chunk_number += 1
        number = self._chunk_number
        self.f.seek(pos + _PREFIX)
        body = self.f.read(length)
        if not lengths_agree(body, length):
            raise _Framing(f"chunk {number}'s length, {length} bytes, is not what its fields "
                           "add up to")
        try:
            _, records = chunk_records(body)
        except Damaged as exc:
            start, end = struct.unpack_from("<QQ", body)
            self.damaged(pos, f"chunk {number} is damaged ({exc}); "
                         f"{lost_messages(start, end)}")
            return pos + _PREFIX + length
        for record in records:
            if isinstance(record, Schema | Channel):
                self._define(pos, record, number)
        messages = [r for r in records if isinstance(r, Message)]
        stamps = self._messages(pos, number, messages)
        self.index.chunks += 1
        self.index.segments.append(Segment(
            stamps[0] if stamps else 0, pos, _PREFIX + length, Opcode.CHUNK, number,
            frozenset(m.channel_id for m in messages), stamps[-1] if stamps else 0))
        return pos + _PREFIX + length

    def _define(self, pos: int, record: Schema | Channel, number: int = 0) -> None:
        """A schema or channel, unless its id is taken by a different one (damage: the spec
        says records sharing an id are identical) or, for a channel, its schema is not known
        (its messages are then reported as lost where they are)."""
        where = f"chunk {number}" if number else "a record"
        if isinstance(record, Schema):
            known_schema = self.index.schemas.get(record.id)
            if record.id == 0:
                return  # "a Schema record with an id of zero is invalid and should be ignored"
            if known_schema is None:
                self.index.schemas[record.id] = record
            elif known_schema != record:
                self.damaged(pos, f"{where} redefines schema {record.id} ({record.name}) "
                             f"differently; the first definition is kept")
            return
        known = self.index.channels.get(record.id)
        if known is not None:
            if known != record:
                self.damaged(pos, f"{where} redefines channel {record.id} ({record.topic}) "
                             "differently; the first definition is kept")
            return
        if record.schema_id and record.schema_id not in self.index.schemas:
            return
        self.index.channels[record.id] = record
        self.index.counts.setdefault(record.id, 0)

    def _messages(self, pos: int, number: int, messages: list[Message]) -> list[int]:
        """Count messages whose channel is known; report those whose is not. Their log
        times, sorted."""
        index = self.index
        stamps = []
        orphans: dict[int, int] = {}
        for m in messages:
            if m.channel_id not in index.channels:
                orphans[m.channel_id] = orphans.get(m.channel_id, 0) + 1
                continue
            index.counts[m.channel_id] += 1
            index.start_ns = min(index.start_ns, m.log_time)
            index.end_ns = max(index.end_ns, m.log_time)
            stamps.append(m.log_time)
        if orphans:
            where = f"chunk {number}" if number else "a message record"
            ids = ", ".join(str(c) for c in sorted(orphans))
            self.damaged(pos, f"{where} holds {sum(orphans.values())} message(s) on channel "
                         f"{ids}, which no sound record defines (with its schema); they are "
                         "skipped")
        return sorted(stamps)


def data_crc(f: IO[bytes], end: int) -> int:
    """The CRC32 of the file's first ``end`` bytes: the spec's data section CRC ("all bytes
    in the data section", the leading magic included, as mcap's writer computes it)."""
    crc = 0
    f.seek(0)
    left = end
    while left:
        block = f.read(min(left, _SEARCH_BLOCK))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        left -= len(block)
    return crc
