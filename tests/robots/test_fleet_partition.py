"""A fleet across a partition: a TurtleBot3 Waffle under ros2_control in its namespace, its
commander on another "host" reaching it only through a ``servolab router``. The router killed
mid-run, the commands stop arriving and diff_drive_controller's ``cmd_vel_timeout`` brakes the
wheels: they read back at 0 on the robot's own ``/robot1/joint_states`` within that timeout.
The router started again on the same endpoint, the same commander (never restarted) reaches
the same robot (never restarted) and the wheels turn again.

Who reaches whom: the commander is a Zenoh *client* (``ZENOH_SESSION_CONFIG_URI`` naming
``{mode: "client"}``), rmw_zenoh's way for a node on another host, so every message it sends
goes through the router (rmw_zenoh's DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5: "All
communications with other hosts are routed by the Zenoh router"). This test watches the robot
as a peer linked to the robot directly, so it sees the wheels whatever the router does.

Facts from outside this code: diff_drive_controller brakes when no command came for
``cmd_vel_timeout`` s (ros2_controllers jazzy, diff_drive_controller.cpp, "Velocity command
timed out"); the Waffle's controllers file sets it to 0.5 s, as turtlebot3's does."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path
from typing import Any

import pytest

from servolab.middleware.zenoh_config import SESSION_CONFIG_ENV
from tests.clirun import SERVOLAB
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_line

pytestmark = [pytest.mark.slow, pytest.mark.realtime]

JOINT_STATE = "sensor_msgs/msg/JointState"
#: s: the controllers file's cmd_vel_timeout (turtlebot3_waffle_controllers.yaml)
CMD_VEL_TIMEOUT = 0.5
#: s beyond the timeout the brake may take to show: two controller updates and a /joint_states
#: hop on a machine running the rest of the suite beside this test
SLACK = 1.0
#: rad/s: a wheel turning (0.1 m/s on a 33 mm wheel is 3 rad/s), and one at rest (the
#: encoder's noise floor: an XM430's Present Velocity unit is 0.229 rev/min, 0.024 rad/s)
TURNING, AT_REST = 1.0, 0.05


def _stamp(message: Any) -> float:
    return float(message.header.stamp.sec) + message.header.stamp.nanosec * 1e-9


def _at_rest(message: Any) -> bool:
    return all(abs(v) <= AT_REST for v in message.velocity)


def test_the_router_killed_brakes_the_wheels_and_restarted_drives_them_again(
        tmp_path: Path) -> None:
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.transport import TransportOptions

    client = tmp_path / "client.json5"
    client.write_text('{mode: "client"}')
    router_endpoint = f"tcp/127.0.0.1:{free_port()}"
    robot_endpoint = f"tcp/127.0.0.2:{free_port()}"
    robot = [*SERVOLAB, "control", "run", "turtlebot3_waffle", "--world", "robot",
             "--namespace", "/robot1", "--spawn", "joint_state_broadcaster",
             "diff_drive_controller", "--listen", robot_endpoint, "--connect", router_endpoint]
    commander = [*SERVOLAB, "topic", "pub", "/robot1/diff_drive_controller/cmd_vel",
                 "geometry_msgs/msg/TwistStamped", "{twist: {linear: {x: 0.1}}}", "--rate",
                 "10", "--listen", "tcp/127.0.0.3:0", "--connect", router_endpoint]
    router = [*SERVOLAB, "router", "--listen", router_endpoint]
    with started(router) as first_router, \
            started(robot, stderr_to_stdout=True) as running:
        wait_for_line(first_router, "listening on", timeout=20)
        wait_for_line(running, "running; Ctrl-C stops it", timeout=60)
        with started(commander, env={**os.environ, SESSION_CONFIG_ENV: str(client)}) as pub, \
                Context.open(TransportOptions("zenoh", connect=[robot_endpoint])) as ctx:
            states: list[Any] = []
            Node(ctx, "probe").create_subscription(JOINT_STATE, "/robot1/joint_states",
                                                   states.append, 0)

            def turning(since: float = 0.0) -> bool:
                return any(_stamp(m) >= since and min(abs(v) for v in m.velocity) > TURNING
                           for m in states[-5:])

            assert ctx.spin_until(turning, timeout=30.0), (
                "the commander's cmd_vel never reached the robot through the router; last "
                f"velocities {[list(m.velocity) for m in states[-3:]]}")
            first_router.kill()
            killed = time.time()
            first_router.wait(5)

            def braked() -> bool:
                return any(_stamp(m) > killed and _at_rest(m) for m in states[-5:])

            assert ctx.spin_until(braked, timeout=10.0), (
                f"the wheels still turn after the router went: {list(states[-1].velocity)}")
            stopped = min(_stamp(m) for m in states if _stamp(m) > killed and _at_rest(m))
            # the robot's own stamps: braked within the controller's timeout of the last
            # command that could have come (the one just before the router went)
            assert stopped - killed <= CMD_VEL_TIMEOUT + SLACK, stopped - killed
            # and by that timeout, not by the partition itself: the wheels went on turning on
            # the last command until it was stale (the commands came every 0.1 s, so the last
            # one left at most that long before the router went)
            last_turning = max(_stamp(m) for m in states if min(abs(v) for v in m.velocity)
                               > TURNING)
            assert last_turning - killed >= CMD_VEL_TIMEOUT - 0.2, last_turning - killed
            with started(router) as second_router:
                wait_for_line(second_router, "listening on", timeout=20)
                back = time.time()
                assert ctx.spin_until(lambda: turning(back), timeout=30.0), (
                    "the same commander never reached the same robot again through the "
                    f"restarted router; last velocities {list(states[-1].velocity)}")
                assert pub.poll() is None and running.poll() is None   # never restarted
        running.send_signal(signal.SIGINT)
        said, _ = running.communicate(timeout=60)
        assert running.returncode == 128 + signal.SIGINT, said
