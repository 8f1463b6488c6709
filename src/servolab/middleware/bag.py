"""Recordings: MCAP files in the rosbag2 layout, written, read, described and played back.

A bag is what ``ros2 bag record -s mcap`` leaves behind: a directory ``NAME/`` holding
``NAME_0.mcap`` and ``metadata.yaml``. The MCAP file follows the ``ros2`` profile as rosbag2's
MCAP storage plugin writes it (schemas are ``ros2msg`` text, messages are CDR, each channel
carries ``offered_qos_profiles`` and ``topic_type_hash``, and a ``rosbag2`` metadata record
holds the bag's metadata, as rosbag2 Jazzy writes them), so ``ros2 bag info/play`` (on the
directory or the lone ``.mcap``), Foxglove and ``rosbags`` open servolab's recordings, and
servolab opens theirs. ``metadata.yaml`` is version 9, Jazzy's: offered QoS profiles a list.

This module knows files and timestamps, never nodes or transports: the recorder node subscribes
and hands bytes to :class:`BagWriter`; :func:`play` hands bytes to whatever ``publish`` callable
it is given.

Crashes. A robot's recorder is often stopped by pulling the power or by ``kill -9``, so the
writer never keeps a finished chunk in a user-space buffer: each chunk reaches the operating
system in one ``write`` the moment it is full, and :meth:`BagWriter.flush` ends the open chunk
early. A killed process therefore loses at most its open chunk. Such a file has no summary or
footer; :class:`BagReader` then scans it record by record, keeps every complete and
CRC-checked chunk and says so (:attr:`BagInfo.recovered`). Readers that seek (the ``mcap``
library's ``make_reader``, ``ros2 bag``) need the summary and footer: :func:`reindex`
(``servolab bag reindex``) rewrites such a file as a complete one.
"""

from __future__ import annotations

import contextlib
import heapq
import io
import math
import os
import shutil
import struct
import threading
from collections.abc import Callable, Generator, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import IO, Any

import yaml
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import breakup_chunk
from mcap.summary import Summary
from mcap.writer import CompressionType, Writer
from rosbags.typesys import get_types_from_idl, get_types_from_msg

from .. import __version__
from ..clock import Clock, WallClock
from .errors import BagError, MessageError
from .messages import MessageTypes

MCAP_MAGIC = b"\x89MCAP0\r\n"
#: rosbag2 metadata version written: 9, as rosbag2 Jazzy writes it (``offered_qos_profiles`` a
#: list of profiles whose policies are names, ``keep_last``, ``reliable``; version 8 had a YAML
#: string of numbers).
METADATA_VERSION = 9
#: rmw's RMW_DURATION_INFINITE as rosbag2 writes a duration: what deadline, lifespan and the
#: liveliness lease are for every profile servolab offers.
_INFINITE = {"sec": 9223372036, "nsec": 854775807}
#: The distribution whose message definitions (and RIHS01 hashes) servolab's types are.
ROS_DISTRO = "jazzy"
LIBRARY = f"servolab {__version__}"

_OP_HEADER, _OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 1, 2, 3, 4, 5, 6
_OP_DATA_END = 0x0F
_FOOTER_TAIL = 9 + 20 + len(MCAP_MAGIC)  # footer record (opcode, length, 3 fields) + magic
#: While waiting for a message's time, :func:`play` looks at ``should_stop`` this often.
_STOP_POLL_S = 0.05


def _best_compression() -> CompressionType:
    """zstd, else lz4, else none: whichever the ``mcap`` writer can load.

    Images and joint states compress several times over, and a robot's SD card is small; zstd
    at its default level keeps up with a camera on a small ARM board. Both are what rosbag2's
    own MCAP presets and every MCAP reader (C++, Python, Foxglove, rosbags) understand, so no
    option is offered beyond this and ``compression=`` for tests."""
    try:
        import zstandard  # noqa: F401
        return CompressionType.ZSTD
    except ImportError:
        pass
    try:
        import lz4.frame  # noqa: F401
        return CompressionType.LZ4
    except ImportError:
        return CompressionType.NONE


_COMPRESSIONS = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4,
                 "none": CompressionType.NONE, "": CompressionType.NONE}


def qos_profile(*, reliable: bool = True, transient_local: bool = False, keep_all: bool = False,
                depth: int = 10) -> dict[str, Any]:
    """One offered QoS profile, field for field as rosbag2 Jazzy writes it (``qos.cpp``,
    version 9): policies by name, durations as ``{sec, nsec}``, infinite where servolab has no
    deadline, lifespan or liveliness lease."""
    return {
        "history": "keep_all" if keep_all else "keep_last",
        "depth": depth,
        "reliability": "reliable" if reliable else "best_effort",
        "durability": "transient_local" if transient_local else "volatile",
        "deadline": dict(_INFINITE),
        "lifespan": dict(_INFINITE),
        "liveliness": "automatic",
        "liveliness_lease_duration": dict(_INFINITE),
        "avoid_ros_namespace_conventions": False,
    }


def _yaml(value: Any) -> str:
    """Block-style YAML, keys in the order given (as yaml-cpp's ``Dump`` writes them)."""
    return yaml.safe_dump(value, sort_keys=False, default_flow_style=False)


# -- what a reader reports -------------------------------------------------------------------


@dataclass(frozen=True)
class TopicInfo:
    """A topic of a bag, its message type and how many messages it holds."""

    name: str
    type: str
    count: int


@dataclass(frozen=True)
class BagMessage:
    """One recorded message: its topic, type, receive time and CDR bytes (not yet decoded, so
    playing a bag back costs no (de)serialization)."""

    topic: str
    type: str
    log_time_ns: int
    data: bytes
    publish_time_ns: int | None = None


@dataclass(frozen=True)
class BagInfo:
    """What ``ros2 bag info`` says of a bag; ``recovered`` is true for a file that was cut short
    (no footer or unreadable summary), whose messages come from its complete chunks, and
    ``lost_bytes`` is how much of its end could not be used."""

    path: Path
    topics: list[TopicInfo]
    message_count: int
    start_ns: int
    end_ns: int
    duration_s: float
    size_bytes: int
    recovered: bool
    lost_bytes: int = 0


# -- writing ---------------------------------------------------------------------------------


class _DirectFile:
    """The MCAP file without a user-space buffer: every ``write`` of the mcap writer (one per
    chunk, one per message index) goes to the OS at once, so a killed process leaves whole
    chunks on disk. The writer batches records itself, so this costs a few syscalls a chunk."""

    def __init__(self, path: Path) -> None:
        self._raw = open(path, "xb", buffering=0)  # noqa: SIM115 - closed by close()
        self._pos = 0

    def write(self, data: bytes | bytearray | memoryview) -> int:
        view = memoryview(data)
        while view:
            n = self._raw.write(view)  # a regular file may take less than all, never none
            if not n:
                raise OSError(f"no bytes written to {self._raw.name}")
            view = view[n:]
            self._pos += n
        return len(data)

    def tell(self) -> int:
        return self._pos

    def flush(self) -> None:
        """Nothing is buffered here; the OS has every byte already."""

    def fsync(self) -> None:
        os.fsync(self._raw.fileno())

    def close(self) -> None:
        self._raw.close()


@dataclass
class _Topic:
    name: str
    type: str
    channel_id: int
    type_hash: str
    qos: list[dict[str, Any]] = field(default_factory=list)
    count: int = 0


class BagWriter:
    """Writes a rosbag2 bag directory with one MCAP file.

    ``BagWriter(path, types)`` creates ``path/`` (refusing one that holds anything) and
    ``path/<name>_0.mcap``; :meth:`close` (or leaving the ``with`` block, also by an exception)
    writes the MCAP summary and index and ``metadata.yaml``.

    Threads: the calls are serialized by a lock, so a stray call from another thread cannot
    corrupt the file, but the writer is meant to be fed by one writer thread. ``write``
    serializes, compresses and writes to disk, which is too slow for a transport's receive
    callback; the recorder queues messages and drains the queue in its own thread.

    ``chunk_size`` (bytes of messages per chunk) bounds what a killed process loses; call
    :meth:`flush` every second or so to bound it in time as well.
    """

    def __init__(self, path: str | os.PathLike[str], types: MessageTypes, *,
                 chunk_size: int = 1 << 20, compression: str | None = None,
                 file_name: str | None = None) -> None:
        self.path = Path(path)
        self.types = types
        if chunk_size <= 0:
            raise BagError(f"bag {self.path}: chunk_size must be positive, not {chunk_size}")
        if compression is not None and compression not in _COMPRESSIONS:
            raise BagError(f"bag {self.path}: unknown compression {compression!r} "
                           f"(zstd, lz4 or none)")
        kind = _best_compression() if compression is None else _COMPRESSIONS[compression]
        if self.path.exists() and not self.path.is_dir():
            raise BagError(f"bag directory {self.path} exists and is not a directory")
        if self.path.is_dir() and any(self.path.iterdir()):
            raise BagError(f"bag directory {self.path} already exists and is not empty")
        try:
            self.path.mkdir(parents=True, exist_ok=True)
            if file_name is not None and (Path(file_name).name != file_name
                                          or not file_name.endswith(".mcap")):
                raise BagError(f"bag {self.path}: file name {file_name!r} is not NAME.mcap")
            self.file_path = self.path / (file_name or f"{self.path.name}_0.mcap")
            self._file = _DirectFile(self.file_path)
        except OSError as exc:
            raise BagError(f"cannot create bag {self.path}: {exc.strerror or exc}") from None
        try:
            # mcap annotates ``output`` as IO[Any] but only calls write, tell and flush,
            # which _DirectFile has: its annotation is narrower than what it needs.
            self._mcap = Writer(self._file, chunk_size=chunk_size,  # type: ignore[arg-type]
                                compression=kind)
            self._mcap.start(profile="ros2", library=LIBRARY)
        except OSError as exc:
            self._file.close()
            raise BagError(f"cannot write bag {self.path}: {exc.strerror or exc}") from None
        self._lock = threading.Lock()
        self._topics: dict[str, _Topic] = {}
        self._schemas: dict[str, int] = {}
        self._start_ns: int | None = None
        self._end_ns = 0
        self._closed = False

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self._topics.values())

    @property
    def closed(self) -> bool:
        return self._closed

    def add_topic(self, topic: str, type_name: str,
                  qos: Sequence[Mapping[str, Any]] = ()) -> None:
        """Declare a topic and its type (``pkg/msg/Name``); declaring it again with the same type
        does nothing, so a recorder may call this whenever it sees a publisher.

        ``qos`` is the profiles its publishers offer (see :func:`qos_profile`), written to the
        channel's ``offered_qos_profiles`` and to ``metadata.yaml`` as rosbag2 Jazzy does, so
        ``ros2 bag play`` offers them again."""
        with self._lock:
            self._add_topic(topic, type_name, qos)

    def _add_topic(self, topic: str, type_name: str,
                   qos: Sequence[Mapping[str, Any]] = ()) -> _Topic:
        self._check_open()
        if not topic or not isinstance(topic, str):
            raise BagError(f"bag {self.path}: topic name {topic!r} is empty")
        name = self.types.check(type_name)
        known = self._topics.get(topic)
        if known is not None:
            if known.type != name:
                raise BagError(f"bag {self.path}: topic {topic} is recorded as {known.type}, "
                               f"not {name}")
            return known
        schema_id = self._schemas.get(name)
        if schema_id is None:
            schema_id = self._mcap.register_schema(
                name=name, encoding="ros2msg", data=self.types.msgdef(name).encode())
            self._schemas[name] = schema_id
        type_hash = self.types.rihs01(name)
        profiles = [dict(p) for p in qos]
        # rosbag2_storage_mcap: YAML::Dump of the version-9 list, "[]" when there is none.
        offered = _yaml(profiles).rstrip("\n") if profiles else "[]"
        channel_id = self._mcap.register_channel(
            topic=topic, message_encoding="cdr", schema_id=schema_id,
            metadata={"offered_qos_profiles": offered, "topic_type_hash": type_hash})
        entry = self._topics[topic] = _Topic(topic, name, channel_id, type_hash, profiles)
        return entry

    def write(self, topic: str, data: bytes | bytearray | memoryview | Any, log_time_ns: int,
              publish_time_ns: int | None = None) -> None:
        """Record one message received at ``log_time_ns`` (ns since the epoch, as rosbag2).

        ``data`` is the CDR bytes as they came off the wire, or a message object, which is
        serialized (and whose topic is added on first use)."""
        publish = log_time_ns if publish_time_ns is None else publish_time_ns
        for what, value in (("log_time_ns", log_time_ns), ("publish_time_ns", publish)):
            if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < 1 << 64:
                raise BagError(f"bag {self.path}: {what} {value!r} on {topic} is not a "
                               f"non-negative integer of nanoseconds")
        with self._lock:
            self._check_open()
            if isinstance(data, bytes | bytearray | memoryview):
                entry = self._topics.get(topic)
                if entry is None:
                    raise BagError(f"bag {self.path}: topic {topic} was not added "
                                   f"(call add_topic({topic!r}, TYPE) first)")
                payload = bytes(data)
            else:
                entry = self._add_topic(topic, self.types.type_of(data))  # or its type differs
                payload = self.types.serialize(data)
            try:
                self._mcap.add_message(channel_id=entry.channel_id, log_time=log_time_ns,
                                       data=payload, publish_time=publish)
            except OSError as exc:
                raise BagError(f"bag {self.path}: cannot write: {exc.strerror or exc}") from None
            entry.count += 1
            self._start_ns = log_time_ns if self._start_ns is None else min(self._start_ns,
                                                                            log_time_ns)
            self._end_ns = max(self._end_ns, log_time_ns)

    def flush(self, *, fsync: bool = False) -> None:
        """End the open chunk and hand it to the OS, so a killed process keeps every message
        written so far; ``fsync=True`` also waits until it is on the disk (power loss)."""
        with self._lock:
            self._check_open()
            try:
                self._mcap.flush()
                if fsync:
                    self._file.fsync()
            except OSError as exc:
                raise BagError(f"bag {self.path}: cannot write: {exc.strerror or exc}") from None

    def close(self) -> None:
        """Finish the MCAP file (the ``rosbag2`` metadata record, summary, index, footer) and
        write ``metadata.yaml``. Closing again does nothing."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            try:
                try:
                    # As rosbag2_storage_mcap's update_metadata (Jazzy): the bag's metadata,
                    # without metadata.yaml's outer key, so `ros2 bag info x.mcap` needs no
                    # metadata.yaml. Its ros_distro is inside serialized_metadata.
                    inner = self.metadata()["rosbag2_bagfile_information"]
                    # ROS_DISTRO is what Humble wrote and Jazzy still reads.
                    self._mcap.add_metadata("rosbag2", {
                        "serialized_metadata": _yaml(inner).rstrip("\n"),
                        "ROS_DISTRO": ROS_DISTRO})
                    self._mcap.finish()
                    self._file.fsync()
                finally:
                    self._file.close()
                self._write_metadata()
            except OSError as exc:
                raise BagError(f"bag {self.path}: cannot finish: {exc.strerror or exc}") from None

    def _check_open(self) -> None:
        if self._closed:
            raise BagError(f"bag {self.path} is closed")

    def metadata(self) -> dict[str, Any]:
        """``metadata.yaml``'s content, field for field as rosbag2 writes it."""
        count = self.message_count
        start = self._start_ns or 0
        duration = self._end_ns - start if count else 0
        name = self.file_path.name
        return {"rosbag2_bagfile_information": {
            "version": METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {"topic_metadata": {"name": t.name, "type": t.type,
                                    "serialization_format": "cdr",
                                    "offered_qos_profiles": [dict(p) for p in t.qos],
                                    "type_description_hash": t.type_hash},
                 "message_count": t.count}
                for t in self._topics.values()],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [name],
            "files": [{"path": name,
                       "starting_time": {"nanoseconds_since_epoch": start},
                       "duration": {"nanoseconds": duration},
                       "message_count": count}],
            "custom_data": None,
            "ros_distro": ROS_DISTRO,
        }}

    def _write_metadata(self) -> None:
        """Written to a temporary name and renamed: a ``metadata.yaml`` is whole or absent."""
        text = _yaml(self.metadata())
        tmp = self.path / "metadata.yaml.tmp"
        tmp.write_text(text, encoding="utf-8")
        tmp.replace(self.path / "metadata.yaml")

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if exc_type is None:
            self.close()
            return
        with contextlib.suppress(Exception):  # the first error is the one worth reporting
            self.close()


# -- reading ---------------------------------------------------------------------------------


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
            if not schema.name or schema.name in store.fielddefs:
                continue
            try:
                text = schema.data.decode("utf-8")
                if schema.encoding == "ros2msg":
                    parsed = get_types_from_msg(text, schema.name)
                elif schema.encoding == "ros2idl":
                    parsed = get_types_from_idl(text)
                else:
                    raise ValueError(f"its schema is {schema.encoding or 'missing'}, "
                                     f"not ros2msg")
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


# -- describing ------------------------------------------------------------------------------


def _size(n: int) -> str:
    if n < 1024:
        return f"{n} B"
    value, unit = n / 1024, "KiB"
    for bigger in ("MiB", "GiB"):
        if value < 1024:
            break
        value, unit = value / 1024, bigger
    return f"{value:.1f} {unit}"


def _stamp(ns: int) -> str:
    local = datetime.fromtimestamp(ns / 1e9).strftime("%b %d %Y %H:%M:%S")
    return f"{local}.{ns % 1_000_000_000:09d} ({ns // 1_000_000_000}.{ns % 1_000_000_000:09d})"


def format_info(info: BagInfo) -> str:
    """The bag described as ``ros2 bag info`` does."""
    label = 19
    lines = [
        f"{'Files:':<{label}}{info.path}",
        f"{'Bag size:':<{label}}{_size(info.size_bytes)}",
        f"{'Storage id:':<{label}}mcap",
        f"{'Duration:':<{label}}{info.duration_s:.9f}s",
        f"{'Start:':<{label}}{_stamp(info.start_ns)}",
        f"{'End:':<{label}}{_stamp(info.end_ns)}",
        f"{'Messages:':<{label}}{info.message_count}",
    ]
    if info.recovered:
        lines.append(f"{'Recovered:':<{label}}the recording was cut short; "
                     f"{info.message_count} messages read from its complete chunks, "
                     f"last {info.lost_bytes} bytes lost")
    name_w = max((len(t.name) for t in info.topics), default=0)
    type_w = max((len(t.type) for t in info.topics), default=0)
    rows = [f"Topic: {t.name:<{name_w}} | Type: {t.type:<{type_w}} | Count: {t.count} | "
            f"Serialization Format: cdr" for t in info.topics] or ["(none)"]
    lines.append(f"{'Topic information:':<{label}}{rows[0]}")
    lines.extend(" " * label + row for row in rows[1:])
    return "\n".join(lines)


# -- playing ---------------------------------------------------------------------------------


def play(reader: BagReader, publish: Callable[[str, str, bytes], None], *, rate: float = 1.0,
         clock: Clock | None = None, topics: Iterable[str] | None = None,
         start_offset: float = 0.0, should_stop: Callable[[], bool] | None = None,
         progress: Callable[[int, int], None] | None = None) -> int:
    """Publish the bag's messages (``publish(topic, type, cdr_bytes)``) at the bag's own pace.

    A message logged ``t`` seconds after the bag's start (plus ``start_offset``) is published
    ``t / rate`` seconds after ``play`` begins on ``clock`` (rate 2 is twice as fast; rate 0 or
    infinity, as fast as possible); messages before ``start_offset`` are skipped. With a
    :class:`~servolab.clock.VirtualClock` no real time passes. ``progress(done, total)`` follows
    each message: ``done`` counts messages published or skipped, ``total`` those the chosen
    topics hold. ``should_stop()`` is asked before each message and while waiting. Returns the
    number published.
    """
    if math.isnan(rate) or rate < 0:
        raise BagError(f"playback rate must be zero, positive or infinite, not {rate}")
    if math.isnan(start_offset) or start_offset < 0:
        raise BagError(f"start offset must be zero or positive seconds, not {start_offset}")
    clock = clock or WallClock()
    wanted = None if topics is None else ({topics} if isinstance(topics, str) else set(topics))
    messages = reader.messages(wanted)  # checks the topics before any time passes
    info = reader.info()
    total = sum(t.count for t in info.topics if wanted is None or t.name in wanted)
    origin_ns = info.start_ns + round(start_offset * 1e9)
    timed = 0 < rate < math.inf
    began = clock.now()
    played = 0
    with contextlib.closing(messages):  # stopping early closes the file at once
        for done, msg in enumerate(messages, 1):
            if should_stop is not None and should_stop():
                break
            if msg.log_time_ns >= origin_ns:
                if timed and not _wait_until(
                        clock, began + (msg.log_time_ns - origin_ns) / 1e9 / rate, should_stop):
                    break
                publish(msg.topic, msg.type, msg.data)
                played += 1
            if progress is not None:
                progress(done, total)
    return played


def _wait_until(clock: Clock, target: float, should_stop: Callable[[], bool] | None) -> bool:
    """Sleep until ``clock`` reads ``target``; false if ``should_stop`` said stop meanwhile."""
    while True:
        delay = target - clock.now()
        if delay <= 0:
            return True
        if should_stop is None:
            clock.sleep(delay)
            continue
        if should_stop():
            return False
        clock.sleep(min(delay, _STOP_POLL_S))
