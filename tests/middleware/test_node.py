"""Nodes on the in-process transport: topics, timers, Rate, services, parameters."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.errors import (
    MessageError,
    NameValidationError,
    ParameterError,
    ServiceError,
)
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.parameters import ParameterOverrides

TYPES = MessageTypes()
TWIST = "geometry_msgs/msg/Twist"


@pytest.fixture
def ctx_clock() -> VirtualClock:
    """``ctx`` (tests/conftest.py) on a virtual clock: these tests step time themselves."""
    return VirtualClock()


def test_publish_subscribe_across_namespaces_and_remapping(ctx: Context) -> None:
    talker = Node(ctx, "talker", "/robot1")
    listener = Node(ctx, "listener", remappings={"cmd": "/robot1/cmd_vel"})
    got: list[tuple[float, int]] = []
    listener.create_subscription(TWIST, "cmd", lambda m, i: got.append((m.angular.z,
                                                                         i.sequence_number)),
                                 with_info=True)
    pub = talker.create_publisher(TWIST, "cmd_vel")
    assert pub.topic == "/robot1/cmd_vel"
    for k in range(5):
        pub.publish(talker.message(TWIST, angular={"z": k / 2}))
    ctx.spin_until(lambda: len(got) == 5, timeout=1.0)
    assert got == [(k / 2, k + 1) for k in range(5)]


def test_same_topic_other_type_never_delivers(ctx: Context) -> None:
    node = Node(ctx, "n")
    got: list = []
    node.create_subscription("std_msgs/msg/Float64", "/x", got.append)
    node.create_publisher("std_msgs/msg/Float32", "/x").publish(
        node.message("std_msgs/msg/Float32", data=1.0))
    ctx.spin_for(0.1)
    assert got == []
    with pytest.raises(MessageError, match="/x carries std_msgs/msg/Float32, not "
                                           "std_msgs/msg/Float64"):
        node.create_publisher("std_msgs/msg/Float32", "/x").publish(
            node.message("std_msgs/msg/Float64"))


def test_keep_last_depth_drops_the_oldest_and_counts(ctx: Context) -> None:
    node = Node(ctx, "n")
    got: list[float] = []
    sub = node.create_subscription("std_msgs/msg/Float64", "/x", lambda m: got.append(m.data),
                                   qos_profile=3)
    pub = node.create_publisher("std_msgs/msg/Float64", "/x")
    for k in range(10):
        pub.publish(node.message("std_msgs/msg/Float64", data=float(k)))
    ctx.spin_for(0.1)
    assert got == [7.0, 8.0, 9.0] and sub.dropped == 7 and sub.received == 3  # 7 + 3 = 10


def test_raw_subscription_gets_cdr(ctx: Context) -> None:
    node = Node(ctx, "n")
    raw: list[bytes] = []
    node.create_subscription(TWIST, "/cmd_vel", raw.append, raw=True, qos_profile=0)
    msg = node.message(TWIST, linear={"x": 0.25})
    node.create_publisher(TWIST, "/cmd_vel").publish(msg)
    ctx.spin_for(0.1)
    assert raw == [TYPES.serialize(msg)]


def test_timer_and_rate_keep_time_on_the_clock(ctx: Context) -> None:
    node = Node(ctx, "n")
    ticks: list[float] = []
    node.create_timer(0.25, lambda: ticks.append(ctx.clock.now()))
    ctx.spin_for(1.0)
    assert ticks == pytest.approx([0.25, 0.5, 0.75, 1.0])
    rate = node.create_rate(4.5)  # the gait player's loop in seed 001
    start = ctx.clock.now()
    stamps = []
    for _ in range(9):
        rate.sleep()
        stamps.append(ctx.clock.now() - start)
    assert stamps == pytest.approx([(k + 1) / 4.5 for k in range(9)])
    assert len(ticks) == 4 + 8  # the timer kept running while the Rate waited


def test_rate_that_falls_behind_restarts_its_schedule() -> None:
    clock = VirtualClock()
    with Context.open(types=TYPES, clock=clock) as ctx:
        rate = Node(ctx, "n").create_rate(10)
        clock.advance(0.55)             # the loop body took 5.5 periods
        rate.sleep()                     # returns at once ...
        assert clock.now() == pytest.approx(0.55)
        rate.sleep()                     # ... and the next tick is on the new schedule
        assert clock.now() == pytest.approx(0.6)


def test_services_answer_and_failures_are_named(ctx: Context) -> None:
    server = Node(ctx, "motor")
    speeds: list[float] = []

    def set_speed(request, response):
        if request.speed < 0:
            raise ValueError("speed must be >= 0")
        speeds.append(request.speed)
        return response

    server.create_service("dynamixel_controllers/srv/SetSpeed", "~/set_speed", set_speed)
    client = Node(ctx, "ui").create_client("dynamixel_controllers/srv/SetSpeed",
                                           "/motor/set_speed")
    assert client.wait_for_service(1.0)
    client.call(client.request(speed=1.5))
    assert speeds == [1.5]
    with pytest.raises(ServiceError, match="/motor/set_speed failed: speed must be >= 0"):
        client.call(client.request(speed=-1.0))
    missing = Node(ctx, "other").create_client("std_srvs/srv/Trigger", "/nobody")
    with pytest.raises(ServiceError, match="no service /nobody"):
        missing.call()


def test_service_call_while_another_thread_spins(ctx: Context) -> None:
    server = Node(ctx, "s")
    server.create_service("example_interfaces/srv/AddTwoInts", "add",
                          lambda req, resp: (setattr(resp, "sum", req.a + req.b), resp)[1])
    client = Node(ctx, "c").create_client("example_interfaces/srv/AddTwoInts", "/add")
    with Context.open(types=TYPES) as wall:  # a wall-clock context spun by a thread
        s2 = Node(wall, "s")
        s2.create_service("example_interfaces/srv/AddTwoInts", "add",
                          lambda req, resp: (setattr(resp, "sum", req.a * req.b), resp)[1])
        c2 = Node(wall, "c").create_client("example_interfaces/srv/AddTwoInts", "/add")
        thread = wall.executor.spin_in_thread()
        assert c2.call(c2.request(a=6, b=7), timeout=2.0).sum == 42
        wall.shutdown()
        thread.join(2.0)
        assert not thread.is_alive()
    assert client.call(client.request(a=2, b=3)).sum == 5


def test_parameters_declared_typed_overridden_and_guarded(ctx: Context,
                                                          tmp_path: Path) -> None:
    params = tmp_path / "params.yaml"
    params.write_text("/**:\n  ros__parameters:\n    use_sim: true\n"
                      "talker:\n  ros__parameters:\n    rate: 10\n    camera:\n"
                      "      width: 640\n")
    ctx.parameter_overrides.merge(ParameterOverrides.from_file(params))
    ctx.parameter_overrides.merge(ParameterOverrides.from_assignments(["talker:topic:=/x"]))
    node = Node(ctx, "talker")
    assert node.declare_parameter("rate", 4.5).value == 10.0          # int given for a double
    assert isinstance(node.get_parameter("rate").value, float)
    assert node.declare_parameter("camera.width", 320).value == 640
    assert node.declare_parameter("use_sim", False).value is True
    assert node.declare_parameter("topic", "/cmd_vel").value == "/x"
    assert node.declare_parameter("port", "/dev/ttyUSB0", read_only=True).value == "/dev/ttyUSB0"
    with pytest.raises(ParameterError, match="parameter rate is a double; 'fast' is a string"):
        node.set_parameter("rate", "fast")
    with pytest.raises(ParameterError, match="read-only"):
        node.set_parameter("port", "/dev/ttyUSB1")
    with pytest.raises(ParameterError, match="/talker has no parameter 'speed'"):
        node.get_parameter("speed")

    def no_fast(name, value):
        if name == "rate" and value > 50:
            raise ParameterError(f"rate {value} Hz is more than the bus can do")
    node.add_on_set_parameter_callback(no_fast)
    with pytest.raises(ParameterError, match=r"rate 60\.0 Hz"):
        node.set_parameter("rate", 60)
    node.set_parameter("rate", 20)
    assert node.get_parameter("rate").value == 20.0


def test_parameter_services_reach_a_node(ctx: Context) -> None:
    node = Node(ctx, "talker", "/robot")
    node.declare_parameter("rate", 4.5)
    node.declare_parameter("names", ["a", "b"])
    other = Node(ctx, "tool")
    lister = other.create_client("rcl_interfaces/srv/ListParameters",
                                 "/robot/talker/list_parameters")
    assert lister.call().result.names == ["names", "rate"]
    getter = other.create_client("rcl_interfaces/srv/GetParameters",
                                 "/robot/talker/get_parameters")
    values = getter.call(getter.request(names=["rate", "names"])).values
    assert values[0].double_value == 4.5 and values[1].string_array_value == ["a", "b"]
    setter = other.create_client("rcl_interfaces/srv/SetParameters",
                                 "/robot/talker/set_parameters")
    result = setter.call(setter.request(parameters=[
        {"name": "rate", "value": {"type": 3, "double_value": 9.0}},
        {"name": "rate", "value": {"type": 4, "string_value": "x"}}])).results
    assert result[0].successful and not result[1].successful
    assert "is a double" in result[1].reason and node.get_parameter("rate").value == 9.0


@pytest.mark.parametrize(("text", "expected"), [
    ("talker:\n  rate: 4\n", "params.yaml:1: key 'ros__parameters' missing under 'talker'"),
    ("talker:\n  ros__parameters:\n    rate: {a: [1, x]}\n", "params.yaml:3"),
    ("talker:\n  ros__parameters:\n    a: [1, x]\n", "params.yaml:3: a:"),
    ("talker:\n  ros__parameters: {a: 1}\n  extra: 2\n",
     "params.yaml:3: unexpected key 'extra'"),
    ("talker: [\n", "params.yaml:2: not valid YAML"),
    ("- a\n", "params.yaml:1: a parameter file is a mapping"),
])
def test_bad_parameter_files_name_file_line_and_key(tmp_path: Path, text: str,
                                                    expected: str) -> None:
    path = tmp_path / "params.yaml"
    path.write_text(text)
    with pytest.raises(ParameterError) as info:
        ParameterOverrides.from_file(path)
    assert expected in str(info.value) and "\n" not in str(info.value)


def test_bad_names_and_assignments() -> None:
    with pytest.raises(ParameterError, match="'rate=4' is not name:=value"):
        ParameterOverrides.from_assignments(["rate=4"])
    with Context.open(types=TYPES) as ctx:
        with pytest.raises(NameValidationError, match="node name must not start with a number"):
            Node(ctx, "1talker")
        node = Node(ctx, "n")
        with pytest.raises(NameValidationError, match="must not contain repeated '/'"):
            node.create_publisher(TWIST, "cmd//vel")
        with pytest.raises(MessageError, match="unknown message type 'Twist'"):
            node.create_publisher("Twist", "/cmd_vel")


def test_callbacks_run_on_the_spinning_thread_only(ctx: Context) -> None:
    node = Node(ctx, "n")
    threads: set[int] = set()
    node.create_subscription("std_msgs/msg/Empty", "/e", lambda m: threads.add(
        threading.get_ident()))
    pub = node.create_publisher("std_msgs/msg/Empty", "/e")
    workers = [threading.Thread(target=lambda: [pub.publish(node.message("std_msgs/msg/Empty"))
                                                for _ in range(50)]) for _ in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    ctx.spin_for(0.1)
    assert threads == {threading.get_ident()}
