"""The navigator node alone, on a hand-made map in virtual time: it drives on a fresh pose,
stops the wheels when the pose gets old (the camera lost the robot), drives on when poses come
back, and gives the goal up after controller_patience without one."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.planning.dwa import DwaConfig
from servolab.robots.navigation.navigator import NavigationStatus, NavigatorNode, Patience
from servolab.robots.navigation.params import (
    CLEAR_COSTMAP_RECOVERY,
    DEFAULT_COSTMAP,
    DEFAULT_DWA,
    RecoveryBehavior,
    load_costmap,
    load_dwa,
)
from servolab.robots.navigation.tracker_node import LATCHED

POSE = "geometry_msgs/msg/PoseStamped"


Region = tuple[slice, slice] | list[tuple[slice, slice]] | None
#: the rig's patience: 3 s without a valid command (move_base's default is 15)
PATIENCE = Patience(controller=3.0)


class Rig:
    def __init__(self, occupied: Region = None, goal: tuple[float, float] | None = (2.5, 1.0),
                 *, recovery: tuple[RecoveryBehavior, ...] = (),
                 patience: Patience = PATIENCE) -> None:
        self.context = Context.open(clock=VirtualClock())
        dwa = DwaConfig.from_params(load_dwa(DEFAULT_DWA))
        dwa = DwaConfig(**{**dwa.__dict__, "controller_frequency": 5.0})
        self.node = NavigatorNode(self.context, goal, costmap=load_costmap(
            DEFAULT_COSTMAP), dwa=dwa, patience=patience, recovery=recovery,
            pose_timeout=0.25)
        self.probe = Node(self.context, "probe")
        self.commands: list[Any] = []
        self.probe.create_subscription("geometry_msgs/msg/Twist", "/cmd_vel",
                                       self.commands.append, 0)
        self.grid = self.probe.create_publisher("nav_msgs/msg/OccupancyGrid", "/map", LATCHED)
        self.pose = self.probe.create_publisher(POSE, "/fused_pose", 10)
        self.publish_map(occupied)

    def publish_map(self, occupied: Region) -> None:
        cells = np.zeros((40, 60), dtype=np.int8)
        for region in ([occupied] if isinstance(occupied, tuple) else occupied or []):
            cells[region] = 100
        self.grid.publish(self.probe.message("nav_msgs/msg/OccupancyGrid", header={
            "frame_id": "map"}, info={"resolution": 0.05, "width": 60, "height": 40,
                                      "origin": {"orientation": {"w": 1.0}}},
            data=cells.reshape(-1)))

    def send_pose(self, x: float = 0.5, y: float = 1.0) -> None:
        self.pose.publish(self.probe.message(POSE, header={"frame_id": "map"}, pose={
            "position": {"x": x, "y": y}, "orientation": {"w": 1.0}}))

    def drive_for(self, seconds: float, *, poses: bool,
                  at: tuple[float, float] = (0.5, 1.0)) -> None:
        end = self.context.clock.now() + seconds
        while self.context.clock.now() < end:
            if poses:
                self.send_pose(*at)
            self.context.spin_for(0.1)


@pytest.fixture
def rig() -> Any:
    r = Rig()
    yield r
    r.context.close()


def test_an_old_pose_stops_the_wheels_until_a_new_one_comes(rig: Rig) -> None:
    rig.drive_for(1.0, poses=True)
    assert rig.node.status is NavigationStatus.ACTIVE
    assert rig.commands[-1].linear.x > 0  # heading for the goal, 2 m ahead
    rig.drive_for(1.0, poses=False)
    assert rig.node.stale_cycles > 0
    last = rig.commands[-1]
    assert (last.linear.x, last.angular.z) == (0.0, 0.0)
    rig.drive_for(1.0, poses=True)
    assert rig.commands[-1].linear.x > 0 and rig.node.status is NavigationStatus.ACTIVE


def test_no_pose_for_controller_patience_gives_the_goal_up(rig: Rig) -> None:
    rig.drive_for(0.6, poses=True)
    rig.drive_for(4.0, poses=False)
    assert rig.node.status is NavigationStatus.ABORTED
    assert "no pose newer than 0.25 s for 3 s" in rig.node.reason
    assert (rig.commands[-1].linear.x, rig.commands[-1].angular.z) == (0.0, 0.0)


def test_a_goal_the_first_map_shows_in_an_obstacle_is_refused_before_moving() -> None:
    rig = Rig(occupied=(slice(17, 23), slice(47, 53)))  # around the goal (2.5, 1.0)
    try:
        rig.drive_for(1.0, poses=True)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED
    assert "goal (2.5, 1) is inside an obstacle" in rig.node.reason
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in rig.commands)


def test_a_robot_the_camera_never_sees_is_refused_within_seconds() -> None:
    """No pose at all after the goal: refused after start_timeout (controller_patience, 3 s
    here), saying why, instead of waiting out the run's whole timeout."""
    rig = Rig()
    try:
        rig.drive_for(4.0, poses=False)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED and rig.node.refused
    assert rig.node.reason == ("no pose of the robot (the camera does not see it) for 3 s "
                               "after the goal")
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in rig.commands)


def test_an_enclosed_goal_is_refused_from_the_first_map_before_moving() -> None:
    """A ring of obstacles round the goal (2.5, 1.0): the first map has no path to it, so it
    is refused at once, not after planner_patience and the recoveries."""
    ring = [(slice(8, 10), slice(38, 60)), (slice(30, 32), slice(38, 60)),
            (slice(8, 32), slice(38, 40))]
    rig = Rig(occupied=ring)
    try:
        rig.drive_for(0.6, poses=True)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED and rig.node.refused
    assert "no path from the robot to goal (2.5, 1) on the first map" in rig.node.reason
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in rig.commands)


@pytest.mark.slow
def test_a_goal_dwa_cannot_settle_on_is_refused_with_its_cost() -> None:
    """A wall from x = 2.85 m (cells 57..59) and the goal 0.275 m in front of it: the goal lies in
    the inflated band, and with D.3's occdist_scale 0.8 DWA's dry run stalls short of
    xy_goal_tolerance (the failure issue 30 found 0.25-0.3 m from every wall); the refusal names
    the cost and what to change. A goal 0.35 m from the wall, in the band too (cost 44), is one
    the dry run reaches: it is driven to, with a warning; so is one 0.65 m away."""
    wall = (slice(0, 40), slice(57, 60))
    rig = Rig(occupied=wall, goal=(2.575, 1.0))
    try:
        rig.drive_for(0.6, poses=True)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED and rig.node.refused
    assert "lies in the inflated band" in rig.node.reason
    assert "costmap cost" in rig.node.reason and "a dry run of DWA" in rig.node.reason
    assert "lower occdist_scale" in rig.node.reason
    assert all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in rig.commands)
    for x, warned in ((2.5, True), (2.2, False)):
        free = Rig(occupied=wall, goal=(x, 1.0))
        try:
            free.drive_for(0.6, poses=True)
        finally:
            free.context.close()
        assert free.node.status is NavigationStatus.ACTIVE
        assert free.commands[-1].linear.x > 0
        assert bool(free.node.warnings) is warned
        if warned:
            assert "lies in the inflated band" in free.node.warnings[0]


def test_goals_come_on_goal_pose_and_move_base_simple_goal() -> None:
    """nav2's /goal_pose and move_base's /move_base_simple/goal (geometry_msgs/PoseStamped in
    the map frame); a new goal preempts the one being driven to (ABORTED 6, as nav2's
    SimpleActionServer::accept_pending_goal aborts it; then EXECUTING 2 for the new one); a
    goal in another frame, or with an all-zero orientation (move_base's "Empty quaternion"),
    is refused."""
    from servolab.robots.navigation.navigator import STATUS_TOPIC
    from servolab.robots.navigation.tracker_node import LATCHED as STATUS_QOS

    rig = Rig(goal=None)
    statuses: list[Any] = []
    rig.probe.create_subscription("action_msgs/msg/GoalStatusArray", STATUS_TOPIC,
                                  statuses.append, STATUS_QOS)
    feedback: list[Any] = []
    rig.probe.create_subscription("nav2_msgs/action/NavigateToPose_FeedbackMessage",
                                  "/navigate_to_pose/_action/feedback", feedback.append, 0)
    goal_pose = rig.probe.create_publisher(POSE, "/goal_pose", 10)
    simple = rig.probe.create_publisher(POSE, "/move_base_simple/goal", 10)

    def goal(publisher: Any, x: float, frame: str = "map", w: float = 1.0) -> None:
        publisher.publish(rig.probe.message(POSE, header={"frame_id": frame}, pose={
            "position": {"x": x, "y": 1.0}, "orientation": {"w": w}}))

    try:
        rig.drive_for(0.6, poses=True)
        assert rig.node.goal is None and not rig.commands  # no goal: nothing driven
        goal(goal_pose, 2.5, frame="odom")
        goal(goal_pose, 2.5, w=0.0)
        rig.drive_for(0.4, poses=True)
        assert rig.node.goal is None  # refused: goals are in the map frame, with a heading
        goal(goal_pose, 2.5)
        rig.drive_for(1.0, poses=True)
        assert rig.node.goal == (2.5, 1.0) and rig.node.status is NavigationStatus.ACTIVE
        assert rig.commands[-1].linear.x > 0
        goal(simple, 2.0)
        rig.drive_for(1.0, poses=True)
        assert rig.node.goal == (2.0, 1.0) and rig.node.status is NavigationStatus.ACTIVE
    finally:
        rig.context.close()
    # the status array lists the preempted goal (ABORTED 6) and the new one (EXECUTING 2)
    assert [int(s.status) for s in statuses[-1].status_list] == [6, 2]
    assert len({bytes(s.goal_info.goal_id.uuid) for s in statuses[-1].status_list}) == 2
    assert feedback and feedback[-1].feedback.distance_remaining == pytest.approx(1.5, abs=0.1)


@pytest.mark.parametrize(("at", "reached"), [
    # 0.141 m from the goal's cell centre (2.525, 1.025), 0.177 m from the goal asked for:
    # within xy_goal_tolerance 0.15 of the first only (issue 44 measured such "successes")
    ((2.625, 1.125), False),
    ((2.6, 1.0), True),  # 0.1 m from the goal asked for
])
def test_goal_reached_is_judged_on_the_requested_goal_not_its_cell(
        at: tuple[float, float], reached: bool) -> None:
    """The plan ends at the requested goal, as navfn appends it to the cells it found, and
    DWA's goal check measures xy_goal_tolerance from the plan's last pose."""
    rig = Rig()
    try:
        rig.drive_for(0.6, poses=True)
        assert rig.node.status is NavigationStatus.ACTIVE
        assert tuple(rig.node.plans[-1][1][-1]) == (2.5, 1.0)
        rig.drive_for(1.0, poses=True, at=at)
    finally:
        rig.context.close()
    assert rig.node.status is (NavigationStatus.SUCCEEDED if reached
                               else NavigationStatus.ACTIVE), rig.node.reason


def test_a_goal_an_obstacle_covers_later_is_aborted_saying_so_with_the_wheels_stopped() -> None:
    """The goal is free on the first map; a later map puts an obstacle on it. The planner
    finds no path, the clearing recovery runs (it once rebuilt D* Lite on the occupied goal
    cell and crashed the navigator: issue 44), and the goal ends ABORTED with the reason."""
    clear = RecoveryBehavior("conservative_reset", CLEAR_COSTMAP_RECOVERY)
    rig = Rig(recovery=(clear, clear), patience=Patience(planner=1.0, controller=3.0))
    try:
        rig.drive_for(0.6, poses=True)
        assert rig.node.status is NavigationStatus.ACTIVE
        rig.publish_map((slice(17, 23), slice(47, 53)))  # around the goal (2.5, 1.0)
        rig.drive_for(6.0, poses=True)
    finally:
        rig.context.close()
    assert rig.node.status is NavigationStatus.ABORTED
    assert [r.name for r in rig.node.recoveries] == ["conservative_reset"] * 2
    assert "no plan to the goal" in rig.node.reason
    assert "goal (2.5, 1) is inside an obstacle" in rig.node.reason
    assert "the map covered it after the goal was given" in rig.node.reason
    assert (rig.commands[-1].linear.x, rig.commands[-1].angular.z) == (0.0, 0.0)


def test_navigate_to_pose_is_served_as_nav2_serves_it() -> None:
    """nav2's NavigateToPose action (``/navigate_to_pose``, nav2_msgs Jazzy): a client's goal
    is driven to with feedback (the pose, the distance left); a cancel stops the wheels and
    ends the goal CANCELED; a goal in another frame is rejected."""
    from servolab.rclpy.action import ActionClient
    from servolab.rclpy.action.server import STATUS_CANCELED

    rig = Rig(goal=None)
    client = ActionClient(rig.probe, "nav2_msgs/action/NavigateToPose", "/navigate_to_pose")

    def goal(x: float, frame: str = "map") -> Any:
        return rig.probe.message("nav2_msgs/action/NavigateToPose_Goal", pose={
            "header": {"frame_id": frame},
            "pose": {"position": {"x": x, "y": 1.0}, "orientation": {"w": 1.0}}})

    try:
        rig.drive_for(0.4, poses=True)
        assert client.server_is_ready()
        feedback: list[Any] = []
        sent = client.send_goal_async(goal(2.5), feedback_callback=feedback.append)
        rig.drive_for(1.0, poses=True)
        handle = sent.result()
        assert handle.accepted and rig.node.goal == (2.5, 1.0)
        assert rig.node.status is NavigationStatus.ACTIVE and rig.commands[-1].linear.x > 0
        assert feedback[-1].feedback.distance_remaining == pytest.approx(2.0, abs=0.05)
        assert feedback[-1].feedback.current_pose.header.frame_id == "map"
        canceling = handle.cancel_goal_async()
        rig.drive_for(0.6, poses=True)
        answer = canceling.result()
        assert (answer.return_code, len(answer.goals_canceling)) == (0, 1)
        ended = handle.get_result_async()
        rig.drive_for(0.4, poses=True)
        assert ended.result().status == STATUS_CANCELED
        assert rig.node.status is NavigationStatus.CANCELED
        assert (rig.commands[-1].linear.x, rig.commands[-1].angular.z) == (0.0, 0.0)
        other = client.send_goal_async(goal(2.0, frame="odom"))
        rig.drive_for(0.4, poses=True)
        assert not other.result().accepted
        # a goal in an obstacle: ABORTED, the reason in the result's error_msg
        rig.publish_map((slice(17, 23), slice(37, 43)))  # around (2.0, 1.0)
        rig.drive_for(0.4, poses=True)
        blocked = client.send_goal_async(goal(2.0))
        rig.drive_for(1.0, poses=True)
        ended = blocked.result().get_result_async()
        rig.drive_for(0.4, poses=True)
        assert ended.result().status == 6  # ABORTED
        assert "goal (2, 1) is inside an obstacle" in ended.result().result.error_msg
    finally:
        rig.context.close()
