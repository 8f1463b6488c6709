"""A recording cut by SIGKILL has no summary or footer, so the *seeking* ``mcap`` reader cannot
open it as is; ``reindex`` (``servolab bag reindex``) makes it a complete file that it opens and
``mcap-ros2-support`` decodes, message for message."""

from __future__ import annotations

import signal
import sys
import textwrap
import warnings
from pathlib import Path

import pytest
import yaml
from mcap.exceptions import McapError
from mcap.reader import SeekingReader, make_reader
from rosbags.rosbag2 import Reader as RosbagsReader

from servolab.middleware.bag import BagReader, BagWriter, qos_profile, reindex
from servolab.middleware.errors import BagError
from servolab.middleware.messages import MessageTypes
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_bag, wait_for_line

with warnings.catch_warnings():  # importing it warns, with mcap_ros1's text, of a deprecation
    warnings.simplefilter("ignore", DeprecationWarning)
    from mcap_ros2.decoder import DecoderFactory

T0 = 1_700_000_000_000_000_000
SRC = str(Path(__file__).resolve().parents[2] / "src")

#: Writes 500 Twists (flushed: on disk), 10 more that stay in the open chunk, then waits to be
#: killed. Publish times differ from log times, and /cmd_vel offers two QoS profiles.
CHILD = textwrap.dedent("""
    import sys
    sys.path.insert(0, sys.argv[2])
    from servolab.middleware.bag import BagWriter, qos_profile
    from servolab.middleware.messages import MessageTypes

    types = MessageTypes()
    writer = BagWriter(sys.argv[1], types, chunk_size=4096)
    writer.add_topic("/cmd_vel", "geometry_msgs/msg/Twist",
                     [qos_profile(depth=10), qos_profile(reliable=False, depth=1)])

    def twist(i):
        return types.from_value("geometry_msgs/msg/Twist", {"linear": {"x": float(i)}})

    for i in range(510):
        t = 1_700_000_000_000_000_000 + i * 1_000_000
        writer.write("/cmd_vel", twist(i), t, t - 17)
        if i == 499:
            writer.flush()
    print("written", flush=True)
    import threading
    threading.Event().wait()  # wait here to be killed
""")


def killed_recording(bag: Path) -> None:
    """``bag`` as a recorder killed by SIGKILL leaves it."""
    with started([sys.executable, "-c", CHILD, str(bag), SRC]) as proc:
        wait_for_line(proc, "written", timeout=20)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    assert not (bag / "metadata.yaml").exists()


def seeking_read(path: Path) -> list[tuple[str, float, int, int]]:
    """(topic, linear.x, log time, publish time) of every message, through mcap's seeking
    reader (summary, index, footer) and mcap-ros2-support's decoder."""
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert isinstance(reader, SeekingReader)
        return [(channel.topic, msg.linear.x, message.log_time, message.publish_time)
                for _, channel, message, msg in reader.iter_decoded_messages()]


def test_a_killed_recording_is_not_readable_by_the_seeking_reader_as_is(
        tmp_path: Path) -> None:
    killed_recording(tmp_path / "killed")
    with pytest.raises(McapError):
        seeking_read(tmp_path / "killed" / "killed_0.mcap")


def test_reindex_makes_it_a_complete_bag(tmp_path: Path, types: MessageTypes) -> None:
    bag = tmp_path / "killed"
    killed_recording(bag)
    found = reindex(bag, types)
    assert found is not None and found.recovered and found.message_count == 500

    got = seeking_read(bag / "killed_0.mcap")
    assert got == [("/cmd_vel", float(i), T0 + i * 1_000_000, T0 + i * 1_000_000 - 17)
                   for i in range(500)]
    with open(bag / "killed_0.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 500
    assert [m.name for m in summary.metadata_indexes] == ["rosbag2"]
    (channel,) = summary.channels.values()
    assert yaml.safe_load(channel.metadata["offered_qos_profiles"]) == [
        qos_profile(depth=10), qos_profile(reliable=False, depth=1)]

    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["message_count"] == 500
    assert info["relative_file_paths"] == ["killed_0.mcap"]
    assert sorted(p.name for p in bag.iterdir()) == ["killed_0.mcap", "metadata.yaml"]
    assert not list(tmp_path.glob(".*"))  # no work files left
    with RosbagsReader(bag) as other:
        assert other.message_count == 500
    assert not BagReader(bag, types).info().recovered
    assert reindex(bag, types) is None  # complete now: left alone


def test_reindex_of_a_lone_file_and_of_a_complete_bag(tmp_path: Path,
                                                      types: MessageTypes) -> None:
    killed_recording(tmp_path / "killed")
    lone = tmp_path / "lone.mcap"
    (tmp_path / "killed" / "killed_0.mcap").rename(lone)
    found = reindex(lone, types)
    assert found is not None and found.message_count == 500
    assert len(seeking_read(lone)) == 500
    assert sorted(p.name for p in tmp_path.iterdir()) == ["killed", "lone.mcap"]

    with BagWriter(tmp_path / "whole", types) as writer:
        writer.write("/x", types.from_value("geometry_msgs/msg/Twist", {}), T0)
    before = (tmp_path / "whole" / "whole_0.mcap").read_bytes()
    assert reindex(tmp_path / "whole", types) is None
    assert (tmp_path / "whole" / "whole_0.mcap").read_bytes() == before
    with pytest.raises(BagError, match="does not exist"):
        reindex(tmp_path / "nope", types)


@pytest.mark.slow
def test_cli_record_killed_then_reindexed_reads_every_message(tmp_path: Path) -> None:
    bag = tmp_path / "run"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "bag", "record", "/cmd_vel", "-o", str(bag), "--type",
                  "/cmd_vel:geometry_msgs/msg/Twist", "--listen", endpoint]) as recorder:
        wait_for_line(recorder, "recording to")
        sent = servolab("topic", "pub", "/cmd_vel", "geometry_msgs/msg/Twist",
                        "{linear: {x: 0.25}, angular: {z: -1.5}}", "--rate", "0", "--count", "300",
                        "--connect", endpoint, timeout=60)
        assert sent.returncode == 0, sent.stderr
        wait_for_bag(bag, 300)  # received and flushed (the recorder flushes every second)
        recorder.send_signal(signal.SIGKILL)
        recorder.wait(timeout=10)
    assert recorder.returncode == -signal.SIGKILL
    mcap_file = bag / "run_0.mcap"
    with pytest.raises(McapError):
        seeking_read(mcap_file)

    result = servolab("bag", "reindex", str(bag), timeout=30)
    assert result.returncode == 0, result.stderr
    assert f"reindexed {mcap_file}: 300 message(s) kept" in result.stdout
    got = seeking_read(mcap_file)
    assert len(got) == 300
    assert all(topic == "/cmd_vel" and x == 0.25 for topic, x, _, _ in got)
    assert [t for _, _, t, _ in got] == sorted(t for _, _, t, _ in got)
    again = servolab("bag", "reindex", str(bag), timeout=30)
    assert again.returncode == 0 and "nothing to do" in again.stdout
    assert "Messages:          300" in servolab("bag", "info", str(bag), timeout=30).stdout


def test_reindex_cli_names_a_bad_path(tmp_path: Path) -> None:
    result = servolab("bag", "reindex", str(tmp_path / "nope"), timeout=30)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert str(tmp_path / "nope") in result.stderr
