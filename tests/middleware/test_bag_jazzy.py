"""Bags as rosbag2 Jazzy writes them: metadata.yaml version 9 field for field (rosbag2_storage's
``yaml.hpp`` / ``qos.cpp``), offered QoS profiles as a list, and the ``rosbag2`` metadata record
inside the MCAP (rosbag2_storage_mcap's ``update_metadata``), checked with ``rosbags`` and
``mcap``, readers servolab does not share code with."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from mcap.reader import make_reader
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader as RosbagsReader
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as RosbagsWriter
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import Stores, get_typestore

from servolab.middleware.bag import BagWriter, qos_profile
from servolab.middleware.messages import MessageTypes

T0 = 1_700_000_000_000_000_000
INFINITE = {"sec": 9223372036, "nsec": 854775807}  # RMW_DURATION_INFINITE

#: Key order of each YAML map, as the ``encode`` functions of rosbag2 Jazzy's yaml.hpp and
#: qos.cpp set them (yaml-cpp keeps insertion order).
BAG_KEYS = ["version", "storage_identifier", "duration", "starting_time", "message_count",
            "topics_with_message_count", "compression_format", "compression_mode",
            "relative_file_paths", "files", "custom_data", "ros_distro"]
TOPIC_INFO_KEYS = ["topic_metadata", "message_count"]
TOPIC_KEYS = ["name", "type", "serialization_format", "offered_qos_profiles",
              "type_description_hash"]
QOS_KEYS = ["history", "depth", "reliability", "durability", "deadline", "lifespan",
            "liveliness", "liveliness_lease_duration", "avoid_ros_namespace_conventions"]
FILE_KEYS = ["path", "starting_time", "duration", "message_count"]


def jazzy_profile(*, depth: int, reliability: str, durability: str,
                  history: str = "keep_last") -> dict[str, Any]:
    """A profile as rosbag2 Jazzy writes one of a publisher with no deadline, lifespan or
    liveliness lease (rclcpp's defaults), e.g. in ``ros2 bag record``'s metadata.yaml."""
    return {"history": history, "depth": depth, "reliability": reliability,
            "durability": durability, "deadline": INFINITE, "lifespan": INFINITE,
            "liveliness": "automatic", "liveliness_lease_duration": INFINITE,
            "avoid_ros_namespace_conventions": False}


def record(path: Path, types: MessageTypes) -> None:
    twist = types.from_value("geometry_msgs/msg/Twist", {"linear": {"x": 1.5}})
    with BagWriter(path, types) as writer:
        writer.add_topic("/cmd_vel", "geometry_msgs/msg/Twist",
                         [qos_profile(depth=10), qos_profile(reliable=False, depth=5)])
        writer.add_topic("/robot_description", "std_msgs/msg/String",
                         [qos_profile(transient_local=True, depth=1)])
        writer.add_topic("/unseen", "std_msgs/msg/String")
        for i in range(4):
            writer.write("/cmd_vel", twist, T0 + i * 1000)
        writer.write("/robot_description",
                     types.from_value("std_msgs/msg/String", {"data": "<robot/>"}), T0 + 500)


EXPECTED_QOS = {
    "/cmd_vel": [jazzy_profile(depth=10, reliability="reliable", durability="volatile"),
                 jazzy_profile(depth=5, reliability="best_effort", durability="volatile")],
    "/robot_description": [jazzy_profile(depth=1, reliability="reliable",
                                         durability="transient_local")],
    "/unseen": [],
}


def test_metadata_yaml_is_version_9_field_for_field(tmp_path: Path,
                                                    types: MessageTypes) -> None:
    record(tmp_path / "run", types)
    meta = yaml.safe_load((tmp_path / "run" / "metadata.yaml").read_text())
    assert list(meta) == ["rosbag2_bagfile_information"]
    info = meta["rosbag2_bagfile_information"]
    assert list(info) == BAG_KEYS
    assert info["version"] == 9 and info["ros_distro"] == "jazzy"
    assert info["custom_data"] is None  # yaml-cpp writes an empty map as ~
    assert [list(f) for f in info["files"]] == [FILE_KEYS]
    assert info["message_count"] == 5
    assert info["duration"] == {"nanoseconds": 3000}
    topics = info["topics_with_message_count"]
    assert [list(t) for t in topics] == [TOPIC_INFO_KEYS] * 3
    assert [list(t["topic_metadata"]) for t in topics] == [TOPIC_KEYS] * 3
    got = {t["topic_metadata"]["name"]: t["topic_metadata"]["offered_qos_profiles"]
           for t in topics}
    assert got == EXPECTED_QOS
    for profiles in got.values():
        for profile in profiles:
            assert list(profile) == QOS_KEYS
    assert {t["topic_metadata"]["name"]: t["message_count"] for t in topics} == {
        "/cmd_vel": 4, "/robot_description": 1, "/unseen": 0}


def test_rosbags_reads_the_offered_qos_profiles(tmp_path: Path, types: MessageTypes) -> None:
    record(tmp_path / "run", types)
    infinite = QosTime(**INFINITE)

    def qos(depth: int, reliability: QosReliability, durability: QosDurability) -> Qos:
        return Qos(QosHistory.KEEP_LAST, depth, reliability, durability, infinite, infinite,
                   QosLiveliness.AUTOMATIC, infinite, False)

    with RosbagsReader(tmp_path / "run") as reader:
        offered = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        assert reader.message_count == 5 and reader.ros_distro == "jazzy"
    assert offered == {
        "/cmd_vel": [qos(10, QosReliability.RELIABLE, QosDurability.VOLATILE),
                     qos(5, QosReliability.BEST_EFFORT, QosDurability.VOLATILE)],
        "/robot_description": [qos(1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL)],
        "/unseen": []}


def test_profiles_match_what_rosbags_writes_for_version_9(tmp_path: Path,
                                                          types: MessageTypes) -> None:
    """rosbags' own version-9 writer, given the same profiles, writes the same list."""
    record(tmp_path / "ours", types)
    infinite = QosTime(**INFINITE)
    store = get_typestore(Stores.ROS2_JAZZY)
    profiles = [Qos(QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, QosDurability.VOLATILE,
                    infinite, infinite, QosLiveliness.AUTOMATIC, infinite, False),
                Qos(QosHistory.KEEP_LAST, 5, QosReliability.BEST_EFFORT,
                    QosDurability.VOLATILE, infinite, infinite, QosLiveliness.AUTOMATIC,
                    infinite, False)]
    with RosbagsWriter(tmp_path / "theirs", version=9,
                       storage_plugin=StoragePlugin.MCAP) as writer:
        writer.add_connection("/cmd_vel", "geometry_msgs/msg/Twist", typestore=store,
                              offered_qos_profiles=profiles)

    def cmd_vel(bag: Path) -> dict[str, Any]:
        info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
        assert info["version"] == 9
        return next(t["topic_metadata"] for t in info["topics_with_message_count"]
                    if t["topic_metadata"]["name"] == "/cmd_vel")

    ours, theirs = cmd_vel(tmp_path / "ours"), cmd_vel(tmp_path / "theirs")
    assert ours["offered_qos_profiles"] == theirs["offered_qos_profiles"]
    assert set(ours) == set(theirs)  # rosbags orders keys its own way; Jazzy's is TOPIC_KEYS


def test_channels_carry_the_profiles_as_rosbag2_mcap_does(tmp_path: Path,
                                                          types: MessageTypes) -> None:
    record(tmp_path / "run", types)
    with open(tmp_path / "run" / "run_0.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    channels = {c.topic: c.metadata for c in summary.channels.values()}
    for topic, expected in EXPECTED_QOS.items():
        text = channels[topic]["offered_qos_profiles"]
        assert not text.endswith("\n")  # YAML::Dump, no final newline
        assert yaml.safe_load(text) == expected
        assert parse_qos(text) == parse_qos(expected)  # type: ignore[arg-type]
    assert channels["/unseen"]["offered_qos_profiles"] == "[]"


def test_the_mcap_file_alone_carries_the_bag_s_metadata(tmp_path: Path,
                                                        types: MessageTypes) -> None:
    """``ros2 bag info run_0.mcap`` (Jazzy) reads the ``rosbag2`` metadata record's
    ``serialized_metadata``: the same map as metadata.yaml, without its outer key."""
    record(tmp_path / "run", types)
    yaml_info = yaml.safe_load((tmp_path / "run" / "metadata.yaml").read_text())[
        "rosbag2_bagfile_information"]
    (tmp_path / "run" / "metadata.yaml").unlink()
    with open(tmp_path / "run" / "run_0.mcap", "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        records = [(m.name, m.metadata) for m in reader.iter_metadata()]
    assert summary is not None
    # Jazzy finds it through the summary's metadata index.
    assert [i.name for i in summary.metadata_indexes] == ["rosbag2"]
    assert len(records) == 1
    name, data = records[0]
    assert name == "rosbag2"
    assert set(data) == {"serialized_metadata", "ROS_DISTRO"}
    assert data["ROS_DISTRO"] == "jazzy"
    assert not data["serialized_metadata"].endswith("\n")
    inner = yaml.safe_load(data["serialized_metadata"])
    assert list(inner) == BAG_KEYS
    assert inner == yaml_info
    assert inner["ros_distro"] == "jazzy" and inner["version"] == 9
