"""rclpy's parameters on servolab (issue 32): ``rclpy/parameter.py``'s Parameter and the
rules of ``rclpy/node.py`` (descriptors, callbacks, exceptions), stored once in servolab's
node. The slow test runs one snippet under the real rclpy and servolab and compares."""

from __future__ import annotations

import pytest

from servolab.interfaces.rcl_interfaces.msg import (
    FloatingPointRange,
    ParameterDescriptor,
    SetParametersResult,
)
from servolab.middleware.context import Context
from servolab.middleware.parameters import ParameterOverrides
from servolab.rclpy.exceptions import (
    InvalidParameterTypeException,
    ParameterAlreadyDeclaredException,
    ParameterNotDeclaredException,
)
from servolab.rclpy.node import Node
from servolab.rclpy.parameter import Parameter, get_parameter_value, parameter_value_to_python
from tests.rclpy.oracle import run_both


def test_parameter_shape() -> None:
    """rclpy/parameter.py: Parameter(name, type_=None, value=None), the type from the value;
    a type that disagrees with the value is a ValueError; messages both ways."""
    p = Parameter("gain", value=2.5)
    assert (p.name, p.type_, p.value) == ("gain", Parameter.Type.DOUBLE, 2.5)
    assert Parameter("ids", value=[1, 2]).type_ is Parameter.Type.INTEGER_ARRAY
    assert Parameter("unset").type_ is Parameter.Type.NOT_SET
    with pytest.raises(ValueError, match="do not agree"):
        Parameter("gain", Parameter.Type.INTEGER, 2.5)
    value = p.get_parameter_value()
    assert value.__msgtype__ == "rcl_interfaces/msg/ParameterValue"
    assert (value.type, value.double_value) == (3, 2.5)
    msg = Parameter("names", value=["a", "b"]).to_parameter_msg()
    back = Parameter.from_parameter_msg(msg)
    assert (back.name, back.type_, back.value) == ("names", Parameter.Type.STRING_ARRAY,
                                                   ["a", "b"])
    assert parameter_value_to_python(get_parameter_value("[1, 2]")) == [1, 2]
    assert parameter_value_to_python(get_parameter_value("hello")) == "hello"


def test_declare_get_set_with_rclpys_rules(ctx: Context) -> None:
    """rclpy/node.py: declare returns the Parameter; a second declare raises
    ParameterAlreadyDeclaredException; setting a double to an int is refused ("Wrong
    parameter type"), as is a value out of a floating-point range."""
    node = Node(ctx, "n")
    descriptor = ParameterDescriptor(floating_point_range=[
        FloatingPointRange(from_value=0.0, to_value=1.0, step=0.0)])
    assert node.declare_parameter("gain", 0.5, descriptor).value == 0.5
    with pytest.raises(ParameterAlreadyDeclaredException):
        node.declare_parameter("gain", 0.1)
    [result] = node.set_parameters([Parameter("gain", value=1)])
    assert not result.successful and result.reason.startswith("Wrong parameter type")
    [result] = node.set_parameters([Parameter("gain", value=1.5)])
    assert result.reason == "Parameter gain out of range Min: 0.0, Max: 1.0, value: 1.5"
    with pytest.raises(ParameterNotDeclaredException):
        node.set_parameters([Parameter("nope", value=1)])
    assert node.describe_parameter("gain").floating_point_range[0].to_value == 1.0
    assert node.get_parameter_or("nope", Parameter("nope", value=3)).value == 3


def test_overrides_come_from_the_context_and_keep_their_type(ctx: Context) -> None:
    """rclpy takes an override's type from its value: an int for a double parameter is an
    InvalidParameterTypeException; the context's (servolab's -p) overrides count."""
    ctx.parameter_overrides.merge(ParameterOverrides.from_assignments(["/n:rate:=2",
                                                                       "/n:gain:=2.5"]))
    node = Node(ctx, "n")
    assert node.declare_parameter("gain", 1.0).value == 2.5
    with pytest.raises(InvalidParameterTypeException, match="expecting type 'DOUBLE'"):
        node.declare_parameter("rate", 1.0)


def test_pre_on_and_post_set_callbacks(ctx: Context) -> None:
    """rclpy/node.py: pre-set callbacks may change the list (not on declare); on-set ones
    may refuse it; post-set ones see what was set (on declare too)."""
    node = Node(ctx, "n")
    seen: list[list[tuple[str, object]]] = []
    node.add_post_set_parameters_callback(lambda ps: seen.append([(p.name, p.value) for p in ps]))
    node.declare_parameter("a", 1)
    node.declare_parameter("b", 1)
    node.add_pre_set_parameters_callback(lambda ps: [*ps, Parameter("b", value=2)])
    node.add_on_set_parameters_callback(
        lambda ps: SetParametersResult(successful=all(p.value != 13 for p in ps),
                                       reason="13"))
    assert node.set_parameters([Parameter("a", value=5)])[0].successful
    assert not node.set_parameters([Parameter("a", value=13)])[0].successful
    assert seen == [[("a", 1)], [("b", 1)], [("a", 5), ("b", 2)]]
    assert node.get_parameter("b").value == 2


def test_parameter_services_follow_the_same_rules(ctx: Context) -> None:
    """rclpy/parameter_service.py answers a set through the node's own rules: the service
    of an rclpy node refuses a wrong type that servolab's own nodes would coerce."""
    node = Node(ctx, "n")
    node.declare_parameter("gain", 1.0)
    client = node.create_client("rcl_interfaces/srv/SetParameters", "/n/set_parameters")
    request = client.request(parameters=[Parameter("gain", value=2).to_parameter_msg()])
    [result] = client.call(request, timeout_sec=2.0).results
    assert not result.successful and "Wrong parameter type" in result.reason
    request = client.request(parameters=[Parameter("gain", value=2.0).to_parameter_msg()])
    assert client.call(request, timeout_sec=2.0).results[0].successful
    assert node.get_parameter("gain").value == 2.0


@pytest.mark.slow
def test_the_same_snippet_prints_the_same_under_rclpy() -> None:
    code = """
        import rclpy
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rcl_interfaces.msg import ParameterDescriptor, IntegerRange
        rclpy.init(args=['--ros-args', '-p', 'level:=4', '-p', 'label:=hi'])
        node = Node('n')
        for p in node.declare_parameters('', [
                ('level', 1, ParameterDescriptor(integer_range=[
                    IntegerRange(from_value=0, to_value=8, step=2)])),
                ('label', 'x', ParameterDescriptor()),
                ('flags', [True, False], ParameterDescriptor(read_only=True))]):
            print(p.name, repr(p.value), p.type_, p.type_.name)
        print([n for n in ('level', 'label', 'flags', 'use_sim_time') if node.has_parameter(n)])
        for value in (6, 7, 9, 'a'):
            r = node.set_parameters([Parameter('level', value=value)])[0]
            print(value, r.successful, r.reason)
        r = node.set_parameters_atomically([Parameter('label', value='y'),
                                            Parameter('flags', value=[False])])
        print(r.successful, r.reason, node.get_parameter('label').value)
        print(node.list_parameters([], 0).names == node.list_parameters([], 0).names)
        print(node.get_parameter_types(['level', 'label']))
        print(node.describe_parameter('level').integer_range[0].step)
        for bad in (lambda: node.declare_parameter('level', 2),
                    lambda: node.get_parameter('nope'),
                    lambda: node.declare_parameter('t', Parameter.Type.NOT_SET),
                    lambda: Parameter('x', Parameter.Type.BOOL, 1)):
            try:
                bad()
            except Exception as e:
                print(type(e).__name__, e)
        p = Parameter('d', value=[1.5, 2.5])
        m = p.to_parameter_msg()
        print(m.name, m.value.type, m.value.double_array_value.tolist())  # array.array | numpy
        q = Parameter.from_parameter_msg(m)
        print(q.name, q.type_, list(q.value))
        rclpy.shutdown()
        """
    ros, ours = run_both(code)
    assert ours == ros
