"""The ``ros2`` command line a user types, as ``servolab`` prints it (issue 32): ``node list |
info``, ``service type``, ``topic info | type | bw | echo`` (echo on a latched topic, D6),
``interface list | show``, ``param dump | load | describe`` and ``bag record -a | -e``.

Most run in one process on the in-process transport, where the graph is exactly what the test
built; a few run as a user does, separate processes over Zenoh on loopback (a port chosen free
at run time, every process stopped at the end). The layouts are ros2cli's (its sources, read
for their output); where a real ROS 2 oracle can check the contents, it does: ``topic info -v``
and ``node info`` against the real rclpy's graph API for the same graph built there over DDS,
and ``interface show`` against the ``.msg`` / ``.srv`` files the real packages install.
"""

from __future__ import annotations

import json
import re
import signal
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from servolab.apps.bag import record
from servolab.apps.interface import interface_list, interface_package, interface_show
from servolab.apps.node import node_info, node_list
from servolab.apps.param import param_describe, param_dump, param_load
from servolab.apps.service import service_list, service_type
from servolab.apps.topic import (
    echo_qos,
    format_bw,
    topic_bw,
    topic_echo,
    topic_info,
    topic_list,
    topic_type,
)
from servolab.errors import UsageError
from servolab.middleware.bag import BagReader
from servolab.middleware.context import Context
from servolab.middleware.demo_nodes import Talker
from servolab.middleware.errors import MessageError, ParameterError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from servolab.middleware.recorder import Recorder
from servolab.middleware.transport import Endpoint
from tests.clirun import SERVOLAB, servolab
from tests.middleware.conftest import free_port
from tests.processes import started
from tests.rosoracle import free_domain_id, ros_python, ros_venv, run_ros
from tests.waiting import wait_for_bag, wait_for_graph_at, wait_for_line

TYPES = MessageTypes()
STRING = "std_msgs/msg/String"
SET_BOOL = "std_srvs/srv/SetBool"
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SENSOR = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)


def build_graph(ctx: Context) -> Node:
    """The graph the oracle builds too (ORACLE below): /robot/talker publishes /robot/chatter
    latched, subscribes to it best-effort, serves /robot/add and calls /other/add."""
    node = Node(ctx, "talker", "/robot")
    node.create_publisher(STRING, "chatter", LATCHED)
    node.create_subscription(STRING, "/robot/chatter", lambda m: None, SENSOR)
    node.create_service(SET_BOOL, "add", lambda request, response: response)
    node.create_client(SET_BOOL, "/other/add")
    return node


# -- node ----------------------------------------------------------------------------------------


def test_node_list_sorts_names_hides_tools_and_warns_of_duplicates(
        ctx: Context, monkeypatch: pytest.MonkeyPatch) -> None:
    build_graph(ctx)
    Node(ctx, "listener")
    Node(ctx, "_servolab_echo_1")
    lines: list[str] = []
    assert node_list(ctx, lines.append) == ["/listener", "/robot/talker"]
    assert lines == ["/listener", "/robot/talker"]
    lines.clear()
    node_list(ctx, lines.append, include_hidden=True)
    assert lines == ["/_servolab_echo_1", "/listener", "/robot/talker"]
    lines.clear()
    node_list(ctx, lines.append, count_only=True)
    assert lines == ["2"]
    # a second node of the same name, in another process (one process cannot have two)
    graph = ctx.transport.graph
    monkeypatch.setattr(ctx.transport, "graph", lambda timeout=0.5: [
        *graph(timeout), Endpoint("NN", "/listener")])
    warnings: list[str] = []
    lines.clear()
    node_list(ctx, lines.append, warn=warnings.append)
    assert lines == ["/listener", "/listener", "/robot/talker"]
    assert warnings == ["WARNING: Be aware that there are nodes in the graph that share an "
                        "exact name, which can have unintended side effects."]


def test_node_info_prints_the_sections_of_ros2_node_info(ctx: Context) -> None:
    build_graph(ctx)
    lines: list[str] = []
    node_info(ctx, "/robot/talker", lines.append)
    params = [f"    /robot/talker/{name}: rcl_interfaces/srv/{kind}" for name, kind in (
        ("describe_parameters", "DescribeParameters"),
        ("get_parameter_types", "GetParameterTypes"), ("get_parameters", "GetParameters"),
        ("list_parameters", "ListParameters"), ("set_parameters", "SetParameters"),
        ("set_parameters_atomically", "SetParametersAtomically"))]
    assert "\n".join(lines).split("\n") == [
        "/robot/talker",
        "  Subscribers:",
        "    /robot/chatter: std_msgs/msg/String",
        "  Publishers:",
        "    /robot/chatter: std_msgs/msg/String",
        "  Service Servers:",
        "    /robot/add: std_srvs/srv/SetBool",
        *params,
        "  Service Clients:",
        "    /other/add: std_srvs/srv/SetBool",
        "  Action Servers:",
        "",  # an empty section is an empty line, as ros2 prints it
        "  Action Clients:",
        "",
    ]
    # a name without its leading / is taken from /, as the other commands take names
    lines.clear()
    node_info(ctx, "robot/talker", lines.append)
    assert lines[0] == "/robot/talker"


@pytest.mark.parametrize(("name", "message"), [
    ("/robot/talkr", "Unable to find node '/robot/talkr'; the graph has /robot/talker "
     "('servolab node list')"),
    ("/robot/9talker", "'/robot/9talker' is not a node name ("),
])
def test_node_info_of_a_node_not_there_is_one_line_naming_it(ctx: Context, name: str,
                                                             message: str) -> None:
    build_graph(ctx)
    with pytest.raises(UsageError) as caught:
        node_info(ctx, name, lambda _: None)
    assert str(caught.value).startswith(message) and "\n" not in str(caught.value)


# -- topic ---------------------------------------------------------------------------------------


def test_topic_info_and_type_as_ros2_prints_them(ctx: Context) -> None:
    build_graph(ctx)
    lines: list[str] = []
    assert topic_info(ctx, "/robot/chatter", lines.append) == (1, 1)
    assert lines == ["Type: std_msgs/msg/String", "Publisher count: 1",
                     "Subscription count: 1"]
    lines.clear()
    assert topic_type(ctx, "robot/chatter", lines.append) == [STRING]
    assert lines == [STRING]
    with pytest.raises(UsageError, match=r"^Unknown topic '/robot/chater' \(did you mean "
                       r"/robot/chatter\?\); the graph has /robot/chatter \('servolab topic "
                       r"list'\)$"):
        topic_info(ctx, "/robot/chater", lines.append)
    with pytest.raises(UsageError, match=r"^Unknown topic '/nope'"):
        topic_type(ctx, "/nope", lines.append)


def test_topic_info_verbose_shows_each_endpoint_and_its_qos(ctx: Context) -> None:
    build_graph(ctx)
    lines: list[str] = []
    topic_info(ctx, "/robot/chatter", lines.append, verbose=True)
    text = "\n".join(lines)
    hash_ = TYPES.rihs01(STRING)
    endpoint = ("Node name: talker\nNode namespace: /robot\nTopic type: std_msgs/msg/String\n"
                f"Topic type hash: {hash_}\nEndpoint type: {{kind}}\nGID: \nQoS profile:\n"
                "  Reliability: {reliability}\n  History (Depth): KEEP_LAST ({depth})\n"
                "  Durability: {durability}\n  Lifespan: Infinite\n  Deadline: Infinite\n"
                "  Liveliness: AUTOMATIC\n  Liveliness lease duration: Infinite\n")
    assert text == (
        "Type: std_msgs/msg/String\n\nPublisher count: 1\n\n"
        + endpoint.format(kind="PUBLISHER", reliability="RELIABLE", depth=1,
                          durability="TRANSIENT_LOCAL")
        + "\nSubscription count: 1\n\n"
        + endpoint.format(kind="SUBSCRIPTION", reliability="BEST_EFFORT", depth=5,
                          durability="VOLATILE"))


def test_topic_bw_reports_bytes_per_second_and_message_sizes(ctx: Context) -> None:
    node = Node(ctx, "chatty")
    pub = node.create_publisher(STRING, "/chatter", 10)
    msg = node.message(STRING, data="hello")
    node.create_timer(0.02, lambda: pub.publish(msg))
    lines: list[str] = []
    rates = topic_bw(ctx, "/chatter", lines.append, report_every=0.3, reports=2)
    size = len(TYPES.serialize(msg))
    assert lines[0] == "Subscribed to [/chatter]"
    assert len(rates) == 2 and all(r > 0 for r in rates)
    for line in lines[1:]:
        assert re.fullmatch(rf"\d+ B/s from \d+ messages\n\tMessage size mean: {size} B "
                            rf"min: {size} B max: {size} B", line), line


def test_bw_units_are_ros2s() -> None:
    assert format_bw(1500.0, [1000, 2000]) == (
        "1.50 KB/s from 2 messages\n\tMessage size mean: 1.50 KB min: 1.00 KB max: 2.00 KB")
    assert format_bw(999.0, [14, 14, 15]) == (
        "999 B/s from 3 messages\n\tMessage size mean: 14 B min: 14 B max: 15 B")
    assert format_bw(2.5e6, [2_000_000]).startswith("2.50 MB/s from 1 messages")


def test_echo_shows_the_message_a_latched_topic_kept(ctx: Context) -> None:
    """D6: a /robot_description published once before the echo starts is shown, as ros2
    topic echo shows it (its subscription takes TRANSIENT_LOCAL from the publishers)."""
    talker = Node(ctx, "robot_state_publisher")
    talker.create_publisher(STRING, "/robot_description", LATCHED).publish(
        talker.message(STRING, data="<robot name='biped'/>"))
    guard = Node(ctx, "guard")
    guard.create_timer(5.0, ctx.shutdown)  # without the fix the echo would wait for ever
    lines: list[str] = []
    assert topic_echo(ctx, "/robot_description", lines.append, count=1) == 1
    assert lines == ["data: <robot name='biped'/>", "---"]


def test_echo_qos_adapts_to_the_publishers_as_ros2s_choose_qos() -> None:
    said: list[str] = []
    volatile = QoSProfile()
    assert echo_qos([LATCHED, LATCHED]).transient_local
    assert echo_qos([LATCHED, LATCHED]).reliable
    mixed = echo_qos([LATCHED, volatile, SENSOR], said.append)
    assert not mixed.transient_local and not mixed.reliable
    assert said == [
        "Some, but not all, publishers are offering QoSReliabilityPolicy.RELIABLE. Falling "
        "back to QoSReliabilityPolicy.BEST_EFFORT as it will connect to all publishers",
        "Some, but not all, publishers are offering QoSDurabilityPolicy.TRANSIENT_LOCAL. "
        "Falling back to QoSDurabilityPolicy.VOLATILE as it will connect to all publishers"]
    nobody = echo_qos([])
    assert nobody.reliable and not nobody.transient_local and nobody.keep_all


LATCHER = textwrap.dedent("""
    import sys
    from servolab.middleware.context import Context
    from servolab.middleware.node import Node
    from servolab.middleware.qos import DurabilityPolicy, QoSProfile
    from servolab.middleware.transport import TransportOptions
    with Context.open(TransportOptions("zenoh", listen=[sys.argv[1]])) as ctx:
        node = Node(ctx, "robot_state_publisher")
        node.create_publisher("std_msgs/msg/String", "/robot_description", QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)).publish(
            node.message("std_msgs/msg/String", data="<robot name='biped'/>"))
        print("ready", flush=True)
        ctx.spin()
""")


@pytest.mark.slow
def test_echo_over_zenoh_shows_a_latched_message_published_before_it_started() -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", LATCHER, endpoint]) as latcher:
        wait_for_line(latcher, "ready", timeout=20.0)
        echo = servolab("topic", "echo", "/robot_description", "--count", "1", "--connect",
                        endpoint, timeout=40)
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout == "data: <robot name='biped'/>\n---\n"


# -- service -------------------------------------------------------------------------------------


def test_service_type_prints_the_type_or_names_the_services_there_are(ctx: Context) -> None:
    build_graph(ctx)
    lines: list[str] = []
    assert service_type(ctx, "/robot/add", lines.append) == [SET_BOOL]
    assert lines == [SET_BOOL]
    with pytest.raises(UsageError, match=r"^no service /robot/ad in the graph \(did you mean "
                       r"/robot/add\?\); it has /other/add, /robot/add, "):
        service_type(ctx, "/robot/ad", lines.append)


# -- interface -----------------------------------------------------------------------------------


def test_interface_list_has_ros2s_sections() -> None:
    lines: list[str] = []
    interface_list(TYPES, lines.append)
    messages, services = lines.index("Messages:"), lines.index("Services:")
    actions = lines.index("Actions:")
    assert messages == 0 and actions > services
    assert "    test_msgs/action/Fibonacci" in lines[actions:]
    assert "    nav2_msgs/action/NavigateToPose" in lines[actions:]
    assert "    geometry_msgs/msg/Twist" in lines[messages:services]
    assert "    std_srvs/srv/SetBool" in lines[services:]
    listed = lines[messages + 1:services]
    assert listed == sorted(listed) and all(line.startswith("    ") for line in listed)
    only: list[str] = []
    interface_list(TYPES, only.append, messages=False, actions=False)
    assert only[0] == "Services:" and "Messages:" not in only and "Actions:" not in only


def test_interface_package_lists_a_packages_interfaces() -> None:
    """``ros2 interface package PKG``: its messages, services and actions, sorted."""
    lines: list[str] = []
    interface_package(TYPES, "action_msgs", lines.append)
    assert lines == ["action_msgs/msg/GoalInfo", "action_msgs/msg/GoalStatus",
                     "action_msgs/msg/GoalStatusArray", "action_msgs/srv/CancelGoal"]
    with pytest.raises(UsageError, match=r"unknown package 'nav2_msg' \(did you mean nav2_msgs"):
        interface_package(TYPES, "nav2_msg", lines.append)


def test_interface_show_expands_nested_types_and_separates_a_service() -> None:
    lines: list[str] = []
    interface_show(TYPES, "geometry_msgs/msg/TwistStamped", lines.append)
    assert lines[:5] == ["std_msgs/Header header", "\tbuiltin_interfaces/Time stamp",
                         "\t\tint32 sec", "\t\tuint32 nanosec", "\tstring frame_id"]
    assert lines[5:7] == ["Twist twist", "\tVector3 linear"]
    lines.clear()
    interface_show(TYPES, "std_srvs/srv/SetBool", lines.append)
    assert lines == ["bool data", "---", "bool success", "string message"]
    with pytest.raises(MessageError, match="did you mean std_srvs/srv/SetBool"):
        interface_show(TYPES, "std_srvs/srv/SetBoo", lines.append)
    with pytest.raises(MessageError, match=r"^Invalid name 'std_msgs/msg/String/x'"):
        interface_show(TYPES, "std_msgs/msg/String/x", lines.append)


#: The types whose ros2 definitions the oracle test reads from the real packages' files.
SHOWN = ("geometry_msgs/msg/TwistStamped", "sensor_msgs/msg/Imu", "nav_msgs/msg/Odometry",
         "sensor_msgs/msg/JointState", "sensor_msgs/msg/BatteryState",
         "rcl_interfaces/msg/ParameterDescriptor", "std_srvs/srv/SetBool",
         "rcl_interfaces/srv/ListParameters", "rcl_interfaces/srv/GetParameters",
         "action_msgs/srv/CancelGoal", "test_msgs/action/Fibonacci")
_PRIMITIVES = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
               "int64", "uint64", "float32", "float64", "string", "wstring"}


def _show_from_files(share: Path, name: str, indent: int = 0) -> list[str]:
    """What ``ros2 interface show --no-comments NAME`` prints, read from the installed
    ``.msg`` / ``.srv`` file by rosidl's rules (comments and blank lines left out, a field's
    default value left out since servolab's types do not keep it, whitespace made single, a
    field of a message type followed by that type's lines one tab further in)."""
    package, kind, short = name.split("/")
    lines = []
    for raw in (share / package / kind / f"{short}.{kind}").read_text().splitlines():
        text = raw.split("#", 1)[0].strip() if not raw.strip().startswith("#") else ""
        if not text:
            continue
        if text == "---":
            lines.append(text)
            continue
        if re.match(r"\S+\s+\w+\s*=", text):  # a constant: TYPE NAME=VALUE
            left, value = text.split("=", 1)
            lines.append("\t" * indent + f"{' '.join(left.split())}={value.strip()}")
            continue
        field_type, field_name = text.split()[:2]
        lines.append("\t" * indent + f"{field_type} {field_name}")
        base = re.sub(r"(<=\d+)?(\[.*\])?$", "", field_type)
        if base not in _PRIMITIVES:
            nested_pkg, _, nested = base.rpartition("/")
            lines += _show_from_files(share, f"{nested_pkg or package}/msg/{nested}",
                                      indent + 1)
    return lines


@pytest.mark.parametrize("name", SHOWN)
def test_interface_show_matches_the_real_packages_definitions(name: str) -> None:
    ros_python()  # skipped, saying why, where the real ROS 2 packages are not installed
    lines: list[str] = []
    interface_show(TYPES, name, lines.append)
    assert lines == _show_from_files(ros_venv() / "share", name)


# -- param ---------------------------------------------------------------------------------------


@pytest.fixture
def talker(ctx: Context) -> Talker:
    return Talker(ctx, "talker", "/robot")


def test_param_dump_prints_a_parameter_file_as_ros2_param_dump(ctx: Context,
                                                                talker: Talker) -> None:
    talker.declare_parameter("camera.width", 640)
    lines: list[str] = []
    text = param_dump(ctx, "/robot/talker", lines.append)
    assert lines == [text]
    assert text == ("/robot/talker:\n  ros__parameters:\n    camera:\n      width: 640\n"
                    "    count: 0\n    rate: 10.0\n    speed: 0.1\n")
    with pytest.raises(UsageError, match=r"^Node not found: /robot/talkr; nodes with "
                       r"parameters: /robot/talker \('servolab param list'\)$"):
        param_dump(ctx, "/robot/talkr", lines.append, wait=0.1)


def test_param_load_sets_each_parameter_of_a_file_and_round_trips_a_dump(
        ctx: Context, talker: Talker, tmp_path: Path) -> None:
    params = tmp_path / "talker.yaml"
    params.write_text("/**:\n  ros__parameters:\n    count: 3\n"
                      "robot/talker:\n  ros__parameters:\n    speed: 0.4\n    rate: fast\n")
    said: list[str] = []
    refused: list[str] = []
    assert not param_load(ctx, "/robot/talker", str(params), said.append, warn=refused.append)
    assert said == ["Set parameter count successful", "Set parameter speed successful"]
    assert refused == ["Set parameter rate failed: parameter rate is a double; 'fast' is a "
                       "string"]
    assert talker.get_parameter("speed").value == 0.4 and talker.get_parameter("count").value == 3
    # without the wildcard, only the node's own entries
    said.clear()
    params.write_text("/**:\n  ros__parameters:\n    count: 7\n"
                      "/robot/talker:\n  ros__parameters:\n    speed: 0.2\n")
    assert param_load(ctx, "/robot/talker", str(params), said.append, use_wildcard=False)
    assert said == ["Set parameter speed successful"] and talker.get_parameter("count").value == 3
    # what dump prints, load takes back
    dumped = tmp_path / "dumped.yaml"
    dumped.write_text(param_dump(ctx, "/robot/talker", lambda _: None))
    talker.set_parameter("speed", 0.9)
    said.clear()
    assert param_load(ctx, "/robot/talker", str(dumped), said.append)
    assert talker.get_parameter("speed").value == 0.2
    other = tmp_path / "other.yaml"
    other.write_text("/listener:\n  ros__parameters:\n    x: 1\n")
    with pytest.raises(ParameterError, match=r"does not contain parameters for /robot/talker, "
                       "only for nodes: /listener$"):
        param_load(ctx, "/robot/talker", str(other), said.append)


def test_param_describe_prints_type_description_and_constraints(ctx: Context,
                                                                talker: Talker) -> None:
    talker.declare_parameter("port", "/dev/ttyUSB0", description="serial port",
                             read_only=True)
    lines: list[str] = []
    param_describe(ctx, "/robot/talker", ["rate", "port"], lines.append)
    assert lines == ["Parameter name: rate", "  Type: double",
                     "  Description: messages per second", "  Constraints:",
                     "Parameter name: port", "  Type: string", "  Description: serial port",
                     "  Constraints:", "    Read only: true"]
    with pytest.raises(ParameterError, match=r"^/robot/talker has no parameter rat \(it has "
                       r"count, port, rate, speed\)$"):
        param_describe(ctx, "/robot/talker", ["rat"], lines.append)


# -- bag record -a / -e ----------------------------------------------------------------------


def _bag_topics(path: Path) -> dict[str, int]:
    return {t.name: t.count for t in BagReader(str(path), TYPES).info().topics}


def test_record_all_takes_topics_that_appear_while_recording(ctx: Context,
                                                             tmp_path: Path) -> None:
    node = Node(ctx, "robot")
    early = node.create_publisher(STRING, "/early", 10)
    hidden = node.create_publisher(STRING, "/robot/_action/status", 10)
    recorder = Recorder(ctx, str(tmp_path / "all"), [], all_topics=True)
    late = node.create_publisher(STRING, "/late", 10)  # appears once recording runs
    assert ctx.spin_until(lambda: {"/early", "/late"} <= set(recorder.counts), timeout=5.0)
    assert ctx.spin_until(lambda: late.wait_for_subscription(0) and
                          early.wait_for_subscription(0), timeout=5.0)
    for pub in (early, late, hidden):
        pub.publish(node.message(STRING, data="x"))
    assert ctx.spin_until(lambda: recorder.counts["/late"] == 1 and
                          recorder.counts["/early"] == 1, timeout=5.0)
    recorder.destroy()
    assert _bag_topics(tmp_path / "all") == {"/early": 1, "/late": 1}  # not the hidden one


def test_record_regex_takes_the_topics_it_matches(ctx: Context, tmp_path: Path) -> None:
    node = Node(ctx, "robot")
    pubs = {t: node.create_publisher(STRING, t, 10)
            for t in ("/robot/odom", "/robot/cmd_vel", "/camera/image", "/robot/debug")}
    recorder = Recorder(ctx, str(tmp_path / "re"), [], regex="^/robot/",
                        exclude="debug")
    assert ctx.spin_until(lambda: len(recorder.counts) == 2 and all(
        pubs[t].wait_for_subscription(0) for t in recorder.counts), timeout=5.0)
    for pub in pubs.values():
        pub.publish(node.message(STRING, data="x"))
    assert ctx.spin_until(lambda: sum(recorder.counts.values()) == 2, timeout=5.0)
    recorder.destroy()
    assert _bag_topics(tmp_path / "re") == {"/robot/odom": 1, "/robot/cmd_vel": 1}


@pytest.mark.parametrize(("args", "message"), [
    ([], "servolab bag record: error: nothing to record: name topics, or give -a (all topics) "
     "or -e REGEX (topics matching it)"),
    (["-e", "(robot"], "servolab bag record: error: --regex '(robot' is not a regular "
     "expression (...); e.g. '/robot/.*'"),
])
def test_record_without_topics_or_with_a_bad_regex_is_refused(tmp_path: Path,
                                                               args: list[str],
                                                               message: str) -> None:
    result = servolab("bag", "record", *args, "-o", str(tmp_path / "b"), "--transport", "local",
                      timeout=30)
    assert result.returncode == 2
    head, _, tail = message.partition("(...)")  # the regex error's own words vary by Python
    assert result.stderr.startswith(head) and result.stderr.endswith(tail + "\n")
    assert result.stderr.count("\n") == 1
    assert not (tmp_path / "b").exists()
    with Context.open(types=TYPES) as context, pytest.raises(UsageError):
        record(context, str(tmp_path / "b"), [], lambda _: None)


@pytest.mark.slow
def test_record_all_over_zenoh_records_a_topic_published_after_it_started(
        tmp_path: Path) -> None:
    bag = tmp_path / "everything"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([*SERVOLAB, "bag", "record", "-a", "-o", str(bag), "--listen", endpoint]) as rec:
        wait_for_line(rec, "recording every topic a publisher appears on")
        pub = servolab("topic", "pub", "/chatter", STRING, "{data: hello}", "--rate", "20",
                       "--count", "5", "--wait-matching", "10", "--connect", endpoint, timeout=30)
        assert pub.returncode == 0, pub.stderr
        wait_for_bag(bag, 5)
        rec.send_signal(signal.SIGINT)
        out, err = rec.communicate(timeout=30)
    assert rec.returncode == 0, err
    assert "recorded 5 message(s)" in out
    assert _bag_topics(bag) == {"/chatter": 5}


# -- the real rclpy's graph, for the same graph -----------------------------------------------

#: The graph of build_graph, made with the real rclpy over DDS; prints what its graph API says.
ORACLE = textwrap.dedent("""
    import json, time
    import rclpy
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import String
    from std_srvs.srv import SetBool
    rclpy.init()
    node = Node("talker", namespace="/robot")
    node.create_publisher(String, "chatter", QoSProfile(
        depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    node.create_subscription(String, "/robot/chatter", lambda m: None, QoSProfile(
        depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
    node.create_service(SetBool, "add", lambda request, response: response)
    node.create_client(SetBool, "/other/add")
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and not (
            node.get_publishers_info_by_topic("/robot/chatter")
            and node.get_subscriptions_info_by_topic("/robot/chatter")):
        time.sleep(0.05)
    by_node = {kind: getattr(node, f"get_{kind}_names_and_types_by_node")("talker", "/robot")
               for kind in ("publisher", "subscriber", "service", "client")}
    print(json.dumps({
        "nodes": node.get_node_names_and_namespaces(),
        "topics": node.get_topic_names_and_types(),
        "services": node.get_service_names_and_types(),
        "publishers": [str(i) for i in node.get_publishers_info_by_topic("/robot/chatter")],
        "subscriptions": [str(i) for i in
                          node.get_subscriptions_info_by_topic("/robot/chatter")],
        "by_node": by_node}))
    rclpy.shutdown()
""")
#: What rclpy offers that servolab's nodes do not: /rosout, /parameter_events, the type
#: description service.
ROS_ONLY = {"/rosout", "/parameter_events", "/robot/talker/get_type_description"}


@pytest.fixture(scope="module")
def oracle() -> dict:
    ros_python()  # skipped where the real rclpy is not installed
    result = run_ros(ORACLE, free_domain_id())
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


@pytest.mark.slow
def test_topic_info_verbose_matches_rclpys_endpoint_info(oracle: dict, ctx: Context) -> None:
    """Line for line what rclpy's ``TopicEndpointInfo`` prints for the same graph, but the
    GID (DDS's own; servolab's graph has none) and the history (over DDS rclpy says UNKNOWN,
    rmw_zenoh and servolab give KEEP_LAST (depth))."""
    build_graph(ctx)
    lines: list[str] = []
    topic_info(ctx, "/robot/chatter", lines.append, verbose=True)
    ours = [block.rstrip("\n") for block in lines if block.startswith("Node name:")]
    theirs = oracle["publishers"] + oracle["subscriptions"]
    assert len(ours) == len(theirs) == 2

    def comparable(block: str) -> list[str]:
        return [line for line in block.split("\n")
                if not line.startswith(("GID:", "  History (Depth):"))]

    assert [comparable(b) for b in ours] == [comparable(b) for b in theirs]


@pytest.mark.slow
def test_node_list_and_info_match_rclpys_graph_api(oracle: dict, ctx: Context) -> None:
    build_graph(ctx)
    lines: list[str] = []
    node_list(ctx, lines.append)
    assert lines == [f"{ns.rstrip('/')}/{name}" for name, ns in sorted(
        oracle["nodes"], key=lambda n: f"{n[1]}/{n[0]}")]
    sections = node_info(ctx, "/robot/talker", lambda _: None)
    for title, kind in (("Publishers", "publisher"), ("Subscribers", "subscriber"),
                        ("Service Servers", "service"), ("Service Clients", "client")):
        theirs = {name: types for name, types in oracle["by_node"][kind]
                  if name not in ROS_ONLY}
        assert sections[title] == theirs, title


@pytest.mark.slow
def test_topic_and_service_lists_match_rclpys_graph_api(oracle: dict, ctx: Context) -> None:
    build_graph(ctx)
    topics: list[str] = []
    topic_list(ctx, topics.append, show_types=True)
    assert topics == [f"{name} [{', '.join(types)}]" for name, types in oracle["topics"]
                      if name not in ROS_ONLY]
    services: list[str] = []
    service_list(ctx, services.append, show_types=True)
    assert services == [f"{name} [{', '.join(types)}]" for name, types in oracle["services"]
                        if name not in ROS_ONLY]


@pytest.mark.slow
def test_the_new_commands_over_zenoh_as_a_user_types_them() -> None:
    """node list / info, topic info / type, service type and param dump / describe from
    separate processes, against a node in another process."""
    server = textwrap.dedent("""
        import sys
        from servolab.middleware.context import Context
        from servolab.middleware.demo_nodes import Talker
        from servolab.middleware.transport import TransportOptions
        with Context.open(TransportOptions("zenoh", listen=[sys.argv[1]])) as ctx:
            Talker(ctx, "talker", "/robot", parameter_overrides={"rate": 20.0})
            print("ready", flush=True)
            ctx.spin()
    """)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    with started([sys.executable, "-c", server, endpoint]) as proc:
        wait_for_line(proc, "ready", timeout=20.0)
        wait_for_graph_at(endpoint, ("MP", "/robot/talker", "/robot/cmd_vel"))
        connect = ["--connect", endpoint]
        assert servolab("node", "list", *connect, timeout=30).stdout == "/robot/talker\n"
        info = servolab("node", "info", "/robot/talker", *connect, timeout=30)
        assert info.stdout.startswith("/robot/talker\n  Subscribers:\n\n  Publishers:\n"
                                      "    /robot/cmd_vel: geometry_msgs/msg/Twist\n"), info
        assert servolab("topic", "type", "/robot/cmd_vel", *connect, timeout=30).stdout == \
            "geometry_msgs/msg/Twist\n"
        assert servolab("topic", "info", "/robot/cmd_vel", *connect, timeout=30).stdout == (
            "Type: geometry_msgs/msg/Twist\nPublisher count: 1\nSubscription count: 0\n")
        assert servolab("service", "type", "/robot/talker/get_parameters", *connect,
                        timeout=30).stdout == \
            "rcl_interfaces/srv/GetParameters\n"
        dump = servolab("param", "dump", "/robot/talker", *connect, timeout=30)
        assert yaml.safe_load(dump.stdout) == {"/robot/talker": {"ros__parameters": {
            "count": 0, "rate": 20.0, "speed": 0.1}}}
        described = servolab("param", "describe", "/robot/talker", "speed", *connect, timeout=30)
        assert described.stdout == ("Parameter name: speed\n  Type: double\n  Description: "
                                    "linear.x in m/s (live)\n  Constraints:\n")
        missing = servolab("node", "info", "/robot/talkr", *connect, timeout=30)
        assert missing.returncode == 2
        assert missing.stderr == ("servolab node info: error: Unable to find node "
                                  "'/robot/talkr'; the graph has /robot/talker ('servolab node "
                                  "list')\n")
