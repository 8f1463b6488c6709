"""Reading a bag, also one whose recording was cut short, and making such a file whole again.

A file whose writer was killed has no summary or footer; :class:`BagReader` then scans it
record by record, keeps every complete and CRC-checked chunk and says so
(:attr:`~.layout.BagInfo.recovered`). Readers that seek (the ``mcap`` library's
``make_reader``, ``ros2 bag``) need the summary and footer: :func:`reindex` (``servolab bag
reindex``) rewrites such a file as a complete one. It lives here, not with the writer, because
it is recovery: it reads what only the reader's index of a scanned file knows.
"""

from __future__ import annotations

import heapq
import io
import os
import shutil
import struct
from collections.abc import Generator, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import yaml
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk
from mcap.summary import Summary
from rosbags.typesys import get_types_from_idl, get_types_from_msg

from ..errors import BagError, MessageError
from ..messages import MessageTypes
from .layout import (
    _FOOTER_TAIL,
    _OP_CHANNEL,
    _OP_CHUNK,
    _OP_DATA_END,
    _OP_FOOTER,
    _OP_HEADER,
    _OP_MESSAGE,
    _OP_SCHEMA,
    MCAP_MAGIC,
    BagInfo,
    BagMessage,
    TopicInfo,
)
from .writer import BagWriter


@dataclass
class _Index:
    """What a reader learns once when it opens a file."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    start_ns: int = 0
    end_ns: int = 0
    #: For a scanned file: (first log time, file offset, opcode) of each chunk or bare
    #: message, so messages can be merged in log-time order without holding them all.
    segments: list[tuple[int, int, int]] = field(default_factory=list)
    scanned: bool = False
    recovered: bool = False
    lost_bytes: int = 0


class BagReader:
    """Reads a bag directory (as ``ros2 bag record`` or :class:`BagWriter` left it) or one
    ``.mcap`` file, including one whose recording was killed.

    Types in the bag that ``types`` does not know are registered from the bag's own schemas,
    so a bag from another ROS 2 system decodes.
    """

    def __init__(self, path: str | os.PathLike[str], types: MessageTypes) -> None:
        self.path = Path(path)
        self.types = types
        self.file_path = self._find_file(self.path)
        self._undecodable: dict[str, str] = {}
        try:
            with self.file_path.open("rb") as f:
                head = f.read(len(MCAP_MAGIC))
                if head != MCAP_MAGIC:
                    raise BagError(f"{self.file_path} is not an MCAP file (starts with "
                                   f"{head!r})")
                self.size_bytes = os.fstat(f.fileno()).st_size
                self._index = self._open_index(f)
        except OSError as exc:
            raise BagError(f"cannot read {self.file_path}: {exc.strerror or exc}") from None
        self._encodings = {c.topic: c.message_encoding for c in self._index.channels.values()}
        self._register_types()

    # -- opening ------------------------------------------------------------------------------

    @staticmethod
    def _find_file(path: Path) -> Path:
        if not path.exists():
            raise BagError(f"{path} does not exist")
        if not path.is_dir():
            return path
        meta = path / "metadata.yaml"
        if meta.exists():
            try:
                info = yaml.safe_load(meta.read_text(encoding="utf-8"))
                info = info["rosbag2_bagfile_information"]
                storage = info.get("storage_identifier", "")
                files = [Path(p).name for p in info["relative_file_paths"]]
            except (OSError, yaml.YAMLError, KeyError, TypeError, AttributeError) as exc:
                reason = (str(exc).splitlines() or [type(exc).__name__])[0]
                raise BagError(f"{meta} is not a rosbag2 metadata file ({reason})") from None
            if storage != "mcap":
                raise BagError(f"{path} is a {storage or 'unknown'} bag; servolab reads mcap")
            if len(files) != 1:
                raise BagError(f"{path} is split into {len(files)} files; servolab reads "
                               f"bags of one file")
            return path / files[0]
        found = sorted(path.glob("*.mcap"))
        if len(found) != 1:
            what = "no .mcap file" if not found else f"{len(found)} .mcap files"
            raise BagError(f"bag directory {path} holds {what} and no metadata.yaml")
        return found[0]

    def _open_index(self, f: IO[bytes]) -> _Index:
        """The summary when the file has a usable one, else a scan of the whole file."""
        ended = False
        if self.size_bytes >= 2 * len(MCAP_MAGIC) + _FOOTER_TAIL:
            f.seek(-_FOOTER_TAIL, io.SEEK_END)
            tail = f.read(_FOOTER_TAIL)
            ended = tail.endswith(MCAP_MAGIC) and tail[:9] == struct.pack("<BQ", _OP_FOOTER, 20)
        if ended:
            try:
                f.seek(0)
                summary = SeekingReader(f).get_summary()
            except Exception:  # a damaged summary: the records before it still count
                summary = None
            else:
                stats = summary.statistics if summary else None
                if summary and stats and (summary.chunk_indexes or not stats.message_count):
                    return self._index_from_summary(summary)
        index = self._scan(f)
        index.recovered = not ended
        return index

    @staticmethod
    def _index_from_summary(summary: Summary) -> _Index:
        stats = summary.statistics
        assert stats is not None
        counts = {cid: stats.channel_message_counts.get(cid, 0) for cid in summary.channels}
        return _Index(dict(summary.schemas), dict(summary.channels), counts,
                      stats.message_start_time, stats.message_end_time)

    def _scan(self, f: IO[bytes]) -> _Index:
        """Read the file record by record, as far as records are whole and sound.

        A record counts only if all its bytes are in the file, and a chunk only if it
        decompresses to its stated size and CRC: a process killed in the middle of writing a
        chunk leaves a short record, which ends the scan."""
        index = _Index(start_ns=1 << 64, scanned=True)
        pos = len(MCAP_MAGIC)
        size = self.size_bytes
        first = True
        while pos + 9 <= size:
            f.seek(pos)
            opcode, length = struct.unpack("<BQ", f.read(9))
            end = pos + 9 + length
            if end > size or opcode == 0 or (first and opcode != _OP_HEADER):
                break
            first = False
            if opcode in (_OP_FOOTER, _OP_DATA_END):
                pos = size
                break
            if opcode in (_OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK):
                try:
                    records = self._records(opcode, f.read(length))
                except Exception:  # a damaged record, whatever the parser says of it
                    break
                known = set(index.channels) | {r.id for r in records if isinstance(r, Channel)}
                if any(isinstance(r, Message) and r.channel_id not in known for r in records):
                    break
                stamps = [t for r in records if (t := self._take(index, r)) is not None]
                if stamps:
                    index.segments.append((min(stamps), pos, opcode))
            pos = end
        index.lost_bytes = size - pos
        return index

    @staticmethod
    def _records(opcode: int, body: bytes) -> list[Any]:
        stream = ReadDataStream(io.BytesIO(body))
        if opcode == _OP_SCHEMA:
            return [Schema.read(stream)]
        if opcode == _OP_CHANNEL:
            return [Channel.read(stream)]
        if opcode == _OP_MESSAGE:
            return [Message.read(stream, len(body))]
        chunk = Chunk.read(stream)
        if chunk.compression not in ("", "zstd", "lz4"):
            raise McapError(f"unknown chunk compression {chunk.compression!r}")
        records = breakup_chunk(chunk, validate_crc=True)
        if chunk.compression == "" and len(chunk.data) != chunk.uncompressed_size:
            raise McapError("chunk is shorter than it says")
        return records

    @staticmethod
    def _take(index: _Index, record: Any) -> int | None:
        """Learn one record of a scanned file; a message's log time is returned."""
        if isinstance(record, Schema):
            index.schemas[record.id] = record
        elif isinstance(record, Channel):
            index.channels[record.id] = record
            index.counts.setdefault(record.id, 0)
        elif isinstance(record, Message):
            index.counts[record.channel_id] += 1
            index.start_ns = min(index.start_ns, record.log_time)
            index.end_ns = max(index.end_ns, record.log_time)
            return record.log_time
        return None

    def _register_types(self) -> None:
        """Teach ``types`` the bag's types it lacks, from the schema text the bag carries (the
        type, then each type it uses after a ``===`` line and ``MSG: pkg/Name``)."""
        store = self.types.store
        for schema in self._index.schemas.values():
            if schema.name:
                self.types.load_package_of(schema.name)  # servolab's own, when it ships it
            if not schema.name or schema.name in store.fielddefs:
                continue
            try:
                text = schema.data.decode("utf-8")
                if schema.encoding == "ros2msg":
                    parsed = get_types_from_msg(text, schema.name)
                elif schema.encoding == "ros2idl":
                    parsed = get_types_from_idl(text)
                else:
                    raise BagError(f"its schema is {schema.encoding or 'missing'}, "
                                   f"not ros2msg")
                for name in parsed:  # servolab's own definitions first, where it ships them
                    self.types.load_package_of(name)
                store.register({k: v for k, v in parsed.items() if k not in store.fielddefs})
            except Exception as exc:  # rosbags raises its own parser errors
                reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
                self._undecodable[schema.name] = reason

    # -- asking -------------------------------------------------------------------------------

    def _type_of(self, channel: Channel) -> str:
        schema = self._index.schemas.get(channel.schema_id)
        return schema.name if schema else ""

    def topics(self) -> list[TopicInfo]:
        """Every topic, sorted by name, with its type and message count."""
        found: dict[tuple[str, str], int] = {}
        for cid, channel in self._index.channels.items():
            key = (channel.topic, self._type_of(channel))
            found[key] = found.get(key, 0) + self._index.counts.get(cid, 0)
        return [TopicInfo(name, type_, count) for (name, type_), count in sorted(found.items())]

    def info(self) -> BagInfo:
        topics = self.topics()
        count = sum(t.count for t in topics)
        start, end = (self._index.start_ns, self._index.end_ns) if count else (0, 0)
        return BagInfo(self.file_path, topics, count, start, end, (end - start) / 1e9,
                       self.size_bytes, self._index.recovered, self._index.lost_bytes)

    def messages(self, topics: Iterable[str] | None = None) -> Generator[BagMessage, None, None]:
        """Every message (of ``topics``, if given), in log-time order; a message logged at the
        same time as another keeps its place in the file."""
        wanted = None if topics is None else self._check_topics(topics)
        return self._messages(wanted)

    def _check_topics(self, topics: Iterable[str]) -> set[str]:
        wanted = {topics} if isinstance(topics, str) else set(topics)
        have = {c.topic for c in self._index.channels.values()}
        missing = sorted(wanted - have)
        if missing:
            raise BagError(f"bag {self.path} has no topic {', '.join(missing)} "
                           f"(it has {', '.join(sorted(have)) or 'none'})")
        return wanted

    def _messages(self, wanted: set[str] | None) -> Generator[BagMessage, None, None]:
        with self.file_path.open("rb") as f:
            if not self._index.scanned:
                found = SeekingReader(f).iter_messages(
                    topics=None if wanted is None else sorted(wanted), log_time_order=True)
                try:
                    for schema, channel, message in found:
                        yield BagMessage(channel.topic, schema.name if schema else "",
                                         message.log_time, bytes(message.data),
                                         message.publish_time)
                except (McapError, ValueError, struct.error) as exc:
                    raise BagError(f"{self.file_path} is damaged: {exc}") from None
                return
            for message in self._merge(f):
                channel = self._index.channels[message.channel_id]
                if wanted is None or channel.topic in wanted:
                    yield BagMessage(channel.topic, self._type_of(channel), message.log_time,
                                     bytes(message.data), message.publish_time)

    def _merge(self, f: IO[bytes]) -> Iterator[Message]:
        """Messages of a scanned file in log-time order, loading a chunk only once no message
        already loaded is earlier than its first one."""
        segments = sorted(self._index.segments)
        heap: list[tuple[int, int, int, Message]] = []
        i = 0
        while i < len(segments) or heap:
            while i < len(segments) and (not heap or segments[i][0] <= heap[0][0]):
                _, pos, opcode = segments[i]
                f.seek(pos)
                _, length = struct.unpack("<BQ", f.read(9))
                for j, record in enumerate(self._records(opcode, f.read(length))):
                    if isinstance(record, Message):
                        heapq.heappush(heap, (record.log_time, pos, j, record))
                i += 1
            yield heapq.heappop(heap)[3]

    def decode(self, msg: BagMessage) -> Any:
        """The message object of a recorded message."""
        encoding = self._encodings.get(msg.topic, "cdr")
        if encoding != "cdr":
            raise BagError(f"cannot decode {msg.topic}: its messages are {encoding}, not cdr")
        if msg.type in self._undecodable:
            raise BagError(f"cannot decode {msg.type} on {msg.topic}: "
                           f"{self._undecodable[msg.type]}")
        try:
            return self.types.deserialize(msg.data, msg.type)
        except MessageError as exc:
            raise BagError(f"{msg.topic} at {msg.log_time_ns} ns: {exc}") from None


# -- reindexing ------------------------------------------------------------------------------

#: rmw's policy numbers, as version-8 metadata (and Humble's channels) write them.
_POLICY_NAMES = {
    "history": ("system_default", "keep_last", "keep_all", "unknown"),
    "reliability": ("system_default", "reliable", "best_effort", "unknown", "best_available"),
    "durability": ("system_default", "transient_local", "volatile", "unknown",
                   "best_available"),
    "liveliness": ("system_default", "automatic", "manual_by_node", "manual_by_topic",
                   "unknown", "best_available"),
}


def _offered_qos(channel: Channel) -> list[dict[str, Any]]:
    """A channel's ``offered_qos_profiles`` as version-9 profiles; none if it has none or
    they do not parse."""
    try:
        profiles = yaml.safe_load(channel.metadata.get("offered_qos_profiles") or "[]")
    except yaml.YAMLError:
        return []
    if not isinstance(profiles, list) or not all(isinstance(p, dict) for p in profiles):
        return []
    out = []
    for profile in profiles:
        profile = dict(profile)
        for key, names in _POLICY_NAMES.items():
            value = profile.get(key)
            if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < len(names):
                profile[key] = names[value]
        out.append(profile)
    return out


def reindex(path: str | os.PathLike[str], types: MessageTypes, *,
            compression: str | None = None) -> BagInfo | None:
    """Rewrite a bag whose recording was cut short (killed: no summary, index or footer, and
    no ``metadata.yaml``) as a complete one, which any MCAP reader, seeking ones included,
    opens: its complete chunks are kept, in log-time order, with their topics, types, offered
    QoS and publish times; ``metadata.yaml`` is written when ``path`` is a bag directory.

    The new file is written next to the old one and renamed over it, so a reindex that is
    itself interrupted leaves the original. Returns what was recovered (:class:`BagInfo`), or
    ``None`` for a complete bag, which is left as it is."""
    reader = BagReader(path, types)
    found = reader.info()
    if not found.recovered:
        return None
    source = reader.file_path
    work = source.parent / f".{source.name}.reindex"
    try:
        if work.exists():
            shutil.rmtree(work)  # what an interrupted reindex left
        with BagWriter(work, reader.types, file_name=source.name,
                       compression=compression) as writer:
            for channel in sorted(reader._index.channels.values(), key=lambda c: c.id):
                writer.add_topic(channel.topic, reader._type_of(channel), _offered_qos(channel))
            for m in reader.messages():
                writer.write(m.topic, m.data, m.log_time_ns, m.publish_time_ns)
        os.replace(work / source.name, source)
        if reader.path.is_dir():
            os.replace(work / "metadata.yaml", reader.path / "metadata.yaml")
    except OSError as exc:
        raise BagError(f"cannot reindex {source}: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return found
