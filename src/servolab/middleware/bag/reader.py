"""Reading a bag, also one whose recording was cut short or whose bytes were damaged, and
making such a file whole again.

A complete file is read through its summary, the index of its chunks, and each chunk is
checked as it is loaded: its CRC, and every record in it whole. A file without a usable summary
(a writer killed: no summary or footer; a damaged footer or summary) is read record by record
by :mod:`.scan`, on past damage where a later chunk can be found. Either way a damaged chunk
is reported (which chunk, at what byte: a one-line :class:`~.layout.BagDamage`, to the
reader's ``on_damage`` or the log) and skipped, and the rest is read; what the file holds
never makes the reader raise anything but a one-line
:class:`~servolab.middleware.errors.BagError`. A message is given only from a chunk that is
sound, so none is silently wrong where the file has CRCs (servolab's, mcap's and rosbag2's
writers write them).

:meth:`BagReader.check` goes through every record and compares the summary with what the
records hold (``servolab bag info --check``). Readers that seek (the ``mcap`` library's
``make_reader``, ``ros2 bag``) need a sound summary and footer: :func:`reindex` (``servolab bag
reindex``) rewrites a cut or damaged file as a complete one of what is sound. It lives here, not
with the writer, because it is recovery: it reads what only the reader's index knows.
"""

from __future__ import annotations

import contextlib
import dataclasses
import heapq
import logging
import os
import shutil
import struct
from collections.abc import Callable, Generator, Iterable, Iterator
from pathlib import Path
from typing import IO, Any

import yaml
from mcap.opcode import Opcode
from mcap.records import Channel, Message
from rosbags.typesys import get_types_from_idl, get_types_from_msg

from ..errors import BagError, MessageError
from ..messages import MessageTypes
from .layout import (
    MCAP_MAGIC,
    BagCheck,
    BagDamage,
    BagInfo,
    BagMessage,
    TopicInfo,
)
from .scan import (
    Damaged,
    Index,
    Scan,
    Segment,
    chunk_records,
    data_crc,
    index_from_summary,
    is_mcap_start,
    lost_messages,
    parse,
    read_ending,
    read_summary,
    reason,
)
from .writer import BagWriter

_log = logging.getLogger("servolab.bag")
_PREFIX = 9  # a record's opcode and length


class BagReader:
    """Reads a bag directory (as ``ros2 bag record`` or :class:`BagWriter` left it) or one
    ``.mcap`` file, including one whose recording was killed or whose bytes are damaged.

    Types in the bag that ``types`` does not know are registered from the bag's own schemas,
    so a bag from another ROS 2 system decodes.

    ``on_damage`` is called once with each damaged part found (a :class:`~.layout.BagDamage`,
    a one-line :class:`~servolab.middleware.errors.BagError`), when the file is opened or when
    reading reaches it; without one, each is logged as a warning (logger ``servolab.bag``).
    One that raises it makes a damaged bag an error instead. :attr:`damage` lists them.
    """

    def __init__(self, path: str | os.PathLike[str], types: MessageTypes, *,
                 on_damage: Callable[[BagDamage], None] | None = None) -> None:
        self.path = Path(path)
        self.types = types
        self.file_path = self._find_file(self.path)
        self._undecodable: dict[str, str] = {}
        self._on_damage = on_damage
        self._damage: dict[int, BagDamage] = {}
        try:
            with self.file_path.open("rb") as f:
                head = f.read(len(MCAP_MAGIC))
                if not is_mcap_start(head):
                    raise BagError(f"{self.file_path} is not an MCAP file (starts with "
                                   f"{head!r})")
                self.size_bytes = os.fstat(f.fileno()).st_size
                self._index = self._open_index(f, head)
        except OSError as exc:
            raise BagError(f"cannot read {self.file_path}: {exc.strerror or exc}") from None
        self._encodings = {c.topic: c.message_encoding for c in self._index.channels.values()}
        self._register_types()
        for damage in self._index.damage:
            self._report(damage)

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
            except (OSError, UnicodeError, yaml.YAMLError, KeyError, TypeError,
                    AttributeError) as exc:
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

    def _open_index(self, f: IO[bytes], head: bytes) -> Index:
        """The summary when the file has a sound one, else a scan of the whole file."""
        damage: list[BagDamage] = []
        if head != MCAP_MAGIC:
            damage.append(BagDamage(self.file_path, 0, f"the magic is {head!r}, not "
                                    f"{MCAP_MAGIC!r}; nothing is lost", lost=False))
        footer, ended = read_ending(f, self.file_path, self.size_bytes, damage)
        summary = None
        if footer is not None and footer.summary_start:
            summary = read_summary(f, self.file_path, self.size_bytes, footer, damage)
            stats = summary.statistics if summary else None
            if summary and stats and (summary.chunk_indexes or not stats.message_count):
                index = index_from_summary(summary, footer.summary_start)
                index.damage = damage
                return index
        index = Scan(f, self.file_path, self.size_bytes,
                     data_end_at=footer.summary_start if footer else 0).run()
        index.damage[:0] = damage
        index.cut = not ended
        index.recovered = not ended or footer is None or bool(
            footer.summary_start and summary is None)
        return index

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
                       self.size_bytes, self._index.recovered, self._index.lost_bytes,
                       self.damage)

    @property
    def damage(self) -> tuple[BagDamage, ...]:
        """The damaged parts found so far, in file order."""
        return tuple(sorted(self._damage.values(), key=lambda d: d.offset))

    def _report(self, damage: BagDamage) -> None:
        """Say a damaged part once (a place is reported once, however often it is read)."""
        if damage.offset in self._damage:
            return
        self._damage[damage.offset] = damage
        if self._on_damage is not None:
            self._on_damage(damage)
        else:
            _log.warning("%s", damage)

    def messages(self, topics: Iterable[str] | None = None) -> Generator[BagMessage, None, None]:
        """Every message (of ``topics``, if given), in log-time order; a message logged at the
        same time as another keeps its place in the file. A damaged chunk is reported and
        skipped."""
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
        channels = self._index.channels
        ids = None if wanted is None else {c for c, ch in channels.items() if ch.topic in wanted}
        try:
            with self.file_path.open("rb") as f:
                for message in self._merge(f, ids):
                    channel = channels[message.channel_id]
                    yield BagMessage(channel.topic, self._type_of(channel), message.log_time,
                                     bytes(message.data), message.publish_time)
        except OSError as exc:
            raise BagError(f"cannot read {self.file_path}: {exc.strerror or exc}") from None

    def _merge(self, f: IO[bytes], ids: set[int] | None) -> Iterator[Message]:
        """Messages in log-time order, loading a chunk only once no message already loaded is
        earlier than its first one (so a bag is never held in memory whole)."""
        segments = sorted(self._index.segments, key=lambda s: (s.first_ns, s.offset))
        if ids is not None:
            segments = [s for s in segments if s.channels is None or s.channels & ids]
        heap: list[tuple[int, int, int, Message]] = []
        i = 0
        while i < len(segments) or heap:
            while i < len(segments) and (not heap or segments[i].first_ns <= heap[0][0]):
                segment = segments[i]
                i += 1
                for j, message in enumerate(self._load(f, segment)):
                    if ids is None or message.channel_id in ids:
                        heapq.heappush(heap, (message.log_time, segment.offset, j, message))
            if heap:
                yield heapq.heappop(heap)[3]

    def _load(self, f: IO[bytes], segment: Segment) -> list[Message]:
        """The messages of a chunk (or of a message record), if it is sound; else none, and
        the damage reported."""
        what = f"chunk {segment.number}" if segment.number else "a message record"
        f.seek(segment.offset)
        raw = f.read(segment.length)
        try:
            if len(raw) < segment.length:
                raise Damaged("the file ends inside it")
            opcode, length = struct.unpack_from("<BQ", raw)
            if opcode != segment.opcode or _PREFIX + length != segment.length:
                raise Damaged(f"its opcode and length, {opcode:#04x} and {length} bytes, are "
                              "not the index's")
            body = raw[_PREFIX:]
            records = ([parse(opcode, body)[0]] if opcode == Opcode.MESSAGE
                       else chunk_records(body)[1])
        except Damaged as exc:
            self._report(BagDamage(self.file_path, segment.offset, f"{what} is damaged ({exc}); "
                                   f"{lost_messages(segment.first_ns, segment.last_ns)}"))
            return []
        messages = [r for r in records if isinstance(r, Message)]
        orphans = sorted({m.channel_id for m in messages} - set(self._index.channels))
        if orphans:
            lost = sum(m.channel_id in orphans for m in messages)
            self._report(BagDamage(self.file_path, segment.offset, f"{what} holds {lost} "
                                   f"message(s) on channel {', '.join(map(str, orphans))}, "
                                   "which no sound record defines (with its schema); they "
                                   "are skipped"))
            messages = [m for m in messages if m.channel_id not in orphans]
        return messages

    def check(self) -> BagCheck:
        """Go through the whole file: every chunk's CRC, every record whole, the data
        section's CRC (if it has one), and the summary against what the records hold. Each
        damaged part is reported as reading reports it (``on_damage``); all are returned, with
        a cut-short end (no summary or footer) among them."""
        index = self._index
        try:
            with self.file_path.open("rb") as f:
                scan = index if index.scanned else Scan(
                    f, self.file_path, self.size_bytes, known=index.summary,
                    data_end_at=index.summary_start).run()
                for damage in scan.damage:
                    self._report(damage)
                if scan.data_end is not None and scan.data_crc:
                    crc = data_crc(f, scan.data_end)
                    if crc != scan.data_crc:
                        self._report(BagDamage(
                            self.file_path, scan.data_end, f"the data section's CRC is "
                            f"{crc:#010x}, its Data End record says {scan.data_crc:#010x}: "
                            "some of its bytes are damaged"))
        except OSError as exc:
            raise BagError(f"cannot read {self.file_path}: {exc.strerror or exc}") from None
        if not index.scanned and not scan.damage:
            said = list(self._disagreements(scan))
            if said:
                self._report(BagDamage(self.file_path, index.summary_start,
                                       f"the summary disagrees with the records: "
                                       f"{'; '.join(said)}", lost=False))
        problems = list(self.damage)
        if index.cut:
            lost = (f"; its last {index.lost_bytes} bytes, an unfinished record, are lost"
                    if index.lost_bytes else "")
            problems.append(BagDamage(
                self.file_path, self.size_bytes - index.lost_bytes, "the file ends without "
                f"its summary and footer (a recording cut short){lost}",
                lost=bool(index.lost_bytes)))
        return BagCheck(self.file_path, scan.chunks, sum(scan.counts.values()), tuple(problems))

    def _disagreements(self, scan: Index) -> Iterator[str]:
        """Where a summary (sound by its CRC) says other than the records of a sound data
        section: what a seeking reader would get wrong."""
        summary = self._index.summary
        assert summary is not None and summary.statistics is not None
        stats = summary.statistics
        found = {s.offset: s for s in scan.segments if s.opcode == Opcode.CHUNK}
        indexed = {ci.chunk_start_offset: ci for ci in summary.chunk_indexes}
        for offset in sorted(set(found) - set(indexed)):
            yield f"the chunk at byte {offset} is not in its index"
        for offset in sorted(set(indexed) - set(found)):
            yield f"it indexes a chunk at byte {offset}, where there is none"
        for offset, ci in sorted(indexed.items()):
            seg = found.get(offset)
            if seg is not None and (ci.chunk_length, ci.message_start_time,
                                    ci.message_end_time) != (seg.length, seg.first_ns,
                                                             seg.last_ns):
                yield (f"chunk {seg.number} is {seg.length} bytes logged {seg.first_ns} to "
                       f"{seg.last_ns} ns; its index says {ci.chunk_length} bytes, "
                       f"{ci.message_start_time} to {ci.message_end_time} ns")
        total = sum(scan.counts.values())
        if stats.message_count != total:
            yield f"it counts {stats.message_count} messages, the chunks hold {total}"
        for cid in sorted(set(stats.channel_message_counts) | set(scan.counts)):
            said, held = stats.channel_message_counts.get(cid, 0), scan.counts.get(cid, 0)
            if said != held:
                topic = self._index.channels[cid].topic if cid in self._index.channels else "?"
                yield f"it counts {said} messages on {topic}, the chunks hold {held}"
        if total and (stats.message_start_time, stats.message_end_time) != (scan.start_ns,
                                                                             scan.end_ns):
            yield (f"its log times are {stats.message_start_time} to "
                   f"{stats.message_end_time} ns, the messages' {scan.start_ns} to "
                   f"{scan.end_ns} ns")
        if stats.chunk_count != len(found):
            yield f"it counts {stats.chunk_count} chunks, the file holds {len(found)}"

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
        except Exception as exc:  # bytes that do not fit the type (a chunk without a CRC)
            raise BagError(f"{self.file_path}: {msg.topic} at {msg.log_time_ns} ns does not "
                           f"decode as {msg.type} ({reason(exc)})") from None


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
            compression: str | None = None,
            on_damage: Callable[[BagDamage], None] | None = None) -> BagInfo | None:
    """Rewrite a bag whose recording was cut short (killed: no summary, index or footer, and
    no ``metadata.yaml``) or whose bytes are damaged as a complete one, which any MCAP
    reader, seeking ones included, opens: its sound chunks are kept, in log-time order, with
    their topics, types, offered QoS and publish times, and damaged ones left out (reported to
    ``on_damage``, as :class:`BagReader` reports them); ``metadata.yaml`` is written when
    ``path`` is a bag directory. rosbag2's ``ros2 bag reindex`` does the like for its metadata
    ("in the event of loss or corruption"); an MCAP file's index is inside it, so it is the
    file that is rewritten.

    The new file is written next to the old one and renamed over it, so a reindex that is
    itself interrupted leaves the original; a damaged original (not merely cut short) is kept
    beside it as ``NAME.mcap.damaged``. Returns what was recovered (:class:`BagInfo` of the new
    file, with the old one's ``lost_bytes`` and ``damage``), or ``None`` for a sound bag, which
    is left as it is."""
    reader = BagReader(path, types, on_damage=on_damage)
    checked = reader.check()
    if checked.sound:
        return None
    source = reader.file_path
    work = source.parent / f".{source.name}.reindex"
    kept = source.with_name(f"{source.name}.damaged") if reader.damage else None
    try:
        if work.exists():
            shutil.rmtree(work)  # what an interrupted reindex left
        with BagWriter(work, reader.types, file_name=source.name,
                       compression=compression) as writer:
            added = set()
            for channel in sorted(reader._index.channels.values(), key=lambda c: c.id):
                kind = reader._type_of(channel)
                if kind and channel.message_encoding == "cdr":
                    writer.add_topic(channel.topic, kind, _offered_qos(channel))
                    added.add(channel.topic)
            for m in reader.messages():
                if m.topic in added:
                    writer.write(m.topic, m.data, m.log_time_ns, m.publish_time_ns)
        if kept is not None:
            with contextlib.suppress(FileNotFoundError):
                kept.unlink()  # an older copy, from an earlier reindex
            try:
                os.link(source, kept)
            except OSError:  # a file system without hard links
                shutil.copy2(source, kept)
        os.replace(work / source.name, source)
        if reader.path.is_dir():
            os.replace(work / "metadata.yaml", reader.path / "metadata.yaml")
    except OSError as exc:
        raise BagError(f"cannot reindex {source}: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
    info = BagReader(source, types, on_damage=on_damage).info()
    return dataclasses.replace(info, recovered=True, lost_bytes=reader.info().lost_bytes,
                               damage=reader.damage)
