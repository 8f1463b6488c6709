"""The fusion node (issue 30): by default robot_localization's way (a fixed-rate prediction
from odometry, the tracker's corrections, /odometry/filtered with its covariance, map -> odom
on /tf, carrying through camera dropouts); with ``filter: seed_000`` it gives, message by
message, what seed 000's D.4 loop gives over a whole recording
(servolab.estimation.kalman.fuse_seed_000, the pure reference). Both refuse NaN.

The D.4 tests below are the ones from before issue 30, changed only to ask for
``filter: seed_000`` (the default became the EKF)."""

from __future__ import annotations

import logging
import math
from typing import Any

import numpy as np
import pytest

from servolab.clock import VirtualClock
from servolab.estimation.kalman import fuse_seed_000
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.robots.base.fusion_node import FusionNode
from servolab.robots.errors import RobotValueError


def _run(odometry: np.ndarray, tracker: np.ndarray) -> tuple[list[Any], FusionNode]:
    ctx = Context.open(clock=VirtualClock())
    node = FusionNode(ctx, parameter_overrides={"filter": "seed_000"})
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
    node = FusionNode(ctx, parameter_overrides={"align_odometry": True, "filter": "seed_000"})
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
    node = FusionNode(ctx, parameter_overrides={"align_odometry": True, "heading_gain": gain,
                                                "filter": "seed_000"})
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


# -- the EKF, robot_localization's way (the default) -------------------------------------------

ODOMETRY = "nav_msgs/msg/Odometry"
POSE = "geometry_msgs/msg/PoseStamped"
#: where the base was switched on, in the map: odometry counts from here
START = (1.0, 2.0, math.pi / 2)


def _quaternion(yaw: float) -> dict[str, float]:
    return {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}


def _yaw(q: Any) -> float:
    return 2 * math.atan2(q.z, q.w)


def _compose(a: tuple[float, float, float], b: tuple[float, float, float]
             ) -> tuple[float, float, float]:
    """``a (+) b`` written out here, not taken from the code under test."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


class Drive:
    """A FusionNode in virtual time, fed by hand: odometry at 50 Hz of a robot on an arc
    (0.2 m/s, 0.4 rad/s, exact), the tracker at 10 Hz seeing the robot where odometry puts it
    in the map (map -> odom = START) unless it is told otherwise; what the node publishes is
    kept with the odometry pose last published before it. Odometry comes 5 ms after the
    node's cycles could (they run at n/30 s from 0): never at the same instant as a cycle,
    whose order against a message would be the executor's to choose."""

    def __init__(self, **overrides: Any) -> None:
        self.ctx = Context.open(clock=VirtualClock())
        self.node = FusionNode(self.ctx, parameter_overrides=overrides)
        self.probe = Node(self.ctx, "probe")
        self.filtered: list[tuple[Any, tuple[float, float, float]]] = []
        self.fused: list[Any] = []
        self.tf: list[tuple[Any, tuple[float, float, float]]] = []
        self.odom_pose = (0.0, 0.0, 0.0)
        self.probe.create_subscription(ODOMETRY, "/odometry/filtered",
                                       lambda m: self.filtered.append((m, self.odom_pose)), 0)
        self.probe.create_subscription(POSE, "/fused_pose", self.fused.append, 0)
        self.probe.create_subscription("tf2_msgs/msg/TFMessage", "/tf",
                                       lambda m: self.tf.append((m, self.odom_pose)), 0)
        self.odom = self.probe.create_publisher(ODOMETRY, "/odom", 0)
        self.tracker = self.probe.create_publisher(POSE, "/tracker/pose", 0)
        self.t = 0.0
        self.ctx.spin_for(0.005)

    def odometry_at(self, t: float) -> tuple[float, float, float]:
        v, w = 0.2, 0.4
        return (v / w * math.sin(w * t), v / w * (1 - math.cos(w * t)), w * t)

    def publish_odometry(self, pose: tuple[float, float, float]) -> None:
        self.odom.publish(self.probe.message(ODOMETRY, header={"frame_id": "odom"}, pose={
            "pose": {"position": {"x": pose[0], "y": pose[1]},
                     "orientation": _quaternion(pose[2])}},
            twist={"twist": {"linear": {"x": 0.2}, "angular": {"z": 0.4}}}))

    def sight(self, pose: tuple[float, float, float], frame: str = "map") -> None:
        self.tracker.publish(self.probe.message(POSE, header={"frame_id": frame}, pose={
            "position": {"x": pose[0], "y": pose[1]}, "orientation": _quaternion(pose[2])}))

    def run(self, seconds: float, *, tracker: bool = True,
            offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Drive ``seconds`` more; the tracker sees the robot (moved by ``offset``) every
        fifth odometry step, if on."""
        for _ in range(round(seconds * 50)):
            k = round(self.t * 50)
            self.odom_pose = self.odometry_at(self.t)
            self.publish_odometry(self.odom_pose)
            if tracker and k % 5 == 0:
                x, y, yaw = _compose(START, self.odom_pose)
                self.sight((x + offset[0], y + offset[1], yaw + offset[2]))
            self.ctx.spin_for(0.02)
            self.t = (k + 1) / 50

    def close(self) -> None:
        self.ctx.close()


@pytest.fixture
def drive() -> Any:
    d = Drive()
    yield d
    d.close()


def _covariance(msg: Any) -> np.ndarray:
    c = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)
    return c[np.ix_([0, 1, 5], [0, 1, 5])]


def _pose_of(msg: Any) -> tuple[float, float, float]:
    p = msg.pose.pose.position if hasattr(msg.pose, "pose") else msg.pose.position
    q = msg.pose.pose.orientation if hasattr(msg.pose, "pose") else msg.pose.orientation
    return (p.x, p.y, _yaw(q))


def test_nothing_is_published_before_the_tracker_has_seen_the_robot(drive: Drive) -> None:
    drive.run(0.5, tracker=False)
    assert drive.filtered == [] and drive.fused == [] and drive.tf == []
    assert drive.node.pose is None


def test_through_a_dropout_the_pose_follows_odometry_at_the_fixed_rate_its_covariance_growing(
        drive: Drive, caplog: pytest.LogCaptureFixture) -> None:
    """The tracker speaks for 1 s, then is silent for 2 s: the node keeps publishing at 30 Hz
    (robot_localization's default frequency), the pose is odometry's moved into the map
    (exact here, as odometry is), and the covariance's volume and trace grow every cycle."""
    drive.run(1.0)
    seen = len(drive.filtered)
    drive.run(2.0, tracker=False)
    dropout = drive.filtered[seen:]
    assert len(dropout) == pytest.approx(60, abs=1)  # 30 Hz for 2 s
    stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m, _ in dropout]
    assert np.diff(stamps) == pytest.approx(1 / 30, abs=1e-6)
    for msg, odom in dropout:
        expected = _compose(START, odom)
        got = _pose_of(msg)
        assert got[:2] == pytest.approx(expected[:2], abs=1e-9)
        assert math.remainder(got[2] - expected[2], 2 * math.pi) == pytest.approx(0, abs=1e-9)
    moved = _pose_of(dropout[-1][0])[:2]
    assert math.dist(moved, _pose_of(dropout[0][0])[:2]) > 0.3  # 0.4 m of arc, predicted
    sigmas = [_covariance(m) for m, _ in dropout]
    assert np.all(np.diff([np.linalg.det(s) for s in sigmas]) > 0)
    assert np.all(np.diff([np.trace(s) for s in sigmas]) > 0)
    assert drive.node.tracker_silent and drive.node.dropouts == 1
    warnings = [r.getMessage() for r in caplog.records if r.levelname == "WARNING"]
    assert len(warnings) == 1 and "no tracker pose for" in warnings[0]


def test_a_sighting_pulls_the_pose_towards_it_and_shrinks_the_covariance(
        drive: Drive, caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO)
    drive.run(1.0)
    drive.run(1.0, tracker=False)
    before = drive.filtered[-1][0]
    predicted = _pose_of(before)
    expected = _compose(START, drive.odom_pose)  # where odometry alone puts it now
    drive.sight((expected[0] + 0.05, expected[1], expected[2]))  # 5 cm off, along map +x
    drive.ctx.spin_for(1 / 30)  # to the next cycle
    after = drive.filtered[-1][0]
    assert after is not before
    got = _pose_of(after)
    assert expected[0] + 0.005 < got[0] < expected[0] + 0.05  # pulled most of the way
    shrunk, grown = np.diag(_covariance(after)), np.diag(_covariance(before))
    assert np.all(shrunk < grown)
    assert shrunk[:2].sum() < 0.5 * grown[:2].sum()  # the position's variance at least halved
    assert not drive.node.tracker_silent and drive.node.corrections > 0
    assert any("tracker back after" in r.getMessage() for r in caplog.records)
    assert predicted != got


def test_a_wrong_first_heading_is_corrected_by_later_sightings() -> None:
    """The first sighting's heading is 10° off: odometry is then moved into the map 10°
    askew. Later (right) sightings pull the heading back: the Kalman gain does what D.4's
    heading_gain did by hand, and map -> odom converges to START."""
    d = Drive()
    try:
        d.sight(_compose(START, (0.0, 0.0, math.radians(10))))
        d.run(2.0)
        assert d.node.map_from_odom is not None
        assert d.node.map_from_odom[:2] == pytest.approx(START[:2], abs=0.005)
        assert math.degrees(abs(math.remainder(d.node.map_from_odom[2] - START[2],
                                               2 * math.pi))) < 0.5
    finally:
        d.close()


def test_map_to_odom_on_tf_composes_with_the_odometry_to_the_fused_pose(drive: Drive) -> None:
    drive.run(1.0)
    drive.run(0.5, tracker=False)
    drive.run(0.5, offset=(0.02, -0.01, 0.03))  # disagreeing: map -> odom moves
    assert len(drive.tf) == len(drive.fused) == len(drive.filtered) > 50
    for (tf, odom), fused, (filtered, _) in zip(drive.tf, drive.fused, drive.filtered,
                                                strict=True):
        (t,) = tf.transforms
        assert (t.header.frame_id, t.child_frame_id) == ("map", "odom")
        map_odom = (t.transform.translation.x, t.transform.translation.y,
                    _yaw(t.transform.rotation))
        composed = _compose(map_odom, odom)
        pose = _pose_of(fused)
        assert composed[:2] == pytest.approx(pose[:2], abs=1e-9)
        assert math.remainder(composed[2] - pose[2], 2 * math.pi) == pytest.approx(0, abs=1e-9)
        assert fused.header == t.header == filtered.header
    maps = {tuple(np.round(_pose_of_tf(tf), 6)) for tf, _ in drive.tf}
    assert len(maps) > 1  # the disagreeing sightings moved it


def _pose_of_tf(msg: Any) -> tuple[float, float, float]:
    t = msg.transforms[0].transform
    return (t.translation.x, t.translation.y, _yaw(t.rotation))


def test_odometry_filtered_is_filled_as_robot_localization_fills_it(drive: Drive) -> None:
    drive.run(0.5)
    msg = drive.filtered[-1][0]
    assert (msg.header.frame_id, msg.child_frame_id) == ("map", "base_footprint")
    c = np.asarray(msg.pose.covariance).reshape(6, 6)
    assert c.shape == (6, 6) and np.array_equal(c, c.T)
    sigma = drive.node.pose_filter.covariance if drive.node.pose_filter else None
    assert sigma is not None
    np.testing.assert_array_equal(c[np.ix_([0, 1, 5], [0, 1, 5])], sigma)
    assert [c[2, 2], c[3, 3], c[4, 4]] == [1e-6] * 3  # two_d_mode's z, roll, pitch
    off = c.copy()
    off[np.ix_([0, 1, 5], [0, 1, 5])] = 0
    np.fill_diagonal(off, 0)
    assert not off.any()  # z, roll and pitch are correlated with nothing
    assert (msg.twist.twist.linear.x, msg.twist.twist.angular.z) == (0.2, 0.4)


def test_non_finite_input_is_refused_in_one_line_and_changes_nothing(
        drive: Drive, caplog: pytest.LogCaptureFixture) -> None:
    drive.run(0.5)
    node = drive.node
    assert node.pose_filter is not None
    mean, sigma = node.pose_filter.mean, node.pose_filter.covariance
    odom_before = node._odometry_pose
    caplog.clear()
    drive.publish_odometry((math.nan, 0.0, 0.0))
    drive.sight((1.0, math.inf, 0.0))
    drive.sight((1.0, 2.0, math.nan))
    drive.sight((1.0, 2.0, 0.0), frame="odom")
    while drive.ctx.spin_once(0.0):  # the messages, no time passing: no cycle runs
        pass
    errors = [r.getMessage() for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 4 and all("\n" not in e and "refused" in e for e in errors)
    assert "odom refused" in errors[0] and "'odom'" in errors[3]
    assert np.array_equal(node.pose_filter.mean, mean)
    assert np.array_equal(node.pose_filter.covariance, sigma)
    assert node._odometry_pose == odom_before
    drive.run(0.5)  # and it goes on as before
    assert _pose_of(drive.fused[-1])[:2] == pytest.approx(
        _compose(START, drive.odom_pose)[:2], abs=1e-9)


def test_bad_parameters_are_refused() -> None:
    ctx = Context.open(clock=VirtualClock())
    try:
        for overrides in ({"filter": "ukf"}, {"frequency": 0.0}, {"sensor_timeout": -1.0},
                          {"tracker_position_variance": 0.0},
                          {"process_noise.translation_per_metre": math.nan}):
            with pytest.raises(RobotValueError):
                FusionNode(ctx, f"fusion_{len(ctx.nodes)}", parameter_overrides=overrides)
    finally:
        ctx.close()


def test_after_max_dead_reckoning_without_the_tracker_nothing_is_published(
        caplog: pytest.LogCaptureFixture) -> None:
    """A tracker silent longer than max_dead_reckoning (1 s here): the node stops publishing,
    so the navigator's pose timeout stops the wheels instead of driving on odometry alone;
    the next sighting brings the pose back."""
    d = Drive(max_dead_reckoning=1.0)
    try:
        d.run(1.0)
        seen = len(d.fused)
        d.run(2.0, tracker=False)
        blind = len(d.fused) - seen
        # about 1 s more at 30 Hz after the last sighting (at 0.9 or 1.0 s), then nothing
        assert 25 <= blind <= 32
        assert d.node.blind and "max_dead_reckoning" in caplog.text
        d.run(0.5)
        assert not d.node.blind and len(d.fused) > seen + blind
    finally:
        d.close()


def test_with_the_base_node_the_fused_pose_is_the_truth_and_tf_closes_the_loop() -> None:
    """The real BaseNode (an emulated seed 000 base switched on at START on the floor) drives
    an arc; the tracker reports the floor's truth at 10 Hz, then falls silent for 0.7 s. The
    fused pose stays on the truth, and map -> odom composed with the BaseNode's own
    odom -> base_footprint on /tf, once the base stands, is the fused pose."""
    from servolab.robots.base.config import SHIPPED_DIR, load
    from servolab.robots.base.mobile_base import MobileBase
    from servolab.robots.base.node import BaseNode

    base = MobileBase.emulated(load(SHIPPED_DIR / "base_seed000.yaml"), start=START)
    ctx = Context.open(clock=base.clock)
    try:
        BaseNode(ctx, base)
        fusion = FusionNode(ctx)
        probe = Node(ctx, "probe")
        base_tf: list[Any] = []
        fusion_tf: list[Any] = []

        def on_tf(msg: Any) -> None:
            (t,) = msg.transforms
            (fusion_tf if t.header.frame_id == "map" else base_tf).append(t)

        probe.create_subscription("tf2_msgs/msg/TFMessage", "/tf", on_tf, 0)
        fused: list[Any] = []
        probe.create_subscription(POSE, "/fused_pose", fused.append, 0)
        cmd = probe.create_publisher("geometry_msgs/msg/Twist", "/cmd_vel", 0)
        tracker = probe.create_publisher(POSE, "/tracker/pose", 0)
        errors = []
        start = base.clock.now()
        while (t := base.clock.now() - start) < 2.0:
            moving = t < 1.7
            cmd.publish(probe.message("geometry_msgs/msg/Twist", linear={"x": 0.1 * moving},
                                      angular={"z": 0.3 * moving}))
            truth = base.truth()
            if not 0.8 <= t < 1.5:
                tracker.publish(probe.message(POSE, header={"frame_id": "map"}, pose={
                    "position": {"x": truth["x"], "y": truth["y"]},
                    "orientation": _quaternion(truth["yaw"])}))
            ctx.spin_for(0.1)
            if fused:
                errors.append(math.dist(_pose_of(fused[-1])[:2], (truth["x"], truth["y"])))
        assert fusion.dropouts == 1
        assert max(errors) < 0.02, errors
        t_map = fusion_tf[-1].transform
        t_odom = base_tf[-1].transform
        composed = _compose((t_map.translation.x, t_map.translation.y, _yaw(t_map.rotation)),
                            (t_odom.translation.x, t_odom.translation.y, _yaw(t_odom.rotation)))
        assert composed[:2] == pytest.approx(_pose_of(fused[-1])[:2], abs=1e-9)
        assert base_tf[-1].child_frame_id == "base_footprint"
    finally:
        ctx.close()
        base.bus.close()
