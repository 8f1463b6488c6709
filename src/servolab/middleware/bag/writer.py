"""Writing a bag: :class:`BagWriter`, which a killed recorder leaves readable.

Crashes. A robot's recorder is often stopped by pulling the power or by ``kill -9``, so the
writer never keeps a finished chunk in a user-space buffer: each chunk reaches the operating
system in one ``write`` the moment it is full, and :meth:`BagWriter.flush` ends the open chunk
early. A killed process therefore loses at most its open chunk; :mod:`.reader` recovers the
rest.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.data_stream import RecordBuilder
from mcap.writer import CompressionType, Writer

from ...signals import signals_held
from ..errors import BagError, BagWriteError
from ..messages import MessageTypes
from .layout import LIBRARY, METADATA_VERSION, ROS_DISTRO, _yaml


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


class _SpilledChunkIndexes:
    """mcap's ``Writer`` keeps one ``ChunkIndex`` per chunk until ``finish`` writes the
    summary: about 5 kB a chunk with the walk's 45 channels (an offset per channel), and the
    recorder ends a chunk every second, so a ten-hour walk would hold 180 MB for it
    (``benchmarks/soak.py``). Here each is serialized to an anonymous temporary file as its
    chunk ends, and this one object, left in the writer's list in their place, writes them all
    back into the summary (byte for byte what ``ChunkIndex.write`` writes): memory is then
    taken once, when the bag is closed, as mcap builds its summary. Hand-written:
    the ``mcap`` library has no way to bound its summary's memory (rosbag2 bounds it by
    splitting bags). The writer's list is private to ``mcap``: where a future version renames
    it, nothing is spilled and the bag is still written whole."""

    def __init__(self, folder: Path) -> None:
        # beside the bag, not in /tmp, which is memory (tmpfs) on many systems; unnamed, so
        # nothing is left behind; closed by close(), when the bag is finished
        self._file = tempfile.TemporaryFile(prefix=".chunk-index-", dir=folder)  # noqa: SIM115
        self.count = 0

    def take(self, indexes: list[Any]) -> None:
        """Move every ``ChunkIndex`` of ``indexes`` (mcap's list) to the file, leaving self."""
        if len(indexes) == 1 and indexes[0] is self:
            return
        builder = RecordBuilder()
        for index in indexes:
            if index is not self:
                index.write(builder)
                self.count += 1
        self._file.write(builder.end())
        indexes[:] = [self]

    def write(self, stream: RecordBuilder) -> None:
        """What ``Writer.finish`` calls on each chunk index: all of them, in order."""
        self._file.seek(0)
        while block := self._file.read(1 << 20):
            stream.write(block)

    def close(self) -> None:
        self._file.close()


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
            raise BagWriteError(f"cannot write bag {self.path}: {exc.strerror or exc}") from None
        self._chunk_indexes: list[Any] | None = getattr(self._mcap, "_Writer__chunk_indices",
                                                        None)
        self._spilled = _SpilledChunkIndexes(self.path)
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
                with signals_held():  # a stop signal must not leave half a record in a chunk
                    self._mcap.add_message(channel_id=entry.channel_id, log_time=log_time_ns,
                                           data=payload, publish_time=publish)
                    self._spill()
            except OSError as exc:
                raise BagWriteError(f"bag {self.path}: cannot write: "
                                    f"{exc.strerror or exc}") from None
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
                with signals_held():
                    self._mcap.flush()
                    self._spill()
                if fsync:
                    self._file.fsync()
            except OSError as exc:
                raise BagWriteError(f"bag {self.path}: cannot write: "
                                    f"{exc.strerror or exc}") from None

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
                    with signals_held():
                        self._mcap.add_metadata("rosbag2", {
                            "serialized_metadata": _yaml(inner).rstrip("\n"),
                            "ROS_DISTRO": ROS_DISTRO})
                        self._mcap.finish()
                    self._file.fsync()
                finally:
                    self._file.close()
                    self._spilled.close()
                self._write_metadata()
            except OSError as exc:
                raise BagWriteError(f"bag {self.path}: cannot finish: "
                                    f"{exc.strerror or exc}") from None

    def _spill(self) -> None:
        """Move the chunk indexes mcap holds to the temporary file (a chunk just ended)."""
        indexes = self._chunk_indexes
        if indexes is not None and (len(indexes) > 1 or (indexes and indexes[0] is not
                                                             self._spilled)):
            self._spilled.take(indexes)

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
