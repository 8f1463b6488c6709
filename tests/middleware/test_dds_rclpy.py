"""servolab on DDS against the real thing: ROS 2 Jazzy's rclpy on its default middleware,
Fast DDS (``rmw_fastrtps_cpp``), installed from the package index in a venv of its own
(``tests/rosoracle.py``). servolab runs in this process; rclpy in another, in a ROS domain no
one else uses, with loopback discovery on both sides.

What the tests hold servolab to is what rclpy itself does and reports: messages, the graph
through rclpy's graph API (``get_node_names_and_namespaces``, ``get_topic_names_and_types``,
``get_service_names_and_types``), and a service answered. Where DDS vendors do not
interoperate (a Fast DDS client's reply: ``rmw_fastrtps_shared_cpp/src/rmw_response.cpp``
matches it by RTPS inline QoS), the test shows what servolab does instead: it says why.
"""

from __future__ import annotations

import json
import logging
import os
import subprocess

import pytest

from servolab.middleware.context import Context
from servolab.middleware.node import Node
from servolab.middleware.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from servolab.middleware.transport import TransportOptions
from tests.clirun import servolab
from tests.processes import started
from tests.rosoracle import free_domain_id, ros_env, ros_python
from tests.waiting import wait_for_line, wait_until

#: realtime too: each test runs a second interpreter (and the real rclpy's DDS threads) beside
#: this one, which keeps both cores busy; the wall-clock tests must not run beside that
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

TWIST = "geometry_msgs/msg/Twist"
SET_BOOL = "std_srvs/srv/SetBool"


@pytest.fixture
def domain(monkeypatch: pytest.MonkeyPatch) -> int:
    ros_python()  # skips, saying why, where the real rclpy is not installed
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    return free_domain_id()


@pytest.fixture
def ctx_transport(domain: int) -> TransportOptions:
    """``ctx`` (tests/conftest.py) on DDS, in the test's own domain."""
    return TransportOptions("dds", domain_id=domain)


def ros(code: str, domain: int) -> list[str]:
    return [str(ros_python()), "-c", code]


ROS_LISTENER = """
import rclpy
from geometry_msgs.msg import Twist
rclpy.init()
node = rclpy.create_node("ros_listener")
heard = []
node.create_subscription(Twist, "/cmd_vel", lambda m: heard.append(m), 10)
print("ready", flush=True)
while len(heard) < 3:
    rclpy.spin_once(node, timeout_sec=0.1)
for m in heard:
    print(f"heard {m.linear.x:.2f} {m.angular.z:.2f}", flush=True)
"""


def test_a_real_rclpy_subscriber_hears_servolabs_cmd_vel(ctx: Context, domain: int) -> None:
    node = Node(ctx, "servolab_driver")
    pub = node.create_publisher(TWIST, "/cmd_vel")
    with started(ros(ROS_LISTENER, domain), env=ros_env(domain)) as proc:
        wait_for_line(proc, "ready", timeout=30)
        assert pub.wait_for_subscription(15.0), "rclpy's subscription never matched"

        def published() -> bool:
            pub.publish(node.message(TWIST, linear={"x": 0.25}, angular={"z": -0.5}))
            return proc.poll() is not None
        assert wait_until(published, timeout=15.0, step=0.05)
        out = proc.stdout.read() if proc.stdout else ""
    assert out.splitlines()[:3] == ["heard 0.25 -0.50"] * 3


ROS_TALKER = """
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("ros_talker")
pub = node.create_publisher(String, "/chatter", 10)
count = 0
def tick():
    global count
    count += 1
    pub.publish(String(data=f"Hello World: {count}"))
node.create_timer(0.05, tick)
print("ready", flush=True)
rclpy.spin(node)
"""


def test_servolab_hears_a_real_rclpy_talker(ctx: Context, domain: int) -> None:
    got: list[str] = []
    Node(ctx, "servolab_listener").create_subscription(
        "std_msgs/msg/String", "/chatter", lambda m: got.append(m.data))
    with started(ros(ROS_TALKER, domain), env=ros_env(domain)) as proc:
        wait_for_line(proc, "ready", timeout=30)
        assert ctx.spin_until(lambda: len(got) >= 5, timeout=20.0), got
    numbers = [int(text.removeprefix("Hello World: ")) for text in got[:5]]
    assert numbers == list(range(numbers[0], numbers[0] + 5))  # in order, none lost


def ros_count_watcher(count: str, setup: str = "") -> str:
    """An rclpy program that prints "seen" once ``count`` (an expression on its ``node``,
    after ``setup``) is 1, then "gone" once it is 0 ("never seen", "still there" after 30 s)."""
    return f"""
import time, rclpy
rclpy.init()
node = rclpy.create_node("ros_watcher")
{setup}
def wait(count, seconds):
    end = time.monotonic() + seconds
    while time.monotonic() < end and {count} != count:
        rclpy.spin_once(node, timeout_sec=0.05)
    return {count} == count
print("seen" if wait(1, 30) else "never seen", flush=True)
print("gone" if wait(0, 30) else "still there", flush=True)
"""


ROS_PUBLISHER_WATCHER = ros_count_watcher('node.count_publishers("/chatter")')


def test_a_publisher_servolab_destroys_leaves_fast_dds_graph_at_once(ctx: Context,
                                                                     domain: int) -> None:
    """A servolab publisher destroyed while its process lives is gone from the real rclpy's
    graph (``count_publishers``), as one rclpy destroys is. Cyclone DDS says so in a key-only
    discovery message that Fast DDS 2.14 drops unless it carries a key hash (its
    ``MessageReceiver::proc_Submsg_Data``, "too large key-only data"; servolab.middleware
    .rmw_dds.cyclone_config): without one, the publisher stays in rclpy's graph for as long
    as servolab's participant lives — this test's 30 s — and an rclpy server waiting for its
    clients to leave (``count_clients``) waited for Cyclone's 10 s lease after every exit."""
    node = Node(ctx, "servolab_talker")
    with started(ros(ROS_PUBLISHER_WATCHER, domain), env=ros_env(domain)) as proc:
        publisher = node.create_publisher("std_msgs/msg/String", "/chatter")
        assert wait_for_line(proc, "seen", timeout=40)[-1] == "seen"
        publisher.destroy()
        assert wait_for_line(proc, "gone", timeout=40)[-1] == "gone"


ROS_CLIENT_WATCHER = ros_count_watcher(
    'node.count_clients("/set_bool")',
    "from std_srvs.srv import SetBool\n"
    'node.create_service(SetBool, "/set_bool", lambda request, response: response)')


def test_a_client_servolab_destroys_leaves_the_servers_count_at_once(ctx: Context,
                                                                     domain: int) -> None:
    """A servolab client destroyed while its node lives is no longer one of the real rclpy
    server's clients (``count_clients``), as an rclpy client's ``destroy_client`` leaves it:
    servolab's clients of one service share their endpoints, and the last one destroyed
    deletes them (they stayed until the process ended)."""
    node = Node(ctx, "servolab_caller")
    with started(ros(ROS_CLIENT_WATCHER, domain), env=ros_env(domain)) as proc:
        client = node.create_client(SET_BOOL, "/set_bool")
        assert wait_for_line(proc, "seen", timeout=40)[-1] == "seen"
        node.destroy_client(client)
        assert wait_for_line(proc, "gone", timeout=40)[-1] == "gone"


ROS_GRAPH_WATCHER = """
import json, time, rclpy
rclpy.init()
node = rclpy.create_node("ros_watcher")
end = time.monotonic() + 30
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
    nodes = node.get_node_names_and_namespaces()
    topics = dict(node.get_topic_names_and_types())
    services = dict(node.get_service_names_and_types())
    if ("servolab_robot", "/robot1") in nodes and "/robot1/odom" in topics and \\
            "/robot1/reset" in services:
        break
print(json.dumps({"nodes": nodes, "topics": topics, "services": services,
                  "pubs": node.get_publisher_names_and_types_by_node("servolab_robot", "/robot1"),
                  "subs": node.get_subscriber_names_and_types_by_node("servolab_robot",
                                                                      "/robot1")}), flush=True)
"""


def test_rclpy_lists_servolabs_node_topics_and_services(ctx: Context, domain: int) -> None:
    robot = Node(ctx, "servolab_robot", "/robot1")
    robot.create_publisher("nav_msgs/msg/Odometry", "odom")
    robot.create_subscription(TWIST, "cmd_vel", lambda m: None)
    robot.create_service("std_srvs/srv/Trigger", "reset", lambda req, resp: resp)
    with started(ros(ROS_GRAPH_WATCHER, domain), env=ros_env(domain)) as proc:
        out, _ = proc.communicate(timeout=60)
    seen = json.loads(out.strip().splitlines()[-1])
    assert ["servolab_robot", "/robot1"] in seen["nodes"]
    assert seen["topics"]["/robot1/odom"] == ["nav_msgs/msg/Odometry"]
    assert seen["topics"]["/robot1/cmd_vel"] == [TWIST]
    assert seen["services"]["/robot1/reset"] == ["std_srvs/srv/Trigger"]
    assert seen["services"]["/robot1/servolab_robot/get_parameters"] == [
        "rcl_interfaces/srv/GetParameters"]
    assert ["/robot1/odom", ["nav_msgs/msg/Odometry"]] in seen["pubs"]
    assert ["/robot1/cmd_vel", [TWIST]] in seen["subs"]


ROS_GRAPH_NODE = """
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan
from std_msgs.msg import String
from std_srvs.srv import SetBool
rclpy.init()
node = rclpy.create_node("ros_robot", namespace="/lab")
node.create_publisher(String, "chatter", 10)
node.create_subscription(LaserScan, "scan", lambda m: None,
                         QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
def answer(request, response):
    response.success = request.data
    response.message = f"rclpy set {request.data}"
    return response
node.create_service(SetBool, "set_flag", answer)
print("ready", flush=True)
rclpy.spin(node)
"""


def test_servolab_lists_and_calls_a_real_rclpy_node(ctx: Context, domain: int) -> None:
    """servolab's graph shows rclpy's node with its topics (and their QoS) and services, and
    a servolab client gets the rclpy service's answers."""
    with started(ros(ROS_GRAPH_NODE, domain), env=ros_env(domain)) as proc:
        wait_for_line(proc, "ready", timeout=30)
        wanted = {("NN", "/lab/ros_robot", "", ""),
                  ("MP", "/lab/ros_robot", "/lab/chatter", "std_msgs/msg/String"),
                  ("MS", "/lab/ros_robot", "/lab/scan", "sensor_msgs/msg/LaserScan"),
                  ("SS", "/lab/ros_robot", "/lab/set_flag", "std_srvs/srv/SetBool"),
                  ("SS", "/lab/ros_robot", "/lab/ros_robot/get_parameters",
                   "rcl_interfaces/srv/GetParameters")}
        assert wait_until(lambda: {(e.kind, e.node, e.name, e.type_name)
                                   for e in ctx.transport.graph()} >= wanted, timeout=20.0), \
            sorted(ctx.transport.graph())
        scan = next(e for e in ctx.transport.graph() if e.name == "/lab/scan")
        # (Fast DDS does not announce the history depth: ``ros2 topic info -v`` prints
        # "History (Depth): UNKNOWN" for it; reliability and durability it does)
        assert scan.qos is not None and not scan.qos.reliable and not scan.qos.transient_local
        # and the command line a user types, as its own process
        env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
        options = ["--transport", "dds", "--domain-id", str(domain)]
        node_list = servolab("node", "list", *options, env=env, timeout=60)
        topic_list = servolab("topic", "list", "-t", *options, env=env, timeout=60)
        assert node_list.returncode == topic_list.returncode == 0, \
            node_list.stderr + topic_list.stderr
        nodes, topics = node_list.stdout.splitlines(), topic_list.stdout.splitlines()
        assert "/lab/ros_robot" in nodes
        assert "/lab/chatter [std_msgs/msg/String]" in topics
        assert "/lab/scan [sensor_msgs/msg/LaserScan]" in topics
        client = Node(ctx, "servolab_caller").create_client("std_srvs/srv/SetBool",
                                                             "/lab/set_flag")
        assert client.wait_for_service(15.0)
        answers = [client.call(client.request(data=flag), timeout=10.0)
                   for flag in (True, False, True)]
    assert [(a.success, a.message) for a in answers] == [
        (True, "rclpy set True"), (False, "rclpy set False"), (True, "rclpy set True")]


ROS_CLIENT = """
import rclpy
from std_srvs.srv import SetBool
rclpy.init()
node = rclpy.create_node("ros_client")
client = node.create_client(SetBool, "/set_flag")
print("available", client.wait_for_service(timeout_sec=20.0), flush=True)
future = client.call_async(SetBool.Request(data=True))
rclpy.spin_until_future_complete(node, future, timeout_sec=3.0)
print("answered" if future.done() else "no answer", flush=True)
"""


def test_a_real_rclpy_client_is_not_answered_and_servolab_says_why(
        ctx: Context, domain: int, caplog: pytest.LogCaptureFixture) -> None:
    """The one thing that does not interoperate: a Fast DDS client of a servolab service.
    It sees the service (the graph interoperates), its request is never run by servolab, and
    servolab logs why, once."""
    calls: list[bool] = []
    server = Node(ctx, "servolab_server")
    server.create_service("std_srvs/srv/SetBool", "/set_flag",
                          lambda req, resp: (calls.append(req.data), resp)[1])
    spinner = ctx.executor.spin_in_thread()
    try:
        with caplog.at_level(logging.WARNING), \
                started(ros(ROS_CLIENT, domain), env=ros_env(domain)) as proc:
            out, _ = proc.communicate(timeout=60)
    finally:
        ctx.shutdown()
        spinner.join(2.0)
    assert out.splitlines() == ["available True", "no answer"]
    assert calls == []
    assert "a Fast DDS (rmw_fastrtps) client of /set_flag appeared" in caplog.text


ROS_LATCHED = """
import rclpy
from rclpy.qos import QoSProfile, DurabilityPolicy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("ros_describer")
latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
node.create_publisher(String, "/robot_description", latched).publish(String(data="<robot/>"))
heard = []
node.create_subscription(String, "/servolab_description", lambda m: heard.append(m.data), latched)
print("published", flush=True)
while not heard:
    rclpy.spin_once(node, timeout_sec=0.1)
print("heard", heard[0], flush=True)
rclpy.spin(node)
"""


def test_latched_topics_reach_late_subscriptions_both_ways(ctx: Context, domain: int) -> None:
    """TRANSIENT_LOCAL maps to DDS durability both ways: each side subscribes after the
    other published, and gets the message."""
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node = Node(ctx, "servolab_describer")
    node.create_publisher("std_msgs/msg/String", "/servolab_description", latched).publish(
        node.message("std_msgs/msg/String", data="<servolab/>"))
    with started(ros(ROS_LATCHED, domain), env=ros_env(domain)) as proc:
        wait_for_line(proc, "published", timeout=30)
        got: list[str] = []
        node.create_subscription("std_msgs/msg/String", "/robot_description",
                                 lambda m: got.append(m.data), latched)
        assert ctx.spin_until(lambda: got, timeout=20.0)
        lines = wait_for_line(proc, "heard", timeout=20)
    assert got == ["<robot/>"]
    assert lines[-1] == "heard <servolab/>"


def test_the_oracle_is_the_real_rclpy_on_fast_dds(domain: int) -> None:
    """What the other side of these tests is: rclpy from ROS 2 Jazzy, on rmw_fastrtps_cpp."""
    out = subprocess.run([str(ros_python()), "-c",
                          "import rclpy; from rclpy.utilities import get_rmw_implementation_"
                          "identifier as i; print(i())"],
                         env=ros_env(domain), capture_output=True, text=True, timeout=60,
                         check=True).stdout
    assert out.strip() == "rmw_fastrtps_cpp"


ROS_QOS = """
import rclpy
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("ros_qos")
node.create_publisher(String, "/best_effort_talk",
                      QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
node.create_subscription(String, "/reliable_listen", lambda m: None, 10)  # RELIABLE
print("ready", flush=True)
while True:
    rclpy.spin_once(node, timeout_sec=0.1)
"""

INCOMPATIBLE = "incompatible QoS"


def test_an_incompatible_qos_is_reported_as_rclpy_reports_it(
        ctx: Context, domain: int, caplog: pytest.LogCaptureFixture) -> None:
    """A reliable subscription and a best-effort publisher never match in DDS; rclpy's default
    incompatible-QoS callbacks (rclpy/event_handler.py, Jazzy) say so on the node's logger,
    on both sides. The real rclpy here (Fast DDS) and servolab (Cyclone DDS) each hold one
    such pair with the other, the other way round: each side's lines are the other's, topic
    for topic."""
    node = Node(ctx, "servolab_qos")
    node.create_subscription("std_msgs/msg/String", "/best_effort_talk", lambda m: None, 10)
    node.create_publisher("std_msgs/msg/String", "/reliable_listen",
                          QoSProfile(reliability=ReliabilityPolicy.BEST_EFFORT))
    caplog.set_level(logging.WARNING, logger="servolab.node")
    with started(ros(ROS_QOS, domain), env=ros_env(domain), stderr_to_stdout=True) as proc:
        real = wait_for_line(proc, "ready", timeout=30)
        assert wait_until(lambda: sum(INCOMPATIBLE in r.getMessage()
                                      for r in caplog.records) >= 2, timeout=20)
        while sum(INCOMPATIBLE in line for line in real) < 2:
            real += wait_for_line(proc, INCOMPATIBLE, timeout=20)
    ours = sorted(r.getMessage() for r in caplog.records if INCOMPATIBLE in r.getMessage())
    assert all(r.name == "servolab.node/servolab_qos" for r in caplog.records
               if INCOMPATIBLE in r.getMessage())
    # rclpy's line: "[WARN] [<time>] [ros_qos]: <text>"
    theirs = sorted(line.split("]: ", 1)[1] for line in real if INCOMPATIBLE in line)
    swap = {"/best_effort_talk": "/reliable_listen", "/reliable_listen": "/best_effort_talk"}
    assert ours == sorted(
        text.replace(f"'{a}'", f"'{b}'", 1) for text in theirs for a, b in swap.items()
        if f"'{a}'" in text)
    assert ours == [
        "New publisher discovered on topic '/best_effort_talk', offering incompatible QoS. "
        "No messages will be received from it. Last incompatible policy: RELIABILITY",
        "New subscription discovered on topic '/reliable_listen', requesting incompatible "
        "QoS. No messages will be sent to it. Last incompatible policy: RELIABILITY"]
