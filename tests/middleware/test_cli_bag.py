"""``servolab bag`` as a user runs it, checked with decoders that are not servolab's."""

from __future__ import annotations

import signal
import warnings
from pathlib import Path

import pytest
import yaml

from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.transport import TransportOptions
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_bag, wait_for_graph_at, wait_for_line

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    from mcap_ros2.reader import read_ros2_messages


@pytest.mark.slow
def test_record_10000_as_fast_as_they_come_loses_none(tmp_path: Path) -> None:
    bag = tmp_path / "burst"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "bag", "record", "/cmd_vel", "/odom_x", "-o", str(bag), "--type",
                  "/cmd_vel:geometry_msgs/msg/Twist", "--type", "/odom_x:std_msgs/msg/Float64",
                  "--listen", endpoint]) as recorder:
        wait_for_line(recorder, "recording to")
        burst = servolab("topic", "pub", "/cmd_vel", "geometry_msgs/msg/Twist",
                         "{linear: {x: 0.25}, angular: {z: -1.5}}", "--rate", "0", "--count",
                         "10000", "--connect", endpoint, timeout=120)
        assert burst.returncode == 0, burst.stderr
        paced = servolab("topic", "pub", "/odom_x", "std_msgs/msg/Float64", "3.5", "--rate", "100",
                         "--count", "7", "--connect", endpoint, timeout=30)
        assert paced.returncode == 0, paced.stderr
        wait_for_bag(bag, 10007)  # every message received and flushed before the SIGINT
        recorder.send_signal(signal.SIGINT)
        out, err = recorder.communicate(timeout=30)
    assert recorder.returncode == 0, err
    assert "recorded 10007 message(s)" in out
    # An independent decoder: mcap + mcap-ros2-support, not servolab's reader.
    mcap_file = bag / "burst_0.mcap"
    seen = {"/cmd_vel": 0, "/odom_x": 0}
    for m in read_ros2_messages(str(mcap_file)):
        seen[m.channel.topic] += 1
        if m.channel.topic == "/cmd_vel":
            assert m.schema.name == "geometry_msgs/msg/Twist"
            assert (m.ros_msg.linear.x, m.ros_msg.angular.z) == (0.25, -1.5)
            assert (m.ros_msg.linear.y, m.ros_msg.linear.z) == (0.0, 0.0)
        else:
            assert m.ros_msg.data == 3.5
    assert seen == {"/cmd_vel": 10000, "/odom_x": 7}
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["message_count"] == 10007
    assert metadata["storage_identifier"] == "mcap"
    info = servolab("bag", "info", str(bag), timeout=30)
    assert "Messages:          10007" in info.stdout
    assert "Topic: /cmd_vel | Type: geometry_msgs/msg/Twist | Count: 10000" in info.stdout


@pytest.mark.slow
def test_sigterm_closes_the_bag_and_play_reproduces_it(tmp_path: Path,
                                                       types: MessageTypes) -> None:
    """``bag record`` and ``bag play`` as processes; the five messages recorded come from a
    talker in this process over Zenoh (what publishes them is not what this test is about:
    ``topic pub`` is tests/middleware/test_startup_race.py's and test_cli_graph.py's)."""
    bag = tmp_path / "talk"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "bag", "record", "/chatter", "-o", str(bag), "--type",
                  "/chatter:std_msgs/msg/String", "--listen", endpoint]) as recorder:
        wait_for_line(recorder, "recording to")
        with Context.open(TransportOptions("zenoh", connect=[endpoint]), types=types) as ctx:
            talker = Node(ctx, "talker").create_publisher("std_msgs/msg/String", "/chatter")
            assert talker.wait_for_subscription(30.0), "the recorder's subscription not seen"
            for k in range(5):
                talker.publish(types.from_value("std_msgs/msg/String", {"data": f"hello {k}"}))
            wait_for_bag(bag, 5)  # every message received and flushed before the SIGTERM
        recorder.send_signal(signal.SIGTERM)
        recorder.communicate(timeout=30)
    assert recorder.returncode == 0
    texts = [m.ros_msg.data for m in read_ros2_messages(str(bag / "talk_0.mcap"))]
    assert texts == [f"hello {k}" for k in range(5)]
    endpoint2 = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "topic", "echo", "/chatter", "--type", "std_msgs/msg/String",
                  "--count", "5", "--listen", endpoint2]) as echo:
        wait_for_graph_at(endpoint2, ("MS", None, "/chatter"))  # the echo listens, subscribed
        played = servolab("bag", "play", str(bag), "--rate", "4", "--connect", endpoint2,
                          timeout=30)
        assert played.returncode == 0, played.stderr
        assert "played 5 message(s)" in played.stdout
        out, _ = echo.communicate(timeout=20)
    assert [d["data"] for d in yaml.safe_load_all(out) if d] == texts


@pytest.mark.slow
def test_bag_paths_that_are_not_mcap_are_named(tmp_path: Path) -> None:
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    result = servolab("bag", "info", str(text), timeout=30)
    assert result.returncode == 2 and result.stderr.count("\n") == 1
    assert result.stderr.startswith("servolab bag info: error: ") and str(text) in result.stderr
    assert "not an MCAP file" in result.stderr
    missing = servolab("bag", "info", str(tmp_path / "nope"), timeout=30)
    assert missing.returncode == 2 and str(tmp_path / "nope") in missing.stderr
    bad_type = servolab("bag", "record", "/x", "-o", str(tmp_path / "b"), "--type", "/x",
                        "--transport", "local", timeout=30)
    assert bad_type.returncode == 2
    assert "--type '/x' is not TOPIC:TYPE" in bad_type.stderr
