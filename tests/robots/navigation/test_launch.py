"""configs/navigation.launch.yaml: the floor (base + overhead camera), the tracker, the
localiser and the navigator in four processes over Zenoh, in real time. A goal published with
``servolab topic pub /goal_pose`` from a fifth process is reached: nav2's action status
(action_msgs/GoalStatus SUCCEEDED = 4, as nav2's NavigateToPose server publishes it on
/navigate_to_pose/_action/status) says so, the floor's truth agrees within D.3's
xy_goal_tolerance, and the stamps are wall-clock time (rclpy's ROS time without use_sim_time
is the system clock: docs.ros.org, "Clock and Time"), within a second of ``time.time()``."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import pytest

from tests.clirun import launched, servolab

ROOT = Path(__file__).resolve().parents[3]
GOAL = (1.2, 0.6)


@pytest.mark.slow
def test_a_goal_on_goal_pose_is_reached_by_the_launch_over_zenoh() -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.messages import seconds_of
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions
    from servolab.robots.navigation.navigator import STATUS_TOPIC
    from servolab.robots.navigation.params import DEFAULT_DWA, load_dwa
    from servolab.robots.navigation.tracker_node import LATCHED

    with launched(ROOT / "configs" / "navigation.launch.yaml") as (_, endpoint), \
            Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
        probe = Node(ctx, "probe")
        statuses: list[Any] = []
        truth: list[Any] = []
        late: list[float] = []

        def on_pose(msg: Any) -> None:
            late.append(time.time() - seconds_of(msg.header.stamp))

        probe.create_subscription("action_msgs/msg/GoalStatusArray", STATUS_TOPIC,
                                  statuses.append, LATCHED)
        probe.create_subscription("nav_msgs/msg/Odometry", "/ground_truth",
                                  truth.append, 0)
        probe.create_subscription("geometry_msgs/msg/PoseStamped", "/fused_pose",
                                  on_pose, 0)
        # the localiser publishes once the tracker (calibrated at start) sees the robot
        assert ctx.spin_until(lambda: len(late) >= 3, timeout=90.0), \
            "no /fused_pose: the tracker never saw the robot"
        x, y = GOAL
        goal = (f"{{header: {{frame_id: map}}, pose: {{position: {{x: {x}, y: {y}}}, "
                "orientation: {w: 1.0}}}")
        pub = servolab("topic", "pub", "/goal_pose", "geometry_msgs/msg/PoseStamped", goal,
                       "--count", "1", "--connect", endpoint, timeout=60)
        assert pub.returncode == 0, pub.stderr

        def last_status() -> int | None:
            if not statuses or not statuses[-1].status_list:
                return None
            return int(statuses[-1].status_list[-1].status)

        assert ctx.spin_until(lambda: last_status() in (4, 5, 6), timeout=60.0), \
            statuses[-1:]
        assert last_status() == 4  # SUCCEEDED
        x = truth[-1].pose.pose.position.x
        y = truth[-1].pose.pose.position.y
        tolerance = load_dwa(DEFAULT_DWA).xy_goal_tolerance
        assert math.hypot(x - GOAL[0], y - GOAL[1]) <= tolerance + 0.03
        # wall-clock stamps (not seconds since boot): the least delayed message shows the
        # stamps' clock within a second of time.time() (a busy machine delays some more)
        assert late and min(abs(d) for d in late) < 1.0, late[:5]
        stamp = statuses[-1].status_list[-1].goal_info.stamp
        assert abs(time.time() - seconds_of(stamp)) < 30.0


@pytest.mark.slow
@pytest.mark.realtime  # five processes in real time: not beside another wall-clock test
def test_navigate_to_pose_from_the_shell_reaches_the_goal_and_ctrl_c_cancels() -> None:
    """``servolab action send_goal /navigate_to_pose nav2_msgs/action/NavigateToPose ...
    --feedback`` against the launch, as a nav2 user sends one: feedback, then SUCCEEDED with
    the floor's truth within xy_goal_tolerance; a second goal, interrupted with Ctrl-C after its
    first feedbacks, back to where the robot started, is canceled and the wheels read back
    still (the floor's odometry)."""
    import signal

    from servolab.middleware.context import Context
    from servolab.middleware.messages import seconds_of
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions
    from servolab.robots.navigation.params import DEFAULT_DWA, load_dwa
    from tests.clirun import SERVOLAB
    from tests.processes import started
    from tests.waiting import wait_for_line

    def goal(x: float, y: float) -> str:
        return (f"{{pose: {{header: {{frame_id: map}}, pose: {{position: {{x: {x}, y: {y}}}, "
                "orientation: {w: 1.0}}}}")

    with launched(ROOT / "configs" / "navigation.launch.yaml") as (_, endpoint), \
            Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
        probe = Node(ctx, "probe")
        truth: list[Any] = []
        odom: list[Any] = []
        probe.create_subscription("nav_msgs/msg/Odometry", "/ground_truth", truth.append, 0)
        probe.create_subscription("nav_msgs/msg/Odometry", "/odom", odom.append, 0)
        sent = servolab("action", "send_goal", "/navigate_to_pose",
                        "nav2_msgs/action/NavigateToPose", goal(*GOAL), "--feedback",
                        "--connect", endpoint, timeout=180)
        assert sent.returncode == 0, sent.stderr
        assert "Feedback:\n    current_pose:" in sent.stdout
        assert sent.stdout.endswith("Goal finished with status: SUCCEEDED\n"), sent.stdout[-500:]
        # the truth that came while the goal ran waits in the probe's queue: take it all,
        # and the newest, from after the goal ended, is last
        ended = time.time()
        assert ctx.spin_until(lambda: bool(truth) and seconds_of(
            truth[-1].header.stamp) > ended, timeout=20.0)
        x, y = truth[-1].pose.pose.position.x, truth[-1].pose.pose.position.y
        assert math.hypot(x - GOAL[0], y - GOAL[1]) <= load_dwa(DEFAULT_DWA).xy_goal_tolerance \
            + 0.03
        with started([*SERVOLAB, "action", "send_goal", "/navigate_to_pose",
                      "nav2_msgs/action/NavigateToPose", goal(0.6, 0.6), "--feedback",
                      "--connect", endpoint]) as client:
            wait_for_line(client, "Feedback:", timeout=120.0)
            wait_for_line(client, "Feedback:", timeout=30.0)  # it is driving
            client.send_signal(signal.SIGINT)
            out, err = client.communicate(timeout=60)
        assert "Canceling goal...\nGoal canceled.\n" in out, (out[-500:], err[-500:])
        odom.clear()

        def still() -> bool:
            recent = odom[-5:]
            return len(recent) == 5 and all(
                abs(m.twist.twist.linear.x) < 1e-3 and abs(m.twist.twist.angular.z) < 1e-3
                for m in recent)

        assert ctx.spin_until(still, timeout=20.0), odom[-5:]
        # stopped by the cancel, not by arriving: still far from the goal it was given
        stopped = time.time()
        assert ctx.spin_until(lambda: seconds_of(truth[-1].header.stamp) > stopped,
                              timeout=20.0)
        x, y = truth[-1].pose.pose.position.x, truth[-1].pose.pose.position.y
        assert math.hypot(x - 0.6, y - 0.6) > 0.3, (x, y)
