"""``servolab param``: list, get and set the parameters of running nodes, as ``ros2 param``
does.

Every function takes an open :class:`~servolab.middleware.context.Context` and a ``say``
function for its output, so the CLI stays a parser and the tests can capture what is printed.
Values are checked before anything is set. The middleware (and Zenoh) is imported inside the
functions, so that ``servolab --help`` does not load it.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from servolab.errors import UsageError
from servolab.middleware.errors import ParameterError

from .arguments import add_transport, positive_float, transport_options
from .registry import Command
from .topic import DISCOVERY_S

if TYPE_CHECKING:
    from servolab.middleware.context import Context

Say = Callable[[str], None]
#: ``rcl_interfaces/msg/ParameterType`` as ros2param names it (``get_parameter_type_string``)
TYPE_WORDS = {0: "not set", 1: "boolean", 2: "integer", 3: "double", 4: "string",
              5: "byte array", 6: "boolean array", 7: "integer array", 8: "double array",
              9: "string array"}


def _param_nodes(ctx: Context) -> list[str]:
    from ._graph import hidden

    return sorted({e.node for e in ctx.transport.graph(DISCOVERY_S)
                   if e.kind == "SS" and e.name == f"{e.node}/list_parameters"
                   and not hidden(e.node)})


def _client(ctx: Context, node_name: str, service: str) -> Any:
    from ._graph import tool_node

    node = tool_node(ctx, "param")
    target = node_name if node_name.startswith("/") else f"/{node_name}"
    srv = "".join(p.capitalize() for p in service.split("_"))
    return node.create_client(f"rcl_interfaces/srv/{srv}", f"{target}/{service}")


def param_list(ctx: Context, say: Say, node_name: str | None = None,
               timeout: float = 2.0) -> dict[str, list[str]]:
    """Every node's parameter names (or one node's), as ``ros2 param list`` prints them."""
    nodes = [node_name if node_name.startswith("/") else f"/{node_name}"] if node_name \
        else _param_nodes(ctx)
    listing: dict[str, list[str]] = {}
    for name in nodes:
        names = list(_client(ctx, name, "list_parameters").call(timeout=timeout).result.names)
        listing[name] = names
        say(f"{name}:")
        for param in names:
            say(f"  {param}")
    return listing


def param_get(ctx: Context, node_name: str, name: str, say: Say, timeout: float = 2.0) -> Any:
    from servolab.middleware.parameters import from_parameter_value

    client = _client(ctx, node_name, "get_parameters")
    values = client.call(client.request(names=[name]), timeout=timeout).values
    value = from_parameter_value(values[0]) if values else None
    if value is None:
        raise ParameterError(f"{node_name} has no parameter {name!r}")
    say(f"{name}: {value!r}")
    return value


def param_set(ctx: Context, node_name: str, name: str, text: str, say: Say,
              timeout: float = 2.0) -> None:
    import yaml

    from servolab.middleware.parameters import to_parameter_value

    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        raise ParameterError(f"value {text!r} for {name} is not YAML") from None
    parameter = {"name": name, "value": to_parameter_value(ctx.types, value)}
    client = _client(ctx, node_name, "set_parameters")
    results = client.call(client.request(parameters=[parameter]), timeout=timeout).results
    if not results or not results[0].successful:
        reason = results[0].reason if results else "no answer"
        raise ParameterError(f"setting {name} on {node_name} failed: {reason}")
    say(f"set {name} = {value!r} on {node_name}")


def wait_for_node(ctx: Context, node_name: str, timeout: float) -> str:
    """The node's fully qualified name once the graph shows its parameter services, waiting
    up to ``timeout`` s (as ros2param's ``wait_for_node``); else a one-line error naming the
    nodes that have parameters."""
    from ._graph import listed
    from ._graph import node_name as checked

    name = checked(node_name)
    end = time.monotonic() + timeout
    while True:
        nodes = _param_nodes(ctx)
        if name in nodes:
            return name
        if time.monotonic() >= end:
            raise UsageError(f"Node not found: {name}; nodes with parameters: "
                             f"{listed(nodes)} ('servolab param list')")
        time.sleep(0.1)


def _nest(tree: dict[str, Any], name: str, value: Any) -> None:
    """``camera.width`` under ``camera: {width: ...}``, as ros2param dump's ``insert_dict``."""
    head, dot, rest = name.partition(".")
    if dot:
        _nest(tree.setdefault(head, {}), rest, value)
    else:
        tree[name] = value


def param_dump(ctx: Context, node_name: str, say: Say, *, timeout: float = 2.0,
               wait: float = 1.0) -> str:
    """Every parameter of the node as YAML, in the layout ``ros2 param dump`` prints (a
    parameter file ``servolab param load`` and ``--params-file`` read back)::

        /robot/talker:
          ros__parameters:
            rate: 10.0

    Returns the text printed."""
    import yaml

    from servolab.middleware.parameters import from_parameter_value

    name = wait_for_node(ctx, node_name, wait)
    names = sorted(_client(ctx, name, "list_parameters").call(timeout=timeout).result.names)
    client = _client(ctx, name, "get_parameters")
    values = client.call(client.request(names=names), timeout=timeout).values if names else []
    tree: dict[str, Any] = {}
    for param, value in zip(names, values, strict=False):
        _nest(tree, param, from_parameter_value(value))
    text = yaml.safe_dump({name: {"ros__parameters": tree}}, default_flow_style=False)
    say(text)  # print() of yaml.dump, as ros2: the text and an empty line
    return text


def param_load(ctx: Context, node_name: str, path: str, say: Say, *,
               use_wildcard: bool = True, timeout: float = 2.0, wait: float = 1.0,
               warn: Say | None = None) -> bool:
    """Set the node's parameters from a ROS 2 parameter file (its entries for the node, and
    for ``/**`` unless ``use_wildcard`` is False), one set each, printing ``Set parameter X
    successful`` (``failed: reason`` on ``warn``, stderr) as ``ros2 param load`` does.
    Returns whether every one was set."""
    from servolab.middleware.parameters import ParameterOverrides, to_parameter_value

    overrides = ParameterOverrides.from_file(path)  # refused here, naming file, line and key
    name = wait_for_node(ctx, node_name, wait)
    values = overrides.for_node(name) if use_wildcard else dict(overrides.by_node.get(name, {}))
    if not values:
        nodes = ", ".join(n for n in overrides.by_node if use_wildcard or n != "/**")
        raise ParameterError(f"Param file {path} does not contain parameters for {name}, only "
                             f"for nodes: {nodes or 'none'}")
    parameters = [{"name": param, "value": to_parameter_value(ctx.types, value)}
                  for param, value in values.items()]
    client = _client(ctx, name, "set_parameters")
    results = client.call(client.request(parameters=parameters), timeout=timeout).results
    ok = True
    for param, result in zip(values, results, strict=False):
        if result.successful:
            say(f"Set parameter {param} successful" + (f": {result.reason}" if result.reason
                                                      else ""))
        else:
            ok = False
            (warn or _stderr)(f"Set parameter {param} failed" + (f": {result.reason}"
                                                                if result.reason else ""))
    return ok


def _stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def param_describe(ctx: Context, node_name: str, names: list[str], say: Say, *,
                   timeout: float = 2.0, wait: float = 1.0) -> list[Any]:
    """Each parameter's type, description and constraints, as ``ros2 param describe``
    prints them. A name the node does not have is a one-line error naming those it has
    (ros2 prints nothing). Returns the descriptors."""
    name = wait_for_node(ctx, node_name, wait)
    client = _client(ctx, name, "describe_parameters")
    descriptors = list(client.call(client.request(names=names), timeout=timeout).descriptors)
    if len(descriptors) != len(names):
        known = sorted(_client(ctx, name, "list_parameters").call(timeout=timeout).result.names)
        missing = [n for n in names if n not in known]
        raise ParameterError(f"{name} has no parameter {', '.join(missing) or names[0]} (it "
                             f"has {', '.join(known) or 'none'})")
    for d in descriptors:
        say(f"Parameter name: {d.name}")
        say(f"  Type: {TYPE_WORDS.get(int(d.type), str(d.type))}")
        if d.description:
            say(f"  Description: {d.description}")
        say("  Constraints:")
        if d.read_only:
            say("    Read only: true")
        ranges = list(d.floating_point_range) + list(d.integer_range)
        if ranges:
            say(f"    Min value: {ranges[0].from_value}")
            say(f"    Max value: {ranges[0].to_value}")
            if ranges[0].step:
                say(f"    Step: {ranges[0].step}")
        if d.additional_constraints:
            say(f"    Additional constraints: {d.additional_constraints}")
    return descriptors


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    p = actions.add_parser("list", help="parameters of every node, or of one")
    p.add_argument("node", nargs="?", help="e.g. /robot/talker (default: every node)")
    _add_call_timeout(p)
    add_transport(p)
    p = actions.add_parser("get", help="one parameter's value")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("name")
    _add_call_timeout(p)
    add_transport(p)
    p = actions.add_parser("set", help="change a parameter (the value is YAML)")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("name")
    p.add_argument("value", help="YAML: 0.3, true, [1, 2], ...")
    _add_call_timeout(p)
    add_transport(p)
    p = actions.add_parser("dump", help="a node's parameters as a YAML parameter file, as "
                           "ros2 param dump")
    p.add_argument("node", help="e.g. /robot/talker")
    _add_timeout(p)
    add_transport(p)
    p = actions.add_parser(
        "load", help="set a node's parameters from a parameter file, as ros2 param load",
        description="Set a node's parameters from a ROS 2 parameter file (its own entries and "
        "those of /**), printing each result as 'ros2 param load' does. Where servolab "
        "differs: a file with errors is refused naming file, line and key, and the exit "
        "status is 1 if any parameter was refused (ros2 exits 0).")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("parameter_file", metavar="FILE", help="e.g. talker.yaml")
    p.add_argument("--no-use-wildcard", action="store_true",
                   help="leave out the file's /** parameters")
    _add_timeout(p)
    add_transport(p)
    p = actions.add_parser(
        "describe", help="parameters' types, descriptions and constraints, as ros2 param "
        "describe",
        description="Print each parameter's type, description and constraints as 'ros2 param "
        "describe' does. Where servolab differs: a parameter the node does not have is an "
        "error naming those it has (ros2 prints nothing).")
    p.add_argument("node", help="e.g. /robot/talker")
    p.add_argument("names", nargs="+", metavar="NAME")
    _add_timeout(p)
    add_transport(p)


def _add_call_timeout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--timeout", type=positive_float, default=5.0, metavar="SECONDS",
                   help="wait up to this long for the node's answer, finding it included "
                   "(discovery with a Fast DDS node can take seconds; default 5)")


def _add_timeout(p: argparse.ArgumentParser) -> None:
    p.add_argument("--timeout", type=positive_float, default=1.0, metavar="SECONDS",
                   help="wait up to this long for the node to appear (default 1)")


def _run(args: argparse.Namespace) -> int:
    from servolab.middleware.context import Context

    from ._graph import say

    with Context.open(transport_options(args)) as ctx:
        if args.action == "list":
            param_list(ctx, say, args.node, timeout=args.timeout)
        elif args.action == "get":
            param_get(ctx, args.node, args.name, say, timeout=args.timeout)
        elif args.action == "set":
            param_set(ctx, args.node, args.name, args.value, say, timeout=args.timeout)
        elif args.action == "dump":
            param_dump(ctx, args.node, say, wait=args.timeout)
        elif args.action == "load":
            if not param_load(ctx, args.node, args.parameter_file, say,
                              use_wildcard=not args.no_use_wildcard, wait=args.timeout):
                return 1
        elif args.action == "describe":
            param_describe(ctx, args.node, args.names, say, wait=args.timeout)
    return 0


COMMAND = Command(
    name="param", group="graph", help="list, get, set, dump, load and describe parameters",
    description="List, get and set the parameters of running nodes, as 'ros2 param' does.",
    examples=("servolab param list",
              "servolab param dump /robot/talker > talker.yaml",
              "servolab param load /robot/talker talker.yaml",
              "servolab param describe /robot/talker rate",
              "servolab param set /robot/talker speed 0.3 --connect tcp/robot.local:7447"),
    add_arguments=_add_arguments, run=_run)
