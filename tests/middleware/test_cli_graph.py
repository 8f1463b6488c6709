"""``servolab topic`` and ``servolab param`` as a user runs them: separate OS processes
talking over Zenoh on loopback, on ports chosen free at run time."""

from __future__ import annotations

import math
import sys
import textwrap

import pytest
import yaml

from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.waiting import wait_for_graph_at, wait_for_line

TWIST_VALUES = "{linear: {x: 0.1, y: -0.2}, angular: {z: 0.5}}"


@pytest.mark.slow
def test_two_processes_exchange_twist_on_cmd_vel_over_zenoh() -> None:
    port = free_port()
    echo_args = [*SERVOLAB, "topic", "echo", "/cmd_vel", "--type", "geometry_msgs/msg/Twist",
                 "--count", "20", "--listen", f"tcp/127.0.0.1:{port}"]
    with started(echo_args) as echo:
        # the echo listens and is subscribed before the publisher looks for it (it looks for
        # 2 s only, and a slow start of the echo would lose the first messages)
        wait_for_graph_at(f"tcp/127.0.0.1:{port}", ("MS", None, "/cmd_vel"))
        pub = servolab("topic", "pub", "/cmd_vel", "geometry_msgs/msg/Twist", TWIST_VALUES,
                       "--rate", "50", "--count", "20", "--connect", f"tcp/127.0.0.1:{port}",
                       timeout=30)
        assert pub.returncode == 0, pub.stderr
        out, err = echo.communicate(timeout=20)
    assert echo.returncode == 0, err
    docs = [d for d in yaml.safe_load_all(out) if d is not None]
    assert len(docs) == 20
    for doc in docs:
        assert doc == {"linear": {"x": 0.1, "y": -0.2, "z": 0.0},
                       "angular": {"x": 0.0, "y": 0.0, "z": 0.5}}


TALKER = textwrap.dedent("""
    import sys
    from servolab.middleware.context import Context
    from servolab.middleware.demo_nodes import Talker
    from servolab.middleware.transport import TransportOptions
    with Context.open(TransportOptions("zenoh", listen=[sys.argv[1]])) as ctx:
        Talker(ctx, "talker", "/robot", parameter_overrides={"rate": 20.0})
        print("ready", flush=True)
        ctx.spin()
""")


@pytest.mark.slow
def test_topic_list_hz_and_params_of_a_running_node() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", TALKER, endpoint]) as talker:
        assert wait_for_line(talker, "ready", timeout=20.0)[-1].strip() == "ready"
        listing = servolab("topic", "list", "-t", "--connect", endpoint, timeout=30)
        assert "/robot/cmd_vel [geometry_msgs/msg/Twist]" in listing.stdout, listing
        params = servolab("param", "list", "--connect", endpoint, timeout=30)
        assert params.returncode == 0, params.stderr
        assert "/robot/talker:" in params.stdout and "  rate" in params.stdout
        got = servolab("param", "get", "/robot/talker", "speed", "--connect", endpoint, timeout=30)
        assert got.stdout.strip() == "speed: 0.1"
        changed = servolab("param", "set", "/robot/talker", "speed", "0.3", "--connect", endpoint,
                           timeout=30)
        assert changed.returncode == 0, changed.stderr
        assert servolab("param", "get", "/robot/talker", "speed", "--connect", endpoint,
                        timeout=30).stdout.strip() == "speed: 0.3"
        refused = servolab("param", "set", "/robot/talker", "speed", "fast", "--connect", endpoint,
                           timeout=30)
        assert refused.returncode == 2
        assert refused.stderr.strip() == ("servolab param set: error: setting speed on "
                                          "/robot/talker failed: parameter speed is a double; "
                                          "'fast' is a string")
        echo = servolab("topic", "echo", "/robot/cmd_vel", "--count", "3", "--connect", endpoint,
                        timeout=30)
        docs = [d for d in yaml.safe_load_all(echo.stdout) if d]
        assert [d["linear"]["x"] for d in docs] == [0.3] * 3   # the new speed, live
        # its first report (one a second) and the line of gaps that goes with it: what it
        # reports is the same every second, so reading one is enough
        with started([*SERVOLAB, "topic", "hz", "/robot/cmd_vel", "--connect", endpoint]) as hz:
            lines = wait_for_line(hz, "average rate", timeout=30.0)
            lines.append(hz.stdout.readline())
        rates = [float(line.split(":")[1]) for line in lines if line.startswith("average rate")]
        assert rates and all(math.isfinite(r) and r > 0 for r in rates)
        assert lines[-1].startswith("\tmin: "), lines


@pytest.mark.parametrize(("args", "message"), [
    (["topic", "pub", "/x", "std_msgs/msg/Float64", "abc"],
     "servolab topic pub: error: std_msgs/msg/Float64 data: 'abc' is not a float64"),
    (["topic", "pub", "/x", "nav_msgs/msg/Odometryy", "{}"],
     "servolab topic pub: error: unknown message type 'nav_msgs/msg/Odometryy'"),
    (["topic", "pub", "/cmd_vel", "geometry_msgs/msg/Twist", "{linear: {x: fast}}"],
     "servolab topic pub: error: geometry_msgs/msg/Twist linear.x: 'fast' is not a float64"),
    (["topic", "list", "--connect", "localhost:7447"],
     "servolab topic list: error: Zenoh endpoint 'localhost:7447' is not"),
    (["topic", "list", "--transport", "local", "--listen", "tcp/127.0.0.1:1"],
     "servolab topic list: error: --listen and --connect need --transport zenoh"),
])
def test_bad_input_is_one_line_naming_it(args: list[str], message: str) -> None:
    result = servolab(*args, "--transport", "local", timeout=30) if "--transport" not in args and \
        "--connect" not in args else servolab(*args, timeout=30)
    assert result.returncode == 2
    assert result.stderr.startswith(message), result.stderr
    assert result.stderr.count("\n") == 1


def test_a_bad_name_is_shown_with_a_mark_under_its_first_bad_character() -> None:
    """As rclpy shows a name error (rclpy/validate_topic_name.py): the rule, then the name,
    then a caret under the first character that breaks it; exit status 2."""
    result = servolab("topic", "pub", "bad//name", "std_msgs/msg/Float64", "1", "--transport",
                      "local", timeout=30)
    assert result.returncode == 2
    first, name, mark = result.stderr.splitlines()
    assert first.startswith("servolab topic pub: error: Invalid topic name: topic name must not "
                            "contain repeated '/'")
    assert name.strip() == "'/bad//name'"
    assert name.index("//") + 1 == mark.index("^")
