"""Bags: what BagWriter records, other MCAP/rosbag2 readers read field for field; what a killed
recorder leaves, BagReader recovers; play keeps the bag's timing (on a virtual clock)."""

from __future__ import annotations

import os
import re
import select
import signal
import subprocess
import sys
import textwrap
import threading
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as RosbagsWriter

from servolab.apps.bag import format_info
from servolab.clock import VirtualClock
from servolab.middleware.bag import (
    BagReader,
    BagWriter,
    TopicInfo,
    play,
)
from servolab.middleware.errors import BagError
from servolab.middleware.messages import MessageTypes

with warnings.catch_warnings():  # importing it warns, with mcap_ros1's text, of a deprecation
    warnings.simplefilter("ignore", DeprecationWarning)
    from mcap_ros2.reader import read_ros2_messages

T0 = 1_700_000_000_000_000_000  # ns since the epoch, as rosbag2 stamps messages
SRC = str(Path(__file__).resolve().parents[2] / "src")


def plain(value: Any) -> Any:
    """mcap_ros2's decoded message as the plain values MessageTypes.to_value gives."""
    if hasattr(value, "__slots__") and type(value).__module__.startswith("mcap_ros2"):
        return {name: plain(getattr(value, name)) for name in value.__slots__}
    if isinstance(value, bytes | bytearray):
        return list(value)
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    return value


def twist(types: MessageTypes, i: int) -> Any:
    return types.from_value("geometry_msgs/msg/Twist",
                            {"linear": {"x": i * 0.5, "y": -i / 7.0}, "angular": {"z": i + 0.25}})


def twist_x(types: MessageTypes, i: int) -> Any:
    return types.from_value("geometry_msgs/msg/Twist", {"linear": {"x": float(i)}})


def some_messages(types: MessageTypes) -> list[tuple[str, Any, int]]:
    """(topic, message, log time) of four types, an image among them, in log-time order."""
    rng = np.random.default_rng(7)
    out: list[tuple[str, Any, int]] = []
    for i in range(3):
        t = T0 + i * 100_000_000
        pixels = rng.integers(0, 256, 640 * 376, dtype=np.uint8)
        out.append(("/camera/image_raw", types.from_value("sensor_msgs/msg/Image", {
            "header": {"stamp": {"sec": 1_700_000_000 + i, "nanosec": 123 + i},
                       "frame_id": "camera"},
            "height": 376, "width": 640, "encoding": "mono8", "is_bigendian": 0, "step": 640,
            "data": pixels}), t))
        out.append(("/cmd_vel", twist(types, i), t + 1))
        out.append(("/joint_states", types.from_value("sensor_msgs/msg/JointState", {
            "header": {"stamp": {"sec": 5, "nanosec": i}, "frame_id": "base"},
            "name": ["pan", "tilt"], "position": [0.1 * i, -0.2], "velocity": [1.0, 2.0 + i],
            "effort": []}), t + 2))
        out.append(("/motor_states", types.from_value("dynamixel_msgs/msg/MotorStateList", {
            "motor_states": [
                {"timestamp": 12.5 + i, "id": 1, "goal": 512, "position": 500 + i, "error": -12,
                 "speed": -3, "load": 0.25, "voltage": 12.1, "temperature": 41, "moving": True},
                {"timestamp": 12.5 + i, "id": 2, "goal": 0, "position": 1023, "error": 7,
                 "speed": 0, "load": -0.5, "voltage": 11.9, "temperature": 39,
                 "moving": False}]}), t + 3))
    return out


def write_bag(path: Path, types: MessageTypes, records: list[tuple[str, Any, int]],
              **options: Any) -> None:
    with BagWriter(path, types, **options) as writer:
        for topic, msg, t in records:
            writer.write(topic, msg, t)


# -- independent readers ---------------------------------------------------------------------


def test_every_field_of_four_types_survives_an_independent_decoder(
        tmp_path: Path, types: MessageTypes) -> None:
    records = some_messages(types)
    write_bag(tmp_path / "bag", types, records)
    read = list(read_ros2_messages(str(tmp_path / "bag" / "bag_0.mcap")))
    assert len(read) == len(records) == 12
    for (topic, msg, t), got in zip(records, read, strict=True):
        assert got.channel.topic == topic
        assert got.log_time_ns == got.publish_time_ns == t
        assert got.schema.name == types.type_of(msg)
        assert plain(got.ros_msg) == types.to_value(msg)
    image = read[0].ros_msg
    assert (image.width, image.height, len(image.data)) == (640, 376, 640 * 376)


def test_the_file_is_rosbag2_s_mcap(tmp_path: Path, types: MessageTypes) -> None:
    write_bag(tmp_path / "bag", types, some_messages(types))
    with open(tmp_path / "bag" / "bag_0.mcap", "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2" and "servolab" in header.library
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 12
    schemas = {s.name: s for s in summary.schemas.values()}
    assert set(schemas) == {"sensor_msgs/msg/Image", "geometry_msgs/msg/Twist",
                            "sensor_msgs/msg/JointState", "dynamixel_msgs/msg/MotorStateList"}
    for name, schema in schemas.items():
        assert schema.encoding == "ros2msg"
        assert schema.data.decode() == types.msgdef(name)
    for channel in summary.channels.values():
        assert channel.message_encoding == "cdr"
        name = summary.schemas[channel.schema_id].name
        # rosbag2_storage_mcap writes YAML::Dump of an empty profile list: "[]".
        assert channel.metadata == {"offered_qos_profiles": "[]",
                                    "topic_type_hash": types.rihs01(name)}


def test_ten_thousand_twists_all_come_back(tmp_path: Path, types: MessageTypes) -> None:
    n = 10_000
    with BagWriter(tmp_path / "many", types, chunk_size=64 * 1024) as writer:
        writer.add_topic("/cmd_vel", "geometry_msgs/msg/Twist")
        for i in range(n):
            writer.write("/cmd_vel", twist(types, i), T0 + i * 10_000_000)
    reader = BagReader(tmp_path / "many", types)
    assert reader.info().message_count == n and not reader.info().recovered
    got = list(reader.messages())
    assert len(got) == n
    assert [m.log_time_ns for m in got] == [T0 + i * 10_000_000 for i in range(n)]
    for i, m in enumerate(got):
        value = reader.decode(m)
        assert (value.linear.x, value.linear.y, value.angular.z) == (i * 0.5, -i / 7.0, i + 0.25)

    # rosbags' rosbag2 reader: goes through metadata.yaml, then its own MCAP parser.
    with RosbagsReader(tmp_path / "many") as other:
        assert other.message_count == n
        assert [(c.topic, c.msgtype) for c in other.connections] == [
            ("/cmd_vel", "geometry_msgs/msg/Twist")]
        theirs = [(t, bytes(data)) for _, t, data in other.messages()]
    assert theirs == [(m.log_time_ns, m.data) for m in got]


def test_rosbags_reads_every_type(tmp_path: Path, types: MessageTypes) -> None:
    records = some_messages(types)
    write_bag(tmp_path / "bag", types, records)
    with RosbagsReader(tmp_path / "bag") as other:
        got = [(c.topic, c.msgtype, t, bytes(data)) for c, t, data in other.messages()]
    assert got == [(topic, types.type_of(m), t, types.serialize(m)) for topic, m, t in records]


def test_metadata_yaml_is_rosbag2_s(tmp_path: Path, types: MessageTypes) -> None:
    records = some_messages(types)
    write_bag(tmp_path / "run1", types, records)
    meta = yaml.safe_load((tmp_path / "run1" / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    first, last = records[0][2], records[-1][2]
    assert info["starting_time"] == {"nanoseconds_since_epoch": first}
    assert info["duration"] == {"nanoseconds": last - first}
    assert info["message_count"] == 12
    assert info["relative_file_paths"] == ["run1_0.mcap"]
    assert info["files"] == [{"path": "run1_0.mcap",
                              "starting_time": {"nanoseconds_since_epoch": first},
                              "duration": {"nanoseconds": last - first}, "message_count": 12}]
    assert (info["compression_format"], info["compression_mode"]) == ("", "")
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert set(topics) == {"/camera/image_raw", "/cmd_vel", "/joint_states", "/motor_states"}
    for topic, msg, _ in records:
        entry = topics[topic]
        assert entry["message_count"] == 3
        assert entry["topic_metadata"] == {
            "name": topic, "type": types.type_of(msg), "serialization_format": "cdr",
            "offered_qos_profiles": [],
            "type_description_hash": types.rihs01(types.type_of(msg))}
    assert info["custom_data"] is None and info["ros_distro"] == "jazzy"


# -- BagReader -------------------------------------------------------------------------------


def test_reader_topics_info_and_filter(tmp_path: Path, types: MessageTypes) -> None:
    records = some_messages(types)
    write_bag(tmp_path / "bag", types, records)
    for path in (tmp_path / "bag", tmp_path / "bag" / "bag_0.mcap"):
        reader = BagReader(path, types)
        assert reader.topics() == [
            TopicInfo("/camera/image_raw", "sensor_msgs/msg/Image", 3),
            TopicInfo("/cmd_vel", "geometry_msgs/msg/Twist", 3),
            TopicInfo("/joint_states", "sensor_msgs/msg/JointState", 3),
            TopicInfo("/motor_states", "dynamixel_msgs/msg/MotorStateList", 3)]
        info = reader.info()
        assert (info.message_count, info.start_ns, info.end_ns) == (12, T0, T0 + 200_000_003)
        assert info.duration_s == pytest.approx(0.200000003)
        assert info.size_bytes == os.path.getsize(tmp_path / "bag" / "bag_0.mcap")
        assert not info.recovered
    got = list(reader.messages(topics=["/cmd_vel", "/motor_states"]))
    assert [m.topic for m in got] == ["/cmd_vel", "/motor_states"] * 3
    assert types.to_value(reader.decode(got[1])) == types.to_value(records[3][1])
    with pytest.raises(BagError, match=r"no topic /nope .*it has /camera/image_raw"):
        reader.messages(["/nope"])


def test_format_info_reads_like_ros2_bag_info(tmp_path: Path, types: MessageTypes) -> None:
    write_bag(tmp_path / "bag", types, some_messages(types))
    text = format_info(BagReader(tmp_path / "bag", types).info())
    assert f"Files:             {tmp_path / 'bag' / 'bag_0.mcap'}" in text
    assert "Messages:          12" in text and "Duration:          0.200000003s" in text
    assert re.search(r"\nBag size: {10}\d+\.\d [KM]iB\n", text)
    assert "(1700000000.000000000)" in text and "(1700000000.200000003)" in text
    assert "Topic: /cmd_vel          | Type: geometry_msgs/msg/Twist    " in text
    assert "dynamixel_msgs/msg/MotorStateList | Count: 3" in text
    assert "Recovered" not in text


def test_messages_come_in_log_time_order_with_or_without_the_index(
        tmp_path: Path, types: MessageTypes) -> None:
    """Recorders receive topics with jitter: times go back and forth across chunks."""
    rng = np.random.default_rng(3)
    stamps = [int(T0 + i * 1_000_000 + rng.integers(-40, 40) * 1_000_000) for i in range(600)]
    with BagWriter(tmp_path / "bag", types, chunk_size=2048) as writer:
        for i, t in enumerate(stamps):
            writer.write("/a" if i % 3 else "/b", twist(types, i), t)
    indexed = list(BagReader(tmp_path / "bag", types).messages())
    assert [m.log_time_ns for m in indexed] == sorted(stamps)
    cut = tmp_path / "cut.mcap"  # the same file without its footer: read by scanning
    cut.write_bytes((tmp_path / "bag" / "bag_0.mcap").read_bytes()[:-1])
    scanned = BagReader(cut, types)
    assert scanned.info().recovered and scanned.info().message_count == 600
    assert list(scanned.messages()) == indexed
    assert [m.topic for m in scanned.messages(["/b"])] == ["/b"] * 200


@pytest.mark.parametrize("make", [
    pytest.param(lambda p: p, id="missing"),
    pytest.param(lambda p: (p.write_text("hello, not a bag\n"), p)[1], id="text file"),
    pytest.param(lambda p: (p.write_bytes(b""), p)[1], id="empty file"),
    pytest.param(lambda p: (p.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64)), p)[1], id="png"),
    pytest.param(lambda p: (p.mkdir(), p)[1], id="empty directory"),
    pytest.param(lambda p: (p.mkdir(), (p / "metadata.yaml").write_text("- [unclosed"), p)[2],
                 id="broken metadata.yaml"),
])
def test_bad_paths_are_one_line_errors_naming_them(tmp_path: Path, types: MessageTypes,
                                                   make: Any) -> None:
    path = make(tmp_path / "thing")
    with pytest.raises(BagError) as error:
        BagReader(path, types)
    message = str(error.value)
    assert str(path) in message and "\n" not in message


def test_a_text_file_says_what_it_starts_with(tmp_path: Path, types: MessageTypes) -> None:
    path = tmp_path / "notes.mcap"
    path.write_text("hello, not a bag\n")
    with pytest.raises(BagError, match=r"notes.mcap is not an MCAP file \(starts with "
                                       r"b'hello, n'\)"):
        BagReader(path, types)


def test_a_type_unknown_to_the_reader_comes_from_the_bag(tmp_path: Path) -> None:
    lab = MessageTypes(extra_msgs={
        "lab_msgs/msg/Sample": "int32 id\nfloat32[3] xyz\n",
        "lab_msgs/msg/Reading": "std_msgs/Header header\nstring unit\n"
                                "lab_msgs/Sample[] samples\nuint8 KIND=3\n",
    })
    msg = lab.from_value("lab_msgs/msg/Reading", {
        "header": {"frame_id": "lab"}, "unit": "mm",
        "samples": [{"id": 1, "xyz": [1.0, 2.5, -3.0]}, {"id": 2, "xyz": [0.0, 0.0, 0.5]}]})
    write_bag(tmp_path / "bag", lab, [("/reading", msg, T0)])
    plain_types = MessageTypes()
    assert "lab_msgs/msg/Reading" not in plain_types.names()
    reader = BagReader(tmp_path / "bag", plain_types)
    assert reader.topics() == [TopicInfo("/reading", "lab_msgs/msg/Reading", 1)]
    (got,) = reader.messages()
    assert plain_types.to_value(reader.decode(got)) == lab.to_value(msg)
    assert {"lab_msgs/msg/Reading", "lab_msgs/msg/Sample"} <= set(plain_types.names())


def test_a_bag_written_by_rosbags_reads(tmp_path: Path, types: MessageTypes) -> None:
    """Another writer's layout: ``NAME.mcap``, uncompressed chunks without CRCs."""
    with RosbagsWriter(tmp_path / "theirs", version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/chatter", "std_msgs/msg/String", typestore=types.store)
        for i in range(5):
            w.write(conn, T0 + i, types.serialize(types.from_value("std_msgs/msg/String",
                                                                   f"hello {i}")))
    reader = BagReader(tmp_path / "theirs", MessageTypes())
    assert reader.topics() == [TopicInfo("/chatter", "std_msgs/msg/String", 5)]
    assert [reader.decode(m).data for m in reader.messages()] == [f"hello {i}" for i in range(5)]


# -- BagWriter -------------------------------------------------------------------------------


def test_writer_refuses_a_non_empty_directory(tmp_path: Path, types: MessageTypes) -> None:
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "keep.txt").write_text("precious")
    with pytest.raises(BagError) as error:
        BagWriter(tmp_path / "old", types)
    assert str(tmp_path / "old") in str(error.value) and "\n" not in str(error.value)
    assert os.listdir(tmp_path / "old") == ["keep.txt"]
    empty = tmp_path / "empty"
    empty.mkdir()
    BagWriter(empty, types).close()  # an empty directory is taken
    assert sorted(os.listdir(empty)) == ["empty_0.mcap", "metadata.yaml"]
    reader = BagReader(empty, types)
    assert (reader.info().message_count, reader.topics(), list(reader.messages())) == (0, [], [])


def test_writer_misuse_is_reported(tmp_path: Path, types: MessageTypes) -> None:
    writer = BagWriter(tmp_path / "bag", types)
    with pytest.raises(BagError, match="topic /raw was not added"):
        writer.write("/raw", b"\x00\x01\x00\x00", T0)
    writer.add_topic("/cmd_vel", "geometry_msgs/Twist")
    writer.add_topic("/cmd_vel", "geometry_msgs/msg/Twist")  # again: nothing happens
    with pytest.raises(BagError, match="/cmd_vel is recorded as geometry_msgs/msg/Twist"):
        writer.add_topic("/cmd_vel", "std_msgs/msg/String")
    with pytest.raises(BagError, match="recorded as geometry_msgs/msg/Twist, not std_msgs/msg/S"):
        writer.write("/cmd_vel", types.from_value("std_msgs/msg/String", "hi"), T0)
    with pytest.raises(BagError, match="log_time_ns -1"):
        writer.write("/cmd_vel", twist(types, 1), -1)
    writer.write("/cmd_vel", types.serialize(twist(types, 1)), T0)
    writer.close()
    writer.close()  # idempotent
    with pytest.raises(BagError, match="is closed"):
        writer.write("/cmd_vel", twist(types, 2), T0)
    assert BagReader(tmp_path / "bag", types).info().message_count == 1


def test_an_exception_in_the_with_block_still_leaves_a_complete_bag(
        tmp_path: Path, types: MessageTypes) -> None:
    with pytest.raises(RuntimeError, match="robot fell over"), \
            BagWriter(tmp_path / "bag", types) as writer:
        for i in range(50):
            writer.write("/cmd_vel", twist(types, i), T0 + i)
        raise RuntimeError("robot fell over")
    assert (tmp_path / "bag" / "metadata.yaml").exists()
    info = BagReader(tmp_path / "bag", types).info()
    assert info.message_count == 50 and not info.recovered
    with RosbagsReader(tmp_path / "bag") as other:
        assert other.message_count == 50


def test_two_threads_writing_at_once_lose_nothing(tmp_path: Path, types: MessageTypes) -> None:
    data = types.serialize(twist(types, 1))
    with BagWriter(tmp_path / "bag", types, chunk_size=4096) as writer:
        writer.add_topic("/a", "geometry_msgs/msg/Twist")
        writer.add_topic("/b", "geometry_msgs/msg/Twist")

        def feed(topic: str) -> None:
            for i in range(2000):
                writer.write(topic, data, T0 + i)

        threads = [threading.Thread(target=feed, args=(t,)) for t in ("/a", "/b")]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    assert [t.count for t in BagReader(tmp_path / "bag", types).topics()] == [2000, 2000]


# -- a recorder killed with SIGKILL ----------------------------------------------------------

CHILD = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[3])
    from servolab.middleware.bag import BagWriter
    from servolab.middleware.messages import MessageTypes

    types = MessageTypes()
    writer = BagWriter(sys.argv[1], types, chunk_size=4096)
    flush = sys.argv[2] == "flush"

    def twist(i):
        return types.from_value("geometry_msgs/msg/Twist", {"linear": {"x": float(i)}})

    for i in range(500):
        writer.write("/cmd_vel", twist(i), 1_700_000_000_000_000_000 + i * 1_000_000)
    if flush:
        writer.flush()
        for i in range(500, 510):  # fewer than a chunk holds: they stay in memory
            writer.write("/cmd_vel", twist(i), 1_700_000_000_000_000_000 + i * 1_000_000)
    print("written", flush=True)
    sys.stdin.read()  # wait here to be killed
""")


@pytest.mark.parametrize("mode", ["flush", "no-flush"])
def test_a_killed_recorder_leaves_its_complete_chunks(tmp_path: Path, types: MessageTypes,
                                                      mode: str) -> None:
    bag = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-c", CHILD, str(bag), mode, SRC],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 20.0)
        line = proc.stdout.readline() if ready else ""  # type: ignore[union-attr]
        assert line == "written\n", proc.stderr.read() if proc.poll() is not None else line  # type: ignore[union-attr]
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
        for stream in (proc.stdin, proc.stdout, proc.stderr):
            if stream:
                stream.close()
    assert proc.returncode == -signal.SIGKILL
    assert not (bag / "metadata.yaml").exists()

    reader = BagReader(bag, types)
    info = reader.info()
    assert info.recovered
    got = [reader.decode(m).linear.x for m in reader.messages()]
    assert got == [float(i) for i in range(len(got))]  # a prefix, in order, every value right
    if mode == "flush":
        assert info.message_count == len(got) == 500  # exactly what was flushed
    else:
        # No flush: every chunk the writer filled reached the OS the moment it was full; only
        # the open one is lost. The same 500 messages written here and closed show which
        # message the last chunk (finished by close) starts with.
        write_bag(tmp_path / "same", types, [("/cmd_vel", twist_x(types, i), T0 + i * 1_000_000)
                                             for i in range(500)], chunk_size=4096)
        with open(tmp_path / "same" / "same_0.mcap", "rb") as f:
            summary = make_reader(f).get_summary()
        assert summary is not None and len(summary.chunk_indexes) > 5
        last_chunk_starts_at = (summary.chunk_indexes[-1].message_start_time - T0) // 1_000_000
        assert info.message_count == len(got) == last_chunk_starts_at
    assert info.lost_bytes == 0  # the killed process never started writing its open chunk
    assert "Recovered:" in format_info(info) and f"{info.message_count} messages" in format_info(
        info)


def test_a_chunk_cut_in_the_middle_is_dropped_not_misread(tmp_path: Path,
                                                          types: MessageTypes) -> None:
    write_bag(tmp_path / "bag", types, [("/cmd_vel", twist(types, i), T0 + i)
                                        for i in range(300)], chunk_size=2048)
    whole = (tmp_path / "bag" / "bag_0.mcap").read_bytes()
    counts = []
    for size in range(len(whole) // 10, len(whole), len(whole) // 10):
        cut = tmp_path / f"cut{size}.mcap"
        cut.write_bytes(whole[:size])
        reader = BagReader(cut, types)
        got = [reader.decode(m).linear.x for m in reader.messages()]
        assert got == [i * 0.5 for i in range(len(got))]
        assert reader.info().recovered
        counts.append(len(got))
    assert counts == sorted(counts) and 0 < counts[0] < counts[-1] <= 300


# -- play ------------------------------------------------------------------------------------


@pytest.fixture
def timed_bag(tmp_path: Path, types: MessageTypes) -> tuple[BagReader, list[tuple[str, int]]]:
    """Messages at irregular times over 1000 s: a virtual clock plays it in no time."""
    offsets_s = [0.0, 0.1, 0.15, 1.0, 2.5, 2.5, 60.0, 1000.0]
    stamps = [(("/a", "/b")[i % 2], T0 + round(s * 1e9)) for i, s in enumerate(offsets_s)]
    with BagWriter(tmp_path / "bag", types) as writer:
        for i, (topic, t) in enumerate(stamps):
            writer.write(topic, twist(types, i), t)
    return BagReader(tmp_path / "bag", types), stamps


@pytest.mark.parametrize("rate", [1.0, 2.0, 0.5])
def test_play_keeps_the_bag_s_timing_scaled_by_rate(
        timed_bag: tuple[BagReader, list[tuple[str, int]]], rate: float) -> None:
    reader, stamps = timed_bag
    clock = VirtualClock(start=50.0)
    published: list[tuple[float, str, str, bytes]] = []
    wall = time.monotonic()
    count = play(reader, lambda topic, type_, data: published.append(
        (clock.now(), topic, type_, data)), rate=rate, clock=clock)
    assert time.monotonic() - wall < 2.0  # 1000 s of bag, no real waiting
    assert count == len(published) == len(stamps)
    assert [p[1] for p in published] == [topic for topic, _ in stamps]
    assert {p[2] for p in published} == {"geometry_msgs/msg/Twist"}
    for (at, _, _, data), (_, t), msg in zip(published, stamps, reader.messages(), strict=True):
        assert at == pytest.approx(50.0 + (t - T0) / 1e9 / rate, abs=1e-9)
        assert data == msg.data


@pytest.mark.parametrize("rate", [0.0, float("inf")])
def test_play_as_fast_as_possible(timed_bag: tuple[BagReader, list[tuple[str, int]]],
                                  rate: float) -> None:
    reader, _ = timed_bag
    clock = VirtualClock()
    times: list[float] = []
    assert play(reader, lambda *_: times.append(clock.now()), rate=rate, clock=clock) == 8
    assert times == [0.0] * 8


def test_play_from_an_offset_topics_progress_and_stop(
        timed_bag: tuple[BagReader, list[tuple[str, int]]]) -> None:
    reader, _ = timed_bag
    clock = VirtualClock()
    got: list[tuple[float, str]] = []
    progress: list[tuple[int, int]] = []
    n = play(reader, lambda topic, *_: got.append((clock.now(), topic)), clock=clock,
             start_offset=1.0, progress=lambda done, total: progress.append((done, total)))
    assert n == 5
    assert got == [(pytest.approx(0.0), "/b"), (pytest.approx(1.5), "/a"),
                   (pytest.approx(1.5), "/b"), (pytest.approx(59.0), "/a"),
                   (pytest.approx(999.0), "/b")]
    assert progress == [(i, 8) for i in range(1, 9)]

    clock = VirtualClock()
    only_a: list[float] = []
    assert play(reader, lambda *_: only_a.append(clock.now()), clock=clock, topics=["/a"]) == 4
    assert only_a == pytest.approx([0.0, 0.15, 2.5, 60.0])

    clock = VirtualClock()
    stopped: list[str] = []
    n = play(reader, lambda topic, *_: stopped.append(topic), clock=clock,
             should_stop=lambda: clock.now() > 10.0)
    assert n == len(stopped) == 6  # the 60 s message is never reached
    assert clock.now() == pytest.approx(10.0 + 0.05, abs=0.06)

    with pytest.raises(BagError, match="rate"):
        play(reader, lambda *_: None, rate=-1.0, clock=VirtualClock())
    with pytest.raises(BagError, match="no topic /c"):
        play(reader, lambda *_: None, topics=["/c"], clock=VirtualClock())


def test_chunk_indexes_wait_on_disk_not_in_memory(tmp_path: Path, types: MessageTypes) -> None:
    """mcap's Writer keeps a ChunkIndex per chunk until the bag is finished (issue 45: a
    long walk grew 1.2 kB a row for it); BagWriter moves each to a temporary file as its
    chunk ends. mcap's own reader then finds every chunk through the summary's indexes,
    and every message comes back in order, read through them."""
    name = "geometry_msgs/msg/Twist"
    with BagWriter(tmp_path / "bag", types, chunk_size=2048) as writer:
        for i in range(3000):
            writer.write("/cmd_vel", types.from_value(name, {"linear": {"x": i / 10}}),
                         1_000 + i)
            if i % 500 == 499:
                writer.flush()
        held = writer._chunk_indexes
        assert held is not None and len(held) <= 2, len(held or [])  # mcap's list: spilled
        spilled = writer._spilled.count
    assert spilled > 100
    with (tmp_path / "bag" / "bag_0.mcap").open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and len(summary.chunk_indexes) == summary.statistics.chunk_count
        assert spilled <= len(summary.chunk_indexes) <= spilled + 1  # the last, at close
        starts = [c.chunk_start_offset for c in summary.chunk_indexes]
        assert starts == sorted(starts)
        xs = [msg.data for _, _, msg in reader.iter_messages()]
    assert len(xs) == 3000
    decoded = [types.deserialize(data, name).linear.x for data in xs]
    assert decoded == [i / 10 for i in range(3000)]
