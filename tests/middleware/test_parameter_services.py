"""The parameter services every node offers, called through a servolab client and answered as
rclpy answers them. References are to ros2/rclpy (rolling, 8.0.0): ``rclpy/parameter_service.py``
(``ParameterService``) and ``rclpy/node.py`` (``Node``)."""

from __future__ import annotations

from typing import Any

import pytest

from servolab.clock import VirtualClock
from servolab.middleware.context import Context
from servolab.middleware.errors import ParameterError, ServiceError
from servolab.middleware.messages import MessageTypes
from servolab.middleware.node import Node
from servolab.middleware.parameters import (
    DOUBLE,
    INTEGER,
    NOT_SET,
    STRING_ARRAY,
    Parameter,
    SetParametersResult,
    list_names,
)

TYPES = MessageTypes()


@pytest.fixture
def ctx_clock() -> VirtualClock:
    """``ctx`` (tests/conftest.py) on a virtual clock: these tests step time themselves."""
    return VirtualClock()


@pytest.fixture
def talker(ctx: Context) -> Node:
    node = Node(ctx, "talker", "/robot")
    node.declare_parameter("rate", 4.5, description="loop rate in Hz")
    node.declare_parameter("port", "/dev/ttyUSB0", read_only=True)
    node.declare_parameter("names", ["a", "b"])
    node.declare_parameter("camera.width", 640)
    node.declare_parameter("camera.lens.focal", 2.8)
    return node


def call(ctx: Context, service: str, **fields: Any) -> Any:
    srv = "".join(p.capitalize() for p in service.split("_"))
    tool = next((n for n in ctx.nodes if n.name == "tool"), None) or Node(ctx, "tool")
    client = tool.create_client(f"rcl_interfaces/srv/{srv}", f"/robot/talker/{service}")
    return client.call(client.request(**fields))


def test_every_node_offers_rclpys_six_parameter_services(ctx: Context, talker: Node) -> None:
    # ParameterService.__init__: these names and types, on every node
    offered = {(e.name, e.type_name) for e in ctx.transport.graph() if e.kind == "SS"
               and e.node == "/robot/talker"}
    assert offered == {(f"/robot/talker/{name}", f"rcl_interfaces/srv/{srv}") for name, srv in (
        ("describe_parameters", "DescribeParameters"),
        ("get_parameter_types", "GetParameterTypes"),
        ("get_parameters", "GetParameters"),
        ("list_parameters", "ListParameters"),
        ("set_parameters", "SetParameters"),
        ("set_parameters_atomically", "SetParametersAtomically"))}


def test_get_parameters_of_an_unknown_name_answers_no_values(ctx: Context,
                                                             talker: Node) -> None:
    # ParameterService._get_parameters_callback: ParameterNotDeclaredException ->
    # response.values = node.get_parameters([]), an empty list for the whole request
    # (``ros2 param get`` then prints "Parameter not set").
    assert list(call(ctx, "get_parameters", names=["rate", "speed"]).values) == []
    values = call(ctx, "get_parameters", names=["rate", "names"]).values
    assert values[0].type == DOUBLE and values[0].double_value == 4.5
    assert values[1].type == STRING_ARRAY and list(values[1].string_array_value) == ["a", "b"]


def test_an_empty_array_keeps_its_declared_type(ctx: Context) -> None:
    node = Node(ctx, "talker", "/robot")
    node.declare_parameter("names", ["a"])
    node.set_parameter("names", [])
    assert call(ctx, "get_parameters", names=["names"]).values[0].type == STRING_ARRAY


def test_get_parameter_types(ctx: Context, talker: Node) -> None:
    # ParameterService._get_parameter_types_callback / Node.get_parameter_type
    assert list(call(ctx, "get_parameter_types", names=["rate", "camera.width"]).types) == [
        DOUBLE, INTEGER]
    assert list(call(ctx, "get_parameter_types", names=["rate", "nope"]).types) == []


def test_describe_parameters(ctx: Context, talker: Node) -> None:
    # ParameterService._describe_parameters_callback / Node.describe_parameter: the descriptor
    # given at declaration, with name and type filled in (Node._apply_descriptor)
    rate, port = call(ctx, "describe_parameters", names=["rate", "port"]).descriptors
    assert (rate.name, rate.type, rate.description, rate.read_only, rate.dynamic_typing) == (
        "rate", DOUBLE, "loop rate in Hz", False, False)
    assert port.name == "port" and port.read_only
    assert list(call(ctx, "describe_parameters", names=["nope"]).descriptors) == []


@pytest.mark.parametrize(("prefixes", "depth", "names", "prefix_out"), [
    # Node.list_parameters: no prefixes and DEPTH_RECURSIVE (0) is everything
    ([], 0, ["camera.lens.focal", "camera.width", "names", "port", "rate"],
     ["camera.lens", "camera"]),
    # no prefixes: names with fewer than depth separators
    ([], 1, ["names", "port", "rate"], []),
    ([], 2, ["camera.width", "names", "port", "rate"], ["camera"]),
    # a prefix: itself and names below it, at most depth levels down
    (["camera"], 0, ["camera.lens.focal", "camera.width"], ["camera.lens", "camera"]),
    (["camera"], 1, ["camera.width"], ["camera"]),
    (["rate"], 1, ["rate"], []),
    # a prefix matches whole segments only
    (["cam"], 0, [], []),
])
def test_list_parameters_with_prefixes_and_depth(ctx: Context, talker: Node,
                                                 prefixes: list[str], depth: int,
                                                 names: list[str],
                                                 prefix_out: list[str]) -> None:
    result = call(ctx, "list_parameters", prefixes=prefixes, depth=depth).result
    assert list(result.names) == names
    assert list(result.prefixes) == prefix_out


def test_list_names_matches_rclpys_algorithm() -> None:
    # Node.list_parameters on rclpy's own test names (test_node.py, test_list_parameters)
    names = ["foo.first", "foo.second", "bar.first", "bar.second", "baz", "foo.bar.first"]
    assert list_names(names, ["foo"], 1)[0] == ["foo.first", "foo.second"]
    assert list_names(names, ["foo", "bar"], 0)[0] == [
        "foo.first", "foo.second", "bar.first", "bar.second", "foo.bar.first"]
    assert list_names(names, [], 1)[0] == ["baz"]


def test_set_parameters_answers_one_result_each(ctx: Context, talker: Node) -> None:
    # ParameterService._set_parameters_callback: each parameter set on its own
    # (set_parameters_atomically([param])); undeclared -> unsuccessful with the exception's
    # text; read-only -> Node._apply_descriptor's reason
    results = call(ctx, "set_parameters", parameters=[
        {"name": "rate", "value": {"type": DOUBLE, "double_value": 9.0}},
        {"name": "rate", "value": {"type": 4, "string_value": "x"}},
        {"name": "speed", "value": {"type": DOUBLE, "double_value": 1.0}},
        {"name": "port", "value": {"type": 4, "string_value": "/dev/ttyUSB1"}},
        {"name": "names", "value": {"type": NOT_SET}}]).results
    assert [r.successful for r in results] == [True, False, False, False, False]
    assert "is a double" in results[1].reason
    assert results[2].reason == "Invalid access to undeclared parameter(s): ['speed']"
    assert results[3].reason == "Trying to set a read-only parameter: port."
    assert results[4].reason == "Static parameter cannot be undeclared"
    assert talker.get_parameter("rate").value == 9.0
    assert talker.get_parameter("names").value == ["a", "b"]


def test_set_parameters_atomically_is_all_or_nothing(ctx: Context, talker: Node) -> None:
    # ParameterService._set_parameters_atomically_callback / Node._set_parameters_atomically_common:
    # one refused parameter and none is set
    result = call(ctx, "set_parameters_atomically", parameters=[
        {"name": "rate", "value": {"type": DOUBLE, "double_value": 9.0}},
        {"name": "camera.width", "value": {"type": 4, "string_value": "wide"}}]).result
    assert not result.successful and "camera.width is an integer" in result.reason
    assert talker.get_parameter("rate").value == 4.5
    result = call(ctx, "set_parameters_atomically", parameters=[
        {"name": "rate", "value": {"type": DOUBLE, "double_value": 9.0}},
        {"name": "nope", "value": {"type": DOUBLE, "double_value": 1.0}}]).result
    assert not result.successful and "undeclared" in result.reason
    assert talker.get_parameter("rate").value == 4.5
    result = call(ctx, "set_parameters_atomically", parameters=[
        {"name": "rate", "value": {"type": DOUBLE, "double_value": 9.0}},
        {"name": "camera.width", "value": {"type": INTEGER, "integer_value": 1280}}]).result
    assert result.successful and result.reason == ""
    assert talker.get_parameter("rate").value == 9.0
    assert talker.get_parameter("camera.width").value == 1280


def test_on_set_parameters_callback_vetoes_with_its_reason(ctx: Context, talker: Node) -> None:
    # Node.add_on_set_parameters_callback: callback(parameters) -> SetParametersResult,
    # called once per atomic set, the last added first; unsuccessful refuses the whole set
    seen: list[list[tuple[str, Any]]] = []

    def no_fast(parameters: list[Parameter]) -> SetParametersResult:
        seen.append([(p.name, p.value) for p in parameters])
        fast = [p for p in parameters if p.name == "rate" and p.value > 50]
        return SetParametersResult(not fast, "more than the bus can do" if fast else "")

    talker.add_on_set_parameters_callback(no_fast)
    result = call(ctx, "set_parameters_atomically", parameters=[
        {"name": "rate", "value": {"type": DOUBLE, "double_value": 60.0}},
        {"name": "camera.width", "value": {"type": INTEGER, "integer_value": 1280}}]).result
    assert (result.successful, result.reason) == (False, "more than the bus can do")
    assert seen == [[("rate", 60.0), ("camera.width", 1280)]]
    assert talker.get_parameter("camera.width").value == 640
    with pytest.raises(ParameterError, match="more than the bus can do"):
        talker.set_parameter("rate", 60)
    assert talker.set_parameters({"rate": 20, "camera.width": 800}) == [
        SetParametersResult(True, ""), SetParametersResult(True, "")]
    assert talker.get_parameter("rate").value == 20.0

    # the rcl_interfaces message itself is a result too; the last added runs first
    order: list[str] = []

    def refuse_all(parameters: list[Parameter]) -> Any:
        order.append("refuse_all")
        return ctx.types.from_value("rcl_interfaces/msg/SetParametersResult",
                                    {"successful": False, "reason": "frozen"})

    talker.add_on_set_parameters_callback(refuse_all)
    assert talker.set_parameters_atomically({"rate": 1.0}) == SetParametersResult(False,
                                                                                 "frozen")
    assert order == ["refuse_all"] and talker.get_parameter("rate").value == 20.0


def test_on_set_parameters_callback_without_a_result_refuses(talker: Node) -> None:
    talker.add_on_set_parameters_callback(lambda parameters: None)
    result = talker.set_parameters_atomically({"rate": 1.0})
    assert not result.successful and "not a SetParametersResult" in result.reason
    assert talker.get_parameter("rate").value == 4.5


def test_a_raising_handler_answers_the_client_with_an_error(ctx: Context) -> None:
    # rclpy lets the exception out of the executor and never answers (the client waits);
    # servolab answers, and the client raises ServiceError with the handler's text at once.
    server = Node(ctx, "server")

    def broken(request: Any, response: Any) -> Any:
        raise RuntimeError("motor bus unplugged")

    server.create_service("std_srvs/srv/Trigger", "/trigger", broken)
    server.create_service("std_srvs/srv/Trigger", "/wrong", lambda request, response: 42)
    client = Node(ctx, "caller").create_client("std_srvs/srv/Trigger", "/trigger")
    with pytest.raises(ServiceError, match="motor bus unplugged"):
        client.call(timeout=5.0)
    wrong = Node(ctx, "caller2").create_client("std_srvs/srv/Trigger", "/wrong")
    with pytest.raises(ServiceError, match="returned 42, not a std_srvs/srv/Trigger_Response"):
        wrong.call(timeout=5.0)
    # the node keeps serving
    server.create_service("std_srvs/srv/Trigger", "/ok",
                          lambda request, response: response)
    ok = Node(ctx, "caller3").create_client("std_srvs/srv/Trigger", "/ok")
    assert ok.call(timeout=5.0).success is False


def test_param_app_reports_an_unknown_parameter(ctx: Context, talker: Node) -> None:
    from servolab.apps.param import param_get

    with pytest.raises(ParameterError, match="has no parameter 'speed'"):
        param_get(ctx, "/robot/talker", "speed", say=lambda text: None)
    said: list[str] = []
    assert param_get(ctx, "/robot/talker", "rate", said.append) == 4.5
