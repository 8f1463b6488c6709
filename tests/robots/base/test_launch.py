"""configs/base.launch.yaml: the base node on the emulated seed-000 robot in one process,
driven with `servolab topic pub /cmd_vel` from a second, and heard over Zenoh from a third
(this test): it drives, its odometry follows the floor's /ground_truth, and the watchdog stops
it when the commands end."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.clirun import launched, servolab

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.slow
def test_drive_the_base_across_processes() -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions
    from tests.waiting import wait_for_line

    with launched(ROOT / "configs" / "base.launch.yaml") as (base, endpoint):
        wait_for_line(base, "started base_robot (in process", timeout=60.0)
        with Context.open(TransportOptions("zenoh", connect=[endpoint])) as ctx:
            odom: list[Any] = []
            truth: list[Any] = []
            probe = Node(ctx, "probe")
            probe.create_subscription("nav_msgs/msg/Odometry", "/odom", odom.append, 0)
            probe.create_subscription("nav_msgs/msg/Odometry", "/ground_truth",
                                      truth.append, 0)
            pub = servolab("topic", "pub", "/cmd_vel", "geometry_msgs/msg/Twist",
                           "{linear: {x: 0.1}}", "--rate", "10", "--count", "10", "--connect",
                           endpoint, timeout=60)
            assert pub.returncode == 0, pub.stderr
            # after the last command the watchdog stops the wheels: the truth stands still
            assert ctx.spin_until(
                lambda: len(truth) > 2 and truth[-1].pose.pose.position.x > 0.05
                and truth[-1].twist.twist.linear.x == 0.0, timeout=30.0), truth[-1:]
            assert ctx.spin_until(
                lambda: bool(odom) and odom[-1].twist.twist.linear.x == 0.0, timeout=10.0)
            assert len(odom) > 10 and len(truth) > 10
            assert odom[-1].pose.pose.position.x == pytest.approx(
                truth[-1].pose.pose.position.x, abs=0.005)
