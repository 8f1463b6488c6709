"""The DDS transport between two participants on loopback (two in one process: Cyclone DDS
delivers between them locally; across processes, ``tests/rclpy/test_programs.py[dds]`` and
``test_dds_rclpy.py``), its names and types on DDS, and what it refuses.

The layout checked here is ROS 2's (``rt/``, ``rq/…Request``, ``rr/…Reply``,
``pkg::msg::dds_::Type_``, ``ros_discovery_info``: the ROS 2 design article "Topic and Service
name mapping to DDS" and ``rmw_dds_common``); ``test_dds_rclpy.py`` checks it against the real
rclpy on Fast DDS.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator

import pytest

from servolab.middleware.context import Context
from servolab.middleware.errors import ServiceError, TransportError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from servolab.middleware.rmw_dds import (
    cyclone_config,
    discovery_range,
    reply_topic,
    request_topic,
    ros_name,
    static_peers,
    topic_name,
)
from servolab.middleware.transport import TransportOptions
from tests.rosoracle import free_domain_id
from tests.waiting import wait_for_subscriber, wait_until

TWIST = "geometry_msgs/msg/Twist"


@pytest.fixture
def dds_pair(types: MessageTypes, monkeypatch: pytest.MonkeyPatch) -> Iterator[
        tuple[Context, Context]]:
    """Two DDS participants in a ROS domain nothing else on the machine uses."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    domain = free_domain_id()
    a = Context.open(TransportOptions("dds", domain_id=domain), types=types)
    try:
        b = Context.open(TransportOptions("dds", domain_id=domain), types=types)
    except BaseException:
        a.close()
        raise
    try:
        yield a, b
    finally:
        b.close()
        a.close()


def test_twist_crosses_participants_with_every_value(dds_pair) -> None:
    a, b = dds_pair
    talker, listener = Node(a, "talker", "/robot1"), Node(b, "listener", "/robot1")
    got: list = []
    listener.create_subscription(TWIST, "cmd_vel", lambda m, info: got.append((m, info)),
                                 qos_profile=0, with_info=True)
    pub = talker.create_publisher(TWIST, "cmd_vel")
    wait_for_subscriber(a, "/robot1/cmd_vel", TWIST, "/robot1/listener")
    sent = [talker.message(TWIST, linear={"x": k * 0.01, "y": -k}, angular={"z": k / 7})
            for k in range(50)]
    for msg in sent:
        pub.publish(msg)
    assert b.spin_until(lambda: len(got) == 50, timeout=5.0)
    assert [b.types.to_value(m) for m, _ in got] == [a.types.to_value(m) for m in sent]
    assert all(info.source_timestamp_ns <= info.received_timestamp_ns for _, info in got)


def test_a_publisher_and_subscription_destroyed_then_their_node(dds_pair) -> None:
    """Destroying an entity, then its node (which destroys what it still holds), closes each
    once: the incompatible-QoS watch an entity carries goes with its first close."""
    a, _ = dds_pair
    node = Node(a, "short_lived")
    pub = node.create_publisher(TWIST, "cmd_vel")
    sub = node.create_subscription(TWIST, "cmd_vel", lambda m: None)
    node.destroy_publisher(pub)
    node.destroy_subscription(sub)
    pub.destroy()
    node.destroy()


def test_a_latched_message_reaches_a_late_subscription(dds_pair) -> None:
    """TRANSIENT_LOCAL is DDS's own durability: the writer keeps its last ``depth``."""
    a, b = dds_pair
    latched = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = Node(a, "describer").create_publisher("std_msgs/msg/String", "/robot_description",
                                                latched)
    for text in ("old", "urdf 1", "urdf 2"):
        pub.publish(Node(a, "m").message("std_msgs/msg/String", data=text))
    got: list = []
    Node(b, "viewer").create_subscription("std_msgs/msg/String", "/robot_description",
                                          lambda m: got.append(m.data), latched)
    assert b.spin_until(lambda: len(got) == 2, timeout=5.0)
    assert got == ["urdf 1", "urdf 2"]


@pytest.mark.slow
def test_services_and_parameters_across_participants(dds_pair, caplog) -> None:
    a, b = dds_pair
    server = Node(a, "adder")
    server.declare_parameter("gain", 2)
    server.create_service("example_interfaces/srv/AddTwoInts", "add_two_ints",
                          lambda req, resp: (setattr(resp, "sum", req.a + req.b), resp)[1])

    def fail(req, resp):
        raise RuntimeError("torque enable refused: overheating")
    server.create_service("dynamixel_controllers/srv/TorqueEnable", "torque", fail)
    spinner = a.executor.spin_in_thread()
    try:
        client_node = Node(b, "client")
        add = client_node.create_client("example_interfaces/srv/AddTwoInts", "/add_two_ints")
        assert add.wait_for_service(5.0)
        # several calls at once, each answered with its own sum (rmw_cyclonedds' header)
        futures = [add.call_async(add.request(a=k, b=100)) for k in range(8)]
        assert b.spin_until(lambda: all(f.done() for f in futures), timeout=5.0)
        assert [f.result().sum for f in futures] == [k + 100 for k in range(8)]
        setter = client_node.create_client("rcl_interfaces/srv/SetParameters",
                                           "/adder/set_parameters")
        setter.call(setter.request(parameters=[{"name": "gain",
                                                "value": {"type": 2, "integer_value": 5}}]),
                    timeout=5.0)
        assert server.get_parameter("gain").value == 5
        # DDS has no error reply: the failure is logged by the server, the caller times out
        torque = client_node.create_client("dynamixel_controllers/srv/TorqueEnable", "/torque")
        assert torque.wait_for_service(5.0)
        with caplog.at_level(logging.ERROR), pytest.raises(ServiceError):
            torque.call(torque.request(torque_enable=True), timeout=1.0)
        assert "overheating" in caplog.text
        nobody = client_node.create_client("std_srvs/srv/Trigger", "/nobody")
        with pytest.raises(ServiceError, match="no service /nobody answered"):
            nobody.call(timeout=0.5)
    finally:
        a.shutdown()
        spinner.join(2.0)


def test_builtin_reads_from_many_threads(dds_pair) -> None:
    """Concurrent service calls each ask whether a Fast DDS server answers, reading DDS's
    builtin subscription topic from their own thread. cyclonedds-python's builtin readers are
    not safe to read from several threads at once (unguarded, "Callfunc endpoint constructor
    errored" in 5 of ~1 600 rounds with eight threads, none with one; it failed a service call
    in CI), so the transport lets one thread at a time read them: a reader that takes its time
    never has two threads inside it."""
    _, b = dds_pair
    transport = b.transport
    real = transport._builtin["subscription"]  # type: ignore[attr-defined]
    inside, most = [0], [0]
    count_lock = threading.Lock()

    class SlowReader:
        def read(self, **kwargs: object) -> list[object]:
            with count_lock:
                inside[0] += 1
                most[0] = max(most[0], inside[0])
            try:
                time.sleep(0.002)  # long enough for every other thread to come in unguarded
                return list(real.read(**kwargs))
            finally:
                with count_lock:
                    inside[0] -= 1

    errors: list[BaseException] = []

    def ask() -> None:
        for _ in range(5):
            try:
                transport.fast_dds_serves("/add_two_ints")  # type: ignore[attr-defined]
            except Exception as exc:  # every failure is the finding
                errors.append(exc)

    askers = [threading.Thread(target=ask) for _ in range(8)]
    try:
        transport._builtin["subscription"] = SlowReader()  # type: ignore[attr-defined]
        for thread in askers:
            thread.start()
        for thread in askers:
            thread.join()
    finally:
        transport._builtin["subscription"] = real  # type: ignore[attr-defined]
    assert not errors, errors[0]
    assert most[0] == 1, f"{most[0]} threads read the builtin topic at once"


@pytest.mark.slow
def test_a_failing_check_does_not_stop_the_dispatch_thread(dds_pair, caplog) -> None:
    """The dispatch thread runs the transport's periodic checks (a service's look for Fast
    DDS clients). One that raises, as a closed service's did on its deleted reader (CI), is
    logged while it is still registered, and every reader keeps being served."""
    a, b = dds_pair
    transport = a.transport
    calls = [0]

    def failing() -> None:
        calls[0] += 1
        raise RuntimeError("the reader this check looks at is gone")

    transport._checks.append(failing)  # type: ignore[attr-defined]
    try:
        with caplog.at_level(logging.ERROR, logger="servolab.middleware.dds_transport"):
            assert wait_until(lambda: calls[0] >= 2, timeout=5.0)  # ran, and ran again
        assert transport._dispatcher.is_alive()  # type: ignore[attr-defined]
        assert caplog.text.count("a periodic check failed") == 1  # told once, not each time
    finally:
        transport._checks.remove(failing)  # type: ignore[attr-defined]
    got: list[float] = []
    Node(a, "listener").create_subscription(TWIST, "/after", lambda m: got.append(m.linear.x),
                                            10)
    talker = Node(b, "talker")
    pub = talker.create_publisher(TWIST, "/after", 10)
    wait_for_subscriber(b, "/after", TWIST, "/listener")
    pub.publish(talker.message(TWIST, linear={"x": 1.5}))
    assert a.spin_until(lambda: got == [1.5], timeout=5.0)


def test_clients_of_one_service_share_it_until_the_last_is_destroyed(dds_pair) -> None:
    """Two clients of /reset on one node, one on another, all sharing the service's two
    endpoints: each node keeps its claim on them while one of its clients lives, and the
    endpoints are deleted with the last client (as rclpy's destroy_client deletes a client's;
    tests/middleware/test_dds_rclpy.py shows the real rclpy's count_clients fall to 0 then).
    Shared endpoints are one entity in the graph, shown under one of the nodes that claim
    them, where rclpy would show one per client."""
    a, b = dds_pair
    trigger = "std_srvs/srv/Trigger"
    one, other = Node(b, "one"), Node(b, "other")
    first, second = one.create_client(trigger, "/reset"), one.create_client(trigger, "/reset")
    third = other.create_client(trigger, "/reset")
    shared = b.transport._clients["/reset"]  # type: ignore[attr-defined]
    gid = shared.writer.get_guid().bytes

    def claimed() -> dict[int, int]:  # each node's live clients of the shared endpoints
        return {node: count for node, (count, _) in shared.users.items()}

    def in_graph() -> bool:
        return any(e.kind == "SC" and e.name == "/reset" for e in a.transport.graph())

    assert claimed() == {one.info.node_id: 2, other.info.node_id: 1}
    assert wait_until(in_graph, timeout=5.0)
    one.destroy_client(first)
    assert claimed() == {one.info.node_id: 1, other.info.node_id: 1}
    assert gid in b.transport._writers[one.info.node_id]  # type: ignore[attr-defined]
    one.destroy_client(second)                              # node one's last: its claim goes
    assert claimed() == {other.info.node_id: 1}
    assert gid not in b.transport._writers[one.info.node_id]  # type: ignore[attr-defined]
    assert gid in b.transport._writers[other.info.node_id]  # type: ignore[attr-defined]
    assert b.transport._clients["/reset"] is shared  # type: ignore[attr-defined]
    other.destroy_client(third)                             # the last of all: deleted
    assert "/reset" not in b.transport._clients  # type: ignore[attr-defined]
    assert wait_until(lambda: not in_graph(), timeout=5.0), a.transport.graph()


def test_graph_shows_both_participants(dds_pair) -> None:
    a, b = dds_pair
    Node(a, "talker", "/robot1").create_publisher(TWIST, "/cmd_vel")
    listener = Node(b, "listener")
    listener.create_subscription(TWIST, "/cmd_vel", lambda m: None,
                                 QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT))
    listener.create_client("std_srvs/srv/Trigger", "/reset")
    wanted = {("NN", "/robot1/talker", "", ""), ("NN", "/listener", "", ""),
              ("MP", "/robot1/talker", "/cmd_vel", TWIST),
              ("MS", "/listener", "/cmd_vel", TWIST),
              ("SC", "/listener", "/reset", "std_srvs/srv/Trigger"),
              ("SS", "/robot1/talker", "/robot1/talker/get_parameters",
               "rcl_interfaces/srv/GetParameters")}
    assert wait_until(lambda: {(e.kind, e.node, e.name, e.type_name)
                               for e in a.transport.graph()} >= wanted, timeout=5.0), \
        a.transport.graph()
    sub = next(e for e in a.transport.graph() if e.kind == "MS")
    assert sub.qos is not None and not sub.qos.reliable and sub.qos.depth == 5
    # a node that is destroyed leaves the graph
    listener.destroy_node()
    assert wait_until(lambda: not any(e.node == "/listener" for e in a.transport.graph()),
                      timeout=5.0)


def test_ros_names_on_dds() -> None:
    """ROS 2 design, "Topic and Service name mapping to DDS"."""
    assert topic_name("/robot1/cmd_vel") == "rt/robot1/cmd_vel"
    assert request_topic("/add_two_ints") == "rq/add_two_intsRequest"
    assert reply_topic("/add_two_ints") == "rr/add_two_intsReply"
    assert ros_name("rt/cmd_vel", "geometry_msgs::msg::dds_::Twist_").name == "/cmd_vel"
    request = ros_name("rq/a/setRequest", "std_srvs::srv::dds_::SetBool_Request_")
    assert request is not None and (request.role, request.name, request.type_name) == (
        "request", "/a/set", "std_srvs/srv/SetBool")
    assert ros_name("ros_discovery_info",
                    "rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_") is None
    assert ros_name("DCPSPublication", "org::eclipse::cyclonedds::builtin::DCPSPublication") \
        is None


def test_discovery_settings_are_checked_and_configured() -> None:
    assert discovery_range("") == "LOCALHOST"
    assert discovery_range("subnet") == "SUBNET"
    with pytest.raises(TransportError, match="ROS_AUTOMATIC_DISCOVERY_RANGE='LAN'"):
        discovery_range("LAN")
    assert static_peers("10.0.0.2; robot.local;") == ["10.0.0.2", "robot.local"]
    local = cyclone_config("LOCALHOST", [])
    assert '<NetworkInterface address="127.0.0.1"/>' in local
    assert "<AllowMulticast>false</AllowMulticast>" in local
    assert '<Peer address="127.0.0.1"/>' in local
    # a static peer on another machine: not bound to loopback, still no multicast
    with_peer = cyclone_config("LOCALHOST", ["10.0.0.2"])
    assert "NetworkInterface" not in with_peer
    assert "<AllowMulticast>false</AllowMulticast>" in with_peer
    assert '<Peer address="127.0.0.1"/><Peer address="10.0.0.2"/>' in with_peer
    assert "Interfaces" not in cyclone_config("SUBNET", [])


def test_options_that_mean_nothing_to_dds_are_refused(types, monkeypatch) -> None:
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    with pytest.raises(TransportError, match="--listen is Zenoh's"):
        Context.open(TransportOptions("dds", listen=["tcp/127.0.0.1:0"],
                                      domain_id=free_domain_id()), types=types)
    with pytest.raises(TransportError, match="--connect 'tcp/robot:7447'"):
        Context.open(TransportOptions("dds", connect=["tcp/robot:7447"],
                                      domain_id=free_domain_id()), types=types)
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "everywhere")
    with pytest.raises(TransportError, match="ROS_AUTOMATIC_DISCOVERY_RANGE"):
        Context.open(TransportOptions("dds", domain_id=free_domain_id()), types=types)
