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
from servolab.robots.fusion_node import FusionNode


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
