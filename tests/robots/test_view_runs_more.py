"""``servolab drive --view`` and ``servolab flyball --view`` watched by Foxglove's own client.

As in :mod:`tests.robots.test_view_runs`: ``@foxglove/ws-protocol``'s client in Node, speaking
``foxglove.sdk.v1`` (Foxglove now), decodes what the run serves, which must equal what the
run's bag recorded (read back with ``mcap`` and ``mcap-ros2-support``); the treadmill camera's
overlay, which the bag does not hold, must be the image the rig's camera makes.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.robots.test_view_runs import _messages, _recorded, _stamp, _watch
from tests.viewclient import SDK_V1

# each runs a robot or a launch in other processes (and a browser): every core busy, so
# not beside the tests that hold the wall clock to a deadline (tests/conftest.py)
pytestmark = [pytest.mark.slow, pytest.mark.realtime]


def test_a_watched_drive_shows_its_odometry_as_its_bag_recorded_it(tmp_path: Path) -> None:
    # 10 simulated seconds, 2.5 s of wall time at --view-speed 4: the run starts as the
    # client connects, and its subscription takes a moment to reach the graph
    events = _watch(["drive", "line", "--distance", "1", "--speed", "0.1"], tmp_path,
                    ["/odom", "/ground_truth"], SDK_V1, count=5)
    server = next(e for e in events if e.get("op") == "serverInfo")
    assert "time" in server["capabilities"]  # a simulated run: the app follows its clock
    recorded = _recorded(tmp_path / "drive_bag")
    # watching changes nothing of the move: nobody else moved the simulated clock under it
    measured = json.loads((tmp_path / "summary.json").read_text())["measured"]
    assert measured["truth_length_m"] == pytest.approx(1.0, rel=0.01)

    odometry = {_stamp(m.header): m for m in recorded["/odom"]}
    shown = _messages(events, "/odom")
    assert len(shown) >= 5
    for msg in shown:
        twin = odometry[_stamp(msg["header"])]
        assert msg["header"]["frame_id"] == twin.header.frame_id == "odom"
        assert msg["child_frame_id"] == twin.child_frame_id
        p, q = msg["pose"]["pose"]["position"], msg["pose"]["pose"]["orientation"]
        assert (p["x"], p["y"]) == (twin.pose.pose.position.x, twin.pose.pose.position.y)
        assert (q["z"], q["w"]) == (twin.pose.pose.orientation.z, twin.pose.pose.orientation.w)
    assert shown[-1]["pose"]["pose"]["position"]["x"] > 0  # the base moved while watched

    truth = {_stamp(m.header): m for m in recorded["/ground_truth"]}
    for msg in _messages(events, "/ground_truth"):
        twin = truth[_stamp(msg["header"])]
        assert msg["pose"]["pose"]["position"]["x"] == twin.pose.pose.position.x


def test_a_watched_flyball_shows_the_fly_and_the_camera_overlay(tmp_path: Path) -> None:
    from servolab.robots.treadmill.config import load_rig
    from servolab.robots.treadmill.node import OVERLAY_TOPIC

    # 4 simulated seconds, 264 camera frames: at least 1 s of wall time at --view-speed 4 (see
    # the drive's test) for the client's 5 poses and first overlay, which need 5 frames (the
    # overlay is drawn on every frame while someone watches); a longer run adds only frames
    events = _watch(["flyball", "--duration", "4"], tmp_path, ["/fly/pose", OVERLAY_TOPIC],
                    SDK_V1, count=5)
    server = next(e for e in events if e.get("op") == "serverInfo")
    assert "time" in server["capabilities"]
    recorded = _recorded(tmp_path / "flyball_bag")

    # geometry_msgs/Pose2D has no header: what was shown is a run of the bag's, in order
    poses = [(m.x, m.y, m.theta) for m in recorded["/fly/pose"]]
    shown = [(m["x"], m["y"], m["theta"]) for m in _messages(events, "/fly/pose")]
    assert len(shown) >= 5
    start = poses.index(shown[0])
    assert poses[start:start + len(shown)] == shown

    camera = load_rig(None).camera  # the rig's camera: the overlay is drawn on its frames
    images = _messages(events, OVERLAY_TOPIC)
    assert images
    for image in images:
        assert (image["width"], image["height"]) == (camera.width, camera.height)
        assert image["encoding"] in ("bgr8", "rgb8")
        assert image["step"] == 3 * camera.width
        assert len(image["data"]) == image["step"] * image["height"]
