"""The fusion node gives, message by message, what seed 000's D.4 loop gives over a whole
recording (servolab.estimation.kalman.fuse_seed_000, the pure reference), and refuses NaN."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from servolab.clock import VirtualClock
from servolab.estimation.kalman import fuse_seed_000
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.base.fusion_node import FusionNode


def _run(odometry: np.ndarray, tracker: np.ndarray) -> tuple[list[Any], FusionNode]:
    ctx = Context.open(clock=VirtualClock())
    node = FusionNode(ctx)
    probe = Node(ctx, "probe")
    fused: list[Any] = []
    probe.create_subscription("geometry_msgs/msg/PoseStamped", "/fused_pose", fused.append, 0)
    odom = probe.create_publisher("nav_msgs/msg/Odometry", "/odom", 0)
    pose = probe.create_publisher("geometry_msgs/msg/PoseStamped", "/tracker/pose", 0)
    for (ox, oy), (tx, ty) in zip(odometry, tracker, strict=True):
        odom.publish(probe.message("nav_msgs/msg/Odometry",
                                   pose={"pose": {"position": {"x": ox, "y": oy}}}))
        ctx.spin_until(lambda ox=ox: (node.odometry is not None and node.odometry[0] == ox)
                       or math.isnan(ox), timeout=1.0)
        before = len(fused)
        pose.publish(probe.message("geometry_msgs/msg/PoseStamped",
                                   header={"frame_id": "map"},
                                   pose={"position": {"x": tx, "y": ty}}))
        ctx.spin_until(lambda before=before, tx=tx: len(fused) > before or math.isnan(tx),
                       timeout=1.0)
    ctx.close()
    return fused, node


def test_the_node_fuses_as_the_seeds_loop_does() -> None:
    rng = np.random.default_rng(1)
    t = np.linspace(0, 2 * np.pi, 60)
    truth = np.column_stack([50 * np.cos(t), 50 * np.sin(t)])
    odometry = truth + np.cumsum(rng.normal(0, 0.3, truth.shape), axis=0)
    tracker = truth + rng.normal(0, 2.5, truth.shape)
    fused, _ = _run(odometry, tracker)
    got = np.array([(m.pose.position.x, m.pose.position.y) for m in fused])
    np.testing.assert_allclose(got, fuse_seed_000(odometry, tracker), atol=1e-9)
    assert {m.header.frame_id for m in fused} == {"map"}


def test_a_nan_tracker_pose_is_refused_and_changes_nothing() -> None:
    odometry = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    tracker = np.array([[0.0, 0.0], [math.nan, 1.0], [2.0, 2.0]])
    fused, _ = _run(odometry, tracker)
    assert len(fused) == 2  # the NaN sample made no estimate
    expected = fuse_seed_000(odometry[[0, 2]], tracker[[0, 2]])
    assert (fused[-1].pose.position.x, fused[-1].pose.position.y) == pytest.approx(
        tuple(expected[-1]))


def test_aligned_odometry_is_fused_in_the_map_frame() -> None:
    """A base switched on at map pose (1, 2, 90°): its odometry counts from (0, 0, 0). With
    align_odometry the first tracker pose gives map -> odom, and later odometry lands on the
    truth in the map frame, heading included (the seed's fusion would average two frames)."""
    ctx = Context.open(clock=VirtualClock())
    node = FusionNode(ctx, parameter_overrides={"align_odometry": True})
    probe = Node(ctx, "probe")
    fused: list[Any] = []
    probe.create_subscription("geometry_msgs/msg/PoseStamped", "/fused_pose", fused.append, 0)
    odom = probe.create_publisher("nav_msgs/msg/Odometry", "/odom", 0)
    pose = probe.create_publisher("geometry_msgs/msg/PoseStamped", "/tracker/pose", 0)
    start = (1.0, 2.0, math.pi / 2)

    def quaternion(yaw: float) -> dict[str, float]:
        return {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}

    for k in range(20):  # forward along the odometry's x, which is the map's +y
        s = 0.05 * k
        odom.publish(probe.message("nav_msgs/msg/Odometry", pose={"pose": {
            "position": {"x": s, "y": 0.0}, "orientation": quaternion(0.0)}}))
        ctx.spin_until(lambda s=s: node._odometry_pose is not None
                       and node._odometry_pose[0] == s, timeout=1.0)
        before = len(fused)
        pose.publish(probe.message("geometry_msgs/msg/PoseStamped", header={"frame_id": "map"},
                                   pose={"position": {"x": start[0], "y": start[1] + s},
                                         "orientation": quaternion(start[2])}))
        ctx.spin_until(lambda before=before: len(fused) > before, timeout=1.0)
    ctx.close()
    assert node.map_from_odom == pytest.approx(start)
    # odometry in the map frame is the truth here, as is the tracker: D.4's loop on the two
    truth = np.array([(1.0, 2.0 + 0.05 * k) for k in range(20)])
    got = np.array([(m.pose.position.x, m.pose.position.y) for m in fused])
    np.testing.assert_allclose(got, fuse_seed_000(truth, truth), atol=1e-9)
    last = fused[-1].pose
    assert 2 * math.atan2(last.orientation.z, last.orientation.w) == pytest.approx(math.pi / 2)


@pytest.mark.parametrize("gain", [0.0, 0.05])
def test_the_trackers_heading_corrects_a_wrong_alignment(gain: float) -> None:
    """The first sighting's heading is 10° off (the tracker's error); later sightings are
    right. With heading_gain the fused heading converges to the tracker's (0.95^k of the
    error is left after k sightings); with 0 it keeps the first alignment's error."""
    ctx = Context.open(clock=VirtualClock())
    node = FusionNode(ctx, parameter_overrides={"align_odometry": True, "heading_gain": gain})
    probe = Node(ctx, "probe")
    fused: list[Any] = []
    probe.create_subscription("geometry_msgs/msg/PoseStamped", "/fused_pose", fused.append, 0)
    odom = probe.create_publisher("nav_msgs/msg/Odometry", "/odom", 0)
    pose = probe.create_publisher("geometry_msgs/msg/PoseStamped", "/tracker/pose", 0)
    odom.publish(probe.message("nav_msgs/msg/Odometry", pose={"pose": {
        "orientation": {"w": 1.0}}}))
    ctx.spin_until(lambda: node._odometry_pose is not None, timeout=1.0)
    for k in range(60):
        yaw = math.radians(10.0) if k == 0 else 0.0
        pose.publish(probe.message("geometry_msgs/msg/PoseStamped", header={"frame_id": "map"},
                                   pose={"position": {"x": 1.0, "y": 1.0},
                                         "orientation": {"z": math.sin(yaw / 2),
                                                         "w": math.cos(yaw / 2)}}))
        ctx.spin_until(lambda k=k: len(fused) > k, timeout=1.0)
    ctx.close()
    q = fused[-1].pose.orientation
    heading = math.degrees(2 * math.atan2(q.z, q.w))
    if gain:
        assert heading == pytest.approx(10.0 * 0.95**59, abs=0.01)
        assert (fused[-1].pose.position.x, fused[-1].pose.position.y) == pytest.approx(
            (1.0, 1.0))  # turned about the robot: its position stayed
    else:
        assert heading == pytest.approx(10.0)
