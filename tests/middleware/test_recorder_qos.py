"""The recorder takes each topic's QoS from its publishers, as ``ros2 bag record`` does
(rosbag2_storage ``qos.cpp``, ``Rosbag2QoS::adapt_request_to_offers``), and writes the offered
profiles into the bag, read back here with the independent ``rosbags`` reader."""

from __future__ import annotations

from pathlib import Path

from rosbags.interfaces import QosDurability, QosReliability
from rosbags.rosbag2 import Reader as RosbagsReader

from servolab.middleware.context import Context
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from servolab.middleware.recorder import Recorder, request_for

STRING = "std_msgs/msg/String"
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SENSOR = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def test_a_latched_topic_published_before_recording_is_recorded(tmp_path: Path,
                                                                 types: MessageTypes) -> None:
    """A /robot_description published once, before the recorder starts, is in the bag: every
    publisher offers TRANSIENT_LOCAL, so the recorder asks for it; the offered profiles are
    in the metadata as rosbag2 Jazzy writes them."""
    with Context.open(types=types) as ctx:
        node = Node(ctx, "robot_state_publisher")
        node.create_publisher(STRING, "/robot_description", LATCHED).publish(
            node.message(STRING, data="<robot name='biped'/>"))
        node.create_publisher(STRING, "/chatter", SENSOR).publish(
            node.message(STRING, data="before recording: not latched, not recorded"))
        recorder = Recorder(ctx, str(tmp_path / "run"), ["/robot_description", "/chatter"])
        assert ctx.spin_until(lambda: recorder.counts["/robot_description"] == 1, timeout=5.0)
        recorder.destroy()
    with RosbagsReader(tmp_path / "run") as reader:
        offered = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
        data = {c.topic: [types.deserialize(raw, c.msgtype).data
                          for _, _, raw in reader.messages(connections=[c])]
                for c in reader.connections}
    assert data == {"/robot_description": ["<robot name='biped'/>"], "/chatter": []}
    [latched] = offered["/robot_description"]
    assert latched.durability == QosDurability.TRANSIENT_LOCAL and latched.depth == 1
    [sensor] = offered["/chatter"]
    assert sensor.reliability == QosReliability.BEST_EFFORT and sensor.depth == 5


def test_the_request_adapts_to_every_offer_as_rosbag2s() -> None:
    """adapt_request_to_offers: TRANSIENT_LOCAL / RELIABLE only when *every* publisher offers
    it (so the recorder connects to all of them); history KEEP_ALL so no burst is cut."""
    volatile = QoSProfile()
    assert request_for([LATCHED, LATCHED]).transient_local
    assert not request_for([LATCHED, volatile]).transient_local
    assert request_for([LATCHED, volatile]).reliable
    assert not request_for([volatile, SENSOR]).reliable
    assert request_for([]).reliable and not request_for([]).transient_local
    assert all(request_for(o).keep_all for o in ([], [LATCHED], [SENSOR]))
