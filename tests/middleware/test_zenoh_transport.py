"""The Zenoh transport between two sessions on loopback, and its bytes on the wire."""

from __future__ import annotations

import time

import pytest

from servolab.middleware.context import Context
from servolab.middleware.errors import ServiceError, TransportError
from servolab.middleware.node import Node
from servolab.middleware.rmw_zenoh import decode_attachment, parse_token, topic_keyexpr
from servolab.middleware.transport import TransportOptions
from tests.middleware.conftest import free_port
from tests.waiting import wait_for_route, wait_for_subscriber, wait_until

TWIST = "geometry_msgs/msg/Twist"


def test_twist_crosses_sessions_with_every_value(zenoh_pair) -> None:
    a, b, _ = zenoh_pair
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
    assert [info.sequence_number for _, info in got] == list(range(1, 51))
    assert len({info.publisher_gid for _, info in got}) == 1


def test_wire_layout_is_rmw_zenohs(zenoh_pair) -> None:
    """A bare Zenoh subscriber sees the key expression, CDR payload and 33-byte attachment
    that rmw_zenoh writes, and the liveliness tokens parse as rmw_zenoh's."""
    a, b, _ = zenoh_pair
    samples: list = []
    raw = b.transport.session.declare_subscriber("0/**", samples.append)
    try:
        node = Node(a, "talker")
        pub = node.create_publisher("std_msgs/msg/String", "chatter")
        # the raw subscriber has no liveliness token, so the graph cannot show it: wait until
        # a's session routes the publisher's key to it
        wait_for_route(a.transport.session, topic_keyexpr(
            0, "/chatter", "std_msgs/msg/String", a.types.rihs01("std_msgs/msg/String")))
        msg = node.message("std_msgs/msg/String", data="Hello World: 1")
        before = time.time_ns()
        pub.publish(msg)
        assert wait_until(lambda: samples, timeout=3.0), "the raw subscriber got nothing"
        sample = samples[0]
        assert str(sample.key_expr) == ("0/chatter/std_msgs::msg::dds_::String_/RIHS01_"
                                        "df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e"
                                        "948f6b1a18")
        assert sample.payload.to_bytes() == a.types.serialize(msg)
        attachment = decode_attachment(sample.attachment.to_bytes())
        assert attachment.sequence_number == 1
        assert before <= attachment.source_timestamp_ns <= time.time_ns()
        tokens = [str(r.ok.key_expr) for r in b.transport.session.liveliness().get(
            "@ros2_lv/0/**", timeout=1.0) if r.ok is not None]
        entities = [parse_token(t) for t in tokens]
        mp = [e for e in entities if e.kind == "MP"]
        assert len(mp) == 1 and mp[0].topic == "/chatter" and mp[0].node_name == "talker"
        assert mp[0].session_id == a.transport.session_id
        assert any(e.kind == "NN" and e.node_name == "talker" for e in entities)
    finally:
        raw.undeclare()


def test_foreign_rmw_zenoh_style_publisher_reaches_a_node(zenoh_pair) -> None:
    """What a ROS 2 node on rmw_zenoh would put arrives at a servolab subscription."""
    a, b, _ = zenoh_pair
    got: list = []
    Node(b, "listener").create_subscription("std_msgs/msg/String", "/chatter", got.append)
    wait_for_subscriber(a, "/chatter", "std_msgs/msg/String", "/listener")
    from servolab.middleware.rmw_zenoh import encode_attachment
    key = ("0/chatter/std_msgs::msg::dds_::String_/"
           + a.types.rihs01("std_msgs/msg/String"))
    payload = a.types.serialize(a.types.from_value("std_msgs/msg/String", {"data": "hi"}))
    a.transport.session.put(key, payload, attachment=encode_attachment(7, time.time_ns(),
                                                                       bytes(16)))
    assert b.spin_until(lambda: got, timeout=3.0)
    assert got[0].data == "hi"


def test_services_and_parameters_across_sessions(zenoh_pair) -> None:
    a, b, _ = zenoh_pair
    server = Node(a, "adder")
    server.declare_parameter("gain", 2)
    server.create_service("example_interfaces/srv/AddTwoInts", "add_two_ints",
                          lambda req, resp: (setattr(resp, "sum", req.a + req.b), resp)[1])

    def fail(req, resp):
        raise RuntimeError("torque enable refused: overheating")
    server.create_service("dynamixel_controllers/srv/TorqueEnable", "torque", fail)
    spinner = a.executor.spin_in_thread()
    client_node = Node(b, "client")
    add = client_node.create_client("example_interfaces/srv/AddTwoInts", "/add_two_ints")
    assert add.wait_for_service(3.0)
    assert add.call(add.request(a=40, b=2), timeout=3.0).sum == 42
    setter = client_node.create_client("rcl_interfaces/srv/SetParameters",
                                       "/adder/set_parameters")
    setter.call(setter.request(parameters=[{"name": "gain",
                                            "value": {"type": 2, "integer_value": 5}}]))
    assert server.get_parameter("gain").value == 5
    torque = client_node.create_client("dynamixel_controllers/srv/TorqueEnable", "/torque")
    with pytest.raises(ServiceError, match="overheating"):
        torque.call(torque.request(torque_enable=True), timeout=3.0)
    nobody = client_node.create_client("std_srvs/srv/Trigger", "/nobody")
    with pytest.raises(ServiceError, match="no service /nobody answered"):
        nobody.call(timeout=0.5)
    a.shutdown()
    spinner.join(2.0)


def test_graph_shows_both_sessions(zenoh_pair) -> None:
    a, b, _ = zenoh_pair
    Node(a, "talker").create_publisher(TWIST, "/cmd_vel")
    Node(b, "listener").create_subscription(TWIST, "/cmd_vel", lambda m: None)
    assert wait_until(lambda: {(e.kind, e.node) for e in a.transport.graph(0.3)} >= {
        ("MP", "/talker"), ("MS", "/listener"), ("NN", "/talker"), ("NN", "/listener")},
        timeout=3.0), a.transport.graph(0.3)


@pytest.mark.parametrize("endpoint", ["127.0.0.1:7447", "tcp/localhost", "carrier-pigeon/x"])
def test_bad_endpoints_are_named(types, endpoint: str) -> None:
    with pytest.raises(TransportError, match=f"Zenoh endpoint '{endpoint}'"):
        Context.open(TransportOptions("zenoh", connect=[endpoint]), types=types)


def test_listen_on_a_taken_port_is_one_line(types) -> None:
    port = free_port()
    holder = Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{port}"]),
                          types=types)
    try:
        with pytest.raises(TransportError) as info:
            Context.open(TransportOptions("zenoh", listen=[f"tcp/127.0.0.1:{port}"]),
                         types=types)
        assert "\n" not in str(info.value) and str(port) in str(info.value)
    finally:
        holder.close()
