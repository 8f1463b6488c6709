"""What the navigator thinks, published as Nav2 publishes it so rviz2 and Foxglove draw it:
the inflated costmap on /global_costmap/costmap (nav_msgs/OccupancyGrid on Nav2's 0..100 / -1
scale, Costmap2DPublisher's cost_translation_table_), DWA's chosen trajectory on /local_plan,
the driven path on /path (nav_msgs/Path) and the goal on /goal_pose (PoseStamped, latched).

First the navigator alone on a hand-made map in virtual time, then a short `servolab navigate`
run whose MCAP is read back with the independent decoders (mcap + mcap-ros2-support)."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from servolab.planning.costmap import inflate
from servolab.robots.navigation.display import PATH_SPACING, costmap_occupancy, costmap_values
from servolab.robots.navigation.params import DEFAULT_COSTMAP, load_costmap
from servolab.robots.navigation.tracker_node import LATCHED
from tests.robots.navigation.test_navigator import POSE, Rig

PATH = "nav_msgs/msg/Path"
GRID = "nav_msgs/msg/OccupancyGrid"


def nav2_scale(cost: int) -> int:
    """Nav2's Costmap2DPublisher (nav2_costmap_2d/src/costmap_2d_publisher.cpp), written out
    here again: 0 free, 1..252 to 1..98, 253 inscribed 99, 254 lethal 100, 255 unknown -1."""
    special = {0: 0, 253: 99, 254: 100, 255: -1}
    return special[cost] if cost in special else 1 + (97 * (cost - 1)) // 251


def yaw_of(q: Any) -> float:
    return 2.0 * math.atan2(float(q.z), float(q.w))


def test_the_cost_scale_is_nav2s() -> None:
    table = costmap_values()
    assert [int(v) for v in table] == [nav2_scale(c) for c in range(256)]
    assert (table[1], table[128], table[252]) == (1, 50, 98)
    assert np.all(np.diff(table[:255].astype(int)) >= 0)  # monotone up to lethal
    grid = np.array([[0, 1, 252], [253, 254, 255]], dtype=np.uint8)
    assert costmap_occupancy(grid).tolist() == [0, 1, 98, 99, 100, -1]


class Watched(Rig):
    """The navigator rig with a probe on the four display topics."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.costmaps: list[Any] = []
        self.local_plans: list[Any] = []
        self.paths: list[Any] = []
        self.goals: list[Any] = []
        self.probe.create_subscription(GRID, "/global_costmap/costmap", self.costmaps.append,
                                       LATCHED)
        self.probe.create_subscription(PATH, "/local_plan", self.local_plans.append, 0)
        self.probe.create_subscription(PATH, "/path", self.paths.append, 0)
        self.probe.create_subscription(POSE, "/goal_pose", self.goals.append, LATCHED)


@pytest.fixture
def watched() -> Iterator[Watched]:
    rig = Watched(occupied=(slice(0, 8), slice(20, 30)))
    yield rig
    rig.context.close()


def test_the_costmap_is_the_inflated_grid_on_nav2s_scale(watched: Watched) -> None:
    watched.drive_for(0.4, poses=True)
    (msg,) = watched.costmaps  # latched; published once while the map stays the same
    assert watched.node.costmap is not None
    occupied = np.zeros((40, 60), dtype=bool)
    occupied[0:8, 20:30] = True
    params = load_costmap(DEFAULT_COSTMAP)
    inflated = inflate(occupied, 0.05, params.inflation_radius, params.cost_scaling_factor,
                       params.inscribed_radius)
    assert np.array_equal(watched.node.costmap, inflated)  # what the planner plans on
    expected = [nav2_scale(int(c)) for c in inflated.reshape(-1)]
    assert np.asarray(msg.data, dtype=np.int8).tolist() == expected
    assert {100, 99, 0} <= set(expected) and any(0 < v < 99 for v in expected)
    assert (msg.header.frame_id, msg.info.width, msg.info.height) == ("map", 60, 40)
    assert msg.info.resolution == pytest.approx(0.05)
    assert (msg.info.origin.position.x, msg.info.origin.position.y) == (0.0, 0.0)
    assert msg.info.origin.orientation.w == 1.0


def test_a_changed_map_republishes_the_costmap(watched: Watched) -> None:
    watched.drive_for(0.4, poses=True)
    grid = watched.probe.create_publisher(GRID, "/map", LATCHED)
    cells = np.zeros((40, 60), dtype=np.int8)
    cells[30:34, 40:44] = 100
    grid.publish(watched.probe.message(GRID, header={"frame_id": "map"}, info={
        "resolution": 0.05, "width": 60, "height": 40, "origin": {"orientation": {"w": 1.0}}},
        data=cells.reshape(-1)))
    watched.drive_for(0.4, poses=True)
    assert len(watched.costmaps) == 2
    data = np.asarray(watched.costmaps[-1].data, dtype=np.int8).reshape(40, 60)
    assert (data[30:34, 40:44] == 100).all() and (data[0:8, 20:30] != 100).all()


def test_goal_local_plan_and_driven_path(watched: Watched) -> None:
    poses = [(0.5 + k / 64, 1.0) for k in range(12)]  # creeping 1/64 m a pose
    for x, y in poses:
        watched.send_pose(x, y)
        watched.context.spin_for(0.1)
    watched.context.spin_for(0.05)  # the probe takes what the last cycle published
    # the goal, latched, and its own echo did not preempt it (one EXECUTING goal)
    (goal,) = watched.goals
    assert (goal.pose.position.x, goal.pose.position.y) == (2.5, 1.0)
    assert goal.header.frame_id == "map"
    assert watched.node.status.name == "ACTIVE" and watched.node.goal_count == 1
    # each cycle's chosen trajectory starts at the pose DWA was given
    assert len(watched.local_plans) == len(watched.node.cycles) >= 4
    for plan, (_, x, y, yaw, v, omega, _) in zip(watched.local_plans, watched.node.cycles,
                                                 strict=True):
        first, last = plan.poses[0].pose, plan.poses[-1].pose
        assert (first.position.x, first.position.y) == pytest.approx((x, y), abs=1e-12)
        assert yaw_of(first.orientation) == pytest.approx(yaw, abs=1e-9)
        assert plan.header.frame_id == "map" and len(plan.poses) > 1
        # DWA's horizon: the chosen (v, w) held for sim_time from the pose
        horizon = watched.node.dwa.sim_time
        assert math.hypot(last.position.x - x, last.position.y - y) <= abs(v) * horizon + 1e-9
        assert math.remainder(yaw_of(last.orientation) - yaw - omega * horizon,
                              2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    # the driven path: a pose kept every PATH_SPACING m, stamped as the pose it was
    driven = [(p.pose.position.x, p.pose.position.y) for p in watched.paths[-1].poses]
    assert driven[0] == pytest.approx(poses[0])
    assert all(math.dist(a, b) >= PATH_SPACING - 1e-9 for a, b in itertools.pairwise(driven))
    assert all(any(math.dist(d, p) < 1e-12 for p in poses) for d in driven)
    assert len(driven) == 6 and len(watched.paths) == 6  # every second pose


def test_a_new_goal_is_published_on_goal_pose(watched: Watched) -> None:
    watched.drive_for(0.4, poses=True)
    watched.node.set_goal(2.0, 1.5, math.pi / 2)
    watched.drive_for(0.4, poses=True)
    assert [(g.pose.position.x, g.pose.position.y) for g in watched.goals] == [
        (2.5, 1.0), (2.0, 1.5)]
    assert yaw_of(watched.goals[-1].pose.orientation) == pytest.approx(math.pi / 2)
    assert watched.node.goal == (2.0, 1.5) and watched.node.goal_count == 2


# -- a whole run, read back from its MCAP -------------------------------------------------------


@pytest.fixture(scope="module")
def short_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    from servolab.robots.navigation.params import load_nav_scene
    from servolab.robots.navigation.run import (
        BOARD_AT,
        calibrate_synthetic,
        prepare,
        run_navigate,
    )
    from servolab.runs import RunFolder
    from servolab.sim.scene import DEFAULT_SCENE

    calibration = calibrate_synthetic(load_nav_scene(DEFAULT_SCENE), np.random.default_rng(0))
    navigation = dataclasses.replace(prepare((1.2, 0.9), goal_yaw=0.5),
                                     calibration=calibration, board_at=BOARD_AT)
    return run_navigate(RunFolder.create("navigate", tmp_path_factory.mktemp("nav")),
                        navigation, say=lambda _: None, show_progress=False)


def _read(summary: dict[str, Any]) -> dict[str, list[tuple[int, Any]]]:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    (mcap,) = Path(summary["bag"]).glob("*.mcap")
    topics: dict[str, list[tuple[int, Any]]] = {}
    with mcap.open("rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages():
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
    return topics


def _stamp(header: Any) -> tuple[int, int]:
    return int(header.stamp.sec), int(header.stamp.nanosec)


@pytest.mark.slow
def test_a_run_records_what_the_navigator_thinks(short_run: dict[str, Any]) -> None:
    assert short_run["status"] == "SUCCEEDED", short_run["reason"]
    topics = _read(short_run)
    # the costmap: the planner's inflation of the camera's map, on Nav2's scale, same frame
    params = load_costmap(DEFAULT_COSTMAP)
    maps, costmaps = topics["/map"], topics["/global_costmap/costmap"]
    assert len(costmaps) == len(maps) >= 1  # the camera's map did not change: nor did it
    for (_, grid), (_, costmap) in zip(maps, costmaps, strict=True):
        info, cinfo = grid.info, costmap.info
        assert (cinfo.width, cinfo.height, cinfo.resolution) == (info.width, info.height,
                                                                 info.resolution)
        assert (cinfo.origin.position.x, cinfo.origin.position.y) == (
            info.origin.position.x, info.origin.position.y)
        assert costmap.header.frame_id == "map"
        occupied = (np.asarray(grid.data, dtype=np.int8) >= 65).reshape(info.height,
                                                                         info.width)
        inflated = inflate(occupied, info.resolution, params.inflation_radius,
                           params.cost_scaling_factor, params.inscribed_radius)
        expected = [nav2_scale(int(c)) for c in inflated.reshape(-1)]
        assert np.asarray(costmap.data, dtype=np.int8).tolist() == expected
    # the robot's poses the navigator drove on, by stamp
    fused = {_stamp(m.header): m.pose for _, m in topics["/fused_pose"]}
    # the driven path: each pose one of the robot's, in order, PATH_SPACING apart, growing
    paths = [m for _, m in topics["/path"]]
    assert len(paths) >= 5
    for earlier, later in itertools.pairwise(paths):
        assert len(later.poses) == len(earlier.poses) + 1
    last = paths[-1]
    assert last.header.frame_id == "map"
    points = []
    for pose in last.poses:
        robot = fused[_stamp(pose.header)]
        assert (pose.pose.position.x, pose.pose.position.y) == (robot.position.x,
                                                                robot.position.y)
        points.append((robot.position.x, robot.position.y))
    assert all(math.dist(a, b) >= PATH_SPACING for a, b in itertools.pairwise(points))
    stamps = [_stamp(p.header) for p in last.poses]
    assert stamps == sorted(stamps)
    final = fused[max(fused)]
    assert math.dist(points[-1], (final.position.x, final.position.y)) < PATH_SPACING
    # DWA's choice each cycle: starts at the robot's pose of that cycle (stamped as it)
    local_plans = [m for _, m in topics["/local_plan"]]
    assert len(local_plans) >= 5
    for plan in local_plans:
        robot = fused[_stamp(plan.header)]
        first = plan.poses[0].pose
        assert (first.position.x, first.position.y) == pytest.approx(
            (robot.position.x, robot.position.y), abs=1e-9)
        assert math.remainder(yaw_of(first.orientation) - yaw_of(robot.orientation),
                              2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert max(len(p.poses) for p in local_plans) >= 5  # a rollout over DWA's horizon
    # the goal, as requested
    (_, goal), = topics["/goal_pose"]
    assert (goal.pose.position.x, goal.pose.position.y) == (1.2, 0.9)
    assert yaw_of(goal.pose.orientation) == pytest.approx(0.5)
    assert goal.header.frame_id == "map"
    # the TF tree a viewer needs to place base_footprint in map is there
    edges = {(t.header.frame_id, t.child_frame_id) for _, m in topics["/tf"]
             for t in m.transforms}
    assert {("map", "odom"), ("odom", "base_footprint")} <= edges
